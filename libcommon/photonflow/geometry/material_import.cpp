// Material import: assimp material → pf_material and its textures (material_import.h).
//
// Material mapping (same table in docs/SCENES.md). Values are read through assimp's keys:
//   Kd = AI_MATKEY_COLOR_DIFFUSE (glTF baseColorFactor), Ks = AI_MATKEY_COLOR_SPECULAR,
//   Ke = AI_MATKEY_COLOR_EMISSIVE,
//   Kr = AI_MATKEY_COLOR_REFLECTIVE × AI_MATKEY_REFLECTIVITY (COLLADA <reflective>,
//        <reflectivity>),
//   d  = AI_MATKEY_OPACITY (OBJ `d`, COLLADA <transparent> × <transparency>),
//   Ni = AI_MATKEY_REFRACTI (glTF: KHR_materials_ior's ior, absent without the extension),
//   Ns = AI_MATKEY_SHININESS (OBJ `Ns`, COLLADA <shininess>),
//   M, R = AI_MATKEY_METALLIC_FACTOR, AI_MATKEY_ROUGHNESS_FACTOR (glTF metallicFactor and
//        roughnessFactor, always present for glTF with the spec's defaults 1 and 1; OBJ `Pm`, `Pr`
//        of the MTL PBR extension, present only when given),
//   T  = AI_MATKEY_TRANSMISSION_FACTOR (glTF KHR_materials_transmission),
//   shading = AI_MATKEY_SHADING_MODEL (OBJ illum 2 → Phong, illum 0/1 → no highlight; COLLADA
//        <phong> → Phong, <blinn> → Blinn, <lambert> → Gouraud),
//   illum = AI_MATKEY_OBJ_ILLUM ("$mat.illum", OBJ only: assimp 5.2.5 folds illum 0..2 into
//           AI_MATKEY_SHADING_MODEL and keeps the original number under this key; checked by
//           experiment with illum 1, 3, 5 and 7; a missing illum reads as 1).
// All checked by experiment with assimp 5.2.5 (glTF: the metallic-roughness texture arrives as
// aiTextureType_UNKNOWN index 0, AI_MATKEY_GLTF_PBRMETALLICROUGHNESS_METALLICROUGHNESS_TEXTURE).
// The first rule that matches decides:
//   1. max(Ke) > 0                                     → EMITTER, emission = Ke, color = Kd
//   2. illum 4, 6 or 7, or d < 1                       → GLASS, ior = Ni (1.5 if Ni ≤ 1), color = 1
//      (d is not read for glTF: its base-colour alpha, which assimp also hands as d, is the
//      alpha cut-out of a MASK/BLEND material, alpha_import.h, and ignored under OPAQUE)
//   3. M or R present (glTF, MTL Pm/Pr)                → metallic-roughness (below): base = Kd,
//                                                         metallic M (0 if absent), roughness R
//                                                         (1 if absent), transmission T
//   4. shading Phong or Blinn, Ks not black, Kr black, Ns > 0, not illum 3 or 5
//                                                      → metallic-roughness: roughness
//                                                         1 − √min(Ns, 900)/30 (Blender's OBJ
//                                                         importer, the inverse of its exporter's
//                                                         Ns = (30(1 − roughness))²); a black Kd is
//                                                         a metal of base colour Ks (metallic 1),
//                                                         else a dielectric of base Kd (metallic 0)
//   5. illum 3 or 5, or Kd black and Kr or Ks not black → MIRROR, color = Kr, else Ks, else 1
//   6. otherwise                                       → DIFFUSE, color = Kd
// Metallic-roughness (rules 3 and 4) is PF_MAT_PBR (material/bsdf_shared.h) except for the limits
// where an existing type is that material:
//   a. metallic 0, transmission 0, roughness 1, no metallic-roughness texture → DIFFUSE as rule 6
//      (glTF's roughness-1 dielectric is rendered Lambertian: every scene that rendered diffuse
//      before version 5 keeps its materials, its image and its id);
//   b. α = roughness² below PF_BSDF_ALPHA_MIN, no texture: metallic 1 → MIRROR (color = base),
//      metallic 0 and transmission 1 → GLASS (color = base: glTF tints the transmitted light by
//      the base colour, PF_MAT_GLASS its transmittance); the delta lobes, with the renderer's exact
//      Fresnel (glass) or a constant reflectance (mirror) in place of Schlick's;
//   c. otherwise PF_MAT_PBR, α clamped to PF_BSDF_ALPHA_MIN by the BSDF itself.
// PBR ior: Ni where it is above 1, else 1.5 (glTF's default; OBJ's missing Ni reads as 1, which
// would remove the F0 = 0.04 coat); a transmitting material whose file gives an ior of at most 1 is
// refused (ior 1 is index-matched: the surface would be invisible, bsdf_shared.h).
// M, R, T outside [0, 1] are clamped with a warning (OBJ Pm/Pr; glTF refuses them before,
// gltf_features.h); a PBR base colour to [0, 1].
// Diffuse albedo (also the emitter's) is clamped per channel to [0, kMaxAlbedo] with a warning;
// mirror reflectance to [0, 1].
// Note: assimp's OBJ loader fills a missing Kd with 0.6 and COLLADA's a missing <specular> with
// 0.4 and <shininess> with 10, so an OBJ mirror needs `illum 3` or an explicit `Kd 0 0 0`, and a
// COLLADA <phong> or <blinn> without <specular> is glossy (rule 4, roughness 0.89).
#include "photonflow/geometry/material_import.h"

