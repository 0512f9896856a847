/*
 * environment_shared.h — the environment light (PF_LIGHT_ENVIRONMENT, shared_types.h): an
 * equirectangular radiance map around the scene, written once in plain C for the C++ host
 * (scene.cpp, photon_pass.cpp, pathtrace.cpp through Scene) and the OpenCL kernels
 * (trace_photons.cl; trace_hitpoints.cl through pf_scene_view.env). Rules as sampling_shared.h:
 * scalars and float[3] only, the same expressions in the same order on both sides, FP_CONTRACT
 * OFF, and no library trigonometry (sin, cos, atan2 and acos below are polynomials), so host and
 * device sample the same directions and give photons the same flux, bit for bit.
 *
 * Orientation (docs/SCENES.md "Environment"), that of Mitsuba 3's `envmap` emitter with an
 * identity to_world (src/emitters/envmap.cpp, eval): for a unit world direction d pointing from
 * the scene towards the environment, first turned back by the rotation about +y (d_l = R_y(−ρ)·d),
 *   u = atan2(d_l.x, −d_l.z) / 2π  (mod 1),   v = acos(d_l.y) / π,   v = 0 the image's top row,
 * and back: θ = π·v, φ = 2π·u, d_l = (sin θ sin φ, cos θ, −sin θ cos φ), d = R_y(ρ)·d_l with
 * R_y(ρ)·(x, y, z) = (cos ρ·x + sin ρ·z, y, −sin ρ·x + cos ρ·z).
 *
 * Radiance: texel-constant (texel (i, j), column i of W, row j of H, covers u in [i/W, (i+1)/W),
 * v in [j/H, (j+1)/H)), times the strength: L(d) = strength · texel(u, v). Texel-constant so that
 * the radiance and the sampling density are constant over the same cells.
 *
 * Sampling (pbrt-v3 InfiniteAreaLight, Pharr, Jakob & Humphreys 2016, sec. 14.2.4 with its
 * Distribution2D of sec. 13.6.7): a piecewise-constant 2-D distribution over the texels with
 * f(i, j) = luminance(texel) · sin θ_j (θ_j the row's centre), the marginal over rows and the
 * conditional within each row; for a point (u, v) in texel (i, j)
 *   pdf_uv = f(i, j) / ∫∫ f du dv = f(i, j) · W·H / Σ f,        pdf_ω = pdf_uv / (2π² sin θ)
 * (pbrt-v3 eq. 14.12 and InfiniteAreaLight::Pdf_Li). The MIS density of a direction is this same
 * pdf_ω (pf_env_pdf), the one pf_env_sample draws from.
 *
 * The packed buffer (one float array, built by the host: geometry/environment.cpp
 * pack_environment; uploaded as-is to the device): PF_ENV_HEADER header floats, then the texels
 * (3·W·H, RGB, row-major, row 0 the top), f (W·H), the conditional CDFs (H rows of W + 1 entries,
 * each from 0 to 1), the marginal CDF (H + 1 entries). A buffer whose width is 0 is "no
 * environment": every function returns 0.
 */
#ifndef PHOTONFLOW_ENVIRONMENT_SHARED_H
#define PHOTONFLOW_ENVIRONMENT_SHARED_H

#include "photonflow/sampling/sampling_shared.h"

#ifdef __OPENCL_VERSION__
#pragma OPENCL FP_CONTRACT OFF
#endif

/* Header slots of the packed buffer. */
#define PF_ENV_WIDTH 0     /* W, columns (an integer as a float; 0 = no environment) */
#define PF_ENV_HEIGHT 1    /* H = W / 2, rows */
#define PF_ENV_STRENGTH 2  /* radiance scale */
#define PF_ENV_COS_ROT 3   /* cos ρ, ρ the rotation about +y */
#define PF_ENV_SIN_ROT 4   /* sin ρ */
#define PF_ENV_INV_FUNC 5  /* W·H / Σ f: pdf_uv = f · this */
#define PF_ENV_CENTRE 6    /* 3 floats: the centre c of the scene's bounding sphere */
#define PF_ENV_RADIUS 9    /* its radius R */
#define PF_ENV_LIGHT 10    /* the environment's index in the scene's lights (−1 none) */
#define PF_ENV_P_PICK 11   /* its pick probability in the light CDF */
#define PF_ENV_HEADER 16

