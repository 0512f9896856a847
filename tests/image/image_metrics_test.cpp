// Image metrics (issue 7, image_metrics.h) and the imgcompare tool: hand-computable cases
// (identical images, constant offsets, flat images' SSIM), SSIM against a direct 2-D
// implementation written here, masks (EXR and PNG: every filter type, grey, RGB16, palette,
// alpha, Adam7; damaged and truncated files refused), non-finite pixels, size mismatches refused,
// JSON output.
#include <catch2/catch.hpp>

#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "photonflow/foundations/error.h"
#include "photonflow/image/image.h"
#include "photonflow/image/image_metrics.h"
#include "photonflow/foundations/rng.h"
#include "support.h"

using namespace pf;
using test::TempDir;

namespace {

// An image of values in [lo, hi) from the counter-based generator (independent per channel).
Image random_image(int w, int h, uint32_t seed, float lo = 0.f, float hi = 1.f) {
  Image img(w, h);
  for (size_t i = 0; i < img.rgb.size(); ++i)
    img.rgb[i] = lo + (hi - lo) * pf_rng_float(seed, 0, uint32_t(i), 0);
  return img;
}

Image constant_image(int w, int h, float v) {
  Image img(w, h);
  for (float& x : img.rgb) x = v;
  return img;
}

// SSIM of Wang et al. (2004) straight from its definition: 2-D Gaussian weights (σ = 1.5) over
// the 11×11 window, the weighted statistics as sums over the window, eq. 13, and the mean over
// the centres. `clipped` false: the centres whose window lies inside the image, weights normalised
// over the window; true: every pixel, the window cut at the border and the weights normalised over
// what is left. Luminance as in image_metrics.h.
double ssim_direct(const Image& a, const Image& b, double L, bool clipped = false) {
  auto Y = [](const Image& img, int x, int y) {
    Vec3 c = img.get(x, y);
    return 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z;
  };
  const double C1 = (0.01 * L) * (0.01 * L), C2 = (0.03 * L) * (0.03 * L);
  const int m = clipped ? 0 : 5;
  double total = 0;
  int n = 0;
  for (int cy = m; cy < a.height - m; ++cy)
    for (int cx = m; cx < a.width - m; ++cx) {
      double sum = 0, mx = 0, my = 0;
      auto each = [&](auto f) {
        for (int y = std::max(0, cy - 5); y <= std::min(a.height - 1, cy + 5); ++y)
          for (int x = std::max(0, cx - 5); x <= std::min(a.width - 1, cx + 5); ++x)
            f(x, y, std::exp(-((x - cx) * (x - cx) + (y - cy) * (y - cy)) / (2 * 1.5 * 1.5)));
      };
      each([&](int, int, double w) { sum += w; });
      each([&](int x, int y, double w) {
        mx += w / sum * Y(a, x, y);
        my += w / sum * Y(b, x, y);
      });
      double vx = 0, vy = 0, cxy = 0;
      each([&](int x, int y, double w) {
        const double dx = Y(a, x, y) - mx, dy = Y(b, x, y) - my;
        vx += w / sum * dx * dx;
        vy += w / sum * dy * dy;
        cxy += w / sum * dx * dy;
      });
      total += (2 * mx * my + C1) * (2 * cxy + C2) / ((mx * mx + my * my + C1) * (vx + vy + C2));
      ++n;
    }
  return total / n;
}

void put_be32(std::string& s, uint32_t v) {
  for (int k = 3; k >= 0; --k) s += char((v >> (8 * k)) & 0xFF);
}

void put_chunk(std::string& png, const char* type, const std::string& data) {
  put_be32(png, uint32_t(data.size()));
  std::string td = std::string(type, 4) + data;
  png += td;
  put_be32(png, uint32_t(crc32(0L, reinterpret_cast<const Bytef*>(td.data()), uInt(td.size()))));
}

int paeth(int a, int b, int c) {
  int p = a + b - c, pa = std::abs(p - a), pb = std::abs(p - b), pc = std::abs(p - c);
  return (pa <= pb && pa <= pc) ? a : (pb <= pc ? b : c);
}

// A complete PNG (zlib-compressed, as image editors write them) from unfiltered scanlines `rows`
// (each `row_bytes` long), row y filtered with type y % 5 (None, Sub, Up, Average, Paeth).
std::string make_png(int w, int h, int depth, int ctype, const std::vector<std::string>& rows,
                     size_t bpp, const std::string& palette = {}) {
  std::string raw;
  std::string prev(rows[0].size(), '\0');
  for (int y = 0; y < h; ++y) {
    const std::string& cur = rows[size_t(y)];
    const int f = y % 5;
    raw += char(f);
    for (size_t i = 0; i < cur.size(); ++i) {
      const int x = uint8_t(cur[i]), a = i >= bpp ? uint8_t(cur[i - bpp]) : 0,
                b = uint8_t(prev[i]), c = i >= bpp ? uint8_t(prev[i - bpp]) : 0;
      const int pred = f == 0 ? 0 : f == 1 ? a : f == 2 ? b : f == 3 ? (a + b) / 2 : paeth(a, b, c);
      raw += char(uint8_t(x - pred));
    }
    prev = cur;
  }
  uLongf zlen = compressBound(uLong(raw.size()));
  std::string z(zlen, '\0');
  REQUIRE(compress2(reinterpret_cast<Bytef*>(&z[0]), &zlen,
                    reinterpret_cast<const Bytef*>(raw.data()), uLong(raw.size()), 9) == Z_OK);
  z.resize(zlen);
  std::string png = "\x89PNG\r\n\x1a\n";
  std::string ihdr;
  put_be32(ihdr, uint32_t(w));
  put_be32(ihdr, uint32_t(h));
  ihdr += char(depth);
  ihdr += char(ctype);
  ihdr += std::string(3, '\0');
  put_chunk(png, "IHDR", ihdr);
  if (!palette.empty()) put_chunk(png, "PLTE", palette);
  put_chunk(png, "IDAT", z);
  put_chunk(png, "IEND", "");
  return png;
}

// The number after "key": in a JSON text (NaN when absent).
double json_number(const std::string& js, const std::string& key) {
  const size_t at = js.find("\"" + key + "\": ");
  return at == std::string::npos ? std::nan("") : std::stod(js.substr(at + key.size() + 4));
}

}  // namespace

