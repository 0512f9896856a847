// The environment light (geometry/environment.h, environment_shared.h): the sampling density
// integrates to one and matches a histogram of its samples (chi-square), the orientation of the
// map (Mitsuba 3's envmap convention, docs/SCENES.md) through the shared lookup, the light sampler
// and the path tracer, the power in the light CDF, and a furnace: a diffuse sphere inside a
// constant environment, whose photons and path-traced radiance match the analytic values.
#include <catch2/catch.hpp>

#include <cmath>
#include <functional>
#include <random>
#include <vector>

#include "chi2.h"
#include "support.h"
#include "photonflow/geometry/environment.h"
#include "photonflow/geometry/environment_shared.h"
#include "photonflow/geometry/procedural.h"
#include "photonflow/geometry/scene.h"
#include "photonflow/geometry/scene_file.h"
#include "photonflow/io/provenance.h"
#include "photonflow/io/validate.h"
#include "photonflow/stages/pathtrace.h"
#include "photonflow/stages/photon_pass.h"

using namespace pf;

namespace {

constexpr double kPi = 3.14159265358979323846;

// A w × w/2 map of radiance `sky` with texel (col, row) set to `sun`.
Environment map_with_texel(int w, float sky, int col, int row, float sun) {
  Environment e;
  e.width = w;
  e.height = w / 2;
  e.texels.assign(size_t(w) * size_t(w / 2) * 3, sky);
  for (int c = 0; c < 3; ++c) e.texels[3 * (size_t(row) * size_t(w) + size_t(col)) + size_t(c)] = sun;
  e.source = "test";
  return e;
}

// The world direction of map position (u, v) by the documented convention, in double:
// θ = πv, φ = 2πu, d = (sin θ sin φ, cos θ, −sin θ cos φ), turned by ρ about +y.
Vec3 convention_dir(double u, double v, double rot_deg = 0) {
  const double th = kPi * v, ph = 2 * kPi * u, r = rot_deg * kPi / 180;
  const double x = std::sin(th) * std::sin(ph), y = std::cos(th), z = -std::sin(th) * std::cos(ph);
  return Vec3(float(std::cos(r) * x + std::sin(r) * z), float(y), float(-std::sin(r) * x + std::cos(r) * z));
}

std::vector<float> packed(const Environment& e) {
  return pack_environment(e, Vec3(0, 0, 0), 1.f, 0, 1.f);
}

// A floor quad far below (a scene needs triangles) and the environment as the only light.
Scene env_scene(const Environment& e, const pf_camera& cam) {
  Scene s;
  s.triangles = make_box(Vec3(-1, -50, -1), Vec3(1, -49.9f, 1), false, {0, 0});
  s.mesh_names = {"floor"};
  pf_material m{};
  m.type = PF_MAT_DIFFUSE;
  m.ior = 1.f;
  for (float& c : m.color) c = 0.5f;
  s.materials = {m};
  s.material_names = {"floor"};
  s.environment = e;
  s.camera = cam;
  finish_scene(s);
  return s;
}

}  // namespace

