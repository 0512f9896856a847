// The estimators with a new eye pass every pass (sppm.h): SPPM (Hachisuka & Jensen 2009) and
// probabilistic PPM (Knaus & Zwicker 2011). Closed forms (white furnace, a floor under a point
// light), agreement with PPM where no pixel sees an edge, the light outline that a fixed eye pass
// never resolves, the pixel sampler's stratification, the exact merge of pass ranges, resumes,
// the wall-clock budget, and CPU against OpenCL.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <random>

#include "photonflow/geometry/camera.h"
#include "photonflow/opencl/cl_gather.h"
#include "photonflow/opencl/cl_runtime.h"
#include "photonflow/estimators/pass_sums.h"
#include "photonflow/sampling/pixel_sampler.h"
#include "photonflow/estimators/render_driver.h"
#include "photonflow/sampling/sampling.h"
#include "photonflow/estimators/render_defaults.h"
#include "photonflow/estimators/sppm.h"
#include "photonflow/stages/synthesize.h"
#include "h5edit.h"
#include "support.h"
#include "support_cl.h"

using namespace pf;

namespace {

// The image of a run of `opt` with any estimator.
Image render_image(const Scene& s, const RenderOptions& opt, RenderStatus* status = nullptr) {
  const Provenance prov;
  if (opt.estimator == Estimator::Pppm) return synthesize(render_pppm(s, opt, false, prov, {}, {}, status));
  return synthesize(render_progressive(s, opt, false, prov, {}, {}, status));
}

RenderOptions options(Estimator e, int passes, uint32_t photons, float radius) {
  RenderOptions opt;
  opt.estimator = e;
  opt.passes = passes;
  opt.photons.photons = photons;
  opt.eye.radius = radius;
  opt.eye.sampler = e == Estimator::Ppm ? PixelSampler::Strata : PixelSampler::Sobol;
  return opt;
}

// A floor y = 0 (albedo rho, 8 × 8) under a point light of intensity I at height h, the camera
// looking straight down: L(x) = ρ/π · I h / d³ (direct light only).
Scene floor_scene(float rho, float intensity, float h, int size) {
  Scene s;
  s.triangles = test::quad(Vec3(-4, 0, -4), Vec3(-4, 0, 4), Vec3(4, 0, 4), Vec3(4, 0, -4), 0);
  s.mesh_names = {"floor"};
  pf_material m{};
  m.type = PF_MAT_DIFFUSE;
  m.ior = 1.f;
  m.color[0] = m.color[1] = m.color[2] = rho;
  s.materials = {m};
  s.material_names = {"floor"};
  pf_light l{};
  l.type = PF_LIGHT_POINT;
  l.position[1] = h;
  l.radiance[0] = l.radiance[1] = l.radiance[2] = intensity;
  s.lights = {l};
  s.camera = pf_camera{{0.f, 3.f, 0.f}, {0.f, 0.f, 0.f}, {0, 0, 1}, 40.f, size, size};
  finish_scene(s);
  return s;
}

// Mean of ρ/π · I h / d³ over pixel (x, y) of the floor scene (8 × 8 point rule: the pixel's
// samples move inside it from pass to pass, so the pixel's value is its area mean).
double floor_expected(const Scene& s, int x, int y, float rho, float intensity, float h) {
  const CameraFrame cam(s.camera);
  double sum = 0;
  for (int j = 0; j < 8; ++j)
    for (int i = 0; i < 8; ++i) {
      const Vec3 d = cam.direction(float(x) + (float(i) + 0.5f) / 8.f, float(y) + (float(j) + 0.5f) / 8.f);
      const Vec3 p = cam.eye() + d * (cam.eye().y / -d.y);
      const Vec3 w = Vec3(0, h, 0) - p;
      const double d2 = double(dot(w, w)), dist = std::sqrt(d2);
      sum += rho / kPi * intensity * (double(w.y) / dist) / d2;
    }
  return sum / 64.0;
}

// A square emitter (radiance le, black: it reflects nothing) seen head-on against nothing: the
// image is the light alone, and a pixel's exact value is le times the part of its area that the
// square covers. The square's sides fall between pixel centres at fractional positions.
Scene lamp_scene(float le, int size) {
  Scene s;
  const float a = 0.437f, z = -2.f;
  s.triangles = test::quad(Vec3(-a, -a * 0.81f, z), Vec3(a, -a * 0.81f, z), Vec3(a, a * 1.13f, z),
                           Vec3(-a, a * 1.13f, z), 0);
  s.mesh_names = {"lamp"};
  pf_material m{};
  m.type = PF_MAT_EMITTER;
  m.ior = 1.f;
  m.emission[0] = m.emission[1] = m.emission[2] = le;
  s.materials = {m};
  s.material_names = {"lamp"};
  s.camera = pf_camera{{0.f, 0.f, 0.f}, {0.f, 0.f, -1.f}, {0, 1, 0}, 40.f, size, size};
  finish_scene(s);
  return s;
}

// The lamp's exact image: the square's corners projected to pixel coordinates (an axis-aligned
// rectangle: the square is parallel to the image plane), and each pixel's covered fraction.
std::vector<double> lamp_expected(const Scene& s, float le) {
  const pf_camera& c = s.camera;
  const double t = std::tan(double(c.fov_y_deg) * kPi / 360.0);  // square pixels
  auto px = [&](double x, double z) { return (x / -z / t + 1.0) * 0.5 * c.width; };
  auto py = [&](double y, double z) { return (1.0 - y / -z / t) * 0.5 * c.height; };
  double x0 = 1e9, x1 = -1e9, y0 = 1e9, y1 = -1e9;
  for (const pf_triangle& tr : s.triangles)
    for (const float* v : {tr.v0, tr.v1, tr.v2}) {
      x0 = std::min(x0, px(v[0], v[2]));
      x1 = std::max(x1, px(v[0], v[2]));
      y0 = std::min(y0, py(v[1], v[2]));
      y1 = std::max(y1, py(v[1], v[2]));
    }
  std::vector<double> e(size_t(c.width) * size_t(c.height));
  for (int y = 0; y < c.height; ++y)
    for (int x = 0; x < c.width; ++x) {
      const double cx = std::max(0.0, std::min(x1, x + 1.0) - std::max(x0, double(x)));
      const double cy = std::max(0.0, std::min(y1, y + 1.0) - std::max(y0, double(y)));
      e[size_t(y * c.width + x)] = le * cx * cy;
    }
  return e;
}

// RMSE over the pixels the lamp's outline crosses (expected strictly between 0 and le).
double outline_rmse(const Image& img, const std::vector<double>& expected, float le) {
  double sum = 0;
  size_t n = 0;
  for (size_t i = 0; i < expected.size(); ++i) {
    if (expected[i] <= 1e-6 * le || expected[i] >= le * (1 - 1e-6)) continue;
    const double d = double(img.rgb[3 * i + 1]) - expected[i];
    sum += d * d;
    ++n;
  }
  REQUIRE(n > 20);
  return std::sqrt(sum / double(n));
}

}  // namespace

