// Work-group clusters of hitpoints (thesis ch. 7.3): filler counts, membership, mesh purity, shared
// radii, determinism, eq. 7.1 grid cells, clusters.h5 round trip and refusals, radius refresh.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstring>
#include <map>

#include "photonflow/stages/clusters.h"
#include "photonflow/stages/eye_pass.h"
#include "photonflow/io/h5io.h"
#include "photonflow/geometry/scene_file.h"
#include "support.h"

using namespace pf;
using test::TempDir;
using test::same_clusters;

namespace {
pf_hitpoint hp(float x, float y, float z, int mesh, float r) {
  pf_hitpoint p{};
  p.position[0] = x;
  p.position[1] = y;
  p.position[2] = z;
  p.radius = r;
  p.mesh = mesh;
  return p;
}

// 10 hitpoints on mesh 0 (a row along x), 3 on mesh 1 (far away); scene "s".
HitpointSet hand_set() {
  HitpointSet h;
  for (int i = 0; i < 10; ++i) h.hitpoints.push_back(hp(0.1f * float(i), 0, 0, 0, 0.05f));
  for (int i = 0; i < 3; ++i) h.hitpoints.push_back(hp(5, 5, 0.1f * float(i), 1, 0.02f));
  for (size_t i = 0; i < h.hitpoints.size(); ++i) h.hitpoints[i].pixel_x = int(i);
  h.width = 13;
  h.height = 1;
  h.scene_id = "s";
  return h;
}

HitpointSet room_hitpoints(int w, int hgt) {
  Scene s = test::room_scene(PF_MAT_DIFFUSE, w, hgt);
  EyePassOptions eo;
  return make_hitpoint_set(trace_hitpoints(s, eo), eo.direct, s.scene_id);
}

size_t padded_sum(const ClusterSet& c) {
  size_t s = 0;
  for (auto& cl : c.clusters)
    s += size_t((cl.count + c.wg_size - 1) / c.wg_size) * size_t(c.wg_size);
  return s;
}

// The largest |x − centre| + r over a cluster's members (in double): the radius its members'
// gather spheres need.
double member_extent(const ClusterSet& c, const HitpointSet& h, const pf_cluster& cl) {
  double m = 0;
  for (int t = cl.first; t < cl.first + cl.count; ++t) {
    const pf_hitpoint& p = h.hitpoints[size_t(c.order[size_t(t)])];
    double d2 = 0;
    for (int a = 0; a < 3; ++a) {
      double d = double(p.position[a]) - double(cl.centre[a]);
      d2 += d * d;
    }
    m = std::max(m, std::sqrt(d2) + double(p.radius));
  }
  return m;
}

// Every member's gather sphere lies inside the cluster's sphere (checked in double).
bool radii_contain(const ClusterSet& c, const HitpointSet& h) {
  for (auto& cl : c.clusters)
    if (member_extent(c, h, cl) > double(cl.radius)) return false;
  return true;
}

// Every cluster's R is the rule of clusters.h, not merely large enough: max over its members of
// |x − centre| + r (in double), rounded up to float — within one float step of that maximum.
bool radii_tight(const ClusterSet& c, const HitpointSet& h) {
  for (auto& cl : c.clusters) {
    const double m = member_extent(c, h, cl);
    if (!(double(cl.radius) >= m && double(std::nextafter(cl.radius, 0.f)) < m)) return false;
  }
  return true;
}

Provenance prov() {
  Provenance p;
  p.tool = "test";
  return p;
}
}  // namespace

