// light_import_test.cpp — glTF's KHR_lights_punctual spot and directional lights and
// KHR_materials_emissive_strength (issue 32 item 4): the spec's falloff and its integral, photon
// emission and next-event estimation against analytic irradiance (within the noise each test
// derives), path tracing against SPPM and PPM, CPU against OpenCL (PoCL), import of each light
// type and of emissive strength from small glTF files (tests/data, make_punctual_gltf.py), the
// scene.h5 format (version 5, the id of area/point scenes unchanged, versions 1-4 read, checks on
// read) and the refusal of bad light values.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "h5edit.h"
#include "photonflow/opencl/cl_backend.h"
#include "photonflow/stages/eye_pass.h"
#include "photonflow/foundations/hash.h"
#include "photonflow/stages/illuminate.h"
#include "photonflow/geometry/light_shared.h"
#include "photonflow/material/pbr_scatter_shared.h"
#include "photonflow/stages/pathtrace.h"
#include "photonflow/stages/photon_pass.h"
#include "photonflow/geometry/procedural.h"
#include "photonflow/estimators/render_driver.h"
#include "photonflow/sampling/sampling.h"
#include "photonflow/geometry/scene_import.h"
#include "photonflow/stages/synthesize.h"
#include "photonflow/geometry/scene_file.h"
#include "photonflow/io/h5_types.h"
#include "support.h"
#include "support_cl.h"

using namespace pf;
using test::quad;
using test::TempDir;

namespace {

constexpr double kPiD = 3.14159265358979323846;

pf_material diffuse(float rho) {
  pf_material m{};
  m.type = PF_MAT_DIFFUSE;
  m.ior = 1.f;
  for (int c = 0; c < 3; ++c) m.color[c] = rho;
  return m;
}

pf_light spot_light(const Vec3& pos, const Vec3& dir, const Vec3& intensity, float inner,
                    float outer) {
  pf_light l{};
  l.type = PF_LIGHT_SPOT;
  l.triangle = -1;
  pos.store(l.position);
  normalize(dir).store(l.direction);
  intensity.store(l.radiance);
  l.cos_inner = std::cos(inner);
  l.cos_outer = std::cos(outer);
  return l;
}

pf_light directional_light(const Vec3& dir, const Vec3& irradiance) {
  pf_light l{};
  l.type = PF_LIGHT_DIRECTIONAL;
  l.triangle = -1;
  normalize(dir).store(l.direction);
  irradiance.store(l.radiance);
  return l;
}

pf_light point_light(const Vec3& pos, float intensity) {
  pf_light l{};
  l.type = PF_LIGHT_POINT;
  l.triangle = -1;
  pos.store(l.position);
  for (int c = 0; c < 3; ++c) l.radiance[c] = intensity;
  return l;
}

// A diffuse floor y = 0 (front up, half side `half`, albedo rho) plus `extra` triangles (mesh 1,
// material 0), lit by `lights`; a W × H camera looks down at it from above and the side.
Scene floor_scene(std::vector<pf_light> lights, float half = 4.f, float rho = 0.5f, int W = 8,
                  int H = 8, std::vector<pf_triangle> extra = {}) {
  Scene s;
  s.triangles = quad(Vec3(-half, 0, half), Vec3(half, 0, half), Vec3(half, 0, -half),
                     Vec3(-half, 0, -half), 0);
  s.triangles.insert(s.triangles.end(), extra.begin(), extra.end());
  s.mesh_names = {"floor"};
  if (!extra.empty()) s.mesh_names.push_back("box");
  s.materials = {diffuse(rho)};
  s.material_names = {"floor"};
  s.lights = std::move(lights);
  s.camera = pf_camera{{0, 3, 3}, {0, 0, 0}, {0, 1, 0}, 60.f, W, H, 0.f, 0.f};
  finish_scene(s);
  return s;
}

// The spec's falloff written out independently in double (KHR_lights_punctual, "Inner and Outer
// Cone Angles").
double spec_falloff(double cd, double cos_inner, double cos_outer) {
  const double scale = 1.0 / std::max(0.001, cos_inner - cos_outer);
  const double a = std::clamp(cd * scale - cos_outer * scale, 0.0, 1.0);
  return a * a;
}

// Irradiance at floor point (x, 0, z) (normal +y) from a spot of intensity I at height h pointing
// straight down: E = I·falloff(cos θ)·cos θ / d², cos θ = h/d.
double spot_floor_irradiance(double r, double h, double I, double ci, double co) {
  const double d2 = h * h + r * r, c = h / std::sqrt(d2);
  return I * spec_falloff(c, ci, co) * c / d2;
}

// Mean of spot_floor_irradiance over the annulus r0 <= r < r1 (midpoint rule, 4000 rings).
double annulus_mean(double r0, double r1, double h, double I, double ci, double co) {
  const int n = 4000;
  double s = 0;
  for (int i = 0; i < n; ++i) {
    const double r = r0 + (r1 - r0) * (i + 0.5) / n;
    s += spot_floor_irradiance(r, h, I, ci, co) * 2 * kPiD * r * (r1 - r0) / n;
  }
  return s / (kPiD * (r1 * r1 - r0 * r0));
}

// Photon flux density estimate over a region: mean of X_i = flux_i·[photon i lands in it] over
// the N emitted photons, divided by the region's area; its standard error from the sample
// variance of X (one photon per emitted photon is the first, DIRECT, hit).
struct Density {
  double sum = 0, sum2 = 0;
  void add(double x) {
    sum += x;
    sum2 += x * x;
  }
  double mean(uint64_t n, double area) const { return sum / double(n) / area; }
  double se(uint64_t n, double area) const {
    const double m = sum / double(n);
    return std::sqrt(std::max(0.0, sum2 / double(n) - m * m) / double(n)) / area;
  }
};

std::string read_text(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string replaced(std::string s, const std::string& from, const std::string& to) {
  const size_t at = s.find(from);
  REQUIRE(at != std::string::npos);
  return s.replace(at, from.size(), to);
}

std::string data_path(const std::string& name) { return test::source_dir() + "/tests/data/" + name; }

Scene bake(const std::string& path, BakeReport* report = nullptr) {
  BakeOptions o;
  o.input = path;
  BakeReport r;
  Scene s = bake_scene(o, r);
  if (report) *report = r;
  return s;
}

double lum(const float* c) { return 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]; }

}  // namespace

