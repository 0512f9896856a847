// photon_grid.cpp — per-mesh uniform photon grids (thesis ch. 7.3, eq. 7.1), built with a stable
// counting sort by (mesh, bin).
#include "photonflow/photon_grid.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>

#include "photonflow/vec.h"

namespace pf {

namespace {

// Linear bin offset of p in grid g (eq. 7.1): x + y·nx + z·nx·ny.
int bin_of(const pf_mesh_grid& g, const float* p) {
  int x = grid_coord(p[0], g.lo[0], g.bin_size, g.nx);
  int y = grid_coord(p[1], g.lo[1], g.bin_size, g.ny);
  int z = grid_coord(p[2], g.lo[2], g.bin_size, g.nz);
  return x + (y + z * g.ny) * g.nx;
}

// Bins along an extent: enough bins of size d to cover it, at least one and at most max_bins
// (extent/d can exceed max_bins by rounding; grid_coord clamps, so the last bin absorbs it).
int bins_along(float extent, float d, int max_bins) {
  return std::clamp(static_cast<int>(std::ceil(extent / d)), 1, max_bins);
}

}  // namespace

std::vector<int32_t> PhotonGrid::gather(int mesh, const float q[3], float radius) const {
  std::vector<int32_t> out;
  for_each_in_radius(mesh, q, radius, [&](int i) { out.push_back(i); });
  return out;
}

PhotonGrid build_photon_grid(const std::vector<pf_photon>& photons, int mesh_count,
                             const PhotonGridParams& params) {
  if (!(params.default_radius > 0.f) || !std::isfinite(params.default_radius))
    throw std::invalid_argument("photon grid: default_radius must be positive and finite");
  if (params.max_bins < 1) throw std::invalid_argument("photon grid: max_bins must be >= 1");
  if (mesh_count < 0) throw std::invalid_argument("photon grid: negative mesh count");
  if (photons.size() > static_cast<size_t>(std::numeric_limits<int32_t>::max()))
    throw std::invalid_argument("photon grid: more than 2^31-1 photons");

  // Bounds and count of each mesh's photons.
  std::vector<Bounds> bounds(mesh_count);
  std::vector<int32_t> count(mesh_count, 0);
  for (size_t i = 0; i < photons.size(); ++i) {
    const pf_photon& p = photons[i];
    Vec3 pos(p.position);
    if (p.mesh < 0 || p.mesh >= mesh_count)
      throw std::invalid_argument("photon grid: photon " + std::to_string(i) + " has mesh id " +
                                  std::to_string(p.mesh) + " outside [0, " +
                                  std::to_string(mesh_count) + ")");
    if (!finite(pos))
      throw std::invalid_argument("photon grid: photon " + std::to_string(i) +
                                  " has a non-finite position");
    bounds[p.mesh].extend(pos);
    ++count[p.mesh];
  }

  // Per-mesh headers: bin size and counts (eq. 7.1), bin and photon offsets.
  PhotonGrid grid;
  grid.params = params;
  grid.mesh_grid.resize(mesh_count);
  int64_t total_entries = 0;
  int32_t first_photon = 0;
  for (int m = 0; m < mesh_count; ++m) {
    pf_mesh_grid& g = grid.mesh_grid[m];
    g.first_bin = static_cast<pf_int>(total_entries);
    g.first_photon = first_photon;
    g.photon_count = count[m];
    if (count[m] == 0) {
      g.lo[0] = g.lo[1] = g.lo[2] = 0.f;
      g.bin_size = params.default_radius;
      g.nx = g.ny = g.nz = 0;
      total_entries += 1;
    } else {
      Vec3 ext = bounds[m].extent();
      float longest = std::max(ext.x, std::max(ext.y, ext.z));
      float d = std::max(longest / static_cast<float>(params.max_bins), params.default_radius);
      bounds[m].lo.store(g.lo);
      g.bin_size = d;
      g.nx = bins_along(ext.x, d, params.max_bins);
      g.ny = bins_along(ext.y, d, params.max_bins);
      g.nz = bins_along(ext.z, d, params.max_bins);
      total_entries += static_cast<int64_t>(g.nx) * g.ny * g.nz + 1;
    }
    if (total_entries > std::numeric_limits<int32_t>::max())
      throw std::invalid_argument("photon grid: more than 2^31-1 bins (lower max_bins)");
    first_photon += count[m];
  }

  // Counting sort by global bin = first_bin(mesh) + bin. Each mesh's last entry (its end marker)
  // receives no photons, so one prefix sum over all entries gives every mesh's bins+1 starts.
  std::vector<int32_t> key(photons.size());
  grid.cell_start.assign(static_cast<size_t>(total_entries), 0);
  for (size_t i = 0; i < photons.size(); ++i) {
    const pf_mesh_grid& g = grid.mesh_grid[photons[i].mesh];
    key[i] = g.first_bin + bin_of(g, photons[i].position);
    ++grid.cell_start[key[i]];
  }
  int32_t running = 0;
  for (int32_t& c : grid.cell_start) {
    int32_t n = c;
    c = running;
    running += n;
  }
  std::vector<int32_t> next(grid.cell_start);  // write cursor per bin
  grid.photons.resize(photons.size());
  grid.order.resize(photons.size());
  for (size_t i = 0; i < photons.size(); ++i) {
    int32_t dst = next[key[i]]++;
    grid.photons[dst] = photons[i];
    grid.order[dst] = static_cast<int32_t>(i);
  }
  return grid;
}

}  // namespace pf
