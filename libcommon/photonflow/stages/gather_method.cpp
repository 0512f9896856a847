// The hitpoint-illumination methods: see gather_method.h.
#include "photonflow/stages/gather_method.h"

#include "photonflow/foundations/error.h"

namespace pf {

const std::vector<GatherMethodInfo>& gather_methods() {
  static const std::vector<GatherMethodInfo> table = {
      {GatherMethod::Grid, "grid", false, nullptr, "CPU: per-mesh uniform grid (eq. 7.1)"},
      {GatherMethod::Flann, "flann", false, nullptr, "CPU: FLANN kd-tree radius search"},
      {GatherMethod::Naive, "naive", true, nullptr, "OpenCL: every hitpoint reads every photon"},
      {GatherMethod::LocalMemory, "local-memory", true, nullptr,
       "OpenCL: photons staged through local memory in tiles"},
      {GatherMethod::PhotonSort, "photon-sort", true, nullptr,
       "OpenCL: photons sorted into per-mesh arrays"},
      {GatherMethod::HitpointSort, "hitpoint-sort", true, nullptr,
       "OpenCL: + hitpoints grouped per mesh, padded with fillers"},
      {GatherMethod::HitpointSortLocal, "hitpoint-sort-local", true, nullptr,
       "OpenCL: + the mesh's photons staged through local memory"},
      {GatherMethod::ManualDistance, "manual-distance", true, nullptr,
       "OpenCL: + squared distance by hand instead of distance()"},
      {GatherMethod::KmeansClusters, "kmeans-clusters", true, "kmeans",
       "OpenCL: work-group = k-means cluster, photons culled by its sphere"},
      {GatherMethod::GridKmeans, "grid-kmeans", true, "kmeans",
       "OpenCL: k-means clusters read their sphere's bins of the mesh grid"},
      {GatherMethod::GridGridClusters, "grid-gridclusters", true, "grid",
       "OpenCL: clusters made from grid bins read their sphere's bins"},
      {GatherMethod::HashGrid, "hash-grid", true, nullptr,
       "OpenCL: one hashed grid over all meshes, <= 8 cells per hitpoint"},
  };
  return table;
}

const GatherMethodInfo& gather_method_info(GatherMethod m) {
  for (const GatherMethodInfo& i : gather_methods())
    if (i.method == m) return i;
  return gather_methods().front();  // unreachable: the table lists every enumerator
}

const char* gather_method_name(GatherMethod m) { return gather_method_info(m).name; }

std::string gather_method_choices() {
  std::string s;
  for (const GatherMethodInfo& i : gather_methods()) s += (s.empty() ? "" : " | ") + std::string(i.name);
  return s;
}

GatherMethod parse_gather_method(const std::string& name) {
  for (const GatherMethodInfo& i : gather_methods())
    if (name == i.name) return i.method;
  throw input_error("", "--method must be one of " + gather_method_choices() + ", got '" + name + "'");
}

GatherMethod default_gather_method(bool device) {
  return device ? GatherMethod::HashGrid : GatherMethod::Grid;
}

}  // namespace pf