TEST_CASE("white furnace: SPPM and probabilistic PPM converge to Le/(1-rho)", "[sppm][furnace]") {
  const float rho = 0.5f, le = 1.f, expected = le / (1.f - rho);
  const Scene s = test::furnace_scene(rho, le, 16);
  for (Estimator e : {Estimator::Sppm, Estimator::Pppm}) {
    RenderOptions opt = options(e, 8, 50000, 0.15f);
    opt.photons.max_bounces = 64;
    const Image img = render_image(s, opt);
    double sum = 0, worst = 0;
    for (float v : img.rgb) {
      sum += v;
      worst = std::max(worst, std::fabs(v / expected - 1.0));
    }
    const double mean_err = std::fabs(sum / double(img.rgb.size()) / expected - 1.0);
    INFO(estimator_name(e) << ": mean error " << mean_err << ", worst pixel " << worst);
    CHECK(mean_err < 0.01);
    CHECK(worst < 0.06);
  }
}

TEST_CASE("SPPM, PPPM and PPM agree with L = rho I h / (pi d^3) where no pixel sees an edge",
          "[sppm][transport]") {
  // Only direct light reaches the camera, all of it by photons, and every pixel sees the floor:
  // the estimators differ only in where samples lie inside the pixel and in their radii. The
  // pixel's value is the mean over its area (floor_expected; PPM's centre sample differs from it
  // by under 0.1% here). Tolerances as in test_transport's PPM case: 3% on the mean, 50% per pixel.
  // Caught: β left out of τ (SPPM), the pass radius r_i² = r_1² Π (j + α)/(j + 1) off by one pass
  // or squared twice (PPPM), the running mean of the layers divided by the wrong pass count.
  const float rho = 0.8f, intensity = 5.f, h = 1.f;
  const int size = 16;
  const Scene s = floor_scene(rho, intensity, h, size);
  double mean_expected = 0;
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) mean_expected += floor_expected(s, x, y, rho, intensity, h);
  mean_expected /= size * size;
  std::vector<Image> images;
  for (Estimator e : {Estimator::Ppm, Estimator::Sppm, Estimator::Pppm}) {
    const Image img = render_image(s, options(e, 8, 100000, 0.06f));
    double mean = 0, worst = 0;
    for (int y = 0; y < size; ++y)
      for (int x = 0; x < size; ++x) {
        const double v = img.get(x, y).y;
        mean += v / (size * size);
        worst = std::max(worst, std::fabs(v / floor_expected(s, x, y, rho, intensity, h) - 1.0));
      }
    INFO(estimator_name(e) << ": mean " << mean << ", expected " << mean_expected << ", worst "
                           << worst);
    CHECK(mean == Approx(mean_expected).epsilon(0.03));
    CHECK(worst < 0.5);
    images.push_back(img);
  }
  // The three images agree pixel by pixel within their noise (relative RMSE, measured 0.07-0.09).
  CHECK(test::relative_rmse(images[1], images[0]) < 0.2);
  CHECK(test::relative_rmse(images[2], images[0]) < 0.2);
}

TEST_CASE("a light's outline converges with SPPM and PPPM, never with PPM's fixed eye pass",
          "[sppm][outline]") {
  // lamp_scene's exact image is the covered part of each pixel. PPM samples every pixel once, at
  // its centre, so an outline pixel stays 0 or le however many passes run. SPPM and PPPM move the
  // sample every pass: with the scrambled (0,2)-sequence the outline error falls about as 1/k
  // (measured: 16× the passes, 18× less error), with independent jitter as 1/sqrt(k) (3.8×).
  const float le = 1.f;
  const Scene s = lamp_scene(le, 24);
  const std::vector<double> expected = lamp_expected(s, le);
  auto error = [&](Estimator e, PixelSampler sampler, int passes) {
    RenderOptions opt = options(e, passes, 16, 0.01f);
    opt.eye.sampler = sampler;
    return outline_rmse(render_image(s, opt), expected, le);
  };
  const double ppm4 = error(Estimator::Ppm, PixelSampler::Strata, 4);
  const double ppm64 = error(Estimator::Ppm, PixelSampler::Strata, 64);
  INFO("ppm: " << ppm4 << " -> " << ppm64);
  CHECK(ppm64 > 0.9 * ppm4);  // a floor: the fixed eye pass
  CHECK(ppm64 > 0.1 * le);
  for (Estimator e : {Estimator::Sppm, Estimator::Pppm}) {
    const double sobol4 = error(e, PixelSampler::Sobol, 4), sobol64 = error(e, PixelSampler::Sobol, 64);
    const double rand4 = error(e, PixelSampler::Random, 4), rand64 = error(e, PixelSampler::Random, 64);
    INFO(estimator_name(e) << ": sobol " << sobol4 << " -> " << sobol64 << ", random " << rand4
                           << " -> " << rand64);
    CHECK(sobol64 < 0.2 * sobol4);
    CHECK(rand64 < 0.45 * rand4);
    CHECK(sobol64 < 0.5 * rand64);  // the sequence beats independent jitter at equal passes
  }
}

TEST_CASE("pixel sampler: the first 2^k samples of a pixel fill every elementary interval",
          "[sppm][sampler]") {
  // The (0,2)-sequence property, kept by Owen scrambling: for every k <= 10 and every shape of
  // 2^k cells (2^a columns × 2^(k−a) rows) the first 2^k samples of a pixel lie one per cell. Four
  // pixels of two seeds. The independent jitter (PF_SAMPLER_RANDOM) fails it, so the check can
  // fail.
  auto stratified = [](auto&& sample, int k) {
    const int n = 1 << k;
    std::vector<float> xs(static_cast<size_t>(n)), ys(static_cast<size_t>(n));
    for (int i = 0; i < n; ++i) sample(uint32_t(i), xs[size_t(i)], ys[size_t(i)]);
    return test::is_net(xs, ys, k);
  };
  for (uint32_t seed : {1u, 77u})
    for (uint32_t pixel : {0u, 1u, 513u, 262143u}) {
      for (int k = 0; k <= 10; ++k) {
        INFO("seed " << seed << ", pixel " << pixel << ", k " << k);
        CHECK(stratified(
            [&](uint32_t i, float& x, float& y) { pf_sobol_pixel_sample(seed, pixel, i, &x, &y); },
            k));
      }
      // Through pf_eye_jitter, sample i of pass p is index p (spp 1).
      CHECK(stratified(
          [&](uint32_t i, float& x, float& y) {
            pf_rng rng = pf_rng_start(seed, 0xE7E0000u + i, pixel);
            pf_eye_jitter(PF_SAMPLER_SOBOL, seed, i, pixel, 0, 1, 1, &rng, &x, &y);
          },
          8));
    }
  int random_ok = 0;
  for (uint32_t pixel = 0; pixel < 16; ++pixel)
    random_ok += stratified(
        [&](uint32_t i, float& x, float& y) {
          pf_rng rng = pf_rng_start(1, 0xE7E0000u + i, pixel);
          pf_eye_jitter(PF_SAMPLER_RANDOM, 1, i, pixel, 0, 1, 1, &rng, &x, &y);
        },
        4);
  CHECK(random_ok == 0);
  // Different pixels get different scrambles.
  float x0, y0, x1, y1;
  pf_sobol_pixel_sample(1, 0, 0, &x0, &y0);
  pf_sobol_pixel_sample(1, 1, 0, &x1, &y1);
  CHECK((x0 != x1 || y0 != y1));
}

