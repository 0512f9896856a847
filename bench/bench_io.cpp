// bench_io — the cost of the file formats photonflow hands to libraries: SHA-256 of a
// large input file (sha256_file, as every stage hashes its inputs for provenance) and writing the
// PNG preview of an image (write_png, as synthesize, render and pathtrace do), then libpng's
// encoding alone of the same pixels at several zlib levels and row filters (the choice behind
// image.cpp's kPngZlibLevel and kPngFilters). Prints markdown tables of medians over --runs runs.
//
//   build/bin/bench_io [--runs 5] [--hash-mb 100] [--width 1920 --height 1080] [--dir /tmp]
//
// The file to hash is --hash-mb MB of pseudo-random bytes, written once to --dir and read from
// the page cache (the first, uncounted run reads it in). The preview is a rendering-like image:
// smooth shading with per-pixel noise (a converging render), so that compression has real work.
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <csetjmp>
#include <cxxopts.hpp>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <png.h>

#include "bench_common.h"
#include "photonflow/foundations/hash.h"
#include "photonflow/image/image.h"
#include "photonflow/foundations/rng.h"

using pf::bench::median;
using pf::bench::now;

namespace {

std::vector<unsigned char>* g_out = nullptr;  // png_write's sink (one encode at a time)

void append(png_structp, png_bytep data, size_t n) { g_out->insert(g_out->end(), data, data + n); }
void no_flush(png_structp) {}

// libpng's encoding of `rows` (w×h 8-bit RGB) into `out`; level < 0: libpng's own defaults (zlib
// level 6, adaptive filter choice per row). Exits on a libpng error (none is expected; nothing
// with a destructor lives in this frame, which setjmp marks).
void encode(png_bytepp rows, int w, int h, int level, int filters,
            std::vector<unsigned char>* out) {
  out->clear();
  g_out = out;
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png_create_info_struct(png);
  if (setjmp(png_jmpbuf(png))) {
    std::fprintf(stderr, "bench_io: libpng failed\n");
    std::exit(1);
  }
  png_set_write_fn(png, nullptr, append, no_flush);
  png_set_IHDR(png, info, png_uint_32(w), png_uint_32(h), 8, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  if (level >= 0) {
    png_set_compression_level(png, level);
    png_set_filter(png, PNG_FILTER_TYPE_BASE, filters);
  }
  png_write_info(png, info);
  png_write_image(png, rows);
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
}

}  // namespace

int main(int argc, char** argv) {
  cxxopts::Options o("bench_io", "SHA-256 of a large file and PNG preview writing, timed.");
  o.add_options()("runs", "runs per measurement (median reported)",
                  cxxopts::value<int>()->default_value("5"))(
      "hash-mb", "size of the hashed file in MB (10^6 bytes)",
      cxxopts::value<int>()->default_value("100"))(
      "width", "preview width", cxxopts::value<int>()->default_value("1920"))(
      "height", "preview height", cxxopts::value<int>()->default_value("1080"))(
      "dir", "folder for the scratch files", cxxopts::value<std::string>()->default_value("/tmp"))(
      "h,help", "this help");
  const auto a = o.parse(argc, argv);
  if (a.count("help")) {
    std::printf("%s", o.help().c_str());
    return 0;
  }
  const int runs = std::max(1, a["runs"].as<int>());
  const size_t bytes = size_t(std::max(1, a["hash-mb"].as<int>())) * 1000000;
  const int w = a["width"].as<int>(), h = a["height"].as<int>();
  const std::string tag = std::to_string(getpid());
  const std::filesystem::path dir = a["dir"].as<std::string>();
  const std::string data = (dir / ("bench_io-" + tag + ".bin")).string();
  const std::string png = (dir / ("bench_io-" + tag + ".png")).string();

  {
    std::vector<uint32_t> block(1 << 18);
    std::ofstream f(data, std::ios::binary);
    for (size_t done = 0, i = 0; done < bytes; ++i) {
      for (size_t k = 0; k < block.size(); ++k)
        block[k] = pf_rng_bits(pf_rng_key(1, 0), uint32_t(i * block.size() + k), 0);
      const size_t n = std::min(bytes - done, block.size() * 4);
      f.write(reinterpret_cast<const char*>(block.data()), std::streamsize(n));
      done += n;
    }
  }
  std::vector<double> hash_s;
  std::string digest = pf::sha256_file(data);  // warm-up: the file into the page cache
  for (int r = 0; r < runs; ++r) {
    const double t = now();
    digest = pf::sha256_file(data);
    hash_s.push_back(now() - t);
  }
  std::filesystem::remove(data);

  pf::Image img(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const float shade = 0.5f + 0.4f * std::sin(x * 0.01f) * std::cos(y * 0.013f);
      const float noise = 0.1f * (pf_rng_float(2, 0, uint32_t(y * w + x), 0) - 0.5f);
      img.set(x, y, pf::Vec3(shade + noise, 0.8f * shade + noise, 0.6f * shade + noise));
    }
  std::vector<double> png_s;
  for (int r = 0; r < runs; ++r) {
    const double t = now();
    pf::write_png(img, png, 0.f);
    png_s.push_back(now() - t);
  }
  const auto png_bytes = std::filesystem::file_size(png);
  std::filesystem::remove(png);

  const double hs = median(hash_s), ps = median(png_s);
  std::printf("| measurement | median of %d | |\n|---|---|---|\n", runs);
  std::printf("| sha256_file, %zu MB | %.3f s | %.0f MB/s (digest %.12s…) |\n", bytes / 1000000,
              hs, double(bytes) / 1e6 / hs, digest.c_str());
  std::printf("| write_png, %dx%d | %.1f ms | %.2f MB file |\n", w, h, ps * 1e3,
              double(png_bytes) / 1e6);

  // libpng alone (no sRGB mapping, no file) on the preview's pixels.
  const std::vector<uint8_t> rgb8 = pf::to_srgb8(img, 0.f);
  std::vector<png_bytep> rows(static_cast<size_t>(h));
  for (int y = 0; y < h; ++y)
    rows[size_t(y)] = const_cast<png_bytep>(rgb8.data() + 3 * size_t(w) * size_t(y));
  struct Setting {
    const char* name;
    int level, filters;
  };
  const Setting settings[] = {{"zlib 0 (stored), no filter", 0, PNG_FILTER_NONE},
                              {"zlib 1, no filter", 1, PNG_FILTER_NONE},
                              {"zlib 1, Sub (photonflow)", 1, PNG_FILTER_SUB},
                              {"zlib 1, Paeth", 1, PNG_FILTER_PAETH},
                              {"zlib 1, adaptive (all filters)", 1, PNG_ALL_FILTERS},
                              {"zlib 3, Sub", 3, PNG_FILTER_SUB},
                              {"libpng default (zlib 6, adaptive)", -1, 0}};
  std::printf("\n| libpng encoding, %dx%d | median of %d | file |\n|---|---|---|\n", w, h, runs);
  std::vector<unsigned char> out;
  for (const Setting& st : settings) {
    std::vector<double> t;
    for (int r = 0; r < runs; ++r) {
      const double t0 = now();
      encode(rows.data(), w, h, st.level, st.filters, &out);
      t.push_back(now() - t0);
    }
    std::printf("| %s | %.1f ms | %.2f MB |\n", st.name, median(t) * 1e3, double(out.size()) / 1e6);
  }
  return 0;
}
