// Base-colour textures end to end on the CPU (issue 32 item 1): scene-bake reads OBJ map_Kd and
// glb-embedded images with their samplers and UV channels, stores texels once in scene.h5
// (format version 3), refuses damaged and oversized images, warns about missing ones; the eye
// pass, photon bounces and the path tracer shade with texture × colour factor. The PNGs are made
// here with libpng (pf::encode_png); nothing is read from ../shared.
#include <catch2/catch.hpp>

#include <functional>

#include <cstdio>
#include <fstream>

#include <jpeglib.h>

#include "h5edit.h"
#include "photonflow/foundations/error.h"
#include "photonflow/image/image.h"
#include "photonflow/material/texture_shared.h"
#include "photonflow/opencl/cl_backend.h"
#include "photonflow/stages/eye_pass.h"
#include "photonflow/stages/pathtrace.h"
#include "photonflow/stages/photon_pass.h"
#include "photonflow/geometry/scene.h"
#include "photonflow/io/h5_types.h"
#include "photonflow/geometry/scene_file.h"
#include "photonflow/geometry/scene_import.h"
#include "photonflow/image/texture_image.h"
#include "support.h"
#include "support_cl.h"

using namespace pf;

namespace {

std::string q(const std::string& s) { return "'" + s + "'"; }

void write_text(const std::string& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

// An 8-bit RGB PNG of w×h pixels, colour of pixel (x, y) from `f` (libpng, image.cpp).
template <class F> std::string png_bytes(int w, int h, F f) {
  std::vector<uint8_t> rgb(size_t(w) * size_t(h) * 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const auto c = f(x, y);
      for (int k = 0; k < 3; ++k) rgb[(size_t(y) * size_t(w) + size_t(x)) * 3 + size_t(k)] = c[k];
    }
  const std::vector<uint8_t> png = encode_png(w, h, rgb);
  return std::string(png.begin(), png.end());
}

// The test texture: 64×64, 4×4 squares of 16 texels, the top-left square bright. Not symmetric
// under a flip of u or v (a flip swaps bright and dark), so a wrong UV convention shows.
constexpr uint8_t kBright = 200, kDark = 50;
bool bright_square(int i, int j) { return (i + j) % 2 == 0; }
std::string checker_png() {
  return png_bytes(64, 64, [](int x, int y) {
    const uint8_t c = bright_square(x / 16, y / 16) ? kBright : kDark;
    return std::array<uint8_t, 3>{c, c, c};
  });
}

// A 2×2 m floor (y = 0) under a 20×20 m emitting ceiling (y = 3, facing down, albedo
// `ceiling_kd`), seen from straight above. Floor UVs: glTF (0, 0) at (−1, 0, −1), u along +x,
// v along +z; in OBJ (v up) that corner is vt (0, 1).
std::string floor_obj(const std::string& mtl) {
  return "mtllib " + mtl +
         "\n"
         "v -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\n"
         "v -10 3 -10\nv 10 3 -10\nv 10 3 10\nv -10 3 10\n"
         "vt 0 1\nvt 1 1\nvt 1 0\nvt 0 0\n"
         "o floor\nusemtl floor\nf 1/1 4/4 3/3\nf 1/1 3/3 2/2\n"
         "o ceiling\nusemtl light\nf 5 6 7\nf 5 7 8\n";
}
// The same ceiling over a 20×20 m floor (UVs 0 … 10: the texture repeats), so that much of the
// light the floor reflects comes back to it from the ceiling.
std::string big_floor_obj(const std::string& mtl) {
  return "mtllib " + mtl +
         "\n"
         "v -10 0 -10\nv 10 0 -10\nv 10 0 10\nv -10 0 10\n"
         "v -10 3 -10\nv 10 3 -10\nv 10 3 10\nv -10 3 10\n"
         "vt 0 10\nvt 10 10\nvt 10 0\nvt 0 0\n"
         "o floor\nusemtl floor\nf 1/1 4/4 3/3\nf 1/1 3/3 2/2\n"
         "o ceiling\nusemtl light\nf 5 6 7\nf 5 7 8\n";
}
std::string light_mtl(const std::string& ceiling_kd = "0 0 0") {
  return "newmtl light\nKd " + ceiling_kd + "\nKe 1 1 1\n";
}

// The camera of the floor scenes: straight down from 2.5 m, 40° (the view stays on the floor),
// image top = −z, right = +x.
constexpr float kFov = 40.f;
BakeOptions floor_options(const std::string& input, int size) {
  BakeOptions o;
  o.input = input;
  o.eye = Vec3(0, 2.5f, 0);
  o.look_at = Vec3(0, 0, 0);
  o.up = Vec3(0, 0, -1);
  o.fov_y_deg = kFov;
  o.width = o.height = size;
  return o;
}

// The glTF UV that pixel (px, py) of a size×size floor image sees (pixel centre).
void pixel_uv(int px, int py, int size, float& u, float& v) {
  const float half = 2.5f * std::tan(0.5f * kFov * 3.14159265f / 180.f);
  const float x = (2.f * (float(px) + 0.5f) / float(size) - 1.f) * half;
  const float z = (2.f * (float(py) + 0.5f) / float(size) - 1.f) * half;
  u = 0.5f * (x + 1.f);
  v = 0.5f * (z + 1.f);
}

// Square (i, j) of the checker under pixel (px, py), false when the pixel lies within 15 % of a
// square's side from its edge (bilinear filtering and the pixel's footprint mix squares there).
bool pixel_square(int px, int py, int size, int& i, int& j) {
  float u, v;
  pixel_uv(px, py, size, u, v);
  const float su = 4.f * u, sv = 4.f * v;
  i = int(std::floor(su));
  j = int(std::floor(sv));
  const float fu = su - float(i), fv = sv - float(j);
  return fu > 0.15f && fu < 0.85f && fv > 0.15f && fv < 0.85f && i >= 0 && i < 4 && j >= 0 && j < 4;
}

Scene bake(const BakeOptions& o, BakeReport& report) { return bake_scene(o, report); }
Scene bake(const BakeOptions& o) {
  BakeReport report;
  return bake_scene(o, report);
}

Image pathtrace_image(const Scene& s, int spp) {
  PathTraceOptions o;
  o.spp = spp;
  o.seed = 7;
  o.threads = 2;
  return pathtrace(s, o);
}

float channel_mean(const Image& img, int c) {
  double sum = 0;
  for (size_t i = 0; i < img.pixel_count(); ++i) sum += img.rgb[3 * i + size_t(c)];
  return float(sum / double(img.pixel_count()));
}

// A minimal glb (glTF 2.0 binary): the floor as one quad with TEXCOORD_0 (all zero) and
// TEXCOORD_1 (the floor UVs, glTF convention), its material's baseColorTexture reading texCoord 1
// from an image embedded in the binary chunk (sampler: wrapS clamp, wrapT mirrored repeat,
// magFilter nearest), baseColorFactor `factor`; and the emitting ceiling.
std::string floor_glb(const std::string& png, const std::string& factor) {
  std::string bin;
  auto put_floats = [&bin](std::initializer_list<float> v) {
    for (float f : v) bin.append(reinterpret_cast<const char*>(&f), 4);
  };
  // Floor: positions (4 × vec3), uv0, uv1 (4 × vec2), indices (6 × u16, padded to 4 bytes).
  put_floats({-1, 0, -1, 1, 0, -1, 1, 0, 1, -1, 0, 1});           // 0: 48 bytes
  put_floats({0, 0, 0, 0, 0, 0, 0, 0});                           // 48: 32 bytes (uv0)
  put_floats({0, 0, 1, 0, 1, 1, 0, 1});                           // 80: 32 bytes (uv1)
  const uint16_t idx[6] = {0, 3, 2, 0, 2, 1};                     // faces up
  bin.append(reinterpret_cast<const char*>(idx), 12);             // 112: 12 bytes
  // Ceiling at y = 3 facing down.
  put_floats({-10, 3, -10, 10, 3, -10, 10, 3, 10, -10, 3, 10});  // 124: 48 bytes
  const uint16_t cidx[6] = {0, 1, 2, 0, 2, 3};
  bin.append(reinterpret_cast<const char*>(cidx), 12);            // 172: 12 bytes
  const size_t image_at = bin.size();                             // 184
  bin += png;
  while (bin.size() % 4) bin.push_back('\0');
  const std::string json =
      R"({"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0,1]}],)"
      R"("nodes":[{"mesh":0,"name":"floor"},{"mesh":1,"name":"ceiling"}],)"
      R"("meshes":[{"primitives":[{"attributes":{"POSITION":0,"TEXCOORD_0":1,"TEXCOORD_1":2},"indices":3,"material":0}]},)"
      R"({"primitives":[{"attributes":{"POSITION":4},"indices":5,"material":1}]}],)"
      R"("materials":[{"name":"floor","pbrMetallicRoughness":{"baseColorFactor":[)" + factor +
      R"(],"baseColorTexture":{"index":0,"texCoord":1},"metallicFactor":0}},)"
      R"({"name":"light","emissiveFactor":[1,1,1],"pbrMetallicRoughness":{"baseColorFactor":[0,0,0,1],"metallicFactor":0}}],)"
      R"("textures":[{"source":0,"sampler":0}],)"
      R"("samplers":[{"magFilter":9728,"wrapS":33071,"wrapT":33648}],)"
      R"("images":[{"bufferView":6,"mimeType":"image/png"}],)"
      R"("accessors":[)"
      R"({"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[-1,0,-1],"max":[1,0,1]},)"
      R"({"bufferView":1,"componentType":5126,"count":4,"type":"VEC2"},)"
      R"({"bufferView":2,"componentType":5126,"count":4,"type":"VEC2"},)"
      R"({"bufferView":3,"componentType":5123,"count":6,"type":"SCALAR"},)"
      R"({"bufferView":4,"componentType":5126,"count":4,"type":"VEC3","min":[-10,3,-10],"max":[10,3,10]},)"
      R"({"bufferView":5,"componentType":5123,"count":6,"type":"SCALAR"}],)"
      R"("bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":48},{"buffer":0,"byteOffset":48,"byteLength":32},)"
      R"({"buffer":0,"byteOffset":80,"byteLength":32},{"buffer":0,"byteOffset":112,"byteLength":12},)"
      R"({"buffer":0,"byteOffset":124,"byteLength":48},{"buffer":0,"byteOffset":172,"byteLength":12},)"
      R"({"buffer":0,"byteOffset":)" + std::to_string(image_at) + R"(,"byteLength":)" +
      std::to_string(png.size()) + R"(}],)"
      R"("buffers":[{"byteLength":)" + std::to_string(bin.size()) + "}]}";
  std::string j = json;
  while (j.size() % 4) j.push_back(' ');
  std::string glb = "glTF";
  auto u32 = [&glb](uint32_t v) { glb.append(reinterpret_cast<const char*>(&v), 4); };
  u32(2);
  u32(uint32_t(12 + 8 + j.size() + 8 + bin.size()));
  u32(uint32_t(j.size()));
  glb += "JSON";
  glb += j;
  u32(uint32_t(bin.size()));
  glb += std::string("BIN\0", 4);
  glb += bin;
  return glb;
}

