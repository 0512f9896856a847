// scene-bake — stage 1 of the pipeline: a scene file (COLLADA, OBJ/MTL, glTF, PLY, ...) → scene.h5
// (flat triangles, Havel–Herout planes, materials, lights, camera, SAH kd-tree with ropes).
// The work is in bake_scene() (scene_import.h); this file parses options, records provenance,
// writes the result and prints a summary.
#include <cstdio>
#include <iostream>
#include <sstream>

#include "photonflow/geometry/bake_options.h"
#include "photonflow/foundations/make_depfile.h"
#include "photonflow/foundations/options.h"
#include "photonflow/foundations/text_file.h"
#include "photonflow/geometry/scene_inputs.h"
#include "photonflow/io/provenance.h"
#include "photonflow/geometry/scene.h"
#include "photonflow/geometry/scene_file.h"
#include "photonflow/geometry/scene_import.h"
#include "photonflow/geometry/scene_source.h"
#include "photonflow/foundations/tool_main.h"

namespace {

constexpr const char* kTool = "scene-bake";

const char* material_type_name(int type) {
  switch (type) {
    case PF_MAT_DIFFUSE: return "diffuse";
    case PF_MAT_MIRROR: return "mirror";
    case PF_MAT_GLASS: return "glass";
    case PF_MAT_EMITTER: return "emitter";
    case PF_MAT_PBR: return "metallic-roughness";
    default: return "unknown";
  }
}

void print_summary(const pf::Scene& s, const pf::BakeReport& r, const std::string& out) {
  int by_type[5] = {0, 0, 0, 0, 0};
  for (auto& m : s.materials)
    if (m.type >= 0 && m.type <= PF_MAT_PBR) ++by_type[m.type];
  int area = 0, point = 0, spot = 0, directional = 0;
  double power = 0;
  for (auto& l : s.lights) {
    power += l.power;
    if (l.type == PF_LIGHT_ENVIRONMENT) continue;  // its own line below
    (l.type == PF_LIGHT_AREA    ? area
     : l.type == PF_LIGHT_SPOT  ? spot
     : l.type == PF_LIGHT_POINT ? point
                                : directional)++;
  }
  size_t leaves = 0;
  for (auto& n : s.kd.nodes) leaves += n.axis == PF_KD_LEAF;
  const pf_camera& c = s.camera;
  std::printf("%s: %s -> %s\n", kTool, s.source.c_str(), out.c_str());
  std::printf("  triangles  %zu (%zu inserted, %zu zero-area dropped)\n", s.triangles.size(),
              r.inserted_triangles, r.degenerate_dropped);
  std::printf("  meshes     %zu\n", s.mesh_names.size());
  std::printf("  materials  %zu:", s.materials.size());
  for (int t = 0; t < 4; ++t) std::printf(" %d %s", by_type[t], material_type_name(t));
  // glTF metallic-roughness (format version 5): named only where the scene has some.
  if (by_type[PF_MAT_PBR])
    std::printf(" %d %s", by_type[PF_MAT_PBR], material_type_name(PF_MAT_PBR));
  if (!s.textures.empty()) {
    size_t textured = 0;
    for (size_t m = 0; m < s.materials.size(); ++m) textured += s.texture_of(int(m)) >= 0;
    std::printf("\n  textures   %zu (%zu texels, %.1f MiB), %zu textured materials",
                s.textures.size(), s.texels.size() / 4,
                double(s.texels.size() * sizeof(float)) / double(1 << 20), textured);
    size_t mr = 0;
    for (size_t m = 0; m < s.materials.size(); ++m) mr += s.mr_texture_of(int(m)) >= 0;
    if (mr) std::printf(", %zu with a metallic-roughness texture", mr);
  }
  std::printf("\n  lights     %zu (%d area, %d point", s.lights.size(), area, point);
  if (spot + directional > 0) std::printf(", %d spot, %d directional", spot, directional);
  if (s.environment.present()) std::printf(", 1 environment");
  std::printf("), power %.4g W (luminance)\n", power);
  if (s.environment.present())
    std::printf("  environment %s, %dx%d, strength %g, rotated %g deg\n",
                s.environment.source.c_str(), s.environment.width, s.environment.height,
                s.environment.strength, s.environment.rotation_deg);
  std::printf("  camera     eye %g,%g,%g look-at %g,%g,%g up %g,%g,%g fov %.4g deg %dx%d (%s)\n",
              c.eye[0], c.eye[1], c.eye[2], c.look_at[0], c.look_at[1], c.look_at[2], c.up[0],
              c.up[1], c.up[2], c.fov_y_deg, c.width, c.height, r.camera_source.c_str());
  if (c.aperture > 0.f)
    std::printf("  lens       radius %g, focused at %g (depth of field)\n", c.aperture,
                c.focus_distance);
  if (r.inserted_triangles)
    std::printf("  up axis    %s (the inserted meshes stand along it)\n",
                pf::up_axis_name(r.insert_up).c_str());
  std::printf("  kd-tree    %zu nodes, %zu leaves, depth %d\n", s.kd.nodes.size(), leaves,
              s.kd.depth);
  std::printf("  time       import %.3f s, kd-tree build %.3f s\n", r.import_seconds,
              s.kd.build_seconds);
  std::printf("  scene_id   %s\n", s.scene_id.substr(0, 16).c_str());
}

int run(int argc, char** argv) {
  pf::Stopwatch clock;
  cxxopts::Options opts(kTool,
                        "Bakes a scene file (anything assimp reads: COLLADA .dae, Wavefront "
                        ".obj/.mtl, glTF, PLY, ...) into scene.h5: world-space triangles, "
                        "materials, lights, camera and a SAH kd-tree with ropes. Material "
                        "mapping: docs/SCENES.md.");
  opts.positional_help("INPUT");
  // clang-format off
  opts.add_options()
    ("input", "scene file to bake", cxxopts::value<std::string>())
    ("o,output", "output scene file (HDF5), written atomically", cxxopts::value<std::string>());
  pf::add_bake_options(opts);  // shared with render --scene SOURCE (bake_options.h)
  pf::add_options_file_options(opts);
  opts.add_options()
    ("threads", "threads for the kd-tree build (0 = all cores; the result does not depend "
                "on it)", cxxopts::value<int>()->default_value("0"))
    ("depfile", "also write a make dependency file here: the output's name and every file the "
                "bake read (scene, options file, inserts, buffers, textures, environment map; "
                "names make would read as syntax left out), for pipelines/render.mk; \"\" = none",
     cxxopts::value<std::string>()->default_value(""))
    ("h,help", "print this help");
  // clang-format on
  opts.parse_positional({"input"});
  // One INPUT (a second is unexpected); the options file's bake options before the command line's.
  auto args = pf::parse_bake_command_line(opts, argc, argv, "input", false);
  if (args.count("help")) {
    std::cout << opts.help() << "\n";
    return 0;
  }
  if (!args.count("input"))
    throw pf::input_error("", "no INPUT scene file given", "see scene-bake --help");
  if (!args.count("output"))
    throw pf::input_error("", "no output file given", "add -o scene.h5");
  pf::require_options(opts, args, {"input", "output"});  // both given: refuses empty values

  const pf::BakeOptions o =
      pf::bake_options(args, args["input"].as<std::string>(), args["threads"].as<int>());
  const std::string out = args["output"].as<std::string>();
  const std::string depfile = args.count("depfile") ? args["depfile"].as<std::string>() : "";
  if (args.count("depfile") && depfile.empty())
    throw pf::input_error("", "--depfile is empty", "give it a file name");
  if (!depfile.empty() && !pf::make_safe_name(out))
    throw pf::input_error(out, "--depfile: make would read this output name as syntax",
                          "name the output with A-Z a-z 0-9 . _ / + ~ @ , - only, not starting with - or ~");
  std::vector<std::string> inserted;
  for (const pf::MeshInsert& ins : o.inserts) inserted.push_back(ins.path);
  std::vector<std::string> inputs = inserted;
  inputs.push_back(o.input);
  pf::check_outputs(inputs, {out, depfile});

  pf::BakeReport report;
  pf::Scene scene = pf::bake_scene(o, report);
  pf::Provenance prov = pf::bake_provenance(args, o, out, pf::join_command_line(argc, argv));
  prov.wall_time_s = clock.seconds();
  pf::save_scene(scene, out, prov);
  if (!depfile.empty()) {
    const std::string options_file =
        args.count("options-file") ? args["options-file"].as<std::string>() : "";
    std::vector<std::string> read =
        pf::bake_input_files(o.input, inserted, o.environment, options_file);
    pf::write_text_atomic(depfile, pf::make_depfile_text(out, read));
  }

  for (const std::string& w : pf::bake_warnings(o, report)) std::cerr << kTool << ": " << w << "\n";
  print_summary(scene, report, out);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return pf::run_tool(kTool, [&] { return run(argc, argv); });
}
