/*
 * material/bsdf_shared.h — the glTF 2.0 metallic-roughness BSDF with a rough dielectric
 * transmission lobe, written once in plain C for the C++ host and the OpenCL C 1.2 kernels (the
 * rules of intersect_shared.h and sampling_shared.h: scalars and float[3] arrays, no float3, no
 * references, no std::; float contraction off).
 *
 * Layer: material model (libcommon/photonflow/material/). It depends only on cl_compat.h,
 * shared_types.h and sampling_shared.h (geometry helpers, the concentric disc). Used by
 * scene-bake's material import (material_import.cpp), by geometry/surface.h (scattering at a hit:
 * the photon pass, the eye passes and the path tracer) and, through pbr_point_shared.h and
 * pbr_scatter_shared.h, by the OpenCL kernels.
 *
 * Parameters (pf_bsdf_params, the glTF material's values after texture lookup)
 *
 *   | name          | range    | meaning                                                        |
 *   |---------------|----------|----------------------------------------------------------------|
 *   | base_color    | [0,1]^3  | linear RGB: diffuse albedo of dielectrics, F0 of metals, tint   |
 *   |               |          | of the transmission lobe (KHR_materials_transmission)          |
 *   | metallic      | [0,1]    | mix(dielectric, metal, metallic) (spec appendix B)             |
 *   | roughness     | [0,1]    | perceptual roughness; α = roughness², clamped to ≥ ALPHA_MIN   |
 *   | transmission  | [0,1]    | share of the dielectric's base that is the rough BTDF          |
 *   | ior           | > 1      | KHR_materials_ior, default 1.5 (F0 = ((ior−1)/(ior+1))² = 0.04)|
 *
 * ior = 1 with transmission is index-matched: light passes straight through whatever the
 * roughness, a delta this code does not represent (its transmission samples are lost, f = 0);
 * scene-bake should treat such a surface as invisible or refuse it.
 *
 * Model (glTF 2.0 specification, appendix B "BRDF implementation"; KHR_materials_transmission):
 *   D(h)   = α² χ⁺(n·h) / (π ((n·h)²(α² − 1) + 1)²)                       (GGX / Trowbridge-Reitz)
 *   V      = 1 / (2 (|n·l| √((n·v)²(1 − α²) + α²) + |n·v| √((n·l)²(1 − α²) + α²)))
 *            (height-correlated Smith; V = G2 / (4 |n·l||n·v|), so f_spec = F·D·V)
 *   F(c)   = F0 + (1 − F0)(1 − c)^5                                        (Schlick, c = v·h)
 *   metal      = F(F0 = base_color) · D · V
 *   dielectric = fresnel_mix: (1 − F(F0_ior)) · base + F(F0_ior) · D · V,
 *                base = mix(base_color/π, base_color · BTDF, transmission)
 *   f = mix(dielectric, metal, metallic)
 * The BTDF is Walter et al. 2007's rough dielectric (eq. 16 generalized half vector, eq. 17
 * Jacobian, eq. 21 BTDF) with the same D, the height-correlated Smith G2 = 1/(1 + Λ(o) + Λ(i))
 * (as pbrt-v4's DielectricBxDF) and the Schlick Fresnel taken at the cosine on the outer
 * (lower-IOR) side, which makes it reciprocal and gives total internal reflection from inside.
 * Note the spec's fresnel_mix weights the diffuse base by 1 − F(v·h) with the half vector of
 * (v, l): that is the specification's formula (kept exactly) and it is not energy-conserving at
 * grazing v (docs/MATERIALS.md gives the measured albedo).
 *
 * Frames and conventions: every function works in a LOCAL shading frame, z = shading normal
 * (pf_bsdf_to_local builds it). wo and wi are unit vectors pointing AWAY from the surface; wo is
 * the given direction (towards the camera for eye paths, back along the photon's arrival for
 * photon paths), wi the sampled/other one. Reflection: wo.z·wi.z > 0; transmission: < 0.
 *   - Without transmission the surface is two-sided (wo.z < 0 mirrors the frame).
 *   - With transmission > 0 the side matters: +z is the outside (IOR 1), −z the inside (ior).
 *
 * Transport mode (photon mapping): f(wo, wi) is the radiance BSDF (PF_TRANSPORT_RADIANCE: light
 * arrives along wi, leaves along wo). Photons follow importance's adjoint,
 * f*(wo, wi) = f(wi, wo) (PF_TRANSPORT_IMPORTANCE). The two differ only for transmission, by
 * (η_i/η_o)²: radiance entering a denser medium is scaled by 1/η² (Veach 1997 §5.2, generalized
 * reciprocity f(wo, wi)/η_o² = f(wi, wo)/η_i²), photon flux is not. Shading normals need the
 * further adjoint correction of pf_shading_normal_adjoint for photons (Veach 1996 / 1997 §5.3).
 *
 * Roughness → 0: α is clamped to PF_BSDF_ALPHA_MIN (roughness ≈ 0.032), so every lobe here is
 * non-delta with a finite (if peaked) pdf. Exact mirrors and smooth glass stay the renderer's
 * existing delta paths (PF_MAT_MIRROR, PF_MAT_GLASS and sampling_shared.h); a caller that maps
 * roughness 0 to those never reaches this code. pf_bsdf_sample's `delta` is therefore always 0;
 * it is in the record so that one record serves both kinds of vertex.
 */