// A baseline JPEG (libjpeg-turbo, quality 95) of the checker at 64×64, RGB.
std::string checker_jpeg() {
  jpeg_compress_struct c;
  jpeg_error_mgr err;
  c.err = jpeg_std_error(&err);
  jpeg_create_compress(&c);
  unsigned char* out = nullptr;
  unsigned long size = 0;
  jpeg_mem_dest(&c, &out, &size);
  c.image_width = 64;
  c.image_height = 64;
  c.input_components = 3;
  c.in_color_space = JCS_RGB;
  jpeg_set_defaults(&c);
  jpeg_set_quality(&c, 95, TRUE);
  jpeg_start_compress(&c, TRUE);
  std::vector<unsigned char> row(64 * 3);
  while (c.next_scanline < 64) {
    for (int x = 0; x < 64; ++x)
      for (int k = 0; k < 3; ++k)
        row[size_t(3 * x + k)] = bright_square(x / 16, int(c.next_scanline) / 16) ? kBright : kDark;
    JSAMPROW r = row.data();
    jpeg_write_scanlines(&c, &r, 1);
  }
  jpeg_finish_compress(&c);
  std::string bytes(reinterpret_cast<const char*>(out), size);
  jpeg_destroy_compress(&c);
  std::free(out);
  return bytes;
}

