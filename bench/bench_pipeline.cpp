// bench_pipeline — per-stage times of the CPU progressive-photon-mapping pipeline, the
// CPU column of the thesis's Tables 7.1/7.2, plus PPM throughput and peak memory. Prints markdown
// tables (docs/BENCHMARKS.md, "CPU pipeline").
//
//   bench_pipeline [--scene scene.h5 | --dae data/cornell-box.dae] [--runs 5] [--threads 1,2]
//                  [--sizes 320x280,1920x1080] [--photons 100000]
//                  [--ppm-size 512 --ppm-photons 262144 --ppm-passes 10]
//   bench_pipeline --memory-passes 1000 [--memory-size 320x280 --memory-photons 100000]
//
// Stage mode (default). For every image size and thread count, each stage is run --runs times and
// the median wall time is printed:
//   ray tracing         trace_hitpoints (eye pass, DirectMode::Photons, 1 spp)
//   photon tracing      trace_photons (pass 0, --photons emitted; photons returned in one array)
//   grid build          build_photon_grid_into over pass 0's photons (part of "grid gather")
//   grid gather         ppm_pass(GatherMethod::Grid): grid build + eq. 3.14–3.18 for every hitpoint
//   FLANN gather        ppm_pass(GatherMethod::Flann): kd-tree build + the same update
//   synthesis           synthesize (eq. 3.19 into the frame buffer)
//   PPM pass            what ProgressiveRenderer::run_iteration does (trace_photons_into, grid
//                       built from the photon chunks, ppm_pass_grid), buffers warm as in every
//                       pass of a run but the first
//   first pass          run_iteration of a newly made renderer (buffers allocated on the way)
// Each measurement is the median of --runs timed calls after one untimed warm-up call.
// Every gather run starts from the same fresh eye-pass state (R = R0, the first pass, where each
// hitpoint gathers the most photons), so the runs are identical work; the grid and FLANN results
// are checked to be bit-identical.
// Then PPM passes per second at --ppm-size² with --ppm-photons per pass: --runs runs of
// --ppm-passes consecutive passes of one renderer from a fresh eye-pass state (the eye pass is not
// timed; the first, cold pass is), median.
//
// Memory mode (--memory-passes N): one ProgressiveRenderer, N passes, then prints VmHWM (peak
// resident set) both for the whole process and since the renderer was created (the kernel's peak
// counter is reset through /proc/self/clear_refs after the scene is baked, so the bake's own peak
// does not hide what the passes use). Run it as separate processes, e.g. N = 10 and N = 1000.
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <cxxopts.hpp>
#include <fstream>
#include <functional>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "photonflow/stages/eye_pass.h"
#include "photonflow/stages/illuminate.h"
#include "photonflow/stages/photon_grid.h"
#include "photonflow/stages/photon_pass.h"
#include "photonflow/estimators/render_driver.h"
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

// Median wall time in ms of `runs` calls of f, after one untimed warm-up call (first-touch page
// faults, the allocator's first growth, lazily built caches); prep() runs untimed before each.
double time_ms(int runs, const std::function<void()>& f, const std::function<void()>& prep = {}) {
  if (prep) prep();
  f();
  std::vector<double> t;
  for (int r = 0; r < runs; ++r) {
    if (prep) prep();
    double t0 = now();
    f();
    t.push_back((now() - t0) * 1e3);
  }
  return median(t);
}

// A field of /proc/self/status in kB (VmHWM, VmRSS), -1 if missing.
long status_kb(const char* field) {
  std::ifstream in("/proc/self/status");
  std::string line;
  size_t n = std::strlen(field);
  while (std::getline(in, line))
    if (line.compare(0, n, field) == 0 && line.size() > n && line[n] == ':')
      return std::atol(line.c_str() + n + 1);
  return -1;
}

// Resets the kernel's peak-RSS counter (VmHWM) to the current RSS (Linux >= 4.0).
bool reset_peak() {
  std::ofstream out("/proc/self/clear_refs");
  out << "5";
  out.flush();
  return bool(out);
}

pf::HitpointSet fresh_state(const pf::Scene& scene, const pf::EyePassOptions& eye) {
  return pf::make_hitpoint_set(pf::trace_hitpoints(scene, eye), eye.direct, scene.scene_id);
}

std::string fmt(double ms) {
  char buf[64];
  if (ms >= 100)
    std::snprintf(buf, sizeof buf, "%.0f", ms);
  else if (ms >= 10)
    std::snprintf(buf, sizeof buf, "%.1f", ms);
  else
    std::snprintf(buf, sizeof buf, "%.2f", ms);
  return buf;
}

