// No NaN or Inf in any layer: one scene with every material and every light type that a baked
// scene can hold (diffuse, mirror, smooth glass, near-delta and rough glossy metal, near-delta and
// rough glass, plastic; an area lamp, a point, a spot, a directional light and an environment map
// with a sun 10⁴ times its sky), seen at grazing angles, rendered by every estimator (the path
// tracer with both samplers, classic photon mapping, ppm, sppm and pppm with each glossy rule,
// photons and shadow rays for direct light, emission and glossy samples) on the CPU and, where a
// device is present, on OpenCL. Every float that a stage hands on is checked: the photons' flux,
// the hitpoints' flux, weight, radius and photon count, the emitted and direct images, the pass
// sums, and the final image's colour and every AOV layer (and each of them holds some light, so
// a route that returns zeros does not pass as finite).
#include <catch2/catch.hpp>

#include <cmath>
#include <sstream>
#include <string>
#include <vector>

#include "photonflow/estimators/render_driver.h"
#include "photonflow/geometry/environment.h"
#include "photonflow/geometry/procedural.h"
#include "photonflow/geometry/scene.h"
#include "photonflow/io/hitpoints_file.h"
#include "photonflow/stages/eye_pass.h"
#include "photonflow/stages/illuminate.h"
#include "photonflow/stages/pathtrace.h"
#include "photonflow/stages/photon_pass.h"
#include "photonflow/stages/synthesize.h"
#include "support.h"
#include "support_cl.h"

using namespace pf;

