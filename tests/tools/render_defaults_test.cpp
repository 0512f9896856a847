// render's defaults by measurement (render_defaults.h, issue 34 item 1): the rule of the automatic
// photon count and radius, what --help says, what the run record and the summary line say, that
// every choice is overridable, and that trace-photons, trace-hitpoints and illuminate take the
// same defaults as render (their --help and their run records).
#include <catch2/catch.hpp>

#include <cmath>
#include <nlohmann/json.hpp>

#include "photonflow/foundations/options.h"
#include "photonflow/estimators/pass_sums.h"
#include "photonflow/estimators/render_defaults.h"
#include "photonflow/io/stage_files.h"
#include "photonflow/geometry/scene_file.h"
#include "support.h"

using namespace pf;

namespace {

std::string q(const std::string& s) { return "'" + s + "'"; }

std::map<std::string, std::string> record_parameters(const std::string& file) {
  const nlohmann::json j = nlohmann::json::parse(test::file_bytes(file));
  std::map<std::string, std::string> out;
  for (const auto& [k, v] : j.at("parameters").items()) out[k] = v.get<std::string>();
  return out;
}

// render with nothing but the scene, the passes, the output (plain.exr) and its record
// (plain.json): every choice automatic.
test::ToolRun plain_render(test::TempDir& tmp, const std::string& scene, int passes) {
  return test::run_tool("render", "--scene " + q(scene) + " --passes " + std::to_string(passes) +
                                      " -o " + q(tmp / "plain.exr") + " --stats " +
                                      q(tmp / "plain.json"),
                        tmp);
}

// The staged route with no estimator, direct light, photon count or shadow samples:
// trace-hitpoints and illuminate default to render's, trace-photons to its count; pass p > 0
// names only its pass and the state before it. Returns synthesize's image of `passes` passes.
Image staged_image(test::TempDir& tmp, const std::string& scene, int passes) {
  std::string state;
  for (int p = 0; p < passes; ++p) {
    const std::string eye = tmp / ("eye" + std::to_string(p) + ".h5");
    const std::string ph = tmp / ("ph" + std::to_string(p) + ".h5");
    const std::string next = tmp / ("sums" + std::to_string(p) + ".h5");  // pppm's pass sums
    REQUIRE(test::run_tool("trace-hitpoints", "--scene " + q(scene) +
                                                  (p > 0 ? " --pass " + std::to_string(p) : "") +
                                                  " -o " + q(eye),
                           tmp)
                .exit_code == 0);
    REQUIRE(test::run_tool("trace-photons", "--scene " + q(scene) + " --first-pass " +
                                                std::to_string(p) + " -o " + q(ph),
                           tmp)
                .exit_code == 0);
    REQUIRE(test::run_tool("illuminate", "--scene " + q(scene) + " --hitpoints " +
                                             q(eye) + " --photons " + q(ph) +
                                             (state.empty() ? "" : " --state " + q(state)) +
                                             " -o " + q(next),
                           tmp)
                .exit_code == 0);
    state = next;
  }
  REQUIRE(test::run_tool("synthesize", "--sums " + q(state) + " -o " + q(tmp / "staged.exr"),
                         tmp)
              .exit_code == 0);
  return read_exr(tmp / "staged.exr");
}

// Runs of white space (cxxopts' line wrapping and column padding) as one space.
std::string squeeze(const std::string& text) {
  std::string out;
  for (char c : text) {
    const bool space = c == ' ' || c == '\n' || c == '\t';
    if (space && !out.empty() && out.back() == ' ') continue;
    out += space ? ' ' : c;
  }
  return out;
}

// The help text of one option (its line and the continuation lines up to the next option).
std::string help_of(const std::string& help, const std::string& option) {
  const size_t at = help.find("--" + option + " ");
  if (at == std::string::npos) return "";
  const size_t next = help.find("\n  -", at);
  return squeeze(help.substr(at, next == std::string::npos ? std::string::npos : next - at));
}

// The automatic radius as eye_pass.h documents it, computed here from the scene: 2 × the
// footprint rule where every triangle is diffuse or an emitter, 1.5 × with a mirror, glass or PBR
// material (eye_pass.h kRadiusScale and kRadiusScaleDiffuse, RESULTS.md section 8).
float expected_radius(const Scene& s) {
  bool diffuse_only = true;
  for (const pf_triangle& t : s.triangles) {
    const int type = s.materials[size_t(t.material)].type;
    diffuse_only = diffuse_only && (type == PF_MAT_DIFFUSE || type == PF_MAT_EMITTER);
  }
  const Vec3 e(s.camera.eye), l(s.camera.look_at);
  const float dist = length(l - e);
  const float pixel_angle = 2.f * std::tan(s.camera.fov_y_deg * 0.5f * 3.14159265f / 180.f) /
                            float(s.camera.height);
  return (diffuse_only ? 2.f : 1.5f) * std::max(length(s.bounds.extent()) / 200.f, 4.f * pixel_angle * dist);
}

}  // namespace