#ifndef PHOTONFLOW_MATERIAL_BSDF_SHARED_H
#define PHOTONFLOW_MATERIAL_BSDF_SHARED_H

#include "photonflow/foundations/cl_compat.h"
#include "photonflow/sampling/sampling_shared.h"
#include "photonflow/foundations/shared_types.h"

#ifdef __OPENCL_VERSION__
#pragma OPENCL FP_CONTRACT OFF
#endif

/* Smallest α of a non-delta lobe (pbrt-v4 treats α < 1e-3 as smooth). */
#define PF_BSDF_ALPHA_MIN 1e-3f

#define PF_TRANSPORT_RADIANCE 0   /* eye paths: f(wo, wi) */
#define PF_TRANSPORT_IMPORTANCE 1 /* photon paths: the adjoint f*(wo, wi) = f(wi, wo) */

#define PF_BSDF_LOBE_NONE (-1)
#define PF_BSDF_LOBE_DIFFUSE 0
#define PF_BSDF_LOBE_SPECULAR 1     /* GGX reflection (metal and dielectric coat) */
#define PF_BSDF_LOBE_TRANSMISSION 2 /* Walter 2007 rough dielectric refraction */

/* A material's parameters at a shading point (textures already applied). 28 bytes, 4-byte
 * members only (shared_types.h rules), so an array of them can live in a device buffer. */
typedef struct {
  pf_float base_color[3];
  pf_float metallic;
  pf_float roughness;
  pf_float transmission;
  pf_float ior;
} pf_bsdf_params;

/* A sampled direction. weight = f(wo, wi)·|wi.z| / pdf (rgb), pdf the mixture pdf (solid angle)
 * of all lobes at wi (the one-sample MIS pdf), lobe the PF_BSDF_LOBE_* that produced it. */
typedef struct {
  float wi[3];
  float weight[3];
  float pdf;
  int lobe;
  int delta; /* always 0 here (see the header comment) */
} pf_bsdf_sample_rec;

#ifndef __OPENCL_VERSION__
static_assert(sizeof(pf_bsdf_params) == 28, "pf_bsdf_params layout");
#endif

PF_INLINE float pf_bsdf_clamp01(float x) {
  x = pf_max0(x); /* NaN → 0 */
  return x < 1.0f ? x : 1.0f;
}

/* α = roughness² (spec appendix B), roughness clamped to [0, 1] (NaN → 0), α ≥ ALPHA_MIN. */
PF_INLINE float pf_bsdf_alpha(float roughness) {
  const float r = pf_bsdf_clamp01(roughness);
  const float a = r * r;
  return a > PF_BSDF_ALPHA_MIN ? a : PF_BSDF_ALPHA_MIN;
}

/* ---- microfacet terms ------------------------------------------------------------------- */

/* GGX / Trowbridge-Reitz normal distribution D(h) of cos_h = n·h (spec appendix B; Walter 2007
 * eq. 33). 0 for cos_h ≤ 0 (χ⁺). */
PF_INLINE float pf_ggx_d(float cos_h, float alpha) {
  if (!(cos_h > 0.0f)) return 0.0f;
  const float a2 = alpha * alpha;
  const float t = cos_h * cos_h * (a2 - 1.0f) + 1.0f;
  return a2 / (PF_S_PI * t * t);
}

