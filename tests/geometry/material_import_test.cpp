// Metallic-roughness materials from the file to scene.h5 (issue 32 item 2, the data and import
// half): scene-bake maps glTF metallicFactor/roughnessFactor/metallicRoughnessTexture,
// KHR_materials_transmission and KHR_materials_ior, OBJ Ks/Ns (and Pm/Pr) and COLLADA
// <specular>/<shininess> onto PF_MAT_PBR (docs/SCENES.md), with the delta limits mapped to the
// exact mirror and glass; scene.h5 format version 5 stores the new fields and the
// metallic-roughness textures, still reads versions 1-4, refuses bad values in one line, and keeps
// the scene id of every scene without a PBR material. The glTF files and PNGs are made here.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "h5edit.h"
#include "photonflow/foundations/error.h"
#include "photonflow/foundations/hash.h"
#include "photonflow/image/image.h"
#include "photonflow/material/texture_shared.h"
#include "photonflow/geometry/scene.h"
#include "photonflow/io/h5_types.h"
#include "photonflow/geometry/scene_file.h"
#include "photonflow/geometry/scene_import.h"
#include "photonflow/geometry/surface.h"
#include "gltf_builder.h"
#include "support.h"

using namespace pf;
using nlohmann::json;

using namespace pf::test::gltf;  // q, write_text, base64 (gltf_builder.h)

namespace {

// The test image: 2×2 RGB texels, row 0 on top. Its texel (1, 0) is the one the textured
// triangle's point below reads.
const uint8_t kTexels[4][3] = {{10, 20, 30}, {40, 200, 100}, {250, 0, 0}, {0, 0, 250}};
std::string texture_png() {
  std::vector<uint8_t> rgb;
  for (const auto& t : kTexels) rgb.insert(rgb.end(), t, t + 3);
  const std::vector<uint8_t> png = encode_png(2, 2, rgb);
  return std::string(png.begin(), png.end());
}

// A glTF 2.0 file (JSON, buffers and images as data URIs): one triangle per material, material k
// at x = 2k, corners (0,0,0), (1,0,0), (0,1,0) shifted by x, with TEXCOORD_0 (0,0), (1,0), (0,1),
// then an emitting triangle (its own material "light") above them. `images`: PNG bytes referenced by
// textures 0, 1, ... (texture i = image i).
std::string gltf(const std::vector<json>& materials, const std::vector<std::string>& images = {}) {
  const size_t n = materials.size() + 1;
  pf::test::gltf::TriangleRows rows = pf::test::gltf::triangle_rows(n);
  std::string& bin = rows.bin;
  const size_t uv_offset = rows.uv_offset;
  json g = pf::test::gltf::document_head();
  g["extensionsUsed"] = {"KHR_materials_transmission", "KHR_materials_ior"};
  json mats = json::array(), meshes = json::array(), nodes = json::array(),
       accessors = json::array(), views = json::array();
  for (size_t k = 0; k < n; ++k) {
    mats.push_back(k + 1 < n ? materials[k]
                             : json{{"name", "light"},
                                    {"emissiveFactor", {1, 1, 1}},
                                    {"pbrMetallicRoughness",
                                     {{"baseColorFactor", {0.5, 0.5, 0.5, 1}},
                                      {"metallicFactor", 0}}}});
    views.push_back({{"buffer", 0}, {"byteOffset", 36 * k}, {"byteLength", 36}});
    accessors.push_back({{"bufferView", k}, {"componentType", 5126}, {"count", 3},
                         {"type", "VEC3"}, {"min", {-100, -100, -100}}, {"max", {100, 100, 100}}});
    meshes.push_back({{"primitives", json::array({{{"attributes",
                                                    {{"POSITION", k}, {"TEXCOORD_0", n}}},
                                                   {"material", k}}})}});
    nodes.push_back({{"name", mats.back()["name"]}, {"mesh", k}});
    g["scenes"][0]["nodes"].push_back(k);
  }
  pf::test::gltf::put_arrays(g, mats, meshes, nodes, accessors, views, uv_offset, n);
  g["buffers"] = json::array({{{"byteLength", bin.size()},
                               {"uri", "data:application/octet-stream;base64," + base64(bin)}}});
  if (!images.empty()) {
    g["images"] = json::array();
    g["textures"] = json::array();
    for (size_t i = 0; i < images.size(); ++i) {
      g["images"].push_back({{"uri", "data:image/png;base64," + base64(images[i])}});
      g["textures"].push_back({{"source", i}});
    }
  }
  return g.dump(1);
}

json pbr(const std::string& name, json factors, json extensions = nullptr) {
  json m = {{"name", name}, {"pbrMetallicRoughness", factors}};
  if (!extensions.is_null()) m["extensions"] = extensions;
  return m;
}

Scene bake(const std::string& file, BakeReport& report) {
  BakeOptions o;
  o.input = file;
  o.width = o.height = 16;
  return bake_scene(o, report);
}

size_t material_index(const Scene& s, const std::string& name) {
  const auto it = std::find(s.material_names.begin(), s.material_names.end(), name);
  REQUIRE(it != s.material_names.end());
  return size_t(it - s.material_names.begin());
}
const pf_material& material(const Scene& s, const std::string& name) {
  return s.materials[material_index(s, name)];
}

// A triangle of material `m`.
int triangle_of(const Scene& s, size_t m) {
  for (size_t i = 0; i < s.triangles.size(); ++i)
    if (size_t(s.triangles[i].material) == m) return int(i);
  std::string all;
  for (const auto& t : s.triangles) all += std::to_string(t.material) + " ";
  FAIL("no triangle of material " << m << " in " << all);
  return -1;
}

bool has_warning(const BakeReport& r, const std::string& needle) {
  for (const auto& w : r.warnings)
    if (w.find(needle) != std::string::npos) return true;
  return false;
}

// The scene id as format versions 1-4 computed it (scene.cpp before version 5): the materials
// hashed as the packed 32-byte struct of those versions.
std::string version4_scene_id(const Scene& s) {
  struct Material4 {
    int32_t type;
    float ior, color[3], emission[3];
  };
  static_assert(sizeof(Material4) == 32, "the version-4 material");
  std::vector<Material4> materials;
  for (const pf_material& m : s.materials) {
    Material4 o;
    o.type = m.type;
    o.ior = m.ior;
    std::memcpy(o.color, m.color, sizeof o.color);
    std::memcpy(o.emission, m.emission, sizeof o.emission);
    materials.push_back(o);
  }
  Sha256 h;
  auto feed = [&h](const auto& v) {
    uint64_t n = v.size();
    h.update(&n, sizeof n);
    if (n) h.update(v.data(), n * sizeof(v[0]));
  };
  // The version-4 light: the first 40 bytes of pf_light (version 5 appended the spot/directional
  // fields; an area or point light has them 0 and the id does not cover them).
  struct Light4 {
    unsigned char bytes[40];
  };
  static_assert(offsetof(pf_light, direction) == sizeof(Light4), "the version-4 light");
  std::vector<Light4> lights;
  for (const pf_light& l : s.lights) {
    Light4 o;
    std::memcpy(o.bytes, &l, sizeof o.bytes);
    lights.push_back(o);
  }
  feed(s.triangles);
  feed(materials);
  feed(lights);
  h.update(&s.camera, offsetof(pf_camera, aperture));
  if (s.camera.aperture > 0.f) {
    h.update(&s.camera.aperture, sizeof s.camera.aperture);
    h.update(&s.camera.focus_distance, sizeof s.camera.focus_distance);
  }
  if (!s.textures.empty()) {
    feed(s.textures);
    feed(s.texels);
    feed(s.material_texture);
    feed(s.uvs);
  }
  return h.hex();
}

// The message of the InputError load_scene throws, "" when it reads the file.
std::string refusal(const std::string& file) {
  try {
    load_scene(file);
  } catch (const InputError& e) {
    return e.what();
  }
  return {};
}

}  // namespace