TEST_CASE("filler counts follow the definition on a hand-built set", "[clusters]") {
  HitpointSet h = hand_set();
  // One grid bin per mesh (max_bins 1): mesh 0 → chunks 4, 4, 2; mesh 1 → 3.
  ClusterSet g = cluster_grid(h, 4, 1);
  REQUIRE(check_clusters(g, h) == "");
  ClusterStats s = stats(g);
  CHECK(s.clusters == 4);
  CHECK(s.hitpoints == 13);
  CHECK(s.hitpoints_with_fillers == 16);  // 4 + 4 + 4 + 4
  CHECK(s.fillers == 3);                  // 2 after the chunk of 2, 1 after the chunk of 3
  CHECK(g.order.size() == 16);
  CHECK(g.order[10] == -1);
  CHECK(g.order[11] == -1);
  CHECK(g.order[15] == -1);
  CHECK(g.clusters[3].mesh == 1);
  CHECK(g.clusters[3].count == 3);
  CHECK(g.clusters[3].padded_count == 4);

  // k-means: K = ceil(10/4) = 3 on mesh 0 and 1 on mesh 1.
  ClusterSet k = cluster_kmeans(h, 4, 10, 1, 1);
  REQUIRE(check_clusters(k, h) == "");
  ClusterStats ks = stats(k);
  CHECK(ks.clusters <= 4);
  CHECK(ks.hitpoints == 13);
  CHECK(ks.hitpoints_with_fillers == padded_sum(k));
  CHECK(ks.fillers == ks.hitpoints_with_fillers - 13);
  CHECK(k.clusters.back().mesh == 1);
  CHECK(k.clusters.back().count == 3);
  // With wg = 1 nothing is padded.
  CHECK(stats(cluster_grid(h, 1, 8)).fillers == 0);
}

TEST_CASE("the validity check catches broken clusterings", "[clusters]") {
  HitpointSet h = hand_set();
  ClusterSet g = cluster_grid(h, 4, 1);
  ClusterSet bad = g;
  bad.order[0] = bad.order[1];
  CHECK_THAT(check_clusters(bad, h), Catch::Contains("more than one cluster"));
  bad = g;
  std::swap(bad.order[9], bad.order[10]);  // a filler before a hitpoint
  CHECK(check_clusters(bad, h) != "");
  bad = g;
  bad.clusters[0].padded_count = 5;
  CHECK(check_clusters(bad, h) != "");
  bad = g;
  bad.clusters[3].mesh = 0;
  CHECK_THAT(check_clusters(bad, h), Catch::Contains("mixes meshes"));
  HitpointSet more = h;
  more.hitpoints.push_back(hp(1, 1, 1, 0, 0.1f));
  CHECK_THAT(check_clusters(g, more), Catch::Contains("in no cluster"));
}

TEST_CASE("k-means and grid clusters of a traced room are valid partitions", "[clusters]") {
  HitpointSet h = room_hitpoints(64, 48);
  REQUIRE(h.hitpoints.size() > 2000);
  for (int wg : {16, 64}) {
    for (int method = 0; method < 2; ++method) {
      ClusterSet c = method == 0 ? cluster_kmeans(h, wg, 10, 1, 2) : cluster_grid(h, wg, 16);
      INFO("wg " << wg << " method " << c.method);
      REQUIRE(check_clusters(c, h) == "");
      // every hitpoint exactly once, no mixed meshes (also checked here directly)
      std::vector<int> seen(h.hitpoints.size(), 0);
      bool pure = true;
      for (auto& cl : c.clusters) {
        CHECK(cl.count > 0);
        CHECK(cl.padded_count % wg == 0);
        for (int t = cl.first; t < cl.first + cl.count; ++t) {
          ++seen[size_t(c.order[size_t(t)])];
          pure = pure && h.hitpoints[size_t(c.order[size_t(t)])].mesh == cl.mesh;
        }
      }
      CHECK(pure);
      CHECK(std::all_of(seen.begin(), seen.end(), [](int s) { return s == 1; }));
      CHECK(radii_contain(c, h));
      CHECK(radii_tight(c, h));
      ClusterStats s = stats(c);
      CHECK(s.hitpoints == h.hitpoints.size());
      CHECK(s.hitpoints_with_fillers == padded_sum(c));
      CHECK(s.hitpoints_with_fillers == c.order.size());
      CHECK(s.mean_radius > 0);
    }
  }
}

