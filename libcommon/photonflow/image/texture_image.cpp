// Texture images: PNG by libpng's simplified API (png_image_*), JPEG by libjpeg-turbo
// (texture_image.h). Both libraries report errors by longjmp: the simplified API handles that
// inside libpng; for libjpeg every step that may fail is a function of plain data with its own
// setjmp (as image.cpp does for libpng), and the C++ caller owns the buffers.
#include "photonflow/image/texture_image.h"

#include <png.h>
#include <cstdio>  // jpeglib.h needs FILE and size_t first
#include <jpeglib.h>

#include <csetjmp>
#include <cstring>

#include "photonflow/foundations/error.h"

namespace pf {

namespace {

const char* kHint = "save the image again as PNG or JPEG";

void check_size(uint64_t w, uint64_t h, const std::string& name, int max_side,
                uint64_t max_texels) {
  if (w < 1 || h < 1 || w > uint64_t(max_side) || h > uint64_t(max_side) || w * h > max_texels)
    throw input_error(name, "texture image of " + std::to_string(w) + "x" + std::to_string(h) +
                                " pixels is larger than the limit of " +
                                std::to_string(max_side) + " a side and " +
                                std::to_string(max_texels) + " texels",
                      "scale the image down");
}

std::string one_line(const char* s) {
  std::string out = s ? s : "unknown error";
  for (char& c : out)
    if (static_cast<unsigned char>(c) < 0x20) c = ' ';
  return out;
}

DecodedImage decode_png_texture(const std::string& bytes, const std::string& name, int max_side,
                                uint64_t max_texels) {
  png_image img;
  std::memset(&img, 0, sizeof img);
  img.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_memory(&img, bytes.data(), bytes.size()))
    throw input_error(name, "is not a readable PNG: " + one_line(img.message), kHint);
  try {
    check_size(img.width, img.height, name, max_side, max_texels);
  } catch (...) {
    png_image_free(&img);
    throw;
  }
  img.format = PNG_FORMAT_RGBA;  // 8-bit sRGB, not premultiplied
  DecodedImage out;
  out.width = int(img.width);
  out.height = int(img.height);
  out.rgba8.resize(size_t(img.width) * img.height * 4);
  // A damaged or cut file fails here (png_image_finish_read frees the image either way).
  if (!png_image_finish_read(&img, nullptr, out.rgba8.data(), 0, nullptr))
    throw input_error(name, "has damaged PNG image data: " + one_line(img.message), kHint);
  return out;
}

// libjpeg's error manager: errors AND warnings (corrupt data that libjpeg would fill with grey)
// leave by longjmp with the message kept.
struct JpegError {
  jpeg_error_mgr mgr;
  std::jmp_buf jump;
  char message[JMSG_LENGTH_MAX];
};

void jpeg_on_error(j_common_ptr c) {
  auto* e = reinterpret_cast<JpegError*>(c->err);
  (*c->err->format_message)(c, e->message);
  std::longjmp(e->jump, 1);
}

void jpeg_on_message(j_common_ptr c, int level) {
  if (level < 0) jpeg_on_error(c);  // a warning: the data is damaged
}

struct JpegState {
  jpeg_decompress_struct info;
  JpegError err;
  bool created = false;
};

bool jpeg_header_step(JpegState* s, const unsigned char* data, unsigned long size) {
  if (setjmp(s->err.jump)) return false;
  jpeg_create_decompress(&s->info);
  s->created = true;
  jpeg_mem_src(&s->info, data, size);
  jpeg_read_header(&s->info, TRUE);
  return true;
}

bool jpeg_pixels_step(JpegState* s, unsigned char* out) {
  if (setjmp(s->err.jump)) return false;
  s->info.out_color_space = JCS_EXT_RGBA;
  jpeg_start_decompress(&s->info);
  const size_t stride = size_t(s->info.output_width) * 4;
  while (s->info.output_scanline < s->info.output_height) {
    JSAMPROW row = out + size_t(s->info.output_scanline) * stride;
    jpeg_read_scanlines(&s->info, &row, 1);
  }
  jpeg_finish_decompress(&s->info);
  return true;
}

DecodedImage decode_jpeg_texture(const std::string& bytes, const std::string& name, int max_side,
                                 uint64_t max_texels) {
  JpegState s;
  s.info.err = jpeg_std_error(&s.err.mgr);
  s.err.mgr.error_exit = jpeg_on_error;
  s.err.mgr.emit_message = jpeg_on_message;
  s.err.message[0] = 0;
  struct Guard {
    JpegState& s;
    ~Guard() {
      if (s.created) jpeg_destroy_decompress(&s.info);
    }
  } guard{s};
  const auto* data = reinterpret_cast<const unsigned char*>(bytes.data());
  if (!jpeg_header_step(&s, data, static_cast<unsigned long>(bytes.size())))
    throw input_error(name, "is not a readable JPEG: " + one_line(s.err.message), kHint);
  check_size(s.info.image_width, s.info.image_height, name, max_side, max_texels);
  DecodedImage out;
  out.width = int(s.info.image_width);
  out.height = int(s.info.image_height);
  out.rgba8.resize(size_t(out.width) * size_t(out.height) * 4);
  if (!jpeg_pixels_step(&s, out.rgba8.data()) ||
      s.info.output_width != s.info.image_width || s.info.output_height != s.info.image_height)
    throw input_error(name, "has damaged JPEG image data: " + one_line(s.err.message), kHint);
  return out;
}

}  // namespace