int memory_mode(const std::string& scene_h5, const std::string& dae, Size sz, int passes,
                uint32_t photons, int threads) {
  pf::Scene scene = make_scene(scene_h5, dae, sz);
  long hwm_setup = status_kb("VmHWM");
  bool reset = reset_peak();
  pf::RenderOptions ro;
  ro.photons.photons = photons;
  ro.eye.threads = ro.photons.threads = ro.ppm.threads = threads;
  ro.passes = passes;
  double t0 = now();
  pf::ProgressiveRenderer r(scene, ro);
  long rss_after_eye = status_kb("VmRSS");
  long hwm_at10 = -1;
  while (r.passes_done() < passes) {
    r.run_iteration();
    if (r.passes_done() == std::min(10, passes)) hwm_at10 = status_kb("VmHWM");
  }
  double secs = now() - t0;
  long hwm = status_kb("VmHWM");
  long rss = status_kb("VmRSS");
  std::printf("| passes | size | photons/pass | threads | peak since render start (VmHWM, MiB) "
              "| peak at pass 10 (MiB) | RSS after eye pass (MiB) | RSS at end (MiB) "
              "| process peak incl. scene setup (MiB) | wall (s) |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|\n");
  std::printf("| %d | %dx%d | %u | %d | %.1f%s | %.1f | %.1f | %.1f | %.1f | %.1f |\n", passes,
              sz.w, sz.h, photons, threads > 0 ? threads : omp_get_max_threads(), hwm / 1024.0,
              reset ? "" : " (reset failed: includes setup)", hwm_at10 / 1024.0,
              rss_after_eye / 1024.0, rss / 1024.0, std::max(hwm, hwm_setup) / 1024.0, secs);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  cxxopts::Options options("bench_pipeline", "CPU PPM pipeline benchmark (issue 3)");
  // clang-format off
  options.add_options()
    ("scene", "baked scene.h5 (camera resolution overridden per size); default: bake --dae",
     cxxopts::value<std::string>()->default_value(""))
    ("dae", "scene file baked in-process", cxxopts::value<std::string>()->default_value("data/cornell-box.dae"))
    ("runs", "runs per measurement (median)", cxxopts::value<int>()->default_value("5"))
    ("threads", "thread counts, comma-separated", cxxopts::value<std::string>()->default_value("1,2"))
    ("sizes", "image sizes of the stage table", cxxopts::value<std::string>()->default_value("320x280,1920x1080"))
    ("photons", "photons per pass of the stage table", cxxopts::value<uint32_t>()->default_value("100000"))
    ("no-flann", "skip the FLANN gather")
    ("ppm-size", "square image size of the passes/s measurement (0 = skip)", cxxopts::value<int>()->default_value("512"))
    ("ppm-photons", "photons per pass of the passes/s measurement", cxxopts::value<uint32_t>()->default_value("262144"))
    ("ppm-passes", "consecutive passes per passes/s run", cxxopts::value<int>()->default_value("20"))
    ("memory-passes", "memory mode: run this many passes and print peak memory", cxxopts::value<int>()->default_value("0"))
    ("memory-size", "image size of memory mode", cxxopts::value<std::string>()->default_value("320x280"))
    ("memory-photons", "photons per pass of memory mode", cxxopts::value<uint32_t>()->default_value("100000"))
    ("memory-threads", "threads of memory mode (0 = all)", cxxopts::value<int>()->default_value("0"))
    ("h,help", "print this help");
  // clang-format on
  auto a = options.parse(argc, argv);
  if (a.count("help")) {
    std::cout << options.help() << "\n";
    return 0;
  }
  const std::string scene_h5 = a["scene"].as<std::string>();
  const std::string dae = a["dae"].as<std::string>();
  const int runs = std::max(1, a["runs"].as<int>());

  if (a["memory-passes"].as<int>() > 0)
    return memory_mode(scene_h5, dae, parse_size(a["memory-size"].as<std::string>()),
                       a["memory-passes"].as<int>(), a["memory-photons"].as<uint32_t>(),
                       a["memory-threads"].as<int>());

  std::vector<int> threads;
  for (auto& t : pf::bench::split_list(a["threads"].as<std::string>())) threads.push_back(std::stoi(t));
  const uint32_t photons = a["photons"].as<uint32_t>();
  const bool flann = !a.count("no-flann");

  std::printf("## Stage times (median of %d runs, ms), %u photons per pass, scene %s\n\n", runs,
              photons, scene_h5.empty() ? dae.c_str() : scene_h5.c_str());
  std::printf("| size | threads | hitpoints | photons stored | ray tracing | photon tracing "
              "| grid build | grid gather (incl. build) | FLANN gather (incl. build) "
              "| synthesis | PPM pass (trace + grid + gather) | first pass of a new renderer |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (auto& s : pf::bench::split_list(a["sizes"].as<std::string>())) {
    Size sz = parse_size(s);
    pf::Scene scene = make_scene(scene_h5, dae, sz);
    for (int t : threads) {
      pf::EyePassOptions eye;
      eye.threads = t;
      pf::PhotonPassOptions po;
      po.photons = photons;
      po.threads = t;
      pf::PpmOptions grid_opt, flann_opt;
      grid_opt.threads = flann_opt.threads = t;
      flann_opt.method = pf::GatherMethod::Flann;

      pf::HitpointSet fresh;
      double t_eye = time_ms(runs, [&] { fresh = fresh_state(scene, eye); });
      pf::PhotonPassResult pass;
      double t_photons = time_ms(runs, [&] { pass = pf::trace_photons(scene, 0, po); });
      pf::PhotonGridParams gp;
      gp.max_bins = grid_opt.max_bins;
      gp.default_radius = fresh.radius0;
      const int meshes = int(scene.mesh_names.size());
      pf::PhotonGrid build_grid;
      double t_build = time_ms(runs, [&] {
        pf::build_photon_grid_into(build_grid, pass.photons, meshes, gp, t);
        if (build_grid.photons.size() != pass.photons.size()) std::abort();
      });
      pf::HitpointSet h;
      auto reset = [&] { h = fresh; };
      double t_grid = time_ms(
          runs, [&] { pf::ppm_pass(scene, h, pass.photons, pass.emitted, grid_opt); }, reset);
      pf::HitpointSet grid_state = h;
      double t_flann = -1;
      if (flann) {
        t_flann = time_ms(
            runs, [&] { pf::ppm_pass(scene, h, pass.photons, pass.emitted, flann_opt); }, reset);
        if (std::memcmp(h.hitpoints.data(), grid_state.hitpoints.data(),
                        h.hitpoints.size() * sizeof(pf_hitpoint)) != 0) {
          std::fprintf(stderr, "grid and FLANN gathers differ\n");
          return 1;
        }
      }
      double t_synth = time_ms(runs, [&] {
        pf::Image img = pf::synthesize(grid_state);
        if (img.rgb.empty()) std::abort();
      });
      // One PPM pass as ProgressiveRenderer::run_iteration does it, with its buffers warm (the
      // state of every pass but the first of a run): trace into the chunk buffers, grid straight
      // from the chunks, gather.
      pf::PhotonBuffers chunks;
      pf::PhotonGrid pass_grid;
      double t_pass = time_ms(
          runs,
          [&] {
            uint64_t emitted = pf::trace_photons_into(scene, 0, po, chunks);
            std::vector<pf::PhotonSpan> spans = chunks.spans();
            pf::build_photon_grid_into(pass_grid, spans.data(), spans.size(), meshes,
                                       pf::ppm_grid_params(h, grid_opt), t);
            pf::ppm_pass_grid(scene, h, pass_grid, emitted, grid_opt);
          },
          reset);
      if (std::memcmp(h.hitpoints.data(), grid_state.hitpoints.data(),
                      h.hitpoints.size() * sizeof(pf_hitpoint)) != 0) {
        std::fprintf(stderr, "the driver's pass differs from ppm_pass\n");
        return 1;
      }
      // The first pass of a fresh renderer: its buffers are allocated and grown on the way.
      pf::RenderOptions ro;
      ro.eye = eye;
      ro.photons = po;
      ro.ppm = grid_opt;
      std::vector<double> cold_ms;
      for (int r = 0; r < runs; ++r) {
        pf::ProgressiveRenderer pr(scene, ro, fresh);
        double t0 = now();
        pr.run_iteration();
        cold_ms.push_back((now() - t0) * 1e3);
      }
      std::printf("| %dx%d | %d | %zu | %zu | %s | %s | %s | %s | %s | %s | %s | %s |\n", sz.w, sz.h,
                  t, fresh.hitpoints.size(), pass.photons.size(), fmt(t_eye).c_str(),
                  fmt(t_photons).c_str(), fmt(t_build).c_str(), fmt(t_grid).c_str(),
                  flann ? fmt(t_flann).c_str() : "—", fmt(t_synth).c_str(), fmt(t_pass).c_str(),
                  fmt(median(cold_ms)).c_str());
      std::fflush(stdout);
    }
  }

  const int ppm_size = a["ppm-size"].as<int>();
  if (ppm_size > 0) {
    const uint32_t ppm_photons = a["ppm-photons"].as<uint32_t>();
    const int ppm_passes = std::max(1, a["ppm-passes"].as<int>());
    std::printf("\n## PPM throughput, %dx%d, %u photons per pass, %d passes per run (median of "
                "%d runs)\n\n",
                ppm_size, ppm_size, ppm_photons, ppm_passes, runs);
    std::printf("| threads | passes/s | ms per pass | photons emitted/s |\n|---|---|---|---|\n");
    pf::Scene scene = make_scene(scene_h5, dae, Size{ppm_size, ppm_size});
    for (int t : threads) {
      pf::RenderOptions ro;
      ro.eye.threads = ro.photons.threads = ro.ppm.threads = t;
      ro.photons.photons = ppm_photons;
      pf::HitpointSet fresh = fresh_state(scene, ro.eye);
      std::vector<double> secs;
      for (int r = 0; r < runs; ++r) {
        pf::ProgressiveRenderer pr(scene, ro, fresh);
        double t0 = now();
        for (int p = 0; p < ppm_passes; ++p) pr.run_iteration();
        secs.push_back(now() - t0);
      }
      double s = median(secs);
      std::printf("| %d | %.2f | %s | %.3g |\n", t, ppm_passes / s,
                  fmt(s * 1e3 / ppm_passes).c_str(), double(ppm_photons) * ppm_passes / s);
      std::fflush(stdout);
    }
  }
  return 0;
}
