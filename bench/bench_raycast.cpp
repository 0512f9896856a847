// bench_raycast — ray casting throughput (ropes, stack, brute force, Embree 3) and kd-tree build
// time / memory on procedural scenes. Prints markdown tables (docs/BENCHMARKS.md, "Ray casting
// and kd-tree build").
//
//   bench_raycast [--rays 200000] [--image 512] [--runs 5] [--mesh PATH] ...
//
// Ray sets: primary (a pinhole camera's), random (origins in the box, directions on the sphere),
// and bounce: from the hits of the random rays, back to the side they came from in uniform
// directions, offset as the renderer's tracers do (spawn_ray), like photon bounces; these carry
// their hit's leaf (Ray::leaf), and the row "from the origin's leaf" casts them with it (the
// renderer's default traversal), the other rows without it.
//
// Closest-hit rays per second are medians over --runs runs, each casting the same ray set through
// intersect_closest_batch (schedule(dynamic), results independent of the thread count); Embree
// casts the same rays with rtcIntersect1 (single rays) in an identical OpenMP loop.
#include <omp.h>

#include <algorithm>
#include <assimp/Importer.hpp>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <chrono>
#include <cstdio>
#include <cxxopts.hpp>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "photonflow/geometry/intersect_shared.h"
#include "photonflow/geometry/kdtree.h"
#include "photonflow/geometry/procedural.h"
#include "photonflow/geometry/raycast.h"
#include "photonflow/geometry/surface.h"

#ifdef PF_HAVE_EMBREE
#include <embree3/rtcore.h>
#endif

#include "bench_common.h"