TEST_CASE("k-means is deterministic for a seed and independent of the thread count",
          "[clusters]") {
  HitpointSet h = room_hitpoints(64, 48);
  ClusterSet a = cluster_kmeans(h, 32, 8, 7, 1);
  ClusterSet b = cluster_kmeans(h, 32, 8, 7, 2);
  ClusterSet c = cluster_kmeans(h, 32, 8, 7, 1);
  CHECK(same_clusters(a, b));
  CHECK(same_clusters(a, c));
  // K per mesh is ceil(n / wg) before empty clusters are dropped.
  std::map<int, size_t> per_mesh, clusters_per_mesh;
  for (auto& p : h.hitpoints) ++per_mesh[p.mesh];
  for (auto& cl : a.clusters) ++clusters_per_mesh[cl.mesh];
  for (auto& kv : per_mesh) CHECK(clusters_per_mesh[kv.first] <= (kv.second + 31) / 32);
}

TEST_CASE("grid clusters follow the cells of eq. 7.1", "[clusters]") {
  HitpointSet h = room_hitpoints(48, 32);
  const int wg = 16, max_bins = 8;
  ClusterSet c = cluster_grid(h, wg, max_bins);
  REQUIRE(check_clusters(c, h) == "");
  std::map<int, std::vector<int>> by_mesh;
  for (size_t i = 0; i < h.hitpoints.size(); ++i) by_mesh[h.hitpoints[i].mesh].push_back(int(i));
  std::map<std::pair<int, int>, int> cell_count;  // (mesh, cell) → hitpoints
  std::map<int, std::vector<int>> cell_of_hp;
  for (auto& kv : by_mesh) {
    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int i : kv.second)
      for (int a = 0; a < 3; ++a) {
        lo[a] = std::min(lo[a], h.hitpoints[size_t(i)].position[a]);
        hi[a] = std::max(hi[a], h.hitpoints[size_t(i)].position[a]);
      }
    float longest = std::max(hi[0] - lo[0], std::max(hi[1] - lo[1], hi[2] - lo[2]));
    float d = std::max(longest / float(max_bins), h.radius0);
    int n[3];
    for (int a = 0; a < 3; ++a) n[a] = std::clamp(int(std::ceil((hi[a] - lo[a]) / d)), 1, max_bins);
    pf_mesh_grid g = hitpoint_mesh_grid(h, kv.first, max_bins);
    CHECK(g.bin_size == d);
    CHECK(g.nx == n[0]);
    CHECK(g.ny == n[1]);
    CHECK(g.nz == n[2]);
    for (int i : kv.second) {
      int cc[3];
      for (int a = 0; a < 3; ++a) {
        float x = (h.hitpoints[size_t(i)].position[a] - lo[a]) / d;
        cc[a] = std::clamp(int(std::floor(x)), 0, n[a] - 1);
      }
      int cell = cc[0] + cc[1] * n[0] + cc[2] * n[0] * n[1];
      cell_of_hp[i] = {kv.first, cell};
      ++cell_count[{kv.first, cell}];
    }
  }
  std::map<std::pair<int, int>, int> clusters_in_cell;
  for (auto& cl : c.clusters) {
    CHECK(cl.count <= wg);
    const auto& first = cell_of_hp[c.order[size_t(cl.first)]];
    bool one_cell = true;
    for (int t = cl.first; t < cl.first + cl.count; ++t)
      one_cell = one_cell && cell_of_hp[c.order[size_t(t)]] == first;
    CHECK(one_cell);
    ++clusters_in_cell[{first[0], first[1]}];
  }
  for (auto& kv : cell_count) CHECK(clusters_in_cell[kv.first] == (kv.second + wg - 1) / wg);
  CHECK(clusters_in_cell.size() == cell_count.size());
}