TEST_CASE("punctual lights: the spot falloff is the KHR_lights_punctual formula and its integral",
          "[lights][spot]") {
  struct Cone {
    float inner, outer;
  };
  for (const Cone c : {Cone{0.3f, 0.6f}, Cone{0.f, 0.785398f}, Cone{0.5f, 0.50001f},
                       Cone{0.f, 0.02f}, Cone{1.2f, 1.5707963f}}) {
    const float ci = std::cos(c.inner), co = std::max(0.f, std::cos(c.outer));
    INFO("inner " << c.inner << ", outer " << c.outer);
    // The float formula loses |cd·scale| ulps to cancellation (scale = 1000 for the narrowest
    // cones): allow 4 of them in the ramp a, 8 in a².
    const double scale = 1.0 / std::max(0.001, double(ci) - double(co));
    for (int i = 0; i <= 200; ++i) {
      const float cd = co - 0.01f + (1.01f - co) * float(i) / 200.f;
      CHECK(pf_spot_falloff(cd, ci, co) ==
            Approx(spec_falloff(cd, ci, co)).margin(8 * 1.2e-7 * (scale + 1)));
    }
    // Full intensity inside the inner cone, unless the cosines differ by less than the spec's
    // 0.001 clamp: then the ramp is 0.001 wide in cos θ and the axis gets min(1, (1 − cos_outer)/0.001)².
    if (double(ci) - double(co) >= 0.001)
      CHECK(pf_spot_falloff(1.f, ci, co) == 1.f);
    else
      CHECK(pf_spot_falloff(1.f, ci, co) ==
            Approx(std::pow(std::min(1.0, (1.0 - co) / 0.001), 2)).epsilon(1e-3));
    CHECK(pf_spot_falloff(co - 1e-3f, ci, co) == 0.f);
    CHECK(pf_spot_falloff(NAN, ci, co) == 0.f);
    // ∫ falloff over cos θ in [cos_outer, 1], against a fine midpoint sum of the spec formula.
    const int n = 200000;
    double sum = 0;
    for (int i = 0; i < n; ++i) sum += spec_falloff(co + (1.0 - co) * (i + 0.5) / n, ci, co);
    sum *= (1.0 - co) / n;
    CHECK(pf_spot_cone_integral(ci, co) == Approx(sum).epsilon(1e-5));
  }
}

TEST_CASE("punctual lights: a spot's photons on a floor follow the falloff (density vs analytic)",
          "[lights][spot][photons]") {
  // Spot at height h = 1 pointing down, intensity (8, 4, 2), cone 0.3 / 0.6 rad: the photons'
  // flux density in rings around the axis equals the mean of E(r) = I·falloff·cos θ/d² over each
  // ring within 4 standard errors (derived from the photons' own spread) + 0.2%; the total power
  // reaching the floor is 2π·I·∫ falloff. Caught: a falloff of 1 in the cone (the outer rings
  // 30–100% too bright), a 1/pdf factor of the sphere instead of the cone (×2/(1 − cos 0.6)).
  const double h = 1.0, I = 8.0, inner = 0.3, outer = 0.6;
  const Scene s = floor_scene({spot_light(Vec3(0, float(h), 0), Vec3(0, -1, 0), Vec3(8, 4, 2),
                                          float(inner), float(outer))});
  REQUIRE(s.lights.size() == 1);
  const pf_light& l = s.lights[0];
  const double ci = l.cos_inner, co = l.cos_outer;
  CHECK(l.power == Approx(2 * kPiD * lum(l.radiance) * pf_spot_cone_integral(l.cos_inner, l.cos_outer)).epsilon(1e-6));
  PhotonPassOptions opt;
  opt.photons = 400000;
  opt.seed = 11;
  opt.max_bounces = 1;
  const PhotonPassResult r = trace_photons(s, 0, opt);
  const int rings = 8;
  const double dr = 0.1;  // the cone reaches r = tan 0.6 = 0.684
  std::vector<Density> ring(rings);
  Density total;
  for (const pf_photon& p : r.photons) {
    if (!(p.flags & PF_PHOTON_DIRECT)) continue;
    CHECK(p.flux[1] == Approx(0.5 * p.flux[0]).epsilon(1e-6));
    const double rr = std::hypot(double(p.position[0]), double(p.position[2]));
    total.add(p.flux[0]);
    const int k = int(rr / dr);
    if (k < rings) ring[size_t(k)].add(p.flux[0]);
  }
  for (int k = 0; k < rings; ++k) {
    const double r0 = k * dr, r1 = (k + 1) * dr, area = kPiD * (r1 * r1 - r0 * r0);
    const double est = ring[size_t(k)].mean(r.emitted, area), se = ring[size_t(k)].se(r.emitted, area);
    const double expected = annulus_mean(r0, r1, h, I, ci, co);
    INFO("ring " << r0 << ".." << r1 << ": photons " << est << " +- " << se << ", analytic "
                 << expected);
    CHECK(std::fabs(est - expected) <= 4 * se + 2e-3 * expected);
  }
  const double power = 2 * kPiD * I * pf_spot_cone_integral(l.cos_inner, l.cos_outer);
  INFO("power on the floor " << total.mean(r.emitted, 1.0) << ", 2 pi I int falloff " << power);
  CHECK(std::fabs(total.mean(r.emitted, 1.0) - power) <= 4 * total.se(r.emitted, 1.0) + 1e-4 * power);
}