TEST_CASE("glTF metallic, roughness, transmission and ior become PF_MAT_PBR, delta limits the exact types",
          "[pbr_import]") {
  test::TempDir tmp("pbr-gltf");
  const std::vector<json> mats = {
      pbr("gold", {{"baseColorFactor", {1.0, 0.8, 0.3, 1}}, {"metallicFactor", 1},
                   {"roughnessFactor", 0.4}}),
      pbr("plastic", {{"baseColorFactor", {0.2, 0.3, 0.4, 1}}, {"metallicFactor", 0},
                      {"roughnessFactor", 0.5}}),
      pbr("rough_glass", {{"baseColorFactor", {0.9, 1, 0.9, 1}}, {"metallicFactor", 0},
                          {"roughnessFactor", 0.3}},
          {{"KHR_materials_transmission", {{"transmissionFactor", 1}}},
           {"KHR_materials_ior", {{"ior", 1.33}}}}),
      pbr("half", {{"metallicFactor", 0.5}, {"roughnessFactor", 0}},
          {{"KHR_materials_transmission", {{"transmissionFactor", 0.25}}}}),
      pbr("matte", {{"baseColorFactor", {0.5, 0.6, 0.7, 1}}, {"metallicFactor", 0}}),
      pbr("spec_default", json::object()),  // glTF defaults: metallic 1, roughness 1
      pbr("smooth_metal", {{"baseColorFactor", {0.9, 0.6, 0.3, 1}}, {"metallicFactor", 1},
                           {"roughnessFactor", 0.01}}),
      pbr("smooth_glass", {{"baseColorFactor", {0.8, 0.9, 1, 1}}, {"metallicFactor", 0},
                           {"roughnessFactor", 0}},
          {{"KHR_materials_transmission", {{"transmissionFactor", 1}}},
           {"KHR_materials_ior", {{"ior", 1.7}}}}),
  };
  write_text(tmp / "m.gltf", gltf(mats));
  BakeReport report;
  const Scene s = bake(tmp / "m.gltf", report);

  const pf_material& gold = material(s, "gold");
  CHECK(gold.type == PF_MAT_PBR);
  CHECK(gold.metallic == 1.f);
  CHECK(gold.roughness == Approx(0.4f));
  CHECK(gold.transmission == 0.f);
  CHECK(gold.ior == 1.5f);  // glTF's default ior
  CHECK(gold.color[0] == 1.f);
  CHECK(gold.color[1] == Approx(0.8f));
  const pf_material& plastic = material(s, "plastic");
  CHECK(plastic.type == PF_MAT_PBR);
  CHECK(plastic.metallic == 0.f);
  CHECK(plastic.roughness == Approx(0.5f));
  CHECK(plastic.color[2] == Approx(0.4f));
  const pf_material& glass = material(s, "rough_glass");
  CHECK(glass.type == PF_MAT_PBR);
  CHECK(glass.transmission == 1.f);
  CHECK(glass.ior == Approx(1.33f));  // KHR_materials_ior, through AI_MATKEY_REFRACTI
  CHECK(glass.roughness == Approx(0.3f));
  // Roughness 0 but half metal: no exact type; stays PBR (the BSDF clamps α).
  const pf_material& half = material(s, "half");
  CHECK(half.type == PF_MAT_PBR);
  CHECK(half.roughness == 0.f);
  CHECK(half.metallic == 0.5f);
  CHECK(half.transmission == 0.25f);
  // Metallic 0, roughness 1 (absent): diffuse as before format version 5.
  const pf_material& matte = material(s, "matte");
  CHECK(matte.type == PF_MAT_DIFFUSE);
  CHECK(matte.color[1] == Approx(0.6f));
  CHECK(matte.metallic == 0.f);
  CHECK(matte.roughness == 0.f);
  // The spec's defaults make a rough metal, not a diffuse surface.
  const pf_material& def = material(s, "spec_default");
  CHECK(def.type == PF_MAT_PBR);
  CHECK(def.metallic == 1.f);
  CHECK(def.roughness == 1.f);
  // α = roughness² below PF_BSDF_ALPHA_MIN: the exact delta types.
  const pf_material& mirror = material(s, "smooth_metal");
  CHECK(mirror.type == PF_MAT_MIRROR);
  CHECK(mirror.color[1] == Approx(0.6f));
  CHECK(mirror.metallic == 0.f);
  CHECK(mirror.roughness == 0.f);
  const pf_material& smooth = material(s, "smooth_glass");
  CHECK(smooth.type == PF_MAT_GLASS);
  CHECK(smooth.ior == Approx(1.7f));
  CHECK(smooth.color[0] == Approx(0.8f));
  // glTF factors outside [0, 1] are refused, not clamped (the schema's range; test_gltf_features).
  CHECK(s.has_pbr());
  for (size_t m = 0; m < s.materials.size(); ++m) CHECK(s.mr_texture_of(int(m)) == -1);

  // scene.h5 keeps them; the id covers them.
  save_scene(s, tmp / "s.h5", Provenance{});
  const Scene r = load_scene(tmp / "s.h5");
  REQUIRE(r.materials.size() == s.materials.size());
  CHECK(std::memcmp(r.materials.data(), s.materials.data(),
                    s.materials.size() * sizeof(pf_material)) == 0);
  CHECK(r.material_mr_texture == std::vector<int32_t>(s.materials.size(), -1));
  CHECK(r.scene_id == s.scene_id);
  CHECK(s.scene_id != version4_scene_id(s));  // a PBR scene's id covers the new fields
  for (auto edit : {+[](pf_material& m) { m.roughness = 0.41f; },
                    +[](pf_material& m) { m.metallic = 0.9f; },
                    +[](pf_material& m) { m.transmission = 0.1f; }}) {
    Scene e = s;
    edit(e.materials[material_index(s, "gold")]);
    e.compute_scene_id();
    CHECK(e.scene_id != s.scene_id);
  }

  // The tool's summary counts them.
  const test::ToolRun run = test::run_tool("scene-bake", q(tmp / "m.gltf") + " -o " + q(tmp / "t.h5"), tmp);
  CHECK(run.exit_code == 0);
  CHECK(run.out.find("1 diffuse 1 mirror 1 glass 1 emitter 5 metallic-roughness") !=
        std::string::npos);
}

