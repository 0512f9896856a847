// The lights of an imported file: see light_import.h and docs/SCENES.md ("Lights").
//
// Units (docs/SCENES.md): KHR_lights_punctual gives point and spot intensity in candela (lm/sr)
// and directional illuminance in lux (lm/m²); assimp 5.2.5's glTF importer hands color × intensity
// as the aiLight's diffuse colour, and photonflow takes that number 1:1 as radiant intensity
// (W/sr per linear RGB channel) or irradiance (W/m²): the convention it always had for point
// lights, and the one Blender's glTF exporter writes in its "Unitless" lighting mode (candela =
// Blender watts / 4π, lux = sun strength in W/m²), which keeps the balance between lamps and
// emissive surfaces (emissive is radiance 1:1). Blender's default "Standard" mode multiplies by
// 683 lm/W: such a file's lamps come out 683 times brighter relative to its emitters.
// Spot cones: assimp copies innerConeAngle/outerConeAngle (half-angles, radians; defaults 0 and
// π/4) into mAngleInnerCone/mAngleOuterCone; mDirection is the light's local −z.
#include "photonflow/geometry/light_import.h"

#include "photonflow/geometry/gltf_json.h"
#include "photonflow/geometry/scene_inputs.h"

#include <assimp/scene.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "photonflow/foundations/error.h"
#include "photonflow/io/validate.h"

