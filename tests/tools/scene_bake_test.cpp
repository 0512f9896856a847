// Tests of the scene-bake executable (run through std::system): bad input gives exactly one line
// on stderr naming the file, exit code 2 and no output (nor temporary) file; a good input writes a
// readable scene.h5 with provenance; --help documents every option.
#include <catch2/catch.hpp>
#include <sys/wait.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "photonflow/io/h5io.h"
#include "photonflow/io/provenance.h"
#include "photonflow/geometry/scene.h"
#include "photonflow/geometry/scene_file.h"
#include "photonflow/geometry/scene_import.h"
#include "support.h"

namespace fs = std::filesystem;

namespace {

std::string src(const std::string& rel) { return std::string(PF_SOURCE_DIR) + "/" + rel; }

std::string tool() {
  const char* bin = std::getenv("PF_BIN");
  return (bin ? std::string(bin) : std::string(PF_BINARY_DIR) + "/bin") + "/scene-bake";
}

// A fresh scratch directory for one test case.
fs::path scratch(const std::string& name) {
  fs::path d = fs::path(PF_BINARY_DIR) / "test_scratch" / "scene_bake_tool" / name;
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

std::string read_text(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

struct Run {
  int code = -1;
  std::string out, err;
};

// Runs scene-bake with `args` (already shell-quoted where needed).
Run run_tool(const std::string& args, const fs::path& dir) {
  const fs::path out = dir / "stdout.txt", err = dir / "stderr.txt";
  const std::string cmd = "'" + tool() + "' " + args + " >'" + out.string() + "' 2>'" +
                          err.string() + "'";
  const int status = std::system(cmd.c_str());
  Run r;
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.out = read_text(out);
  r.err = read_text(err);
  return r;
}

size_t lines(const std::string& s) {
  size_t n = 0;
  for (char c : s) n += c == '\n';
  return n;
}

// No *.h5 and no temporary file in `dir`.
bool no_outputs(const fs::path& dir) {
  for (auto& e : fs::directory_iterator(dir)) {
    const std::string name = e.path().filename().string();
    if (name.find(".h5") != std::string::npos || name.find(".tmp.") != std::string::npos)
      return false;
  }
  return true;
}

}  // namespace

TEST_CASE("scene-bake: bad inputs give one line, exit code 2 and no file", "[scene_bake_tool]") {
  const fs::path dir = scratch("bad");
  const std::string out = (dir / "scene.h5").string();
  for (const char* rel :
       {"tests/data/nan.obj", "tests/data/degenerate.obj", "tests/data/bad-index.obj",
        "tests/data/bad-index.dae", "tests/data/no-light.obj", "tests/data/lines.obj",
        "tests/data/garbage.dae", "tests/data/unknown.xyz", "tests/data/missing.obj",
        // assimp runs away (memory), crashes, aborts or loops on these (test_scene_import)
        "tests/data/letter-in-index.dae", "tests/data/damaged-segv.ply",
        "tests/data/damaged-assert.ply", "tests/data/damaged-loop.ply"}) {
    INFO(rel);
    const std::string input = std::string(rel).find(".ply") != std::string::npos
                                  ? src("data/cornell-box.dae") + "' --insert '" + src(rel)
                                  : src(rel);
    // 1 s for the file that loops, 30 s for the rest (well under a second each, on a loaded
    // machine too)
    const bool loops = std::string(rel).find("loop") != std::string::npos;
    Run r = run_tool("'" + input + "' -o '" + out + "' --import-seconds " + (loops ? "1" : "30"),
                     dir);
    INFO(r.err);
    CHECK(r.code == 2);
    CHECK(lines(r.err) == 1);
    CHECK(r.err.rfind("scene-bake: ", 0) == 0);
    CHECK(r.err.find(rel) != std::string::npos);
    CHECK(no_outputs(dir));
  }
}

TEST_CASE("scene-bake: bad options give one line and exit code 2", "[scene_bake_tool]") {
  const fs::path dir = scratch("options");
  const std::string in = "'" + src("data/cornell-box.dae") + "'";
  const std::string out = " -o '" + (dir / "scene.h5").string() + "'";
  for (const std::string& args :
       {in + out + " --fov 200", in + out + " --eye 1,2", in + out + " --width -3",
        in + out + " --no-such-option", in, std::string("-o x.h5"),
        in + out + " --insert-box 0,0,0,1,1,1",
        in + out + " --insert '" + src("tests/data/tetra.ply") + "' --insert-material nope",
        in + out + " --kd-max-leaf many", in + out + " --kd-max-leaf 0",
        in + out + " --kd-ct -1", in + out + " --kd-max-depth 999", in + out + " --threads -2",
        in + out + " --import-seconds -1", in + out + " --import-memory-mb 99999999"}) {
    INFO(args);
    Run r = run_tool(args, dir);
    INFO(r.err);
    CHECK(r.code == 2);
    CHECK(lines(r.err) == 1);
    CHECK(no_outputs(dir));
  }
}

TEST_CASE("scene-bake: an unwritable output path is an input error", "[scene_bake_tool]") {
  const fs::path dir = scratch("unwritable");
  Run r = run_tool("'" + src("data/cornell-box.dae") + "' -o /nonexistent/dir/x.h5", dir);
  INFO(r.err);
  CHECK(r.code == 2);
  CHECK(lines(r.err) == 1);
  CHECK(r.err.find("/nonexistent/dir/x.h5") != std::string::npos);
  CHECK_FALSE(fs::exists("/nonexistent/dir/x.h5"));
}

TEST_CASE("scene-bake: a good input writes scene.h5 with provenance", "[scene_bake_tool]") {
  const fs::path dir = scratch("good");
  const fs::path out = dir / "scene.h5";
  const std::string ply = src("tests/data/tetra.ply");
  Run r = run_tool("'" + src("data/cornell-box.dae") + "' -o '" + out.string() +
                       "' --width 320 --height 240 --insert '" + ply +
                       "' --insert-box 0.2,0,0.2,0.5,0.3,0.5 --insert-material white --threads 1",
                   dir);
  INFO(r.err);
  REQUIRE(r.code == 0);
  CHECK(r.err.empty());
  CHECK(r.out.find("triangles  36 (4 inserted") != std::string::npos);
  CHECK(r.out.find("scene_id") != std::string::npos);
  REQUIRE(fs::exists(out));
  CHECK(pf::test::temporary_files(dir).empty());

  const pf::Scene s = pf::load_scene(out.string());
  CHECK(s.triangles.size() == 36);
  CHECK(s.camera.width == 320);
  CHECK(s.camera.height == 240);
  CHECK_FALSE(s.lights.empty());

  pf::h5::Reader reader(out.string(), pf::kSceneFormat, pf::kSceneFormatVersion);
  const pf::Provenance p = pf::read_provenance(reader);
  CHECK(p.tool == "scene-bake");
  CHECK(p.parameters.at("insert-material") == "white");
  CHECK(p.parameters.at("width") == "320");
  CHECK(p.parameters.count("kd-ct") == 1);
  bool source = false, insert = false;
  for (auto& in : p.inputs) {
    source |= in.role == "source" && in.sha256.size() == 64;
    insert |= in.role == "insert0" && in.path == ply;
  }
  CHECK(source);
  CHECK(insert);

  if (std::system("command -v h5dump >/dev/null 2>&1") == 0) {
    const std::string cmd = "h5dump -H '" + out.string() + "' >/dev/null 2>&1";
    CHECK(std::system(cmd.c_str()) == 0);
  }
}

// The tool's kd-tree defaults are KdBuildParams's, so `make render` bakes the tree the benchmarks
// measured and the in-process bakes build (they once differed: 1/1.5/0.2 against 3/1/0.5).
TEST_CASE("scene-bake: default options build the same kd-tree as an in-process bake",
          "[scene_bake_tool]") {
  const fs::path dir = scratch("defaults");
  const fs::path out = dir / "scene.h5";
  Run r = run_tool("'" + src("data/cornell-box.dae") + "' -o '" + out.string() + "'", dir);
  INFO(r.err);
  REQUIRE(r.code == 0);
  const pf::Scene tool = pf::load_scene(out.string());

  pf::BakeOptions o;
  o.input = src("data/cornell-box.dae");
  pf::BakeReport report;
  const pf::Scene lib = pf::bake_scene(o, report);
  const pf::KdBuildParams want{};
  CHECK(tool.kd.params.cost_traversal == want.cost_traversal);
  CHECK(tool.kd.params.cost_intersect == want.cost_intersect);
  CHECK(tool.kd.params.empty_bonus == want.empty_bonus);
  CHECK(tool.kd.params.max_leaf_size == want.max_leaf_size);
  REQUIRE(tool.kd.nodes.size() == lib.kd.nodes.size());
  CHECK(std::memcmp(tool.kd.nodes.data(), lib.kd.nodes.data(),
                    lib.kd.nodes.size() * sizeof(lib.kd.nodes[0])) == 0);
  CHECK(tool.kd.leaf_tris == lib.kd.leaf_tris);
}

TEST_CASE("scene-bake: zero-area triangles are reported as a warning", "[scene_bake_tool]") {
  const fs::path dir = scratch("degenerate");
  Run r = run_tool("'" + src("tests/data/some-degenerate.obj") + "' -o '" +
                       (dir / "scene.h5").string() + "'",
                   dir);
  CHECK(r.code == 0);
  CHECK(r.err.find("dropped 1 zero-area triangles") != std::string::npos);
  CHECK(fs::exists(dir / "scene.h5"));
}

TEST_CASE("scene-bake: --help explains every option", "[scene_bake_tool]") {
  const fs::path dir = scratch("help");
  Run r = run_tool("--help", dir);
  CHECK(r.code == 0);
  for (const char* opt :
       {"--output", "--eye", "--look-at", "--up", "--fov", "--width", "--height", "--insert",
        "--insert-box", "--insert-material", "--up-axis", "--kd-ct", "--kd-ci", "--kd-empty-bonus",
        "--kd-max-depth", "--kd-max-leaf", "--import-memory-mb", "--import-seconds", "--threads",
        "--environment", "--environment-strength", "--environment-rotate",
        "--help", "INPUT", "degrees", "pixels",
        "default"}) {
    INFO(opt);
    CHECK(r.out.find(opt) != std::string::npos);
  }
}

namespace {

// Writes a small room without a camera, up = +z: a floor quad at z = 0 (x, y in 0..1) and a lamp
// facing down at z = 1.
std::string write_z_up_room(const fs::path& dir) {
  std::ofstream(dir / "room.mtl") << "newmtl white\nKd 0.5 0.5 0.5\nnewmtl lamp\nKd 0 0 0\n"
                                     "Ke 10 10 10\n";
  std::ofstream(dir / "room.obj") << "mtllib room.mtl\n"
                                     "o floor\nusemtl white\n"
                                     "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n"
                                     "o lamp\nusemtl lamp\n"
                                     "v 0.4 0.4 1\nv 0.4 0.6 1\nv 0.6 0.6 1\nv 0.6 0.4 1\n"
                                     "f 5 6 7 8\n";
  return (dir / "room.obj").string();
}

// A square pyramid modelled y-up: base 1 x 1 at y = 0, apex at y = 4.
std::string write_pyramid(const fs::path& dir) {
  std::ofstream(dir / "pyramid.obj") << "v 0 0 0\nv 1 0 0\nv 1 0 1\nv 0 0 1\nv 0.5 4 0.5\n"
                                        "f 1 2 3 4\nf 1 5 2\nf 2 5 3\nf 3 5 4\nf 4 5 1\n";
  return (dir / "pyramid.obj").string();
}

// The bounds of a baked scene's inserted triangles (meshes "insert0:...") and of the others, and
// the mean of the inserted vertices.
struct InsertGeometry {
  pf::Bounds inserted, scene;
  pf::Vec3 mean{0, 0, 0};
};
InsertGeometry insert_geometry(const pf::Scene& s) {
  InsertGeometry g;
  size_t n = 0;
  for (const pf_triangle& t : s.triangles) {
    const bool ins = s.mesh_names[size_t(t.mesh)].rfind("insert0:", 0) == 0;
    for (const float* v : {t.v0, t.v1, t.v2}) {
      (ins ? g.inserted : g.scene).extend(pf::Vec3(v));
      if (ins) {
        g.mean = g.mean + pf::Vec3(v);
        ++n;
      }
    }
  }
  if (n) g.mean = g.mean * (1.f / float(n));
  return g;
}

}  // namespace

TEST_CASE("scene-bake: the camera line says where each camera value came from",
          "[scene_bake_tool]") {
  // Before: "(default framing)" for any OBJ without a camera, also when every value was given.
  const fs::path dir = scratch("camera-source");
  const std::string obj = write_z_up_room(dir), out = " -o '" + (dir / "scene.h5").string() + "'";
  const std::string dae = "'" + src("data/cornell-box.dae") + "'";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"'" + obj + "'" + out + " --eye 0.5,-2,0.5 --look-at 0.5,0.5,0.5 --up 0,0,1 --fov 50",
       "(eye, look-at, up, fov from options)"},
      {"'" + obj + "'" + out, "(eye, look-at, up, fov from default framing)"},
      {"'" + obj + "'" + out + " --eye 0.5,0.5,3", "(eye from options; look-at, up, fov from "
                                                   "default framing)"},
      {dae + out, "(eye, look-at, up, fov from file)"},
      {dae + out + " --fov 30 --up 0,1,0.1", "(up, fov from options; eye, look-at from file)"},
  };
  for (const auto& [args, says] : cases) {
    INFO(args);
    const Run r = run_tool(args, dir);
    INFO(r.err);
    REQUIRE(r.code == 0);
    const size_t at = r.out.find("  camera     ");
    REQUIRE(at != std::string::npos);
    const std::string line = r.out.substr(at, r.out.find('\n', at) - at);
    INFO(line);
    CHECK(line.size() >= says.size());
    CHECK(line.compare(line.size() - says.size(), says.size(), says) == 0);
  }
}