// The index of the material named "floor" (REQUIREd to exist).
size_t floor_material(const Scene& s) {
  size_t m = 0;
  while (m < s.material_names.size() && s.material_names[m] != "floor") ++m;
  REQUIRE(m < s.materials.size());
  return m;
}

// The floor spans x, z in [−1, 1]: its UVs, in the glTF convention, are ((x + 1)/2, (z + 1)/2).
void check_floor_uvs(const Scene& s, size_t floor_mat) {
  REQUIRE(s.uvs.size() == s.triangles.size());
  for (size_t i = 0; i < s.triangles.size(); ++i) {
    if (s.triangles[i].material != int(floor_mat)) continue;
    const float* vs[3] = {s.triangles[i].v0, s.triangles[i].v1, s.triangles[i].v2};
    for (int k = 0; k < 3; ++k) {
      CHECK(s.uvs[i].uv[2 * k] == Approx(0.5f * (vs[k][0] + 1.f)));
      CHECK(s.uvs[i].uv[2 * k + 1] == Approx(0.5f * (vs[k][2] + 1.f)));
    }
  }
}

// The checker's bright squares are brighter than its dark ones by the texels' ratio, in the red
// channel of `img` (the light is nearly uniform over the floor); `each` sees every square pixel.
void check_checker_ratio(const Image& img, int size,
                         const std::function<void(const Vec3&)>& each = {}) {
  double sb = 0, sd = 0;
  int nb = 0, nd = 0;
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) {
      int i, j;
      if (!pixel_square(x, y, size, i, j)) continue;
      const Vec3 c = img.get(x, y);
      if (each) each(c);
      (bright_square(i, j) ? sb : sd) += c.x;
      (bright_square(i, j) ? nb : nd) += 1;
    }
  REQUIRE(nb > 0);
  REQUIRE(nd > 0);
  CHECK((sb / nb) / (sd / nd) ==
        Approx(pf_srgb8_to_linear(kBright) / pf_srgb8_to_linear(kDark)).epsilon(0.05));
}

}  // namespace

TEST_CASE("a JPEG texture is decoded by libjpeg-turbo, a cut one is refused", "[textures]") {
  test::TempDir tmp("tex-jpeg");
  const std::string jpeg = checker_jpeg();
  write_text(tmp / "checker.jpg", jpeg);
  write_text(tmp / "j.mtl", "newmtl floor\nKd 1 1 1\nmap_Kd checker.jpg\n" + light_mtl());
  write_text(tmp / "j.obj", floor_obj("j.mtl"));
  const Scene s = bake(floor_options(tmp / "j.obj", 16));
  REQUIRE(s.textures.size() == 1);
  CHECK(s.textures[0].width == 64);
  // Square interiors within JPEG's error of the linear values.
  const auto texel = [&](int x, int y) { return s.texels[4 * size_t(y * 64 + x)]; };
  CHECK(texel(8, 8) == Approx(pf_srgb8_to_linear(kBright)).epsilon(0.03));
  CHECK(texel(24, 8) == Approx(pf_srgb8_to_linear(kDark)).epsilon(0.15));
  CHECK(texel(8, 24) == Approx(pf_srgb8_to_linear(kDark)).epsilon(0.15));
  CHECK(s.texels[3] == 1.f);
  // Cut inside its image data (the headers whole): libjpeg's "premature end" warning, after which
  // it would fill the rest with grey, is a refusal here.
  REQUIRE(jpeg.size() > 400);
  write_text(tmp / "checker.jpg", jpeg.substr(0, jpeg.size() - 40));
  BakeReport report;
  try {
    bake(floor_options(tmp / "j.obj", 16), report);
    FAIL("a cut JPEG was baked");
  } catch (const InputError& e) {
    const std::string what = e.what();
    CHECK(what.find("checker.jpg") != std::string::npos);
    CHECK(what.find("JPEG") != std::string::npos);
    CHECK(what.find("'floor'") != std::string::npos);
  }
}

