// Tests of sampling.h: densities checked by Monte Carlo moments, and the exact scattering
// formulas (orthonormal basis, reflection, Snell refraction, Fresnel).
#include <catch2/catch.hpp>

#include <cmath>
#include <vector>

#include "photonflow/foundations/rng.h"
#include "photonflow/sampling/sampling.h"
#include "photonflow/geometry/surface.h"

using namespace pf;

namespace {

constexpr pf_uint kSeed = 2024;
constexpr int kN = 400000;

// A few unit normals, including the poles and the Duff et al. branch switch at n.z = 0.
std::vector<Vec3> test_normals() {
  return {Vec3(0, 0, 1), Vec3(0, 0, -1), Vec3(1, 0, 0), Vec3(0, -1, 0),
          normalize(Vec3(1, 2, 3)), normalize(Vec3(-0.3f, 0.1f, -0.95f)),
          normalize(Vec3(0.6f, -0.8f, 1e-7f)), normalize(Vec3(0.6f, -0.8f, -1e-7f))};
}

}  // namespace

TEST_CASE("sampling: orthonormal basis is orthonormal and right-handed", "[sampling]") {
  for (const Vec3& n : test_normals()) {
    Vec3 t, b;
    orthonormal_basis(n, t, b);
    INFO("n = " << n.x << " " << n.y << " " << n.z);
    CHECK(length(t) == Approx(1).margin(1e-6));
    CHECK(length(b) == Approx(1).margin(1e-6));
    CHECK(dot(t, b) == Approx(0).margin(1e-6));
    CHECK(dot(t, n) == Approx(0).margin(1e-6));
    CHECK(dot(b, n) == Approx(0).margin(1e-6));
    Vec3 c = cross(t, b);  // right-handed: t × b = n
    CHECK(c.x == Approx(n.x).margin(1e-6));
    CHECK(c.y == Approx(n.y).margin(1e-6));
    CHECK(c.z == Approx(n.z).margin(1e-6));
  }
}

TEST_CASE("sampling: uniform triangle points have the centroid as mean and stay inside",
          "[sampling]") {
  const Vec3 a(0, 0, 0), b(4, 0, 1), c(1, 3, -2);
  const Vec3 n = cross(b - a, c - a);
  Vec3 mean;
  int outside = 0;
  double frac_near_a = 0;  // share of points in the sub-triangle at a with half the edge lengths
  for (int i = 0; i < kN; ++i) {
    Vec3 p = sample_triangle(a, b, c, pf_rng_float(kSeed, 0, i, 0), pf_rng_float(kSeed, 0, i, 1));
    mean += p * (1.f / kN);
    // Barycentric coordinates of p; all >= 0 inside.
    float wb = dot(cross(p - a, c - a), n) / dot(n, n);
    float wc = dot(cross(b - a, p - a), n) / dot(n, n);
    outside += (wb < -1e-5f || wc < -1e-5f || wb + wc > 1 + 1e-5f);
    frac_near_a += (wb + wc <= 0.5f) ? 1.0 / kN : 0.0;
  }
  Vec3 centroid = (a + b + c) * (1.f / 3.f);
  CHECK(outside == 0);
  CHECK(mean.x == Approx(centroid.x).margin(0.01));
  CHECK(mean.y == Approx(centroid.y).margin(0.01));
  CHECK(mean.z == Approx(centroid.z).margin(0.01));
  // Uniform density: the corner triangle holds 1/4 of the area (sd of the share ≈ 7e-4).
  CHECK(frac_near_a == Approx(0.25).margin(0.004));
}

TEST_CASE("sampling: cosine hemisphere has density cos/pi", "[sampling]") {
  for (const Vec3& n : test_normals()) {
    double mean_cos = 0, mean_cos2 = 0;
    int below = 0;
    Vec3 mean_dir;
    for (int i = 0; i < kN; ++i) {
      Vec3 d = sample_cosine_hemisphere(n, pf_rng_float(kSeed, 1, i, 0),
                                        pf_rng_float(kSeed, 1, i, 1));
      double c = dot(d, n);
      below += (c < 0) || std::fabs(length(d) - 1.f) > 1e-5f;
      mean_cos += c / kN;
      mean_cos2 += c * c / kN;
      mean_dir += d * (1.f / kN);
    }
    INFO("n = " << n.x << " " << n.y << " " << n.z);
    CHECK(below == 0);
    // E[cos] = ∫ cos · cos/π dω = 2/3; E[cos²] = 1/2. Tangential mean is 0 by symmetry.
    CHECK(mean_cos == Approx(2.0 / 3.0).margin(0.003));
    CHECK(mean_cos2 == Approx(0.5).margin(0.003));
    Vec3 tangential = mean_dir - n * dot(mean_dir, n);
    CHECK(length(tangential) < 0.005f);
  }
  CHECK(pdf_cosine_hemisphere(1.f) == Approx(1.0 / M_PI));
  CHECK(pdf_cosine_hemisphere(-0.5f) == 0.f);
}