namespace {

pf_material material(int type, float rho, float metallic = 0.f, float roughness = 0.f,
                     float transmission = 0.f) {
  pf_material m{};
  m.type = type;
  m.ior = (type == PF_MAT_GLASS || type == PF_MAT_PBR) ? 1.5f : 1.f;
  for (float& c : m.color) c = rho;
  m.metallic = metallic;
  m.roughness = roughness;
  m.transmission = transmission;
  return m;
}

// Seven objects on a floor, an area lamp above them; a low camera, so the floor is seen at
// grazing angles and the objects against the sky.
Scene everything_scene(int w, int h) {
  Scene s;
  auto add = [&](std::vector<pf_triangle> tris, const char* name, const pf_material& m) {
    const int id = int(s.materials.size());
    for (auto& t : tris) t.mesh = t.material = id;
    s.triangles.insert(s.triangles.end(), tris.begin(), tris.end());
    s.mesh_names.push_back(name);
    s.material_names.push_back(name);
    s.materials.push_back(m);
  };
  add(make_box(Vec3(-4, -0.05f, -4), Vec3(4, 0, 4), false), "floor", material(PF_MAT_DIFFUSE, 0.7f));
  add(make_box(Vec3(-1.6f, 0, -0.9f), Vec3(-1.1f, 0.6f, -0.6f), false), "mirror",
      material(PF_MAT_MIRROR, 0.9f));
  add(make_sphere(Vec3(-0.8f, 0.3f, 0), 0.3f, 800), "glass", material(PF_MAT_GLASS, 1.f));
  add(make_sphere(Vec3(-0.15f, 0.3f, 0), 0.3f, 800), "sharp metal",
      material(PF_MAT_PBR, 1.f, 1.f, 0.03f));
  add(make_sphere(Vec3(0.5f, 0.3f, 0), 0.3f, 800), "rough metal",
      material(PF_MAT_PBR, 0.9f, 1.f, 0.4f));
  add(make_sphere(Vec3(1.15f, 0.3f, 0), 0.3f, 800), "sharp rough glass",
      material(PF_MAT_PBR, 1.f, 0.f, 0.02f, 1.f));
  add(make_sphere(Vec3(0.2f, 0.25f, 0.7f), 0.25f, 800), "rough glass",
      material(PF_MAT_PBR, 1.f, 0.f, 0.3f, 1.f));
  add(make_sphere(Vec3(-0.5f, 0.2f, 0.7f), 0.2f, 800), "plastic",
      material(PF_MAT_PBR, 0.6f, 0.f, 0.5f));
  pf_material lamp = material(PF_MAT_EMITTER, 0.f);
  for (float& c : lamp.emission) c = 30.f;
  auto panel = test::quad(Vec3(-0.2f, 1.6f, -0.2f), Vec3(0.2f, 1.6f, -0.2f), Vec3(0.2f, 1.6f, 0.2f),
                          Vec3(-0.2f, 1.6f, 0.2f), 0);
  for (auto& t : panel) test::flip(t);  // facing down
  add(panel, "lamp", lamp);
  pf_light point{};
  point.type = PF_LIGHT_POINT;
  Vec3(1.2f, 0.9f, 0.6f).store(point.position);
  for (float& c : point.radiance) c = 2.f;
  pf_light spot = point;
  spot.type = PF_LIGHT_SPOT;
  Vec3(-0.5f, 1.4f, 1.f).store(spot.position);
  normalize(Vec3(0.4f, -1.f, -0.6f)).store(spot.direction);
  spot.cos_inner = 0.97f;
  spot.cos_outer = 0.9f;
  for (float& c : spot.radiance) c = 20.f;
  pf_light sun{};
  sun.type = PF_LIGHT_DIRECTIONAL;
  normalize(Vec3(-0.3f, -1.f, -0.2f)).store(sun.direction);
  for (float& c : sun.radiance) c = 1.5f;
  s.lights = {point, spot, sun};
  s.environment = test::sky_with_sun(64, 0.4f, 4000.f);  // a sun 10⁴ times the sky
  s.camera = pf_camera{{0.1f, 0.12f, 2.6f}, {0.1f, 0.3f, 0.f}, {0, 1, 0}, 55.f, w, h};
  finish_scene(s);
  return s;
}

// "" when every value of `v` is finite and >= 0, else what the first bad one is.
std::string first_bad(const std::vector<float>& v, const std::string& what) {
  for (size_t i = 0; i < v.size(); ++i)
    if (!std::isfinite(v[i]) || v[i] < 0.f) {
      std::ostringstream o;
      o << what << "[" << i << "] = " << v[i];
      return o.str();
    }
  return "";
}
std::string first_bad(const std::vector<double>& v, const std::string& what) {
  std::vector<float> f(v.begin(), v.end());
  for (size_t i = 0; i < v.size(); ++i)
    if (!std::isfinite(v[i])) f[i] = v[i] > 0 ? INFINITY : NAN;
  return first_bad(f, what);
}

double total(const std::vector<float>& v) {
  double s = 0;
  for (float x : v) s += double(x);
  return s;
}

// Every layer of an image is finite and >= 0; the colour holds light.
void check_image(const Image& img, const std::string& route) {
  INFO(route);
  CHECK(first_bad(img.rgb, "rgb").empty());
  CHECK(total(img.rgb) > 0.0);
  for (const auto& [name, layer] : img.layers) {
    INFO("layer " << name);
    CHECK(layer.size() == img.pixel_count());
    CHECK(first_bad(layer, name) == "");
  }
}

void check_hitpoints(const HitpointSet& h, const std::string& route) {
  INFO(route);
  std::vector<float> flux, weight, radius, count;
  for (const auto& hp : h.hitpoints) {
    flux.insert(flux.end(), hp.flux, hp.flux + 3);
    weight.insert(weight.end(), hp.weight, hp.weight + 3);
    radius.push_back(hp.radius);
    count.push_back(hp.n_photons);
  }
  CHECK(first_bad(flux, "hitpoint flux") == "");
  CHECK(first_bad(weight, "hitpoint weight") == "");
  CHECK(first_bad(radius, "hitpoint radius") == "");
  CHECK(first_bad(count, "hitpoint photon count") == "");
  CHECK(first_bad(h.emitted, "emitted") == "");
  CHECK(first_bad(h.direct, "direct") == "");
  CHECK(total(flux) > 0.0);
}

RenderOptions options(Estimator e, DirectMode direct, GlossyMerge glossy) {
  RenderOptions opt;
  opt.estimator = e;
  opt.passes = 3;
  opt.photons.photons = 8000;
  opt.photons.seed = 3;
  opt.eye.seed = 3;
  opt.eye.sampler = e == Estimator::Ppm ? PixelSampler::Strata : PixelSampler::Sobol;
  opt.eye.direct = direct;
  opt.eye.glossy = glossy;
  opt.eye.emission_spp = 2;
  if (e == Estimator::Pppm && glossy == GlossyMerge::Mis) opt.eye.glossy_spp = 2;
  opt.ppm.slab = e == Estimator::Ppm ? 0.f : kDefaultSlab;
  return opt;
}

// Every estimator's route with every rule it accepts, on the CPU or on `dev`.
void sweep(const Scene& s, ClContext* dev) {
  const Provenance prov;
  const std::string backend = dev ? "opencl" : "cpu";
  for (Estimator e : {Estimator::Ppm, Estimator::Sppm, Estimator::Pppm})
    for (DirectMode d : {DirectMode::Photons, DirectMode::ShadowRays})
      for (GlossyMerge g : {GlossyMerge::First, GlossyMerge::Mis}) {
        // ppm's one eye pass would freeze a lobe sample, and the continuation's direct light is
        // by shadow rays: render refuses both combinations (render_driver.h).
        if (g == GlossyMerge::Mis && (e == Estimator::Ppm || d == DirectMode::Photons)) continue;
        RenderOptions opt = options(e, d, g);
        opt.device = dev;
        if (dev) opt.ppm.method = GatherMethod::HashGrid;
        const std::string route = backend + " " + estimator_name(e) + ", direct " +
                                  direct_mode_name(d) + ", glossy " + glossy_merge_name(g);
        if (e == Estimator::Pppm) {
          const PassSums sums = render_pppm(s, opt, false, prov);
          INFO(route);
          CHECK(first_bad(sums.sum, "pass sums") == "");
          check_image(synthesize(sums), route);
        } else {
          const HitpointSet h = render_progressive(s, opt, false, prov);
          check_hitpoints(h, route);
          check_image(synthesize(h), route);
        }
      }
}

}  // namespace