TEST_CASE("a textured floor under uniform light reproduces the checker's pattern and mean",
          "[textures]") {
  test::TempDir tmp("tex-floor");
  write_text(tmp / "checker.png", checker_png());
  write_text(tmp / "textured.mtl", "newmtl floor\nKd 1 1 1\nmap_Kd checker.png\n" + light_mtl());
  write_text(tmp / "plain.mtl", "newmtl floor\nKd 0.99 0.99 0.99\n" + light_mtl());
  write_text(tmp / "textured.obj", floor_obj("textured.mtl"));
  write_text(tmp / "plain.obj", floor_obj("plain.mtl"));
  const int size = 48;
  BakeReport report;
  const Scene textured = bake(floor_options(tmp / "textured.obj", size), report);
  CHECK(report.warnings.empty());  // a factor of 1 with a texture is not a clamped albedo
  const Scene plain = bake(floor_options(tmp / "plain.obj", size));
  REQUIRE(textured.textures.size() == 1);
  REQUIRE(textured.uvs.size() == textured.triangles.size());
  CHECK(plain.uvs.empty());
  CHECK(plain.textures.empty());

  const float lin_bright = pf_srgb8_to_linear(kBright), lin_dark = pf_srgb8_to_linear(kDark);
  // The texture's linear mean over the part the camera sees, against the image's: ratio of the
  // textured image to the plain one (the same light and random numbers; the floor's only light
  // is direct, the ceiling is black), pixel by pixel in the squares' interiors.
  auto check_pattern = [&](const Image& t, const Image& p, double tolerance) {
    double sum_ratio = 0, sum_expected = 0;
    int tested = 0, bright = 0, dark = 0;
    for (int y = 0; y < size; ++y)
      for (int x = 0; x < size; ++x) {
        int i, j;
        if (!pixel_square(x, y, size, i, j)) continue;
        const float expected = bright_square(i, j) ? lin_bright : lin_dark;
        const float ratio = t.get(x, y).y / p.get(x, y).y;
        INFO("pixel " << x << "," << y << " square " << i << "," << j);
        CHECK(ratio == Approx(expected).epsilon(tolerance));
        sum_ratio += ratio;
        sum_expected += expected;
        ++tested;
        (bright_square(i, j) ? bright : dark) += 1;
      }
    CHECK(tested > size * size / 4);
    CHECK(bright > 0);
    CHECK(dark > 0);
    CHECK(sum_ratio / tested == Approx(sum_expected / tested).epsilon(tolerance / 2));
  };
  SECTION("path tracer") {
    check_pattern(pathtrace_image(textured, 4), pathtrace_image(plain, 4), 0.01);
  }
  SECTION("render --estimator sppm through the tools, from the OBJ source") {
    const std::string common =
        " --width " + std::to_string(size) + " --height " + std::to_string(size) +
        " --eye 0,2.5,0 --look-at 0,0,0 --up 0,0,-1 --fov 40 --estimator sppm --passes 8"
        " --photons 200000 --threads 2";
    for (const char* name : {"textured", "plain"}) {
      const test::ToolRun r = test::run_tool(
          "render", "--scene " + q(tmp / (std::string(name) + ".obj")) + " -o " +
                        q(tmp / (std::string(name) + ".exr")) + common,
          tmp);
      INFO(r.err);
      REQUIRE(r.exit_code == 0);
    }
    // SPPM's photons are the same in both (the first hit is the floor, later bounces go to the
    // black ceiling), so the ratio is the texture's value at each visible point up to the few
    // photons whose Russian roulette differs.
    check_pattern(read_exr(tmp / "textured.exr"), read_exr(tmp / "plain.exr"), 0.03);
  }
}

TEST_CASE("photon bounces, the path tracer's bounces and SPPM's gather use the textured albedo",
          "[textures]") {
  // A uniform texture (sRGB 255, 60, 60) with factor 1 against the same albedo as a colour: the
  // images agree. The ceiling reflects (albedo 0.5) and the floor is as large as the ceiling, so
  // about a third of the floor's red light is indirect; a bounce that took the factor alone
  // (white) would make the green channel about a third brighter.
  test::TempDir tmp("tex-bounce");
  write_text(tmp / "red.png", png_bytes(8, 8, [](int, int) {
               return std::array<uint8_t, 3>{255, 60, 60};
             }));
  char kd[128];
  const float r = 0.99f * pf_srgb8_to_linear(255), g = 0.99f * pf_srgb8_to_linear(60);
  std::snprintf(kd, sizeof kd, "%.9g %.9g %.9g", double(r), double(g), double(g));
  write_text(tmp / "tex.mtl", "newmtl floor\nKd 1 1 1\nmap_Kd red.png\n" + light_mtl("0.5 0.5 0.5"));
  write_text(tmp / "col.mtl", "newmtl floor\nKd " + std::string(kd) + "\n" + light_mtl("0.5 0.5 0.5"));
  write_text(tmp / "tex.obj", big_floor_obj("tex.mtl"));
  write_text(tmp / "col.obj", big_floor_obj("col.mtl"));
  const int size = 24;
  const Scene tex = bake(floor_options(tmp / "tex.obj", size));
  const Scene col = bake(floor_options(tmp / "col.obj", size));
  REQUIRE(tex.textures.size() == 1);
  SECTION("path tracer") {
    const Image a = pathtrace_image(tex, 16), b = pathtrace_image(col, 16);
    for (int c = 0; c < 3; ++c) CHECK(channel_mean(a, c) == Approx(channel_mean(b, c)).epsilon(0.01));
  }
  SECTION("sppm") {
    const std::string common = " --width " + std::to_string(size) + " --height " +
                               std::to_string(size) +
                               " --eye 0,2.5,0 --look-at 0,0,0 --up 0,0,-1 --fov 40"
                               " --estimator sppm --passes 6 --photons 100000 --threads 2";
    for (const char* name : {"tex", "col"}) {
      const test::ToolRun run = test::run_tool(
          "render", "--scene " + q(tmp / (std::string(name) + ".obj")) + " -o " +
                        q(tmp / (std::string(name) + ".exr")) + common,
          tmp);
      INFO(run.err);
      REQUIRE(run.exit_code == 0);
    }
    const Image a = read_exr(tmp / "tex.exr"), b = read_exr(tmp / "col.exr");
    for (int c = 0; c < 3; ++c) CHECK(channel_mean(a, c) == Approx(channel_mean(b, c)).epsilon(0.02));
  }
}

TEST_CASE("a glb with an embedded texture: texCoord, sampler wrap modes and filter, pattern",
          "[textures]") {
  test::TempDir tmp("tex-glb");
  write_text(tmp / "floor.glb", floor_glb(checker_png(), "1,0.5,1,1"));
  const int size = 32;
  const Scene s = bake(floor_options(tmp / "floor.glb", size));
  REQUIRE(s.textures.size() == 1);
  const pf_texture& t = s.textures[0];
  CHECK(t.width == 64);
  CHECK(t.height == 64);
  CHECK(t.wrap_s == PF_TEX_WRAP_CLAMP);
  CHECK(t.wrap_t == PF_TEX_WRAP_MIRROR);
  CHECK(t.filter == PF_TEX_FILTER_NEAREST);
  CHECK(s.texture_names[0].find("floor.glb#0") != std::string::npos);
  // Texels: sRGB decoded, alpha 1.
  CHECK(s.texels[0] == pf_srgb8_to_linear(kBright));
  CHECK(s.texels[4 * 16] == pf_srgb8_to_linear(kDark));
  CHECK(s.texels[3] == 1.f);
  // The floor's material: the factor (1, 0.5, 1) clamped below 1, its texture 0; the light none.
  const size_t floor_mat = floor_material(s);
  CHECK(s.texture_of(int(floor_mat)) == 0);
  CHECK(s.materials[floor_mat].color[1] == 0.5f);
  // texCoord 1: the UVs are TEXCOORD_1's (TEXCOORD_0 is all zero), in the glTF convention.
  check_floor_uvs(s, floor_mat);
  // The pattern: bright squares brighter than dark ones by the texels' ratio, green to red as
  // the factor's (0.5 to 0.99).
  const float green_per_red = s.materials[floor_mat].color[1] / s.materials[floor_mat].color[0];
  check_checker_ratio(pathtrace_image(s, 8), size, [&](const Vec3& c) {
    CHECK(c.y == Approx(c.x * green_per_red).epsilon(1e-4));
  });
}

