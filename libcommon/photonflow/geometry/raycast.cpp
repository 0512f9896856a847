// raycast.cpp — closest-hit and any-hit ray casting over a baked scene (raycast.h).
//
// All three traversals test triangles with the Havel–Herout routine of intersect_shared.h (thesis
// eq. 4.3–4.7); the rope traversal is the shared compact rope loop (pf_kd_traverse_ropes_compact),
// which the OpenCL kernels can compile too, over a host copy of the tree (8-byte inner nodes,
// 64-byte leaf records) that visits the same leaves as pf_kd_traverse_ropes over pf_kd_node. Like
// the kernels (kernels/trace_common.h), the host substitutes its leaf test (PF_KD_CLEAF_TEST) by
// one that tests four triangles per SSE operation over a leaf-ordered copy of the planes: the same
// operations in the same order per lane, so the same bits as pf_kd_leaf_intersect. The stack
// traversal uses the same leaf test over the 8-byte nodes, or where the CPU has AVX one that
// tests eight triangles per operation (leaf_intersect_avx), with the same bits again.
//
// Alpha cut-outs (alpha_shared.h): in a scene with a masked material every traversal skips a hit
// whose pf_alpha_hit_cut_away is 1 where it would accept it (the ray goes on, closest and any
// hit alike). The test is compiled into separate instances (template kMasked) chosen once per
// ray, so a scene without masks runs the unchanged leaf loops.
//
// The packet leaf tests (SSE, AVX) and the switch between them are raycast_packets.h's; this
// file holds the host copy of the tree and the walks over it.
#include "photonflow/geometry/raycast.h"

#include <omp.h>

#include <atomic>
#include <cstring>
#include <memory>
#include <mutex>

#include "photonflow/foundations/shared_types.h"

// The compact rope loop's leaf test (PF_KD_CLEAF_TEST): a leaf record's aux is its first packet;
// `groups` is the RopeCtx (packets and alpha test) that cast passes as the hh argument.
static int pf_host_cleaf_test4(int first_packet, int count, const pf_hh_triangle* groups,
                               const float* o, const float* d, float tmin, int any_hit,
                               float* hit_t, pf_int* hit_tri, float* hit_u, float* hit_v);
#define PF_KD_CLEAF_TEST(leaf, lt, h, o, d, tmin, any, hit)                                     \
  ((void)(lt), pf_host_cleaf_test4((leaf)->aux, (leaf)->count, h, o, d, tmin, any, &(hit)->t,  \
                                   &(hit)->tri, &(hit)->u, &(hit)->v))

#include "photonflow/geometry/intersect_shared.h"
#include "photonflow/geometry/raycast_packets.h"
#include "photonflow/foundations/threads.h"

namespace pf {

namespace {

// Brute force: every triangle, the reference for tests.
bool traverse_brute(const Scene& scene, const float* o, const float* d, float tmin, bool any_hit,
                    pf_ray_hit& hit) {
  const int32_t n = int32_t(scene.hh.size());
  const AlphaTest alpha{&scene};
  const bool masked = scene.has_alpha_masks();
  for (int32_t i = 0; i < n; ++i) {
    float t, u, v;
    if (!pf_hh_intersect(&scene.hh[size_t(i)], o, d, tmin, hit.t, &t, &u, &v)) continue;
    if (t == hit.t && hit.tri >= 0) continue;  // equal t: the lower index (found first) wins
    if (masked && alpha.cut_away(i, u, v)) continue;
    hit = {t, i, u, v};
    if (any_hit) return true;
  }
  return hit.tri >= 0;
}

// Host-only copy of the kd-tree, derived from the shared arrays on first use
// (KdTree::host_cache): 8-byte nodes in depth-first preorder (the builder's order, so node i is
// nodes[i]; the left child of an inner node is i + 1) for the stack traversal, and the
// Havel–Herout planes of the leaf references in leaf order, transposed in packets of four, for
// the leaf test of both kd traversals (no leaf_tris indirection, one SSE test per four
// triangles). The stack traversal makes the same decisions on the same floats as over
// pf_kd_node; it touches 8 instead of 72 bytes per node.
struct CompactNode {
  uint32_t w0;  // inner: the split's float bits; leaf: first packet
  uint32_t w1;  // inner: right child << 2 | axis; leaf: triangle count << 2 | 3
};

static_assert(sizeof(pf_kd_cnode) == 8 && sizeof(pf_kd_cleaf) == 64, "compact rope layout");

struct HostKd {
  // What it was built from (rebuilt when any of these changed).
  const void* key_nodes;
  size_t n_nodes;
  const void* key_refs;
  size_t n_refs;
  const void* key_hh;
  size_t n_hh;
  std::vector<CompactNode> nodes;
  std::vector<HHPacket> packets;        // hh[leaf_tris[i]], leaf by leaf
  float root_lo[3], root_hi[3];         // the root box as pf_kd_enter_root widens it
  // The compact copy of the rope traversal (pf_kd_traverse_ropes_compact): 8-byte nodes (same
  // numbering as `nodes`), 64-byte leaf records (aux = first packet), the widened root box.
  std::vector<pf_kd_cnode> cnodes;
  std::vector<pf_kd_cleaf> cleaves;
  float root_box[6] = {0, 0, 0, 0, 0, 0};

