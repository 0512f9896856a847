// Evolutionary clustering of hitpoints (thesis ch. 8; ga_clusters.h, photon_distribution.h):
//   - the photon-distribution map: first pass = the gather's own grid, counts of all passes,
//     box sums = brute force, file round trip, refusal of foreign maps;
//   - fitness eq. 8.1–8.3 and `work` on hand-built clusters and a hand-built map;
//   - each mutation of ch. 8.1 keeps a valid clustering (every hitpoint in exactly one cluster of
//     its mesh), the merge rule by sizes, undo restores the state exactly;
//   - incremental evaluation equals a full recomputation after random mutation sequences;
//   - determinism per seed and independence of the thread count; elitism (never worse than the
//     initial best, nor than k-means); resume after an interruption = an uninterrupted run;
//   - GA clusters give the image of the naive gather (OpenCL, PoCL in CI);
//   - the tools: cluster --method ga and photon-distribution write their files with provenance and
//     refuse foreign inputs with one line, exit 2 and no output.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <map>
#include <stdexcept>

#include "photonflow/io/validate.h"
#include "photonflow/opencl/cl_backend.h"
#include "photonflow/stages/clusters.h"
#include "photonflow/stages/eye_pass.h"
#include "photonflow/stages/ga_clusters.h"
#include "photonflow/io/h5io.h"
#include "photonflow/stages/illuminate.h"
#include "photonflow/stages/photon_distribution.h"
#include "photonflow/stages/photon_pass.h"
#include "photonflow/stages/synthesize.h"
#include "photonflow/geometry/scene_file.h"
#include "support.h"
#include "support_cl.h"

using namespace pf;
using test::TempDir;
using test::same_clusters;

namespace {

// A room with a diffuse sphere at w×h, its fresh hitpoints and a distribution map of `passes`.
struct Fixture {
  Scene scene;
  HitpointSet h;
  PhotonDistribution dist;
  std::vector<PhotonPassResult> passes;
};

Fixture make_fixture(int w, int hgt, int passes, uint32_t photons) {
  Fixture f{test::room_scene(PF_MAT_DIFFUSE, w, hgt), {}, {}, {}};
  EyePassOptions eo;
  f.h = make_hitpoint_set(trace_hitpoints(f.scene, eo), eo.direct, f.scene.scene_id);
  PpmOptions ppm;
  f.dist = empty_photon_distribution(ppm_grid_params(f.h, ppm), f.scene.scene_id);
  PhotonPassOptions po;
  po.photons = photons;
  for (int p = 0; p < passes; ++p) {
    f.passes.push_back(trace_photons(f.scene, uint32_t(p), po));
    f.dist.add_pass(f.passes.back().photons, f.passes.back().emitted, int(f.scene.mesh_names.size()));
  }
  return f;
}

const Fixture& fixture() {
  static const Fixture f = make_fixture(64, 48, 6, 4000);
  return f;
}

GaFitnessInputs inputs(const Fixture& f, int wg) {
  GaFitnessInputs in;
  in.hitpoints = &f.h;
  in.wg_size = wg;
  in.distribution = &f.dist;
  return in;
}

Provenance prov() {
  Provenance p;
  p.tool = "test";
  return p;
}

const GaFitness kCpuFitness[] = {GaFitness::Filler, GaFitness::GridBins, GaFitness::MemoryAccess,
                                 GaFitness::Work};

}  // namespace

// ---- the photon-distribution map ----------------------------------------------------------------

TEST_CASE("photon distribution: first pass's grid, all passes counted, box sums", "[ga][distribution]") {
  const Fixture& f = fixture();
  const PhotonDistribution& d = f.dist;
  REQUIRE(d.passes == 6);
  const int meshes = int(f.scene.mesh_names.size());
  REQUIRE(d.mesh_count() == meshes);
  // The bins are the first pass's own photon grid (what the gather builds for that pass).
  PpmOptions ppm;
  const PhotonGrid g0 = build_photon_grid(f.passes[0].photons, meshes, ppm_grid_params(f.h, ppm));
  uint64_t in_bins = 0, all = 0;
  for (int m = 0; m < meshes; ++m) {
    const pf_mesh_grid &a = d.mesh_grid[size_t(m)], &b = g0.mesh_grid[size_t(m)];
    CHECK(a.nx == b.nx);
    CHECK(a.ny == b.ny);
    CHECK(a.nz == b.nz);
    CHECK(a.bin_size == b.bin_size);
    CHECK(std::memcmp(a.lo, b.lo, sizeof a.lo) == 0);
  }
  // Every photon of a mesh with bins is counted once, in the bin eq. 7.1 gives it.
  std::vector<uint64_t> expect(d.counts.size(), 0);
  for (const PhotonPassResult& p : f.passes)
    for (const pf_photon& ph : p.photons) {
      ++all;
      const pf_mesh_grid& m = d.mesh_grid[size_t(ph.mesh)];
      if (m.nx == 0) continue;
      ++in_bins;
      ++expect[size_t(m.first_bin) + size_t(pf_grid_bin(&m, ph.position[0], ph.position[1], ph.position[2]))];
    }
  CHECK(expect == d.counts);
  CHECK(in_bins > all / 2);
  uint64_t emitted = 0;
  for (const PhotonPassResult& p : f.passes) emitted += p.emitted;
  CHECK(d.emitted == emitted);

  // Box sums (summed-volume tables) = brute force, on boxes from actual cluster spheres.
  DistributionSums sums(d);
  const ClusterSet km = cluster_kmeans(f.h, 16, 5, 1, 2);
  size_t checked = 0;
  for (const pf_cluster& c : km.clusters) {
    int lo[3], hi[3];
    if (!sums.box(c.mesh, c.centre, c.radius, lo, hi)) continue;
    const pf_mesh_grid& m = d.mesh_grid[size_t(c.mesh)];
    uint64_t s = 0;
    for (int z = lo[2]; z <= hi[2]; ++z)
      for (int y = lo[1]; y <= hi[1]; ++y)
        for (int x = lo[0]; x <= hi[0]; ++x)
          s += d.counts[size_t(m.first_bin) + size_t(x + (y + z * m.ny) * m.nx)];
    CHECK(sums.photons(c.mesh, lo, hi) == s);
    ++checked;
  }
  CHECK(checked > 50);
}