TEST_CASE("a metallicRoughnessTexture is stored linear beside the sRGB base colour of the same image, B and G scale metallic and roughness",
          "[pbr_import]") {
  test::TempDir tmp("pbr-texture");
  const std::vector<json> mats = {
      pbr("textured", {{"baseColorFactor", {1, 0.5, 1, 1}},
                       {"baseColorTexture", {{"index", 0}}},
                       {"metallicFactor", 0.8},
                       {"roughnessFactor", 0.6},
                       {"metallicRoughnessTexture", {{"index", 0}}}}),
      pbr("mr_only", {{"metallicFactor", 1}, {"roughnessFactor", 1},
                      {"metallicRoughnessTexture", {{"index", 0}}}}),
  };
  write_text(tmp / "t.gltf", gltf(mats, {texture_png()}));
  BakeReport report;
  const Scene s = bake(tmp / "t.gltf", report);
  CHECK(report.warnings.empty());
  const size_t m = material_index(s, "textured");
  REQUIRE(s.materials[m].type == PF_MAT_PBR);
  // One image, two decodings: two parts of the pool, two headers.
  REQUIRE(s.textures.size() == 2);
  CHECK(s.texels.size() == size_t(2 * 4 * 4));
  const int base = s.texture_of(int(m)), mr = s.mr_texture_of(int(m));
  REQUIRE(base >= 0);
  REQUIRE(mr >= 0);
  CHECK(base != mr);
  CHECK(s.textures[size_t(base)].offset != s.textures[size_t(mr)].offset);
  // Both materials share the linear texture (one header per image, decoding and sampler).
  CHECK(s.mr_texture_of(int(material_index(s, "mr_only"))) == mr);
  CHECK(s.texture_of(int(material_index(s, "mr_only"))) == -1);
  // Texel (1, 0) as stored: linear codes / 255 in the data texture, sRGB-decoded in the colour one.
  const size_t at_mr = 4 * (size_t(s.textures[size_t(mr)].offset) + 1);
  const size_t at_base = 4 * (size_t(s.textures[size_t(base)].offset) + 1);
  for (int k = 0; k < 3; ++k) {
    CHECK(s.texels[at_mr + size_t(k)] == float(kTexels[1][k]) / 255.f);
    CHECK(s.texels[at_base + size_t(k)] == pf_srgb8_to_linear(kTexels[1][k]));
  }
  CHECK(!s.uvs.empty());

  // At barycentrics (0.75, 0.25) the triangle's UV is (0.75, 0.25): the centre of texel (1, 0).
  SurfaceHit sh{};
  sh.material = int(m);
  sh.tri = triangle_of(s, m);
  sh.u = 0.75f;
  sh.v = 0.25f;
  const pf_bsdf_params p = bsdf_params_at(s, s.materials[m], sh);
  CHECK(p.metallic == Approx(0.8f * 100.f / 255.f).epsilon(1e-5));   // factor × B
  CHECK(p.roughness == Approx(0.6f * 200.f / 255.f).epsilon(1e-5));  // factor × G
  CHECK(p.base_color[0] == Approx(pf_srgb8_to_linear(40)).epsilon(1e-5));
  CHECK(p.base_color[1] == Approx(0.5f * pf_srgb8_to_linear(200)).epsilon(1e-5));
  CHECK(p.ior == 1.5f);
  // The triangle's other corner texels differ: the look-up follows the UVs.
  sh.u = 0.25f;
  sh.v = 0.75f;  // UV (0.25, 0.75): texel (0, 1)
  const pf_bsdf_params p2 = bsdf_params_at(s, s.materials[m], sh);
  CHECK(p2.metallic == Approx(0.f).margin(1e-6));
  CHECK(p2.roughness == Approx(0.f).margin(1e-6));

  // scene.h5 keeps the table; edits are refused.
  save_scene(s, tmp / "s.h5", Provenance{});
  const Scene r = load_scene(tmp / "s.h5");
  CHECK(r.material_mr_texture == s.material_mr_texture);
  CHECK(r.scene_id == s.scene_id);
  Scene e = s;
  e.material_mr_texture[m] = -1;
  e.compute_scene_id();
  CHECK(e.scene_id != s.scene_id);  // the id covers the table
  {
    const std::string f = tmp / "range.h5";
    std::filesystem::copy_file(tmp / "s.h5", f);
    std::vector<int32_t> t = s.material_mr_texture;
    t[m] = 7;
    test::rewrite_dataset(f, "/materials/metallic_roughness_texture", H5T_NATIVE_INT32, t);
    test::refresh_scene_id(f);
    const std::string why = refusal(f);
    CHECK(why.find("materials/metallic_roughness_texture[" + std::to_string(m) + "] = 7") !=
          std::string::npos);
    CHECK(why.find('\n') == std::string::npos);
  }
  {
    const std::string f = tmp / "diffuse.h5";
    std::filesystem::copy_file(tmp / "s.h5", f);
    const size_t light = material_index(s, "light");
    std::vector<int32_t> t = s.material_mr_texture;
    t[light] = mr;
    test::rewrite_dataset(f, "/materials/metallic_roughness_texture", H5T_NATIVE_INT32, t);
    test::refresh_scene_id(f);
    CHECK(refusal(f).find("only PF_MAT_PBR") != std::string::npos);
  }
  {
    const std::string f = tmp / "missing.h5";
    std::filesystem::copy_file(tmp / "s.h5", f);
    h5::Handle file(H5Fopen(f.c_str(), H5F_ACC_RDWR, H5P_DEFAULT));
    REQUIRE(H5Ldelete(file.get(), "/materials/metallic_roughness_texture", H5P_DEFAULT) >= 0);
    file = h5::Handle(-1);
    CHECK(refusal(f).find("metallic_roughness_texture") != std::string::npos);
  }
}

