// Image error metrics and mask reading: see image_metrics.h.
#include "photonflow/image/image_metrics.h"

#include <unistd.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <limits>
#include <sstream>
#include <vector>

#include "photonflow/foundations/error.h"
#include "photonflow/io/output_file.h"
#include "photonflow/foundations/text_file.h"

namespace pf {

const char* ssim_window_name(SsimWindow w) { return w == SsimWindow::Valid ? "valid" : "clipped"; }

namespace {

double luma(const float* rgb) {
  return 0.2126 * double(rgb[0]) + 0.7152 * double(rgb[1]) + 0.0722 * double(rgb[2]);
}

bool finite3(const float* p) {
  return std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]);
}

// Normalised 1-D Gaussian of kSsimWindow taps, σ = kSsimSigma: the 2-D window of Wang et al.
// (MATLAB fspecial('gaussian', 11, 1.5)) is the outer product of two of these.
std::vector<double> gaussian_taps() {
  const int r = kSsimWindow / 2;
  std::vector<double> g(static_cast<size_t>(kSsimWindow));
  double sum = 0;
  for (int k = -r; k <= r; ++k) {
    g[size_t(k + r)] = std::exp(-double(k * k) / (2.0 * kSsimSigma * kSsimSigma));
    sum += g[size_t(k + r)];
  }
  for (double& v : g) v /= sum;
  return g;
}

// Gaussian-weighted local mean of `v` (W×H) at every pixel, separably: a horizontal then a
// vertical pass, each dividing by the sum of the taps that fall inside the image. The product of
// the two partial sums is the sum of the 2-D weights inside the image, so this is the clipped,
// renormalised 2-D window; for a window wholly inside the image it is the plain weighted mean.
std::vector<double> local_mean(const std::vector<double>& v, int W, int H,
                               const std::vector<double>& g) {
  const int r = kSsimWindow / 2;
  std::vector<double> tmp(v.size()), out(v.size());
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      double s = 0, w = 0;
      for (int k = std::max(-r, -x); k <= std::min(r, W - 1 - x); ++k) {
        s += g[size_t(k + r)] * v[size_t(y) * size_t(W) + size_t(x + k)];
        w += g[size_t(k + r)];
      }
      tmp[size_t(y) * size_t(W) + size_t(x)] = s / w;
    }
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      double s = 0, w = 0;
      for (int k = std::max(-r, -y); k <= std::min(r, H - 1 - y); ++k) {
        s += g[size_t(k + r)] * tmp[size_t(y + k) * size_t(W) + size_t(x)];
        w += g[size_t(k + r)];
      }
      out[size_t(y) * size_t(W) + size_t(x)] = s / w;
    }
  return out;
}

// The SSIM map (Wang et al. 2004, eq. 13) of luminance planes x (test) and y (reference).
std::vector<double> ssim_map(const std::vector<double>& x, const std::vector<double>& y, int W,
                             int H, double L) {
  const std::vector<double> g = gaussian_taps();
  const size_t n = x.size();
  std::vector<double> xx(n), yy(n), xy(n);
  for (size_t i = 0; i < n; ++i) {
    xx[i] = x[i] * x[i];
    yy[i] = y[i] * y[i];
    xy[i] = x[i] * y[i];
  }
  const std::vector<double> mx = local_mean(x, W, H, g), my = local_mean(y, W, H, g);
  const std::vector<double> mxx = local_mean(xx, W, H, g), myy = local_mean(yy, W, H, g);
  const std::vector<double> mxy = local_mean(xy, W, H, g);
  const double C1 = (0.01 * L) * (0.01 * L), C2 = (0.03 * L) * (0.03 * L);
  std::vector<double> s(n);
  for (size_t i = 0; i < n; ++i) {
    const double vx = mxx[i] - mx[i] * mx[i];  // σ_x² = E[x²] − μ_x²
    const double vy = myy[i] - my[i] * my[i];
    const double cxy = mxy[i] - mx[i] * my[i];
    s[i] = ((2 * mx[i] * my[i] + C1) * (2 * cxy + C2)) /
           ((mx[i] * mx[i] + my[i] * my[i] + C1) * (vx + vy + C2));
  }
  return s;
}