namespace {

using pf::Vec3;

using pf::bench::median;
using pf::bench::now;

// A benchmark scene: triangles, baked acceleration data, and a pinhole camera.
struct BenchScene {
  std::string name;
  pf::Scene scene;
  Vec3 eye, look_at;
  float fov_y_deg = 60.f;
};

// Build parameters of the benchmark scenes (defaults unless overridden on the command line).
pf::KdBuildParams g_kd_params;

BenchScene make_scene(const std::string& name, std::vector<pf_triangle> tris, Vec3 eye,
                      Vec3 look_at) {
  BenchScene b;
  b.name = name;
  b.scene.triangles = std::move(tris);
  b.scene.compute_hh();
  b.scene.compute_bounds();
  b.scene.kd = pf::build_kdtree(b.scene.triangles, g_kd_params);
  b.eye = eye;
  b.look_at = look_at;
  return b;
}

// Triangles of a mesh file (all meshes, node transforms ignored), scaled and centred so that the
// longest extent is `size` and the centre is `center`. Empty if the file cannot be read.
std::vector<pf_triangle> load_mesh(const std::string& path, Vec3 center, float size) {
  Assimp::Importer importer;
  const aiScene* s = importer.ReadFile(path, aiProcess_Triangulate);
  std::vector<pf_triangle> tris;
  if (!s) return tris;
  pf::Bounds box;
  for (unsigned m = 0; m < s->mNumMeshes; ++m)
    for (unsigned v = 0; v < s->mMeshes[m]->mNumVertices; ++v) {
      const aiVector3D& p = s->mMeshes[m]->mVertices[v];
      box.extend(Vec3(p.x, p.y, p.z));
    }
  const Vec3 e = box.extent();
  const float scale = size / std::max({e.x, e.y, e.z});
  for (unsigned m = 0; m < s->mNumMeshes; ++m) {
    const aiMesh* mesh = s->mMeshes[m];
    for (unsigned f = 0; f < mesh->mNumFaces; ++f) {
      if (mesh->mFaces[f].mNumIndices != 3) continue;
      pf_triangle t{};
      float* v[3] = {t.v0, t.v1, t.v2};
      for (int c = 0; c < 3; ++c) {
        const aiVector3D& p = mesh->mVertices[mesh->mFaces[f].mIndices[c]];
        ((Vec3(p.x, p.y, p.z) - box.center()) * scale + center).store(v[c]);
      }
      const Vec3 n = pf::cross(Vec3(t.v1) - Vec3(t.v0), Vec3(t.v2) - Vec3(t.v0));
      if (!(pf::length(n) > 0.f)) continue;  // the kd-tree wants no degenerate triangles
      pf::normalize(n).store(t.n0);
      pf::normalize(n).store(t.n1);
      pf::normalize(n).store(t.n2);
      t.mesh = 1;
      t.material = 1;
      tris.push_back(t);
    }
  }
  return tris;
}

// Primary rays of a pinhole camera, one through each pixel centre of an image×image grid.
std::vector<pf::Ray> primary_rays(const BenchScene& b, int image) {
  const Vec3 fwd = pf::normalize(b.look_at - b.eye);
  const Vec3 right = pf::normalize(pf::cross(fwd, Vec3(0, 1, 0)));
  const Vec3 up = pf::cross(right, fwd);
  const float h = std::tan(0.5f * b.fov_y_deg * 3.14159265f / 180.f);
  std::vector<pf::Ray> rays;
  rays.reserve(size_t(image) * size_t(image));
  for (int y = 0; y < image; ++y)
    for (int x = 0; x < image; ++x) {
      const float sx = (2.f * (float(x) + 0.5f) / float(image) - 1.f) * h;
      const float sy = (1.f - 2.f * (float(y) + 0.5f) / float(image)) * h;
      pf::Ray r;
      r.o = b.eye;
      r.d = pf::normalize(fwd + right * sx + up * sy);
      rays.push_back(r);
    }
  return rays;
}

// xorshift64*: uniform floats in [0, 1) from a 64-bit state (the ray sets' own generator, so
// that they do not change with the renderer's streams).
struct XorShift {
  uint64_t s;
  float operator()() {
    s ^= s >> 12;
    s ^= s << 25;
    s ^= s >> 27;
    return float((s * 0x2545F4914F6CDD1Dull) >> 40) * (1.f / 16777216.f);
  }
  // A direction uniform on the sphere: z, then the azimuth.
  Vec3 direction() {
    const float z = 2.f * (*this)() - 1.f;
    const float phi = 6.2831853f * (*this)();
    const float q = std::sqrt(std::max(0.f, 1.f - z * z));
    return Vec3(q * std::cos(phi), q * std::sin(phi), z);
  }
};

// Rays with origins uniform in the scene box and directions uniform on the sphere.
std::vector<pf::Ray> random_rays(const BenchScene& b, size_t n, uint32_t seed) {
  XorShift uni{seed + 0x9E3779B97F4A7C15ull};
  const pf::Bounds& box = b.scene.bounds;
  std::vector<pf::Ray> rays(n);
  for (pf::Ray& r : rays) {
    const Vec3 e = box.extent();
    // One draw per statement (z, y, x, the order GCC gave these rays): argument order is
    // unspecified, and Clang made other rays from the same seed.
    const float oz = uni() * e.z, oy = uni() * e.y, ox = uni() * e.x;
    r.o = box.lo + Vec3(ox, oy, oz);
    r.d = uni.direction();
  }
  return rays;
}

// Bounce rays from the closest hits of `from` (see the top of this file).
std::vector<pf::Ray> bounce_rays(const BenchScene& b, const std::vector<pf::Ray>& from,
                                 uint32_t seed) {
  XorShift uni{seed + 0x9E3779B97F4A7C15ull};
  std::vector<pf::Hit> hits;
  pf::intersect_closest_batch(b.scene, from, hits);
  const float eps = pf::ray_epsilon(b.scene);
  std::vector<pf::Ray> rays;
  for (size_t i = 0; i < from.size(); ++i) {
    if (!hits[i].hit()) continue;
    const pf::SurfaceHit sh = pf::surface_at(b.scene, from[i], hits[i]);
    Vec3 d = uni.direction();
    if ((pf::dot(d, sh.ng) > 0.f) == (pf::dot(from[i].d, sh.ng) > 0.f)) d = -d;
    rays.push_back(pf::spawn_ray(sh, d, eps));
  }
  return rays;
}

#ifdef PF_HAVE_EMBREE
// The same triangles in an Embree 3 scene (default build quality).
class EmbreeScene {
 public:
  explicit EmbreeScene(const std::vector<pf_triangle>& tris) {
    device_ = rtcNewDevice(nullptr);
    scene_ = rtcNewScene(device_);
    RTCGeometry g = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_TRIANGLE);
    auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(
        g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), 3 * tris.size()));
    auto* idx = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
        g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), tris.size()));
    for (size_t i = 0; i < tris.size(); ++i) {
      std::copy(tris[i].v0, tris[i].v0 + 3, v + 9 * i);
      std::copy(tris[i].v1, tris[i].v1 + 3, v + 9 * i + 3);
      std::copy(tris[i].v2, tris[i].v2 + 3, v + 9 * i + 6);
      for (unsigned c = 0; c < 3; ++c) idx[3 * i + c] = unsigned(3 * i + c);
    }
    rtcCommitGeometry(g);
    rtcAttachGeometry(scene_, g);
    rtcReleaseGeometry(g);
    rtcCommitScene(scene_);
  }
  ~EmbreeScene() {
    rtcReleaseScene(scene_);
    rtcReleaseDevice(device_);
  }
  EmbreeScene(const EmbreeScene&) = delete;
  EmbreeScene& operator=(const EmbreeScene&) = delete;

  // Closest hits of all rays (triangle index or −1) with rtcIntersect1.
  void intersect(const std::vector<pf::Ray>& rays, std::vector<int32_t>& tri, int threads) const {
    tri.resize(rays.size());
    const int64_t n = int64_t(rays.size());
#pragma omp parallel for schedule(dynamic, 256) num_threads(threads)
    for (int64_t i = 0; i < n; ++i) {
      const pf::Ray& r = rays[size_t(i)];
      RTCIntersectContext ctx;
      rtcInitIntersectContext(&ctx);
      RTCRayHit rh;
      rh.ray.org_x = r.o.x;
      rh.ray.org_y = r.o.y;
      rh.ray.org_z = r.o.z;
      rh.ray.dir_x = r.d.x;
      rh.ray.dir_y = r.d.y;
      rh.ray.dir_z = r.d.z;
      rh.ray.tnear = r.tmin;
      rh.ray.tfar = r.tmax;
      rh.ray.time = 0.f;
      rh.ray.mask = ~0u;
      rh.ray.id = 0;
      rh.ray.flags = 0;
      rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
      rtcIntersect1(scene_, &ctx, &rh);
      tri[size_t(i)] = rh.hit.geomID == RTC_INVALID_GEOMETRY_ID ? -1 : int32_t(rh.hit.primID);
    }
  }

 private:
  RTCDevice device_;
  RTCScene scene_;
};
#endif