TEST_CASE("clusters.h5 round-trips and refuses other hitpoints or scenes", "[clusters][formats]") {
  TempDir tmp("clusters");
  HitpointSet h = room_hitpoints(40, 30);
  ClusterSet c = cluster_kmeans(h, 32, 5, 3, 2);
  save_clusters(c, tmp / "c.h5", prov());
  ClusterSet r = load_clusters(tmp / "c.h5", h);
  CHECK(same_clusters(r, c));
  CHECK(r.wg_size == 32);
  CHECK(r.method == "kmeans");
  CHECK(r.scene_id == h.scene_id);
  CHECK(r.hitpoint_count == h.hitpoints.size());
  CHECK(r.hitpoints_sha256 == hitpoints_hash(h));
  CHECK(read_provenance(h5::Reader(tmp / "c.h5", kClustersFormat, 1)).tool == "test");

  // PPM state changes (radius, flux) keep the clusters valid.
  HitpointSet shrunk = h;
  for (auto& p : shrunk.hitpoints) p.radius *= 0.5f;
  CHECK_NOTHROW(load_clusters(tmp / "c.h5", shrunk));

  // Other hitpoints: another image size (the camera is part of scene_id, so give the other set
  // this scene's id to reach the hitpoints check).
  HitpointSet other = room_hitpoints(41, 30);
  CHECK_THROWS_WITH(load_clusters(tmp / "c.h5", other), Catch::Contains("different scene"));
  other.scene_id = h.scene_id;
  CHECK_THROWS_AS(load_clusters(tmp / "c.h5", other), InputError);
  CHECK_THROWS_WITH(load_clusters(tmp / "c.h5", other), Catch::Contains("other hitpoints") &&
                                                             Catch::Contains(tmp / "c.h5"));
  // Same count, one position moved.
  HitpointSet moved = h;
  moved.hitpoints[5].position[0] += 1e-3f;
  CHECK_THROWS_WITH(load_clusters(tmp / "c.h5", moved), Catch::Contains("other hitpoints"));
  // Another scene.
  HitpointSet foreign = h;
  foreign.scene_id = std::string(64, 'a');
  CHECK_THROWS_WITH(load_clusters(tmp / "c.h5", foreign), Catch::Contains("different scene"));

  // Grid clusters round-trip too.
  ClusterSet g = cluster_grid(h, 16, 8);
  save_clusters(g, tmp / "g.h5", prov());
  ClusterSet gr = load_clusters(tmp / "g.h5", h);
  CHECK(same_clusters(gr, g));
  CHECK(gr.method == "grid");
}

TEST_CASE("update_cluster_radii tightens radii as hitpoint radii shrink", "[clusters]") {
  HitpointSet h = room_hitpoints(48, 32);
  for (int method = 0; method < 2; ++method) {
    ClusterSet c = method == 0 ? cluster_kmeans(h, 32, 5, 1, 2) : cluster_grid(h, 32, 16);
    HitpointSet cur = h;
    ClusterSet before = c;
    update_cluster_radii(c, cur);  // same radii: unchanged
    CHECK(same_clusters(c, before));
    for (int pass = 0; pass < 3; ++pass) {
      for (size_t i = 0; i < cur.hitpoints.size(); ++i)
        cur.hitpoints[i].radius *= (i % 3 == 0) ? 0.5f : 0.9f;
      std::vector<float> old;
      for (auto& cl : c.clusters) old.push_back(cl.radius);
      update_cluster_radii(c, cur);
      bool never_grew = true, some_shrank = false;
      for (size_t k = 0; k < old.size(); ++k) {
        never_grew = never_grew && c.clusters[k].radius <= old[k];
        some_shrank = some_shrank || c.clusters[k].radius < old[k];
      }
      CHECK(never_grew);
      CHECK(some_shrank);
      CHECK(radii_contain(c, cur));
      CHECK(radii_tight(c, cur));
      CHECK(c.order == before.order);  // membership kept
    }
  }
}