/* The photons' disc lies this many R from c towards the sampled direction (> 1: outside the
 * bounds, as the directional light's disc: scene.h kDirectionalDiscMargin). */
#define PF_ENV_DISC_MARGIN 1.01f

PF_INLINE int pf_env_width(PF_GLOBAL const float* env) { return (int)env[PF_ENV_WIDTH]; }
PF_INLINE int pf_env_height(PF_GLOBAL const float* env) { return (int)env[PF_ENV_HEIGHT]; }
/* Offsets of the tables after the header (floats). */
PF_INLINE int pf_env_func_at(int w, int h) { return PF_ENV_HEADER + 3 * w * h; }
PF_INLINE int pf_env_cond_at(int w, int h) { return PF_ENV_HEADER + 4 * w * h; }
PF_INLINE int pf_env_marg_at(int w, int h) { return PF_ENV_HEADER + 4 * w * h + h * (w + 1); }
/* Floats of the packed buffer for a W×H map. */
PF_INLINE int pf_env_packed_size(int w, int h) {
  return PF_ENV_HEADER + 4 * w * h + h * (w + 1) + h + 1;
}

/* sin and cos of 2π·t for t in [0, 1] without library trigonometry: t to the nearest quarter
 * turn k/4, the rest r = 2π·(t − k/4) in [−π/4, π/4] through pf_sin_pi4 / pf_cos_pi4, then
 * sin(r + kπ/2), cos(r + kπ/2) by the quadrant. */
PF_INLINE void pf_sincos_turns(float t, float* s, float* c) {
  const int q = (int)(t * 4.0f + 0.5f); /* t ≥ 0: truncation is floor */
  const float r = (t - (float)q * 0.25f) * (2.0f * PF_S_PI);
  const float sr = pf_sin_pi4(r), cr = pf_cos_pi4(r);
  const int k = q & 3;
  if (k == 0) {
    *s = sr;
    *c = cr;
  } else if (k == 1) {
    *s = cr;
    *c = -sr;
  } else if (k == 2) {
    *s = -sr;
    *c = -cr;
  } else {
    *s = -cr;
    *c = sr;
  }
}

/* atan2(y, x) in [−π, π] without library trigonometry: Cephes' atanf (S. Moshier) on
 * t = min(|x|, |y|) / max(|x|, |y|) in [0, 1], reduced to [−tan(π/8), tan(π/8)] by
 * atan t = π/4 + atan((t − 1)/(t + 1)), then the octant. 0 for x = y = 0. */
PF_INLINE float pf_atan2(float y, float x) {
  const float ax = PF_S_FABS(x), ay = PF_S_FABS(y);
  const float mx = ax > ay ? ax : ay;
  const float mn = ax > ay ? ay : ax;
  if (!(mx > 0.0f)) return 0.0f;
  float t = mn / mx, base = 0.0f;
  if (t > 0.41421356237309504880f) {
    base = PF_S_PI / 4.0f;
    t = (t - 1.0f) / (t + 1.0f);
  }
  const float z = t * t;
  float a = ((((8.05374449538e-2f * z - 1.38776856032e-1f) * z + 1.99777106478e-1f) * z -
              3.33329491539e-1f) * z) * t + t + base;
  if (ay > ax) a = PF_S_PI / 2.0f - a;
  if (x < 0.0f) a = PF_S_PI - a;
  return y < 0.0f ? -a : a;
}

/* The texel (column, row) of a unit world direction d (the orientation above). */
PF_INLINE void pf_env_texel_of(PF_GLOBAL const float* env, const float* d, int* col, int* row,
                               float* sin_theta) {
  const int w = pf_env_width(env), h = pf_env_height(env);
  const float c = env[PF_ENV_COS_ROT], s = env[PF_ENV_SIN_ROT];
  /* d_l = R_y(−ρ)·d */
  const float lx = c * d[0] - s * d[2];
  const float ly = d[1];
  const float lz = s * d[0] + c * d[2];
  const float st = PF_S_SQRT(lx * lx + lz * lz);
  float u = pf_atan2(lx, -lz) * (0.5f * PF_S_INV_PI);
  if (u < 0.0f) u = u + 1.0f;
  const float v = pf_atan2(st, ly) * PF_S_INV_PI; /* acos(d_l.y) for a unit d */
  int i = (int)(u * (float)w), j = (int)(v * (float)h);
  *col = i < w - 1 ? (i > 0 ? i : 0) : w - 1;
  *row = j < h - 1 ? (j > 0 ? j : 0) : h - 1;
  *sin_theta = st;
}

