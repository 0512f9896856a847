// Depth of field (issue 32 item 5): the thin-lens camera (camera.h, lens_shared.h) in the eye
// pass on both backends and in the path tracer. Eye-pass hitpoints on a plane at the focus
// distance stay exactly where the pinhole camera puts them (sharp); on a plane at depth z ≠ d
// they are displaced uniformly over a disc whose image-space diameter is the circle of confusion
// 2a|z − d|/z (in focus-plane units, pf_lens_coc_diameter). SPPM's per-pixel lens sequence is a
// stratified (0,2)-sequence in an order uncorrelated with the pixel position's. Bad lens
// parameters are refused by scene-bake and by the scene loader.
#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>

#include "photonflow/geometry/camera.h"
#include "photonflow/stages/eye_pass.h"
#include "photonflow/stages/pathtrace.h"
#include "photonflow/geometry/procedural.h"
#include "photonflow/io/provenance.h"
#include "photonflow/geometry/scene.h"
#include "photonflow/geometry/scene_file.h"
#include "photonflow/sampling/sampling.h"
#include "photonflow/io/validate.h"
#include "support.h"
#include "support_cl.h"
#include "photonflow/opencl/cl_backend.h"

using namespace pf;

namespace {

constexpr int kSide = 32;
constexpr float kFovDeg = 30.f;

// A large diffuse plane facing the camera at depth z (camera at the origin looking along −z),
// seen through a thin lens of radius `aperture` focused at `focus` (0, 0: a pinhole).
Scene plane_scene(float z, float aperture, float focus) {
  Scene s;
  s.triangles = make_box(Vec3(-20, -20, -z - 0.5f), Vec3(20, 20, -z), false, {0, 0});
  s.mesh_names = {"plane"};
  pf_material m{};
  m.type = PF_MAT_DIFFUSE;
  m.ior = 1.f;
  for (float& c : m.color) c = 0.5f;
  s.materials = {m};
  s.material_names = {"plane"};
  s.camera = pf_camera{{0, 0, 0}, {0, 0, -1}, {0, 1, 0}, kFovDeg, kSide, kSide, aperture, focus};
  finish_scene(s);
  return s;
}

struct Spread {
  double max_offset = 0, mean_offset = 0, mean_x = 0, mean_y = 0;
  size_t n = 0;
};

// Displacement of every hitpoint of the lens scene from the pinhole scene's hitpoint of the same
// sample (the same pixel position: the lens draws come after the jitter), over `passes` SPPM eye
// passes (the Sobol sampler).
Spread lens_spread(const Scene& lens, const Scene& pinhole, int passes) {
  Spread s;
  EyePassOptions opt;
  opt.sampler = PixelSampler::Sobol;
  opt.radius = 0.01f;
  for (int p = 0; p < passes; ++p) {
    opt.pass = uint32_t(p);
    const EyePassResult a = trace_hitpoints(lens, opt), b = trace_hitpoints(pinhole, opt);
    REQUIRE(a.hitpoints.size() == size_t(kSide * kSide));
    REQUIRE(b.hitpoints.size() == a.hitpoints.size());
    for (size_t i = 0; i < a.hitpoints.size(); ++i) {
      const Vec3 d = Vec3(a.hitpoints[i].position) - Vec3(b.hitpoints[i].position);
      REQUIRE(std::fabs(length(Vec3(a.hitpoints[i].dir)) - 1.f) < 1e-5f);
      const double r = length(d);
      s.max_offset = std::max(s.max_offset, r);
      s.mean_offset += r;
      s.mean_x += d.x;
      s.mean_y += d.y;
      ++s.n;
    }
  }
  s.mean_offset /= double(s.n);
  s.mean_x /= double(s.n);
  s.mean_y /= double(s.n);
  return s;
}

Provenance test_provenance() {
  Provenance p;
  p.tool = "test";
  return p;
}

}  // namespace

