/*
 * intersect_shared.h — ray–triangle test, ray–box test and stackless kd-tree traversal with
 * ropes, written once for the C++ host and the OpenCL C 1.2 kernels (one source for CPU and
 * GPU, in the manner of pbrt-v4).
 *
 * Rules that keep this file valid in both languages:
 *   - plain C: scalars, float arrays and the structs of shared_types.h; no references, no
 *     overloads, no std::, no float3 (its alignment differs between host and device);
 *   - buffers of the scene (hh triangles, kd nodes, leaf triangle lists) are PF_GLOBAL pointers:
 *     `__global` in a kernel, nothing on the host;
 *   - rays and hit records live in private memory (plain pointers in both languages).
 *
 * Conventions: a ray is P(t) = o + t·d, d not necessarily unit length; a hit is accepted only for
 * t in (tmin, tmax]. Barycentrics follow shared_types.h: P = (1−u−v)·v0 + u·v1 + v·v2.
 */
#ifndef PHOTONFLOW_INTERSECT_SHARED_H
#define PHOTONFLOW_INTERSECT_SHARED_H

#include "photonflow/foundations/cl_compat.h"
#include "photonflow/foundations/shared_types.h"

#ifndef __OPENCL_VERSION__
#include <math.h>
#endif

/* Widening of the scene's root box, as a fraction of its largest extent (pf_kd_enter_root and
 * the host's compact tree): a bound on how far the triangle test below accepts points outside a
 * triangle, so that those points are reachable too. */
#define PF_HH_EDGE_EPS 1e-4f

/* Slack of the barycentric sign tests: a bound on their rounding error, not a fraction of the
 * triangle. The planes of eq. 4.3 are rounded once per triangle and u' = P'·N1 + det·d1 cancels
 * the digits of terms as large as |det|·|N1|·(|O| + t|D|) and |det·d1|, so two triangles sharing
 * an edge or a vertex do not agree on which side of it a point lies; without slack a ray through
 * the edge can slip between them. Each test therefore accepts u' >= −s_u with
 *   s_u = PF_HH_ROUNDING · (m · |N1|_1 + |det| · |d1|),   m = |det| · max_k |O_k| + |t'| · max_k |D_k|
 * (m bounds |P'_k| and the error of computing it; |N1|_1 = |N1x| + |N1y| + |N1z|), likewise s_v
 * with N2, and u' + v' <= |det| + s_u + s_v. The slack is absolute in world units (a few float
 * roundoffs of the coordinates' size): a triangle is widened by the precision of its position,
 * 2e-6 world units in a unit box seen from 2.4 away, not by a fraction of its size (which drew a
 * 0.2-unit lamp 2e-5 wider on every side, a bright ring at its outline). */
#define PF_HH_ROUNDING 2.38418579e-7f /* 2^-22: four units of float roundoff */

/* max_k |v_k| of a ray's origin or direction (the magnitudes of the slack above). */
PF_INLINE float pf_hh_magnitude(const float* v) {
  const float a = fabs(v[0]), b = fabs(v[1]), c = fabs(v[2]);
  const float ab = a > b ? a : b;
  return ab > c ? ab : c;
}

/* Closest (or any) hit of a ray: t in units of |d|, triangle index (−1 = none), barycentrics. */
typedef struct {
  pf_float t;
  pf_int tri;
  pf_float u;
  pf_float v;
} pf_ray_hit;

/* Havel–Herout ray–triangle test (thesis eq. 4.3–4.7) against the precomputed planes of
 * `tri`. Returns 1 and writes t, u, v when the ray hits with t in (tmin, tmax], else 0.
 *
 * The sign tests of eq. 4.5–4.7 (sign(t') = sign(det·tmax − t'), sign(u') = sign(det − u'),
 * sign(v') = sign(det − u' − v')) are evaluated after multiplying every quantity by sign(det),
 * which turns each into one comparison against |det| = |D·N| and is free of signed-zero
 * surprises. All of them are combined without branching: in a leaf most triangles are
 * missed, and a mispredicted branch costs more than the arithmetic it would skip. */
