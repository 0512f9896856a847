// Tests of image.h: EXR round trip (bit-exact floats and layers), the sRGB transfer function and
// the preview mapping, and the PNG writer (libpng) checked by chunk checks written here
// (signature, IHDR, chunk CRCs) and by libpng's simplified reading API (pixels).
#include <catch2/catch.hpp>

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfOutputFile.h>
#include <png.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <string>
#include <vector>

#include "photonflow/foundations/error.h"
#include "photonflow/image/image.h"
#include "photonflow/foundations/rng.h"

using namespace pf;
namespace fs = std::filesystem;

namespace {

fs::path scratch_dir() {
  fs::path d = fs::path(PF_BINARY_DIR) / "test_scratch" / "image";
  fs::create_directories(d);
  return d;
}

std::vector<uint8_t> read_file(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  return std::vector<uint8_t>(std::istreambuf_iterator<char>(f), {});
}

// Bitwise CRC-32 (reflected 0xEDB88320), deliberately not table-driven like the encoder's.
uint32_t crc32_bitwise(const uint8_t* p, size_t n) {
  uint32_t c = 0xFFFFFFFFu;
  for (size_t i = 0; i < n; ++i) {
    c ^= p[i];
    for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0xEDB88320u & (0u - (c & 1u)));
  }
  return ~c;
}

uint32_t be32(const uint8_t* p) {
  return (uint32_t(p[0]) << 24) | (uint32_t(p[1]) << 16) | (uint32_t(p[2]) << 8) | p[3];
}

// A preview PNG: its chunks checked here (signature, CRC-32 of every chunk, IHDR first with 8-bit
// RGB, no interlace, IEND last), its pixels decoded by libpng's simplified API (png_image), not by
// photonflow's decode_png.
struct DecodedPng {
  uint32_t width = 0, height = 0;
  std::vector<uint8_t> rgb;
};

DecodedPng decode_preview_png(const std::vector<uint8_t>& f) {
  DecodedPng out;
  const uint8_t sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  REQUIRE(f.size() > 8);
  REQUIRE(std::memcmp(f.data(), sig, 8) == 0);
  size_t pos = 8;
  std::vector<std::string> types;
  while (pos < f.size()) {
    REQUIRE(pos + 12 <= f.size());
    uint32_t len = be32(&f[pos]);
    REQUIRE(pos + 12 + len <= f.size());
    std::string type(reinterpret_cast<const char*>(&f[pos + 4]), 4);
    INFO("chunk " << type);
    CHECK(be32(&f[pos + 8 + len]) == crc32_bitwise(&f[pos + 4], 4 + len));
    const uint8_t* data = &f[pos + 8];
    if (type == "IHDR") {
      REQUIRE(len == 13);
      out.width = be32(data);
      out.height = be32(data + 4);
      CHECK(data[8] == 8);   // bit depth
      CHECK(data[9] == 2);   // truecolour RGB
      CHECK(data[10] == 0);  // deflate
      CHECK(data[11] == 0);  // filter method 0
      CHECK(data[12] == 0);  // no interlace
    }
    types.push_back(type);
    pos += 12 + len;
  }
  REQUIRE(types.size() >= 3);
  CHECK(types.front() == "IHDR");
  CHECK(types.back() == "IEND");

  png_image im;
  std::memset(&im, 0, sizeof im);
  im.version = PNG_IMAGE_VERSION;
  REQUIRE(png_image_begin_read_from_memory(&im, f.data(), f.size()) != 0);
  CHECK(im.width == out.width);
  CHECK(im.height == out.height);
  im.format = PNG_FORMAT_RGB;  // 8-bit sRGB in, 8-bit sRGB out: no conversion
  out.rgb.resize(PNG_IMAGE_SIZE(im));
  REQUIRE(png_image_finish_read(&im, nullptr, out.rgb.data(), 0, nullptr) != 0);
  return out;
}

}  // namespace

