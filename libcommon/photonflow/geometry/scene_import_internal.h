// scene_import_internal.h — what the parts of the scene import share, private to them
// (assimp_read.cpp, scene_flatten.cpp, camera_import.cpp, scene_import_child.cpp and
// scene_import.cpp): the assimp read of a file, the node-graph flattener, the file's camera, and
// the import that bake_scene runs in a child process. It names assimp types.
#pragma once
#include <assimp/Importer.hpp>
#include <assimp/scene.h>

#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "photonflow/geometry/alpha_import.h"
#include "photonflow/geometry/light_import.h"
#include "photonflow/geometry/material_import.h"
#include "photonflow/geometry/scene.h"
#include "photonflow/geometry/scene_import.h"

namespace pf::import {

// `s` on one line: line breaks as spaces, no trailing spaces (assimp's messages).
std::string one_line(std::string s);

// What every assimp read of one bake shares: the address-space budget (BakeOptions::
// import_memory_mb) and a notice of the file about to be read (bake_scene's child process
// reports it, so that a crash is put down to the file assimp was reading).
struct ImportContext {
  uint64_t memory_mb = 0;
  std::function<void(const std::string&)> reading;
};

// Reads a file with assimp; the Importer owns the returned scene. ctx.memory_mb > 0 fixes the
// import's address-space budget, 0 makes it automatic (kImportBudget*).
const aiScene* read_file(Assimp::Importer& importer, const std::string& path,
                         const ImportContext& ctx);

// World matrix of a node: the product of its ancestors' transforms and its own.
aiMatrix4x4 global_transform(const aiNode* node);

// Appends the triangles of one assimp scene to a triangle list, adding mesh names and (lazily, in
// order of first use) materials to the Scene.
class Flattener {
 public:
  // `gltf`: the file's glTF JSON when the import has read it (check_gltf_features), else null.
  Flattener(const aiScene& ai, const std::string& file, Scene& scene, BakeReport& report,
            TextureLoader& textures, const nlohmann::json* gltf = nullptr)
      : ai_(ai), file_(file), scene_(scene), report_(report), textures_(textures),
        material_map_(ai.mNumMaterials, -1), uv_channel_(ai.mNumMaterials, 0),
        checked_(ai.mNumMeshes, false), emissive_strength_(gltf_emissive_strengths(file, gltf)) {}

  // Flattens the whole node graph into `out`, each triangle's texture coordinates into `uvs`
  // (zero where the mesh has none). Mesh names get `prefix` in front; material ≥ 0 replaces the
  // file's materials (the meshes' first UV channel is used then).
  void run(const std::string& prefix, int material, std::vector<pf_triangle>& out,
           std::vector<TriangleUV>& uvs);

  // Scene material index of assimp material `i`, converting it on first use.
  int material(unsigned i);

  // The alpha cut-out of the material just added (alpha_import.h): its material_alpha entry
  // (the table is created at the first masked material, earlier ones opaque). A masked material
  // reads the base-colour texture's alpha even where it is not diffuse (it is loaded then).
  void add_alpha(const AlphaImport& a, unsigned i, const std::string& name, const aiMaterial& am,
                 int texture);

  // Scene material index of the file's material called `name`, or −1 if there is none.
  int material_by_name(const std::string& name);

 private:
  void visit(const aiNode& node, const aiMatrix4x4& parent);

  void check_vertices(const aiMesh& mesh, unsigned mi, const std::string& name);

  void add_instance(const aiMesh& mesh, unsigned mi, const aiNode& node, const aiMatrix4x4& m);

  // One warning per material whose textures read a UV channel that one of its meshes lacks
  // (glTF texCoord N without TEXCOORD_N, an OBJ face without vt): its texels are read at (0, 0).
  void warn_missing_uvs(unsigned file_material, int mat, const std::string& mesh,
                        unsigned channel);

  const aiScene& ai_;
  const std::string& file_;
  Scene& scene_;
  BakeReport& report_;
  TextureLoader& textures_;
  std::vector<int> material_map_;
  std::vector<unsigned> uv_channel_;  // per file material: the UV channel of its texture
  std::vector<bool> checked_;
  std::set<unsigned> uv_warned_;  // file materials warned about by warn_missing_uvs
  std::map<std::string, float> emissive_strength_;  // glTF emissiveStrength by name (light_import.h)
  // The emissiveStrength of material `am` (1 where the file gives none).
  float emissive_strength_of(const aiMaterial& am) const {
    const auto it = emissive_strength_.find(am.GetName().C_Str());
    return it == emissive_strength_.end() ? 1.f : it->second;
  }
  std::string prefix_;
  int material_override_ = -1;
  std::vector<pf_triangle>* out_ = nullptr;
  std::vector<TriangleUV>* uvs_ = nullptr;
};

// The first camera of a file in world space.
struct FileCamera {
  Vec3 eye, dir, up;
  float fov_x_rad = 0;  // full horizontal angle (see the note at the top of camera_import.cpp)
  float aspect = 0;     // width / height; 0 = not given
};

// The first camera of assimp scene `ai` read from `file` (none when it has none); a warning in
// `report` when its angle is unusable (fov_x_rad 0 then).
std::optional<FileCamera> read_camera(const aiScene& ai, const std::string& file,
                                      BakeReport& report);

// Camera from options, else from the file, else a default that frames the bounds: looking along
// −z at the centre from the distance where the bounding sphere fits the narrower field of view.
pf_camera resolve_camera(const BakeOptions& o, const std::optional<FileCamera>& fc,
                         const Bounds& bounds, const std::string& file);

// BakeReport::camera_source: each camera value from the options, else the file's camera, else the
// default framing (resolve_camera's order).
std::string camera_sources(const BakeOptions& o, const std::optional<FileCamera>& fc);

// Everything of the bake that reads files through assimp (scene, inserts, lights, camera), up to
// the derived data (finish_scene). Runs in bake_scene's child process.
Scene import_scene(const BakeOptions& options, BakeReport& report, const ImportContext& ctx);

// import_scene in a child process (isolate.h): a crash, an abort or an endless loop of an assimp
// loader on a damaged file becomes an InputError naming the file it was reading.
Scene import_isolated(const BakeOptions& options, BakeReport& report);

}  // namespace pf::import