PF_INLINE int pf_hh_intersect(PF_GLOBAL const pf_hh_triangle* tri, const float* o, const float* d,
                              float tmin, float tmax, float* t_out, float* u_out, float* v_out) {
  /* eq. 4.3: det = D·N; eq. 4.4: t' = −(d + O·N), so that t = t'/det. */
  const float det = d[0] * tri->n[0] + d[1] * tri->n[1] + d[2] * tri->n[2];
  const float tp = -(tri->n[3] + o[0] * tri->n[0] + o[1] * tri->n[1] + o[2] * tri->n[2]);
  const float sgn = det < 0.0f ? -1.0f : 1.0f;
  const float adet = det * sgn;
  const float st = tp * sgn; /* t'·sign(det) = t·|det| */
  /* eq. 4.5: P' = det·O + t'·D is the hit point scaled by det. */
  const float px = det * o[0] + tp * d[0];
  const float py = det * o[1] + tp * d[1];
  const float pz = det * o[2] + tp * d[2];
  /* eq. 4.6: u' = P'·N1 + det·d1 = det·u; eq. 4.7: v' = P'·N2 + det·d2 = det·v. */
  const float su = (px * tri->n1[0] + py * tri->n1[1] + pz * tri->n1[2] + det * tri->n1[3]) * sgn;
  const float sv = (px * tri->n2[0] + py * tri->n2[1] + pz * tri->n2[2] + det * tri->n2[3]) * sgn;
  /* The slack of the sign tests (PF_HH_ROUNDING above). */
  const float m = adet * pf_hh_magnitude(o) + st * pf_hh_magnitude(d);
  const float slack_u =
      PF_HH_ROUNDING * (m * (fabs(tri->n1[0]) + fabs(tri->n1[1]) + fabs(tri->n1[2])) +
                        adet * fabs(tri->n1[3]));
  const float slack_v =
      PF_HH_ROUNDING * (m * (fabs(tri->n2[0]) + fabs(tri->n2[1]) + fabs(tri->n2[2])) +
                        adet * fabs(tri->n2[3]));
  /* t in [0, tmax]; u >= 0, v >= 0, u + v <= 1 (u <= 1 follows); det == 0 (ray parallel to the
   * plane) fails st <= adet·tmax or the barycentric tests, which then read 0 <= ±0. */
  const int inside = (st >= 0.0f) & (st <= adet * tmax) & (su >= -slack_u) & (sv >= -slack_v) &
                     (su + sv <= adet + (slack_u + slack_v)) & (adet > 0.0f);
  if (!inside) return 0;
  const float t = tp / det;
  /* The exact contract (tmin, tmax] on the divided t, whatever the rounding above. */
  if (!(t > tmin && t <= tmax)) return 0;
  *t_out = t;
  *u_out = su / adet;
  *v_out = sv / adet;
  return 1;
}

/* Whether point p lies in the closed box [lo, hi] (a point on a face counts; NaN never does): the
 * test that lets a walk start in a given leaf (pf_kd_traverse_ropes_from and its compact twin,
 * raycast.cpp). */
PF_INLINE int pf_point_in_box(PF_GLOBAL const float* lo, PF_GLOBAL const float* hi,
                              const float* p) {
  return p[0] >= lo[0] && p[1] >= lo[1] && p[2] >= lo[2] && p[0] <= hi[0] && p[1] <= hi[1] &&
         p[2] <= hi[2];
}

/* Slab test of a ray against the box [lo, hi] (Kay & Kajiya), clipped to [tmin, tmax].
 * inv_d = 1/d per axis (±inf for a zero component, which is handled without NaNs).
 * Returns 1 and writes the parametric entry and exit when the clipped segment is not empty. */
PF_INLINE int pf_ray_box(const float* lo, const float* hi, const float* o, const float* d,
                         const float* inv_d, float tmin, float tmax, float* t_enter,
                         float* t_leave) {
  float t0 = tmin;
  float t1 = tmax;
  for (int k = 0; k < 3; ++k) {
    if (d[k] == 0.0f) {
      if (o[k] < lo[k] || o[k] > hi[k]) return 0; /* parallel to the slab and outside it */
      continue;
    }
    float tn = (lo[k] - o[k]) * inv_d[k];
    float tf = (hi[k] - o[k]) * inv_d[k];
    if (tn > tf) {
      const float s = tn;
      tn = tf;
      tf = s;
    }
    t0 = tn > t0 ? tn : t0;
    t1 = tf < t1 ? tf : t1;
  }
  *t_enter = t0;
  *t_leave = t1;
  return t0 <= t1;
}

