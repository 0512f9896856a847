// The JSON of a glTF file, read and parsed without assimp: see gltf_json.h.
#include "photonflow/geometry/gltf_json.h"

#include <cstdint>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "photonflow/foundations/error.h"
#include "photonflow/geometry/scene_inputs.h"

namespace pf {

std::string gltf_json_text(const std::string& file, const GltfJsonRead& how) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw input_error(file, how.unreadable, how.unreadable_hint);
  if (lower_extension(file) != ".glb") {
    std::ostringstream os;
    os << in.rdbuf();
    return os.str();
  }
  unsigned char head[20];
  if (!in.read(reinterpret_cast<char*>(head), sizeof head) || std::memcmp(head, "glTF", 4) != 0 ||
      std::memcmp(head + 16, "JSON", 4) != 0)
    throw input_error(file, "is not a binary glTF with a JSON chunk first", "export it again");
  const uint32_t n = uint32_t(head[12]) | uint32_t(head[13]) << 8 | uint32_t(head[14]) << 16 |
                     uint32_t(head[15]) << 24;
  const uint32_t total = uint32_t(head[8]) | uint32_t(head[9]) << 8 | uint32_t(head[10]) << 16 |
                         uint32_t(head[11]) << 24;
  // The chunk is measured against the file before any of it is allocated.
  in.seekg(0, std::ios::end);
  const uint64_t size = uint64_t(in.tellg());
  in.seekg(sizeof head);
  if (!in || n > size - sizeof head || (how.within_declared_length && n > total))
    throw input_error(file, "its JSON chunk runs past the file", "export it again");
  std::string text(n, '\0');
  if (!in.read(&text[0], std::streamsize(n)))
    throw input_error(file, "its JSON chunk runs past the file", "export it again");
  return text;
}

nlohmann::json gltf_json(const std::string& file, const GltfJsonRead& how) {
  try {
    return nlohmann::json::parse(gltf_json_text(file, how));
  } catch (const nlohmann::json::exception& e) {
    throw input_error(file, std::string("its glTF JSON cannot be read: ") + e.what(),
                      "check that the file is valid glTF");
  }
}

}  // namespace pf