TEST_CASE("photon distribution: file round trip and refusal of foreign maps", "[ga][distribution][formats]") {
  TempDir tmp("ga-dist");
  const Fixture& f = fixture();
  save_photon_distribution(f.dist, tmp / "d.h5", prov());
  const PhotonDistribution r = load_photon_distribution(tmp / "d.h5");
  CHECK(r.counts == f.dist.counts);
  CHECK(r.passes == f.dist.passes);
  CHECK(r.emitted == f.dist.emitted);
  CHECK(r.params.max_bins == f.dist.params.max_bins);
  CHECK(r.params.default_radius == f.dist.params.default_radius);
  CHECK(std::memcmp(r.mesh_grid.data(), f.dist.mesh_grid.data(),
                    r.mesh_grid.size() * sizeof(pf_mesh_grid)) == 0);
  CHECK(read_provenance(h5::Reader(tmp / "d.h5", kPhotonDistributionFormat, 1)).tool == "test");
  CHECK_NOTHROW(require_distribution_for(r, tmp / "d.h5", f.h));
  HitpointSet other = f.h;
  other.scene_id = std::string(64, 'b');
  CHECK_THROWS_WITH(require_distribution_for(r, tmp / "d.h5", other),
                    Catch::Contains("different scene") && Catch::Contains(tmp / "d.h5"));
  other = f.h;
  other.radius0 *= 2.f;
  CHECK_THROWS_AS(require_distribution_for(r, tmp / "d.h5", other), InputError);
  // Another format is refused.
  save_clusters(cluster_grid(f.h, 16, 4), tmp / "c.h5", prov());
  CHECK_THROWS_AS(load_photon_distribution(tmp / "c.h5"), InputError);
}

TEST_CASE("photon distribution: first_pass and the per-pass mean are stored", "[ga][distribution][formats]") {
  // Two passes of hand-placed photons on one mesh, the first pass numbered 3: /mean_photons is
  // /photon_count / passes (docs/FORMATS.md), first_pass reads back.
  TempDir tmp("ga-dist-mean");
  PhotonGridParams gp;
  gp.max_bins = 4;
  gp.default_radius = 0.1f;
  PhotonDistribution d = empty_photon_distribution(gp, std::string(64, 'a'));
  d.first_pass = 3;
  std::vector<pf_photon> ph(5);
  for (size_t i = 0; i < ph.size(); ++i) {
    ph[i] = pf_photon{};
    ph[i].position[0] = float(i) * 0.25f;  // 0 .. 1 along x
    ph[i].mesh = 0;
    ph[i].pass = 3;
  }
  d.add_pass(ph, 10, 1);
  for (auto& p : ph) p.pass = 4;
  ph.resize(3);
  d.add_pass(ph, 7, 1);
  REQUIRE(d.passes == 2);
  save_photon_distribution(d, tmp / "d.h5", prov());
  const PhotonDistribution r = load_photon_distribution(tmp / "d.h5");
  CHECK(r.first_pass == 3);
  CHECK(r.emitted == 17u);
  CHECK(r.scene_id == d.scene_id);
  h5::Reader reader(tmp / "d.h5", kPhotonDistributionFormat, 1);
  const std::vector<uint64_t> counts = reader.read<uint64_t>("/photon_count");
  const std::vector<float> mean = reader.read<float>("/mean_photons");
  REQUIRE(mean.size() == counts.size());
  uint64_t total = 0;
  for (size_t b = 0; b < counts.size(); ++b) {
    total += counts[b];
    CHECK(mean[b] == float(double(counts[b]) / 2.0));
  }
  CHECK(total == 8u);
  // /mesh_grid photon_count: the mesh's photons over all passes (5 + 3), not the first pass's.
  REQUIRE(r.mesh_grid.size() == 1);
  CHECK(r.mesh_grid[0].photon_count == 8);
  // A bin table that does not match the grid headers is refused: one count short, or a mesh
  // whose bins do not start where the previous mesh's end (here: not at 0). (The writer refuses
  // to write them: damaged files made on purpose.)
  const UncheckedWritesForTests damaged;
  PhotonDistribution shorter = d;
  shorter.counts.pop_back();
  save_photon_distribution(shorter, tmp / "short.h5", prov());
  CHECK_THROWS_WITH(load_photon_distribution(tmp / "short.h5"),
                    Catch::Contains("bin table does not match"));
  PhotonDistribution shifted = d;
  shifted.mesh_grid[0].first_bin = 1;
  shifted.counts.push_back(0);
  save_photon_distribution(shifted, tmp / "shifted.h5", prov());
  CHECK_THROWS_WITH(load_photon_distribution(tmp / "shifted.h5"), Catch::Contains("not contiguous"));
}

// ---- fitness on hand-built cases -----------------------------------------------------------------

