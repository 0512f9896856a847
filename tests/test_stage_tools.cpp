// The render stages as executables (issue 3): bad input refused with one line and no output, the
// staged route equal to the render driver, kill-and-resume equal to an uninterrupted run, and the
// Make DAG's caching.
#include <catch2/catch.hpp>

#include <cstring>
#include <filesystem>
#include <fstream>

#include "photonflow/image.h"
#include "support.h"

using namespace pf;
using test::run_tool;
using test::TempDir;

namespace {

// Bakes data/<name> at a small size into tmp/<out>.
void bake(const TempDir& tmp, const std::string& name, const std::string& out) {
  auto r = run_tool("scene-bake",
                    std::string(PF_SOURCE_DIR) + "/data/" + name + " -o " + (tmp / out) +
                        " --width 40 --height 30",
                    tmp);
  REQUIRE(r.exit_code == 0);
}

// Checks a refused run: exit 2, one line on stderr naming what is wrong, no output file.
void check_refused(const test::ToolRun& r, const std::string& output, const std::string& needle) {
  INFO("stderr: " << r.err);
  CHECK(r.exit_code == 2);
  CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
  CHECK(r.err.find(needle) != std::string::npos);
  CHECK_FALSE(std::filesystem::exists(output));
  for (auto& e : std::filesystem::directory_iterator(std::filesystem::path(output).parent_path()))
    CHECK(e.path().string().find(".tmp.") == std::string::npos);
}

bool same_pixels(const Image& a, const Image& b) {
  return a.width == b.width && a.height == b.height && a.rgb == b.rgb;
}

}  // namespace

TEST_CASE("stages refuse bad input with one line, exit code 2 and no output", "[tools][badinput]") {
  TempDir tmp("stages");
  bake(tmp, "cornell-box.dae", "box.h5");
  bake(tmp, "cornell-spheres.dae", "spheres.h5");
  std::string box = tmp / "box.h5", spheres = tmp / "spheres.h5", out = tmp / "out.h5";
  REQUIRE(run_tool("trace-hitpoints", "--scene " + box + " -o " + (tmp / "hp.h5"), tmp).exit_code == 0);
  REQUIRE(run_tool("trace-photons", "--scene " + box + " -o " + (tmp / "ph.h5") + " --photons 2000", tmp).exit_code == 0);
  REQUIRE(run_tool("trace-photons", "--scene " + spheres + " -o " + (tmp / "ph-other.h5") + " --photons 2000", tmp).exit_code == 0);
  REQUIRE(run_tool("trace-hitpoints", "--scene " + spheres + " -o " + (tmp / "hp-other.h5"), tmp).exit_code == 0);
  std::string hp = tmp / "hp.h5", ph = tmp / "ph.h5";

  SECTION("hitpoints from another scene") {
    check_refused(run_tool("illuminate", "--scene " + box + " --hitpoints " + (tmp / "hp-other.h5") +
                                             " --photons " + ph + " -o " + out, tmp),
                  out, "different scene");
  }
  SECTION("photons from another scene") {
    check_refused(run_tool("illuminate", "--scene " + box + " --hitpoints " + hp + " --photons " +
                                             (tmp / "ph-other.h5") + " -o " + out, tmp),
                  out, "different scene");
    check_refused(run_tool("build-grid", "--scene " + box + " --photons " + (tmp / "ph-other.h5") +
                                             " --hitpoints " + hp + " -o " + out, tmp),
                  out, "different scene");
  }
  SECTION("a truncated HDF5 file") {
    std::string cut = tmp / "cut.h5";
    std::filesystem::copy_file(ph, cut);
    std::filesystem::resize_file(cut, std::filesystem::file_size(ph) / 3);
    check_refused(run_tool("illuminate", "--scene " + box + " --hitpoints " + hp + " --photons " +
                                             cut + " -o " + out, tmp),
                  out, cut);
  }
  SECTION("a foreign file: photons where hitpoints belong, text where HDF5 belongs") {
    check_refused(run_tool("illuminate", "--scene " + box + " --hitpoints " + ph + " --photons " +
                                             ph + " -o " + out, tmp),
                  out, "expected photonflow.hitpoints");
    std::string text = tmp / "text.h5";
    std::ofstream(text) << "hello\n";
    check_refused(run_tool("synthesize", "--hitpoints " + text + " -o " + (tmp / "img.exr"), tmp),
                  tmp / "img.exr", "not a readable HDF5");
    check_refused(run_tool("trace-photons", "--scene " + hp + " -o " + out, tmp), out,
                  "expected photonflow.scene");
  }
  SECTION("zero or negative photon counts") {
    check_refused(run_tool("trace-photons", "--scene " + box + " -o " + out + " --photons 0", tmp),
                  out, "--photons must be positive");
    check_refused(run_tool("trace-photons", "--scene " + box + " -o " + out + " --photons -5", tmp),
                  out, "--photons must be positive");
    check_refused(run_tool("render", "--scene " + box + " -o " + (tmp / "r.exr") + " --photons 0", tmp),
                  tmp / "r.exr", "--photons must be positive");
  }
  SECTION("radius or alpha out of range") {
    check_refused(run_tool("trace-hitpoints", "--scene " + box + " -o " + out + " --radius -1", tmp),
                  out, "--radius must be 0 (automatic) or a positive length");
    for (const char* a : {"0", "1.5", "-0.2"})
      check_refused(run_tool("illuminate", "--scene " + box + " --hitpoints " + hp + " --photons " +
                                               ph + " -o " + out + " --alpha " + a, tmp),
                    out, "--alpha must be in (0, 1]");
    check_refused(run_tool("render", "--scene " + box + " -o " + (tmp / "r.exr") + " --alpha 2", tmp),
                  tmp / "r.exr", "--alpha must be in (0, 1]");
  }
  SECTION("photons of the wrong pass for the hitpoint state") {
    REQUIRE(run_tool("trace-photons", "--scene " + box + " -o " + (tmp / "ph3.h5") +
                                          " --photons 2000 --first-pass 3", tmp).exit_code == 0);
    check_refused(run_tool("illuminate", "--scene " + box + " --hitpoints " + hp + " --photons " +
                                             (tmp / "ph3.h5") + " -o " + out, tmp),
                  out, "--first-pass 0");
  }
  SECTION("a fresh hitpoint file cannot be synthesized") {
    check_refused(run_tool("synthesize", "--hitpoints " + hp + " -o " + (tmp / "img.exr"), tmp),
                  tmp / "img.exr", "illuminate");
  }
}

