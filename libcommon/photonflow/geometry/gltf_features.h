// gltf_features.h — what a scene file asks for that photonflow does not render, said once
// (docs/SCENES.md, "What is honoured, warned about or refused"). Internal to
// libcommon/photonflow/geometry: the scene import (scene_import.cpp, scene_flatten.cpp) calls
// these before it converts the materials.
#pragma once
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

struct aiMaterial;

namespace pf {

// The glTF extensions photonflow implements (every other one is warned about where a file uses
// it, and refused where the file requires it).
const std::vector<std::string>& gltf_implemented_extensions();

// Checks the JSON of .gltf/.glb file `file` before assimp reads it (nothing for other formats,
// nor for JSON it cannot parse: assimp then says what is wrong). Refuses (InputError, one
// line naming the file and what to do): an extensionsRequired entry photonflow does not
// implement; a material's alphaMode other than OPAQUE, MASK or BLEND; a KHR_lights_punctual
// light whose type is not point, spot or directional; a baseColorFactor, emissiveFactor,
// metallicFactor, roughnessFactor or transmissionFactor outside [0, 1] (the glTF schema's range).
// Appends one warning line to `warnings` per owner (material, light, node, mesh, camera, texture,
// the file) and feature it ignores: an extension it does not implement (KHR_texture_transform on
// a texture reference included), a normal, occlusion, emissive or transmission texture, an
// orthographic camera, animations, skins and morph targets. The document it read goes to `doc`
// (when given), so the import reads the file's JSON once; it is left alone when `file` is not
// glTF or its JSON cannot be read (assimp then says why).
void check_gltf_features(const std::string& file, std::vector<std::string>& warnings,
                         nlohmann::json* doc = nullptr);

// The textures of an OBJ/MTL, COLLADA or other non-glTF material that photonflow does not read
// (bump, normal, specular, shininess, ambient, emissive, displacement, reflection, light maps,
// and a non-OBJ opacity map): one warning line per material and kind of map.
void warn_unread_maps(const aiMaterial& am, const std::string& file, const std::string& material,
                      std::vector<std::string>& warnings);

}  // namespace pf
