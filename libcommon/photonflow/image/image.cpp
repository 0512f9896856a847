// image.cpp — Image, OpenEXR I/O (OpenEXR 3 C++ API), sRGB preview, PNG through libpng.
#include "photonflow/image/image.h"

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfOutputFile.h>
#include <png.h>

#include <algorithm>
#include <csetjmp>
#include <cstdint>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <new>
#include <stdexcept>

#include "photonflow/foundations/error.h"
#include "photonflow/io/output_file.h"

namespace pf {

namespace {

bool is_rgb_channel(const std::string& name) { return name == "R" || name == "G" || name == "B"; }

}  // namespace

Image::Image(int w, int h) : width(w), height(h) {
  if (w < 0 || h < 0) throw std::invalid_argument("image: negative size");
  rgb.assign(3 * pixel_count(), 0.f);
}

std::vector<float>& Image::layer(const std::string& name) {
  if (name.empty() || is_rgb_channel(name))
    throw std::invalid_argument("image: invalid layer name '" + name + "'");
  auto it = layers.find(name);
  if (it == layers.end()) it = layers.emplace(name, std::vector<float>(pixel_count(), 0.f)).first;
  return it->second;
}

void write_exr(const Image& img, const std::string& path) {
  if (img.pixel_count() == 0) throw std::invalid_argument("write_exr: empty image");
  if (img.rgb.size() != 3 * img.pixel_count())
    throw std::invalid_argument("write_exr: rgb size does not match the image size");
  for (const auto& [name, data] : img.layers)
    if (data.size() != img.pixel_count() || name.empty() || is_rgb_channel(name))
      throw std::invalid_argument("write_exr: bad layer '" + name + "'");

  Imf::Header header(img.width, img.height);  // ZIP compression: lossless
  Imf::FrameBuffer fb;
  const size_t px = sizeof(float);
  const char* rgb = reinterpret_cast<const char*>(img.rgb.data());
  const char* names[3] = {"R", "G", "B"};
  for (int c = 0; c < 3; ++c) {
    header.channels().insert(names[c], Imf::Channel(Imf::FLOAT));
    fb.insert(names[c], Imf::Slice(Imf::FLOAT, const_cast<char*>(rgb + c * px), 3 * px,
                                   3 * px * img.width));
  }
  for (const auto& [name, data] : img.layers) {
    header.channels().insert(name, Imf::Channel(Imf::FLOAT));
    fb.insert(name, Imf::Slice(Imf::FLOAT,
                               reinterpret_cast<char*>(const_cast<float*>(data.data())), px,
                               px * img.width));
  }
  TempOutput tmp(path);
  try {
    Imf::OutputFile out(tmp.path().c_str(), header);
    out.setFrameBuffer(fb);
    out.writePixels(img.height);
  } catch (const std::exception& e) {
    throw input_error(path, std::string("cannot write EXR: ") + e.what(), "is the disk full?");
  }
  tmp.commit();
}

Image read_exr(const std::string& path) {
  require_regular_input(path);
  try {
    Imf::InputFile in(path.c_str());
    const Imath::Box2i dw = in.header().dataWindow();
    const int w = dw.max.x - dw.min.x + 1;
    const int h = dw.max.y - dw.min.y + 1;
    Image img(w, h);
    const Imf::ChannelList& channels = in.header().channels();
    for (const char* c : {"R", "G", "B"})
      if (!channels.findChannel(c))
        throw input_error(path, std::string("EXR has no channel ") + c, "expected an RGB image");
    Imf::FrameBuffer fb;
    const size_t px = sizeof(float);
    const char* names[3] = {"R", "G", "B"};
    for (int c = 0; c < 3; ++c)
      fb.insert(names[c], Imf::Slice::Make(Imf::FLOAT, img.rgb.data() + c, dw, 3 * px, 3 * px * w));
    for (auto it = channels.begin(); it != channels.end(); ++it) {
      std::string name = it.name();
      if (is_rgb_channel(name)) continue;
      std::vector<float>& data = img.layer(name);
      fb.insert(name, Imf::Slice::Make(Imf::FLOAT, data.data(), dw, px, px * w));
    }
    in.setFrameBuffer(fb);
    in.readPixels(dw.min.y, dw.max.y);
    return img;
  } catch (const InputError&) {
    throw;
  } catch (const std::exception& e) {
    throw input_error(path, std::string("cannot read EXR: ") + e.what());
  }
}

float srgb_encode(float v) {
  if (v <= 0.0031308f) return 12.92f * v;
  return 1.055f * std::pow(v, 1.f / 2.4f) - 0.055f;
}

std::vector<uint8_t> to_srgb8(const Image& img, float exposure_stops) {
  const float scale = std::exp2(exposure_stops);
  std::vector<uint8_t> out(img.rgb.size());
  for (size_t i = 0; i < img.rgb.size(); ++i) {
    float v = img.rgb[i] * scale;
    v = v > 0.f ? std::min(v, 1.f) : 0.f;  // clamps, and NaN fails `v > 0`
    out[i] = static_cast<uint8_t>(srgb_encode(v) * 255.f + 0.5f);
  }
  return out;
}

// ---- PNG through libpng ---------------------------------------------------------------------
//
// libpng reports an error by calling the error function and then leaving the libpng call with
// longjmp to the setjmp of that call's caller. A longjmp skips C++ destructors, so every function
// below that calls setjmp (the png_* "steps") holds only plain data, and owns nothing: buffers
// belong to the C++ callers (encode_png, decode_png), which never call setjmp themselves, and the
// libpng structures are freed by a guard in those callers. A step returns false when libpng
// failed, with libpng's message in PngIo::message.

namespace {

// What libpng's callbacks share with the steps: plain data only (see above).
struct PngIo {
  png_structp png = nullptr;
  png_infop info = nullptr;
  const unsigned char* in = nullptr;  // reading: the file's bytes
  size_t in_size = 0, in_pos = 0;
  std::vector<uint8_t>* out = nullptr;  // writing: the file's bytes, appended
  char message[160] = {};               // libpng's error text
  char short_read[64] = {};             // png_read_memory's error text
};

// libpng's error function: keeps the message (made one line) and leaves by longjmp.
void png_on_error(png_structp png, png_const_charp msg) {
  auto* io = static_cast<PngIo*>(png_get_error_ptr(png));
  std::snprintf(io->message, sizeof io->message, "%s", msg ? msg : "unknown error");
  for (char* c = io->message; *c; ++c)
    if (static_cast<unsigned char>(*c) < 0x20) *c = ' ';
  png_longjmp(png, 1);
}

// Warnings (an ancillary chunk with a bad CRC, dropped; an unknown sRGB profile) are not errors
// of the mask and would be a second stderr line: ignored.
void png_on_warning(png_structp, png_const_charp) {}

void png_read_memory(png_structp png, png_bytep data, size_t n) {
  auto* io = static_cast<PngIo*>(png_get_io_ptr(png));
  if (n > io->in_size - io->in_pos) {
    std::snprintf(io->short_read, sizeof io->short_read, "the file ends early, after %zu bytes",
                  io->in_size);
    png_error(png, io->short_read);
  }
  std::memcpy(data, io->in + io->in_pos, n);
  io->in_pos += n;
}

void png_write_memory(png_structp png, png_bytep data, size_t n) {
  auto* io = static_cast<PngIo*>(png_get_io_ptr(png));
  bool full = false;
  try {
    io->out->insert(io->out->end(), data, data + n);
  } catch (const std::bad_alloc&) {
    full = true;  // png_error below, outside the handler: a longjmp must not leave a catch block
  }
  if (full) png_error(png, "out of memory");
}

void png_flush_none(png_structp) {}

// Frees libpng's structures when the C++ caller leaves, normally or by an exception.
struct PngGuard {
  PngIo* io;
  bool writing;
  ~PngGuard() {
    if (writing)
      png_destroy_write_struct(&io->png, io->info ? &io->info : nullptr);
    else
      png_destroy_read_struct(&io->png, io->info ? &io->info : nullptr, nullptr);
  }
};

// Preview encoding: zlib level 1 with the Sub filter on every row: on a render-like preview it
// halves the raw bytes, and libpng's default (level 6, a filter chosen per row) takes several
// times as long for a file no smaller (bench_io; docs/BENCHMARKS.md, "PNG, SHA-256 and JSON
// through libraries").
constexpr int kPngZlibLevel = 1;
constexpr int kPngFilters = PNG_FILTER_SUB;

// Step: the whole PNG of `rows` (8-bit RGB) into io->out.
bool png_write_rgb8(PngIo* io, png_uint_32 w, png_uint_32 h, png_bytepp rows) {
  if (setjmp(png_jmpbuf(io->png))) return false;
  png_set_write_fn(io->png, io, png_write_memory, png_flush_none);
  png_set_IHDR(io->png, io->info, w, h, 8, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_set_compression_level(io->png, kPngZlibLevel);
  png_set_filter(io->png, PNG_FILTER_TYPE_BASE, kPngFilters);
  png_write_info(io->png, io->info);
  png_write_image(io->png, rows);
  png_write_end(io->png, nullptr);
  return true;
}

// The file's header, and the rows after the transforms decode_png asks for.
struct PngHeader {
  png_uint_32 width = 0, height = 0;
  int depth = 0, colour = 0, interlace = 0;
  size_t file_row_bytes = 0;  // a scanline as stored (before the transforms)
  size_t row_bytes = 0;       // a row as decoded: 8- or 16-bit samples, or palette indices
  int channels = 0;           // samples per decoded pixel: 1 (grey, index) or 3 (RGB)
};

// Step: signature and chunks up to the first IDAT (IHDR, PLTE, ...).
bool png_read_header(PngIo* io, PngHeader* hdr) {
  if (setjmp(png_jmpbuf(io->png))) return false;
  png_set_read_fn(io->png, io, png_read_memory);
  png_read_info(io->png, io->info);
  hdr->width = png_get_image_width(io->png, io->info);
  hdr->height = png_get_image_height(io->png, io->info);
  hdr->depth = png_get_bit_depth(io->png, io->info);
  hdr->colour = png_get_color_type(io->png, io->info);
  hdr->interlace = png_get_interlace_type(io->png, io->info);
  hdr->file_row_bytes = png_get_rowbytes(io->png, io->info);
  return true;
}

// Step: the transforms to samples decode_png converts: grey of 1, 2 or 4 bits scaled to 8 bits
// (v·255/(2^depth − 1), so v/(2^depth − 1) is kept exactly), palette indices one per byte, alpha
// dropped; 16-bit samples stay 16-bit (big-endian); Adam7-interlaced files de-interlaced.
bool png_set_transforms(PngIo* io, PngHeader* hdr) {
  if (setjmp(png_jmpbuf(io->png))) return false;
  if (hdr->colour == PNG_COLOR_TYPE_GRAY && hdr->depth < 8) png_set_expand_gray_1_2_4_to_8(io->png);
  if (hdr->colour == PNG_COLOR_TYPE_PALETTE && hdr->depth < 8) png_set_packing(io->png);
  if (hdr->colour & PNG_COLOR_MASK_ALPHA) png_set_strip_alpha(io->png);
  png_set_interlace_handling(io->png);
  png_read_update_info(io->png, io->info);
  hdr->row_bytes = png_get_rowbytes(io->png, io->info);
  hdr->channels = png_get_channels(io->png, io->info);
  return true;
}

// Step: every row (all passes of an interlaced file), then the chunks up to IEND.
bool png_read_rows(PngIo* io, png_bytepp rows) {
  if (setjmp(png_jmpbuf(io->png))) return false;
  png_read_image(io->png, rows);
  png_read_end(io->png, nullptr);
  return true;
}

}  // namespace

std::vector<uint8_t> encode_png(int w, int h, const std::vector<uint8_t>& rgb8) {
  if (w <= 0 || h <= 0 || rgb8.size() != 3 * static_cast<size_t>(w) * static_cast<size_t>(h))
    throw std::invalid_argument("encode_png: size does not match the pixel data");
  std::vector<png_bytep> rows(static_cast<size_t>(h));
  for (int y = 0; y < h; ++y)
    rows[size_t(y)] = const_cast<png_bytep>(rgb8.data() + 3 * size_t(w) * size_t(y));
  std::vector<uint8_t> out;
  out.reserve(rgb8.size() / 2 + 1024);
  PngIo io;
  io.out = &out;
  io.png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &io, png_on_error, png_on_warning);
  if (!io.png) throw std::bad_alloc();
  PngGuard guard{&io, true};
  io.info = png_create_info_struct(io.png);
  if (!io.info) throw std::bad_alloc();
  if (!png_write_rgb8(&io, png_uint_32(w), png_uint_32(h), rows.data()))
    throw std::runtime_error(std::string("encode_png: libpng: ") + io.message);
  return out;
}

void write_png(const Image& img, const std::string& path, float exposure_stops) {
  const std::vector<uint8_t> png = encode_png(img.width, img.height, to_srgb8(img, exposure_stops));
  write_file_atomic(path, reinterpret_cast<const char*>(png.data()), png.size());
}

Image decode_png(const std::string& bytes, const std::string& name) {
  const auto* p = reinterpret_cast<const unsigned char*>(bytes.data());
  if (bytes.size() < 8 || png_sig_cmp(p, 0, 8) != 0) throw input_error(name, "is not a PNG file");
  PngIo io;
  io.in = p;
  io.in_size = bytes.size();
  io.png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &io, png_on_error, png_on_warning);
  if (!io.png) throw std::bad_alloc();
  PngGuard guard{&io, false};
  io.info = png_create_info_struct(io.png);
  if (!io.info) throw std::bad_alloc();

