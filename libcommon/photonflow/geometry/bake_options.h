// bake_options.h — the options that shape a bake (camera, image size, inserted meshes, kd-tree,
// import limits), defined once for every tool that bakes: scene-bake, and render when its --scene
// is a scene source (scene_source.h). Same names, same meaning, same defaults, same checks in both.
// Header-only so that only the tools (which link cxxopts) see cxxopts; the checks themselves are
// check_bake_options (scene_source.h).
//
// Not here: the tool's --threads (the kd-tree build's threads; each tool defines it, with the same
// meaning) and the input and output names.
//
// The bake options may also come from an options file (options_file.h): --options-file FILE, or
// else the scene's NAME.bake-options beside it, unless --no-options-file. parse_bake_command_line
// reads it in the tool's own process (no shell) and puts its options before the command line's,
// so an option given on the command line wins (cxxopts keeps the last value of an option).
#pragma once
#include <cxxopts.hpp>
#include <sstream>
#include <filesystem>
#include <string>
#include <vector>

#include "photonflow/foundations/options.h"
#include "photonflow/foundations/options_file.h"
#include "photonflow/foundations/tool_main.h"
#include "photonflow/io/provenance.h"
#include "photonflow/geometry/scene_import.h"
#include "photonflow/geometry/scene_source.h"

