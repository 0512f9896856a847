// gltf_features.cpp — the parts of a scene file photonflow does not render, each said once
// (gltf_features.h; the table in docs/SCENES.md, "What is honoured, warned about or refused").
//
// assimp 5.2.5 reads a glTF file's geometry and most of its materials, but it keeps no record of
// what it skipped: an extension it does not know, a KHR_texture_transform, an unknown alphaMode
// (it keeps the string, which then reads as OPAQUE) or light type (it becomes a spot light).
// These are read here from the file's JSON, with the glTF 2.0 schema's ranges for the factors.
#include "photonflow/geometry/gltf_features.h"

#include <assimp/material.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <utility>

#include "photonflow/geometry/gltf_json.h"
#include "photonflow/geometry/light_import.h"
#include "photonflow/geometry/scene_inputs.h"
#include "photonflow/foundations/error.h"
#include "photonflow/geometry/scene_import.h"

namespace pf {

namespace {

using nlohmann::json;

std::string show(double v) {
  std::ostringstream os;
  os << v;
  return os.str();
}

// "material 'fence'", or "material 3" for an unnamed one.
std::string owner_name(const std::string& kind, const json& item, size_t index) {
  if (item.is_object() && item.contains("name") && item["name"].is_string() &&
      !item["name"].get<std::string>().empty())
    return kind + " '" + item["name"].get<std::string>() + "'";
  return kind + " " + std::to_string(index);
}

bool implemented(const std::string& ext) {
  const auto& v = gltf_implemented_extensions();
  return std::find(v.begin(), v.end(), ext) != v.end();
}

// One warning per (owner, extension): the first place in the owner that uses it.
class ExtensionUses {
 public:
  // Records every extension below `value` (an object of the owner, at `path` within it).
  void walk(const json& value, const std::string& owner, const std::string& path) {
    if (value.is_array()) {
      for (size_t i = 0; i < value.size(); ++i)
        walk(value[i], owner, path + "[" + std::to_string(i) + "]");
      return;
    }
    if (!value.is_object()) return;
    for (auto it = value.begin(); it != value.end(); ++it) {
      if (it.key() == "extras") continue;  // application data, not a rendering feature
      if (it.key() == "extensions" && it->is_object()) {
        for (auto e = it->begin(); e != it->end(); ++e) {
          seen_.insert(e.key());
          if (!implemented(e.key()) && found_.emplace(std::make_pair(owner, e.key()), path).second)
            order_.emplace_back(owner, e.key());
          walk(*e, owner, path.empty() ? e.key() : path + "." + e.key());
        }
        continue;
      }
      walk(*it, owner, path.empty() ? it.key() : path + "." + it.key());
    }
  }
  bool seen(const std::string& ext) const { return seen_.count(ext) > 0; }
  void report(const std::string& file, std::vector<std::string>& warnings) const {
    for (const auto& key : order_) {
      const std::string& where = found_.at(key);
      const bool transform = key.second == "KHR_texture_transform";
      warnings.push_back(file + ": " + key.first + ": extension " + key.second +
                         (where.empty() ? "" : " (on " + where + ")") +
                         " is not implemented; ignored" +
                         (transform ? " (the texture is read untransformed)" : ""));
    }
  }

