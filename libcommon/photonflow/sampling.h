// sampling.h — Monte Carlo sampling and scattering geometry for host-side photon and eye tracing:
// points on triangles (area lights), directions (diffuse bounces, point lights), orthonormal
// bases, mirror reflection, Snell refraction and the dielectric Fresnel term (thesis ch. 3.4:
// diffuse bounce in the hemisphere, exact mirror bounce, glass with Fresnel).
//
// Conventions: random numbers u1, u2 are uniform in [0, 1) (rng.h). A direction `d` that arrives
// at a surface points INTO the surface (dot(d, n) < 0 when n faces the arriving ray). All returned
// directions are unit length when the inputs are.
#pragma once
#include <algorithm>
#include <cmath>

#include "photonflow/vec.h"

namespace pf {

constexpr float kPi = 3.14159265358979323846f;
constexpr float kInvPi = 0.318309886183790671538f;

// Uniform point on triangle (a, b, c), square-root parametrisation (Osada et al. 2002):
// P = (1 − √u1)·a + √u1·(1 − u2)·b + √u1·u2·c. Density 1/area.
inline Vec3 sample_triangle(const Vec3& a, const Vec3& b, const Vec3& c, float u1, float u2) {
  float su = std::sqrt(u1);
  float wb = su * (1.f - u2);
  float wc = su * u2;
  return a * (1.f - su) + b * wb + c * wc;
}

// Tangent t and bitangent b completing unit normal n to a right-handed orthonormal basis
// (t, b, n), branchless and continuous except at n.z = 0 (Duff et al. 2017, "Building an
// Orthonormal Basis, Revisited", JCGT 6(1)).
inline void orthonormal_basis(const Vec3& n, Vec3& t, Vec3& b) {
  float sign = std::copysign(1.f, n.z);
  float a = -1.f / (sign + n.z);
  float bb = n.x * n.y * a;
  t = Vec3(1.f + sign * n.x * n.x * a, sign * bb, -sign * n.x);
  b = Vec3(bb, sign + n.y * n.y * a, -n.y);
}

// Local coordinates (x, y along t, b; z along n) to world.
inline Vec3 to_world(const Vec3& local, const Vec3& n) {
  Vec3 t, b;
  orthonormal_basis(n, t, b);
  return t * local.x + b * local.y + n * local.z;
}

// Uniform point on the unit disc, concentric mapping (Shirley & Chiu 1997): keeps the
// stratification of (u1, u2).
inline void sample_concentric_disc(float u1, float u2, float& x, float& y) {
  float a = 2.f * u1 - 1.f;
  float b = 2.f * u2 - 1.f;
  if (a == 0.f && b == 0.f) {
    x = y = 0.f;
    return;
  }
  float r, phi;
  if (std::fabs(a) > std::fabs(b)) {
    r = a;
    phi = (kPi / 4.f) * (b / a);
  } else {
    r = b;
    phi = (kPi / 2.f) - (kPi / 4.f) * (a / b);
  }
  x = r * std::cos(phi);
  y = r * std::sin(phi);
}

// Cosine-weighted direction in the hemisphere around unit normal n (Malley's method: a uniform
// point on the disc lifted to the hemisphere). Density cosθ/π per steradian
// (pdf_cosine_hemisphere).
inline Vec3 sample_cosine_hemisphere(const Vec3& n, float u1, float u2) {
  float x, y;
  sample_concentric_disc(u1, u2, x, y);
  float z = std::sqrt(std::max(0.f, 1.f - x * x - y * y));
  return to_world(Vec3(x, y, z), n);
}

inline float pdf_cosine_hemisphere(float cos_theta) {
  return cos_theta > 0.f ? cos_theta * kInvPi : 0.f;
}

// Uniform direction on the unit sphere (point lights). Density 1/(4π).
inline Vec3 sample_uniform_sphere(float u1, float u2) {
  float z = 1.f - 2.f * u1;
  float r = std::sqrt(std::max(0.f, 1.f - z * z));
  float phi = 2.f * kPi * u2;
  return Vec3(r * std::cos(phi), r * std::sin(phi), z);
}

constexpr float kPdfUniformSphere = 0.25f * kInvPi;

// Mirror reflection of arriving direction d about normal n (either side): d − 2(d·n)n.
inline Vec3 reflect(const Vec3& d, const Vec3& n) { return d - n * (2.f * dot(d, n)); }

// Refraction of arriving unit direction d through a surface with unit normal n facing the arriving
// ray (dot(d, n) <= 0), eta = η_incident / η_transmitted (Snell: η_i sinθ_i = η_t sinθ_t).
// Returns false on total internal reflection (t untouched), else the unit transmitted direction t.
inline bool refract(const Vec3& d, const Vec3& n, float eta, Vec3& t) {
  float cos_i = -dot(d, n);
  float sin2_t = eta * eta * std::max(0.f, 1.f - cos_i * cos_i);
  if (sin2_t >= 1.f) return false;
  float cos_t = std::sqrt(1.f - sin2_t);
  t = d * eta + n * (eta * cos_i - cos_t);
  return true;
}

// Fresnel reflectance of a smooth dielectric boundary for unpolarised light (exact formula:
// mean of the s- and p-polarised reflectances). cos_i = cosine of the angle of incidence (>= 0),
// eta_i / eta_t = refractive indices on the incident / transmitted side. Returns 1 under total
// internal reflection. At normal incidence it equals ((η_t − η_i)/(η_t + η_i))².
inline float fresnel_dielectric(float cos_i, float eta_i, float eta_t) {
  cos_i = std::min(1.f, std::max(0.f, cos_i));
  float sin_i = std::sqrt(std::max(0.f, 1.f - cos_i * cos_i));
  float sin_t = eta_i / eta_t * sin_i;
  if (sin_t >= 1.f) return 1.f;
  float cos_t = std::sqrt(std::max(0.f, 1.f - sin_t * sin_t));
  float rs = (eta_i * cos_i - eta_t * cos_t) / (eta_i * cos_i + eta_t * cos_t);
  float rp = (eta_t * cos_i - eta_i * cos_t) / (eta_t * cos_i + eta_i * cos_t);
  return 0.5f * (rs * rs + rp * rp);
}

// Relative luminance of linear Rec.709/sRGB primaries (the weights pf_light.power uses).
inline float luminance(const Vec3& rgb) {
  return 0.2126f * rgb.x + 0.7152f * rgb.y + 0.0722f * rgb.z;
}

}  // namespace pf