#include "photonflow/geometry/alpha_import.h"

#include <assimp/GltfMaterial.h>
#include <assimp/ObjMaterial.h>
#include <assimp/material.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <optional>
#include <set>
#include <sstream>
#include <vector>

#include "photonflow/foundations/error.h"
#include "photonflow/material/bsdf_shared.h"
#include "photonflow/material/texture_shared.h"
#include "photonflow/image/texture_image.h"

namespace pf::import {

std::string fmt_float(float f) {
  std::ostringstream os;
  os << f;
  return os.str();
}

std::string fmt_vec(const Vec3& v) {
  std::ostringstream os;
  os << v.x << "," << v.y << "," << v.z;
  return os.str();
}

namespace {

constexpr float kDefaultGlassIor = 1.5f;  // glass whose file gives no usable Ni
constexpr float kDefaultPbrIor = 1.5f;    // glTF's (KHR_materials_ior's default; F0 = 0.04)
constexpr float kMaxPhongExponent = 900.f;  // Blender's OBJ Ns range, 0 … 900

Vec3 get_color(const aiMaterial& m, const char* key, unsigned type, unsigned idx, Vec3 dflt) {
  aiColor3D c;
  return m.Get(key, type, idx, c) == aiReturn_SUCCESS ? to_vec(c) : dflt;
}
float get_float(const aiMaterial& m, const char* key, unsigned type, unsigned idx, float dflt) {
  float f = 0;
  return m.Get(key, type, idx, f) == aiReturn_SUCCESS ? f : dflt;
}
bool has_float(const aiMaterial& m, const char* key, unsigned type, unsigned idx) {
  float f = 0;
  return m.Get(key, type, idx, f) == aiReturn_SUCCESS;
}

// Perceptual roughness of a Phong/Blinn exponent: Blender's OBJ importer's rule (see the top).
float roughness_from_exponent(float ns) {
  return 1.f - std::sqrt(std::clamp(ns, 0.f, kMaxPhongExponent)) / 30.f;
}

int wrap_mode(aiTextureMapMode m) {
  if (m == aiTextureMapMode_Clamp) return PF_TEX_WRAP_CLAMP;
  if (m == aiTextureMapMode_Mirror) return PF_TEX_WRAP_MIRROR;
  return PF_TEX_WRAP_REPEAT;  // wrap, decal (not modelled) or absent
}

// The first texture of type `type`, with its UV channel, wrap modes and glTF magFilter.
std::optional<TextureRef> texture_ref(const aiMaterial& am, aiTextureType type,
                                      TexelDecoding decoding) {
  if (am.GetTextureCount(type) == 0) return std::nullopt;
  aiString path;
  aiTextureMapping mapping = aiTextureMapping_UV;
  unsigned uv = 0;
  aiTextureMapMode modes[3] = {aiTextureMapMode_Wrap, aiTextureMapMode_Wrap,
                               aiTextureMapMode_Wrap};
  if (am.GetTexture(type, 0, &path, &mapping, &uv, nullptr, nullptr, modes) != aiReturn_SUCCESS)
    return std::nullopt;
  if (path.length == 0) return std::nullopt;
  TextureRef r;
  r.path = path.C_Str();
  r.uv_channel = uv;
  r.wrap_s = wrap_mode(modes[0]);
  r.wrap_t = wrap_mode(modes[1]);
  r.decoding = decoding;
  int mag = 0;
  if (am.Get(AI_MATKEY_GLTF_MAPPINGFILTER_MAG(type, 0), mag) == aiReturn_SUCCESS && mag == 9728)
    r.filter = PF_TEX_FILTER_NEAREST;  // GL NEAREST
  return r;
}


// glTF's metallicRoughnessTexture (assimp 5.2.5: aiTextureType_UNKNOWN index 0; it is also listed
// as METALNESS and DIFFUSE_ROUGHNESS), decoded linear.
std::optional<TextureRef> metallic_roughness_texture(const aiMaterial& am) {
  return texture_ref(am, aiTextureType_UNKNOWN, TexelDecoding::kLinear);
}

// Linear value of each 8-bit sRGB code (texture_shared.h's EOTF).
const float* srgb8_table() {
  static const auto table = [] {
    std::vector<float> t(256);
    for (int i = 0; i < 256; ++i) t[size_t(i)] = pf_srgb8_to_linear(i);
    return t;
  }();
  return table.data();
}

// Largest texture file read (a PNG of the largest allowed image compresses to less).
constexpr uint64_t kMaxTextureFileBytes = uint64_t(1) << 30;

// What the file says about one material, before the rules decide its type.
struct MaterialValues {
  Vec3 kd, ks, ke, kr;
  float opacity = 1, ni = 1, ns = 0;
  bool has_ni = false;
  int illum = -1, shading = -1;
  bool has_mr = false;  // metallic or roughness factor given (rule 3)
  float metallic = 0, roughness = 1, transmission = 0;
};

MaterialValues read_values(const aiMaterial& am, const std::string& name, const std::string& file) {
  MaterialValues v;
  v.kd = get_color(am, AI_MATKEY_COLOR_DIFFUSE, Vec3(0, 0, 0));
  v.ks = get_color(am, AI_MATKEY_COLOR_SPECULAR, Vec3(0, 0, 0));
  v.ke = get_color(am, AI_MATKEY_COLOR_EMISSIVE, Vec3(0, 0, 0));
  v.kr = get_color(am, AI_MATKEY_COLOR_REFLECTIVE, Vec3(0, 0, 0)) *
         get_float(am, AI_MATKEY_REFLECTIVITY, 0.f);
  v.opacity = get_float(am, AI_MATKEY_OPACITY, 1.f);
  v.has_ni = has_float(am, AI_MATKEY_REFRACTI);
  v.ni = get_float(am, AI_MATKEY_REFRACTI, 1.f);
  v.ns = get_float(am, AI_MATKEY_SHININESS, 0.f);
  am.Get(AI_MATKEY_OBJ_ILLUM, v.illum);
  // glTF stores its shading model as a 4-byte buffer, not an integer: read only integer ones.
  for (unsigned p = 0; p < am.mNumProperties; ++p) {
    const aiMaterialProperty& prop = *am.mProperties[p];
    if (std::string(prop.mKey.C_Str()) == "$mat.shadingm" && prop.mType == aiPTI_Integer &&
        prop.mDataLength >= sizeof(int))
      std::memcpy(&v.shading, prop.mData, sizeof(int));
  }
  const bool has_m = has_float(am, AI_MATKEY_METALLIC_FACTOR);
  const bool has_r = has_float(am, AI_MATKEY_ROUGHNESS_FACTOR);
  v.has_mr = has_m || has_r;
  v.metallic = get_float(am, AI_MATKEY_METALLIC_FACTOR, 0.f);
  v.roughness = get_float(am, AI_MATKEY_ROUGHNESS_FACTOR, 1.f);
  v.transmission = get_float(am, AI_MATKEY_TRANSMISSION_FACTOR, 0.f);

  for (const Vec3& c : {v.kd, v.ks, v.ke, v.kr})
    if (!finite(c))
      throw input_error(file, "material '" + name + "' has a non-finite colour",
                        "fix the material's numbers");
  if (!std::isfinite(v.opacity) || !std::isfinite(v.ni))
    throw input_error(file, "material '" + name + "' has a non-finite opacity or IOR",
                      "fix the material's numbers");
  if (!std::isfinite(v.ns) || !std::isfinite(v.metallic) || !std::isfinite(v.roughness) ||
      !std::isfinite(v.transmission))
    throw input_error(file, "material '" + name + "' has a non-finite shininess, metallic, "
                            "roughness or transmission factor",
                      "fix the material's numbers");
  return v;
}

}  // namespace

std::optional<TextureRef> base_color_texture(const aiMaterial& am) {
  for (aiTextureType type : {aiTextureType_BASE_COLOR, aiTextureType_DIFFUSE})
    if (auto r = texture_ref(am, type, TexelDecoding::kSrgb)) return r;
  return std::nullopt;
}

int TextureLoader::load(const aiScene& ai, const std::string& file, const std::string& material,
                        const TextureRef& ref) {
  std::string key, name, bytes;
  const aiTexture* embedded = ai.GetEmbeddedTexture(ref.path.c_str());
  if (embedded) {
    const int index = ai.GetEmbeddedTextureAndIndex(ref.path.c_str()).second;
    key = "embedded:" + file + "#" + std::to_string(index);
    name = file + "#" + std::to_string(index);
  } else {
    std::string rel = ref.path;
    std::replace(rel.begin(), rel.end(), '\\', '/');  // Windows exporters
    const size_t slash = file.find_last_of('/');
    key = name = (rel.empty() || rel[0] == '/' || slash == std::string::npos)
                     ? rel
                     : file.substr(0, slash + 1) + rel;
  }
  const bool linear = ref.decoding == TexelDecoding::kLinear;
  // Refusals name the image and the material that uses it.
  const bool coverage_map = ref.decoding == TexelDecoding::kCoverage;
  const std::string label = name + " (" +
                            (linear ? "metallic-roughness" : coverage_map ? "alpha" : "base-colour") +
                            " texture of material '" + material + "')";
  const auto image_key = std::make_pair(int(ref.decoding), key);
  auto image = images_.find(image_key);
  if (image == images_.end()) {
    const uint64_t pool = scene_.texels.size() / 4;
    const uint64_t left = kMaxTextureTexels - pool;
    DecodedImage img;
    if (embedded && embedded->mHeight != 0) {  // raw BGRA8 texels
      const uint64_t w = embedded->mWidth, h = embedded->mHeight;
      if (w > uint64_t(kMaxTextureSide) || h > uint64_t(kMaxTextureSide) || w * h > left)
        throw input_error(label, "embedded texture of " + std::to_string(w) + "x" +
                                    std::to_string(h) + " texels is larger than the limit",
                          "scale the image down");
      img.width = int(w);
      img.height = int(h);
      img.rgba8.resize(size_t(w * h * 4));
      for (size_t i = 0; i < size_t(w * h); ++i) {
        const aiTexel& t = embedded->pcData[i];
        img.rgba8[4 * i] = t.r;
        img.rgba8[4 * i + 1] = t.g;
        img.rgba8[4 * i + 2] = t.b;
        img.rgba8[4 * i + 3] = t.a;
      }
    } else {
      if (embedded) {
        bytes.assign(reinterpret_cast<const char*>(embedded->pcData), embedded->mWidth);
      } else {
        // A FIFO, device, directory or symlink loop is refused before it is opened (its read
        // would wait or never end), and so is a file outside the folder with --confine-inputs.
        const std::string role = std::string(linear ? "metallic-roughness" : coverage_map
                                                                                ? "alpha"
                                                                                : "base-colour") +
                                 " texture of material '" + material + "'";
        const bool found = check_input_file(name, role, file, policy_, root_);
        struct stat st {};
        if (!found || stat(name.c_str(), &st) != 0 || access(name.c_str(), R_OK) != 0) {
          const std::string what = std::string(found ? "cannot be read" : "not found");
          if (!policy_.missing_textures_warn)
            throw input_error(file, "material '" + material + "': " +
                                        (linear ? "metallic-roughness " : "") + "texture '" +
                                        name + "' " + what,
                              "put the image beside the scene, or bake with --missing-textures "
                              "warn to use the material's factors alone");
          report_.warnings.push_back(file + ": material '" + material + "': " +
                                     (linear ? "metallic-roughness " : "") + "texture '" + name +
                                     "' " + what + ", using the " +
                                     (linear ? "metallic and roughness factors" : "colour factor") +
                                     " alone");
          return -1;
        }
        // The size is not told: the file may be one the scene has no business naming.
        if (uint64_t(st.st_size) > kMaxTextureFileBytes)
          throw input_error(label, "texture file is larger than the limit of " +
                                      std::to_string(kMaxTextureFileBytes) + " bytes",
                            "scale the image down");
        std::ifstream in(name, std::ios::binary);
        bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
        if (!in.good() && !in.eof())
          throw input_error(label, "cannot read the texture file", "check its permissions");
      }
      img = decode_texture_image(bytes, label, kMaxTextureSide, left);
    }
    // Colour map: sRGB-encoded RGB to linear, alpha as stored. Data map (metallic-roughness,
    // glTF 2.0 spec 3.9.2: linear): every channel code / 255.
    const float* lut = srgb8_table();
    const size_t n = size_t(img.width) * size_t(img.height);
    scene_.texels.reserve(scene_.texels.size() + 4 * n);
    // Coverage map (OBJ map_d): the coverage in all four channels.
    const std::vector<float> coverage = ref.decoding == TexelDecoding::kCoverage
                                            ? map_d_coverage(img.rgba8)
                                            : std::vector<float>();
    for (size_t i = 0; i < coverage.size(); ++i)
      scene_.texels.insert(scene_.texels.end(), 4, coverage[i]);
    for (size_t i = 0; coverage.empty() && i < n; ++i) {
      for (int k = 0; k < 3; ++k) {
        const uint8_t c = img.rgba8[4 * i + size_t(k)];
        scene_.texels.push_back(linear ? float(c) / 255.f : lut[c]);
      }
      scene_.texels.push_back(float(img.rgba8[4 * i + 3]) / 255.f);
    }
    pf_texture t{};
    t.width = img.width;
    t.height = img.height;
    t.offset = int32_t(pool);
    image = images_.emplace(image_key, std::make_pair(t, name)).first;
  }
  pf_texture t = image->second.first;
  t.wrap_s = ref.wrap_s;
  t.wrap_t = ref.wrap_t;
  t.filter = ref.filter;
  const auto header = std::make_tuple(int(ref.decoding), key, t.wrap_s, t.wrap_t, t.filter);
  auto found = headers_.find(header);
  if (found != headers_.end()) return found->second;
  const int index = int(scene_.textures.size());
  scene_.textures.push_back(t);
  scene_.texture_names.push_back(image->second.second);
  headers_.emplace(header, index);
  return index;
}

void TextureLoader::charge_budget(const aiScene& ai, const std::string& file) {
  struct Charged {
    std::string label;
    uint64_t w, h;
  };
  std::set<std::pair<int, std::string>> seen;  // (decoding, image), as load() keys its images
  std::optional<Charged> largest;
  for (unsigned i = 0; i < ai.mNumMaterials; ++i) {
    const aiMaterial& am = *ai.mMaterials[i];
    std::string material = am.GetName().C_Str();
    if (material.empty()) material = "material" + std::to_string(i);
    for (const std::optional<TextureRef>& ref : {base_color_texture(am), metallic_roughness_texture(am)}) {
      if (!ref) continue;
      const bool linear = ref->decoding == TexelDecoding::kLinear;
      const aiTexture* embedded = ai.GetEmbeddedTexture(ref->path.c_str());
      std::string name, bytes;
      uint64_t w = 0, h = 0;
      if (embedded) {
        name = file + "#" + std::to_string(ai.GetEmbeddedTextureAndIndex(ref->path.c_str()).second);
        if (!seen.insert({int(ref->decoding), "embedded:" + name}).second) continue;
        if (embedded->mHeight != 0) {
          w = embedded->mWidth;
          h = embedded->mHeight;
        } else {
          bytes.assign(reinterpret_cast<const char*>(embedded->pcData), embedded->mWidth);
          if (!texture_image_size(bytes, w, h)) continue;
        }
      } else {
        std::string rel = ref->path;
        std::replace(rel.begin(), rel.end(), '\\', '/');
        const size_t slash = file.find_last_of('/');
        name = (rel.empty() || rel[0] == '/' || slash == std::string::npos)
                   ? rel
                   : file.substr(0, slash + 1) + rel;
        if (!seen.insert({int(ref->decoding), name}).second) continue;
        // Only a regular file inside the rules is opened; every other case is load()'s to refuse.
        try {
          if (!check_input_file(name, "texture", file, policy_, root_)) continue;
        } catch (const InputError&) {
          continue;
        }
        // The header is at the start (PNG's IHDR first; a JPEG frame header after its markers).
        std::ifstream in(name, std::ios::binary);
        bytes.resize(size_t(4) << 20);
        in.read(&bytes[0], std::streamsize(bytes.size()));
        bytes.resize(size_t(in.gcount()));
        if (!texture_image_size(bytes, w, h)) continue;
      }
      const std::string label = name + " (" + (linear ? "metallic-roughness" : "base-colour") +
                                " texture of material '" + material + "')";
      if (!largest || w * h > largest->w * largest->h) largest = Charged{label, w, h};
      charged_ += w * h;
      if (charged_ > kMaxTextureTexels)
        throw input_error(largest->label,
                          "texture image of " + std::to_string(largest->w) + "x" +
                              std::to_string(largest->h) + " texels, the largest of the scene's " +
                              "textures, which need " + std::to_string(charged_) +
                              " texels by the first " + std::to_string(seen.size()) +
                              " images, more than the " + std::to_string(kMaxTextureTexels) +
                              " a scene may have",
                          "scale this image down");
    }
  }
}

ImportedMaterial import_material(const aiScene& ai, const aiMaterial& am, const std::string& name,
                                 const std::string& file, TextureLoader& textures,
                                 BakeReport& report, bool gltf, float emissive_strength) {
  MaterialValues v = read_values(am, name, file);
  v.ke = v.ke * emissive_strength;  // KHR_materials_emissive_strength (light_import.h)
  if (gltf) v.opacity = 1.f;  // base-colour alpha: a cut-out (alpha_import.h) or ignored, no glass
  const std::optional<TextureRef> base_ref = base_color_texture(am);
  // The metallic-roughness texture belongs to the glTF factors (rule 3).
  const std::optional<TextureRef> mr_ref =
      v.has_mr ? metallic_roughness_texture(am) : std::nullopt;
  const bool textured = base_ref.has_value();
  auto warn = [&](const std::string& what) {
    report.warnings.push_back(file + ": material '" + name + "': " + what);
  };
  // `textured`: the material has a base-colour texture (then Kd is its colour factor; a factor of
  // up to 1, glTF's default, becomes kMaxAlbedo without a warning: texels reach 1 and the product
  // must stay below 1). A COLLADA <diffuse> is a colour or a texture, never both: assimp 5.2.5
  // gives a textured one the colour 1 (test_textures checks it).
  auto albedo = [&](const Vec3& c) {
    Vec3 a = clamp3(c, kMaxAlbedo);
    const bool quiet = textured && max3(c) <= 1.f;
    if (!quiet && (max3(c) > kMaxAlbedo || c.x < 0 || c.y < 0 || c.z < 0))
      warn("albedo " + fmt_vec(c) + " clamped to " + fmt_vec(a) + " (albedo must be < 1)");
    return a;
  };
  auto unit_factor = [&](const char* what, float f) {
    const float c = std::clamp(f, 0.f, 1.f);
    if (c != f) warn(std::string(what) + " " + fmt_float(f) + " clamped to " + fmt_float(c));
    return c;
  };

  const bool glossy_phong = (v.shading == aiShadingMode_Phong || v.shading == aiShadingMode_Blinn) &&
                            !black(v.ks) && black(v.kr) && v.ns > 0.f && v.illum != 3 &&
                            v.illum != 5;
  pf_material out{};
  out.ior = 1.f;
  Vec3 color(1, 1, 1);
  if (max3(v.ke) > 0.f) {
    out.type = PF_MAT_EMITTER;
    clamp3(v.ke, INFINITY).store(out.emission);
    color = albedo(v.kd);
  } else if (v.illum == 4 || v.illum == 6 || v.illum == 7 || v.opacity < 1.f) {
    out.type = PF_MAT_GLASS;
    out.ior = v.ni > 1.f ? v.ni : kDefaultGlassIor;
    if (!(v.ni > 1.f))
      warn("glass without an index of refraction > 1, using " + fmt_float(kDefaultGlassIor));
  } else if (v.has_mr || glossy_phong) {
    // Metallic-roughness (rules 3 and 4).
    float metallic, roughness, transmission = 0.f;
    Vec3 base = v.kd;
    if (v.has_mr) {
      metallic = unit_factor("metallic factor", v.metallic);
      roughness = unit_factor("roughness factor", v.roughness);
      transmission = unit_factor("transmission factor", v.transmission);
    } else {
      metallic = black(v.kd) ? 1.f : 0.f;
      if (metallic == 1.f) base = v.ks;
      roughness = roughness_from_exponent(v.ns);
    }
    if (transmission > 0.f && v.has_ni && !(v.ni > 1.f))
      throw input_error(file, "material '" + name + "' transmits (transmission " +
                                  fmt_float(transmission) + ") with an index of refraction of " +
                                  fmt_float(v.ni) + ": an ior of 1 is index-matched, the surface "
                                  "would be invisible",
                        "give KHR_materials_ior an ior above 1 (1.5 is glass), or no transmission");
    const float ior = v.has_ni && v.ni > 1.f ? v.ni : kDefaultPbrIor;
    const bool delta = roughness * roughness < PF_BSDF_ALPHA_MIN && !mr_ref && !textured;
    if (metallic == 0.f && transmission == 0.f && roughness >= 1.f && !mr_ref) {
      out.type = PF_MAT_DIFFUSE;  // limit a: Lambertian, as before format version 5
      color = albedo(v.kd);
    } else if (delta && metallic == 1.f) {
      out.type = PF_MAT_MIRROR;  // limit b: a smooth metal
      color = clamp3(base, 1.f);
    } else if (delta && metallic == 0.f && transmission == 1.f) {
      out.type = PF_MAT_GLASS;  // limit b: smooth glass
      out.ior = ior;
      color = clamp3(base, 1.f);
    } else {
      out.type = PF_MAT_PBR;
      out.ior = ior;
      out.metallic = metallic;
      out.roughness = roughness;
      out.transmission = transmission;
      color = clamp3(base, 1.f);
      const bool quiet = textured && max3(base) <= 1.f;
      if (!quiet && (max3(base) > 1.f || base.x < 0 || base.y < 0 || base.z < 0))
        warn("base colour " + fmt_vec(base) + " clamped to " + fmt_vec(color));
    }
  } else if (v.illum == 3 || v.illum == 5 || (black(v.kd) && (!black(v.kr) || !black(v.ks)))) {
    out.type = PF_MAT_MIRROR;
    color = clamp3(!black(v.kr) ? v.kr : (!black(v.ks) ? v.ks : Vec3(1, 1, 1)), 1.f);
  } else {
    out.type = PF_MAT_DIFFUSE;
    color = albedo(v.kd);
  }
  color.store(out.color);

  ImportedMaterial r;
  r.material = out;
  if (base_ref &&
      (out.type == PF_MAT_DIFFUSE || out.type == PF_MAT_EMITTER || out.type == PF_MAT_PBR)) {
    r.texture = textures.load(ai, file, name, *base_ref);
    r.uv_channel = base_ref->uv_channel;
  } else if (base_ref) {
    warn(std::string("its base-colour texture '") + base_ref->path + "' is not read (a " +
         (out.type == PF_MAT_GLASS ? "glass" : "mirror") + " takes no texture)");
  }
  if (mr_ref && out.type == PF_MAT_PBR) {
    r.mr_texture = textures.load(ai, file, name, *mr_ref);
    if (!base_ref) {
      r.uv_channel = mr_ref->uv_channel;
    } else if (mr_ref->uv_channel != base_ref->uv_channel) {
      warn("its metallic-roughness texture reads UV channel " +
           std::to_string(mr_ref->uv_channel) + ", its base-colour texture channel " +
           std::to_string(base_ref->uv_channel) + "; both read channel " +
           std::to_string(base_ref->uv_channel) + " (a scene keeps one UV set per triangle)");
    }
  }
  return r;
}

}  // namespace pf::import
