// bench_opencl — the thesis's Tables 7.1/7.2 (ch. 7.2) on this machine: the CPU backend against the
// OpenCL backend (PoCL on the CPU here, or a GPU driver), per block, median of --runs runs
// (docs/BENCHMARKS.md, "OpenCL backend").
//
//   bench_opencl [--scene scene.h5 | --dae data/cornell-box.dae] [--sizes 320x280,1920x1080]
//                [--photons 100000] [--runs 5] [--gather-runs 5] [--gather-sample 0]
//                [--cl-platform -1 --cl-device -1 --work-group 64]
//
// CPU and OpenCL runs of a block alternate (cpu, cl, cpu, cl, ...) so that other load on the
// machine hits both columns alike; the process runs with OMP_WAIT_POLICY=passive (it re-executes
// itself with it) so that spinning OpenMP workers do not steal the cores from PoCL's threads.
//
// Blocks (each the whole backend function: uploads, kernels, read-back and host compaction):
//   ray tracing            trace_hitpoints (eye pass, 1 spp, DirectMode::Photons)
//   photon tracing         trace_photons (pass 0, --photons emitted)
//   hitpoint illumination  CPU: ppm_pass with the grid gather (the CPU backend's default);
//                          OpenCL: ppm_pass, naive gather (every hitpoint loops over all photons,
//                          thesis Table 7.1's "Hitpoint Illumination"); both from the same fresh
//                          eye-pass state and pass-0 photons
//   synthesis              synthesize of the illuminated state
// The OpenCL column also gives the kernel-only time (enqueue to clFinish). Kernel build time is
// measured apart: once with an empty PoCL kernel cache (POCL_CACHE_DIR pointed at a fresh folder
// before the first OpenCL call) and once more from the cache.
//
// The naive gather is O(hitpoints × photons): at 1080p one run takes minutes on 2 CPU cores. With
// --gather-sample N > 1 (default: automatic, 1 at <= 320x280 and 16 above), the OpenCL gather runs
// on every N-th hitpoint only and the time is scaled by N (its cost per hitpoint does not depend on
// which hitpoints: each loops over all photons); the table marks such rows.
#include <omp.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cxxopts.hpp>
#include <filesystem>
#include <functional>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "photonflow/opencl/cl_backend.h"
#include "photonflow/stages/eye_pass.h"
#include "photonflow/stages/illuminate.h"
#include "photonflow/opencl/kernels_embedded.h"
#include "photonflow/stages/photon_pass.h"
#include "photonflow/geometry/scene.h"
#include "photonflow/geometry/scene_import.h"
#include "photonflow/stages/synthesize.h"
#include "bench_common.h"

namespace {

using pf::bench::make_scene;
using pf::bench::median;
using pf::bench::now;
using pf::bench::parse_size;
using pf::bench::parse_sizes;
using pf::bench::Size;

struct Timing {
  double wall_ms = 0, kernel_ms = 0;
};

// Median wall time (and median kernel time on `dev`) of `runs` calls; prep() untimed.
Timing time_ms(int runs, const std::function<void()>& f, pf::ClContext* dev = nullptr,
               const std::function<void()>& prep = {}) {
  std::vector<double> wall, kern;
  for (int r = 0; r < runs; ++r) {
    if (prep) prep();
    if (dev) dev->reset_kernel_seconds();
    double t0 = now();
    f();
    wall.push_back((now() - t0) * 1e3);
    if (dev) kern.push_back(dev->kernel_seconds() * 1e3);
  }
  return {median(wall), median(kern)};
}

// CPU and OpenCL runs interleaved (cpu, cl, cpu, cl, ...) so that load from other processes on
// the machine affects both columns alike; medians of each.
std::pair<Timing, Timing> pair_ms(int runs, const std::function<void()>& cpu,
                                  const std::function<void()>& cl, pf::ClContext* dev,
                                  const std::function<void()>& prep = {}) {
  std::vector<double> wc, wg, kg;
  for (int r = 0; r < runs; ++r) {
    Timing c = time_ms(1, cpu, nullptr, prep);
    Timing g = time_ms(1, cl, dev, prep);
    wc.push_back(c.wall_ms);
    wg.push_back(g.wall_ms);
    kg.push_back(g.kernel_ms);
  }
  return {Timing{median(wc), 0}, Timing{median(wg), median(kg)}};
}



pf::HitpointSet state_of(const pf::Scene& scene, pf::EyePassResult r) {
  return pf::make_hitpoint_set(std::move(r), pf::DirectMode::Photons, scene.scene_id);
}

}  // namespace