/* √(c²(1 − α²) + α²) = |c|·√(1 + α² tan²θ): the term shared by Λ, G1 and V. */
PF_INLINE float pf_ggx_root(float c, float alpha) {
  const float a2 = alpha * alpha;
  return PF_S_SQRT(c * c * (1.0f - a2) + a2);
}

/* Smith masking G1(ω) = 1/(1 + Λ(ω)) = 2|c| / (|c| + √(c²(1 − α²) + α²)) (Walter 2007 eq. 34;
 * Heitz 2018 section 2). */
PF_INLINE float pf_ggx_g1(float c, float alpha) {
  const float ac = PF_S_FABS(c);
  const float den = ac + pf_ggx_root(c, alpha);
  return den > 0.0f ? (2.0f * ac) / den : 0.0f;
}

/* Height-correlated Smith visibility V = G2/(4|n·o||n·i|), G2 = 1/(1 + Λ(o) + Λ(i)) (spec
 * appendix B, V_GGX). Arguments are cosines (signs ignored). */
PF_INLINE float pf_ggx_v(float cos_o, float cos_i, float alpha) {
  const float co = PF_S_FABS(cos_o), ci = PF_S_FABS(cos_i);
  const float den = ci * pf_ggx_root(co, alpha) + co * pf_ggx_root(ci, alpha);
  return den > 0.0f ? 0.5f / den : 0.0f;
}

PF_INLINE float pf_pow5(float x) {
  const float x2 = x * x;
  return x2 * x2 * x;
}

/* F0 of a dielectric from its IOR (spec: 0.04 for 1.5). */
PF_INLINE float pf_f0_from_ior(float ior) {
  const float r = (ior - 1.0f) / (ior + 1.0f);
  return r * r;
}

/* Schlick Fresnel of a dielectric interface crossed from a medium of index eta_o (the side of the
 * given direction, cos_oh = |o·h|) to eta_t. The cosine used is the one on the lower-index side:
 * cos_oh itself when eta_o ≤ eta_t, else the refracted cosine by Snell; 1 under total internal
 * reflection. Symmetric in a refracted pair, so the BTDF built on it is reciprocal. */
PF_INLINE float pf_fresnel_schlick_dielectric(float cos_oh, float eta_o, float eta_t, float f0) {
  float c = pf_bsdf_clamp01(PF_S_FABS(cos_oh));
  if (eta_o > eta_t) {
    const float e = eta_o / eta_t;
    const float sin2_t = e * e * (1.0f - c * c);
    if (sin2_t >= 1.0f) return 1.0f;
    c = PF_S_SQRT(1.0f - sin2_t);
  }
  return f0 + (1.0f - f0) * pf_pow5(1.0f - c);
}

/* ---- lobe samplers and their pdfs (local frame, o.z > 0) --------------------------------- */

/* Cosine-weighted direction on the +z hemisphere (Malley; concentric disc). pdf = z/π. */
PF_INLINE void pf_bsdf_sample_cosine(float u1, float u2, float* out) {
  pf_sample_concentric_disc(u1, u2, &out[0], &out[1]);
  out[2] = PF_S_SQRT(pf_max0(1.0f - out[0] * out[0] - out[1] * out[1]));
}
PF_INLINE float pf_bsdf_pdf_cosine(const float* i) { return i[2] > 0.0f ? i[2] * PF_S_INV_PI : 0.0f; }

/* Visible normal h ~ D_o(h) = G1(o) max(0, o·h) D(h) / o.z (Heitz 2018, "Sampling the GGX
 * Distribution of Visible Normals", JCGT 7(4); the steps are its sections 3.2, 4.1, 4.2, 4.3
 * and 3.4). o.z must be > 0. The uniform disc point of section 4.2 comes from the concentric
 * mapping instead of (√u1, 2πu2): the same density, and no library sin/cos (host = device). */
