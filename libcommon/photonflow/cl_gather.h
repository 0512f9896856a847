// cl_gather.h — hitpoint illumination on the OpenCL device (issue 5; thesis ch. 7.3): the device
// photon orderings (kernels/build_grid.cl) and the gather methods of gather_method.h
// (kernels/illuminate_methods.cl), behind cl_backend.h's ppm_pass(…, ClContext&).
//
// What each method builds on the device before it gathers (all deterministic):
//   naive, local-memory                 nothing (photons in pass order);
//   photon-sort … kmeans-clusters       per-mesh photon arrays: a stable counting sort by mesh;
//   grid-kmeans, grid-gridclusters      the per-mesh uniform grid of eq. 7.1: bounds reduced on the
//                                       device, headers by photon_grid.h's mesh_grid_header, bins
//                                       counted with atomic counters, a prefix sum (the bin-start
//                                       table), a separate scatter kernel, bins sorted by photon
//                                       index — the same arrays as the CPU's build_photon_grid;
//   hash-grid                           one grid of cells hash_cell·max R (default 2, times a
//                                       1e-4 slack) over the scene, its cells hashed by linear
//                                       index into 2^k ≥ photons slots, built by the same count /
//                                       scan / scatter / sort kernels.
// The host supplies the hitpoint orders: mesh_sorted_order (hitpoint sorting, fillers) and the
// clusters' order (clusters.h), one work-group per cluster.
//
// Limits: every method but naive keeps the pass's hitpoints and photons in one device buffer
// each (InputError naming --method naive, which batches, when they exceed the device's largest
// allocation).
#pragma once
#include <vector>

#include "photonflow/cl_runtime.h"
#include "photonflow/gather_method.h"
#include "photonflow/photon_grid.h"
#include "photonflow/shared_types.h"

namespace pf {

// Where the time of one device ppm_pass went (seconds of kernel execution, clFinish'ed).
struct GatherTimes {
  double order = 0;   // photon ordering: mesh sort, grid or hash build
  double gather = 0;  // the gather kernel(s)
  double apply = 0;   // eq. 3.14–3.18
  double total = 0;   // wall time of the whole call, transfers and host work included
  size_t work_items = 0;  // hitpoint slots launched (fillers included)
};

struct ClusterSet;
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

}  // namespace pf
