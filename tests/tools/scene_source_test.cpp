// render --scene with a scene source (scene_source.h, bake_options.h; issue 34): a source and the
// scene.h5 scene-bake makes of it with the same options give the same image, bit for bit;
// --keep-scene writes that scene.h5 with scene-bake's provenance; a baked scene is told apart by
// its HDF5 signature, not its name; bad sources and misplaced bake options give one line, exit 2
// and no output.
#include <catch2/catch.hpp>
#include <hdf5.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "photonflow/io/h5io.h"
#include "photonflow/io/provenance.h"
#include "photonflow/geometry/scene.h"
#include "photonflow/geometry/scene_file.h"
#include "photonflow/geometry/scene_source.h"
#include "support.h"

using namespace pf;
namespace fs = std::filesystem;

namespace {

size_t lines(const std::string& s) { return size_t(std::count(s.begin(), s.end(), '\n')); }
std::string q(const std::string& s) { return "'" + s + "'"; }
std::string src(const std::string& rel) { return test::source_dir() + "/" + rel; }

Provenance scene_provenance(const std::string& path) {
  h5::Reader r(path, kSceneFormat, kSceneFormatVersion);
  return read_provenance(r);
}

// No file in `dir` but the ones named in `keep`.
std::vector<std::string> files_except(const test::TempDir& tmp, std::initializer_list<std::string> keep) {
  std::vector<std::string> extra;
  for (auto& e : fs::directory_iterator(tmp.dir)) {
    const std::string name = e.path().filename().string();
    if (std::find(keep.begin(), keep.end(), name) == keep.end()) extra.push_back(name);
  }
  return extra;
}

}  // namespace

TEST_CASE("render: a scene source and its baked scene give the same image", "[scene_source]") {
  test::TempDir tmp("scene-source-same");
  struct Case {
    std::string source, bake_options, render_options;
  };
  // COLLADA with an inserted PLY mesh (the --insert options shared with scene-bake), and a glTF
  // file; the estimators' two routes (fixed eye pass, a new one every pass).
  const Case cases[] = {
      {src("data/cornell-box.dae"),
       "--width 24 --height 20 --insert " + q(src("tests/data/tetra.ply")) +
           " --insert-box 0.2,0,0.2,0.5,0.3,0.5 --kd-max-leaf 2",
       "--estimator sppm --passes 2 --photons 3000"},
      {src("tests/data/lamp.gltf"), "--width 16 --height 16 --fov 50",
       "--estimator ppm --passes 2 --photons 2000 --direct shadow-rays"},
  };
  for (const Case& c : cases) {
    INFO(c.source);
    fs::remove_all(tmp.dir);
    fs::create_directories(tmp.dir);
    const auto bake = test::run_tool(
        "scene-bake", q(c.source) + " -o " + q(tmp / "baked.h5") + " " + c.bake_options, tmp);
    INFO(bake.err);
    REQUIRE(bake.exit_code == 0);
    const auto from_h5 = test::run_tool(
        "render", "--scene " + q(tmp / "baked.h5") + " -o " + q(tmp / "a.exr") + " " +
                      c.render_options + " --stats " + q(tmp / "a.json"),
        tmp);
    INFO(from_h5.err);
    REQUIRE(from_h5.exit_code == 0);
    const auto from_source = test::run_tool(
        "render", "--scene " + q(c.source) + " " + c.bake_options + " -o " + q(tmp / "b.exr") +
                      " " + c.render_options + " --keep-scene " + q(tmp / "kept.h5") +
                      " --stats " + q(tmp / "b.json"),
        tmp);
    INFO(from_source.err);
    REQUIRE(from_source.exit_code == 0);
    CHECK(from_source.out.find("render: baked ") != std::string::npos);
    const std::string a = test::file_bytes(tmp / "a.exr"), b = test::file_bytes(tmp / "b.exr");
    REQUIRE_FALSE(a.empty());
    CHECK(a == b);

    // The kept scene is the baked one, with scene-bake's provenance: the same tool, parameters
    // (but the output's name) and inputs.
    const Scene baked = load_scene(tmp / "baked.h5"), kept = load_scene(tmp / "kept.h5");
    CHECK(kept.scene_id == baked.scene_id);
    CHECK(kept.kd.nodes.size() == baked.kd.nodes.size());
    Provenance pb = scene_provenance(tmp / "baked.h5"), pk = scene_provenance(tmp / "kept.h5");
    CHECK(pk.tool == pb.tool);
    CHECK(pk.parameters.at("output") == tmp / "kept.h5");
    pb.parameters.erase("output");
    pk.parameters.erase("output");
    CHECK(pk.parameters == pb.parameters);
    REQUIRE(pk.inputs.size() == pb.inputs.size());
    for (size_t i = 0; i < pk.inputs.size(); ++i) {
      CHECK(pk.inputs[i].role == pb.inputs[i].role);
      CHECK(pk.inputs[i].sha256 == pb.inputs[i].sha256);
    }
    CHECK(pk.command_line.find("render") != std::string::npos);

    // The run record names the source as the scene, with the baked scene's id.
    const auto rec = nlohmann::json::parse(test::file_bytes(tmp / "b.json"));
    CHECK(rec.at("inputs").at(0).at("path") == c.source);
    CHECK(rec.at("inputs").at(0).at("scene_id") == baked.scene_id);
    CHECK(rec.at("parameters").at("width") == scene_provenance(tmp / "baked.h5").parameters.at("width"));
    CHECK(test::temporary_files(tmp.dir).empty());
  }
}