/* Radiance L(d) (W/(sr m²)) arriving from the environment along the unit world direction d
 * (d points away from the scene: an escaping ray's direction), texel-constant times strength.
 * Writes 0 without an environment. */
PF_INLINE void pf_env_radiance(PF_GLOBAL const float* env, const float* d, float* le) {
  le[0] = 0.0f;
  le[1] = 0.0f;
  le[2] = 0.0f;
  const int w = pf_env_width(env);
  if (w <= 0) return;
  int col, row;
  float st;
  pf_env_texel_of(env, d, &col, &row, &st);
  PF_GLOBAL const float* t = env + PF_ENV_HEADER + 3 * (row * w + col);
  const float k = env[PF_ENV_STRENGTH];
  for (int c = 0; c < 3; ++c) le[c] = t[c] * k;
}

/* The environment's sampling density pdf_ω (per unit solid angle) of the unit world direction d,
 * without the light's pick probability: pdf_uv / (2π² sin θ), 0 at the poles (sin θ = 0) and
 * without an environment. */
PF_INLINE float pf_env_pdf(PF_GLOBAL const float* env, const float* d) {
  const int w = pf_env_width(env), h = pf_env_height(env);
  if (w <= 0) return 0.0f;
  int col, row;
  float st;
  pf_env_texel_of(env, d, &col, &row, &st);
  if (!(st > 0.0f)) return 0.0f;
  const float f = env[pf_env_func_at(w, h) + row * w + col];
  return (f * env[PF_ENV_INV_FUNC]) / ((2.0f * PF_S_PI * PF_S_PI) * st);
}

/* The light-sampling density of direction d as next-event estimation draws it (Scene::
 * sample_light): the environment's pick probability times pf_env_pdf (solid angle). The density
 * a BSDF-sampled ray that escapes weighs against (MIS). */
PF_INLINE float pf_env_light_pdf(PF_GLOBAL const float* env, const float* d) {
  if (pf_env_width(env) <= 0) return 0.0f;
  return env[PF_ENV_P_PICK] * pf_env_pdf(env, d);
}

/* One of pbrt's Distribution1D::SampleContinuous over n cells whose CDF (n + 1 entries, cdf[0] =
 * 0, cdf[n] = 1) starts at `cdf`: the cell o, the largest with cdf[o] ≤ u (clamped to 0 .. n−1;
 * cells of zero width are never chosen), and the continuous position (o + du)/n, du the
 * fraction of u within the cell. */
PF_INLINE int pf_env_sample_1d(PF_GLOBAL const float* cdf, int n, float u, float* x) {
  int lo = 0, hi = n; /* invariant: cdf[lo] ≤ u (or lo = 0), cdf[hi] > u (or hi = n) */
  while (hi - lo > 1) {
    const int mid = (lo + hi) / 2;
    if (cdf[mid] <= u)
      lo = mid;
    else
      hi = mid;
  }
  const float c0 = cdf[lo], c1 = cdf[lo + 1];
  float du = u - c0;
  if (c1 - c0 > 0.0f) du = du / (c1 - c0);
  du = du < 0.0f ? 0.0f : (du < 1.0f ? du : 0.99999994f);
  *x = ((float)lo + du) / (float)n;
  return lo;
}

/* Samples a direction from the environment by two uniform numbers u1 (the row), u2 (the column):
 * writes w, the unit world direction towards the environment, and le = L(w) (the texel sampled,
 * times strength), and returns pdf_ω (solid angle, without the pick probability); 0 without an
 * environment or for a sample at a pole (w and le then 0). */
