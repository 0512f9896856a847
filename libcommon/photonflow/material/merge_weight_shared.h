/*
 * material/merge_weight_shared.h — how an eye path shares the light at a glossy (PF_MAT_PBR)
 * vertex between gathering photons there (merging) and continuing by the BSDF's sample, written
 * once for the C++ host and the OpenCL C kernels (the rules of bsdf_shared.h).
 *
 * At a narrow lobe a gather is a narrow density estimate: few of the photons within the radius
 * fall in the lobe, and the estimate is blotchy. Continuing by the BSDF's sample (pbrt-v3's SPPM
 * through every non-diffuse BSDF) suits a narrow lobe and wastes a wide one, whose light a gather
 * estimates at once from every direction. Vertex connection and merging (Georgiev, Křivánek,
 * Davidovič, Slusallek 2012, section 5; Hachisuka, Pantaleoni, Jensen 2012) weights merging
 * against the other strategies of the same path by MIS. For a path x0 (eye) → x1 (glossy) → x2
 * (diffuse), merging at x1 and merging at x2 after the BSDF's sample at x1 share the light
 * sub-path up to x2 and the radius; the ratio of their path densities is
 *     p_merge(x1) / p_merge(x2) = p_light(x2 → x1) / p_eye(x1 → x2)
 *                               = (cos θ_2/π · |cos θ_1| / d²) / (p_bsdf(ω_o, ω_i) · cos θ_2 / d²)
 *                               = (|cos θ_1| / π) / p_bsdf(ω_o, ω_i),
 * with the photon's diffuse scattering at x2 (cos θ_2/π) and ω_i = x1 → x2. The merge weight of
 * direction ω_i is the power heuristic (Veach 1997 eq. 9.13) between a = κ |cos θ_i| / π and
 * b = p_bsdf(ω_o, ω_i) (pf_bsdf_pdf, the sampler's own density):
 *     w_m(ω_o, ω_i) = a² / (a² + b²),    w_c = 1 − w_m                                   (1)
 * A wide lobe (b ≈ cos/π) is mostly merged, a narrow one (b ≫ a inside the lobe) continued, with
 * no roughness at which the rule jumps. κ = PF_MERGE_SCALE favours the gather: one eye sample a
 * pass continues, against the pass's whole photon map for the gather (chosen by measurement,
 * docs/RESULTS.md "Glossy points").
 *
 * The two weights partition the directions, so
 *     L_o = ∫ w_m f L_i cos dω + ∫ w_c f L_i cos dω                                      (2)
 * for any w_m in [0, 1]: the gather estimates the first term (each photon's f times w_m of its
 * direction, pf_pbr_point_eval), the continuation the second (the BSDF sample's weight times
 * w_c). An eye sample takes ONE of the two, merging with probability q (pf_merge_probability)
 * and dividing by it, q or 1 − q, so each pass still stores one visible point per eye sample:
 *     E = q · (M / q) + (1 − q) · (C / (1 − q)) = M + C.                                  (3)
 * q is the share of the lobe that (1) merges, estimated from fixed BSDF samples (no random
 * number, the same bits on host and device). Where q < PF_MERGE_Q_MIN the vertex always
 * continues with w_c = 1, where q > 1 − PF_MERGE_Q_MIN it always merges with w_m = 1 (either
 * side of (2) alone is then the whole integral: no bias, and no sample divided by a tiny q).
 * Direct light at the vertex is not shared this way: next-event estimation and the BSDF's sample
 * hitting an emitter are weighted against each other by the power heuristic (eye_pass.cpp),
 * since the photons the gather counts carry no direct light (render_defaults.h).
 */
#ifndef PHOTONFLOW_MATERIAL_MERGE_WEIGHT_SHARED_H
#define PHOTONFLOW_MATERIAL_MERGE_WEIGHT_SHARED_H

#include "photonflow/material/bsdf_shared.h"

