// The CPU pipeline (issue 3): white furnace, energy bookkeeping, determinism, caustic flags,
// gather equivalence.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstring>

#include "photonflow/stages/eye_pass.h"
#include "photonflow/stages/illuminate.h"
#include "photonflow/stages/photon_pass.h"
#include "photonflow/estimators/render_driver.h"
#include "photonflow/stages/synthesize.h"
#include "support.h"

using namespace pf;

namespace {
HitpointSet eye_state(const Scene& s, const EyePassOptions& opt) {
  return make_hitpoint_set(trace_hitpoints(s, opt), opt.direct, s.scene_id);
}

// Mean and worst relative deviation of the image's channels from `expected`.
void furnace_errors(const Image& img, float expected, double& mean_err, double& max_err) {
  double sum = 0;
  max_err = 0;
  for (float v : img.rgb) {
    sum += v;
    max_err = std::max(max_err, std::fabs(v / expected - 1.0));
  }
  mean_err = std::fabs(sum / double(img.rgb.size()) / expected - 1.0);
}
}  // namespace

TEST_CASE("white furnace: PPM converges to Le/(1-rho)", "[pipeline][furnace]") {
  const float rho = 0.5f, le = 1.f, expected = le / (1.f - rho);
  Scene s = test::furnace_scene(rho, le, 16);
  EyePassOptions eye;
  eye.radius = 0.15f;
  HitpointSet h = eye_state(s, eye);
  REQUIRE(h.hitpoints.size() == 16u * 16u);
  PhotonPassOptions po;
  po.photons = 50000;
  po.max_bounces = 64;
  PpmOptions ppm;
  for (uint32_t pass = 0; pass < 8; ++pass) {
    PhotonPassResult r = trace_photons(s, pass, po);
    ppm_pass(s, h, r.photons, r.emitted, ppm);
  }
  Image img = synthesize(h);
  double mean_err, max_err;
  furnace_errors(img, expected, mean_err, max_err);
  INFO("mean error " << mean_err << ", worst pixel " << max_err);
  CHECK(mean_err < 0.01);
  CHECK(max_err < 0.05);
}

TEST_CASE("white furnace: classic photon mapping converges to Le/(1-rho)", "[pipeline][furnace]") {
  const float rho = 0.5f, le = 1.f, expected = le / (1.f - rho);
  Scene s = test::furnace_scene(rho, le, 12);
  HitpointSet h = eye_state(s, EyePassOptions{});
  PhotonPassOptions po;
  po.photons = 1000000;
  po.max_bounces = 64;
  PhotonPassResult r = trace_photons(s, 0, po);
  ClassicOptions co;
  co.k = 8000;
  classic_estimate(s, h, r.photons, r.emitted, co);
  Image img = synthesize(h);
  double mean_err, max_err;
  furnace_errors(img, expected, mean_err, max_err);
  INFO("mean error " << mean_err << ", worst pixel " << max_err);
  CHECK(mean_err < 0.01);
  CHECK(max_err < 0.05);
}

TEST_CASE("photon tracing conserves energy: stored flux = emitted power / (1 - rho)",
          "[pipeline][energy]") {
  const float rho = 0.5f, le = 1.f;
  Scene s = test::furnace_scene(rho, le, 4);
  double area = 0;
  for (auto& l : s.lights) area += l.area;
  const double power = 3.14159265358979 * area * le;  // one-sided Lambertian emitters
  PhotonPassOptions po;
  po.photons = 100000;
  po.max_bounces = 64;
  PhotonPassResult r = trace_photons(s, 0, po);
  double stored[3] = {0, 0, 0}, direct = 0;
  for (auto& p : r.photons) {
    for (int c = 0; c < 3; ++c) stored[c] += p.flux[c];
    if (p.flags & PF_PHOTON_DIRECT) direct += p.flux[0];
  }
  for (int c = 0; c < 3; ++c)
    CHECK(stored[c] / double(r.emitted) == Approx(power / (1.0 - rho)).epsilon(0.01));
  // The first hits carry exactly the emitted power.
  CHECK(direct / double(r.emitted) == Approx(power).epsilon(0.001));
}

