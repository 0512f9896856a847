// cl_gather_methods.h — what the device's gather methods (cl_gather.h, gather_method.h) hand over:
// where a pass's time went, the photons of a pass left on the device, and the gather of a
// probabilistic-PPM pass; ppm_pass itself is declared with the other stages in cl_backend.h.
#pragma once
#include <cstddef>
#include <cstdint>
#include <vector>

#include "photonflow/foundations/shared_types.h"
#include "photonflow/opencl/cl_runtime.h"
#include "photonflow/stages/eye_pass.h"

namespace pf {

struct PpmOptions;
struct Scene;

// Where the time of one device ppm_pass went (seconds of kernel execution, clFinish'ed).
struct GatherTimes {
  double order = 0;   // photon ordering: mesh sort, grid or hash build
  double gather = 0;  // the gather kernel(s)
  double apply = 0;   // eq. 3.14–3.18
  double total = 0;   // wall time of the whole call, transfers and host work included
  size_t work_items = 0;  // hitpoint slots launched (fillers included)
};

// The photons of one pass kept on the device (cl_backend.h, trace_photons_device): `count`
// pf_photon records in `photons` (a scratch buffer of the context, valid until the next pass is
// traced), in the CPU backend's order; `emitted` photons were emitted for them.
struct DevicePhotons {
  const ClBuffer* photons = nullptr;
  size_t count = 0;
  uint64_t emitted = 0;
};

// The gather of one probabilistic-PPM pass (sppm.h) on the device: eye pass p's visible points
// gather the device's photons of pass p within the pass's global radius (pppm_pass_radius) through
// the hashed grid; returns β·τ_M per visible point (3 floats), which pppm_accumulate adds to the
// sums, as pppm_pass's host gather does (the same values where the device rounds like the host).
std::vector<float> pppm_gather_device(const Scene& scene, const EyePassResult& eye, float radius,
                                      DirectMode direct, const DevicePhotons& photons,
                                      const PpmOptions& opt, ClContext& dev);

}  // namespace pf
