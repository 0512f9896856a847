// Option fuzz (issue 33): every numeric option of render (each estimator), merge, synthesize and
// scene-bake at 0, −1, ±1e-300, ±1e308, NaN, ±inf, 2^31 − 1, 2^31, 2^31 + 1 and 2^63, one at a time
// on an otherwise small valid command. Each run must end in
//   exit 0 with finite image values and files that the next stage accepts (the checkpoint or pass
//        sums by their loaders, the baked scene by load_scene), or
//   exit 2 with one line on stderr and none of the run's outputs,
// never exit 1 (an internal error), never a signal, and never a run past kSeconds (a small image
// and a few passes: an option that asks for unbounded work must be refused, not attempted).
// No temporary file is left behind either way. PF_OPTION_FUZZ_VERBOSE=1 prints every run.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <iostream>
#include <string>
#include <vector>

#include "photonflow/image/image.h"
#include "photonflow/estimators/pass_sums.h"
#include "photonflow/estimators/render_driver.h"
#include "photonflow/geometry/scene.h"
#include "photonflow/geometry/scene_file.h"
#include "photonflow/io/stage_files.h"
#include "support.h"

using namespace pf;
using test::TempDir;

namespace {

constexpr int kSeconds = 20;  // a hang guard for runs of well under a second, not a speed target

const std::vector<std::string>& values() {
  static const std::vector<std::string> v = {
      "0",          "-1",         "1e-300",     "-1e-300",    "1e308",      "-1e308",
      "nan",        "inf",        "-inf",       "2147483647", "2147483648", "2147483649",
      "9223372036854775808"};
  return v;
}

struct Outputs {
  std::vector<std::string> images;  // OpenEXR files whose values must be finite
  // Files the next stage reads, with its loader: throws InputError when it refuses them.
  std::vector<std::pair<std::string, std::function<void(const std::string&)>>> files;
  std::vector<std::string> others;  // further outputs (previews, records): gone after a refusal
};

struct Tally {
  int runs = 0, accepted = 0, refused = 0;
};

// Runs `tool args`, checks the outcome as above, and counts it.
void run_one(const TempDir& tmp, const std::string& tool, const std::string& args,
             const Outputs& outs, Tally& tally) {
  std::vector<std::string> all = outs.images;
  for (const auto& [f, load] : outs.files) all.push_back(f);
  all.insert(all.end(), outs.others.begin(), outs.others.end());
  for (const std::string& f : all) std::filesystem::remove(f);
  const test::ToolRun r = test::run_tool(tool, args, tmp, "", kSeconds);
  ++tally.runs;
  if (std::getenv("PF_OPTION_FUZZ_VERBOSE"))
    std::cout << tool << " " << args << " -> " << r.exit_code << " " << r.err;
  INFO(tool << " " << args << "\nexit " << r.exit_code << "\nstderr: " << r.err);
  CHECK((r.exit_code == 0 || r.exit_code == kExitBadInput));
  CHECK(test::temporary_files(tmp.dir).empty());
  if (r.exit_code == kExitBadInput) {
    ++tally.refused;
    CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
    for (const std::string& f : all) CHECK_FALSE(std::filesystem::exists(f));
    return;
  }
  if (r.exit_code != 0) return;
  ++tally.accepted;
  for (const std::string& f : outs.images) {
    REQUIRE(std::filesystem::exists(f));
    const Image img = read_exr(f);
    const auto bad = std::find_if(img.rgb.begin(), img.rgb.end(), [](float x) { return !std::isfinite(x); });
    CHECK(bad == img.rgb.end());
  }
  for (const auto& [f, load] : outs.files) {
    REQUIRE(std::filesystem::exists(f));
    try {
      load(f);
    } catch (const InputError& e) {
      FAIL_CHECK("the next stage refuses what the run wrote: " << e.what());
    }
  }
}

// Every value of `values()` for each option, on `base(option)` (the command without that option).
void fuzz_options(const TempDir& tmp, const std::string& tool, const std::vector<std::string>& options,
                  const std::function<std::string(const std::string&)>& base,
                  const std::function<std::string(const std::string&, const std::string&)>& spell,
                  const Outputs& outs, const std::string& label) {
  Tally t;
  for (const std::string& o : options)
    for (const std::string& v : values()) run_one(tmp, tool, base(o) + " " + spell(o, v), outs, t);
  std::cout << "option fuzz " << label << ": " << t.runs << " runs, " << t.accepted
            << " accepted with finite outputs the next stage reads, " << t.refused
            << " refused with one line\n";
}

std::string plain(const std::string& o, const std::string& v) { return "--" + o + " " + v; }

// The command line without `drop` and its value: "--name value" pairs and bare flags.
std::string without(const std::vector<std::pair<std::string, std::string>>& args,
                    const std::string& drop) {
  std::string s;
  for (const auto& [name, value] : args)
    if (name != drop) s += " --" + name + (value.empty() ? "" : " " + value);
  return s;
}

struct Fixture {
  TempDir tmp{"optfuzz"};
  std::string scene = tmp / "scene.h5";
  Fixture() {
    const Scene s = test::room_scene(PF_MAT_GLASS, 10, 8);
    save_scene(s, scene, Provenance{});
  }
};

Fixture& fixture() {
  static Fixture f;
  return f;
}

const std::vector<std::string> kRenderNumeric = {
    "passes",       "time",           "first-pass",  "photons",       "alpha",
    "slab",         "max-bins",       "spp",         "max-depth",     "max-bounces",
    "shadow-samples", "radius",       "seed",        "checkpoint-every", "snapshot-every",
    "snapshot-at",  "exposure",       "threads",     "cl-platform",   "cl-device",
    "work-group"};

void fuzz_render(const std::string& estimator, const std::string& direct) {
  Fixture& fx = fixture();
  const TempDir& tmp = fx.tmp;
  const std::string out = tmp / "r.exr", ck = tmp / "ck.h5", stats = tmp / "r.json";
  const std::vector<std::pair<std::string, std::string>> args = {
      {"scene", fx.scene}, {"output", out},       {"estimator", estimator},
      {"passes", "2"},     {"photons", "300"},    {"threads", "1"},
      {"direct", direct},  {"checkpoint", ck},    {"stats", stats},
      {"snapshot", tmp / "snap-{pass}.exr"}};
  Outputs outs;
  outs.images = {out};
  if (estimator == "pppm")
    outs.files = {{ck, [](const std::string& f) { load_pass_sums(f); }}};
  else
    outs.files = {{ck, [](const std::string& f) { load_hitpoints(f); }}};
  outs.others = {pf::preview_path(out), stats, tmp / "snap-1.exr", tmp / "snap-2.exr"};
  fuzz_options(
      tmp, "render", kRenderNumeric,
      [&](const std::string& o) {
        // An option that sets the number of passes runs under a budget: 2^31 − 1 passes are a
        // valid request, which --time bounds.
        std::string b = without(args, o);
        if (o == "passes") b += " --time 1";
        return b;
      },
      plain, outs, "render " + estimator + " " + direct);
}

}  // namespace