TEST_CASE("image_metrics: identical images: no error, PSNR infinite, SSIM 1", "[image_metrics]") {
  Image a = random_image(24, 20, 7, 0.f, 3.f);
  ImageMetrics m = compare_images(a, a);
  CHECK(m.pixels == 24u * 20u);
  CHECK(m.mse == 0.0);
  CHECK(m.rmse == 0.0);
  CHECK(m.rel_mse == 0.0);
  CHECK(m.mae == 0.0);
  CHECK(std::isinf(m.psnr));
  CHECK(m.psnr > 0);
  CHECK(m.ssim == Approx(1.0).epsilon(1e-12));
  CHECK(m.ssim_window == SsimWindow::Valid);
  CHECK(m.ssim_centres == size_t(24 - 10) * size_t(20 - 10));
}

TEST_CASE("image_metrics: constant offset: known RMSE, MAE, PSNR, relMSE and SSIM",
          "[image_metrics]") {
  SECTION("flat images, value 1 and 1.25") {
    // MSE = 0.0625, RMSE = MAE = 0.25, relMSE = 0.0625 / (1 + 0.01), PSNR = 10 log10(1/0.0625)
    // = 12.0412 dB. The reference is flat, so L = 1: C1 = 1e-4, and both images' windows have
    // σ = 0, so SSIM = (2·1.25·1 + C1)/(1.25² + 1 + C1) · C2/C2 = 2.5001 / 2.5626.
    Image ref = constant_image(16, 16, 1.f), test = constant_image(16, 16, 1.25f);
    ImageMetrics m = compare_images(test, ref);
    CHECK(m.mse == Approx(0.0625).epsilon(1e-12));
    CHECK(m.rmse == Approx(0.25).epsilon(1e-12));
    CHECK(m.mae == Approx(0.25).epsilon(1e-12));
    CHECK(m.rel_mse == Approx(0.0625 / 1.01).epsilon(1e-12));
    CHECK(m.peak == 1.0);
    CHECK(m.psnr == Approx(12.041199826559248).epsilon(1e-9));
    CHECK(m.ssim_range == 1.0);
    CHECK(m.ssim == Approx(2.5001 / 2.5626).epsilon(1e-9));
  }
  SECTION("a textured reference plus 0.25") {
    // Values in [0, 0.75) with one pixel at exactly 1: peak 1, PSNR = 20 log10(1/0.25).
    Image ref = random_image(20, 16, 3, 0.f, 0.75f);
    ref.set(5, 5, Vec3(1.f, 1.f, 1.f));
    Image test = ref;
    for (float& v : test.rgb) v += 0.25f;  // rounded to float: differences 0.25 ± 6e-8
    ImageMetrics m = compare_images(test, ref);
    CHECK(m.rmse == Approx(0.25).epsilon(1e-6));
    CHECK(m.mae == Approx(0.25).epsilon(1e-6));
    CHECK(m.psnr == Approx(20.0 * std::log10(4.0)).epsilon(1e-6));
    // relMSE = mean of 0.0625 / (b² + 0.01) over the reference's values.
    double rel = 0;
    for (float b : ref.rgb) rel += 0.0625 / (double(b) * b + 0.01);
    CHECK(m.rel_mse == Approx(rel / double(ref.rgb.size())).epsilon(1e-5));
    // A shift lowers only SSIM's luminance term; the structure and contrast terms stay 1.
    CHECK(m.ssim < 1.0);
    CHECK(m.ssim > 0.5);
  }
}

TEST_CASE("image_metrics: SSIM equals a direct implementation of Wang et al. 2004",
          "[image_metrics][ssim]") {
  Image ref = random_image(27, 23, 11, 0.f, 2.f);
  Image test = ref;
  Image noise = random_image(27, 23, 12, -0.3f, 0.3f);
  for (size_t i = 0; i < test.rgb.size(); ++i) test.rgb[i] += noise.rgb[i];
  ImageMetrics m = compare_images(test, ref);
  // L = max − min of the reference's luminance.
  double ymin = 1e30, ymax = -1e30;
  for (int y = 0; y < 23; ++y)
    for (int x = 0; x < 27; ++x) {
      Vec3 c = ref.get(x, y);
      double Y = 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z;
      ymin = std::min(ymin, Y);
      ymax = std::max(ymax, Y);
    }
  CHECK(m.ssim_range == Approx(ymax - ymin).epsilon(1e-12));
  CHECK(m.ssim == Approx(ssim_direct(test, ref, ymax - ymin)).epsilon(1e-10));
  CHECK(m.ssim < 0.99);

  // More noise, lower SSIM; scaling both images leaves SSIM unchanged (L scales with them).
  Image worse = ref;
  for (size_t i = 0; i < worse.rgb.size(); ++i) worse.rgb[i] += 3.f * noise.rgb[i];
  CHECK(compare_images(worse, ref).ssim < m.ssim);
  Image ref4 = ref, test4 = test;
  for (float& v : ref4.rgb) v *= 4.f;
  for (float& v : test4.rgb) v *= 4.f;
  CHECK(compare_images(test4, ref4).ssim == Approx(m.ssim).epsilon(1e-9));

  // Inverted structure: a checkerboard against its negative is anti-correlated, SSIM near −1.
  Image board(16, 16), inverse(16, 16);
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 16; ++x) {
      float v = float((x + y) % 2);
      board.set(x, y, Vec3(v, v, v));
      inverse.set(x, y, Vec3(1 - v, 1 - v, 1 - v));
    }
  CHECK(compare_images(inverse, board).ssim < -0.9);
}