TEST_CASE("sampling: cosine hemisphere directions are uniform in azimuth", "[sampling]") {
  // The density cosθ/π does not depend on the azimuth φ (measured in the basis t, b of
  // orthonormal_basis), so each of the 8 octants of φ holds 1/8 of the directions (sd of a share
  // over 400,000 samples: 5.2e-4; tolerance 5 sd). The moments above are blind to a concentric
  // mapping that puts the disc's top and bottom wedges onto its right and left ones (the radius
  // and the tangential mean stay right); the octants are not.
  for (const Vec3& n : test_normals()) {
    Vec3 t, b;
    orthonormal_basis(n, t, b);
    std::vector<int> octant(8, 0);
    for (int i = 0; i < kN; ++i) {
      Vec3 d = sample_cosine_hemisphere(n, pf_rng_float(kSeed, 3, i, 0),
                                        pf_rng_float(kSeed, 3, i, 1));
      double phi = std::atan2(double(dot(d, b)), double(dot(d, t)));  // (−π, π]
      int k = int(std::floor((phi + M_PI) / (M_PI / 4)));
      ++octant[size_t(std::min(7, std::max(0, k)))];
    }
    INFO("n = " << n.x << " " << n.y << " " << n.z);
    for (int k = 0; k < 8; ++k) CHECK(octant[size_t(k)] / double(kN) == Approx(0.125).margin(0.0026));
  }
}

TEST_CASE("sampling: the concentric disc mapping is exact polar coordinates", "[sampling]") {
  // Shirley & Chiu 1997: with (a, b) = (2u1 − 1, 2u2 − 1) the point is r·(cos φ, sin φ) where
  // r = a, φ = (π/4)(b/a) when |a| > |b|, and r = b, φ = π/2 − (π/4)(a/b) otherwise. The
  // polynomial sin and cos of sampling_shared.h (relative error ~1e-7) must give these points.
  for (int i = 0; i <= 40; ++i)
    for (int j = 0; j <= 40; ++j) {
      const float u1 = i / 40.f * 0.999f, u2 = j / 40.f * 0.999f;
      float x, y;
      sample_concentric_disc(u1, u2, x, y);
      const double a = 2.0 * u1 - 1.0, b = 2.0 * u2 - 1.0;
      double r, phi;
      if (a == 0 && b == 0) {
        r = 0;
        phi = 0;
      } else if (std::fabs(a) > std::fabs(b)) {
        r = a;
        phi = M_PI / 4 * (b / a);
      } else {
        r = b;
        phi = M_PI / 2 - M_PI / 4 * (a / b);
      }
      INFO("u " << u1 << " " << u2);
      CHECK(x == Approx(r * std::cos(phi)).margin(1e-6));
      CHECK(y == Approx(r * std::sin(phi)).margin(1e-6));
    }
}

