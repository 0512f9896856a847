// The estimator files of SPPM and PPPM (issue 33's audit): SPPM and PPPM checkpoints, pass-sums
// parts, merge, and the options that make them. One case per cause the audit found, each built to
// fail without its fix:
//   1. a radius whose square underflows float is refused as an option (render, trace-hitpoints);
//   2. and 5. every pixel of an SPPM state, reached or not, has R in [kMinRadius, kMaxRadius], and
//      every writer checks what it writes with its readers' checks (validate.h written_check);
//   3. a checkpoint whose own attributes disagree with the run (direct mode) is a refusal, and a
//      float64 attribute that narrowing to float takes out of range (radius1, alpha of 1e-300) is
//      refused with the file's name;
//   4. counts of photons emitted are bounded per pass (validate.h kMaxPhotonsPerPass), so merges
//      and resumes never wrap;
//   6. datasets of another shape or type are refused (h5io.h Reader::read);
//   7. pppm_radius of a pass near 2^31 takes a bounded number of steps and keeps its value;
//   and the smaller findings: a range ending at 2^31, whole-number options echoed as integers,
//   and a PPM state without hitpoints, which stays accepted (it is what a camera that sees only
//   emitters and the background makes).
#include <catch2/catch.hpp>

#include <algorithm>
#include <functional>
#include <climits>
#include <cmath>
#include <cstdint>
#include <filesystem>

#include "h5edit.h"
#include "photonflow/stages/eye_pass.h"
#include "photonflow/foundations/options.h"
#include "photonflow/estimators/pass_sums.h"
#include "photonflow/estimators/render_driver.h"
#include "photonflow/estimators/sppm.h"
#include "photonflow/io/stage_files.h"
#include "photonflow/stages/synthesize.h"
#include "photonflow/io/validate.h"
#include "photonflow/geometry/scene_file.h"
#include "support.h"

using namespace pf;
using test::TempDir;

namespace {

RenderOptions small_run(Estimator e, int passes) {
  RenderOptions o;
  o.estimator = e;
  o.passes = passes;
  o.photons.photons = 1500;
  o.photons.threads = o.eye.threads = o.ppm.threads = 1;
  o.eye.sampler = e == Estimator::Ppm ? PixelSampler::Strata : PixelSampler::Sobol;
  return o;
}

using test::refused;

// Retypes or reshapes dataset `dset` of `file` (h5edit.h rewrite_dataset_as).
void rewrite_as(const std::string& file, const std::string& dset, hid_t stored, hid_t mem,
                const void* data, const std::vector<hsize_t>& dims) {
  h5::Handle f(H5Fopen(file.c_str(), H5F_ACC_RDWR, H5P_DEFAULT));
  REQUIRE(f.valid());
  size_t n = 1;
  for (hsize_t d : dims) n *= size_t(d);
  test::rewrite_dataset_as(f.get(), dset, stored, mem, data, n, dims);
}

std::string copy_to(const TempDir& tmp, const std::string& src, const std::string& name) {
  const std::string dst = tmp / name;
  std::filesystem::remove(dst);
  std::filesystem::copy_file(src, dst);
  return dst;
}

bool all_finite(const Image& img) {
  for (float v : img.rgb)
    if (!std::isfinite(v)) return false;
  return true;
}

}  // namespace

TEST_CASE("estimator files 1: a radius whose square underflows float is refused as an option",
          "[estimator-files][options]") {
  EyePassOptions eo;
  for (float r : {1e-23f, 1e-30f, -1e-30f, 1e-16f, 2e12f, -1.f, NAN, INFINITY}) {
    eo.radius = r;
    INFO("radius " << r);
    refused([&] { check_options(eo); }, "", "--radius must be 0 (automatic) or a length in");
  }
  for (float r : {0.f, 1e-15f, 0.05f, 1e12f}) {
    eo.radius = r;
    CHECK_NOTHROW(check_options(eo));
  }
  // The tools: exit 2, one line, no output (before: exit 0 with NaN pixels, or a hitpoints file
  // that illuminate refused).
  TempDir tmp("estfiles-radius");
  const Scene s = test::room_scene(PF_MAT_DIFFUSE, 8, 6);
  save_scene(s, tmp / "scene.h5", Provenance{});
  for (const char* est : {"ppm", "sppm"}) {
    const test::ToolRun r = test::run_tool(
        "render", "--scene " + (tmp / "scene.h5") + " -o " + (tmp / "r.exr") +
                      " --passes 1 --photons 100 --radius 1e-23 --estimator " + est, tmp);
    INFO(r.err);
    CHECK(r.exit_code == kExitBadInput);
    CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
    CHECK_FALSE(std::filesystem::exists(tmp / "r.exr"));
  }
  const test::ToolRun t = test::run_tool(
      "trace-hitpoints", "--estimator ppm --direct photons --scene " + (tmp / "scene.h5") + " -o " + (tmp / "h.h5") + " --radius 1e-30", tmp);
  INFO(t.err);
  CHECK(t.exit_code == kExitBadInput);
  CHECK_FALSE(std::filesystem::exists(tmp / "h.h5"));
}

