// merge_weight_shared_test.cpp — material/merge_weight_shared.h: the split of a glossy vertex's
// light between the gather there and the continuation of the eye path.
//
//   - the weights and the merge probability are in range, q is snapped as documented, and the
//     weight favours the gather on wide lobes and the continuation on narrow ones;
//   - eq. (2)–(3) as the eye pass and the gathers use them: in a white furnace (incident radiance
//     1 from every direction) the gather's share (∫ f·w_m cos, with f·w_m from
//     pf_pbr_point_eval of a merge-weighted point) plus the continuation's (E[β (1 − w_m)]) is
//     the albedo ∫ f cos, and so is the mean of the one-branch estimator that takes the gather
//     with probability q (divided by q) and the continuation otherwise (divided by 1 − q).
//     Caught: a gather that weighs photons by w_c instead of w_m, or not at all; a continuation
//     weight that is not the complement of the gather's.
#include <catch2/catch.hpp>

#include <cmath>
#include <random>

#include "photonflow/material/merge_weight_shared.h"
#include "photonflow/material/pbr_point_shared.h"

namespace {

pf_bsdf_params material(float c, float metallic, float roughness, float transmission = 0.f) {
  pf_bsdf_params m;
  m.base_color[0] = m.base_color[1] = m.base_color[2] = c;
  m.metallic = metallic;
  m.roughness = roughness;
  m.transmission = transmission;
  m.ior = 1.5f;
  return m;
}

void dir_from(float cos_theta, float phi, float* w) {
  const float s = std::sqrt(std::max(0.f, 1.f - cos_theta * cos_theta));
  w[0] = s * std::cos(phi);
  w[1] = s * std::sin(phi);
  w[2] = cos_theta;
}

// ∫ g(wi) |wi.z| dωi over the sphere by the midpoint rule.
template <class G>
double sphere_integral(G g, int nt = 900, int np = 360) {
  double s = 0;
  const double dt = M_PI / nt, dp = 2 * M_PI / np;
  for (int a = 0; a < nt; ++a) {
    const double th = (a + 0.5) * dt;
    for (int b = 0; b < np; ++b) {
      const double ph = (b + 0.5) * dp;
      const float wi[3] = {float(std::sin(th) * std::cos(ph)), float(std::sin(th) * std::sin(ph)),
                           float(std::cos(th))};
      s += g(wi) * std::fabs(std::cos(th)) * std::sin(th) * dt * dp;
    }
  }
  return s;
}

}  // namespace

TEST_CASE("merge weight: in range, and the merge probability snapped as documented",
          "[merge]") {
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> uni(0.f, 1.f);
  int merges = 0, continues = 0, shared = 0;
  for (float roughness : {0.05f, 0.2f, 0.4f, 0.7f, 1.f})
    for (float cos_o : {0.1f, 0.5f, 0.95f})
      for (const pf_bsdf_params& m : {material(0.9f, 1, roughness), material(1, 0, roughness, 1),
                                      material(0.8f, 0, roughness)}) {
        float o[3];
        dir_from(cos_o, 0.3f, o);
        const float q = pf_merge_probability(&m, o);
        INFO("roughness " << roughness << " cos " << cos_o << " q " << q);
        CHECK((q == 0.f || q == 1.f || (q >= PF_MERGE_Q_MIN && q <= 1.f - PF_MERGE_Q_MIN)));
        merges += q == 1.f;
        continues += q == 0.f;
        shared += q > 0.f && q < 1.f;
        for (int k = 0; k < 50; ++k) {
          float i[3];
          pf_sample_uniform_sphere(uni(rng), uni(rng), i);
          const float w = pf_merge_weight(&m, o, i);
          CHECK(w >= 0.f);
          CHECK(w <= 1.f);
        }
      }
  CHECK(continues > 0);  // smooth metal and glass go on
  CHECK(shared > 0);
  // a narrow lobe is continued, a wide one gathered more
  float o[3];
  dir_from(0.8f, 0.f, o);
  const pf_bsdf_params smooth = material(1, 1, 0.1f), rough = material(1, 1, 1.f);
  CHECK(pf_merge_probability(&smooth, o) < 0.05f);
  CHECK(pf_merge_probability(&rough, o) > 0.5f);
  (void)merges;
}

