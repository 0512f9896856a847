// gltf_features_test.cpp — what scene-bake does with the parts of a file it does not render
// (issue 47 item 4; docs/SCENES.md "What is honoured, warned about or refused"): one warning line
// per material, light or other owner and feature it ignores (an extension it does not implement,
// KHR_texture_transform, a texture it does not read, a UV set a mesh lacks, an orthographic
// camera, an OBJ bump or specular map); exit 2 with one line and no output for what it cannot
// render faithfully (an extensionsRequired it does not implement, an unknown alphaMode or light
// type, a factor outside the glTF schema's [0, 1]); and glTF's alpha rule: OPAQUE ignores the
// base colour's alpha. The files are made here.
#include <catch2/catch.hpp>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "photonflow/foundations/error.h"
#include "photonflow/image/image.h"
#include "photonflow/geometry/scene.h"
#include "photonflow/geometry/scene_file.h"
#include "photonflow/geometry/scene_import.h"
#include "gltf_builder.h"
#include "support.h"

using namespace pf;
using nlohmann::json;

using namespace pf::test::gltf;  // q, write_text, base64 (gltf_builder.h)

namespace {

std::string png_2x2() {
  const std::vector<uint8_t> rgb = {200, 100, 50, 50, 100, 200, 10, 20, 30, 90, 90, 90};
  const std::vector<uint8_t> png = encode_png(2, 2, rgb);
  return std::string(png.begin(), png.end());
}

// A glTF 2.0 document (buffer and image as data URIs): one triangle per material, material k at
// x = 2k, with TEXCOORD_0 (and TEXCOORD_1 where `second_uv`), then an emitting triangle above
// them (material "light"). Textures 0 and 1 are one 2×2 PNG.
json document(const std::vector<json>& materials, bool second_uv = false) {
  const size_t n = materials.size() + 1;
  pf::test::gltf::TriangleRows rows = pf::test::gltf::triangle_rows(n);
  std::string& bin = rows.bin;
  const size_t uv_offset = rows.uv_offset;
  json g = pf::test::gltf::document_head();
  json mats = json::array(), meshes = json::array(), nodes = json::array(),
       accessors = json::array(), views = json::array();
  for (size_t k = 0; k < n; ++k) {
    mats.push_back(k + 1 < n ? materials[k]
                             : json{{"name", "light"},
                                    {"emissiveFactor", {1, 1, 1}},
                                    {"pbrMetallicRoughness", {{"baseColorFactor", {0.5, 0.5, 0.5, 1}}}}});
    views.push_back({{"buffer", 0}, {"byteOffset", 36 * k}, {"byteLength", 36}});
    accessors.push_back({{"bufferView", k}, {"componentType", 5126}, {"count", 3},
                         {"type", "VEC3"}, {"min", {-100, -100, -100}}, {"max", {100, 100, 100}}});
    json attributes = {{"POSITION", k}, {"TEXCOORD_0", n}};
    if (second_uv) attributes["TEXCOORD_1"] = n;
    meshes.push_back({{"name", "mesh of " + mats.back()["name"].get<std::string>()},
                      {"primitives", json::array({{{"attributes", attributes}, {"material", k}}})}});
    nodes.push_back({{"name", mats.back()["name"]}, {"mesh", k}});
    g["scenes"][0]["nodes"].push_back(k);
  }
  pf::test::gltf::put_arrays(g, mats, meshes, nodes, accessors, views, uv_offset, n);
  g["buffers"] = json::array({{{"byteLength", bin.size()},
                               {"uri", "data:application/octet-stream;base64," + base64(bin)}}});
  g["images"] = json::array({{{"uri", "data:image/png;base64," + base64(png_2x2())}}});
  g["textures"] = json::array({{{"source", 0}}, {{"source", 0}}});
  return g;
}

// A material of metallic 0 and base colour 0.5 unless `factors` says otherwise (no albedo warning).
json pbr(const std::string& name, json factors = json::object()) {
  factors["metallicFactor"] = factors.value("metallicFactor", 0.0);
  if (!factors.contains("baseColorFactor")) factors["baseColorFactor"] = {0.5, 0.5, 0.5, 1};
  return {{"name", name}, {"pbrMetallicRoughness", factors}};
}

BakeReport bake_doc(const json& doc, const test::TempDir& tmp, Scene* out = nullptr) {
  write_text(tmp / "s.gltf", doc.dump(1));
  BakeOptions o;
  o.input = tmp / "s.gltf";
  o.width = o.height = 8;
  BakeReport report;
  Scene s = bake_scene(o, report);
  if (out) *out = std::move(s);
  return report;
}

// The warning lines that contain every one of `needles`.
size_t lines_with(const BakeReport& r, std::initializer_list<std::string> needles) {
  return size_t(std::count_if(r.warnings.begin(), r.warnings.end(), [&](const std::string& w) {
    return std::all_of(needles.begin(), needles.end(),
                       [&](const std::string& n) { return w.find(n) != std::string::npos; });
  }));
}

std::string all_lines(const BakeReport& r) {
  std::string s;
  for (const auto& w : r.warnings) s += w + "\n";
  return s;
}

// scene-bake on `doc`: exit 2, one line on stderr naming the file and each of `needles`, no
// output file.
void refused(const json& doc, std::initializer_list<std::string> needles) {
  test::TempDir tmp("gltf-refused");
  write_text(tmp / "s.gltf", doc.dump(1));
  const test::ToolRun r =
      test::run_tool("scene-bake", q(tmp / "s.gltf") + " -o " + q(tmp / "s.h5"), tmp);
  INFO(r.err);
  CHECK(r.exit_code == kExitBadInput);
  CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
  CHECK(r.err.find(tmp / "s.gltf") != std::string::npos);
  for (const std::string& n : needles) CHECK(r.err.find(n) != std::string::npos);
  CHECK_FALSE(std::filesystem::exists(tmp / "s.h5"));
}

}  // namespace