TEST_CASE("the automatic photon count follows its rule: share, measured ratio, pixels",
          "[render_defaults]") {
  // The rule with the measured constants (render_defaults.h, docs/RESULTS.md "Defaults"): an eye
  // pixel costs 0.7 photons, photons take 2/3 of the pass: 1.4 photons per pixel. A change of the
  // constants must change this test and RESULTS.md together.
  CHECK(kAutoPhotonShare == 2.0 / 3.0);
  CHECK(kEyePixelCostInPhotons == 0.7);
  CHECK(auto_photons(512, 512) == 366592);    // 367001.6 → 358.4 → 358 steps of 1024
  CHECK(auto_photons(640, 480) == 430080);    // 430080 = 420 steps
  CHECK(auto_photons(1280, 720) == 1290240);  // 1260 steps
  // A multiple of the step, rounded to the nearest: 333 × 333 × 1.4 = 155244.6 → 151.6 steps.
  CHECK(auto_photons(333, 333) == 152 * kAutoPhotonsStep);
  // Clamped: small images still get a useful photon map, huge ones a bounded pass.
  CHECK(auto_photons(16, 12) == kMinAutoPhotons);
  CHECK(auto_photons(100000, 100000) == kMaxAutoPhotons);
  // The same size, the same count (no timing at run time).
  CHECK(auto_photons(512, 512) == auto_photons(512, 512));
  const std::string rule = auto_photons_rule();
  CHECK(rule.rfind("auto: ", 0) == 0);
  CHECK(rule.find("366592 at 512x512") != std::string::npos);
}

TEST_CASE("choose_defaults: pppm with shadow rays, photons from the image, radius from the "
          "scene's extent and the pixel footprint",
          "[render_defaults]") {
  // Two scenes of different extent and camera: a unit-sphere furnace seen from its centre and the
  // unit room, at different image sizes.
  const Scene furnace = test::furnace_scene(0.5f, 1.f, 64);
  const Scene room = test::room_scene(PF_MAT_GLASS, 800, 600);
  const RenderDefaults a = choose_defaults(furnace), b = choose_defaults(room);
  CHECK(a.estimator == Estimator::Pppm);
  CHECK(a.direct == DirectMode::ShadowRays);
  CHECK(a.photons == kMinAutoPhotons);  // 64 × 64 = 4096 pixels: below the floor
  CHECK(b.photons == 671744);           // 800 × 600 × 1.4 = 672000 → 656 steps of 1024
  CHECK(a.radius == Approx(expected_radius(furnace)).epsilon(1e-5));
  CHECK(b.radius == Approx(expected_radius(room)).epsilon(1e-5));
  CHECK(a.radius != Approx(b.radius));
  // The radius grows with the scene: the room scaled by 10 (extent and camera alike).
  Scene big = test::room_scene(PF_MAT_GLASS, 800, 600);
  for (auto& t : big.triangles)
    for (float* v : {t.v0, t.v1, t.v2})
      for (int c = 0; c < 3; ++c) v[c] *= 10.f;
  for (int c = 0; c < 3; ++c) {
    big.camera.eye[c] *= 10.f;
    big.camera.look_at[c] *= 10.f;
  }
  finish_scene(big);
  CHECK(choose_defaults(big).radius == Approx(10.f * b.radius).epsilon(1e-4));
  CHECK(choose_defaults(big).photons == b.photons);
  // The same room with a diffuse block instead of the glass one: diffuse surfaces only, the
  // radius 2/1.5 of the glass room's (the caustics that mirrors and glass focus want it small).
  const Scene diffuse = test::room_scene(PF_MAT_DIFFUSE, 800, 600);
  CHECK(radius_scale(diffuse) == kRadiusScaleDiffuse);
  CHECK(radius_scale(room) == kRadiusScale);
  CHECK(choose_defaults(diffuse).radius == Approx(b.radius * 2.f / 1.5f).epsilon(1e-5));
  CHECK(choose_defaults(diffuse).radius == Approx(expected_radius(diffuse)).epsilon(1e-5));
}

