// raycast_packets.h — the kd walks' leaf test over packets of triangle planes (raycast.cpp):
// four triangles per SSE operation (leaf_intersect), eight per AVX operation where the CPU has it
// (leaf_intersect_avx), each bit for bit the scalar pf_kd_leaf_intersect. Private to raycast.cpp
// and raycast_packets.cpp; inline, so that the stack walk's loop holds the SSE test itself.
#pragma once
#include <atomic>
#include <cstdint>
#ifdef __SSE2__
#include <immintrin.h>
#endif

#include "photonflow/geometry/intersect_shared.h"
#include "photonflow/geometry/scene.h"

namespace pf {

// The any-hit test of a masked scene (alpha_shared.h) over the scene's own tables.
struct AlphaTest {
  const Scene* s;
  bool cut_away(int32_t tri, float u, float v) const {
    return pf_alpha_hit_cut_away(s->material_alpha.data(), s->triangles.data(),
                                 s->textures.data(), s->texels.data(),
                                 s->uvs.empty() ? nullptr : s->uvs[0].uv, tri, u, v) != 0;
  }
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
std::atomic<bool>& kd_leaf_avx();

// The same for one leaf of the rope traversal (PF_KD_CLEAF_TEST), eight triangles at a time
// where the stack traversal's test does so; r is the ray's lanes, set up once per ray as the stack
// traversal does.
inline bool leaf_intersect_packets(const HHPacket* p, uint32_t count, const RayLanes& r, float tmin,
                                   bool any_hit, pf_ray_hit& best, const AlphaTest* alpha) {
#ifdef PF_HAVE_AVX_LEAF
  if (count > 4 && kd_leaf_avx().load(std::memory_order_relaxed))
    return alpha ? leaf_intersect_avx<true>(p, count, r, tmin, any_hit, best, alpha)
                 : leaf_intersect_avx<false>(p, count, r, tmin, any_hit, best, nullptr);
#endif
  return alpha ? leaf_intersect<true>(p, count, r, tmin, any_hit, best, alpha)
               : leaf_intersect<false>(p, count, r, tmin, any_hit, best, nullptr);
}

}  // namespace pf