PF_INLINE float pf_env_sample(PF_GLOBAL const float* env, float u1, float u2, float* w,
                              float* le) {
  const int nw = pf_env_width(env), nh = pf_env_height(env);
  for (int k = 0; k < 3; ++k) {
    w[k] = 0.0f;
    le[k] = 0.0f;
  }
  if (nw <= 0) return 0.0f;
  float v, u;
  const int row = pf_env_sample_1d(env + pf_env_marg_at(nw, nh), nh, u1, &v);
  const int col = pf_env_sample_1d(env + pf_env_cond_at(nw, nh) + row * (nw + 1), nw, u2, &u);
  float st, ct, sp, cp;
  pf_sincos_turns(0.5f * v, &st, &ct); /* θ = π·v */
  pf_sincos_turns(u, &sp, &cp);        /* φ = 2π·u */
  st = pf_max0(st);
  const float lx = st * sp, ly = ct, lz = -(st * cp);
  const float c = env[PF_ENV_COS_ROT], s = env[PF_ENV_SIN_ROT];
  w[0] = c * lx + s * lz; /* d = R_y(ρ)·d_l */
  w[1] = ly;
  w[2] = -(s * lx) + c * lz;
  PF_GLOBAL const float* t = env + PF_ENV_HEADER + 3 * (row * nw + col);
  const float k = env[PF_ENV_STRENGTH];
  for (int ch = 0; ch < 3; ++ch) le[ch] = t[ch] * k;
  const float sin_theta = PF_S_SQRT(lx * lx + lz * lz); /* as pf_env_pdf measures it */
  if (!(sin_theta > 0.0f)) return 0.0f;
  const float f = env[pf_env_func_at(nw, nh) + row * nw + col];
  return (f * env[PF_ENV_INV_FUNC]) / ((2.0f * PF_S_PI * PF_S_PI) * sin_theta);
}

/* Next-event estimation of the environment at point p (the G of light_shared.h
 * pf_light_incident, for PF_LIGHT_ENVIRONMENT): samples w (pf_env_sample), writes le = L(w) and
 * q, the shadow ray's end, p + w·2(R + |p − c|) (beyond the scene's bounding sphere: a shadow ray
 * "to infinity"), and returns G = 1 / pdf_ω, so that L_direct ≈ le · f · |cos θ_x| · G / p_light
 * and the sample's solid-angle density is p_light / G. 0: no sample. */
PF_INLINE float pf_env_incident(PF_GLOBAL const float* env, const float* p, float u1, float u2,
                                float* w, float* q, float* le) {
  const float pdf = pf_env_sample(env, u1, u2, w, le);
  for (int k = 0; k < 3; ++k) q[k] = p[k];
  if (!(pdf > 0.0f)) return 0.0f;
  float rel[3];
  for (int k = 0; k < 3; ++k) rel[k] = p[k] - env[PF_ENV_CENTRE + k];
  const float reach = 2.0f * (env[PF_ENV_RADIUS] + PF_S_SQRT(pf_dot3(rel, rel)));
  for (int k = 0; k < 3; ++k) q[k] = p[k] + w[k] * reach;
  return 1.0f / pdf;
}

/* Photon emission from the environment (pbrt-v3 InfiniteAreaLight::Sample_Le): ω from the map
 * (u1, u2: pf_env_sample), the photon travelling along d = −ω from o, a uniform point (u3, u4:
 * the concentric disc) of the disc of radius R perpendicular to ω whose centre lies
 * PF_ENV_DISC_MARGIN·R from c towards ω (pdf_pos = 1/(πR²)). Writes o, d and `power` =
 * L(ω) / (pdf_ω · pdf_pos) = L(ω)·πR²/pdf_ω (divide by the pick probability for the photon's
 * flux) and returns 1, or 0 (no photon) for a sample the map gives no density. */
PF_INLINE int pf_env_emit(PF_GLOBAL const float* env, float u1, float u2, float u3, float u4,
                          float* o, float* d, float* power) {
  float w[3], le[3];
  const float pdf = pf_env_sample(env, u1, u2, w, le);
  if (!(pdf > 0.0f)) return 0;
  float x, y, t[3], b[3];
  pf_sample_concentric_disc(u3, u4, &x, &y);
  pf_orthonormal_basis(w, t, b);
  const float r = env[PF_ENV_RADIUS];
  const float reach = r * PF_ENV_DISC_MARGIN;
  const float px = x * r, py = y * r;
  for (int k = 0; k < 3; ++k) {
    o[k] = env[PF_ENV_CENTRE + k] + w[k] * reach + t[k] * px + b[k] * py;
    d[k] = -w[k];
  }
  const float f = (PF_S_PI * (r * r)) / pdf;
  for (int k = 0; k < 3; ++k) power[k] = le[k] * f;
  return 1;
}

#endif /* PHOTONFLOW_ENVIRONMENT_SHARED_H */
