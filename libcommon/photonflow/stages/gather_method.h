// gather_method.h — the hitpoint-illumination methods (`illuminate --method`, `render --method`):
// the CPU gathers and the thesis's OpenCL variants (ch. 7.3, Table 7.3) plus a hashed grid.
//
// Every method gathers exactly the same photons for every hitpoint (illuminate.h's rule: same
// mesh, arrived on the hitpoint's side, not a direct photon when direct light came from shadow
// rays, pf_ppm_in_radius(pf_ppm_dist2(x, x_p), R)); they differ only in how they find them and in
// the order the f_r·Φ terms are summed (double precision where the device has it), so images
// agree with naive's to float rounding. Photon counts M, hence radii (eq. 3.14–3.16), agree
// exactly.
//
// These methods serve PPM's fixed hitpoints (render --estimator ppm, illuminate). SPPM and PPPM
// (sppm.h) trace new visible points every pass: their CPU gather is `grid` (gather_site, the grid
// rebuilt from each pass's photons as for PPM), SPPM's OpenCL gather is `hash-grid` with the
// per-pixel state resident (DevicePpmState::sppm_pass), and render refuses any other --method with
// them. The clustered methods and the GA's precomputed clusters (cluster stage) group FIXED
// hitpoints: clusters of one pass's visible points would have to be made again every pass (k-means
// of an eye pass costs about a whole SPPM pass on 2 cores, docs/BENCHMARKS.md "Hitpoint clusters:
// the `cluster` stage on the CPU", to save part of one gather), so they are not offered for the
// moving estimators.
//
//   method               backend  photons read by a hitpoint                 thesis Table 7.3
//   -------------------  -------  -----------------------------------------  ----------------
//   grid                 cpu      bins of its sphere in the mesh's grid      (CPU, FLANN row)
//   flann                cpu      FLANN kd-tree radius search                CPU version
//   naive                opencl   all photons of the pass                    naive
//   local-memory         opencl   all, staged by the work-group in tiles     local memory
//   photon-sort          opencl   its mesh's photons (per-mesh arrays)       photon sorting
//   hitpoint-sort        opencl   + hitpoints grouped per mesh, fillers      hitpoint sorting
//   hitpoint-sort-local  opencl   + the mesh's photons staged in tiles       + local memory
//   manual-distance      opencl   same, squared distance by hand             manual distance
//   kmeans-clusters      opencl   + work-group = k-means cluster; tiles      k-means clusters
//                                 keep photons inside the cluster sphere
//   grid-kmeans          opencl   cluster sphere's bins of the mesh grid     grid + k-means
//   grid-gridclusters    opencl   same with clusters made from grid bins     grid + grid clust.
//   hash-grid            opencl   the cells of its sphere's box in one       (beyond the thesis)
//                                 hashed grid over all meshes (cells 2·max R:
//                                 ≤ 2 per axis), one work-item per hitpoint;
//                                 photon keys tested 4 per vector, eq. 3.14–
//                                 3.18 in the same kernel, the state can stay
//                                 on the device between passes (cl_gather.h)
//
// The methods before manual-distance test distances with OpenCL's built-in distance() as the
// thesis's kernels did, guarded by the exact squared-distance rule so that they select the same
// photons; manual-distance and later use the squared distance only.
#pragma once
#include <string>
#include <vector>

namespace pf {

enum class GatherMethod {
  Grid,
  Flann,
  Naive,
  LocalMemory,
  PhotonSort,
  HitpointSort,
  HitpointSortLocal,
  ManualDistance,
  KmeansClusters,
  GridKmeans,
  GridGridClusters,
  HashGrid,
};

// What a method needs.
struct GatherMethodInfo {
  GatherMethod method;
  const char* name;      // the --method spelling
  bool device;           // true: OpenCL backend; false: CPU backend
  const char* clusters;  // cluster method it reads ("kmeans", "grid"), nullptr when none
  const char* summary;   // one line for --help
};

// All methods, in the order of the table above (thesis Table 7.3 order for the device ones).
const std::vector<GatherMethodInfo>& gather_methods();
const GatherMethodInfo& gather_method_info(GatherMethod m);
const char* gather_method_name(GatherMethod m);
// Parses a --method value; InputError listing the choices otherwise.
GatherMethod parse_gather_method(const std::string& name);
// "grid | flann | naive | ..." for --help.
std::string gather_method_choices();
// The method a backend uses when --method is not given: grid on the CPU, hash-grid on OpenCL (the
// fastest on PoCL in docs/BENCHMARKS.md, and it needs no clusters).
GatherMethod default_gather_method(bool device);

}  // namespace pf