// Work per ray of the two kd traversals, counted by replicas of their loops (same decisions as
// pf_kd_traverse_ropes and the stack traversal of raycast.cpp): triangle tests, leaves visited
// (and how many of them were empty) and inner nodes stepped through.
struct WorkCount {
  double tests = 0, leaves = 0, inner = 0, empty = 0;
};

bool leaf_count(const pf::Scene& s, const pf_kd_node& n, const float* o, const float* d,
                float tmin, pf_ray_hit& hit, WorkCount& c) {
  c.leaves += 1;
  if (n.count == 0) c.empty += 1;
  bool found = false;
  for (int32_t i = n.first; i < n.first + n.count; ++i) {
    const int32_t tri = s.kd.leaf_tris[size_t(i)];
    float t, u, v;
    c.tests += 1;
    if (!pf_hh_intersect(&s.hh[size_t(tri)], o, d, tmin, hit.t, &t, &u, &v)) continue;
    if (t == hit.t && hit.tri >= 0 && tri > hit.tri) continue;
    hit = {t, tri, u, v};
    found = true;
  }
  return found;
}

void count_ropes(const pf::Scene& s, const pf::Ray& r, WorkCount& c) {
  const float o[3] = {r.o.x, r.o.y, r.o.z}, d[3] = {r.d.x, r.d.y, r.d.z};
  const auto& nodes = s.kd.nodes;
  pf_ray_hit hit{r.tmax, -1, 0, 0};
  float inv_d[3];
  int high[3];
  for (int k = 0; k < 3; ++k) {
    inv_d[k] = 1.f / d[k];
    high[k] = inv_d[k] > 0.f;
  }
  float t_entry, t_leave;
  if (!pf_kd_enter_root(nodes.data(), o, d, inv_d, r.tmin, hit.t, &t_entry, &t_leave)) return;
  int32_t node = 0;
  float tie = -1.f;
  for (size_t step = 0; step < nodes.size(); ++step) {
    const float p[3] = {o[0] + t_entry * d[0], o[1] + t_entry * d[1], o[2] + t_entry * d[2]};
    const pf_kd_node* n = &nodes[size_t(node)];
    while (n->axis != PF_KD_LEAF) {
      c.inner += 1;
      const int a = n->axis;
      const bool go_left = p[a] < n->split || (p[a] == n->split && d[a] * tie > 0.f);
      node = go_left ? n->left : n->right;
      n = &nodes[size_t(node)];
    }
    leaf_count(s, *n, o, d, r.tmin, hit, c);
    float t_exit = INFINITY;
    int face = -1;
    for (int k = 0; k < 3; ++k) {
      const float te = ((high[k] ? n->hi[k] : n->lo[k]) - o[k]) * inv_d[k];
      if (te < t_exit && d[k] != 0.f) t_exit = te, face = 2 * k + high[k];
    }
    if (face < 0 || hit.t < t_exit) break;
    node = n->ropes[face];
    if (node < 0) break;
    tie = 1.f;
    t_entry = std::max(t_exit, t_entry);
  }
}