TEST_CASE("environment: the sampling pdf integrates to one and matches its samples",
          "[environment]") {
  // A 24 × 12 map (texel edges on the chi-square grid's bin edges: 2 × 2 bins a texel) with a
  // gradient, a dark row and a sun 10^4 times the sky; the grid's z is the map's +y and its φ the
  // map's φ, so the density is smooth inside every bin.
  Environment e = map_with_texel(24, 0.2f, 17, 3, 2000.f);
  for (int j = 0; j < 12; ++j)
    for (int i = 0; i < 24; ++i)
      e.texels[3 * size_t(j * 24 + i)] += 0.05f * float(i);  // red gradient in u
  for (int i = 0; i < 24; ++i)
    for (int c = 0; c < 3; ++c) e.texels[3 * size_t(8 * 24 + i) + size_t(c)] = 0.f;  // a black row
  const std::vector<float> env = packed(e);
  auto to_grid = [](const float* d, float* g) { g[0] = -d[2]; g[1] = d[0]; g[2] = d[1]; };
  auto from_grid = [](const float* g, float* d) { d[0] = g[1]; d[1] = g[2]; d[2] = -g[0]; };
  const test::Chi2Result r = test::chi2_test(
      [&](float u1, float u2, float, float* g) {
        float d[3], le[3];
        if (!(pf_env_sample(env.data(), u1, u2, d, le) > 0.f)) return false;
        to_grid(d, g);
        return true;
      },
      [&](const float* g) {
        float d[3];
        from_grid(g, d);
        return double(pf_env_pdf(env.data(), d));
      },
      400000, 11);
  INFO(r.detail);
  CHECK(std::fabs(r.pdf_integral - 1.0) < 1e-3);
  CHECK(r.success > 0.999);
  CHECK(r.p > 0.01);
  // The sun's share of the samples is its share of luminance × sin θ.
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> uni(0.f, 1.f);
  int in_sun = 0;
  const int n = 100000;
  for (int k = 0; k < n; ++k) {
    float d[3], le[3];
    pf_env_sample(env.data(), uni(rng), uni(rng), d, le);
    in_sun += le[1] > 1000.f;
  }
  double sun = 0, all = 0;
  for (int j = 0; j < 12; ++j)
    for (int i = 0; i < 24; ++i) {
      const float* t = &e.texels[3 * size_t(j * 24 + i)];
      const double f = (0.2126 * t[0] + 0.7152 * t[1] + 0.0722 * t[2]) * std::sin(kPi * (j + 0.5) / 12);
      all += f;
      if (i == 17 && j == 3) sun = f;
    }
  CHECK(std::fabs(double(in_sun) / n - sun / all) < 0.01);
}

TEST_CASE("environment: the radiance estimate L/pdf of a sun map has no fireflies",
          "[environment]") {
  // L(ω)/pdf_ω of luminance sampling is bounded by (Σ f)·2π²/(W·H) · sin θ / sin θ_row and the
  // texels' colour: no sample is more than a few times the mean, the sun included.
  const Environment e = map_with_texel(64, 0.1f, 40, 10, 5e4f);
  const std::vector<float> env = packed(e);
  std::mt19937 rng(9);
  std::uniform_real_distribution<float> uni(0.f, 1.f);
  double sum = 0, worst = 0;
  const int n = 200000;
  for (int k = 0; k < n; ++k) {
    float d[3], le[3];
    const float pdf = pf_env_sample(env.data(), uni(rng), uni(rng), d, le);
    if (!(pdf > 0.f)) continue;
    const double v = double(le[1]) / pdf;
    sum += v;
    worst = std::max(worst, v);
  }
  const double mean = sum / n;
  CHECK(std::fabs(mean / environment_luminance_integral(e) - 1.0) < 0.01);  // ∫ L dω
  CHECK(worst < 4 * mean);
}