TEST_CASE("render: --help, the run record and the summary say the defaults used, every one "
          "is overridable",
          "[render_defaults]") {
  test::TempDir tmp("render-defaults");
  const std::string dae = test::source_dir() + "/data/cornell-box.dae";
  REQUIRE(test::run_tool("scene-bake", q(dae) + " -o " + q(tmp / "s.h5") +
                                           " --width 256 --height 192",
                         tmp)
              .exit_code == 0);
  const Scene scene = load_scene(tmp / "s.h5");
  const uint32_t photons = auto_photons(256, 192);
  REQUIRE(photons == 68608);  // 49152 pixels × 1.4 = 68812.8 → 67 steps of 1024

  const auto help = test::run_tool("render", "--help", tmp);
  REQUIRE(help.exit_code == 0);
  CHECK(help_of(help.out, "estimator").find("(default: pppm)") != std::string::npos);
  CHECK(help_of(help.out, "direct").find("(default: shadow-rays)") != std::string::npos);
  CHECK(help_of(help.out, "photons").find(auto_photons_rule()) != std::string::npos);
  CHECK(help_of(help.out, "photons").find("(default: auto)") != std::string::npos);
  CHECK(help_of(help.out, "radius").find(auto_radius_rule()) != std::string::npos);
  CHECK(help_of(help.out, "radius").find("(default: auto)") != std::string::npos);
  CHECK(help_of(help.out, "emission-spp").find("auto: " + std::to_string(kDefaultEmissionSpp)) !=
        std::string::npos);
  CHECK(help_of(help.out, "shadow-samples")
            .find("auto: " + std::to_string(kDefaultShadowSamples) + " for sppm and pppm") !=
        std::string::npos);
  CHECK(help_of(help.out, "shadow-samples").find("(default: auto)") != std::string::npos);
  CHECK(help_of(help.out, "gather-area").find("auto = surface for sppm and pppm") !=
        std::string::npos);
  CHECK(help_of(help.out, "gather-area").find("(default: auto)") != std::string::npos);

  SECTION("no options: the automatic choices") {
    const auto r = test::run_tool("render", "--scene " + q(tmp / "s.h5") + " -o " +
                                                q(tmp / "a.exr") + " --passes 2 --stats " +
                                                q(tmp / "a.json"),
                                  tmp);
    INFO(r.err);
    REQUIRE(r.exit_code == 0);
    const auto p = record_parameters(tmp / "a.json");
    CHECK(p.at("estimator") == "pppm");
    CHECK(p.at("estimator_auto") == "true");
    CHECK(p.at("direct") == "shadow-rays");
    CHECK(p.at("direct_auto") == "true");
    CHECK(p.at("photons") == std::to_string(photons));
    CHECK(p.at("photons_auto") == "true");
    CHECK(std::stof(p.at("radius")) == Approx(default_radius(scene)).epsilon(1e-6));
    CHECK(p.at("radius_auto") == "true");
    CHECK(p.at("emission-spp") == std::to_string(kDefaultEmissionSpp));
    CHECK(p.at("emission-spp_auto") == "true");
    CHECK(p.at("shadow-samples") == std::to_string(kDefaultShadowSamples));
    CHECK(p.at("shadow-samples_auto") == "true");
    CHECK(p.at("gather-area") == "surface");
    CHECK(p.at("gather-area_auto") == "true");
    // The images: 2 passes of the automatic count emitted.
    const nlohmann::json j = nlohmann::json::parse(test::file_bytes(tmp / "a.json"));
    CHECK(j.at("images").back().at("photons_emitted").get<uint64_t>() == 2ull * photons);
    INFO(r.out);
    CHECK(r.out.find("pppm (auto), direct shadow-rays (auto), 1 shadow sample (auto), " +
                     std::to_string(photons) + " photons/pass (auto), R0 " + default_text(default_radius(scene)) +
                     " (auto), " + std::to_string(kDefaultEmissionSpp) +
                     " emission samples (auto), gather area surface (auto)") != std::string::npos);
  }
  SECTION("every choice overridden") {
    const auto r = test::run_tool(
        "render", "--scene " + q(tmp / "s.h5") + " -o " + q(tmp / "b.exr") +
                      " --passes 2 --estimator ppm --direct photons --photons 777 --radius 0.05"
                      " --emission-spp 2 --stats " + q(tmp / "b.json"),
        tmp);
    INFO(r.err);
    REQUIRE(r.exit_code == 0);
    const auto p = record_parameters(tmp / "b.json");
    CHECK(p.at("estimator") == "ppm");
    CHECK(p.at("estimator_auto") == "false");
    CHECK(p.at("direct") == "photons");
    CHECK(p.at("direct_auto") == "false");
    CHECK(p.at("photons") == "777");
    CHECK(p.at("photons_auto") == "false");
    CHECK(p.at("radius") == "0.05");
    CHECK(p.at("radius_auto") == "false");
    CHECK(p.at("emission-spp") == "2");
    CHECK(p.at("emission-spp_auto") == "false");
    CHECK(p.at("gather-area") == "disc");  // ppm's automatic choice
    CHECK(p.at("gather-area_auto") == "true");
    const nlohmann::json j = nlohmann::json::parse(test::file_bytes(tmp / "b.json"));
    CHECK(j.at("images").back().at("photons_emitted").get<uint64_t>() == 2ull * 777);
    CHECK(r.out.find("ppm, direct photons, 777 photons/pass, R0 0.05, 2 emission samples,") !=
          std::string::npos);
  }
  SECTION("shadow samples: auto is 4 for ppm's one eye pass; a count is used and recorded") {
    const auto r = test::run_tool("render", "--scene " + q(tmp / "s.h5") + " -o " +
                                                q(tmp / "f.exr") + " --passes 1 --estimator ppm " +
                                                "--stats " + q(tmp / "d.json"),
                                  tmp);
    REQUIRE(r.exit_code == 0);
    auto p = record_parameters(tmp / "d.json");
    CHECK(p.at("shadow-samples") == std::to_string(kPpmShadowSamples));
    CHECK(p.at("shadow-samples_auto") == "true");
    CHECK(r.out.find(std::to_string(kPpmShadowSamples) + " shadow samples (auto)") !=
          std::string::npos);
    const auto r3 = test::run_tool("render", "--scene " + q(tmp / "s.h5") + " -o " +
                                                 q(tmp / "g.exr") + " --passes 1 " +
                                                 "--shadow-samples 3 --stats " + q(tmp / "e.json"),
                                   tmp);
    REQUIRE(r3.exit_code == 0);
    p = record_parameters(tmp / "e.json");
    CHECK(p.at("shadow-samples") == "3");
    CHECK(p.at("shadow-samples_auto") == "false");
    CHECK(r3.out.find("shadow-rays (auto), 3 shadow samples,") != std::string::npos);
  }
  SECTION("--photons auto and --radius auto or 0 are the automatic choices, spelled out") {
    const auto r = test::run_tool("render", "--scene " + q(tmp / "s.h5") + " -o " +
                                                q(tmp / "c.exr") +
                                                " --passes 1 --photons auto --radius 0 --stats " +
                                                q(tmp / "c.json"),
                                  tmp);
    REQUIRE(r.exit_code == 0);
    const auto p = record_parameters(tmp / "c.json");
    CHECK(p.at("photons") == std::to_string(photons));
    CHECK(p.at("photons_auto") == "true");
    CHECK(p.at("radius_auto") == "true");
  }
  SECTION("bad values are refused with one line naming the option") {
    for (const std::string bad : {"--photons many", "--photons 0", "--photons 12x",
                                  "--radius big", "--radius -1", "--shadow-samples some",
                                  "--shadow-samples 0", "--shadow-samples 2x"}) {
      INFO(bad);
      const auto r = test::run_tool(
          "render", "--scene " + q(tmp / "s.h5") + " -o " + q(tmp / "d.exr") + " " + bad, tmp);
      CHECK(r.exit_code == 2);
      CHECK(r.err.find(bad.substr(0, bad.find(' '))) != std::string::npos);
      CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
      CHECK_FALSE(std::filesystem::exists(tmp / "d.exr"));
    }
  }
}