TEST_CASE("estimator files 2 and 5: every SPPM pixel's radius is a gather radius, and writers "
          "write only what their readers accept", "[estimator-files][sppm]") {
  TempDir tmp("estfiles-sppm");
  const Scene s = test::room_scene(PF_MAT_GLASS, 12, 10);
  HitpointSet st = make_sppm_state(s, 0.05f, DirectMode::Photons);
  // An unreached pixel (mesh −1) with a radius below kMinRadius or 0: refused on read (before: a
  // NaN pixel from synthesize and --resume, or a checkpoint the next --resume refused) ...
  for (float r : {1e-30f, 0.f}) {
    HitpointSet bad = st;
    bad.hitpoints[3].radius = r;
    const std::string p = tmp / "bad.h5";
    std::filesystem::remove(p);
    {
      const UncheckedWritesForTests damaged;
      save_hitpoints(bad, p, Provenance{});
    }
    refused([&] { load_hitpoints(p); }, p, "hitpoints[3].radius");
    // ... and never written: the writer applies the reader's checks, an internal error.
    CHECK_THROWS_AS(save_hitpoints(bad, tmp / "never.h5", Provenance{}), std::logic_error);
    CHECK_THROWS_WITH(save_hitpoints(bad, tmp / "never.h5", Provenance{}),
                      Catch::Contains("about to write what its readers refuse"));
    CHECK_FALSE(std::filesystem::exists(tmp / "never.h5"));
  }
  // What a run writes, the next --resume reads: an SPPM run with checkpoints every pass.
  RenderOptions o = small_run(Estimator::Sppm, 2);
  o.checkpoint = tmp / "ck.h5";
  o.checkpoint_every = 1;
  render_progressive(s, o, false, Provenance{});
  const HitpointSet back = load_hitpoints(o.checkpoint);
  CHECK(back.passes == 2);
  o.passes = 3;
  CHECK(render_progressive(s, o, true, Provenance{}).passes == 3);
  // Pass sums: the writer and merge check what they write.
  PassSums sums = render_pppm(s, small_run(Estimator::Pppm, 1), false, Provenance{});
  PassSums broken = sums;
  broken.photons_emitted = 0;
  CHECK_THROWS_AS(save_pass_sums(broken, tmp / "never.h5", Provenance{}), std::logic_error);
  CHECK_FALSE(std::filesystem::exists(tmp / "never.h5"));
}

TEST_CASE("estimator files 3: a checkpoint's direct mode and float attributes are refusals, not "
          "internal errors", "[estimator-files][resume]") {
  TempDir tmp("estfiles-direct");
  const Scene s = test::room_scene(PF_MAT_GLASS, 12, 10);
  save_scene(s, tmp / "scene.h5", Provenance{});
  for (Estimator e : {Estimator::Sppm, Estimator::Pppm}) {
    RenderOptions o = small_run(e, 1);
    o.checkpoint = tmp / (std::string(estimator_name(e)) + ".h5");
    if (e == Estimator::Pppm)
      render_pppm(s, o, false, Provenance{});
    else
      render_progressive(s, o, false, Provenance{});
    test::set_string_attr(o.checkpoint, "/", "direct_mode", "shadow-rays");
    o.passes = 2;
    INFO(estimator_name(e));
    refused(
        [&] {
          if (e == Estimator::Pppm)
            render_pppm(s, o, true, Provenance{});
          else
            render_progressive(s, o, true, Provenance{});
        },
        o.checkpoint, "holds a state of direct mode shadow-rays, this run has --direct photons");
    // The tool: exit 2 and one line (before: exit 1 "internal error").
    const test::ToolRun r = test::run_tool(
        "render", "--scene " + (tmp / "scene.h5") + " -o " + (tmp / "r.exr") +
                      " --passes 2 --photons 1500 --threads 1 --estimator " + estimator_name(e) +
                      " --checkpoint " + o.checkpoint + " --resume",
        tmp);
    INFO(r.err);
    CHECK(r.exit_code == kExitBadInput);
    CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
  }
  // radius1 and alpha of 1e-300 are positive doubles but 0 as floats: refused, naming the file.
  const std::string sums = tmp / "pppm.h5";
  for (const char* attr : {"radius1", "alpha"}) {
    const std::string p = copy_to(tmp, sums, std::string("narrow-") + attr + ".h5");
    test::set_double_attr(p, "/", attr, 1e-300);
    refused([&] { load_pass_sums(p); }, p, std::string("attribute ") + attr + " = 1e-300 is outside");
  }
}