 private:
  std::set<std::string> seen_;
  std::map<std::pair<std::string, std::string>, std::string> found_;
  std::vector<std::pair<std::string, std::string>> order_;
};

// A factor the glTF schema bounds to [0, 1]: a number, or an array of `n` numbers.
bool unit_values(const json& v, size_t n) {
  auto unit = [](const json& x) {
    if (!x.is_number()) return false;
    const double d = x.get<double>();
    return d >= 0.0 && d <= 1.0;
  };
  if (n == 0) return unit(v);
  return v.is_array() && v.size() == n && std::all_of(v.begin(), v.end(), unit);
}

void check_material(const std::string& file, const json& m, const std::string& who,
                    std::vector<std::string>& warnings) {
  auto refuse_range = [&](const std::string& what, const json& v, const std::string& hint) {
    throw input_error(file, who + ": " + what + " " + v.dump() + " is outside [0, 1]",
                      hint.empty() ? "glTF's " + what + " is in [0, 1]; fix the material's numbers"
                                   : hint);
  };
  if (m.contains("alphaMode")) {
    const json& a = m["alphaMode"];
    const std::string mode = a.is_string() ? a.get<std::string>() : a.dump();
    if (mode != "OPAQUE" && mode != "MASK" && mode != "BLEND")
      throw input_error(file, who + ": alphaMode '" + mode + "' is not OPAQUE, MASK or BLEND",
                        "give the material one of glTF's three alpha modes");
  }
  if (m.contains("pbrMetallicRoughness") && m["pbrMetallicRoughness"].is_object()) {
    const json& p = m["pbrMetallicRoughness"];
    if (p.contains("baseColorFactor") && !unit_values(p["baseColorFactor"], 4))
      refuse_range("baseColorFactor", p["baseColorFactor"], "");
    for (const char* f : {"metallicFactor", "roughnessFactor"})
      if (p.contains(f) && !unit_values(p[f], 0)) refuse_range(f, p[f], "");
  }
  if (m.contains("emissiveFactor") && !unit_values(m["emissiveFactor"], 3))
    refuse_range("emissiveFactor", m["emissiveFactor"],
                 "glTF's emissiveFactor is in [0, 1]; a brighter emitter takes "
                 "KHR_materials_emissive_strength");
  const json* transmission = nullptr;
  if (m.contains("extensions") && m["extensions"].is_object() &&
      m["extensions"].contains("KHR_materials_transmission"))
    transmission = &m["extensions"]["KHR_materials_transmission"];
  if (transmission && transmission->is_object() && transmission->contains("transmissionFactor") &&
      !unit_values((*transmission)["transmissionFactor"], 0))
    refuse_range("KHR_materials_transmission transmissionFactor",
                 (*transmission)["transmissionFactor"], "");

  // Texture references photonflow does not read.
  auto warn_texture = [&](const std::string& slot, const std::string& why) {
    warnings.push_back(file + ": " + who + ": " + slot + " is not read; " + why);
  };
  if (m.contains("normalTexture"))
    warn_texture("normalTexture", "shading uses the mesh's normals");
  if (m.contains("occlusionTexture"))
    warn_texture("occlusionTexture", "the renderer computes occlusion from the geometry");
  bool emissive = false;  // emissiveFactor defaults to black, which the texture cannot brighten
  if (m.contains("emissiveFactor") && m["emissiveFactor"].is_array())
    for (const json& c : m["emissiveFactor"]) emissive = emissive || (c.is_number() && c > 0.0);
  if (m.contains("emissiveTexture") && emissive)
    warn_texture("emissiveTexture", "the emission is emissiveFactor alone");
  if (transmission && transmission->is_object() && transmission->contains("transmissionTexture"))
    warn_texture("KHR_materials_transmission transmissionTexture",
                 "the transmission is transmissionFactor alone");
}

}  // namespace

const std::vector<std::string>& gltf_implemented_extensions() {
  static const std::vector<std::string> v = {
      "KHR_lights_punctual", "KHR_materials_emissive_strength", "KHR_materials_ior",
      "KHR_materials_transmission"};
  return v;
}

void check_gltf_features(const std::string& file, std::vector<std::string>& warnings,
                         json* read) {
  if (!is_gltf(file)) return;
  // Runs before assimp reads the file (assimp turns an unknown light type into a spot, or
  // refuses it for want of spot parameters): a file whose JSON cannot be read is left to
  // assimp's own message.
  json own;
  json& doc = read ? *read : own;  // parsed in place: the caller's copy is this one
  try {
    doc = gltf_json(file);
  } catch (const InputError&) {
    doc = nullptr;
    return;
  }
  if (!doc.is_object()) return;
  auto names = [&doc](const char* key) {
    std::vector<std::string> out;
    if (doc.contains(key) && doc[key].is_array())
      for (const json& e : doc[key]) out.push_back(e.is_string() ? e.get<std::string>() : e.dump());
    return out;
  };
  std::string missing;
  for (const std::string& ext : names("extensionsRequired"))
    if (!implemented(ext)) missing += (missing.empty() ? "" : ", ") + ext;
  if (!missing.empty())
    throw input_error(file, "extensionsRequired names " + missing +
                                ", which photonflow does not implement",
                      "export the scene without it; docs/SCENES.md lists the glTF extensions "
                      "photonflow reads");

  const json* lights = nullptr;
  if (doc.contains("extensions") && doc["extensions"].is_object() &&
      doc["extensions"].contains("KHR_lights_punctual") &&
      doc["extensions"]["KHR_lights_punctual"].is_object() &&
      doc["extensions"]["KHR_lights_punctual"].contains("lights") &&
      doc["extensions"]["KHR_lights_punctual"]["lights"].is_array())
    lights = &doc["extensions"]["KHR_lights_punctual"]["lights"];
  for (size_t i = 0; lights && i < lights->size(); ++i) {
    const json& l = (*lights)[i];
    const json type = l.is_object() && l.contains("type") ? l["type"] : json();
    const std::string t = type.is_string() ? type.get<std::string>() : type.dump();
    if (t != "point" && t != "spot" && t != "directional")
      throw input_error(file, owner_name("light", l, i) + ": KHR_lights_punctual type '" + t +
                                  "' is not point, spot or directional",
                        "give the light one of the three types, or make the surface emissive");
  }

  if (doc.contains("materials") && doc["materials"].is_array())
    for (size_t i = 0; i < doc["materials"].size(); ++i) {
      const json& m = doc["materials"][i];
      if (m.is_object()) check_material(file, m, owner_name("material", m, i), warnings);
    }

  // Extensions photonflow does not implement, by the object that uses them.
  ExtensionUses uses;
  const std::pair<const char*, const char*> kinds[] = {
      {"materials", "material"}, {"meshes", "mesh"},       {"nodes", "node"},
      {"cameras", "camera"},     {"textures", "texture"},  {"images", "image"},
      {"samplers", "sampler"},   {"accessors", "accessor"}, {"bufferViews", "bufferView"},
      {"buffers", "buffer"},     {"scenes", "scene"},      {"skins", "skin"},
      {"animations", "animation"}};
  for (const auto& [key, kind] : kinds)
    if (doc.contains(key) && doc[key].is_array())
      for (size_t i = 0; i < doc[key].size(); ++i)
        uses.walk(doc[key][i], owner_name(kind, doc[key][i], i), "");
  for (size_t i = 0; lights && i < lights->size(); ++i)
    uses.walk((*lights)[i], owner_name("light", (*lights)[i], i), "");
  if (doc.contains("extensions") && doc["extensions"].is_object()) {
    json root = json::object();
    root["extensions"] = doc["extensions"];
    uses.walk(root, "the file", "");
  }
  uses.report(file, warnings);
  for (const std::string& ext : names("extensionsUsed"))
    if (!implemented(ext) && !uses.seen(ext))
      warnings.push_back(file + ": extension " + ext +
                         " (extensionsUsed) is not implemented; ignored");

  // Orthographic cameras, animations, skins and morph targets.
  if (doc.contains("cameras") && doc["cameras"].is_array())
    for (size_t i = 0; i < doc["cameras"].size(); ++i) {
      const json& c = doc["cameras"][i];
      if (c.is_object() && c.contains("type") && c["type"] == "orthographic")
        warnings.push_back(file + ": " + owner_name("camera", c, i) +
                           ": orthographic projection is not implemented; the camera's place and "
                           "direction are used with a perspective view of " +
                           show(kDefaultFovYDeg) + " degrees vertical (or --fov)");
    }
  for (const auto& [key, what] :
       {std::make_pair("animations", "animations are ignored; nodes keep their rest transforms"),
        std::make_pair("skins", "skins are ignored; skinned meshes are drawn unposed")})
    if (doc.contains(key) && doc[key].is_array() && !doc[key].empty())
      warnings.push_back(file + ": " + std::to_string(doc[key].size()) + " " + what);
  if (doc.contains("meshes") && doc["meshes"].is_array())
    for (size_t i = 0; i < doc["meshes"].size(); ++i) {
      const json& mesh = doc["meshes"][i];
      bool targets = false;
      if (mesh.is_object() && mesh.contains("primitives") && mesh["primitives"].is_array())
        for (const json& p : mesh["primitives"])
          targets = targets || (p.is_object() && p.contains("targets") && p["targets"].is_array() &&
                                !p["targets"].empty());
      if (targets)
        warnings.push_back(file + ": " + owner_name("mesh", mesh, i) +
                           ": morph targets are ignored; the base shape is drawn");
    }
}

void warn_unread_maps(const aiMaterial& am, const std::string& file, const std::string& material,
                      std::vector<std::string>& warnings) {
  if (is_gltf(file)) return;  // check_gltf_features says it from the JSON, by glTF's names
  const bool obj = lower_extension(file) == ".obj";
  const std::pair<aiTextureType, const char*> maps[] = {
      {aiTextureType_SPECULAR, "specular map"},
      {aiTextureType_SHININESS, "shininess map"},
      {aiTextureType_AMBIENT, "ambient map"},
      {aiTextureType_EMISSIVE, "emissive map"},
      {aiTextureType_HEIGHT, "bump map"},
      {aiTextureType_NORMALS, "normal map"},
      {aiTextureType_DISPLACEMENT, "displacement map"},
      {aiTextureType_REFLECTION, "reflection map"},
      {aiTextureType_LIGHTMAP, "light map"},
      {aiTextureType_OPACITY, "opacity map"},
      {aiTextureType_METALNESS, "metallic map"},
      {aiTextureType_DIFFUSE_ROUGHNESS, "roughness map"},
      {aiTextureType_AMBIENT_OCCLUSION, "ambient-occlusion map"},
      {aiTextureType_EMISSION_COLOR, "emission map"},
      {aiTextureType_NORMAL_CAMERA, "normal map"},
      {aiTextureType_SHEEN, "sheen map"},
      {aiTextureType_CLEARCOAT, "clearcoat map"},
      {aiTextureType_TRANSMISSION, "transmission map"},
  };
  for (const auto& [type, what] : maps) {
    if (obj && type == aiTextureType_OPACITY) continue;  // OBJ map_d: the alpha cut-out
    if (am.GetTextureCount(type) == 0) continue;
    aiString path;
    am.GetTexture(type, 0, &path);
    warnings.push_back(file + ": material '" + material + "': its " + what + " '" +
                       path.C_Str() + "' is not read");
  }
}

}  // namespace pf
