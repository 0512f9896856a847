// Sobol points (sampling/sobol_shared.h) and the light samples of the shadow rays that use them
// (pixel_sampler.h pf_light_draws; eye_pass.cpp direct_light).
#include <catch2/catch.hpp>

#include <cmath>
#include <vector>

#include "photonflow/stages/eye_pass.h"
#include "photonflow/sampling/pixel_sampler.h"
#include "photonflow/sampling/sampling.h"
#include "photonflow/sampling/sobol_shared.h"
#include "support.h"

using namespace pf;

namespace {

// Joe & Kuo (2008), new-joe-kuo-6.21201, rows d = 2..16: degree s, coefficients a, m_1..m_s.
struct JoeKuoRow {
  int s;
  uint32_t a;
  std::vector<uint32_t> m;
};
const std::vector<JoeKuoRow> kJoeKuo = {
    {1, 0, {1}},          {2, 1, {1, 3}},        {3, 1, {1, 3, 1}},
    {3, 2, {1, 1, 1}},    {4, 1, {1, 1, 3, 3}},  {4, 4, {1, 3, 5, 13}},
    {5, 2, {1, 1, 5, 5, 17}},   {5, 4, {1, 1, 5, 5, 5}},   {5, 7, {1, 1, 7, 11, 19}},
    {5, 11, {1, 1, 5, 1, 1}},   {5, 13, {1, 1, 1, 3, 11}}, {5, 14, {1, 3, 5, 5, 31}},
    {6, 1, {1, 3, 3, 9, 7, 49}}, {6, 13, {1, 1, 1, 15, 21, 21}}, {6, 16, {1, 3, 1, 13, 27, 49}}};

// The generator matrix of dimension d from the published numbers (Joe & Kuo eq. 2.3).
std::vector<uint32_t> directions(int d) {
  std::vector<uint32_t> v(32);
  if (d == 0) {
    for (int k = 0; k < 32; ++k) v[size_t(k)] = 1u << (31 - k);
    return v;
  }
  const JoeKuoRow& r = kJoeKuo[size_t(d - 1)];
  for (int k = 0; k < r.s; ++k) v[size_t(k)] = r.m[size_t(k)] << (31 - k);
  for (int k = r.s; k < 32; ++k) {
    uint32_t x = v[size_t(k - r.s)] ^ (v[size_t(k - r.s)] >> r.s);
    for (int j = 1; j < r.s; ++j)
      if ((r.a >> (r.s - 1 - j)) & 1u) x ^= v[size_t(k - j)];
    v[size_t(k)] = x;
  }
  return v;
}

// Whether n = 2^k values lie one in each interval [i/n, (i+1)/n).
bool stratified_1d(const std::vector<float>& xs, int k) {
  std::vector<int> hits(size_t(1) << k, 0);
  for (float x : xs)
    if (!(x >= 0.f && x < 1.f) || ++hits[size_t(x * float(hits.size()))] > 1) return false;
  return true;
}

}  // namespace

TEST_CASE("Sobol: the table is Joe and Kuo's numbers, and its points have the net properties",
          "[sobol]") {
  for (int d = 0; d < PF_SOBOL_DIMS; ++d) {
    const std::vector<uint32_t> v = directions(d);
    for (int k = 0; k < 32; ++k) {
      INFO("dimension " << d << ", column " << k);
      REQUIRE(pf_sobol_matrix[d * 32 + k] == v[size_t(k)]);
    }
  }
  // Dimension 0 is the radical inverse; dimension 1 the Pascal matrix the pixel sampler used.
  for (uint32_t i : {0u, 1u, 2u, 3u, 1000u, 123456789u, 0xffffffffu}) {
    CHECK(pf_sobol_bits(0, i) == pf_reverse_bits32(i));
    uint32_t r = 0;
    uint32_t v = 0x80000000u;
    for (uint32_t j = i; j != 0; j >>= 1, v ^= v >> 1)
      if (j & 1u) r ^= v;
    CHECK(pf_sobol_bits(1, i) == r);
  }
  // Every dimension alone is a (0,1)-sequence: the first 2^k points, one per interval; so is
  // every aligned block of 2^k points. Dimensions 0 and 1 together are a (0,2)-sequence.
  for (int d = 0; d < PF_SOBOL_DIMS; ++d)
    for (int k : {1, 4, 8, 12})
      for (uint32_t block : {0u, 5u}) {
        std::vector<float> xs;
        for (uint32_t i = 0; i < (1u << k); ++i)
          xs.push_back(pf_rng_unit(pf_sobol_bits(uint32_t(d), (block << k) + i)));
        INFO("dimension " << d << ", k " << k << ", block " << block);
        CHECK(stratified_1d(xs, k));
      }
  for (int k = 0; k <= 12; ++k) {
    std::vector<float> xs, ys;
    for (uint32_t i = 0; i < (1u << k); ++i) {
      xs.push_back(pf_rng_unit(pf_sobol_bits(0, i)));
      ys.push_back(pf_rng_unit(pf_sobol_bits(1, i)));
    }
    INFO("k " << k);
    CHECK(test::is_net(xs, ys, k));
  }
  // The check can fail: dimensions 1 and 2 are not a (0,2)-sequence (t > 0 for that pair).
  bool all_nets = true;
  for (int k = 2; k <= 8; ++k) {
    std::vector<float> xs, ys;
    for (uint32_t i = 0; i < (1u << k); ++i) {
      xs.push_back(pf_rng_unit(pf_sobol_bits(1, i)));
      ys.push_back(pf_rng_unit(pf_sobol_bits(2, i)));
    }
    all_nets = all_nets && test::is_net(xs, ys, k);
  }
  CHECK_FALSE(all_nets);
}