/* Where a ray enters and leaves the kd-tree's root box, clipped to [tmin, tmax]. The box is
 * widened by PF_HH_EDGE_EPS of its largest extent: the triangle test accepts points up to that
 * fraction of a triangle's size outside it, and those points must be reachable too. */
PF_INLINE int pf_kd_enter_root(PF_GLOBAL const pf_kd_node* root, const float* o, const float* d,
                               const float* inv_d, float tmin, float tmax, float* t_enter,
                               float* t_leave) {
  float ext = 0.0f;
  for (int k = 0; k < 3; ++k) {
    const float e = root->hi[k] - root->lo[k];
    ext = e > ext ? e : ext;
  }
  const float margin = PF_HH_EDGE_EPS * ext;
  const float lo[3] = {root->lo[0] - margin, root->lo[1] - margin, root->lo[2] - margin};
  const float hi[3] = {root->hi[0] + margin, root->hi[1] + margin, root->hi[2] + margin};
  return pf_ray_box(lo, hi, o, d, inv_d, tmin, tmax, t_enter, t_leave);
}

/* Tests the triangles leaf_tris[first, first+count), keeping the closest hit in `hit` (hit->t is
 * the current tmax). Equal t are resolved towards the lower triangle index so the result does not
 * depend on the order in which leaves are visited. With any_hit, returns 1 at the first hit. */
PF_INLINE int pf_leaf_range_intersect(pf_int first, pf_int count,
                                      PF_GLOBAL const pf_int* leaf_tris,
                                      PF_GLOBAL const pf_hh_triangle* hh, const float* o,
                                      const float* d, float tmin, int any_hit, pf_ray_hit* hit) {
  pf_ray_hit best = *hit; /* a private copy: stores through `hit` could alias the scene arrays */
  const pf_int end = first + count;
  int found = 0;
  for (pf_int i = first; i < end; ++i) {
    const pf_int tri = leaf_tris[i];
    float t, u, v;
    if (!pf_hh_intersect(&hh[tri], o, d, tmin, best.t, &t, &u, &v)) continue;
    if (t == best.t && best.tri >= 0 && tri > best.tri) continue;
    best.t = t;
    best.tri = tri;
    best.u = u;
    best.v = v;
    found = 1;
    if (any_hit) break;
  }
  if (found) *hit = best;
  return found && any_hit;
}

/* The triangles of one kd leaf (pf_leaf_range_intersect over its range). */
PF_INLINE int pf_kd_leaf_intersect(PF_GLOBAL const pf_kd_node* leaf,
                                   PF_GLOBAL const pf_int* leaf_tris,
                                   PF_GLOBAL const pf_hh_triangle* hh, const float* o,
                                   const float* d, float tmin, int any_hit, pf_ray_hit* hit) {
  return pf_leaf_range_intersect(leaf->first, leaf->count, leaf_tris, hh, o, d, tmin, any_hit,
                                 hit);
}

/* The leaf test of the rope traversal below. An OpenCL kernel may define PF_KD_LEAF_TEST before
 * including this header to substitute a test with the same signature and the same result
 * (kernels/trace_common.h: four triangles per vector operation over a leaf-ordered copy of the
 * planes, reached through the leaf_tris and hh arguments). The host does the same with SSE in the
 * compact rope loop below (PF_KD_CLEAF_TEST, raycast.cpp); both are tested to return this
 * function's bits. */
#ifndef PF_KD_LEAF_TEST
#define PF_KD_LEAF_TEST pf_kd_leaf_intersect
#endif

