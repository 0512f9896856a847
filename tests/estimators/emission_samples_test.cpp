// Emission samples (eye_pass.h EyePassOptions::emission_spp, emission_pixels): extra eye paths
// through mirrors and glass only, in the pixels that see an emitter that way or directly. They
// mark exactly the pixels whose 3×3 neighbourhood has a centre ray reaching an emitter, leave the
// emitted layer unbiased (the same mean as without them) with less variance per pass, route light
// found after a glossy continuation to the direct layer, give the same layer on the OpenCL
// device, and render/trace-hitpoints take --emission-spp (auto, a count, refusals in one line).
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "photonflow/opencl/cl_backend.h"
#include "photonflow/stages/eye_pass.h"
#include "photonflow/geometry/raycast.h"
#include "photonflow/estimators/render_defaults.h"
#include "photonflow/foundations/error.h"
#include "photonflow/estimators/pass_sums.h"
#include "photonflow/io/stage_files.h"
#include "photonflow/geometry/surface.h"
#include "photonflow/geometry/scene_file.h"
#include "support.h"
#include "support_cl.h"

using namespace pf;

namespace {

// The room with a glass (or mirror) sphere, seen from below the light so that the lamp is in view
// directly, and through the sphere.
Scene lamp_room(int sphere_type, int size) {
  Scene s = test::room_scene(sphere_type, size, size);
  s.camera = pf_camera{{0.5f, 0.25f, 0.95f}, {0.5f, 0.7f, 0.3f}, {0, 1, 0}, 70.f, size, size};
  finish_scene(s);
  return s;
}

// The emitted layer of pass `pass` with K emission samples (Sobol eye samples, spp 1).
std::vector<float> emitted(const Scene& s, int K, uint32_t pass,
                           const std::vector<uint8_t>* marks = nullptr) {
  EyePassOptions o;
  o.sampler = PixelSampler::Sobol;
  o.emission_spp = K;
  o.emission_pixels = marks;
  o.pass = pass;
  o.seed = 3;
  return trace_hitpoints(s, o).emitted;
}

}  // namespace

TEST_CASE("emission samples: the marked pixels are the 3x3 neighbourhoods of centre rays that "
          "reach an emitter",
          "[emission]") {
  for (int type : {PF_MAT_GLASS, PF_MAT_MIRROR}) {
    const Scene s = lamp_room(type, 48);
    const std::vector<uint8_t> marks = emission_pixels(s);
    REQUIRE(marks.size() == size_t(48 * 48));
    // The centre rays' first hits by the host's caster: an emitter seen directly is marked with
    // its neighbours; a pixel whose neighbourhood sees only diffuse surfaces is not.
    const CameraFrame cam(s.camera);
    std::vector<int> first(marks.size());
    for (int y = 0; y < 48; ++y)
      for (int x = 0; x < 48; ++x) {
        Ray r;
        cam.ray(float(x) + 0.5f, float(y) + 0.5f, 0.5f, 0.5f, r.o, r.d);
        Hit h;
        first[size_t(y) * 48 + size_t(x)] =
            intersect_closest(s, r, h, Traversal::Ropes)
                ? s.materials[size_t(s.triangles[size_t(h.tri)].material)].type
                : -1;
      }
    size_t lamp = 0, through = 0, marked = 0;
    for (int y = 0; y < 48; ++y)
      for (int x = 0; x < 48; ++x) {
        bool emitter_near = false, specular_near = false;
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) {
            const int xx = x + dx, yy = y + dy;
            if (xx < 0 || yy < 0 || xx >= 48 || yy >= 48) continue;
            const int t = first[size_t(yy) * 48 + size_t(xx)];
            emitter_near |= t == PF_MAT_EMITTER;
            specular_near |= t == PF_MAT_GLASS || t == PF_MAT_MIRROR;
          }
        const uint8_t m = marks[size_t(y) * 48 + size_t(x)];
        marked += m;
        if (emitter_near) {
          ++lamp;
          CHECK(m == 1);
        } else if (!specular_near) {
          CHECK(m == 0);
        } else {
          through += m;
        }
      }
    INFO("sphere type " << type << ": " << marked << " marked, " << lamp << " near the lamp, "
                        << through << " through the sphere");
    CHECK(lamp > 20);
    CHECK(through > 0);          // the lamp in (or through) the sphere
    CHECK(marked < marks.size() / 4);  // a small part of the image
  }
}

