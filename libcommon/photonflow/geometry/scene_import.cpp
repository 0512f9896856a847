// Scene import: assimp scene → baked pf::Scene (see scene_import.h, docs/SCENES.md).
//
// Reading. Post-processing is aiProcess_Triangulate | aiProcess_ValidateDataStructure only:
//   - no aiProcess_GenNormals/GenSmoothNormals: shading normals are the file's own, or the
//     geometric normal when the file has none;
//   - no aiProcess_JoinIdenticalVertices: the output is a triangle soup, so joining changes
//     nothing in the result, and it is not safe on bad input — it merges a vertex with a NaN
//     coordinate into a finite one, which hides the error this stage must report;
//   - no aiProcess_PreTransformVertices: the node graph is flattened here, keeping one mesh id per
//     mesh instance (node × mesh), which the per-mesh photon sorting of thesis ch. 7.3 needs.
// Face indices are checked again here (ValidateDataStructure runs only when the loader succeeds).
// Each import runs under an address-space cap (memory_cap.h): 256 MiB + 64 × the bytes of the files
// assimp opens (BudgetIOSystem counts them, glTF buffers and OBJ material libraries included), or
// BakeOptions::import_memory_mb; a parser that runs away on a damaged file is refused promptly.
//
// Isolation. Everything that touches assimp (import_scene: reading, flattening, lights, camera)
// runs in a child process (isolate.h, import_isolated), because assimp 5.2.5 crashes, aborts or
// loops on some damaged files; the child sends the flattened scene back as bytes (encode/decode)
// and bake_scene derives the rest (finish_scene: kd-tree, lights' CDF, scene id) in this process.
//
// Flattening. Each mesh instance is transformed by its node's accumulated matrix; normals by the
// inverse transpose of its 3×3 part. A transform with a negative determinant (a mirror) reverses
// the winding, so v1/v2 are swapped to keep the geometric normal on the front (CCW) side.
//
// Alpha cut-outs (glTF alphaMode/alphaCutoff, OBJ map_d): read by alpha_import.cpp, stored per
// material in Scene::material_alpha (format version 5), the map_d image as its own texture.
//
// Materials and textures: material_import.cpp (the mapping table, also in docs/SCENES.md).
//
// Camera. assimp's camera.h documents mHorizontalFOV as the half angle, but the loaders store the
// full angle: the COLLADA loader copies <xfov> (the full horizontal angle of the COLLADA spec)
// converted to radians, verified with <xfov>60</xfov> → 1.0472; glTF and FBX store full angles
// too. It is therefore read as the full horizontal angle and converted to the vertical one with
// the camera's aspect (mAspect, or width/height when the file has none). Two loader quirks of
// assimp 5.2.5 are compensated: glTF stores yfov·aspect (not the exact 2·atan(aspect·tan(yfov/2)))
// as the horizontal angle, which is accepted as is (a small error for wide cameras), and glTF
// copies the camera node's translation into aiCamera::mPosition although the node keeps it too,
// so the position is taken from the node alone for .gltf/.glb files.
#include "photonflow/geometry/scene_import.h"

#include "photonflow/geometry/alpha_import.h"

#include <assimp/DefaultIOSystem.h>
#include <assimp/IOStream.hpp>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <assimp/Importer.hpp>
#include <cctype>
#include <cmath>
#include <cstring>
#include <functional>
#include <memory>
#include <new>
#include <optional>
#include <set>
#include <sstream>
#include <type_traits>

#include "photonflow/geometry/camera.h"
#include "photonflow/foundations/error.h"
#include "photonflow/foundations/isolate.h"
#include "photonflow/foundations/memory_cap.h"
#include "photonflow/io/provenance.h"
#include "photonflow/geometry/scene_inputs.h"
#include "photonflow/geometry/gltf_features.h"
#include "photonflow/image/texture_image.h"
#include "photonflow/geometry/light_import.h"
#include "photonflow/geometry/material_import.h"
#include "photonflow/geometry/scene_validate.h"