TEST_CASE("a missing metallic-roughness image is refused, or with --missing-textures warn one "
          "warning and the factors are used", "[pbr_import]") {
  test::TempDir tmp("pbr-missing");
  json m = pbr("rough", {{"metallicFactor", 0.5}, {"roughnessFactor", 0.7},
                         {"metallicRoughnessTexture", {{"index", 0}}}});
  std::string text = gltf({m}, {"x"});
  // Point the image at a file that is not there.
  json g = json::parse(text);
  g["images"][0]["uri"] = "nowhere.png";
  write_text(tmp / "m.gltf", g.dump());
  BakeReport report;
  CHECK_THROWS_AS(bake(tmp / "m.gltf", report), InputError);
  BakeOptions o;
  o.input = tmp / "m.gltf";
  o.width = o.height = 16;
  o.inputs.missing_textures_warn = true;
  const Scene s = bake_scene(o, report);
  INFO((report.warnings.empty() ? "" : report.warnings[0] + " | " + report.warnings.back()));
  REQUIRE(report.warnings.size() == 1);
  CHECK(report.warnings[0].find("nowhere.png") != std::string::npos);
  CHECK(report.warnings[0].find("'rough'") != std::string::npos);
  const pf_material& r = material(s, "rough");
  CHECK(r.type == PF_MAT_PBR);
  CHECK(r.roughness == Approx(0.7f));
  CHECK(s.mr_texture_of(int(material_index(s, "rough"))) == -1);
  CHECK(s.uvs.empty());
}

