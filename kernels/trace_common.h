/*
 * trace_common.h — kernel-side pieces shared by the ray-tracing kernels (trace_hitpoints.cl,
 * trace_photons.cl): the scene view over the baked scene's device buffers, the surface record at
 * a hit (the device twin of surface.h's surface_at), light choice by power and ray offsets.
 *
 * Every expression mirrors the host code it stands for (surface.h, eye_pass.cpp, photon_pass.cpp)
 * operation by operation, with float contraction off, so the OpenCL backend follows the CPU
 * backend's paths up to the rounding of the device's sqrt/sin/cos.
 */
#ifndef PF_KERNEL_TRACE_COMMON_H
#define PF_KERNEL_TRACE_COMMON_H

#pragma OPENCL FP_CONTRACT OFF

#include "scene_features.h"
#include "photonflow/foundations/shared_types.h"
#include "photonflow/material/texture_shared.h"
#include "photonflow/material/pbr_point_shared.h"
#include "photonflow/material/pbr_scatter_shared.h"
#include "photonflow/material/alpha_shared.h"

/* Alpha cut-outs (alpha_shared.h): the masked scene's tables the leaf test reads. pf_trace hands
 * the traversal a pf_trace_hit, whose first member is the pf_ray_hit the traversal passes through
 * to PF_KD_LEAF_TEST unchanged, so the leaf test recovers the view from its hit pointer (a
 * pointer to a struct's first member converts to one to the struct, C99 6.7.2.1). alpha = 0: the
 * scene has no masked material, and the leaf test never reads the tables. */
typedef struct {
  __global const pf_alpha_material* mats;
  __global const pf_triangle* tris;
  __global const pf_texture* textures;
  __global const float* texels;
  __global const float* uvs;
} pf_alpha_view;

struct pf_trace_hit_s; /* defined below, after intersect_shared.h's pf_ray_hit */

/* The rope traversal's leaf test, vectorised: intersect_shared.h's pf_kd_leaf_intersect runs one
 * Havel–Herout test per triangle through the leaf's index list; this one reads a leaf-ordered copy
 * of the planes in groups of four (transposed: 12 float4 of plane coefficients + the 4 triangle
 * indices, built by cl_backend.cpp) and tests four triangles per vector operation — the same
 * operations in the same order per lane, so the same bits — then applies the scalar rules
 * (interval (tmin, t], ties to the lower triangle index, any-hit at the first hit in leaf order)
 * lane by lane. The traversal passes it the group table as `leaf_tris` (group of each leaf's
 * first index) and the groups as `hh`. In a scene with alpha cut-outs it also skips a lane whose
 * hit point is cut away (pf_alpha_hit_cut_away, where the scalar test would accept it), reading
 * the alpha view from the pf_trace_hit its hit pointer belongs to. */
static int pf_leaf_test4(__global const pf_kd_node* leaf, __global const pf_int* group_of_first,
                         __global const pf_hh_triangle* groups, const float* o, const float* d,
                         float tmin, int any_hit, struct pf_trace_hit_s* th);
#define PF_KD_LEAF_TEST(n, lt, h, o, d, tmin, any, hit) \
  pf_leaf_test4(n, lt, h, o, d, tmin, any, (struct pf_trace_hit_s*)(hit))

#include "photonflow/geometry/intersect_shared.h"
#include "photonflow/foundations/rng.h"
#include "photonflow/sampling/sampling_shared.h"
#include "photonflow/geometry/light_shared.h"
#include "photonflow/geometry/light_choice_shared.h"
#include "photonflow/geometry/environment_shared.h"

struct pf_trace_hit_s {
  pf_ray_hit hit; /* first */
  const pf_alpha_view* alpha;
};
typedef struct pf_trace_hit_s pf_trace_hit;

#define PF_LEAF_GROUP_FLOAT4 13 /* float4 per group: n, n1, n2 (x, y, z, w each), triangle ids */