TEST_CASE("punctual lights: a spot's direct light by shadow rays follows the falloff",
          "[lights][spot][direct]") {
  // One delta light: every light sample gives the same value, so direct_light is exact up to
  // float rounding: ρ/π·E(r) at points across the cone edge, 0 outside it and below the floor.
  const float rho = 0.5f;
  const Scene s = floor_scene({spot_light(Vec3(0, 1, 0), Vec3(0, -1, 0), Vec3(8, 8, 8), 0.3f, 0.6f)},
                              4.f, rho);
  const pf_light& l = s.lights[0];
  const Vec3 n(0, 1, 0);
  for (double r : {0.0, 0.2, 0.3, 0.35, 0.45, 0.55, 0.65, 0.7, 1.5}) {
    const Vec3 p(float(r * 0.6), 0.f, float(r * 0.8));
    const double expected = rho / kPiD * spot_floor_irradiance(r, 1.0, 8.0, l.cos_inner, l.cos_outer);
    const Vec3 got = direct_light(s, p, n, n, s.materials[0], 4, 1, 0, 0);
    INFO("r " << r << ": direct " << got.x << ", analytic " << expected);
    CHECK(got.x == Approx(expected).epsilon(1e-4).margin(1e-9));  // float falloff in the ramp
  }
  const Vec3 down(0, -1, 0);
  CHECK(direct_light(s, Vec3(0, 0, 0), down, down, s.materials[0], 4, 1, 0, 0).x == 0.f);
}

TEST_CASE("punctual lights: a directional light's irradiance on a plane is E cos(theta)",
          "[lights][directional]") {
  // E = 3 travelling 30° from straight down. The disc of photons covers the bounding sphere of
  // the floor (R = half its diagonal), lies outside the bounds, and carries Φ = E·πR². The
  // photons' flux density over the central 4 × 4 square equals E cos θ within 4 standard errors
  // (from the photons' spread) + 0.2%; next-event estimation gives ρ/π·E cos θ exactly, 0 in an
  // occluder's shadow (displaced by h·tan θ) and 0 from below.
  const float rho = 0.5f, E = 3.f, theta = float(kPiD / 6);
  const Vec3 dir(std::sin(theta), -std::cos(theta), 0.f);
  // A small occluder quad at height 1 over x in [1.5, 2.5], z in [−0.5, 0.5] (facing down).
  const std::vector<pf_triangle> roof =
      quad(Vec3(1.5f, 1, -0.5f), Vec3(2.5f, 1, -0.5f), Vec3(2.5f, 1, 0.5f), Vec3(1.5f, 1, 0.5f), 1);
  const Scene s = floor_scene({directional_light(dir, Vec3(E, E, E))}, 4.f, rho, 8, 8, roof);
  REQUIRE(s.lights.size() == 1);
  const pf_light& l = s.lights[0];
  const double R = 0.5 * length(s.bounds.extent());
  CHECK(l.area == Approx(kPiD * R * R).epsilon(1e-6));
  CHECK(l.power == Approx(E * kPiD * R * R).epsilon(1e-5));
  const Vec3 c = s.bounds.center();
  CHECK(length(Vec3(l.position) - c) == Approx(kDirectionalDiscMargin * R).epsilon(1e-5));
  CHECK(dot(Vec3(l.position) - c, dir) < 0.f);  // against the light

  PhotonPassOptions opt;
  opt.photons = 300000;
  opt.seed = 5;
  opt.max_bounces = 1;
  const PhotonPassResult r = trace_photons(s, 0, opt);
  Density sq;
  size_t direct = 0;
  for (const pf_photon& p : r.photons) {
    if (!(p.flags & PF_PHOTON_DIRECT)) continue;
    ++direct;
    if (p.mesh == 0 && std::fabs(p.position[0]) < 2.f && std::fabs(p.position[2]) < 2.f)
      sq.add(p.flux[0]);
  }
  REQUIRE(direct > 1000);
  const double est = sq.mean(r.emitted, 16.0), se = sq.se(r.emitted, 16.0);
  const double expected = E * std::cos(theta);
  INFO("photons " << est << " +- " << se << ", E cos theta " << expected);
  CHECK(std::fabs(est - expected) <= 4 * se + 2e-3 * expected);
  CHECK(se < 0.01 * expected);  // the test can tell a 4% error

  const Vec3 n(0, 1, 0);
  for (const Vec3& p : {Vec3(0, 0, 0), Vec3(-3, 0, 2), Vec3(3.5f, 0, -3.5f)}) {
    const Vec3 got = direct_light(s, p, n, n, s.materials[0], 2, 1, 0, 0);
    INFO("point " << p.x << "," << p.z << ": " << got.x);
    CHECK(got.x == Approx(rho / kPiD * expected).epsilon(1e-5));
  }
  // The occluder's shadow on the floor: its centre (2, 1, 0) projected along the light.
  const Vec3 shadow(2.f + std::tan(theta), 0.f, 0.f);
  CHECK(direct_light(s, shadow, n, n, s.materials[0], 2, 1, 0, 0).x == 0.f);
  const Vec3 down(0, -1, 0);
  CHECK(direct_light(s, Vec3(0, 0, 0), down, down, s.materials[0], 2, 1, 0, 0).x == 0.f);
}