TEST_CASE("transmission with an ior of 1 and NaN factors are refused: exit 2, one line, no output", "[pbr_import]") {
  test::TempDir tmp("pbr-ior1");
  write_text(tmp / "m.gltf",
             gltf({pbr("window", {{"metallicFactor", 0}, {"roughnessFactor", 0.2}},
                       {{"KHR_materials_transmission", {{"transmissionFactor", 1}}},
                        {"KHR_materials_ior", {{"ior", 1.0}}}})}));
  const test::ToolRun r =
      test::run_tool("scene-bake", q(tmp / "m.gltf") + " -o " + q(tmp / "s.h5"), tmp);
  CHECK(r.exit_code == kExitBadInput);
  CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
  CHECK(r.err.find("'window'") != std::string::npos);
  CHECK(r.err.find("index of refraction of 1") != std::string::npos);
  CHECK_FALSE(std::filesystem::exists(tmp / "s.h5"));
  // A NaN factor (glTF's JSON cannot hold one; an OBJ's Pr can): the same refusal kind.
  write_text(tmp / "n.mtl", "newmtl a\nKd 0.5 0.5 0.5\nPr nan\nnewmtl l\nKe 1 1 1\n");
  write_text(tmp / "n.obj", "mtllib n.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n"
                            "usemtl l\nf 1 3 2\n");
  const test::ToolRun n =
      test::run_tool("scene-bake", q(tmp / "n.obj") + " -o " + q(tmp / "n.h5"), tmp);
  INFO(n.err);
  CHECK(n.exit_code == kExitBadInput);
  CHECK(std::count(n.err.begin(), n.err.end(), '\n') == 1);
  CHECK(n.err.find("material 'a' has a non-finite") != std::string::npos);
  CHECK_FALSE(std::filesystem::exists(tmp / "n.h5"));
}

TEST_CASE("OBJ Ks and Ns with illum 2, and Pm and Pr, map onto the metallic-roughness model", "[pbr_import]") {
  test::TempDir tmp("pbr-obj");
  write_text(tmp / "m.mtl",
             "newmtl plastic\nKd 0.5 0.2 0.2\nKs 0.5 0.5 0.5\nNs 225\nillum 2\n"
             "newmtl copper\nKd 0 0 0\nKs 0.95 0.64 0.54\nNs 400\nillum 2\n"
             "newmtl chrome\nKd 0 0 0\nKs 0.9 0.9 0.9\nNs 900\nillum 2\n"
             "newmtl no_highlight\nKd 0.5 0.5 0.5\nKs 0.5 0.5 0.5\nNs 225\nillum 1\n"
             "newmtl no_exponent\nKd 0.5 0.5 0.5\nKs 0.5 0.5 0.5\nillum 2\n"
             "newmtl pbr_ext\nKd 0.3 0.3 0.3\nPr 0.25\nPm 0.75\n"
             "newmtl light\nKd 0.5 0.5 0.5\nKe 1 1 1\n");
  std::ofstream obj(tmp / "m.obj");
  obj << "mtllib m.mtl\n";
  const char* names[] = {"plastic", "copper", "chrome", "no_highlight", "no_exponent", "pbr_ext",
                         "light"};
  for (int k = 0; k < 7; ++k)
    obj << "v " << 2 * k << " 0 0\nv " << 2 * k + 1 << " 0 0\nv " << 2 * k << " 1 0\no "
        << names[k] << "\nusemtl " << names[k] << "\nf " << 3 * k + 1 << " " << 3 * k + 2 << " "
        << 3 * k + 3 << "\n";
  obj.close();
  BakeReport report;
  const Scene s = bake(tmp / "m.obj", report);
  // Blender's rule: roughness = 1 − √Ns / 30; a coloured Kd is a dielectric of base Kd.
  const pf_material& plastic = material(s, "plastic");
  CHECK(plastic.type == PF_MAT_PBR);
  CHECK(plastic.metallic == 0.f);
  CHECK(plastic.roughness == Approx(0.5f));
  CHECK(plastic.color[0] == Approx(0.5f));
  CHECK(plastic.ior == 1.5f);
  // A black Kd is a metal of base colour Ks.
  const pf_material& copper = material(s, "copper");
  CHECK(copper.type == PF_MAT_PBR);
  CHECK(copper.metallic == 1.f);
  CHECK(copper.roughness == Approx(1.f / 3.f));
  CHECK(copper.color[1] == Approx(0.64f));
  // Ns 900: roughness 0, the exact mirror (as a black Kd with Ks always was).
  const pf_material& chrome = material(s, "chrome");
  CHECK(chrome.type == PF_MAT_MIRROR);
  CHECK(chrome.color[0] == Approx(0.9f));
  // illum 1 (the MTL spec: no highlight; also what assimp reads for a missing illum) and Ns 0
  // (a Phong exponent of 0 is a constant lobe) stay diffuse.
  CHECK(material(s, "no_highlight").type == PF_MAT_DIFFUSE);
  CHECK(material(s, "no_exponent").type == PF_MAT_DIFFUSE);
  // The MTL PBR extension's Pr and Pm, as assimp 5.2.5 reads them.
  const pf_material& ext = material(s, "pbr_ext");
  CHECK(ext.type == PF_MAT_PBR);
  CHECK(ext.metallic == Approx(0.75f));
  CHECK(ext.roughness == Approx(0.25f));
  CHECK(ext.ior == 1.5f);  // OBJ's Ni 1 (assimp's default) is not an ior: glTF's 1.5
}

