// Light transport of the photon and eye passes against closed-form answers, from mutation testing
// of photon_pass.cpp, eye_pass.cpp, illuminate.cpp and synthesize.cpp: each test names the wrong
// edits it catches ("Caught:"); most of them passed every other test, the rest were caught only
// indirectly (by an OpenCL comparison, which needs a device, or a loose image comparison).
//
// Scenes are a few flat quads and point lights, so every expected value follows from a formula:
// the power of an isotropic point light Φ = 4π·I, the irradiance of a plane under it
// E = I·h/d³, the Neumann series of a closed enclosure, the form factor of a square lamp. Statistical
// tolerances sit at five standard errors or more (estimated in the comments); the random numbers are
// counter-based, so a passing test passes on every run.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <set>
#include <vector>

#include "photonflow/geometry/camera.h"
#include "photonflow/stages/eye_pass.h"
#include "photonflow/stages/illuminate.h"
#include "photonflow/stages/photon_pass.h"
#include "photonflow/foundations/rng.h"
#include "photonflow/sampling/sampling.h"
#include "photonflow/io/stage_files.h"
#include "photonflow/stages/synthesize.h"
#include "support.h"

using namespace pf;
using test::quad;

namespace {

pf_material material(int type, const Vec3& color, float emission = 0.f, float ior = 1.f) {
  pf_material m{};
  m.type = type;
  m.ior = ior;
  for (int c = 0; c < 3; ++c) {
    m.color[c] = color[c];
    m.emission[c] = emission;
  }
  return m;
}

// Square of half side `s` centred on `c` in the plane spanned by unit vectors e1, e2; its front
// faces e1 × e2.
std::vector<pf_triangle> square(const Vec3& c, const Vec3& e1, const Vec3& e2, float s, int id) {
  return quad(c - e1 * s - e2 * s, c + e1 * s - e2 * s, c + e1 * s + e2 * s, c - e1 * s + e2 * s,
              id);
}

pf_light point_light(const Vec3& p, float intensity) {
  pf_light l{};
  l.type = PF_LIGHT_POINT;
  l.triangle = -1;
  p.store(l.position);
  for (int c = 0; c < 3; ++c) l.radiance[c] = intensity;
  return l;
}

// Irradiance of a plane point at `p` (unit normal n) from an isotropic point light (position q,
// intensity I): E = I cos θ / d² (0 behind the plane).
double point_irradiance(const Vec3& p, const Vec3& n, const Vec3& q, float intensity) {
  const Vec3 w = q - p;
  const double d2 = dot(w, w), c = dot(w, n) / std::sqrt(d2);
  return c > 0 ? intensity * c / d2 : 0.0;
}

// Closed box [-1, 1]³ seen from inside, walls diffuse with albedo rho and their fronts facing
// OUTWARD: every photon hits a back face (the case where the scattering code must turn the normal
// to the photon's side). Two point lights of unequal intensity inside.
Scene point_lights_in_box(float rho, float i1, float i2) {
  Scene s;
  s.triangles = make_box(Vec3(-1, -1, -1), Vec3(1, 1, 1), false, {0, 0});
  s.mesh_names = {"box"};
  s.materials = {material(PF_MAT_DIFFUSE, Vec3(rho, rho, rho))};
  s.material_names = {"walls"};
  s.lights = {point_light(Vec3(0.1f, 0.2f, -0.3f), i1), point_light(Vec3(-0.4f, -0.1f, 0.2f), i2)};
  s.camera = pf_camera{{0, 0, 0}, {0, 0, -1}, {0, 1, 0}, 60.f, 4, 4};
  finish_scene(s);
  return s;
}

// A scene of one diffuse mesh `name` (albedo rho) made of `tris`, lit by `lights`, seen by `cam`.
Scene diffuse_mesh(const std::string& name, std::vector<pf_triangle> tris, float rho,
                   std::vector<pf_light> lights, const pf_camera& cam) {
  Scene s;
  s.triangles = std::move(tris);
  s.mesh_names = {name};
  s.materials = {material(PF_MAT_DIFFUSE, Vec3(rho, rho, rho))};
  s.material_names = {name};
  s.lights = std::move(lights);
  s.camera = cam;
  finish_scene(s);
  return s;
}

// A diffuse plane z = −1 (6 × 6 wide, albedo 1/2) facing a W × H camera at the origin that looks
// straight at it: image positions map affinely onto the plane (camera.h).
Scene plane_facing_camera(int W, int H) {
  return diffuse_mesh("plane", square(Vec3(0, 0, -1), Vec3(1, 0, 0), Vec3(0, 1, 0), 3.f, 0), 0.5f,
                      {}, pf_camera{{0, 0, 0}, {0, 0, -1}, {0, 1, 0}, 50.f, W, H});
}

// A diffuse floor y = 0 (albedo rho, 8 × 8 wide), its front up or down, under a point light of
// intensity I at height h; the camera looks straight down from above. Nothing else: the light the
// camera sees is direct only, L = ρ/π · I h / d³, whichever side of the floor is its front.
Scene floor_under_point_light(bool front_up, float rho, float intensity, float h, int size) {
  return diffuse_mesh("floor", front_up ? square(Vec3(0, 0, 0), Vec3(0, 0, 1), Vec3(1, 0, 0), 4.f, 0)
                                : square(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 0, 1), 4.f, 0),
                       rho, {point_light(Vec3(0, h, 0), intensity)},
                       pf_camera{{0.f, 3.f, 0.f}, {0.f, 0.f, 0.f}, {0, 0, 1}, 40.f, size, size});
}