PF_INLINE void pf_ggx_sample_vndf(const float* o, float alpha, float u1, float u2, float* h) {
  /* 3.2: stretch o to the hemisphere configuration */
  float vh[3] = {alpha * o[0], alpha * o[1], o[2]};
  pf_normalize3(vh);
  /* 4.1: orthonormal basis around vh */
  const float lensq = vh[0] * vh[0] + vh[1] * vh[1];
  float t1[3] = {1.0f, 0.0f, 0.0f};
  if (lensq > 0.0f) {
    const float inv = 1.0f / PF_S_SQRT(lensq);
    t1[0] = -vh[1] * inv;
    t1[1] = vh[0] * inv;
  }
  float t2[3];
  pf_cross3(vh, t1, t2);
  /* 4.2: uniform point on the disc, warped onto the visible half */
  float p1, p2;
  pf_sample_concentric_disc(u1, u2, &p1, &p2);
  const float s = 0.5f * (1.0f + vh[2]);
  p2 = (1.0f - s) * PF_S_SQRT(pf_max0(1.0f - p1 * p1)) + s * p2;
  /* 4.3: reproject onto the hemisphere */
  const float pz = PF_S_SQRT(pf_max0(1.0f - p1 * p1 - p2 * p2));
  float nh[3];
  for (int k = 0; k < 3; ++k) nh[k] = p1 * t1[k] + p2 * t2[k] + pz * vh[k];
  /* 3.4: unstretch */
  h[0] = alpha * nh[0];
  h[1] = alpha * nh[1];
  h[2] = pf_max0(nh[2]);
  pf_normalize3(h);
}

/* D_o(h) = G1(o) max(0, o·h) D(h) / o.z (Heitz 2018 section 2, the density sampled above). */
PF_INLINE float pf_ggx_vndf_pdf(const float* o, const float* h, float alpha) {
  const float oh = pf_dot3(o, h);
  if (!(o[2] > 0.0f) || !(oh > 0.0f)) return 0.0f;
  return pf_ggx_g1(o[2], alpha) * oh * pf_ggx_d(h[2], alpha) / o[2];
}

/* GGX reflection lobe: i = reflect(o) about a visible normal. Returns 0 (no direction) when i
 * falls under the horizon (single-scattering loss). pdf(i) = D_o(h) / (4 o·h) (Walter 2007
 * eq. 14 Jacobian) = G1(o) D(h) / (4 o.z). */
PF_INLINE int pf_ggx_sample_reflection(const float* o, float alpha, float u1, float u2,
                                       float* i) {
  float h[3];
  pf_ggx_sample_vndf(o, alpha, u1, u2, h);
  const float oh = pf_dot3(o, h);
  for (int k = 0; k < 3; ++k) i[k] = 2.0f * oh * h[k] - o[k];
  return i[2] > 0.0f;
}
PF_INLINE float pf_ggx_pdf_reflection(const float* o, const float* i, float alpha) {
  if (!(o[2] > 0.0f) || !(i[2] > 0.0f)) return 0.0f;
  float h[3] = {o[0] + i[0], o[1] + i[1], o[2] + i[2]};
  pf_normalize3(h);
  const float oh = pf_dot3(o, h);
  if (!(oh > 0.0f)) return 0.0f;
  return pf_ggx_vndf_pdf(o, h, alpha) / (4.0f * oh);
}

/* Generalized half vector of a refracted pair (Walter 2007 eq. 16), h = ±(η_o o + η_i i)/‖·‖
 * oriented to +z. Returns 0 when the pair is no refraction through any microfacet (o and i on
 * the same side of h). */
PF_INLINE int pf_bsdf_half_transmission(const float* o, const float* i, float eta_o, float eta_i,
                                        float* h) {
  for (int k = 0; k < 3; ++k) h[k] = eta_o * o[k] + eta_i * i[k];
  const float l2 = pf_dot3(h, h);
  if (!(l2 > 0.0f)) return 0;
  const float s = (h[2] < 0.0f ? -1.0f : 1.0f) / PF_S_SQRT(l2);
  for (int k = 0; k < 3; ++k) h[k] = h[k] * s;
  if (!(h[2] > 0.0f)) return 0;
  return pf_dot3(o, h) > 0.0f && pf_dot3(i, h) < 0.0f;
}

/* GGX transmission lobe: i = refract(o) through a visible normal, from index eta_o (o's side,
 * o.z > 0) into eta_i. Returns 0 on total internal reflection or when i does not leave through
 * the other side (i.z ≥ 0). pdf(i) = D_o(h) · η_i² |i·h| / (η_o (o·h) + η_i (i·h))² (Walter 2007
 * eq. 17, with o and i named as here). */
