// Tests of rng.h: determinism, range, bijectivity and statistical sanity of the counter-based
// generator. All tests use fixed seeds, so they are deterministic; the statistical thresholds sit
// at about 5 standard deviations.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <vector>

#include "photonflow/foundations/rng.h"

namespace {

constexpr pf_uint kSeed = 12345;
constexpr int kSamples = 1 << 20;

// Pearson correlation of two equally long samples.
double correlation(const std::vector<double>& a, const std::vector<double>& b) {
  double n = static_cast<double>(a.size()), sa = 0, sb = 0, saa = 0, sbb = 0, sab = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    sa += a[i];
    sb += b[i];
    saa += a[i] * a[i];
    sbb += b[i] * b[i];
    sab += a[i] * b[i];
  }
  double cov = sab / n - (sa / n) * (sb / n);
  return cov / std::sqrt((saa / n - (sa / n) * (sa / n)) * (sbb / n - (sb / n) * (sb / n)));
}

// Chi-square statistic of bin counts against a uniform expectation.
double chi_square(const std::vector<int>& counts, double total) {
  double expected = total / static_cast<double>(counts.size()), chi2 = 0;
  for (int c : counts) chi2 += (c - expected) * (c - expected) / expected;
  return chi2;
}

// Passes iff chi2 lies within ±5 standard deviations of its mean for `dof` degrees of freedom
// (too uniform is as suspicious as too lumpy).
bool chi_square_plausible(double chi2, int dof) {
  double sd = std::sqrt(2.0 * dof);
  return chi2 > dof - 5 * sd && chi2 < dof + 5 * sd;
}

}  // namespace

TEST_CASE("rng: pinned values guard reproducibility of stored results", "[rng]") {
  CHECK(pf_hash32(0u) == 0u);
  CHECK(pf_hash32(1u) == 0x688990c0u);
  CHECK(pf_rng_key(1, 1) == 0xc2ef3ec9u);
  CHECK(pf_rng_bits(pf_rng_key(12345, 0), 0, 0) == 0xe57a7874u);
  CHECK(pf_rng_bits(pf_rng_key(12345, 3), 7, 2) == 0x7ab4984au);
  CHECK(pf_rng_bits(pf_rng_key(0, 0), 0, 0) == 0xb72bd39fu);
}

TEST_CASE("rng: a sample depends only on (seed, pass, index, dim)", "[rng]") {
  // Evaluation order must not matter: forward and backward give the same values.
  std::vector<float> fwd(1000), bwd(1000);
  for (int i = 0; i < 1000; ++i) fwd[i] = pf_rng_float(kSeed, 4, i, i % 7);
  for (int i = 999; i >= 0; --i) bwd[i] = pf_rng_float(kSeed, 4, i, i % 7);
  CHECK(fwd == bwd);

  // The stream cursor yields exactly the stateless samples.
  pf_rng r = pf_rng_start(kSeed, 9, 77);
  for (pf_uint k = 0; k < 50; ++k) CHECK(pf_rng_next(&r) == pf_rng_float(kSeed, 9, 77, k));

  // Changing any one input changes the sample.
  float base = pf_rng_float(kSeed, 1, 2, 3);
  CHECK(pf_rng_float(kSeed + 1, 1, 2, 3) != base);
  CHECK(pf_rng_float(kSeed, 2, 2, 3) != base);
  CHECK(pf_rng_float(kSeed, 1, 3, 3) != base);
  CHECK(pf_rng_float(kSeed, 1, 2, 4) != base);
}

TEST_CASE("rng: floats lie in 0 <= u < 1 with 24-bit resolution", "[rng]") {
  CHECK(pf_rng_unit(0u) == 0.0f);
  CHECK(pf_rng_unit(0xFFFFFFFFu) < 1.0f);
  CHECK(pf_rng_unit(0xFFFFFFFFu) == 1.0f - 1.0f / 16777216.0f);
  CHECK(pf_rng_unit(0x00000100u) == 1.0f / 16777216.0f);  // the smallest step
  CHECK(pf_rng_unit(0x000000FFu) == 0.0f);                // the low 8 bits are dropped
  int outside = 0;
  for (int i = 0; i < kSamples; ++i) {
    float u = pf_rng_float(kSeed, 0, i, 0);
    outside += !(u >= 0.0f && u < 1.0f);
  }
  CHECK(outside == 0);
}

TEST_CASE("rng: index -> bits is a bijection for a fixed (seed, pass, dim)", "[rng]") {
  const pf_uint key = pf_rng_key(kSeed, 5);
  for (pf_uint dim : {0u, 1u, 17u}) {
    std::vector<pf_uint> v(kSamples);
    for (int i = 0; i < kSamples; ++i) v[i] = pf_rng_bits(key, i, dim);
    std::sort(v.begin(), v.end());
    CHECK(std::adjacent_find(v.begin(), v.end()) == v.end());
  }
}

