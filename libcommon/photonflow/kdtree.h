// kdtree.h — SAH kd-tree with ropes over the scene's triangles (thesis ch. 4.3, eq. 4.8;
// Wald & Havran 2006 for the O(N log N) build; Popov et al. 2007 for ropes).
//
// The tree is flat (pf_kd_node array + leaf triangle list) so that it is written to scene.h5 and
// uploaded to an OpenCL device unchanged. Node 0 is the root; nodes are stored in depth-first
// preorder, so an inner node's left child is the next node and its right child follows the whole
// left subtree.
//
// Build: nodes with many triangles are split by binned SAH (kKdBins candidate planes per axis);
// below kKdExactMaxTriangles the exact SAH over all triangle bounds is found by a sweep over events
// kept sorted from parent to child (Wald & Havran 2006). Triangles that straddle a split are
// clipped to each child's box as polygons ("split clipping"), so every reference's bounds are those
// of the part of the triangle inside the node. A triangle that only touches a split plane (with a
// vertex or an edge) is kept on both sides: splits sit at vertex coordinates, and a ray through
// such a vertex is caught by the widened triangle test (PF_HH_EDGE_EPS, intersect_shared.h) at a
// point a rounding error away on either side. Subtrees are built in parallel and spliced in a
// fixed order: the arrays are the same bytes for any thread count.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "photonflow/shared_types.h"
#include "photonflow/vec.h"

namespace pf {

// Hard limit of the tree depth (the stack traversal's stack size).
constexpr int kKdMaxDepth = 64;
// Candidate planes per axis of the binned SAH.
constexpr int kKdBins = 64;
// Nodes with fewer triangle references than this are split by the exact event sweep.
constexpr size_t kKdExactMaxTriangles = 1024;

// Defaults measured with bench/bench_raycast.cpp: one traversal step of the rope loop (descent,
// exit face, cache miss on the node) costs about three Havel–Herout tests, and larger ratios
// C_i/C_ts only deepen the tree (slower build, more memory) without faster rays.
struct KdBuildParams {
  float cost_traversal = 3.0f;  // C_ts of eq. 4.8 (cost of one traversal step)
  float cost_intersect = 1.0f;  // C_L, C_R weight per triangle of eq. 4.8
  float empty_bonus = 0.5f;     // fraction of the SAH cost saved by splits that cut off empty space
  int max_depth = 0;            // 0 = automatic: 8 + 1.3·log2(N); at most kKdMaxDepth
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
  // Bytes of the two arrays (what a device upload needs).
  size_t memory_bytes() const {
    return nodes.size() * sizeof(pf_kd_node) + leaf_tris.size() * sizeof(int32_t);
  }
};

// Builds the tree with ropes. Degenerate (zero-area) triangles must have been removed before.
// Deterministic: the same triangles and parameters give the same arrays, for any thread count.
// No triangles give a single empty leaf.
KdTree build_kdtree(const std::vector<pf_triangle>& tris, const KdBuildParams& params);

// Structural check used by tests and by scene loading: child/leaf indices in range, every node
// reached once, children's boxes the halves of their parent's, leaf ranges inside leaf_tris,
// triangle indices below triangle_count, ropes pointing at nodes whose boxes cover the face (or −1
// exactly when the face lies on the root box). Returns "" when valid, else the first problem found.
std::string validate_kdtree(const KdTree& tree, size_t triangle_count);

}  // namespace pf
