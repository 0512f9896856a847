// texture_shared_test.cpp — material/texture_shared.h: wrap modes, bilinear filtering with the
// half-texel convention and glTF's v-down UVs, the sRGB EOTF (issue 32 items 1 and 6). Every
// expected value is computed by hand from a 4×2 (or 2×2) texture of distinct texel values.
#include <catch2/catch.hpp>

#include <cmath>
#include <vector>

#include "photonflow/material/texture_shared.h"

namespace {

// A pool holding a 1×1 dummy texture first (so offsets are exercised), then a 4×2 texture whose
// texel (x, y) has r = 10y + x, g = 100 + r, b = 0.5, a = 1 − 0.1x.
struct Fixture {
  std::vector<float> pool;
  pf_texture tex{};
  Fixture(int wrap_s = PF_TEX_WRAP_REPEAT, int wrap_t = PF_TEX_WRAP_REPEAT) {
    pool = {-1, -1, -1, -1};
    for (int y = 0; y < 2; ++y)
      for (int x = 0; x < 4; ++x) {
        const float r = float(10 * y + x);
        pool.insert(pool.end(), {r, 100 + r, 0.5f, 1.f - 0.1f * x});
      }
    tex.width = 4;
    tex.height = 2;
    tex.offset = 1;
    tex.wrap_s = wrap_s;
    tex.wrap_t = wrap_t;
    tex.filter = PF_TEX_FILTER_BILINEAR;
  }
  float r(float u, float v) const {
    float rgba[4];
    pf_tex_sample(&tex, pool.data(), u, v, rgba);
    return rgba[0];
  }
};

}  // namespace

TEST_CASE("texture: texel centres return the texel, all four channels", "[texture]") {
  Fixture f;
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 4; ++x) {
      float rgba[4];
      pf_tex_sample(&f.tex, f.pool.data(), (x + 0.5f) / 4, (y + 0.5f) / 2, rgba);
      CHECK(rgba[0] == Approx(10 * y + x));
      CHECK(rgba[1] == Approx(100 + 10 * y + x));
      CHECK(rgba[2] == Approx(0.5f));
      CHECK(rgba[3] == Approx(1.f - 0.1f * x));
    }
}

TEST_CASE("texture: glTF UVs: (0,0) is the first stored row's left edge, v grows down",
          "[texture]") {
  Fixture f(PF_TEX_WRAP_CLAMP, PF_TEX_WRAP_CLAMP);
  CHECK(f.r(0.125f, 0.25f) == Approx(0));   // texel (0, 0): the top-left of the image
  CHECK(f.r(0.125f, 0.75f) == Approx(10));  // v = 0.75 is the second row, below it
  CHECK(f.r(0.875f, 0.25f) == Approx(3));   // u = 0.875 the rightmost column
}

TEST_CASE("texture: bilinear weights with the half-texel convention", "[texture]") {
  Fixture f;
  // u = 0.25 lies halfway between texel centres x = 0 (0.125) and x = 1 (0.375); v = 0.5 halfway
  // between rows 0 and 1: the mean of texels 0, 1, 10, 11 = 5.5.
  CHECK(f.r(0.25f, 0.5f) == Approx(5.5f));
  // u = 0.4375: x = 4u − ½ = 1.25, fx = 0.25 between texels 1 and 2, at row 0's centre:
  // 1·0.75 + 2·0.25 = 1.25.
  CHECK(f.r(0.4375f, 0.25f) == Approx(1.25f));
  // a quarter of the way from row 0 to row 1 at column 2's centre: 2 + 10·0.25 = 4.5.
  CHECK(f.r(0.625f, 0.375f) == Approx(4.5f));
}

