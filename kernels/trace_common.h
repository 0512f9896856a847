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

#include "photonflow/shared_types.h"
#include "photonflow/intersect_shared.h"
#include "photonflow/rng.h"
#include "photonflow/sampling_shared.h"

/* The baked scene on the device (scene.h arrays, unchanged layouts). */
typedef struct {
  __global const pf_triangle* tris;
  __global const pf_hh_triangle* hh;
  __global const pf_kd_node* nodes;
  __global const pf_int* leaf_tris;
  __global const pf_material* mats;
  __global const pf_light* lights;
  __global const float* light_cdf;
  int node_count;
  int light_count;
} pf_scene_view;

/* Kernel parameters of the scene, in this order in every tracing kernel. */
#define PF_SCENE_PARAMS                                                                    \
  __global const pf_triangle *tris, __global const pf_hh_triangle *hh,                     \
      __global const pf_kd_node *nodes, int node_count, __global const pf_int *leaf_tris,  \
      __global const pf_material *mats, __global const pf_light *lights,                   \
      __global const float *light_cdf, int light_count

#define PF_SCENE_VIEW(s)   \
  pf_scene_view s;         \
  s.tris = tris;           \
  s.hh = hh;               \
  s.nodes = nodes;         \
  s.leaf_tris = leaf_tris; \
  s.mats = mats;           \
  s.lights = lights;       \
  s.light_cdf = light_cdf; \
  s.node_count = node_count; \
  s.light_count = light_count

/* Closest (any_hit = 0) or any (1) hit of o + t·d for t in (tmin, tmax], rope traversal. */
static inline int pf_trace(const pf_scene_view* s, const float* o, const float* d, float tmin,
                           float tmax, int any_hit, pf_ray_hit* hit) {
  hit->t = tmax;
  hit->tri = -1;
  hit->u = 0.0f;
  hit->v = 0.0f;
  return pf_kd_traverse_ropes(s->nodes, s->node_count, s->leaf_tris, s->hh, o, d, tmin, any_hit,
                              hit);
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