namespace pf {

namespace {

constexpr float kPi = 3.14159265358979323846f;

aiMatrix4x4 world_of(const aiNode* node) {
  aiMatrix4x4 m;
  for (const aiNode* n = node; n; n = n->mParent) m = n->mTransformation * m;
  return m;
}

std::string num(double v) {
  std::ostringstream os;
  os << v;
  return os.str();
}

}  // namespace

bool is_gltf(const std::string& file) {
  const std::string ext = lower_extension(file);
  return ext == ".gltf" || ext == ".glb";
}

void add_lights(const aiScene& ai, const std::string& file, Scene& scene, BakeReport& report) {
  const bool gltf = is_gltf(file);
  for (unsigned i = 0; i < ai.mNumLights; ++i) {
    const aiLight& l = *ai.mLights[i];
    const std::string name = l.mName.C_Str();
    const bool punctual = l.mType == aiLightSource_SPOT || l.mType == aiLightSource_DIRECTIONAL;
    if (l.mType != aiLightSource_POINT && !(gltf && punctual)) {
      report.warnings.push_back(
          file + ": light '" + name + "' ignored (" +
          (punctual ? "spot and directional lights are read from glTF files only"
                    : "only point, spot and directional lights and emissive surfaces are used") +
          ")");
      continue;
    }
    const aiNode* node = ai.mRootNode->FindNode(l.mName);
    const aiMatrix4x4 m = node ? world_of(node) : aiMatrix4x4();
    const Vec3 pos = Vec3((m * l.mPosition).x, (m * l.mPosition).y, (m * l.mPosition).z);
    const aiVector3D dw = aiMatrix3x3(m) * l.mDirection;
    const Vec3 intensity(l.mColorDiffuse.r, l.mColorDiffuse.g, l.mColorDiffuse.b);
    if (!finite(pos) || !finite(intensity))
      throw input_error(file, "light '" + name + "' has a non-finite position or colour",
                        "fix the light");
    if (intensity.x < 0.f || intensity.y < 0.f || intensity.z < 0.f)
      throw input_error(file, "light '" + name + "' has a negative intensity or colour",
                        "give the light a colour and intensity >= 0");
    if (!(std::max(intensity.x, std::max(intensity.y, intensity.z)) > 0.f)) {
      report.warnings.push_back(file + ": light '" + name + "' ignored (zero intensity)");
      continue;
    }
    if (gltf && node && node->mMetaData && node->mMetaData->HasKey("PBR_LightRange"))
      report.warnings.push_back(file + ": light '" + name +
                                "': range ignored (lights fall off with 1/d² without a cut-off)");
    pf_light pl{};
    pl.triangle = -1;
    intensity.store(pl.radiance);  // power (and a directional light's disc) by compute_light_cdf
    if (l.mType == aiLightSource_POINT) {
      pl.type = PF_LIGHT_POINT;
      pos.store(pl.position);
      scene.lights.push_back(pl);
      continue;
    }
    const Vec3 dir(dw.x, dw.y, dw.z);
    const float len = length(dir);
    if (!finite(dir) || !(len > 0.f) || !std::isfinite(len))
      throw input_error(file, "light '" + name + "' has no direction (its node's transform "
                                                  "collapses or is not finite)",
                        "fix the light's node transform");
    normalize(dir).store(pl.direction);
    if (l.mType == aiLightSource_DIRECTIONAL) {
      pl.type = PF_LIGHT_DIRECTIONAL;  // position and area: derive_lights (the scene's bounds)
      scene.lights.push_back(pl);
      continue;
    }
    pl.type = PF_LIGHT_SPOT;
    pos.store(pl.position);
    const float inner = l.mAngleInnerCone, outer = l.mAngleOuterCone;
    if (!std::isfinite(inner) || !std::isfinite(outer) || !(inner >= 0.f) || !(outer > inner) ||
        !(outer <= 0.5f * kPi))
      throw input_error(file, "spot light '" + name + "' has innerConeAngle " + num(inner) +
                                  " and outerConeAngle " + num(outer) +
                                  " (KHR_lights_punctual needs 0 <= inner < outer <= pi/2)",
                        "fix the spot's cone angles");
    pl.cos_inner = std::min(1.f, std::cos(inner));
    pl.cos_outer = std::max(0.f, std::cos(outer));  // cos(π/2) in float is -4e-8
    if (!(pl.cos_inner > pl.cos_outer) || !(pl.cos_outer < 1.f))
      throw input_error(file, "spot light '" + name + "' has innerConeAngle " + num(inner) +
                                  " and outerConeAngle " + num(outer) +
                                  ", too close to tell apart in single precision",
                        "widen the spot's outer cone");
    scene.lights.push_back(pl);
  }
}

std::map<std::string, float> gltf_emissive_strengths(const std::string& file,
                                                     const nlohmann::json* read) {
  if (!is_gltf(file)) return {};
  nlohmann::json own;
  if (!read) own = gltf_json(file);
  const nlohmann::json& doc = read ? *read : own;
  std::map<std::string, float> out;
  const auto mats = doc.find("materials");
  if (mats == doc.end() || !mats->is_array()) return out;
  for (size_t i = 0; i < mats->size(); ++i) {
    float strength = 1.f;
    const nlohmann::json& m = (*mats)[i];
    if (m.is_object() && m.contains("extensions") && m["extensions"].is_object() &&
        m["extensions"].contains("KHR_materials_emissive_strength")) {
      const nlohmann::json& ext = m["extensions"]["KHR_materials_emissive_strength"];
      if (ext.is_object() && ext.contains("emissiveStrength")) {
        const nlohmann::json& v = ext["emissiveStrength"];
        const double d = v.is_number() ? v.get<double>() : NAN;
        if (!(d >= 0.0 && d <= double(kMaxValue)))
          throw input_error(file, "material " + std::to_string(i) +
                                      ": KHR_materials_emissive_strength emissiveStrength " +
                                      (v.is_number() ? num(d) : v.dump()) +
                                      " is not a number in [0, 1e30]",
                            "fix the material's emissiveStrength");
        strength = float(d);
      }
    }
    // assimp names an unnamed glTF material "" as well; such materials share the entry "".
    const std::string name =
        m.is_object() && m.contains("name") && m["name"].is_string() ? m["name"].get<std::string>()
                                                                      : std::string();
    const auto [it, added] = out.emplace(name, strength);
    if (!added && it->second != strength)
      throw input_error(file, "materials named '" + name + "' have different " +
                                  "KHR_materials_emissive_strength values (" + num(it->second) +
                                  " and " + num(strength) + ")",
                        "give the materials distinct names");
  }
  return out;
}

}  // namespace pf
