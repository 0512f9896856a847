// alpha_shared_test.cpp — the shared alpha cut-out rules (material/alpha_shared.h; glTF 2.0
// section 3.9.4): cutoff validation, the coverage test, and the open fraction of a stripe mask.
#include <catch2/catch.hpp>

#include <cmath>
#include <vector>

#include "photonflow/material/alpha_shared.h"

TEST_CASE("alpha cutoffs from a file: 0..1 accepted, NaN, negative and > 1 refused",
          "[alpha]") {
  CHECK(pf_alpha_cutoff_valid(0.0f));
  CHECK(pf_alpha_cutoff_valid(PF_ALPHA_DEFAULT_CUTOFF));
  CHECK(pf_alpha_cutoff_valid(1.0f));
  CHECK_FALSE(pf_alpha_cutoff_valid(std::nanf("")));
  CHECK_FALSE(pf_alpha_cutoff_valid(-0.25f));
  CHECK_FALSE(pf_alpha_cutoff_valid(1.5f));
  CHECK_FALSE(pf_alpha_cutoff_valid(INFINITY));
}

TEST_CASE("coverage: cut away exactly when alpha < cutoff, opaque materials never",
          "[alpha]") {
  CHECK(pf_alpha_cut_away(0.49f, 0.5f));
  CHECK_FALSE(pf_alpha_cut_away(0.5f, 0.5f));  // alpha >= cutoff is opaque (spec 3.9.4)
  CHECK_FALSE(pf_alpha_cut_away(0.0f, PF_ALPHA_OPAQUE));
  CHECK_FALSE(pf_alpha_masked(PF_ALPHA_OPAQUE));
  CHECK(pf_alpha_cut_away(0.0f, 1e-6f));
  CHECK_FALSE(pf_alpha_cut_away(0.0f, 0.0f));  // cutoff 0: everything opaque
}

TEST_CASE("a stripe alpha mask over a quad's triangle is open over exactly its open fraction",
          "[alpha]") {
  // 8×1 texels, nearest filter: columns 0..2 alpha 0 (cut), 3..7 alpha 1: 3/8 open.
  std::vector<float> pool;
  for (int x = 0; x < 8; ++x) pool.insert(pool.end(), {1.f, 1.f, 1.f, x < 3 ? 0.f : 1.f});
  pf_texture tex{};
  tex.width = 8;
  tex.height = 1;
  tex.offset = 0;
  tex.wrap_s = PF_TEX_WRAP_REPEAT;
  tex.wrap_t = PF_TEX_WRAP_REPEAT;
  tex.filter = PF_TEX_FILTER_NEAREST;
  // Triangle (0,0) (1,0) (0,1) in UV space: v0 → uv (0,0), v1 → (1,0), v2 → (0,1).
  const float uv[6] = {0.f, 0.f, 1.f, 0.f, 0.f, 1.f};
  // Sample the unit square's lower triangle at cell centres; the open area of the triangle
  // u + v <= 1 with u < 3/8 is 3/8 − (3/8)²/2 of its area 1/2.
  const int n = 1600;
  int64_t inside = 0, open = 0;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const float u = (float(i) + 0.5f) / float(n), v = (float(j) + 0.5f) / float(n);
      if (u + v > 1.f) continue;
      ++inside;
      open += pf_alpha_cut_away(pf_alpha_at(&tex, pool.data(), uv, u, v, 1.f), 0.5f);
    }
  const double expected = (0.375 - 0.375 * 0.375 / 2) / 0.5;
  CHECK(std::fabs(double(open) / double(inside) - expected) < 2e-3);
  // A factor alpha of 0.4 cuts everything at the default cutoff.
  CHECK(pf_alpha_cut_away(pf_alpha_at(&tex, pool.data(), uv, 0.9f, 0.05f, 0.4f), 0.5f));
}