TEST_CASE("option fuzz: render --estimator sppm", "[fuzz][options][render]") {
  fuzz_render("sppm", "photons");
}
TEST_CASE("option fuzz: render --estimator pppm --direct shadow-rays", "[fuzz][options][render]") {
  fuzz_render("pppm", "shadow-rays");
}
TEST_CASE("option fuzz: render --estimator ppm", "[fuzz][options][render]") {
  fuzz_render("ppm", "photons");
}

TEST_CASE("option fuzz: merge and synthesize", "[fuzz][options][merge]") {
  Fixture& fx = fixture();
  const TempDir& tmp = fx.tmp;
  // Two parts of one pppm run: passes [0, 2) and [2, 3).
  const std::string a = tmp / "part-a.h5", b = tmp / "part-b.h5";
  const std::string common = "--scene " + fx.scene + " --estimator pppm --photons 300 --threads 1";
  REQUIRE(test::run_tool("render", common + " --passes 2 --sums " + a, tmp).exit_code == 0);
  REQUIRE(test::run_tool("render", common + " --first-pass 2 --passes 1 --sums " + b, tmp).exit_code == 0);
  const std::string out = tmp / "m.exr", sums = tmp / "m.h5";
  Outputs outs;
  outs.images = {out};
  outs.files = {{sums, [](const std::string& f) { load_pass_sums(f); }}};
  outs.others = {pf::preview_path(out)};
  fuzz_options(
      tmp, "merge", {"exposure", "range-first", "range-end"},
      [&](const std::string&) { return a + " " + b + " -o " + out + " --sums " + sums; },
      [](const std::string& o, const std::string& v) {
        if (o == "range-first") return "--range " + v + ":3";
        if (o == "range-end") return "--range 0:" + v;
        return plain(o, v);
      },
      outs, "merge");
  Outputs img;
  img.images = {out};
  img.others = {pf::preview_path(out)};
  fuzz_options(
      tmp, "synthesize", {"exposure"},
      [&](const std::string&) { return "--sums " + a + " -o " + out; }, plain, img, "synthesize");
}

TEST_CASE("option fuzz: scene-bake", "[fuzz][options][scene-bake]") {
  Fixture& fx = fixture();
  const TempDir& tmp = fx.tmp;
  const std::string input = test::source_dir() + "/data/cornell-box.dae", out = tmp / "baked.h5";
  Outputs outs;
  outs.files = {{out, [](const std::string& f) { load_scene(f); }}};
  fuzz_options(
      tmp, "scene-bake",
      {"width", "height", "fov", "eye", "look-at", "up", "kd-ct", "kd-ci", "kd-empty-bonus",
       "kd-max-depth", "kd-max-leaf", "import-memory-mb", "import-seconds", "threads"},
      [&](const std::string& o) {
        // Both sides given when one is fuzzed (the other follows the file camera's aspect).
        std::string b = input + " -o " + out;
        if (o != "width") b += " --width 16";
        if (o != "height") b += " --height 12";
        return b;
      },
      [](const std::string& o, const std::string& v) {
        if (o == "eye") return "--eye " + v + ",1,3";
        if (o == "look-at") return "--look-at 0," + v + ",0";
        if (o == "up") return "--up 0,1," + v;
        return plain(o, v);
      },
      outs, "scene-bake");
}