TEST_CASE("sampling: specular_bounce applies the tint and the Fresnel split", "[sampling]") {
  // surface.h's specular_bounce, shared by the eye pass, the photon pass and the path tracer:
  //  - a mirror reflects exactly and multiplies the weight by its reflectance (colour), drawing no
  //    random number;
  //  - glass draws one random number, reflects with probability F (Fresnel, weight unchanged) and
  //    refracts otherwise (weight times its tint, direction by Snell);
  //  - beyond the critical angle inside the glass it always reflects, weight unchanged.
  // Caught: a mirror's or the glass's colour not applied (every other test used colour 1 or the same
  // code on both sides of a comparison); reflecting with probability 1 − F.
  SurfaceHit sh{};
  sh.ng = Vec3(0, 0, 1);
  sh.ns = Vec3(0, 0, 1);
  sh.front = true;
  const float th = kPi / 4;
  const Vec3 d(std::sin(th), 0.f, -std::cos(th));  // arriving on the front at 45°

  pf_material mirror{};
  mirror.type = PF_MAT_MIRROR;
  mirror.ior = 1.f;
  const Vec3 tint(0.5f, 0.25f, 0.9f);
  tint.store(mirror.color);
  pf_rng rng = pf_rng_start(kSeed, 4, 0);
  Vec3 w(1, 1, 1);
  Vec3 r = specular_bounce(mirror, sh, d, &rng, w);
  CHECK(rng.dim == 0u);
  CHECK(r.x == Approx(d.x));
  CHECK(r.z == Approx(-d.z));
  for (int c = 0; c < 3; ++c) CHECK(w[c] == tint[c]);

  pf_material glass{};
  glass.type = PF_MAT_GLASS;
  glass.ior = 1.5f;
  const Vec3 gt(0.9f, 0.6f, 0.3f);
  gt.store(glass.color);
  const float F = fresnel_dielectric(std::cos(th), 1.f, 1.5f);
  const int n = 40000;
  int reflected = 0, bad = 0;
  for (int i = 0; i < n; ++i) {
    pf_rng g = pf_rng_start(kSeed, 5, uint32_t(i));
    Vec3 wg(1, 1, 1);
    Vec3 o = specular_bounce(glass, sh, d, &g, wg);
    bad += g.dim != 1u;
    if (o.z > 0.f) {  // reflected
      ++reflected;
      bad += wg.x != 1.f || wg.y != 1.f || wg.z != 1.f;
      bad += std::fabs(o.x - d.x) > 1e-6f;
    } else {  // refracted: sinθ_t = sinθ_i / 1.5
      bad += wg.x != gt.x || wg.y != gt.y || wg.z != gt.z;
      bad += std::fabs(o.x - std::sin(th) / 1.5f) > 1e-6f;
    }
  }
  CHECK(bad == 0);
  // Share of reflections: F = 0.0502, sd of the share over 40,000 draws 0.0011; tolerance 5 sd.
  CHECK(reflected / double(n) == Approx(F).margin(0.0055));

  // From inside (the ray meets the back of the glass surface), 60° > critical angle 41.8°.
  SurfaceHit inside = sh;
  inside.front = false;
  const float t2 = kPi / 3;
  const Vec3 up(std::sin(t2), 0.f, std::cos(t2));
  for (int i = 0; i < 100; ++i) {
    pf_rng g = pf_rng_start(kSeed, 6, uint32_t(i));
    Vec3 wg(1, 1, 1);
    Vec3 o = specular_bounce(glass, inside, up, &g, wg);
    CHECK(o.z == Approx(-up.z));
    CHECK(wg.x == 1.f);
  }
}

TEST_CASE("sampling: uniform sphere directions are isotropic", "[sampling]") {
  Vec3 mean;
  double mean_z2 = 0, upper = 0;
  int not_unit = 0;
  for (int i = 0; i < kN; ++i) {
    Vec3 d = sample_uniform_sphere(pf_rng_float(kSeed, 2, i, 0), pf_rng_float(kSeed, 2, i, 1));
    not_unit += std::fabs(length(d) - 1.f) > 1e-5f;
    mean += d * (1.f / kN);
    mean_z2 += double(d.z) * d.z / kN;
    upper += (d.x > 0.5f) ? 1.0 / kN : 0.0;  // spherical cap x > 1/2 holds 1/4 of the sphere
  }
  CHECK(not_unit == 0);
  CHECK(length(mean) < 0.006f);
  CHECK(mean_z2 == Approx(1.0 / 3.0).margin(0.003));
  CHECK(upper == Approx(0.25).margin(0.004));
  CHECK(kPdfUniformSphere == Approx(1.0 / (4 * M_PI)));
}

TEST_CASE("sampling: reflect mirrors about the normal", "[sampling]") {
  Vec3 n(0, 0, 1);
  Vec3 d = normalize(Vec3(1, 2, -3));
  Vec3 r = reflect(d, n);
  CHECK(r.x == Approx(d.x));
  CHECK(r.y == Approx(d.y));
  CHECK(r.z == Approx(-d.z));
  CHECK(length(r) == Approx(1.f));
  // Independent of the normal's side.
  Vec3 r2 = reflect(d, -n);
  CHECK(r2.z == Approx(r.z));
}

