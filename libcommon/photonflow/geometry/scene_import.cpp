// The scene-bake driver: bake_scene (scene_import.h) checks the files a bake reads, runs the
// import in a child process (scene_import_child.cpp) and derives the rest here; import_scene,
// which that child runs, reads the scene (assimp_read.cpp), flattens it (scene_flatten.cpp), adds
// its lights (light_import.cpp), the inserted meshes (insert_mesh) and the camera
// (camera_import.cpp). See docs/SCENES.md.
#include "photonflow/geometry/scene_import.h"

#include <sys/stat.h>

#include <algorithm>
#include <nlohmann/json.hpp>
#include <cmath>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "photonflow/foundations/error.h"
#include "photonflow/geometry/gltf_features.h"
#include "photonflow/geometry/light_import.h"
#include "photonflow/geometry/material_import.h"
#include "photonflow/geometry/scene_validate.h"
#include "photonflow/geometry/scene_import_internal.h"
#include "photonflow/geometry/scene_inputs.h"
#include "photonflow/io/provenance.h"

namespace pf {

namespace import {

namespace {

// Turns v so that +y goes to `up` (a proper rotation by a multiple of 90°: handedness, winding and
// normals stay consistent).
Vec3 turn_y_to(UpAxis up, const Vec3& v) {
  if (up.axis == 1) return up.sign > 0 ? v : Vec3(v.x, -v.y, -v.z);
  if (up.axis == 2) return up.sign > 0 ? Vec3(v.x, -v.z, v.y) : Vec3(v.x, v.z, -v.y);
  return up.sign > 0 ? Vec3(v.y, -v.x, v.z) : Vec3(-v.y, v.x, v.z);
}

// Inserts one extra mesh file, fitted into its box (see MeshInsert), standing along `up`.
void insert_mesh(const MeshInsert& ins, size_t k, UpAxis up, const Bounds& scene_bounds,
                 Flattener& main_file, const std::string& main_path, const ImportContext& ctx,
                 TextureLoader& textures, Scene& scene, BakeReport& report) {
  const int ua = up.axis;
  Vec3 box_lo(0.3f, 0.3f, 0.3f), box_hi(0.7f, 0.7f, 0.7f);
  box_lo[ua] = up.sign > 0 ? 0.f : 0.6f;
  box_hi[ua] = up.sign > 0 ? 0.4f : 1.f;
  if (ins.box_lo) box_lo = *ins.box_lo;
  if (ins.box_hi) box_hi = *ins.box_hi;
  if (!finite(box_lo) || !finite(box_hi) || box_lo.x > box_hi.x || box_lo.y > box_hi.y ||
      box_lo.z > box_hi.z)
    throw input_error(ins.path, "insert box " + fmt_vec(box_lo) + " .. " +
                                    fmt_vec(box_hi) + " is empty or not finite",
                      "give --insert-box as x0,y0,z0,x1,y1,z1 fractions with x0<=x1 etc.");
  int material;
  if (ins.material.empty()) {
    auto it = std::find(scene.material_names.begin(), scene.material_names.end(),
                        "insert-default");
    material = int(it - scene.material_names.begin());
    if (it == scene.material_names.end()) {
      pf_material m{};
      m.type = PF_MAT_DIFFUSE;
      m.ior = 1.f;
      Vec3(kInsertAlbedo, kInsertAlbedo, kInsertAlbedo).store(m.color);
      scene.materials.push_back(m);
      scene.material_names.push_back("insert-default");
    }
  } else {
    material = main_file.material_by_name(ins.material);
    if (material < 0)
      throw input_error(ins.path, "material '" + ins.material + "' is not defined in " +
                                      main_path,
                        "give --insert-material one of the scene's material names");
  }

  Assimp::Importer importer;
  const aiScene* ai = read_file(importer, ins.path, ctx);
  std::vector<pf_triangle> tris;
  std::vector<TriangleUV> uvs;
  Flattener(*ai, ins.path, scene, report, textures)
      .run("insert" + std::to_string(k) + ":", material, tris, uvs);
  if (tris.empty())
    throw input_error(ins.path, "has no triangles to insert", "check the mesh file");

  Bounds mb;
  for (auto& t : tris) {
    for (float* v : {t.v0, t.v1, t.v2, t.n0, t.n1, t.n2}) turn_y_to(up, Vec3(v)).store(v);
    mb.extend(Vec3(t.v0));
    mb.extend(Vec3(t.v1));
    mb.extend(Vec3(t.v2));
  }
  const Vec3 lo = scene_bounds.lo + box_lo * scene_bounds.extent();
  const Vec3 hi = scene_bounds.lo + box_hi * scene_bounds.extent();
  float scale = INFINITY;
  for (int a = 0; a < 3; ++a)
    if (mb.extent()[a] > 0.f) scale = std::min(scale, (hi[a] - lo[a]) / mb.extent()[a]);
  if (!(scale > 0.f && std::isfinite(scale)))
    throw input_error(ins.path, "insert box " + fmt_vec(lo) + " .. " + fmt_vec(hi) +
                                    " has no room for the mesh",
                      "give an --insert-box with a non-zero size on every axis");
  // Centred on the horizontal axes; along up, the mesh's floor-side end on the box's floor face.
  Vec3 anchor = mb.center(), target = (lo + hi) * 0.5f;
  anchor[ua] = up.sign > 0 ? mb.lo[ua] : mb.hi[ua];
  target[ua] = up.sign > 0 ? lo[ua] : hi[ua];
  for (auto& t : tris) {
    for (float* v : {t.v0, t.v1, t.v2}) ((Vec3(v) - anchor) * scale + target).store(v);
    scene.triangles.push_back(t);
  }
  scene.uvs.insert(scene.uvs.end(), uvs.begin(), uvs.end());
  report.inserted_triangles += tris.size();
}

}  // namespace

Scene import_scene(const BakeOptions& options, BakeReport& report, const ImportContext& ctx) {
  Scene scene;
  scene.source = options.input;
  const std::string& file = options.input;

  Assimp::Importer importer;
  struct stat st {};
  nlohmann::json gltf;  // the glTF JSON, read once: checked here, its emissive strengths below
  if (stat(file.c_str(), &st) == 0 && S_ISREG(st.st_mode))
    check_gltf_features(file, report.warnings, &gltf);  // refusals and warnings from the JSON
  const aiScene* ai = read_file(importer, file, ctx);
  TextureLoader textures(scene, report, options.inputs, input_root(file));
  textures.charge_budget(*ai, file);  // from the images' headers, before any is decoded
  Flattener flattener(*ai, file, scene, report, textures, gltf.is_null() ? nullptr : &gltf);
  flattener.run("", -1, scene.triangles, scene.uvs);
  if (scene.triangles.empty())
    throw input_error(file, "no triangles (" + std::to_string(report.triangles_read) +
                                " read, " + std::to_string(report.degenerate_dropped) +
                                " of zero area, " + std::to_string(report.primitives_skipped) +
                                " points or lines)",
                      "the scene needs triangle or polygon meshes");
  add_lights(*ai, file, scene, report);  // light_import.cpp
  const std::optional<FileCamera> file_camera = read_camera(*ai, file, report);
  report.camera_from_file = file_camera.has_value();
  report.camera_source = camera_sources(options, file_camera);
  // Up for the inserts: --up-axis, else the camera's up as resolve_camera takes it.
  if (options.up_axis.axis > 2 || (options.up_axis.sign != 1 && options.up_axis.sign != -1))
    throw std::invalid_argument("bake_scene: up_axis out of range");
  report.insert_up = options.up_axis.axis >= 0
                         ? options.up_axis
                         : dominant_axis(options.up ? *options.up
                                                    : file_camera ? file_camera->up : Vec3(0, 1, 0));

  scene.compute_bounds();
  for (size_t k = 0; k < options.inserts.size(); ++k)
    insert_mesh(options.inserts[k], k, report.insert_up, scene.bounds, flattener, file, ctx,
                textures, scene, report);
  // Every material has its texture entries (−1: the inserts' default material); UVs are kept only
  // where some material has a texture (format version 3, docs/FORMATS.md), base-colour or
  // metallic-roughness (version 5).
  scene.material_texture.resize(scene.materials.size(), -1);
  scene.material_mr_texture.resize(scene.materials.size(), -1);
  // Alpha cut-outs (format version 5): an entry per material once one is masked (the inserts'
  // default material opaque); the UVs stay where a masked material reads an alpha texture.
  if (!scene.material_alpha.empty())
    scene.material_alpha.resize(scene.materials.size(), pf_alpha_material{PF_ALPHA_OPAQUE, 1.f, -1, 0});
  auto some = [](const std::vector<int32_t>& v) {
    return std::any_of(v.begin(), v.end(), [](int32_t t) { return t >= 0; });
  };
  if (!some(scene.material_texture) && !some(scene.material_mr_texture) &&
      std::none_of(scene.material_alpha.begin(), scene.material_alpha.end(),
                   [](const pf_alpha_material& a) { return a.texture >= 0; }))
    scene.uvs.clear();

  bool emitter = !scene.lights.empty();
  for (size_t i = 0; i < scene.triangles.size() && !emitter; ++i)
    emitter = scene.materials[size_t(scene.triangles[i].material)].type == PF_MAT_EMITTER;
  if (!emitter && options.environment.empty())
    throw input_error(file, "no light: no emissive material (Ke > 0), no point, spot or directional light and no --environment",
                      "give a surface an emissive colour, add a point light or give --environment");

  scene.compute_bounds();
  scene.camera = resolve_camera(options, file_camera, scene.bounds, file);
  return scene;
}

}  // namespace import

UpAxis parse_up_axis(const std::string& text) {
  const char* names[] = {"x", "y", "z"};
  for (int a = 0; a < 3; ++a) {
    if (text == names[a]) return UpAxis{a, 1};
    if (text == std::string("-") + names[a]) return UpAxis{a, -1};
  }
  if (text == "auto") return UpAxis{};
  throw input_error("", "--up-axis must be x, y, z, -x, -y, -z or auto, got '" + text + "'");
}

std::string up_axis_name(UpAxis a) {
  if (a.axis < 0 || a.axis > 2) return "auto";
  return std::string(a.sign < 0 ? "-" : "+") + "xyz"[a.axis];
}

UpAxis dominant_axis(const Vec3& up) {
  UpAxis best{1, 1};
  float m = 0.f;
  for (int a = 0; a < 3; ++a)
    if (std::fabs(up[a]) > m) {  // false for NaN: a non-finite vector keeps +y
      m = std::fabs(up[a]);
      best = UpAxis{a, up[a] < 0.f ? -1 : 1};
    }
  return std::isfinite(up.x) && std::isfinite(up.y) && std::isfinite(up.z) ? best : UpAxis{1, 1};
}

Scene bake_scene(const BakeOptions& options, BakeReport& report) {
  report = BakeReport();
  Stopwatch import_clock;
  // Every file the scene and the inserts reference, checked before assimp opens any of them (it
  // opens glTF buffers and OBJ material libraries itself; a FIFO among them would hang it).
  std::vector<std::string> inserts, warnings;
  for (const MeshInsert& ins : options.inserts) inserts.push_back(ins.path);
  check_scene_inputs(options.input, inserts, options.inputs, warnings);
  // The environment map, before the import (a bad map is refused without waiting for it), in
  // this process: OpenEXR and stb_image read the header and check the size before decoding
  // (environment_image.h). With --confine-inputs the map must lie in the scene's folder too.
  Environment environment;
  if (!options.environment.empty()) {
    float rgb[3];
    const bool colour = parse_environment_colour(options.environment, rgb);
    if (!colour && options.inputs.confine &&
        !check_input_file(options.environment, "environment map", "", options.inputs,
                          input_root(options.input)))
      throw input_error(options.environment, "environment map: no such file", "check the path");
    environment = load_environment(options.environment, options.environment_strength,
                                   options.environment_rotate_deg);
  }
  Scene scene = import::import_isolated(options, report);
  scene.environment = std::move(environment);
  report.warnings.insert(report.warnings.begin(), warnings.begin(), warnings.end());
  report.import_seconds = import_clock.seconds();
  finish_scene(scene, options.kd);
  // A baked scene is one load_scene reads: refused here, naming the source, when the file's
  // coordinates or the camera options (--eye 1e19) lie beyond what the stages accept.
  validate_scene(scene, options.input);
  return scene;
}

}  // namespace pf
