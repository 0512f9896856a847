// The path tracer's sampler (sampling/path_sampler.h): the padded Sobol points are stratified per
// dimension, uniform, independent between dimensions and pixels; the deep dimensions and the
// independent sampler are uniform; the byte table gives Sobol's dimension 1 exactly.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <vector>

#include "photonflow/sampling/path_sampler.h"
#include "photonflow/sampling/sobol_shared.h"

using namespace pf;

namespace {

// Whether the 2^k points lie one in each elementary interval of every shape 2^a × 2^(k−a).
bool net_2d(const std::vector<float>& u, const std::vector<float>& v, int k) {
  for (int a = 0; a <= k; ++a) {
    const int nx = 1 << a, ny = 1 << (k - a);
    std::vector<int> hits(size_t(nx) * size_t(ny), 0);
    for (size_t i = 0; i < u.size(); ++i) {
      if (!(u[i] >= 0.f && u[i] < 1.f && v[i] >= 0.f && v[i] < 1.f)) return false;
      const size_t cell = size_t(int(u[i] * float(nx))) * size_t(ny) + size_t(int(v[i] * float(ny)));
      if (++hits[cell] > 1) return false;
    }
  }
  return true;
}

bool strata_1d(const std::vector<float>& u, int k) {
  std::vector<int> hits(size_t(1) << k, 0);
  for (float x : u)
    if (!(x >= 0.f && x < 1.f) || ++hits[size_t(x * float(hits.size()))] > 1) return false;
  return true;
}

// Chi-square statistic of `u` against the uniform distribution over `bins` bins.
double chi2_uniform(const std::vector<float>& u, int bins) {
  std::vector<double> h(size_t(bins), 0.0);
  for (float x : u) h[size_t(std::min(bins - 1, int(x * float(bins))))] += 1.0;
  const double e = double(u.size()) / bins;
  double c = 0;
  for (double n : h) c += (n - e) * (n - e) / e;
  return c;
}

double correlation(const std::vector<float>& a, const std::vector<float>& b) {
  double ma = 0, mb = 0;
  for (size_t i = 0; i < a.size(); ++i) ma += a[i], mb += b[i];
  ma /= double(a.size());
  mb /= double(b.size());
  double sab = 0, saa = 0, sbb = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    sab += (a[i] - ma) * (b[i] - mb);
    saa += (a[i] - ma) * (a[i] - ma);
    sbb += (b[i] - mb) * (b[i] - mb);
  }
  return sab / std::sqrt(saa * sbb);
}

}  // namespace

TEST_CASE("path sampler: the byte table is Sobol's dimension 1", "[sampling][path_sampler]") {
  uint32_t x = 12345u;
  for (int n = 0; n < 100000; ++n) {
    const uint32_t i = n < 70000 ? uint32_t(n) : (x = x * 1664525u + 1013904223u);
    REQUIRE(kSobolDim1(i) == pf_sobol_bits(1u, i));
  }
}

TEST_CASE("path sampler: a pixel's samples stratify every Sobol dimension",
          "[sampling][path_sampler]") {
  const uint32_t key = PathSampler::key(PathSamplerKind::Sobol, 7u);
  const uint32_t dims2[] = {PathSampler::kCameraPixel, PathSampler::kCameraLens,
                            PathSampler::at(0, PathSampler::kLightPoint),
                            PathSampler::at(2, PathSampler::kBsdfDirection)};
  const uint32_t dims1[] = {PathSampler::at(0, PathSampler::kLightPick),
                            PathSampler::at(1, PathSampler::kRoulette),
                            PathSampler::at(2, PathSampler::kLobe)};
  for (uint32_t pixel : {0u, 17u, 40000u}) {
    for (int k : {4, 6, 8}) {
      // The first 2^k samples, and the next aligned block of 2^k.
      for (uint32_t start : {0u, 1u << k}) {
        for (uint32_t d : dims2) {
          std::vector<float> u, v;
          for (uint32_t s = start; s < start + (1u << k); ++s) {
            float a, b;
            PathSampler(PathSamplerKind::Sobol, key, 0u, pixel, s).get2(d, a, b);
            u.push_back(a);
            v.push_back(b);
          }
          INFO("pixel " << pixel << ", 2-D dimension " << d << ", samples " << start << " + 2^" << k);
          CHECK(net_2d(u, v, k));
        }
        for (uint32_t d : dims1) {
          std::vector<float> u;
          for (uint32_t s = start; s < start + (1u << k); ++s)
            u.push_back(PathSampler(PathSamplerKind::Sobol, key, 0u, pixel, s).get1(d));
          INFO("pixel " << pixel << ", 1-D dimension " << d << ", samples " << start << " + 2^" << k);
          CHECK(strata_1d(u, k));
        }
      }
    }
  }
  // The independent sampler does not stratify (it is the test's other side).
  std::vector<float> u, v;
  for (uint32_t s = 0; s < 64; ++s) {
    float a, b;
    PathSampler(PathSamplerKind::Independent, 0u, pf_rng_key(7u, s), 3u, s).get2(0u, a, b);
    u.push_back(a);
    v.push_back(b);
  }
  CHECK_FALSE(net_2d(u, v, 6));
}

TEST_CASE("path sampler: uniform over pixels, dimensions independent, deep dimensions too",
          "[sampling][path_sampler]") {
  const uint32_t key = PathSampler::key(PathSamplerKind::Sobol, 3u);
  const uint32_t deep = PathSampler::kSobolDims + 2u;  // past the Sobol bounces
  for (PathSamplerKind kind : {PathSamplerKind::Sobol, PathSamplerKind::Independent}) {
    for (uint32_t s : {0u, 1u, 37u}) {
      // One sample number over many pixels: each pixel's scramble is its own, so the values of
      // one sample number must look uniform, and two dimensions uncorrelated.
      std::vector<float> a, b, c, d, e;
      for (uint32_t p = 0; p < 40000; ++p) {
        const PathSampler ps(kind, key, pf_rng_key(3u, s), p, s);
        float u1, u2;
        ps.get2(PathSampler::kCameraPixel, u1, u2);
        a.push_back(u1);
        b.push_back(u2);
        c.push_back(ps.get1(PathSampler::at(0, PathSampler::kLightPick)));
        ps.get2(PathSampler::at(0, PathSampler::kLightPoint), u1, u2);
        d.push_back(u1);
        e.push_back(ps.get1(deep));
      }
      INFO((kind == PathSamplerKind::Sobol ? "sobol" : "independent") << ", sample " << s);
      // 64 bins, 63 degrees of freedom: P(χ² > 120) < 1e-5.
      for (const auto* x : {&a, &b, &c, &d, &e}) CHECK(chi2_uniform(*x, 64) < 120.0);
      // |r| of independent variables over n = 40000: standard deviation 0.005.
      CHECK(std::fabs(correlation(a, b)) < 0.03);
      CHECK(std::fabs(correlation(a, d)) < 0.03);
      CHECK(std::fabs(correlation(c, e)) < 0.03);
    }
  }
  // Deep dimensions change with the sample number (a stuck hash would repeat them).
  int same = 0;
  for (uint32_t s = 0; s < 100; ++s)
    same += PathSampler(PathSamplerKind::Sobol, key, 0u, 5u, s).get1(deep) ==
            PathSampler(PathSamplerKind::Sobol, key, 0u, 5u, s + 1).get1(deep);
  CHECK(same == 0);
}
