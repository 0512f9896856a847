// photon_distribution.h — the photon-distribution map of thesis ch. 8.2 (eq. 8.3): how many
// photons each bin of the per-mesh photon grid (eq. 7.1) holds, averaged over many photon passes,
// and its file photon_distribution.h5 (format "photonflow.photon_distribution", docs/FORMATS.md).
//
// The memory-access fitness of the evolutionary clustering (ga_clusters.h) predicts how many
// photons a work-group reads from the bins its cluster sphere traverses. The thesis precomputes the
// map once ("average of thousand iterations"): it changes little between passes as long as the
// scene does not change, so it is an intermediate of its own, cached like the others.
//
// The grid: per mesh, exactly the grid the gather builds for the FIRST pass of the map
// (mesh_grid_header over that pass's photons of the mesh, with max_bins and default_radius = the
// hitpoints' R0, as ppm_grid_params gives the gather). Photons of later passes are binned into that
// same grid with the clamped coordinates of eq. 7.1 (grid_shared.h), so a photon slightly outside
// the first pass's bounds counts in the border bin where a pass's own grid would also have put it.
// A mesh that got no photons in the first pass has no bins (nx = ny = nz = 0).
//
// Counts are integers summed over the passes (the fitness is integer arithmetic, so an incremental
// evaluation equals a full one exactly); the mean per pass is count / passes.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "photonflow/stages/photon_grid.h"
#include "photonflow/io/provenance.h"
#include "photonflow/foundations/shared_types.h"
#include "photonflow/io/stage_files.h"

namespace pf {

constexpr const char* kPhotonDistributionFormat = "photonflow.photon_distribution";

// Slack of the clustered gather's bin box: kernels/illuminate_methods.cl, gather_grid_clusters,
// reads the bins of the box centre ± R·PF_SLACK·PF_SLACK (PF_SLACK = 1.0001f).
constexpr float kClusterBoxSlack = 1.0001f;

struct PhotonDistribution {
  // Per mesh id: the eq. 7.1 header (lo, bin_size, nx, ny, nz); first_bin indexes `counts`,
  // photon_count = the mesh's photons over all passes (first_photon unused, 0).
  std::vector<pf_mesh_grid> mesh_grid;
  std::vector<uint64_t> counts;  // photons per bin, summed over the passes
  int passes = 0;
  int first_pass = 0;            // pass index of the first pass (its grid defines the bins)
  uint64_t emitted = 0;          // photons emitted, all passes
  PhotonGridParams params;       // max_bins; default_radius = the hitpoints' R0 (ppm_grid_params)
  std::string scene_id;

  int mesh_count() const { return int(mesh_grid.size()); }
  size_t bins() const { return counts.size(); }
  // Mean photons per pass in bin `b` (global bin index).
  double mean(size_t b) const { return passes > 0 ? double(counts[b]) / double(passes) : 0.0; }
  // Adds one pass. The first call fixes the grid (the pass's own eq. 7.1 grid); every photon's
  // mesh must lie in [0, mesh_count) (std::invalid_argument otherwise, as build_photon_grid).
  void add_pass(const std::vector<pf_photon>& photons, uint64_t pass_emitted, int mesh_count);
};

// An empty map for `mesh_count` meshes with grid parameters `params` (bins are fixed by the first
// add_pass), bound to `scene_id`.
PhotonDistribution empty_photon_distribution(const PhotonGridParams& params,
                                             const std::string& scene_id);

// Box sums over the map (a summed-volume table per mesh): the photons and bins a clustered
// work-group reads (eq. 8.2, 8.3) in O(1) per cluster.
class DistributionSums {
 public:
  DistributionSums() = default;
  explicit DistributionSums(const PhotonDistribution& d);
  // Bin box [lo, hi] (inclusive, per axis) of the sphere (centre, radius) in mesh m's grid: the
  // bins gather_grid_clusters reads (pad = radius·kClusterBoxSlack², coordinates clamped as in
  // eq. 7.1). False when the mesh has no bins (the kernel then reads nothing).
  bool box(int mesh, const float centre[3], float radius, int lo[3], int hi[3]) const;
  // Photons summed over the passes in the bins of box [lo, hi] of mesh m.
  uint64_t photons(int mesh, const int lo[3], const int hi[3]) const;
  const PhotonDistribution* map() const { return d_; }

 private:
  const PhotonDistribution* d_ = nullptr;
  std::vector<size_t> first_;   // per mesh: first entry of its table in sat_
  std::vector<uint64_t> sat_;   // (nx+1)(ny+1)(nz+1) per mesh, inclusive prefix sums
};

void save_photon_distribution(const PhotonDistribution& d, const std::string& path,
                              const Provenance& prov);
PhotonDistribution load_photon_distribution(const std::string& path);
// The checks load_photon_distribution applies to what it read and save_photon_distribution to
// what it writes (validate.h written_check): pass range, photons emitted a count of `passes`
// passes, grid headers and contiguous bins, counts that sum to each mesh's photon_count.
void validate_photon_distribution(const PhotonDistribution& d, const std::string& path);

// Refuses (InputError naming `path`, one line) a map that does not belong to these hitpoints: other
// scene, or bins made with another lower bound than the hitpoints' R0 (the gather's grids would
// differ), or fewer meshes than the hitpoints use.
void require_distribution_for(const PhotonDistribution& d, const std::string& path,
                              const HitpointSet& h);

}  // namespace pf
