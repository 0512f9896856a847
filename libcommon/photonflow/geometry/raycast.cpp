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
#include "photonflow/geometry/raycast.h"

#include <omp.h>

#include <atomic>
#include <cstring>
#include <memory>
#ifdef __SSE2__
#include <immintrin.h>
#endif
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
#include "photonflow/foundations/threads.h"

namespace pf {

namespace {

// The any-hit test of a masked scene (alpha_shared.h) over the scene's own tables.
struct AlphaTest {
  const Scene* s;
  bool cut_away(int32_t tri, float u, float v) const {
    return pf_alpha_hit_cut_away(s->material_alpha.data(), s->triangles.data(),
                                 s->textures.data(), s->texels.data(),
                                 s->uvs.empty() ? nullptr : s->uvs[0].uv, tri, u, v) != 0;
  }
};

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

// Four triangles' Havel–Herout planes in structure-of-arrays form ([component][lane]), tested
// together with SSE. A leaf's triangles fill consecutive packets in leaf order; unused lanes hold
// zero planes (det = 0, never a hit).
struct alignas(16) HHPacket {
  float n[4][4];
  float n1[4][4];
  float n2[4][4];
  int32_t tri[4];
};
static_assert(sizeof(HHPacket) == 208, "HHPacket layout (bench_raycast reports its memory)");
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

// A ray's origin and direction broadcast to four lanes.
// (With the magnitudes max_k |o_k| and max_k |d_k| of the test's slack, pf_hh_magnitude.)
struct RayLanes {
  const float* o;
  const float* d;
  float ao, ad;
#ifdef __SSE2__
  __m128 o4[3], d4[3], ao4, ad4;
#endif
  RayLanes(const float* o_, const float* d_)
      : o(o_), d(d_), ao(pf_hh_magnitude(o_)), ad(pf_hh_magnitude(d_)) {
#ifdef __SSE2__
    for (int k = 0; k < 3; ++k) {
      o4[k] = _mm_set1_ps(o[k]);
      d4[k] = _mm_set1_ps(d[k]);
    }
    ao4 = _mm_set1_ps(ao);
    ad4 = _mm_set1_ps(ad);
#endif
  }
};

// A packet test's lane values (st, |det|, tp, det, su, sv of pf_hh_intersect, scaled by det's
// sign), stored lane by lane.
struct Lanes {
  const float *st, *adet, *tp, *det, *su, *sv;
};

// The lanes of `mask` that passed a packet test, finished one by one in leaf order, each against
// the tmax of that moment (pf_hh_intersect's last steps; tri_of(l) is lane l's triangle); with
// kMasked skipping cut-away points (alpha->cut_away). Returns true at the first hit with any_hit.
template <bool kMasked, class TriOf>
inline bool finish_lanes(int mask, const Lanes& a, TriOf&& tri_of, float tmin, bool any_hit,
                         pf_ray_hit& best, const AlphaTest* alpha) {
  for (; mask; mask &= mask - 1) {
    const int l = __builtin_ctz(unsigned(mask));
    if (!(a.st[l] <= a.adet[l] * best.t)) continue;  // tmax has shrunk within the packet
    const float t = a.tp[l] / a.det[l];
    if (!(t > tmin && t <= best.t)) continue;
    const int32_t tri = tri_of(l);
    if (t == best.t && best.tri >= 0 && tri > best.tri) continue;
    const float u = a.su[l] / a.adet[l], v = a.sv[l] / a.adet[l];
    if (kMasked && alpha->cut_away(tri, u, v)) continue;
    best = {t, tri, u, v};
    if (any_hit) return true;
  }
  return false;
}

// Tests the `count` triangles of a leaf stored from `p` on, keeping the closest hit in `best`
// (best.t is the current tmax); with any_hit returns true at the first hit. Bit for bit the result
// of pf_kd_leaf_intersect over the same triangles in the same order: every lane evaluates
// pf_hh_intersect's expressions in the same order (no contraction: baseline x86-64 has no FMA),
// and the lanes that pass are then finished one by one in leaf order, each against the tmax of
// that moment, exactly as the scalar loop does.
template <bool kMasked>
inline bool leaf_intersect(const HHPacket* p, uint32_t count, const RayLanes& r, float tmin,
                           bool any_hit, pf_ray_hit& best, const AlphaTest* alpha) {
#ifdef __SSE2__
  const __m128 zero = _mm_setzero_ps(), one = _mm_set1_ps(1.0f), minus_one = _mm_set1_ps(-1.0f);
  const __m128 sign = _mm_set1_ps(-0.0f), rounding = _mm_set1_ps(PF_HH_ROUNDING);
  for (uint32_t first = 0; first < count; first += 4, ++p) {
    const __m128 n0 = _mm_load_ps(p->n[0]), n1 = _mm_load_ps(p->n[1]);
    const __m128 n2 = _mm_load_ps(p->n[2]), n3 = _mm_load_ps(p->n[3]);
    const __m128 det = _mm_add_ps(_mm_add_ps(_mm_mul_ps(r.d4[0], n0), _mm_mul_ps(r.d4[1], n1)),
                                  _mm_mul_ps(r.d4[2], n2));
    const __m128 tp = _mm_xor_ps(
        _mm_add_ps(_mm_add_ps(_mm_add_ps(n3, _mm_mul_ps(r.o4[0], n0)), _mm_mul_ps(r.o4[1], n1)),
                   _mm_mul_ps(r.o4[2], n2)),
        sign);
    const __m128 neg = _mm_cmplt_ps(det, zero);
    const __m128 sgn = _mm_or_ps(_mm_and_ps(neg, minus_one), _mm_andnot_ps(neg, one));
    const __m128 adet = _mm_mul_ps(det, sgn);
    const __m128 st = _mm_mul_ps(tp, sgn);
    const __m128 px = _mm_add_ps(_mm_mul_ps(det, r.o4[0]), _mm_mul_ps(tp, r.d4[0]));
    const __m128 py = _mm_add_ps(_mm_mul_ps(det, r.o4[1]), _mm_mul_ps(tp, r.d4[1]));
    const __m128 pz = _mm_add_ps(_mm_mul_ps(det, r.o4[2]), _mm_mul_ps(tp, r.d4[2]));
    const __m128 su = _mm_mul_ps(
        _mm_add_ps(_mm_add_ps(_mm_add_ps(_mm_mul_ps(px, _mm_load_ps(p->n1[0])),
                                         _mm_mul_ps(py, _mm_load_ps(p->n1[1]))),
                              _mm_mul_ps(pz, _mm_load_ps(p->n1[2]))),
                   _mm_mul_ps(det, _mm_load_ps(p->n1[3]))),
        sgn);
    const __m128 sv = _mm_mul_ps(
        _mm_add_ps(_mm_add_ps(_mm_add_ps(_mm_mul_ps(px, _mm_load_ps(p->n2[0])),
                                         _mm_mul_ps(py, _mm_load_ps(p->n2[1]))),
                              _mm_mul_ps(pz, _mm_load_ps(p->n2[2]))),
                   _mm_mul_ps(det, _mm_load_ps(p->n2[3]))),
        sgn);
    // The slack of the sign tests, pf_hh_intersect's expressions (|x| = x without its sign bit).
    const __m128 m = _mm_add_ps(_mm_mul_ps(adet, r.ao4), _mm_mul_ps(st, r.ad4));
#define absl(a) _mm_andnot_ps(sign, _mm_load_ps(a))
#define slack_of(pl)                                                                          \
  _mm_mul_ps(rounding, _mm_add_ps(_mm_mul_ps(m, _mm_add_ps(_mm_add_ps(absl(pl[0]), absl(pl[1])), \
                                                           absl(pl[2]))),                     \
                                  _mm_mul_ps(adet, absl(pl[3]))))
    const __m128 slack_u = slack_of(p->n1), slack_v = slack_of(p->n2);
#undef slack_of
#undef absl
    const __m128 tmax = _mm_mul_ps(adet, _mm_set1_ps(best.t));
    __m128 in = _mm_and_ps(_mm_cmpge_ps(st, zero), _mm_cmple_ps(st, tmax));
    in = _mm_and_ps(in, _mm_and_ps(_mm_cmpge_ps(su, _mm_xor_ps(slack_u, sign)),
                                   _mm_cmpge_ps(sv, _mm_xor_ps(slack_v, sign))));
    in = _mm_and_ps(in, _mm_cmple_ps(_mm_add_ps(su, sv),
                                     _mm_add_ps(adet, _mm_add_ps(slack_u, slack_v))));
    in = _mm_and_ps(in, _mm_cmpgt_ps(adet, zero));
    int mask = _mm_movemask_ps(in);
    if (!mask) continue;
    alignas(16) float a_st[4], a_adet[4], a_tp[4], a_det[4], a_su[4], a_sv[4];
    _mm_store_ps(a_st, st);
    _mm_store_ps(a_adet, adet);
    _mm_store_ps(a_tp, tp);
    _mm_store_ps(a_det, det);
    _mm_store_ps(a_su, su);
    _mm_store_ps(a_sv, sv);
    const Lanes lanes{a_st, a_adet, a_tp, a_det, a_su, a_sv};
    if (finish_lanes<kMasked>(mask, lanes, [p](int l) { return p->tri[l]; }, tmin, any_hit, best,
                              alpha))
      return true;
  }
  return false;
#else
  for (uint32_t i = 0; i < count; ++i) {
    const HHPacket& q = p[i / 4];
    const int l = int(i % 4);
    pf_hh_triangle h;
    for (int k = 0; k < 4; ++k) {
      h.n[k] = q.n[k][l];
      h.n1[k] = q.n1[k][l];
      h.n2[k] = q.n2[k][l];
    }
    float t, u, v;
    if (!pf_hh_intersect(&h, r.o, r.d, tmin, best.t, &t, &u, &v)) continue;
    if (t == best.t && best.tri >= 0 && q.tri[l] > best.tri) continue;
    if (kMasked && alpha->cut_away(q.tri[l], u, v)) continue;
    best = {t, q.tri[l], u, v};
    if (any_hit) return true;
  }
  return false;
#endif
}

#if defined(__GNUC__) && defined(__x86_64__)
#define PF_HAVE_AVX_LEAF 1
// leaf_intersect with eight triangles per AVX operation: packets p and p + 1 side by side in the
// lanes (0–3 and 4–7, leaf order), the same expressions per lane as the SSE test (AVX rounds each
// operation as SSE does; no FMA), the passing lanes finished one by one in leaf order against the
// tmax of that moment, a last odd packet by the SSE test: the same hits bit for bit. Built for
// the AVX target and called only where the CPU has it (kd_leaf_avx).
template <bool kMasked>
__attribute__((target("avx"))) bool leaf_intersect_avx(const HHPacket* p, uint32_t count,
                                                       const RayLanes& r, float tmin,
                                                       bool any_hit, pf_ray_hit& best,
                                                       const AlphaTest* alpha) {
  const __m256 zero = _mm256_setzero_ps(), one = _mm256_set1_ps(1.0f);
  const __m256 minus_one = _mm256_set1_ps(-1.0f), sign = _mm256_set1_ps(-0.0f);
  const __m256 rounding = _mm256_set1_ps(PF_HH_ROUNDING);
  const __m256 ao = _mm256_set1_ps(r.ao), ad = _mm256_set1_ps(r.ad);
  const __m256 o0 = _mm256_set1_ps(r.o[0]), o1 = _mm256_set1_ps(r.o[1]), o2 = _mm256_set1_ps(r.o[2]);
  const __m256 d0 = _mm256_set1_ps(r.d[0]), d1 = _mm256_set1_ps(r.d[1]), d2 = _mm256_set1_ps(r.d[2]);
  uint32_t first = 0;
  for (; first + 4 < count; first += 8, p += 2) {  // five or more left: two packets
    const HHPacket* q = p + 1;
#define both(a, b) _mm256_insertf128_ps(_mm256_castps128_ps256(_mm_load_ps(a)), _mm_load_ps(b), 1)
    const __m256 n0 = both(p->n[0], q->n[0]), n1 = both(p->n[1], q->n[1]);
    const __m256 n2 = both(p->n[2], q->n[2]), n3 = both(p->n[3], q->n[3]);
    const __m256 det = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(d0, n0), _mm256_mul_ps(d1, n1)),
                                     _mm256_mul_ps(d2, n2));
    const __m256 tp = _mm256_xor_ps(
        _mm256_add_ps(
            _mm256_add_ps(_mm256_add_ps(n3, _mm256_mul_ps(o0, n0)), _mm256_mul_ps(o1, n1)),
            _mm256_mul_ps(o2, n2)),
        sign);
    const __m256 neg = _mm256_cmp_ps(det, zero, _CMP_LT_OS);
    const __m256 sgn = _mm256_or_ps(_mm256_and_ps(neg, minus_one), _mm256_andnot_ps(neg, one));
    const __m256 adet = _mm256_mul_ps(det, sgn);
    const __m256 st = _mm256_mul_ps(tp, sgn);
    const __m256 px = _mm256_add_ps(_mm256_mul_ps(det, o0), _mm256_mul_ps(tp, d0));
    const __m256 py = _mm256_add_ps(_mm256_mul_ps(det, o1), _mm256_mul_ps(tp, d1));
    const __m256 pz = _mm256_add_ps(_mm256_mul_ps(det, o2), _mm256_mul_ps(tp, d2));
    const __m256 su = _mm256_mul_ps(
        _mm256_add_ps(_mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(px, both(p->n1[0], q->n1[0])),
                                                  _mm256_mul_ps(py, both(p->n1[1], q->n1[1]))),
                                    _mm256_mul_ps(pz, both(p->n1[2], q->n1[2]))),
                      _mm256_mul_ps(det, both(p->n1[3], q->n1[3]))),
        sgn);
    const __m256 sv = _mm256_mul_ps(
        _mm256_add_ps(_mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(px, both(p->n2[0], q->n2[0])),
                                                  _mm256_mul_ps(py, both(p->n2[1], q->n2[1]))),
                                    _mm256_mul_ps(pz, both(p->n2[2], q->n2[2]))),
                      _mm256_mul_ps(det, both(p->n2[3], q->n2[3]))),
        sgn);
    // The slack of the sign tests: the SSE test's expressions, eight lanes.