// Where the ray through pixel position (px, py) meets the floor y = 0.
Vec3 floor_point(const CameraFrame& cam, float px, float py) {
  const Vec3 d = cam.direction(px, py);
  return cam.eye() + d * (cam.eye().y / -d.y);
}

}  // namespace

// ---- photon pass ------------------------------------------------------------------------------

TEST_CASE("photon pass: point lights in a closed box: direct flux 4*pi*I, total /(1 - rho)",
          "[transport][photons]") {
  // Every photon leaves a point light and hits the box once, directly: the direct photons carry
  // the lights' whole power per emitted photon, Φ = 4π (I1 + I2) (an isotropic point light), exactly
  // — each photon's flux is 4π I_k / p_k with p_k = I_k / (I1 + I2) the chance to pick light k.
  // Diffuse bounces with Russian roulette by the albedo ρ keep the expected flux per stored photon,
  // so all stored photons carry Φ·Σ ρ^k = Φ / (1 − ρ) per emitted photon (the box is closed).
  // Caught: the point light's 4π written 2π; the pick probability left out; survival tested the
  // wrong way round (survive with 1 − ρ, weight 1/ρ: invisible at ρ = 0.5, the value the furnace
  // tests use); the diffuse bounce sampled around the unflipped normal (photons hitting a back face
  // leave the box: only Φ stored).
  const float rho = 0.8f, i1 = 2.f, i2 = 5.f;
  const double power = 4.0 * kPi * (i1 + i2);
  Scene s = point_lights_in_box(rho, i1, i2);
  REQUIRE(s.lights.size() == 2);
  PhotonPassOptions po;
  po.photons = 100000;
  po.max_bounces = 100;  // ρ^101 ≈ 2e-10 of the series is cut
  PhotonPassResult r = trace_photons(s, 0, po);
  REQUIRE(r.emitted == po.photons);
  double direct = 0, total = 0;
  size_t n_direct = 0;
  for (const pf_photon& p : r.photons) {
    total += p.flux[1];
    if (p.flags & PF_PHOTON_DIRECT) {
      direct += p.flux[1];
      ++n_direct;
    }
  }
  CHECK(n_direct == r.emitted);  // the box is closed: every photon arrives once directly
  CHECK(direct / double(r.emitted) == Approx(power).epsilon(1e-4));
  // Stored photons per path: geometric with mean 1/(1 − ρ) = 5 and sd sqrt(ρ)/(1 − ρ) ≈ 4.5, so
  // the mean over 1e5 paths has a relative standard error of 0.28%; tolerance 2% (7 SE).
  CHECK(total / double(r.emitted) == Approx(power / (1.0 - rho)).epsilon(0.02));
}