PF_INLINE int pf_ggx_sample_transmission(const float* o, float alpha, float eta_o, float eta_i,
                                         float u1, float u2, float* i) {
  float h[3];
  pf_ggx_sample_vndf(o, alpha, u1, u2, h);
  const float c = pf_dot3(o, h);
  const float e = eta_o / eta_i;
  const float sin2_t = e * e * pf_max0(1.0f - c * c);
  if (sin2_t >= 1.0f) return 0;
  const float cos_t = PF_S_SQRT(1.0f - sin2_t);
  const float s = e * c - cos_t;
  for (int k = 0; k < 3; ++k) i[k] = -e * o[k] + s * h[k];
  pf_normalize3(i);
  return i[2] < 0.0f;
}
PF_INLINE float pf_ggx_pdf_transmission(const float* o, const float* i, float alpha, float eta_o,
                                        float eta_i) {
  if (!(o[2] > 0.0f) || !(i[2] < 0.0f)) return 0.0f;
  float h[3];
  if (!pf_bsdf_half_transmission(o, i, eta_o, eta_i, h)) return 0.0f;
  const float oh = pf_dot3(o, h), ih = pf_dot3(i, h);
  const float den = eta_o * oh + eta_i * ih;
  if (!(den * den > 0.0f)) return 0.0f;
  return pf_ggx_vndf_pdf(o, h, alpha) * (eta_i * eta_i * PF_S_FABS(ih)) / (den * den);
}

/* ---- the material ------------------------------------------------------------------------ */

/* Everything eval, pdf and sample need about (material, wo): the frame flip, the two indices,
 * the clamped parameters and the lobe-selection probabilities. */
typedef struct {
  float flip;  /* −1 when wo.z < 0: the local frame is mirrored so that o.z > 0 */
  float o[3];  /* wo in the (possibly mirrored) frame */
  float eta_o; /* index on o's side */
  float eta_i; /* index on the other side */
  float alpha;
  float metallic;
  float transmission; /* 0 unless the material transmits (and is not fully metallic) */
  float t_lobe;       /* transmission, or 0 where its f is 0 (a black tint): the sampled share */
  float f0;           /* dielectric F0 from ior */
  float metal_f0;     /* luminance of the base colour: the metal's F0 for the lobe choice */
  float p_diffuse;    /* probability of the cosine lobe; 1 − p_diffuse the microfacet lobes */
} pf_bsdf_ctx;

/* The microfacet lobes are sampled together (Heitz 2018 section 2, Walter 2007 section 5.3):
 * a visible normal h ~ D_o(h), then reflection about h with probability
 *   P_r(h) = r / (r + t),  r = (1 − m) F(o·h) + m F_metal(o·h),  t = (1 − m)(1 − F(o·h)) T,
 * refraction through h otherwise (F the dielectric Schlick Fresnel at the microfacet, T the
 * transmission share, m metallic; F_metal Schlick with F0 the base colour's luminance). For a
 * rough dielectric (m = 0, T = 1) P_r = F, the weight of either choice is then G2/G1 ≤ 1 (times
 * (η_o/η_i)² for radiance crossing the interface, Veach 1997 §5.2), and for a conductor
 * (m = 1) it is F_metal·G2/G1 ≤ F: every sample's weight is bounded. The colour of the base
 * (the tint of the transmission) is left out of P_r, so a tinted glass's weight is the tint
 * times the bound. Returns P_r at the microfacet cosine oh = o·h (1 when neither lobe can
 * scatter, so that the pdf and the sampler agree). */
PF_INLINE float pf_bsdf_reflect_probability(const pf_bsdf_ctx* c, float oh) {
  const float fd = pf_fresnel_schlick_dielectric(oh, c->eta_o, c->eta_i, c->f0);
  const float w5 = pf_pow5(1.0f - pf_bsdf_clamp01(oh));
  const float fm = c->metal_f0 + (1.0f - c->metal_f0) * w5;
  const float r = (1.0f - c->metallic) * fd + c->metallic * fm;
  const float t = (1.0f - c->metallic) * (1.0f - fd) * c->t_lobe;
  return r + t > 0.0f ? r / (r + t) : 1.0f;
}

/* The cosine lobe's probability, from an estimate of each lobe's albedo at o (Schlick at n·o,
 * luminance Y of the base colour): diffuse (1 − m)(1 − F)(1 − T) Y against the microfacet lobes'
 * specular (1 − m) F + m F_metal plus transmission (1 − m)(1 − F) T Y. Every lobe that can be
 * non-zero gets at least 0.02 before normalization, so that no direction where f > 0 has pdf 0.
 * It depends on wo only, and pdf() sums the lobes' pdfs with these weights (one-sample MIS),
 * consistent with sample(). */