TEST_CASE("COLLADA phong and blinn specular and shininess map onto the metallic-roughness model, lambert stays diffuse",
          "[pbr_import]") {
  test::TempDir tmp("pbr-dae");
  auto effect = [](const std::string& id, const std::string& model, const std::string& body) {
    return "<effect id=\"" + id + "-fx\"><profile_COMMON><technique sid=\"common\"><" + model +
           ">" + body + "</" + model + "></technique></profile_COMMON></effect>\n";
  };
  const std::vector<std::pair<std::string, std::string>> effects = {
      {"glossy", effect("glossy", "phong",
                        "<diffuse><color>0.5 0.2 0.2 1</color></diffuse>"
                        "<specular><color>0.5 0.5 0.5 1</color></specular>"
                        "<shininess><float>100</float></shininess>")},
      {"blinn_metal", effect("blinn_metal", "blinn",
                             "<diffuse><color>0 0 0 1</color></diffuse>"
                             "<specular><color>0.8 0.7 0.6 1</color></specular>"
                             "<shininess><float>25</float></shininess>")},
      {"matte", effect("matte", "lambert", "<diffuse><color>0.5 0.2 0.2 1</color></diffuse>")},
      {"flat", effect("flat", "phong",
                      "<diffuse><color>0.5 0.5 0.5 1</color></diffuse>"
                      "<specular><color>0 0 0 1</color></specular>")},
      {"light", effect("light", "lambert",
                       "<emission><color>1 1 1 1</color></emission>"
                       "<diffuse><color>0.5 0.5 0.5 1</color></diffuse>")},
  };
  std::string dae =
      "<?xml version=\"1.0\" encoding=\"utf-8\"?>\n<COLLADA "
      "xmlns=\"http://www.collada.org/2005/11/COLLADASchema\" version=\"1.4.1\">\n"
      "<library_effects>\n";
  for (const auto& e : effects) dae += e.second;
  dae += "</library_effects>\n<library_materials>\n";
  for (const auto& e : effects)
    dae += "<material id=\"" + e.first + "\" name=\"" + e.first + "\"><instance_effect url=\"#" +
           e.first + "-fx\"/></material>\n";
  dae += "</library_materials>\n<library_geometries><geometry id=\"g\"><mesh>"
         "<source id=\"p\"><float_array id=\"pa\" count=\"9\">0 0 0 1 0 0 0 1 0</float_array>"
         "<technique_common><accessor source=\"#pa\" count=\"3\" stride=\"3\"><param name=\"X\" "
         "type=\"float\"/><param name=\"Y\" type=\"float\"/><param name=\"Z\" type=\"float\"/>"
         "</accessor></technique_common></source><vertices id=\"v\"><input semantic=\"POSITION\" "
         "source=\"#p\"/></vertices>";
  for (const auto& e : effects)
    dae += "<triangles material=\"" + e.first +
           "\" count=\"1\"><input semantic=\"VERTEX\" source=\"#v\" offset=\"0\"/><p>0 1 "
           "2</p></triangles>";
  dae += "</mesh></geometry></library_geometries>\n<library_visual_scenes><visual_scene "
         "id=\"s\"><node id=\"n\"><instance_geometry url=\"#g\"><bind_material><technique_common>";
  for (const auto& e : effects)
    dae += "<instance_material symbol=\"" + e.first + "\" target=\"#" + e.first + "\"/>";
  dae += "</technique_common></bind_material></instance_geometry></node></visual_scene>"
         "</library_visual_scenes>\n<scene><instance_visual_scene url=\"#s\"/></scene>\n"
         "</COLLADA>\n";
  write_text(tmp / "m.dae", dae);
  BakeReport report;
  const Scene s = bake(tmp / "m.dae", report);
  const pf_material& glossy = material(s, "glossy");
  CHECK(glossy.type == PF_MAT_PBR);
  CHECK(glossy.metallic == 0.f);
  CHECK(glossy.roughness == Approx(2.f / 3.f));  // 1 − √100 / 30
  CHECK(glossy.color[1] == Approx(0.2f));
  const pf_material& metal = material(s, "blinn_metal");
  CHECK(metal.type == PF_MAT_PBR);
  CHECK(metal.metallic == 1.f);
  CHECK(metal.roughness == Approx(1.f - 5.f / 30.f));
  CHECK(metal.color[0] == Approx(0.8f));
  CHECK(material(s, "matte").type == PF_MAT_DIFFUSE);  // lambert: assimp's Ks 0.4 is no highlight
  CHECK(material(s, "flat").type == PF_MAT_DIFFUSE);   // a black <specular>
}