void count_stack(const pf::Scene& s, const pf::Ray& r, WorkCount& c) {
  const float o[3] = {r.o.x, r.o.y, r.o.z}, d[3] = {r.d.x, r.d.y, r.d.z};
  const auto& nodes = s.kd.nodes;
  pf_ray_hit hit{r.tmax, -1, 0, 0};
  const float inv_d[3] = {1.f / d[0], 1.f / d[1], 1.f / d[2]};
  float t0, t1;
  if (!pf_kd_enter_root(nodes.data(), o, d, inv_d, r.tmin, hit.t, &t0, &t1)) return;
  struct Todo {
    int32_t node;
    float t0, t1;
  } stack[pf::kKdMaxDepth + 1];
  int top = 0;
  int32_t node = 0;
  for (;;) {
    if (hit.t < t0) break;
    const pf_kd_node& n = nodes[size_t(node)];
    if (n.axis != PF_KD_LEAF) {
      c.inner += 1;
      const int a = n.axis;
      const bool left_first = o[a] < n.split || (o[a] == n.split && d[a] <= 0.f);
      const int32_t near = left_first ? n.left : n.right, far = left_first ? n.right : n.left;
      const float tp = d[a] != 0.f ? (n.split - o[a]) * inv_d[a] : INFINITY;
      if (tp > t1 || tp <= 0.f) {
        node = near;
      } else if (tp < t0) {
        node = far;
      } else {
        stack[top++] = {far, tp, t1};
        node = near;
        t1 = tp;
      }
      continue;
    }
    leaf_count(s, n, o, d, r.tmin, hit, c);
    if (top == 0) break;
    --top;
    node = stack[top].node;
    t0 = stack[top].t0;
    t1 = stack[top].t1;
  }
}

// "tests / leaves / inner" per ray for one traversal.
std::string work_per_ray(const pf::Scene& s, const std::vector<pf::Ray>& rays, bool ropes) {
  WorkCount c;
  for (const pf::Ray& r : rays) (ropes ? count_ropes : count_stack)(s, r, c);
  const double n = double(rays.size());
  char buf[96];
  std::snprintf(buf, sizeof buf, "%.1f | %.2f | %.1f | %.2f", c.tests / n, c.leaves / n,
                c.inner / n, c.empty / n);
  return buf;
}

// Million rays per second: two decimals, or three significant digits below 1 (brute force).
std::string mrays(double rays, double seconds) {
  const double m = rays / seconds / 1e6;
  char buf[32];
  std::snprintf(buf, sizeof buf, m < 1.0 ? "%.3g" : "%.2f", m);
  return buf;
}

