// cl_grid_gather_timer.h — GridGatherTimer: the grid-cluster gather alone, timed, for the GA's
// device-time fitness, which times many clusterings against one photon pass.
#pragma once
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "photonflow/foundations/shared_types.h"
#include "photonflow/opencl/cl_runtime.h"

namespace pf {

struct ClusterSet;
struct Scene;
struct HitpointSet;
struct PpmOptions;

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