TEST_CASE("rng: mean, variance and 64-bin chi-square of each dimension", "[rng]") {
  for (pf_uint dim : {0u, 1u, 2u, 31u}) {
    double sum = 0, sum2 = 0;
    std::vector<int> bins(64, 0);
    const pf_uint key = pf_rng_key(kSeed, 1);
    for (int i = 0; i < kSamples; ++i) {
      double u = pf_rng_unit(pf_rng_bits(key, i, dim));
      sum += u;
      sum2 += u * u;
      ++bins[static_cast<int>(u * 64)];
    }
    double mean = sum / kSamples, var = sum2 / kSamples - mean * mean;
    INFO("dim " << dim << " mean " << mean << " var " << var);
    // Standard errors: sqrt(1/12 / n) ≈ 2.8e-4 for the mean, ≈ 7e-5 for the variance.
    CHECK(std::fabs(mean - 0.5) < 5 * 2.9e-4);
    CHECK(std::fabs(var - 1.0 / 12.0) < 5 * 7.5e-5);
    double chi2 = chi_square(bins, kSamples);
    INFO("chi2 " << chi2);
    CHECK(chi_square_plausible(chi2, 63));
  }
}

TEST_CASE("rng: consecutive indices, dimensions and passes are uncorrelated", "[rng]") {
  const int n = kSamples;
  const double limit = 5.0 / std::sqrt(static_cast<double>(n));  // 5 sigma of r under independence
  std::vector<double> a(n), next_index(n), next_dim(n), next_pass(n), next_seed(n);
  const pf_uint key = pf_rng_key(kSeed, 2);
  const pf_uint key_next_pass = pf_rng_key(kSeed, 3);
  const pf_uint key_next_seed = pf_rng_key(kSeed + 1, 2);
  for (int i = 0; i < n; ++i) {
    a[i] = pf_rng_unit(pf_rng_bits(key, i, 0));
    next_index[i] = pf_rng_unit(pf_rng_bits(key, i + 1, 0));
    next_dim[i] = pf_rng_unit(pf_rng_bits(key, i, 1));
    next_pass[i] = pf_rng_unit(pf_rng_bits(key_next_pass, i, 0));
    next_seed[i] = pf_rng_unit(pf_rng_bits(key_next_seed, i, 0));
  }
  CHECK(std::fabs(correlation(a, next_index)) < limit);
  CHECK(std::fabs(correlation(a, next_dim)) < limit);
  CHECK(std::fabs(correlation(a, next_pass)) < limit);
  CHECK(std::fabs(correlation(a, next_seed)) < limit);
}

TEST_CASE("rng: pairs of dimensions fill the unit square uniformly", "[rng]") {
  // 2-D chi-square on 32x32 cells over (dim k, dim k+1): catches dependence that a linear
  // correlation misses, e.g. for sampling a direction from two dimensions.
  for (pf_uint k : {0u, 5u}) {
    std::vector<int> cells(32 * 32, 0);
    const pf_uint key = pf_rng_key(kSeed, 0);
    for (int i = 0; i < kSamples; ++i) {
      int x = static_cast<int>(pf_rng_unit(pf_rng_bits(key, i, k)) * 32);
      int y = static_cast<int>(pf_rng_unit(pf_rng_bits(key, i, k + 1)) * 32);
      ++cells[x + 32 * y];
    }
    double chi2 = chi_square(cells, kSamples);
    INFO("dims " << k << "," << k + 1 << " chi2 " << chi2);
    CHECK(chi_square_plausible(chi2, 32 * 32 - 1));
  }
}

TEST_CASE("rng: each output bit is balanced and flips with each input bit half the time", "[rng]") {
  // Avalanche of the (index -> bits) map: flipping one index bit flips each output bit with
  // probability close to 1/2.
  const pf_uint key = pf_rng_key(kSeed, 0);
  const int n = 1 << 14;
  double worst = 0;
  for (int in_bit = 0; in_bit < 32; ++in_bit) {
    std::vector<int> flips(32, 0);
    for (int i = 0; i < n; ++i) {
      pf_uint idx = pf_rng_bits(key, i, 99);  // spread-out indices
      pf_uint d = pf_rng_bits(key, idx, 0) ^ pf_rng_bits(key, idx ^ (1u << in_bit), 0);
      for (int b = 0; b < 32; ++b) flips[b] += (d >> b) & 1u;
    }
    for (int b = 0; b < 32; ++b) worst = std::max(worst, std::fabs(flips[b] / double(n) - 0.5));
  }
  // 1024 (in, out) pairs, each a binomial proportion with sd = 0.5/sqrt(n) ≈ 0.0039.
  CHECK(worst < 6 * 0.5 / std::sqrt(double(n)));
}