int main(int argc, char** argv) {
  pf::bench::reexec_with_passive_openmp(argv);
  cxxopts::Options o("bench_opencl", "CPU backend vs OpenCL backend per block (thesis Tables 7.1/7.2)");
  o.add_options()
    ("scene", "baked scene.h5 (camera resolution overridden per size); default: bake --dae",
     cxxopts::value<std::string>()->default_value(""))
    ("dae", "scene file baked in-process", cxxopts::value<std::string>()->default_value("data/cornell-box.dae"))
    ("sizes", "image sizes", cxxopts::value<std::string>()->default_value("320x280,1920x1080"))
    ("photons", "photons emitted per pass", cxxopts::value<uint32_t>()->default_value("100000"))
    ("runs", "runs per block (median)", cxxopts::value<int>()->default_value("5"))
    ("gather-runs", "runs of the naive OpenCL gather (median)", cxxopts::value<int>()->default_value("5"))
    ("gather-sample", "naive gather on every N-th hitpoint, time × N; 0 = automatic",
     cxxopts::value<int>()->default_value("0"))
    ("work-group", "work-group size", cxxopts::value<int>()->default_value("0"))
    ("h,help", "print this help");
  pf::bench::add_opencl_device_options(o);
  auto a = o.parse(argc, argv);
  if (a.count("help")) {
    std::cout << o.help() << "\n";
    return 0;
  }
  try {
    // Cold kernel build: an empty PoCL kernel cache, set before PoCL is first loaded.
    std::string cache = (std::filesystem::temp_directory_path() /
                         ("pf-bench-pocl-cache-" + std::to_string(getpid()))).string();
    std::filesystem::create_directories(cache);
    setenv("POCL_CACHE_DIR", cache.c_str(), 1);

    std::unique_ptr<pf::ClContext> dev = pf::bench::open_opencl_device(a, a["work-group"].as<int>(), "bench_opencl");
    dev->build_all();
    const double build_cold = dev->build_seconds();
    double build_warm = 0;
    {
      pf::ClContext again(dev->info(), a["work-group"].as<int>());
      again.build_all();
      build_warm = again.build_seconds();
    }
    std::filesystem::remove_all(cache);

    const int runs = a["runs"].as<int>(), gather_runs = a["gather-runs"].as<int>();
    const uint32_t photons = a["photons"].as<uint32_t>();
    const std::string scene_h5 = a["scene"].as<std::string>(), dae = a["dae"].as<std::string>();
    std::printf("# bench_opencl: %s, %u photons/pass, median of %d runs (naive gather: %d)\n",
                scene_h5.empty() ? dae.c_str() : scene_h5.c_str(), photons, runs, gather_runs);
    std::printf("# CPU backend: %d OpenMP threads; OpenCL: %s, work-group %d\n",
                omp_get_max_threads(), dev->name().c_str(), dev->work_group());
    std::printf("# kernel build (all %zu programs): %.2f s with an empty PoCL cache, %.3f s cached\n\n",
                pf::embedded_kernel_names().size(), build_cold, build_warm);

    for (Size sz : parse_sizes(a["sizes"].as<std::string>())) {
      pf::Scene scene = make_scene(scene_h5, dae, sz);
      pf::EyePassOptions eye;
      pf::PhotonPassOptions ph;
      ph.photons = photons;
      pf::PpmOptions ppm;
      pf::PpmOptions ppm_naive;  // the OpenCL column of Tables 7.1/7.2: the naive gather
      ppm_naive.method = pf::GatherMethod::Naive;

      // First calls, untimed in the table: the first enqueue of a kernel includes code generation
      // (PoCL generates the work-group function per local size; cached in its kernel cache).
      double t_first = now();
      pf::trace_hitpoints(scene, eye, *dev);
      const double first_rt = (now() - t_first) * 1e3;
      t_first = now();
      pf::trace_photons(scene, 0, ph, *dev);
      const double first_pt = (now() - t_first) * 1e3;

      auto [rt_cpu, rt_cl] = pair_ms(runs, [&] { pf::trace_hitpoints(scene, eye); },
                                     [&] { pf::trace_hitpoints(scene, eye, *dev); }, dev.get());
      auto [pt_cpu, pt_cl] = pair_ms(runs, [&] { pf::trace_photons(scene, 0, ph); },
                                     [&] { pf::trace_photons(scene, 0, ph, *dev); }, dev.get());

      const pf::HitpointSet fresh = state_of(scene, pf::trace_hitpoints(scene, eye));
      const std::vector<pf_photon> pass0 = pf::trace_photons(scene, 0, ph).photons;
      pf::HitpointSet work;
      Timing il_cpu = time_ms(runs, [&] { pf::ppm_pass(scene, work, pass0, photons, ppm); }, nullptr,
                              [&] { work = fresh; });
      int sample = a["gather-sample"].as<int>();
      if (sample <= 0) sample = size_t(sz.w) * size_t(sz.h) <= 320 * 280 ? 1 : 16;
      pf::HitpointSet fresh_sub = fresh;
      if (sample > 1) {
        fresh_sub.hitpoints.clear();
        for (size_t i = 0; i < fresh.hitpoints.size(); i += size_t(sample))
          fresh_sub.hitpoints.push_back(fresh.hitpoints[i]);
      }
      {  // first call of the gather kernels, on a few hitpoints
        pf::HitpointSet tiny = fresh;
        tiny.hitpoints.resize(std::min<size_t>(tiny.hitpoints.size(), 64));
        pf::ppm_pass(scene, tiny, pass0, photons, ppm_naive, *dev);
        pf::synthesize(tiny, *dev);
      }
      Timing il_cl;
      if (gather_runs > 0) il_cl = time_ms(gather_runs, [&] { pf::ppm_pass(scene, work, pass0, photons, ppm_naive, *dev); },
                             dev.get(), [&] { work = fresh_sub; });
      il_cl.wall_ms *= sample;
      il_cl.kernel_ms *= sample;

      pf::HitpointSet lit = fresh;
      pf::ppm_pass(scene, lit, pass0, photons, ppm);
      auto [sy_cpu, sy_cl] = pair_ms(runs, [&] { pf::synthesize(lit); },
                                     [&] { pf::synthesize(lit, *dev); }, dev.get());

      std::printf("## %dx%d: %zu hitpoints, %zu photons stored in pass 0\n\n", sz.w, sz.h,
                  fresh.hitpoints.size(), pass0.size());
      std::printf("First OpenCL calls (with code generation): ray tracing %s ms, photon tracing %s ms\n\n",
                  pf::bench::fmt_ms(first_rt).c_str(), pf::bench::fmt_ms(first_pt).c_str());
      std::printf("| block | CPU backend (ms) | OpenCL (ms) | OpenCL kernels only (ms) | OpenCL / CPU |\n");
      std::printf("|---|---:|---:|---:|---:|\n");
      auto row = [&](const char* name, Timing c, Timing g, const char* note) {
        std::printf("| %s%s | %s | %s | %s | %.2f |\n", name, note, pf::bench::fmt_ms(c.wall_ms).c_str(),
                    pf::bench::fmt_ms(g.wall_ms).c_str(), pf::bench::fmt_ms(g.kernel_ms).c_str(), g.wall_ms / c.wall_ms);
      };
      row("ray tracing", rt_cpu, rt_cl, "");
      row("photon tracing", pt_cpu, pt_cl, "");
      std::string note = " (CPU: grid; OpenCL: naive" +
                         (sample > 1 ? ", every " + std::to_string(sample) + "th hitpoint × " +
                                           std::to_string(sample)
                                     : std::string()) + ")";
      row("hitpoint illumination", il_cpu, il_cl, note.c_str());
      row("synthesis", sy_cpu, sy_cl, "");
      std::printf("\n");
      std::fflush(stdout);
    }
  } catch (const std::exception& e) {
    std::cerr << "bench_opencl: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