#ifdef __OPENCL_VERSION__
#pragma OPENCL FP_CONTRACT OFF
#endif

/* κ of (1): the merge density's factor over |cos θ|/π. */
#ifndef PF_MERGE_SCALE
#define PF_MERGE_SCALE 4.0f
#endif
/* Below this merge share a vertex always continues, above 1 − it always merges. */
#define PF_MERGE_Q_MIN 0.02f
/* Fixed BSDF samples that estimate the merge share q. */
#define PF_MERGE_Q_SAMPLES 16

/* The power heuristic, β = 2 (Veach 1997 eq. 9.13): the weight of the strategy of density a
 * against one of density b (0 when both are 0). */
PF_INLINE float pf_power_heuristic(float a, float b) {
  const float a2 = a * a, b2 = b * b;
  return a2 + b2 > 0.0f ? a2 / (a2 + b2) : 0.0f;
}

/* (1) in the BSDF's local frame (o, i as pf_bsdf_eval takes them). */
PF_INLINE float pf_merge_weight(const pf_bsdf_params* m, const float* o, const float* i) {
  const float a = PF_MERGE_SCALE * PF_S_FABS(i[2]) * PF_S_INV_PI;
  const float b = pf_bsdf_pdf(m, o, i);
  const float a2 = a * a, b2 = b * b;
  return a2 + b2 > 0.0f ? a2 / (a2 + b2) : 1.0f;
}

/* Radical inverse of k in base 2 and 3 (k < 32): the fixed points of pf_merge_probability. */
PF_INLINE float pf_merge_radical2(int k) {
  float r = 0.0f, f = 0.5f;
  for (int b = k; b > 0; b >>= 1, f *= 0.5f)
    if (b & 1) r += f;
  return r;
}
PF_INLINE float pf_merge_radical3(int k) {
  float r = 0.0f, f = 1.0f / 3.0f;
  for (int b = k; b > 0; b /= 3, f *= (1.0f / 3.0f)) r += f * (float)(b % 3);
  return r;
}

/* The merge probability q of (3) at a vertex with outgoing direction o (local frame): the share
 * of the lobe's sampled throughput that (1) gives the gather,
 *     q = Σ_k w_m(o, i_k) Y(β_k) / Σ_k Y(β_k)
 * over PF_MERGE_Q_SAMPLES samples i_k of pf_bsdf_sample at fixed points (a Hammersley set
 * shifted by half a cell; β_k their weights, Y the luminance), snapped to 0 below
 * PF_MERGE_Q_MIN and to 1 above 1 − PF_MERGE_Q_MIN. 1 when every sample is lost. */
PF_INLINE float pf_merge_probability(const pf_bsdf_params* m, const float* o) {
  float num = 0.0f, den = 0.0f;
  for (int k = 0; k < PF_MERGE_Q_SAMPLES; ++k) {
    const float u1 = ((float)k + 0.5f) / (float)PF_MERGE_Q_SAMPLES;
    const float u2 = pf_merge_radical2(k) + 0.5f / (float)PF_MERGE_Q_SAMPLES;
    const float u3 = pf_merge_radical3(k) + 1.0f / 54.0f;
    pf_bsdf_sample_rec rec;
    if (!pf_bsdf_sample(m, o, u1, u2 < 1.0f ? u2 : u2 - 1.0f, u3, PF_TRANSPORT_RADIANCE, &rec))
      continue;
    const float y = pf_luminance3(rec.weight);
    if (!(y > 0.0f)) continue;
    num += pf_merge_weight(m, o, rec.wi) * y;
    den += y;
  }
  if (!(den > 0.0f)) return 1.0f;
  const float q = num / den;
  if (q < PF_MERGE_Q_MIN) return 0.0f;
  if (q > 1.0f - PF_MERGE_Q_MIN) return 1.0f;
  return q;
}

#endif /* PHOTONFLOW_MATERIAL_MERGE_WEIGHT_SHARED_H */