TEST_CASE("environment: one bright texel lights the direction the convention gives",
          "[environment]") {
  const int w = 64, h = 32;
  SECTION("named axes: the centre column looks along +z, a quarter along +x, the top row +y") {
    struct Case { int col, row; Vec3 dir; };
    for (const Case c : {Case{w / 2, h / 2, Vec3(0, 0, 1)}, Case{w / 4, h / 2, Vec3(1, 0, 0)},
                         Case{3 * w / 4, h / 2, Vec3(-1, 0, 0)}, Case{0, h / 2, Vec3(0, 0, -1)},
                         Case{5, 0, Vec3(0, 1, 0)}}) {
      const Environment e = map_with_texel(w, 0.01f, c.col, c.row, 100.f);
      const std::vector<float> env = packed(e);
      // The texel's corner (u, v) = (col/W, row/H) plus a little: the direction lies in it.
      const Vec3 d = normalize(c.dir + convention_dir((c.col + 0.5) / w, (c.row + 0.5) / h) * 1e-3f);
      const float fd[3] = {d.x, d.y, d.z};
      float le[3];
      pf_env_radiance(env.data(), fd, le);
      INFO("texel " << c.col << "," << c.row);
      CHECK(le[0] == 100.f);
    }
  }
  SECTION("the light sampler finds the texel's direction, also rotated about +y") {
    for (float rot : {0.f, 90.f, -30.f}) {
      Environment e = map_with_texel(w, 0.001f, 11, 9, 1e5f);
      e.rotation_deg = rot;
      pf_camera cam{{0, 0, 0}, {0, 0, 1}, {0, 1, 0}, 40.f, 4, 4};
      const Scene s = env_scene(e, cam);
      REQUIRE(s.lights.size() == 1);
      REQUIRE(s.lights[0].type == PF_LIGHT_ENVIRONMENT);
      const Vec3 want = convention_dir((11 + 0.5) / w, (9 + 0.5) / h, rot);
      std::mt19937 rng(3);
      std::uniform_real_distribution<float> uni(0.f, 1.f);
      int near = 0, bright = 0;
      for (int k = 0; k < 2000; ++k) {
        Scene::LightSample ls;
        if (!s.sample_light(uni(rng), uni(rng), uni(rng), Vec3(0, 0, 0), ls)) continue;
        if (ls.le.x < 1e4f) continue;
        ++bright;
        // within the texel: its half-diagonal is below 0.08 rad at this row
        near += dot(ls.w, want) > std::cos(0.08f);
        CHECK(length(ls.q) > 2.f * 50.f);  // the shadow ray ends beyond the bounding sphere
      }
      INFO("rotation " << rot);
      CHECK(bright > 1900);
      CHECK(near == bright);
      // and the lookup of that direction gives the texel back
      CHECK(s.environment_radiance(want).y == 1e5f);
    }
  }
  SECTION("the path tracer sees the texel where a camera looking that way points") {
    const Environment e = map_with_texel(w, 0.01f, w / 4, h / 2, 50.f);  // by +x, below the horizon
    // Camera at the origin looking at the texel's centre with a field of view of half a texel:
    // every pixel sees the bright texel; a camera looking the opposite way does not.
    const Vec3 at = convention_dir((w / 4 + 0.5) / w, (h / 2 + 0.5) / h);
    CHECK(at.x > 0.99f);
    const float fov = 0.5f * 360.f / w;
    pf_camera cam{{0, 0, 0}, {at.x, at.y, at.z}, {0, 1, 0}, fov, 3, 3};
    PathTraceOptions opt;
    opt.spp = 4;
    const Image plus = pathtrace(env_scene(e, cam), opt);
    for (int k = 0; k < 3; ++k) cam.look_at[k] = -cam.look_at[k];
    const Image minus = pathtrace(env_scene(e, cam), opt);
    CHECK(plus.get(0, 0).y == Approx(50.f));
    CHECK(plus.get(2, 2).y == Approx(50.f));
    CHECK(plus.get(1, 1).y == Approx(50.f));
    CHECK(minus.get(1, 1).y == Approx(0.01f));
  }
}

TEST_CASE("environment: its power joins the light CDF by flux", "[environment]") {
  // A constant map L = 2: ∫ L dω = 8π, flux π R² · 8π.
  Environment e;
  e = load_environment("2,2,2", 1.f, 0.f);
  REQUIRE(e.width == kConstantEnvironmentWidth);
  CHECK(environment_luminance_integral(e) == Approx(8 * kPi).epsilon(1e-6));
  pf_camera cam{{0, 0, 0}, {0, 0, 1}, {0, 1, 0}, 40.f, 4, 4};
  Scene s = env_scene(e, cam);
  const float r = 0.5f * length(s.bounds.hi - s.bounds.lo);
  CHECK(s.lights.back().power == Approx(kPi * r * r * 8 * kPi).epsilon(1e-5));
  CHECK(s.light_cdf.back() == 1.f);
  // the light-sampling pdf of a direction: pick probability (1 here) × pdf_ω ≈ 1/(4π)
  CHECK(s.environment_light_pdf(normalize(Vec3(0.3f, 0.4f, -0.2f))) ==
        Approx(1 / (4 * kPi)).epsilon(0.02));
  // Strength scales the radiance and the power.
  e.strength = 3.f;
  Scene s3 = env_scene(e, cam);
  CHECK(s3.lights.back().power == Approx(3 * s.lights.back().power).epsilon(1e-6));
  CHECK(s3.environment_radiance(Vec3(0, 1, 0)).x == 6.f);
}