TEST_CASE("punctual lights: next-event estimation at a glossy (PBR) point follows the spot's falloff "
          "and the directional light's cosine",
          "[lights][spot][directional][direct][pbr]") {
  // direct_light_pbr (and the path tracer's and the kernels' PBR next-event estimation, which
  // share Scene::light_incident / pf_light_incident) must sample spot and directional lights as
  // lights of their own type, not as point lights at their position. One delta light: exact up to
  // float rounding, against f(wo, w)·I·falloff·cos θ/d² (spot) and f·E·cos θ (directional) with
  // the falloff written out in double and f from pf_pbr_eval_world; 0 outside the spot's cone
  // (a point light there would give I·cos θ/d² > 0).
  const pf_bsdf_params metal{{0.9f, 0.7f, 0.3f}, 1.f, 0.5f, 0.f, 1.5f};
  const Vec3 n(0, 1, 0);
  float fn[3];
  n.store(fn);
  const Vec3 eye(0.3f, 2.f, 1.5f);
  const auto f_of = [&](const Vec3& p, const Vec3& w) {
    float o[3], wi[3], f[3];
    normalize(eye - p).store(o);
    w.store(wi);
    pf_pbr_eval_world(&metal, fn, fn, o, wi, f);
    return double(f[0]);
  };
  {
    const Scene s = floor_scene({spot_light(Vec3(0, 1, 0), Vec3(0, -1, 0), Vec3(8, 8, 8), 0.3f, 0.6f)});
    const pf_light& l = s.lights[0];
    for (double r : {0.0, 0.2, 0.35, 0.45, 0.55, 0.65, 0.7, 1.5}) {
      const Vec3 p(float(r * 0.6), 0.f, float(r * 0.8));
      const Vec3 w = normalize(Vec3(0, 1, 0) - p);
      const double expected =
          f_of(p, w) * spot_floor_irradiance(r, 1.0, 8.0, l.cos_inner, l.cos_outer);
      const Vec3 got = direct_light_pbr(s, p, n, n, metal, normalize(eye - p), 4, 1, 0, 0);
      INFO("spot, r " << r << ": direct " << got.x << ", analytic " << expected);
      CHECK(got.x == Approx(expected).epsilon(1e-4).margin(1e-9));
      if (r >= 0.7) CHECK(got.x == 0.f);  // outside the outer cone (tan 0.6 = 0.684 at h = 1)
    }
  }
  {
    const float E = 3.f, theta = float(kPiD / 6);
    const Vec3 dir(std::sin(theta), -std::cos(theta), 0.f);
    const Scene s = floor_scene({directional_light(dir, Vec3(E, E, E))});
    for (const Vec3& p : {Vec3(0, 0, 0), Vec3(-3, 0, 2), Vec3(3.5f, 0, -3.5f)}) {
      const double expected = f_of(p, -dir) * E * std::cos(theta);
      const Vec3 got = direct_light_pbr(s, p, n, n, metal, normalize(eye - p), 2, 1, 0, 0);
      INFO("directional, point " << p.x << "," << p.z << ": " << got.x << ", analytic " << expected);
      REQUIRE(expected > 0.01);
      CHECK(got.x == Approx(expected).epsilon(1e-5));
    }
  }
}

namespace {

// A floor with a box on it, lit by a spot, a directional light and a point light.

double block_luminance(const Image& img, int x0, int y0, int x1, int y1) {
  double s = 0;
  for (int y = y0; y < y1; ++y)
    for (int x = x0; x < x1; ++x) s += luminance(img.get(x, y));
  return s / double((x1 - x0) * (y1 - y0));
}

// With `floor_material` the floor (material 0) gets it instead of the diffuse 0.6.
Scene mixed_scene(int W, int H, const pf_material* floor_material = nullptr) {
  std::vector<pf_triangle> box = make_box(Vec3(-0.4f, 0, -0.4f), Vec3(0.4f, 0.6f, 0.4f), false, {1, 0});
  Scene s = floor_scene(
      {spot_light(Vec3(-1.f, 2.f, 0.5f), Vec3(0.5f, -1, -0.2f), Vec3(6, 5, 4), 0.25f, 0.5f),
       directional_light(Vec3(0.4f, -1, 0.3f), Vec3(0.3f, 0.35f, 0.4f)),
       point_light(Vec3(1.2f, 1.5f, 1.f), 0.8f)},
      2.f, 0.6f, W, H, box);
  if (floor_material) {
    s.materials[0] = *floor_material;
    finish_scene(s);
  }
  return s;
}

// SPPM as the agreement tests below run it: 64 passes of 50,000 photons, Sobol pixel samples,
// R0 0.05 (the automatic R0, 4 pixel footprints, is 0.7 here and blurs the floor's edge).
RenderOptions agreement_options() {
  RenderOptions o;
  o.estimator = Estimator::Sppm;
  o.passes = 64;
  o.photons.photons = 50000;
  o.eye.sampler = PixelSampler::Sobol;
  o.eye.radius = 0.05f;
  return o;
}

// Checks that `img` agrees with the path-traced `ref`: image means within `mean_tol`, every 8×8
// block within `block_tol` (relative, luminance).
void check_agrees(const char* name, const Image& ref, const Image& img, double mean_tol,
                  double block_tol) {
  const int W = ref.width, H = ref.height;
  const double m_pt = block_luminance(ref, 0, 0, W, H);
  REQUIRE(m_pt > 0.01);
  const double m = block_luminance(img, 0, 0, W, H);
  double worst = 0;
  for (int by = 0; by < H; by += 8)
    for (int bx = 0; bx < W; bx += 8) {
      const double a = block_luminance(ref, bx, by, bx + 8, by + 8);
      const double b = block_luminance(img, bx, by, bx + 8, by + 8);
      worst = std::max(worst, std::fabs(b / a - 1.0));
      UNSCOPED_INFO(name << " block " << bx << "," << by << ": PT " << a << ", " << b);
    }
  INFO(name << ": image mean PT " << m_pt << ", " << name << " " << m << ", worst 8x8 block "
            << worst);
  CHECK(std::fabs(m / m_pt - 1.0) < mean_tol);
  CHECK(worst < block_tol);
}

}  // namespace