static int pf_leaf_test4(__global const pf_kd_node* leaf, __global const pf_int* group_of_first,
                         __global const pf_hh_triangle* groups, const float* o, const float* d,
                         float tmin, int any_hit, struct pf_trace_hit_s* th) {
  const int count = leaf->count;
  if (count <= 0) return 0;
  float* hit_t = &th->hit.t;
  int* hit_tri = &th->hit.tri;
  float* hit_u = &th->hit.u;
  float* hit_v = &th->hit.v;
  const pf_alpha_view* alpha = th->alpha; /* pf_trace's record */
  __global const float4* g =
      (__global const float4*)groups + (size_t)group_of_first[leaf->first] * PF_LEAF_GROUP_FLOAT4;
  float best_t = *hit_t, best_u = *hit_u, best_v = *hit_v;
  int best_tri = *hit_tri, found = 0;
  const float4 ox = (float4)(o[0]), oy = (float4)(o[1]), oz = (float4)(o[2]);
  const float4 dx = (float4)(d[0]), dy = (float4)(d[1]), dz = (float4)(d[2]);
  const float4 ao = (float4)(pf_hh_magnitude(o)), ad = (float4)(pf_hh_magnitude(d));
  for (int base = 0; base < count; base += 4, g += PF_LEAF_GROUP_FLOAT4) {
    /* pf_hh_intersect, four lanes (see intersect_shared.h for the equations) */
    const float4 det = dx * g[0] + dy * g[1] + dz * g[2];
    const float4 tp = -(g[3] + ox * g[0] + oy * g[1] + oz * g[2]);
    const float4 sgn = select((float4)(1.0f), (float4)(-1.0f), det < (float4)(0.0f));
    const float4 adet = det * sgn;
    const float4 st = tp * sgn;
    const float4 px = det * ox + tp * dx;
    const float4 py = det * oy + tp * dy;
    const float4 pz = det * oz + tp * dz;
    const float4 su = (px * g[4] + py * g[5] + pz * g[6] + det * g[7]) * sgn;
    const float4 sv = (px * g[8] + py * g[9] + pz * g[10] + det * g[11]) * sgn;
    const float4 m = adet * ao + st * ad;
    const float4 slack_u =
        PF_HH_ROUNDING * (m * (fabs(g[4]) + fabs(g[5]) + fabs(g[6])) + adet * fabs(g[7]));
    const float4 slack_v =
        PF_HH_ROUNDING * (m * (fabs(g[8]) + fabs(g[9]) + fabs(g[10])) + adet * fabs(g[11]));
    const int4 inside = (st >= (float4)(0.0f)) & (su >= -slack_u) & (sv >= -slack_v) &
                        (su + sv <= adet + (slack_u + slack_v)) & (adet > (float4)(0.0f));
    if (!any(inside)) continue;
    const float4 t4 = tp / det, u4 = su / adet, v4 = sv / adet;
    int in[4], tri[4];
    float t[4], u[4], v[4], st_[4], adet_[4];
    vstore4(inside, 0, in);
    vstore4(as_int4(g[12]), 0, tri);
    vstore4(t4, 0, t);
    vstore4(u4, 0, u);
    vstore4(v4, 0, v);
    vstore4(st, 0, st_);
    vstore4(adet, 0, adet_);
    const int lanes = count - base < 4 ? count - base : 4;
    for (int k = 0; k < lanes; ++k) {
      /* the scalar test's remaining conditions against the current closest hit */
      if (!in[k] || !(st_[k] <= adet_[k] * best_t)) continue;
      if (!(t[k] > tmin && t[k] <= best_t)) continue;
      if (t[k] == best_t && best_tri >= 0 && tri[k] > best_tri) continue;
      if (PF_SCENE_ALPHA && alpha && pf_alpha_hit_cut_away(alpha->mats, alpha->tris, alpha->textures,
                                         alpha->texels, alpha->uvs, tri[k], u[k], v[k]))
        continue; /* a cut-away point: the ray passes (alpha_shared.h) */
      best_t = t[k];
      best_tri = tri[k];
      best_u = u[k];
      best_v = v[k];
      found = 1;
      if (any_hit) break;
    }
    if (found && any_hit) break;
  }
  if (found) {
    *hit_t = best_t;
    *hit_tri = best_tri;
    *hit_u = best_u;
    *hit_v = best_v;
  }
  return found && any_hit;
}