TEST_CASE("image_metrics: images under 11x11 use clipped windows", "[image_metrics][ssim]") {
  Image a = random_image(8, 6, 5);
  ImageMetrics m = compare_images(a, a);
  CHECK(m.ssim_window == SsimWindow::Clipped);
  CHECK(m.ssim_centres == 48u);
  CHECK(m.ssim == Approx(1.0).epsilon(1e-12));
  Image b = a;
  b.rgb[0] += 0.5f;
  ImageMetrics mb = compare_images(b, a);
  CHECK(mb.ssim < 1.0);
  CHECK(mb.ssim == Approx(ssim_direct(b, a, mb.ssim_range, true)).epsilon(1e-10));
}

TEST_CASE("image_metrics: different sizes are refused", "[image_metrics][badinput]") {
  Image a(16, 16), b(16, 15);
  CHECK_THROWS_AS(compare_images(a, b), InputError);
  try {
    compare_images(a, b, nullptr, "t.exr", "r.exr");
  } catch (const InputError& e) {
    CHECK(std::string(e.what()).find("16x16") != std::string::npos);
    CHECK(std::string(e.what()).find("16x15") != std::string::npos);
  }
  Image mask(15, 16);
  CHECK_THROWS_AS(compare_images(a, a, &mask), InputError);
  Image empty;
  CHECK_THROWS_AS(compare_images(empty, empty), InputError);
}

TEST_CASE("image_metrics: a mask excludes pixels", "[image_metrics][mask]") {
  Image ref = random_image(16, 16, 21), test = ref;
  // Pixels (2, 3) and (10, 12) differ by 1 in every channel.
  test.set(2, 3, test.get(2, 3) + Vec3(1, 1, 1));
  test.set(10, 12, test.get(10, 12) + Vec3(1, 1, 1));
  Image mask = constant_image(16, 16, 1.f);
  mask.set(2, 3, Vec3(0, 0, 0));
  mask.set(10, 12, Vec3(0.2f, 0.6f, 0.6f));  // mean 0.4667 < 0.5: out
  ImageMetrics m = compare_images(test, ref, &mask);
  CHECK(m.pixels == 254u);
  CHECK(m.masked_out == 2u);
  CHECK(m.rmse == 0.0);
  CHECK(m.mae == 0.0);
  // Keep only the four pixels (2..3, 3..4): one differs → MSE = 1/4 (all channels differ by 1).
  Image four = constant_image(16, 16, 0.f);
  for (int y = 3; y <= 4; ++y)
    for (int x = 2; x <= 3; ++x) four.set(x, y, Vec3(0.5f, 0.5f, 0.5f));  // mean 0.5: in
  ImageMetrics q = compare_images(test, ref, &four);
  CHECK(q.pixels == 4u);
  CHECK(q.mse == Approx(0.25).epsilon(1e-6));
  CHECK(q.mae == Approx(0.25).epsilon(1e-6));
  // The four pixels lie within 5 pixels of the border (no whole window around them), so SSIM
  // falls back to clipped windows over them.
  CHECK(q.ssim_window == SsimWindow::Clipped);
  CHECK(q.ssim_centres == 4u);
  // A mask that selects nothing is refused.
  Image none = constant_image(16, 16, 0.f);
  CHECK_THROWS_AS(compare_images(test, ref, &none), InputError);
}

TEST_CASE("image_metrics: PSNR's peak is the reference's largest value over the compared pixels",
          "[image_metrics][psnr]") {
  // Reference values in [0, 2) with a largest value 4 at (3, 3); the test adds 0.5 everywhere:
  // MSE = 0.25 and PSNR = 10 log10(4² / 0.25) — neither 1 (a fixed LDR peak) nor the test's 4.5.
  Image ref = random_image(14, 12, 41, 0.f, 2.f);
  ref.set(3, 3, Vec3(1.f, 4.f, 2.f));
  Image test = ref;
  for (float& v : test.rgb) v += 0.5f;
  ImageMetrics m = compare_images(test, ref);
  CHECK(m.peak == 4.0);
  CHECK(m.mse == Approx(0.25).epsilon(1e-6));
  CHECK(m.psnr == Approx(10.0 * std::log10(16.0 / 0.25)).epsilon(1e-6));
  // A brighter pixel outside the mask is not the peak.
  Image bright_ref = ref, bright_test = test;
  bright_ref.set(9, 9, Vec3(50.f, 50.f, 50.f));
  bright_test.set(9, 9, Vec3(50.5f, 50.5f, 50.5f));
  Image mask = constant_image(14, 12, 1.f);
  mask.set(9, 9, Vec3(0.f, 0.f, 0.f));
  ImageMetrics mm = compare_images(bright_test, bright_ref, &mask);
  CHECK(mm.peak == 4.0);
  CHECK(mm.psnr == Approx(m.psnr).epsilon(1e-9));
  // A reference without a positive value has no peak: PSNR undefined.
  ImageMetrics dark = compare_images(constant_image(12, 12, 0.5f), constant_image(12, 12, 0.f));
  CHECK(std::isnan(dark.psnr));
}