TEST_CASE("a COLLADA <diffuse><texture>: the image through its sampler and surface, v flipped",
          "[textures]") {
  test::TempDir tmp("tex-dae");
  write_text(tmp / "checker.png", checker_png());
  write_text(tmp / "floor.dae", R"(<?xml version="1.0" encoding="utf-8"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
  <asset><unit name="meter" meter="1"/><up_axis>Y_UP</up_axis></asset>
  <library_images><image id="checker-img"><init_from>checker.png</init_from></image></library_images>
  <library_effects>
    <effect id="floor-fx"><profile_COMMON>
      <newparam sid="checker-surface"><surface type="2D"><init_from>checker-img</init_from></surface></newparam>
      <newparam sid="checker-sampler"><sampler2D><source>checker-surface</source></sampler2D></newparam>
      <technique sid="common"><lambert><diffuse><texture texture="checker-sampler" texcoord="UVMap"/></diffuse></lambert></technique>
    </profile_COMMON></effect>
    <effect id="light-fx"><profile_COMMON><technique sid="common"><lambert>
      <emission><color>1 1 1 1</color></emission><diffuse><color>0 0 0 1</color></diffuse>
    </lambert></technique></profile_COMMON></effect>
  </library_effects>
  <library_materials>
    <material id="floor" name="floor"><instance_effect url="#floor-fx"/></material>
    <material id="light" name="light"><instance_effect url="#light-fx"/></material>
  </library_materials>
  <library_geometries>
    <geometry id="floor-g" name="floor"><mesh>
      <source id="fp"><float_array id="fp-a" count="12">-1 0 -1 1 0 -1 1 0 1 -1 0 1</float_array>
        <technique_common><accessor source="#fp-a" count="4" stride="3">
          <param name="X" type="float"/><param name="Y" type="float"/><param name="Z" type="float"/>
        </accessor></technique_common></source>
      <source id="fuv"><float_array id="fuv-a" count="8">0 1 1 1 1 0 0 0</float_array>
        <technique_common><accessor source="#fuv-a" count="4" stride="2">
          <param name="S" type="float"/><param name="T" type="float"/>
        </accessor></technique_common></source>
      <vertices id="fv"><input semantic="POSITION" source="#fp"/></vertices>
      <triangles material="surface" count="2">
        <input semantic="VERTEX" source="#fv" offset="0"/>
        <input semantic="TEXCOORD" source="#fuv" offset="1" set="0"/>
        <p>0 0 3 3 2 2 0 0 2 2 1 1</p></triangles>
    </mesh></geometry>
    <geometry id="ceiling-g" name="ceiling"><mesh>
      <source id="cp"><float_array id="cp-a" count="12">-10 3 -10 10 3 -10 10 3 10 -10 3 10</float_array>
        <technique_common><accessor source="#cp-a" count="4" stride="3">
          <param name="X" type="float"/><param name="Y" type="float"/><param name="Z" type="float"/>
        </accessor></technique_common></source>
      <vertices id="cv"><input semantic="POSITION" source="#cp"/></vertices>
      <triangles material="surface" count="2"><input semantic="VERTEX" source="#cv" offset="0"/>
        <p>0 1 2 0 2 3</p></triangles>
    </mesh></geometry>
  </library_geometries>
  <library_visual_scenes><visual_scene id="scene" name="scene">
    <node id="floor-n" name="floor-n"><instance_geometry url="#floor-g"><bind_material><technique_common>
      <instance_material symbol="surface" target="#floor"><bind_vertex_input semantic="UVMap" input_semantic="TEXCOORD" input_set="0"/></instance_material>
    </technique_common></bind_material></instance_geometry></node>
    <node id="ceiling-n" name="ceiling-n"><instance_geometry url="#ceiling-g"><bind_material><technique_common>
      <instance_material symbol="surface" target="#light"/></technique_common></bind_material></instance_geometry></node>
  </visual_scene></library_visual_scenes>
  <scene><instance_visual_scene url="#scene"/></scene>
</COLLADA>
)");
  const int size = 32;
  BakeReport report;
  const Scene s = bake(floor_options(tmp / "floor.dae", size), report);
  CHECK(report.warnings.empty());
  REQUIRE(s.textures.size() == 1);
  CHECK(s.texture_names[0] == tmp / "checker.png");
  const size_t floor_mat = floor_material(s);
  CHECK(s.texture_of(int(floor_mat)) == 0);
  // <diffuse> is the texture alone: assimp gives it the colour 1, kept below 1 (no warning).
  CHECK(s.materials[floor_mat].color[0] == 0.99f);
  check_floor_uvs(s, floor_mat);
  check_checker_ratio(pathtrace_image(s, 8), size);
}

