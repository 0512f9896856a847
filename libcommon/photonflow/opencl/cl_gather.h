// cl_gather.h — hitpoint illumination on the OpenCL device (issue 5; thesis ch. 7.3): the device
// photon orderings (kernels/build_grid.cl) and the gather methods of gather_method.h
// (kernels/illuminate_methods.cl), behind cl_backend.h's ppm_pass(…, ClContext&).
//
// What each method builds before it gathers (all deterministic):
//   naive, local-memory                 nothing (photons in pass order);
//   photon-sort … kmeans-clusters       per-mesh photon arrays: a stable counting sort by mesh;
//   grid-kmeans, grid-gridclusters      the per-mesh uniform grid of eq. 7.1: bounds reduced on the
//                                       device, headers by photon_grid.h's mesh_grid_header, bins
//                                       counted with atomic counters, a prefix sum (the bin-start
//                                       table), a separate scatter kernel, bins sorted by photon
//                                       index — the same arrays as the CPU's build_photon_grid;
//   hash-grid                           one grid of cells hash_cell·max R (default 2, times a
//                                       1e-4 slack) over the scene, its cells hashed by linear
//                                       index into a power-of-two table (hash_grid.h), built by
//                                       the same count / scan / scatter / sort kernels — or, on a
//                                       CPU device, by the host straight into the mapped buffers
//                                       (PpmOptions::hash_order; the same bytes) — as the photons'
//                                       keys (position, mesh, direct flag, in blocks of four that
//                                       the gather tests per float4) and payloads (direction,
//                                       flux); its gather kernel also applies eq. 3.14–3.18 and
//                                       reduces the next max R.
// The host supplies the hitpoint orders: mesh_sorted_order (hitpoint sorting, fillers) and the
// clusters' order (clusters.h), one work-group per cluster.
//
// Limits: every method but naive keeps the pass's hitpoints and photons in one device buffer
// each (InputError naming --method naive, which batches, when they exceed the device's largest
// allocation).
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "photonflow/opencl/cl_runtime.h"
#include "photonflow/stages/eye_pass.h"
#include "photonflow/stages/gather_method.h"
#include "photonflow/stages/photon_grid.h"
#include "photonflow/foundations/shared_types.h"

namespace pf {

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

// Exclusive prefix sum of the n ints of `data`, in place, on the device (kernels/build_grid.cl,
// scan_blocks and scan_add; the block sums of each level scanned recursively).
void device_exclusive_scan(ClContext& dev, const ClBuffer& data, size_t n);

struct ClusterSet;
struct Scene;
struct HitpointSet;
struct PpmOptions;

// The clusters a clustered device method reads (gather_method.h: kmeans-clusters and grid-kmeans
// read k-means clusters, grid-gridclusters grid clusters), made for `h` with work-group size
// wg_size, opt.cluster_iterations Lloyd steps (seed 1) or automatic bins (cluster_grid with
// max_bins 0; the cluster stage's defaults, so both routes make the same clusters). The method must be
// one of those three (std::invalid_argument otherwise).
ClusterSet clusters_for_method(GatherMethod m, const HitpointSet& h, int wg_size,
                               const PpmOptions& opt);

// The per-mesh photon grid built on the device (the path of grid-kmeans / grid-gridclusters),
// downloaded: the same PhotonGrid as the CPU's build_photon_grid(photons, mesh_count, params)
// (std::invalid_argument on the same bad input). For `build-grid --device opencl` and tests.
PhotonGrid build_photon_grid(const std::vector<pf_photon>& photons, int mesh_count,
                             const PhotonGridParams& params, ClContext& dev);

// The per-mesh photon arrays of photon sorting, downloaded: photons stably sorted by mesh and
// mesh_start (mesh_count + 1 entries). For tests.
void sort_photons_by_mesh(const std::vector<pf_photon>& photons, int mesh_count, ClContext& dev,
                          std::vector<pf_photon>& sorted, std::vector<int32_t>& mesh_start);

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

// The gather of one probabilistic-PPM pass (sppm.h) on the device: eye pass p's visible points
// gather the device's photons of pass p within the pass's global radius (pppm_pass_radius) through
// the hashed grid; returns β·τ_M per visible point (3 floats), which pppm_accumulate adds to the
// sums, as pppm_pass's host gather does (the same values where the device rounds like the host).
std::vector<float> pppm_gather_device(const Scene& scene, const EyePassResult& eye, float radius,
                                      DirectMode direct, const DevicePhotons& photons,
                                      const PpmOptions& opt, ClContext& dev);

// The grid-cluster gather alone (gather_grid_clusters, the kernel of grid-kmeans and
// grid-gridclusters), for timing many clusterings of one eye pass against one photon pass: the
// device-time fitness of the GA (thesis ch. 8.2, Table 8.4). The hitpoints, the photons and their
// per-mesh grid (eq. 7.1, ppm_grid_params(h, opt)) go to the device once, in its own scratch
// buffers ("timer.*", so ppm_pass calls on the same context in between do not disturb them);
// each time() uploads one cluster set and runs the gather, never eq. 3.14–3.18, so every
// candidate meets the same hitpoint state. Its kernel time is what ppm_pass reports as
// GatherTimes::gather for the same clusters (same kernel, same inputs) at a fraction of the cost:
// no photon upload, no grid build, no hitpoint copies. Construction throws as ppm_pass does
// (InputError for the wrong backend or oversized inputs, std::invalid_argument for bad photons).
class GridGatherTimer {
 public:
  GridGatherTimer(const Scene& scene, const HitpointSet& h, const std::vector<pf_photon>& photons,
                  const PpmOptions& opt, ClContext& dev);
  // Kernel seconds of the fastest of `runs` (≥ 1) gathers with clusters c, which must have been
  // made for these hitpoints (InputError otherwise); their radii are refreshed from the state
  // as in ppm_pass (update_cluster_radii).
  double time(const ClusterSet& c, int runs = 1);
  // M of each hitpoint (photons gathered, eq. 3.14) in the last time() call; zeros before one.
  std::vector<int32_t> photon_counts();

 private:
  ClContext& dev_;
  const HitpointSet& h_;
  std::string variant_;  // the scene's kernel variant (scene_kernel_variant)
  size_t nh_ = 0, np_ = 0;
  int mesh_count_ = 0;
  int skip_direct_ = 0;
  const ClBuffer *hps_ = nullptr, *mats_ = nullptr, *pbr_ = nullptr, *acc_m_ = nullptr,
                 *acc_tau_ = nullptr;
  const ClBuffer *sorted_ = nullptr, *mesh_grid_ = nullptr, *cell_start_ = nullptr;
  size_t acc_bytes_ = 0;
};

}  // namespace pf
