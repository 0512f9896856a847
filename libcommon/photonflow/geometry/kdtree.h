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
// vertex or an edge) stays on its own side; rays through such a vertex are caught because the
// widened triangle test (PF_HH_ROUNDING, intersect_shared.h) accepts hits anywhere along the ray
// and both traversals visit the leaves on both sides of a leaf corner the ray passes exactly
// through (tested by aiming rays at every vertex, raycast_test.cpp). Subtrees are built in
// parallel and spliced in a fixed order: the arrays are the same bytes for any thread count.
#pragma once
#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "photonflow/foundations/shared_types.h"
#include "photonflow/foundations/vec.h"

namespace pf {

// Hard limit of the tree depth (the stack traversal's stack size).
constexpr int kKdMaxDepth = 64;
// Candidate planes per axis of the binned SAH.
constexpr int kKdBins = 64;
// Nodes with fewer triangle references than this are split by the exact event sweep.
constexpr size_t kKdExactMaxTriangles = 1024;

// Defaults measured by rendering (docs/BENCHMARKS.md "Walks that start in the origin's leaf, and
// kd-tree costs for the renderer"): with the leaf test taking eight triangles per AVX operation
// and secondary rays starting their walk in their origin's leaf (raycast.h), a traversal step
// costs about ten Havel–Herout tests and empty space is cut off less eagerly: C_ts 10, empty
// bonus 0.2 make a tree of a quarter of the nodes on the 200k-triangle box and render it faster
// (CPU and OpenCL) than C_ts 3, bonus 0.5 (what bench/bench_raycast.cpp's single random rays
// favour); the small scenes render as fast with either. Larger ratios C_i/C_ts (up to pbrt's 80)
// deepen the tree (several times the nodes, slower build) for fewer triangle tests and no faster
// rays.
struct KdBuildParams {
  float cost_traversal = 10.0f;  // C_ts of eq. 4.8 (cost of one traversal step)
  float cost_intersect = 1.0f;   // C_L, C_R weight per triangle of eq. 4.8
  float empty_bonus = 0.2f;      // fraction of the SAH cost saved by cutting off empty space
  int max_depth = 0;            // 0 = automatic: 8 + 1.3·log2(N); at most kKdMaxDepth
  int max_leaf_size = 2;        // never split nodes with this many triangles or fewer
  int threads = 0;              // 0 = all cores; the tree is identical for any thread count
};

// Slot for derived, host-only traversal data (raycast.cpp: compact 8-byte nodes for the stack
// traversal, 8-byte nodes plus 64-byte leaf records for the compact rope loop
// pf_kd_traverse_ropes_compact of intersect_shared.h, and the triangle planes in leaf order), built
// from the arrays on first use. It is no part of the tree's bytes or
// of scene.h5: copies and assignments start without it. raycast.cpp rebuilds it when the arrays
// it was built from were replaced (other data pointers or sizes); arrays changed in place after
// rays were cast need a fresh tree (assign the KdTree). Scene::gather_area_cache holds the
// surface gather area's hierarchy (estimators/gather_area.h) the same way.
class KdHostCache {
 public:
  KdHostCache() = default;
  KdHostCache(const KdHostCache&) {}
  KdHostCache& operator=(const KdHostCache&) {
    current.store(nullptr, std::memory_order_release);
    return *this;
  }
  // The cached T while T::matches(key) holds, else a new one from make() (a shared_ptr<const T>),
  // installed under the lock. Thread-safe; later calls are an atomic load and the key check.
  template <class T, class Key, class Make>
  const T& get(const Key& key, Make&& make) const {
    auto* t = static_cast<const T*>(current.load(std::memory_order_acquire));
    if (t && t->matches(key)) return *t;
    std::lock_guard<std::mutex> lock(mutex);
    t = static_cast<const T*>(current.load(std::memory_order_acquire));
    if (t && t->matches(key)) return *t;
    std::shared_ptr<const T> fresh = make();
    owned.push_back(fresh);  // earlier versions stay alive for threads still using them
    current.store(fresh.get(), std::memory_order_release);
    return *fresh;
  }
  // The cached object (nullptr if none) and the lock and owner list used to install one.
  mutable std::atomic<const void*> current{nullptr};
  mutable std::mutex mutex;
  mutable std::vector<std::shared_ptr<const void>> owned;  // freed with the tree
};

struct KdTree {
  std::vector<pf_kd_node> nodes;  // nodes[0] is the root
  std::vector<int32_t> leaf_tris; // triangle indices referenced by leaves
  Bounds bounds;                  // box of the root
  KdBuildParams params;
  double build_seconds = 0;
  int depth = 0;                  // deepest leaf
  KdHostCache host_cache;         // derived host traversal data (raycast.cpp), not serialised
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