  bool matches(const Scene& s) const {
    return key_nodes == s.kd.nodes.data() && n_nodes == s.kd.nodes.size() &&
           key_refs == s.kd.leaf_tris.data() && n_refs == s.kd.leaf_tris.size() &&
           key_hh == s.hh.data() && n_hh == s.hh.size();
  }
};

std::shared_ptr<const HostKd> make_host_kd(const Scene& s) {
  auto h = std::make_shared<HostKd>();
  const KdTree& kd = s.kd;
  h->key_nodes = kd.nodes.data();
  h->n_nodes = kd.nodes.size();
  h->key_refs = kd.leaf_tris.data();
  h->n_refs = kd.leaf_tris.size();
  h->key_hh = s.hh.data();
  h->n_hh = s.hh.size();
  h->nodes.resize(kd.nodes.size());
  // Depth-first preorder with the left child first: the builder's order (the identity), or a
  // renumbering for a valid tree stored in another order (validate_kdtree does not demand it).
  std::vector<int32_t> order, new_index(kd.nodes.size(), 0);
  order.reserve(kd.nodes.size());
  for (std::vector<int32_t> todo = {0}; !kd.nodes.empty() && !todo.empty();) {
    const int32_t i = todo.back();
    todo.pop_back();
    new_index[size_t(i)] = int32_t(order.size());
    order.push_back(i);
    const pf_kd_node& n = kd.nodes[size_t(i)];
    if (n.axis != PF_KD_LEAF) {
      todo.push_back(n.right);
      todo.push_back(n.left);
    }
  }
  for (size_t i = 0; i < order.size(); ++i) {
    const pf_kd_node& n = kd.nodes[size_t(order[i])];
    CompactNode& c = h->nodes[i];
    if (n.axis == PF_KD_LEAF) {
      c.w0 = uint32_t(h->packets.size());
      c.w1 = uint32_t(n.count) << 2 | 3u;
      for (int32_t j = 0; j < n.count; ++j) {
        if (j % 4 == 0) h->packets.push_back(HHPacket{});
        HHPacket& p = h->packets.back();
        const int32_t tri = kd.leaf_tris[size_t(n.first + j)];
        const pf_hh_triangle& t = s.hh[size_t(tri)];
        for (int k = 0; k < 4; ++k) {
          p.n[k][j % 4] = t.n[k];
          p.n1[k][j % 4] = t.n1[k];
          p.n2[k][j % 4] = t.n2[k];
        }
        p.tri[j % 4] = tri;
      }
    } else {
      std::memcpy(&c.w0, &n.split, 4);
      c.w1 = uint32_t(new_index[size_t(n.right)]) << 2 | uint32_t(n.axis);
    }
  }
  // The compact rope copy, in the same order; leaf records get their first packet.
  {
    size_t n_leaves = 0;
    for (const pf_kd_node& n : kd.nodes) n_leaves += n.axis == PF_KD_LEAF ? 1 : 0;
    h->cnodes.resize(kd.nodes.size());
    h->cleaves.resize(n_leaves);
    if (!kd.nodes.empty()) {
      pf_kd_compact_build(kd.nodes.data(), pf_int(kd.nodes.size()), order.data(),
                          new_index.data(), h->cnodes.data(), h->cleaves.data(), h->root_box);
      for (size_t i = 0; i < h->cnodes.size(); ++i)
        if ((h->cnodes[i].code & 3) == PF_KD_LEAF)
          h->cleaves[size_t(h->cnodes[i].code >> 2)].aux = int32_t(h->nodes[i].w0);
    }
  }
  if (!kd.nodes.empty()) {  // the same arithmetic as pf_kd_enter_root
    const pf_kd_node& root = kd.nodes[0];
    float ext = 0.0f;
    for (int k = 0; k < 3; ++k) {
      const float e = root.hi[k] - root.lo[k];
      ext = e > ext ? e : ext;
    }
    const float margin = PF_HH_EDGE_EPS * ext;
    for (int k = 0; k < 3; ++k) {
      h->root_lo[k] = root.lo[k] - margin;
      h->root_hi[k] = root.hi[k] + margin;
    }
  }
  return h;
}

// The scene's HostKd, built once (thread-safe; later calls are one atomic load and a key check).
const HostKd& host_kd(const Scene& s) {
  return s.kd.host_cache.get<HostKd>(s, [&] { return make_host_kd(s); });
}

// Classic front-to-back kd traversal with an explicit stack (pbrt's KdTreeAccel) over the compact
// copy: each node is visited with the parametric interval [t0, t1] of the ray inside it; the near
// child is entered first and the far child pushed with its interval.
// *end_leaf (closest hits): the leaf record whose interval holds the hit, for Ray::leaf; −1
// without a hit or with any_hit.
template <bool kMasked>
bool traverse_stack(const HostKd& kd, const float* o, const float* d, float tmin, bool any_hit,
                    pf_ray_hit& hit, const AlphaTest* alpha, int32_t* end_leaf) {
  *end_leaf = -1;
  if (kd.nodes.empty()) return false;
  const float inv_d[3] = {1.f / d[0], 1.f / d[1], 1.f / d[2]};
  float t0, t1;
  if (!pf_ray_box(kd.root_lo, kd.root_hi, o, d, inv_d, tmin, hit.t, &t0, &t1)) return false;
  struct Todo {
    uint32_t node;
    float t0, t1;
  };
  Todo stack[kKdMaxDepth + 1];
  int top = 0;
  uint32_t node = 0;
  const CompactNode* nodes = kd.nodes.data();
  pf_ray_hit best = hit;
  const RayLanes r(o, d);
  const bool avx = kd_leaf_avx().load(std::memory_order_relaxed);
  (void)avx;
  uint32_t end_node = ~0u;  // the last leaf whose interval held the closest hit so far
  for (;;) {
    if (best.t < t0) break;  // closest hit lies before this node (stack intervals only grow)
    const CompactNode n = nodes[node];
    const uint32_t a = n.w1 & 3u;
    if (a != 3u) {
      float split;
      std::memcpy(&split, &n.w0, 4);
      // The child holding the ray's origin side is near; on the plane, the side it moves into.
      const bool left_first = o[a] < split || (o[a] == split && d[a] <= 0.f);
      const uint32_t near = left_first ? node + 1 : n.w1 >> 2;
      const uint32_t far = left_first ? n.w1 >> 2 : node + 1;
      const float t_plane = d[a] != 0.f ? (split - o[a]) * inv_d[a] : INFINITY;
      if (t_plane > t1 || t_plane <= 0.f) {
        node = near;  // never reaches the plane within the node (or moves away from it)
      } else if (t_plane < t0) {
        node = far;  // crossed the plane before entering the node
      } else {
        stack[top++] = {far, t_plane, t1};
        node = near;
        t1 = t_plane;
      }
      continue;
    }
    // Leaf: pf_kd_leaf_intersect's loop, four (SSE) or eight (AVX) triangles at a time.
    const HHPacket* const leaf = kd.packets.data() + n.w0;
#ifdef PF_HAVE_AVX_LEAF
    // A leaf of up to four triangles is one packet: the inlined SSE test, no call.
    const uint32_t count = n.w1 >> 2;
    const bool hit_now =
        avx && count > 4 ? leaf_intersect_avx<kMasked>(leaf, count, r, tmin, any_hit, best, alpha)
                         : leaf_intersect<kMasked>(leaf, count, r, tmin, any_hit, best, alpha);
#else
    const bool hit_now = leaf_intersect<kMasked>(leaf, n.w1 >> 2, r, tmin, any_hit, best, alpha);
#endif
    if (hit_now) {
      hit = best;
      return true;
    }
    if (best.t <= t1) end_node = node;
    if (top == 0) break;
    --top;
    node = stack[top].node;
    t0 = stack[top].t0;
    t1 = stack[top].t1;
  }
  hit = best;
  if (hit.tri >= 0 && end_node != ~0u) *end_leaf = kd.cnodes[end_node].code >> 2;
  return hit.tri >= 0;
}

// What the rope traversal passes as its hh argument to PF_KD_CLEAF_TEST: the scene's packets and,
// in a masked scene, the alpha test (nullptr otherwise).
struct RopeCtx {
  const HHPacket* packets;
  const AlphaTest* alpha;
  const RayLanes* lanes;  // the ray's (origin, direction and their magnitudes), for every leaf
};

// The shared compact rope loop over the host copy, entered at the root (start_leaf < 0) or in
// start_leaf when its box holds o.
inline bool traverse_ropes(const HostKd& h, const float* o, const float* d, float tmin,
                           bool any_hit, pf_ray_hit& hit, const AlphaTest* alpha,
                           int32_t start_leaf, int32_t* end_leaf) {
  const RayLanes lanes(o, d);
  const RopeCtx ctx{h.packets.data(), alpha, &lanes};
  return pf_kd_traverse_ropes_compact_from(
             h.cnodes.data(), pf_int(h.cnodes.size()), h.cleaves.data(), h.root_box, nullptr,
             reinterpret_cast<const pf_hh_triangle*>(&ctx), o, d, tmin, any_hit, &hit,
             start_leaf, end_leaf) != 0;
}

// The default traversal: from a known leaf along the ropes when its box holds the origin (a
// secondary ray, Ray::leaf), else the stack traversal from the root; with the alpha test where
// the scene has masks (alpha != nullptr). Both give the same hits (raycast.h); *end_leaf as
// Hit::leaf.
inline bool traverse_default(const HostKd& kd, const float* o, const float* d, float tmin,
                             bool any_hit, int32_t start_leaf, pf_ray_hit& hit,
                             const AlphaTest* alpha, int32_t* end_leaf) {
  // pf_kd_traverse_ropes_compact_from's own test, here to choose the stack walk otherwise
  if (start_leaf >= 0 && size_t(start_leaf) < kd.cleaves.size()) {
    const float* b = kd.cleaves[size_t(start_leaf)].box;
    if (pf_point_in_box(b, b + 3, o))
      return traverse_ropes(kd, o, d, tmin, any_hit, hit, alpha, start_leaf, end_leaf);
  }
  return alpha ? traverse_stack<true>(kd, o, d, tmin, any_hit, hit, alpha, end_leaf)
               : traverse_stack<false>(kd, o, d, tmin, any_hit, hit, nullptr, end_leaf);
}

bool cast(const Scene& scene, const Ray& ray, bool any_hit, Traversal trav, pf_ray_hit& hit,
          int32_t* end_leaf) {
  const float o[3] = {ray.o.x, ray.o.y, ray.o.z};
  const float d[3] = {ray.d.x, ray.d.y, ray.d.z};
  hit = {ray.tmax, -1, 0.f, 0.f};
  *end_leaf = -1;
  const AlphaTest at{&scene};
  const AlphaTest* alpha = scene.has_alpha_masks() ? &at : nullptr;
  switch (trav) {
    case Traversal::Ropes:
      // The shared rope loop over the compact copy (the same bits as pf_kd_traverse_ropes over
      // the pf_kd_node array, tested), always from the root; the packets travel in the hh
      // argument (PF_KD_CLEAF_TEST).
      return traverse_ropes(host_kd(scene), o, d, ray.tmin, any_hit, hit, alpha, -1, end_leaf);
    case Traversal::Stack:
      return traverse_default(host_kd(scene), o, d, ray.tmin, any_hit, ray.leaf, hit, alpha,
                              end_leaf);
    case Traversal::Brute:
      return traverse_brute(scene, o, d, ray.tmin, any_hit, hit);
  }
  return false;
}

Hit to_hit(const pf_ray_hit& h, int32_t leaf) {
  Hit hit;
  hit.t = h.t;
  hit.tri = h.tri;
  hit.u = h.u;
  hit.v = h.v;
  hit.leaf = leaf;
  return hit;
}

}  // namespace

RayCaster::RayCaster(const Scene& scene)
    : kd_(&host_kd(scene)), alpha_scene_(scene.has_alpha_masks() ? &scene : nullptr) {}

bool RayCaster::closest(const Ray& ray, Hit& hit) const {
  const float o[3] = {ray.o.x, ray.o.y, ray.o.z};
  const float d[3] = {ray.d.x, ray.d.y, ray.d.z};
  pf_ray_hit h{ray.tmax, -1, 0.f, 0.f};
  const AlphaTest at{alpha_scene_};
  int32_t leaf;
  const bool found = traverse_default(*static_cast<const HostKd*>(kd_), o, d, ray.tmin, false,
                                      ray.leaf, h, alpha_scene_ ? &at : nullptr, &leaf);
  hit = found ? to_hit(h, leaf) : Hit{};
  return found;
}

bool RayCaster::any(const Ray& ray) const {
  const float o[3] = {ray.o.x, ray.o.y, ray.o.z};
  const float d[3] = {ray.d.x, ray.d.y, ray.d.z};
  pf_ray_hit h{ray.tmax, -1, 0.f, 0.f};
  const AlphaTest at{alpha_scene_};
  int32_t leaf;
  return traverse_default(*static_cast<const HostKd*>(kd_), o, d, ray.tmin, true, ray.leaf, h,
                          alpha_scene_ ? &at : nullptr, &leaf);
}

int32_t RayCaster::leaf_at(const Vec3& p) const {
  const HostKd& kd = *static_cast<const HostKd*>(kd_);
  const float q[3] = {p.x, p.y, p.z};
  if (kd.cnodes.empty() || !pf_point_in_box(kd.root_box, kd.root_box + 3, q)) return -1;
  uint32_t node = 0;
  pf_kd_cnode n = kd.cnodes[0];
  while ((n.code & 3) != PF_KD_LEAF) {
    node = q[n.code & 3] < n.split ? node + 1 : uint32_t(n.code) >> 2;
    n = kd.cnodes[node];
  }
  return n.code >> 2;
}

const char* traversal_name(Traversal t) {
  switch (t) {
    case Traversal::Ropes: return "ropes";
    case Traversal::Stack: return "stack";
    case Traversal::Brute: return "brute";
  }
  return "?";
}

bool intersect_closest(const Scene& scene, const Ray& ray, Hit& hit, Traversal trav) {
  pf_ray_hit h;
  int32_t leaf;
  const bool found = cast(scene, ray, false, trav, h, &leaf);
  hit = found ? to_hit(h, leaf) : Hit{};
  return found;
}

bool intersect_any(const Scene& scene, const Ray& ray, Traversal trav) {
  pf_ray_hit h;
  int32_t leaf;
  return cast(scene, ray, true, trav, h, &leaf);
}

void intersect_closest_batch(const Scene& scene, const std::vector<Ray>& rays,
                             std::vector<Hit>& hits, Traversal trav, int threads) {
  hits.resize(rays.size());
  const int64_t n = int64_t(rays.size());
#pragma omp parallel for schedule(dynamic, 256) num_threads(worker_threads(threads))
  for (int64_t i = 0; i < n; ++i) intersect_closest(scene, rays[size_t(i)], hits[size_t(i)], trav);
}

void intersect_any_batch(const Scene& scene, const std::vector<Ray>& rays,
                         std::vector<uint8_t>& occluded, Traversal trav, int threads) {
  occluded.resize(rays.size());
  const int64_t n = int64_t(rays.size());
#pragma omp parallel for schedule(dynamic, 256) num_threads(worker_threads(threads))
  for (int64_t i = 0; i < n; ++i)
    occluded[size_t(i)] = intersect_any(scene, rays[size_t(i)], trav) ? 1 : 0;
}

}  // namespace pf

static int pf_host_cleaf_test4(int first_packet, int count, const pf_hh_triangle* groups,
                               const float* o, const float* d, float tmin, int any_hit,
                               float* hit_t, pf_int* hit_tri, float* hit_u, float* hit_v) {
  const auto* ctx = reinterpret_cast<const pf::RopeCtx*>(groups);
  (void)o;  // the ray traverse_ropes set ctx->lanes up for, once
  (void)d;
  const pf::HHPacket* p = ctx->packets + first_packet;
  pf_ray_hit best = {*hit_t, *hit_tri, *hit_u, *hit_v};
  const bool stop = pf::leaf_intersect_packets(p, uint32_t(count), *ctx->lanes, tmin,
                                               any_hit != 0, best, ctx->alpha);
  *hit_t = best.t;
  *hit_tri = best.tri;
  *hit_u = best.u;
  *hit_v = best.v;
  return stop ? 1 : 0;
}