TEST_CASE("photon pass: max_bounces k stores exactly k + 1 photons per path in a white box",
          "[transport][photons]") {
  // Albedo 1: Russian roulette keeps every photon (survival max(albedo) = 1) at unchanged flux, and
  // the box is closed, so each path ends only at the bounce limit: the first hit plus k bounces,
  // k + 1 stored photons of flux Φ/N each (photon_pass.h: max_bounces counts the bounces after the
  // first hit). Caught: the bounce loop stopping one bounce early.
  Scene s = point_lights_in_box(1.f, 1.f, 3.f);
  for (int k : {1, 3}) {
    PhotonPassOptions po;
    po.photons = 5000;
    po.max_bounces = k;
    PhotonPassResult r = trace_photons(s, 0, po);
    INFO("max_bounces " << k);
    CHECK(r.photons.size() == size_t(k + 1) * r.emitted);
    size_t direct = 0;
    for (const pf_photon& p : r.photons) direct += (p.flags & PF_PHOTON_DIRECT) != 0;
    CHECK(direct == r.emitted);
  }
}

// ---- eye pass ---------------------------------------------------------------------------------

TEST_CASE("eye pass: emitters are one-sided, as the photons' emission", "[transport][eye]") {
  // A lamp quad fills the view; its radiance Le counts when the camera sees its front and is 0
  // from behind (area lights emit along their front normal only: photon_pass.cpp, the path tracer,
  // scene.cpp's power π·A·Le). Caught: the eye pass adding the emission of a lamp's back.
  const float le = 3.f;
  for (bool facing : {true, false}) {
    Scene s;
    s.triangles = facing ? square(Vec3(0, 0, -1), Vec3(1, 0, 0), Vec3(0, 1, 0), 2.f, 0)
                         : square(Vec3(0, 0, -1), Vec3(0, 1, 0), Vec3(1, 0, 0), 2.f, 0);
    s.mesh_names = {"lamp"};
    s.materials = {material(PF_MAT_EMITTER, Vec3(0, 0, 0), le)};
    s.material_names = {"lamp"};
    s.camera = pf_camera{{0, 0, 0}, {0, 0, -1}, {0, 1, 0}, 30.f, 3, 3};
    finish_scene(s);
    EyePassResult e = trace_hitpoints(s, EyePassOptions{});
    INFO((facing ? "lamp facing the camera" : "lamp's back towards the camera"));
    CHECK(e.hitpoints.empty());  // a black emitter is not diffuse: no hitpoint
    for (float v : e.emitted) CHECK(v == (facing ? le : 0.f));
  }
}

TEST_CASE("eye pass: max_depth specular bounces are followed, the hitpoint weight is their tint",
          "[transport][eye]") {
  // A periscope: the camera's central ray (along −z) meets mirror 1 (normal (0,1,1)/√2), goes up
  // (+y) to mirror 2 (normal (0,−1,1)/√2), then +z to a diffuse wall at z = 2 facing −z. Two
  // specular bounces: with max_depth = 2 the wall gets a hitpoint whose weight is the product of
  // the mirrors' reflectances (times the pixel filter weight 1/spp = 1); with max_depth = 1 the path
  // is dropped (eye_pass.h: max_depth counts specular bounces). Caught: the depth loop stopping
  // one bounce early; a mirror's reflectance not applied to the throughput.
  const Vec3 c1(0.5f, 0.8f, 1.f), c2(0.9f, 0.5f, 0.25f);
  Scene s;
  const float r2 = std::sqrt(0.5f);
  auto m1 = square(Vec3(0, 0, -1), Vec3(1, 0, 0), Vec3(0, r2, -r2), 0.3f, 0);  // front (0,1,1)/√2
  auto m2 = square(Vec3(0, 1, -1), Vec3(1, 0, 0), Vec3(0, r2, r2), 0.3f, 1);   // front (0,−1,1)/√2
  auto wall = square(Vec3(0, 1, 2), Vec3(0, 1, 0), Vec3(1, 0, 0), 1.f, 2);    // front −z
  for (auto* part : {&m1, &m2, &wall}) s.triangles.insert(s.triangles.end(), part->begin(), part->end());
  s.mesh_names = {"mirror1", "mirror2", "wall"};
  s.materials = {material(PF_MAT_MIRROR, c1), material(PF_MAT_MIRROR, c2),
                 material(PF_MAT_DIFFUSE, Vec3(0.5f, 0.5f, 0.5f))};
  s.material_names = {"mirror1", "mirror2", "wall"};
  s.camera = pf_camera{{0, 0, 0}, {0, 0, -1}, {0, 1, 0}, 5.f, 1, 1};
  finish_scene(s);
  EyePassOptions eo;
  eo.max_depth = 2;
  EyePassResult e = trace_hitpoints(s, eo);
  REQUIRE(e.hitpoints.size() == 1);
  const pf_hitpoint& hp = e.hitpoints[0];
  CHECK(hp.mesh == 2);
  CHECK(hp.position[0] == Approx(0.f).margin(1e-5));
  CHECK(hp.position[1] == Approx(1.f).margin(1e-5));
  CHECK(hp.position[2] == Approx(2.f).margin(1e-5));
  CHECK(hp.normal[2] == Approx(-1.f).margin(1e-6));  // facing the arriving ray
  CHECK(hp.dir[2] == Approx(1.f).margin(1e-6));
  for (int c = 0; c < 3; ++c) CHECK(hp.weight[c] == Approx(c1[c] * c2[c]).epsilon(1e-6));
  eo.max_depth = 1;
  CHECK(trace_hitpoints(s, eo).hitpoints.empty());
}