TEST_CASE("environment: a diffuse sphere in a constant environment (furnace)", "[environment]") {
  // A convex diffuse sphere of albedo ρ inside a constant environment L sees the environment in
  // every direction of its hemisphere: irradiance E = π·L everywhere on it, radiance ρ·L leaving
  // it. The photons' first hits carry the flux E · 4πr² in expectation, spread evenly; the path
  // tracer's pixels on the sphere converge to ρ·L, those past it to L.
  const float L = 1.5f, rho = 0.6f, r = 0.5f;
  Scene s;
  s.triangles = make_sphere(Vec3(0, 0, 0), r, 4000, {0, 0});
  s.mesh_names = {"sphere"};
  pf_material m{};
  m.type = PF_MAT_DIFFUSE;
  m.ior = 1.f;
  for (float& c : m.color) c = rho;
  s.materials = {m};
  s.material_names = {"sphere"};
  s.environment = load_environment("1.5,1.5,1.5", 1.f, 0.f);
  s.camera = pf_camera{{0, 0, 3}, {0, 0, 0}, {0, 1, 0}, 30.f, 24, 24};
  finish_scene(s);
  REQUIRE(s.lights.size() == 1);

  SECTION("photons: the first hits' flux is E·A, top and bottom alike") {
    PhotonPassOptions opt;
    opt.photons = 400000;
    opt.seed = 4;
    const PhotonPassResult res = trace_photons(s, 0, opt);
    double top = 0, bottom = 0;
    for (const pf_photon& p : res.photons) {
      if (!(p.flags & PF_PHOTON_DIRECT)) continue;
      (p.position[1] > 0 ? top : bottom) += double(p.flux[1]);
    }
    // The sphere's triangles lie inside the sphere (chords): their area is a little below 4πr².
    double area = 0;
    for (const pf_triangle& t : s.triangles)
      area += 0.5 * double(length(cross(Vec3(t.v1) - Vec3(t.v0), Vec3(t.v2) - Vec3(t.v0))));
    const double want = kPi * L * area, got = (top + bottom) / double(res.emitted);
    INFO("flux of first hits " << got << ", E·A " << want);
    CHECK(std::fabs(got / want - 1.0) < 0.01);
    CHECK(std::fabs(top / bottom - 1.0) < 0.03);
  }
  SECTION("the path tracer: ρ·L on the sphere, L beside it, with MIS and without") {
    for (MisMode mis : {MisMode::Power, MisMode::Off}) {
      PathTraceOptions opt;
      opt.spp = 256;
      opt.mis = mis;
      const Image img = pathtrace(s, opt);
      double centre = 0;
      int n = 0;
      for (int y = 9; y < 15; ++y)
        for (int x = 9; x < 15; ++x, ++n) centre += img.get(x, y).y;
      INFO("MIS " << mis_mode_name(mis));
      CHECK(centre / n == Approx(rho * L).epsilon(0.03));
      CHECK(img.get(0, 0).y == Approx(L).epsilon(1e-6));
    }
  }
}

TEST_CASE("environment: scene.h5 keeps it and refuses a damaged one on read", "[environment]") {
  test::TempDir tmp("env-h5");
  Environment e = map_with_texel(32, 0.3f, 5, 4, 20.f);
  e.strength = 1.5f;
  e.rotation_deg = 12.f;
  pf_camera cam{{0, 0, 0}, {0, 0, 1}, {0, 1, 0}, 40.f, 4, 4};
  const Scene s = env_scene(e, cam);
  save_scene(s, tmp / "s.h5", Provenance{});
  const Scene r = load_scene(tmp / "s.h5");
  CHECK(r.environment.texels == s.environment.texels);
  CHECK(r.environment.rotation_deg == 12.f);
  CHECK(r.env_packed == s.env_packed);  // the tables rebuilt on read are the baker's
  CHECK(r.scene_id == s.scene_id);
  // An environment changes the id; a scene without one keeps the id it had.
  Scene plain = s;
  plain.environment = Environment();
  plain.compute_light_cdf();
  plain.compute_scene_id();
  CHECK(plain.scene_id != s.scene_id);
  const UncheckedWritesForTests unchecked;  // save_scene itself refuses these scenes
  struct Edit {
    const char* says;
    std::function<void(Scene&)> change;
  };
  for (const Edit& edit :
       {Edit{"NaN", [](Scene& d) { d.environment.texels[7] = std::nanf(""); }},
        Edit{"negative", [](Scene& d) { d.environment.texels[7] = -2.f; }},
        Edit{"strength", [](Scene& d) { d.environment.strength = 0.f; }},
        Edit{"map and the scene's bounds give", [](Scene& d) { d.lights.back().power *= 2.f; }},
        Edit{"lights", [](Scene& d) { d.environment = Environment(); }}}) {
    Scene d = s;
    edit.change(d);
    save_scene(d, tmp / "d.h5", Provenance{});
    INFO(edit.says);
    CHECK_THROWS_WITH(load_scene(tmp / "d.h5"), Catch::Contains(edit.says));
  }
}