  PngHeader hdr;
  if (!png_read_header(&io, &hdr))
    throw input_error(name, std::string("is a damaged PNG file: ") + io.message, "save it again");
  const uint32_t W = hdr.width, H = hdr.height;
  if (W > (1u << 16) || H > (1u << 16)) throw input_error(name, "has an unsupported PNG size");
  // Deflate expands at most about 1032:1 (RFC 1951: a 258-byte match per 2 bits at best), so a
  // header that asks for more scanline bytes than that of the whole file is damaged; refused
  // before the rows are allocated (65536 × 65536 RGBA16 would be 34 GB).
  const size_t raw_bytes = size_t(H) * (hdr.file_row_bytes + 1);
  if (raw_bytes / 1100 > bytes.size())
    throw input_error(name, "is a damaged PNG file: its header's " + std::to_string(W) + "x" +
                                std::to_string(H) + " pixels need more data than its " +
                                std::to_string(bytes.size()) + " bytes can hold");
  if (!png_set_transforms(&io, &hdr))
    throw input_error(name, std::string("is a damaged PNG file: ") + io.message, "save it again");
  const bool palette = hdr.colour == PNG_COLOR_TYPE_PALETTE;
  const int depth = palette ? 8 : hdr.depth < 8 ? 8 : hdr.depth;  // of the decoded samples
  if ((hdr.channels != 1 && hdr.channels != 3) ||
      hdr.row_bytes != size_t(W) * size_t(hdr.channels) * size_t(depth / 8))
    throw std::logic_error("decode_png: libpng's rows are not the layout its transforms ask for");