/* The baked scene on the device (scene.h arrays, unchanged layouts). */
typedef struct {
  __global const pf_triangle* tris;
  __global const pf_hh_triangle* hh;
  __global const pf_kd_node* nodes;
  __global const pf_int* group_of_first; /* leaf-ordered plane groups (pf_leaf_test4) */
  __global const float4* leaf_groups;
  __global const pf_int* leaf_tris;
  __global const pf_material* mats;
  __global const pf_light* lights;
  __global const float* light_cdf;
  __global const float* env; /* the environment (environment_shared.h; width 0 = none) */
  int node_count;
  int light_count;
  pf_alpha_view alpha; /* read only when alpha_on (PF_ALPHA_VIEW) */
  int alpha_on;
  /* NEE's light choice (light_choice_shared.h; Scene::light_choice), one entry per light; read
   * only when choice_on (the eye kernel sets both; every other kernel picks by power) */
  __global const pf_light_choice* choice;
  int choice_on;
} pf_scene_view;

/* Kernel parameters of the scene, in this order in every tracing kernel. */
#define PF_SCENE_PARAMS                                                                    \
  __global const pf_triangle *tris, __global const pf_hh_triangle *hh,                     \
      __global const pf_kd_node *nodes, int node_count, __global const pf_int *leaf_tris,  \
      __global const pf_int *group_of_first, __global const float4 *leaf_groups,           \
      __global const pf_material *mats, __global const pf_light *lights,                   \
      __global const float *light_cdf, int light_count, __global const float *env

#define PF_SCENE_VIEW(s)   \
  pf_scene_view s;         \
  s.tris = tris;           \
  s.hh = hh;               \
  s.nodes = nodes;         \
  s.leaf_tris = leaf_tris; \
  s.group_of_first = group_of_first; \
  s.leaf_groups = leaf_groups; \
  s.mats = mats;           \
  s.lights = lights;       \
  s.light_cdf = light_cdf; \
  s.env = env;             \
  s.node_count = node_count; \
  s.light_count = light_count; \
  s.alpha_on = 0; \
  s.choice = 0; \
  s.choice_on = 0

/* Alpha cut-outs: the kernel parameters after PF_TEXTURE_PARAMS in every tracing kernel (the
 * texture parameters hold the alpha textures and UVs). alpha_mats: one pf_alpha_material per
 * material, or one stand-in when alpha_on = 0 (no masked material: never read). */
#define PF_ALPHA_PARAMS __global const pf_alpha_material *alpha_mats, int alpha_on

/* The alpha view of PF_SCENE_VIEW's s, after it, from PF_TEXTURE_PARAMS and PF_ALPHA_PARAMS. */
#define PF_ALPHA_VIEW(s)      \
  s.alpha.mats = alpha_mats;  \
  s.alpha.tris = tris;        \
  s.alpha.textures = textures; \
  s.alpha.texels = texels;    \
  s.alpha.uvs = uvs;          \
  s.alpha_on = alpha_on

/* Closest (any_hit = 0) or any (1) hit of o + t·d for t in (tmin, tmax], rope traversal; in a
 * masked scene hits on cut-away points do not count (pf_leaf_test4). The walk starts in leaf
 * `start` when its box holds o (the leaf of the hit o was made from; −1: from the root), and
 * *end, if end is not null, receives the leaf of the closest hit found (−1 if none):
 * pf_kd_traverse_ropes_from, the host's raycast.h Ray::leaf / Hit::leaf. */
static inline int pf_trace_from(const pf_scene_view* s, const float* o, const float* d,
                                float tmin, float tmax, int any_hit, pf_ray_hit* hit, int start,
                                int* end) {
  pf_trace_hit th;
  th.hit.t = tmax;
  th.hit.tri = -1;
  th.hit.u = 0.0f;
  th.hit.v = 0.0f;
  th.alpha = PF_SCENE_ALPHA && s->alpha_on ? &s->alpha : 0;
  /* PF_KD_LEAF_TEST = pf_leaf_test4: the groups travel in the leaf_tris / hh arguments */
  const int r = pf_kd_traverse_ropes_from(s->nodes, s->node_count, s->group_of_first,
                                          (__global const pf_hh_triangle*)s->leaf_groups, o, d,
                                          tmin, any_hit, &th.hit, start, end);
  *hit = th.hit;
  return r;
}

/* pf_trace_from from the root. */
static inline int pf_trace(const pf_scene_view* s, const float* o, const float* d, float tmin,
                           float tmax, int any_hit, pf_ray_hit* hit) {
  return pf_trace_from(s, o, d, tmin, tmax, any_hit, hit, -1, 0);
}