TEST_CASE("eye pass: spp samples of a pixel are stratified and independently jittered",
          "[transport][eye]") {
  // The camera looks straight at a plane at distance 1, where the image position (px, py) maps
  // affinely to the plane point (x, y) = (sx, sy) of camera.h, so each hitpoint gives back the
  // image position of its ray. With spp = 16 (4 × 4 strata) every pixel must have one sample in
  // each of its 16 cells, at independent uniform offsets within the cells. Caught: both jitter
  // coordinates taken from the same stratum index (s % 4); every sample of a pixel given the same
  // random numbers (the stream index without the sample number).
  const int W = 4, H = 3, spp = 16;
  const Scene s = plane_facing_camera(W, H);
  CameraFrame cam(s.camera);
  EyePassOptions eo;
  eo.spp = spp;
  EyePassResult e = trace_hitpoints(s, eo);
  REQUIRE(e.hitpoints.size() == size_t(W * H * spp));
  std::vector<std::set<int>> cells(size_t(W * H));
  std::set<std::pair<float, float>> offsets;
  double sum_fx = 0, sum_fy = 0;
  for (const pf_hitpoint& hp : e.hitpoints) {
    const float px = (hp.position[0] / cam.tan_half_x() + 1.f) * 0.5f * float(W);
    const float py = (1.f - hp.position[1] / cam.tan_half_y()) * 0.5f * float(H);
    const float u = (px - float(hp.pixel_x)) * 4.f, v = (py - float(hp.pixel_y)) * 4.f;
    REQUIRE(u >= -1e-3f);
    REQUIRE(v >= -1e-3f);
    REQUIRE(u < 4.f + 1e-3f);
    REQUIRE(v < 4.f + 1e-3f);
    const int cx = std::min(3, int(u)), cy = std::min(3, int(v));
    cells[size_t(hp.pixel_y * W + hp.pixel_x)].insert(cx + 4 * cy);
    offsets.insert({u - float(cx), v - float(cy)});
    sum_fx += u - float(cx);
    sum_fy += v - float(cy);
  }
  for (const auto& c : cells) CHECK(c.size() == size_t(spp));
  // Offsets within cells: all different, mean 1/2 (sd of the mean of 192 uniforms: 0.021).
  CHECK(offsets.size() == e.hitpoints.size());
  CHECK(sum_fx / double(e.hitpoints.size()) == Approx(0.5).margin(0.1));
  CHECK(sum_fy / double(e.hitpoints.size()) == Approx(0.5).margin(0.1));
}