TEST_CASE("image_metrics: SSIM averages only the masked-in centres, L over the masked-in pixels",
          "[image_metrics][ssim][mask]") {
  // 24×24: the images differ only at (20, 20). The windows that see it are those centred at
  // x, y in 15..20; the valid centres are 5..18, so 4×4 of them see it. A mask that keeps the
  // pixels with x < 15 or y < 15 keeps 14² − 4² = 180 valid centres, none of whose windows sees the
  // difference: SSIM exactly 1 over them.
  Image ref = random_image(24, 24, 51);
  Image test = ref;
  test.set(20, 20, test.get(20, 20) + Vec3(0.7f, 0.7f, 0.7f));
  // A masked-out reference pixel far outside the others' range must not set L (or the peak).
  ref.set(23, 23, Vec3(30.f, 30.f, 30.f));
  test.set(23, 23, Vec3(30.f, 30.f, 30.f));
  Image mask = constant_image(24, 24, 1.f);
  for (int y = 15; y < 24; ++y)
    for (int x = 15; x < 24; ++x) mask.set(x, y, Vec3(0.f, 0.f, 0.f));
  ImageMetrics m = compare_images(test, ref, &mask);
  CHECK(m.pixels == 24u * 24u - 81u);
  CHECK(m.ssim_window == SsimWindow::Valid);
  CHECK(m.ssim_centres == 180u);
  CHECK(m.ssim == Approx(1.0).epsilon(1e-12));
  CHECK(m.peak < 1.0);
  double ymin = 1e30, ymax = -1e30;
  for (int y = 0; y < 24; ++y)
    for (int x = 0; x < 24; ++x) {
      if (x >= 15 && y >= 15) continue;
      const Vec3 c = ref.get(x, y);
      const double Y = 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z;
      ymin = std::min(ymin, Y);
      ymax = std::max(ymax, Y);
    }
  CHECK(m.ssim_range == Approx(ymax - ymin).epsilon(1e-12));
  // Without the mask the centres that see the difference lower SSIM.
  ImageMetrics all = compare_images(test, ref);
  CHECK(all.ssim_centres == 196u);
  CHECK(all.ssim < 1.0);
}

TEST_CASE("image_metrics: non-finite pixels are left out and counted", "[image_metrics]") {
  Image ref = random_image(12, 12, 31), test = ref;
  test.rgb[3 * 7 + 1] = std::nanf("");
  ref.rgb[3 * 20] = INFINITY;
  ImageMetrics m = compare_images(test, ref);
  CHECK(m.nonfinite == 2u);
  CHECK(m.pixels == 142u);
  CHECK(m.rmse == 0.0);
  CHECK(std::isfinite(m.ssim));
}