TEST_CASE("photons and hitpoints do not depend on the thread count", "[pipeline][determinism]") {
  Scene s = test::room_scene(PF_MAT_GLASS, 48, 32);
  PhotonPassOptions po;
  po.photons = 20000;
  po.threads = 1;
  PhotonPassResult a = trace_photons(s, 3, po);
  po.threads = 2;
  PhotonPassResult b = trace_photons(s, 3, po);
  REQUIRE(a.photons.size() == b.photons.size());
  REQUIRE_FALSE(a.photons.empty());
  CHECK(std::memcmp(a.photons.data(), b.photons.data(), a.photons.size() * sizeof(pf_photon)) == 0);
  // A different pass gives different photons.
  PhotonPassResult c = trace_photons(s, 4, po);
  CHECK((c.photons.size() != a.photons.size() ||
         std::memcmp(a.photons.data(), c.photons.data(), a.photons.size() * sizeof(pf_photon)) != 0));

  EyePassOptions eo;
  eo.spp = 4;
  eo.threads = 1;
  EyePassResult h1 = trace_hitpoints(s, eo);
  eo.threads = 2;
  EyePassResult h2 = trace_hitpoints(s, eo);
  REQUIRE(h1.hitpoints.size() == h2.hitpoints.size());
  CHECK(test::same_hitpoints(h1.hitpoints, h2.hitpoints));
}

TEST_CASE("the caustic map holds only L S+ D paths", "[pipeline][caustic]") {
  PhotonPassOptions po;
  po.photons = 20000;
  SECTION("no specular surface: no caustic photons") {
    Scene s = test::room_scene(PF_MAT_DIFFUSE, 8, 8);
    PhotonPassResult r = trace_photons(s, 0, po);
    REQUIRE_FALSE(r.photons.empty());
    for (auto& p : r.photons) CHECK_FALSE(p.flags & PF_PHOTON_CAUSTIC);
  }
  SECTION("a mirror sphere makes caustic photons, never flagged direct") {
    Scene s = test::room_scene(PF_MAT_MIRROR, 8, 8);
    PhotonPassResult r = trace_photons(s, 0, po);
    size_t caustic = 0;
    for (auto& p : r.photons) {
      caustic += (p.flags & PF_PHOTON_CAUSTIC) != 0;
      CHECK_FALSE(((p.flags & PF_PHOTON_CAUSTIC) && (p.flags & PF_PHOTON_DIRECT)));
    }
    CHECK(caustic > 0);
  }
}

TEST_CASE("grid gather equals FLANN gather", "[pipeline][gather]") {
  Scene s = test::room_scene(PF_MAT_GLASS, 40, 30);
  EyePassOptions eo;
  eo.direct = DirectMode::ShadowRays;
  HitpointSet g = eye_state(s, eo), f = g;
  PhotonPassOptions po;
  po.photons = 20000;
  PpmOptions grid, flann;
  flann.method = GatherMethod::Flann;
  for (uint32_t pass = 0; pass < 3; ++pass) {
    PhotonPassResult r = trace_photons(s, pass, po);
    ppm_pass(s, g, r.photons, r.emitted, grid);
    ppm_pass(s, f, r.photons, r.emitted, flann);
  }
  REQUIRE(g.hitpoints.size() == f.hitpoints.size());
  const size_t gathered = test::gathered_hitpoints(g.hitpoints);
  CHECK(gathered > g.hitpoints.size() / 2);
  CHECK(test::same_hitpoints(g.hitpoints, f.hitpoints));
}

TEST_CASE("alpha = 1 keeps every radius, alpha < 1 shrinks radii where photons arrive",
          "[pipeline][ppm]") {
  Scene s = test::room_scene(PF_MAT_DIFFUSE, 16, 16);
  HitpointSet a = eye_state(s, EyePassOptions{}), b = a;
  PhotonPassOptions po;
  po.photons = 20000;
  PpmOptions keep, shrink;
  keep.alpha = 1.f;
  shrink.alpha = 0.5f;
  PhotonPassResult r = trace_photons(s, 0, po);
  ppm_pass(s, a, r.photons, r.emitted, keep);
  ppm_pass(s, b, r.photons, r.emitted, shrink);
  size_t shrunk = 0;
  for (size_t i = 0; i < a.hitpoints.size(); ++i) {
    CHECK(a.hitpoints[i].radius == a.radius0);
    CHECK(b.hitpoints[i].radius <= b.radius0);
    shrunk += b.hitpoints[i].radius < b.radius0;
  }
  CHECK(shrunk > 0);
  PpmOptions bad;
  bad.alpha = 1.5f;
  CHECK_THROWS_AS(ppm_pass(s, a, r.photons, r.emitted, bad), InputError);
}
