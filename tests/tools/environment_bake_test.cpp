// scene-bake --environment (and render --scene SOURCE, NAME.bake-options): a scene whose only
// light is the environment bakes and renders; bad maps — not 2:1, NaN or negative texels, larger
// than 8192 x 4096, truncated, a directory, missing, another format, black — exit 2 with one line
// on stderr naming the file, and write no output.
#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>

#include "photonflow/geometry/environment.h"
#include "photonflow/geometry/scene.h"
#include "photonflow/geometry/scene_file.h"
#include "photonflow/image/image.h"
#include "support.h"

using namespace pf;
using namespace pf::test;

namespace {

// A lightless scene: one quad (OBJ, no material library: diffuse grey).
void write_quad(const std::string& path) {
  std::ofstream(path) << "v -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\nf 1 3 2\nf 1 4 3\n";
}

void write_map(const std::string& path, int w, int h, float value = 0.5f) {
  Image img(w, h);
  for (float& v : img.rgb) v = value;
  write_exr(img, path);
}

// A flat (not run-length encoded) Radiance RGBE file of w × h texels of mantissa `m`, exponent
// `e` (value m/256 · 2^(e−128)); `rows` of the h rows written (fewer: a cut file).
void write_hdr(const std::string& path, int w, int h, int rows, unsigned char m = 128,
               unsigned char e = 129) {
  std::ofstream f(path, std::ios::binary);
  f << "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y " << h << " +X " << w << "\n";
  for (long long i = 0; i < (long long)w * rows; ++i) f << m << m << m << e;
}

bool one_line(const std::string& s) {
  return !s.empty() && s.find('\n') == s.size() - 1;
}

}  // namespace

TEST_CASE("tools: scene-bake bakes a scene lit by the environment alone", "[tools][environment]") {
  TempDir tmp("env-bake");
  write_quad(tmp / "quad.obj");
  write_map(tmp / "sky.exr", 32, 16, 0.25f);
  SECTION("without --environment the scene has no light") {
    ToolRun r = run_tool("scene-bake", tmp / "quad.obj" + " --no-options-file -o " + tmp / "s.h5", tmp);
    CHECK(r.exit_code == 2);
    CHECK(r.err.find("no light") != std::string::npos);
    CHECK(!std::filesystem::exists(tmp / "s.h5"));
  }
  SECTION("a map file, strength and rotation reach scene.h5") {
    ToolRun r = run_tool("scene-bake", tmp / "quad.obj" + " --no-options-file --environment " +
                                           tmp / "sky.exr" + " --environment-strength 2 "
                                           "--environment-rotate 45 -o " + tmp / "s.h5", tmp);
    INFO(r.err);
    REQUIRE(r.exit_code == 0);
    const Scene s = load_scene(tmp / "s.h5");
    REQUIRE(s.environment.present());
    CHECK(s.environment.width == 32);
    CHECK(s.environment.strength == 2.f);
    CHECK(s.environment.rotation_deg == 45.f);
    CHECK(s.lights.size() == 1);
    CHECK(s.lights[0].type == PF_LIGHT_ENVIRONMENT);
    CHECK(s.environment_radiance(Vec3(0, 1, 0)).x == 0.5f);
  }
  SECTION("a constant colour, and a Radiance .hdr map") {
    ToolRun r = run_tool("scene-bake", tmp / "quad.obj" + " --no-options-file --environment "
                                           "0.5,1,2 -o " + tmp / "c.h5", tmp);
    INFO(r.err);
    REQUIRE(r.exit_code == 0);
    CHECK(load_scene(tmp / "c.h5").environment_radiance(Vec3(1, 0, 0)).z == 2.f);
    write_hdr(tmp / "sky.hdr", 16, 8, 8);  // 128/256 · 2^1 = 1
    r = run_tool("scene-bake", tmp / "quad.obj" + " --no-options-file --environment " +
                                   tmp / "sky.hdr" + " -o " + tmp / "h.h5", tmp);
    INFO(r.err);
    REQUIRE(r.exit_code == 0);
    CHECK(load_scene(tmp / "h.h5").environment_radiance(Vec3(0, -1, 0)).y == 1.f);
  }
  SECTION("render --scene SOURCE takes it from NAME.bake-options") {
    std::ofstream(tmp / "quad.bake-options") << "--environment " << (tmp / "sky.exr")
                                             << "\n--width 8 --height 8\n";
    ToolRun r = run_tool("render", "--scene " + tmp / "quad.obj" + " --passes 1 --photons 16384 -o " +
                                       tmp / "r.exr", tmp);
    INFO(r.err);
    CHECK(r.exit_code == 0);
    CHECK(std::filesystem::exists(tmp / "r.exr"));
  }
}

TEST_CASE("tools: scene-bake refuses bad environment maps with one line", "[tools][environment]") {
  TempDir tmp("env-bad");
  write_quad(tmp / "quad.obj");
  struct Case {
    const char* name;
    std::string map;  // the --environment value
    const char* says;  // part of the line
  };
  write_map(tmp / "square.exr", 16, 16);
  {
    Image img(16, 8);
    for (float& v : img.rgb) v = 0.5f;
    img.rgb[3 * 20 + 1] = std::numeric_limits<float>::quiet_NaN();
    write_exr(img, tmp / "nan.exr");
    img.rgb[3 * 20 + 1] = -1.f;
    write_exr(img, tmp / "negative.exr");
    for (float& v : img.rgb) v = 0.f;
    write_exr(img, tmp / "black.exr");
  }
  write_map(tmp / "whole.exr", 64, 32);
  {
    const std::string bytes = file_bytes(tmp / "whole.exr");
    std::ofstream(tmp / "cut.exr", std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  }
  write_hdr(tmp / "huge.hdr", 16384, 8192, 1);  // the header promises more than the bound
  write_hdr(tmp / "cut.hdr", 16, 8, 4);          // half its rows
  std::filesystem::create_directories(tmp / "folder.exr");
  std::ofstream(tmp / "map.png") << "not an image";
  for (const Case& c : {Case{"not 2:1", tmp / "square.exr", "2 x height"},
                        Case{"a NaN texel", tmp / "nan.exr", "NaN"},
                        Case{"a negative texel", tmp / "negative.exr", "negative"},
                        Case{"black", tmp / "black.exr", "black"},
                        Case{"larger than the bound", tmp / "huge.hdr", "largest accepted"},
                        Case{"a truncated EXR", tmp / "cut.exr", "cannot read"},
                        Case{"a truncated .hdr", tmp / "cut.hdr", "is cut"},
                        Case{"a directory", tmp / "folder.exr", "not a regular file"},
                        Case{"missing", tmp / "none.exr", "cannot open"},
                        Case{"another format", tmp / "map.png", ".exr"},
                        Case{"a negative colour", "1,-1,1", "negative"},
                        Case{"a zero strength", tmp / "whole.exr' --environment-strength '0", "strength"}}) {
    ToolRun r = run_tool("scene-bake", tmp / "quad.obj" + " --no-options-file --environment '" +
                                           c.map + "' -o " + tmp / "out.h5", tmp, "", 60);
    INFO(c.name << ": " << r.err);
    CHECK(r.exit_code == 2);
    CHECK(one_line(r.err));
    CHECK(r.err.find(c.says) != std::string::npos);
    CHECK(!std::filesystem::exists(tmp / "out.h5"));
    CHECK(temporary_files(tmp.dir).empty());
  }
}