TEST_CASE("render: a baked scene is known by its HDF5 signature, not its name", "[scene_source]") {
  test::TempDir tmp("scene-source-signature");
  REQUIRE(test::run_tool("scene-bake", q(src("data/cornell-box.dae")) + " -o " +
                                           q(tmp / "scene.h5") + " --width 16 --height 12",
                         tmp)
              .exit_code == 0);
  fs::copy_file(tmp / "scene.h5", tmp / "scene.bin");
  const std::string opts = " --passes 1 --photons 1000";
  REQUIRE(test::run_tool("render", "--scene " + q(tmp / "scene.h5") + " -o " + q(tmp / "a.exr") + opts, tmp).exit_code == 0);
  const auto r = test::run_tool("render", "--scene " + q(tmp / "scene.bin") + " -o " + q(tmp / "b.exr") + opts, tmp);
  INFO(r.err);
  REQUIRE(r.exit_code == 0);
  CHECK(r.out.find("render: baked") == std::string::npos);
  CHECK(test::file_bytes(tmp / "a.exr") == test::file_bytes(tmp / "b.exr"));

  // The library's test: the signature at byte 0 or after a user block; a damaged .h5 is still a
  // baked scene (so the HDF5 reader, not an importer, names the problem); a source is not.
  CHECK(is_baked_scene(tmp / "scene.bin"));
  {
    hid_t fcpl = H5Pcreate(H5P_FILE_CREATE);
    REQUIRE(H5Pset_userblock(fcpl, 1024) >= 0);
    hid_t f = H5Fcreate((tmp / "userblock.dat").c_str(), H5F_ACC_TRUNC, fcpl, H5P_DEFAULT);
    REQUIRE(f >= 0);
    H5Fclose(f);
    H5Pclose(fcpl);
  }
  CHECK(is_baked_scene(tmp / "userblock.dat"));
  std::ofstream(tmp / "damaged.h5") << "not hdf5";
  CHECK(is_baked_scene(tmp / "damaged.h5"));
  CHECK_FALSE(is_baked_scene(src("data/cornell-box.dae")));
  CHECK_FALSE(is_baked_scene(src("tests/data/tetra-binary.ply")));
  CHECK_THROWS_AS(is_baked_scene(tmp / "missing.glb"), InputError);
}