TEST_CASE("image_metrics: PNG masks: all filters, grey, RGB16, palette, alpha, Adam7",
          "[image_metrics][mask][png]") {
  TempDir tmp("metrics-png");
  SECTION("the preview writer's PNG reads back") {
    Image img(7, 5);
    for (int y = 0; y < 5; ++y)
      for (int x = 0; x < 7; ++x) img.set(x, y, Vec3(x / 6.f, y / 4.f, (x + y) % 2 ? 1.f : 0.f));
    write_png(img, tmp / "m.png");
    Image back = read_mask(tmp / "m.png");
    REQUIRE(back.width == 7);
    REQUIRE(back.height == 5);
    const std::vector<uint8_t> q = to_srgb8(img, 0.f);
    for (size_t i = 0; i < q.size(); ++i) CHECK(back.rgb[i] == Approx(q[i] / 255.0).margin(1e-7));
  }
  SECTION("8-bit grey, compressed, all five filter types") {
    // Random values from a small alphabet (0, 85, 170, 255), so that Paeth's ties (equal
    // distances to two neighbours) occur too.
    const int w = 64, h = 40;
    auto val = [](int x, int y) {
      return 85u * (pf_rng_bits(pf_rng_key(9, 0), uint32_t(y * 64 + x), 0) & 3u);
    };
    std::vector<std::string> rows;
    for (int y = 0; y < h; ++y) {
      std::string r;
      for (int x = 0; x < w; ++x) r += char(uint8_t(val(x, y)));
      rows.push_back(r);
    }
    Image m = decode_png(make_png(w, h, 8, 0, rows, 1), "grey.png");
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const float v = float(val(x, y) / 255.0);
        CHECK(m.get(x, y).x == v);
        CHECK(m.get(x, y).z == v);
      }
  }
  SECTION("16-bit RGB") {
    const int w = 4, h = 6;
    std::vector<std::string> rows;
    auto val = [](int x, int y, int c) {
      return uint16_t((x * 9001 + y * 517 + c * 20000) % 65536);
    };
    for (int y = 0; y < h; ++y) {
      std::string r;
      for (int x = 0; x < w; ++x)
        for (int c = 0; c < 3; ++c) {
          r += char(val(x, y, c) >> 8);
          r += char(val(x, y, c) & 0xFF);
        }
      rows.push_back(r);
    }
    Image m = decode_png(make_png(w, h, 16, 2, rows, 6), "rgb16.png");
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        for (int c = 0; c < 3; ++c)
          CHECK(m.get(x, y)[c] == float(val(x, y, c) / 65535.0));
  }
  SECTION("2-bit palette") {
    const int w = 7, h = 5;  // 14 bits per row: 2 bytes, the last 2 bits padding
    std::string palette = {char(0), char(0), char(0), char(255), char(255), char(255),
                           char(255), char(0), char(0), char(0), char(0), char(255)};
    std::vector<std::string> rows;
    auto idx = [](int x, int y) { return (x + 2 * y) % 4; };
    for (int y = 0; y < h; ++y) {
      std::string r(2, '\0');
      for (int x = 0; x < w; ++x) r[size_t(x / 4)] |= char(idx(x, y) << (6 - 2 * (x % 4)));
      rows.push_back(r);
    }
    Image m = decode_png(make_png(w, h, 2, 3, rows, 1, palette), "pal.png");
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        for (int c = 0; c < 3; ++c)
          CHECK(m.get(x, y)[c] == float(uint8_t(palette[size_t(3 * idx(x, y) + c)]) / 255.0));
  }
  SECTION("8-bit grey + alpha and RGBA: alpha dropped") {
    const int w = 5, h = 3;
    auto val = [](int x, int y, int c) { return uint8_t((x * 50 + y * 30 + c * 70) % 256); };
    std::vector<std::string> ga, rgba;
    for (int y = 0; y < h; ++y) {
      std::string a, b;
      for (int x = 0; x < w; ++x) {
        a += char(val(x, y, 0));
        a += char(255 - val(x, y, 3));  // alpha, ignored
        for (int c = 0; c < 4; ++c) b += char(val(x, y, c));
      }
      ga.push_back(a);
      rgba.push_back(b);
    }
    Image g = decode_png(make_png(w, h, 8, 4, ga, 2), "ga.png");
    Image c = decode_png(make_png(w, h, 8, 6, rgba, 4), "rgba.png");
    REQUIRE(g.width == w);
    REQUIRE(c.width == w);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        for (int k = 0; k < 3; ++k) {
          CHECK(g.get(x, y)[k] == float(val(x, y, 0) / 255.0));
          CHECK(c.get(x, y)[k] == float(val(x, y, k) / 255.0));
        }
  }
  SECTION("Adam7-interlaced files decode (libpng de-interlaces them)") {
    // 11×9 8-bit grey: every one of the seven passes has pixels. Each pass is a sub-image of the
    // pixels (x0 + i·dx, y0 + j·dy), its rows filtered with type None (PNG spec. §8.2).
    const int w = 11, h = 9;
    auto val = [](int x, int y) { return uint8_t((x * 23 + y * 41 + 7) % 256); };
    const int adam7[7][4] = {{0, 0, 8, 8}, {4, 0, 8, 8}, {0, 4, 4, 8}, {2, 0, 4, 4},
                             {0, 2, 2, 4}, {1, 0, 2, 2}, {0, 1, 1, 2}};  // x0, y0, dx, dy
    std::string raw;
    for (const auto& p : adam7) {
      const int cols = w > p[0] ? (w - p[0] + p[2] - 1) / p[2] : 0;
      const int rows = h > p[1] ? (h - p[1] + p[3] - 1) / p[3] : 0;
      if (cols == 0 || rows == 0) continue;
      for (int j = 0; j < rows; ++j) {
        raw += '\0';
        for (int i = 0; i < cols; ++i) raw += char(val(p[0] + i * p[2], p[1] + j * p[3]));
      }
    }
    uLongf zlen = compressBound(uLong(raw.size()));
    std::string z(zlen, '\0');
    REQUIRE(compress2(reinterpret_cast<Bytef*>(&z[0]), &zlen,
                      reinterpret_cast<const Bytef*>(raw.data()), uLong(raw.size()), 9) == Z_OK);
    z.resize(zlen);
    std::string png = "\x89PNG\r\n\x1a\n", ihdr;
    put_be32(ihdr, uint32_t(w));
    put_be32(ihdr, uint32_t(h));
    ihdr += std::string{char(8), char(0), char(0), char(0), char(1)};  // grey 8, Adam7
    put_chunk(png, "IHDR", ihdr);
    put_chunk(png, "IDAT", z);
    put_chunk(png, "IEND", "");
    Image m = decode_png(png, "adam7.png");
    REQUIRE(m.width == w);
    REQUIRE(m.height == h);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) CHECK(m.get(x, y).y == float(val(x, y) / 255.0));
    // A non-interlaced file whose header says Adam7: the passes need more data than it holds.
    std::vector<std::string> rows(3, std::string(3, '\x10'));
    std::string plain = make_png(3, 3, 8, 0, rows, 1);
    // IHDR data starts at byte 16; its interlace byte is the 13th; the CRC follows the data.
    plain[16 + 12] = 1;
    std::string mislabelled = plain.substr(0, 29);
    const uint32_t crc =
        uint32_t(crc32(0L, reinterpret_cast<const Bytef*>(plain.data() + 12), 17));
    put_be32(mislabelled, crc);
    mislabelled += plain.substr(33);
    CHECK_THROWS_WITH(decode_png(mislabelled, "i.png"), Catch::Contains("damaged PNG image data"));
  }
  SECTION("palette indices past the palette are refused") {
    // Index 2 with a palette of two entries.
    std::string palette = {char(0), char(0), char(0), char(255), char(255), char(255)};
    std::vector<std::string> idx(2, std::string{char(0), char(1), char(2)});
    CHECK_THROWS_WITH(decode_png(make_png(3, 2, 8, 3, idx, 1, palette), "p.png"),
                      Catch::Contains("palette index"));
  }
  SECTION("image data short of the header's rows, or an unknown filter type, is refused") {
    // A PNG from raw (already filtered) scanline bytes, whatever the header says.
    auto png_from_raw = [](int w, int h, const std::string& raw) {
      uLongf zlen = compressBound(uLong(raw.size()));
      std::string z(zlen, '\0');
      REQUIRE(compress2(reinterpret_cast<Bytef*>(&z[0]), &zlen,
                        reinterpret_cast<const Bytef*>(raw.data()), uLong(raw.size()), 9) == Z_OK);
      z.resize(zlen);
      std::string png = "\x89PNG\r\n\x1a\n", ihdr;
      put_be32(ihdr, uint32_t(w));
      put_be32(ihdr, uint32_t(h));
      ihdr += char(8);  // 8-bit grey
      ihdr += std::string(4, '\0');
      put_chunk(png, "IHDR", ihdr);
      put_chunk(png, "IDAT", z);
      put_chunk(png, "IEND", "");
      return png;
    };
    const std::string row = std::string(1, '\0') + "abc";  // filter None, 3 samples
    CHECK_NOTHROW(decode_png(png_from_raw(3, 3, row + row + row), "ok.png"));
    CHECK_THROWS_WITH(decode_png(png_from_raw(3, 4, row + row + row), "short.png"),
                      Catch::Contains("damaged PNG image data"));
    // A header far larger than deflate could expand the data to is refused before its rows are
    // allocated (here 4 GB).
    CHECK_THROWS_WITH(decode_png(png_from_raw(65536, 65536, row + row + row), "huge.png"),
                      Catch::Contains("need more data than its"));
    // Filter type 5 does not exist (PNG spec. §9.2); the message is libpng's.
    const std::string bad_filter = std::string(1, '\x05') + "abc";
    CHECK_THROWS_WITH(decode_png(png_from_raw(3, 3, row + bad_filter + row), "filter.png"),
                      Catch::Contains("filter.png: has damaged PNG image data: bad adaptive filter "
                                      "value"));
  }
  SECTION("damaged or foreign files are refused") {
    std::vector<std::string> rows(3, std::string(3, '\x7f'));
    std::string png = make_png(3, 3, 8, 0, rows, 1);
    std::string bad = png;
    bad[40] ^= 0x55;  // inside IDAT: CRC mismatch
    CHECK_THROWS_AS(decode_png(bad, "bad.png"), InputError);
    CHECK_THROWS_AS(decode_png(png.substr(0, png.size() / 2), "cut.png"), InputError);
    CHECK_THROWS_AS(decode_png("hello", "text.png"), InputError);
    std::ofstream(tmp / "text.exr") << "not an image";
    CHECK_THROWS_AS(read_mask(tmp / "text.exr"), InputError);
    CHECK_THROWS_AS(read_mask(tmp / "missing.png"), InputError);
  }
}

