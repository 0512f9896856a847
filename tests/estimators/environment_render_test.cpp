// The environment light through the photon mappers (eye_pass.cpp, trace_hitpoints.cl, the
// photon pass and the gathers): a diffuse furnace converges to its analytic value in sppm and
// pppm, a glossy metal sphere and a rough glass sphere under a sky with a sun agree with the path
// tracer, both glossy rules alike, and the OpenCL route renders the CPU's image.
#include <catch2/catch.hpp>

#include <cmath>
#include <vector>

#include "photonflow/estimators/render_driver.h"
#include "photonflow/geometry/environment.h"
#include "photonflow/geometry/procedural.h"
#include "photonflow/geometry/scene.h"
#include "photonflow/sampling/sampling.h"
#include "photonflow/stages/pathtrace.h"
#include "photonflow/stages/synthesize.h"
#include "support.h"
#include "support_cl.h"

using namespace pf;

namespace {

RenderOptions options(Estimator e, int passes, uint32_t seed, GlossyMerge g) {
  RenderOptions opt;
  opt.estimator = e;
  opt.passes = passes;
  opt.photons.photons = 20000;
  opt.photons.seed = seed;
  opt.eye.seed = seed;
  opt.eye.sampler = PixelSampler::Sobol;
  opt.eye.direct = DirectMode::ShadowRays;
  opt.eye.glossy = g;
  opt.ppm.slab = kDefaultSlab;
  return opt;
}

Image render_image(const Scene& s, const RenderOptions& opt) {
  const Provenance prov;
  if (opt.estimator == Estimator::Pppm) return synthesize(render_pppm(s, opt, false, prov));
  return synthesize(render_progressive(s, opt, false, prov));
}

double centre_mean(const Image& img, int half) {
  double sum = 0;
  int n = 0;
  for (int y = img.height / 2 - half; y < img.height / 2 + half; ++y)
    for (int x = img.width / 2 - half; x < img.width / 2 + half; ++x, ++n)
      sum += double(luminance(img.get(x, y)));
  return sum / n;
}

double image_mean(const Image& img) {
  double sum = 0;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) sum += double(luminance(img.get(x, y)));
  return sum / (double(img.width) * img.height);
}

// A sphere of `m` over a diffuse floor under `env`, seen from the side.
Scene sphere_scene(const pf_material& m, const Environment& env, int w, int h) {
  Scene s;
  s.triangles = make_sphere(Vec3(0, 0.5f, 0), 0.5f, 3000, {0, 0});
  auto floor = make_box(Vec3(-3, -0.05f, -3), Vec3(3, 0, 3), false, {1, 1});
  s.triangles.insert(s.triangles.end(), floor.begin(), floor.end());
  s.mesh_names = {"sphere", "floor"};
  pf_material d{};
  d.type = PF_MAT_DIFFUSE;
  d.ior = 1.f;
  for (float& c : d.color) c = 0.6f;
  s.materials = {m, d};
  s.material_names = {"sphere", "floor"};
  s.environment = env;
  s.camera = pf_camera{{0, 1.2f, 3}, {0, 0.45f, 0}, {0, 1, 0}, 30.f, w, h};
  finish_scene(s);
  return s;
}

pf_material pbr(float metallic, float roughness, float transmission) {
  pf_material m{};
  m.type = PF_MAT_PBR;
  for (float& c : m.color) c = 1.f;
  m.metallic = metallic;
  m.roughness = roughness;
  m.transmission = transmission;
  m.ior = 1.5f;
  return m;
}

}  // namespace

TEST_CASE("environment in the photon mappers: a diffuse furnace converges to rho L",
          "[environment][sppm][pppm]") {
  // A convex diffuse sphere of albedo ρ in a constant environment L: radiance ρ·L leaves every
  // point (the environment's direct light by next-event estimation; no indirect light: the
  // sphere never sees itself), L beside it (the camera's escaping rays).
  const float L = 1.5f, rho = 0.6f;
  Scene s;
  s.triangles = make_sphere(Vec3(0, 0, 0), 0.5f, 4000, {0, 0});
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
  for (Estimator e : {Estimator::Sppm, Estimator::Pppm}) {
    const Image img = render_image(s, options(e, 32, 5, GlossyMerge::Mis));
    INFO(estimator_name(e));
    CHECK(centre_mean(img, 3) == Approx(rho * L).epsilon(0.03));
    CHECK(img.get(0, 0).y == Approx(L).epsilon(1e-5));
  }
}

TEST_CASE("environment in the photon mappers: glossy metal and rough glass under a sky with a "
          "sun agree with the path tracer",
          "[environment][glossy]") {
  // The sun is a texel 10^3 times the sky: the light sampling finds it, MIS keeps the glossy
  // highlights bounded; the image means of sppm and pppm (both rules) and the path tracer agree
  // within their spread over seeds plus the photon estimators' smoothing bias (5 %).
  const Environment env = test::sky_with_sun(64, 0.5f, 500.f);
  const bool glass = GENERATE(false, true);
  const Scene s = sphere_scene(glass ? pbr(0, 0.2f, 1) : pbr(1, 0.3f, 0), env, 24, 18);
  INFO((glass ? "rough glass" : "rough metal"));
  std::vector<double> pt, mis, first;
  for (uint32_t seed = 1; seed <= 4; ++seed) {
    PathTraceOptions po;
    po.spp = 64;
    po.seed = seed;
    pt.push_back(image_mean(pathtrace(s, po)));
    mis.push_back(image_mean(render_image(s, options(Estimator::Pppm, 16, seed, GlossyMerge::Mis))));
    first.push_back(image_mean(render_image(s, options(Estimator::Sppm, 16, seed, GlossyMerge::First))));
  }
  auto mean = [](const std::vector<double>& v) {
    double m = 0;
    for (double x : v) m += x / double(v.size());
    return m;
  };
  auto se = [&](const std::vector<double>& v) {
    const double m = mean(v);
    double q = 0;
    for (double x : v) q += (x - m) * (x - m);
    return std::sqrt(q / double(v.size() - 1) / double(v.size()));
  };
  INFO("path tracer " << mean(pt) << " ± " << se(pt) << ", pppm mis " << mean(mis) << " ± "
                      << se(mis) << ", sppm first " << mean(first) << " ± " << se(first));
  CHECK(mean(pt) > 0.1);
  CHECK(std::fabs(mean(mis) - mean(pt)) <= 4 * std::hypot(se(mis), se(pt)) + 0.05 * mean(pt));
  CHECK(std::fabs(mean(first) - mean(pt)) <= 4 * std::hypot(se(first), se(pt)) + 0.05 * mean(pt));
}

TEST_CASE("environment in the photon mappers: the OpenCL route renders the CPU's image",
          "[environment][opencl]") {
  auto dev = test::test_device();
  if (!dev) return;
  const Scene s = sphere_scene(pbr(1, 0.3f, 0), test::sky_with_sun(64, 0.5f, 500.f), 32, 24);
  test::check_device_route(s, Estimator::Pppm, GatherMethod::HashGrid, 3, 6000, *dev,
                           GlossyMerge::Mis);
  test::check_device_route(s, Estimator::Sppm, GatherMethod::HashGrid, 3, 6000, *dev,
                           GlossyMerge::First);
}