TEST_CASE("glTF: an extension photonflow does not implement is one warning per material",
          "[gltf_features]") {
  test::TempDir tmp("gltf-ext");
  json tiles = pbr("tiles", {{"baseColorTexture",
                              {{"index", 0},
                               {"extensions",
                                {{"KHR_texture_transform", {{"scale", {4, 4}}}}}}}},
                             {"metallicRoughnessTexture",
                              {{"index", 1},
                               {"extensions",
                                {{"KHR_texture_transform", {{"scale", {4, 4}}}}}}}}});
  json velvet = pbr("velvet", {{"baseColorFactor", {0.5, 0.1, 0.1, 1}}});
  velvet["extensions"] = {{"KHR_materials_sheen", {{"sheenColorFactor", {1, 1, 1}}}},
                          {"KHR_materials_ior", {{"ior", 1.4}}}};
  json doc = document({tiles, velvet, pbr("plain")});
  doc["extensionsUsed"] = {"KHR_texture_transform", "KHR_materials_sheen", "KHR_materials_ior",
                           "EXT_nowhere"};
  const BakeReport r = bake_doc(doc, tmp);
  INFO(all_lines(r));
  // One line for the transform although two of the material's textures carry it.
  CHECK(lines_with(r, {"material 'tiles'", "KHR_texture_transform", "not implemented",
                       "read untransformed"}) == 1);
  CHECK(lines_with(r, {"KHR_texture_transform"}) == 1);
  CHECK(lines_with(r, {"material 'velvet'", "KHR_materials_sheen", "not implemented"}) == 1);
  CHECK(lines_with(r, {"KHR_materials_sheen"}) == 1);
  CHECK(lines_with(r, {"EXT_nowhere", "extensionsUsed", "not implemented"}) == 1);
  CHECK(lines_with(r, {"KHR_materials_ior"}) == 0);  // implemented
  CHECK(lines_with(r, {"'plain'"}) == 0);
}

TEST_CASE("glTF: normal, occlusion, emissive and transmission textures are one warning each",
          "[gltf_features]") {
  test::TempDir tmp("gltf-slots");
  json bumpy = pbr("bumpy", {{"baseColorFactor", {0.5, 0.5, 0.5, 1}}});
  bumpy["normalTexture"] = {{"index", 0}};
  bumpy["occlusionTexture"] = {{"index", 1}};
  json glow = pbr("glow");
  glow["emissiveFactor"] = {1, 0.5, 0};
  glow["emissiveTexture"] = {{"index", 0}};
  json dark = pbr("dark");  // emissiveFactor black: its emissive texture has no effect
  dark["emissiveTexture"] = {{"index", 0}};
  json pane = pbr("pane", {{"roughnessFactor", 0.3}});
  pane["extensions"] = {{"KHR_materials_transmission",
                         {{"transmissionFactor", 1}, {"transmissionTexture", {{"index", 0}}}}}};
  json doc = document({bumpy, glow, dark, pane});
  doc["extensionsUsed"] = {"KHR_materials_transmission"};
  const BakeReport r = bake_doc(doc, tmp);
  INFO(all_lines(r));
  CHECK(lines_with(r, {"material 'bumpy'", "normalTexture", "not read"}) == 1);
  CHECK(lines_with(r, {"material 'bumpy'", "occlusionTexture", "not read"}) == 1);
  CHECK(lines_with(r, {"material 'glow'", "emissiveTexture", "not read"}) == 1);
  CHECK(lines_with(r, {"'dark'", "emissiveTexture"}) == 0);
  CHECK(lines_with(r, {"material 'pane'", "transmissionTexture", "not read"}) == 1);
}