bool texture_image_size(const std::string& bytes, uint64_t& width, uint64_t& height) {
  static const unsigned char kPng[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  const auto* b = reinterpret_cast<const unsigned char*>(bytes.data());
  // PNG (ISO 15948 §5.6): the signature, then IHDR first: length, "IHDR", width, height (big-endian).
  if (bytes.size() >= 24 && std::memcmp(b, kPng, 8) == 0 && std::memcmp(b + 12, "IHDR", 4) == 0) {
    auto be32 = [](const unsigned char* p) {
      return uint64_t(p[0]) << 24 | uint64_t(p[1]) << 16 | uint64_t(p[2]) << 8 | uint64_t(p[3]);
    };
    width = be32(b + 16);
    height = be32(b + 20);
    return true;
  }
  if (bytes.size() >= 3 && b[0] == 0xff && b[1] == 0xd8 && b[2] == 0xff) {
    JpegState s;
    s.info.err = jpeg_std_error(&s.err.mgr);
    s.err.mgr.error_exit = jpeg_on_error;
    s.err.mgr.emit_message = jpeg_on_message;
    s.err.message[0] = 0;
    const bool ok = jpeg_header_step(&s, b, static_cast<unsigned long>(bytes.size()));
    if (ok) {
      width = s.info.image_width;
      height = s.info.image_height;
    }
    if (s.created) jpeg_destroy_decompress(&s.info);
    return ok;
  }
  return false;
}

DecodedImage decode_texture_image(const std::string& bytes, const std::string& name, int max_side,
                                  uint64_t max_texels) {
  static const unsigned char kPng[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (bytes.size() >= 8 && std::memcmp(bytes.data(), kPng, 8) == 0)
    return decode_png_texture(bytes, name, max_side, max_texels);
  if (bytes.size() >= 3 && static_cast<unsigned char>(bytes[0]) == 0xff &&
      static_cast<unsigned char>(bytes[1]) == 0xd8 && static_cast<unsigned char>(bytes[2]) == 0xff)
    return decode_jpeg_texture(bytes, name, max_side, max_texels);
  // Neither its size nor its bytes are told: the file may be one the scene has no business
  // naming (/etc/passwd).
  throw input_error(name, bytes.empty() ? "is an empty file, not a PNG or JPEG image"
                                        : "is not a PNG or JPEG image",
                    kHint);
}

}  // namespace pf