TEST_CASE("trace-photons takes render's automatic photon count from the same place",
          "[render_defaults]") {
  test::TempDir tmp("render-defaults-staged");
  const std::string dae = test::source_dir() + "/data/cornell-box.dae";
  REQUIRE(test::run_tool("scene-bake", q(dae) + " -o " + q(tmp / "s.h5") +
                                           " --width 240 --height 180",
                         tmp)
              .exit_code == 0);
  const auto help = test::run_tool("trace-photons", "--help", tmp);
  CHECK(help_of(help.out, "photons").find(auto_photons_rule()) != std::string::npos);
  REQUIRE(test::run_tool("trace-photons", "--scene " + q(tmp / "s.h5") + " -o " + q(tmp / "p.h5"),
                         tmp)
              .exit_code == 0);
  const Provenance prov = load_photons_provenance(tmp / "p.h5");
  CHECK(prov.parameters.at("photons") == std::to_string(auto_photons(240, 180)));
  CHECK(auto_photons(240, 180) == 60416);  // 43200 × 1.4 = 60480 → 59 steps
  CHECK(prov.parameters.at("photons_auto") == "true");
  const PhotonSet set = load_photons(tmp / "p.h5");
  REQUIRE(set.pass_count() == 1);
  CHECK(set.pass_emitted[0] == auto_photons(240, 180));
  // Given, it is used and recorded as given.
  REQUIRE(test::run_tool("trace-photons", "--scene " + q(tmp / "s.h5") + " -o " +
                                              q(tmp / "q.h5") + " --photons 500",
                         tmp)
              .exit_code == 0);
  const Provenance given = load_photons_provenance(tmp / "q.h5");
  CHECK(given.parameters.at("photons") == "500");
  CHECK(given.parameters.at("photons_auto") == "false");
}