PF_INLINE int pf_bsdf_setup(const pf_bsdf_params* m, const float* wo, pf_bsdf_ctx* c) {
  if (!(wo[2] != 0.0f)) return 0;
  c->flip = wo[2] < 0.0f ? -1.0f : 1.0f;
  c->o[0] = wo[0];
  c->o[1] = wo[1];
  c->o[2] = wo[2] * c->flip;
  c->alpha = pf_bsdf_alpha(m->roughness);
  c->metallic = pf_bsdf_clamp01(m->metallic);
  float ior = m->ior;
  if (!(ior >= 1.0f)) ior = 1.5f; /* NaN or < 1: the glTF default */
  const float y = pf_bsdf_clamp01(pf_luminance3(m->base_color));
  c->transmission = c->metallic < 1.0f ? pf_bsdf_clamp01(m->transmission) : 0.0f;
  /* a transmission lobe is sampled only where its f can be non-zero (a black tint has none) */
  c->t_lobe = y > 0.0f ? c->transmission : 0.0f;
  c->f0 = pf_f0_from_ior(ior);
  c->metal_f0 = y;
  if (c->transmission > 0.0f && c->flip < 0.0f) {
    c->eta_o = ior;
    c->eta_i = 1.0f;
  } else {
    c->eta_o = 1.0f;
    c->eta_i = ior;
  }
  const float fd = pf_fresnel_schlick_dielectric(c->o[2], c->eta_o, c->eta_i, c->f0);
  const float fm = y + (1.0f - y) * pf_pow5(1.0f - pf_bsdf_clamp01(c->o[2]));
  const float mm = c->metallic, t = c->t_lobe;
  float ps = (1.0f - mm) * fd + mm * fm;
  float pd = (1.0f - mm) * (1.0f - fd) * (1.0f - c->transmission) * y;
  float pt = (1.0f - mm) * (1.0f - fd) * t * y;
  const int has_d = (mm < 1.0f) && (c->transmission < 1.0f) && (y > 0.0f);
  ps = ps > 0.02f ? ps : 0.02f;
  pd = has_d ? (pd > 0.02f ? pd : 0.02f) : 0.0f;
  pt = t > 0.0f ? (pt > 0.02f ? pt : 0.02f) : 0.0f;
  c->p_diffuse = pd / (ps + pd + pt);
  return 1;
}

/* f(wo, wi) · (no cosine), rgb, for transport `mode` (PF_TRANSPORT_*). Local frame. */
PF_INLINE void pf_bsdf_eval(const pf_bsdf_params* m, const float* wo, const float* wi, int mode,
                            float* f) {
  f[0] = f[1] = f[2] = 0.0f;
  pf_bsdf_ctx c;
  if (!pf_bsdf_setup(m, wo, &c)) return;
  const float i[3] = {wi[0], wi[1], wi[2] * c.flip};
  const float* o = c.o;
  if (i[2] > 0.0f) {
    /* reflection: spec appendix B, metal and dielectric (fresnel_mix) */
    float h[3] = {o[0] + i[0], o[1] + i[1], o[2] + i[2]};
    pf_normalize3(h);
    const float oh = pf_bsdf_clamp01(pf_dot3(o, h));
    const float dv = pf_ggx_d(h[2], c.alpha) * pf_ggx_v(o[2], i[2], c.alpha);
    const float fd = pf_fresnel_schlick_dielectric(oh, c.eta_o, c.eta_i, c.f0);
    const float w5 = pf_pow5(1.0f - oh);
    const float diff = (1.0f - fd) * (1.0f - c.transmission) * PF_S_INV_PI;
    for (int k = 0; k < 3; ++k) {
      const float b = m->base_color[k];
      const float fm = b + (1.0f - b) * w5; /* Schlick with F0 = base colour */
      const float dielectric = diff * b + fd * dv;
      const float metal = fm * dv;
      f[k] = (1.0f - c.metallic) * dielectric + c.metallic * metal;
    }
  } else if (i[2] < 0.0f && c.transmission > 0.0f) {
    /* transmission: Walter 2007 eq. 21, f_t = |o·h||i·h| / (|o·n||i·n|) · η_o² (1 − F) G D /
     * (η_o (o·h) + η_i (i·h))², with G / (|o·n||i·n|) = 4V (height-correlated Smith) */
    float h[3];
    if (!pf_bsdf_half_transmission(o, i, c.eta_o, c.eta_i, h)) return;
    const float oh = pf_dot3(o, h), ih = pf_dot3(i, h);
    const float den = c.eta_o * oh + c.eta_i * ih;
    if (!(den * den > 0.0f)) return;
    /* Schlick at the cosine on the lower-index side: for a refracted pair that is |o·h| or |i·h|
     * directly (the same value whichever of the two is given, so f stays reciprocal in float) */
    const float c_ext = pf_bsdf_clamp01(PF_S_FABS(c.eta_o <= c.eta_i ? oh : ih));
    const float fr = c.f0 + (1.0f - c.f0) * pf_pow5(1.0f - c_ext);
    const float eta_num = mode == PF_TRANSPORT_IMPORTANCE ? c.eta_i : c.eta_o;
    const float bt = PF_S_FABS(oh * ih) * (eta_num * eta_num) * (1.0f - fr) * 4.0f *
                     pf_ggx_v(o[2], i[2], c.alpha) * pf_ggx_d(h[2], c.alpha) / (den * den);
    const float w = (1.0f - c.metallic) * c.transmission * bt;
    for (int k = 0; k < 3; ++k) f[k] = w * m->base_color[k];
  }
}