TEST_CASE("image_metrics: JSON output", "[image_metrics][json]") {
  Image a = constant_image(12, 12, 1.f), b = constant_image(12, 12, 1.25f);
  const std::string same = metrics_json(compare_images(a, a), "a.exr", {"a.exr"}, "");
  CHECK(same.find("\"psnr\": null") != std::string::npos);  // +inf has no JSON number
  CHECK(same.find("\"mask\": null") != std::string::npos);
  CHECK(same.find("\"rmse\": 0,") != std::string::npos);
  const std::string diff = metrics_json(compare_images(b, a), "b \"q\".exr", {"a.exr"}, "m.png");
  CHECK(diff.find("\"rmse\": 0.25,") != std::string::npos);
  CHECK(diff.find("\"test\": \"b \\\"q\\\".exr\"") != std::string::npos);
  CHECK(diff.find("\"mask\": \"m.png\"") != std::string::npos);
  CHECK(diff.find("\"relmse_epsilon\": 0.01") != std::string::npos);
  for (const char* key : {"\"mae\"", "\"psnr\"", "\"ssim\"", "\"ssim_dynamic_range\"",
                          "\"psnr_peak\"", "\"pixels\"", "\"ssim_window\""})
    CHECK(diff.find(key) != std::string::npos);
}

TEST_CASE("image_metrics: every JSON number is the metric of its name", "[image_metrics][json]") {
  // A case where all metrics differ from each other, masked and with a non-finite pixel, so that a
  // value written under another metric's name shows.
  Image ref = random_image(20, 18, 61, 0.f, 3.f);
  Image test = ref;
  Image noise = random_image(20, 18, 62, -0.5f, 0.5f);
  for (size_t i = 0; i < test.rgb.size(); ++i) test.rgb[i] += noise.rgb[i];
  test.rgb[3 * 5] = std::nanf("");
  Image mask = constant_image(20, 18, 1.f);
  mask.set(3, 4, Vec3(0, 0, 0));
  mask.set(7, 9, Vec3(0, 0, 0));
  const ImageMetrics m = compare_images(test, ref, &mask);
  const std::string js = metrics_json(m, "t.exr", {"r.exr"}, "m.exr");
  CHECK(json_number(js, "width") == 20);
  CHECK(json_number(js, "height") == 18);
  CHECK(json_number(js, "pixels") == double(m.pixels));
  CHECK(json_number(js, "masked_out") == 2);
  CHECK(json_number(js, "nonfinite") == 1);
  CHECK(json_number(js, "mse") == m.mse);
  CHECK(json_number(js, "rmse") == m.rmse);
  CHECK(json_number(js, "relmse") == m.rel_mse);
  CHECK(json_number(js, "mae") == m.mae);
  CHECK(json_number(js, "psnr") == m.psnr);
  CHECK(json_number(js, "psnr_peak") == m.peak);
  CHECK(json_number(js, "ssim") == m.ssim);
  CHECK(json_number(js, "ssim_dynamic_range") == m.ssim_range);
  CHECK(json_number(js, "ssim_centres") == double(m.ssim_centres));
  CHECK(js.find("\"ssim_window\": \"valid\"") != std::string::npos);
  CHECK(js.find("\"reference\": \"r.exr\"") != std::string::npos);
  CHECK(js.find("\"test\": \"t.exr\"") != std::string::npos);
  // The values differ from each other, so the checks above tell the names apart.
  CHECK(m.mse != m.rmse);
  CHECK(m.rmse != m.mae);
  CHECK(m.mse != m.rel_mse);
  CHECK(m.masked_out != m.nonfinite);
  // The text form shows the same numbers (6 significant digits).
  const std::string text = metrics_text(m);
  char buf[64];
  std::snprintf(buf, sizeof buf, "RMSE     %.6g\n", m.rmse);
  CHECK(text.find(buf) != std::string::npos);
  std::snprintf(buf, sizeof buf, "MAE      %.6g\n", m.mae);
  CHECK(text.find(buf) != std::string::npos);
  std::snprintf(buf, sizeof buf, "relMSE   %.6g ", m.rel_mse);
  CHECK(text.find(buf) != std::string::npos);
}

