// light_import.h — the lights of an imported file (internal to the scene import, scene_flatten.cpp and scene_import.cpp; docs/SCENES.md,
// "Lights"): assimp's aiLights (point lights of every format; glTF's KHR_lights_punctual spot and
// directional lights) and glTF's KHR_materials_emissive_strength, which assimp 5.2.5 drops and
// which is read from the file's JSON here.
#pragma once
#include <nlohmann/json_fwd.hpp>
#include <map>
#include <string>
#include <vector>

#include "photonflow/geometry/scene.h"
#include "photonflow/geometry/scene_import.h"

struct aiScene;

namespace pf {

// Appends the file's lights to scene.lights, placed and aimed by their nodes' world transforms:
// point lights of every format (intensity = assimp's diffuse colour, W/sr); for .gltf/.glb files
// also spot lights (KHR_lights_punctual innerConeAngle/outerConeAngle) and directional lights;
// a spot or directional light of another format, a light of another kind or one of zero intensity
// is a warning and ignored, as is glTF's `range`. Throws InputError for a non-finite position,
// direction or intensity, a negative intensity, or a cone outside 0 <= inner < outer <= π/2.
void add_lights(const aiScene& ai, const std::string& file, Scene& scene, BakeReport& report);

// KHR_materials_emissive_strength's emissiveStrength of each material of a .gltf or .glb file,
// by the material's name (assimp 5.2.5's glTF importer does not keep the file's material order,
// so the names match them; 1 where a material has none); empty for other formats. Throws
// InputError for a value that is not a finite number >= 0, for two materials of one name with
// different strengths (they could not be told apart), or a file whose JSON cannot be read.
// `doc`: the file's JSON when the caller has read it already (check_gltf_features), else null.
std::map<std::string, float> gltf_emissive_strengths(const std::string& file,
                                                     const nlohmann::json* doc = nullptr);

// True for a .gltf or .glb file name.
bool is_gltf(const std::string& file);

}  // namespace pf
