// bench_gather — the thesis's Tables 7.3, 7.4 and 7.5 (ch. 7.3) on this machine: every gather
// method of gather_method.h for one PPM pass, k-means against grid clusters, and hitpoint counts
// with fillers (docs/BENCHMARKS.md, "Accelerated gathers: thesis Tables 7.3, 7.4 and 7.5").
//
//   bench_gather [--dae data/cornell-box.dae | --scene scene.h5] [--sizes 320x280,1920x1080]
//                [--cluster-sizes 320x280,854x480,1280x720,1920x1080] [--photons 100000]
//                [--runs 5] [--methods all] [--sample 0] [--cl-platform -1 --cl-device -1]
//                [--work-group 64]
//
// Table 7.3: one PPM pass (eq. 3.14–3.18) from the fresh eye-pass state (R = R0, where hitpoints
// gather the most photons) over the pass-0 photons, median of --runs rounds (a round runs every
// method once, so drifting load from other processes hits all rows alike). "pass" is the wall time of
// ppm_pass (uploads, photon ordering, gather, eq. 3.14–3.18, read-back, host work such as the
// cluster-radius refresh); "kernels" the device time of its kernels (enqueue to clFinish). The
// CPU rows (grid, flann) run on all cores. Clusters are made once per size, as the cluster stage
// does, and not counted in the pass. Every method's result is checked against the CPU grid
// gather: the photon counts M of all hitpoints must agree ("same photons"). With hash-grid in the
// list, a row "hash-grid, state on device" times DevicePpmState::pass on a state already on the
// device (the render driver's and illuminate's steady state: the pass's photons go up, nothing
// comes down; the state is read back after the timing for the check), and a row "hash-grid, state
// and photons on device" the same pass over photons already in a device buffer, as
// trace_photons_device leaves them for the render driver (uploaded before the timing; the photons
// are the same, so is the check), with the render driver's waits: none per kernel (ClWaitScope),
// so the kernel clock sees only enqueues and the row has no kernel column. --hash-order lists who
// orders hash-grid's photons (hash_grid.h: auto, device, host); with more than one, each gets its
// three rows, named "(device order)" / "(host order)", in the same rounds.
//
// The methods that read every photon of a mesh (naive … kmeans-clusters) cost O(hitpoints ×
// photons): with --sample N > 1 (0 = automatic: 1 at <= 320×280, 16 above) they run on every N-th
// hitpoint and their times are multiplied by N (marked ×N); their cost per hitpoint does not depend
// on the other hitpoints. (The photon ordering inside the pass is multiplied too, a small overcount.)
//
// Table 7.4: creation time of k-means clusters (cluster_kmeans, 10 Lloyd steps) and grid clusters
// (cluster_grid, --max-bins 64), and the grid-kmeans / grid-gridclusters pass times.
// Table 7.5: hitpoints, and hitpoints with fillers for hitpoint sorting, k-means and grid clusters.
#include <omp.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <cxxopts.hpp>
#include <functional>
#include <iostream>
#include <map>
#include <string>
#include <vector>

#include "photonflow/opencl/cl_backend.h"
#include "photonflow/stages/clusters.h"
#include "photonflow/stages/eye_pass.h"
#include "photonflow/foundations/error.h"
#include "photonflow/stages/gather_method.h"
#include "photonflow/stages/hash_grid.h"
#include "photonflow/stages/illuminate.h"
#include "photonflow/stages/photon_pass.h"
#include "bench_common.h"

namespace {

using pf::bench::make_scene;
using pf::bench::median;
using pf::bench::now;
using pf::bench::parse_sizes;
using pf::bench::Size;

// The methods whose work-groups read all photons of a mesh (or all photons): their cost per
// hitpoint (per cluster, for kmeans-clusters, whose clusters of a sample are as many times fewer
// as they are wider) does not depend on the other hitpoints.
bool reads_whole_meshes(pf::GatherMethod m) {
  using M = pf::GatherMethod;
  return m == M::Naive || m == M::LocalMemory || m == M::PhotonSort || m == M::HitpointSort ||
         m == M::HitpointSortLocal || m == M::ManualDistance || m == M::KmeansClusters;
}

struct Row {
  double pass_ms = 0, kernel_ms = 0;
  int sample = 1;
  bool same = true;
};

}  // namespace