TEST_CASE("fitness eq. 8.1-8.3 and work on hand-built clusters", "[ga][fitness]") {
  // One mesh, a 4×4×1 grid of unit bins from the origin; bin (x, y) holds x + 4y + 1 photons over
  // 2 passes.
  PhotonDistribution d;
  pf_mesh_grid g{};
  g.bin_size = 1.f;
  g.nx = 4;
  g.ny = 4;
  g.nz = 1;
  d.mesh_grid = {g};
  for (int b = 0; b < 16; ++b) d.counts.push_back(uint64_t(b + 1));
  d.passes = 2;
  HitpointSet h;  // only read for the bindings; the fitness reads the clusters' geometry
  h.hitpoints.resize(9);
  ClusterSet c;
  c.wg_size = 4;
  // Cluster 1: 5 members (2 work-groups, 3 fillers) at (1.5, 1.5, 0), R 0.6: bins x, y in 0..2.
  pf_cluster a{{1.5f, 1.5f, 0.f}, 0.6f, 0, 0, 5, 8};
  // Cluster 2: 4 members (1 work-group, no filler) at (3.9, 0.1, 0), R 0.05: bin (3, 0) only.
  pf_cluster b{{3.9f, 0.1f, 0.f}, 0.05f, 0, 8, 4, 4};
  c.clusters = {a, b};
  GaFitnessInputs in;
  in.hitpoints = &h;
  in.wg_size = 4;
  in.distribution = &d;
  // Photons of cluster 1's 3×3 bins: Σ_{x,y<3} (x + 4y + 1) = 54; cluster 2's bin: 4.
  CHECK(cluster_fitness(c, in, GaFitness::Filler) == 3.0);           // eq. 8.1
  CHECK(cluster_fitness(c, in, GaFitness::GridBins) == 9 * 2 + 1 * 1);  // eq. 8.2
  // eq. 8.3: Σ workgroups · Σ mean photons / wg = 2·(54/2)/4 + 1·(4/2)/4
  CHECK(cluster_fitness(c, in, GaFitness::MemoryAccess) == Approx(2 * 27.0 / 4 + 2.0 / 4));
  CHECK(cluster_fitness(c, in, GaFitness::Work) == Approx(5 * 27.0 + 4 * 2.0));  // count · mean photons
  // A sphere over the grid's edge reads the clamped border bins only (eq. 7.1).
  c.clusters = {pf_cluster{{-5.f, 1.5f, 0.f}, 0.2f, 0, 0, 4, 4}};
  CHECK(cluster_fitness(c, in, GaFitness::GridBins) == 1.0);
  CHECK(cluster_fitness(c, in, GaFitness::Work) == Approx(4 * (0 + 4 + 1) / 2.0));
  // A fitness that needs the map refuses to run without it.
  in.distribution = nullptr;
  CHECK_THROWS_AS(cluster_fitness(c, in, GaFitness::MemoryAccess), InputError);
  CHECK(cluster_fitness(c, in, GaFitness::Filler) == 0.0);
}

// ---- mutations -------------------------------------------------------------------------------------

TEST_CASE("every mutation keeps a valid clustering and undo restores the state", "[ga][mutation]") {
  const Fixture& f = fixture();
  const int wg = 16;
  const GaFitnessInputs in = inputs(f, wg);
  const ClusterSet km = cluster_kmeans(f.h, wg, 5, 1, 2);
  for (auto mu : {GaState::Mutation::Merge, GaState::Mutation::Move, GaState::Mutation::Remove,
                  GaState::Mutation::Add}) {
    INFO("mutation " << int(mu));
    GaState st(in, GaFitness::MemoryAccess, km);
    REQUIRE(check_clusters(st.clusters(), f.h) == "");
    int changed = 0, fewer = 0, more = 0;
    for (uint32_t k = 0; k < 40; ++k) {
      const ClusterSet before = st.clusters();
      const int64_t score_before = st.score();
      pf_rng rng = pf_rng_start(5, 77, k);
      const bool ch = st.mutate(mu, rng);
      st.evaluate();
      const ClusterSet after = st.clusters();
      REQUIRE(check_clusters(after, f.h) == "");  // every hitpoint exactly once, meshes pure
      REQUIRE(same_clusters(after, st.full_clusters()));   // still the nearest-centroid clustering
      REQUIRE(st.score() == st.full_score());
      changed += ch;
      fewer += after.clusters.size() < before.clusters.size();
      more += after.clusters.size() > before.clusters.size();
      if (!ch) CHECK(same_clusters(after, before));
      if (k % 3 == 0) {
        st.undo();
        CHECK(same_clusters(st.clusters(), before));
        CHECK(st.score() == score_before);
      } else {
        st.commit();
      }
    }
    CHECK(changed > 5);
    if (mu == GaState::Mutation::Merge || mu == GaState::Mutation::Remove) CHECK(fewer > 5);
    if (mu == GaState::Mutation::Add) CHECK(more > 5);
  }
}

