// The two data/ scenes lit from outside (issue 50 item 5): data/make_outside.py writes exactly the
// committed files (sky.hdr, window-room.gltf, hdri-object.gltf, outside.bin and their bake
// options), the window room bakes with the environment as its only light, sunlight comes in
// through the window onto a floor the camera sees, and a short render is not black inside. And
// the bench scene of the same room behind a glass pane (bench/scenes/make_window_pane.py): the
// script writes the committed files, and the pane closes the window to every sunbeam.

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <vector>

#include "photonflow/geometry/raycast.h"
#include "photonflow/geometry/scene.h"
#include "photonflow/geometry/scene_file.h"
#include "photonflow/image/image.h"
#include "support.h"

using namespace pf;

namespace {

std::string data_dir() { return test::source_dir() + "/data"; }

std::string python3() {
  return std::filesystem::exists("/usr/bin/python3") ? "/usr/bin/python3" : "python3";
}

// Bakes <dir>/<scene>.gltf as make render and docs/SCENES.md do: from the repository root, with
// its NAME.bake-options (whose --environment sky.hdr is resolved against the options file's
// folder).
Scene bake_from_root(const test::TempDir& tmp, const std::string& scene, const std::string& extra,
                     const std::string& dir = "data") {
  const std::string out = tmp / (scene + ".h5"), log = tmp / (scene + ".log");
  const std::string cmd = "cd '" + test::source_dir() + "' && '" + test::bin_dir() +
                          "/scene-bake' " + dir + "/" + scene + ".gltf -o '" + out + "' " + extra +
                          " > '" + log + "' 2>&1";
  const int status = std::system(cmd.c_str());
  INFO(cmd << "\n" << test::file_bytes(log));
  REQUIRE(status == 0);
  std::filesystem::remove(log);
  return load_scene(out);
}

float luminance(const float* c) { return 0.2126f * c[0] + 0.7152f * c[1] + 0.0722f * c[2]; }

// The direction of texel (row, col)'s centre (docs/SCENES.md, "Environment": Mitsuba 3's envmap).
Vec3 texel_direction(const Environment& env, int row, int col) {
  const float theta = 3.14159265f * (float(row) + 0.5f) / float(env.height);
  const float phi = 2.f * 3.14159265f * (float(col) + 0.5f) / float(env.width);
  return Vec3(std::sin(theta) * std::sin(phi), std::cos(theta), -std::sin(theta) * std::cos(phi));
}

// The brightest texel of the map (the sun), as an index into its texels.
size_t brightest_texel(const Environment& env) {
  size_t best = 0;
  for (size_t i = 0; i < size_t(env.width) * size_t(env.height); ++i)
    if (luminance(&env.texels[3 * i]) > luminance(&env.texels[3 * best])) best = i;
  return best;
}

// Point (i, k) of a kFloorX × kFloorZ grid over the floor y = 0 of bounds b, 1 mm above it.
constexpr int kFloorX = 40, kFloorZ = 50;
Vec3 floor_point(const Bounds& b, int i, int k) {
  return Vec3(b.lo.x + (float(i) + 0.5f) / float(kFloorX) * (b.hi.x - b.lo.x), 1e-3f,
              b.lo.z + (float(k) + 0.5f) / float(kFloorZ) * (b.hi.z - b.lo.z));
}

}  // namespace

TEST_CASE("make_outside.py writes exactly the committed sky and outside scenes", "[outside]") {
  test::TempDir tmp("outside-gen");
  const std::string cmd = python3() + " " + data_dir() + "/make_outside.py --out " +
                          tmp.dir.string() + " > " + (tmp / "log.txt") + " 2>&1";
  const int status = std::system(cmd.c_str());
  INFO(cmd << "\n" << test::file_bytes(tmp / "log.txt"));
  REQUIRE(status == 0);
  // Byte for byte, the sky too: its RGBE bytes are written by the script (no compressor).
  for (const char* name : {"sky.hdr", "window-room.gltf", "hdri-object.gltf", "outside.bin",
                           "window-room.bake-options", "hdri-object.bake-options"}) {
    INFO(name << ": data/ differs from what data/make_outside.py writes; run it and commit");
    const std::string committed = test::file_bytes(data_dir() + "/" + name);
    CHECK(!committed.empty());
    CHECK(test::file_bytes(tmp / name) == committed);
  }
  CHECK(tmp.file_count() == 7);  // the 6 files and the log: the script writes nothing else
}