TEST_CASE("punctual lights: path tracing, SPPM, PPPM, PPM and classic PM agree on a spot and a directional light",
          "[lights][pathtrace][sppm][ppm]") {
  // A floor with a box lit by a spot, a directional and a point light (delta lights: the path
  // tracer's next-event estimation is their only strategy; SPPM sees them through photons only,
  // PPM, PPPM and classic photon mapping with shadow rays through the eye pass's direct light).
  // Image means within 2%, 8×8 blocks within 10% (the photon estimators' finite radius blurs the
  // spot's edge, the floor's edge and the box's shadows, and the dim far floor is noisy; observed
  // with these settings: means within 0.9%, blocks within 6%). A falloff of 1 in the cone brightens
  // the spot's blocks by over 30%, a wrong disc area or cone pdf moves the mean by far more than 2%
  // (checked: a 0.8 disc-area factor puts SPPM 9% low, a block 20%).
  const int W = 32, H = 24;
  const Scene s = mixed_scene(W, H);
  REQUIRE(s.lights.size() == 3);
  PathTraceOptions pt;
  pt.spp = 1024;
  const Image ref = pathtrace(s, pt);

  const RenderOptions o = agreement_options();
  const Image sppm = synthesize(render_progressive(s, o, false, Provenance{}));

  EyePassOptions eo;
  eo.spp = 64;  // the direct light picks one of three lights per shadow sample: noise
  eo.radius = 0.03f;
  eo.direct = DirectMode::ShadowRays;
  HitpointSet hp = make_hitpoint_set(trace_hitpoints(s, eo), eo.direct, s.scene_id);
  PhotonPassOptions po;
  po.photons = 100000;
  PpmOptions ppm;
  for (uint32_t pass = 0; pass < 8; ++pass) {
    const PhotonPassResult r = trace_photons(s, pass, po);
    ppm_pass(s, hp, r.photons, r.emitted, ppm);
  }
  const Image ppm_img = synthesize(hp);

  RenderOptions pp = o;  // PPPM with shadow rays: the direct light of every eye pass by NEE
  pp.estimator = Estimator::Pppm;
  pp.passes = 32;
  pp.eye.direct = DirectMode::ShadowRays;
  const Image pppm = synthesize(render_pppm(s, pp, false, Provenance{}));

  // Classic photon mapping: one map of 400,000 photons, k nearest, shadow rays for direct light.
  HitpointSet cl = make_hitpoint_set(trace_hitpoints(s, eo), eo.direct, s.scene_id);
  PhotonPassOptions big;
  big.photons = 400000;
  const PhotonPassResult map = trace_photons(s, 0, big);
  classic_estimate(s, cl, map.photons, map.emitted, ClassicOptions{});
  const Image classic = synthesize(cl);

  for (const auto& [name, img] : {std::pair<const char*, const Image*>{"sppm", &sppm},
                                  std::pair<const char*, const Image*>{"ppm", &ppm_img},
                                  std::pair<const char*, const Image*>{"pppm", &pppm},
                                  std::pair<const char*, const Image*>{"classic", &classic}})
    check_agrees(name, ref, *img, 0.02, 0.10);
}