namespace pf {

// The names of the bake options, in the order --help lists them.
inline const std::vector<std::string>& bake_option_names() {
  static const std::vector<std::string> names = {
      "eye", "look-at", "up", "fov", "aperture", "focus-distance", "width", "height", "insert", "insert-box", "up-axis",
      "insert-material", "kd-ct", "kd-ci", "kd-empty-bonus", "kd-max-depth", "kd-max-leaf",
      "import-memory-mb", "import-seconds", "missing-textures", "confine-inputs", "environment",
      "environment-strength", "environment-rotate"};
  return names;
}

// Adds the bake options to `o` under `group` ("" = the tool's main group).
inline void add_bake_options(cxxopts::Options& o, const std::string& group = "") {
  // The kd-tree defaults are KdBuildParams's (measured, kdtree.h), the same the benchmarks and
  // in-process bakes use.
  const KdBuildParams kd{};
  // clang-format off
  o.add_options(group)
    ("eye", "camera position x,y,z in scene units (default: the file's camera, else a "
            "camera on +z that frames the scene bounds)", cxxopts::value<std::string>())
    ("look-at", "point the camera looks at, x,y,z in scene units (default: from the file's "
                "camera, else the centre of the bounds)", cxxopts::value<std::string>())
    ("up", "camera up direction x,y,z (default: from the file's camera, else 0,1,0)",
     cxxopts::value<std::string>())
    ("fov", "vertical field of view in degrees, (0, 180) (default: from the file's camera, "
            "else " + default_text(kDefaultFovYDeg) + ")", cxxopts::value<float>())
    ("aperture", "thin-lens radius in scene units for depth of field; 0 = pinhole camera, "
                 "everything sharp (assimp gives no aperture from files)",
     cxxopts::value<float>()->default_value("0"))
    ("focus-distance", "distance of the sharp plane along the view axis, scene units; needs "
                       "--aperture (default: the distance from the eye to the look-at point)",
     cxxopts::value<float>())
    ("width", "image width in pixels; 0 = " + default_text(kDefaultImageSize) + ", or from "
              "--height and the file camera's aspect", cxxopts::value<int>()->default_value("0"))
    ("height", "image height in pixels; 0 = " + default_text(kDefaultImageSize) + ", or from "
               "--width and the file camera's aspect", cxxopts::value<int>()->default_value("0"))
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
    ("insert-material", "material name (from the scene file) for the matching --insert "
                        "(repeatable; default: insert-default, diffuse albedo " +
                        default_text(kInsertAlbedo) + ")",
     cxxopts::value<std::vector<std::string>>())
    ("kd-ct", "kd-tree SAH cost of a traversal step C_ts (eq. 4.8), unitless",
     cxxopts::value<float>()->default_value(default_text(kd.cost_traversal)))
    ("kd-ci", "kd-tree SAH cost of a triangle test C_L/C_R (eq. 4.8), unitless",
     cxxopts::value<float>()->default_value(default_text(kd.cost_intersect)))
    ("kd-empty-bonus", "kd-tree SAH cost reduction for cutting off empty space, fraction",
     cxxopts::value<float>()->default_value(default_text(kd.empty_bonus)))
    ("kd-max-depth", "kd-tree maximum depth, levels (0 = automatic: 8 + 1.3 log2 N)",
     cxxopts::value<int>()->default_value(default_text(kd.max_depth)))
    ("kd-max-leaf", "kd-tree: never split nodes with this many triangles or fewer",
     cxxopts::value<int>()->default_value(default_text(kd.max_leaf_size)))
    ("import-memory-mb", "address space each file import may take, MiB (0 = automatic: 256 MiB + "
                         "64 x the bytes of the files read); a loader that runs away on a "
                         "damaged file is stopped there",
     cxxopts::value<uint64_t>()->default_value("0"))
    ("import-seconds", "time limit of the file import, s (0 = automatic: 60 s + 10 s per MB "
                       "of the input files); a loader that loops on a damaged file is stopped "
                       "there", cxxopts::value<double>()->default_value("0"))
    ("missing-textures", "a texture the scene names that cannot be found or has no data "
                         "(missing file, empty or bad URI, image without a source, empty buffer "
                         "view): error (refuse the bake) | warn (drop it with a warning: the "
                         "material's factors alone)",
     cxxopts::value<std::string>()->default_value("error"))
    ("confine-inputs", "every file the scene references (buffers, images, material libraries) "
                       "and every --insert must resolve, after symlinks, inside the scene file's "
                       "folder; for services that render scenes from strangers")
    ("environment", "environment light around the scene: an equirectangular (2:1, at most "
                    "8192x4096) radiance map, .exr or .hdr, or a constant colour R,G,B in "
                    "W/(sr m^2); without it, none (docs/SCENES.md, Environment)",
     cxxopts::value<std::string>())
    ("environment-strength", "factor on the environment's radiance, > 0",
     cxxopts::value<float>()->default_value("1"))
    ("environment-rotate", "rotation of the environment about the up axis +y, degrees "
                           "(counter-clockwise seen from above)",
     cxxopts::value<float>()->default_value("0"));
  // clang-format on
}

// Adds --options-file and --no-options-file to `o` under `group`.
inline void add_options_file_options(cxxopts::Options& o, const std::string& group = "") {
  // clang-format off
  o.add_options(group)
    ("options-file", "read bake options from this file before the command line's, which win: "
                     "words and '#' comments, no shell (docs/SCENES.md); without it the scene "
                     "source's NAME.bake-options beside it is read, if there is one",
     cxxopts::value<std::string>())
    ("no-options-file", "read no options file, not even the scene's NAME.bake-options");
  // clang-format on
}

// The command line of a tool that bakes (add_bake_options, add_options_file_options), parsed
// (parse_options) with the options of its options file in front: --options-file FILE, else
// discover_options_file of the scene (the option `scene_option`: "input" for scene-bake, "scene"
// for render) unless --no-options-file is given or the scene is a baked scene (only when
// `scene_may_be_baked`: render). Each option of the file is parsed alone first, so a value that
// cxxopts refuses is refused naming the file and line. The result holds --options-file FILE for
// the file read (given or found), so provenance and given_bake_options see it.
inline cxxopts::ParseResult parse_bake_command_line(cxxopts::Options& o, int argc, char** argv,
                                                    const std::string& scene_option,
                                                    bool scene_may_be_baked) {
  cxxopts::ParseResult a = parse_options(o, argc, argv);
  require_not_both(a, "options-file", "no-options-file",
                   "--no-options-file reads none, --options-file reads the one given");
  std::string file;
  if (a.count("options-file")) {
    file = a["options-file"].as<std::string>();
    if (file.empty()) throw input_error("", "--options-file is empty", "give it a file name");
  } else if (!a.count("no-options-file") && !a.count("help") && a.count(scene_option)) {
    const std::string scene = a[scene_option].as<std::string>();
    file = discover_options_file(scene);
    if (!file.empty() && scene_may_be_baked && is_baked_scene(scene)) file.clear();
  }
  if (file.empty()) return a;
  std::vector<std::string> words = {argv[0]};
  for (const OptionsFileOption& opt : read_options_file(file, bake_option_names())) {
    // A relative map path in an options file is the file's neighbour (as a glTF's buffers and
    // images are the scene's): resolved against the options file's folder, not the working one.
    // A colour "R,G,B" stays as it is.
    std::string value = opt.value;
    if (opt.name == "environment" && !value.empty() &&
        value.find_first_not_of("0123456789.,+-eE ") != std::string::npos &&
        std::filesystem::path(value).is_relative())
      value = (std::filesystem::path(file).parent_path() / value).lexically_normal().string();
    const std::string word = "--" + opt.name + "=" + value;
    const char* one[] = {argv[0], word.c_str(), nullptr};
    try {
      o.parse(2, one);
    } catch (const cxxopts::exceptions::exception& e) {
      throw input_error(file + ":" + std::to_string(opt.line), e.what(),
                        "correct the value in the options file, or give --no-options-file");
    }
    words.push_back(word);
  }
  words.push_back("--options-file=" + file);
  for (int i = 1; i < argc; ++i) words.push_back(argv[i]);
  std::vector<char*> ptrs;
  for (std::string& w : words) ptrs.push_back(&w[0]);
  ptrs.push_back(nullptr);
  return parse_options(o, int(words.size()), ptrs.data());
}

// The bake options given on the command line or by an options file ("" none): "--width, --kd-ct".
inline std::string given_bake_options(const cxxopts::ParseResult& a) {
  std::string list;
  for (const std::string& name : bake_option_names())
    if (a.count(name)) list += (list.empty() ? "--" : ", --") + name;
  if (a.count("options-file")) list += list.empty() ? "--options-file" : ", --options-file";
  return list;
}

// BakeOptions from the parsed bake options (input: `input`, kd-tree threads: `threads`), checked
// (check_bake_options: one-line InputError naming the option).
inline BakeOptions bake_options(const cxxopts::ParseResult& a, const std::string& input,
                                int threads) {
  BakeOptions o;
  o.input = input;
  if (a.count("eye")) o.eye = parse_vec3("eye", a["eye"].as<std::string>());
  if (a.count("look-at")) o.look_at = parse_vec3("look-at", a["look-at"].as<std::string>());
  if (a.count("up")) o.up = parse_vec3("up", a["up"].as<std::string>());
  if (a.count("fov")) o.fov_y_deg = a["fov"].as<float>();
  o.aperture = a["aperture"].as<float>();
  if (a.count("focus-distance")) o.focus_distance = a["focus-distance"].as<float>();
  o.up_axis = parse_up_axis(a["up-axis"].as<std::string>());
  o.width = a["width"].as<int>();
  o.height = a["height"].as<int>();
  o.kd.cost_traversal = a["kd-ct"].as<float>();
  o.kd.cost_intersect = a["kd-ci"].as<float>();
  o.kd.empty_bonus = a["kd-empty-bonus"].as<float>();
  o.kd.max_depth = a["kd-max-depth"].as<int>();
  o.kd.max_leaf_size = a["kd-max-leaf"].as<int>();
  o.kd.threads = threads;
  o.import_memory_mb = a["import-memory-mb"].as<uint64_t>();
  o.import_seconds = a["import-seconds"].as<double>();
  const std::string missing = a["missing-textures"].as<std::string>();
  require_choice("missing-textures", missing, {"error", "warn"});
  o.inputs.missing_textures_warn = missing == "warn";
  o.inputs.confine = a.count("confine-inputs") > 0;
  if (a.count("environment")) {
    o.environment = a["environment"].as<std::string>();
    if (o.environment.empty())
      throw input_error("", "--environment is empty", "give a .exr or .hdr map or a colour R,G,B");
  }
  o.environment_strength = a["environment-strength"].as<float>();
  o.environment_rotate_deg = a["environment-rotate"].as<float>();
  if ((a.count("environment-strength") || a.count("environment-rotate")) && o.environment.empty())
    throw input_error("", "--environment-strength and --environment-rotate need --environment");
  std::vector<std::string> inserts, materials;
  std::vector<float> boxes;
  if (a.count("insert")) inserts = a["insert"].as<std::vector<std::string>>();
  if (a.count("insert-material")) materials = a["insert-material"].as<std::vector<std::string>>();
  if (a.count("insert-box")) boxes = a["insert-box"].as<std::vector<float>>();
  if (boxes.size() % 6 != 0)
    throw input_error("", "--insert-box needs six numbers x0,y0,z0,x1,y1,z1 per box");
  if (boxes.size() / 6 > inserts.size() || materials.size() > inserts.size())
    throw input_error("", "more --insert-box or --insert-material than --insert files",
                      "give one --insert per box and material");
  for (size_t i = 0; i < inserts.size(); ++i) {
    MeshInsert ins;
    ins.path = inserts[i];
    if (6 * i < boxes.size()) {
      ins.box_lo = Vec3(&boxes[6 * i]);
      ins.box_hi = Vec3(&boxes[6 * i + 3]);
    }
    if (i < materials.size()) ins.material = materials[i];
    o.inserts.push_back(ins);
  }
  check_bake_options(o);
  return o;
}

// Records the bake options in `prov` as scene-bake does: every bake option's text, given or
// default (the optional camera ones only when given), with the repeatable --insert* joined by ';'
// ("default" for a box not given, "insert-default" for a material not given).
inline void record_bake_options(Provenance& prov, const cxxopts::ParseResult& a,
                                const BakeOptions& o) {
  for (const auto& kv : a.defaults())
    for (const std::string& name : bake_option_names())
      if (kv.key() == name) prov.parameters[name] = kv.value();
  for (const auto& kv : a.arguments())
    for (const std::string& name : bake_option_names())
      if (kv.key() == name) prov.parameters[name] = kv.value();
  std::string insert_text, box_text, material_text;
  for (size_t i = 0; i < o.inserts.size(); ++i) {
    const MeshInsert& ins = o.inserts[i];
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
}

// The scene's part of a run's provenance (render): its inputs (add_scene_inputs) and, for a scene
// baked here, the bake options as scene-bake records them; for a baked scene.h5 none of them (they
// were not used: record_options put their defaults in).
inline void record_scene(Provenance& prov, const cxxopts::ParseResult& a, const std::string& path,
                         const OpenedScene& s, const BakeOptions& bake) {
  for (const std::string& name : bake_option_names()) prov.parameters.erase(name);
  if (s.baked_here) record_bake_options(prov, a, bake);
  add_scene_inputs(prov, path, s, bake);
}

// The provenance of a baked scene file, as scene-bake writes it and render --keep-scene too:
// tool "scene-bake" (the stage whose function, options and checks made it; command_line says which
// executable ran it), every bake option (record_bake_options), input, output, threads and depfile, and
// the inputs "source" and "insert<i>" (hashed here: InputError if one is unreadable).
inline Provenance bake_provenance(const cxxopts::ParseResult& a, const BakeOptions& o,
                                  const std::string& output, const std::string& command_line) {
  Provenance prov;
  prov.tool = "scene-bake";
  prov.command_line = command_line;
  record_bake_options(prov, a, o);
  prov.param("input", o.input);
  prov.param("options-file", path_option(a, "options-file"));  // "" none
  prov.param("output", output);
  prov.param("threads", o.kd.threads);
  // scene-bake --depfile ("" none, and for render --keep-scene, which has no such option)
  prov.param("depfile", a.count("depfile") ? a["depfile"].as<std::string>() : std::string());
  add_bake_inputs(prov, o);
  return prov;
}

}  // namespace pf