TEST_CASE("the window room: the sky is its one light, the sun comes in through the window",
          "[outside]") {
  test::TempDir tmp("outside-room");
  const Scene s = bake_from_root(tmp, "window-room", "--width 32 --height 32");

  // Exactly one light, the environment; no emitter.
  REQUIRE(s.lights.size() == 1u);
  CHECK(s.lights[0].type == PF_LIGHT_ENVIRONMENT);
  for (const pf_material& m : s.materials) CHECK(m.type != PF_MAT_EMITTER);
  const Environment& env = s.environment;
  REQUIRE(env.present());
  CHECK(env.width == 512);
  CHECK(env.height == 256);
  CHECK(env.source == "data/sky.hdr");
  CHECK(env.strength > 1.f);

  // The sun: the brightest texel, 10^3 .. 10^4 times the zenith's radiance, above the horizon.
  const size_t sun = brightest_texel(env);
  const float zenith = luminance(&env.texels[3 * size_t(env.width / 2)]);
  const float ratio = luminance(&env.texels[3 * sun]) / zenith;
  CHECK(ratio > 1e3f);
  CHECK(ratio < 1e4f);
  const Vec3 to_sun = texel_direction(env, int(sun) / env.width, int(sun) % env.width);
  CHECK(to_sun.y > 0.3f);

  // Sunlight through the window: floor points that see the sun (a ray towards it leaves the room),
  // and the camera sees some of them (its ray to the point hits the floor there).
  int sunlit = 0, seen = 0;
  const Vec3 eye(s.camera.eye);
  for (int i = 0; i < kFloorX; ++i)
    for (int k = 0; k < kFloorZ; ++k) {
      const Vec3 p = floor_point(s.bounds, i, k);
      if (intersect_any(s, Ray{p, to_sun})) continue;
      ++sunlit;
      const Vec3 d = p - eye;
      Hit h;
      REQUIRE(intersect_closest(s, Ray{eye, normalize(d)}, h));
      seen += std::fabs(h.t - std::sqrt(dot(d, d))) < 1e-2f;
    }
  INFO(sunlit << " of 2000 floor points in the sun, " << seen << " of them in view");
  CHECK(sunlit > 40);
  CHECK(sunlit < 1000);  // the walls shade the rest: the room is closed but for the window
  CHECK(seen > sunlit / 2);

  // A short render: finite, and light everywhere inside (the shade too, from light that came in
  // through the window and bounced: the photons of the environment).
  const test::ToolRun r = test::run_tool(
      "render", "--scene " + (tmp / "window-room.h5") + " -o " + (tmp / "r.exr") +
                    " --passes 8 --threads 2", tmp);
  INFO(r.out << r.err);
  REQUIRE(r.exit_code == 0);
  const Image img = read_exr(tmp / "r.exr");
  std::vector<float> lum;
  for (size_t i = 0; i < img.rgb.size(); i += 3) {
    for (int c = 0; c < 3; ++c) REQUIRE(std::isfinite(img.rgb[i + size_t(c)]));
    lum.push_back(luminance(&img.rgb[i]));
  }
  std::sort(lum.begin(), lum.end());
  const float median = lum[lum.size() / 2], tenth = lum[lum.size() / 10];
  INFO("median " << median << ", 10th percentile " << tenth << ", brightest " << lum.back());
  CHECK(tenth > 0.f);
  CHECK(median > 0.01f);
  CHECK(lum.back() > 10.f * median);  // the sky seen through the window, or the sun patch
}