TEST_CASE("eye pass: the samples of a pixel cover it uniformly for any spp (box filter)",
          "[transport][eye]") {
  // Each of a pixel's spp samples weighs 1/spp (the box filter of eye_pass.h), so the samples'
  // positions, taken together, must be uniform over the pixel whatever spp is, a perfect square
  // or not: mean offset (1/2, 1/2) and a quarter of them in each quadrant of the pixel. The camera
  // and plane are those of the test above; 24 × 24 pixels. Standard deviations for independent
  // uniform positions (stratification only lowers them): mean 0.289/sqrt(576·spp), quadrant share
  // 0.433/sqrt(576·spp); tolerance 5 of them. A strata × strata grid (strata = ⌈√spp⌉) filled
  // in order misses the last cells when spp is not a square: spp = 2 put both samples in the
  // pixel's upper half (mean v = 1/4), spp = 8 left its lower-right ninth empty.
  const int W = 24, H = 24;
  const Scene s = plane_facing_camera(W, H);
  CameraFrame cam(s.camera);
  for (int spp : {2, 3, 4, 5, 6, 8, 9, 12}) {
    EyePassOptions eo;
    eo.spp = spp;
    EyePassResult e = trace_hitpoints(s, eo);
    REQUIRE(e.hitpoints.size() == size_t(W * H * spp));
    double su = 0, sv = 0;
    double quadrant[4] = {0, 0, 0, 0};
    const double n = double(e.hitpoints.size());
    for (const pf_hitpoint& hp : e.hitpoints) {
      const double u = (hp.position[0] / cam.tan_half_x() + 1.0) * 0.5 * W - hp.pixel_x;
      const double v = (1.0 - hp.position[1] / cam.tan_half_y()) * 0.5 * H - hp.pixel_y;
      su += u / n;
      sv += v / n;
      quadrant[(u >= 0.5 ? 1 : 0) + (v >= 0.5 ? 2 : 0)] += 1.0 / n;
    }
    const double sd_mean = 0.289 / std::sqrt(n), sd_share = 0.433 / std::sqrt(n);
    INFO("spp " << spp << ": mean offset (" << su << ", " << sv << "), quadrants " << quadrant[0]
                << " " << quadrant[1] << " " << quadrant[2] << " " << quadrant[3]);
    CHECK(su == Approx(0.5).margin(5 * sd_mean));
    CHECK(sv == Approx(0.5).margin(5 * sd_mean));
    for (double q : quadrant) CHECK(q == Approx(0.25).margin(5 * sd_share));
  }
}

TEST_CASE("direct light: two point lights, L = rho/pi * sum I_k cos_k / d_k^2",
          "[transport][direct]") {
  // direct_light picks one light per sample with probability p_k ∝ its power (4π I_k) and weights
  // it by 1/p_k. Two lights of unequal intensity over a point on a floor:
  //   light 1 at (0, 1, 0), I = 2:        cos 1, d² = 1
  //   light 2 at (1, 2, 0.5), I = 5:      cos 2/√5.25, d² = 5.25.
  // Per sample the estimate is 7 or 1.164 (p = 2/7, 5/7): mean 2.831, sd 2.64, so 40,000 samples
  // have a relative standard error of 0.47%; tolerance 2.5%. Caught: the 1/p_k weight left out
  // (−59%); the point light's 1/d² written 1/d.
  const float rho = 0.6f;
  const Scene s = diffuse_mesh("floor", square(Vec3(0, 0, 0), Vec3(0, 0, 1), Vec3(1, 0, 0), 4.f, 0), rho,
                                {point_light(Vec3(0, 1, 0), 2.f), point_light(Vec3(1, 2, 0.5f), 5.f)},
                                pf_camera{{0, 3, 0}, {0, 0, 0}, {0, 0, 1}, 40.f, 4, 4});
  const Vec3 p(0, 0, 0), n(0, 1, 0);
  const double expected =
      rho / kPi * (point_irradiance(p, n, Vec3(0, 1, 0), 2.f) +
                   point_irradiance(p, n, Vec3(1, 2, 0.5f), 5.f));
  const Vec3 got = direct_light(s, p, n, n, s.materials[0], 40000, 1, 0, 0);
  INFO("direct " << got.x << ", expected " << expected);
  CHECK(got.x == Approx(expected).epsilon(0.025));
  CHECK(got.y == got.x);
  CHECK(got.z == got.x);
}