TEST_CASE("PPPM: sums of disjoint pass ranges merge into one run's, in any part order",
          "[sppm][pppm][merge]") {
  const Scene s = test::room_scene(PF_MAT_GLASS, 24, 18);
  RenderOptions opt = options(Estimator::Pppm, 6, 3000, 0.f);
  opt.eye.direct = DirectMode::ShadowRays;
  const Provenance prov;
  const PassSums whole = render_pppm(s, opt, false, prov);
  REQUIRE(whole.passes == 6);
  std::vector<PassSums> parts;
  for (auto [first, count] : {std::pair{4, 2}, std::pair{0, 1}, std::pair{1, 3}}) {
    RenderOptions o = opt;
    o.first_pass = first;
    o.passes = count;
    parts.push_back(render_pppm(s, o, false, prov));
  }
  const PassSums merged = merge_pass_sums(parts, {"c.h5", "a.h5", "b.h5"}, 0, 6);
  CHECK(merged.first_pass == 0);
  CHECK(merged.passes == 6);
  CHECK(merged.photons_emitted == whole.photons_emitted);
  double worst = 0, scale = 0;
  for (size_t j = 0; j < whole.sum.size(); ++j) {
    worst = std::max(worst, std::fabs(merged.sum[j] - whole.sum[j]));
    scale = std::max(scale, std::fabs(whole.sum[j]));
  }
  INFO("largest difference " << worst << " of sums up to " << scale);
  REQUIRE(scale > 0);
  CHECK(worst <= 1e-12 * scale);  // the order of the double additions only
  // The radius sequence: r_i² = r_1² Π_{j<i} (j + α)/(j + 1); r_2² = r_1² (1 + α)/2.
  CHECK(pppm_radius(2.0, 0.5, 0) == 2.0);
  CHECK(pppm_radius(2.0, 0.5, 1) == Approx(std::sqrt(4.0 * 1.5 / 2.0)));
  CHECK(pppm_radius(2.0, 0.5, 2) == Approx(std::sqrt(4.0 * 1.5 / 2.0 * 2.5 / 3.0)));
  // Refusals: overlap, gap, range not covered, another option set.
  CHECK_THROWS_AS(merge_pass_sums({parts[1], parts[2], parts[2]}, {"a", "b", "b2"}), InputError);
  CHECK_THROWS_AS(merge_pass_sums({parts[1], parts[0]}, {"a", "c"}), InputError);
  CHECK_THROWS_AS(merge_pass_sums({parts[1], parts[2]}, {"a", "b"}, 0, 6), InputError);
  PassSums other = parts[0];
  other.parameters["seed"] = "2";
  CHECK_THROWS_AS(merge_pass_sums({parts[1], parts[2], other}, {"a", "b", "c"}), InputError);
}

TEST_CASE("SPPM and PPPM: a resumed run equals the uninterrupted one, --time ends a run",
          "[sppm][resume]") {
  const Scene s = test::room_scene(PF_MAT_GLASS, 20, 16);
  test::TempDir tmp("pf-sppm-resume");
  for (Estimator e : {Estimator::Sppm, Estimator::Pppm}) {
    RenderOptions opt = options(e, 5, 2000, 0.f);
    opt.checkpoint = tmp / (std::string(estimator_name(e)) + ".h5");
    opt.checkpoint_every = 1;
    const Provenance prov;
    RenderOptions first = opt;
    first.passes = 2;
    Image whole, resumed;
    if (e == Estimator::Pppm) {
      const PassSums a = render_pppm(s, opt, false, prov);
      render_pppm(s, first, false, prov);
      const PassSums b = render_pppm(s, opt, true, prov);
      CHECK(a.sum == b.sum);
      CHECK(b.passes == 5);
    } else {
      const HitpointSet a = render_progressive(s, opt, false, prov);
      render_progressive(s, first, false, prov);
      const HitpointSet b = render_progressive(s, opt, true, prov);
      REQUIRE(a.hitpoints.size() == b.hitpoints.size());
      CHECK(std::memcmp(a.hitpoints.data(), b.hitpoints.data(),
                        a.hitpoints.size() * sizeof(pf_hitpoint)) == 0);
      CHECK(a.emitted == b.emitted);
      CHECK(b.passes == 5);
      CHECK(load_hitpoints(opt.checkpoint).estimator == "sppm");
    }
    // A budget that the first pass already spends ends the run there, as a finished run.
    RenderOptions budget = options(e, 50, 2000, 0.f);
    budget.time_budget = 1e-9;
    RenderStatus st;
    render_image(s, budget, &st);
    CHECK(st.passes == 1);
    CHECK(st.budget_reached);
    CHECK_FALSE(st.stopped);
  }
}

TEST_CASE("OpenCL: SPPM and PPPM images equal the CPU backend's", "[sppm][opencl]") {
  auto dev = test::test_device();
  if (!dev) return;
  const Scene s = test::room_scene(PF_MAT_GLASS, 40, 30);
  for (Estimator e : {Estimator::Sppm, Estimator::Pppm})
    for (GatherArea area : {GatherArea::Disc, GatherArea::Surface}) {
      RenderOptions opt = options(e, 6, 4000, 0.f);
      opt.eye.direct = DirectMode::ShadowRays;
      opt.ppm.gather_area = area;
      const Image cpu = render_image(s, opt);
      opt.device = dev.get();
      const Image gpu = render_image(s, opt);
      const double rmse = test::relative_rmse(gpu, cpu);
      INFO(estimator_name(e) << ", gather area " << gather_area_name(area)
                             << ": relative RMSE opencl vs cpu " << rmse);
      CHECK(rmse <= 1e-3);
    }
}

namespace {

// Runs a tool that must succeed.
void ok(const std::string& tool, const std::string& args, const test::TempDir& tmp) {
  const test::ToolRun r = test::run_tool(tool, args, tmp);
  INFO(tool << " " << args << "\n" << r.err);
  REQUIRE(r.exit_code == 0);
}

// Runs a tool that must refuse: exit 2, one line on stderr, and no file at `output`.
void refused(const std::string& tool, const std::string& args, const test::TempDir& tmp,
             const std::string& output, const std::string& needle) {
  const test::ToolRun r = test::run_tool(tool, args, tmp);
  INFO(tool << " " << args << "\n" << r.err);
  CHECK(r.exit_code == 2);
  CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
  CHECK(r.err.find(needle) != std::string::npos);
  CHECK_FALSE(std::filesystem::exists(output));
}

}  // namespace