TEST_CASE("merge weight: gather and continuation shares sum to the albedo in a furnace",
          "[merge][furnace]") {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> uni(0.f, 1.f);
  struct Case {
    const char* name;
    pf_bsdf_params m;
  };
  const Case cases[] = {{"metal 0.3", material(1, 1, 0.3f)},
                        {"metal 0.6", material(0.9f, 1, 0.6f)},
                        {"rough glass 0.4", material(1, 0, 0.4f, 1)},
                        {"plastic 0.5", material(0.7f, 0, 0.5f)}};
  const float n[3] = {0, 0, 1};
  for (const Case& c : cases)
    for (float cos_o : {0.3f, 0.9f}) {
      float o[3];
      dir_from(cos_o, 1.1f, o);
      pf_pbr_point pt;
      pt.params = c.m;
      pt.outside = PF_PBR_POINT_OUTSIDE;
      auto f_of = [&](const float* wi, int flags) {
        pf_pbr_point p = pt;
        p.outside = flags;
        float f[3];
        pf_pbr_point_eval(&p, n, o, wi, f);
        return double(f[0]);
      };
      const double albedo = sphere_integral([&](const float* wi) { return f_of(wi, 1); });
      const double gathered =
          sphere_integral([&](const float* wi) { return f_of(wi, 1 | PF_PBR_POINT_MERGE_WEIGHTED); });
      // the continuation's share: E[β (1 − w_m)] over the BSDF's samples
      const int N = 400000;
      double cont = 0, cont2 = 0;
      for (int k = 0; k < N; ++k) {
        pf_bsdf_sample_rec rec;
        if (!pf_bsdf_sample(&c.m, o, uni(rng), uni(rng), uni(rng), PF_TRANSPORT_RADIANCE, &rec))
          continue;
        const double v = rec.weight[0] * (1.0 - pf_merge_weight(&c.m, o, rec.wi));
        cont += v;
        cont2 += v * v;
      }
      cont /= N;
      const double se = std::sqrt(std::max(0.0, cont2 / N - cont * cont) / N);
      INFO(c.name << ", cos θo " << cos_o << ": albedo " << albedo << ", gathered " << gathered
                  << ", continued " << cont << " ± " << se);
      CHECK(gathered > 0.0);
      CHECK(std::fabs(gathered + cont - albedo) <= 4 * se + 2e-3 * albedo);
      // the one-branch estimator of eq. (3) with the vertex's own q
      const float q = pf_merge_probability(&c.m, o);
      double est = 0, est2 = 0;
      const int M = 200000;
      for (int k = 0; k < M; ++k) {
        double v;
        if (q >= 1.f || (q > 0.f && uni(rng) < q)) {
          v = q >= 1.f ? albedo : gathered / q;  // the gather's expectation
        } else {
          pf_bsdf_sample_rec rec;
          v = 0;
          if (pf_bsdf_sample(&c.m, o, uni(rng), uni(rng), uni(rng), PF_TRANSPORT_RADIANCE, &rec))
            v = rec.weight[0] *
                (q > 0.f ? (1.0 - pf_merge_weight(&c.m, o, rec.wi)) / (1.0 - q) : 1.0);
        }
        est += v;
        est2 += v * v;
      }
      est /= M;
      const double se2 = std::sqrt(std::max(0.0, est2 / M - est * est) / M);
      INFO("q " << q << ", one-branch estimate " << est << " ± " << se2);
      CHECK(std::fabs(est - albedo) <= 4 * se2 + 2e-3 * albedo);
    }
}
