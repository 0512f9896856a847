// image.cpp — Image, OpenEXR I/O (OpenEXR 3 C++ API), sRGB preview and a minimal PNG encoder.
#include "photonflow/image.h"

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfOutputFile.h>
#include <zlib.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "photonflow/error.h"
#include "photonflow/output_file.h"

namespace pf {

namespace {

// CRC-32 (ISO 3309 / PNG, reflected polynomial 0xEDB88320), table-driven.
uint32_t crc32(const uint8_t* data, size_t n, uint32_t crc = 0) {
  static const std::array<uint32_t, 256> table = [] {
    std::array<uint32_t, 256> t{};
    for (uint32_t i = 0; i < 256; ++i) {
      uint32_t c = i;
      for (int k = 0; k < 8; ++k) c = (c & 1u) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
      t[i] = c;
    }
    return t;
  }();
  crc = ~crc;
  for (size_t i = 0; i < n; ++i) crc = table[(crc ^ data[i]) & 0xFFu] ^ (crc >> 8);
  return ~crc;
}

// Adler-32 (RFC 1950), the zlib stream's checksum of the uncompressed data.
uint32_t adler32(const uint8_t* data, size_t n) {
  uint32_t a = 1, b = 0;
  const uint32_t mod = 65521;
  while (n > 0) {
    size_t block = std::min<size_t>(n, 5552);  // largest run without 32-bit overflow
    n -= block;
    for (size_t i = 0; i < block; ++i) {
      a += *data++;
      b += a;
    }
    a %= mod;
    b %= mod;
  }
  return (b << 16) | a;
}

void put_u32_be(std::vector<uint8_t>& out, uint32_t v) {
  out.push_back(static_cast<uint8_t>(v >> 24));
  out.push_back(static_cast<uint8_t>(v >> 16));
  out.push_back(static_cast<uint8_t>(v >> 8));
  out.push_back(static_cast<uint8_t>(v));
}

// Appends one PNG chunk: length, type, data, CRC-32 of type and data.
void put_chunk(std::vector<uint8_t>& out, const char type[4], const std::vector<uint8_t>& data) {
  put_u32_be(out, static_cast<uint32_t>(data.size()));
  size_t start = out.size();
  out.insert(out.end(), type, type + 4);
  out.insert(out.end(), data.begin(), data.end());
  put_u32_be(out, crc32(&out[start], out.size() - start));
}

// zlib stream (RFC 1950) of `raw` in stored deflate blocks (RFC 1951 §3.2.4, BTYPE = 00).
std::vector<uint8_t> zlib_stored(const std::vector<uint8_t>& raw) {
  // CMF 0x78: deflate with a 32 KiB window; FLG 0x01: no dictionary, FCHECK with 0x7801 % 31 == 0.
  std::vector<uint8_t> z = {0x78, 0x01};
  size_t pos = 0;
  do {
    size_t len = std::min<size_t>(raw.size() - pos, 65535);
    bool last = pos + len == raw.size();
    z.push_back(last ? 1 : 0);  // BFINAL, BTYPE = 00 (stored); the rest of the byte is padding
    z.push_back(static_cast<uint8_t>(len));
    z.push_back(static_cast<uint8_t>(len >> 8));
    z.push_back(static_cast<uint8_t>(~len));
    z.push_back(static_cast<uint8_t>(~len >> 8));
    z.insert(z.end(), raw.begin() + pos, raw.begin() + pos + len);
    pos += len;
  } while (pos < raw.size());
  put_u32_be(z, adler32(raw.data(), raw.size()));
  return z;
}

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

std::vector<uint8_t> encode_png(int w, int h, const std::vector<uint8_t>& rgb8) {
  if (w <= 0 || h <= 0 || rgb8.size() != 3 * static_cast<size_t>(w) * static_cast<size_t>(h))
    throw std::invalid_argument("encode_png: size does not match the pixel data");
  std::vector<uint8_t> out = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  std::vector<uint8_t> ihdr;
  put_u32_be(ihdr, static_cast<uint32_t>(w));
  put_u32_be(ihdr, static_cast<uint32_t>(h));
  ihdr.insert(ihdr.end(), {8, 2, 0, 0, 0});  // 8 bits, truecolour, deflate, filter 0, no interlace
  put_chunk(out, "IHDR", ihdr);
  // Scanlines, each preceded by filter type 0 (None).
  const size_t row = 3 * static_cast<size_t>(w);
  std::vector<uint8_t> raw;
  raw.reserve((row + 1) * h);
  for (int y = 0; y < h; ++y) {
    raw.push_back(0);
    raw.insert(raw.end(), rgb8.begin() + y * row, rgb8.begin() + (y + 1) * row);
  }
  put_chunk(out, "IDAT", zlib_stored(raw));
  put_chunk(out, "IEND", {});
  return out;
}

void write_png(const Image& img, const std::string& path, float exposure_stops) {
  const std::vector<uint8_t> png = encode_png(img.width, img.height, to_srgb8(img, exposure_stops));
  write_file_atomic(path, reinterpret_cast<const char*>(png.data()), png.size());
}

// ---- PNG decoding (masks) --------------------------------------------------------------------

namespace {

uint32_t be32(const unsigned char* p) {
  return (uint32_t(p[0]) << 24) | (uint32_t(p[1]) << 16) | (uint32_t(p[2]) << 8) | uint32_t(p[3]);
}

// PNG Paeth predictor (PNG spec. §9.4).
int paeth(int a, int b, int c) {
  const int p = a + b - c, pa = std::abs(p - a), pb = std::abs(p - b), pc = std::abs(p - c);
  if (pa <= pb && pa <= pc) return a;
  return pb <= pc ? b : c;
}

}  // namespace

Image decode_png(const std::string& bytes, const std::string& name) {
  static const unsigned char sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  const auto* p = reinterpret_cast<const unsigned char*>(bytes.data());
  const size_t n = bytes.size();
  if (n < 8 || !std::equal(sig, sig + 8, p)) throw input_error(name, "is not a PNG file");
  uint32_t W = 0, H = 0;
  int depth = 0, ctype = -1, interlace = 0;
  std::vector<unsigned char> palette, idat;
  bool ended = false;
  for (size_t at = 8; at < n && !ended;) {
    if (n - at < 12) throw input_error(name, "is a truncated PNG file");
    const uint32_t len = be32(p + at);
    if (len > n - at - 12) throw input_error(name, "is a truncated PNG file");
    const std::string type(reinterpret_cast<const char*>(p + at + 4), 4);
    const unsigned char* d = p + at + 8;
    const uint32_t crc = uint32_t(::crc32(::crc32(0L, Z_NULL, 0), p + at + 4, len + 4));
    if (crc != be32(d + len)) throw input_error(name, "is a damaged PNG file (CRC mismatch)");
    if (type == "IHDR") {
      if (len != 13) throw input_error(name, "has a bad PNG header");
      W = be32(d);
      H = be32(d + 4);
      depth = d[8];
      ctype = d[9];
      interlace = d[12];
      if (d[10] != 0 || d[11] != 0) throw input_error(name, "uses an unknown PNG compression");
    } else if (type == "PLTE") {
      palette.assign(d, d + len);
    } else if (type == "IDAT") {
      idat.insert(idat.end(), d, d + len);
    } else if (type == "IEND") {
      ended = true;
    }
    at += size_t(len) + 12;
  }
  if (ctype < 0 || !ended) throw input_error(name, "is an incomplete PNG file");
  int channels;
  switch (ctype) {
    case 0: channels = 1; break;
    case 2: channels = 3; break;
    case 3: channels = 1; break;
    case 4: channels = 2; break;
    case 6: channels = 4; break;
    default: throw input_error(name, "has an unknown PNG colour type");
  }
  const bool depth_ok = (ctype == 0 && (depth == 1 || depth == 2 || depth == 4 || depth == 8 ||
                                        depth == 16)) ||
                        (ctype == 3 && (depth == 1 || depth == 2 || depth == 4 || depth == 8)) ||
                        ((ctype == 2 || ctype == 4 || ctype == 6) && (depth == 8 || depth == 16));
  if (!depth_ok) throw input_error(name, "has an invalid PNG bit depth");
  if (interlace != 0)
    throw input_error(name, "is an interlaced PNG", "save the mask without interlacing");
  if (W == 0 || H == 0 || W > (1u << 16) || H > (1u << 16))
    throw input_error(name, "has an unsupported PNG size");
  if (ctype == 3 && palette.size() < 3) throw input_error(name, "has no PNG palette");

  // Inflate (RFC 1950/1951 through zlib) into H filtered scanlines.
  const size_t row = (size_t(W) * size_t(channels) * size_t(depth) + 7) / 8;
  const size_t bpp = std::max<size_t>(1, size_t(channels) * size_t(depth) / 8);
  // Deflate expands at most about 1032:1 (RFC 1951: a 258-byte match per 2 bits at best), so a
  // header that asks for more scanline bytes than that is damaged; refused before the buffer for
  // them is allocated (65536 × 65536 RGBA16 would be 34 GB).
  const size_t raw_bytes = size_t(H) * (row + 1);
  if (raw_bytes / 1100 > idat.size())
    throw input_error(name, "is a damaged PNG file: its header's " + std::to_string(W) + "x" +
                                std::to_string(H) + " pixels need more data than its " +
                                std::to_string(idat.size()) + " compressed bytes can hold");
  std::vector<unsigned char> raw(raw_bytes);
  z_stream zs{};
  if (inflateInit(&zs) != Z_OK) throw input_error(name, "cannot start zlib");
  zs.next_in = idat.data();
  zs.avail_in = uInt(idat.size());
  zs.next_out = raw.data();
  zs.avail_out = uInt(raw.size());
  const int zr = inflate(&zs, Z_FINISH);
  const size_t got = raw.size() - zs.avail_out;
  inflateEnd(&zs);
  if ((zr != Z_STREAM_END && zr != Z_BUF_ERROR) || got != raw.size())
    throw input_error(name, "has damaged PNG image data");

  // Undo the per-row filters (PNG spec. §9.2) in place.
  std::vector<unsigned char> prev(row, 0);
  for (uint32_t y = 0; y < H; ++y) {
    unsigned char* line = &raw[size_t(y) * (row + 1)];
    const int f = line[0];
    unsigned char* cur = line + 1;
    for (size_t i = 0; i < row; ++i) {
      const int a = i >= bpp ? cur[i - bpp] : 0, b = prev[i], c = i >= bpp ? prev[i - bpp] : 0;
      int v = cur[i];
      switch (f) {
        case 0: break;
        case 1: v += a; break;
        case 2: v += b; break;
        case 3: v += (a + b) / 2; break;
        case 4: v += paeth(a, b, c); break;
        default: throw input_error(name, "has an unknown PNG filter type");
      }
      cur[i] = static_cast<unsigned char>(v);
    }
    std::copy(cur, cur + row, prev.begin());
  }

  // Samples to RGB in [0, 1] (alpha dropped).
  Image img(static_cast<int>(W), static_cast<int>(H));
  const double maxv = double((1u << depth) - 1);
  for (uint32_t y = 0; y < H; ++y) {
    const unsigned char* cur = &raw[size_t(y) * (row + 1) + 1];
    auto sample = [&](size_t k) -> uint32_t {  // k-th sample of the row
      if (depth == 16) return (uint32_t(cur[2 * k]) << 8) | cur[2 * k + 1];
      if (depth == 8) return cur[k];
      const size_t bit = k * size_t(depth);
      return (uint32_t(cur[bit / 8]) >> (8 - depth - bit % 8)) & ((1u << depth) - 1);
    };
    for (uint32_t x = 0; x < W; ++x) {
      float rgb[3];
      const size_t k = size_t(x) * size_t(channels);
      if (ctype == 3) {
        const size_t e = sample(k);
        if (3 * e + 2 >= palette.size())
          throw input_error(name, "has a PNG palette index out of range");
        for (int c = 0; c < 3; ++c) rgb[c] = float(palette[3 * e + size_t(c)] / 255.0);
      } else if (ctype == 0 || ctype == 4) {
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