TEST_CASE("staged route: trace-hitpoints --pass, trace-photons, illuminate --estimator sppm|pppm "
          "give render's image, parts of both routes merge", "[sppm][tools]") {
  test::TempDir tmp("pf-sppm-staged");
  const std::string scene = tmp / "scene.h5";
  ok("scene-bake", test::source_dir() + "/data/cornell-spheres.dae -o " + scene +
                       " --width 24 --height 20", tmp);
  const std::string common = " --scene " + scene + " ";
  for (const std::string e : {"sppm", "pppm"}) {
    std::string state;
    for (int p = 0; p < 3; ++p) {
      const std::string eye = tmp / ("eye" + std::to_string(p) + ".h5");
      const std::string ph = tmp / ("ph" + std::to_string(p) + ".h5");
      const std::string next = tmp / (e + std::to_string(p) + ".h5");
      ok("trace-hitpoints", common + "--estimator " + e + " --pass " + std::to_string(p) +
                                " --direct shadow-rays -o " + eye, tmp);
      ok("trace-photons", common + "--first-pass " + std::to_string(p) +
                              " --passes 1 --photons 3000 -o " + ph, tmp);
      ok("illuminate", common + "--estimator " + e + " --hitpoints " + eye + " --photons " + ph +
                           (state.empty() ? "" : " --state " + state) + " -o " + next, tmp);
      state = next;
    }
    const std::string staged = tmp / (e + "-staged.exr"), rendered = tmp / (e + "-render.exr");
    ok("synthesize", (e == "sppm" ? "--hitpoints " : "--sums ") + state + " -o " + staged, tmp);
    ok("render", common + "--estimator " + e +
                     " --passes 3 --photons 3000 --direct shadow-rays -o " + rendered, tmp);
    const Image a = read_exr(staged), b = read_exr(rendered);
    CHECK(a.rgb == b.rgb);  // the same stage functions: the same bits
    if (e == "pppm") {
      // The staged range [0, 3) and render's [3, 5) are one run's [0, 5).
      const std::string part = tmp / "part35.h5", merged = tmp / "merged.exr";
      ok("render", common + "--estimator pppm --first-pass 3 --passes 2 --photons 3000 "
                            "--direct shadow-rays --sums " + part, tmp);
      ok("merge", state + " " + part + " --range 0:5 -o " + merged, tmp);
      ok("render", common + "--estimator pppm --passes 5 --photons 3000 --direct shadow-rays -o " +
                       rendered, tmp);
      const Image m = read_exr(merged), w = read_exr(rendered);
      CHECK(test::relative_rmse(m, w) < 1e-6);
      // Refusals: a gap, an overlap, another seed, a range not covered; illuminate with the
      // wrong eye pass; a negative budget. One line, exit 2, no output.
      const std::string out = tmp / "bad.exr";
      ok("render", common + "--estimator pppm --first-pass 4 --passes 1 --photons 3000 "
                            "--direct shadow-rays --sums " + tmp / "part4.h5", tmp);
      ok("render", common + "--estimator pppm --first-pass 3 --passes 1 --photons 3000 "
                            "--direct shadow-rays --seed 2 --sums " + tmp / "seed2.h5", tmp);
      refused("merge", state + " " + tmp / "part4.h5" + " -o " + out, tmp, out, "are in no part");
      refused("merge", state + " " + part + " " + tmp / "part4.h5" + " -o " + out, tmp, out,
              "overlap");
      refused("merge", state + " " + tmp / "seed2.h5" + " -o " + out, tmp, out, "seed");
      // The gather area is part of a run's options: a part divided by the disc does not merge
      // with the surface's (the default), whose images differ.
      const std::string disc = tmp / "disc3.h5";
      ok("render", common + "--estimator pppm --first-pass 3 --passes 2 --photons 3000 "
                            "--direct shadow-rays --gather-area disc --sums " + disc, tmp);
      refused("merge", state + " " + disc + " -o " + out, tmp, out, "gather-area");
      const std::string disc_img = tmp / "disc.exr";
      ok("render", common + "--estimator pppm --passes 3 --photons 3000 --direct shadow-rays "
                            "--gather-area disc -o " + disc_img, tmp);
      CHECK(read_exr(disc_img).rgb != b.rgb);
      refused("render", common + "--estimator ppm --gather-area surface -o " + out, tmp, out,
              "--gather-area surface applies to --estimator sppm and pppm");
      refused("render", common + "--gather-area sideways -o " + out, tmp, out, "gather-area");
      refused("illuminate", common + "--estimator ppm --gather-area surface --hitpoints " +
                                tmp / "eye1.h5" + " --photons " + tmp / "ph1.h5" + " -o " + out,
              tmp, out, "--gather-area surface applies");
      refused("merge", state + " --range 0:5 -o " + out, tmp, out, "render the missing passes");
      refused("illuminate", common + "--estimator pppm --hitpoints " + tmp / "eye1.h5" +
                                " --photons " + tmp / "ph2.h5" + " --state " + state + " -o " + out,
              tmp, out, "eye pass 1");
      refused("render", common + "--estimator sppm --time -1 -o " + out, tmp, out, "--time");
      // Values a sums file cannot hold: a negative or NaN sum, passes without photons.
      const std::string edited = tmp / "edited.h5";
      for (double bad : {-1.0, std::nan("")}) {
        std::filesystem::copy_file(part, edited, std::filesystem::copy_options::overwrite_existing);
        test::edit_dataset<double>(edited, "/sum", H5T_NATIVE_DOUBLE,
                                   [&](std::vector<double>& v) { v[7] = bad; });
        refused("synthesize", "--sums " + edited + " -o " + out, tmp, out, "/sum[2]");
        refused("merge", state + " " + edited + " -o " + out, tmp, out, "/sum[2]");
      }
      std::filesystem::copy_file(part, edited, std::filesystem::copy_options::overwrite_existing);
      test::set_int_attr(edited, "/", "photons_emitted", 1);
      refused("synthesize", "--sums " + edited + " -o " + out, tmp, out,
              "photons_emitted = 1 is not the count of");
      refused("render", common + "--estimator sppm --spp 4 -o " + out, tmp, out, "--spp");
    }
  }
}

