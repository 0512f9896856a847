// photon_grid.h — one pass's photons sorted into a uniform grid per mesh (thesis ch. 7.3, eq. 7.1),
// the layout the GPU hitpoint-illumination kernel reads and the CPU gather uses.
//
// A hitpoint gathers only the photons of its own mesh (the thesis sorts photons per mesh and
// illuminates each mesh's hitpoints from that mesh's photons; photons landing on another mesh do
// not contribute even if they are within R). Every query therefore names a mesh.
//
// Layout (the datasets of grid.h5):
//   mesh_grid[m]  header of mesh m (pf_mesh_grid), for every mesh id 0 .. mesh_count−1;
//   cell_start    for mesh m: bins+1 entries starting at mesh_grid[m].first_bin; the photons of
//                 bin b are photons[cell_start[first_bin + b] .. cell_start[first_bin + b + 1]),
//                 as absolute indices into `photons`;
//   photons       the pass's photons reordered by (mesh, bin), stable (a counting sort), so the
//                 result is deterministic; `order[i]` is the input index of photons[i].
#pragma once
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "photonflow/stages/grid_shared.h"
#include "photonflow/estimators/ppm.h"
#include "photonflow/foundations/shared_types.h"

/* pf_mesh_grid, the header of one mesh's grid, lives in shared_types.h (kernels read it). */

namespace pf {

struct PhotonGridParams {
  int max_bins = 64;           // bins along the longest extent of a mesh's photons, at most
  float default_radius = 0.f;  // lower bound of the bin size (the initial hitpoint radius); > 0
};

// Size limits of a grid (photon grids here and in cl_gather.h, the hitpoint grids of
// cluster_grid, photon-distribution maps):
//   kMaxBinsPerAxis  bins along one axis (and so max_bins): pf_grid_coord clamps to n − 1 in
//                    float, exact only for n <= 2^24;
//   kMaxGridEntries  bin-start entries of one grid, Σ over meshes of (bins + 1): 2^28, i.e. at
//                    most 1 GiB per int32 table (cell_start, and the build's histograms). Eq. 7.1
//                    makes bins at least the default radius R0 wide and at most max_bins along a
//                    mesh's longest extent, so a small R0 with a large max_bins can ask for
//                    max_bins³ bins per mesh; such a grid is refused (InputError), not allocated.
constexpr int kMaxBinsPerAxis = 1 << 24;
constexpr int64_t kMaxGridEntries = int64_t(1) << 28;
// What to do about a photon grid past kMaxGridEntries.
constexpr const char* kGridBinsHint =
    "raise --radius (R0, the smallest bin size) or lower --max-bins";

// Bins of a header, nx·ny·nz, in 64 bits (0 for a mesh without bins).
inline int64_t mesh_grid_bins(const pf_mesh_grid& g) {
  return int64_t(g.nx) * int64_t(g.ny) * int64_t(g.nz);
}

// "" when `g` is a well-formed header: nx = ny = nz = 0 (no bins), or each in
// [1, kMaxBinsPerAxis] with at most kMaxGridEntries bins, a positive finite bin size and a
// finite corner; else what is wrong (for the loaders of grid.h5 and photon_distribution.h5).
std::string mesh_grid_problem(const pf_mesh_grid& g);

// Refuses (InputError naming --max-bins) a max_bins above kMaxBinsPerAxis; `what` names the grid.
void check_max_bins(int max_bins, const std::string& what);
// The parameters of a photon grid build (CPU and device): std::invalid_argument for
// default_radius <= 0 or not finite, or max_bins < 1; check_max_bins above kMaxBinsPerAxis.
void check_photon_grid_params(const PhotonGridParams& params);
// Refuses (InputError) a grid of `entries` bin-start entries above kMaxGridEntries: "<what> would
// have <entries> bins, more than 2^28 (<hint>)".
void check_grid_entries(int64_t entries, const std::string& what, const std::string& hint);

// Bin coordinate of x along one axis (eq. 7.1), clamped to [0, n−1] (grid_shared.h, the code the
// kernels run). Monotone in x, so the bins overlapping an interval [x0, x1] are those from
// coord(x0) to coord(x1).
inline int grid_coord(float x, float lo, float bin_size, int n) {
  return pf_grid_coord(x, lo, bin_size, n);
}

// The header of one mesh's grid from the bounds lo..hi and the count of its photons (eq. 7.1):
// d = max(longest extent / max_bins, default_radius), per axis clamp(ceil(extent/d), 1, max_bins)
// bins; first_bin and first_photon are left 0 for the caller. A mesh without photons gets
// nx = ny = nz = 0, lo = 0 and d = default_radius. The host build and the device build
// (cl_gather.h) both call this, so they make the same grids.
pf_mesh_grid mesh_grid_header(const float lo[3], const float hi[3], int32_t count,
                              const PhotonGridParams& params);

struct PhotonGrid {
  std::vector<pf_mesh_grid> mesh_grid;  // one per mesh id
  std::vector<int32_t> cell_start;      // see the file comment
  std::vector<pf_photon> photons;       // sorted by (mesh, bin)
  std::vector<int32_t> order;           // input index of each sorted photon
  PhotonGridParams params;
  // The sorted photons' positions once more, one array per axis, each with kPositionPad
  // entries past the last photon: the CPU gather (gather_site) tests four photons at a time
  // from these. Derived (build_photon_grid_into fills them, load_grids calls index_positions), never
  // stored; a grid whose photons were set otherwise has none, and the gather then reads photons.
  static constexpr size_t kPositionPad = 3;
  std::vector<float> pos_x, pos_y, pos_z;
  void index_positions(int threads = 0);
  bool has_positions() const {
    const size_t n = photons.size() + kPositionPad;
    return pos_x.size() == n && pos_y.size() == n && pos_z.size() == n;
  }