TEST_CASE("one image used by two materials is stored once, other wrap modes share its texels",
          "[textures]") {
  test::TempDir tmp("tex-shared");
  write_text(tmp / "checker.png", checker_png());
  write_text(tmp / "two.mtl",
             "newmtl floor\nKd 1 1 1\nmap_Kd checker.png\n"
             "newmtl other\nKd 0.5 0.5 0.5\nmap_Kd checker.png\n"
             "newmtl clamped\nKd 0.5 0.5 0.5\nmap_Kd -clamp on checker.png\n" +
                 light_mtl());
  write_text(tmp / "two.obj",
             "mtllib two.mtl\n"
             "v -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\n"
             "v -10 3 -10\nv 10 3 -10\nv 10 3 10\nv -10 3 10\n"
             "vt 0 1\nvt 1 1\nvt 1 0\nvt 0 0\n"
             "o a\nusemtl floor\nf 1/1 4/4 3/3\n"
             "o b\nusemtl other\nf 1/1 3/3 2/2\n"
             "o c\nusemtl clamped\nf 1/1 2/2 3/3\n"
             "o ceiling\nusemtl light\nf 5 6 7\nf 5 7 8\n");
  const Scene s = bake(floor_options(tmp / "two.obj", 16));
  CHECK(s.texels.size() == size_t(64 * 64 * 4));  // one image's texels
  REQUIRE(s.textures.size() == 2);                // repeat and clamp headers
  CHECK(s.textures[0].offset == s.textures[1].offset);
  CHECK(s.textures[0].wrap_s == PF_TEX_WRAP_REPEAT);
  CHECK(s.textures[1].wrap_s == PF_TEX_WRAP_CLAMP);
  std::vector<int> tex;
  for (size_t m = 0; m < s.materials.size(); ++m) tex.push_back(s.texture_of(int(m)));
  CHECK(std::count(tex.begin(), tex.end(), 0) == 2);
  CHECK(std::count(tex.begin(), tex.end(), 1) == 1);
  CHECK(std::count(tex.begin(), tex.end(), -1) == 1);  // the light
  // And so in scene.h5.
  save_scene(s, tmp / "scene.h5", Provenance{});
  const Scene r = load_scene(tmp / "scene.h5");
  CHECK(r.texels.size() == size_t(64 * 64 * 4));
  CHECK(r.textures.size() == 2);
}