TEST_CASE("OpenCL: the device's SPPM pass gives sppm_pass's state, bit for bit", "[sppm][opencl]") {
  // The same eye passes and photons on both sides: the host grid gather (sppm_pass) against the
  // device's resident per-pixel state and hashed-grid gather (DevicePpmState::sppm_pass). Bit for
  // bit where the device rounds division and sqrt correctly (PoCL), within 1e-5 elsewhere.
  // Caught: β left out of the device's τ_M, the sites of pixels without a visible point left at
  // the last pass's, pixels reordered between upload and sync.
  auto dev = test::test_device();
  if (!dev) return;
  const Scene s = test::room_scene(PF_MAT_GLASS, 40, 30);
  // Without and with the slab (PpmOptions::slab): the room's walls are one mesh, so its corners
  // have photons of another face inside the sphere, which the slab leaves out.
  const float slab = GENERATE(0.f, 0.25f);
  // And with either gather area (gather_area.h): the surface's factor is folded into β, which
  // the device takes from the host (sppm_sites), so the bits agree.
  const GatherArea area = GENERATE(GatherArea::Disc, GatherArea::Surface);
  INFO("slab " << slab << ", gather area " << gather_area_name(area));
  HitpointSet cpu = make_sppm_state(s, default_radius(s), DirectMode::ShadowRays), gpu = cpu;
  HitpointSet sphere = cpu;  // the CPU without the slab, to see that the slab changes something
  DevicePpmState on_device(s, gpu, *dev);
  PpmOptions ppm;
  ppm.slab = slab;
  ppm.gather_area = area;
  PpmOptions no_slab;
  no_slab.gather_area = area;
  for (uint32_t pass = 0; pass < 4; ++pass) {
    EyePassOptions eo;
    eo.pass = pass;
    eo.sampler = PixelSampler::Sobol;
    eo.direct = DirectMode::ShadowRays;
    EyePassResult eye = trace_hitpoints(s, eo);
    // The closed room shows a diffuse surface in every pixel: drop a different seventh of the
    // visible points each pass, as paths that end on no diffuse surface would.
    std::vector<pf_hitpoint> kept;
    for (size_t i = 0; i < eye.hitpoints.size(); ++i)
      if (i % 7 != pass) kept.push_back(eye.hitpoints[i]);
    eye.hitpoints = kept;
    PhotonPassOptions po;
    po.photons = 4000;
    const PhotonPassResult ph = trace_photons(s, pass, po);
    PhotonGridParams gp;
    gp.default_radius = cpu.radius0;
    gp.max_bins = ppm.max_bins;
    const PhotonGrid grid = build_photon_grid(ph.photons, int(s.mesh_names.size()), gp);
    sppm_pass(s, cpu, eye, grid, ph.emitted, ppm);
    sppm_pass(s, sphere, eye, grid, ph.emitted, no_slab);
    on_device.sppm_pass(eye, ph.photons, ph.emitted, ppm);
  }
  on_device.sync();
  size_t changed = 0;  // pixels where the slab left photons out
  for (size_t i = 0; i < cpu.hitpoints.size(); ++i)
    changed += cpu.hitpoints[i].n_photons != sphere.hitpoints[i].n_photons ? 1 : 0;
  CHECK((slab > 0.f) == (changed > 0));
  REQUIRE(gpu.passes == 4);
  CHECK(gpu.photons_emitted == cpu.photons_emitted);
  CHECK(gpu.estimator == "sppm");
  CHECK(gpu.emitted == cpu.emitted);
  CHECK(gpu.direct == cpu.direct);
  size_t gathered = 0;
  double worst = 0;
  for (size_t i = 0; i < cpu.hitpoints.size(); ++i) {
    const pf_hitpoint &a = cpu.hitpoints[i], &b = gpu.hitpoints[i];
    gathered += a.n_photons > 0 ? 1 : 0;
    CHECK(a.mesh == b.mesh);
    worst = std::max({worst, std::fabs(double(a.radius) - b.radius) / a.radius,
                      std::fabs(double(a.n_photons) - b.n_photons)});
    for (int c = 0; c < 3; ++c)
      worst = std::max(worst, std::fabs(double(a.flux[c]) - b.flux[c]) / (std::fabs(a.flux[c]) + 1e-30));
  }
  INFO("largest relative difference " << worst << "; " << gathered << " pixels gathered");
  CHECK(gathered > cpu.hitpoints.size() / 2);
  if (!cl_float_options(dev->info().device_id).empty())
    CHECK(std::memcmp(cpu.hitpoints.data(), gpu.hitpoints.data(),
                      cpu.hitpoints.size() * sizeof(pf_hitpoint)) == 0);
  CHECK(worst <= 1e-5);
}

TEST_CASE("OpenCL: the device's PPPM gather gives pppm_pass's sums", "[sppm][opencl][pppm]") {
  // The same eye passes and photons: pppm_pass's host grid gather against pppm_gather_device's
  // hashed grid (α = 1 over fresh states: N = M, τ = β·τ_M). Equal sums where the device rounds
  // like the host (PoCL), within 1e-6 relative elsewhere. Caught: the pass radius r_i off by a
  // pass, β left out, the visible points' order lost.
  auto dev = test::test_device();
  if (!dev) return;
  const Scene s = test::room_scene(PF_MAT_GLASS, 40, 30);
  const RenderOptions opt = options(Estimator::Pppm, 3, 4000, 0.f);
  PassSums cpu = make_pass_sums(40, 30, 0, default_radius(s), 0.7f, DirectMode::Photons,
                                s.scene_id, state_parameters(opt)),
           gpu = cpu;
  PassSums sphere = cpu;  // the CPU without the slab
  const float slab = GENERATE(0.f, 0.25f);
  const GatherArea area = GENERATE(GatherArea::Disc, GatherArea::Surface);
  INFO("slab " << slab << ", gather area " << gather_area_name(area));
  PpmOptions ppm;
  ppm.slab = slab;
  ppm.gather_area = area;
  PpmOptions no_slab;
  no_slab.gather_area = area;
  for (uint32_t pass = 0; pass < 3; ++pass) {
    EyePassOptions eo;
    eo.pass = pass;
    eo.sampler = PixelSampler::Sobol;
    eo.spp = 2;  // two visible points per pixel: both add to it
    const EyePassResult eye = trace_hitpoints(s, eo);
    PhotonPassOptions po;
    po.photons = 4000;
    const PhotonPassResult ph = trace_photons(s, pass, po);
    PhotonGridParams gp;
    gp.default_radius = cpu.radius1;
    const PhotonGrid grid = build_photon_grid(ph.photons, int(s.mesh_names.size()), gp);
    pppm_pass(s, cpu, eye, grid, ph.emitted, ppm);
    pppm_pass(s, sphere, eye, grid, ph.emitted, no_slab);
    ClBuffer buf = dev->buffer(ph.photons.size() * sizeof(pf_photon), ph.photons.data());
    const DevicePhotons dp{&buf, ph.photons.size(), ph.emitted};
    pppm_accumulate(gpu, eye,
                    pppm_gather_device(s, eye, pppm_pass_radius(gpu), gpu.direct_mode, dp, ppm, *dev),
                    ph.emitted);
  }
  REQUIRE(gpu.passes == 3);
  double worst = 0, scale = 0;
  for (size_t j = 0; j < cpu.sum.size(); ++j) {
    worst = std::max(worst, std::fabs(cpu.sum[j] - gpu.sum[j]));
    scale = std::max(scale, std::fabs(cpu.sum[j]));
  }
  INFO("largest difference " << worst << " of sums up to " << scale);
  REQUIRE(scale > 0);
  CHECK((slab > 0.f) == (cpu.sum != sphere.sum));
  if (!cl_float_options(dev->info().device_id).empty()) CHECK(cpu.sum == gpu.sum);
  CHECK(worst <= 1e-6 * scale);
}

