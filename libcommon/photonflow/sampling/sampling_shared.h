/*
 * sampling_shared.h — the sampling and scattering formulas of photon and eye tracing, written once
 * in plain C for the C++ host (sampling.h wraps them for Vec3) and the OpenCL C 1.2 kernels, so
 * both backends evaluate the same expressions in the same order (thesis ch. 3.4: diffuse bounce in
 * the hemisphere, exact mirror bounce, glass with Fresnel; ch. 7.2: the GPU tracer).
 *
 * Rules (as in intersect_shared.h): scalars and float[3] arrays only, no float3, no overloads.
 * Every expression is written with explicit parentheses in the order the host's Vec3 operators
 * evaluate them, and float contraction is off in OpenCL (PoCL would otherwise fuse a·b + c into an
 * FMA and the two backends would drift apart in the last bits). The host's x86-64 baseline target
 * has no FMA, so it never contracts (a build with -mfma must add -ffp-contract=off).
 *
 * Conventions (see sampling.h): random numbers uniform in [0, 1); a direction `d` arriving at a
 * surface points INTO it (dot(d, n) < 0 when n faces the arriving ray).
 */
#ifndef PHOTONFLOW_SAMPLING_SHARED_H
#define PHOTONFLOW_SAMPLING_SHARED_H

#include "photonflow/foundations/cl_compat.h"
#include "photonflow/foundations/shared_types.h"

#ifdef __OPENCL_VERSION__
#pragma OPENCL FP_CONTRACT OFF
#define PF_S_SQRT(x) sqrt(x)
#define PF_S_COS(x) cos(x)
#define PF_S_SIN(x) sin(x)
#define PF_S_FABS(x) fabs(x)
#define PF_S_COPYSIGN(a, b) copysign(a, b)
#else
#include <cmath>
#define PF_S_SQRT(x) std::sqrt(x)
#define PF_S_COS(x) std::cos(x)
#define PF_S_SIN(x) std::sin(x)
#define PF_S_FABS(x) std::fabs(x)
#define PF_S_COPYSIGN(a, b) std::copysign(a, b)
#endif

#define PF_S_PI 3.14159265358979323846f
#define PF_S_INV_PI 0.318309886183790671538f

/* max(0, x) with std::max's semantics: (0 < x) ? x : 0 (NaN gives 0). */
PF_INLINE float pf_max0(float x) { return 0.0f < x ? x : 0.0f; }