TEST_CASE("image: pixel access and layers", "[image]") {
  Image img(4, 3);
  CHECK(img.rgb.size() == 36);
  img.set(3, 2, Vec3(1, 2, 3));
  img.add(3, 2, Vec3(1, 1, 1));
  Vec3 c = img.get(3, 2);
  CHECK((c.x == 2 && c.y == 3 && c.z == 4));
  CHECK(img.rgb[3 * (2 * 4 + 3)] == 2.f);  // row-major, row 0 at the top
  std::vector<float>& r = img.layer("radius");
  CHECK(r.size() == 12);
  r[5] = 7.f;
  CHECK(img.layer("radius")[5] == 7.f);  // the same layer, not a new one
  CHECK_THROWS_AS(img.layer("G"), std::invalid_argument);
  CHECK_THROWS_AS(img.layer(""), std::invalid_argument);
}

TEST_CASE("image: EXR round trip is bit-exact with layers", "[image]") {
  const int w = 37, h = 23;
  Image img(w, h);
  for (size_t i = 0; i < img.rgb.size(); ++i) {
    float u = pf_rng_float(1, 0, static_cast<pf_uint>(i), 0);
    img.rgb[i] = (u - 0.25f) * std::pow(10.f, 8.f * pf_rng_float(1, 0, i, 1) - 4.f);
  }
  img.rgb[0] = std::numeric_limits<float>::denorm_min();
  img.rgb[1] = std::numeric_limits<float>::max();
  img.rgb[2] = -0.f;
  std::vector<float>& radius = img.layer("radius");
  std::vector<float>& photons = img.layer("photons");
  std::vector<float>& hitpoints = img.layer("hitpoints");
  std::vector<float>& nx = img.layer("normal.X");
  for (size_t i = 0; i < img.pixel_count(); ++i) {
    radius[i] = 0.01f + pf_rng_float(2, 0, i, 0);
    photons[i] = static_cast<float>(i * 3);
    hitpoints[i] = static_cast<float>(i % 2);
    nx[i] = -pf_rng_float(2, 0, i, 1);
  }
  fs::path path = scratch_dir() / "roundtrip.exr";
  fs::remove(path);
  write_exr(img, path.string());
  REQUIRE(fs::exists(path));
  // No temporary file left beside it.
  int others = 0;
  for (const auto& e : fs::directory_iterator(scratch_dir()))
    others += e.path().filename().string().find("roundtrip.exr.tmp") != std::string::npos;
  CHECK(others == 0);

  Image back = read_exr(path.string());
  REQUIRE(back.width == w);
  REQUIRE(back.height == h);
  CHECK(std::memcmp(back.rgb.data(), img.rgb.data(), img.rgb.size() * sizeof(float)) == 0);
  REQUIRE(back.layers.size() == 4);
  for (const auto& [name, data] : img.layers) {
    INFO("layer " << name);
    REQUIRE(back.layers.count(name) == 1);
    CHECK(std::memcmp(back.layers[name].data(), data.data(), data.size() * sizeof(float)) == 0);
  }
}

