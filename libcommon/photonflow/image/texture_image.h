// texture_image.h — decoding the image files of textures (PNG through libpng's simplified API,
// JPEG through libjpeg-turbo; docs/DEPENDENCIES.md) into 8-bit RGBA, with a size limit checked
// from the file's header before any pixel is decoded. scene-bake (material_import.cpp) turns the
// result into linear texels (texture_shared.h's sRGB decode).
#pragma once
#include <cstdint>
#include <string>
#include <vector>

namespace pf {

struct DecodedImage {
  int width = 0, height = 0;
  std::vector<uint8_t> rgba8;  // width × height × 4, row 0 = the top row of the file
};

// The image of a PNG or JPEG file's bytes (told apart by their signatures). InputError, one line
// naming `name`, for another format, a damaged or cut file (libpng's or libjpeg's reason), or a
// side larger than `max_side` or more than `max_texels` pixels (refused before decoding).
DecodedImage decode_texture_image(const std::string& bytes, const std::string& name, int max_side,
                                  uint64_t max_texels);

// The width and height a PNG or JPEG file's header gives (PNG: the IHDR chunk; JPEG: the frame
// header jpeg_read_header reaches), without decoding a pixel; false when `bytes` (the file, or
// its first part) holds no such header. The texel budget is charged from it before any image is
// decoded.
bool texture_image_size(const std::string& bytes, uint64_t& width, uint64_t& height);

}  // namespace pf