TEST_CASE("punctual lights: path tracing, SPPM and PPPM agree on a glossy floor under a spot and a "
          "directional light",
          "[lights][pathtrace][sppm][pbr]") {
  // The scene above with a rough metal floor (PF_MAT_PBR): the path tracer's next-event
  // estimation at PBR vertices and PPPM's shadow rays at PBR visible points (direct_light_pbr)
  // sample the spot and the directional light by their own type; SPPM's direct light comes from
  // photons, emitted by pf_punctual_emit, so the three meet only if next-event estimation at PBR
  // points is right (sampling the spot as a point light at its position, as before this test,
  // lights the floor outside its cone; the exact per-point check is the test above).
  const int W = 32, H = 24;
  pf_material metal{};
  metal.type = PF_MAT_PBR;
  metal.ior = 1.5f;
  metal.color[0] = 0.9f;
  metal.color[1] = 0.75f;
  metal.color[2] = 0.4f;
  metal.metallic = 1.f;
  metal.roughness = 0.5f;
  const Scene s = mixed_scene(W, H, &metal);
  REQUIRE(s.materials[0].type == PF_MAT_PBR);
  PathTraceOptions pt;
  pt.spp = 1024;
  const Image ref = pathtrace(s, pt);

  RenderOptions o = agreement_options();
  o.eye.direct = DirectMode::Photons;
  const Image sppm = synthesize(render_progressive(s, o, false, Provenance{}));
  RenderOptions pp = o;
  pp.estimator = Estimator::Pppm;
  pp.passes = 32;
  pp.eye.direct = DirectMode::ShadowRays;
  const Image pppm = synthesize(render_pppm(s, pp, false, Provenance{}));
  check_agrees("sppm", ref, sppm, 0.03, 0.12);
  check_agrees("pppm", ref, pppm, 0.03, 0.12);
  // Eye paths that share the metal floor's light with their continuation (GlossyMerge::Mis):
  // the floor's reflection of the delta lights comes from next-event estimation at the glossy
  // vertex (a BSDF sample never hits them; without it the spot's highlight is lost), the rest
  // from the gather there and the visible points beyond it.
  RenderOptions through = o;
  through.eye.direct = DirectMode::ShadowRays;
  through.eye.glossy = GlossyMerge::Mis;
  const Image img = synthesize(render_progressive(s, through, false, Provenance{}));
  check_agrees("sppm through glossy, shadow rays", ref, img, 0.03, 0.12);
}

TEST_CASE("punctual lights: OpenCL photons and direct light equal the CPU's", "[lights][opencl]") {
  auto dev = test::test_device();
  if (!dev) return;
  const Scene s = mixed_scene(48, 32);
  PhotonPassOptions opt;
  opt.photons = 20000;
  opt.seed = 9;
  const PhotonPassResult cpu = trace_photons(s, 1, opt);
  const PhotonPassResult gpu = trace_photons(s, 1, opt, *dev);
  CHECK(gpu.emitted == cpu.emitted);
  REQUIRE(cpu.photons.size() > 5000);  // most of the directional light's disc misses the floor
  // Same order (photon index, bounce); a path may diverge where rounding flips a Russian-roulette
  // choice and store another number of photons, so the sequences are aligned greedily with a
  // small look-ahead (as cl_backend_test.cpp does); 99% of the photons must agree.
  auto same = [](const pf_photon& a, const pf_photon& b) {
    bool eq = a.mesh == b.mesh && a.flags == b.flags;
    for (int c = 0; c < 3; ++c)
      eq = eq && std::fabs(a.position[c] - b.position[c]) <= 1e-4f &&
           std::fabs(a.flux[c] - b.flux[c]) <= 1e-4f * std::fabs(a.flux[c]) + 1e-7f;
    return eq;
  };
  size_t matched = 0, i = 0, j = 0;
  const std::vector<pf_photon>&a = cpu.photons, &b = gpu.photons;
  while (i < a.size() && j < b.size()) {
    if (same(a[i], b[j])) {
      ++matched, ++i, ++j;
      continue;
    }
    bool found = false;
    for (size_t k = 1; k < 32 && !found; ++k)
      for (size_t di = 0; di <= k && !found; ++di)
        if (i + di < a.size() && j + k - di < b.size() && same(a[i + di], b[j + k - di])) {
          i += di;
          j += k - di;
          found = true;
        }
    if (!found) ++i, ++j;
  }
  INFO("photons agreeing: " << matched << " of " << a.size() << " (opencl " << b.size() << ")");
  CHECK(double(matched) >= 0.99 * double(std::max(a.size(), b.size())));
  size_t types[4] = {0, 0, 0, 0};
  // Every light emitted: the photons' first hits came from all three lights' directions.
  for (const pf_light& l : s.lights) ++types[l.type];
  CHECK(types[PF_LIGHT_SPOT] == 1);
  CHECK(types[PF_LIGHT_DIRECTIONAL] == 1);

  EyePassOptions eo;
  eo.spp = 2;
  eo.direct = DirectMode::ShadowRays;
  eo.shadow_samples = 4;
  eo.seed = 3;
  const EyePassResult ce = trace_hitpoints(s, eo);
  const EyePassResult ge = trace_hitpoints(s, eo, *dev);
  REQUIRE(test::sum_squares(ce.direct) > 0);
  const double direct_diff = test::relative_rmse(ge.direct, ce.direct);
  INFO("direct light: relative RMS difference " << direct_diff);
  CHECK(direct_diff <= 1e-4);
}

