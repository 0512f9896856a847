// cl_build_grid.h — the device's photon orderings, downloaded: the per-mesh grid of eq. 7.1 and
// the per-mesh arrays of photon sorting, as the device methods build them, for
// `build-grid --device opencl` and for the tests that compare them with the CPU's.
#pragma once
#include <cstdint>
#include <vector>

#include "photonflow/foundations/shared_types.h"
#include "photonflow/opencl/cl_runtime.h"
#include "photonflow/stages/photon_grid.h"

namespace pf {

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