namespace pf {

namespace {

constexpr float kMinSliver = 1e-7f;        // 2·area / longest_edge² below this = zero area
constexpr float kPi = 3.14159265358979323846f;

std::string one_line(std::string s) {
  std::replace(s.begin(), s.end(), '\n', ' ');
  std::replace(s.begin(), s.end(), '\r', ' ');
  while (!s.empty() && s.back() == ' ') s.pop_back();
  return s;
}

using import::black;
using import::clamp3;
using import::fmt_float;
using import::fmt_vec;
using import::ImportedMaterial;
using import::TextureLoader;
using import::to_vec;

// ".dae" for "dir/scene.DAE"; "" when the name has no extension.
std::string lower_extension(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  const size_t dot = path.find_last_of('.');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return {};
  std::string ext = path.substr(dot);
  for (char& ch : ext) ch = char(std::tolower(static_cast<unsigned char>(ch)));
  return ext;
}

// Automatic import budget (memory_cap.h): a floor for the importer's own state plus a multiple of
// the bytes assimp reads. Measured (--import-memory-mb, smallest power of two that bakes): the
// 3.7 MB ogre.obj imports in 64 MiB, the 2.4 MB stanford-bunny.obj in 32 MiB, 9–17 × their size.
constexpr uint64_t kImportBudgetFloor = uint64_t(256) << 20;
constexpr uint64_t kImportBudgetPerByte = 64;
// Automatic time limit of an import (bake_scene's child process): seconds, plus seconds per MB of
// the files named on the command line.
constexpr double kImportSecondsFloor = 60;
constexpr double kImportSecondsPerMB = 10;

// assimp's file system, counting each file it opens once into the import's address-space budget.
class BudgetIOSystem : public Assimp::DefaultIOSystem {
 public:
  BudgetIOSystem(AddressSpaceCap& cap, uint64_t per_byte) : cap_(cap), per_byte_(per_byte) {}
  Assimp::IOStream* Open(const char* file, const char* mode) override {
    // A FIFO or a directory (an OBJ's mtllib naming one) is not opened: its read would block.
    struct stat st {};
    if (stat(file, &st) == 0 && !S_ISREG(st.st_mode)) return nullptr;
    Assimp::IOStream* stream = Assimp::DefaultIOSystem::Open(file, mode);
    if (stream && per_byte_ > 0 && opened_.insert(file).second) {
      bytes_ += stream->FileSize();
      cap_.grow(per_byte_ * uint64_t(stream->FileSize()));
    }
    return stream;
  }
  uint64_t bytes() const { return bytes_; }

 private:
  AddressSpaceCap& cap_;
  uint64_t per_byte_;
  std::set<std::string> opened_;
  uint64_t bytes_ = 0;
};

std::string mib(uint64_t bytes) { return std::to_string((bytes + (1u << 20) - 1) >> 20) + " MiB"; }

// What every assimp read of one bake shares: the address-space budget (BakeOptions::
// import_memory_mb) and a notice of the file about to be read (bake_scene's child process
// reports it, so that a crash is put down to the file assimp was reading).
struct ImportContext {
  uint64_t memory_mb = 0;
  std::function<void(const std::string&)> reading;
};

// The first file `path` references outside its own folder ("" for none, or when the references
// cannot be read).
std::string reference_outside_folder(const std::string& path) {
  try {
    std::vector<std::string> ignored;
    const std::string root = input_root(path);
    for (const SceneReference& ref : scene_references(path, InputPolicy{}, root, ignored))
      if (outside_root(ref.path, root)) return ref.path;
  } catch (const std::exception&) {
  }
  return {};
}

// Reads a file with assimp; the Importer owns the returned scene. ctx.memory_mb > 0 fixes the
// import's address-space budget, 0 makes it automatic (kImportBudget*).
const aiScene* read_file(Assimp::Importer& importer, const std::string& path,
                         const ImportContext& ctx) {
  struct stat st {};
  if (stat(path.c_str(), &st) != 0 || !S_ISREG(st.st_mode) || access(path.c_str(), R_OK) != 0)
    throw input_error(path, "cannot read scene file", "check the path and its permissions");
  if (ctx.reading) ctx.reading(path);
  const uint64_t memory_mb = ctx.memory_mb;
  const aiScene* ai = nullptr;
  bool threw = false, out_of_memory = false, capped = false;
  uint64_t budget = 0, bytes = 0;
  {
    AddressSpaceCap cap(memory_mb > 0 ? memory_mb << 20 : kImportBudgetFloor);
    auto io = std::make_unique<BudgetIOSystem>(cap, memory_mb > 0 ? 0 : kImportBudgetPerByte);
    importer.SetIOHandler(io.get());
    // Back to assimp's default handler before `io` goes, however this block is left (the
    // importer hands a handler back to its caller when given nullptr).
    struct Restore {
      Assimp::Importer& importer;
      ~Restore() { importer.SetIOHandler(nullptr); }
    } restore{importer};
    try {
      ai = importer.ReadFile(path, aiProcess_Triangulate | aiProcess_ValidateDataStructure);
    } catch (const std::bad_alloc&) {  // loaders that do not catch it themselves
      threw = true;
    }
    capped = cap.active();
    budget = cap.budget();
    bytes = io->bytes();
    // assimp's BaseImporter catches the loader's exceptions and keeps their what() as its error.
    out_of_memory = threw || (!ai && std::string(importer.GetErrorString()) == "std::bad_alloc");
  }
  if (out_of_memory && !capped)
    throw input_error(path, "assimp ran out of memory reading it",
                      "check the file; an assimp loader runs away on some damaged files");
  if (out_of_memory) {
    const std::string limit =
        memory_mb > 0 ? "--import-memory-mb " + std::to_string(memory_mb)
                      : mib(kImportBudgetFloor) + " + " + std::to_string(kImportBudgetPerByte) +
                            " x the " + std::to_string(bytes) + " bytes of its files";
    throw input_error(path, "assimp needed more than the import's " + mib(budget) +
                                " of address space reading it (" + limit +
                                "); an assimp loader runs away on some damaged files",
                      "check the file; if it is whole, raise --import-memory-mb");
  }
  if (!ai) {
    const std::string ext = lower_extension(path);
    if (ext.empty() || !importer.IsExtensionSupported(ext))
      throw input_error(path, "not a scene format assimp reads",
                        "use COLLADA (.dae), Wavefront OBJ, glTF or PLY");
    // assimp's message may quote a referenced file's size or bytes: for a file outside the
    // scene's folder (/etc/passwd as a buffer) it is not shown.
    if (const std::string away = reference_outside_folder(path); !away.empty())
      throw input_error(path, "assimp cannot read it (its message is not shown: the scene "
                              "references " + away + ", outside its folder)",
                        "check that the file is valid " + ext.substr(1));
    throw input_error(path, "assimp cannot read it: " + one_line(importer.GetErrorString()),
                      "check that the file is valid " + ext.substr(1));
  }
  if (!ai->mRootNode)
    throw input_error(path, "has no scene graph", "export it again with its geometry");
  return ai;
}

// World matrix of a node: the product of its ancestors' transforms and its own.
aiMatrix4x4 global_transform(const aiNode* node) {
  aiMatrix4x4 m;
  for (const aiNode* n = node; n; n = n->mParent) m = n->mTransformation * m;
  return m;
}

// Appends the triangles of one assimp scene to a triangle list, adding mesh names and (lazily, in
// order of first use) materials to the Scene.
class Flattener {
 public:
  Flattener(const aiScene& ai, const std::string& file, Scene& scene, BakeReport& report,
            TextureLoader& textures)
      : ai_(ai), file_(file), scene_(scene), report_(report), textures_(textures),
        material_map_(ai.mNumMaterials, -1), uv_channel_(ai.mNumMaterials, 0),
        checked_(ai.mNumMeshes, false), emissive_strength_(gltf_emissive_strengths(file)) {}

