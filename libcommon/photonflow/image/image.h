// image.h — the rendered image: linear float RGB plus named scalar AOV layers (e.g. "radius",
// "photons", "hitpoints"), written as OpenEXR (the result, lossless) and as an 8-bit sRGB PNG
// preview with an exposure setting.
//
// Pixel (x, y) is column x, row y, row 0 at the top (the camera's +y points down, pf_camera).
// Both writers write "<path>.tmp.<pid>" and rename it, so a killed stage never leaves a file that
// looks complete. I/O failures are pf::InputError lines naming the file.
#pragma once
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "photonflow/foundations/vec.h"

namespace pf {

struct Image {
  int width = 0;
  int height = 0;
  std::vector<float> rgb;                            // 3 floats per pixel, row-major
  std::map<std::string, std::vector<float>> layers;  // 1 float per pixel per AOV, by name

  Image() = default;
  Image(int w, int h);  // black, no layers; w, h >= 0

  size_t pixel_count() const { return static_cast<size_t>(width) * static_cast<size_t>(height); }
  size_t offset(int x, int y) const {
    return static_cast<size_t>(y) * static_cast<size_t>(width) + static_cast<size_t>(x);
  }
  Vec3 get(int x, int y) const { return Vec3(&rgb[3 * offset(x, y)]); }
  void set(int x, int y, const Vec3& c) { c.store(&rgb[3 * offset(x, y)]); }
  void add(int x, int y, const Vec3& c) {
    float* p = &rgb[3 * offset(x, y)];
    p[0] += c.x;
    p[1] += c.y;
    p[2] += c.z;
  }
  // The AOV layer `name`, created zero-filled if absent. Names must be non-empty and not "R", "G"
  // or "B" (std::invalid_argument); a name "layer.channel" follows the EXR layer convention.
  std::vector<float>& layer(const std::string& name);
};

// Writes RGB as EXR channels R, G, B and each layer as a channel of its name, all 32-bit float,
// ZIP-compressed (lossless: floats read back bit-exact). The image must not be empty.
void write_exr(const Image& img, const std::string& path);

// Reads an EXR written by write_exr (or any scanline EXR with R, G, B channels): R, G, B become
// rgb, every other channel a layer; half channels are converted to float.
Image read_exr(const std::string& path);

// sRGB transfer function (IEC 61966-2-1) of a linear value in [0, 1]:
// 12.92·v for v <= 0.0031308, else 1.055·v^(1/2.4) − 0.055.
float srgb_encode(float linear);

// Linear RGB → 8-bit sRGB, 3 bytes per pixel: each channel is scaled by 2^exposure_stops, clamped
// to [0, 1] (NaN → 0), sRGB-encoded and rounded to the nearest of 0..255.
std::vector<uint8_t> to_srgb8(const Image& img, float exposure_stops);

// A complete PNG file (8-bit RGB, no interlace) of w×h pixels from `rgb8` (3·w·h bytes), written
// by libpng (zlib level 1, Sub filter on every row: image.cpp). std::invalid_argument if the sizes
// do not match.
std::vector<uint8_t> encode_png(int w, int h, const std::vector<uint8_t>& rgb8);

// Writes the sRGB preview PNG of img's RGB (to_srgb8 then encode_png).
void write_png(const Image& img, const std::string& path, float exposure_stops = 0.f);

// Decodes a PNG file's bytes into an RGB image with values in [0, 1] through libpng: grey of 1 to
// 16 bits, grey + alpha, RGB, RGBA (8 or 16 bits) and palette images, non-interlaced or Adam7;
// alpha and transparency ignored; a sample v of n bits becomes v / (2^n − 1). At most 65536
// pixels a side. Anything libpng refuses (damaged chunks or image data, a cut file) and palette
// indices past the palette are one-line InputErrors naming `name`. Reads masks (image_metrics.h).
Image decode_png(const std::string& bytes, const std::string& name);

}  // namespace pf
