// The files a scene references (issue 47, items 3, 5 and 6; scene_inputs.h): each is a regular
// file or the bake is refused at once, naming it; a texture that cannot be read is an error unless
// --missing-textures warn; the texel budget names the image that takes it, from the headers,
// before any image is decoded; --confine-inputs keeps every file inside the scene's folder; and
// no error line tells the size or contents of a file outside the folder. The hostile folders are
// made here, at test time: FIFOs, /dev/zero, directories, symlink loops, symlinks and ../ paths out
// of the folder. Every tool run has a time limit, so a bake that hangs fails instead of blocking.
#include <catch2/catch.hpp>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>
#include <string>
#include <vector>

#include "photonflow/image/image.h"
#include "gltf_builder.h"
#include "support.h"

using nlohmann::json;
namespace fs = std::filesystem;

using namespace pf::test::gltf;  // q, write_text, base64 (gltf_builder.h)

namespace {

constexpr int kSeconds = 20;  // far above a refusal's time; a hang is killed and fails

void write_bytes(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary) << bytes;
}

std::string png_of(int w, int h) {
  std::vector<uint8_t> rgb(size_t(w) * size_t(h) * 3, 128);
  const std::vector<uint8_t> png = pf::encode_png(w, h, rgb);
  return std::string(png.begin(), png.end());
}

uint32_t crc32_of(const std::string& s) {
  uint32_t c = 0xffffffffu;
  for (unsigned char b : s) {
    c ^= b;
    for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0xedb88320u & (0u - (c & 1u)));
  }
  return ~c;
}

// A PNG whose header (IHDR, with a valid CRC) claims w × h pixels, its data that of a 2×2 image:
// what a header check must see before a decoder reads a byte of pixels.
std::string png_claiming(uint32_t w, uint32_t h) {
  std::string png = png_of(2, 2);
  auto put32 = [&png](size_t at, uint32_t v) {
    for (int k = 0; k < 4; ++k) png[at + size_t(k)] = char((v >> (24 - 8 * k)) & 0xff);
  };
  put32(16, w);
  put32(20, h);
  put32(29, crc32_of(png.substr(12, 17)));  // over "IHDR" and its 13 bytes
  return png;
}

// A glTF 2.0 file: one triangle per image, material k with baseColorTexture k (image k = `uris[k]`,
// a file name or a data: URI; a json object replaces the whole image entry), and an emitting
// triangle. The geometry buffer is `buffer_uri` (the file "geometry.bin" is written beside it
// unless the name is given) or a data: URI when empty.
std::string write_gltf(const std::string& dir, const std::vector<json>& images,
                       const std::string& buffer_uri = "", const std::string& name = "s.gltf") {
  const size_t n = images.size() + 1;
  pf::test::gltf::TriangleRows rows = pf::test::gltf::triangle_rows(n);
  std::string& bin = rows.bin;
  const size_t uv_offset = rows.uv_offset;
  json g = pf::test::gltf::document_head();
  json mats = json::array(), meshes = json::array(), nodes = json::array(),
       accessors = json::array(), views = json::array(), imgs = json::array(),
       texs = json::array();
  for (size_t k = 0; k < n; ++k) {
    const bool light = k + 1 == n;
    json m = {{"name", light ? std::string("light") : "m" + std::to_string(k)},
              {"pbrMetallicRoughness", {{"baseColorFactor", {0.5, 0.5, 0.5, 1}}, {"metallicFactor", 0}}}};
    if (light) m["emissiveFactor"] = {1, 1, 1};
    else m["pbrMetallicRoughness"]["baseColorTexture"] = {{"index", k}};
    mats.push_back(m);
    views.push_back({{"buffer", 0}, {"byteOffset", 36 * k}, {"byteLength", 36}});
    accessors.push_back({{"bufferView", k}, {"componentType", 5126}, {"count", 3},
                         {"type", "VEC3"}, {"min", {-100, -100, -100}}, {"max", {100, 100, 100}}});
    meshes.push_back({{"primitives", json::array({{{"attributes", {{"POSITION", k}, {"TEXCOORD_0", n}}},
                                                   {"material", k}}})}});
    nodes.push_back({{"mesh", k}});
    g["scenes"][0]["nodes"].push_back(k);
    if (!light) {
      imgs.push_back(images[k].is_string() ? json{{"uri", images[k]}} : images[k]);
      texs.push_back({{"source", k}});
    }
  }
  pf::test::gltf::put_arrays(g, mats, meshes, nodes, accessors, views, uv_offset, n);
  if (!imgs.empty()) {
    g["images"] = imgs;
    g["textures"] = texs;
  }
  std::string uri = "data:application/octet-stream;base64," + base64(bin);
  if (!buffer_uri.empty()) {
    uri = buffer_uri;
    if (buffer_uri == "geometry.bin") write_bytes(dir + "/geometry.bin", bin);
  }
  g["buffers"] = json::array({{{"byteLength", bin.size()}, {"uri", uri}}});
  const std::string path = dir + "/" + name;
  write_bytes(path, g.dump(1));
  return path;
}