  // Flattens the whole node graph into `out`, each triangle's texture coordinates into `uvs`
  // (zero where the mesh has none). Mesh names get `prefix` in front; material ≥ 0 replaces the
  // file's materials (the meshes' first UV channel is used then).
  void run(const std::string& prefix, int material, std::vector<pf_triangle>& out,
           std::vector<TriangleUV>& uvs) {
    prefix_ = prefix;
    material_override_ = material;
    out_ = &out;
    uvs_ = &uvs;
    visit(*ai_.mRootNode, aiMatrix4x4());
  }

  // Scene material index of assimp material `i`, converting it on first use.
  int material(unsigned i) {
    if (material_map_[i] < 0) {
      const aiMaterial& am = *ai_.mMaterials[i];
      std::string name = am.GetName().C_Str();
      if (name.empty()) name = "material" + std::to_string(i);
      material_map_[i] = int(scene_.materials.size());
      const AlphaImport alpha =
          read_alpha(am, file_, name, lower_extension(file_) == ".obj", report_.warnings);
      warn_unread_maps(am, file_, name, report_.warnings);  // gltf_features.h
      // glTF has no opacity: the AI_MATKEY_OPACITY assimp hands is baseColorFactor's alpha, a
      // cut-out under MASK/BLEND and nothing under OPAQUE (glTF 2.0 section 3.9.4).
      const ImportedMaterial m = import::import_material(ai_, am, name, file_, textures_, report_,
                                                         is_gltf(file_), emissive_strength_of(am));
      uv_channel_[i] = m.uv_channel;
      scene_.materials.push_back(m.material);
      scene_.material_names.push_back(name);
      scene_.material_texture.resize(scene_.materials.size(), -1);
      scene_.material_texture.back() = m.texture;
      scene_.material_mr_texture.resize(scene_.materials.size(), -1);
      scene_.material_mr_texture.back() = m.mr_texture;
      add_alpha(alpha, i, name, am, m.texture);
    }
    return material_map_[i];
  }

  // The alpha cut-out of the material just added (alpha_import.h): its material_alpha entry
  // (the table is created at the first masked material, earlier ones opaque). A masked material
  // reads the base-colour texture's alpha even where it is not diffuse (it is loaded then).
  void add_alpha(const AlphaImport& a, unsigned i, const std::string& name, const aiMaterial& am,
                 int texture) {
    if (!a.masked()) {
      if (!scene_.material_alpha.empty())
        scene_.material_alpha.push_back(pf_alpha_material{PF_ALPHA_OPAQUE, 1.f, -1, 0});
      return;
    }
    pf_alpha_material m{a.cutoff, a.factor, -1, 0};
    const std::optional<import::TextureRef> ref = import::base_color_texture(am);
    if (a.base_texture_alpha && ref) {
      m.texture = texture >= 0 ? texture : textures_.load(ai_, file_, name, *ref);
      uv_channel_[i] = ref->uv_channel;
    } else if (a.map_d) {
      import::TextureRef d;
      d.path = a.map_d_path;
      d.wrap_s = a.map_d_wrap_s;
      d.wrap_t = a.map_d_wrap_t;
      d.decoding = import::TexelDecoding::kCoverage;
      m.texture = textures_.load(ai_, file_, name, d);  // OBJ: one UV set
    }
    scene_.material_alpha.resize(scene_.materials.size() - 1,
                                 pf_alpha_material{PF_ALPHA_OPAQUE, 1.f, -1, 0});
    scene_.material_alpha.push_back(m);
  }