TEST_CASE("punctual lights: import of a glTF spot, directional light and emissive strength",
          "[lights][import]") {
  SECTION("spot: position, axis, cone, intensity 1:1, range ignored with a warning") {
    BakeReport rep;
    const Scene s = bake(data_path("spot.gltf"), &rep);
    REQUIRE(s.lights.size() == 1);
    const pf_light& l = s.lights[0];
    CHECK(l.type == PF_LIGHT_SPOT);
    CHECK(l.triangle == -1);
    CHECK(Vec3(l.position).x == Approx(0).margin(1e-6));
    CHECK(Vec3(l.position).y == Approx(2).margin(1e-6));
    CHECK(Vec3(l.direction).y == Approx(-1).margin(1e-6));
    CHECK(std::fabs(l.direction[0]) < 1e-6f);
    CHECK(std::fabs(l.direction[2]) < 1e-6f);
    CHECK(l.radiance[0] == 10.f);  // color × intensity (candela taken as W/sr)
    CHECK(l.radiance[1] == 5.f);
    CHECK(l.radiance[2] == 2.5f);
    CHECK(l.cos_inner == Approx(std::cos(0.3)).epsilon(1e-6));
    CHECK(l.cos_outer == Approx(std::cos(0.6)).epsilon(1e-6));
    CHECK(l.power == Approx(2 * kPiD * lum(l.radiance) * pf_spot_cone_integral(l.cos_inner, l.cos_outer))
                         .epsilon(1e-6));
    bool range_warned = false;
    for (const std::string& w : rep.warnings) range_warned |= w.find("range ignored") != std::string::npos;
    CHECK(range_warned);
  }
  SECTION("directional: direction from the node's rotation, irradiance 1:1, disc over the bounds") {
    const Scene s = bake(data_path("directional.gltf"));
    REQUIRE(s.lights.size() == 1);
    const pf_light& l = s.lights[0];
    CHECK(l.type == PF_LIGHT_DIRECTIONAL);
    CHECK(l.direction[0] == Approx(0.5).margin(1e-5));
    CHECK(l.direction[1] == Approx(-std::sqrt(0.75)).margin(1e-5));
    CHECK(l.direction[2] == Approx(0).margin(1e-5));
    CHECK(l.radiance[0] == 3.f);
    const double R = 0.5 * length(s.bounds.extent());  // 10√2
    CHECK(R == Approx(10 * std::sqrt(2.0)).epsilon(1e-6));
    CHECK(l.area == Approx(kPiD * R * R).epsilon(1e-6));
    CHECK(l.power == Approx(3 * kPiD * R * R).epsilon(1e-5));
  }
  SECTION("KHR_materials_emissive_strength multiplies the emissive factor: power kept") {
    const Scene plain = bake(data_path("lamp.gltf"));
    const Scene strong = bake(data_path("emissive_strength.gltf"));
    REQUIRE(plain.materials.size() == strong.materials.size());
    int lamp = -1;
    for (size_t m = 0; m < strong.material_names.size(); ++m)
      if (strong.material_names[m] == "lamp") lamp = int(m);
    REQUIRE(lamp >= 0);
    const pf_material& e = strong.materials[size_t(lamp)];
    CHECK(e.type == PF_MAT_EMITTER);
    CHECK(e.emission[0] == 4.f);
    CHECK(e.emission[1] == 2.f);
    CHECK(e.emission[2] == 1.f);
    double p0 = 0, p1 = 0;
    for (const pf_light& l : plain.lights) p0 += l.power;
    for (const pf_light& l : strong.lights) p1 += l.power;
    CHECK(p0 > 0);
    CHECK(p1 == Approx(4 * p0).epsilon(1e-6));
    // The same strength in a binary glTF (.glb: the JSON chunk, then the BIN chunk).
    const Scene binary = bake(data_path("emissive_strength.glb"));
    double p2 = 0;
    for (const pf_light& l : binary.lights) p2 += l.power;
    CHECK(p2 == Approx(p1).epsilon(1e-6));
  }
}

TEST_CASE("punctual lights: bad light values are refused with one line, exit 2",
          "[lights][import][tools]") {
  TempDir tmp("lights-bad");
  const std::string spot = read_text(data_path("spot.gltf"));
  const std::string lamp = read_text(data_path("emissive_strength.gltf"));
  struct Case {
    const char* name;
    std::string text;
    const char* needle;
  };
  const std::vector<Case> cases = {
      {"inf-intensity.gltf", replaced(spot, "\"intensity\": 10", "\"intensity\": 1e39"),
       "non-finite"},
      {"negative.gltf", replaced(spot, "\"intensity\": 10", "\"intensity\": -2"), "negative"},
      // assimp's ValidateDataStructure refuses inner > outer itself (its own line), photonflow
      // inner == outer and outer > π/2.
      {"outer-below-inner.gltf", replaced(spot, "\"innerConeAngle\": 0.3", "\"innerConeAngle\": 0.7"),
       "Cone"},
      {"outer-equals-inner.gltf", replaced(spot, "\"innerConeAngle\": 0.3", "\"innerConeAngle\": 0.6"),
       "outerConeAngle"},
      {"outer-too-wide.gltf", replaced(spot, "\"outerConeAngle\": 0.6", "\"outerConeAngle\": 2.0"),
       "pi/2"},
      {"negative-strength.gltf", replaced(lamp, "\"emissiveStrength\": 4", "\"emissiveStrength\": -1"),
       "emissiveStrength"},
      {"text-strength.gltf", replaced(lamp, "\"emissiveStrength\": 4", "\"emissiveStrength\": \"x\""),
       "emissiveStrength"},
  };
  for (const Case& c : cases) {
    const std::string in = tmp / c.name, out = tmp / "scene.h5";
    std::ofstream(in) << c.text;
    const test::ToolRun r = test::run_tool("scene-bake", "'" + in + "' -o '" + out + "'", tmp);
    INFO(c.name << ": " << r.err);
    CHECK(r.exit_code == 2);
    CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
    CHECK(r.err.find(c.name) != std::string::npos);
    CHECK(r.err.find(c.needle) != std::string::npos);
    CHECK_FALSE(std::filesystem::exists(out));
  }
}