TEST_CASE("estimator files 4: counts of photons emitted are bounded per pass, so merges and "
          "resumes never wrap", "[estimator-files][merge]") {
  TempDir tmp("estfiles-count");
  const Scene s = test::room_scene(PF_MAT_GLASS, 12, 10);
  const Validator v("f.h5", "");
  CHECK_NOTHROW(v.photons_emitted("n", 0, 0));
  CHECK_NOTHROW(v.photons_emitted("n", 3, 3));
  CHECK_NOTHROW(v.photons_emitted("n", 3 * kMaxPhotonsPerPass, 3));
  refused([&] { v.photons_emitted("n", 3 * kMaxPhotonsPerPass + 1, 3); }, "f.h5", "n = ");
  refused([&] { v.photons_emitted("n", 1, 0); }, "f.h5", "is not the count of 0 passes");
  refused([&] { v.photons_emitted("n", 2, 3); }, "f.h5", "is not the count of 3 passes");
  // The largest counts the rule allows cannot wrap: 2^31 − 1 passes of 2^32 − 1 photons.
  CHECK(uint64_t(INT32_MAX) * kMaxPhotonsPerPass < uint64_t(INT64_MAX));

  RenderOptions o = small_run(Estimator::Pppm, 1);
  o.checkpoint = tmp / "part0.h5";
  render_pppm(s, o, false, Provenance{});
  const std::string big = copy_to(tmp, o.checkpoint, "big.h5");
  test::set_int_attr(big, "/", "photons_emitted", INT64_MAX);  // 2^63 − 1 for one pass
  refused([&] { load_pass_sums(big); }, big, "photons_emitted = 9223372036854775807");
  refused([&] { merge_pass_sum_files({big}); }, big, "photons_emitted");
  RenderOptions more = o;
  more.checkpoint = big;
  more.passes = 2;
  refused([&] { render_pppm(s, more, true, Provenance{}); }, big, "photons_emitted");
  // A hitpoints state too.
  RenderOptions sp = small_run(Estimator::Sppm, 1);
  sp.checkpoint = tmp / "sppm.h5";
  render_progressive(s, sp, false, Provenance{});
  test::set_int_attr(sp.checkpoint, "/", "photons_emitted", INT64_MAX);
  refused([&] { load_hitpoints(sp.checkpoint); }, sp.checkpoint, "photons_emitted = 9223372036854775807");
  // Three parts at the largest allowed count per pass merge to the exact sum.
  std::vector<PassSums> parts;
  for (int k = 0; k < 3; ++k) {
    RenderOptions ok = small_run(Estimator::Pppm, 1);
    ok.first_pass = k;
    parts.push_back(render_pppm(s, ok, false, Provenance{}));
    parts.back().photons_emitted = kMaxPhotonsPerPass;
  }
  const PassSums m = merge_pass_sums(parts, {"a", "b", "c"});
  CHECK(m.photons_emitted == 3 * kMaxPhotonsPerPass);
}