TEST_CASE("the object outdoors: the sky is its one light, and it renders", "[outside]") {
  test::TempDir tmp("outside-object");
  const Scene s = bake_from_root(tmp, "hdri-object", "--width 24 --height 24");
  REQUIRE(s.lights.size() == 1u);
  CHECK(s.lights[0].type == PF_LIGHT_ENVIRONMENT);
  CHECK(s.environment.source == "data/sky.hdr");
  CHECK(s.has_pbr());  // the glossy metal and the plastic
  const test::ToolRun r = test::run_tool(
      "render", "--scene " + (tmp / "hdri-object.h5") + " -o " + (tmp / "r.exr") +
                    " --passes 2 --threads 2", tmp);
  INFO(r.out << r.err);
  REQUIRE(r.exit_code == 0);
  const Image img = read_exr(tmp / "r.exr");
  double sum = 0;
  for (float x : img.rgb) {
    REQUIRE(std::isfinite(x));
    sum += x;
  }
  CHECK(sum > 0);
}

TEST_CASE("the window room behind glass: the script writes the committed files, the pane closes "
          "the window",
          "[outside]") {
  test::TempDir tmp("outside-pane");
  const std::string bench = test::source_dir() + "/bench/scenes";
  const std::string cmd = python3() + " " + bench + "/make_window_pane.py --out " +
                          tmp.dir.string() + " > " + (tmp / "log.txt") + " 2>&1";
  const int status = std::system(cmd.c_str());
  INFO(cmd << "\n" << test::file_bytes(tmp / "log.txt"));
  REQUIRE(status == 0);
  for (const char* name : {"window-pane.gltf", "window-pane.bin", "window-pane.bake-options"}) {
    INFO(name << ": bench/scenes differs from what make_window_pane.py writes; run it and commit");
    const std::string committed = test::file_bytes(bench + "/" + name);
    CHECK(!committed.empty());
    CHECK(test::file_bytes(tmp / name) == committed);
  }

  const Scene open = bake_from_root(tmp, "window-room", "--width 32 --height 32");
  const Scene pane = bake_from_root(tmp, "window-pane", "--width 32 --height 32", "bench/scenes");
  REQUIRE(pane.lights.size() == 1u);
  CHECK(pane.lights[0].type == PF_LIGHT_ENVIRONMENT);
  CHECK(pane.environment.source == open.environment.source);  // the same sky
  size_t glass = 0;
  for (const pf_material& m : pane.materials) glass += m.type == PF_MAT_GLASS;
  CHECK(glass == 1u);  // the pane (the rough-glass sphere is a metallic-roughness material)

  // The sun's direction: the brightest texel.
  const Environment& env = pane.environment;
  const size_t sun = brightest_texel(env);
  const Vec3 to_sun = texel_direction(env, int(sun) / env.width, int(sun) % env.width);
  // Every floor point the open window lets the sun reach has the pane's glass first on its ray to
  // the sun, and behind the glass the sky: the pane fills the window, and nothing else changed.
  int sunlit = 0, through_glass = 0, then_sky = 0;
  for (int i = 0; i < kFloorX; ++i)
    for (int k = 0; k < kFloorZ; ++k) {
      const Vec3 p = floor_point(open.bounds, i, k);
      if (intersect_any(open, Ray{p, to_sun})) continue;
      ++sunlit;
      Hit h;
      if (!intersect_closest(pane, Ray{p, to_sun}, h)) continue;
      if (pane.materials[size_t(pane.triangles[size_t(h.tri)].material)].type != PF_MAT_GLASS)
        continue;
      ++through_glass;
      // Leave the slab: the far face, then nothing more.
      const Vec3 q = p + to_sun * (h.t + 1e-4f);
      Hit h2;
      if (!intersect_closest(pane, Ray{q, to_sun}, h2)) continue;
      const Vec3 r = q + to_sun * (h2.t + 1e-4f);
      then_sky += pane.materials[size_t(pane.triangles[size_t(h2.tri)].material)].type ==
                          PF_MAT_GLASS &&
                      !intersect_any(pane, Ray{r, to_sun});
    }
  INFO(sunlit << " floor points in the sun through the open window, " << through_glass
              << " of them behind the pane's glass, " << then_sky << " then see the sky");
  CHECK(sunlit > 40);
  CHECK(through_glass == sunlit);
  CHECK(then_sky == sunlit);
}