  // Scene material index of the file's material called `name`, or −1 if there is none.
  int material_by_name(const std::string& name) {
    for (unsigned i = 0; i < ai_.mNumMaterials; ++i)
      if (name == ai_.mMaterials[i]->GetName().C_Str()) return material(i);
    return -1;
  }

 private:
  void visit(const aiNode& node, const aiMatrix4x4& parent) {
    aiMatrix4x4 m = parent * node.mTransformation;
    for (unsigned i = 0; i < node.mNumMeshes; ++i) {
      unsigned mi = node.mMeshes[i];
      if (mi >= ai_.mNumMeshes)
        throw input_error(file_, "node '" + std::string(node.mName.C_Str()) +
                                     "' references mesh " + std::to_string(mi) + " of " +
                                     std::to_string(ai_.mNumMeshes),
                          "the file is damaged; export it again");
      add_instance(*ai_.mMeshes[mi], mi, node, m);
    }
    for (unsigned i = 0; i < node.mNumChildren; ++i) visit(*node.mChildren[i], m);
  }

  void check_vertices(const aiMesh& mesh, unsigned mi, const std::string& name) {
    if (checked_[mi]) return;
    checked_[mi] = true;
    for (unsigned v = 0; v < mesh.mNumVertices; ++v)
      if (!finite(to_vec(mesh.mVertices[v])))
        throw input_error(file_, "mesh '" + name + "' vertex " + std::to_string(v) +
                                     " has a non-finite coordinate (NaN or Inf)",
                          "fix or remove that vertex");
  }

  void add_instance(const aiMesh& mesh, unsigned mi, const aiNode& node, const aiMatrix4x4& m) {
    std::string node_name = node.mName.C_Str(), mesh_name = mesh.mName.C_Str();
    std::string name = node_name.empty() ? mesh_name : node_name;
    if (!mesh_name.empty() && mesh_name != node_name && !node_name.empty())
      name += "/" + mesh_name;
    if (name.empty()) name = "mesh" + std::to_string(mi);
    check_vertices(mesh, mi, name);

    if (mesh.mMaterialIndex >= ai_.mNumMaterials)
      throw input_error(file_, "mesh '" + name + "' references material " +
                                   std::to_string(mesh.mMaterialIndex) + " of " +
                                   std::to_string(ai_.mNumMaterials),
                        "the file is damaged; export it again");
    const int mesh_id = int(scene_.mesh_names.size());
    scene_.mesh_names.push_back(prefix_ + name);
    const int mat = material_override_ >= 0 ? material_override_ : material(mesh.mMaterialIndex);
    const unsigned channel = material_override_ >= 0 ? 0 : uv_channel_[mesh.mMaterialIndex];
    const aiVector3D* tex = channel < AI_MAX_NUMBER_OF_TEXTURECOORDS && mesh.HasTextureCoords(channel)
                                ? mesh.mTextureCoords[channel]
                                : nullptr;
    if (!tex && material_override_ < 0) warn_missing_uvs(mesh.mMaterialIndex, mat, name, channel);

    const aiMatrix3x3 lin(m);
    const float det = lin.Determinant();
    const bool flip = det < 0.f;
    aiMatrix3x3 nm = lin;
    const bool use_normals = mesh.HasNormals() && det != 0.f;
    if (use_normals) nm.Inverse().Transpose();

    for (unsigned f = 0; f < mesh.mNumFaces; ++f) {
      const aiFace& face = mesh.mFaces[f];
      if (face.mNumIndices != 3) {
        ++report_.primitives_skipped;
        continue;
      }
      ++report_.triangles_read;
      unsigned idx[3] = {face.mIndices[0], face.mIndices[1], face.mIndices[2]};
      for (unsigned k : idx)
        if (k >= mesh.mNumVertices)
          throw input_error(file_, "mesh '" + name + "' face " + std::to_string(f) +
                                       " references vertex " + std::to_string(k) + " of " +
                                       std::to_string(mesh.mNumVertices),
                            "the file is damaged; export it again");
      if (flip) std::swap(idx[1], idx[2]);
      Vec3 p[3];
      for (int k = 0; k < 3; ++k) p[k] = to_vec(m * mesh.mVertices[idx[k]]);
      for (const Vec3& q : p)
        if (!finite(q))
          throw input_error(file_, "node '" + node_name + "' transforms mesh '" + name +
                                       "' to non-finite coordinates",
                            "fix the node's transform");
      const Vec3 g = cross(p[1] - p[0], p[2] - p[0]);
      const float e2 = std::max({dot(p[1] - p[0], p[1] - p[0]), dot(p[2] - p[1], p[2] - p[1]),
                                 dot(p[0] - p[2], p[0] - p[2])});
      if (!(length(g) > kMinSliver * e2)) {
        ++report_.degenerate_dropped;
        continue;
      }
      const Vec3 ng = normalize(g);
      pf_triangle t{};
      p[0].store(t.v0);
      p[1].store(t.v1);
      p[2].store(t.v2);
      float* normals[3] = {t.n0, t.n1, t.n2};
      for (int k = 0; k < 3; ++k) {
        Vec3 n = ng;
        if (use_normals) {
          Vec3 s = normalize(to_vec(nm * mesh.mNormals[idx[k]]));
          if (finite(s) && length(s) > 0.5f) n = s;
        }
        n.store(normals[k]);
      }
      t.mesh = mesh_id;
      t.material = mat;
      // assimp hands every format's UVs with v up (it flips glTF's): v' = 1 − v gives the glTF
      // convention of texture_shared.h, (0, 0) the image's top-left.
      TriangleUV uv{};
      for (int k = 0; tex && k < 3; ++k) {
        const float u = tex[idx[k]].x, v = 1.f - tex[idx[k]].y;
        if (!(std::fabs(u) <= kMaxUV && std::fabs(v) <= kMaxUV))
          throw input_error(file_, "mesh '" + name + "' vertex " + std::to_string(idx[k]) +
                                       " has a texture coordinate that is not finite or beyond " +
                                       fmt_float(kMaxUV),
                            "fix the mesh's UVs");
        uv.uv[2 * k] = u;
        uv.uv[2 * k + 1] = v;
      }
      out_->push_back(t);
      uvs_->push_back(uv);
    }
  }