PF_INLINE float pf_bsdf_pdf_ctx(const pf_bsdf_ctx* c, const float* wi) {
  const float i[3] = {wi[0], wi[1], wi[2] * c->flip};
  const float p_micro = 1.0f - c->p_diffuse;
  if (i[2] > 0.0f) {
    float h[3] = {c->o[0] + i[0], c->o[1] + i[1], c->o[2] + i[2]};
    pf_normalize3(h);
    const float oh = pf_dot3(c->o, h);
    if (!(oh > 0.0f)) return c->p_diffuse * pf_bsdf_pdf_cosine(i);
    return c->p_diffuse * pf_bsdf_pdf_cosine(i) +
           p_micro * pf_bsdf_reflect_probability(c, oh) * pf_ggx_vndf_pdf(c->o, h, c->alpha) /
               (4.0f * oh);
  }
  if (i[2] < 0.0f && c->t_lobe > 0.0f) {
    float h[3];
    if (!pf_bsdf_half_transmission(c->o, i, c->eta_o, c->eta_i, h)) return 0.0f;
    const float oh = pf_dot3(c->o, h), ih = pf_dot3(i, h);
    const float den = c->eta_o * oh + c->eta_i * ih;
    if (!(den * den > 0.0f)) return 0.0f;
    return p_micro * (1.0f - pf_bsdf_reflect_probability(c, oh)) *
           pf_ggx_vndf_pdf(c->o, h, c->alpha) * (c->eta_i * c->eta_i * PF_S_FABS(ih)) /
           (den * den);
  }
  return 0.0f;
}

/* Solid-angle pdf with which pf_bsdf_sample returns wi given wo (the mixture over lobes; it
 * integrates to < 1 where a lobe's sample can fail: under the horizon, total internal
 * reflection). The same for both transport modes. */
PF_INLINE float pf_bsdf_pdf(const pf_bsdf_params* m, const float* wo, const float* wi) {
  pf_bsdf_ctx c;
  if (!pf_bsdf_setup(m, wo, &c)) return 0.0f;
  return pf_bsdf_pdf_ctx(&c, wi);
}

/* Samples wi given wo: u3 chooses the lobe (the cosine lobe below p_diffuse; above it the
 * visible normal h from (u1, u2), and u3 rescaled to [0, 1) chooses reflection about h or
 * refraction through it with pf_bsdf_reflect_probability). Returns 1 and fills rec, or 0
 * (rec->lobe = NONE, weight 0) when the sample is lost (a reflection under the horizon: the
 * single-scattering loss) — the path then ends, which is the lobe's energy loss, not a bias. */