TEST_CASE("the cluster tool writes loadable clusters and refuses a foreign scene",
          "[clusters][tools]") {
  TempDir tmp("cluster-tool");
  Scene s = test::room_scene(PF_MAT_DIFFUSE, 32, 24);
  Scene other = test::room_scene(PF_MAT_DIFFUSE, 33, 24);
  save_scene(s, tmp / "scene.h5", prov());
  save_scene(other, tmp / "other.h5", prov());
  EyePassOptions eo;
  HitpointSet h = make_hitpoint_set(trace_hitpoints(s, eo), eo.direct, s.scene_id);
  save_hitpoints(h, tmp / "hp.h5", prov());
  for (const char* method : {"kmeans", "grid"}) {
    auto r = test::run_tool("cluster", "--scene " + (tmp / "scene.h5") + " --hitpoints " +
                                           (tmp / "hp.h5") + " -o " + (tmp / "c.h5") +
                                           " --wg-size 32 --method " + method, tmp);
    INFO(r.err);
    REQUIRE(r.exit_code == 0);
    CHECK_THAT(r.out, Catch::Contains("fillers"));
    ClusterSet c = load_clusters(tmp / "c.h5", h);
    CHECK(c.method == method);
    CHECK(c.wg_size == 32);
    Provenance p = read_provenance(h5::Reader(tmp / "c.h5", kClustersFormat, 1));
    CHECK(p.tool == "cluster");
    CHECK(p.parameters.at("wg-size") == "32");
  }
  auto bad = test::run_tool("cluster", "--scene " + (tmp / "other.h5") + " --hitpoints " +
                                           (tmp / "hp.h5") + " -o " + (tmp / "x.h5"), tmp);
  CHECK(bad.exit_code == kExitBadInput);
  CHECK_THAT(bad.err, Catch::Contains("different scene"));
  auto choice = test::run_tool("cluster", "--scene " + (tmp / "scene.h5") + " --hitpoints " +
                                              (tmp / "hp.h5") + " -o " + (tmp / "x.h5") +
                                              " --method spectral", tmp);
  CHECK(choice.exit_code == kExitBadInput);
  CHECK(!std::filesystem::exists(tmp / "x.h5"));
  auto help = test::run_tool("cluster", "--help", tmp);
  CHECK(help.exit_code == 0);
  CHECK_THAT(help.out, Catch::Contains("wg-size") && Catch::Contains("default: 64"));
}

TEST_CASE("automatic grid-cluster bins keep fillers low", "[clusters][fillers]") {
  HitpointSet h = room_hitpoints(160, 120);
  const int wg = 64;
  ClusterSet fixed = cluster_grid(h, wg, 64), automatic = cluster_grid(h, wg, 0);
  REQUIRE(check_clusters(automatic, h) == "");
  const ClusterStats f = stats(fixed), a = stats(automatic);
  INFO("fillers: 64 bins " << f.fillers << ", automatic " << a.fillers << " of "
                           << h.hitpoints.size() << " hitpoints");
  CHECK(a.fillers < f.fillers);
  // Each mesh's bins were halved until cells hold >= 2 work-groups on average (or one bin is
  // left), so a mesh's fillers (< wg per cell) stay below half its hitpoints.
  std::map<int, size_t> members, fillers;
  for (const pf_cluster& c : automatic.clusters) {
    members[c.mesh] += size_t(c.count);
    fillers[c.mesh] += size_t(c.padded_count - c.count);
  }
  for (auto& kv : members)
    if (kv.second >= size_t(4 * wg)) CHECK(2 * fillers[kv.first] <= kv.second);
}

