// sampling.h — Monte Carlo sampling and scattering geometry for host-side photon and eye tracing:
// points on triangles (area lights), directions (diffuse bounces, point lights), orthonormal
// bases, mirror reflection, Snell refraction and the dielectric Fresnel term (thesis ch. 3.4:
// diffuse bounce in the hemisphere, exact mirror bounce, glass with Fresnel).
//
// The formulas themselves live in sampling_shared.h (plain C, also compiled by the OpenCL kernels),
// so the CPU and OpenCL backends evaluate the same expressions; these are Vec3 wrappers.
//
// Conventions: random numbers u1, u2 are uniform in [0, 1) (rng.h). A direction `d` that arrives
// at a surface points INTO the surface (dot(d, n) < 0 when n faces the arriving ray). All returned
// directions are unit length when the inputs are.
#pragma once
#include <algorithm>
#include <cmath>

#include "photonflow/sampling/sampling_shared.h"
#include "photonflow/foundations/vec.h"

namespace pf {

constexpr float kPi = 3.14159265358979323846f;
constexpr float kInvPi = 0.318309886183790671538f;

// Uniform point on triangle (a, b, c), square-root parametrisation (Osada et al. 2002):
// P = (1 − √u1)·a + √u1·(1 − u2)·b + √u1·u2·c. Density 1/area.
inline Vec3 sample_triangle(const Vec3& a, const Vec3& b, const Vec3& c, float u1, float u2) {
  const float fa[3] = {a.x, a.y, a.z}, fb[3] = {b.x, b.y, b.z}, fc[3] = {c.x, c.y, c.z};
  float p[3];
  pf_sample_triangle(fa, fb, fc, u1, u2, p);
  return Vec3(p);
}

// Tangent t and bitangent b completing unit normal n to a right-handed orthonormal basis
// (t, b, n), branchless and continuous except at n.z = 0 (Duff et al. 2017, "Building an
// Orthonormal Basis, Revisited", JCGT 6(1)).
inline void orthonormal_basis(const Vec3& n, Vec3& t, Vec3& b) {
  const float fn[3] = {n.x, n.y, n.z};
  float ft[3], fb[3];
  pf_orthonormal_basis(fn, ft, fb);
  t = Vec3(ft);
  b = Vec3(fb);
}

// Local coordinates (x, y along t, b; z along n) to world.
inline Vec3 to_world(const Vec3& local, const Vec3& n) {
  const float fl[3] = {local.x, local.y, local.z}, fn[3] = {n.x, n.y, n.z};
  float w[3];
  pf_to_world(fl, fn, w);
  return Vec3(w);
}

// Uniform point on the unit disc, concentric mapping (Shirley & Chiu 1997): keeps the
// stratification of (u1, u2).
inline void sample_concentric_disc(float u1, float u2, float& x, float& y) {
  pf_sample_concentric_disc(u1, u2, &x, &y);
}

// Cosine-weighted direction in the hemisphere around unit normal n (Malley's method: a uniform
// point on the disc lifted to the hemisphere). Density cosθ/π per steradian
// (pdf_cosine_hemisphere).
inline Vec3 sample_cosine_hemisphere(const Vec3& n, float u1, float u2) {
  const float fn[3] = {n.x, n.y, n.z};
  float w[3];
  pf_sample_cosine_hemisphere(fn, u1, u2, w);
  return Vec3(w);
}

inline float pdf_cosine_hemisphere(float cos_theta) {
  return cos_theta > 0.f ? cos_theta * kInvPi : 0.f;
}

// Uniform direction on the unit sphere (point lights). Density 1/(4π).
inline Vec3 sample_uniform_sphere(float u1, float u2) {
  float w[3];
  pf_sample_uniform_sphere(u1, u2, w);
  return Vec3(w);
}

constexpr float kPdfUniformSphere = 0.25f * kInvPi;

// Mirror reflection of arriving direction d about normal n (either side): d − 2(d·n)n.
inline Vec3 reflect(const Vec3& d, const Vec3& n) {
  const float fd[3] = {d.x, d.y, d.z}, fn[3] = {n.x, n.y, n.z};
  float r[3];
  pf_reflect(fd, fn, r);
  return Vec3(r);
}

// Refraction of arriving unit direction d through a surface with unit normal n facing the arriving
// ray (dot(d, n) <= 0), eta = η_incident / η_transmitted (Snell: η_i sinθ_i = η_t sinθ_t).
// Returns false on total internal reflection (t untouched), else the unit transmitted direction t.
inline bool refract(const Vec3& d, const Vec3& n, float eta, Vec3& t) {
  const float fd[3] = {d.x, d.y, d.z}, fn[3] = {n.x, n.y, n.z};
  float ft[3];
  if (!pf_refract(fd, fn, eta, ft)) return false;
  t = Vec3(ft);
  return true;
}

// Fresnel reflectance of a smooth dielectric boundary for unpolarised light (exact formula:
// mean of the s- and p-polarised reflectances). cos_i = cosine of the angle of incidence (>= 0),
// eta_i / eta_t = refractive indices on the incident / transmitted side. Returns 1 under total
// internal reflection. At normal incidence it equals ((η_t − η_i)/(η_t + η_i))².
inline float fresnel_dielectric(float cos_i, float eta_i, float eta_t) {
  return pf_fresnel_dielectric(cos_i, eta_i, eta_t);
}

// Relative luminance of linear Rec.709/sRGB primaries (the weights pf_light.power uses).
inline float luminance(const Vec3& rgb) {
  return 0.2126f * rgb.x + 0.7152f * rgb.y + 0.0722f * rgb.z;
}

}  // namespace pf