TEST_CASE("the merge rule follows the cluster sizes (ch. 8.1)", "[ga][mutation]") {
  // Mesh 0: two groups on a line, a far group on mesh 1 (never merged across meshes).
  auto make = [](int na, int nb) {
    HitpointSet h;
    for (int i = 0; i < na; ++i) {
      pf_hitpoint p{};
      p.position[0] = 0.01f * float(i);
      p.radius = 0.01f;
      h.hitpoints.push_back(p);
    }
    for (int i = 0; i < nb; ++i) {
      pf_hitpoint p{};
      p.position[0] = 1.f + 0.01f * float(i);
      p.radius = 0.01f;
      h.hitpoints.push_back(p);
    }
    pf_hitpoint q{};
    q.position[1] = 5.f;
    q.mesh = 1;
    q.radius = 0.01f;
    h.hitpoints.push_back(q);
    h.radius0 = 0.01f;
    h.scene_id = "s";
    return h;
  };
  const int wg = 4;
  auto start = [&](const HitpointSet& h, int na) {
    ClusterSet c = empty_cluster_set(h, wg, "test");
    std::vector<int32_t> a, b;
    for (int i = 0; i < int(h.hitpoints.size()) - 1; ++i) (i < na ? a : b).push_back(i);
    append_cluster(c, 0, a.data(), a.size(), h);
    append_cluster(c, 0, b.data(), b.size(), h);
    const int32_t last = int32_t(h.hitpoints.size() - 1);
    append_cluster(c, 1, &last, 1, h);
    return c;
  };
  size_t merged_small = 0, merged_large = 0, merged_mid = 0;
  const int tries = 200;
  for (int na_nb : {3, 10, 6}) {  // |A|+|B| = 3 < wg: always; 10 > 2·wg: never; 6: p = 1/2
    const int na = na_nb / 2, nb = na_nb - na;
    const HitpointSet h = make(na, nb);
    GaFitnessInputs in;
    in.hitpoints = &h;
    in.wg_size = wg;
    const ClusterSet s = start(h, na);
    for (int k = 0; k < tries; ++k) {
      GaState st(in, GaFitness::Filler, s);
      REQUIRE(st.cluster_count() == 3);
      pf_rng rng = pf_rng_start(1, 2, uint32_t(k));
      st.mutate(GaState::Mutation::Merge, rng);
      st.evaluate();
      REQUIRE(check_clusters(st.clusters(), h) == "");
      const bool merged = st.cluster_count() == 2;
      if (merged) {  // the merged mesh-0 cluster holds all of A and B
        const ClusterSet c = st.clusters();
        CHECK(c.clusters[0].count == na + nb);
        CHECK(c.clusters[1].mesh == 1);
      }
      (na_nb == 3 ? merged_small : na_nb == 10 ? merged_large : merged_mid) += merged;
    }
  }
  // A random pick lands on the mesh-1 cluster (alone on its mesh: nothing to merge) 1/3 of the time.
  CHECK(merged_small > size_t(tries) / 2);
  CHECK(merged_small + size_t(tries) / 5 > size_t(tries) * 2 / 3);
  CHECK(merged_large == 0);
  CHECK(merged_mid > size_t(tries) / 6);                 // about 2/3 · 1/2 = 1/3 of the tries
  CHECK(merged_mid < merged_small - size_t(tries) / 10);
}

TEST_CASE("the remove mutation takes the smaller of two clusters (ch. 8.1)", "[ga][mutation]") {
  // Mutation 3 removes 1–5 centroids, each the smaller of two clusters picked at random, so small
  // clusters are removed more often: the clusters removed are smaller than the clusters on
  // average. 30 tight groups of 1 … 30 hitpoints (sizes shuffled over the positions), one
  // centroid each; a removed centroid is recognised by its position.
  const int groups = 30;
  HitpointSet h;
  std::vector<int> size_at;
  for (int g = 0; g < groups; ++g) {
    const int n = (g * 7) % groups + 1;
    size_at.push_back(n);
    for (int i = 0; i < n; ++i) {
      pf_hitpoint p{};
      p.position[0] = float(g % 6) + 0.001f * float(i);
      p.position[1] = float(g / 6);
      p.radius = 0.01f;
      h.hitpoints.push_back(p);
    }
  }
  h.radius0 = 0.01f;
  h.scene_id = "s";
  GaFitnessInputs in;
  in.hitpoints = &h;
  in.wg_size = 4;
  ClusterSet start = empty_cluster_set(h, in.wg_size, "test");
  int32_t first = 0;
  for (int g = 0; g < groups; ++g) {
    std::vector<int32_t> m(static_cast<size_t>(size_at[size_t(g)]));
    for (int32_t& i : m) i = first++;
    append_cluster(start, 0, m.data(), m.size(), h);
  }
  double removed_size = 0;
  size_t removed = 0;
  for (uint32_t k = 0; k < 200; ++k) {
    GaState st(in, GaFitness::Filler, start);
    REQUIRE(st.cluster_count() == size_t(groups));
    pf_rng rng = pf_rng_start(3, 5, k);
    st.mutate(GaState::Mutation::Remove, rng);
    st.evaluate();
    REQUIRE(check_clusters(st.clusters(), h) == "");
    const std::vector<GaCentroid> left = st.centroids();
    for (int g = 0; g < groups; ++g) {
      bool kept = false;
      for (const GaCentroid& c : left)
        kept |= std::fabs(c.position[0] - float(g % 6)) < 0.5f && std::fabs(c.position[1] - float(g / 6)) < 0.5f;
      if (!kept) {
        removed_size += size_at[size_t(g)];
        ++removed;
      }
    }
  }
  const double mean_size = (groups + 1) / 2.0;
  INFO(removed << " centroids removed, mean size " << removed_size / double(removed) << " vs "
               << mean_size);
  REQUIRE(removed > 200);
  CHECK(removed_size / double(removed) < 0.85 * mean_size);
}

TEST_CASE("incremental fitness equals a full recomputation after random mutation sequences",
          "[ga][incremental]") {
  const Fixture& f = fixture();
  for (int wg : {16, 32}) {
    const GaFitnessInputs in = inputs(f, wg);
    const ClusterSet km = cluster_kmeans(f.h, wg, 5, 1, 2);
    for (GaFitness fit : kCpuFitness) {
      INFO("wg " << wg << ", fitness " << ga_fitness_name(fit));
      GaState st(in, fit, km);
      CHECK(st.score() == st.full_score());
      // The start equals the fitness of its own clusters computed by cluster_fitness.
      CHECK(st.fitness() == cluster_fitness(st.clusters(), in, fit));
      GaState committed = st;
      for (uint32_t k = 0; k < 60; ++k) {
        pf_rng rng = pf_rng_start(9, k, uint32_t(wg));
        st.mutate_child(rng);
        if (k % 4 == 1) {  // two children's worth of mutations before one evaluation
          pf_rng r2 = pf_rng_start(9, k, 1000);
          st.mutate_child(r2);
        }
        st.evaluate();
        REQUIRE(st.score() == st.full_score());
        REQUIRE(same_clusters(st.clusters(), st.full_clusters()));
        CHECK(st.fitness() == cluster_fitness(st.clusters(), in, fit));
        if (k % 5 == 2) {
          st.undo();
          REQUIRE(same_clusters(st.clusters(), committed.clusters()));
          REQUIRE(st.score() == committed.score());
        } else {
          st.commit();
          committed = st;
        }
      }
    }
  }
}