TEST_CASE("k-means ends at a Lloyd fixed point: each hitpoint's nearest centre is its own",
          "[clusters]") {
  // Lloyd's iteration (clusters.h) alternates "each hitpoint to its nearest centre" and "each
  // centre to the mean of its hitpoints"; when it has converged, the clusters' centres (means of
  // their members) are the centres the last assignment used, so every hitpoint's nearest centre of
  // its mesh — by brute force over all clusters — is its own cluster's. Seeds alone (no update
  // step) or a nearest-centre search that stops early do not give that.
  const HitpointSet h = room_hitpoints(48, 32);
  for (int wg : {16, 64}) {
    const ClusterSet c = cluster_kmeans(h, wg, 1000, 1, 2);
    REQUIRE(check_clusters(c, h) == "");
    size_t farther = 0, moved = 0;
    for (size_t k = 0; k < c.clusters.size(); ++k) {
      const pf_cluster& own = c.clusters[k];
      for (int t = own.first; t < own.first + own.count; ++t) {
        const float* x = h.hitpoints[size_t(c.order[size_t(t)])].position;
        auto d2 = [&](const pf_cluster& cl) {
          double s = 0;
          for (int a = 0; a < 3; ++a) s += (double(x[a]) - cl.centre[a]) * (double(x[a]) - cl.centre[a]);
          return s;
        };
        const double mine = d2(own);
        double best = mine;
        for (const pf_cluster& other : c.clusters)
          if (other.mesh == own.mesh) best = std::min(best, d2(other));
        farther += mine > best * (1 + 1e-6) + 1e-12;
      }
    }
    // The iteration did move the seeds: k-means clusters are not the Morton runs of the seeding.
    const ClusterSet seeds = cluster_kmeans(h, wg, 0, 1, 2);
    moved = same_clusters(seeds, c) ? 0 : 1;
    INFO("wg " << wg << ", " << c.clusters.size() << " clusters");
    CHECK(farther == 0);
    CHECK(moved == 1);
  }
}

TEST_CASE("k-means makes K = hitpoints / work-group size clusters per mesh (ch. 7.3)", "[clusters]") {
  // Meshes whose hitpoint counts are multiples of wg: evenly spaced on a line (mesh 0), in two
  // tight, far-apart groups of wg (mesh 1). With K = n / wg, k-means cuts them into runs of wg
  // exactly, with no filler (Table 7.5's count with fillers equals the hitpoint count); one
  // cluster more (K + 1) leaves clusters short of wg: fillers.
  const int wg = 8;
  HitpointSet h;
  for (int i = 0; i < 4 * wg; ++i) h.hitpoints.push_back(hp(0.1f * float(i), 0, 0, 0, 0.05f));
  for (int g = 0; g < 2; ++g)  // mesh 1: two groups of wg on a line
    for (int i = 0; i < wg; ++i) h.hitpoints.push_back(hp(5, 5, 3.f * float(g) + 0.01f * float(i), 1, 0.05f));
  h.width = int(h.hitpoints.size());
  h.height = 1;
  for (size_t i = 0; i < h.hitpoints.size(); ++i) h.hitpoints[i].pixel_x = int(i);
  h.scene_id = "s";
  const ClusterSet c = cluster_kmeans(h, wg, 10, 1, 1);
  REQUIRE(check_clusters(c, h) == "");
  const ClusterStats s = stats(c);
  CHECK(s.clusters == 6);
  CHECK(s.fillers == 0);
  for (const pf_cluster& cl : c.clusters) {  // runs of wg neighbours
    CHECK(cl.count == wg);
    CHECK(cl.radius < 0.1f * float(wg) / 2 + 0.06f);
  }
}

TEST_CASE("k-means assigns a hitpoint at any finite distance (no float overflow)", "[clusters]") {
  // A hitpoint 1e20 away: its squared float distance to every centre overflowed to infinity, no
  // centre was ever nearer than FLT_MAX, and its cluster index stayed INT32_MAX (SIGSEGV writing
  // the members). The tools refuse such a file on reading (stage_files.h); the clustering itself
  // must still give a valid partition.
  for (float far : {1e20f, -1e20f, 3e38f}) {
    INFO("position " << far);
    HitpointSet h = hand_set();
    h.hitpoints[4].position[0] = far;
    h.hitpoints[11].position[2] = far;  // mesh 1's too
    for (int wg : {2, 4}) {
      const ClusterSet c = cluster_kmeans(h, wg, 5, 1, 2);
      CHECK(check_clusters(c, h) == "");
      CHECK(radii_contain(c, h));  // the far hitpoint's cluster reaches it too
    }
  }
}