// One table row per traversal: million closest-hit rays per second for each thread count.
void bench_rays(const BenchScene& b, const std::string& ray_set, const std::vector<pf::Ray>& rays,
                size_t brute_rays, const std::vector<int>& threads, int runs,
                std::ostream& table) {
  // Every row but "from the origin's leaf" casts the rays without a start leaf.
  std::vector<pf::Ray> plain = rays;
  bool with_leaf = false;
  for (pf::Ray& r : plain) {
    with_leaf |= r.leaf >= 0;
    r.leaf = -1;
  }
  std::vector<pf::Hit> ref;
  pf::intersect_closest_batch(b.scene, plain, ref, pf::Traversal::Ropes);
  size_t hits = 0;
  for (const pf::Hit& h : ref) hits += h.hit() ? 1 : 0;
  auto row = [&](const std::string& method, const std::vector<pf::Ray>& rs, auto&& cast) {
    table << "| " << b.name << " | " << ray_set << " | " << method << " |";
    for (int t : threads) {
      std::vector<double> sec;
      for (int r = 0; r < runs; ++r) {
        const double t0 = now();
        cast(rs, t);
        sec.push_back(now() - t0);
      }
      table << " " << mrays(double(rs.size()), median(sec)) << " |";
    }
    table << "\n" << std::flush;
  };
  for (pf::Traversal tr : {pf::Traversal::Ropes, pf::Traversal::Stack}) {
    std::vector<pf::Hit> out;
    row(pf::traversal_name(tr), plain, [&](const std::vector<pf::Ray>& rs, int t) {
      pf::intersect_closest_batch(b.scene, rs, out, tr, t);
    });
  }
  if (with_leaf) {  // the renderer's default: ropes from the origin's leaf where it holds o
    std::vector<pf::Hit> out;
    row("ropes from the origin's leaf", rays, [&](const std::vector<pf::Ray>& rs, int t) {
      pf::intersect_closest_batch(b.scene, rs, out, pf::Traversal::Stack, t);
    });
  }
  if (pf::kd_leaf_avx_supported()) {  // the stack row above tests leaves with AVX; SSE beside it
    std::vector<pf::Hit> out;
    pf::set_kd_leaf_avx(false);
    row("stack, SSE leaf test", plain, [&](const std::vector<pf::Ray>& rs, int t) {
      pf::intersect_closest_batch(b.scene, rs, out, pf::Traversal::Stack, t);
    });
    pf::set_kd_leaf_avx(true);
  }
  const std::vector<pf::Ray> sub(plain.begin(),
                                 plain.begin() + std::min(brute_rays, plain.size()));
  std::vector<pf::Hit> out;
  row("brute (" + std::to_string(sub.size()) + " rays)", sub,
      [&](const std::vector<pf::Ray>& rs, int t) {
        pf::intersect_closest_batch(b.scene, rs, out, pf::Traversal::Brute, t);
      });
#ifdef PF_HAVE_EMBREE
  EmbreeScene embree(b.scene.triangles);
  std::vector<int32_t> etri;
  row("Embree 3 rtcIntersect1", plain, [&](const std::vector<pf::Ray>& rs, int t) {
    embree.intersect(rs, etri, t);
  });
  size_t differ = 0;
  for (size_t i = 0; i < rays.size(); ++i) differ += (etri[i] >= 0) != ref[i].hit() ? 1 : 0;
  std::cerr << b.name << " / " << ray_set << ": " << rays.size() << " rays, " << hits
            << " hits; hit/miss differs from Embree for " << differ << " rays\n";
#else
  table << "| " << b.name << " | " << ray_set << " | Embree 3 | not built (no embree) |\n";
#endif
}

}  // namespace