TEST_CASE("image: an EXR from elsewhere: half channels, a data window not at the origin",
          "[image]") {
  // Written here with the OpenEXR API as another program would: display window 0..31 × 0..19,
  // data window (5, 7)..(9, 10), so 5 × 4 pixels; R, G, B and a layer "Z" as half floats with
  // values that half represents exactly. read_exr keeps the data window (row y of the image is
  // row 7 + y of the file) and converts half to float.
  const int x0 = 5, y0 = 7, w = 5, h = 4;
  auto value = [](int x, int y, int c) { return 0.125f * float(x + 8 * y + 64 * c) - 4.f; };
  std::vector<half> rgb(size_t(w) * h * 3), z(size_t(w) * h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      for (int c = 0; c < 3; ++c) rgb[3 * (size_t(y) * w + x) + c] = half(value(x, y, c));
      z[size_t(y) * w + x] = half(value(x, y, 3));
    }
  fs::path path = scratch_dir() / "foreign.exr";
  {
    Imath::Box2i display({0, 0}, {31, 19}), data({x0, y0}, {x0 + w - 1, y0 + h - 1});
    Imf::Header header(display, data);
    Imf::FrameBuffer fb;
    const char* names[3] = {"R", "G", "B"};
    const size_t hs = sizeof(half);
    // Slice base pointers for a data window off the origin: pointer of pixel (0, 0).
    char* base = reinterpret_cast<char*>(rgb.data()) - (ptrdiff_t(x0) + ptrdiff_t(y0) * w) * 3 * hs;
    for (int c = 0; c < 3; ++c) {
      header.channels().insert(names[c], Imf::Channel(Imf::HALF));
      fb.insert(names[c], Imf::Slice(Imf::HALF, base + c * hs, 3 * hs, 3 * hs * w));
    }
    char* zbase = reinterpret_cast<char*>(z.data()) - (ptrdiff_t(x0) + ptrdiff_t(y0) * w) * hs;
    header.channels().insert("Z", Imf::Channel(Imf::HALF));
    fb.insert("Z", Imf::Slice(Imf::HALF, zbase, hs, hs * w));
    Imf::OutputFile out(path.string().c_str(), header);
    out.setFrameBuffer(fb);
    out.writePixels(h);
  }
  Image img = read_exr(path.string());
  REQUIRE(img.width == w);
  REQUIRE(img.height == h);
  REQUIRE(img.layers.count("Z") == 1);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      INFO("pixel " << x << "," << y);
      const Vec3 c = img.get(x, y);
      CHECK(c.x == value(x, y, 0));
      CHECK(c.y == value(x, y, 1));
      CHECK(c.z == value(x, y, 2));
      CHECK(img.layers["Z"][size_t(y) * w + x] == value(x, y, 3));
    }
}

TEST_CASE("image: EXR errors are one-line input errors", "[image]") {
  fs::path missing = scratch_dir() / "does_not_exist.exr";
  CHECK_THROWS_AS(read_exr(missing.string()), InputError);
  fs::path not_exr = scratch_dir() / "not_an.exr";
  std::ofstream(not_exr) << "hello";
  CHECK_THROWS_AS(read_exr(not_exr.string()), InputError);
  Image img(2, 2);
  CHECK_THROWS_AS(write_exr(img, (scratch_dir() / "no_dir" / "x.exr").string()), InputError);
  CHECK_THROWS_AS(write_exr(Image(), (scratch_dir() / "empty.exr").string()),
                  std::invalid_argument);
}

TEST_CASE("image: sRGB transfer function", "[image]") {
  CHECK(srgb_encode(0.f) == 0.f);
  CHECK(srgb_encode(1.f) == Approx(1.f).epsilon(1e-6));
  // The two branches meet at the breakpoint 0.0031308 (value 0.0404500).
  const float bp = 0.0031308f;
  CHECK(srgb_encode(bp) == Approx(12.92f * bp));
  CHECK(srgb_encode(bp) == Approx(0.04045f).epsilon(1e-4));
  CHECK(srgb_encode(std::nextafter(bp, 1.f)) == Approx(1.055f * std::pow(bp, 1.f / 2.4f) - 0.055f)
                                                    .epsilon(1e-4));
  CHECK(srgb_encode(0.5f) == Approx(0.735357f).epsilon(1e-5));
  CHECK(srgb_encode(0.18f) == Approx(0.461356f).epsilon(1e-5));
  // Monotone over [0, 1].
  float prev = -1.f;
  bool monotone = true;
  for (int i = 0; i <= 10000; ++i) {
    float s = srgb_encode(i / 10000.f);
    monotone &= s > prev;
    prev = s;
  }
  CHECK(monotone);
}