TEST_CASE("estimator files: merge takes a recorded seed that is no number (was exit 1)",
          "[estimator-files][merge]") {
  TempDir tmp("estfiles-seed");
  const Scene s = test::room_scene(PF_MAT_GLASS, 8, 6);
  std::string parts;
  for (int k = 0; k < 2; ++k) {
    RenderOptions o = small_run(Estimator::Pppm, 1);
    o.first_pass = k;
    const std::string p = tmp / ("part" + std::to_string(k) + ".h5");
    save_pass_sums(render_pppm(s, o, false, Provenance{}), p, Provenance{});
    test::set_string_attr(p, "/provenance/parameters", "state.seed", "abc");
    parts += " " + p;
  }
  const test::ToolRun r = test::run_tool("merge", "--sums " + (tmp / "m.h5") + parts, tmp);
  INFO(r.err);
  CHECK(r.exit_code == 0);
  CHECK(load_pass_sums(tmp / "m.h5").parameters.at("seed") == "abc");
}

TEST_CASE("estimator files 6: datasets of another shape or type are refused", "[estimator-files][h5]") {
  TempDir tmp("estfiles-shape");
  const Scene s = test::room_scene(PF_MAT_GLASS, 16, 12);
  RenderOptions o = small_run(Estimator::Pppm, 1);
  o.checkpoint = tmp / "sums.h5";
  const PassSums sums = render_pppm(s, o, false, Provenance{});
  const std::vector<double>& v = sums.sum;
  const hsize_t H = 12, W = 16;
  struct Case {
    const char* name;
    hid_t stored;
    std::vector<hsize_t> dims;
    const char* needle;
  };
  const std::vector<Case> cases = {
      {"transposed", H5T_IEEE_F64LE, {3, H, W}, "has shape 3×12×16, not 12×16×3"},
      {"flat", H5T_IEEE_F64LE, {H * W * 3}, "not 12×16×3"},
      {"int64", H5T_STD_I64LE, {H, W, 3}, "is stored as int64, not float64"},
      {"float32", H5T_IEEE_F32LE, {H, W, 3}, "is stored as float32, not float64"}};
  for (const Case& c : cases) {
    INFO(c.name);
    const std::string p = copy_to(tmp, o.checkpoint, std::string("sum-") + c.name + ".h5");
    rewrite_as(p, "/sum", c.stored, H5T_NATIVE_DOUBLE, v.data(), c.dims);
    refused([&] { load_pass_sums(p); }, p, c.needle);
    refused([&] { merge_pass_sum_files({p}); }, p, c.needle);
    const test::ToolRun r = test::run_tool("merge", "--sums " + (tmp / "m.h5") + " " + p, tmp);
    INFO(r.err);
    CHECK(r.exit_code == kExitBadInput);
    CHECK_FALSE(std::filesystem::exists(tmp / "m.h5"));
  }
  // The image layers of a hitpoints state (height × width × 3) likewise.
  RenderOptions sp = small_run(Estimator::Sppm, 1);
  sp.checkpoint = tmp / "sppm.h5";
  const HitpointSet h = render_progressive(s, sp, false, Provenance{});
  const std::string p = copy_to(tmp, sp.checkpoint, "emitted-transposed.h5");
  rewrite_as(p, "/image/emitted", H5T_IEEE_F32LE, H5T_NATIVE_FLOAT, h.emitted.data(), {3, H, W});
  refused([&] { load_hitpoints(p); }, p, "has shape 3×12×16, not 12×16×3");
}