TEST_CASE("the scene id of a scene without a PBR material is the one format version 4 gave",
          "[pbr_import]") {
  // The id hashes each material's first 32 bytes, the version-4 struct: the same bytes as before.
  for (const char* file : {"tests/data/materials.obj", "tests/data/lamp.gltf", "data/cornell-box.dae",
                           "data/cornell-spheres.dae"}) {
    INFO(file);
    BakeReport report;
    const Scene s = bake(test::source_dir() + "/" + file, report);
    CHECK_FALSE(s.has_pbr());
    CHECK(s.scene_id == version4_scene_id(s));
  }
  for (int type : {PF_MAT_DIFFUSE, PF_MAT_MIRROR, PF_MAT_GLASS}) {
    const Scene s = test::room_scene(type, 8, 8);
    CHECK(s.scene_id == version4_scene_id(s));
  }
  // Pinned: what scene-bake of main at 047da82 (format version 4) wrote for these files. A change
  // here means every baked scene.h5 of users would need a rebake: only a format change that is
  // meant to do so may change it.
  // (scene-bake's default options: the camera is part of the id.)
  BakeReport report;
  BakeOptions o;
  o.input = test::source_dir() + "/tests/data/materials.obj";
  CHECK(bake_scene(o, report).scene_id ==
        "80545823c43cfe52c37bff5f406dee650962809593f87f5ac9c20ea19401129b");
  o.input = test::source_dir() + "/tests/data/lamp.gltf";
  CHECK(bake_scene(o, report).scene_id ==
        "7d8f5827b87148c5f069915bda9d9300262389e90e0bfd51b02febd2e1c25006");
}

TEST_CASE("a version-4 scene.h5 (32-byte materials, no metallic-roughness table) is still read",
          "[pbr_import]") {
  test::TempDir tmp("pbr-v4");
  BakeReport report;
  const Scene s = bake(test::source_dir() + "/tests/data/materials.obj", report);
  const std::string f = tmp / "v4.h5";
  save_scene(s, f, Provenance{});
  {
    // The materials as version 4 stored them: a compound of the version-4 fields only.
    h5::Handle file(H5Fopen(f.c_str(), H5F_ACC_RDWR, H5P_DEFAULT));
    REQUIRE(file.valid());
    h5::Handle stored(H5Tcopy(h5_type_material_v4().id()));
    REQUIRE(H5Tpack(stored.get()) >= 0);
    CHECK(H5Tget_size(stored.get()) == 32);
    test::rewrite_dataset_as(file.get(), "/materials/materials", stored.get(),
                             h5_type_material_v4().id(), s.materials.data(), s.materials.size(),
                             {hsize_t(s.materials.size())});
    REQUIRE(H5Ldelete(file.get(), "/materials/metallic_roughness_texture", H5P_DEFAULT) >= 0);
  }
  CHECK(refusal(f).find("metallic") != std::string::npos);  // version 5 needs both
  test::set_int_attr(f, "/", "format_version", 4);
  const Scene r = load_scene(f);
  REQUIRE(r.materials.size() == s.materials.size());
  for (size_t i = 0; i < r.materials.size(); ++i) {
    CHECK(r.materials[i].type == s.materials[i].type);
    CHECK(r.materials[i].color[0] == s.materials[i].color[0]);
    CHECK(r.materials[i].metallic == 0.f);
    CHECK(r.materials[i].roughness == 0.f);
    CHECK(r.materials[i].transmission == 0.f);
  }
  CHECK(r.material_mr_texture.empty());
  CHECK(r.scene_id == s.scene_id);
  test::set_int_attr(f, "/", "format_version", 7);
  CHECK(!refusal(f).empty());  // a later version is refused by its number
}