TEST_CASE("no NaN or Inf in any layer: every estimator on a scene of every material and light",
          "[stability][finite]") {
  const Scene s = everything_scene(32, 20);
  REQUIRE(s.lights.size() >= 5);  // the lamp's area lights, point, spot, directional, environment

  SECTION("photons") {
    PhotonPassOptions po;
    po.photons = 20000;
    po.seed = 5;
    const PhotonPassResult r = trace_photons(s, 0, po);
    std::vector<float> flux;
    for (const auto& p : r.photons) flux.insert(flux.end(), p.flux, p.flux + 3);
    CHECK(first_bad(flux, "photon flux") == "");
    CHECK(total(flux) > 0.0);
  }
  SECTION("path tracer, both samplers") {
    for (PathSamplerKind k : {PathSamplerKind::Sobol, PathSamplerKind::Independent}) {
      PathTraceOptions po;
      po.spp = 8;
      po.seed = 2;
      po.sampler = k;
      check_image(pathtrace(s, po), k == PathSamplerKind::Sobol ? "pathtrace sobol"
                                                                : "pathtrace independent");
    }
  }
  SECTION("classic photon mapping") {
    EyePassOptions eo;
    eo.radius = 0.05f;
    HitpointSet h = make_hitpoint_set(trace_hitpoints(s, eo), eo.direct, s.scene_id);
    PhotonPassOptions po;
    po.photons = 40000;
    const PhotonPassResult r = trace_photons(s, 0, po);
    ClassicOptions co;
    co.k = 50;
    classic_estimate(s, h, r.photons, r.emitted, co);
    check_hitpoints(h, "classic");
    check_image(synthesize(h), "classic");
  }
  SECTION("ppm, sppm and pppm on the CPU") { sweep(s, nullptr); }
  SECTION("ppm, sppm and pppm on OpenCL") {
    auto dev = test::test_device();
    if (dev) sweep(s, dev.get());
  }
}