TEST_CASE("the staged route gives the render driver's image", "[tools][staged]") {
  TempDir tmp("staged");
  bake(tmp, "cornell-spheres.dae", "scene.h5");
  std::string scene = tmp / "scene.h5";
  for (std::string gather : {"grid", "flann"}) {
    // Passes 0-1 in one photons file, pass 2 in another: illuminate continues the state.
    REQUIRE(run_tool("trace-hitpoints", "--scene " + scene + " -o " + (tmp / "hp.h5") + " --spp 2", tmp).exit_code == 0);
    REQUIRE(run_tool("trace-photons", "--scene " + scene + " -o " + (tmp / "ph01.h5") + " --photons 5000 --passes 2", tmp).exit_code == 0);
    REQUIRE(run_tool("trace-photons", "--scene " + scene + " -o " + (tmp / "ph2.h5") + " --photons 5000 --first-pass 2", tmp).exit_code == 0);
    if (gather == "grid") {
      REQUIRE(run_tool("build-grid", "--scene " + scene + " --photons " + (tmp / "ph01.h5") + " --hitpoints " + (tmp / "hp.h5") + " -o " + (tmp / "grid01.h5"), tmp).exit_code == 0);
      REQUIRE(run_tool("illuminate", "--scene " + scene + " --hitpoints " + (tmp / "hp.h5") + " --grid " + (tmp / "grid01.h5") + " -o " + (tmp / "s2.h5"), tmp).exit_code == 0);
    } else {
      REQUIRE(run_tool("illuminate", "--scene " + scene + " --hitpoints " + (tmp / "hp.h5") + " --photons " + (tmp / "ph01.h5") + " --method flann -o " + (tmp / "s2.h5"), tmp).exit_code == 0);
    }
    REQUIRE(run_tool("illuminate", "--scene " + scene + " --hitpoints " + (tmp / "s2.h5") + " --photons " + (tmp / "ph2.h5") + " --method " + gather + " -o " + (tmp / "s3.h5"), tmp).exit_code == 0);
    REQUIRE(run_tool("synthesize", "--hitpoints " + (tmp / "s3.h5") + " -o " + (tmp / "staged.exr"), tmp).exit_code == 0);
    REQUIRE(run_tool("render", "--scene " + scene + " -o " + (tmp / "driver.exr") + " --spp 2 --photons 5000 --passes 3 --method " + gather, tmp).exit_code == 0);
    Image staged = read_exr(tmp / "staged.exr"), driver = read_exr(tmp / "driver.exr");
    INFO("gather " << gather);
    CHECK(same_pixels(staged, driver));
    double sum = 0;
    for (float v : driver.rgb) sum += v;
    CHECK(sum > 0);
  }
}

