// cl_backend.h — the OpenCL backend of the render stages (thesis ch. 7.2 GPU blocks):
// the same functions, options and results as the CPU backend (eye_pass.h, photon_pass.h,
// illuminate.h, synthesize.h) with a device context as the last argument, so a tool or the render
// driver switches backends with one pointer.
//
//   trace_hitpoints — kernels/trace_hitpoints.cl: one work-item per pixel, iterative specular
//                     chain, stackless kd-tree traversal with ropes (intersect_shared.h); a PBR
//                     scene's BSDF table (EyePassResult::bsdf) compacted with the hitpoints;
//   trace_photons   — kernels/trace_photons.cl: one work-item per photon, fixed bounce limit,
//                     per-photon slots compacted on the host into the CPU's order (or, by
//                     trace_photons_device, on the device, for a pass gathered there);
//   ppm_pass        — kernels/illuminate_methods.cl (cl_gather_methods.cpp; f per photon at
//                     PF_MAT_PBR hitpoints, HitpointSet::bsdf, MATERIALS.md): the naive gather
//                     (every hitpoint loops over all photons; thesis Table 7.1 "Hitpoint
//                     Illumination", the CPU's summation order) and the accelerated variants of
//                     thesis ch. 7.3 (gather_method.h), all with the CPU's acceptance rule;
//   synthesize      — kernels/synthesize.cl: one work-item per pixel adds its hitpoints in array
//                     order (the CPU's bits).
//
// Both backends use the same counter-based random numbers (rng.h) in the same dimension order and
// the same sampling formulas (sampling_shared.h), so they trace the same rays and photon paths up
// to float rounding. Buffers larger than the device's allocation limit (ClContext::max_alloc) are
// processed in batches of pixels, photons or hitpoints; the scene itself must fit one allocation
// per array.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "photonflow/opencl/cl_gather.h"
#include "photonflow/opencl/cl_runtime.h"
#include "photonflow/stages/eye_pass.h"
#include "photonflow/stages/illuminate.h"
#include "photonflow/image/image.h"
#include "photonflow/stages/photon_pass.h"
#include "photonflow/geometry/scene.h"
#include "photonflow/io/stage_files.h"

namespace pf {

// The build options of the tracing and gather kernels for `scene` (kernels/scene_features.h):
// " -DPF_SCENE_PBR=0" where no material is PF_MAT_PBR, " -DPF_SCENE_TEXTURES=0" without
// textures, " -DPF_SCENE_ALPHA=0" without alpha masks; "" for a scene that has all three. Passed
// as ClContext::kernel's variant, so a diffuse scene runs kernels without the branches of the
// materials it lacks, with the same results (the branches cost every work-item on PoCL:
// kernels/scene_features.h). "" too where dev has scene
// variants off (ClContext::scene_variants).
std::string scene_kernel_variant(const Scene& scene, const ClContext& dev);

EyePassResult trace_hitpoints(const Scene& scene, const EyePassOptions& opt, ClContext& dev);

PhotonPassResult trace_photons(const Scene& scene, uint32_t pass, const PhotonPassOptions& opt,
                               ClContext& dev);

// trace_photons with the photons left on the device: the used slots are concatenated there
// (a prefix sum of the per-photon counts, then kernels/trace_photons.cl compact_photons) instead
// of on the host, giving the same array (tested). For a pass gathered on the device
// (DevicePpmState::pass(DevicePhotons)): no photon crosses the bus. A pass too large for one
// batch of slots is traced by trace_photons and uploaded.
DevicePhotons trace_photons_device(const Scene& scene, uint32_t pass, const PhotonPassOptions& opt,
                                   ClContext& dev);

// The photons of a device pass, downloaded (tests; methods that read them on the host).
std::vector<pf_photon> download_photons(const DevicePhotons& p, ClContext& dev);

// One PPM iteration (eq. 3.14–3.18) on the device with opt.method (a device method of
// gather_method.h; InputError for grid/flann). Every method selects the photons the CPU gathers
// select; naive sums them in the CPU's order (bit-identical states), the others in their own
// fixed order (equal to float rounding). Adds `emitted` to h.photons_emitted, counts the pass,
// and returns where the time went.
GatherTimes ppm_pass(const Scene& scene, HitpointSet& h, const std::vector<pf_photon>& photons,
                     uint64_t emitted, const PpmOptions& opt, ClContext& dev);

Image synthesize(const HitpointSet& h, ClContext& dev);

// Casts rays (8 floats each: origin, direction, tmin, tmax) with the kernels' rope traversal
// (kernels/raycast.cl); returns per ray t, triangle (−1 = none) and barycentrics as the host's
// intersect_closest/intersect_any report them. For tests and benchmarks.
struct ClRayHit {
  float t;
  int32_t tri;
  float u, v;
};
std::vector<ClRayHit> cast_rays(const Scene& scene, const std::vector<float>& rays, bool any_hit,
                                ClContext& dev);

}  // namespace pf