// The compared pixels P (1) of test against ref: inside the mask and finite in both; counts the
// pixels compared, masked out and non-finite into m.
std::vector<uint8_t> compared_pixels(const Image& test, const Image& ref, const Image* mask,
                                     ImageMetrics& m) {
  const size_t npix = ref.pixel_count();
  std::vector<uint8_t> in(npix, 0);
  for (size_t i = 0; i < npix; ++i) {
    if (mask) {
      const float* q = &mask->rgb[3 * i];
      if (!((double(q[0]) + double(q[1]) + double(q[2])) / 3.0 >= 0.5)) {
        ++m.masked_out;
        continue;
      }
    }
    if (!finite3(&test.rgb[3 * i]) || !finite3(&ref.rgb[3 * i])) {
      ++m.nonfinite;
      continue;
    }
    in[i] = 1;
    ++m.pixels;
  }
  return in;
}

std::string size_text(const Image& i) {
  return std::to_string(i.width) + "x" + std::to_string(i.height);
}

}  // namespace

namespace {

// compare_images, leaving the compared pixels P in `in` (compare_with_parts estimates the
// reference's noise over the same pixels).
ImageMetrics compare_images(const Image& test, const Image& ref, const Image* mask,
                            const std::string& test_name, const std::string& ref_name,
                            const std::string& mask_name, std::vector<uint8_t>& in) {
  const auto size = size_text;
  if (test.width != ref.width || test.height != ref.height)
    throw input_error(test_name, "is " + size(test) + " but " + ref_name + " is " + size(ref),
                      "images must have the same size");
  if (test.pixel_count() == 0) throw input_error(test_name, "is empty");
  if (mask && (mask->width != ref.width || mask->height != ref.height))
    throw input_error(mask_name, "is " + size(*mask) + " but the images are " + size(ref),
                      "the mask must have the images' size");
  const int W = ref.width, H = ref.height;
  const size_t npix = ref.pixel_count();
  ImageMetrics m;
  m.width = W;
  m.height = H;

  in = compared_pixels(test, ref, mask, m);
  if (m.pixels == 0)
    throw input_error(mask ? mask_name : test_name,
                      mask ? "selects no pixel with finite values in both images"
                           : "has no pixel with finite values in both images");

  // Pixel-wise metrics, summed in double.
  double se = 0, rel = 0, ae = 0, peak = -std::numeric_limits<double>::infinity();
  double ymin = std::numeric_limits<double>::infinity(), ymax = -ymin;
  for (size_t i = 0; i < npix; ++i) {
    if (!in[i]) continue;
    for (int c = 0; c < 3; ++c) {
      const double a = test.rgb[3 * i + size_t(c)], b = ref.rgb[3 * i + size_t(c)];
      const double d = a - b;
      se += d * d;
      rel += d * d / (b * b + kRelMseEpsilon);
      ae += std::fabs(d);
      peak = std::max(peak, b);
    }
    const double y = luma(&ref.rgb[3 * i]);
    ymin = std::min(ymin, y);
    ymax = std::max(ymax, y);
  }
  const double N = 3.0 * double(m.pixels);
  m.mse = se / N;
  m.rmse = std::sqrt(m.mse);
  m.rel_mse = rel / N;
  m.mae = ae / N;
  m.peak = peak;
  if (!(peak > 0.0))
    m.psnr = std::numeric_limits<double>::quiet_NaN();
  else if (m.mse == 0.0)
    m.psnr = std::numeric_limits<double>::infinity();
  else
    m.psnr = 10.0 * std::log10(peak * peak / m.mse);

  // SSIM on luminance (non-finite pixels enter the windows as 0).
  std::vector<double> yt(npix), yr(npix);
  for (size_t i = 0; i < npix; ++i) {
    yt[i] = finite3(&test.rgb[3 * i]) ? luma(&test.rgb[3 * i]) : 0.0;
    yr[i] = finite3(&ref.rgb[3 * i]) ? luma(&ref.rgb[3 * i]) : 0.0;
  }
  m.ssim_range = ymax - ymin > 0.0 ? ymax - ymin : 1.0;
  const std::vector<double> s = ssim_map(yt, yr, W, H, m.ssim_range);
  const int r = kSsimWindow / 2;
  double sum = 0;
  size_t count = 0;
  for (int y = r; y < H - r; ++y)
    for (int x = r; x < W - r; ++x) {
      const size_t i = size_t(y) * size_t(W) + size_t(x);
      if (!in[i]) continue;
      sum += s[i];
      ++count;
    }
  m.ssim_window = SsimWindow::Valid;
  if (count == 0) {  // too small, or the mask keeps no valid centre: clipped windows
    m.ssim_window = SsimWindow::Clipped;
    for (size_t i = 0; i < npix; ++i)
      if (in[i]) {
        sum += s[i];
        ++count;
      }
  }
  m.ssim = sum / double(count);
  m.ssim_centres = count;
  return m;
}

}  // namespace