TEST_CASE("Light samples: a pixel's Sobol draws over the passes stratify the light, per pixel",
          "[sobol][eye]") {
  // Under PF_SAMPLER_SOBOL, sample k of eye sample s in pass p is point (p·spp + s)·S + k of the
  // pixel's sequence: the first 2^k samples of a pixel (whatever spp and S divide them into) are
  // a (0,k,2)-net in (u1, u2) and one per interval in ul, after scrambling and index shuffling.
  for (int spp : {1, 2})
    for (int samples : {1, 4})
      for (uint32_t pixel : {0u, 77u, 262143u}) {
        const int k = 10, n = 1 << k, per_pass = spp * samples;
        std::vector<float> ul, u1, u2;
        for (int pass = 0; pass * per_pass < n; ++pass)
          for (int s = 0; s < spp; ++s) {
            pf_light_draws d = pf_light_draws_start(PF_SAMPLER_SOBOL, 9, pf_sobol_key(9),
                                                    uint32_t(pass), pixel, s, spp, samples);
            for (int j = 0; j < samples; ++j) {
              float a, b, c;
              pf_light_draws_next(&d, &a, &b, &c);
              ul.push_back(a);
              u1.push_back(b);
              u2.push_back(c);
            }
          }
        INFO("spp " << spp << ", samples " << samples << ", pixel " << pixel);
        CHECK(test::is_net(u1, u2, k));
        CHECK(stratified_1d(ul, k));
      }
  // Two pixels, two different scrambles; and the other samplers draw the shadow stream, as
  // direct_light's (seed, pass, index) form does.
  float a0, b0, c0, a1, b1, c1;
  pf_light_draws d0 = pf_light_draws_start(PF_SAMPLER_SOBOL, 9, pf_sobol_key(9), 0, 0, 0, 1, 4);
  pf_light_draws d1 = pf_light_draws_start(PF_SAMPLER_SOBOL, 9, pf_sobol_key(9), 0, 1, 0, 1, 4);
  pf_light_draws_next(&d0, &a0, &b0, &c0);
  pf_light_draws_next(&d1, &a1, &b1, &c1);
  CHECK((a0 != a1 || b0 != b1 || c0 != c1));
  for (int sampler : {PF_SAMPLER_STRATA, PF_SAMPLER_RANDOM}) {
    pf_light_draws d = pf_light_draws_start(sampler, 9, pf_sobol_key(9), 3, 5, 1, 2, 4);
    pf_rng r = pf_rng_start(9, PF_SHADOW_STREAM_SLOT + 3, 5 * 2 + 1);
    for (int j = 0; j < 4; ++j) {
      float ul, u1, u2;
      pf_light_draws_next(&d, &ul, &u1, &u2);
      CHECK(ul == pf_rng_next(&r));
      CHECK(u1 == pf_rng_next(&r));
      CHECK(u2 == pf_rng_next(&r));
    }
  }
}