TEST_CASE("image_metrics: imgcompare tool: metrics printed and written, bad input refused",
          "[image_metrics][tools]") {
  TempDir tmp("imgcompare");
  Image ref = random_image(20, 20, 41), test = ref;
  for (float& v : test.rgb) v += 0.125f;
  write_exr(ref, tmp / "ref.exr");
  write_exr(test, tmp / "test.exr");
  Image mask = constant_image(20, 20, 1.f);
  mask.set(0, 0, Vec3(0, 0, 0));
  write_png(mask, tmp / "mask.png");

  auto r = test::run_tool("imgcompare",
                          (tmp / "test.exr") + " " + (tmp / "ref.exr") + " --mask " +
                              (tmp / "mask.png") + " --json " + (tmp / "m.json"),
                          tmp);
  INFO("stderr: " << r.err);
  REQUIRE(r.exit_code == 0);
  CHECK(r.out.find("RMSE") != std::string::npos);
  CHECK(r.out.find("SSIM") != std::string::npos);
  const std::string js = test::file_bytes(tmp / "m.json");
  CHECK(js.find("\"pixels\": 399") != std::string::npos);
  CHECK(json_number(js, "rmse") == Approx(0.125).epsilon(1e-6));
  CHECK(json_number(js, "mae") == Approx(0.125).epsilon(1e-6));

  auto to_stdout = test::run_tool("imgcompare", (tmp / "test.exr") + " " + (tmp / "ref.exr") +
                                                    " --json -", tmp);
  CHECK(to_stdout.exit_code == 0);
  CHECK(to_stdout.out.rfind("{", 0) == 0);

  auto refused = [&](const std::string& args, const std::string& needle) {
    std::filesystem::remove(tmp / "out.json");
    auto rr = test::run_tool("imgcompare", args + " --json " + (tmp / "out.json"), tmp);
    INFO("stderr: " << rr.err);
    CHECK(rr.exit_code == 2);
    CHECK(std::count(rr.err.begin(), rr.err.end(), '\n') == 1);
    CHECK(rr.err.find(needle) != std::string::npos);
    CHECK_FALSE(std::filesystem::exists(tmp / "out.json"));
  };
  write_exr(Image(20, 19), tmp / "small.exr");
  refused((tmp / "test.exr") + " " + (tmp / "small.exr"), "same size");
  refused((tmp / "missing.exr") + " " + (tmp / "ref.exr"), "missing.exr");
  refused((tmp / "test.exr") + " " + (tmp / "ref.exr") + " --mask " + (tmp / "small.exr"),
          "mask must have the images' size");
  refused(tmp / "test.exr", "two images");
  // A damaged mask PNG: cut anywhere (a file copied in part, a download stopped), or a flipped
  // byte in its image data (CRC mismatch): one line naming the mask, exit 2, no JSON.
  const std::string mask_png = test::file_bytes(tmp / "mask.png");
  REQUIRE(mask_png.size() > 60);
  for (size_t keep : {size_t(0), size_t(5), size_t(8), size_t(20), size_t(33), size_t(45),
                      mask_png.size() / 2, mask_png.size() - 12, mask_png.size() - 1}) {
    INFO("first " << keep << " of " << mask_png.size() << " bytes");
    std::ofstream(tmp / "cut-mask.png", std::ios::binary) << mask_png.substr(0, keep);
    refused((tmp / "test.exr") + " " + (tmp / "ref.exr") + " --mask " + (tmp / "cut-mask.png"),
            "cut-mask.png: ");
  }
  std::string flipped = mask_png;
  flipped[41] ^= 0x20;  // inside IDAT (its data starts at byte 41)
  std::ofstream(tmp / "bad-mask.png", std::ios::binary) << flipped;
  refused((tmp / "test.exr") + " " + (tmp / "ref.exr") + " --mask " + (tmp / "bad-mask.png"),
          "bad-mask.png: has damaged PNG image data: ");
  auto help = test::run_tool("imgcompare", "--help", tmp);
  CHECK(help.exit_code == 0);
  for (const char* k : {"--mask", "--json", "relMSE", "PSNR", "SSIM", "peak"})
    CHECK(help.out.find(k) != std::string::npos);
}

