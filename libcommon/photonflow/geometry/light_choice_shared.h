/*
 * light_choice_shared.h — which light next-event estimation samples at a point x, written once in
 * plain C for the C++ host (Scene::sample_light, pathtrace.cpp, eye_pass.cpp) and the OpenCL eye
 * kernel (trace_hitpoints.cl). Rules as sampling_shared.h: scalars and float[3] only, the same
 * expressions in the same order on both sides, FP_CONTRACT OFF.
 *
 * Choice by power (Scene::light_cdf) wastes samples where a weak light is the one that matters:
 * the showcase's spot has 9 % of the power and lights the rough-glass ball and the floor under it,
 * so a choice by power picks it with p = 0.093 and counts each of its samples 10.75 times. In a
 * scene of 2 to PF_LIGHT_CHOICE_MAX lights with at least two emitters (area lights grouped by
 * their material: the triangles of one lamp are one emitter), the light is picked instead with
 *
 *   p_l(x) = ½ E_l(x) / Σ_k E_k(x)  +  ¼ P_l / Σ_k P_k  +  ¼ u_l                               (1)
 *
 * a defensive mixture (Veach 1997 §9.2.4; Hesterberg 1995) of
 *   E_l(x)  the unoccluded irradiance scale of light l at x, from its centre (luminance):
 *           area π⁻¹·P·cos θ_l / d², point and spot I/d² (0 outside the spot's outer cone),
 *           directional E, environment P/(πR²) — cheap, no visibility, no normal at x;
 *   P_l     the light's power (the power choice);
 *   u_l     uniform over the emitters, split inside an emitter by power.
 * Where every E_l(x) is 0 the first half goes to the other two. Every light keeps p_l(x) ≥ ¼ of
 * its power share, so no light is starved (E_l's estimate from the centroid is 0 for a triangle
 * that only partly faces x, which may still light it). MIS weights of emitters hit by a BSDF
 * sample use the same p_l at the vertex the sample left (pathtrace.cpp, eye_pass.cpp).
 * docs/RESULTS.md "`pathtrace` against Mitsuba 3" measures (1) against each of its parts, and
 * "The light choice and the lens points of emission samples" what it gives the photon mappers.
 *
 * The table (one pf_light_choice per light, Scene::light_choice) is derived from the lights on
 * load and never stored in scene.h5; an empty table means the power choice.
 */
#ifndef PHOTONFLOW_LIGHT_CHOICE_SHARED_H
#define PHOTONFLOW_LIGHT_CHOICE_SHARED_H

#include "photonflow/sampling/sampling_shared.h"

#ifdef __OPENCL_VERSION__
#pragma OPENCL FP_CONTRACT OFF
#endif

/* Largest number of lights the local choice (1) applies to; more go by power. */
#define PF_LIGHT_CHOICE_MAX 16

/* The per-light terms of (1) that do not depend on x (32 bytes, the same layout on both sides). */
typedef struct {
  float centre[3];  /* area: the triangle's centroid; point, spot: the position */
  float power_p;    /* P_l / Σ_k P_k (light_cdf's step) */
  float normal[3];  /* area: the unit face normal; others 0 */
  float uniform_p;  /* u_l: 1/(emitters) × the light's share of its emitter's power */
} pf_light_choice;

/* Luminance of a linear RGB triple, Rec.709 weights (sampling.h luminance). */
PF_INLINE float pf_light_choice_luminance(float r, float g, float b) {
  return 0.2126f * r + 0.7152f * g + 0.0722f * b;
}

/* E_l(x) of (1). */
PF_INLINE float pf_light_choice_irradiance(PF_GLOBAL const pf_light* l,
                                           PF_GLOBAL const pf_light_choice* c, const float* x) {
  if (l->type == PF_LIGHT_DIRECTIONAL)
    return pf_light_choice_luminance(l->radiance[0], l->radiance[1], l->radiance[2]);
  if (l->type == PF_LIGHT_ENVIRONMENT) return l->area > 0.0f ? l->power / l->area : 0.0f;
  const float v[3] = {x[0] - c->centre[0], x[1] - c->centre[1], x[2] - c->centre[2]};
  const float vv = pf_dot3(v, v);
  const float d2 = vv > 1e-8f ? vv : 1e-8f;
  if (l->type == PF_LIGHT_AREA) {
    const float n[3] = {c->normal[0], c->normal[1], c->normal[2]};
    const float cos_l = pf_dot3(v, n) / PF_S_SQRT(d2);
    return cos_l > 0.0f ? l->power * PF_S_INV_PI * cos_l / d2 : 0.0f; /* power = π·A·L_e */
  }
  const float I = pf_light_choice_luminance(l->radiance[0], l->radiance[1], l->radiance[2]);
  if (l->type == PF_LIGHT_SPOT) {
    const float a[3] = {l->direction[0], l->direction[1], l->direction[2]};
    if (pf_dot3(v, a) < l->cos_outer * PF_S_SQRT(d2)) return 0.0f;
  }
  return I / d2;
}

/* p_l(x) of (1) for every light into pr[0 .. n), n ≤ PF_LIGHT_CHOICE_MAX. */
PF_INLINE void pf_light_choice_probabilities(PF_GLOBAL const pf_light* lights,
                                             PF_GLOBAL const pf_light_choice* c, int n,
                                             const float* x, float* pr) {
  float total = 0.0f;
  for (int i = 0; i < n; ++i) {
    pr[i] = pf_light_choice_irradiance(&lights[i], &c[i], x);
    total = total + pr[i];
  }
  const float a = total > 0.0f ? 0.5f / total : 0.0f;
  const float b = total > 0.0f ? 0.25f : 0.5f;
  for (int i = 0; i < n; ++i) pr[i] = a * pr[i] + b * (c[i].power_p + c[i].uniform_p);
}

/* The light that u in [0, 1) picks from pr[0 .. n): the first i with u < pr[0] + … + pr[i],
 * the last light when rounding leaves u above the sum. */
PF_INLINE int pf_light_choice_pick(const float* pr, int n, float u) {
  int i = 0;
  float acc = pr[0];
  while (i + 1 < n && !(u < acc)) {
    i = i + 1;
    acc = acc + pr[i];
  }
  return i;
}

#endif /* PHOTONFLOW_LIGHT_CHOICE_SHARED_H */