TEST_CASE("Light samples: the first two vertices of an eye path each draw a stratified set, "
          "later ones the eye stream",
          "[sobol][eye]") {
  // pf_light_draws_vertex: vertex 0 = pf_light_draws_start's set; vertex 1 = a second set, over
  // the passes a (0,k,2)-net too and not the first's points; vertex 2 on = the eye stream. The
  // same under a glossy sample's key with sobol set (index pass·G + k).
  const int k = 8, n = 1 << k, samples = 1, spp = 1;
  const uint32_t pixel = 4242, seed = 9;
  for (uint32_t key : {pf_sobol_key(seed), pf_glossy_sobol_key(seed)}) {
    std::vector<float> u[2][3];
    int same = 0;
    for (int pass = 0; pass < n; ++pass) {
      const pf_rng eye = pf_rng_start(seed, 0xE7E0000u + uint32_t(pass), pixel);
      float v[2][3];
      for (int vertex = 0; vertex < 2; ++vertex) {
        pf_int from_eye = -1;
        pf_light_draws d = pf_light_draws_vertex(1, key, seed, uint32_t(pass), pixel, 0, spp,
                                                 uint32_t(pass), samples, vertex, eye, &from_eye);
        CHECK(from_eye == 0);
        pf_light_draws_next(&d, &v[vertex][0], &v[vertex][1], &v[vertex][2]);
        for (int c = 0; c < 3; ++c) u[vertex][c].push_back(v[vertex][c]);
      }
      if (key == pf_sobol_key(seed)) {  // vertex 0 is the pixel's set of pf_light_draws_start
        pf_light_draws d0 = pf_light_draws_start(PF_SAMPLER_SOBOL, seed, key, uint32_t(pass),
                                                 pixel, 0, spp, samples);
        float a, b, c;
        pf_light_draws_next(&d0, &a, &b, &c);
        CHECK((a == v[0][0] && b == v[0][1] && c == v[0][2]));
      }
      same += v[0][1] == v[1][1] && v[0][2] == v[1][2];
      // vertex 2 continues the eye stream
      pf_int from_eye = 0;
      pf_light_draws d2 = pf_light_draws_vertex(1, key, seed, uint32_t(pass), pixel, 0, spp,
                                                uint32_t(pass), samples, 2, eye, &from_eye);
      CHECK(from_eye == 1);
      pf_rng r = eye;
      float a, b, c;
      pf_light_draws_next(&d2, &a, &b, &c);
      CHECK((a == pf_rng_next(&r) && b == pf_rng_next(&r) && c == pf_rng_next(&r)));
      CHECK((d2.rng.index == r.index && d2.rng.dim == r.dim));
    }
    for (int vertex = 0; vertex < 2; ++vertex) {
      INFO("vertex " << vertex);
      CHECK(test::is_net(u[vertex][1], u[vertex][2], k));
      CHECK(stratified_1d(u[vertex][0], k));
    }
    CHECK(same == 0);
  }
  // Without Sobol draws vertex 0 is the shadow stream, vertex 1 already the eye stream.
  const pf_rng eye = pf_rng_start(seed, 0xE7E0000u + 3u, pixel);
  pf_int from_eye = -1;
  pf_light_draws d0 = pf_light_draws_vertex(0, pf_sobol_key(seed), seed, 3, pixel, 1, 2, 7, 4, 0,
                                            eye, &from_eye);
  CHECK(from_eye == 0);
  pf_rng r0 = pf_rng_start(seed, PF_SHADOW_STREAM_SLOT + 3, pixel * 2 + 1);
  float a, b, c;
  pf_light_draws_next(&d0, &a, &b, &c);
  CHECK((a == pf_rng_next(&r0) && b == pf_rng_next(&r0) && c == pf_rng_next(&r0)));
  pf_light_draws d1 = pf_light_draws_vertex(0, pf_sobol_key(seed), seed, 3, pixel, 1, 2, 7, 4, 1,
                                            eye, &from_eye);
  CHECK(from_eye == 1);
  pf_rng r1 = eye;
  pf_light_draws_next(&d1, &a, &b, &c);
  CHECK((a == pf_rng_next(&r1) && b == pf_rng_next(&r1) && c == pf_rng_next(&r1)));
}

TEST_CASE("Light samples: Sobol draws give the same direct light with less variance than "
          "independent ones",
          "[sobol][eye][transport]") {
  // A point on the floor of the test room (its lamp: a small box of emitting triangles under the
  // ceiling, so ul picks a triangle and u1, u2 a point on it): one light sample a pass, 64
  // passes, over 48 seeds. The mean over the seeds is the same for both (each Sobol point is
  // uniform), and the 64-pass estimate's variance over the seeds falls below half of the
  // independent draws' (the samples stratify the lamp's triangles and their area).
  const Scene s = test::room_scene(PF_MAT_DIFFUSE, 8, 8);
  REQUIRE(!s.lights.empty());
  const Vec3 n(0, 1, 0);
  const pf_material& m = s.materials[0];
  const Vec3 p(0.45f, 0.001f, 0.82f);  // beside the ball, in front of it
  const int passes = 64, seeds = 48;
  auto run = [&](int sampler, uint32_t seed) {
    double sum = 0.0;
    for (int pass = 0; pass < passes; ++pass) {
      pf_light_draws d = pf_light_draws_start(sampler, seed, pf_sobol_key(seed), uint32_t(pass),
                                              12345u, 0, 1, 1);
      sum += luminance(direct_light(s, p, n, n, m, 1, d));
    }
    return sum / passes;
  };
  double mean[2] = {0, 0}, var[2] = {0, 0};
  const int samplers[2] = {PF_SAMPLER_RANDOM, PF_SAMPLER_SOBOL};
  for (int k = 0; k < 2; ++k) {
    std::vector<double> est;
    for (int i = 0; i < seeds; ++i) est.push_back(run(samplers[k], uint32_t(100 + i)));
    for (double e : est) mean[k] += e / seeds;
    for (double e : est) var[k] += (e - mean[k]) * (e - mean[k]) / (seeds - 1);
  }
  INFO("random mean " << mean[0] << " var " << var[0] << "; sobol mean " << mean[1] << " var "
                      << var[1]);
  REQUIRE(mean[0] > 0.0);
  REQUIRE(var[0] > 0.0);
  // Same expectation: within 4 standard errors of the difference.
  CHECK(std::fabs(mean[0] - mean[1]) < 4.0 * std::sqrt((var[0] + var[1]) / seeds));
  CHECK(var[1] < 0.5 * var[0]);
}