/* Stackless kd-tree traversal with ropes (Popov et al. 2007; thesis ch. 4.3).
 *
 * `hit` must come in with hit->t = tmax and hit->tri = −1; on return it holds the closest hit
 * with t in (tmin, tmax] (or, with any_hit, the first one found). Returns 1 when there is a hit.
 *
 * Loop: locate the leaf holding the entry point P = o + t_entry·d by descending from the current
 * node, test its triangles,
 * find the face through which the ray leaves the leaf, and follow that face's rope. Triangles are
 * accepted anywhere along the ray, so the loop may stop as soon as the closest hit lies before the
 * leaf's exit. In the descents after a rope, a point exactly on a split plane goes to the side the
 * ray comes from (the low side when d > 0, the high side when d < 0): the ray then leaves that
 * leaf at once through the plane (t_exit == t_entry) into the other side, so both leaves are
 * visited. Triangles touching the plane are listed on their own side only (kdtree.h), and a ray
 * aimed exactly at a vertex on a corner of the leaf arrangement would otherwise skip the leaf that
 * holds the vertex's triangles. In the first descent (at the origin or the root entry) a point on
 * a plane goes to the side the ray moves into: behind it there is nothing to find (t > tmin), and
 * eye rays from a point on split planes would pay a useless leaf per plane.
 * t_entry never decreases, and at most `node_count` leaves are visited (a safety net
 * against rounding cycles at leaf corners; a correct tree never needs it). */
/* pf_kd_traverse_ropes_from: the same walk, optionally started in a given leaf.
 * start_node < 0: pf_kd_traverse_ropes. start_node = a leaf whose box (lo, hi, closed) holds the
 * origin: the walk starts there at t = tmin, without the root-box test and the descent from the
 * root; the hit is the same (the leaves visited are the root walk's, plus, for an origin on the
 * leaf's face, that leaf: its triangles are really hit in (tmin, tmax], and ties go to the
 * lowest index). Any other start_node (an inner node, a leaf whose box does not hold o, out of
 * range) is ignored. end_node, if not null, receives the leaf the walk stopped in when it returns
 * a closest hit (the hit lies in its box, up to rounding and the edge tolerance, for a ray from
 * inside the scene's box), else −1: the start_node of the next ray from the hit point. The compact
 * twin is pf_kd_traverse_ropes_compact_from below. */
PF_INLINE int pf_kd_traverse_ropes_from(PF_GLOBAL const pf_kd_node* nodes, pf_int node_count,
                                        PF_GLOBAL const pf_int* leaf_tris,
                                        PF_GLOBAL const pf_hh_triangle* hh, const float* o,
                                        const float* d, float tmin, int any_hit, pf_ray_hit* hit,
                                        pf_int start_node, pf_int* end_node) {
  float inv_d[3];
  int high[3]; /* per axis: 1 if the ray leaves nodes through their high face */
  for (int k = 0; k < 3; ++k) {
    inv_d[k] = 1.0f / d[k];
    /* By the sign of 1/d, not of d: −0 gives −inf and the low face, so (face − o)·inv_d is
     * +inf or NaN (never chosen) on an axis the ray does not move along. */
    high[k] = inv_d[k] > 0.0f;
  }
  if (end_node) *end_node = -1;
  if (node_count <= 0) return 0;
  float t_entry;
  pf_int node = 0;
  int started = 0;
  if (start_node >= 0 && start_node < node_count) {
    PF_GLOBAL const pf_kd_node* sn = &nodes[start_node];
    if (sn->axis == PF_KD_LEAF && pf_point_in_box(sn->lo, sn->hi, o) && tmin < hit->t) {
      node = start_node;
      t_entry = tmin;
      started = 1;
    }
  }
  if (!started) {
    float t_leave_root;
    if (!pf_kd_enter_root(nodes, o, d, inv_d, tmin, hit->t, &t_entry, &t_leave_root)) return 0;
  }
  pf_int leaf_node = -1;
  float tie = -1.0f; /* first descent: ties go where the ray moves (d·tie > 0 picks the left) */
  for (pf_int step = 0; step < node_count; ++step) {
    const float p[3] = {o[0] + t_entry * d[0], o[1] + t_entry * d[1], o[2] + t_entry * d[2]};
    PF_GLOBAL const pf_kd_node* n = &nodes[node];
    while (n->axis != PF_KD_LEAF) {
      const int a = n->axis;
      const int go_left = (p[a] < n->split) | ((p[a] == n->split) & (d[a] * tie > 0.0f));
      node = go_left ? n->left : n->right;
      n = &nodes[node];
    }
    leaf_node = node;
    if (PF_KD_LEAF_TEST(n, leaf_tris, hh, o, d, tmin, any_hit, hit)) return 1;
    /* Exit face: the nearest of the three faces the ray moves towards. An axis the ray does not
     * move along is skipped: its face gives +inf or NaN from inside the slab, but −inf when the
     * ray runs outside it, in the margin of the root box (pf_kd_enter_root) where it may still
     * hit triangles by the edge tolerance. */
    float t_exit = INFINITY;
    int face = -1;
    for (int k = 0; k < 3; ++k) {
      const float te = ((high[k] ? n->hi[k] : n->lo[k]) - o[k]) * inv_d[k];
      if (te < t_exit && d[k] != 0.0f) {
        t_exit = te;
        face = 2 * k + high[k];
      }
    }
    /* The closest hit lies in this leaf, or tmax is reached. A hit exactly on the exit plane goes
     * on into the next leaf, which may hold a triangle hit at the same t with a lower index (the
     * tie rule of pf_kd_leaf_intersect; the stack traversal of raycast.cpp does the same). Ties
     * at a point where leaves meet only by a corner or an edge are not resolved across them
     * (raycast.h, Stack). */
    if (face < 0 || hit->t < t_exit) break;
    node = n->ropes[face];
    if (node < 0) break; /* left the scene box */
    tie = 1.0f; /* later descents: ties go to the side the ray comes from */
    t_entry = t_exit > t_entry ? t_exit : t_entry;
  }
  if (end_node && hit->tri >= 0) *end_node = leaf_node;
  return hit->tri >= 0;
}