  // One warning per material whose textures read a UV channel that one of its meshes lacks
  // (glTF texCoord N without TEXCOORD_N, an OBJ face without vt): its texels are read at (0, 0).
  void warn_missing_uvs(unsigned file_material, int mat, const std::string& mesh,
                        unsigned channel) {
    const size_t m = size_t(mat);
    const bool textured =
        (m < scene_.material_texture.size() && scene_.material_texture[m] >= 0) ||
        (m < scene_.material_mr_texture.size() && scene_.material_mr_texture[m] >= 0) ||
        (m < scene_.material_alpha.size() && scene_.material_alpha[m].texture >= 0);
    if (!textured || uv_warned_.count(file_material)) return;
    uv_warned_.insert(file_material);
    report_.warnings.push_back(file_ + ": material '" + scene_.material_names[m] +
                               "': its textures read UV set " + std::to_string(channel) +
                               " (glTF texCoord " + std::to_string(channel) + "), which mesh '" +
                               mesh + "' does not have; the texture is read at UV (0, 0) there");
  }

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
  float fov_x_rad = 0;  // full horizontal angle (see the note at the top of this file)
  float aspect = 0;     // width / height; 0 = not given
};

std::optional<FileCamera> read_camera(const aiScene& ai, const std::string& file,
                                      BakeReport& report) {
  if (ai.mNumCameras == 0) return std::nullopt;
  const aiCamera& c = *ai.mCameras[0];
  const aiNode* node = ai.mRootNode->FindNode(c.mName);
  const aiMatrix4x4 m = node ? global_transform(node) : aiMatrix4x4();
  const aiMatrix3x3 lin(m);
  const std::string ext = lower_extension(file);
  const bool gltf = ext == ".gltf" || ext == ".glb";
  FileCamera fc;
  fc.eye = to_vec(m * (gltf ? aiVector3D(0, 0, 0) : c.mPosition));
  fc.dir = normalize(to_vec(lin * c.mLookAt));
  fc.up = normalize(to_vec(lin * c.mUp));
  fc.fov_x_rad = c.mHorizontalFOV;
  fc.aspect = c.mAspect;
  if (!(fc.fov_x_rad > 0.f && fc.fov_x_rad < kPi)) {
    // A glTF orthographic camera (no angle) has its own line already (gltf_features.h).
    if (!(gltf && c.mOrthographicWidth > 0.f))
      report.warnings.push_back(file + ": camera '" + std::string(c.mName.C_Str()) +
                                "' has no usable perspective angle; using " +
                                fmt_float(kDefaultFovYDeg) + " degrees vertical");
    fc.fov_x_rad = 0;
  }
  return fc;
}

// Camera from options, else from the file, else a default that frames the bounds: looking along
// −z at the centre from the distance where the bounding sphere fits the narrower field of view.
pf_camera resolve_camera(const BakeOptions& o, const std::optional<FileCamera>& fc,
                         const Bounds& bounds, const std::string& file) {
  const float file_aspect = fc && fc->aspect > 0.f ? fc->aspect : 0.f;
  const float base_aspect = file_aspect > 0.f ? file_aspect : 1.f;
  if (o.width < 0 || o.height < 0 || o.width > kMaxImageSide || o.height > kMaxImageSide)
    throw input_error(file, "image size " + std::to_string(o.width) + "x" +
                                std::to_string(o.height) + " is out of range",
                      "give --width and --height in pixels, 1.." + std::to_string(kMaxImageSide));
  pf_camera cam{};
  cam.width = o.width;
  cam.height = o.height;
  if (!cam.width && !cam.height) cam.width = kDefaultImageSize;
  if (!cam.height) cam.height = std::max(1, int(std::lround(cam.width / base_aspect)));
  if (!cam.width) cam.width = std::max(1, int(std::lround(cam.height * base_aspect)));
  const float image_aspect = float(cam.width) / float(cam.height);

  float fov_y = kDefaultFovYDeg;
  if (o.fov_y_deg) {
    fov_y = *o.fov_y_deg;
  } else if (fc && fc->fov_x_rad > 0.f) {
    const float a = file_aspect > 0.f ? file_aspect : image_aspect;
    fov_y = 2.f * std::atan(std::tan(0.5f * fc->fov_x_rad) / a) * 180.f / kPi;
  }
  if (!(fov_y > 0.f && fov_y < 180.f))
    throw input_error(file, "vertical field of view " + fmt_float(fov_y) +
                                " is outside (0, 180) degrees",
                      "give --fov in degrees");
  cam.fov_y_deg = fov_y;

  Vec3 eye, look_at, up(0, 1, 0);
  if (fc) {
    eye = fc->eye;
    look_at = fc->eye + fc->dir;
    up = fc->up;
  } else {
    const float half_y = 0.5f * fov_y * kPi / 180.f;
    const float half_x = std::atan(std::tan(half_y) * image_aspect);
    const float radius = 0.5f * length(bounds.extent());
    const float dist = radius / std::sin(std::min(half_x, half_y));
    look_at = bounds.center();
    eye = look_at + Vec3(0, 0, dist);
  }
  if (o.eye) eye = *o.eye;
  if (o.look_at) look_at = *o.look_at;
  if (o.up) up = *o.up;
  const Vec3 dir = look_at - eye;
  // A direction from two points closer than float rounding of the scene's coordinates is noise
  // (an --eye typed onto the file's look-at point by its printed digits): refused, not normalised.
  const float min_dist = 1e-5f * std::max({1.f, length(bounds.extent()), length(eye)});
  if (!finite(eye) || !finite(look_at) || !finite(up) || !(length(dir) > min_dist))
    throw input_error(file, "camera eye " + fmt_vec(eye) + " and look-at " + fmt_vec(look_at) +
                                " do not give a view direction",
                      "give distinct finite --eye and --look-at");
  if (!(length(cross(normalize(dir), normalize(up))) > 1e-4f))
    throw input_error(file, "camera up " + fmt_vec(up) + " is parallel to the view direction",
                      "give an --up that is not along the view");
  eye.store(cam.eye);
  look_at.store(cam.look_at);
  normalize(up).store(cam.up);
  // Thin lens: focused on the look-at point unless --focus-distance says otherwise.
  if (o.aperture > 0.f) {
    cam.aperture = o.aperture;
    cam.focus_distance = o.focus_distance ? *o.focus_distance : length(dir);
    if (const char* why = camera_lens_problem(cam.aperture, cam.focus_distance))
      throw input_error(file, why, "give --aperture and --focus-distance in scene units");
  }
  return cam;
}

// BakeReport::camera_source: each camera value from the options, else the file's camera, else the
// default framing (resolve_camera's order).
std::string camera_sources(const BakeOptions& o, const std::optional<FileCamera>& fc) {
  const bool file_fov = fc && fc->fov_x_rad > 0.f;  // an unusable angle: the default 40 degrees
  const std::pair<const char*, int> values[] = {
      {"eye", o.eye ? 0 : fc ? 1 : 2},
      {"look-at", o.look_at ? 0 : fc ? 1 : 2},
      {"up", o.up ? 0 : fc ? 1 : 2},
      {"fov", o.fov_y_deg ? 0 : file_fov ? 1 : 2}};
  const char* from[3] = {" from options", " from file", " from default framing"};
  std::string out;
  for (int src = 0; src < 3; ++src) {
    std::string names;
    for (const auto& [name, s] : values)
      if (s == src) names += (names.empty() ? "" : ", ") + std::string(name);
    if (!names.empty()) out += (out.empty() ? "" : "; ") + names + from[src];
  }
  return out;
}

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

// Everything of the bake that reads files through assimp (scene, inserts, lights, camera), up to
// the derived data (finish_scene). Runs in bake_scene's child process.
Scene import_scene(const BakeOptions& options, BakeReport& report, const ImportContext& ctx) {
  Scene scene;
  scene.source = options.input;
  const std::string& file = options.input;

  Assimp::Importer importer;
  struct stat st {};
  if (stat(file.c_str(), &st) == 0 && S_ISREG(st.st_mode))
    check_gltf_features(file, report.warnings);  // refusals and warnings from the JSON
  const aiScene* ai = read_file(importer, file, ctx);
  TextureLoader textures(scene, report, options.inputs, input_root(file));
  textures.charge_budget(*ai, file);  // from the images' headers, before any is decoded
  Flattener flattener(*ai, file, scene, report, textures);
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
  if (!emitter)
    throw input_error(file, "no light: no emissive material (Ke > 0) and no point, spot or directional light",
                      "give a surface an emissive colour or add a point light");

  scene.compute_bounds();
  scene.camera = resolve_camera(options, file_camera, scene.bounds, file);
  return scene;
}

// The imported scene and report as bytes, from the child to the parent: records of a tag byte, a
// 64-bit length and that many bytes.
enum RecordTag : char {
  kReading = 'F',     // the path assimp is about to read
  kScene = 'S',       // import_scene's result
  kInputError = 'I',  // an InputError's line
  kError = 'E',       // another exception's what()
};

class ByteWriter {
 public:
  template <class T> void pod(const T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    bytes_.append(reinterpret_cast<const char*>(&v), sizeof v);
  }
  template <class T> void pods(const std::vector<T>& v) {
    pod(uint64_t(v.size()));
    bytes_.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
  }
  void text(const std::string& s) {
    pod(uint64_t(s.size()));
    bytes_ += s;
  }
  void texts(const std::vector<std::string>& v) {
    pod(uint64_t(v.size()));
    for (const auto& s : v) text(s);
  }
  const std::string& bytes() const { return bytes_; }

