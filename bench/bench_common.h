// bench_common.h — helpers shared by the benchmarks: clocks, medians, image sizes, the benchmark
// scene at a given resolution. Benchmarks only (not part of libcommon).
#pragma once
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <cxxopts.hpp>

#include "photonflow/opencl/cl_runtime.h"
#include "photonflow/geometry/scene.h"
#include "photonflow/geometry/scene_file.h"
#include "photonflow/geometry/scene_import.h"

namespace pf::bench {

// Seconds on a monotonic clock.
inline double now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

// Median of the values (mean of the middle two for an even count; 0 for none).
inline double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  size_t n = v.size();
  if (n == 0) return 0;
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// Milliseconds with 3 significant digits or so: "1234", "12.3", "0.12".
inline std::string fmt_ms(double ms) {
  char b[64];
  if (ms >= 100)
    std::snprintf(b, sizeof b, "%.0f", ms);
  else if (ms >= 1)
    std::snprintf(b, sizeof b, "%.1f", ms);
  else
    std::snprintf(b, sizeof b, "%.2f", ms);
  return b;
}

// Idle OpenMP threads must not spin while PoCL's threads run an OpenCL measurement on the same
// cores: libgomp reads OMP_WAIT_POLICY when it is loaded, so a benchmark that times both calls this
// first thing in main and is re-executed once with the policy set (unless the caller chose one).
inline void reexec_with_passive_openmp(char** argv) {
  if (std::getenv("OMP_WAIT_POLICY")) return;
  setenv("OMP_WAIT_POLICY", "passive", 1);
  execv("/proc/self/exe", argv);
}

// --cl-platform and --cl-device of the OpenCL benchmarks.
inline void add_opencl_device_options(cxxopts::Options& o) {
  o.add_options()
    ("cl-platform", "OpenCL platform index", cxxopts::value<int>()->default_value("-1"))
    ("cl-device", "OpenCL device index", cxxopts::value<int>()->default_value("-1"));
}

// The OpenCL device those options name (else the one --device opencl picks), with work-group size
// `work_group` (0 = the default); InputError when there is none.
inline std::unique_ptr<ClContext> open_opencl_device(const cxxopts::ParseResult& a, int work_group,
                                                     const std::string& tool) {
  DeviceOptions d;
  d.device = "opencl";
  d.platform = a["cl-platform"].as<int>();
  d.device_index = a["cl-device"].as<int>();
  d.work_group = work_group;
  return open_device(d, tool);
}

struct Size {
  int w = 0, h = 0;
};

// "WxH" → Size; throws on anything else.
inline Size parse_size(const std::string& s) {
  Size z;
  if (std::sscanf(s.c_str(), "%dx%d", &z.w, &z.h) != 2 || z.w <= 0 || z.h <= 0)
    throw std::runtime_error("bad size '" + s + "' (want WxH)");
  return z;
}

// "a,b,c" → items; empty items are skipped.
inline std::vector<std::string> split_list(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ','))
    if (!item.empty()) out.push_back(item);
  return out;
}

// "W1xH1,W2xH2,..." → sizes.
inline std::vector<Size> parse_sizes(const std::string& list) {
  std::vector<Size> out;
  for (const std::string& item : split_list(list)) out.push_back(parse_size(item));
  return out;
}

// The benchmark scene at a resolution: scene.h5 if given (camera size overridden), else the scene
// file baked in-process with width/height overrides.
inline Scene make_scene(const std::string& scene_h5, const std::string& source, Size sz) {
  if (!scene_h5.empty()) {
    Scene s = load_scene(scene_h5);
    s.camera.width = sz.w;
    s.camera.height = sz.h;
    return s;
  }
  BakeOptions bo;
  bo.input = source;
  bo.width = sz.w;
  bo.height = sz.h;
  BakeReport rep;
  return bake_scene(bo, rep);
}

}  // namespace pf::bench
