// alpha_import.h — what scene-bake reads of a material's alpha cut-out (rules in
// docs/SCENES.md "Alpha cut-outs", shared test in material/alpha_shared.h). Internal to
// libcommon/photonflow/geometry (scene_flatten.cpp calls it; the texture loading stays there).
#pragma once
#include <assimp/material.h>

#include <string>
#include <vector>

#include "photonflow/material/alpha_shared.h"

namespace pf {

// A material's alpha source as the file gives it.
struct AlphaImport {
  float cutoff = PF_ALPHA_OPAQUE;  // −1: not masked; [0, 1]: masked
  float factor = 1.f;              // glTF baseColorFactor.a; 1 for OBJ map_d
  bool base_texture_alpha = false; // glTF: the base-colour texture's alpha multiplies factor
  bool map_d = false;              // OBJ: the map_d image (aiTextureType_OPACITY) is the alpha
  std::string map_d_path;          // its path as the file gives it
  int map_d_wrap_s = 0, map_d_wrap_t = 0;  // PF_TEX_WRAP_* (assimp's map modes)
  bool masked() const { return pf_alpha_masked(cutoff); }
};

// The alpha of assimp material `am` (named `material`) of scene file `file`:
//   glTF (the material carries AI_MATKEY_GLTF_ALPHAMODE): OPAQUE (or absent) → not masked, alpha
//     ignored; MASK → cutoff = alphaCutoff (default 0.5; NaN, negative or above 1 refused:
//     InputError naming the file and the material); BLEND → MASK at 0.5 with one warning line;
//     factor = baseColorFactor.a (AI_MATKEY_BASE_COLOR, else AI_MATKEY_COLOR_DIFFUSE, as RGBA),
//     times the base-colour texture's alpha;
//   OBJ (`obj` true): a map_d (aiTextureType_OPACITY) → masked at 0.5 with factor 1, the map's
//     value as alpha (map_d_coverage); `d` alone is not a mask (it stays the glass rule);
//   other formats: not masked.
AlphaImport read_alpha(const aiMaterial& am, const std::string& file, const std::string& material,
                       bool obj, std::vector<std::string>& warnings);

// The coverage of an 8-bit RGBA map_d image, one value in [0, 1] per texel, as stored (linear,
// no sRGB decode): the alpha channel when some texel's alpha is below 255 (an RGBA image whose
// alpha carries the cut-out, as Blender writes it), else the Rec. 709 luma of R, G, B (MTL's
// default scalar channel for map_d, which for a grey image is its grey value).
std::vector<float> map_d_coverage(const std::vector<unsigned char>& rgba8);

}  // namespace pf