TEST_CASE("depth of field: the focus plane is sharp, a plane off it blurs over the circle of confusion",
          "[dof][eye]") {
  const float a = 0.2f, d = 2.f;
  const CameraFrame frame(plane_scene(d, a, d).camera);
  SECTION("a plane at the focus distance: every lens sample lands on the pinhole's point") {
    const Spread s = lens_spread(plane_scene(d, a, d), plane_scene(d, 0.f, 0.f), 16);
    INFO("max offset " << s.max_offset);
    CHECK(s.max_offset < 1e-4 * d);
  }
  SECTION("a plane at twice the focus distance: a uniform disc of the circle of confusion") {
    const float z = 2.f * d;
    const Spread s = lens_spread(plane_scene(z, a, d), plane_scene(z, 0.f, 0.f), 64);
    // On the plane at depth z the lens disc (radius a at depth 0) around the focus point
    // (depth d) has radius r = a|z − d|/d; seen from the camera that is the circle of
    // confusion: its image-plane diameter in pixels 2r/(z·pixel_angle) equals
    // c(z)/(d·pixel_angle), with c(z) = 2a|z − d|/z measured on the focus plane.
    const double r = a * std::fabs(z - d) / d;
    const double coc_pixels = pf_lens_coc_diameter(a, d, z) / (d * frame.pixel_angle());
    const double measured_pixels = 2.0 * s.max_offset / (z * frame.pixel_angle());
    INFO("max offset " << s.max_offset << " (r " << r << "), mean " << s.mean_offset
                       << " (uniform disc: 2r/3 = " << 2 * r / 3 << "), CoC " << coc_pixels
                       << " px, measured " << measured_pixels << " px");
    CHECK(coc_pixels > 5.0);  // the blur is many pixels: the test can tell
    CHECK(measured_pixels <= coc_pixels * 1.001);
    CHECK(measured_pixels >= coc_pixels * 0.98);
    CHECK(s.mean_offset == Approx(2.0 * r / 3.0).epsilon(0.01));  // uniform over the disc
    CHECK(std::fabs(s.mean_x) < 0.01 * r);                        // centred on the pinhole's point
    CHECK(std::fabs(s.mean_y) < 0.01 * r);
  }
}

TEST_CASE("depth of field: a pinhole scene's eye pass is unchanged by the lens code",
          "[dof][eye]") {
  // aperture 0 draws no lens sample: hitpoints equal those of CameraFrame::direction rays, and
  // the scene id is the one the pinhole fields alone give (format version 3 files keep theirs).
  const Scene s = plane_scene(3.f, 0.f, 0.f);
  EyePassOptions opt;
  opt.sampler = PixelSampler::Sobol;
  opt.pass = 3;
  const EyePassResult r = trace_hitpoints(s, opt);
  const CameraFrame cam(s.camera);
  REQUIRE(r.hitpoints.size() == size_t(kSide * kSide));
  for (const pf_hitpoint& h : r.hitpoints) {
    const Vec3 p(h.position);
    const Vec3 dir = normalize(p);
    CHECK(length(cross(dir, Vec3(h.dir))) < 1e-5f);
  }
  Scene lens = plane_scene(3.f, 0.1f, 3.f);
  CHECK(lens.scene_id != s.scene_id);
  lens.camera.aperture = 0.f;
  lens.camera.focus_distance = 0.f;
  lens.compute_scene_id();
  CHECK(lens.scene_id == s.scene_id);
}

TEST_CASE("depth of field: SPPM's lens samples are a stratified sequence per pixel", "[dof][sampler]") {
  const uint32_t key = pf_sobol_key(7);
  double sxy = 0, sx = 0, sy = 0, sxx = 0, syy = 0;
  size_t n = 0;
  for (uint32_t pixel : {0u, 17u, 4095u}) {
    // Every aligned block of 16 passes puts one lens sample into each cell of a 4 × 4 grid, and
    // into each of the 2 × 8 and 8 × 2 elementary intervals.
    for (uint32_t block = 0; block < 8; ++block) {
      int cells44[16] = {}, cells28[16] = {}, cells82[16] = {};
      for (uint32_t p = 16 * block; p < 16 * block + 16; ++p) {
        pf_rng rng{0, 0, 0};
        float jx, jy, u1, u2;
        pf_eye_jitter_keyed(PF_SAMPLER_SOBOL, key, p, pixel, 0, 1, 1, &rng, &jx, &jy);
        pf_eye_lens_keyed(PF_SAMPLER_SOBOL, key, p, pixel, 0, 1, &rng, &u1, &u2);
        CHECK(rng.dim == 4u);
        ++cells44[int(u1 * 4) * 4 + int(u2 * 4)];
        ++cells28[int(u1 * 2) * 8 + int(u2 * 8)];
        ++cells82[int(u1 * 8) * 2 + int(u2 * 2)];
        sxy += double(jx) * u1;
        sx += jx;
        sy += u1;
        sxx += double(jx) * jx;
        syy += double(u1) * u1;
        ++n;
      }
      for (int c = 0; c < 16; ++c) {
        CHECK(cells44[c] == 1);
        CHECK(cells28[c] == 1);
        CHECK(cells82[c] == 1);
      }
    }
  }
  // The lens order is shuffled against the pixel position's: their correlation is small (0.04
  // here; without the index shuffle, two Owen scrambles of the same radical inverse, −0.33).
  const double cov = sxy / double(n) - sx / double(n) * sy / double(n);
  const double corr = cov / std::sqrt((sxx / double(n) - sx * sx / double(n * n)) *
                                      (syy / double(n) - sy * sy / double(n * n)));
  INFO("correlation of jx and u1: " << corr);
  CHECK(std::fabs(corr) < 0.15);
}

