// Tests of ppm.h: each equation with hand-computed numbers, the invariants of the progressive
// update, and convergence of the progressive estimate on a photon field of known irradiance.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstring>
#include <vector>

#include "photonflow/stages/photon_grid.h"
#include "photonflow/estimators/ppm.h"
#include "photonflow/foundations/rng.h"

namespace {

pf_hitpoint make_hitpoint(float radius, float n, float t0, float t1, float t2) {
  pf_hitpoint hp;
  std::memset(&hp, 0, sizeof hp);
  hp.radius = radius;
  hp.n_photons = n;
  hp.flux[0] = t0;
  hp.flux[1] = t1;
  hp.flux[2] = t2;
  return hp;
}

}  // namespace

TEST_CASE("ppm: update follows eq. 3.14, 3.16, 3.18", "[ppm]") {
  // N = 10, R = 2, τ = (4, 8, 12); M = 5 new photons with τ_M = (1, 2, 3); α = 0.6.
  // N̂ = 10 + 0.6·5 = 13; ratio = 13/15; R̂ = 2·sqrt(13/15) = 1.8618987;
  // τ̂ = (5, 10, 15)·13/15 = (4.3333333, 8.6666667, 13).
  pf_hitpoint hp = make_hitpoint(2.f, 10.f, 4.f, 8.f, 12.f);
  const float tau_m[3] = {1.f, 2.f, 3.f};
  pf_ppm_update(&hp, 5, tau_m, 0.6f);
  CHECK(hp.n_photons == Approx(13.f));
  CHECK(hp.radius == Approx(1.8618987f).epsilon(1e-6));
  CHECK(hp.flux[0] == Approx(4.3333333f).epsilon(1e-6));
  CHECK(hp.flux[1] == Approx(8.6666667f).epsilon(1e-6));
  CHECK(hp.flux[2] == Approx(13.f).epsilon(1e-6));
}

TEST_CASE("ppm: a split state (pf_ppm_state) updates to the hitpoint's bits", "[ppm]") {
  // The hashed-grid gather keeps R, N, τ apart from the rest of the hitpoint; its update must give
  // the same bits as the hitpoint's, whatever the inputs (M = 0 included: both unchanged).
  for (uint32_t i = 0; i < 2000; ++i) {
    pf_rng r = pf_rng_start(11, 0, i);
    const float radius = 0.01f + pf_rng_next(&r), n = i % 5 == 0 ? 0.f : 100.f * pf_rng_next(&r);
    // One draw per statement (last argument first, as GCC evaluated the former argument list).
    const float f2 = pf_rng_next(&r), f1 = pf_rng_next(&r), f0 = pf_rng_next(&r);
    pf_hitpoint hp = make_hitpoint(radius, n, f0, f1, f2);
    pf_ppm_state st = {hp.radius, hp.n_photons, {hp.flux[0], hp.flux[1], hp.flux[2]}};
    const float tau_m[3] = {pf_rng_next(&r), 2.f * pf_rng_next(&r), 3.f * pf_rng_next(&r)};
    const int m = int(i % 7);
    const float alpha = 0.1f + 0.9f * pf_rng_next(&r);
    pf_ppm_update(&hp, m, tau_m, alpha);
    pf_ppm_update_state(&st, m, tau_m, alpha);
    INFO("case " << i);
    CHECK(std::memcmp(&st.radius, &hp.radius, sizeof(float)) == 0);
    CHECK(std::memcmp(&st.n_photons, &hp.n_photons, sizeof(float)) == 0);
    CHECK(std::memcmp(st.flux, hp.flux, sizeof st.flux) == 0);
    if (m == 0) CHECK(hp.radius == radius);
    else CHECK(hp.radius < radius);
  }
}

TEST_CASE("ppm: the first pass keeps the fraction alpha", "[ppm]") {
  // N = 0: ratio = αM/M = α, so N̂ = αM, R̂ = R·sqrt(α), τ̂ = α·τ_M.
  pf_hitpoint hp = make_hitpoint(5.f, 0.f, 0.f, 0.f, 0.f);
  const float tau_m[3] = {10.f, 20.f, 30.f};
  pf_ppm_update(&hp, 100, tau_m, 0.7f);
  CHECK(hp.n_photons == Approx(70.f));
  CHECK(hp.radius == Approx(5.f * std::sqrt(0.7f)));
  CHECK(hp.flux[0] == Approx(7.f));
  CHECK(hp.flux[1] == Approx(14.f));
  CHECK(hp.flux[2] == Approx(21.f));
}

TEST_CASE("ppm: M = 0 leaves the hitpoint bit-identical", "[ppm]") {
  pf_hitpoint hp = make_hitpoint(0.37f, 12.5f, 1.f, 2.f, 3.f);
  hp.position[0] = 1.f;
  hp.pixel_x = 7;
  pf_hitpoint before = hp;
  const float tau_m[3] = {0.f, 0.f, 0.f};
  pf_ppm_update(&hp, 0, tau_m, 0.7f);
  CHECK(std::memcmp(&hp, &before, sizeof hp) == 0);
  // Also for a hitpoint that never saw a photon (0/0 must not appear).
  pf_hitpoint fresh = make_hitpoint(1.f, 0.f, 0.f, 0.f, 0.f);
  pf_hitpoint fresh_before = fresh;
  pf_ppm_update(&fresh, 0, tau_m, 0.7f);
  CHECK(std::memcmp(&fresh, &fresh_before, sizeof fresh) == 0);
  // pf_ppm_updated itself (not only its two wrappers, which test m first) keeps the state: with
  // N = 0 and M = 0 the ratio (N + αM)/(N + M) would be 0/0.
  const pf_ppm_state st = {1.f, 0.f, {0.f, 0.f, 0.f}};
  const pf_ppm_state same = pf_ppm_updated(st, 0, tau_m, 0.7f);
  CHECK(std::memcmp(&same, &st, sizeof st) == 0);
}