int main(int argc, char** argv) {
  cxxopts::Options opts("bench_raycast",
                        "Ray casting and kd-tree build benchmark; prints markdown tables.");
  // clang-format off
  opts.add_options()
    ("rays", "random rays per scene", cxxopts::value<size_t>()->default_value("200000"))
    ("image", "primary rays: image side in pixels (image² rays)",
     cxxopts::value<int>()->default_value("512"))
    ("brute-rays", "rays of the brute-force subsample",
     cxxopts::value<size_t>()->default_value("2000"))
    ("runs", "timed runs per measurement (the median is reported)",
     cxxopts::value<int>()->default_value("5"))
    ("threads", "thread counts to measure",
     cxxopts::value<std::vector<int>>()->default_value("1,2"))
    ("blob-triangles", "triangles of the blob scene (at least)",
     cxxopts::value<size_t>()->default_value("100000"))
    ("build-sizes", "blob triangle counts for the build-time table",
     cxxopts::value<std::vector<size_t>>()->default_value("10000,100000,1000000"))
    ("mesh", "optional mesh file (e.g. /work/shared/scenes/stanford-bunny.obj) placed in the room",
     cxxopts::value<std::string>()->default_value(""))
    ("cost-traversal", "kd build: C_ts (default: KdBuildParams)", cxxopts::value<float>())
    ("cost-intersect", "kd build: C_i (default: KdBuildParams)", cxxopts::value<float>())
    ("empty-bonus", "kd build: empty-space bonus (default: KdBuildParams)",
     cxxopts::value<float>())
    ("max-leaf-size", "kd build: never split this many triangles or fewer",
     cxxopts::value<int>())
    ("max-depth", "kd build: depth limit (0 = automatic)", cxxopts::value<int>())
    ("h,help", "print this help");
  // clang-format on
  const auto args = opts.parse(argc, argv);
  if (args.count("help")) {
    std::cout << opts.help() << "\n";
    return 0;
  }
  const size_t n_rays = args["rays"].as<size_t>();
  const int image = args["image"].as<int>();
  const size_t brute_rays = args["brute-rays"].as<size_t>();
  const int runs = std::max(1, args["runs"].as<int>());
  const auto threads = args["threads"].as<std::vector<int>>();
  const std::string mesh = args["mesh"].as<std::string>();
  if (args.count("cost-traversal")) g_kd_params.cost_traversal = args["cost-traversal"].as<float>();
  if (args.count("cost-intersect")) g_kd_params.cost_intersect = args["cost-intersect"].as<float>();
  if (args.count("empty-bonus")) g_kd_params.empty_bonus = args["empty-bonus"].as<float>();
  if (args.count("max-depth")) g_kd_params.max_depth = args["max-depth"].as<int>();
  if (args.count("max-leaf-size")) g_kd_params.max_leaf_size = args["max-leaf-size"].as<int>();

  std::vector<BenchScene> scenes;
  scenes.push_back(make_scene("Cornell room", pf::make_cornell_room(400), {0.5f, 0.5f, 0.99f},
                              {0.5f, 0.5f, 0.f}));
  {
    auto tris = pf::make_box({-2, -2, -2}, {2, 2, 2}, true, {0, 0});
    const auto blob = pf::make_blob({0, 0, 0}, 1.f, args["blob-triangles"].as<size_t>(), 0.3f, 3,
                                    {1, 1});
    tris.insert(tris.end(), blob.begin(), blob.end());
    scenes.push_back(make_scene("blob room", std::move(tris), {0, 0, 1.95f}, {0, 0, 0}));
  }
  if (!mesh.empty()) {
    auto tris = pf::make_box({-2, -2, -2}, {2, 2, 2}, true, {0, 0});
    const auto m = load_mesh(mesh, {0, 0, 0}, 2.5f);
    if (m.empty()) {
      std::cout << "Mesh " << mesh << " not found or unreadable: mesh scene skipped.\n\n";
    } else {
      tris.insert(tris.end(), m.begin(), m.end());
      const std::string name = mesh.substr(mesh.find_last_of('/') + 1) + " room";
      scenes.push_back(make_scene(name, std::move(tris), {0, 0, 1.95f}, {0, 0, 0}));
    }
  }

  std::ostringstream table, work;
  table << "### Closest-hit throughput (million rays/s, median of " << runs << " runs)\n\n"
        << "| scene | rays | method |";
  for (int t : threads) table << " " << t << (t == 1 ? " thread" : " threads") << " |";
  table << "\n|---|---|---|";
  for (size_t i = 0; i < threads.size(); ++i) table << "---:|";
  table << "\n";
  for (const BenchScene& b : scenes) {
    std::cerr << "rays: " << b.name << "\n";
    const auto primary = primary_rays(b, image);
    const auto random = random_rays(b, n_rays, 1);
    bench_rays(b, "primary " + std::to_string(image) + "²", primary, brute_rays, threads, runs,
               table);
    bench_rays(b, "random " + std::to_string(n_rays), random, brute_rays, threads, runs, table);
    const auto bounce = bounce_rays(b, random, 2);
    bench_rays(b, "bounce " + std::to_string(bounce.size()), bounce, brute_rays, threads, runs,
               table);
    for (bool ropes : {true, false}) {
      const char* tr = ropes ? "ropes" : "stack";
      work << "| " << b.name << " | primary " << image << "² | " << tr << " | "
           << work_per_ray(b.scene, primary, ropes) << " |\n";
      work << "| " << b.name << " | random " << n_rays << " | " << tr << " | "
           << work_per_ray(b.scene, random, ropes) << " |\n";
    }
  }
  table << "\n### Work per closest-hit ray\n\n"
        << "| scene | rays | traversal | triangle tests | leaves | inner-node steps |"
        << " empty leaves |\n"
        << "|---|---|---|---:|---:|---:|---:|\n"
        << work.str();

  table << "\n### Scenes and kd-trees\n\n"
        << "| scene | triangles | nodes | leaf refs | depth | tree memory (MiB) |"
        << " host copy (MiB) |\n"
        << "|---|---:|---:|---:|---:|---:|---:|\n";
  for (const BenchScene& b : scenes) {
    const pf::KdTree& kd = b.scene.kd;
    // raycast.cpp's host copy: 8-byte nodes, 208-byte packets of four triangles per leaf, and
    // one int per leaf reference (first packet of a leaf).
    size_t packets = 0;
    for (const pf_kd_node& n : kd.nodes)
      if (n.axis == PF_KD_LEAF) packets += size_t(n.count + 3) / 4;
    const double host = double(kd.nodes.size() * 8 + packets * 208 + kd.leaf_tris.size() * 4);
    char mem[32], hmem[32];
    std::snprintf(mem, sizeof mem, "%.2f", double(kd.memory_bytes()) / (1 << 20));
    std::snprintf(hmem, sizeof hmem, "%.2f", host / (1 << 20));
    table << "| " << b.name << " | " << b.scene.triangles.size() << " | " << kd.nodes.size()
          << " | " << kd.leaf_tris.size() << " | " << kd.depth << " | " << mem << " | " << hmem
          << " |\n";
  }

  table << "\n### kd-tree build (procedural blob; seconds, median of runs)\n\n"
        << "| triangles |";
  for (int t : threads) table << " " << t << (t == 1 ? " thread" : " threads") << " |";
  table << " nodes | leaf refs | tree memory (MiB) |\n|---:|";
  for (size_t i = 0; i < threads.size(); ++i) table << "---:|";
  table << "---:|---:|---:|\n";
  for (size_t n : args["build-sizes"].as<std::vector<size_t>>()) {
    if (n == 0) continue;  // --build-sizes 0: no build table
    std::cerr << "build: " << n << "\n";
    const auto tris = pf::make_blob({0, 0, 0}, 1.f, n, 0.3f, 3);
    table << "| " << tris.size() << " |";
    pf::KdTree tree;
    for (int t : threads) {
      pf::KdBuildParams p = g_kd_params;
      p.threads = t;
      std::vector<double> sec;
      for (int r = 0; r < (n >= 1000000 ? std::min(runs, 3) : runs); ++r) {
        tree = pf::build_kdtree(tris, p);
        sec.push_back(tree.build_seconds);
      }
      char buf[32];
      std::snprintf(buf, sizeof buf, "%.3f", median(sec));
      table << " " << buf << " |";
    }
    char mem[32];
    std::snprintf(mem, sizeof mem, "%.1f", double(tree.memory_bytes()) / (1 << 20));
    table << " " << tree.nodes.size() << " | " << tree.leaf_tris.size() << " | " << mem << " |\n";
  }
  std::cout << table.str();
  return 0;
}
