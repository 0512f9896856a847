// clusters.h — hitpoints grouped into work-group clusters (thesis ch. 7.3, Tables 7.4/7.5), the
// `cluster` stage and its file clusters.h5 (format "photonflow.clusters", docs/FORMATS.md).
//
// A cluster is a set of hitpoints of ONE mesh (the gather is per mesh, photon_grid.h) that a single
// work-group illuminates together: all its work-items share one centre and one radius R, so they
// read the same grid bins. The hitpoint indices of all clusters lie in one ORDER array, clusters
// contiguous; each cluster's run is padded with FILLER entries (index −1) to a multiple of the
// work-group size ("filler hitpoints", thesis ch. 7.3), so work-group g handles exactly the
// entries order[g·wg … (g+1)·wg) and never straddles two clusters:
//
//   order[first … first+count)                 hitpoint indices (ascending), real work
//   order[first+count … first+padded_count)    −1, fillers (idle work-items)
//   padded_count = ceil(count / wg_size) · wg_size,  first = Σ padded_count of earlier clusters.
//
// Shared radius rule: R = max over the cluster's hitpoints i of (|x_i − centre| + r_i), computed in
// double and rounded up to float, i.e. the smallest sphere around `centre` that contains every
// member's gather sphere; any photon a member can gather lies within R of the centre.
//
// Rebuild vs refresh (PPM radii shrink every pass, eq. 3.16):
//   - Refresh (update_cluster_radii): each pass, after the radii change; O(hitpoints), keeps the
//     membership and centres and recomputes R from the current radii, so R only tightens.
//   - Rebuild (cluster_kmeans / cluster_grid): never needed for correctness — radii only shrink,
//     so an old R stays conservative (update_cluster_radii keeps it exact). Rebuild only when the
//     hitpoints themselves change (a new eye pass: other positions, pixels, meshes, image size);
//     load_clusters refuses a file whose hitpoints_sha256 does not match the hitpoints.
#pragma once
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "photonflow/io/provenance.h"
#include "photonflow/foundations/shared_types.h"
#include "photonflow/io/stage_files.h"

/* pf_cluster, one cluster, lives in shared_types.h (kernels read it). */