TEST_CASE("slab: photons of another face of the same mesh are left out, the site's own plane kept",
          "[sppm][slab]") {
  // A visible point x on a block's front face (plane z = 0, normal +z) just below the top edge
  // (y = 0.1 R); the top face is the plane y = 0.1 R behind it (z < 0), the same mesh. Photons:
  // A on the front face (depth 0), B on the top face 0.5 R deep, C on the top face 0.2 R deep, all
  // inside the sphere and arriving against the normal. The sphere gathers all three; the slab
  // κ = 0.25 leaves out B alone (|n·(x − x_p)| = 0.5 R > κ R), and the boundary counts as inside.
  const Scene s = floor_scene(0.5f, 1.f, 1.f, 8);  // one diffuse material for f_r
  const float R = 0.1f;
  auto photon = [](float x, float y, float z, float dy, float dz, float flux) {
    pf_photon p{};
    p.position[0] = x;
    p.position[1] = y;
    p.position[2] = z;
    p.dir[1] = dy;
    p.dir[2] = dz;
    p.flux[0] = p.flux[1] = p.flux[2] = flux;
    p.mesh = 0;
    return p;
  };
  const std::vector<pf_photon> photons = {
      photon(0.1f * R, -0.2f * R, 0.f, 0.f, -1.f, 1.f),         // A: the front face
      photon(0.f, 0.1f * R, -0.5f * R, -0.6f, -0.8f, 10.f),     // B: the top face, deep
      photon(0.f, 0.1f * R, -0.2f * R, -0.6f, -0.8f, 100.f)};   // C: the top face, shallow
  PhotonGridParams gp;
  gp.default_radius = R;
  const PhotonGrid grid = build_photon_grid(photons, 1, gp);
  pf_hitpoint site{};
  site.normal[2] = 1.f;
  site.mesh = 0;
  site.material = 0;
  float tau[3];
  const double fr = 0.5 / kPi;
  CHECK(gather_site(s, grid, site, R, false, 0.f, tau) == 3);
  CHECK(tau[0] == Approx(fr * 111.0).epsilon(1e-6));
  CHECK(gather_site(s, grid, site, R, false, 0.25f, tau) == 2);
  CHECK(tau[0] == Approx(fr * 101.0).epsilon(1e-6));
  CHECK(gather_site(s, grid, site, R, false, 0.5f, tau) == 3);  // B at exactly 0.5 R: inside
  CHECK(gather_site(s, grid, site, R, false, 0.1f, tau) == 1);  // A alone
  // The options: auto is 0.25 for sppm and pppm and 0 for ppm; ppm refuses a slab; a negative or
  // non-numeric slab is one line naming --slab.
  CHECK(parse_slab("auto", true) == kDefaultSlab);
  CHECK(parse_slab("auto", false) == 0.f);
  CHECK(parse_slab("0.5", true) == 0.5f);
  CHECK(parse_slab("0", false) == 0.f);
  for (const auto& [text, new_eye] : std::vector<std::pair<std::string, bool>>{
           {"0.25", false}, {"-1", true}, {"nan", true}, {"inf", true}, {"x", true}, {"0.2x", true}}) {
    INFO(text);
    try {
      parse_slab(text, new_eye);
      FAIL("accepted");
    } catch (const InputError& e) {
      CHECK(std::string(e.what()).find("--slab") != std::string::npos);
    }
  }
  // A state records its slab: a checkpoint of another slab is not resumed, parts of another slab
  // do not merge (state_parameters).
  RenderOptions a = options(Estimator::Sppm, 1, 100, 0.f), b = a;
  a.ppm.slab = 0.25f;
  CHECK(state_parameters(a).at("slab") == "0.25");
  CHECK(state_parameters(a) != state_parameters(b));
  RenderOptions ppm = options(Estimator::Ppm, 1, 100, 0.f);
  CHECK(state_parameters(ppm).count("slab") == 0);
  ppm.ppm.slab = 0.25f;
  CHECK_THROWS_AS(check_options(ppm), InputError);
}

TEST_CASE("glossy merge option: auto by estimator and direct light, checked, recorded only where "
          "eye paths use it, and read back from the staged eye pass",
          "[sppm][glossy-merge]") {
  const DirectMode rays = DirectMode::ShadowRays, photons_mode = DirectMode::Photons;
  CHECK(parse_glossy_merge_option("auto", Estimator::Sppm, rays) == kDefaultGlossyMerge);
  CHECK(parse_glossy_merge_option("auto", Estimator::Pppm, rays) == kDefaultGlossyMerge);
  // ppm's one eye pass never converges a continuation; photons that carry direct light would
  // count the glossy vertex's next-event estimate twice
  CHECK(parse_glossy_merge_option("auto", Estimator::Ppm, rays) == GlossyMerge::First);
  CHECK(parse_glossy_merge_option("auto", Estimator::Pppm, photons_mode) == GlossyMerge::First);
  CHECK(parse_glossy_merge_option("first", Estimator::Ppm, rays) == GlossyMerge::First);
  CHECK(parse_glossy_merge_option("mis", Estimator::Sppm, rays) == GlossyMerge::Mis);
  CHECK_THROWS_AS(parse_glossy_merge_option("mis", Estimator::Ppm, rays), InputError);
  for (const std::string text : {"", "x", "0.3", "MIS"}) {
    INFO("'" << text << "'");
    CHECK_THROWS_AS(parse_glossy_merge_option(text, Estimator::Sppm, rays), InputError);
  }
  EyePassOptions eo;
  eo.glossy = GlossyMerge::Mis;
  eo.direct = DirectMode::Photons;
  CHECK_THROWS_AS(check_options(eo), InputError);
  eo.direct = DirectMode::ShadowRays;
  CHECK_NOTHROW(check_options(eo));
  // A state records the rule when it is not "first", so that a checkpoint or pppm part of
  // another one is not continued or merged with it; runs without it keep their parameters.
  RenderOptions a = options(Estimator::Pppm, 1, 100, 0.f), b = a;
  CHECK(state_parameters(a).count("glossy-merge") == 0);
  a.eye.glossy = GlossyMerge::Mis;
  CHECK(state_parameters(a).at("glossy-merge") == "mis");
  CHECK(state_parameters(a) != state_parameters(b));
  // The staged route (trace-hitpoints records it when it is used) gives render's parameters.
  Provenance eye, photons;
  eye.parameters = {{"spp", "1"}, {"max-depth", "16"}, {"direct", "photons"},
                    {"shadow-samples", "4"}, {"radius", "0"}, {"seed", "1"},
                    {"pixel-sampler", "sobol"}};
  photons.parameters = {{"photons", "100"}, {"max-bounces", "16"}, {"seed", "1"}};
  a.eye.direct = b.eye.direct = DirectMode::Photons;
  a.eye.sampler = b.eye.sampler = PixelSampler::Sobol;
  const auto staged = [&](const Provenance& e) {
    return staged_state_parameters(Estimator::Pppm, e, "eye.h5", photons, "photons.h5",
                                   b.ppm.alpha, b.ppm.slab, b.ppm.gather_area);
  };
  CHECK(staged(eye) == state_parameters(b));
  eye.parameters["glossy-merge"] = "mis";
  CHECK(staged(eye) == state_parameters(a));
}