PF_INLINE int pf_kd_traverse_ropes(PF_GLOBAL const pf_kd_node* nodes, pf_int node_count,
                                   PF_GLOBAL const pf_int* leaf_tris,
                                   PF_GLOBAL const pf_hh_triangle* hh, const float* o,
                                   const float* d, float tmin, int any_hit, pf_ray_hit* hit) {
  return pf_kd_traverse_ropes_from(nodes, node_count, leaf_tris, hh, o, d, tmin, any_hit, hit, -1,
                                   (pf_int*)0);
}

/* ---- Compact rope traversal ------------------------------------------------------------------
 *
 * The same stackless rope loop as pf_kd_traverse_ropes over a compact copy of the tree, derived
 * from the pf_kd_node array (pf_kd_compact_build below; the host caches it, raycast.cpp) so that a
 * descent reads 8 bytes per inner node instead of 72, and only leaves carry their box and ropes:
 *   - pf_kd_cnode: nodes in depth-first preorder with the left child first (the left child of
 *     node i is i + 1). Inner: `split` and code = right child << 2 | axis. Leaf: code =
 *     leaf record index << 2 | PF_KD_LEAF (`split` unused, 0).
 *   - pf_kd_cleaf: one 64-byte record per leaf: box (lo, hi), ropes (indices into the compact
 *     node array, −1 on the scene bounds), the leaf's range of leaf_tris, and `aux`, free for a
 *     substituted leaf test (the host: first packet of the leaf-ordered planes).
 *   - root_box: the root box widened as pf_kd_enter_root widens it (lo[3], hi[3]).
 * Every decision is made on the same floats with the same expressions as pf_kd_traverse_ropes, so
 * the leaves are visited in the same order and the hits are the same bits; empty leaves cost only
 * their exit face (no leaf test). */
typedef struct {
  pf_float split;
  pf_int code;
} pf_kd_cnode;

typedef struct {
  pf_float box[6]; /* lo[3], hi[3] */
  pf_int ropes[6];
  pf_int first;
  pf_int count;
  pf_int aux;
  pf_int pad;
} pf_kd_cleaf;

/* pf_kd_leaf_intersect for a compact leaf record (the same range test). */
PF_INLINE int pf_kd_cleaf_intersect(PF_GLOBAL const pf_kd_cleaf* leaf,
                                    PF_GLOBAL const pf_int* leaf_tris,
                                    PF_GLOBAL const pf_hh_triangle* hh, const float* o,
                                    const float* d, float tmin, int any_hit, pf_ray_hit* hit) {
  return pf_leaf_range_intersect(leaf->first, leaf->count, leaf_tris, hh, o, d, tmin, any_hit,
                                 hit);
}