// ---- the evolution ---------------------------------------------------------------------------------

TEST_CASE("evolution: deterministic per seed, independent of the thread count", "[ga][evolve]") {
  const Fixture& f = fixture();
  const GaFitnessInputs in = inputs(f, 16);
  GaOptions o;
  o.population = 10;
  o.iterations = 40;
  o.seed = 4;
  o.threads = 1;
  const GaResult a = evolve_clusters(in, o);
  o.threads = 2;
  const GaResult b = evolve_clusters(in, o);
  o.threads = 3;
  const GaResult c = evolve_clusters(in, o);
  CHECK(same_clusters(a.clusters, b.clusters));
  CHECK(same_clusters(a.clusters, c.clusters));
  CHECK(a.history == b.history);
  CHECK(a.history == c.history);
  CHECK(a.clusters.method == "ga");
  REQUIRE(check_clusters(a.clusters, f.h) == "");
  o.seed = 5;
  const GaResult d = evolve_clusters(in, o);
  CHECK_FALSE(same_clusters(a.clusters, d.clusters));
}

TEST_CASE("evolution: elitist, never worse than its start, it improves on k-means",
          "[ga][evolve]") {
  const Fixture& f = fixture();
  for (GaFitness fit : kCpuFitness) {
    INFO("fitness " << ga_fitness_name(fit));
    const GaFitnessInputs in = inputs(f, 16);
    GaOptions o;
    o.fitness = fit;
    o.population = 12;
    o.iterations = 60;
    o.threads = 2;
    const GaResult r = evolve_clusters(in, o);
    REQUIRE(r.history.size() == 61);
    CHECK(r.generations == 61);
    CHECK(r.evaluations == 61u * 11u);
    for (size_t g = 1; g < r.history.size(); ++g) CHECK(r.history[g] <= r.history[g - 1]);
    CHECK(r.history[0] <= r.start_fitness);
    CHECK(r.fitness == r.history.back());
    CHECK(r.fitness == cluster_fitness(r.clusters, in, fit));  // the clusters it writes
    CHECK(r.fitness < r.start_fitness);                        // the evolution did something
    CHECK(r.fitness <= r.kmeans_fitness);
    CHECK(r.kmeans_fitness == cluster_fitness(cluster_kmeans(f.h, 16, 10, 1, 2), in, fit));
    REQUIRE(check_clusters(r.clusters, f.h) == "");
  }
}

TEST_CASE("evolution: each generation's parent is the best of parent and children (1+λ)",
          "[ga][evolve]") {
  // ga_clusters.h, ch. 8.1: child c of generation g mutates the parent with the stream
  // (seed, g, c); the child of lowest fitness (the lowest-numbered on equal fitness) replaces the
  // parent when it is not worse — on equal fitness too. Replayed here with GaState alone: the
  // evolution's history and final clusters must be those of the replay.
  const Fixture& f = fixture();
  const GaFitnessInputs in = inputs(f, 16);
  for (GaFitness fit : {GaFitness::Filler, GaFitness::MemoryAccess}) {
    INFO("fitness " << ga_fitness_name(fit));
    GaOptions o;
    o.fitness = fit;
    o.population = 5;
    o.iterations = 12;
    o.seed = 7;
    o.threads = 2;
    const GaResult r = evolve_clusters(in, o);
    GaState parent(in, fit, cluster_kmeans(f.h, 16, o.kmeans_iterations, o.seed, o.threads));
    double best_so_far = parent.fitness();
    std::vector<double> history;
    size_t ties = 0, replaced = 0;
    for (int g = 0; g <= o.iterations; ++g) {
      std::vector<double> child;
      for (int c = 0; c + 1 < o.population; ++c) {
        pf_rng rng = pf_rng_start(o.seed, uint32_t(g), uint32_t(c));
        parent.mutate_child(rng);
        parent.evaluate();
        child.push_back(parent.fitness());
        parent.undo();
      }
      const size_t best = size_t(std::min_element(child.begin(), child.end()) - child.begin());
      if (child[best] <= best_so_far) {
        ties += child[best] == best_so_far;
        ++replaced;
        pf_rng rng = pf_rng_start(o.seed, uint32_t(g), uint32_t(best));
        parent.mutate_child(rng);
        parent.evaluate();
        parent.commit();
        best_so_far = child[best];
      }
      history.push_back(best_so_far);
    }
    INFO(replaced << " generations took a child, " << ties << " of them on equal fitness");
    CHECK(r.history == history);
    CHECK(same_clusters(r.clusters, parent.clusters()));
    CHECK(ties > 0);  // the equal-fitness rule was exercised
  }
}

