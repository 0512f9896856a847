// Reading radiance maps: see environment_image.h.
#include "photonflow/image/environment_image.h"

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <stb_image.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <memory>

#include "photonflow/foundations/error.h"
#include "photonflow/io/output_file.h"

namespace pf {

namespace {

std::string lower_extension(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  const size_t dot = path.find_last_of('.');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return "";
  std::string e = path.substr(dot);
  for (char& c : e) c = char(std::tolower(static_cast<unsigned char>(c)));
  return e;
}

// The equirectangular shape: width = 2·height, within the bound (before decoding).
void check_shape(const std::string& path, long long w, long long h, int max_width) {
  if (w <= 0 || h <= 0 || w != 2 * h)
    throw input_error(path, "an environment map must be equirectangular, width = 2 x height; this "
                            "image is " + std::to_string(w) + " x " + std::to_string(h),
                      "give a latitude-longitude (2:1) map");
  if (w > max_width)
    throw input_error(path, "the environment map is " + std::to_string(w) + " x " +
                                std::to_string(h) + ", more than the largest accepted, " +
                                std::to_string(max_width) + " x " + std::to_string(max_width / 2),
                      "scale the map down");
}

RadianceImage read_exr_rgb(const std::string& path, int max_width) {
  try {
    Imf::InputFile in(path.c_str());
    const Imath::Box2i dw = in.header().dataWindow();
    const long long w = (long long)dw.max.x - dw.min.x + 1;
    const long long h = (long long)dw.max.y - dw.min.y + 1;
    const Imf::ChannelList& channels = in.header().channels();
    for (const char* c : {"R", "G", "B"})
      if (!channels.findChannel(c))
        throw input_error(path, std::string("the EXR has no channel ") + c,
                          "give an RGB environment map");
    check_shape(path, w, h, max_width);
    RadianceImage img;
    img.width = int(w);
    img.height = int(h);
    img.rgb.assign(size_t(w) * size_t(h) * 3, 0.f);
    Imf::FrameBuffer fb;
    const size_t px = sizeof(float);
    const char* names[3] = {"R", "G", "B"};
    for (int c = 0; c < 3; ++c)
      fb.insert(names[c], Imf::Slice::Make(Imf::FLOAT, img.rgb.data() + c, dw, 3 * px,
                                           3 * px * size_t(w)));
    in.setFrameBuffer(fb);
    in.readPixels(dw.min.y, dw.max.y);
    return img;
  } catch (const InputError&) {
    throw;
  } catch (const std::exception& e) {
    std::string why = e.what();
    std::replace(why.begin(), why.end(), '\n', ' ');
    throw input_error(path, "cannot read the EXR environment map: " + why,
                      "give a complete OpenEXR file");
  }
}

// stb_image over the file's bytes through callbacks that note a read past the end: stb_image's
// .hdr decoder reads a cut file's missing texels as zeros without an error, so a decode that
// asked for bytes the file does not have is refused as cut.
struct HdrBytes {
  const std::string* bytes;
  size_t at = 0;
  bool starved = false;
};

int hdr_read(void* user, char* data, int size) {
  HdrBytes& b = *static_cast<HdrBytes*>(user);
  const size_t n = std::min(size_t(size), b.bytes->size() - b.at);
  if (n == 0) b.starved = true;
  std::memcpy(data, b.bytes->data() + b.at, n);
  b.at += n;
  return int(n);
}
void hdr_skip(void* user, int n) {
  HdrBytes& b = *static_cast<HdrBytes*>(user);
  if (n < 0) b.at -= std::min(b.at, size_t(-n));
  else b.at = std::min(b.bytes->size(), b.at + size_t(n));
}
int hdr_eof(void* user) {
  HdrBytes& b = *static_cast<HdrBytes*>(user);
  return b.at >= b.bytes->size();
}

const char* stb_reason() { return stbi_failure_reason() ? stbi_failure_reason() : "unknown"; }

RadianceImage read_hdr_rgb(const std::string& path, int max_width) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw input_error(path, "cannot open the environment map", "check the path");
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const auto* data = reinterpret_cast<const stbi_uc*>(bytes.data());
  const int len = int(std::min<size_t>(bytes.size(), size_t(INT32_MAX)));
  int w = 0, h = 0, n = 0;
  if (!stbi_is_hdr_from_memory(data, len) || !stbi_info_from_memory(data, len, &w, &h, &n))
    throw input_error(path, std::string("not a Radiance .hdr image (stb_image: ") + stb_reason() + ")",
                      "give a Radiance RGBE (.hdr) or OpenEXR (.exr) map");
  check_shape(path, w, h, max_width);
  HdrBytes src{&bytes};
  const stbi_io_callbacks io{hdr_read, hdr_skip, hdr_eof};
  float* px = stbi_loadf_from_callbacks(&io, &src, &w, &h, &n, 3);
  if (!px)
    throw input_error(path, std::string("cannot decode the .hdr environment map (stb_image: ") +
                                stb_reason() + ")",
                      "give a complete Radiance RGBE file");
  RadianceImage img;
  img.width = w;
  img.height = h;
  img.rgb.assign(px, px + size_t(w) * size_t(h) * 3);
  stbi_image_free(px);
  if (src.starved)
    throw input_error(path, "the .hdr environment map is cut: its texels end before " +
                                std::to_string(w) + " x " + std::to_string(h),
                      "give a complete Radiance RGBE file");
  return img;
}

}  // namespace

RadianceImage read_radiance_image(const std::string& path, int max_width) {
  require_regular_input(path);
  FILE* probe = std::fopen(path.c_str(), "rb");
  if (!probe)
    throw input_error(path, std::string("cannot open the environment map: ") + std::strerror(errno),
                      "check the path");
  std::fclose(probe);
  const std::string ext = lower_extension(path);
  if (ext == ".exr") return read_exr_rgb(path, max_width);
  if (ext == ".hdr") return read_hdr_rgb(path, max_width);
  throw input_error(path, "an environment map must be an OpenEXR (.exr) or Radiance (.hdr) file",
                    "convert the map to .exr or .hdr");
}

}  // namespace pf