/* surface.h's SurfaceHit. */
typedef struct {
  float p[3];
  float ng[3]; /* unit geometric normal (CCW front), not flipped */
  float ns[3]; /* unit shading normal on ng's side */
  int front;   /* the ray arrived on the front side */
  int mesh;
  int material;
} pf_surface;

static inline void pf_surface_at(const pf_scene_view* s, const float* o, const float* d,
                                 const pf_ray_hit* h, pf_surface* sh) {
  __global const pf_triangle* t = &s->tris[h->tri];
  float e1[3], e2[3];
  for (int k = 0; k < 3; ++k) {
    sh->p[k] = o[k] + d[k] * h->t;
    e1[k] = t->v1[k] - t->v0[k];
    e2[k] = t->v2[k] - t->v0[k];
  }
  pf_cross3(e1, e2, sh->ng);
  pf_normalize3(sh->ng);
  const float w = 1.0f - h->u - h->v;
  float ns[3];
  for (int k = 0; k < 3; ++k) ns[k] = t->n0[k] * w + t->n1[k] * h->u + t->n2[k] * h->v;
  pf_normalize3(ns);
  if (pf_dot3(ns, sh->ng) < 0.0f) {
    ns[0] = -ns[0];
    ns[1] = -ns[1];
    ns[2] = -ns[2];
  }
  const int bad = !isfinite(ns[0]) || !isfinite(ns[1]) || !isfinite(ns[2]) ||
                  sqrt(pf_dot3(ns, ns)) < 0.5f;
  for (int k = 0; k < 3; ++k) sh->ns[k] = bad ? sh->ng[k] : ns[k];
  sh->front = pf_dot3(d, sh->ng) < 0.0f;
  sh->mesh = t->mesh;
  sh->material = t->material;
}

/* Textures (scene.h, texture_shared.h): the kernel parameters of the tracing kernels that shade,
 * after PF_SCENE_PARAMS. mat_tex[m] is material m's base-colour texture (−1 none), mr_tex[m] its
 * metallic-roughness texture (Scene::mr_texture_of; −1 none), uvs six floats per triangle (u0 v0
 * u1 v1 u2 v2), texels the linear RGBA pool. */
#define PF_TEXTURE_PARAMS                                                                 \
  __global const pf_texture *textures, __global const float *texels,                      \
      __global const pf_int *mat_tex, __global const float *uvs, __global const pf_int *mr_tex

/* The texture factor of a diffuse colour at hit h (Scene::texture_value: the UV interpolated by
 * the barycentrics in the host's order, then pf_tex_sample): 1 and f = the texel value when
 * `material` has a texture, else 0 and f untouched (always 0 in a PF_SCENE_TEXTURES = 0 build). */
static inline int pf_texture_factor(__global const pf_texture* textures, __global const float* texels,
                                    __global const pf_int* mat_tex, __global const float* uvs,
                                    int material, const pf_ray_hit* h, float* f) {
  if (!PF_SCENE_TEXTURES) return 0; /* a scene without textures (scene_features.h) */
  const int ti = mat_tex[material];
  if (ti < 0) return 0;
  const pf_texture t = textures[ti];
  float rgba[4];
  pf_tex_sample_triangle(&t, texels, uvs + 6 * (size_t)h->tri, h->u, h->v, rgba);
  f[0] = rgba[0];
  f[1] = rgba[1];
  f[2] = rgba[2];
  return 1;
}

/* The BSDF parameters of a PF_MAT_PBR material at hit h: surface.h's bsdf_params_at, through the
 * same shared function (pbr_point_shared.h pf_pbr_params_at). */
static inline void pf_pbr_params_hit(__global const pf_texture* textures, __global const float* texels,
                                     __global const pf_int* mat_tex, __global const float* uvs,
                                     __global const pf_int* mr_tex, __global const pf_material* mats,
                                     int material, const pf_ray_hit* h, pf_bsdf_params* p) {
  const int bt = mat_tex[material], mt = mr_tex[material];
  pf_pbr_params_at(&mats[material], textures, texels, bt, mt,
                   bt >= 0 || mt >= 0 ? uvs + 6 * (size_t)h->tri : uvs, h->u, h->v, p);
}

