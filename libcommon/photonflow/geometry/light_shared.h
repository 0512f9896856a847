/*
 * light_shared.h — the punctual lights of glTF's KHR_lights_punctual that are not isotropic points
 * (PF_LIGHT_SPOT, PF_LIGHT_DIRECTIONAL; shared_types.h), written once in plain C for the C++ host
 * (photon_pass.cpp, eye_pass.cpp, pathtrace.cpp, scene.cpp) and the OpenCL kernels
 * (trace_photons.cl, trace_hitpoints.cl): the spot's angular attenuation, photon emission, and the
 * light one of them sends to a point (next-event estimation). Rules as sampling_shared.h: scalars
 * and float[3] only, the same expressions in the same order on both sides, FP_CONTRACT OFF; the
 * disc and cone samples use the concentric mapping's polynomial sin/cos, so host and device draw
 * the same directions. Units: docs/SCENES.md ("Lights"); a delta light is never hit by a ray.
 */
#ifndef PHOTONFLOW_LIGHT_SHARED_H
#define PHOTONFLOW_LIGHT_SHARED_H

#include "photonflow/sampling/sampling_shared.h"

#ifdef __OPENCL_VERSION__
#pragma OPENCL FP_CONTRACT OFF
#endif

/* The spot's angular attenuation, exactly the KHR_lights_punctual specification's ("Inner and
 * Outer Cone Angles", its implementation note for a smooth falloff):
 *   lightAngleScale    = 1.0 / max(0.001, cos(innerConeAngle) − cos(outerConeAngle))
 *   lightAngleOffset   = −cos(outerConeAngle) · lightAngleScale
 *   cd                 = dot(spotlightDir, normalizedLightVector)
 *   angularAttenuation = saturate(cd · lightAngleScale + lightAngleOffset)², saturate = clamp to
 *                        [0, 1] (a NaN gives 0)
 * with cos_angle = cd the cosine between the spot's axis and the direction from the light to the
 * lit point: 1 inside the inner cone, 0 outside the outer cone, a quadratic ramp between. */
PF_INLINE float pf_spot_falloff(float cos_angle, float cos_inner, float cos_outer) {
  const float width = cos_inner - cos_outer;
  const float scale = 1.0f / (width > 0.001f ? width : 0.001f);
  const float offset = -cos_outer * scale;
  float a = cos_angle * scale + offset;
  a = a > 0.0f ? a : 0.0f;
  a = a < 1.0f ? a : 1.0f;
  return a * a;
}

/* ∫ falloff(c) dc over c = cos θ in [cos_outer, 1] (the spot's power is 2π·I times it): with
 * w = max(0.001, cos_inner − cos_outer) the ramp ((c − cos_outer)/w)² gives w/3 and the plateau
 * 1 − cos_outer − w, or (1 − cos_outer)³/(3w²) when the ramp does not reach 1 before c = 1. In
 * double: host only (light power for the CDF; the photons' flux does not depend on it). */
#ifndef __OPENCL_VERSION__
inline double pf_spot_cone_integral(float cos_inner, float cos_outer) {
  const double co = cos_outer;
  const double w = double(cos_inner) - co > 0.001 ? double(cos_inner) - co : 0.001;
  if (co + w <= 1.0) return w / 3.0 + (1.0 - co - w);
  const double r = 1.0 - co;
  return r * r * r / (3.0 * w * w);
}
#endif

/* Photon emission of a spot or directional light from two uniform numbers u1, u2 (the numbers a
 * point light uses for its direction). Writes the ray's origin o and unit direction d and returns
 * the factor f with photon flux = radiance · f / p_light (0: no photon):
 *   spot: d uniform in the outer cone (cos θ = 1 − r²·(1 − cos_outer), the concentric disc point
 *         (x, y) with r² = x² + y² giving cos θ and the azimuth; density 1/(2π(1 − cos_outer))),
 *         o = position, f = falloff(cos θ) · 2π(1 − cos_outer) = intensity·falloff / density;
 *   directional: o uniform on the disc of area `area` = π·R² around `position` perpendicular to
 *         `direction` (density 1/area), d = direction, f = area (flux = E · area).
 * type must be PF_LIGHT_SPOT or PF_LIGHT_DIRECTIONAL. */
PF_INLINE float pf_punctual_emit(int type, const float* position, const float* direction,
                                 float cos_inner, float cos_outer, float area, float u1, float u2,
                                 float* o, float* d) {
  float x, y;
  pf_sample_concentric_disc(u1, u2, &x, &y);
  if (type == PF_LIGHT_SPOT) {
    const float r2 = x * x + y * y;
    const float cos_t = 1.0f - r2 * (1.0f - cos_outer);
    const float sin_t = PF_S_SQRT(pf_max0(1.0f - cos_t * cos_t));
    float loc[3];
    if (r2 > 0.0f) {
      const float s = sin_t / PF_S_SQRT(r2);
      loc[0] = x * s;
      loc[1] = y * s;
    } else {
      loc[0] = 0.0f;
      loc[1] = 0.0f;
    }
    loc[2] = cos_t;
    pf_to_world(loc, direction, d);
    for (int k = 0; k < 3; ++k) o[k] = position[k];
    return pf_spot_falloff(cos_t, cos_inner, cos_outer) * (2.0f * PF_S_PI * (1.0f - cos_outer));
  }
  const float radius = PF_S_SQRT(area * (1.0f / PF_S_PI));
  float t[3], b[3];
  pf_orthonormal_basis(direction, t, b);
  const float px = x * radius, py = y * radius;
  for (int k = 0; k < 3; ++k) {
    o[k] = position[k] + t[k] * px + b[k] * py;
    d[k] = direction[k];
  }
  return area;
}