Image mean_image(const std::vector<Image>& parts, const std::vector<std::string>& names) {
  if (parts.empty()) throw input_error("", "no reference image", "give at least one");
  const auto name = [&](size_t j) { return j < names.size() ? names[j] : "part " + std::to_string(j + 1); };
  Image mean(parts[0].width, parts[0].height);
  std::vector<double> sum(mean.rgb.size(), 0.0);
  for (size_t j = 0; j < parts.size(); ++j) {
    if (parts[j].width != mean.width || parts[j].height != mean.height)
      throw input_error(name(j), "is " + size_text(parts[j]) + " but " + name(0) + " is " +
                                     size_text(parts[0]),
                        "the reference's parts must have the same size");
    for (size_t i = 0; i < sum.size(); ++i) sum[i] += double(parts[j].rgb[i]);
  }
  for (size_t i = 0; i < sum.size(); ++i) mean.rgb[i] = float(sum[i] / double(parts.size()));
  return mean;
}

ImageMetrics compare_with_parts(const Image& test, const std::vector<Image>& parts,
                                const Image* mask, const std::string& test_name,
                                const std::vector<std::string>& names,
                                const std::string& mask_name) {
  const Image mean = mean_image(parts, names);
  std::vector<uint8_t> in;  // the compared pixels P
  ImageMetrics m = compare_images(test, mean, mask, test_name,
                                  names.empty() ? std::string("reference") : names[0], mask_name, in);
  m.reference_parts = int(parts.size());
  if (parts.size() < 2) return m;
  const double n = double(parts.size());
  double var = 0;  // Σ s²/n over the compared values (header: reference MSE)
  for (size_t i = 0; i < in.size(); ++i) {
    if (!in[i]) continue;
    for (size_t c = 3 * i; c < 3 * i + 3; ++c) {
      const double mu = double(mean.rgb[c]);  // b, the reference compared with
      double ss = 0;
      for (const Image& p : parts) ss += (double(p.rgb[c]) - mu) * (double(p.rgb[c]) - mu);
      var += ss / (n - 1.0) / n;
    }
  }
  const double ref_mse = var / (3.0 * double(m.pixels));
  m.reference_rmse = std::sqrt(ref_mse);
  m.rmse_net = std::sqrt(std::max(m.mse - ref_mse, 0.0));
  return m;
}

