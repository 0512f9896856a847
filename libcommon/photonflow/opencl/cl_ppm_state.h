// cl_ppm_state.h — DevicePpmState: a PPM or SPPM state kept on the device between passes, so
// that a stream of passes (the render driver, illuminate over a photons file) need not copy the
// hitpoints each pass.
#pragma once
#include <cstdint>
#include <vector>

#include "photonflow/foundations/shared_types.h"
#include "photonflow/opencl/cl_gather_methods.h"
#include "photonflow/opencl/cl_runtime.h"
#include "photonflow/stages/eye_pass.h"

namespace pf {

struct HitpointSet;
struct PpmOptions;
struct Scene;

// A PPM state kept on the device between passes: the route of a stream of passes (the render
// driver, illuminate over a photons file). With hash-grid the hitpoints stay in device memory:
// a pass uploads only its photons (nothing when they were traced on the device), gathers and applies eq. 3.14–3.18 in one kernel, and brings
// back the largest radius (4 bytes, the next pass's cell size); the host copy h.hitpoints is
// brought up to date by sync(). Other methods copy the state each pass as ppm_pass does (sync()
// first). On the device the hitpoints are kept in cell order (hitpoint_cell_order, cells of
// kHitpointOrderCell × the largest radius), which changes no result: one work-item gathers for
// one hitpoint, and split into the fields a pass reads (pf_gather_site) and the R, N, τ it
// rewrites (pf_ppm_state; shared_types.h), so that sync() copies back only those. The states are
// those of ppm_pass pass by pass, bit for bit (tested).
// h.passes, h.photons_emitted and h.estimator are always current; h.hitpoints only after sync().
// h must outlive this object and must not be changed by others while a pass may be pending.
class DevicePpmState {
 public:
  DevicePpmState(const Scene& scene, HitpointSet& h, ClContext& dev);
  // One pass, as ppm_pass(scene, h, photons, emitted, opt, dev).
  GatherTimes pass(const std::vector<pf_photon>& photons, uint64_t emitted, const PpmOptions& opt);
  // One pass over photons already on the device (trace_photons_device): the same state as
  // pass(photons downloaded, emitted, opt). With hash-grid no photon crosses the bus: a GPU orders
  // them with its kernels, a CPU device (opt.hash_order auto/host) maps them, which costs no copy
  // there, and orders them on the host (checking them as ever). The device route does not check
  // them: trace_photons_device made them from the checked scene. Other methods download them and
  // take the copying route.
  GatherTimes pass(const DevicePhotons& photons, const PpmOptions& opt);
  // One SPPM pass (sppm.h) over an SPPM state (one hitpoint per pixel): `eye` holds eye pass p's
  // visible points, whose sites and throughputs β go up; the pixels' R, N, τ stay on the device,
  // where the hashed-grid gather multiplies each τ_M by β and updates them; the emitted and direct
  // layers are averaged on the host. The same state as sppm_pass(scene, h, eye, grid of the
  // photons, emitted, opt), bit for bit where the device rounds division and sqrt correctly.
  GatherTimes sppm_pass(const EyePassResult& eye, const std::vector<pf_photon>& photons,
                        uint64_t emitted, const PpmOptions& opt);
  GatherTimes sppm_pass(const EyePassResult& eye, const DevicePhotons& photons,
                        const PpmOptions& opt);
  // h.hitpoints ← the device's state (nothing when already current).
  void sync();
  // Copies h.hitpoints to the device now (a hash-grid pass does it when needed); benchmarks
  // time a steady-state pass apart from this one-off copy.
  void upload();
  bool host_current() const { return host_current_; }
  // The largest finite positive radius of the state on the device, as its last hash-grid pass
  // reduced it (the next pass's cell unit); for tests.
  float device_max_radius() const { return rmax_; }

 private:
  // A hash-grid pass over photons on the host (host) or on the device (device), np of them.
  GatherTimes hash_grid(const pf_photon* host, const ClBuffer* device, size_t np, uint64_t emitted,
                        const PpmOptions& opt);
  GatherTimes sppm_hash_grid(const EyePassResult& eye, const pf_photon* host,
                             const ClBuffer* device, size_t np, uint64_t emitted,
                             const PpmOptions& opt);

  const Scene& scene_;
  HitpointSet& h_;
  ClContext& dev_;
  // The resident hitpoints, split (pf_gather_site, pf_ppm_state; allocated on the first
  // hash-grid pass). A pass changes only the states: sync copies those back.
  ClBuffer sites_, states_;
  ClBuffer mats_;                // the scene's materials, written with the hitpoints
  ClBuffer pbr_;                 // the hitpoints' pf_pbr_site table (one stand-in without PBR)
  std::vector<int32_t> sppm_pbr_order_;  // SPPM: the visible point of each pixel
  ClBuffer weights_;             // SPPM: the pass's eye-path throughputs β, 3 per pixel
  // SPPM: the pass's sites and β on the host (sppm_sites), kept from pass to pass.
  std::vector<pf_hitpoint> sppm_sites_;
  std::vector<float> sppm_beta_;
  bool host_current_ = true;     // h_.hitpoints holds the latest state
  bool device_current_ = false;  // hps_ holds it
  float rmax_ = 0.f;             // largest finite positive radius of the device's state
  // entry i holds h_.hitpoints[order_[i]]: the hitpoints in cell order (hitpoint_cell_order,
  // hash_grid.h), so that a work-group's hitpoints read the same rows of the hashed grid.
  std::vector<int32_t> order_;
};

}  // namespace pf