TEST_CASE("emission samples: the emitted layer keeps its mean and loses variance", "[emission]") {
  // Per-pass layers of 24 passes with and without 8 emission samples: their means over the passes
  // agree within the noise in every marked region, and a pass's deviation from the common mean
  // is smaller with them.
  const Scene s = lamp_room(PF_MAT_GLASS, 32);
  const std::vector<uint8_t> marks = emission_pixels(s);
  constexpr int kPasses = 24;
  std::vector<std::vector<float>> a, b;
  for (uint32_t p = 0; p < kPasses; ++p) {
    a.push_back(emitted(s, 0, p));
    b.push_back(emitted(s, 8, p, &marks));
  }
  // Totals over the marked pixels per pass (the unmarked pixels must be unchanged bit for bit).
  std::vector<double> ta, tb;
  for (int p = 0; p < kPasses; ++p) {
    double x = 0, y = 0;
    for (size_t i = 0; i < marks.size(); ++i) {
      if (!marks[i]) {
        for (int c = 0; c < 3; ++c) REQUIRE(a[p][i * 3 + c] == b[p][i * 3 + c]);
        continue;
      }
      x += a[p][i * 3];
      y += b[p][i * 3];
    }
    ta.push_back(x);
    tb.push_back(y);
  }
  auto mean_se = [](const std::vector<double>& v, double& m, double& se) {
    m = 0;
    for (double x : v) m += x;
    m /= double(v.size());
    double s2 = 0;
    for (double x : v) s2 += (x - m) * (x - m);
    se = std::sqrt(s2 / double(v.size() - 1) / double(v.size()));
  };
  double ma, sa, mb, sb;
  mean_se(ta, ma, sa);
  mean_se(tb, mb, sb);
  INFO("marked total: without " << ma << " ± " << sa << ", with " << mb << " ± " << sb);
  REQUIRE(ma > 0);
  CHECK(std::fabs(ma - mb) <= 4 * std::sqrt(sa * sa + sb * sb) + 1e-3 * ma);
  // Per-pixel variance over the passes, summed over the marked pixels.
  double va = 0, vb = 0;
  for (size_t i = 0; i < marks.size(); ++i) {
    if (!marks[i]) continue;
    double m1 = 0, m2 = 0;
    for (int p = 0; p < kPasses; ++p) {
      m1 += a[p][i * 3];
      m2 += b[p][i * 3];
    }
    m1 /= kPasses;
    m2 /= kPasses;
    for (int p = 0; p < kPasses; ++p) {
      va += (a[p][i * 3] - m1) * (a[p][i * 3] - m1);
      vb += (b[p][i * 3] - m2) * (b[p][i * 3] - m2);
    }
  }
  INFO("per-pass variance of the marked pixels: without " << va << ", with " << vb);
  CHECK(vb < 0.3 * va);
}

TEST_CASE("emission samples: light found after a glossy continuation stays whole, in the direct "
          "layer",
          "[emission][glossy-merge]") {
  // A smooth metal sphere (PF_MAT_PBR, roughness 0.05) that eye paths go on from
  // (GlossyMerge::Mis): the lamp it reflects is found by the BSDF's sample and next-event
  // estimation and goes to `direct`, which emission samples (mirror and glass only) leave
  // alone: emitted + direct keep their mean.
  Scene s = lamp_room(PF_MAT_DIFFUSE, 32);
  pf_material& metal = s.materials[2];
  metal.type = PF_MAT_PBR;
  metal.metallic = 1.f;
  metal.roughness = 0.05f;
  metal.ior = 1.5f;
  finish_scene(s);
  EyePassOptions o;
  o.sampler = PixelSampler::Sobol;
  o.glossy = GlossyMerge::Mis;
  o.direct = DirectMode::ShadowRays;
  o.seed = 5;
  double sum[2] = {0, 0}, direct_sum = 0;
  for (int k = 0; k < 2; ++k)
    for (uint32_t p = 0; p < 16; ++p) {
      o.pass = p;
      o.emission_spp = k ? 8 : 0;
      const EyePassResult r = trace_hitpoints(s, o);
      for (size_t i = 0; i < r.emitted.size(); ++i) sum[k] += double(r.emitted[i]) + r.direct[i];
      if (k == 0)
        for (float v : r.direct) direct_sum += v;
    }
  INFO("emitted + direct: without emission samples " << sum[0] << ", with " << sum[1]
                                                     << "; direct " << direct_sum);
  CHECK(direct_sum > 0.05 * sum[0]);  // the lamp in the metal reaches the direct layer
  CHECK(sum[1] == Approx(sum[0]).epsilon(0.03));
}