TEST_CASE("evolution: resume after an interruption = an uninterrupted run", "[ga][evolve][resume]") {
  TempDir tmp("ga-resume");
  const Fixture& f = fixture();
  const GaFitnessInputs in = inputs(f, 16);
  GaOptions o;
  o.population = 8;
  o.iterations = 40;
  o.threads = 2;
  o.checkpoint_every = 7;
  o.checkpoint = tmp / "a.ck.h5";
  const GaResult whole = evolve_clusters(in, o);
  REQUIRE_FALSE(whole.interrupted);

  // Stopped cleanly at generation 17 (Ctrl-C): the checkpoint holds generation 17.
  o.checkpoint = tmp / "b.ck.h5";
  const GaResult part = evolve_clusters(in, o, [](const GaProgress& p) { return p.generation < 17; });
  CHECK(part.interrupted);
  CHECK(part.generations == 17);
  CHECK(part.clusters.clusters.empty());
  o.resume = true;
  const GaResult rest = evolve_clusters(in, o);
  CHECK(rest.resumed_from == 17);
  CHECK(same_clusters(rest.clusters, whole.clusters));
  CHECK(rest.history == whole.history);
  CHECK(rest.fitness == whole.fitness);
  CHECK(rest.evaluations == whole.evaluations);

  // Killed at generation 23 (no clean stop): resumes from the last periodic checkpoint (21).
  o.resume = false;
  o.checkpoint = tmp / "c.ck.h5";
  CHECK_THROWS_AS(evolve_clusters(in, o, [](const GaProgress& p) -> bool {
                    if (p.generation == 23) throw std::runtime_error("killed");
                    return true;
                  }),
                  std::runtime_error);
  o.resume = true;
  const GaResult after_kill = evolve_clusters(in, o);
  CHECK(after_kill.resumed_from == 21);
  CHECK(same_clusters(after_kill.clusters, whole.clusters));
  CHECK(after_kill.history == whole.history);

  // A checkpoint of another run (other seed) is refused, one line naming it.
  o.seed = 99;
  CHECK_THROWS_WITH(evolve_clusters(in, o), Catch::Contains(tmp / "c.ck.h5") && Catch::Contains("seed"));
  o.seed = 1;

  // Every checkpoint carries /provenance (FORMATS.md: every file does): without the caller's,
  // tool "cluster", the GA's parameters and seed, and the seconds so far.
  {
    const Provenance p = read_provenance(h5::Reader(tmp / "c.ck.h5", kGaCheckpointFormat, 1));
    CHECK(p.tool == "cluster");
    CHECK(p.seed == 1);
    CHECK(p.parameters.at("ga-iterations") == "40");
    CHECK(p.parameters.at("fitness") == ga_fitness_name(o.fitness));
    CHECK(p.wall_time_s > 0.0);
    CHECK_FALSE(p.version.empty());
  }
  // A resume asking for fewer iterations than the checkpoint has run is refused: its record would
  // say iterations 20 but generations 41.
  o.iterations = 20;
  CHECK_THROWS_WITH(evolve_clusters(in, o), Catch::Contains(tmp / "c.ck.h5") &&
                                                Catch::Contains("--ga-iterations 20") &&
                                                Catch::Contains("40 iterations"));
  o.iterations = 40;
  // A centroid on a mesh without hitpoints (an index past the hitpoints' meshes, or negative) is
  // refused naming the checkpoint, not left to the GA's internal checks.
  const h5::Compound centroid = [] {
    h5::Compound c(sizeof(GaCentroid));
    c.f32("position", offsetof(GaCentroid, position), 3).i32("mesh", offsetof(GaCentroid, mesh));
    c.u32("id", offsetof(GaCentroid, id));
    return c;
  }();
  for (int32_t mesh : {99, -1, 3}) {  // 3: the light, which the eye pass sees as an emitter only
    const std::string bad = tmp / ("bad" + std::to_string(mesh) + ".ck.h5");
    std::filesystem::copy_file(tmp / "c.ck.h5", bad);
    test::edit_dataset<GaCentroid>(bad, "/centroids", centroid.id(),
                                   [&](std::vector<GaCentroid>& v) { v[0].mesh = mesh; });
    o.checkpoint = bad;
    bool has_hitpoints = false;
    for (const pf_hitpoint& x : f.h.hitpoints) has_hitpoints |= x.mesh == mesh;
    if (has_hitpoints) continue;
    INFO("mesh " << mesh);
    CHECK_THROWS_WITH(evolve_clusters(in, o), Catch::Contains(bad) && Catch::Contains("centroid 0"));
  }
  // Values (issue 26): a centroid that is no world position, a fitness that is not a number.
  {
    const std::string bad = tmp / "nan-centroid.ck.h5";
    std::filesystem::copy_file(tmp / "c.ck.h5", bad);
    test::edit_dataset<GaCentroid>(bad, "/centroids", centroid.id(), [&](std::vector<GaCentroid>& v) {
      v[1].position[2] = std::nanf("");
    });
    o.checkpoint = bad;
    CHECK_THROWS_WITH(evolve_clusters(in, o),
                      Catch::Contains(bad) && Catch::Contains("centroids[1].position"));
    const std::string bad2 = tmp / "nan-fitness.ck.h5";
    std::filesystem::copy_file(tmp / "c.ck.h5", bad2);
    test::edit_dataset<double>(bad2, "/best_fitness", H5T_NATIVE_DOUBLE,
                               [&](std::vector<double>& v) { v[2] = -1.0; });
    o.checkpoint = bad2;
    CHECK_THROWS_WITH(evolve_clusters(in, o),
                      Catch::Contains(bad2) && Catch::Contains("best_fitness[2]"));
  }
}

// ---- images (OpenCL) ---------------------------------------------------------------------------------