TEST_CASE("ppm: alpha = 1 keeps the radius and sums flux and counts", "[ppm]") {
  pf_hitpoint hp = make_hitpoint(0.25f, 3.f, 1.f, 1.f, 1.f);
  const float tau_m[3] = {0.5f, 1.5f, 2.5f};
  for (int pass = 0; pass < 10; ++pass) pf_ppm_update(&hp, 4, tau_m, 1.f);
  CHECK(hp.radius == 0.25f);
  CHECK(hp.n_photons == Approx(43.f));
  CHECK(hp.flux[0] == Approx(6.f));
  CHECK(hp.flux[1] == Approx(16.f));
  CHECK(hp.flux[2] == Approx(26.f));
}

TEST_CASE("ppm: the radius decreases monotonically for alpha < 1", "[ppm]") {
  for (float alpha : {0.3f, 0.7f, 0.95f}) {
    pf_hitpoint hp = make_hitpoint(1.f, 0.f, 0.f, 0.f, 0.f);
    const float tau_m[3] = {1.f, 1.f, 1.f};
    float prev = hp.radius;
    for (int pass = 0; pass < 200; ++pass) {
      int m = 1 + (pass * 7919) % 13;  // varying photon counts
      pf_ppm_update(&hp, m, tau_m, alpha);
      INFO("alpha " << alpha << " pass " << pass);
      REQUIRE(hp.radius < prev);
      prev = hp.radius;
    }
    CHECK(hp.radius > 0.f);
  }
}

TEST_CASE("ppm: radiance estimates eq. 3.19 and eq. 3.10", "[ppm]") {
  // eq. 3.19: τ = 2π, R = 0.5, N_emitted = 1000 → L = 2π / (π·0.25·1000) = 0.008.
  CHECK(pf_ppm_radiance(2.f * PF_PI, 0.5f, 1000.f) == Approx(0.008f));
  CHECK(pf_ppm_radiance(1.f, 0.5f, 0.f) == 0.f);
  // eq. 3.10: Σ f_r ΔΦ = 3, r² = 0.25 → L = 3 / (π·0.25) = 3.8197186.
  CHECK(pf_pm_estimate(3.f, 0.25f) == Approx(3.8197186f));
  CHECK(pf_pm_estimate(3.f, 0.f) == 0.f);
}

TEST_CASE("ppm: the gather rule includes the boundary", "[ppm]") {
  float d2 = pf_ppm_dist2(1.f, 2.f, 3.f, 1.f, 2.f, 3.5f);
  CHECK(d2 == 0.25f);
  CHECK(pf_ppm_in_radius(d2, 0.5f));
  CHECK_FALSE(pf_ppm_in_radius(d2, std::nextafter(0.5f, 0.f)));
}

TEST_CASE("ppm: progressive estimate converges on a uniform photon field", "[ppm]") {
  // A light sends power P onto the unit square z = 0 (area A = 1) uniformly: irradiance E = P/A.
  // Each photon carries the whole power P (eq. 3.19 divides by the photons emitted). A Lambertian
  // surface of albedo ρ reflects L = (ρ/π)·E, which every hitpoint must approach.
  const float power = 10.f, albedo = 0.5f, alpha = 0.7f, r0 = 0.1f;
  const float f_r = albedo / PF_PI;
  const double expected = f_r * power / 1.0;
  const int photons_per_pass = 100000, passes = 60;
  const float centres[4][2] = {{0.3f, 0.3f}, {0.7f, 0.4f}, {0.5f, 0.5f}, {0.35f, 0.75f}};

  std::vector<pf_hitpoint> hps;
  for (const auto& c : centres) {
    pf_hitpoint hp = make_hitpoint(r0, 0.f, 0.f, 0.f, 0.f);
    hp.position[0] = c[0];
    hp.position[1] = c[1];
    hps.push_back(hp);
  }
  pf::PhotonGridParams gp;  // photon_grid.h gathers, as the CPU stage will
  gp.default_radius = r0;
  double emitted = 0;
  std::vector<pf_photon> photons(photons_per_pass);
  for (int pass = 0; pass < passes; ++pass) {
    for (int i = 0; i < photons_per_pass; ++i) {
      pf_photon& p = photons[i];
      std::memset(&p, 0, sizeof p);
      p.position[0] = pf_rng_float(7, pass, i, 0);
      p.position[1] = pf_rng_float(7, pass, i, 1);
      p.flux[0] = p.flux[1] = p.flux[2] = power;
      p.pass = pass;
    }
    emitted += photons_per_pass;
    pf::PhotonGrid grid = pf::build_photon_grid(photons, 1, gp);
    for (pf_hitpoint& hp : hps) {
      int m = 0;
      float tau_m[3] = {0.f, 0.f, 0.f};
      grid.for_each_in_radius(0, hp.position, hp.radius, [&](int i) {
        ++m;
        for (int c = 0; c < 3; ++c) tau_m[c] += f_r * grid.photons[i].flux[c];  // eq. 3.17
      });
      pf_ppm_update(&hp, m, tau_m, alpha);
    }
  }
  for (const pf_hitpoint& hp : hps) {
    double l = pf_ppm_radiance(hp.flux[0], hp.radius, static_cast<float>(emitted));
    INFO("hitpoint (" << hp.position[0] << ", " << hp.position[1] << "): L = " << l
                      << ", expected " << expected << ", R = " << hp.radius
                      << ", N = " << hp.n_photons);
    CHECK(hp.radius < r0 * 0.75f);  // the radius has shrunk (consistency)
    CHECK(std::fabs(l / expected - 1.0) < 0.02);
  }
}
