// cl_clusters.h — the clusters a clustered device method reads, made the way the cluster stage
// makes them, so that ppm_pass without clusters and the cluster stage agree.
#pragma once
#include "photonflow/stages/gather_method.h"

namespace pf {

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

}  // namespace pf