TEST_CASE("render: bad scene sources and misplaced bake options give one line, exit 2, no output",
          "[scene_source]") {
  test::TempDir tmp("scene-source-bad");
  REQUIRE(test::run_tool("scene-bake", q(src("data/cornell-box.dae")) + " -o " +
                                           q(tmp / "scene.h5") + " --width 16 --height 12",
                         tmp)
              .exit_code == 0);
  std::ofstream(tmp / "garbage.obj") << "this is not a mesh\n";
  fs::create_directories(tmp / "folder.glb");
  struct Bad {
    std::string args, needle;
  };
  const Bad cases[] = {
      {"--scene " + q(tmp / "missing.glb"), "missing.glb: no such file"},
      {"--scene " + q(tmp / "garbage.obj"), "garbage.obj"},
      {"--scene " + q(src("tests/data/garbage.dae")), "garbage.dae"},
      {"--scene " + q(tmp / "folder.glb"), "is not a regular file"},
      {"--scene " + q(tmp / "scene.h5") + " --width 64", "the bake options --width cannot change"},
      {"--scene " + q(tmp / "scene.h5") + " --keep-scene " + q(tmp / "kept.h5"),
       "--keep-scene keeps the scene baked from a scene source"},
      {"--scene " + q(src("data/cornell-box.dae")) + " --kd-ct 0", "--kd-ct must be positive"},
      {"--scene " + q(src("data/cornell-box.dae")) + " --insert-box 1,2,3", "--insert-box"},
      {"--scene " + q(src("data/cornell-box.dae")) + " --insert " + q(tmp / "nomesh.ply"),
       "nomesh.ply"},
      {"--scene " + q(src("data/cornell-box.dae")) + " --keep-scene " + q(tmp / "nodir/kept.h5"),
       "nodir"},
      // Refused after the bake, by render's own checks: the kept scene is not written either.
      {"--scene " + q(src("data/cornell-box.dae")) + " --keep-scene " + q(tmp / "kept.h5") +
           " --estimator sppm --method flann",
       "--method flann"},
  };
  for (const Bad& c : cases) {
    INFO(c.args);
    const auto run = test::run_tool(
        "render", c.args + " -o " + q(tmp / "out.exr") + " --passes 1 --photons 500", tmp);
    INFO(run.err);
    CHECK(run.exit_code == 2);
    CHECK(lines(run.err) == 1);
    CHECK(run.err.rfind("render: ", 0) == 0);
    CHECK(run.err.find(c.needle) != std::string::npos);
    CHECK(files_except(tmp, {"scene.h5", "garbage.obj", "folder.glb"}).empty());
  }
}

// `make render SCENE=path`: any scene file, its intermediates under OUT/<file stem>/, and the image
// the same as render's of that source with the same options; a SCENE that is neither a file nor a
// name in data/ stops make before any stage, with one message.
TEST_CASE("make render SCENE=path renders any scene file into OUT/<stem>/", "[scene_source][dag]") {
  test::TempDir tmp("scene-source-make");
  fs::create_directories(tmp.dir / "models");
  const std::string model = tmp / "models/my-box.dae";
  fs::copy_file(src("data/cornell-box.dae"), model);
  const std::string opts = "WIDTH=32 HEIGHT=24 PASSES=2 PHOTONS=2000 ESTIMATOR=sppm SPP=1 "
                           "DIRECT=photons RADIUS=0 SEED=1 ALPHA=0.7 MAX_BINS=64";
  const std::string make = "make -s --no-print-directory -C " + q(test::source_dir()) +
                           " -f pipelines/render.mk BIN=" + q(test::bin_dir()) + " OUT=" +
                           q(tmp / "out") + " " + opts;
  const std::string log = tmp / "make.log";
  REQUIRE(std::system((make + " SCENE=" + q(model) + " render >" + log + " 2>&1").c_str()) == 0);
  INFO(test::file_bytes(log));
  REQUIRE(fs::exists(tmp / "out/my-box/render.exr"));
  CHECK(fs::exists(tmp / "out/my-box/scene.h5"));
  CHECK(load_scene(tmp / "out/my-box/scene.h5").source == model);
  const auto r = test::run_tool(
      "render", "--scene " + q(model) + " --width 32 --height 24 --passes 2 --photons 2000 "
                "--estimator sppm --spp 1 --direct photons --radius 0 --seed 1 --alpha 0.7 "
                "--max-bins 64 -o " + q(tmp / "direct.exr"),
      tmp);
  INFO(r.err);
  REQUIRE(r.exit_code == 0);
  CHECK(test::file_bytes(tmp / "direct.exr") == test::file_bytes(tmp / "out/my-box/render.exr"));

  // Neither a file nor a name in data/.
  const int bad = std::system((make + " SCENE=" + q(tmp / "models/none.glb") + " render >" + log +
                               " 2>&1").c_str());
  CHECK(bad != 0);
  CHECK(test::file_bytes(log).find("no file '" + tmp / "models/none.glb") != std::string::npos);
  CHECK_FALSE(fs::exists(tmp / "out/none"));
}