// scene-bake of `scene` (with `extra` options) must be refused: exit 2, one line that names
// `culprit`, no output file, within kSeconds.
void refused(const pf::test::TempDir& tmp, const std::string& scene, const std::string& culprit,
             const std::string& extra = "", const std::string& also = "") {
  const std::string out = tmp / "out.h5";
  const pf::test::ToolRun r =
      pf::test::run_tool("scene-bake", q(scene) + " -o " + q(out) + " " + extra, tmp, "", kSeconds);
  INFO("culprit " << culprit << "; stderr: " << r.err);
  CHECK(r.exit_code == 2);
  CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
  CHECK(r.err.find(culprit) != std::string::npos);
  if (!also.empty()) CHECK(r.err.find(also) != std::string::npos);
  CHECK_FALSE(fs::exists(out));
}

pf::test::ToolRun bake_ok(const pf::test::TempDir& tmp, const std::string& scene,
                          const std::string& extra = "") {
  const std::string out = tmp / "ok.h5";
  fs::remove(out);
  pf::test::ToolRun r =
      pf::test::run_tool("scene-bake", q(scene) + " -o " + q(out) + " " + extra, tmp, "", kSeconds);
  INFO(r.err);
  CHECK(r.exit_code == 0);
  CHECK(fs::exists(out));
  return r;
}

}  // namespace