TEST_CASE("depth of field: OpenCL eye pass equals the CPU's through a thin lens", "[dof][opencl]") {
  auto dev = test::test_device();
  if (!dev) return;
  const Scene s = plane_scene(4.f, 0.2f, 2.f);
  for (PixelSampler sampler : {PixelSampler::Sobol, PixelSampler::Random, PixelSampler::Strata}) {
    EyePassOptions opt;
    opt.sampler = sampler;
    opt.pass = 5;
    const EyePassResult cpu = trace_hitpoints(s, opt), gpu = trace_hitpoints(s, opt, *dev);
    REQUIRE(cpu.hitpoints.size() == gpu.hitpoints.size());
    double worst = 0;
    for (size_t i = 0; i < cpu.hitpoints.size(); ++i)
      worst = std::max<double>(worst, length(Vec3(cpu.hitpoints[i].position) -
                                             Vec3(gpu.hitpoints[i].position)));
    INFO(pixel_sampler_name(sampler) << ": largest position difference " << worst);
    CHECK(worst < 1e-4);
  }
}

TEST_CASE("depth of field: the path tracer blurs by the same lens", "[dof][pathtrace]") {
  // A plane lit by a point light, half of it black (x < 0): the edge at depth z = 2d blurs over
  // the circle of confusion in the path-traced image; at z = d it stays within a pixel.
  auto edge_width = [](float z, float a, float d) {
    Scene s = plane_scene(z, a, d);
    pf_material black = s.materials[0];
    for (float& c : black.color) c = 0.f;
    s.materials.push_back(black);
    s.material_names.push_back("black");
    auto right = make_box(Vec3(-20, -20, -z + 0.001f), Vec3(0, 20, -z + 0.002f), false, {1, 1});
    s.triangles.insert(s.triangles.end(), right.begin(), right.end());
    s.mesh_names.push_back("black");
    pf_light l{};
    l.type = PF_LIGHT_POINT;
    l.position[2] = 0.5f;
    for (float& c : l.radiance) c = 10.f;
    s.lights = {l};
    finish_scene(s);
    PathTraceOptions opt;
    opt.spp = 256;
    const Image img = pathtrace(s, opt);
    // Pixels of the middle row whose value lies between 10 % and 90 % of the bright side's.
    const int y = kSide / 2;
    const float bright = luminance(img.get(kSide - 2, y));
    int between = 0;
    for (int x = 0; x < kSide; ++x) {
      const float v = luminance(img.get(x, y));
      between += v > 0.1f * bright && v < 0.9f * bright;
    }
    return between;
  };
  const float a = 0.2f, d = 2.f;
  const int sharp = edge_width(d, a, d), blurred = edge_width(2.f * d, a, d);
  const CameraFrame frame(plane_scene(2.f * d, a, d).camera);
  const double coc_pixels = pf_lens_coc_diameter(a, d, 2.f * d) / (d * frame.pixel_angle());
  INFO("edge: " << sharp << " px in focus, " << blurred << " px at 2d (CoC " << coc_pixels
                << " px)");
  CHECK(sharp <= 2);
  // The 10–90 % width of a uniform disc's edge spread is 0.73 of its diameter.
  CHECK(blurred >= int(0.5 * coc_pixels));
  CHECK(blurred <= int(coc_pixels) + 2);
}

TEST_CASE("depth of field: bad lens options and lens values are refused", "[dof][input]") {
  test::TempDir tmp("dof");
  const std::string src = test::source_dir() + "/data/cornell-box.dae";
  for (const std::string& args : {std::string("--aperture -1"), std::string("--aperture nan"),
                                  std::string("--aperture 1e13"),
                                  std::string("--focus-distance 2"),
                                  std::string("--aperture 0.1 --focus-distance 0"),
                                  std::string("--aperture 0.1 --focus-distance -3")}) {
    const test::ToolRun r = test::run_tool("scene-bake", src + " -o " + (tmp / "s.h5") + " " + args, tmp);
    INFO(args << ": " << r.err);
    CHECK(r.exit_code == 2);
    CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
    CHECK_FALSE(std::filesystem::exists(tmp / "s.h5"));
  }
  // A stored lens the loader refuses (written unchecked, as a damaged file would be).
  const UncheckedWritesForTests damaged;
  for (auto [ap, fd] : {std::pair{-0.1f, 2.f}, std::pair{0.1f, 0.f}, std::pair{0.f, 2.f},
                        std::pair{NAN, 2.f}}) {
    Scene s = plane_scene(3.f, 0.1f, 3.f);
    s.camera.aperture = ap;
    s.camera.focus_distance = fd;
    s.compute_scene_id();
    save_scene(s, tmp / "bad.h5", test_provenance());
    test::refused([&] { load_scene(tmp / "bad.h5"); }, "bad.h5", "camera.aperture");
  }
  // A good lens round-trips.
  const Scene s = plane_scene(3.f, 0.1f, 2.5f);
  save_scene(s, tmp / "good.h5", test_provenance());
  const Scene r = load_scene(tmp / "good.h5");
  CHECK(r.camera.aperture == 0.1f);
  CHECK(r.camera.focus_distance == 2.5f);
  CHECK(r.scene_id == s.scene_id);
}