TEST_CASE("scene.h5 keeps textures, texels, materials' textures and UVs, edits are refused",
          "[textures]") {
  test::TempDir tmp("tex-h5");
  write_text(tmp / "checker.png", checker_png());
  write_text(tmp / "t.mtl", "newmtl floor\nKd 1 1 1\nmap_Kd checker.png\n" + light_mtl());
  write_text(tmp / "t.obj", floor_obj("t.mtl"));
  const Scene s = bake(floor_options(tmp / "t.obj", 16));
  const std::string path = tmp / "scene.h5";
  save_scene(s, path, Provenance{});
  const Scene r = load_scene(path);
  REQUIRE(r.textures.size() == s.textures.size());
  CHECK(std::memcmp(r.textures.data(), s.textures.data(), s.textures.size() * sizeof(pf_texture)) == 0);
  CHECK(r.texels == s.texels);
  CHECK(r.texture_names == s.texture_names);
  CHECK(r.material_texture == s.material_texture);
  REQUIRE(r.uvs.size() == s.uvs.size());
  CHECK(std::memcmp(r.uvs.data(), s.uvs.data(), s.uvs.size() * sizeof(TriangleUV)) == 0);
  CHECK(r.scene_id == s.scene_id);
  {
    h5::Reader rd(path, kSceneFormat, kSceneFormatVersion);
    CHECK(rd.version() == kSceneFormatVersion);  // 3 added textures
    CHECK(rd.shape("/textures/texels") == std::vector<size_t>{64 * 64, 4});
    CHECK(rd.shape("/geometry/uvs") == std::vector<size_t>{s.triangles.size(), 6});
  }

  auto refused = [&](const std::string& file) {
    try {
      load_scene(file);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  auto copy = [&](const std::string& name) {
    std::filesystem::copy_file(path, tmp / name);
    return tmp / name;
  };
  SECTION("the scene id covers the texels, the UVs and the materials' textures") {
    Scene a = s;
    a.texels[5] = 0.25f;
    a.compute_scene_id();
    CHECK(a.scene_id != s.scene_id);
    Scene b = s;
    b.uvs[0].uv[1] += 0.5f;
    b.compute_scene_id();
    CHECK(b.scene_id != s.scene_id);
    Scene c = s;
    c.material_texture.assign(c.material_texture.size(), -1);
    c.compute_scene_id();
    CHECK(c.scene_id != s.scene_id);
    // An edited texel (checksum refreshed, as an editing script would) is refused by the id.
    const std::string f = copy("texel.h5");
    std::vector<float> texels = s.texels;
    texels[5] = 0.25f;
    {
      h5::Handle file(H5Fopen(f.c_str(), H5F_ACC_RDWR, H5P_DEFAULT));
      h5::Handle d(H5Dopen2(file.get(), "/textures/texels", H5P_DEFAULT));
      REQUIRE(H5Dwrite(d.get(), H5T_NATIVE_FLOAT, H5S_ALL, H5S_ALL, H5P_DEFAULT, texels.data()) >= 0);
      test::refresh_checksum(d.get());
    }
    CHECK(refused(f).find("scene_id does not match") != std::string::npos);
    // With the id recomputed from the content (h5edit.h, as docs/FORMATS.md defines it), the
    // edited texel is read.
    test::refresh_scene_id(f);
    CHECK(refused(f).empty());
    CHECK(load_scene(f).texels[5] == 0.25f);
  }
  SECTION("every new dataset is validated on read") {
    {
      const std::string f = copy("value.h5");
      std::vector<float> texels = s.texels;
      texels[6] = 2.f;
      h5::Handle file(H5Fopen(f.c_str(), H5F_ACC_RDWR, H5P_DEFAULT));
      h5::Handle d(H5Dopen2(file.get(), "/textures/texels", H5P_DEFAULT));
      REQUIRE(H5Dwrite(d.get(), H5T_NATIVE_FLOAT, H5S_ALL, H5S_ALL, H5P_DEFAULT, texels.data()) >= 0);
      test::refresh_checksum(d.get());
      file = h5::Handle(-1);
      const std::string e = refused(f);
      CHECK(e.find("textures/texels[1]") != std::string::npos);
      CHECK(e.find('\n') == std::string::npos);
    }
    {
      const std::string f = copy("offset.h5");
      std::vector<pf_texture> t = s.textures;
      t[0].offset = 5;
      test::rewrite_dataset(f, "/textures/textures", h5_type_texture().id(), t);
      CHECK(refused(f).find("run past") != std::string::npos);
    }
    {
      const std::string f = copy("wrap.h5");
      std::vector<pf_texture> t = s.textures;
      t[0].wrap_t = 7;
      test::rewrite_dataset(f, "/textures/textures", h5_type_texture().id(), t);
      CHECK(refused(f).find("textures/textures[0].wrap_t") != std::string::npos);
    }
    {
      const std::string f = copy("index.h5");
      std::vector<int32_t> m = s.material_texture;
      m[0] = 3;
      test::rewrite_dataset(f, "/materials/texture", H5T_NATIVE_INT32, m);
      CHECK(refused(f).find("materials/texture[0]") != std::string::npos);
    }
    {
      const std::string f = copy("uv.h5");
      h5::Handle file(H5Fopen(f.c_str(), H5F_ACC_RDWR, H5P_DEFAULT));
      REQUIRE(H5Ldelete(file.get(), "/geometry/uvs", H5P_DEFAULT) >= 0);
      file = h5::Handle(-1);
      CHECK(refused(f).find("geometry/uvs") != std::string::npos);
    }
  }
  SECTION("an untextured scene keeps its id; a version-2 file is still read") {
    write_text(tmp / "p.mtl", "newmtl floor\nKd 0.5 0.5 0.5\n" + light_mtl());
    write_text(tmp / "p.obj", floor_obj("p.mtl"));
    Scene p = bake(floor_options(tmp / "p.obj", 16));
    const std::string id = p.scene_id;
    p.material_texture.clear();  // as a version-2 scene holds it
    p.compute_scene_id();
    CHECK(p.scene_id == id);
    save_scene(p, tmp / "p.h5", Provenance{});
    {
      h5::Handle file(H5Fopen((tmp / "p.h5").c_str(), H5F_ACC_RDWR, H5P_DEFAULT));
      REQUIRE(H5Ldelete(file.get(), "/materials/texture", H5P_DEFAULT) >= 0);
    }
    CHECK(!refused(tmp / "p.h5").empty());  // version 3 needs it
    test::set_int_attr(tmp / "p.h5", "/", "format_version", 2);
    const Scene old = load_scene(tmp / "p.h5");
    CHECK(old.textures.empty());
    CHECK(old.texture_of(0) == -1);
    CHECK(old.scene_id == id);
  }
}

TEST_CASE("a missing texture is refused, or with --missing-textures warn one warning naming the "
          "file and the material and the factor is used",
          "[textures]") {
  test::TempDir tmp("tex-missing");
  write_text(tmp / "m.mtl", "newmtl floor\nKd 0.5 0.25 0.5\nmap_Kd nowhere.png\n" + light_mtl());
  write_text(tmp / "m.obj", floor_obj("m.mtl"));
  BakeReport report;
  // By default an error: exit 2, one line naming the image and the material, no output.
  CHECK_THROWS_AS(bake(floor_options(tmp / "m.obj", 16), report), InputError);
  test::ToolRun refused =
      test::run_tool("scene-bake", q(tmp / "m.obj") + " -o " + q(tmp / "s.h5"), tmp);
  CHECK(refused.exit_code == 2);
  CHECK(std::count(refused.err.begin(), refused.err.end(), '\n') == 1);
  CHECK(refused.err.find("nowhere.png") != std::string::npos);
  CHECK(refused.err.find("'floor'") != std::string::npos);
  CHECK_FALSE(std::filesystem::exists(tmp / "s.h5"));
  BakeOptions warn = floor_options(tmp / "m.obj", 16);
  warn.inputs.missing_textures_warn = true;
  const Scene s = bake(warn, report);
  REQUIRE(report.warnings.size() == 1);
  CHECK(report.warnings[0].find("nowhere.png") != std::string::npos);
  CHECK(report.warnings[0].find("'floor'") != std::string::npos);
  CHECK(s.textures.empty());
  CHECK(s.uvs.empty());
  const size_t floor_mat = floor_material(s);
  CHECK(s.texture_of(int(floor_mat)) == -1);
  CHECK(s.materials[floor_mat].color[1] == 0.25f);
  // The tool: exit 0, the scene written, that one line on stderr.
  const test::ToolRun r = test::run_tool(
      "scene-bake", q(tmp / "m.obj") + " -o " + q(tmp / "s.h5") + " --missing-textures warn", tmp);
  CHECK(r.exit_code == 0);
  CHECK(std::filesystem::exists(tmp / "s.h5"));
  CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
  CHECK(r.err.find("warning") != std::string::npos);
  CHECK(r.err.find("nowhere.png") != std::string::npos);
}

TEST_CASE("a damaged or oversized texture is refused: exit 2, one line, no output", "[textures]") {
  test::TempDir tmp("tex-bad");
  const std::string good = checker_png();
  std::string crc = good;
  const size_t idat = crc.find("IDAT");
  REQUIRE(idat != std::string::npos);
  crc[idat + 6] = char(crc[idat + 6] ^ 0x55);  // image data no longer matches its CRC
  struct Case {
    const char* name;
    std::string bytes;
    const char* says;
  } cases[] = {
      {"garbage.png", "this is not an image at all", "not a PNG or JPEG"},
      {"cut.png", good.substr(0, good.size() / 2), "PNG"},
      {"crc.png", crc, "PNG"},
      {"jpeg.jpg", std::string("\xff\xd8\xff\xe0", 4) + std::string(40, 'x'), "JPEG"},
      {"wide.png", png_bytes(kMaxTextureSide + 1, 1,
                             [](int, int) { return std::array<uint8_t, 3>{1, 2, 3}; }),
       "larger than the limit"},
  };
  for (const Case& c : cases) {
    DYNAMIC_SECTION(c.name) {
      write_text(tmp / c.name, c.bytes);
      write_text(tmp / "b.mtl", "newmtl floor\nKd 1 1 1\nmap_Kd " + std::string(c.name) + "\n" +
                                    light_mtl());
      write_text(tmp / "b.obj", floor_obj("b.mtl"));
      const test::ToolRun r =
          test::run_tool("scene-bake", q(tmp / "b.obj") + " -o " + q(tmp / "s.h5"), tmp);
      INFO(r.err);
      CHECK(r.exit_code == 2);
      CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
      CHECK(r.err.find(c.name) != std::string::npos);
      CHECK(r.err.find(c.says) != std::string::npos);
      CHECK(!std::filesystem::exists(tmp / "s.h5"));
      CHECK(test::temporary_files(tmp.dir).empty());
    }
  }
}

TEST_CASE("decode_texture_image: RGBA8 as stored, the size limits before decoding", "[textures]") {
  const std::string png = png_bytes(3, 2, [](int x, int y) {
    return std::array<uint8_t, 3>{uint8_t(10 * x), uint8_t(100 + y), 7};
  });
  const DecodedImage img = decode_texture_image(png, "t.png", 16, 100);
  REQUIRE(img.width == 3);
  REQUIRE(img.height == 2);
  CHECK(img.rgba8[4 * (1 * 3 + 2)] == 20);
  CHECK(img.rgba8[4 * (1 * 3 + 2) + 1] == 101);
  CHECK(img.rgba8[4 * (1 * 3 + 2) + 3] == 255);
  CHECK_THROWS_AS(decode_texture_image(png, "t.png", 2, 100), InputError);   // a side
  CHECK_THROWS_AS(decode_texture_image(png, "t.png", 16, 5), InputError);    // the texel budget
  CHECK_NOTHROW(decode_texture_image(png, "t.png", 3, 6));
}

TEST_CASE("OpenCL: the device tracers shade with the texture as the CPU does",
          "[textures][opencl]") {
  auto dev = test::test_device();
  if (!dev) return;
  // The checker on the large floor under the reflecting ceiling: eye samples land on both kinds
  // of square, photons bounce off them and the ceiling.
  test::TempDir tmp("tex-cl");
  write_text(tmp / "checker.png", checker_png());
  write_text(tmp / "t.mtl", "newmtl floor\nKd 1 0.5 1\nmap_Kd checker.png\n" + light_mtl("0.5 0.5 0.5"));
  write_text(tmp / "t.obj", big_floor_obj("t.mtl"));
  const Scene scene = bake(floor_options(tmp / "t.obj", 32));
  REQUIRE(scene.textures.size() == 1);
  const float tol = 1e-4f * length(scene.bounds.extent());

  EyePassOptions eo;
  eo.spp = 2;
  eo.direct = DirectMode::ShadowRays;
  eo.seed = 5;
  const EyePassResult cpu = trace_hitpoints(scene, eo);
  const EyePassResult gpu = trace_hitpoints(scene, eo, *dev);
  REQUIRE(cpu.hitpoints.size() == size_t(32 * 32 * 2));
  REQUIRE(gpu.hitpoints.size() == cpu.hitpoints.size());
  size_t same = 0, dark = 0;
  for (size_t i = 0; i < cpu.hitpoints.size(); ++i) {
    const pf_hitpoint &a = cpu.hitpoints[i], &b = gpu.hitpoints[i];
    bool ok = a.pixel_x == b.pixel_x && a.pixel_y == b.pixel_y;
    for (int c = 0; c < 3; ++c)
      ok = ok && std::fabs(a.position[c] - b.position[c]) <= tol &&
           std::fabs(a.weight[c] - b.weight[c]) <= 1e-5f * a.weight[c] + 1e-9f;
    same += ok;
    dark += a.weight[0] < 0.1f * (0.5f / float(eo.spp));  // a dark square's texel in the weight
  }
  CHECK(same >= cpu.hitpoints.size() * 999 / 1000);
  CHECK(dark > cpu.hitpoints.size() / 4);
  REQUIRE(test::sum_squares(cpu.direct) > 0);
  CHECK(test::relative_rmse(gpu.direct, cpu.direct) <= 1e-3);

  PhotonPassOptions po;
  po.photons = 20000;
  po.seed = 3;
  const PhotonPassResult pc = trace_photons(scene, 1, po);
  const PhotonPassResult pg = trace_photons(scene, 1, po, *dev);
  REQUIRE(pc.photons.size() > 20000);  // bounces stored too
  // In emission order, aligned greedily past paths that diverged at a Russian-roulette threshold.
  auto same_photon = [&](const pf_photon& a, const pf_photon& b) {
    for (int c = 0; c < 3; ++c)
      if (std::fabs(a.position[c] - b.position[c]) > tol ||
          std::fabs(a.flux[c] - b.flux[c]) > 1e-3f * std::fabs(a.flux[c]) + 1e-9f)
        return false;
    return a.flags == b.flags;
  };
  size_t matched = 0, i = 0, j = 0;
  while (i < pc.photons.size() && j < pg.photons.size()) {
    if (same_photon(pc.photons[i], pg.photons[j])) {
      ++matched, ++i, ++j;
      continue;
    }
    bool found = false;
    for (size_t step = 1; step < 32 && !found; ++step)
      for (size_t di = 0; di <= step && !found; ++di)
        if (i + di < pc.photons.size() && j + step - di < pg.photons.size() &&
            same_photon(pc.photons[i + di], pg.photons[j + step - di])) {
          i += di;
          j += step - di;
          found = true;
        }
    if (!found) ++i, ++j;
  }
  INFO("photons agreeing: " << matched << " of " << pc.photons.size() << " (opencl "
                            << pg.photons.size() << ")");
  CHECK(matched >= pc.photons.size() * 99 / 100);
  // As many stored (the alignment above matches a prefix-wise subsequence; a device whose bounces
  // survive more often stores more).
  CHECK(std::fabs(double(pg.photons.size()) - double(pc.photons.size())) <=
        0.01 * double(pc.photons.size()));
}