namespace pf {

constexpr const char* kClustersFormat = "photonflow.clusters";

// Size limits of a clustering, refused with an InputError before anything is allocated:
//   kMaxWorkGroupSize  work-items per work-group (cluster --wg-size, the OpenCL --work-group):
//                      1 … 8192, above every device's CL_DEVICE_MAX_WORK_GROUP_SIZE we know of;
//   kMaxOrderEntries   entries of the order array, Σ padded_count (hitpoints plus fillers):
//                      2^28 (1 GiB of int32); fillers grow with the work-group size, up to
//                      wg_size − 1 per cluster;
//   the hitpoint grid of cluster_grid: at most kMaxGridEntries cells per mesh (photon_grid.h).
constexpr int kMaxWorkGroupSize = 8192;
constexpr int64_t kMaxOrderEntries = int64_t(1) << 28;

struct ClusterSet {
  std::vector<pf_cluster> clusters;  // ordered by mesh, then as the method made them
  std::vector<int32_t> order;        // Σ padded_count entries: hitpoint index or −1 (filler)
  int wg_size = 0;                   // work-group size
  std::string method;                // "kmeans", "grid" or "ga" (ga_clusters.h)
  std::string scene_id;
  uint64_t hitpoint_count = 0;       // hitpoints of the set the clusters were made for
  std::string hitpoints_sha256;      // hitpoints_hash() of that set
};

struct ClusterStats {
  size_t clusters = 0;
  size_t hitpoints = 0;               // Σ count
  size_t fillers = 0;                 // Σ (padded_count − count)
  size_t hitpoints_with_fillers = 0;  // Σ padded_count (Table 7.5)
  double mean_radius = 0;             // mean of the clusters' R, world units
};

// K-means per mesh (thesis: K = hitpoints / work-group size): K = ceil(hitpoints_of_mesh /
// wg_size). Seeding: the mesh's hitpoints in Morton (Z-curve) order over their bounding box, cut
// into K runs of nearly equal size, centre = mean of each run. Then `iterations` Lloyd steps
// (nearest centre through a uniform grid over the centres; ties to the lower centre index; means
// summed in double in hitpoint order), then a final assignment. Empty clusters are dropped;
// members are listed in ascending hitpoint index and the centre is their mean. The result depends
// on the hitpoints, wg_size, iterations and seed only (not on `threads`, 0 = all cores). The
// Morton seeding is deterministic and does not use `seed` (it is recorded in the file's
// provenance; the evolutionary clustering, ga_clusters.h, starts from these clusters and draws its
// own random streams from its seed).
ClusterSet cluster_kmeans(const HitpointSet& h, int wg_size, int iterations, uint32_t seed,
                          int threads = 0);

// Grid clusters: per mesh, the uniform grid of eq. 7.1 over the mesh's hitpoints (box lo…hi of
// their positions, bin size d = max(longest extent / max_bins, R0) with R0 = h.radius0 if > 0,
// bins per axis clamp(ceil(extent/d), 1, max_bins), cell c = clamp(⌊(p − lo)/d⌋, 0, n − 1)).
// max_bins = 0 chooses per mesh: 64 bins, halved while the non-empty cells hold fewer than
// 2·wg_size hitpoints on average (bins much smaller than a work-group's worth of hitpoints make
// one padded cluster each: mostly fillers, thesis Table 7.5).
// Each non-empty cell's hitpoints (ascending index) are cut into chunks of at most wg_size, one
// cluster per chunk, clusters in cell offset order (x + y·nx + z·nx·ny). Centre = chunk mean.
ClusterSet cluster_grid(const HitpointSet& h, int wg_size, int max_bins);

// The grid header cluster_grid uses for the hitpoints of `mesh` (nx = ny = nz = 0 when it has
// none); reuses pf_mesh_grid (first_bin, first_photon = 0, photon_count = hitpoints of the mesh).
pf_mesh_grid hitpoint_mesh_grid(const HitpointSet& h, int mesh, int max_bins);

ClusterStats stats(const ClusterSet& c);

// "Hitpoint sorting" (thesis ch. 7.3, Table 7.5 "plain"): the hitpoint indices grouped by mesh
// (meshes ascending, indices ascending within a mesh), each mesh's run padded with fillers (−1)
// to a multiple of wg_size, so that no work-group straddles two meshes. Its size is Table 7.5's
// hitpoint count with fillers for hitpoint sorting.
std::vector<int32_t> mesh_sorted_order(const HitpointSet& h, int wg_size);

// "" when `c` is a valid clustering of `h`, else what is wrong (one phrase): clusters contiguous
// in order, counts > 0, padded_count = ceil(count/wg)·wg, fillers only at cluster tails, every
// hitpoint exactly once, every member of the cluster's mesh. Radii are not checked here.
std::string check_clusters(const ClusterSet& c, const HitpointSet& h);

// Recomputes every cluster's R from the current hitpoint radii (same rule, same centre and
// members). Cheap; call it after each PPM pass. Never grows R when hitpoint radii shrink.
void update_cluster_radii(ClusterSet& c, const HitpointSet& h);

// SHA-256 over width, height, hitpoint count and each hitpoint's position, pixel and mesh (not its
// radius or PPM state, which change between passes without invalidating the clusters).
std::string hitpoints_hash(const HitpointSet& h);

// Building blocks of the clustering methods (k-means and grid here, the evolutionary clustering of
// ga_clusters.h), so that every method makes its clusters by the same rules:
//   empty_cluster_set  a set without clusters bound to `h` (wg_size, method, scene_id, hitpoint
//                      count and hash);
//   cluster_centre_radius  centre = mean of the members (summed in double in the given order,
//                      rounded to float) and the shared radius R of the rule above;
//   append_cluster     appends one cluster of `members` (ascending hitpoint indices, all on `mesh`,
//                      n > 0) with that centre and radius, padded with fillers to a multiple of
//                      wg_size.
ClusterSet empty_cluster_set(const HitpointSet& h, int wg_size, const std::string& method);
void cluster_centre_radius(const HitpointSet& h, const int32_t* members, size_t n, float centre[3],
                           float* radius);
void append_cluster(ClusterSet& c, int mesh, const int32_t* members, size_t n, const HitpointSet& h);

// Writes clusters.h5; `extra`, when given, adds method-specific groups (the GA's /ga) before the
// file is committed.
void save_clusters(const ClusterSet& c, const std::string& path, const Provenance& prov,
                   const std::function<void(h5::Writer&)>& extra = {});
// Loads clusters.h5 and refuses (InputError, one line) a file made for another scene or other
// hitpoints than `h`, or one that is not a valid clustering of `h`.
ClusterSet load_clusters(const std::string& path, const HitpointSet& h);
// The checks of a clusters file that need no hitpoints (wg_size, method, finite centres, radii),
// which load_clusters applies after check_clusters and save_clusters to what it writes
// (validate.h written_check). InputError naming `path`.
void validate_cluster_values(const ClusterSet& c, const std::string& path);

}  // namespace pf