TEST_CASE("emission samples: the OpenCL eye pass gives the CPU's emitted layer", "[emission][opencl]") {
  auto dev = test::test_device();
  if (!dev) return;
  Scene s = lamp_room(PF_MAT_GLASS, 40);
  const bool lens = GENERATE(false, true);  // a thin lens: the samples' lens points too
  INFO((lens ? "thin lens" : "pinhole"));
  if (lens) {
    s.camera.aperture = 0.06f;
    s.camera.focus_distance = 0.15f;
    finish_scene(s);
  }
  EyePassOptions o;
  o.sampler = PixelSampler::Sobol;
  o.emission_spp = 8;
  o.pass = 3;
  o.direct = DirectMode::ShadowRays;
  const EyePassResult cpu = trace_hitpoints(s, o);
  const EyePassResult gpu = trace_hitpoints(s, o, *dev);
  o.emission_spp = 0;
  const EyePassResult plain = trace_hitpoints(s, o);
  REQUIRE(test::sum_squares(cpu.emitted) > 0);
  CHECK(test::relative_rmse(gpu.emitted, cpu.emitted) <= 1e-3);
  CHECK(test::relative_rmse(plain.emitted, cpu.emitted) > 1e-2);  // the samples changed it
  CHECK(test::relative_rmse(gpu.direct, cpu.direct) <= 1e-3);
}

TEST_CASE("emission samples: --emission-spp of render and trace-hitpoints", "[emission][tools]") {
  test::TempDir tmp("emission-opt");
  save_scene(lamp_room(PF_MAT_GLASS, 24), tmp / "s.h5", Provenance{});
  const std::string scene = "--scene '" + std::string(tmp / "s.h5") + "'";
  CHECK(parse_emission_spp("auto") == kDefaultEmissionSpp);
  CHECK(parse_emission_spp("0") == 0);
  CHECK(parse_emission_spp("1024") == 1024);
  for (const char* bad : {"-1", "1025", "x", "8x", ""}) {
    INFO("--emission-spp '" << bad << "'");
    CHECK_THROWS_AS(parse_emission_spp(bad), InputError);
    for (const char* tool : {"render", "trace-hitpoints"}) {
      const std::string out = tmp / "out.h5";
      const test::ToolRun r = test::run_tool(
          tool, scene + " -o '" + out + "' --emission-spp '" + std::string(bad) + "'", tmp);
      CHECK(r.exit_code == 2);
      CHECK(r.err.find("--emission-spp") != std::string::npos);
      CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
      CHECK(!std::filesystem::exists(out));
    }
  }
  // trace-hitpoints records the count it used (auto resolved), 0 not at all.
  for (const char* k : {"auto", "0", "3"}) {
    const std::string out = tmp / "hp.h5";
    const test::ToolRun r =
        test::run_tool("trace-hitpoints", scene + " -o '" + out + "' --emission-spp " + k, tmp);
    INFO(r.err);
    REQUIRE(r.exit_code == 0);
    const Provenance p = load_hitpoints_provenance(out);
    const auto it = p.parameters.find("emission-spp");
    if (std::string(k) == "0") {
      CHECK(it == p.parameters.end());
    } else {
      REQUIRE(it != p.parameters.end());
      CHECK(it->second == (std::string(k) == "auto" ? std::to_string(kDefaultEmissionSpp) : k));
    }
  }
}