TEST_CASE("direct light: a square lamp above a point, L = rho Le F (form factor)",
          "[transport][direct]") {
  // A square Lambertian lamp of radiance Le and half side a, facing down, centred at height h
  // above a floor point. Its point-to-area form factor (four corner rectangles of the standard
  // formula, X = a/h) is F = (4/π)·X/√(1 + X²)·atan(X/√(1 + X²)), the irradiance E = π Le F and
  // the reflected radiance ρ/π·E = ρ Le F. Area sampling with shadow rays (one-sided emitter).
  // The estimator's relative sd per sample is below 1 here, so 40,000 samples give < 0.5%;
  // tolerance 2.5%. Caught: a missing cosine at the lamp or at the floor, a missing area factor,
  // the lamp's back counted, light arriving from below the floor counted.
  const float rho = 0.7f, le = 2.f, a = 0.5f, h = 1.f;
  for (bool facing_down : {true, false}) {
    Scene s;
    s.triangles = square(Vec3(0, 0, 0), Vec3(0, 0, 1), Vec3(1, 0, 0), 4.f, 0);
    auto lamp = facing_down ? square(Vec3(0, h, 0), Vec3(1, 0, 0), Vec3(0, 0, 1), a, 1)
                            : square(Vec3(0, h, 0), Vec3(0, 0, 1), Vec3(1, 0, 0), a, 1);
    s.triangles.insert(s.triangles.end(), lamp.begin(), lamp.end());
    s.mesh_names = {"floor", "lamp"};
    s.materials = {material(PF_MAT_DIFFUSE, Vec3(rho, rho, rho)),
                   material(PF_MAT_EMITTER, Vec3(0, 0, 0), le)};
    s.material_names = {"floor", "lamp"};
    s.camera = pf_camera{{0, 3, 0}, {0, 0, 0}, {0, 0, 1}, 40.f, 4, 4};
    finish_scene(s);
    REQUIRE(s.lights.size() == 2);
    const double X = a / h, q = X / std::sqrt(1.0 + X * X);
    const double F = 4.0 / M_PI * q * std::atan(q);
    const double expected = facing_down ? rho * le * F : 0.0;
    const Vec3 n(0, 1, 0);
    const Vec3 got = direct_light(s, Vec3(0, 0, 0), n, n, s.materials[0], 40000, 3, 0, 7);
    INFO((facing_down ? "lamp facing down" : "lamp facing up") << ": direct " << got.x
                                                               << ", expected " << expected);
    if (facing_down)
      CHECK(got.x == Approx(expected).epsilon(0.025));
    else
      CHECK(got.x == 0.f);
    // Seen from below the floor (normal −y, the lamp behind the surface): no light.
    const Vec3 down(0, -1, 0);
    CHECK(direct_light(s, Vec3(0, 0, 0), down, down, s.materials[0], 1000, 3, 0, 7).x == 0.f);
  }
}

// ---- PPM and classic estimates ----------------------------------------------------------------

TEST_CASE("PPM: a floor under a point light, seen from either side: L = rho I h / (pi d^3)",
          "[transport][ppm]") {
  // floor_under_point_light: only direct light reaches the camera, L(x) = ρ/π · I h / d³, and
  // hitpoints sit at the pixel centres (spp 1). Both sides of the floor must behave alike (the
  // eye pass turns the hitpoint's normal to the eye ray; photons arrive on that side).
  //  - shadow rays: the image is direct_light of one point light: deterministic, exact up to
  //    rounding; photons are all direct, so gathered none (they are left to the shadow rays);
  //  - photons: PPM over 6 passes of 100,000 photons with R0 = 0.06 (about 90 photons per
  //    hitpoint per pass where d ≈ 1, fewer towards the image corners). Measured spread of the
  //    pixels' relative errors: sd 9%, so the mean of the 256 independent pixels has a standard
  //    error of 0.6%; the radius bias (curvature of L over the disc) is about 0.3%. Tolerance 3%
  //    on the mean (5 SE), 50% on each pixel (5.5 sd; observed worst 33%).
  // Caught: the hitpoint normal stored unflipped (back side black); the point light's 4π written
  // 2π (half the photon power); the direct layer dropped from the image; the shadow-ray estimate
  // of a point light with 1/d instead of 1/d².
  const float rho = 0.8f, intensity = 5.f, h = 1.f;
  const int size = 16;
  for (bool front_up : {true, false}) {
    Scene s = floor_under_point_light(front_up, rho, intensity, h, size);
    CameraFrame cam(s.camera);
    std::vector<double> expected(size_t(size * size));
    double mean_expected = 0;
    for (int y = 0; y < size; ++y)
      for (int x = 0; x < size; ++x) {
        const Vec3 p = floor_point(cam, x + 0.5f, y + 0.5f);
        expected[size_t(y * size + x)] =
            rho / kPi * point_irradiance(p, Vec3(0, 1, 0), Vec3(0, h, 0), intensity);
        mean_expected += expected[size_t(y * size + x)] / (size * size);
      }
    for (DirectMode mode : {DirectMode::ShadowRays, DirectMode::Photons}) {
      EyePassOptions eo;
      eo.radius = 0.06f;
      eo.direct = mode;
      HitpointSet hs = make_hitpoint_set(trace_hitpoints(s, eo), mode, s.scene_id);
      REQUIRE(hs.hitpoints.size() == size_t(size * size));
      PhotonPassOptions po;
      po.photons = 100000;
      PpmOptions ppm;
      const uint32_t passes = mode == DirectMode::ShadowRays ? 2 : 6;
      for (uint32_t pass = 0; pass < passes; ++pass) {
        PhotonPassResult r = trace_photons(s, pass, po);
        ppm_pass(s, hs, r.photons, r.emitted, ppm);
      }
      const Image img = synthesize(hs);
      double mean = 0, worst = 0;
      for (int y = 0; y < size; ++y)
        for (int x = 0; x < size; ++x) {
          const double v = img.get(x, y).y, ex = expected[size_t(y * size + x)];
          mean += v / (size * size);
          worst = std::max(worst, std::fabs(v / ex - 1.0));
        }
      INFO((front_up ? "front up" : "front down")
           << ", " << direct_mode_name(mode) << ": mean " << mean << ", expected "
           << mean_expected << ", worst pixel " << worst);
      if (mode == DirectMode::ShadowRays) {
        CHECK(worst < 1e-4);
        CHECK(test::gathered_hitpoints(hs.hitpoints) == 0);
      } else {
        CHECK(mean == Approx(mean_expected).epsilon(0.03));
        CHECK(worst < 0.5);
      }
    }
  }
}