TEST_CASE("GA clusters give the naive gather's image", "[ga][opencl]") {
  auto dev = test::test_device();
  if (!dev) return;
  const Fixture& f = fixture();
  const int wg = dev->work_group();
  const GaFitnessInputs in = inputs(f, wg);
  GaOptions o;
  o.population = 8;
  o.iterations = 30;
  o.fitness = GaFitness::Work;
  GaResult r = evolve_clusters(in, o);
  REQUIRE(r.fitness < r.start_fitness);
  const ClusterSet km = cluster_kmeans(f.h, wg, 10, 1, 2);
  REQUIRE_FALSE(same_clusters(r.clusters, km));  // the test gathers with clusters k-means did not make
  auto run = [&](GatherMethod m, ClusterSet* cs) {
    PpmOptions opt;
    opt.method = m;
    opt.clusters = cs;
    HitpointSet h = f.h;
    for (const PhotonPassResult& p : f.passes) ppm_pass(f.scene, h, p.photons, p.emitted, opt, *dev);
    return h;
  };
  const HitpointSet naive = run(GatherMethod::Naive, nullptr);
  const HitpointSet ga = run(GatherMethod::GridKmeans, &r.clusters);
  size_t same_r = 0, gathered = 0;
  for (size_t i = 0; i < ga.hitpoints.size(); ++i) {
    same_r += ga.hitpoints[i].radius == naive.hitpoints[i].radius &&
              ga.hitpoints[i].n_photons == naive.hitpoints[i].n_photons;
    gathered += naive.hitpoints[i].n_photons > 0;
  }
  CHECK(gathered > naive.hitpoints.size() / 4);
  CHECK(same_r == ga.hitpoints.size());
  const double e = test::relative_rmse(synthesize(ga), synthesize(naive));
  INFO("relative RMSE vs naive " << e);
  CHECK(e <= 1e-5);
}

TEST_CASE("device-time fitness: the gather kernel timed on the device", "[ga][opencl][device-time]") {
  auto dev = test::test_device();
  if (!dev) return;
  const Fixture& f = fixture();
  GaFitnessInputs in = inputs(f, dev->work_group());
  in.scene = &f.scene;
  in.photons = &f.passes[0].photons;
  in.emitted = f.passes[0].emitted;
  in.device = dev.get();
  in.device_runs = 2;
  GaOptions o;
  o.fitness = GaFitness::DeviceTime;
  o.population = 3;
  o.iterations = 2;
  const GaResult r = evolve_clusters(in, o);
  REQUIRE(check_clusters(r.clusters, f.h) == "");
  CHECK(r.fitness > 0);
  CHECK(r.start_fitness > 0);
  REQUIRE(r.history.size() == 3);
  for (double t : r.history) CHECK(t > 0);
  // The fitness is the kernel time of the clusters it returns: timing them again gives the same
  // order of magnitude (a shared CPU device varies by about 2x).
  const double again = cluster_fitness(r.clusters, in, GaFitness::DeviceTime);
  CHECK(again < 10 * r.fitness);
  CHECK(r.fitness < 10 * again);
  in.device = nullptr;
  CHECK_THROWS_AS(evolve_clusters(in, o), InputError);
}

// ---- the tools ---------------------------------------------------------------------------------------