#define absb(a, b) _mm256_andnot_ps(sign, both(a, b))
#define slack_of(pl, ql)                                                                        \
  _mm256_mul_ps(rounding,                                                                       \
                _mm256_add_ps(_mm256_mul_ps(m, _mm256_add_ps(_mm256_add_ps(absb(pl[0], ql[0]),  \
                                                                           absb(pl[1], ql[1])), \
                                                             absb(pl[2], ql[2]))),              \
                              _mm256_mul_ps(adet, absb(pl[3], ql[3]))))
    const __m256 m = _mm256_add_ps(_mm256_mul_ps(adet, ao), _mm256_mul_ps(st, ad));
    const __m256 slack_u = slack_of(p->n1, q->n1), slack_v = slack_of(p->n2, q->n2);
#undef slack_of
#undef absb
    const __m256 tmax = _mm256_mul_ps(adet, _mm256_set1_ps(best.t));
    __m256 in = _mm256_and_ps(_mm256_cmp_ps(st, zero, _CMP_GE_OS), _mm256_cmp_ps(st, tmax, _CMP_LE_OS));
    in = _mm256_and_ps(
        in, _mm256_and_ps(_mm256_cmp_ps(su, _mm256_xor_ps(slack_u, sign), _CMP_GE_OS),
                          _mm256_cmp_ps(sv, _mm256_xor_ps(slack_v, sign), _CMP_GE_OS)));
    in = _mm256_and_ps(in, _mm256_cmp_ps(_mm256_add_ps(su, sv),
                                         _mm256_add_ps(adet, _mm256_add_ps(slack_u, slack_v)),
                                         _CMP_LE_OS));
    in = _mm256_and_ps(in, _mm256_cmp_ps(adet, zero, _CMP_GT_OS));
    int mask = _mm256_movemask_ps(in);
    if (!mask) continue;
    alignas(32) float a_st[8], a_adet[8], a_tp[8], a_det[8], a_su[8], a_sv[8];
    _mm256_store_ps(a_st, st);
    _mm256_store_ps(a_adet, adet);
    _mm256_store_ps(a_tp, tp);
    _mm256_store_ps(a_det, det);
    _mm256_store_ps(a_su, su);
    _mm256_store_ps(a_sv, sv);
    const Lanes lanes{a_st, a_adet, a_tp, a_det, a_su, a_sv};
    if (finish_lanes<kMasked>(
            mask, lanes, [p, q](int l) { return l < 4 ? p->tri[l] : q->tri[l - 4]; }, tmin,
            any_hit, best, alpha))
      return true;
  }