TEST_CASE("glTF: a texCoord the mesh lacks is one warning, a second UV set it has is read",
          "[gltf_features]") {
  SECTION("TEXCOORD_1 missing") {
    test::TempDir tmp("gltf-uv-missing");
    json doc = document({pbr("decal", {{"baseColorTexture", {{"index", 0}, {"texCoord", 1}}}})});
    const BakeReport r = bake_doc(doc, tmp);
    INFO(all_lines(r));
    CHECK(lines_with(r, {"material 'decal'", "texCoord 1", "mesh 'decal", "does not have"}) == 1);
  }
  SECTION("TEXCOORD_1 present") {
    test::TempDir tmp("gltf-uv-present");
    json doc =
        document({pbr("decal", {{"baseColorTexture", {{"index", 0}, {"texCoord", 1}}}})}, true);
    const BakeReport r = bake_doc(doc, tmp);
    INFO(all_lines(r));
    CHECK(lines_with(r, {"'decal'"}) == 0);
  }
}

TEST_CASE("glTF: an orthographic camera is one warning naming it", "[gltf_features]") {
  test::TempDir tmp("gltf-ortho");
  json doc = document({pbr("plain")});
  doc["cameras"] = json::array(
      {{{"name", "plan view"},
        {"type", "orthographic"},
        {"orthographic", {{"xmag", 2}, {"ymag", 2}, {"znear", 0.1}, {"zfar", 100}}}}});
  doc["nodes"].push_back({{"name", "plan view"}, {"camera", 0}, {"translation", {0, 1, 10}}});
  doc["scenes"][0]["nodes"].push_back(doc["nodes"].size() - 1);
  const BakeReport r = bake_doc(doc, tmp);
  INFO(all_lines(r));
  CHECK(lines_with(r, {"camera 'plan view'", "orthographic", "not implemented", "perspective"}) == 1);
  CHECK(lines_with(r, {"camera 'plan view'"}) == 1);  // not a second line about its angle
}

TEST_CASE("glTF: OPAQUE ignores the base colour's alpha, the material is not a glass",
          "[gltf_features]") {
  test::TempDir tmp("gltf-opaque");
  json gold = pbr("gold", {{"baseColorFactor", {1, 0.766, 0.336, 0.9}},
                           {"metallicFactor", 1},
                           {"roughnessFactor", 0.3}});
  gold["alphaMode"] = "OPAQUE";
  json wall = pbr("wall", {{"baseColorFactor", {0.5, 0.5, 0.5, 0.5}}});  // OPAQUE by default
  json doc = document({gold, wall});
  write_text(tmp / "s.gltf", doc.dump(1));
  const test::ToolRun run =
      test::run_tool("scene-bake", q(tmp / "s.gltf") + " -o " + q(tmp / "s.h5"), tmp);
  INFO(run.err);
  REQUIRE(run.exit_code == 0);
  const Scene s = load_scene(tmp / "s.h5");
  auto material = [&s](const std::string& name) {
    const auto it = std::find(s.material_names.begin(), s.material_names.end(), name);
    REQUIRE(it != s.material_names.end());
    return size_t(it - s.material_names.begin());
  };
  CHECK(s.materials[material("gold")].type == PF_MAT_PBR);
  CHECK(s.materials[material("gold")].metallic == 1.f);
  CHECK(s.materials[material("wall")].type == PF_MAT_DIFFUSE);
  for (const char* name : {"gold", "wall"})
    CHECK((s.material_alpha.empty() ||
           s.material_alpha[material(name)].cutoff == PF_ALPHA_OPAQUE));
  CHECK(run.out.find(" 0 glass ") != std::string::npos);  // scene-bake's material summary
}