TEST_CASE("estimator files 7: pppm_radius of any pass takes bounded work and keeps its value",
          "[estimator-files][pppm]") {
  const double r1 = 0.25;
  for (double alpha : {0.7, 0.2, 0.999, 1.0}) {
    INFO("alpha " << alpha);
    // The same bits as the product itself up to kPppmLoopPasses.
    double r2 = r1 * r1;
    for (int p = 0; p <= kPppmLoopPasses; ++p) {
      if (p > 0) r2 *= (double(p) + alpha) / (double(p) + 1.0);
      if (p % 997 == 0 || p == kPppmLoopPasses) REQUIRE(pppm_radius(r1, alpha, p) == std::sqrt(r2));
    }
    // Beyond: the closed form against the product continued in long double.
    long double e2 = (long double)r1 * r1;
    for (int j = 1; j <= kPppmLoopPasses; ++j) e2 *= ((long double)j + alpha) / ((long double)j + 1);
    double worst = 0;
    for (int p = kPppmLoopPasses + 1; p <= kPppmLoopPasses + 2000000; ++p) {
      e2 *= ((long double)p + alpha) / ((long double)p + 1);
      if (p % 50021 == 0 || p == kPppmLoopPasses + 1) {
        const double want = double(std::sqrt(e2));
        worst = std::max(worst, std::fabs(pppm_radius(r1, alpha, p) - want) / want);
      }
    }
    CHECK(worst < 1e-12);
    // Near 2^31: Γ-function ratio in long double (lgammal), good to about 1e-8 there.
    const int p = INT32_MAX - 1;
    const long double lg = lgammal(p + 1.0L + alpha) - lgammal(p + 2.0L) -
                           lgammal(kPppmLoopPasses + 1.0L + alpha) + lgammal(kPppmLoopPasses + 2.0L);
    long double base = (long double)r1 * r1;
    for (int j = 1; j <= kPppmLoopPasses; ++j) base *= ((long double)j + alpha) / ((long double)j + 1);
    const double want = double(std::sqrt(base * expl(lg)));
    CHECK(pppm_radius(r1, alpha, p) == Approx(want).epsilon(1e-7));
    // Monotone: the radius never grows (α <= 1).
    CHECK(pppm_radius(r1, alpha, p) <= pppm_radius(r1, alpha, p - 1000));
  }
  // A run of the last passes before 2^31 - 1 (before: 30 s and more, a loop over the pass index).
  const Scene s = test::room_scene(PF_MAT_DIFFUSE, 8, 6);
  RenderOptions o = small_run(Estimator::Pppm, 10);
  o.first_pass = INT32_MAX - 10;
  const PassSums sums = render_pppm(s, o, false, Provenance{});
  CHECK(sums.end_pass() == INT32_MAX);
  CHECK(all_finite(synthesize(sums)));
}

TEST_CASE("estimator files: a range ends at 2^31 - 1, a PPM state may hold no hitpoint, "
          "whole-number options echo as integers", "[estimator-files][smaller]") {
  TempDir tmp("estfiles-small");
  const Scene s = test::room_scene(PF_MAT_GLASS, 12, 10);
  RenderOptions o = small_run(Estimator::Pppm, 2);
  o.first_pass = INT32_MAX - 1;  // passes 2^31 − 2 and 2^31 − 1: the end would be 2^31
  refused([&] { check_options(o); }, "", "ends past 2^31-1");
  o.passes = 1;
  CHECK_NOTHROW(check_options(o));
  // A sums file whose range ends at 2^31: refused, and no message prints a wrapped int.
  o.checkpoint = tmp / "last.h5";
  render_pppm(s, o, false, Provenance{});
  test::set_int_attr(o.checkpoint, "/", "passes", 2);
  test::set_int_attr(o.checkpoint, "/", "photons_emitted", 3000);
  try {
    load_pass_sums(o.checkpoint);
    FAIL_CHECK("a range ending at 2^31 was accepted");
  } catch (const InputError& e) {
    const std::string msg = e.what();
    INFO(msg);
    CHECK(msg.find("[2147483646, 2147483648) end past 2^31-1") != std::string::npos);
    CHECK(msg.find("-2147483648") == std::string::npos);
  }
  CHECK_THROWS_AS(parse_pass_range("0:2147483648"), InputError);
  // A PPM state without a hitpoint is legitimate (a camera that sees only emitters and the
  // background): written, read back and resumed, its image the emitted layer.
  RenderOptions p = small_run(Estimator::Ppm, 1);
  p.checkpoint = tmp / "ppm.h5";
  HitpointSet h = render_progressive(s, p, false, Provenance{});
  h.hitpoints.clear();
  save_hitpoints(h, p.checkpoint, load_hitpoints_provenance(p.checkpoint));
  CHECK(load_hitpoints(p.checkpoint).hitpoints.empty());
  p.passes = 2;
  const HitpointSet resumed = render_progressive(s, p, true, Provenance{});
  CHECK(resumed.passes == 2);
  CHECK(all_finite(synthesize(resumed)));
  // Whole-number options: "got 0", "got -1", never "got 0.000000".
  refused([&] { require_positive("passes", 0); }, "", "--passes must be positive, got 0");
  refused([&] { require_positive("photons", int64_t(-1)); }, "", "got -1");
  refused([&] { require_positive("radius", -0.5); }, "", "got -0.5");
  RenderOptions z = small_run(Estimator::Sppm, 0);
  refused([&] { check_options(z); }, "", "--passes must be positive, got 0");
}