TEST_CASE("punctual lights: scene.h5 version 5 keeps spot and directional lights, checks them on "
          "read, and keeps the id of area and point scenes",
          "[lights][formats]") {
  TempDir tmp("lights-h5");
  const Scene s = mixed_scene(8, 8);
  const std::string path = tmp / "scene.h5";
  save_scene(s, path, Provenance{});
  const Scene r = load_scene(path);
  REQUIRE(r.lights.size() == s.lights.size());
  CHECK(std::memcmp(r.lights.data(), s.lights.data(), s.lights.size() * sizeof(pf_light)) == 0);
  CHECK(r.light_cdf == s.light_cdf);
  CHECK(r.scene_id == s.scene_id);
  CHECK(kSceneFormatVersion == 6);  // 6 added the environment, not written without one

  SECTION("the id of a scene of area and point lights is the one format version 4 gave") {
    Scene a = floor_scene({point_light(Vec3(0, 1, 0), 2.f)});
    // SHA-256 as version 4 computed it: triangles, materials, the 40-byte lights, pinhole camera.
    Sha256 h;
    auto feed = [&h](const void* p, uint64_t n, size_t size) {
      h.update(&n, sizeof n);
      if (n) h.update(p, n * size);
    };
    feed(a.triangles.data(), a.triangles.size(), sizeof(pf_triangle));
    // The version-4 material: the first 32 bytes of pf_material (version 5 appended the
    // metallic-roughness fields, hashed only where a material is PF_MAT_PBR).
    const uint64_t nm = a.materials.size();
    h.update(&nm, sizeof nm);
    for (const pf_material& m : a.materials) h.update(&m, offsetof(pf_material, metallic));
    const uint64_t nl = a.lights.size();
    h.update(&nl, sizeof nl);
    for (const pf_light& l : a.lights) h.update(&l, 40);
    h.update(&a.camera, offsetof(pf_camera, aperture));
    CHECK(a.scene_id == h.hex());
    // A spot or directional light's fields count: the id changes with the cone.
    Scene b = mixed_scene(8, 8);
    const std::string id = b.scene_id;
    b.lights[0].cos_outer *= 0.99f;
    b.compute_scene_id();
    CHECK(b.scene_id != id);
  }
  SECTION("versions 1-4 are read through the old light compound") {
    const Scene a = floor_scene({point_light(Vec3(0, 1, 0), 2.f)});
    const std::string old = tmp / "v4.h5";
    save_scene(a, old, Provenance{});
    {
      const std::vector<pf_light> lights =
          test::read_dataset<pf_light>(old, "/lights/lights", h5_type_light().id());
      h5::Handle f(H5Fopen(old.c_str(), H5F_ACC_RDWR, H5P_DEFAULT));
      REQUIRE(f.valid());
      test::rewrite_dataset_as(f.get(), "/lights/lights", h5_type_light_v4().id(),
                               h5_type_light_v4().id(), lights.data(), lights.size(),
                               {hsize_t(lights.size())});
    }
    test::set_int_attr(old, "/", "format_version", 4);
    const Scene back = load_scene(old);
    REQUIRE(back.lights.size() == 1);
    CHECK(std::memcmp(back.lights.data(), a.lights.data(), sizeof(pf_light)) == 0);
    CHECK(back.scene_id == a.scene_id);
    test::set_int_attr(old, "/", "format_version", 7);
    CHECK_THROWS_AS(load_scene(old), InputError);
  }
  SECTION("bad values on read are refused with one line naming the light") {
    struct Edit {
      const char* needle;
      std::function<void(pf_light&)> change;
    };
    const std::vector<Edit> edits = {
        {"cos_outer", [](pf_light& l) { l.cos_outer = l.cos_inner + 0.01f; }},
        {"cos_outer", [](pf_light& l) { l.cos_outer = -0.2f; }},
        {"radiance[0] is not finite", [](pf_light& l) { l.radiance[0] = NAN; }},
        {"direction", [](pf_light& l) { l.direction[1] *= 2.f; }},
    };
    for (const Edit& e : edits) {
      const std::string p = tmp / "edited.h5";
      std::filesystem::copy_file(path, p, std::filesystem::copy_options::overwrite_existing);
      test::edit_dataset<pf_light>(p, "/lights/lights", h5_type_light().id(),
                                   [&](std::vector<pf_light>& v) { e.change(v[0]); });
      test::refresh_scene_id(p);
      test::refused([&] { load_scene(p); }, p, e.needle);
    }
    // An area or point light with a direction, a directional light with a cone.
    const std::string p = tmp / "edited.h5";
    std::filesystem::copy_file(path, p, std::filesystem::copy_options::overwrite_existing);
    test::edit_dataset<pf_light>(p, "/lights/lights", h5_type_light().id(),
                                 [](std::vector<pf_light>& v) { v[2].direction[0] = 1.f; });
    test::refresh_scene_id(p);
    test::refused([&] { load_scene(p); }, p, "must be 0");
    std::filesystem::copy_file(path, p, std::filesystem::copy_options::overwrite_existing);
    test::edit_dataset<pf_light>(p, "/lights/lights", h5_type_light().id(),
                                 [](std::vector<pf_light>& v) { v[1].cos_inner = 0.5f; });
    test::refresh_scene_id(p);
    test::refused([&] { load_scene(p); }, p, "must be 0");
    // A directional light whose disc does not match the bounds (derive_lights).
    std::filesystem::copy_file(path, p, std::filesystem::copy_options::overwrite_existing);
    test::edit_dataset<pf_light>(p, "/lights/lights", h5_type_light().id(),
                                 [](std::vector<pf_light>& v) { v[1].area *= 0.5f; });
    test::refresh_scene_id(p);
    test::refused([&] { load_scene(p); }, p, "irradiance and the scene's bounds");
  }
}
