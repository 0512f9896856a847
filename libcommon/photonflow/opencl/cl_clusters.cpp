// cl_clusters.cpp — the clusters of the clustered device methods (kmeans-clusters, grid-kmeans,
// grid-gridclusters): which cluster set a method reads, and a set on the device (the hitpoint
// order, the work-group → cluster table, the clusters), shared by ppm_pass and the GA's timer.
#include "photonflow/opencl/cl_clusters.h"

#include <stdexcept>
#include <string>
#include <vector>

#include "photonflow/foundations/error.h"
#include "photonflow/opencl/cl_gather_internal.h"
#include "photonflow/stages/clusters.h"
#include "photonflow/stages/illuminate.h"

namespace pf {

namespace {

// Work-group → cluster table of a cluster set (work-group g covers order[g·wg, (g+1)·wg)).
std::vector<cl_int> group_clusters(const ClusterSet& cs) {
  std::vector<cl_int> t(cs.order.size() / size_t(cs.wg_size));
  for (size_t c = 0; c < cs.clusters.size(); ++c) {
    const pf_cluster& k = cs.clusters[c];
    for (int g = k.first / cs.wg_size; g < (k.first + k.padded_count) / cs.wg_size; ++g)
      t[size_t(g)] = cl_int(c);
  }
  return t;
}

}  // namespace

namespace detail {

DeviceClusters upload_clusters(ClContext& dev, const ClusterSet& cs, const std::string& ns) {
  DeviceClusters d;
  d.wg = size_t(cs.wg_size);
  d.items = cs.order.size();
  const std::vector<cl_int> groups = group_clusters(cs);
  d.order = &dev.scratch(ns + ".order", cs.order.size() * sizeof(cl_int));
  d.groups = &dev.scratch(ns + ".group_cluster", groups.size() * sizeof(cl_int));
  d.clusters = &dev.scratch(ns + ".clusters", cs.clusters.size() * sizeof(pf_cluster));
  dev.write(*d.order, cs.order.size() * sizeof(cl_int), cs.order.data());
  dev.write(*d.groups, groups.size() * sizeof(cl_int), groups.data());
  dev.write(*d.clusters, cs.clusters.size() * sizeof(pf_cluster), cs.clusters.data());
  return d;
}

void check_cluster_count(const ClusterSet& cs, size_t hitpoints) {
  if (cs.hitpoint_count != hitpoints)
    throw input_error("", "the clusters were made for " + std::to_string(cs.hitpoint_count) +
                              " hitpoints, the state has " + std::to_string(hitpoints),
                      "run the cluster stage on these hitpoints");
}

}  // namespace detail

ClusterSet clusters_for_method(GatherMethod m, const HitpointSet& h, int wg_size,
                               const PpmOptions& opt) {
  const char* kind = gather_method_info(m).clusters;
  if (!kind) throw std::invalid_argument(std::string("method ") + gather_method_name(m) + " reads no clusters");
  return std::string(kind) == "kmeans" ? cluster_kmeans(h, wg_size, opt.cluster_iterations, 1, opt.threads)
                                       : cluster_grid(h, wg_size, 0);
}

}  // namespace pf