  // Calls f(i) for every sorted photon index i of `mesh` with
  // pf_ppm_in_radius(pf_ppm_dist2(q, photons[i].position), radius), in sorted order.
  // A mesh id outside [0, mesh_count) or a negative radius visits nothing.
  template <class F> void for_each_in_radius(int mesh, const float q[3], float radius, F&& f) const;

  // The sorted photon indices that for_each_in_radius visits.
  std::vector<int32_t> gather(int mesh, const float q[3], float radius) const;
};

// The check every photon ordering makes (CPU grid, device orderings, hash_grid.h): the photon's
// mesh in [0, mesh_count) and its position finite. photon_ok says whether it passes;
// throw_bad_photon throws the std::invalid_argument naming photon i and what is wrong.
inline bool photon_ok(const pf_photon& p, int mesh_count) {
  return p.mesh >= 0 && p.mesh < mesh_count && std::isfinite(p.position[0]) &&
         std::isfinite(p.position[1]) && std::isfinite(p.position[2]);
}
[[noreturn]] void throw_bad_photon(const pf_photon& p, size_t i, int mesh_count);
// The checks before any photon: mesh_count >= 0 and at most 2^31 − 1 photons (int indices);
// std::invalid_argument otherwise.
void check_photon_count(size_t n, int mesh_count);

// Sorts one pass's photons into per-mesh grids. mesh_count = number of meshes of the scene; every
// photon's mesh must lie in [0, mesh_count) and its position must be finite
// (std::invalid_argument otherwise, also for default_radius <= 0 or max_bins < 1). A max_bins
// above kMaxBinsPerAxis, or a grid of more than kMaxGridEntries entries, is an InputError that
// says to raise the radius or lower --max-bins (before anything is allocated).
PhotonGrid build_photon_grid(const std::vector<pf_photon>& photons, int mesh_count,
                             const PhotonGridParams& params);

// A run of photons; a list of spans stands for their concatenation (photon index = position in
// the concatenation), e.g. the per-chunk buffers of a photon pass.
struct PhotonSpan {
  const pf_photon* data;
  size_t size;
};

// The same grid, built into `grid` with `threads` workers (0 = all cores), reusing the capacity
// of grid's arrays: a stream of similar passes allocates nothing after the first. The result is
// identical to build_photon_grid's for any thread count.
void build_photon_grid_into(PhotonGrid& grid, const std::vector<pf_photon>& photons,
                            int mesh_count, const PhotonGridParams& params, int threads = 0);
void build_photon_grid_into(PhotonGrid& grid, const PhotonSpan* spans, size_t span_count,
                            int mesh_count, const PhotonGridParams& params, int threads = 0);

template <class F>
void PhotonGrid::for_each_in_radius(int mesh, const float q[3], float radius, F&& f) const {
  if (mesh < 0 || mesh >= static_cast<int>(mesh_grid.size()) || !(radius >= 0.f)) return;
  const pf_mesh_grid& g = mesh_grid[mesh];
  if (g.photon_count == 0) return;
  // Box of the sphere, widened by a relative 1e-4: a photon outside [q − pad, q + pad] on some axis
  // has a float |Δ| >= pad there (rounding is monotone), hence distance² > R² in float, so the
  // bins of the widened box hold every photon the distance test accepts.
  const float pad = radius * 1.0001f;
  int lo[3], hi[3];
  const int n[3] = {g.nx, g.ny, g.nz};
  for (int a = 0; a < 3; ++a) {
    lo[a] = grid_coord(q[a] - pad, g.lo[a], g.bin_size, n[a]);
    hi[a] = grid_coord(q[a] + pad, g.lo[a], g.bin_size, n[a]);
  }
  for (int z = lo[2]; z <= hi[2]; ++z) {
    for (int y = lo[1]; y <= hi[1]; ++y) {
      const int row = g.first_bin + (y + z * g.ny) * g.nx;
      const int begin = cell_start[row + lo[0]];
      const int end = cell_start[row + hi[0] + 1];  // bins lo..hi of a row are contiguous
      for (int i = begin; i < end; ++i) {
        const float* p = photons[i].position;
        if (pf_ppm_in_radius(pf_ppm_dist2(q[0], q[1], q[2], p[0], p[1], p[2]), radius)) f(i);
      }
    }
  }
}

}  // namespace pf