TEST_CASE("scene inputs: a FIFO, device, directory or symlink loop is refused at once, named",
          "[scene-inputs][tools]") {
  pf::test::TempDir tmp("scene-inputs-special");
  const std::string dir = tmp.dir.string();
  write_bytes(tmp / "t.png", png_of(4, 4));
  SECTION("a FIFO glTF buffer") {
    REQUIRE(mkfifo((tmp / "geo.bin").c_str(), 0600) == 0);
    refused(tmp, write_gltf(dir, {"t.png"}, "geo.bin"), "geo.bin", "", "FIFO");
    // render --scene bakes the same way.
    const pf::test::ToolRun r = pf::test::run_tool(
        "render", "--scene " + q(tmp / "s.gltf") + " -o " + q(tmp / "r.exr") + " --passes 1",
        tmp, "", kSeconds);
    INFO(r.err);
    CHECK(r.exit_code == 2);
    CHECK(r.err.find("geo.bin") != std::string::npos);
    CHECK_FALSE(fs::exists(tmp / "r.exr"));
  }
  SECTION("a FIFO texture") {
    REQUIRE(mkfifo((tmp / "f.png").c_str(), 0600) == 0);
    refused(tmp, write_gltf(dir, {"t.png", "f.png"}), "f.png", "", "FIFO");
    // ... also when missing textures only warn: it is not missing.
    refused(tmp, tmp / "s.gltf", "f.png", "--missing-textures warn");
  }
  SECTION("/dev/zero as a texture") {
    refused(tmp, write_gltf(dir, {"/dev/zero"}), "/dev/zero", "", "device");
  }
  SECTION("a directory as a texture") {
    fs::create_directory(tmp / "d.png");
    refused(tmp, write_gltf(dir, {"d.png"}), "d.png", "", "directory");
  }
  SECTION("a symlink loop as a texture") {
    fs::create_symlink("loop-b.png", tmp / "loop-a.png");
    fs::create_symlink("loop-a.png", tmp / "loop-b.png");
    refused(tmp, write_gltf(dir, {"loop-a.png"}), "loop-a.png", "", "loop");
  }
  SECTION("an OBJ whose material library is a FIFO") {
    REQUIRE(mkfifo((tmp / "m.mtl").c_str(), 0600) == 0);
    write_bytes(tmp / "s.obj", "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    refused(tmp, tmp / "s.obj", "m.mtl", "", "FIFO");
  }
  SECTION("an inserted mesh that is a FIFO") {
    REQUIRE(mkfifo((tmp / "ins.obj").c_str(), 0600) == 0);
    refused(tmp, write_gltf(dir, {"t.png"}), "ins.obj", "--insert " + q(tmp / "ins.obj"));
  }
  SECTION("the plain scene bakes") { bake_ok(tmp, write_gltf(dir, {"t.png"}, "geometry.bin")); }
}

TEST_CASE("scene inputs: a texture that cannot be read is an error unless --missing-textures warn",
          "[scene-inputs][tools]") {
  pf::test::TempDir tmp("scene-inputs-missing");
  const std::string dir = tmp.dir.string();
  write_bytes(tmp / "t.png", png_of(4, 4));
  const std::vector<std::pair<std::string, json>> cases = {
      {"gone.png", "gone.png"},
      {"dangling.png", "dangling.png"},
      {"URI is empty", ""},
      {"data: URI", "data:image/png,not-base64"},
      {"no image source", json::object()},
      {"bufferView is empty", json{{"bufferView", 99}, {"mimeType", "image/png"}}},
  };
  fs::create_symlink("nowhere.png", tmp / "dangling.png");
  for (const auto& [needle, image] : cases) {
    INFO("case " << needle);
    std::string scene = write_gltf(dir, {"t.png", image});
    if (needle == "no image source") {  // a texture without "source"
      json g = json::parse(pf::test::file_bytes(scene));
      g["textures"][1].erase("source");
      write_bytes(scene, g.dump());
    }
    if (needle == "bufferView is empty") {
      json g = json::parse(pf::test::file_bytes(scene));
      g["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", 0}, {"byteLength", 0}});
      g["images"][1]["bufferView"] = g["bufferViews"].size() - 1;
      write_bytes(scene, g.dump());
    }
    const std::string culprit = needle == "no image source" || needle == "bufferView is empty" ||
                                        needle == "URI is empty" || needle == "data: URI"
                                    ? "m1"
                                    : needle;
    refused(tmp, scene, culprit, "", needle == "dangling.png" || needle == "gone.png" ? "" : needle);
    const pf::test::ToolRun r = bake_ok(tmp, scene, "--missing-textures warn");
    CHECK(r.err.find("warning") != std::string::npos);
  }
  // An unknown choice is refused.
  refused(tmp, write_gltf(dir, {"t.png"}), "--missing-textures", "--missing-textures maybe");
}

TEST_CASE("scene inputs: the texel budget names the image that takes it, before decoding",
          "[scene-inputs][tools]") {
  pf::test::TempDir tmp("scene-inputs-budget");
  const std::string dir = tmp.dir.string();
  // 8192² texels are the whole budget (2^26): the small image after it passes the sum. The big
  // one's pixel data is not there: it must be refused from its header, not decoded.
  write_bytes(tmp / "big.png", png_claiming(8192, 8192));
  write_bytes(tmp / "small.png", png_of(128, 128));
  refused(tmp, write_gltf(dir, {"big.png", "small.png"}), "big.png", "", "texels");
  // One image over the budget on its own is named the same way.
  write_bytes(tmp / "huge.png", png_claiming(12000, 12000));
  refused(tmp, write_gltf(dir, {"small.png", "huge.png"}), "huge.png", "", "texels");
}

