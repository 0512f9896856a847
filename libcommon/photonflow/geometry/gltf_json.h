// gltf_json.h — the JSON of a glTF file, read without assimp: the whole of a .gltf, or the JSON
// chunk of a .glb (glTF 2.0 §4.4), and that text parsed. One reader serves the checks made before
// assimp opens a file (scene_inputs.cpp, gltf_features.cpp) and the material extension assimp
// drops (light_import.cpp).
#pragma once
#include <nlohmann/json_fwd.hpp>
#include <string>

namespace pf {

// How gltf_json_text treats a file it cannot open, and a .glb whose JSON chunk fits the file but
// not the total length its header declares. The defaults are the scene import's; the check of a
// scene's references (scene_inputs.cpp) passes its own.
struct GltfJsonRead {
  // The InputError's problem and hint when the file cannot be opened.
  const char* unreadable = "cannot read scene file";
  const char* unreadable_hint = "check the path and its permissions";
  // A .glb's JSON chunk must also lie within the header's declared length (it must always lie
  // within the file).
  bool within_declared_length = true;
};

// The JSON text of a .gltf file (the whole file), or the JSON chunk of a .glb (a 12-byte header
// "glTF", version, length, then chunks of length, type, data; the first chunk is JSON); a .glb is
// told by its extension. InputError (one line naming `file`) when it cannot be opened
// (how.unreadable), for a .glb shorter than its header and first chunk header or whose first
// chunk is not JSON, and for a JSON chunk that runs past the file (or past the declared length).
std::string gltf_json_text(const std::string& file, const GltfJsonRead& how = {});

// gltf_json_text(file, how), parsed; InputError "its glTF JSON cannot be read: <the parser's
// message>" for a text that is not JSON.
nlohmann::json gltf_json(const std::string& file, const GltfJsonRead& how = {});

}  // namespace pf