int main(int argc, char** argv) {
  pf::bench::reexec_with_passive_openmp(argv);
  cxxopts::Options o("bench_gather", "Gather methods per pass (thesis Tables 7.3-7.5)");
  o.add_options()
    ("scene", "baked scene.h5 (camera resolution overridden per size); default: bake --dae",
     cxxopts::value<std::string>()->default_value(""))
    ("dae", "scene file baked in-process", cxxopts::value<std::string>()->default_value("data/cornell-box.dae"))
    ("sizes", "image sizes of Table 7.3", cxxopts::value<std::string>()->default_value("320x280,1920x1080"))
    ("cluster-sizes", "image sizes of Tables 7.4 and 7.5",
     cxxopts::value<std::string>()->default_value("320x280,854x480,1280x720,1920x1080"))
    ("photons", "photons emitted per pass", cxxopts::value<uint32_t>()->default_value("100000"))
    ("runs", "runs per method (median)", cxxopts::value<int>()->default_value("5"))
    ("methods", "comma-separated methods, or all", cxxopts::value<std::string>()->default_value("all"))
    ("sample", "whole-mesh methods on every N-th hitpoint, time x N; 0 = automatic",
     cxxopts::value<int>()->default_value("0"))
    ("hash-cell", "hash-grid cell side in units of the largest radius",
     cxxopts::value<float>()->default_value("2"))
    ("hash-order", "hash-grid photon ordering: comma-separated auto, device, host",
     cxxopts::value<std::string>()->default_value("auto"))
    ("work-group", "work-group size (and cluster size)", cxxopts::value<int>()->default_value("0"))
    ("h,help", "print this help");
  pf::bench::add_opencl_device_options(o);
  auto a = o.parse(argc, argv);
  if (a.count("help")) {
    std::cout << o.help() << "\n";
    return 0;
  }
  try {
    std::unique_ptr<pf::ClContext> dev = pf::bench::open_opencl_device(a, a["work-group"].as<int>(), "bench_gather");
    dev->build_all();
    const int wg = dev->work_group();
    const int runs = a["runs"].as<int>();
    const uint32_t photons = a["photons"].as<uint32_t>();
    const std::string scene_h5 = a["scene"].as<std::string>(), dae = a["dae"].as<std::string>();

    std::vector<pf::GatherMethod> methods;
    {
      const std::string list = a["methods"].as<std::string>();
      if (list == "all") {
        for (const pf::GatherMethodInfo& i : pf::gather_methods()) methods.push_back(i.method);
      } else {
        for (const std::string& m : pf::bench::split_list(list))
          methods.push_back(pf::parse_gather_method(m));
      }
    }
    std::vector<pf::HashOrder> orders;
    for (const std::string& o : pf::bench::split_list(a["hash-order"].as<std::string>()))
      orders.push_back(pf::parse_hash_order(o));
    if (orders.empty()) throw pf::input_error("", "--hash-order lists no ordering");
    // The table's rows, in order: a label per method, two per hash-grid ordering.
    struct RowName {
      std::string label;
      pf::GatherMethod m;
      bool resident;
      pf::HashOrder order;
      bool photons_on_device = false;  // resident, and the photons already on the device
    };
    std::vector<RowName> row_names;
    for (pf::GatherMethod m : methods) {
      const std::string name = pf::gather_method_info(m).name;
      if (m != pf::GatherMethod::HashGrid) {
        row_names.push_back({name, m, false, pf::HashOrder::Auto});
        continue;
      }
      for (pf::HashOrder o : orders) {
        const std::string tag =
            orders.size() > 1 ? std::string(" (") + pf::hash_order_name(o) + " order)" : "";
        row_names.push_back({name + tag, m, false, o});
        row_names.push_back({name + ", state on device" + tag, m, true, o});
        row_names.push_back({name + ", state and photons on device" + tag, m, true, o, true});
      }
    }
    std::printf("# bench_gather: %s, %u photons/pass, median of %d runs\n",
                scene_h5.empty() ? dae.c_str() : scene_h5.c_str(), photons, runs);
    std::printf("# CPU rows: %d OpenMP threads; OpenCL: %s, work-group %d\n\n",
                omp_get_max_threads(), dev->name().c_str(), wg);

    // ---- Table 7.3 ----
    const std::vector<Size> sizes = parse_sizes(a["sizes"].as<std::string>());
    std::map<std::pair<std::string, int>, Row> table;  // (row label, size index)
    std::vector<size_t> hitpoints_of(sizes.size());
    for (size_t si = 0; si < sizes.size(); ++si) {
      const Size sz = sizes[si];
      pf::Scene scene = make_scene(scene_h5, dae, sz);
      pf::EyePassOptions eye;
      const pf::HitpointSet fresh = pf::make_hitpoint_set(pf::trace_hitpoints(scene, eye),
                                                          pf::DirectMode::Photons, scene.scene_id);
      hitpoints_of[si] = fresh.hitpoints.size();
      pf::PhotonPassOptions ph;
      ph.photons = photons;
      const pf::PhotonPassResult pass0 = pf::trace_photons(scene, 0, ph);
      pf::HitpointSet ref = fresh;
      pf::PpmOptions ref_opt;
      pf::ppm_pass(scene, ref, pass0.photons, pass0.emitted, ref_opt);
      int sample = a["sample"].as<int>();
      if (sample <= 0) sample = size_t(sz.w) * size_t(sz.h) <= 320 * 280 ? 1 : 16;
      std::fprintf(stderr, "bench_gather: %dx%d, %zu hitpoints, %zu photons stored\n", sz.w, sz.h,
                   fresh.hitpoints.size(), pass0.photons.size());
      // The pass's photons in a device buffer, as trace_photons_device leaves them (the rows
      // "state and photons on device"; nothing else writes this scratch buffer), uploaded a few
      // times first to report what one upload costs (a blocking write from pageable memory): the
      // part of a "state on device" pass that no kernel shows.
      pf::DevicePhotons on_device;
      {
        const size_t bytes = pass0.photons.size() * sizeof(pf_photon);
        on_device.photons = &dev->scratch("bench.photons", std::max<size_t>(bytes, 4));
        on_device.count = pass0.photons.size();
        on_device.emitted = pass0.emitted;
        std::vector<double> t;
        for (int r = 0; r < std::max(runs, 3); ++r) {
          const double t0 = now();
          dev->write(*on_device.photons, bytes, pass0.photons.data());
          t.push_back(now() - t0);
        }
        std::fprintf(stderr, "  photon upload: %.3f ms for %.1f MB (%.1f GB/s), median of %zu\n",
                     median(t) * 1e3, bytes / 1e6, bytes / median(t) / 1e9, t.size());
      }
      // Per method: its start state (a sample for the whole-mesh methods), clusters, and one
      // untimed call (PoCL generates code per kernel and local size at the first enqueue).
      struct Run {
        RowName name;
        pf::GatherMethod m;
        Row row;
        pf::HitpointSet start, work;
        std::vector<size_t> index;  // hitpoints of the sample, as indices into fresh
        pf::PpmOptions opt;
        pf::ClusterSet clusters;
        bool resident = false;  // hash-grid with the state kept on the device (DevicePpmState)
        std::vector<double> wall, kern, order_ms, gather_ms;
      };
      std::vector<Run> set(row_names.size());
      for (size_t k = 0; k < set.size(); ++k) {
        Run& u = set[k];
        u.name = row_names[k];
        u.m = u.name.m;
        u.resident = u.name.resident;
        const pf::GatherMethodInfo& info = pf::gather_method_info(u.m);
        u.row.sample = info.device && reads_whole_meshes(u.m) ? sample : 1;
        u.start = fresh;
        for (size_t i = 0; i < fresh.hitpoints.size(); i += size_t(u.row.sample)) u.index.push_back(i);
        if (u.row.sample > 1) {
          u.start.hitpoints.clear();
          for (size_t i : u.index) u.start.hitpoints.push_back(fresh.hitpoints[i]);
        }
        u.opt.method = u.m;
        u.opt.hash_cell = a["hash-cell"].as<float>();
        u.opt.hash_order = u.name.order;
        if (info.clusters) {
          u.clusters = pf::clusters_for_method(u.m, u.start, wg, u.opt);
          u.opt.clusters = &u.clusters;
        }
        u.work = u.start;
        if (info.device) pf::ppm_pass(scene, u.work, pass0.photons, pass0.emitted, u.opt, *dev);
      }
      // Rounds over all methods (each round runs every method once), so that load from other
      // processes drifting over time affects every row alike; medians per method.
      for (int r = 0; r < runs; ++r) {
        for (Run& u : set) {
          const bool device = pf::gather_method_info(u.m).device;
          u.work = u.start;
          dev->reset_kernel_seconds();
          const double t0 = now();
          if (u.resident) {  // the render driver's steady state: photons up, nothing down
            pf::DevicePpmState st(scene, u.work, *dev);
            st.upload();
            dev->reset_kernel_seconds();
            const pf::ClWaitScope wait(*dev, !u.name.photons_on_device);
            const double t1 = now();
            const pf::GatherTimes t = u.name.photons_on_device
                                          ? st.pass(on_device, u.opt)
                                          : st.pass(pass0.photons, pass0.emitted, u.opt);
            const double ms = (now() - t1) * 1e3;
            st.sync();
            u.order_ms.push_back(t.order * 1e3);
            u.gather_ms.push_back(t.gather * 1e3);
            u.wall.push_back(ms);
            u.kern.push_back(dev->kernel_seconds() * 1e3);
            continue;
          }
          if (device) {
            const pf::GatherTimes t = pf::ppm_pass(scene, u.work, pass0.photons, pass0.emitted, u.opt, *dev);
            u.order_ms.push_back(t.order * 1e3);  // the photons, not the hitpoints: not scaled
            u.gather_ms.push_back(t.gather * 1e3 * u.row.sample);
          } else {
            pf::ppm_pass(scene, u.work, pass0.photons, pass0.emitted, u.opt);
          }
          u.wall.push_back((now() - t0) * 1e3 * u.row.sample);
          u.kern.push_back(dev->kernel_seconds() * 1e3 * u.row.sample);
        }
        std::fprintf(stderr, "  round %d of %d done\n", r + 1, runs);
      }
      for (Run& u : set) {
        const pf::GatherMethodInfo& info = pf::gather_method_info(u.m);
        u.row.pass_ms = median(u.wall);
        // Without per-kernel waits the kernel clock only saw enqueues: no kernel column.
        u.row.kernel_ms = info.device && !u.name.photons_on_device ? median(u.kern) : 0;
        for (size_t k = 0; k < u.index.size(); ++k)
          u.row.same &= u.work.hitpoints[k].n_photons == ref.hitpoints[u.index[k]].n_photons;
        table[{u.name.label, int(si)}] = u.row;
        const std::string split = u.name.photons_on_device
                                      ? "no per-kernel waits"
                                      : "ordering " + pf::bench::fmt_ms(median(u.order_ms)) +
                                            ", gather " + pf::bench::fmt_ms(median(u.gather_ms));
        std::fprintf(stderr, "  %-44s %10s ms (%s)%s\n", u.name.label.c_str(),
                     pf::bench::fmt_ms(u.row.pass_ms).c_str(), split.c_str(),
                     u.row.same ? "" : "  (DIFFERENT PHOTONS)");
      }
    }
    std::printf("## Table 7.3: one PPM pass per method (ms; %u photons)\n\n", photons);
    std::printf("| method | backend |");
    for (const Size& s : sizes) std::printf(" %dx%d pass | kernels | × naive |", s.w, s.h);
    std::printf(" same photons |\n|---|---|");
    for (size_t i = 0; i < sizes.size(); ++i) std::printf("---:|---:|---:|");
    std::printf("---|\n");
    for (const RowName& row : row_names) {
      const pf::GatherMethodInfo& info = pf::gather_method_info(row.m);
      std::printf("| %s | %s |", row.label.c_str(), info.device ? "OpenCL" : "CPU");
      bool same = true;
      for (size_t si = 0; si < sizes.size(); ++si) {
        const Row& r = table[{row.label, int(si)}];
        auto naive = table.find({std::string(pf::gather_method_name(pf::GatherMethod::Naive)), int(si)});
        std::string speed = naive != table.end() && r.pass_ms > 0
                                ? pf::bench::fmt_ms(naive->second.pass_ms / r.pass_ms) : "—";
        std::string mark = r.sample > 1 ? " (×" + std::to_string(r.sample) + ")" : "";
        std::printf(" %s%s | %s | %s |", pf::bench::fmt_ms(r.pass_ms).c_str(), mark.c_str(),
                    info.device && r.kernel_ms > 0 ? pf::bench::fmt_ms(r.kernel_ms).c_str() : "—",
                    speed.c_str());
        same &= r.same;
      }
      std::printf(" %s |\n", same ? "yes" : "NO");
    }
    std::printf("\nhitpoints:");
    for (size_t si = 0; si < sizes.size(); ++si)
      std::printf(" %dx%d %zu;", sizes[si].w, sizes[si].h, hitpoints_of[si]);
    std::printf("\n\n");

    // ---- Tables 7.4 and 7.5 ----
    const std::vector<Size> csizes = parse_sizes(a["cluster-sizes"].as<std::string>());
    std::printf("## Table 7.4: k-means vs grid clusters (work-group %d)\n\n", wg);
    std::printf("| size | k-means creation (s) | grid creation (s) | grid-kmeans pass (ms) | "
                "grid-gridclusters pass (ms) |\n|---|---:|---:|---:|---:|\n");
    std::string t75 = "| size | hitpoints | hitpoint sort | k-means | grid clusters |\n"
                      "|---|---:|---:|---:|---:|\n";
    for (const Size& sz : csizes) {
      pf::Scene scene = make_scene(scene_h5, dae, sz);
      pf::EyePassOptions eye;
      const pf::HitpointSet fresh = pf::make_hitpoint_set(pf::trace_hitpoints(scene, eye),
                                                          pf::DirectMode::Photons, scene.scene_id);
      pf::PhotonPassOptions ph;
      ph.photons = photons;
      const pf::PhotonPassResult pass0 = pf::trace_photons(scene, 0, ph);
      pf::PpmOptions opt;
      std::vector<double> tk, tg;
      pf::ClusterSet km, gr;
      for (int r = 0; r < runs; ++r) {
        double t0 = now();
        km = pf::cluster_kmeans(fresh, wg, opt.cluster_iterations, 1);
        tk.push_back(now() - t0);
        t0 = now();
        gr = pf::cluster_grid(fresh, wg, 0);  // automatic bins, as the cluster stage
        tg.push_back(now() - t0);
      }
      auto pass_ms = [&](pf::GatherMethod m, pf::ClusterSet& c) {
        pf::PpmOptions po;
        po.method = m;
        po.clusters = &c;
        pf::HitpointSet w = fresh;
        pf::ppm_pass(scene, w, pass0.photons, pass0.emitted, po, *dev);  // untimed first call
        std::vector<double> t;
        for (int r = 0; r < runs; ++r) {
          w = fresh;
          const double t0 = now();
          pf::ppm_pass(scene, w, pass0.photons, pass0.emitted, po, *dev);
          t.push_back((now() - t0) * 1e3);
        }
        return median(t);
      };
      const double gk = pass_ms(pf::GatherMethod::GridKmeans, km);
      const double gg = pass_ms(pf::GatherMethod::GridGridClusters, gr);
      std::printf("| %dx%d | %.3f | %.3f | %s | %s |\n", sz.w, sz.h, median(tk), median(tg),
                  pf::bench::fmt_ms(gk).c_str(), pf::bench::fmt_ms(gg).c_str());
      char line[256];
      std::snprintf(line, sizeof line, "| %dx%d | %zu | %zu | %zu | %zu |\n", sz.w, sz.h,
                    fresh.hitpoints.size(), pf::mesh_sorted_order(fresh, wg).size(),
                    pf::stats(km).hitpoints_with_fillers, pf::stats(gr).hitpoints_with_fillers);
      t75 += line;
      std::fflush(stdout);
    }
    std::printf("\n## Table 7.5: hitpoints with fillers (work-group %d)\n\n%s", wg, t75.c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_gather: %s\n", e.what());
    return 1;
  }
  return 0;
}
