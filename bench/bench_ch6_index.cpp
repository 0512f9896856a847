// bench_ch6_index — the thesis's Table 6.1 on this machine: spatial indices for ray casting
// (brute force, an octree, the SAH kd-tree with ropes), index build time and the time of
// 100,000 closest-hit rays on a scene of about 12,000 triangles. Prints markdown tables
// (docs/results/ch6-index.md, pipelines/ch6.mk).
//
//   bench_ch6_index [--dae data/cornell-box.dae] [--meshes teapot.obj,spot.obj] [--rays 100000]
//                   [--runs 3] [--threads 1] [--octree-depth 8 --octree-leaf 8]
//
// Scene: the Cornell box with two real meshes standing on its floor (../shared/scenes/teapot.obj,
// 6,320 triangles, front left; spot.obj, 5,856, back right), baked in-process: 12,208 triangles,
// against the thesis's 12,140. Without those files a procedural blob of the same size
// (procedural.h) takes their place, and the table says so.
//
// Rays: "primary" = a pinhole camera's rays through a square grid of pixel centres (the scene's
// camera), "random" = origins uniform in the scene box, directions uniform on the sphere. The
// thesis cast 100,000 rays "pointing at the same place in the scene"; camera rays are the nearest
// ordinary equivalent.
//
// Every timed method casts the same rays; each time is the median of --runs runs, taken round
// robin over the methods, and each ratio the median of the ratios within a run. Brute force
// casts all the rays too (it is the reference), unless --brute-rays says fewer. Every method's
// closest hit is compared with brute force's on every ray brute force cast: a hit at another t
// is an error (exit code 1); another triangle at the same t (a point shared by two triangles)
// is counted and reported.
//
// kd-tree build = build_kdtree (SAH, ropes, split clipping) plus the host copy that the CPU
// traversals derive on first use (raycast.cpp), timed separately. The octree is bench/octree.h.
// A second table sweeps the octree's two parameters on the primary rays, so that the comparator
// is seen at its best settings and not only at the defaults.
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cxxopts.hpp>
#include <filesystem>
#include <functional>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "photonflow/geometry/camera.h"
#include "photonflow/geometry/kdtree.h"
#include "photonflow/geometry/procedural.h"
#include "photonflow/geometry/raycast.h"
#include "photonflow/geometry/scene_import.h"
#include "bench_common.h"
#include "ch6_common.h"
#include "octree.h"