/* Origin of a ray leaving the surface along d: pushed off on d's side (surface.h). */
static inline void pf_offset_origin(const pf_surface* sh, const float* d, float eps, float* o) {
  const float e = pf_dot3(d, sh->ng) >= 0.0f ? eps : -eps;
  for (int k = 0; k < 3; ++k) o[k] = sh->p[k] + sh->ng[k] * e;
}

/* Light chosen by power: std::upper_bound over the CDF (first entry > u), clamped. Writes the
 * light's selection probability. */
static inline int pf_pick_light(const pf_scene_view* s, float u, float* p_light) {
  int lo = 0, hi = s->light_count;
  while (lo < hi) {
    const int mid = lo + (hi - lo) / 2;
    if (u < s->light_cdf[mid])
      hi = mid;
    else
      lo = mid + 1;
  }
  const int li = lo < s->light_count - 1 ? lo : s->light_count - 1;
  *p_light = s->light_cdf[li] - (li ? s->light_cdf[li - 1] : 0.0f);
  return li;
}

/* Scene::sample_light's choice: the light that u picks for next-event estimation at x, by power
 * or by x's local choice where the view has one (light_choice_shared.h eq. 1). Writes the pick's
 * probability. */
static inline int pf_pick_nee_light(const pf_scene_view* s, const float* x, float u,
                                    float* p_light) {
  if (!s->choice_on) return pf_pick_light(s, u, p_light);
  float pr[PF_LIGHT_CHOICE_MAX];
  pf_light_choice_probabilities(s->lights, s->choice, s->light_count, x, pr);
  const int li = pf_light_choice_pick(pr, s->light_count, u);
  *p_light = pr[li];
  return li;
}

/* Scene::light_pick_probability: the probability that NEE at x picks light li. */
static inline float pf_nee_pick_probability(const pf_scene_view* s, int li, const float* x) {
  if (!s->choice_on) return s->light_cdf[li] - (li ? s->light_cdf[li - 1] : 0.0f);
  float pr[PF_LIGHT_CHOICE_MAX];
  pf_light_choice_probabilities(s->lights, s->choice, s->light_count, x, pr);
  return pr[li];
}

/* Scene::environment_light_pdf(d, x): NEE's density of the unit direction d at x, per unit solid
 * angle, with x's light choice. */
static inline float pf_env_light_pdf_at(const pf_scene_view* s, const float* d, const float* x) {
  const float pdf = pf_env_light_pdf(s->env, d); /* p_pick by power × pdf_ω */
  if (!s->choice_on || !(pdf > 0.0f)) return pdf;
  const int li = s->light_count - 1; /* the environment is the last light */
  return pdf * (pf_nee_pick_probability(s, li, x) / s->choice[li].power_p);
}

/* Diffuse for light transport: Lambertian, or an emitter whose surface reflects (eye_pass.cpp). */
static inline int pf_is_diffuse(__global const pf_material* m) {
  float c[3] = {m->color[0], m->color[1], m->color[2]};
  return m->type == PF_MAT_DIFFUSE || (m->type == PF_MAT_EMITTER && pf_luminance3(c) > 0.0f);
}

/* Glass: reflect with the Fresnel probability F, refract otherwise (and on total internal
 * reflection reflect); `u` is the path's next random number, drawn by the caller in the host's
 * order. Multiplies `weight` by the tint on refraction. d is updated in place. */
static inline void pf_glass_bounce(__global const pf_material* m, const pf_surface* sh,
                                   const float* n, float u, float* d, float* weight) {
  const float eta_i = sh->front ? 1.0f : m->ior;
  const float eta_t = sh->front ? m->ior : 1.0f;
  const float F = pf_fresnel_dielectric(-pf_dot3(d, n), eta_i, eta_t);
  float t[3];
  if (u < F || !pf_refract(d, n, eta_i / eta_t, t)) {
    pf_reflect(d, n, d);
  } else {
    pf_normalize3(t);
    d[0] = t[0];
    d[1] = t[1];
    d[2] = t[2];
    for (int k = 0; k < 3; ++k) weight[k] = weight[k] * m->color[k];
  }
}

#endif /* PF_KERNEL_TRACE_COMMON_H */