TEST_CASE("make render, the staged route and render without options give one image: the "
          "defaults come from one place",
          "[render_defaults][dag]") {
  test::TempDir tmp("render-defaults-routes");
  // make render with no estimator, direct light or photon count: render.mk leaves them to
  // render (ESTIMATOR=auto, DIRECT=shadow-rays, PHOTONS=auto, RADIUS=0).
  const std::string make = "make -s --no-print-directory -C " + test::source_dir() +
                           " -f pipelines/render.mk BIN=" + test::bin_dir() + " OUT=" +
                           tmp.dir.string() + " WIDTH=40 HEIGHT=30 PASSES=2 render > " +
                           (tmp / "make.log") + " 2>&1";
  REQUIRE(std::system(make.c_str()) == 0);
  const std::string dir = tmp / "cornell-box";
  const std::string scene = dir + "/scene.h5";
  // render with nothing but the scene, the passes and the output.
  const auto r = plain_render(tmp, scene, 2);
  INFO(r.err);
  REQUIRE(r.exit_code == 0);
  CHECK(record_parameters(tmp / "plain.json").at("photons") == std::to_string(kMinAutoPhotons));
  const Image made = read_exr(dir + "/render.exr"), plain = read_exr(tmp / "plain.exr");
  CHECK(made.rgb == plain.rgb);
  CHECK(staged_image(tmp, scene, 2).rgb == plain.rgb);
}