  std::vector<unsigned char> raw(size_t(H) * hdr.row_bytes);
  std::vector<png_bytep> rows(H);
  for (uint32_t y = 0; y < H; ++y) rows[y] = raw.data() + size_t(y) * hdr.row_bytes;
  if (!png_read_rows(&io, rows.data()))
    throw input_error(name, std::string("has damaged PNG image data: ") + io.message,
                      "save it again");

  png_colorp entries = nullptr;
  int entry_count = 0;
  if (palette && png_get_PLTE(io.png, io.info, &entries, &entry_count) != PNG_INFO_PLTE)
    throw input_error(name, "has no PNG palette");

  // Samples to RGB in [0, 1] (alpha dropped).
  Image img(static_cast<int>(W), static_cast<int>(H));
  const double maxv = depth == 16 ? 65535.0 : 255.0;
  for (uint32_t y = 0; y < H; ++y) {
    const unsigned char* cur = rows[y];
    auto sample = [&](size_t k) -> uint32_t {  // k-th sample of the row
      if (depth == 16) return (uint32_t(cur[2 * k]) << 8) | cur[2 * k + 1];
      return cur[k];
    };
    for (uint32_t x = 0; x < W; ++x) {
      float rgb[3];
      const size_t k = size_t(x) * size_t(hdr.channels);
      if (palette) {
        const uint32_t e = sample(k);
        if (e >= uint32_t(entry_count))
          throw input_error(name, "has a PNG palette index out of range");
        rgb[0] = float(entries[e].red / 255.0);
        rgb[1] = float(entries[e].green / 255.0);
        rgb[2] = float(entries[e].blue / 255.0);
      } else if (hdr.channels == 1) {
        rgb[0] = rgb[1] = rgb[2] = float(sample(k) / maxv);
      } else {
        for (int c = 0; c < 3; ++c) rgb[c] = float(sample(k + size_t(c)) / maxv);
      }
      img.set(int(x), int(y), Vec3(rgb));
    }
  }
  return img;
}

}  // namespace pf