TEST_CASE("emission samples: a checkpoint records them, and one made without resumes only without",
          "[emission][tools]") {
  test::TempDir tmp("emission-resume");
  save_scene(lamp_room(PF_MAT_GLASS, 24), tmp / "s.h5", Provenance{});
  const std::string base = "--scene '" + std::string(tmp / "s.h5") + "' -o '" +
                           std::string(tmp / "o.exr") + "' --photons 2000 --checkpoint '" +
                           std::string(tmp / "c.h5") + "'";
  // Made without emission samples (as before they existed: no state.emission-spp) ...
  test::ToolRun r = test::run_tool("render", base + " --passes 2 --emission-spp 0", tmp);
  INFO(r.err);
  REQUIRE(r.exit_code == 0);
  CHECK(load_pass_sums_provenance(tmp / "c.h5").parameters.count("state.emission-spp") == 0);
  // ... a resume with the default refuses in one line that names the way out ...
  r = test::run_tool("render", base + " --passes 3 --resume", tmp);
  CHECK(r.exit_code == 2);
  CHECK(r.err.find("--emission-spp 0") != std::string::npos);
  CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
  // ... which works; a checkpoint made with the default records its count.
  r = test::run_tool("render", base + " --passes 3 --resume --emission-spp 0", tmp);
  CHECK(r.exit_code == 0);
  std::filesystem::remove(tmp / "c.h5");
  r = test::run_tool("render", base + " --passes 1", tmp);
  REQUIRE(r.exit_code == 0);
  CHECK(load_pass_sums_provenance(tmp / "c.h5").parameters.at("state.emission-spp") ==
        std::to_string(kDefaultEmissionSpp));
}

TEST_CASE("emission samples: through a thin lens their lens points are stratified as their jitter",
          "[emission][lens]") {
  // A defocused lamp: each marked pixel's emitted value depends on where its samples cross the
  // lens. The lens points of a pixel's emission samples over the passes are one stratified
  // sequence (pixel_sampler.h pf_eye_lens_keyed under the emission key), so the mean of 16
  // passes is nearer the converged layer (passes 16 to 271) than independent samples of the
  // same per-pass variance would be (Σ var / 16). With independent lens points (pf_emission_rng's
  // draws, tried) the ratio is 0.84; stratified 0.37.
  Scene s = lamp_room(PF_MAT_GLASS, 24);
  s.camera.aperture = 0.06f;
  s.camera.focus_distance = 0.15f;
  finish_scene(s);
  const std::vector<uint8_t> marks = emission_pixels(s);
  constexpr int kShort = 16, kLong = 256;
  std::vector<std::vector<float>> layers;
  for (uint32_t p = 0; p < uint32_t(kShort + kLong); ++p)
    layers.push_back(emitted(s, 8, p, &marks));
  double err2 = 0, var_sum = 0;
  size_t marked = 0;
  for (size_t i = 0; i < marks.size(); ++i) {
    if (!marks[i]) continue;
    ++marked;
    double shortm = 0, longm = 0, m = 0, v = 0;
    for (int p = 0; p < kShort; ++p) shortm += layers[size_t(p)][i * 3] / kShort;
    for (int p = kShort; p < kShort + kLong; ++p) longm += layers[size_t(p)][i * 3] / kLong;
    for (int p = 0; p < kShort + kLong; ++p) m += layers[size_t(p)][i * 3] / (kShort + kLong);
    for (int p = 0; p < kShort + kLong; ++p)
      v += (layers[size_t(p)][i * 3] - m) * (layers[size_t(p)][i * 3] - m) / (kShort + kLong - 1);
    err2 += (shortm - longm) * (shortm - longm);
    var_sum += v;
  }
  const double independent = var_sum / kShort;
  INFO(marked << " marked pixels: squared error of 16 passes " << err2 << ", independent samples' "
              << independent);
  REQUIRE(marked > 20);
  REQUIRE(independent > 0);
  CHECK(err2 < 0.5 * independent);
}