TEST_CASE("a killed render resumes to the uninterrupted image", "[tools][resume]") {
  TempDir tmp("resume");
  bake(tmp, "cornell-box.dae", "scene.h5");
  std::string scene = tmp / "scene.h5";
  const std::string common = "--scene " + scene + " --photons 20000 --passes 12";
  REQUIRE(run_tool("render", common + " -o " + (tmp / "full.exr"), tmp).exit_code == 0);
  // Interrupted after a few passes (a real SIGKILL at some point after the first checkpoint).
  std::string ck = tmp / "ck.h5";
  std::string cmd = "timeout -s KILL 0.4 " + test::bin_dir() + "/render " + common + " -o " +
                    (tmp / "x.exr") + " --checkpoint " + ck + " --checkpoint-every 1 >/dev/null 2>&1";
  int status = std::system(cmd.c_str());
  (void)status;  // killed or finished: both must resume to the same image
  CHECK_FALSE(std::filesystem::exists(tmp / "x.exr.tmp"));
  REQUIRE(run_tool("render", common + " -o " + (tmp / "resumed.exr") + " --checkpoint " + ck +
                                 " --checkpoint-every 1 --resume", tmp).exit_code == 0);
  CHECK(same_pixels(read_exr(tmp / "full.exr"), read_exr(tmp / "resumed.exr")));
  // Resuming a finished run with fewer passes than it has is refused.
  auto r = run_tool("render", "--scene " + scene + " --photons 20000 --passes 5 -o " +
                                  (tmp / "y.exr") + " --checkpoint " + ck + " --resume", tmp);
  CHECK(r.exit_code == 2);
}

TEST_CASE("the Make DAG reruns exactly the stages whose parameters changed", "[tools][dag]") {
  TempDir tmp("dag");
  const std::string make = "make --no-print-directory -C " + std::string(PF_SOURCE_DIR) +
                           " -f pipelines/render.mk BIN=" + test::bin_dir() + " OUT=" +
                           tmp.dir.string() + " WIDTH=32 HEIGHT=24 PASSES=2";
  // Runs make with `vars` and returns the stages it ran, in order.
  auto stages = [&](const std::string& vars) {
    std::string log = tmp / "make.log";
    std::string cmd = make + " " + vars + " render > " + log + " 2>&1";
    REQUIRE(std::system(cmd.c_str()) == 0);
    std::ifstream f(log);
    std::string line, found;
    while (std::getline(f, line))
      for (const char* s : {"scene-bake", "trace-hitpoints", "trace-photons", "build-grid",
                            "illuminate", "synthesize"})
        if (!line.empty() && line[0] == '/' &&  // an echoed recipe: the tool's absolute path
            line.find(std::string("/") + s + " ") != std::string::npos)
          found += std::string(s) + " ";
    return found;
  };
  const std::string base = "PHOTONS=3000 ALPHA=0.7";
  CHECK(stages(base) == "scene-bake trace-hitpoints trace-photons build-grid illuminate synthesize ");
  CHECK(stages(base) == "");
  CHECK(stages("PHOTONS=3000 ALPHA=0.5") == "illuminate synthesize ");
  CHECK(stages("PHOTONS=4000 ALPHA=0.5") == "trace-photons build-grid illuminate synthesize ");
  CHECK(stages("PHOTONS=4000 ALPHA=0.5 SPP=2") == "trace-hitpoints build-grid illuminate synthesize ");
  CHECK(stages("PHOTONS=4000 ALPHA=0.5 SPP=2 EXPOSURE=1") == "synthesize ");
  CHECK(stages("PHOTONS=4000 ALPHA=0.5 SPP=2 EXPOSURE=1") == "");
}

// Long runs go through the render driver with a checkpoint (render.mk). A rerun after a state
// option changed starts afresh (render --resume would refuse the old checkpoint), one after more
// PASSES resumes; both give the image of an uninterrupted run with those options.
TEST_CASE("the Make DAG's render driver restarts after a state option changed, resumes otherwise",
          "[tools][dag][resume]") {
  TempDir tmp("dag-driver");
  const std::string make = "make -s --no-print-directory -C " + std::string(PF_SOURCE_DIR) +
                           " -f pipelines/render.mk BIN=" + test::bin_dir() + " OUT=" +
                           tmp.dir.string() + " WIDTH=32 HEIGHT=24 PHOTONS=2000 STAGED_MAX_PASSES=2";
  const std::string dir = tmp / "cornell-box";
  auto make_ok = [&](const std::string& vars) {
    const std::string cmd = make + " " + vars + " render > " + (tmp / "make.log") + " 2>&1";
    REQUIRE(std::system(cmd.c_str()) == 0);
  };
  auto fresh = [&](const std::string& opts, const std::string& name) {
    REQUIRE(run_tool("render", "--scene " + dir + "/scene.h5 --photons 2000 " + opts + " -o " +
                                   (tmp / name), tmp)
                .exit_code == 0);
    return read_exr(tmp / name);
  };
  make_ok("PASSES=3 ALPHA=0.7");
  REQUIRE(std::filesystem::exists(dir + "/render-checkpoint.h5"));
  make_ok("PASSES=3 ALPHA=0.5");
  CHECK(same_pixels(read_exr(dir + "/render.exr"), fresh("--passes 3 --alpha 0.5", "a.exr")));
  make_ok("PASSES=5 ALPHA=0.5");
  CHECK(same_pixels(read_exr(dir + "/render.exr"), fresh("--passes 5 --alpha 0.5", "b.exr")));
}