/* The compact loop's leaf test; substitutable like PF_KD_LEAF_TEST (same signature as
 * pf_kd_cleaf_intersect, same result). Called for non-empty leaves only. */
#ifndef PF_KD_CLEAF_TEST
#define PF_KD_CLEAF_TEST pf_kd_cleaf_intersect
#endif

/* pf_kd_traverse_ropes over the compact copy, optionally started in a given leaf.
 *
 * With start_leaf < 0: the same arguments and result as pf_kd_traverse_ropes (node_count = the
 * number of compact nodes, the number of pf_kd_node): the walk enters at the root box.
 * With start_leaf = a leaf record index whose box holds the origin (closed box: o on a face
 * counts): the walk starts in that leaf at t = tmin and skips the root-box test and the descent
 * from the root (about seven dependent node loads on a 200k-triangle scene). A secondary ray
 * leaves from a hit point, and the leaf the hit lies in is known from the ray that found it
 * (end_leaf below), so bounce and shadow rays need no descent at all when the origin is still
 * inside. The leaves visited from there on are those of the root walk, except that an origin on
 * the start leaf's face may add that leaf (the root walk puts such a point on the side the ray
 * moves into): its triangles are then tested too, and since every triangle tested is really hit
 * in (tmin, tmax] and ties go to the lowest index, the closest hit is the same. A start_leaf whose
 * box does not hold o (or a NaN origin) is ignored: the walk enters at the root.
 * end_leaf, if not null, receives the leaf record the walk stopped in when it returns a closest
 * hit (the hit lies in that leaf's box up to rounding: the loop stops where hit->t < t_exit), else
 * −1 (no hit, or any_hit). */
PF_INLINE int pf_kd_traverse_ropes_compact_from(
    PF_GLOBAL const pf_kd_cnode* cnodes, pf_int node_count, PF_GLOBAL const pf_kd_cleaf* leaves,
    PF_GLOBAL const float* root_box, PF_GLOBAL const pf_int* leaf_tris,
    PF_GLOBAL const pf_hh_triangle* hh, const float* o, const float* d, float tmin, int any_hit,
    pf_ray_hit* hit, pf_int start_leaf, pf_int* end_leaf) {
  float inv_d[3];
  int high[3], exit_face[3]; /* exit_face[k]: index into box[] of the face the ray leaves by */
  for (int k = 0; k < 3; ++k) {
    inv_d[k] = 1.0f / d[k];
    high[k] = inv_d[k] > 0.0f;
    exit_face[k] = 3 * high[k] + k;
  }
  if (end_leaf) *end_leaf = -1;
  if (node_count <= 0) return 0;
  float t_entry;
  pf_int node = 0, leaf_index = -1;
  if (start_leaf >= 0 && pf_point_in_box(leaves[start_leaf].box, leaves[start_leaf].box + 3, o) &&
      tmin < hit->t)
    leaf_index = start_leaf;
  if (leaf_index >= 0) {
    t_entry = tmin;
  } else {
    float t_leave_root;
    const float lo[3] = {root_box[0], root_box[1], root_box[2]};
    const float hi[3] = {root_box[3], root_box[4], root_box[5]};
    if (!pf_ray_box(lo, hi, o, d, inv_d, tmin, hit->t, &t_entry, &t_leave_root)) return 0;
  }
  float tie = -1.0f; /* as in pf_kd_traverse_ropes */
  for (pf_int step = 0; step < node_count; ++step) {
    if (leaf_index < 0) {
      const float p[3] = {o[0] + t_entry * d[0], o[1] + t_entry * d[1], o[2] + t_entry * d[2]};
      pf_kd_cnode n = cnodes[node];
      while ((n.code & 3) != PF_KD_LEAF) {
        const int a = n.code & 3;
        const int go_left = (p[a] < n.split) | ((p[a] == n.split) & (d[a] * tie > 0.0f));
        node = go_left ? node + 1 : (n.code >> 2);
        n = cnodes[node];
      }
      leaf_index = n.code >> 2;
    }
    PF_GLOBAL const pf_kd_cleaf* leaf = &leaves[leaf_index];
    if (leaf->count > 0 && PF_KD_CLEAF_TEST(leaf, leaf_tris, hh, o, d, tmin, any_hit, hit))
      return 1;
    float t_exit = INFINITY;
    int face = -1;
    for (int k = 0; k < 3; ++k) {
      const float te = (leaf->box[exit_face[k]] - o[k]) * inv_d[k];
      if (te < t_exit && d[k] != 0.0f) {
        t_exit = te;
        face = 2 * k + high[k];
      }
    }
    if (face < 0 || hit->t < t_exit) break;
    node = leaf->ropes[face];
    if (node < 0) break;
    leaf_index = -1;
    tie = 1.0f;
    t_entry = t_exit > t_entry ? t_exit : t_entry;
  }
  if (end_leaf && hit->tri >= 0) *end_leaf = leaf_index;
  return hit->tri >= 0;
}

