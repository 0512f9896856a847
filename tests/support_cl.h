// support_cl.h — the OpenCL device of the tests (PoCL in CI).
#pragma once
#include <catch2/catch.hpp>

#include <memory>

#include "photonflow/opencl/cl_runtime.h"
#include "photonflow/stages/gather_method.h"
#include "photonflow/io/provenance.h"
#include "photonflow/estimators/render_driver.h"
#include "photonflow/stages/synthesize.h"
#include "support.h"

namespace pf::test {

// The device --device opencl would pick; nullptr (and a WARN) when there is none, so that a
// machine without OpenCL skips the device tests visibly instead of failing them.
inline std::unique_ptr<ClContext> test_device() {
  if (cl_list_devices().empty()) {
    WARN("SKIPPED: no OpenCL platform with a device (install pocl-opencl-icd to run this test)");
    return nullptr;
  }
  DeviceOptions o;
  o.device = "opencl";
  return open_device(o, "test");
}

// Renders `s` with estimator `e` through the render driver on the CPU and then on `dev` (its gather
// `device_method`), `passes` passes of `photons` photons, shadow-ray direct light, PPM with
// strata and SPPM/PPPM with Sobol pixel samples, and checks that the CPU image is not black and
// that the device's equals it up to float rounding (relative RMSE ≤ 1e-3).
inline void check_device_route(const Scene& s, Estimator e, GatherMethod device_method,
                               int passes, uint32_t photons, ClContext& dev,
                               GlossyMerge glossy = GlossyMerge::First) {
  RenderOptions opt;
  opt.eye.glossy = glossy;
  opt.estimator = e;
  opt.passes = passes;
  opt.photons.photons = photons;
  opt.eye.sampler = e == Estimator::Ppm ? PixelSampler::Strata : PixelSampler::Sobol;
  opt.eye.direct = DirectMode::ShadowRays;
  const Provenance prov;
  auto image = [&]() {
    return e == Estimator::Pppm ? synthesize(render_pppm(s, opt, false, prov))
                                : synthesize(render_progressive(s, opt, false, prov));
  };
  const Image cpu = image();
  opt.device = &dev;
  opt.ppm.method = device_method;
  const Image gpu = image();
  double sum = 0;
  for (float v : cpu.rgb) sum += double(v);
  const double rmse = relative_rmse(gpu, cpu);
  INFO(estimator_name(e) << " (" << gather_method_name(device_method)
                         << "): relative RMSE opencl vs cpu " << rmse);
  CHECK(sum > 0);
  CHECK(rmse <= 1e-3);
}

}  // namespace pf::test