TEST_CASE("classic estimate: caustic photons are rescaled to the global radius (eq. 3.10)",
          "[transport][classic]") {
  // Synthetic photons on the unit square floor (every photon arriving from above): N_g global
  // photons of flux Φ_g and N_c caustic photons (flag CAUSTIC) of flux Φ_c, each set uniform, out of
  // N_e emitted. Irradiance E_g = N_g Φ_g / N_e (area 1), likewise E_c; a Lambertian floor of
  // albedo ρ reflects L = ρ/π (E_g + E_c) (eq. 3.10 summed over both maps). The global estimate
  // uses the k = 400 nearest photons (radius r_g ≈ 0.05 among 50,000), the caustic one a fixed
  // radius r_c = 0.1 (about 630 photons); classic_estimate stores r_g as the hitpoint radius and
  // rescales the caustic sum by r_g²/r_c² so that eq. 3.19 applies one radius to both. Noise per
  // hitpoint about 4%; 49 hitpoints 0.1 apart (discs barely overlap): about 0.6% on the mean;
  // tolerance 3%. Caught: the caustic sum not rescaled (L = ρ/π (E_g + 4 E_c) here).
  const float rho = 0.5f;
  const Scene s = diffuse_mesh("floor", square(Vec3(0.5f, 0, 0.5f), Vec3(0, 0, 1), Vec3(1, 0, 0), 0.5f, 0),
                                rho, {}, pf_camera{{0.5f, 2, 0.5f}, {0.5f, 0, 0.5f}, {0, 0, 1}, 40.f, 7, 7});
  const int n_g = 50000, n_c = 20000;
  const uint64_t n_e = 100000;
  const float phi_g = 3.f, phi_c = 6.f;
  std::vector<pf_photon> photons;
  for (int i = 0; i < n_g + n_c; ++i) {
    pf_photon p{};
    p.position[0] = pf_rng_float(5, 0, uint32_t(i), 0);
    p.position[2] = pf_rng_float(5, 0, uint32_t(i), 1);
    p.dir[1] = -1.f;
    const float phi = i < n_g ? phi_g : phi_c;
    for (int c = 0; c < 3; ++c) p.flux[c] = phi;
    p.flags = i < n_g ? 0 : PF_PHOTON_CAUSTIC;
    photons.push_back(p);
  }
  HitpointSet h;
  h.width = h.height = 7;
  h.emitted.assign(7 * 7 * 3, 0.f);
  h.direct.assign(7 * 7 * 3, 0.f);
  h.radius0 = 0.1f;
  h.scene_id = s.scene_id;
  for (int y = 0; y < 7; ++y)
    for (int x = 0; x < 7; ++x) {
      pf_hitpoint hp{};
      hp.position[0] = 0.2f + 0.1f * float(x);
      hp.position[2] = 0.2f + 0.1f * float(y);
      hp.normal[1] = 1.f;
      hp.dir[1] = -1.f;
      for (int c = 0; c < 3; ++c) hp.weight[c] = 1.f;
      hp.radius = h.radius0;
      hp.pixel_x = x;
      hp.pixel_y = y;
      h.hitpoints.push_back(hp);
    }
  ClassicOptions co;
  co.k = 400;
  co.caustic_radius = 0.1f;
  classic_estimate(s, h, photons, n_e, co);
  const double e_g = double(n_g) * phi_g / double(n_e), e_c = double(n_c) * phi_c / double(n_e);
  const double expected = rho / kPi * (e_g + e_c);
  const Image img = synthesize(h);
  double mean = 0, mean_r = 0;
  for (size_t i = 0; i < img.pixel_count(); ++i) mean += img.rgb[3 * i] / 49.0;
  for (const pf_hitpoint& hp : h.hitpoints) mean_r += hp.radius / 49.0;
  INFO("mean " << mean << ", expected " << expected << ", mean global radius " << mean_r);
  REQUIRE(mean_r < 0.07);  // the rescaling is exercised: r_g well below r_c
  CHECK(mean == Approx(expected).epsilon(0.03));
}