TEST_CASE("scene-bake: --insert stands the mesh on the floor of the scene's up axis",
          "[scene_bake_tool]") {
  // Before: +y was taken as up, so in a +z-up scene an inserted mesh lay on its side, centred
  // mid-room in z. The pyramid (y-up, 4 high on a 1 x 1 base) must stand on the floor along the
  // up axis (its lowest point there, its height along up, its base at the floor side).
  const fs::path dir = scratch("up-axis");
  const std::string obj = write_z_up_room(dir), pyramid = write_pyramid(dir);
  const std::string out = (dir / "scene.h5").string();
  // The Cornell box (+y up, camera up +y) turned about x by +90 degrees (+y → +z: camera up +z)
  // and by −90 degrees (+y → −z): auto takes the axis from the file's camera.
  const std::string box = read_text(src("data/cornell-box.dae"));
  auto turned = [&](const std::string& name, const char* angle) {
    std::string s = box;
    const std::string open = "<visual_scene id=\"scene\" name=\"scene\">";
    REQUIRE(s.find(open) != std::string::npos);
    s.replace(s.find(open), open.size(),
              open + "<node id=\"turn\" name=\"turn\"><rotate>1 0 0 " + angle + "</rotate>");
    s.replace(s.find("</visual_scene>"), 15, "</node></visual_scene>");
    std::ofstream(dir / name) << s;
    return (dir / name).string();
  };
  struct Case {
    std::string args;
    int axis, sign;
  };
  const std::vector<Case> cases = {
      {"'" + src("data/cornell-box.dae") + "'", 1, 1},
      {"'" + turned("z-up.dae", "90") + "'", 2, 1},
      {"'" + turned("minus-z-up.dae", "-90") + "'", 2, -1},
      {"'" + obj + "' --eye 0.5,-2,0.5 --look-at 0.5,0.5,0.3 --up 0,0,1", 2, 1},  // --up
      {"'" + obj + "' --up-axis z", 2, 1},  // the option over the default camera's +y
      {"'" + turned("z-up2.dae", "90") + "' --up-axis -z --insert-box 0.2,0.3,0.6,0.6,0.7,1", 2,
       -1},  // the option over the file's camera; a box of its own (0.4 on every axis)
  };
  for (const Case& k : cases) {
    INFO(k.args);
    fs::remove(out);
    const Run r = run_tool(k.args + " -o '" + out + "' --insert '" + pyramid + "'", dir);
    INFO(r.err);
    REQUIRE(r.code == 0);
    CHECK(r.out.find(std::string("up axis    ") + (k.sign > 0 ? "+" : "-") + "xyz"[k.axis]) !=
          std::string::npos);
    const InsertGeometry g = insert_geometry(pf::load_scene(out));
    const int a = k.axis;
    const pf::Vec3 ext = g.scene.extent();
    // Box: 0.4 of the scene on every axis (default box and the one given); the pyramid's
    // extents after turning are 1, 1 and 4 (along up).
    float scale = 0.4f * ext[a] / 4.f;
    for (int b = 0; b < 3; ++b)
      if (b != a) scale = std::min(scale, 0.4f * ext[b]);
    const float height = g.inserted.extent()[a];
    CHECK(height == Approx(4.f * scale).epsilon(1e-4));
    for (int b = 0; b < 3; ++b) CHECK(g.inserted.extent()[b] <= height * 1.0001f);
    // On the floor: the scene's lo along +axis, hi along −axis.
    const float floor_at = k.sign > 0 ? g.scene.lo[a] : g.scene.hi[a];
    const float base = k.sign > 0 ? g.inserted.lo[a] : g.inserted.hi[a];
    CHECK(base == Approx(floor_at).margin(1e-5));
    // Standing, not upside down: the vertices' mean (4 base corners, 1 apex) near the floor.
    CHECK(std::fabs(g.mean[a] - base) < 0.5f * height);
  }
  const Run bad = run_tool("'" + obj + "' -o '" + out + "' --up-axis w", dir);
  CHECK(bad.code == 2);
  CHECK(bad.err == "scene-bake: --up-axis must be x, y, z, -x, -y, -z or auto, got 'w'\n");
}
