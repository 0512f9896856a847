// alpha_import.cpp — glTF alphaMode / alphaCutoff and OBJ map_d as scene-bake reads them
// (alpha_import.h; docs/SCENES.md "Alpha cut-outs"; glTF 2.0 section 3.9.4).
#include "photonflow/geometry/alpha_import.h"

#include <assimp/GltfMaterial.h>
#include <assimp/types.h>

#include <cmath>
#include <sstream>

#include "photonflow/foundations/error.h"
#include "photonflow/material/texture_shared.h"

namespace pf {

namespace {

int wrap_of(aiTextureMapMode m) {
  if (m == aiTextureMapMode_Clamp) return PF_TEX_WRAP_CLAMP;
  if (m == aiTextureMapMode_Mirror) return PF_TEX_WRAP_MIRROR;
  return PF_TEX_WRAP_REPEAT;
}

std::string show(float f) {
  std::ostringstream s;
  s << f;
  return s.str();
}

}  // namespace

AlphaImport read_alpha(const aiMaterial& am, const std::string& file, const std::string& material,
                       bool obj, std::vector<std::string>& warnings) {
  AlphaImport a;
  aiString mode;
  if (am.Get(AI_MATKEY_GLTF_ALPHAMODE, mode) == aiReturn_SUCCESS) {
    const std::string m = mode.C_Str();
    if (m != "MASK" && m != "BLEND") return a;  // OPAQUE (others refused: gltf_features.h)
    float cutoff = PF_ALPHA_DEFAULT_CUTOFF;
    if (m == "MASK") {
      float c = PF_ALPHA_DEFAULT_CUTOFF;
      if (am.Get(AI_MATKEY_GLTF_ALPHACUTOFF, c) == aiReturn_SUCCESS) cutoff = c;
      if (!pf_alpha_cutoff_valid(cutoff))
        throw input_error(file, "material '" + material + "': alphaCutoff " + show(cutoff) +
                                    " is outside [0, 1]",
                          "give the material an alphaCutoff in [0, 1] (glTF default 0.5)");
    } else {
      warnings.push_back(file + ": material '" + material +
                         "': alphaMode BLEND is rendered as MASK with alphaCutoff 0.5 (no "
                         "partial transparency)");
    }
    aiColor4D c(1.f, 1.f, 1.f, 1.f);
    if (am.Get(AI_MATKEY_BASE_COLOR, c) != aiReturn_SUCCESS)
      am.Get(AI_MATKEY_COLOR_DIFFUSE, c);
    if (!(c.a >= 0.f && c.a <= 1.f))
      throw input_error(file, "material '" + material + "': baseColorFactor alpha " +
                                  show(c.a) + " is outside [0, 1]",
                        "give the material a baseColorFactor alpha in [0, 1]");
    a.cutoff = cutoff;
    a.factor = c.a;
    a.base_texture_alpha = true;
    return a;
  }
  if (!obj || am.GetTextureCount(aiTextureType_OPACITY) == 0) return a;
  aiString path;
  aiTextureMapMode modes[3] = {aiTextureMapMode_Wrap, aiTextureMapMode_Wrap,
                               aiTextureMapMode_Wrap};
  if (am.GetTexture(aiTextureType_OPACITY, 0, &path, nullptr, nullptr, nullptr, nullptr, modes) !=
          aiReturn_SUCCESS ||
      path.length == 0)
    return a;
  a.cutoff = PF_ALPHA_DEFAULT_CUTOFF;
  a.factor = 1.f;
  a.map_d = true;
  a.map_d_path = path.C_Str();
  a.map_d_wrap_s = wrap_of(modes[0]);
  a.map_d_wrap_t = wrap_of(modes[1]);
  return a;
}

std::vector<float> map_d_coverage(const std::vector<unsigned char>& rgba8) {
  const size_t n = rgba8.size() / 4;
  bool has_alpha = false;
  for (size_t i = 0; i < n && !has_alpha; ++i) has_alpha = rgba8[4 * i + 3] < 255;
  std::vector<float> out(n);
  for (size_t i = 0; i < n; ++i) {
    const unsigned char* p = &rgba8[4 * i];
    const bool grey = p[0] == p[1] && p[1] == p[2];  // exactly its value, no weights' rounding
    const float v = has_alpha ? float(p[3]) / 255.f
                    : grey    ? float(p[0]) / 255.f
                              : (0.2126f * float(p[0]) + 0.7152f * float(p[1]) +
                                 0.0722f * float(p[2])) / 255.f;
    out[i] = v < 0.f ? 0.f : (v > 1.f ? 1.f : v);
  }
  return out;
}

}  // namespace pf