/* The light a spot or directional light sends to point p, for next-event estimation. Writes w, the
 * unit direction from p towards the light, and q, the end of the shadow ray (the light's position;
 * for a directional light the point of its emitting disc's plane on the line p + t·w), and
 * returns the factor f with irradiance at p = radiance · f · cos θ_p (cos θ_p = dot(w, n)):
 *   spot: f = falloff(dot(−w, direction)) / |q − p|²;
 *   directional: f = 1 (parallel light: irradiance E·cos θ).
 * Returns 0 (and nothing lit) when p coincides with the spot or lies on the wrong side of the
 * directional light's disc. */
PF_INLINE float pf_punctual_incident(int type, const float* position, const float* direction,
                                     float cos_inner, float cos_outer, const float* p, float* w,
                                     float* q) {
  if (type == PF_LIGHT_SPOT) {
    for (int k = 0; k < 3; ++k) {
      q[k] = position[k];
      w[k] = position[k] - p[k];
    }
    const float d2 = pf_dot3(w, w);
    if (!(d2 > 0.0f)) return 0.0f;
    const float dl = PF_S_SQRT(d2);
    for (int k = 0; k < 3; ++k) w[k] = w[k] / dl;
    return pf_spot_falloff(-pf_dot3(w, direction), cos_inner, cos_outer) / d2;
  }
  float rel[3];
  for (int k = 0; k < 3; ++k) {
    w[k] = -direction[k];
    rel[k] = p[k] - position[k];
  }
  const float dist = pf_dot3(rel, direction); /* from the disc's plane to p along the light */
  if (!(dist > 0.0f)) return 0.0f;
  for (int k = 0; k < 3; ++k) q[k] = p[k] + w[k] * dist;
  return 1.0f;
}

/* One light sample for next-event estimation at point p, for every light type (thesis eq. 3.7's
 * L_direct; Hachisuka & Jensen 2009 section 4, direct light by ray tracing), so that the eye
 * pass's diffuse and PBR points (eye_pass.cpp, trace_hitpoints.cl) and the path tracer
 * (pathtrace.cpp) sample each light the same way. The light: its type and fields (shared_types.h
 * pf_light), and for PF_LIGHT_AREA its triangle's corners v0, v1, v2 and unit front normal nl
 * (light leaves along +nl; unused for the other types). u1, u2: the sample's two numbers. Writes
 * w, the unit direction from p towards the light, and q, the end of the shadow ray, and returns
 * G, the light's side of the geometry term over the sample's density, with
 *   L_direct ≈ L_e · f(ω_o, w) · |cos θ_x| · G / p_light      (p_light: the light's pick chance)
 *   area:        q uniform on the triangle (pdf_A = 1/area), G = cos θ_l · area / |q − p|²;
 *                its density per unit solid angle at p is p_light / G (for MIS);
 *   point:       q = position, G = 1 / |q − p|²;
 *   spot:        q = position, G = falloff / |q − p|² (pf_punctual_incident);
 *   directional: q on the emitting disc's plane, G = 1 (parallel light).
 * Returns 0 (nothing lit) for p on the light, the back of a one-sided area light, a point outside
 * a spot's cone or behind a directional light's disc, and for PF_LIGHT_ENVIRONMENT, whose sample
 * needs the map: pf_env_incident (environment_shared.h), which Scene::light_incident calls. */
PF_INLINE float pf_light_incident(int type, const float* position, const float* direction,
                                  float cos_inner, float cos_outer, float area, const float* v0,
                                  const float* v1, const float* v2, const float* nl,
                                  const float* p, float u1, float u2, float* w, float* q) {
  if (type == PF_LIGHT_ENVIRONMENT) return 0.0f;
  if (type == PF_LIGHT_SPOT || type == PF_LIGHT_DIRECTIONAL)
    return pf_punctual_incident(type, position, direction, cos_inner, cos_outer, p, w, q);
  if (type == PF_LIGHT_AREA) {
    pf_sample_triangle(v0, v1, v2, u1, u2, q);
  } else {
    for (int k = 0; k < 3; ++k) q[k] = position[k];
  }
  for (int k = 0; k < 3; ++k) w[k] = q[k] - p[k];
  const float d2 = pf_dot3(w, w);
  if (!(d2 > 0.0f)) return 0.0f;
  const float dl = PF_S_SQRT(d2);
  for (int k = 0; k < 3; ++k) w[k] = w[k] / dl;
  if (type != PF_LIGHT_AREA) return 1.0f / d2;
  const float cos_l = -pf_dot3(w, nl); /* one-sided emitter: light leaves along +nl */
  return cos_l > 0.0f ? cos_l * area / d2 : 0.0f;
}

#endif /* PHOTONFLOW_LIGHT_SHARED_H */