PF_INLINE int pf_bsdf_sample(const pf_bsdf_params* m, const float* wo, float u1, float u2,
                             float u3, int mode, pf_bsdf_sample_rec* rec) {
  rec->lobe = PF_BSDF_LOBE_NONE;
  rec->delta = 0;
  rec->pdf = 0.0f;
  rec->weight[0] = rec->weight[1] = rec->weight[2] = 0.0f;
  rec->wi[0] = rec->wi[1] = rec->wi[2] = 0.0f;
  pf_bsdf_ctx c;
  if (!pf_bsdf_setup(m, wo, &c)) return 0;
  float i[3];
  int lobe, ok;
  if (u3 < c.p_diffuse) {
    lobe = PF_BSDF_LOBE_DIFFUSE;
    pf_bsdf_sample_cosine(u1, u2, i);
    ok = i[2] > 0.0f;
  } else {
    float h[3];
    pf_ggx_sample_vndf(c.o, c.alpha, u1, u2, h);
    const float oh = pf_dot3(c.o, h);
    if (!(oh > 0.0f)) return 0;
    float v = (u3 - c.p_diffuse) / (1.0f - c.p_diffuse); /* uniform on [0, 1) again */
    v = v < 1.0f ? v : 0.99999994f;
    if (v < pf_bsdf_reflect_probability(&c, oh)) {
      lobe = PF_BSDF_LOBE_SPECULAR;
      for (int k = 0; k < 3; ++k) i[k] = 2.0f * oh * h[k] - c.o[k];
      ok = i[2] > 0.0f;
    } else {
      lobe = PF_BSDF_LOBE_TRANSMISSION;
      const float e = c.eta_o / c.eta_i;
      const float sin2_t = e * e * pf_max0(1.0f - oh * oh);
      ok = sin2_t < 1.0f; /* P_r = 1 under total internal reflection: never taken there */
      if (ok) {
        const float cos_t = PF_S_SQRT(1.0f - sin2_t);
        const float s = e * oh - cos_t;
        for (int k = 0; k < 3; ++k) i[k] = -e * c.o[k] + s * h[k];
        pf_normalize3(i);
        ok = i[2] < 0.0f;
      }
    }
  }
  if (!ok) return 0;
  const float wi[3] = {i[0], i[1], i[2] * c.flip};
  const float pdf = pf_bsdf_pdf_ctx(&c, wi);
  if (!(pdf > 0.0f)) return 0;
  float f[3];
  pf_bsdf_eval(m, wo, wi, mode, f);
  const float s = PF_S_FABS(wi[2]) / pdf;
  for (int k = 0; k < 3; ++k) {
    rec->wi[k] = wi[k];
    rec->weight[k] = f[k] * s;
  }
  rec->pdf = pdf;
  rec->lobe = lobe;
  return 1;
}

/* ---- frames and shading normals ---------------------------------------------------------- */

/* World → local frame of unit normal n (the basis of pf_orthonormal_basis: x = t, y = b, z = n);
 * pf_to_world (sampling_shared.h) is its inverse. */
PF_INLINE void pf_bsdf_to_local(const float* n, const float* v, float* out) {
  float t[3], b[3];
  pf_orthonormal_basis(n, t, b);
  const float x = pf_dot3(v, t), y = pf_dot3(v, b), z = pf_dot3(v, n);
  out[0] = x;
  out[1] = y;
  out[2] = z;
}

/* Veach's adjoint correction for shading normals (Veach 1996; Veach's thesis 1997, §5.3):
 * a photon (importance transport) scattered with the BSDF evaluated in the shading frame (normal
 * ns, geometric normal ng) is weighted additionally by |wo·ns| |wi·ng| / (|wo·ng| |wi·ns|), where
 * wo is the direction back along the photon's arrival and wi the continuation (world space,
 * both away from the surface). Radiance transport needs no factor. Returns 0 when wo or wi is
 * tangent to the geometric or shading surface (the factor is unbounded there; such a photon is
 * dropped rather than given an infinite weight). */
PF_INLINE float pf_shading_normal_adjoint(const float* wo, const float* wi, const float* ns,
                                          const float* ng) {
  const float den = PF_S_FABS(pf_dot3(wo, ng)) * PF_S_FABS(pf_dot3(wi, ns));
  if (!(den > 0.0f)) return 0.0f;
  return PF_S_FABS(pf_dot3(wo, ns)) * PF_S_FABS(pf_dot3(wi, ng)) / den;
}

#endif /* PHOTONFLOW_MATERIAL_BSDF_SHARED_H */