PF_INLINE float pf_dot3(const float* a, const float* b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

PF_INLINE void pf_cross3(const float* a, const float* b, float* out) {
  const float x = a[1] * b[2] - a[2] * b[1];
  const float y = a[2] * b[0] - a[0] * b[2];
  const float z = a[0] * b[1] - a[1] * b[0];
  out[0] = x;
  out[1] = y;
  out[2] = z;
}

/* normalize as vec.h: l = sqrt(a·a); a / l when l > 0, else a unchanged. In place. */
PF_INLINE void pf_normalize3(float* a) {
  const float l = PF_S_SQRT(pf_dot3(a, a));
  if (l > 0.0f) {
    a[0] = a[0] / l;
    a[1] = a[1] / l;
    a[2] = a[2] / l;
  }
}

/* Relative luminance of linear Rec.709 RGB (the weights of pf_light.power). */
PF_INLINE float pf_luminance3(const float* rgb) {
  return 0.2126f * rgb[0] + 0.7152f * rgb[1] + 0.0722f * rgb[2];
}

/* Uniform point on triangle (a, b, c) (Osada et al. 2002):
 * P = (1 − √u1)·a + √u1·(1 − u2)·b + √u1·u2·c. Density 1/area. */
PF_INLINE void pf_sample_triangle(const float* a, const float* b, const float* c, float u1,
                                  float u2, float* out) {
  const float su = PF_S_SQRT(u1);
  const float wb = su * (1.0f - u2);
  const float wc = su * u2;
  const float wa = 1.0f - su;
  for (int k = 0; k < 3; ++k) out[k] = a[k] * wa + b[k] * wb + c[k] * wc;
}

/* The barycentric weights of b and c (the (u, v) of a hit) of pf_sample_triangle's point for
 * (u1, u2), by the same expressions: the texture coordinates of a sampled light point. */
PF_INLINE void pf_sample_triangle_weights(float u1, float u2, float* wb, float* wc) {
  const float su = PF_S_SQRT(u1);
  *wb = su * (1.0f - u2);
  *wc = su * u2;
}

/* Tangent t and bitangent b completing unit normal n to a right-handed orthonormal basis
 * (Duff et al. 2017, JCGT 6(1)). */
PF_INLINE void pf_orthonormal_basis(const float* n, float* t, float* b) {
  const float sign = PF_S_COPYSIGN(1.0f, n[2]);
  const float a = -1.0f / (sign + n[2]);
  const float bb = n[0] * n[1] * a;
  t[0] = 1.0f + sign * n[0] * n[0] * a;
  t[1] = sign * bb;
  t[2] = -sign * n[0];
  b[0] = bb;
  b[1] = sign + n[1] * n[1] * a;
  b[2] = -n[1];
}

/* Local (x along t, y along b, z along n) to world: t·x + b·y + n·z. */
PF_INLINE void pf_to_world(const float* loc, const float* n, float* out) {
  float t[3], b[3];
  pf_orthonormal_basis(n, t, b);
  for (int k = 0; k < 3; ++k) out[k] = t[k] * loc[0] + b[k] * loc[1] + n[k] * loc[2];
}

/* sin and cos of x in [−π/4, π/4] by the single-precision minimax polynomials of Cephes' sinf and
 * cosf (S. Moshier; relative error about 1e-7): plain arithmetic, so host and device compute the
 * same bits (library sin/cos differ between libm and OpenCL implementations in the last bit, and
 * PoCL's are several times slower than these for arguments that need no reduction). */
PF_INLINE float pf_sin_pi4(float x) {
  const float z = x * x;
  return x + x * z * (-1.6666654611e-1f + z * (8.3321608736e-3f + z * -1.9515295891e-4f));
}
PF_INLINE float pf_cos_pi4(float x) {
  const float z = x * x;
  return 1.0f - 0.5f * z +
         z * z * (4.166664568298827e-2f + z * (-1.388731625493765e-3f + z * 2.443315711809948e-5f));
}

/* Uniform point on the unit disc, concentric mapping (Shirley & Chiu 1997). The angle is
 * φ = (π/4)·(b/a) in the first case and φ = π/2 − (π/4)·(a/b) in the second, where
 * cos φ = sin θ and sin φ = cos θ with θ = (π/4)·(a/b); both θ lie in [−π/4, π/4]. */
PF_INLINE void pf_sample_concentric_disc(float u1, float u2, float* x, float* y) {
  const float a = 2.0f * u1 - 1.0f;
  const float b = 2.0f * u2 - 1.0f;
  if (a == 0.0f && b == 0.0f) {
    *x = 0.0f;
    *y = 0.0f;
    return;
  }
  if (PF_S_FABS(a) > PF_S_FABS(b)) {
    const float phi = (PF_S_PI / 4.0f) * (b / a);
    *x = a * pf_cos_pi4(phi);
    *y = a * pf_sin_pi4(phi);
  } else {
    const float theta = (PF_S_PI / 4.0f) * (a / b);
    *x = b * pf_sin_pi4(theta);
    *y = b * pf_cos_pi4(theta);
  }
}

/* Cosine-weighted direction around unit normal n (Malley's method). Density cosθ/π. */
PF_INLINE void pf_sample_cosine_hemisphere(const float* n, float u1, float u2, float* out) {
  float loc[3];
  pf_sample_concentric_disc(u1, u2, &loc[0], &loc[1]);
  loc[2] = PF_S_SQRT(pf_max0(1.0f - loc[0] * loc[0] - loc[1] * loc[1]));
  pf_to_world(loc, n, out);
}

/* Uniform direction on the unit sphere. Density 1/(4π). */
PF_INLINE void pf_sample_uniform_sphere(float u1, float u2, float* out) {
  const float z = 1.0f - 2.0f * u1;
  const float r = PF_S_SQRT(pf_max0(1.0f - z * z));
  const float phi = 2.0f * PF_S_PI * u2;
  out[0] = r * PF_S_COS(phi);
  out[1] = r * PF_S_SIN(phi);
  out[2] = z;
}

/* Mirror reflection of arriving d about n (either side): d − n·(2(d·n)). out may alias d. */
PF_INLINE void pf_reflect(const float* d, const float* n, float* out) {
  const float s = 2.0f * pf_dot3(d, n);
  const float r0 = d[0] - n[0] * s, r1 = d[1] - n[1] * s, r2 = d[2] - n[2] * s;
  out[0] = r0;
  out[1] = r1;
  out[2] = r2;
}

/* Refraction of unit d through a surface with unit n facing it, eta = η_i/η_t (Snell).
 * Returns 0 on total internal reflection (out untouched), else 1 and the transmitted direction
 * d·eta + n·(eta·cos_i − cos_t). out must not alias d or n. */
PF_INLINE int pf_refract(const float* d, const float* n, float eta, float* out) {
  const float cos_i = -pf_dot3(d, n);
  const float sin2_t = eta * eta * pf_max0(1.0f - cos_i * cos_i);
  if (sin2_t >= 1.0f) return 0;
  const float cos_t = PF_S_SQRT(1.0f - sin2_t);
  const float s = eta * cos_i - cos_t;
  for (int k = 0; k < 3; ++k) out[k] = d[k] * eta + n[k] * s;
  return 1;
}

/* Fresnel reflectance of a smooth dielectric for unpolarised light (mean of s and p). cos_i is
 * clamped to [0, 1]; returns 1 under total internal reflection. */
PF_INLINE float pf_fresnel_dielectric(float cos_i, float eta_i, float eta_t) {
  cos_i = pf_max0(cos_i);                /* std::max(0, x) first (NaN → 0), */
  cos_i = cos_i < 1.0f ? cos_i : 1.0f;  /* then std::min(1, x) */
  const float sin_i = PF_S_SQRT(pf_max0(1.0f - cos_i * cos_i));
  const float sin_t = eta_i / eta_t * sin_i;
  if (sin_t >= 1.0f) return 1.0f;
  const float cos_t = PF_S_SQRT(pf_max0(1.0f - sin_t * sin_t));
  const float rs = (eta_i * cos_i - eta_t * cos_t) / (eta_i * cos_i + eta_t * cos_t);
  const float rp = (eta_t * cos_i - eta_i * cos_t) / (eta_t * cos_i + eta_i * cos_t);
  return 0.5f * (rs * rs + rp * rp);
}

#endif /* PHOTONFLOW_SAMPLING_SHARED_H */
