// The flattening of an assimp node graph into world-space triangles, converting the file's
// materials on first use (Flattener, scene_import_internal.h).
//
// Flattening. Each mesh instance is transformed by its node's accumulated matrix; normals by the
// inverse transpose of its 3×3 part. A transform with a negative determinant (a mirror) reverses
// the winding, so v1/v2 are swapped to keep the geometric normal on the front (CCW) side.
//
// Alpha cut-outs (glTF alphaMode/alphaCutoff, OBJ map_d): read by alpha_import.cpp, stored per
// material in Scene::material_alpha (format version 5), the map_d image as its own texture.
//
// Materials and textures: material_import.cpp (the mapping table, also in docs/SCENES.md).
#include <algorithm>
#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include "photonflow/foundations/error.h"
#include "photonflow/geometry/alpha_import.h"
#include "photonflow/geometry/gltf_features.h"
#include "photonflow/geometry/light_import.h"
#include "photonflow/geometry/scene_import_internal.h"
#include "photonflow/geometry/scene_inputs.h"

namespace pf::import {

namespace {

constexpr float kMinSliver = 1e-7f;        // 2·area / longest_edge² below this = zero area

}  // namespace

aiMatrix4x4 global_transform(const aiNode* node) {
  aiMatrix4x4 m;
  for (const aiNode* n = node; n; n = n->mParent) m = n->mTransformation * m;
  return m;
}

void Flattener::run(const std::string& prefix, int material, std::vector<pf_triangle>& out,
                    std::vector<TriangleUV>& uvs) {
  prefix_ = prefix;
  material_override_ = material;
  out_ = &out;
  uvs_ = &uvs;
  visit(*ai_.mRootNode, aiMatrix4x4());
}

int Flattener::material(unsigned i) {
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

void Flattener::add_alpha(const AlphaImport& a, unsigned i, const std::string& name,
                          const aiMaterial& am, int texture) {
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

int Flattener::material_by_name(const std::string& name) {
  for (unsigned i = 0; i < ai_.mNumMaterials; ++i)
    if (name == ai_.mMaterials[i]->GetName().C_Str()) return material(i);
  return -1;
}

void Flattener::visit(const aiNode& node, const aiMatrix4x4& parent) {
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

void Flattener::check_vertices(const aiMesh& mesh, unsigned mi, const std::string& name) {
  if (checked_[mi]) return;
  checked_[mi] = true;
  for (unsigned v = 0; v < mesh.mNumVertices; ++v)
    if (!finite(to_vec(mesh.mVertices[v])))
      throw input_error(file_, "mesh '" + name + "' vertex " + std::to_string(v) +
                                   " has a non-finite coordinate (NaN or Inf)",
                        "fix or remove that vertex");
}

void Flattener::add_instance(const aiMesh& mesh, unsigned mi, const aiNode& node,
                             const aiMatrix4x4& m) {
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

void Flattener::warn_missing_uvs(unsigned file_material, int mat, const std::string& mesh,
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

}  // namespace pf::import
