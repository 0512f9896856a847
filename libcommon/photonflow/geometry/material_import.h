// material_import.h — scene-bake's materials and textures: one assimp material → pf_material
// (the mapping of docs/SCENES.md, "Materials") and its images → the scene's texel pool.
// Private to the import (scene_flatten.cpp, scene_import.cpp, material_import.cpp): it names assimp types.
#pragma once
#include <assimp/scene.h>

#include <map>
#include <optional>
#include <string>
#include <tuple>
#include <utility>

#include "photonflow/geometry/scene.h"
#include "photonflow/geometry/scene_import.h"

namespace pf::import {

constexpr float kMaxAlbedo = 0.99f;  // diffuse albedo must stay below 1 (energy)

inline Vec3 to_vec(const aiVector3D& v) { return {v.x, v.y, v.z}; }
inline Vec3 to_vec(const aiColor3D& c) { return {c.r, c.g, c.b}; }
inline float max3(const Vec3& v) { return std::max(v.x, std::max(v.y, v.z)); }
inline bool black(const Vec3& v) { return max3(v) <= 0.f; }
inline Vec3 clamp3(const Vec3& v, float hi) {
  return {std::clamp(v.x, 0.f, hi), std::clamp(v.y, 0.f, hi), std::clamp(v.z, 0.f, hi)};
}
std::string fmt_float(float f);
std::string fmt_vec(const Vec3& v);

// A texture a material names, and how its texels are decoded into the pool.
enum class TexelDecoding {
  kSrgb,    // colour map (base colour): sRGB-encoded RGB → linear, alpha as stored
  kLinear,  // data map (glTF metallicRoughnessTexture: B metallic, G roughness): code / 255
  kCoverage,  // OBJ map_d (alpha_import.h map_d_coverage): the coverage in all four channels
};
struct TextureRef {
  std::string path;          // as the file gives it: a file name, or "*N" / a name for embedded ones
  unsigned uv_channel = 0;   // glTF texCoord (AI_MATKEY_UVWSRC)
  int wrap_s = PF_TEX_WRAP_REPEAT, wrap_t = PF_TEX_WRAP_REPEAT;
  int filter = PF_TEX_FILTER_BILINEAR;
  TexelDecoding decoding = TexelDecoding::kSrgb;
};

// The textures of one bake: image files and embedded images decoded once per (image, decoding)
// into the scene's texel pool, one pf_texture header per (image, decoding, wrap modes, filter).
class TextureLoader {
 public:
  // `policy` (BakeOptions::inputs) and `root` (input_root of the scene file, scene_inputs.h) say
  // which image files may be read and what a missing one does.
  TextureLoader(Scene& scene, BakeReport& report, const InputPolicy& policy = {},
                const std::string& root = "")
      : scene_(scene), report_(report), policy_(policy), root_(root) {}

  // Texture index for `ref` of material `material` in scene file `file`. A missing image file is
  // an InputError naming the material and the file, or, with --missing-textures warn, −1 with one
  // warning line. InputError for an image path that is not a regular file (check_input_file), one
  // outside the scene's folder with --confine-inputs, and a damaged or oversized image.
  int load(const aiScene& ai, const std::string& file, const std::string& material,
           const TextureRef& ref);

  // Charges every image that a material of `ai` names (base colour, metallic-roughness), in
  // material order, against the scene's texel budget (kMaxTextureTexels) from its header alone,
  // before load() decodes any: InputError naming the largest image charged when the sum passes
  // the budget (an 8192² image then a 128² one: the 8192² is named, and neither is decoded).
  // Images that cannot be read are left to load().
  void charge_budget(const aiScene& ai, const std::string& file);

 private:
  Scene& scene_;
  BakeReport& report_;
  InputPolicy policy_;
  std::string root_;
  uint64_t charged_ = 0;  // texels charge_budget counted so far
  // (decoding, image key) → pool part, name
  std::map<std::pair<int, std::string>, std::pair<pf_texture, std::string>> images_;
  std::map<std::tuple<int, std::string, int, int, int>, int> headers_;
};

// One file material as the scene stores it.
struct ImportedMaterial {
  pf_material material{};
  int texture = -1;         // base-colour texture (Scene::material_texture)
  int mr_texture = -1;      // metallic-roughness texture (Scene::material_mr_texture)
  unsigned uv_channel = 0;  // the mesh UV channel its textures read
};

// The base-colour texture a material names: glTF's baseColorTexture (assimp 5.2 gives it as
// aiTextureType_BASE_COLOR and as DIFFUSE), OBJ's map_Kd and COLLADA's diffuse <texture> (DIFFUSE).
std::optional<TextureRef> base_color_texture(const aiMaterial& am);

// Converts material `am` (called `name`) of assimp scene `ai`, read from `file`, by the rules of
// docs/SCENES.md, loading its textures through `textures`. Warnings go to `report`; InputError for
// non-finite values and for a transmitting material with an ior of 1. `gltf`: a glTF material,
// whose baseColorFactor alpha (which assimp 5.2.5 also hands as AI_MATKEY_OPACITY) is its
// cut-out under MASK/BLEND (alpha_import.h) and ignored under OPAQUE, never a glass: the opacity
// is not read then.
// `emissive_strength`: glTF's KHR_materials_emissive_strength (light_import.h; 1 for other
// formats), a factor on Ke: radiance = emissiveFactor × emissiveStrength.
ImportedMaterial import_material(const aiScene& ai, const aiMaterial& am, const std::string& name,
                                 const std::string& file, TextureLoader& textures,
                                 BakeReport& report, bool gltf = false,
                                 float emissive_strength = 1.f);

}  // namespace pf::import