TEST_CASE("scene.h5: NaN, negative or above-1 factors and PBR fields on other types are refused in one line, exit 2",
          "[pbr_import]") {
  test::TempDir tmp("pbr-values");
  write_text(tmp / "m.gltf",
             gltf({pbr("shiny", {{"metallicFactor", 0.2}, {"roughnessFactor", 0.5}},
                       {{"KHR_materials_transmission", {{"transmissionFactor", 0.5}}}}),
                   pbr("matte", {{"metallicFactor", 0}})}));
  BakeReport report;
  const Scene s = bake(tmp / "m.gltf", report);
  const size_t shiny = material_index(s, "shiny"), matte = material_index(s, "matte");
  REQUIRE(s.materials[shiny].type == PF_MAT_PBR);
  REQUIRE(s.materials[matte].type == PF_MAT_DIFFUSE);
  const std::string good = tmp / "s.h5";
  save_scene(s, good, Provenance{});
  int k = 0;
  auto edited = [&](size_t which, const std::function<void(pf_material&)>& change) {
    const std::string f = tmp / ("e" + std::to_string(k++) + ".h5");
    std::filesystem::copy_file(good, f);
    test::edit_dataset<pf_material>(f, "/materials/materials", h5_type_material().id(),
                                    [&](std::vector<pf_material>& v) { change(v[which]); });
    test::refresh_scene_id(f);  // the values reach the checks behind the id
    return f;
  };
  const std::string at = "materials/materials[" + std::to_string(shiny) + "]";
  const std::string at_matte = "materials/materials[" + std::to_string(matte) + "]";
  std::string p = edited(shiny, [](pf_material& m) { m.roughness = NAN; });
  test::refused([&] { load_scene(p); }, p, at + ".roughness is not finite (nan)");
  const std::string nan_file = p;
  p = edited(shiny, [](pf_material& m) { m.roughness = -0.25f; });
  test::refused([&] { load_scene(p); }, p, at + ".roughness = -0.25 is outside");
  const std::string negative = p;
  p = edited(shiny, [](pf_material& m) { m.roughness = 1.5f; });
  test::refused([&] { load_scene(p); }, p, at + ".roughness = 1.5 is outside");
  p = edited(shiny, [](pf_material& m) { m.metallic = 2.f; });
  test::refused([&] { load_scene(p); }, p, at + ".metallic = 2 is outside");
  p = edited(shiny, [](pf_material& m) { m.transmission = -INFINITY; });
  test::refused([&] { load_scene(p); }, p, at + ".transmission is not finite");
  p = edited(shiny, [](pf_material& m) { m.ior = 1.f; });
  test::refused([&] { load_scene(p); }, p, at + ".ior = 1 with transmission 0.5");
  p = edited(shiny, [](pf_material& m) { m.ior = NAN; });
  test::refused([&] { load_scene(p); }, p, at + ".ior is not finite");
  p = edited(matte, [](pf_material& m) { m.metallic = 0.5f; });
  test::refused([&] { load_scene(p); }, p, at_matte + ".metallic = 0.5 on a material of type 0");
  p = edited(matte, [](pf_material& m) { m.type = 5; });
  test::refused([&] { load_scene(p); }, p, "unknown type 5");
  // Without a transmission an ior of 1 is a PBR material's own business (F0 = 0): read.
  p = edited(shiny, [](pf_material& m) {
    m.ior = 1.f;
    m.transmission = 0.f;
  });
  CHECK(refusal(p).empty());
  // The tools: one line naming the file, exit 2, no output.
  for (const std::string& f : {nan_file, negative}) {
    const std::string out = tmp / "hp.h5";
    const test::ToolRun r =
        test::run_tool("trace-hitpoints", "--scene " + q(f) + " -o " + q(out), tmp);
    INFO(r.err);
    CHECK(r.exit_code == kExitBadInput);
    CHECK(r.err.find(f + ": " + at + ".roughness") != std::string::npos);
    CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
    CHECK_FALSE(std::filesystem::exists(out));
  }
}

TEST_CASE("tests/data/pbr.gltf, the example scene of make_pbr_gltf.py, bakes its metallic-roughness materials",
          "[pbr_import]") {
  BakeReport report;
  BakeOptions o;
  o.input = test::source_dir() + "/tests/data/pbr.gltf";
  const Scene s = bake_scene(o, report);
  CHECK(report.warnings.empty());
  CHECK(material(s, "floor").type == PF_MAT_DIFFUSE);
  CHECK(material(s, "gold").type == PF_MAT_PBR);
  CHECK(material(s, "gold").metallic == 1.f);
  const pf_material& glass = material(s, "rough_glass");
  CHECK(glass.type == PF_MAT_PBR);
  CHECK(glass.transmission == 1.f);
  CHECK(glass.ior == 1.5f);
  const size_t t = material_index(s, "textured");
  CHECK(s.materials[t].type == PF_MAT_PBR);
  const int mr = s.mr_texture_of(int(t));
  REQUIRE(mr >= 0);
  REQUIRE(s.texture_of(int(t)) >= 0);
  CHECK(s.texture_of(int(t)) != mr);
  // Its checker's texel (0, 0): B 0, G 230 (linear) — a rough dielectric square.
  const size_t at = 4 * size_t(s.textures[size_t(mr)].offset);
  CHECK(s.texels[at + 2] == 0.f);
  CHECK(s.texels[at + 1] == 230.f / 255.f);
  CHECK(report.camera_from_file);
}