#undef both
  return first < count && leaf_intersect<kMasked>(p, count - first, r, tmin, any_hit, best, alpha);
}
#endif

// Whether the stack traversal tests leaves eight triangles at a time (AVX): where the CPU has
// AVX, unless set_kd_leaf_avx turned it off.
std::atomic<bool>& kd_leaf_avx() {
#ifdef PF_HAVE_AVX_LEAF
  static std::atomic<bool> on{__builtin_cpu_supports("avx") != 0};
#else
  static std::atomic<bool> on{false};
#endif
  return on;
}

// The same for one leaf of the rope traversal (PF_KD_CLEAF_TEST), eight triangles at a time
// where the stack traversal's test does so; r is the ray's lanes, set up once per ray as the stack
// traversal does.
bool leaf_intersect_packets(const HHPacket* p, uint32_t count, const RayLanes& r, float tmin,
                            bool any_hit, pf_ray_hit& best, const AlphaTest* alpha) {
#ifdef PF_HAVE_AVX_LEAF
  if (count > 4 && kd_leaf_avx().load(std::memory_order_relaxed))
    return alpha ? leaf_intersect_avx<true>(p, count, r, tmin, any_hit, best, alpha)
                 : leaf_intersect_avx<false>(p, count, r, tmin, any_hit, best, nullptr);
#endif
  return alpha ? leaf_intersect<true>(p, count, r, tmin, any_hit, best, alpha)
               : leaf_intersect<false>(p, count, r, tmin, any_hit, best, nullptr);
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

bool set_kd_leaf_avx(bool on) {
  if (on && !kd_leaf_avx_supported()) return false;
  kd_leaf_avx().store(on);
  return true;
}

bool kd_leaf_avx_supported() {
#ifdef PF_HAVE_AVX_LEAF
  return __builtin_cpu_supports("avx") != 0;
#else
  return false;
#endif
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
