// cl_grid_gather_timer.cpp — GridGatherTimer: the grid-cluster gather alone, its inputs on the
// device once, so that the GA's device-time fitness times many clusterings of one eye pass at a
// fraction of a ppm_pass's cost.
#include "photonflow/opencl/cl_grid_gather_timer.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "photonflow/geometry/scene.h"
#include "photonflow/io/stage_files.h"
#include "photonflow/opencl/cl_backend.h"
#include "photonflow/opencl/cl_gather_internal.h"
#include "photonflow/stages/clusters.h"
#include "photonflow/stages/illuminate.h"

namespace pf {

using namespace detail;

GridGatherTimer::GridGatherTimer(const Scene& scene, const HitpointSet& h,
                                 const std::vector<pf_photon>& photons, const PpmOptions& opt,
                                 ClContext& dev)
    : dev_(dev), h_(h), variant_(scene_kernel_variant(scene, dev)) {
  nh_ = h.hitpoints.size();
  np_ = photons.size();
  check_sizes(nh_, np_);
  require_one_buffer(dev, nh_, sizeof(pf_hitpoint), "hitpoints", GatherMethod::GridKmeans);
  require_one_buffer(dev, np_, sizeof(pf_photon), "photons", GatherMethod::GridKmeans);
  mesh_count_ = int(scene.mesh_names.size());
  check_photons(photons, mesh_count_);
  skip_direct_ = h.direct_mode == DirectMode::ShadowRays ? 1 : 0;
  acc_bytes_ = dev.info().fp64 ? sizeof(double) : sizeof(float);
  const size_t nh1 = std::max<size_t>(nh_, 1), np1 = std::max<size_t>(np_, 1);
  mats_ = &dev.scratch("timer.materials", std::max<size_t>(scene.materials.size(), 1) * sizeof(pf_material));
  dev.write(*mats_, scene.materials.size() * sizeof(pf_material), scene.materials.data());
  hps_ = &dev.scratch("timer.hitpoints", nh1 * sizeof(pf_hitpoint));
  dev.write(*hps_, nh_ * sizeof(pf_hitpoint), h.hitpoints.data());
  require_bsdf_table(scene, h.hitpoints, h.bsdf);
  pbr_ = &pbr_sites(dev, scene, "timer.pbr", h.hitpoints, h.bsdf, nullptr, 0, nh_);
  acc_m_ = &dev.scratch("timer.acc_m", nh1 * sizeof(cl_int));
  acc_tau_ = &dev.scratch("timer.acc_tau", nh1 * 3 * acc_bytes_);
  dev.fill_zero(*acc_m_, nh1 * sizeof(cl_int));
  const ClBuffer& phs = dev.scratch("timer.photons_in", np1 * sizeof(pf_photon));
  dev.write(phs, np_ * sizeof(pf_photon), photons.data());
  const DeviceGrid g = device_grid(dev, phs, np_, mesh_count_, ppm_grid_params(h, opt), "timer.grid");
  sorted_ = g.sorted;
  mesh_grid_ = g.mesh_grid;
  cell_start_ = g.cell_start;
}

double GridGatherTimer::time(const ClusterSet& c, int runs) {
  check_cluster_count(c, nh_);
  if (nh_ == 0 || np_ == 0) return 0.0;
  ClusterSet cs = c;
  update_cluster_radii(cs, h_);
  const DeviceClusters dc = upload_clusters(dev_, cs, "timer");
  cl_kernel k = dev_.kernel("illuminate_methods", "gather_grid_clusters", variant_);
  double best = INFINITY;
  for (int r = 0; r < std::max(1, runs); ++r) {
    dev_.fill_zero(*acc_m_, nh_ * sizeof(cl_int));
    dev_.fill_zero(*acc_tau_, nh_ * 3 * acc_bytes_);
    dev_.args(k, *hps_, *dc.order, *dc.groups, *dc.clusters, *sorted_, *mesh_grid_, *cell_start_,
              cl_int(mesh_count_), *mats_, *pbr_, cl_int(skip_direct_), *acc_m_, *acc_tau_);
    const double t0 = dev_.kernel_seconds();
    dev_.run(k, dc.items, dc.wg);
    best = std::min(best, since(dev_, t0));
  }
  return best;
}

std::vector<int32_t> GridGatherTimer::photon_counts() {
  std::vector<int32_t> m(nh_, 0);
  if (nh_ > 0) dev_.read(*acc_m_, nh_ * sizeof(cl_int), m.data());
  return m;
}

}  // namespace pf