TEST_CASE("glTF: what photonflow cannot render faithfully is refused: exit 2, one line, no output",
          "[gltf_features]") {
  SECTION("an extensionsRequired it does not implement") {
    json doc = document({pbr("plain")});
    doc["extensionsUsed"] = {"KHR_materials_ior", "EXT_made_up_geometry"};
    doc["extensionsRequired"] = {"KHR_materials_ior", "EXT_made_up_geometry"};
    refused(doc, {"extensionsRequired", "EXT_made_up_geometry", "does not implement"});
  }
  SECTION("KHR_texture_transform required") {
    json doc = document({pbr("tiles", {{"baseColorTexture",
                                        {{"index", 0},
                                         {"extensions",
                                          {{"KHR_texture_transform", {{"scale", {4, 4}}}}}}}}})});
    doc["extensionsUsed"] = {"KHR_texture_transform"};
    doc["extensionsRequired"] = {"KHR_texture_transform"};
    refused(doc, {"extensionsRequired", "KHR_texture_transform"});
  }
  SECTION("an unknown alphaMode") {
    json fence = pbr("fence", {{"baseColorTexture", {{"index", 0}}}});
    fence["alphaMode"] = "CUTOUT";
    refused(document({fence}), {"material 'fence'", "alphaMode 'CUTOUT'", "OPAQUE, MASK or BLEND"});
  }
  SECTION("an unknown light type") {
    json doc = document({pbr("plain")});
    doc["extensionsUsed"] = {"KHR_lights_punctual"};
    doc["extensions"] = {{"KHR_lights_punctual",
                          {{"lights", json::array({{{"name", "panel"}, {"type", "area"},
                                                    {"intensity", 5}}})}}}};
    doc["nodes"].push_back(
        {{"name", "panel"}, {"extensions", {{"KHR_lights_punctual", {{"light", 0}}}}}});
    doc["scenes"][0]["nodes"].push_back(doc["nodes"].size() - 1);
    refused(doc, {"light 'panel'", "type 'area'", "point, spot or directional"});
  }
  SECTION("a negative emissive channel") {
    json hot = pbr("hot");
    hot["emissiveFactor"] = {-1, 0.5, 0.5};
    refused(document({hot}), {"material 'hot'", "emissiveFactor", "outside [0, 1]"});
  }
  SECTION("an emissive channel above 1") {
    json hot = pbr("hot");
    hot["emissiveFactor"] = {2, 0.5, 0.5};
    refused(document({hot}), {"material 'hot'", "emissiveFactor", "KHR_materials_emissive_strength"});
  }
  SECTION("a base colour outside [0, 1]") {
    refused(document({pbr("bright", {{"baseColorFactor", {1.2, 0.5, 0.5, 1}}})}),
            {"material 'bright'", "baseColorFactor", "outside [0, 1]"});
  }
  SECTION("metallic and roughness outside [0, 1]") {
    refused(document({pbr("rough", {{"roughnessFactor", 1.5}})}),
            {"material 'rough'", "roughnessFactor 1.5", "outside [0, 1]"});
    refused(document({pbr("metal", {{"metallicFactor", -0.25}})}),
            {"material 'metal'", "metallicFactor -0.25", "outside [0, 1]"});
  }
  SECTION("a transmission factor outside [0, 1]") {
    json pane = pbr("pane");
    pane["extensions"] = {{"KHR_materials_transmission", {{"transmissionFactor", 2}}}};
    json doc = document({pane});
    doc["extensionsUsed"] = {"KHR_materials_transmission"};
    refused(doc, {"material 'pane'", "transmissionFactor 2", "outside [0, 1]"});
  }
}

TEST_CASE("OBJ: bump and specular maps are one warning each, a mirror's colour map is said",
          "[gltf_features]") {
  test::TempDir tmp("obj-maps");
  write_text(tmp / "t.png", png_2x2());
  write_text(tmp / "s.mtl",
             "newmtl brick\nKd 0.5 0.5 0.5\nmap_Kd t.png\nmap_bump t.png\nmap_Ks t.png\n"
             "newmtl chrome\nKd 0 0 0\nKs 1 1 1\nillum 3\nmap_Kd t.png\n"
             "newmtl plain\nKd 0.5 0.5 0.5\n"
             "newmtl lamp\nKd 0 0 0\nKe 1 1 1\n");
  write_text(tmp / "s.obj",
             "mtllib s.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nv 3 0 0\nv 2 1 0\n"
             "v 4 0 0\nv 5 0 0\nv 4 1 0\nv 0 5 0\nv 1 5 0\nv 0 5 1\n"
             "vt 0 0\nvt 1 0\nvt 0 1\n"
             "usemtl brick\nf 1/1 2/2 3/3\nusemtl chrome\nf 4/1 5/2 6/3\n"
             "usemtl plain\nf 7 8 9\nusemtl lamp\nf 10 11 12\n");
  BakeOptions o;
  o.input = tmp / "s.obj";
  o.width = o.height = 8;
  BakeReport r;
  bake_scene(o, r);
  INFO(all_lines(r));
  CHECK(lines_with(r, {"material 'brick'", "bump map", "not read"}) == 1);
  CHECK(lines_with(r, {"material 'brick'", "specular map", "not read"}) == 1);
  CHECK(lines_with(r, {"material 'brick'"}) == 2);
  CHECK(lines_with(r, {"material 'chrome'", "base-colour texture", "mirror"}) == 1);
  CHECK(lines_with(r, {"'plain'"}) == 0);
}