TEST_CASE("image_metrics: a reference in parts: its mean, its own noise, the net RMSE",
          "[image_metrics][parts]") {
  // Truth t; parts b_j = t + independent noise of standard deviation sigma; a test image
  // t + noise of standard deviation tau. Uniform noise on [-h, h) has sigma = h/sqrt(3).
  const int W = 200, H = 150;
  const Image truth = random_image(W, H, 71, 0.f, 2.f);
  const float h_ref = 0.3f, h_test = 0.6f;
  const double sigma = h_ref / std::sqrt(3.0), tau = h_test / std::sqrt(3.0);
  Image test = truth;
  const Image tn = random_image(W, H, 72, -h_test, h_test);
  for (size_t i = 0; i < test.rgb.size(); ++i) test.rgb[i] += tn.rgb[i];
  for (int n : {2, 3, 6}) {
    INFO(n << " parts");
    std::vector<Image> parts;
    std::vector<std::string> names;
    for (int j = 0; j < n; ++j) {
      Image p = truth;
      const Image noise = random_image(W, H, 100 + uint32_t(j), -h_ref, h_ref);
      for (size_t i = 0; i < p.rgb.size(); ++i) p.rgb[i] += noise.rgb[i];
      parts.push_back(p);
      names.push_back("part" + std::to_string(j) + ".exr");
    }
    const ImageMetrics m = compare_with_parts(test, parts, nullptr, "test.exr", names);
    CHECK(m.reference_parts == n);
    // The mean is the reference: the same numbers as compare_images against it.
    const ImageMetrics direct = compare_images(test, mean_image(parts, names));
    CHECK(m.mse == direct.mse);
    CHECK(m.ssim == direct.ssim);
    // The mean's noise is sigma/sqrt(n) (90,000 values: a few per cent of statistical spread).
    CHECK(m.reference_rmse == Approx(sigma / std::sqrt(double(n))).epsilon(0.03));
    // MSE against the mean = tau² + sigma²/n; the net RMSE recovers tau.
    CHECK(m.rmse == Approx(std::sqrt(tau * tau + sigma * sigma / n)).epsilon(0.03));
    CHECK(m.rmse_net == Approx(tau).epsilon(0.03));
    if (n == 2) {  // two parts: RMSE(b1, b2)/2, exactly up to rounding
      CHECK(m.reference_rmse == Approx(compare_images(parts[0], parts[1]).rmse / 2).epsilon(1e-9));
    }
  }
  // One part: no noise estimate (NaN, null in JSON); the metrics are those against the part.
  const ImageMetrics one = compare_with_parts(test, {truth}, nullptr, "test.exr", {"t.exr"});
  CHECK(one.reference_parts == 1);
  CHECK(std::isnan(one.reference_rmse));
  CHECK(one.mse == compare_images(test, truth).mse);
  CHECK(metrics_json(one, "test.exr", {"t.exr"}, "").find("\"reference_rmse\": null") !=
        std::string::npos);
  // A mask: the noise is estimated over the same pixels as the error. Parts equal outside the
  // masked-in half and different inside: the estimate sees only the inside.
  Image a = constant_image(20, 20, 1.f), b = a, mask = constant_image(20, 20, 0.f);
  for (int y = 0; y < 20; ++y)
    for (int x = 0; x < 10; ++x) {
      mask.set(x, y, Vec3(1, 1, 1));
      b.set(x, y, Vec3(1.5f, 1.5f, 1.5f));
    }
  const ImageMetrics masked = compare_with_parts(a, {a, b}, &mask, "a", {"a", "b"});
  CHECK(masked.pixels == 200);
  CHECK(masked.reference_rmse == Approx(0.25).epsilon(1e-9));  // |b1 − b2| / 2
  // Parts of different sizes are refused, naming the part.
  try {
    compare_with_parts(a, {a, Image(20, 19)}, nullptr, "a", {"r1.exr", "r2.exr"});
    FAIL("parts of different sizes were accepted");
  } catch (const InputError& e) {
    CHECK(std::string(e.what()).find("r2.exr") != std::string::npos);
    CHECK(std::string(e.what()).find("same size") != std::string::npos);
  }
}

TEST_CASE("image_metrics: imgcompare with a reference in parts", "[image_metrics][parts][tools]") {
  TempDir tmp("imgcompare-parts");
  Image truth = random_image(16, 16, 81), p1 = truth, p2 = truth, test = truth;
  for (size_t i = 0; i < truth.rgb.size(); ++i) {
    p1.rgb[i] += 0.1f;
    p2.rgb[i] -= 0.1f;
    test.rgb[i] += 0.25f;
  }
  write_exr(p1, tmp / "r1.exr");
  write_exr(p2, tmp / "r2.exr");
  write_exr(test, tmp / "test.exr");
  auto r = test::run_tool("imgcompare", (tmp / "test.exr") + " " + (tmp / "r1.exr") + " " +
                                            (tmp / "r2.exr") + " --json " + (tmp / "m.json"),
                          tmp);
  INFO("stderr: " << r.err);
  REQUIRE(r.exit_code == 0);
  CHECK(r.out.find("the mean of 2 parts") != std::string::npos);
  const std::string js = test::file_bytes(tmp / "m.json");
  CHECK(json_number(js, "rmse") == Approx(0.25).epsilon(1e-5));           // against the mean
  CHECK(json_number(js, "reference_rmse") == Approx(0.1).epsilon(1e-5));  // |p1 − p2| / 2
  CHECK(json_number(js, "rmse_net") == Approx(std::sqrt(0.25 * 0.25 - 0.01)).epsilon(1e-5));
  CHECK(js.find("\"reference_parts\": [") != std::string::npos);
  write_exr(Image(16, 15), tmp / "small.exr");
  auto bad = test::run_tool("imgcompare", (tmp / "test.exr") + " " + (tmp / "r1.exr") + " " +
                                              (tmp / "small.exr") + " --json " + (tmp / "x.json"),
                            tmp);
  CHECK(bad.exit_code == 2);
  CHECK(std::count(bad.err.begin(), bad.err.end(), '\n') == 1);
  CHECK(bad.err.find("small.exr") != std::string::npos);
  CHECK_FALSE(std::filesystem::exists(tmp / "x.json"));
}