TEST_CASE("cluster --method ga and photon-distribution: files, provenance, refusals",
          "[ga][tools]") {
  TempDir tmp("ga-tools");
  Scene s = test::room_scene(PF_MAT_DIFFUSE, 40, 30);
  Scene other = test::room_scene(PF_MAT_DIFFUSE, 41, 30);
  save_scene(s, tmp / "scene.h5", prov());
  save_scene(other, tmp / "other.h5", prov());
  EyePassOptions eo;
  HitpointSet h = make_hitpoint_set(trace_hitpoints(s, eo), eo.direct, s.scene_id);
  save_hitpoints(h, tmp / "hp.h5", prov());
  HitpointSet ho = make_hitpoint_set(trace_hitpoints(other, eo), eo.direct, other.scene_id);
  save_hitpoints(ho, tmp / "hp-other.h5", prov());
  eo.radius = h.radius0 * 1.5f;
  HitpointSet hr = make_hitpoint_set(trace_hitpoints(s, eo), eo.direct, s.scene_id);
  save_hitpoints(hr, tmp / "hp-r.h5", prov());
  const std::string S = " --scene " + (tmp / "scene.h5"), HP = " --hitpoints " + (tmp / "hp.h5");

  auto d = test::run_tool("photon-distribution", S + HP + " -o " + (tmp / "d.h5") +
                                                      " --passes 3 --emit 3000", tmp);
  INFO(d.err);
  REQUIRE(d.exit_code == 0);
  {
    const PhotonDistribution dist = load_photon_distribution(tmp / "d.h5");
    CHECK(dist.passes == 3);
    const Provenance p = read_provenance(h5::Reader(tmp / "d.h5", kPhotonDistributionFormat, 1));
    CHECK(p.tool == "photon-distribution");
    CHECK(p.inputs.size() == 2);
  }
  // The same map from a photons file of the same passes.
  PhotonSet ps;
  ps.scene_id = s.scene_id;
  ps.seed = 1;
  PhotonPassOptions po;
  po.photons = 3000;
  for (int p = 0; p < 3; ++p) {
    PhotonPassResult r = trace_photons(s, uint32_t(p), po);
    ps.append_pass(r.photons, r.emitted);
  }
  save_photons(ps, tmp / "ph.h5", prov());
  auto d2 = test::run_tool("photon-distribution", S + HP + " -o " + (tmp / "d2.h5") + " --photons " +
                                                       (tmp / "ph.h5"), tmp);
  REQUIRE(d2.exit_code == 0);
  CHECK(load_photon_distribution(tmp / "d2.h5").counts == load_photon_distribution(tmp / "d.h5").counts);

  const std::string GA = S + HP + " --method ga --wg-size 16 --population 6 --ga-iterations 12 "
                                  "--distribution " + (tmp / "d.h5");
  auto r = test::run_tool("cluster", GA + " -o " + (tmp / "ga.h5"), tmp);
  INFO(r.err);
  REQUIRE(r.exit_code == 0);
  CHECK_THAT(r.out, Catch::Contains("memory-access"));
  {
    const ClusterSet c = load_clusters(tmp / "ga.h5", h);
    CHECK(c.method == "ga");
    CHECK(c.wg_size == 16);
    h5::Reader rd(tmp / "ga.h5", kClustersFormat, 1);
    const std::vector<double> hist = rd.read<double>("/ga/best_fitness");
    CHECK(hist.size() == 13);
    CHECK(rd.attr_string("/ga", "fitness") == "memory-access");
    CHECK(rd.attr_int("/ga", "seed") == 1);
    CHECK(rd.attr_double("/ga", "best_fitness") == hist.back());
    const Provenance p = read_provenance(rd);
    CHECK(p.tool == "cluster");
    bool has_dist = false;
    for (const InputRef& i : p.inputs) has_dist |= i.role == "distribution" && i.format == kPhotonDistributionFormat;
    CHECK(has_dist);
    CHECK(p.parameters.at("fitness") == "memory-access");
    CHECK(p.parameters.at("population") == "6");
  }
  CHECK(std::filesystem::exists(tmp / "ga.h5.checkpoint.h5"));
  {  // the checkpoint's provenance: the run's tool, parameters, seed and inputs with hashes
    const Provenance p =
        read_provenance(h5::Reader(tmp / "ga.h5.checkpoint.h5", kGaCheckpointFormat, 1));
    CHECK(p.tool == "cluster");
    CHECK(p.seed == 1);
    CHECK(p.parameters.at("ga-iterations") == "12");
    CHECK(p.parameters.at("method") == "ga");
    CHECK(p.command_line.find("--ga-iterations 12") != std::string::npos);
    std::map<std::string, std::string> hashes;
    for (const InputRef& i : p.inputs) hashes[i.role] = i.sha256;
    CHECK(hashes.size() == 3);
    for (const char* role : {"scene", "hitpoints", "distribution"}) CHECK(hashes[role].size() == 64);
  }
  // Resuming a finished run gives the same clusters.
  auto again = test::run_tool("cluster", GA + " -o " + (tmp / "ga2.h5") + " --resume --checkpoint " +
                                             (tmp / "ga.h5.checkpoint.h5"), tmp);
  REQUIRE(again.exit_code == 0);
  CHECK(same_clusters(load_clusters(tmp / "ga2.h5", h), load_clusters(tmp / "ga.h5", h)));

  // Bad input: one line, exit 2, no output.
  auto refuse = [&](const std::string& args, const std::string& what) {
    INFO(args);
    const size_t files = tmp.file_count();
    auto b = test::run_tool("cluster", args + " -o " + (tmp / "bad.h5"), tmp);
    CHECK(b.exit_code == kExitBadInput);
    CHECK_THAT(b.err, Catch::Contains(what));
    CHECK(std::count(b.err.begin(), b.err.end(), '\n') == 1);
    CHECK_FALSE(std::filesystem::exists(tmp / "bad.h5"));
    CHECK(tmp.file_count() == files);
  };
  // A distribution of another scene (made from the other scene's hitpoints).
  REQUIRE(test::run_tool("photon-distribution", " --scene " + (tmp / "other.h5") + " --hitpoints " +
                                                    (tmp / "hp-other.h5") + " -o " + (tmp / "do.h5") +
                                                    " --passes 1 --emit 2000", tmp).exit_code == 0);
  refuse(S + HP + " --method ga --distribution " + (tmp / "do.h5"), "different scene");
  // A distribution made for hitpoints with another R0 (other bins than the gather's).
  REQUIRE(test::run_tool("photon-distribution", S + " --hitpoints " + (tmp / "hp-r.h5") + " -o " +
                                                    (tmp / "dr.h5") + " --passes 1 --emit 2000", tmp).exit_code == 0);
  refuse(S + HP + " --method ga --distribution " + (tmp / "dr.h5"), "R0");
  // Hitpoints of another scene.
  refuse(S + " --hitpoints " + (tmp / "hp-other.h5") + " --method ga --distribution " + (tmp / "d.h5"),
         "different scene");
  // No distribution for a fitness that needs one; an unknown fitness; a file that is no map.
  refuse(S + HP + " --method ga", "--distribution");
  refuse(S + HP + " --method ga --fitness speed --distribution " + (tmp / "d.h5"), "--fitness");
  refuse(S + HP + " --method ga --distribution " + (tmp / "hp.h5"), "hp.h5");
  // The checkpoint of another run.
  refuse(GA + " --seed 2 --resume --checkpoint " + (tmp / "ga.h5.checkpoint.h5"), "checkpoint");
  // Resuming the 12-iteration run with --ga-iterations 5 (it once wrote iterations 5 with
  // generations 13).
  refuse(S + HP + " --method ga --wg-size 16 --population 6 --ga-iterations 5 --distribution " +
             (tmp / "d.h5") + " --resume --checkpoint " + (tmp / "ga.h5.checkpoint.h5"),
         "--ga-iterations 5");
  // photon-distribution: hitpoints of another scene.
  auto pd = test::run_tool("photon-distribution", S + " --hitpoints " + (tmp / "hp-other.h5") +
                                                       " -o " + (tmp / "bad.h5"), tmp);
  CHECK(pd.exit_code == kExitBadInput);
  CHECK_FALSE(std::filesystem::exists(tmp / "bad.h5"));

  // illuminate reads the GA clusters (OpenCL grid-kmeans).
  if (!cl_list_devices().empty()) {
    auto il = test::run_tool("illuminate", "--estimator ppm " + S + HP + " --photons " + (tmp / "ph.h5") + " -o " +
                                               (tmp / "state.h5") + " --device opencl --work-group 16 "
                                               "--method grid-kmeans --clusters " + (tmp / "ga.h5"), tmp);
    INFO(il.err);
    CHECK(il.exit_code == 0);
  }
}