TEST_CASE("image: 8-bit preview applies exposure, clamping and rounding", "[image]") {
  Image img(6, 1);
  img.set(0, 0, Vec3(0.f, 1.f, 0.18f));
  img.set(1, 0, Vec3(0.09f, 0.5f, 2.f));
  img.set(2, 0, Vec3(-1.f, NAN, INFINITY));
  img.set(3, 0, Vec3(0.0031308f, 0.001f, 1e-9f));
  std::vector<uint8_t> v = to_srgb8(img, 0.f);
  CHECK(v[0] == 0);
  CHECK(v[1] == 255);
  CHECK(v[2] == 118);  // 0.461356·255 = 117.6
  CHECK(v[3] == 85);   // 0.09 → 0.331843·255 = 84.6
  CHECK(v[4] == 188);  // 0.735357·255 = 187.5 → 188
  CHECK(v[5] == 255);  // clamped
  CHECK(v[6] == 0);    // negative → 0
  CHECK(v[7] == 0);    // NaN → 0
  CHECK(v[8] == 255);  // +inf → 1
  CHECK(v[9] == 10);   // 0.04045·255 = 10.3
  CHECK(v[10] == 3);   // 0.01292·255 = 3.3
  CHECK(v[11] == 0);
  // +1 stop doubles the linear value: 0.09 → 0.18.
  std::vector<uint8_t> up = to_srgb8(img, 1.f);
  CHECK(up[3] == 118);
  // −1 stop halves it: 1 → 0.5.
  std::vector<uint8_t> down = to_srgb8(img, -1.f);
  CHECK(down[1] == 188);
}

TEST_CASE("image: PNG decodes to the preview pixels", "[image]") {
  const int w = 200, h = 120;
  Image img(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      img.set(x, y, Vec3(x / float(w - 1), y / float(h - 1), pf_rng_float(3, 0, x + y * w, 0)));
  fs::path path = scratch_dir() / "preview.png";
  write_png(img, path.string(), 0.f);
  DecodedPng png = decode_preview_png(read_file(path));
  CHECK(png.width == static_cast<uint32_t>(w));
  CHECK(png.height == static_cast<uint32_t>(h));
  CHECK(png.rgb == to_srgb8(img, 0.f));
  // Corners: top-left black red/green, bottom-right full red and green.
  CHECK(png.rgb[0] == 0);
  CHECK(png.rgb[1] == 0);
  size_t last = 3 * (size_t(w) * h - 1);
  CHECK(png.rgb[last] == 255);
  CHECK(png.rgb[last + 1] == 255);
  // photonflow's own decoder reads the same pixels.
  const std::vector<uint8_t> bytes = read_file(path);
  Image back = decode_png(std::string(bytes.begin(), bytes.end()), "preview.png");
  for (size_t i = 0; i < png.rgb.size(); ++i) REQUIRE(back.rgb[i] == float(png.rgb[i] / 255.0));

  // A 1×1 image.
  DecodedPng tiny = decode_preview_png(encode_png(1, 1, {10, 20, 30}));
  CHECK(tiny.rgb == std::vector<uint8_t>{10, 20, 30});
  CHECK_THROWS_AS(encode_png(2, 2, {1, 2, 3}), std::invalid_argument);
}

TEST_CASE("image: the preview PNG is compressed", "[image]") {
  // A smooth 1920×1080 gradient: 6.2 MB of pixels, a small fraction of that as PNG (the stored
  // deflate blocks of the encoder before libpng wrote every byte: 6.2 MB).
  const int w = 1920, h = 1080;
  Image img(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) img.set(x, y, Vec3(x / float(w), y / float(h), 0.25f));
  const std::vector<uint8_t> png = encode_png(w, h, to_srgb8(img, 0.f));
  CHECK(png.size() < size_t(w) * h * 3 / 10);
  CHECK(decode_preview_png(png).rgb == to_srgb8(img, 0.f));
}