TEST_CASE("scene inputs: --confine-inputs keeps every file in the scene's folder",
          "[scene-inputs][tools]") {
  pf::test::TempDir tmp("scene-inputs-confine");
  const std::string dir = (tmp.dir / "scene").string();
  fs::create_directories(dir);
  write_bytes(tmp / "outside.png", png_of(4, 4));
  write_bytes(dir + "/t.png", png_of(4, 4));
  fs::create_symlink(tmp / "outside.png", dir + "/link.png");
  // ../ and a symlink out of the folder bake without the option ...
  for (const std::string& uri : {"../outside.png", "link.png"}) {
    INFO(uri);
    const std::string scene = write_gltf(dir, {"t.png", uri});
    bake_ok(tmp, scene);
    // ... and are refused with it, naming the file.
    refused(tmp, scene, uri, "--confine-inputs", "outside the scene's folder");
    // render --scene takes it too.
    const pf::test::ToolRun r = pf::test::run_tool(
        "render", "--scene " + q(scene) + " -o " + q(tmp / "r.exr") + " --passes 1 --confine-inputs",
        tmp, "", kSeconds);
    INFO(r.err);
    CHECK(r.exit_code == 2);
    CHECK(r.err.find(uri) != std::string::npos);
    CHECK_FALSE(fs::exists(tmp / "r.exr"));
  }
  // A buffer out of the folder, and an inserted mesh.
  write_bytes(tmp / "geometry.bin", "");
  const std::string scene = write_gltf(dir, {"t.png"}, "geometry.bin");
  fs::rename(dir + "/geometry.bin", tmp / "geometry.bin");
  json g = json::parse(pf::test::file_bytes(scene));
  g["buffers"][0]["uri"] = "../geometry.bin";
  write_bytes(scene, g.dump());
  bake_ok(tmp, scene);
  refused(tmp, scene, "../geometry.bin", "--confine-inputs");
  write_bytes(tmp / "ins.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  refused(tmp, write_gltf(dir, {"t.png"}, "", "plain.gltf"), "ins.obj",
          "--confine-inputs --insert " + q(tmp / "ins.obj"));
  // The scene's own files pass.
  bake_ok(tmp, dir + "/plain.gltf", "--confine-inputs");
}

TEST_CASE("scene inputs: an error line does not tell a foreign file's size or contents",
          "[scene-inputs][tools]") {
  pf::test::TempDir tmp("scene-inputs-disclose");
  const std::string dir = tmp.dir.string();
  // A file of known size and contents outside the folder, as /etc/passwd would be.
  pf::test::TempDir other("scene-inputs-secret");
  const std::string secret = "root:x:0:0:secret-line-of-the-file:/root:/bin/bash\n";
  write_bytes(other / "passwd", secret);
  const std::string size = std::to_string(secret.size());
  // The size as a number of its own, in the line with the folders' names (which hold a process
  // id whose digits may contain it) taken out.
  const auto tells_size = [&](std::string err) {
    for (const std::string& d : {other.dir.string(), dir})
      for (size_t at; (at = err.find(d)) != std::string::npos;) err.erase(at, d.size());
    return std::regex_search(err, std::regex("(^|[^0-9])" + size + "([^0-9]|$)"));
  };
  for (const std::string& extra : {std::string(), std::string("--missing-textures warn")}) {
    const std::string scene = write_gltf(dir, {other / "passwd"});
    const pf::test::ToolRun r =
        pf::test::run_tool("scene-bake", q(scene) + " -o " + q(tmp / "o.h5") + " " + extra, tmp,
                           "", kSeconds);
    INFO(r.err);
    CHECK(r.exit_code == 2);
    CHECK_FALSE(tells_size(r.err));
    CHECK(r.err.find("secret-line") == std::string::npos);
    // As a buffer (assimp's own message would tell the bytes it found).
    json g = json::parse(pf::test::file_bytes(scene));
    g["buffers"][0]["uri"] = other / "passwd";
    write_bytes(scene, g.dump());
    const pf::test::ToolRun b =
        pf::test::run_tool("scene-bake", q(scene) + " -o " + q(tmp / "o.h5") + " " + extra, tmp,
                           "", kSeconds);
    INFO(b.err);
    CHECK(b.exit_code == 2);
    CHECK_FALSE(tells_size(b.err));
    CHECK(b.err.find("secret-line") == std::string::npos);
    CHECK_FALSE(fs::exists(tmp / "o.h5"));
  }
}