TEST_CASE("shadow samples: auto is 4 where an environment lights the scene, on both routes",
          "[render_defaults][environment]") {
  test::TempDir tmp("render-defaults-env");
  const std::string dae = test::source_dir() + "/data/cornell-box.dae";
  const std::string scene = tmp / "env.h5";
  REQUIRE(test::run_tool("scene-bake", q(dae) + " -o " + q(scene) +
                                           " --width 40 --height 30 --environment 0.5,0.6,0.7",
                         tmp)
              .exit_code == 0);
  REQUIRE(auto_shadow_samples(Estimator::Pppm, load_scene(scene)) == kEnvironmentShadowSamples);
  REQUIRE(auto_shadow_samples(Estimator::Sppm, load_scene(scene)) == kEnvironmentShadowSamples);
  REQUIRE(auto_shadow_samples(Estimator::Ppm, load_scene(scene)) == kPpmShadowSamples);
  REQUIRE(kEnvironmentShadowSamples != kDefaultShadowSamples);
  const auto r = plain_render(tmp, scene, 2);
  INFO(r.err);
  REQUIRE(r.exit_code == 0);
  const auto p = record_parameters(tmp / "plain.json");
  CHECK(p.at("shadow-samples") == std::to_string(kEnvironmentShadowSamples));
  CHECK(p.at("shadow-samples_auto") == "true");
  CHECK(r.out.find(std::to_string(kEnvironmentShadowSamples) + " shadow samples (auto)") !=
        std::string::npos);
  // trace-hitpoints chooses the same from the scene: the staged image is render's.
  CHECK(staged_image(tmp, scene, 2).rgb == read_exr(tmp / "plain.exr").rgb);
  const auto one = test::run_tool("render", "--scene " + q(scene) + " --passes 2 -o " +
                                                q(tmp / "one.exr") + " --shadow-samples 1",
                                  tmp);
  REQUIRE(one.exit_code == 0);
  CHECK(read_exr(tmp / "one.exr").rgb != read_exr(tmp / "plain.exr").rgb);
}

