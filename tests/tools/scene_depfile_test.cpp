// scene-bake --depfile and pipelines/render.mk: the bake's dependency file lists every file the
// bake read (the scene, its options file, buffers, the environment map), leaves out names make
// would read as syntax, and make render bakes again when one of them changes — and only then.
#include <catch2/catch.hpp>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "photonflow/foundations/make_depfile.h"
#include "support.h"

using namespace pf;
namespace fs = std::filesystem;

namespace {

std::string q(const std::string& s) { return "'" + s + "'"; }

bool has_line(const std::string& text, const std::string& line) {
  return ("\n" + text).find("\n" + line + "\n") != std::string::npos;
}

// data/hdri-object.gltf with its buffer, options file and map copied into `dir` (the options
// file names the map relative to itself).
void copy_hdri_object(const fs::path& dir) {
  fs::create_directories(dir);
  for (const char* f : {"hdri-object.gltf", "hdri-object.bake-options", "outside.bin", "sky.hdr"})
    fs::copy_file(fs::path(test::source_dir()) / "data" / f, dir / f);
}

}  // namespace

TEST_CASE("make depfile: plain names only, each once, an empty rule for each",
          "[tools][depfile]") {
  CHECK(make_safe_name("data/sky.hdr"));
  CHECK(make_safe_name("/tmp/a-b_c+d@e,f~g.glb"));
  for (const char* bad : {"", "-o", "~/x", "a b", "a$b", "a:b", "a#b", "a%b", "a\\b", "a'b",
                          "a\"b", "a\nb", "a;b", "a=b", "a*b", "caf\xc3\xa9"})
    CHECK_FALSE(make_safe_name(bad));
  size_t left = 99;
  const std::string t =
      make_depfile_text("out/s.h5", {"a.gltf", "a.bin", "a$(shell touch x).bin", "a.bin", "b c"},
                        &left);
  CHECK(left == 2);
  CHECK(t.find("$") == std::string::npos);
  CHECK(t.find("b c") == std::string::npos);
  CHECK(t.find("2 left out") != std::string::npos);
  CHECK(t.find("out/s.h5: \\\n  a.gltf \\\n  a.bin\n") != std::string::npos);
  CHECK(has_line(t, "a.gltf:"));
  CHECK(has_line(t, "a.bin:"));
  CHECK(t.find("a.bin \\\n  a.bin") == std::string::npos);  // once
  CHECK_THROWS_AS(make_depfile_text("out/$(x).h5", {"a"}), std::invalid_argument);
}

TEST_CASE("scene-bake --depfile lists the scene, options file, buffer and environment map",
          "[tools][depfile][environment]") {
  test::TempDir tmp("scene-depfile");
  copy_hdri_object(tmp.dir / "in");
  const std::string scene = tmp / "in/hdri-object.gltf";
  const auto r = test::run_tool("scene-bake", q(scene) + " -o " + q(tmp / "s.h5") +
                                                  " --width 16 --height 16 --depfile " +
                                                  q(tmp / "s.d"),
                                tmp);
  INFO(r.err);
  REQUIRE(r.exit_code == 0);
  const std::string d = test::file_bytes(tmp / "s.d");
  CHECK(d.find(tmp / "s.h5" + ": \\\n") != std::string::npos);
  for (const char* f : {"hdri-object.gltf", "hdri-object.bake-options", "outside.bin", "sky.hdr"}) {
    INFO(f);
    CHECK(d.find(tmp / "in" + "/" + f) != std::string::npos);
  }
  // A bad --depfile: refused before the bake, no scene written.
  const auto bad = test::run_tool("scene-bake", q(scene) + " -o " + q(tmp / "t.h5") +
                                                    " --width 16 --height 16 --depfile " +
                                                    q(tmp / "no/such/dir/t.d"),
                                  tmp);
  CHECK(bad.exit_code == 2);
  CHECK_FALSE(fs::exists(tmp / "t.h5"));
}

TEST_CASE("make render bakes again when the environment map changes, and not otherwise",
          "[tools][depfile][dag][environment]") {
  test::TempDir tmp("scene-depfile-make");
  copy_hdri_object(tmp.dir / "in");
  const std::string make = "make -s --no-print-directory -C " + q(test::source_dir()) +
                           " -f pipelines/render.mk BIN=" + q(test::bin_dir()) + " OUT=" +
                           q(tmp / "out") + " WIDTH=16 HEIGHT=16 PASSES=1 SCENE=" +
                           q(tmp / "in/hdri-object.gltf") + " render > " + q(tmp / "make.log") +
                           " 2>&1";
  REQUIRE(std::system(make.c_str()) == 0);
  const fs::path h5 = tmp.dir / "out/hdri-object/scene.h5";
  REQUIRE(fs::exists(h5));
  REQUIRE(fs::exists(tmp / "out/hdri-object/scene.d"));
  // The outputs an hour ahead and the inputs an hour behind (the tools, just built, lie between):
  // a bake then shows as an output time other than `ahead`, and an input is made newer than the
  // outputs by setting it two hours ahead. (make may note the clock skew; it is not an error.)
  const auto now = fs::file_time_type::clock::now();
  const auto ahead = now + std::chrono::hours(1);
  auto age = [&] {
    for (const auto& e : fs::directory_iterator(tmp.dir / "out/hdri-object"))
      fs::last_write_time(e.path(), ahead);
    for (const auto& e : fs::directory_iterator(tmp.dir / "in"))
      fs::last_write_time(e.path(), now - std::chrono::hours(1));
  };
  age();
  REQUIRE(std::system(make.c_str()) == 0);
  CHECK(fs::last_write_time(h5) == ahead);  // nothing changed: no bake
  fs::last_write_time(tmp.dir / "in/sky.hdr", now + std::chrono::hours(2));
  REQUIRE(std::system(make.c_str()) == 0);
  CHECK(fs::last_write_time(h5) != ahead);  // the map changed: baked again
  age();
  fs::last_write_time(tmp.dir / "in/outside.bin", now + std::chrono::hours(2));
  REQUIRE(std::system(make.c_str()) == 0);
  CHECK(fs::last_write_time(h5) != ahead);  // the glTF buffer changed: baked again
}