TEST_CASE("trace_hitpoints_into: reused buffers give trace_hitpoints' result, pass after pass",
          "[sppm][eye]") {
  // The per-pass eye pass of sppm and pppm keeps its vectors (EyePassResult, EyePassWork) from
  // call to call; rows left longer by an earlier call (more samples, more visible points) must
  // not leak into a later one.
  const Scene s = test::room_scene(PF_MAT_GLASS, 24, 18);
  EyePassResult reused;
  EyePassWork work;
  for (const auto& [pass, spp] : std::vector<std::pair<uint32_t, int>>{{0, 4}, {1, 1}, {2, 2}, {0, 4}}) {
    INFO("pass " << pass << ", spp " << spp);
    EyePassOptions eo;
    eo.pass = pass;
    eo.spp = spp;
    eo.sampler = PixelSampler::Sobol;
    eo.direct = DirectMode::ShadowRays;
    trace_hitpoints_into(s, eo, reused, work);
    const EyePassResult fresh = trace_hitpoints(s, eo);
    REQUIRE(reused.hitpoints.size() == fresh.hitpoints.size());
    CHECK(test::same_hitpoints(reused.hitpoints, fresh.hitpoints));
    CHECK(reused.emitted == fresh.emitted);
    CHECK(reused.direct == fresh.direct);
    CHECK(reused.width == fresh.width);
    CHECK(reused.radius == fresh.radius);
  }
}

namespace {

// One pass's inputs for the traced-versus-staged comparisons below: eye options of pass `pass`
// (at most 3 specular bounces), that pass's photons and their grid.
struct PassInputs {
  EyePassOptions eye;
  PhotonPassResult photons;
  PhotonGrid grid;
};
PassInputs pass_inputs(const Scene& s, uint32_t pass, DirectMode mode, PixelSampler sampler,
                       int spp, int threads, uint32_t photons, float radius0) {
  PassInputs in;
  in.eye.pass = pass;
  in.eye.spp = spp;
  in.eye.sampler = sampler;
  in.eye.direct = mode;
  in.eye.max_depth = 3;
  in.eye.threads = threads;
  PhotonPassOptions po;
  po.photons = photons;
  in.photons = trace_photons(s, pass, po);
  PhotonGridParams gp;
  gp.default_radius = radius0;
  in.grid = build_photon_grid(in.photons.photons, int(s.mesh_names.size()), gp);
  return in;
}

}  // namespace

TEST_CASE("sppm_pass_traced: tracing as it gathers gives trace_hitpoints_into + sppm_pass, bit "
          "for bit", "[sppm][eye]") {
  // render's CPU route (sppm_pass_traced, no eye pass kept) against the staged route's two
  // steps, on a room with a glass ball (specular chains, pixels without a visible point when the
  // chain runs out of depth), both direct modes, both pass samplers and 1 or 2 threads.
  // Caught: the emitted layer averaged before the pass's light was added, the state's geometry
  // left at the last pass's, the eye stream's key reused across passes.
  const Scene s = test::room_scene(PF_MAT_GLASS, 32, 24);
  const DirectMode mode = GENERATE(DirectMode::Photons, DirectMode::ShadowRays);
  const PixelSampler sampler = GENERATE(PixelSampler::Sobol, PixelSampler::Random);
  const int threads = GENERATE(1, 2);
  const GatherArea area = GENERATE(GatherArea::Disc, GatherArea::Surface);
  INFO(direct_mode_name(mode) << ", " << pixel_sampler_name(sampler) << ", " << threads
                              << " threads, gather area " << gather_area_name(area));
  HitpointSet staged = make_sppm_state(s, default_radius(s), mode), traced = staged;
  PpmOptions ppm;
  ppm.slab = kDefaultSlab;
  ppm.threads = threads;
  ppm.gather_area = area;
  EyePassResult eye;
  EyePassWork work;
  for (uint32_t pass = 0; pass < 4; ++pass) {
    const PassInputs in = pass_inputs(s, pass, mode, sampler, 1, threads, 6000, staged.radius0);
    trace_hitpoints_into(s, in.eye, eye, work);
    sppm_pass(s, staged, eye, in.grid, in.photons.emitted, ppm);
    sppm_pass_traced(s, traced, in.eye, in.grid, in.photons.emitted, ppm);
  }
  REQUIRE(traced.passes == 4);
  CHECK(traced.photons_emitted == staged.photons_emitted);
  CHECK(std::memcmp(traced.hitpoints.data(), staged.hitpoints.data(),
                    staged.hitpoints.size() * sizeof(pf_hitpoint)) == 0);
  CHECK(traced.emitted == staged.emitted);
  CHECK(traced.direct == staged.direct);
  size_t gathered = 0;
  for (const pf_hitpoint& h : traced.hitpoints) gathered += h.n_photons > 0 ? 1 : 0;
  CHECK(gathered > traced.hitpoints.size() / 2);  // the comparison saw gathers
  // An eye pass of another pass or direct mode than the state's is a programming error.
  EyePassOptions wrong;
  wrong.pass = 7;
  wrong.direct = mode;
  PhotonGrid none;
  CHECK_THROWS_AS(sppm_pass_traced(s, traced, wrong, none, 0, ppm), std::invalid_argument);
}

TEST_CASE("gather_site: four photons at a time from the position arrays, or one at a time, "
          "accept the same photons", "[sppm][gather]") {
  // A grid loaded or assembled without PhotonGrid::pos_x/y/z gathers photon by photon; both ways
  // must give the same m and τ_M at every site, with and without the slab and direct photons.
  const Scene s = test::room_scene(PF_MAT_DIFFUSE, 24, 18);
  PhotonPassOptions po;
  po.photons = 20000;
  const PhotonPassResult ph = trace_photons(s, 0, po);
  PhotonGridParams gp;
  gp.default_radius = default_radius(s);
  const PhotonGrid four = build_photon_grid(ph.photons, int(s.mesh_names.size()), gp);
  REQUIRE(four.has_positions());
  PhotonGrid one = four;
  one.pos_x.clear();
  REQUIRE_FALSE(one.has_positions());
  EyePassOptions eo;
  const EyePassResult eye = trace_hitpoints(s, eo);
  size_t sites = 0, photons = 0;
  for (float slab : {0.f, 0.25f})
    for (bool skip_direct : {false, true})
      for (const pf_hitpoint& v : eye.hitpoints)
        for (float r : {0.5f * gp.default_radius, 2.f * gp.default_radius}) {
          float a[3], b[3];
          const int ma = gather_site(s, four, v, r, skip_direct, slab, a);
          const int mb = gather_site(s, one, v, r, skip_direct, slab, b);
          CHECK(ma == mb);
          CHECK(std::memcmp(a, b, sizeof a) == 0);
          sites += ma > 0 ? 1 : 0;
          photons += size_t(ma);
        }
  CHECK(sites > eye.hitpoints.size());  // most sites gathered something
  CHECK(photons > 10 * sites);
}

