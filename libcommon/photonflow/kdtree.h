// kdtree.h — SAH kd-tree with ropes over the scene's triangles (thesis ch. 4.3, eq. 4.8;
// Wald & Havran 2006 for the O(N log N) build; Popov et al. 2007 for ropes).
//
// The tree is flat (pf_kd_node array + leaf triangle list) so that it is written to scene.h5 and
// uploaded to an OpenCL device unchanged. Node 0 is the root.
#pragma once
#include <cstdint>
#include <vector>

#include "photonflow/shared_types.h"
#include "photonflow/vec.h"

namespace pf {

struct KdBuildParams {
  float cost_traversal = 1.0f;  // C_ts of eq. 4.8 (cost of one traversal step)
  float cost_intersect = 1.5f;  // C_L, C_R weight per triangle of eq. 4.8
  float empty_bonus = 0.2f;     // SAH cost reduction for splits that cut off empty space
  int max_depth = 0;            // 0 = automatic: 8 + 1.3·log2(N)
  int max_leaf_size = 2;        // never split nodes with this many triangles or fewer
  int threads = 0;              // 0 = all cores; the tree is identical for any thread count
};

struct KdTree {
  std::vector<pf_kd_node> nodes;  // nodes[0] is the root
  std::vector<int32_t> leaf_tris; // triangle indices referenced by leaves
  Bounds bounds;                  // box of the root
  KdBuildParams params;
  double build_seconds = 0;
  int depth = 0;                  // deepest leaf
  bool empty() const { return nodes.empty(); }
};

// Builds the tree with ropes. Degenerate (zero-area) triangles must have been removed before.
// Deterministic: the same triangles and parameters give the same arrays.
KdTree build_kdtree(const std::vector<pf_triangle>& tris, const KdBuildParams& params);

// Structural check used by tests and by scene loading: child/leaf indices in range, leaf ranges
// inside leaf_tris, ropes pointing at nodes whose boxes touch the face. Returns "" when valid,
// else the first problem found.
std::string validate_kdtree(const KdTree& tree, size_t triangle_count);

}  // namespace pf
