// scene-bake — stage 1 of the pipeline: a scene file (COLLADA, OBJ/MTL, glTF, PLY, ...) → scene.h5
// (flat triangles, Havel–Herout planes, materials, lights, camera, SAH kd-tree with ropes).
// The work is in bake_scene() (scene_import.h); this file parses options, records provenance,
// writes the result and prints a summary.
#include <cstdio>
#include <iostream>
#include <sstream>

#include "photonflow/options.h"
#include "photonflow/provenance.h"
#include "photonflow/scene.h"
#include "photonflow/scene_import.h"
#include "photonflow/tool_main.h"

namespace {

constexpr const char* kTool = "scene-bake";
// The kd-tree defaults are KdBuildParams's (measured, kdtree.h), the same the benchmarks and
// in-process bakes use.
const pf::KdBuildParams kKd{};

const char* material_type_name(int type) {
  switch (type) {
    case PF_MAT_DIFFUSE: return "diffuse";
    case PF_MAT_MIRROR: return "mirror";
    case PF_MAT_GLASS: return "glass";
    case PF_MAT_EMITTER: return "emitter";
    default: return "unknown";
  }
}

void print_summary(const pf::Scene& s, const pf::BakeReport& r, const std::string& out) {
  int by_type[4] = {0, 0, 0, 0};
  for (auto& m : s.materials)
    if (m.type >= 0 && m.type < 4) ++by_type[m.type];
  int area = 0, point = 0;
  double power = 0;
  for (auto& l : s.lights) {
    (l.type == PF_LIGHT_AREA ? area : point)++;
    power += l.power;
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
  std::printf("\n  lights     %zu (%d area, %d point), power %.4g W (luminance)\n",
              s.lights.size(), area, point, power);
  std::printf("  camera     eye %g,%g,%g look-at %g,%g,%g up %g,%g,%g fov %.4g deg %dx%d (%s)\n",
              c.eye[0], c.eye[1], c.eye[2], c.look_at[0], c.look_at[1], c.look_at[2], c.up[0],
              c.up[1], c.up[2], c.fov_y_deg, c.width, c.height, r.camera_source.c_str());
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
    ("o,output", "output scene file (HDF5), written atomically", cxxopts::value<std::string>())
    ("eye", "camera position x,y,z in scene units (default: the file's camera, else a "
            "camera on +z that frames the scene bounds)", cxxopts::value<std::string>())
    ("look-at", "point the camera looks at, x,y,z in scene units (default: from the file's "
                "camera, else the centre of the bounds)", cxxopts::value<std::string>())
    ("up", "camera up direction x,y,z (default: from the file's camera, else 0,1,0)",
     cxxopts::value<std::string>())
    ("fov", "vertical field of view in degrees, (0, 180) (default: from the file's camera, "
            "else 40)", cxxopts::value<float>())
    ("width", "image width in pixels (default: 512, or from --height and the file camera's "
              "aspect)", cxxopts::value<int>()->default_value("0"))
    ("height", "image height in pixels (default: 512, or from --width and the file camera's "
               "aspect)", cxxopts::value<int>()->default_value("0"))
    ("insert", "extra mesh file to insert into the scene (repeatable; default: none)",
     cxxopts::value<std::vector<std::string>>())
    ("insert-box", "box for the matching --insert as x0,y0,z0,x1,y1,z1, fractions of the scene "
                   "bounds; the mesh is scaled uniformly to fit, centred on the horizontal axes, "
                   "standing on the box's floor along --up-axis (repeatable; default: 0.3 .. 0.7 "
                   "horizontally, the 40 % of the up axis at the floor: 0.3,0,0.3,0.7,0.4,0.7 "
                   "for +y)", cxxopts::value<std::vector<float>>())
    ("up-axis", "the scene's up for --insert: x, y, z, -x, -y, -z, or auto = the dominant axis "
                "of the camera's up vector (--up, else the file's camera, else +y); the inserted "
                "mesh's +y is turned to it", cxxopts::value<std::string>()->default_value("auto"))
    ("insert-material", "material name (from INPUT) for the matching --insert (repeatable; "
                        "default: insert-default, diffuse albedo 0.75)",
     cxxopts::value<std::vector<std::string>>())
    ("kd-ct", "kd-tree SAH cost of a traversal step C_ts (eq. 4.8), unitless",
     cxxopts::value<float>()->default_value(pf::default_text(kKd.cost_traversal)))
    ("kd-ci", "kd-tree SAH cost of a triangle test C_L/C_R (eq. 4.8), unitless",
     cxxopts::value<float>()->default_value(pf::default_text(kKd.cost_intersect)))
    ("kd-empty-bonus", "kd-tree SAH cost reduction for cutting off empty space, fraction",
     cxxopts::value<float>()->default_value(pf::default_text(kKd.empty_bonus)))
    ("kd-max-depth", "kd-tree maximum depth, levels (0 = automatic: 8 + 1.3 log2 N)",
     cxxopts::value<int>()->default_value(pf::default_text(kKd.max_depth)))
    ("kd-max-leaf", "kd-tree: never split nodes with this many triangles or fewer",
     cxxopts::value<int>()->default_value(pf::default_text(kKd.max_leaf_size)))
    ("import-memory-mb", "address space each file import may take, MiB (0 = automatic: 256 MiB + "
                         "64 x the bytes of the files read); a loader that runs away on a "
                         "damaged file is stopped there",
     cxxopts::value<uint64_t>()->default_value("0"))
    ("import-seconds", "time limit of the file import, s (0 = automatic: 60 s + 10 s per MB "
                       "of the input files); a loader that loops on a damaged file is stopped "
                       "there", cxxopts::value<double>()->default_value("0"))
    ("threads", "threads for the kd-tree build (0 = all cores; the result does not depend "
                "on it)", cxxopts::value<int>()->default_value("0"))
    ("h,help", "print this help");
  // clang-format on
  opts.parse_positional({"input"});
  auto args = pf::parse_options(opts, argc, argv);  // one INPUT: a second is unexpected
  if (args.count("help")) {
    std::cout << opts.help() << "\n";
    return 0;
  }
  if (!args.count("input"))
    throw pf::input_error("", "no INPUT scene file given", "see scene-bake --help");
  if (!args.count("output"))
    throw pf::input_error("", "no output file given", "add -o scene.h5");
  pf::require_options(opts, args, {"input", "output"});  // both given: refuses empty values

  pf::BakeOptions o;
  o.input = args["input"].as<std::string>();
  const std::string out = args["output"].as<std::string>();
  if (args.count("eye")) o.eye = pf::parse_vec3("eye", args["eye"].as<std::string>());
  if (args.count("look-at"))
    o.look_at = pf::parse_vec3("look-at", args["look-at"].as<std::string>());
  if (args.count("up")) o.up = pf::parse_vec3("up", args["up"].as<std::string>());
  if (args.count("fov")) o.fov_y_deg = args["fov"].as<float>();
  o.up_axis = pf::parse_up_axis(args["up-axis"].as<std::string>());
  o.width = args["width"].as<int>();
  o.height = args["height"].as<int>();
  o.kd.cost_traversal = args["kd-ct"].as<float>();
  o.kd.cost_intersect = args["kd-ci"].as<float>();
  o.kd.empty_bonus = args["kd-empty-bonus"].as<float>();
  o.kd.max_depth = args["kd-max-depth"].as<int>();
  o.kd.max_leaf_size = args["kd-max-leaf"].as<int>();
  o.kd.threads = args["threads"].as<int>();
  o.import_memory_mb = args["import-memory-mb"].as<uint64_t>();
  o.import_seconds = args["import-seconds"].as<double>();
  if (!(o.import_seconds >= 0 && o.import_seconds < 1e9))
    throw pf::input_error("", "--import-seconds must be >= 0", "give 0 for the automatic limit");
  if (o.import_memory_mb > (uint64_t(1) << 24))
    throw pf::input_error("", "--import-memory-mb must be at most 16777216 (16 TiB)",
                          "give 0 for the automatic budget");
  pf::require_positive("kd-ct", o.kd.cost_traversal);
  pf::require_positive("kd-ci", o.kd.cost_intersect);
  if (!(o.kd.empty_bonus >= 0.f && o.kd.empty_bonus < 1.f))
    throw pf::input_error("", "--kd-empty-bonus must be in [0, 1)");
  if (o.kd.max_depth < 0 || o.kd.max_depth > pf::kKdMaxDepth)
    throw pf::input_error("", "--kd-max-depth must be in 0.." + std::to_string(pf::kKdMaxDepth));
  pf::require_positive("kd-max-leaf", o.kd.max_leaf_size);

  std::vector<std::string> inserts, materials;
  std::vector<float> boxes;
  if (args.count("insert")) inserts = args["insert"].as<std::vector<std::string>>();
  if (args.count("insert-material"))
    materials = args["insert-material"].as<std::vector<std::string>>();
  if (args.count("insert-box")) boxes = args["insert-box"].as<std::vector<float>>();
  if (boxes.size() % 6 != 0)
    throw pf::input_error("", "--insert-box needs six numbers x0,y0,z0,x1,y1,z1 per box");
  if (boxes.size() / 6 > inserts.size() || materials.size() > inserts.size())
    throw pf::input_error("", "more --insert-box or --insert-material than --insert files",
                          "give one --insert per box and material");
  for (size_t i = 0; i < inserts.size(); ++i) {
    pf::MeshInsert ins;
    ins.path = inserts[i];
    if (6 * i < boxes.size()) {
      ins.box_lo = pf::Vec3(&boxes[6 * i]);
      ins.box_hi = pf::Vec3(&boxes[6 * i + 3]);
    }
    if (i < materials.size()) ins.material = materials[i];
    o.inserts.push_back(ins);
  }
  std::vector<std::string> inputs = inserts;
  inputs.push_back(o.input);
  pf::check_outputs(inputs, {out});

  pf::Provenance prov;
  prov.tool = kTool;
  prov.command_line = pf::join_command_line(argc, argv);
  pf::record_options(prov, args);  // the repeatable --insert* are joined below
  std::string insert_text, box_text, material_text;
  for (size_t i = 0; i < o.inserts.size(); ++i) {
    const auto& ins = o.inserts[i];
    const char* sep = i ? ";" : "";
    insert_text += sep + ins.path;
    material_text += sep + (ins.material.empty() ? std::string("insert-default") : ins.material);
    std::ostringstream b;
    if (ins.box_lo && ins.box_hi)
      b << ins.box_lo->x << "," << ins.box_lo->y << "," << ins.box_lo->z << "," << ins.box_hi->x
        << "," << ins.box_hi->y << "," << ins.box_hi->z;
    else
      b << "default";
    box_text += sep + b.str();
  }
  prov.param("insert", insert_text);
  prov.param("insert-box", box_text);
  prov.param("insert-material", material_text);

  pf::BakeReport report;
  pf::Scene scene = pf::bake_scene(o, report);
  prov.add_input("source", o.input);
  for (size_t i = 0; i < o.inserts.size(); ++i)
    prov.add_input("insert" + std::to_string(i), o.inserts[i].path);
  prov.wall_time_s = clock.seconds();
  pf::save_scene(scene, out, prov);

  for (auto& w : report.warnings) std::cerr << kTool << ": warning: " << w << "\n";
  if (report.degenerate_dropped)
    std::cerr << kTool << ": warning: " << o.input << ": dropped " << report.degenerate_dropped
              << " zero-area triangles\n";
  if (report.primitives_skipped)
    std::cerr << kTool << ": warning: " << o.input << ": ignored " << report.primitives_skipped
              << " point or line primitives\n";
  print_summary(scene, report, out);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return pf::run_tool(kTool, [&] { return run(argc, argv); });
}