ImageMetrics compare_images(const Image& test, const Image& ref, const Image* mask,
                            const std::string& test_name, const std::string& ref_name,
                            const std::string& mask_name) {
  std::vector<uint8_t> in;
  return compare_images(test, ref, mask, test_name, ref_name, mask_name, in);
}


Image read_mask(const std::string& path) {
  require_regular_input(path);
  std::ifstream f(path, std::ios::binary);
  if (!f) throw input_error(path, "cannot open the mask file", "check the path");
  char head[8] = {};
  f.read(head, 8);
  static const char png_sig[8] = {'\x89', 'P', 'N', 'G', '\r', '\n', '\x1A', '\n'};
  if (f.gcount() == 8 && std::equal(head, head + 8, png_sig)) {
    std::stringstream ss;
    f.seekg(0);
    ss << f.rdbuf();
    return decode_png(ss.str(), path);
  }
  return read_exr(path);
}

std::string metrics_json(const ImageMetrics& m, const std::string& test_path,
                         const std::vector<std::string>& reference_paths,
                         const std::string& mask_path) {
  Json doc = Json::object();
  doc["test"] = test_path;
  doc["reference"] = reference_paths.empty() ? std::string() : reference_paths[0];
  doc["mask"] = mask_path.empty() ? Json(nullptr) : Json(mask_path);
  doc["width"] = m.width;
  doc["height"] = m.height;
  doc["pixels"] = m.pixels;
  doc["masked_out"] = m.masked_out;
  doc["nonfinite"] = m.nonfinite;
  doc["mse"] = json_value(m.mse);
  doc["rmse"] = json_value(m.rmse);
  doc["relmse"] = json_value(m.rel_mse);
  doc["relmse_epsilon"] = json_value(kRelMseEpsilon);
  doc["mae"] = json_value(m.mae);
  doc["psnr"] = json_value(m.psnr);
  doc["psnr_peak"] = json_value(m.peak);
  doc["ssim"] = json_value(m.ssim);
  doc["ssim_dynamic_range"] = json_value(m.ssim_range);
  doc["ssim_window"] = ssim_window_name(m.ssim_window);
  doc["ssim_centres"] = m.ssim_centres;
  doc["reference_parts"] = reference_paths;
  doc["reference_rmse"] = json_value(m.reference_rmse);
  doc["rmse_net"] = json_value(m.rmse_net);
  return json_record_text(doc);
}

std::string metrics_text(const ImageMetrics& m) {
  char buf[512];
  std::string psnr;
  if (std::isinf(m.psnr))
    psnr = "inf (identical)";
  else if (std::isnan(m.psnr))
    psnr = "undefined (reference peak <= 0)";
  else {
    std::snprintf(buf, sizeof buf, "%.4f dB", m.psnr);
    psnr = buf;
  }
  std::snprintf(buf, sizeof buf,
                "pixels   %zu of %dx%d (%zu masked out, %zu non-finite)\n"
                "RMSE     %.6g\n"
                "relMSE   %.6g (epsilon %g)\n"
                "MAE      %.6g\n"
                "PSNR     %s (peak %.6g)\n"
                "SSIM     %.6f (L = %.6g, %s windows, %zu centres)\n",
                m.pixels, m.width, m.height, m.masked_out, m.nonfinite, m.rmse, m.rel_mse,
                kRelMseEpsilon, m.mae, psnr.c_str(), m.peak, m.ssim, m.ssim_range,
                ssim_window_name(m.ssim_window), m.ssim_centres);
  std::string out = buf;
  if (m.reference_parts > 1) {
    std::snprintf(buf, sizeof buf,
                  "reference: the mean of %d parts, its own RMSE %.6g (from their spread)\n"
                  "RMSE net %.6g (RMSE with the reference's noise taken out)\n",
                  m.reference_parts, m.reference_rmse, m.rmse_net);
    out += buf;
  }
  return out;
}

void write_metrics_file(const std::string& path, const std::string& text) {
  write_text_atomic(path, text);
}

}  // namespace pf