TEST_CASE("pppm_pass_traced: tracing as it gathers gives trace_hitpoints_into + pppm_pass, bit "
          "for bit", "[sppm][pppm][eye]") {
  // As for SPPM above; PPPM also takes several samples per pixel, whose β·τ_M a pixel's sum
  // takes in sample order after its L_d.
  const Scene s = test::room_scene(PF_MAT_GLASS, 32, 24);
  const DirectMode mode = GENERATE(DirectMode::Photons, DirectMode::ShadowRays);
  const int spp = GENERATE(1, 3);
  const int threads = GENERATE(1, 2);
  const GatherArea area = GENERATE(GatherArea::Disc, GatherArea::Surface);
  INFO(direct_mode_name(mode) << ", spp " << spp << ", " << threads << " threads, gather area "
                              << gather_area_name(area));
  PassSums staged = make_pass_sums(s.camera.width, s.camera.height, 0, default_radius(s), 0.7f,
                                   mode, s.scene_id, {});
  PassSums traced = staged;
  PpmOptions ppm;
  ppm.slab = kDefaultSlab;
  ppm.threads = threads;
  ppm.gather_area = area;
  EyePassResult eye;
  EyePassWork work;
  for (uint32_t pass = 0; pass < 4; ++pass) {
    // Pass 2 has no photons: its pixels add their L_d alone.
    const PassInputs in = pass_inputs(s, pass, mode, PixelSampler::Sobol, spp, threads,
                                      pass == 2 ? 0 : 6000, staged.radius1);
    trace_hitpoints_into(s, in.eye, eye, work);
    pppm_pass(s, staged, eye, in.grid, in.photons.emitted, ppm);
    pppm_pass_traced(s, traced, in.eye, in.grid, in.photons.emitted, ppm);
  }
  REQUIRE(traced.passes == 4);
  CHECK(traced.photons_emitted == staged.photons_emitted);
  CHECK(traced.sum == staged.sum);
  double total = 0;
  for (double v : traced.sum) total += v;
  CHECK(total > 0);
  EyePassOptions wrong;
  wrong.pass = 2;  // the sums' next pass is 4
  wrong.direct = mode;
  PhotonGrid none;
  CHECK_THROWS_AS(pppm_pass_traced(s, traced, wrong, none, 0, ppm), std::invalid_argument);
}

TEST_CASE("gather_site: τ_M is the sum in original photon order, also where the order of the "
          "terms changes it", "[sppm][gather]") {
  // gather_site sums in the candidates' order when that sum is exact in double (then every
  // order gives it) and sorts by original photon index otherwise. Random fluxes spread over up
  // to 70 binades must give the sum in original index order; and one site is built so that the
  // order decides the float: terms 1, 2^-24 (half a float ulp of 1) and 512 × 2^-60 sum exactly
  // to 1 + 2^-24 + 2^-51, which rounds up to 1 + 2^-23; taken big first (the grid's order here)
  // the tiny terms vanish in double and 1 + 2^-24 ties down to 1. Checked to fail when the
  // exactness test always passes.
  Scene s = test::room_scene(PF_MAT_DIFFUSE, 8, 8);
  // A diffuse colour whose f_r = colour / π is exactly 1/4 in float, so each term is flux / 4.
  float c = 0.78f;
  while (!(c * kInvPi >= 0.25f)) c = std::nextafter(c, 1.f);
  REQUIRE(c * kInvPi == 0.25f);
  s.materials[0].color[0] = s.materials[0].color[1] = s.materials[0].color[2] = c;
  const Vec3 fr = Vec3(s.materials[0].color) * kInvPi;
  auto photon = [](float x, float z, float flux) {
    pf_photon p{};
    p.position[0] = x;
    p.position[2] = z;
    p.dir[1] = -1.f;  // arriving from above
    p.flux[0] = p.flux[1] = p.flux[2] = flux;
    return p;
  };
  PhotonGridParams gp;
  gp.default_radius = 0.01f;
  pf_hitpoint site{};
  site.normal[1] = 1.f;
  site.mesh = 0;
  site.material = 0;

  SECTION("random fluxes") {
    std::mt19937 rng(25);
    std::uniform_real_distribution<float> u(0.f, 1.f);
    std::vector<pf_photon> photons;
    for (int i = 0; i < 600; ++i)  // a 0.2 × 0.2 patch of the plane y = 0: many bins
      photons.push_back(photon(0.2f * u(rng), 0.2f * u(rng),
                               std::ldexp(0.5f + u(rng), -int(70.f * u(rng) * u(rng)))));
    const PhotonGrid grid = build_photon_grid(photons, int(s.mesh_names.size()), gp);
    size_t sites = 0;
    for (int i = 0; i < 40; ++i) {
      site.position[0] = 0.2f * u(rng);
      site.position[2] = 0.2f * u(rng);
      const float r = 0.02f + 0.08f * u(rng);
      double ref = 0;
      int inside = 0;
      for (const pf_photon& p : photons) {  // original order
        const float dx = site.position[0] - p.position[0], dz = site.position[2] - p.position[2];
        if (!(dx * dx + 0.f * 0.f + dz * dz <= r * r)) continue;
        ++inside;
        ref += double(fr.x * p.flux[0]);
      }
      float tau[3];
      REQUIRE(gather_site(s, grid, site, r, false, 0.f, tau) == inside);
      CHECK(tau[0] == float(ref));
      sites += inside > 0 ? 1 : 0;
    }
    CHECK(sites >= 30);
  }
  SECTION("a sum the order decides") {
    std::vector<pf_photon> photons;
    for (int i = 0; i < 512; ++i)  // first in original order, in a later bin than the big two
      photons.push_back(photon(0.05f, 0.001f, 4.f * std::ldexp(1.f, -60)));
    photons.push_back(photon(0.001f, 0.001f, 4.f * std::ldexp(1.f, -24)));
    photons.push_back(photon(0.001f, 0.001f, 4.f));
    const PhotonGrid grid = build_photon_grid(photons, int(s.mesh_names.size()), gp);
    REQUIRE(grid.order.back() < 512);  // the grid lists the big two first
    site.position[0] = 0.025f;
    site.position[2] = 0.001f;
    float tau[3];
    REQUIRE(gather_site(s, grid, site, 0.04f, false, 0.f, tau) == 514);
    const float up = std::nextafter(1.f, 2.f);  // 1 + 2^-23
    CHECK(tau[0] == up);
    CHECK(tau[1] == up);
    CHECK(tau[2] == up);
  }
}