TEST_CASE("synthesis: a pixel adds its hitpoints' weighted eq. 3.19 radiance and averages the layers",
          "[transport][synthesize]") {
  // Two hitpoints in pixel (1, 0) of a 2 × 1 image, none in pixel (0, 0):
  //   A: weight (0.5, 0.25, 1), τ = (2π, 4π, π), R = 1, N = 10
  //   B: weight (0.5, 0.5, 0.5), τ = (8π, 8π, 8π), R = 2, N = 30
  // with N_emitted = 4 (eq. 3.19: L = τ / (π R² N_emitted)): L_A = (0.5, 1, 0.25), L_B = (0.5, 0.5,
  // 0.5), so the pixel is Σ weight·L + emitted + direct = (0.25 + 0.25, 0.25 + 0.25, 0.25 + 0.25)
  // + (0.1, 0.2, 0.3) + (0.01, 0.02, 0.03). The "radius" and "photons" layers are the means over the
  // pixel's hitpoints (1.5, 20), "hitpoints" their count; an empty pixel keeps 0 and its own
  // emitted + direct. Caught (without an OpenCL device): the layers summed instead of averaged.
  HitpointSet h;
  h.width = 2;
  h.height = 1;
  h.emitted = {0.f, 0.f, 0.f, 0.1f, 0.2f, 0.3f};
  h.direct = {0.5f, 0.f, 0.f, 0.01f, 0.02f, 0.03f};
  h.photons_emitted = 4;
  auto hitpoint = [](Vec3 w, Vec3 tau_over_pi, float r, float n) {
    pf_hitpoint hp{};
    w.store(hp.weight);
    (tau_over_pi * kPi).store(hp.flux);
    hp.radius = r;
    hp.n_photons = n;
    hp.pixel_x = 1;
    return hp;
  };
  h.hitpoints = {hitpoint(Vec3(0.5f, 0.25f, 1.f), Vec3(2, 4, 1), 1.f, 10.f),
                 hitpoint(Vec3(0.5f, 0.5f, 0.5f), Vec3(8, 8, 8), 2.f, 30.f)};
  const Image img = synthesize(h);
  const Vec3 p = img.get(1, 0);
  CHECK(p.x == Approx(0.5f + 0.1f + 0.01f));
  CHECK(p.y == Approx(0.5f + 0.2f + 0.02f));
  CHECK(p.z == Approx(0.5f + 0.3f + 0.03f));
  CHECK(img.get(0, 0).x == 0.5f);
  CHECK(img.layers.at("radius")[1] == Approx(1.5f));
  CHECK(img.layers.at("photons")[1] == Approx(20.f));
  CHECK(img.layers.at("hitpoints")[1] == 2.f);
  CHECK(img.layers.at("radius")[0] == 0.f);
  CHECK(img.layers.at("hitpoints")[0] == 0.f);
  // Before any photon pass (N_emitted = 0) only emitted + direct remain.
  h.photons_emitted = 0;
  CHECK(synthesize(h).get(1, 0).x == Approx(0.1f + 0.01f));
}