/* pf_kd_traverse_ropes over the compact copy: same arguments and result (node_count = the number
 * of compact nodes, the number of pf_kd_node). */
PF_INLINE int pf_kd_traverse_ropes_compact(PF_GLOBAL const pf_kd_cnode* cnodes, pf_int node_count,
                                           PF_GLOBAL const pf_kd_cleaf* leaves,
                                           PF_GLOBAL const float* root_box,
                                           PF_GLOBAL const pf_int* leaf_tris,
                                           PF_GLOBAL const pf_hh_triangle* hh, const float* o,
                                           const float* d, float tmin, int any_hit,
                                           pf_ray_hit* hit) {
  return pf_kd_traverse_ropes_compact_from(cnodes, node_count, leaves, root_box, leaf_tris, hh, o,
                                           d, tmin, any_hit, hit, -1, (pf_int*)0);
}

#ifndef __OPENCL_VERSION__
/* Host: fills the compact copy of a valid tree. order[i] is the pf_kd_node placed at compact
 * position i (a depth-first preorder with the left child first; the identity for the builder's
 * trees), new_index its inverse. cnodes has node_count entries, leaves room for every leaf.
 * Returns the number of leaf records written (leaf j's aux = 0). */
PF_INLINE pf_int pf_kd_compact_build(const pf_kd_node* nodes, pf_int node_count,
                                     const pf_int* order, const pf_int* new_index,
                                     pf_kd_cnode* cnodes, pf_kd_cleaf* leaves, float* root_box) {
  pf_int n_leaves = 0;
  for (pf_int i = 0; i < node_count; ++i) {
    const pf_kd_node* n = &nodes[order[i]];
    pf_kd_cnode* c = &cnodes[i];
    if (n->axis == PF_KD_LEAF) {
      pf_kd_cleaf* l = &leaves[n_leaves];
      for (int k = 0; k < 3; ++k) {
        l->box[k] = n->lo[k];
        l->box[3 + k] = n->hi[k];
      }
      for (int f = 0; f < 6; ++f) l->ropes[f] = n->ropes[f] < 0 ? -1 : new_index[n->ropes[f]];
      l->first = n->first;
      l->count = n->count;
      l->aux = 0;
      l->pad = 0;
      c->split = 0.0f;
      c->code = n_leaves << 2 | PF_KD_LEAF;
      ++n_leaves;
    } else {
      c->split = n->split;
      c->code = new_index[n->right] << 2 | n->axis;
    }
  }
  if (node_count > 0) { /* the arithmetic of pf_kd_enter_root */
    float ext = 0.0f;
    for (int k = 0; k < 3; ++k) {
      const float e = nodes[0].hi[k] - nodes[0].lo[k];
      ext = e > ext ? e : ext;
    }
    const float margin = PF_HH_EDGE_EPS * ext;
    for (int k = 0; k < 3; ++k) {
      root_box[k] = nodes[0].lo[k] - margin;
      root_box[3 + k] = nodes[0].hi[k] + margin;
    }
  }
  return n_leaves;
}
#endif

#endif /* PHOTONFLOW_INTERSECT_SHARED_H */
