// gltf_builder.h — what the import tests' small glTF 2.0 documents share: a shell-quoted name, a
// file written whole, base64 for data: URIs, and the geometry every such document starts with
// (one triangle per material along +x, then an emitting triangle above them, and one triangle's
// UVs), so each test builds only the materials, images and extensions it checks.
#pragma once
#include <cstdint>
#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

namespace pf::test::gltf {

inline std::string q(const std::string& s) { return "'" + s + "'"; }

inline void write_text(const std::string& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

inline std::string base64(const std::string& in) {
  static const char* t = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  size_t i = 0;
  for (; i + 2 < in.size(); i += 3) {
    const uint32_t v = uint32_t(uint8_t(in[i])) << 16 | uint32_t(uint8_t(in[i + 1])) << 8 |
                       uint32_t(uint8_t(in[i + 2]));
    for (int k = 3; k >= 0; --k) out += t[(v >> (6 * k)) & 63];
  }
  const size_t rest = in.size() - i;
  if (rest > 0) {
    uint32_t v = uint32_t(uint8_t(in[i])) << 16;
    if (rest == 2) v |= uint32_t(uint8_t(in[i + 1])) << 8;
    out += t[(v >> 18) & 63];
    out += t[(v >> 12) & 63];
    out += rest == 2 ? t[(v >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

// The vertex buffer of `n` triangles: triangle k at x = 2k, (x, y, 0), (x + 1, y, 0) and
// (x, y + 1, 0), the last one (the light) at y = 5 with its third corner at (x, y, 1), facing
// down; then the UVs (0, 0), (1, 0), (0, 1) of one triangle, from byte `uv_offset`.
struct TriangleRows {
  std::string bin;
  size_t uv_offset = 0;
};
inline TriangleRows triangle_rows(size_t n) {
  TriangleRows r;
  auto f32 = [&r](float v) { r.bin.append(reinterpret_cast<const char*>(&v), 4); };
  for (size_t k = 0; k < n; ++k) {
    const bool light = k + 1 == n;
    const float x = 2.f * float(k), y = light ? 5.f : 0.f;
    for (float p : {x, y, 0.f, x + 1.f, y, 0.f, x, light ? y : y + 1.f, light ? 1.f : 0.f}) f32(p);
  }
  r.uv_offset = r.bin.size();
  for (float t : {0.f, 0.f, 1.f, 0.f, 0.f, 1.f}) f32(t);
  return r;
}

// A document's head: asset version 2.0 and one scene (its nodes added by the caller).
inline nlohmann::json document_head() {
  nlohmann::json g;
  g["asset"] = {{"version", "2.0"}};
  g["scene"] = 0;
  g["scenes"] = nlohmann::json::array({{{"nodes", nlohmann::json::array()}}});
  return g;
}

// The document's arrays, with the UV view and accessor (index `n`, after the `n` position
// accessors) that every primitive's TEXCOORD_0 names.
inline void put_arrays(nlohmann::json& g, const nlohmann::json& mats, const nlohmann::json& meshes,
                       const nlohmann::json& nodes, nlohmann::json accessors,
                       nlohmann::json views, size_t uv_offset, size_t n) {
  views.push_back({{"buffer", 0}, {"byteOffset", uv_offset}, {"byteLength", 24}});
  accessors.push_back({{"bufferView", n}, {"componentType", 5126}, {"count", 3}, {"type", "VEC2"}});
  g["materials"] = mats;
  g["meshes"] = meshes;
  g["nodes"] = nodes;
  g["accessors"] = accessors;
  g["bufferViews"] = views;
}

}  // namespace pf::test::gltf