TEST_CASE("texture: wrap modes at and beyond the edges", "[texture]") {
  SECTION("repeat: u = 0 blends the last and first columns; u + 1 is u") {
    Fixture f(PF_TEX_WRAP_REPEAT, PF_TEX_WRAP_CLAMP);
    CHECK(f.r(0.0f, 0.25f) == Approx(0.5f * (3 + 0)));  // x = −0.5: texels 3 and 0
    CHECK(f.r(1.3f, 0.25f) == Approx(f.r(0.3f, 0.25f)));
    CHECK(f.r(-0.7f, 0.25f) == Approx(f.r(0.3f, 0.25f)));
    CHECK(f.r(1000.3f, 0.25f) == Approx(f.r(0.3f, 0.25f)).epsilon(1e-3));
  }
  SECTION("clamp: the edge texel beyond the edge centre") {
    Fixture f(PF_TEX_WRAP_CLAMP, PF_TEX_WRAP_CLAMP);
    CHECK(f.r(0.0f, 0.25f) == Approx(0));
    CHECK(f.r(-5.0f, 0.25f) == Approx(0));
    CHECK(f.r(1.0f, 0.25f) == Approx(3));
    CHECK(f.r(1e9f, 1e9f) == Approx(13));
  }
  SECTION("mirrored repeat: 0..3 3..0 0..3 along u") {
    Fixture f(PF_TEX_WRAP_MIRROR, PF_TEX_WRAP_CLAMP);
    CHECK(f.r(0.0f, 0.25f) == Approx(0));  // x = −0.5: texels −1 → 0 and 0: both 0
    CHECK(f.r(1.0f, 0.25f) == Approx(3));  // x = 3.5: texels 3 and 4 → 3
    CHECK(f.r(1.125f, 0.25f) == Approx(3));  // centre of mirrored texel 4 → 3
    CHECK(f.r(1.375f, 0.25f) == Approx(2));  // texel 5 → 2
    CHECK(f.r(1.875f, 0.25f) == Approx(0));  // texel 7 → 0
    CHECK(f.r(2.125f, 0.25f) == Approx(0));  // period 2: texel 8 → 0
    CHECK(f.r(-0.125f, 0.25f) == Approx(0));  // texel −1 → 0
    CHECK(f.r(-0.375f, 0.25f) == Approx(1));  // texel −2 → 1
  }
  SECTION("integer wrap") {
    CHECK(pf_tex_wrap_index(-1, 4, PF_TEX_WRAP_REPEAT) == 3);
    CHECK(pf_tex_wrap_index(9, 4, PF_TEX_WRAP_REPEAT) == 1);
    CHECK(pf_tex_wrap_index(-1, 4, PF_TEX_WRAP_MIRROR) == 0);
    CHECK(pf_tex_wrap_index(-5, 4, PF_TEX_WRAP_MIRROR) == 3);
    CHECK(pf_tex_wrap_index(5, 4, PF_TEX_WRAP_MIRROR) == 2);
    CHECK(pf_tex_wrap_index(7, 1, PF_TEX_WRAP_MIRROR) == 0);
    CHECK(pf_tex_wrap_index(-3, 4, PF_TEX_WRAP_CLAMP) == 0);
    CHECK(pf_tex_wrap_index(4, 4, PF_TEX_WRAP_CLAMP) == 3);
  }
  SECTION("glTF sampler codes") {
    CHECK(pf_tex_wrap_from_gltf(10497) == PF_TEX_WRAP_REPEAT);
    CHECK(pf_tex_wrap_from_gltf(33071) == PF_TEX_WRAP_CLAMP);
    CHECK(pf_tex_wrap_from_gltf(33648) == PF_TEX_WRAP_MIRROR);
    CHECK(pf_tex_wrap_from_gltf(0) == PF_TEX_WRAP_REPEAT);
  }
}

TEST_CASE("texture: nearest filtering and NaN coordinates", "[texture]") {
  Fixture f;
  f.tex.filter = PF_TEX_FILTER_NEAREST;
  CHECK(f.r(0.26f, 0.49f) == Approx(1));
  CHECK(f.r(0.24f, 0.51f) == Approx(10));
  f.tex.filter = PF_TEX_FILTER_BILINEAR;
  const float r = f.r(std::nanf(""), std::nanf(""));
  CHECK(r == Approx(f.r(0.f, 0.f)));  // NaN reads as 0, not out of bounds
}

TEST_CASE("texture: the mean of a bilinearly filtered repeat texture is the texel mean",
          "[texture]") {
  // Averaged over one period, bilinear filtering with repeat preserves the mean (each texel's
  // tent integrates to one texel's area): the property the textured-floor test relies on.
  Fixture f;
  double s = 0;
  const int n = 400;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) s += f.r((i + 0.5f) / n, (j + 0.5f) / n);
  CHECK(s / (n * n) == Approx((0 + 1 + 2 + 3 + 10 + 11 + 12 + 13) / 8.0).epsilon(1e-4));
}

TEST_CASE("texture: the sRGB EOTF", "[texture]") {
  CHECK(pf_srgb_to_linear(0.f) == 0.f);
  CHECK(pf_srgb_to_linear(1.f) == Approx(1.f).epsilon(1e-6));
  // linear segment: 0.04045 / 12.92 = 0.0031308
  CHECK(pf_srgb_to_linear(0.04045f) == Approx(0.0031308f).epsilon(1e-4));
  CHECK(pf_srgb_to_linear(0.02f) == Approx(0.02f / 12.92f).epsilon(1e-6));
  // power segment: ((0.5 + 0.055)/1.055)^2.4 = 0.21404
  CHECK(pf_srgb_to_linear(0.5f) == Approx(0.214041f).epsilon(1e-5));
  // the two pieces meet (continuity within 1e-7 at the breakpoint)
  CHECK(std::fabs(pf_srgb_to_linear(0.040451f) - pf_srgb_to_linear(0.040449f)) < 1e-6f);
  CHECK(pf_srgb8_to_linear(128) == Approx(0.215861f).epsilon(1e-5));
  CHECK(pf_srgb8_to_linear(255) == Approx(1.f).epsilon(1e-6));
  CHECK(pf_srgb_to_linear(-1.f) == 0.f);
  CHECK(pf_srgb_to_linear(2.f) == Approx(1.f).epsilon(1e-6));
  CHECK(pf_srgb_to_linear(std::nanf("")) == 0.f);
  // monotonic over all 8-bit codes
  for (int v = 1; v < 256; ++v) CHECK(pf_srgb8_to_linear(v) > pf_srgb8_to_linear(v - 1));
}