 private:
  std::string bytes_;
};

class ByteReader {
 public:
  explicit ByteReader(const std::string& bytes) : bytes_(bytes) {}
  template <class T> T pod() {
    T v;
    std::memcpy(&v, take(sizeof v), sizeof v);
    return v;
  }
  template <class T> std::vector<T> pods() {
    const uint64_t n = pod<uint64_t>();
    if (n > (bytes_.size() - at_) / sizeof(T)) short_of_data();
    std::vector<T> v(n);
    if (n) std::memcpy(v.data(), take(n * sizeof(T)), n * sizeof(T));
    return v;
  }
  std::string text() {
    const uint64_t n = pod<uint64_t>();
    return std::string(take(n), n);
  }
  std::vector<std::string> texts() {
    const uint64_t n = pod<uint64_t>();
    std::vector<std::string> v;
    for (uint64_t i = 0; i < n; ++i) v.push_back(text());
    return v;
  }
  bool done() const { return at_ == bytes_.size(); }

 private:
  const char* take(uint64_t n) {
    if (n > bytes_.size() - at_) short_of_data();
    const char* p = bytes_.data() + at_;
    at_ += n;
    return p;
  }
  [[noreturn]] static void short_of_data() {
    throw std::runtime_error("scene import: the child's record is shorter than its contents");
  }
  const std::string& bytes_;
  size_t at_ = 0;
};

std::string record(char tag, const std::string& bytes) {
  ByteWriter w;
  w.pod(tag);
  w.text(bytes);
  return w.bytes();
}

// The records of a child's output. A child killed while sending leaves its last record cut short;
// that one is dropped.
std::vector<std::pair<char, std::string>> split_records(const std::string& output) {
  std::vector<std::pair<char, std::string>> records;
  size_t at = 0;
  while (output.size() - at >= 1 + sizeof(uint64_t)) {
    uint64_t n = 0;
    std::memcpy(&n, output.data() + at + 1, sizeof n);
    if (n > output.size() - at - 1 - sizeof n) break;
    records.emplace_back(output[at], output.substr(at + 1 + sizeof n, n));
    at += 1 + sizeof n + n;
  }
  return records;
}

std::string encode(const Scene& s, const BakeReport& r) {
  ByteWriter w;
  w.pods(s.triangles);
  w.texts(s.mesh_names);
  w.pods(s.materials);
  w.texts(s.material_names);
  w.pods(s.lights);
  w.pod(s.camera);
  w.text(s.source);
  w.pods(s.textures);
  w.pods(s.texels);
  w.texts(s.texture_names);
  w.pods(s.material_texture);
  w.pods(s.material_mr_texture);
  w.pods(s.uvs);
  w.pods(s.material_alpha);
  w.pod(uint64_t(r.triangles_read));
  w.pod(uint64_t(r.degenerate_dropped));
  w.pod(uint64_t(r.primitives_skipped));
  w.pod(uint64_t(r.inserted_triangles));
  w.pod(r.camera_from_file);
  w.text(r.camera_source);
  w.pod(r.insert_up);
  w.texts(r.warnings);
  return w.bytes();
}

Scene decode(const std::string& bytes, BakeReport& r) {
  ByteReader in(bytes);
  Scene s;
  s.triangles = in.pods<pf_triangle>();
  s.mesh_names = in.texts();
  s.materials = in.pods<pf_material>();
  s.material_names = in.texts();
  s.lights = in.pods<pf_light>();
  s.camera = in.pod<pf_camera>();
  s.source = in.text();
  s.textures = in.pods<pf_texture>();
  s.texels = in.pods<float>();
  s.texture_names = in.texts();
  s.material_texture = in.pods<int32_t>();
  s.material_mr_texture = in.pods<int32_t>();
  s.uvs = in.pods<TriangleUV>();
  s.material_alpha = in.pods<pf_alpha_material>();
  r.triangles_read = size_t(in.pod<uint64_t>());
  r.degenerate_dropped = size_t(in.pod<uint64_t>());
  r.primitives_skipped = size_t(in.pod<uint64_t>());
  r.inserted_triangles = size_t(in.pod<uint64_t>());
  r.camera_from_file = in.pod<bool>();
  r.camera_source = in.text();
  r.insert_up = in.pod<UpAxis>();
  r.warnings = in.texts();
  if (!in.done()) throw std::runtime_error("scene import: the child's record has extra bytes");
  return s;
}

// The last line of a console text (what an aborting assimp printed), at most 200 characters.
std::string last_line(const std::string& console) {
  const size_t end = console.find_last_not_of(" \n\r");
  if (end == std::string::npos) return {};
  const size_t nl = console.find_last_of('\n', end);
  const size_t from = nl == std::string::npos ? 0 : nl + 1;
  const std::string s = one_line(console.substr(from, end + 1 - from));
  return s.size() > 200 ? s.substr(0, 200) + "..." : s;
}

// Time limit of the child: a floor plus a rate per byte of the files named (measured: the Cornell
// box with the 3.7 MB ogre.obj inserted imports in 0.14 s here, docs/BENCHMARKS.md), or
// BakeOptions::import_seconds.
double import_time_limit(const BakeOptions& o) {
  if (o.import_seconds > 0) return o.import_seconds;
  uint64_t bytes = 0;
  struct stat st {};
  if (stat(o.input.c_str(), &st) == 0) bytes += uint64_t(st.st_size);
  for (const auto& ins : o.inserts)
    if (stat(ins.path.c_str(), &st) == 0) bytes += uint64_t(st.st_size);
  return kImportSecondsFloor + kImportSecondsPerMB * double(bytes) / 1e6;
}

// import_scene in a child process (isolate.h): a crash, an abort or an endless loop of an assimp
// loader on a damaged file becomes an InputError naming the file it was reading.
Scene import_isolated(const BakeOptions& options, BakeReport& report) {
  const double limit = import_time_limit(options);
  const IsolatedRun run = run_isolated(
      [&](const IsolatedSend& send) {
        try {
          ImportContext ctx;
          ctx.memory_mb = options.import_memory_mb;
          ctx.reading = [&](const std::string& path) { send(record(kReading, path)); };
          BakeReport r;
          const Scene s = import_scene(options, r, ctx);
          send(record(kScene, encode(s, r)));
        } catch (const InputError& e) {
          send(record(kInputError, e.what()));
        } catch (const std::exception& e) {
          send(record(kError, e.what()));
        }
      },
      limit);
  std::string reading = options.input;
  for (const auto& [tag, bytes] : split_records(run.output)) {
    if (tag == kReading) reading = bytes;
    if (tag == kScene && run.exit_code == 0) return decode(bytes, report);
    if (tag == kInputError) throw InputError(bytes);
    if (tag == kError) throw std::runtime_error(bytes);
  }
  const std::string hint = "the file is damaged, or assimp mishandles it: check it or export it "
                           "again";
  if (run.timed_out)
    throw input_error(reading, "assimp did not finish reading it in " +
                                   fmt_float(float(limit)) + " s (an assimp loader loops on some "
                                   "damaged files)",
                      hint + "; if it is whole and large, raise --import-seconds");
  if (run.exit_code == kIsolatedSendFailed)
    throw input_error(reading, "the importing child process could not pass the scene back: its "
                               "memory file could not grow",
                      "no memory left, or a file-size limit (ulimit -f) too small");
  const std::string said = last_line(run.console);
  throw input_error(reading, "assimp crashed reading it (" +
                                 (run.signal ? signal_text(run.signal)
                                             : "exit code " + std::to_string(run.exit_code)) +
                                 (said.empty() ? "" : ": " + said) + ")",
                    hint);
}

}  // namespace

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
  Scene scene = import_isolated(options, report);
  report.warnings.insert(report.warnings.begin(), warnings.begin(), warnings.end());
  report.import_seconds = import_clock.seconds();
  finish_scene(scene, options.kd);
  // A baked scene is one load_scene reads: refused here, naming the source, when the file's
  // coordinates or the camera options (--eye 1e19) lie beyond what the stages accept.
  validate_scene(scene, options.input);
  return scene;
}

}  // namespace pf
