// lens_shared_test.cpp — material/lens_shared.h: the thin-lens camera of issue 32 item 5. Points on the
// focus plane are sharp (every lens sample's ray passes through the pinhole ray's focus point);
// a point off it is blurred over a disc whose diameter, on the focus plane, is the circle of
// confusion 2a|z − d|/z, filled uniformly; aperture 0 is the pinhole camera.
#include <catch2/catch.hpp>

#include <cmath>
#include <random>

#include "photonflow/material/lens_shared.h"

namespace {
// A camera at o looking along forward, tilted so that no axis is special.
struct Cam {
  float o[3] = {0.3f, -1.2f, 2.0f};
  float right[3], up[3], forward[3];
  Cam() {
    float f[3] = {0.2f, 0.9f, -0.4f};
    pf_normalize3(f);
    float wup[3] = {0, 0, 1};
    float r[3];
    pf_cross3(f, wup, r);
    pf_normalize3(r);
    float u[3];
    pf_cross3(r, f, u);
    for (int k = 0; k < 3; ++k) {
      forward[k] = f[k];
      right[k] = r[k];
      up[k] = u[k];
    }
  }
  // pinhole direction through image-plane offset (x, y) at unit distance
  void pinhole(float x, float y, float* d) const {
    for (int k = 0; k < 3; ++k) d[k] = forward[k] + right[k] * x + up[k] * y;
    pf_normalize3(d);
  }
  // the point where ray (p, d) meets the plane at depth z along forward
  void at_depth(const float* p, const float* d, float z, float* out) const {
    float rel[3] = {p[0] - o[0], p[1] - o[1], p[2] - o[2]};
    const float t = (z - pf_dot3(rel, forward)) / pf_dot3(d, forward);
    for (int k = 0; k < 3; ++k) out[k] = p[k] + d[k] * t;
  }
};
float dist(const float* a, const float* b) {
  const float d[3] = {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
  return std::sqrt(pf_dot3(d, d));
}
}  // namespace

TEST_CASE("lens: the focus plane is sharp for every lens sample", "[lens]") {
  Cam c;
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> uni(0.f, 1.f);
  const float aperture = 0.05f, focus = 3.7f;
  for (int px = 0; px < 50; ++px) {
    float d[3];
    c.pinhole(uni(rng) - 0.5f, uni(rng) - 0.5f, d);
    float p_pin[3];
    c.at_depth(c.o, d, focus, p_pin);
    for (int s = 0; s < 64; ++s) {
      float lo[3], ld[3];
      REQUIRE(pf_thin_lens_ray(c.o, d, c.right, c.up, c.forward, aperture, focus, uni(rng),
                               uni(rng), lo, ld) == 1);
      CHECK(std::fabs(pf_dot3(ld, ld) - 1.f) < 1e-5f);
      // the lens point lies in the lens disc (the plane through o normal to forward)
      const float rel[3] = {lo[0] - c.o[0], lo[1] - c.o[1], lo[2] - c.o[2]};
      CHECK(std::fabs(pf_dot3(rel, c.forward)) < 1e-6f);
      CHECK(std::sqrt(pf_dot3(rel, rel)) <= aperture * (1 + 1e-5f));
      float p[3];
      c.at_depth(lo, ld, focus, p);
      CHECK(dist(p, p_pin) < 2e-6f * focus);  // same point: sharp
    }
  }
}

TEST_CASE("lens: the blur of an out-of-focus point is the circle of confusion", "[lens]") {
  // Rays of one pixel (all through the focus point P) spread, at depth z, over a disc of radius
  // a|z − d|/d around the pinhole ray; a point there is seen by the pixels whose focus points lie
  // within (d/z) times that, i.e. a disc of diameter 2a|z − d|/z on the focus plane.
  Cam c;
  std::mt19937 rng(2);
  std::uniform_real_distribution<float> uni(0.f, 1.f);
  const float aperture = 0.08f, focus = 2.5f;
  for (float z : {1.0f, 1.8f, 4.0f, 10.0f}) {
    float d[3];
    c.pinhole(0.13f, -0.21f, d);
    float q_pin[3], p_pin[3];
    c.at_depth(c.o, d, z, q_pin);
    c.at_depth(c.o, d, focus, p_pin);
    double rmax = 0, r2sum = 0;
    const int n = 20000;
    for (int s = 0; s < n; ++s) {
      float lo[3], ld[3], q[3];
      pf_thin_lens_ray(c.o, d, c.right, c.up, c.forward, aperture, focus, uni(rng), uni(rng), lo, ld);
      c.at_depth(lo, ld, z, q);
      const double r = dist(q, q_pin) * (focus / z);  // on the focus plane's scale
      rmax = std::max(rmax, r);
      r2sum += r * r;
    }
    const double coc = pf_lens_coc_diameter(aperture, focus, z);
    INFO("z " << z << ": circle of confusion " << coc << ", largest blur radius ×2 " << 2 * rmax);
    CHECK(coc == Approx(2 * aperture * std::fabs(z - focus) / z).epsilon(1e-6));
    CHECK(2 * rmax == Approx(coc).epsilon(0.01));           // the disc's edge is reached
    CHECK(2 * rmax <= coc * (1 + 1e-4));                    // and never passed
    CHECK(r2sum / n == Approx(coc * coc / 8).epsilon(0.03));  // uniform disc: E r² = R²/2
  }
  CHECK(pf_lens_coc_diameter(0.08f, 2.5f, 2.5f) == 0.f);
  CHECK(pf_lens_coc_diameter(0.08f, 2.5f, 1e30f) == Approx(0.16f));
}

TEST_CASE("lens: aperture 0 (or a bad focus distance) is the pinhole camera", "[lens]") {
  Cam c;
  float d[3] = {0.3f, 1.7f, -0.2f};  // not unit: returned normalized
  for (float a : {0.f, -1.f})
    for (float f : {2.f, 0.f}) {
      float lo[3], ld[3];
      const int thin = pf_thin_lens_ray(c.o, d, c.right, c.up, c.forward, a, a == 0.f ? f : 2.f,
                                         0.9f, 0.1f, lo, ld);
      CHECK(thin == 0);
      float dn[3] = {d[0], d[1], d[2]};
      pf_normalize3(dn);
      for (int k = 0; k < 3; ++k) {
        CHECK(lo[k] == c.o[k]);
        CHECK(ld[k] == Approx(dn[k]).epsilon(1e-6));
      }
    }
  float lo[3], ld[3];
  CHECK(pf_thin_lens_ray(c.o, d, c.right, c.up, c.forward, 0.1f, 0.f, 0.3f, 0.3f, lo, ld) == 0);
  const float back[3] = {-c.forward[0], -c.forward[1], -c.forward[2]};
  CHECK(pf_thin_lens_ray(c.o, back, c.right, c.up, c.forward, 0.1f, 2.f, 0.3f, 0.3f, lo, ld) == 0);
}