namespace {

using pf::Vec3;
using pf::bench::median;
using pf::bench::now;

// Camera rays through the pixel centres of a square grid of ceil(sqrt(n))² pixels, row by row,
// the first n of them.
std::vector<pf::Ray> camera_rays(const pf::Scene& scene, size_t n) {
  pf_camera cam = scene.camera;
  const int side = int(std::ceil(std::sqrt(double(n))));
  cam.width = cam.height = side;
  const pf::CameraFrame frame(cam);
  std::vector<pf::Ray> rays(n);
  for (size_t i = 0; i < n; ++i) {
    rays[i].o = frame.eye();
    rays[i].d = frame.direction(float(i % size_t(side)) + 0.5f, float(i / size_t(side)) + 0.5f);
  }
  return rays;
}

// Origins uniform in the scene box, directions uniform on the sphere (xorshift64*).
std::vector<pf::Ray> random_rays(const pf::Scene& scene, size_t n, uint64_t seed) {
  uint64_t s = seed + 0x9E3779B97F4A7C15ull;
  auto uni = [&]() {
    s ^= s >> 12;
    s ^= s << 25;
    s ^= s >> 27;
    return float((s * 0x2545F4914F6CDD1Dull) >> 40) * (1.f / 16777216.f);
  };
  const Vec3 lo = scene.bounds.lo, e = scene.bounds.extent();
  std::vector<pf::Ray> rays(n);
  for (pf::Ray& r : rays) {
    // One draw per statement (z, y, x, the order GCC gave these rays): argument order is
    // unspecified, and Clang made other rays from the same seed.
    const float oz = uni() * e.z, oy = uni() * e.y, ox = uni() * e.x;
    r.o = lo + Vec3(ox, oy, oz);
    const float z = 2.f * uni() - 1.f, phi = 6.2831853f * uni();
    const float q = std::sqrt(std::max(0.f, 1.f - z * z));
    r.d = Vec3(q * std::cos(phi), q * std::sin(phi), z);
  }
  return rays;
}

void octree_batch(const pf::bench::Octree& oct, const std::vector<pf::Ray>& rays,
                  std::vector<pf::Hit>& hits, int threads) {
  hits.resize(rays.size());
  const int64_t n = int64_t(rays.size());
#pragma omp parallel for schedule(dynamic, 256) num_threads(threads)
  for (int64_t i = 0; i < n; ++i) oct.intersect(rays[size_t(i)], hits[size_t(i)]);
}

// Rays (among the first ref.size()) whose closest hit differs from the reference's: `wrong`
// at another distance (or a hit against a miss), `tie` at the same t on another triangle, where
// the hit point lies on both (an edge of one on the face of the other, e.g. where a block stands
// on the floor). Ties are resolved by triangle index only among the triangles a traversal
// visits; which of them it visits at a shared point is up to the index, so ties are no error.
struct Differences {
  size_t wrong = 0, tie = 0;
};
Differences differences(const std::vector<pf::Hit>& ref, const std::vector<pf::Hit>& hits) {
  Differences d;
  for (size_t i = 0; i < ref.size(); ++i)
    if (ref[i].tri != hits[i].tri) (ref[i].t == hits[i].t ? d.tie : d.wrong) += 1;
  return d;
}

std::string fmt(const char* f, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

// The benchmark scene: the Cornell box with the meshes inserted (front-left and back-right floor
// corners, clear of both blocks), or a procedural blob of `fallback_triangles` in their place.
pf::Scene make_scene(const std::string& dae, const std::vector<std::string>& meshes,
                     size_t fallback_triangles, std::string& note) {
  const Vec3 box_lo[2] = {{0.05f, 0.f, 0.6f}, {0.58f, 0.f, 0.05f}};
  const Vec3 box_hi[2] = {{0.42f, 0.4f, 0.97f}, {0.95f, 0.45f, 0.45f}};
  pf::BakeOptions bo;
  bo.input = dae;
  std::vector<std::string> paths;
  for (const std::string& m : meshes)
    if (std::filesystem::exists(m)) paths.push_back(m);
  const bool fallback = paths.size() != meshes.size() || paths.empty();
  if (fallback) {
    const std::string obj = (std::filesystem::temp_directory_path() /
                             ("pf-ch6-blob-" + std::to_string(::getpid()) + ".obj"))
                                .string();
    pf::write_obj(obj, pf::make_blob({0, 0, 0}, 1.f, fallback_triangles, 0.25f, 1));
    paths = {obj};
    note = "a procedural blob (make_blob, at least " + std::to_string(fallback_triangles) +
           " triangles) inserted: the mesh files were not found";
  } else {
    note = "inserted";
    for (const std::string& m : meshes) note += " " + std::filesystem::path(m).filename().string();
  }
  for (size_t k = 0; k < paths.size(); ++k) {
    pf::MeshInsert ins;
    ins.path = paths[k];
    ins.box_lo = box_lo[k % 2];
    ins.box_hi = box_hi[k % 2];
    bo.inserts.push_back(ins);
  }
  pf::BakeReport rep;
  pf::Scene scene = pf::bake_scene(bo, rep);
  if (fallback) std::filesystem::remove(paths[0]);
  return scene;
}

}  // namespace

int main(int argc, char** argv) {
  cxxopts::Options opts("bench_ch6_index",
                        "Thesis Table 6.1: brute force, octree and kd-tree with ropes; prints "
                        "markdown tables.");
  // clang-format off
  opts.add_options()
    ("dae", "scene file the meshes are inserted into",
     cxxopts::value<std::string>()->default_value("data/cornell-box.dae"))
    ("meshes", "mesh files inserted (comma-separated; a procedural blob if any is missing)",
     cxxopts::value<std::string>()->default_value(
         "../shared/scenes/teapot.obj,../shared/scenes/spot.obj"))
    ("fallback-triangles", "triangles of the procedural blob used without the mesh files",
     cxxopts::value<size_t>()->default_value("12176"))
    ("rays", "rays per ray set", cxxopts::value<size_t>()->default_value("100000"))
    ("brute-rays", "rays cast by brute force (0 = all)",
     cxxopts::value<size_t>()->default_value("0"))
    ("runs", "timed runs per measurement (median)", cxxopts::value<int>()->default_value("3"))
    ("threads", "threads of ray casting and of the kd-tree build",
     cxxopts::value<int>()->default_value("1"))
    ("octree-depth", "octree maximum depth", cxxopts::value<int>()->default_value("8"))
    ("octree-leaf", "octree: most triangles in a leaf", cxxopts::value<int>()->default_value("8"))
    ("sweep-depths", "octree depths of the parameter sweep (empty = no sweep)",
     cxxopts::value<std::string>()->default_value("6,8,10,12"))
    ("sweep-leaves", "octree leaf sizes of the parameter sweep",
     cxxopts::value<std::string>()->default_value("2,4,8,16"))
    ("h,help", "print this help");
  // clang-format on
  const auto args = opts.parse(argc, argv);
  if (args.count("help")) {
    std::cout << opts.help() << "\n";
    return 0;
  }
  const size_t n_rays = args["rays"].as<size_t>();
  const int runs = std::max(1, args["runs"].as<int>());
  const int threads = std::max(1, args["threads"].as<int>());
  size_t brute_rays = args["brute-rays"].as<size_t>();
  if (brute_rays == 0 || brute_rays > n_rays) brute_rays = n_rays;
  pf::bench::OctreeParams op;
  op.max_depth = args["octree-depth"].as<int>();
  op.max_leaf = args["octree-leaf"].as<int>();

  const double load_start = pf::bench::load_average();
  std::string note;
  const pf::Scene scene = make_scene(args["dae"].as<std::string>(),
                                     pf::bench::split_list(args["meshes"].as<std::string>()),
                                     args["fallback-triangles"].as<size_t>(), note);

  // Builds, each the median of --runs.
  std::vector<double> kd_build, kd_copy, oct_build;
  pf::KdBuildParams kp = scene.kd.params;
  kp.threads = threads;
  pf::Scene kd_scene = scene;  // the scene with the tree built here (same arrays as the bake's)
  for (int r = 0; r < runs; ++r) {
    kd_scene.kd = pf::build_kdtree(scene.triangles, kp);
    kd_build.push_back(kd_scene.kd.build_seconds);
    // The first traversal derives the host copy (compact nodes, packed planes); one ray that
    // misses everything times little else.
    pf::Ray miss;
    miss.o = scene.bounds.hi + Vec3(1, 1, 1);
    miss.d = Vec3(1, 1, 1);
    pf::Hit h;
    const double t0 = now();
    pf::intersect_closest(kd_scene, miss, h, pf::Traversal::Stack);
    pf::intersect_closest(kd_scene, miss, h, pf::Traversal::Ropes);
    kd_copy.push_back(now() - t0);
    oct_build.push_back(pf::bench::Octree(scene, op).build_seconds());
  }
  const pf::bench::Octree octree(scene, op);

  std::printf("## Table 6.1: spatial indices, %zu triangles, %zu rays per set, %d thread%s "
              "(median of %d runs)\n\n",
              scene.triangles.size(), n_rays, threads, threads == 1 ? "" : "s", runs);
  std::printf("Scene: %s with %s.\n\n", scene.source.c_str(), note.c_str());
  std::printf("| index | build (s) | nodes | leaves | triangle refs | depth | memory (MiB) |\n");
  std::printf("|---|---:|---:|---:|---:|---:|---:|\n");
  std::printf("| octree (depth ≤ %d, ≤ %d triangles per leaf) | %.4f | %zu | %zu | %zu | %d | "
              "%.2f |\n",
              op.max_depth, op.max_leaf, median(oct_build), octree.nodes(), octree.leaves(),
              octree.references(), octree.depth(), double(octree.memory_bytes()) / (1 << 20));
  size_t kd_leaves = 0;
  for (const pf_kd_node& n : kd_scene.kd.nodes) kd_leaves += n.axis == PF_KD_LEAF ? 1 : 0;
  std::printf("| kd-tree with ropes (SAH) | %.4f + %.4f host copy | %zu | %zu | %zu | %d | %.2f "
              "|\n\n",
              median(kd_build), median(kd_copy), kd_scene.kd.nodes.size(), kd_leaves,
              kd_scene.kd.leaf_tris.size(), kd_scene.kd.depth,
              double(kd_scene.kd.memory_bytes()) / (1 << 20));

  std::printf("| rays | method | time for the rays (s) | Mrays/s | speed-up over brute force | "
              "time ÷ kd ropes | other t than brute force | same t, other triangle |\n");
  std::printf("|---|---|---:|---:|---:|---:|---:|---:|\n");
  struct RaySet {
    std::string name;
    std::vector<pf::Ray> rays;
  };
  const RaySet sets[2] = {{"primary", camera_rays(scene, n_rays)},
                          {"random", random_rays(scene, n_rays, 1)}};
  bool all_agree = true;
  for (const RaySet& set : sets) {
    const std::vector<pf::Ray> sub(set.rays.begin(), set.rays.begin() + long(brute_rays));
    struct Method {
      std::string name;
      const std::vector<pf::Ray>& rays;
      std::function<void(const std::vector<pf::Ray>&, std::vector<pf::Hit>&)> cast;
      std::vector<pf::Hit> hits;
      std::vector<double> seconds;  // per run, scaled to all n_rays rays
    };
    auto kd = [&](pf::Traversal tr) {
      return [&, tr](const std::vector<pf::Ray>& rays, std::vector<pf::Hit>& hits) {
        pf::intersect_closest_batch(kd_scene, rays, hits, tr, threads);
      };
    };
    std::vector<Method> methods;
    methods.push_back({brute_rays == n_rays ? "brute force"
                                            : "brute force (" + std::to_string(brute_rays) +
                                                  " rays, time scaled)",
                       sub,
                       [&](const std::vector<pf::Ray>& rays, std::vector<pf::Hit>& hits) {
                         pf::intersect_closest_batch(scene, rays, hits, pf::Traversal::Brute,
                                                     threads);
                       },
                       {}, {}});
    methods.push_back({"octree", set.rays,
                       [&](const std::vector<pf::Ray>& rays, std::vector<pf::Hit>& hits) {
                         octree_batch(octree, rays, hits, threads);
                       },
                       {}, {}});
    methods.push_back({"kd-tree, ropes (stackless)", set.rays, kd(pf::Traversal::Ropes), {}, {}});
    methods.push_back({"kd-tree, stack", set.rays, kd(pf::Traversal::Stack), {}, {}});
    // Round robin over the methods, run by run, so that load from other processes falls on
    // every method of a run alike; the ratios below are medians of per-run ratios.
    for (int r = 0; r < runs; ++r)
      for (Method& m : methods) {
        const double t0 = now();
        m.cast(m.rays, m.hits);
        m.seconds.push_back((now() - t0) * double(n_rays) / double(m.rays.size()));
      }
    auto ratio = [&](const Method& a, const Method& b) {
      std::vector<double> q;
      for (int r = 0; r < runs; ++r) q.push_back(a.seconds[size_t(r)] / b.seconds[size_t(r)]);
      return median(q);
    };
    const Method& brute = methods[0];
    const Method& ropes = methods[2];
    for (const Method& m : methods) {
      const Differences d = differences(brute.hits, m.hits);
      all_agree = all_agree && d.wrong == 0;
      const double sec = median(m.seconds);
      std::printf("| %s %zu | %s | %s | %s | %s | %s | %zu | %zu |\n", set.name.c_str(), n_rays,
                  m.name.c_str(), fmt(sec < 1 ? "%.4f" : "%.2f", sec).c_str(),
                  fmt("%.3g", double(n_rays) / sec / 1e6).c_str(),
                  fmt("%.1f×", ratio(brute, m)).c_str(), fmt("%.2f×", ratio(m, ropes)).c_str(),
                  d.wrong, d.tie);
      std::fflush(stdout);
    }
  }

  const auto depths = pf::bench::parse_list<int>(args["sweep-depths"].as<std::string>());
  if (!depths.empty()) {
    std::printf("\n### Octree parameters (primary rays, %d thread%s, median of %d runs)\n\n",
                threads, threads == 1 ? "" : "s", runs);
    std::printf("| max depth | max triangles per leaf | build (s) | leaves | triangle refs | "
                "time for %zu rays (s) |\n|---:|---:|---:|---:|---:|---:|\n",
                n_rays);
    std::vector<pf::Hit> hits;
    for (int d : depths)
      for (int l : pf::bench::parse_list<int>(args["sweep-leaves"].as<std::string>())) {
        pf::bench::OctreeParams p;
        p.max_depth = d;
        p.max_leaf = l;
        const pf::bench::Octree o(scene, p);
        std::vector<double> t;
        for (int r = 0; r < runs; ++r) {
          const double t0 = now();
          octree_batch(o, sets[0].rays, hits, threads);
          t.push_back(now() - t0);
        }
        std::printf("| %d | %d | %.4f | %zu | %zu | %.4f |\n", p.max_depth, p.max_leaf,
                    o.build_seconds(), o.leaves(), o.references(), median(t));
        std::fflush(stdout);
      }
  }
  std::printf("\nLoad average (1 min) at start / end: %.2f / %.2f.\n", load_start,
              pf::bench::load_average());
  if (!all_agree) {
    std::fprintf(stderr, "bench_ch6_index: an index returned a closest hit at another distance "
                         "than brute force (table column 'other t than brute force')\n");
    return 1;
  }
  return 0;
}