TEST_CASE("sampling: refract obeys Snell's law and total internal reflection", "[sampling]") {
  const Vec3 n(0, 0, 1);
  for (float eta : {1.f / 1.5f, 1.5f, 1.f / 1.33f, 1.33f}) {
    for (float theta_deg : {0.f, 10.f, 30.f, 41.f, 45.f, 60.f, 85.f}) {
      float th = theta_deg * kPi / 180.f;
      Vec3 d(std::sin(th), 0.f, -std::cos(th));  // arriving from above, into the surface
      Vec3 t;
      bool ok = refract(d, n, eta, t);
      float sin_t = eta * std::sin(th);
      INFO("eta " << eta << " theta " << theta_deg);
      CHECK(ok == (sin_t < 1.f));
      if (!ok) {
        CHECK(fresnel_dielectric(std::cos(th), 1.f, 1.f / eta) == 1.f);  // TIR: all reflected
        continue;
      }
      CHECK(length(t) == Approx(1.f).margin(1e-6));
      CHECK(t.z < 0.f);                                     // continues through the surface
      CHECK(t.y == Approx(0.f).margin(1e-7));               // stays in the plane of incidence
      CHECK(t.x == Approx(sin_t).margin(1e-6));             // η_i sinθ_i = η_t sinθ_t
      CHECK(t.x * d.x >= 0.f);                              // same side of the normal
      // Reciprocity: refracting back with 1/eta recovers d.
      Vec3 back;
      REQUIRE(refract(-t, -n, 1.f / eta, back));
      CHECK(back.x == Approx(-d.x).margin(1e-5));
      CHECK(back.z == Approx(-d.z).margin(1e-5));
    }
  }
}

TEST_CASE("sampling: dielectric Fresnel reflectance", "[sampling]") {
  // Normal incidence: ((n − 1)/(n + 1))², from either side.
  for (float ior : {1.33f, 1.5f, 2.4f}) {
    float r0 = (ior - 1) / (ior + 1);
    CHECK(fresnel_dielectric(1.f, 1.f, ior) == Approx(r0 * r0).epsilon(1e-5));
    CHECK(fresnel_dielectric(1.f, ior, 1.f) == Approx(r0 * r0).epsilon(1e-5));
  }
  // Glass, 45° from air: hand-computed Rs = 0.0920, Rp = 0.00846, mean 0.0502.
  CHECK(fresnel_dielectric(std::cos(kPi / 4), 1.f, 1.5f) == Approx(0.05023).epsilon(1e-3));
  // Brewster angle tan θ_B = η_t/η_i: Rp = 0, so R = Rs/2.
  float tb = std::atan(1.5f);
  float ct = std::cos(std::asin(std::sin(tb) / 1.5f));
  float rs = (std::cos(tb) - 1.5f * ct) / (std::cos(tb) + 1.5f * ct);
  CHECK(fresnel_dielectric(std::cos(tb), 1.f, 1.5f) == Approx(0.5f * rs * rs).epsilon(1e-4));
  // Grazing incidence reflects everything; inside glass beyond the critical angle, TIR.
  CHECK(fresnel_dielectric(0.f, 1.f, 1.5f) == Approx(1.f));
  float critical = std::asin(1.f / 1.5f);
  CHECK(fresnel_dielectric(std::cos(critical + 0.01f), 1.5f, 1.f) == 1.f);
  CHECK(fresnel_dielectric(std::cos(critical - 0.01f), 1.5f, 1.f) < 1.f);
  // Energy: reflectance within [0, 1] everywhere, and equal for the same pair of angles seen from
  // both sides (reciprocity of the unpolarised formula).
  for (int i = 0; i <= 100; ++i) {
    float c = i / 100.f;
    float r = fresnel_dielectric(c, 1.f, 1.5f);
    CHECK(r >= 0.f);
    CHECK(r <= 1.f);
    float sin_t = std::sqrt(1 - c * c) / 1.5f;
    float cos_t = std::sqrt(1 - sin_t * sin_t);
    CHECK(fresnel_dielectric(cos_t, 1.5f, 1.f) == Approx(r).margin(1e-4));
  }
}

TEST_CASE("sampling: luminance uses Rec.709 weights", "[sampling]") {
  CHECK(luminance(Vec3(1, 1, 1)) == Approx(1.f));
  CHECK(luminance(Vec3(1, 0, 0)) == Approx(0.2126f));
  CHECK(luminance(Vec3(0, 1, 0)) == Approx(0.7152f));
  CHECK(luminance(Vec3(0, 0, 1)) == Approx(0.0722f));
}