TEST_CASE("trace-hitpoints and illuminate: --help and the run record say render's estimator and "
          "direct light, which they default to",
          "[render_defaults]") {
  test::TempDir tmp("render-defaults-stage-help");
  const std::string est = estimator_name(kDefaultEstimator), dir = direct_mode_name(kDefaultDirect);
  // render's --help, the reference: the same "(default: ...)" in all three tools.
  const auto render = test::run_tool("render", "--help", tmp);
  const auto eye = test::run_tool("trace-hitpoints", "--help", tmp);
  const auto ill = test::run_tool("illuminate", "--help", tmp);
  REQUIRE(render.exit_code == 0);
  REQUIRE(eye.exit_code == 0);
  REQUIRE(ill.exit_code == 0);
  const std::string est_default = "(default: " + est + ")", dir_default = "(default: " + dir + ")";
  CHECK(est == "pppm");
  CHECK(dir == "shadow-rays");
  CHECK(help_of(render.out, "estimator").find(est_default) != std::string::npos);
  CHECK(help_of(render.out, "direct").find(dir_default) != std::string::npos);
  CHECK(help_of(eye.out, "estimator").find(est_default) != std::string::npos);
  CHECK(help_of(eye.out, "direct").find(dir_default) != std::string::npos);
  CHECK(help_of(ill.out, "estimator").find(est_default) != std::string::npos);

  // The run records: the values used and that they were the defaults.
  const std::string dae = test::source_dir() + "/data/cornell-box.dae";
  const std::string scene = tmp / "s.h5", hp = tmp / "hp.h5", ph = tmp / "ph.h5",
                    st = tmp / "st.h5";
  REQUIRE(test::run_tool("scene-bake", q(dae) + " -o " + q(scene) + " --width 32 --height 24",
                         tmp)
              .exit_code == 0);
  REQUIRE(test::run_tool("trace-hitpoints", "--scene " + q(scene) + " -o " + q(hp), tmp)
              .exit_code == 0);
  REQUIRE(test::run_tool("trace-photons", "--scene " + q(scene) + " -o " + q(ph), tmp)
              .exit_code == 0);
  const auto lit = test::run_tool("illuminate", "--scene " + q(scene) + " --hitpoints " + q(hp) +
                                                    " --photons " + q(ph) + " -o " + q(st),
                                  tmp);
  INFO(lit.err);
  REQUIRE(lit.exit_code == 0);
  const Provenance e = load_hitpoints_provenance(hp);
  CHECK(e.parameters.at("estimator") == est);
  CHECK(e.parameters.at("estimator_auto") == "true");
  CHECK(e.parameters.at("direct") == dir);
  CHECK(e.parameters.at("direct_auto") == "true");
  CHECK(e.parameters.at("pixel-sampler") == "sobol");  // pppm's sampler, as render's
  CHECK(load_hitpoints(hp).direct_mode == kDefaultDirect);
  const Provenance i = load_pass_sums_provenance(st);  // pppm writes its pass sums
  CHECK(i.parameters.at("estimator") == est);
  CHECK(i.parameters.at("estimator_auto") == "true");
  const PassSums sums = load_pass_sums(st);
  CHECK(sums.first_pass == 0);
  CHECK(sums.passes == 1);
  CHECK(sums.direct_mode == kDefaultDirect);

  // Named, they are used and recorded as given.
  REQUIRE(test::run_tool("trace-hitpoints", "--scene " + q(scene) + " -o " + q(tmp / "hp2.h5") +
                                                " --estimator ppm --direct photons --spp 2",
                         tmp)
              .exit_code == 0);
  const Provenance e2 = load_hitpoints_provenance(tmp / "hp2.h5");
  CHECK(e2.parameters.at("estimator") == "ppm");
  CHECK(e2.parameters.at("estimator_auto") == "false");
  CHECK(e2.parameters.at("direct") == "photons");
  CHECK(e2.parameters.at("direct_auto") == "false");
  REQUIRE(test::run_tool("illuminate", "--scene " + q(scene) + " --hitpoints " + q(tmp / "hp2.h5") +
                                           " --photons " + q(ph) + " -o " + q(tmp / "st2.h5") +
                                           " --estimator ppm",
                         tmp)
              .exit_code == 0);
  const Provenance i2 = load_hitpoints_provenance(tmp / "st2.h5");
  CHECK(i2.parameters.at("estimator") == "ppm");
  CHECK(i2.parameters.at("estimator_auto") == "false");

  // What belongs to ppm alone, under the default, is refused with one line that names the way.
  const auto cont = test::run_tool("illuminate", "--scene " + q(scene) + " --hitpoints " +
                                                     q(tmp / "st2.h5") + " --photons " + q(ph) +
                                                     " -o " + q(tmp / "x.h5"),
                                   tmp);
  CHECK(cont.exit_code == 2);
  CHECK(cont.err.find("give --estimator ppm to continue it") != std::string::npos);
  CHECK(std::count(cont.err.begin(), cont.err.end(), '\n') == 1);
  const auto method = test::run_tool("illuminate", "--scene " + q(scene) + " --hitpoints " +
                                                       q(hp) + " --photons " + q(ph) + " -o " +
                                                       q(tmp / "x.h5") + " --method flann",
                                     tmp);
  CHECK(method.exit_code == 2);
  CHECK(method.err.find("--estimator ppm") != std::string::npos);
  CHECK_FALSE(std::filesystem::exists(tmp / "x.h5"));
}
