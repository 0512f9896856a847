// image_metrics.h — error metrics between a rendered image and a reference (what imgcompare prints):
// RMSE, relative MSE, MAE, PSNR and SSIM, over all pixels or the pixels of a mask.
//
// Let P be the compared pixels (all, or those whose mask value is >= 0.5; pixels where either
// image has a NaN or infinite channel are left out and counted), a the test image, b the reference,
// and the sums run over p ∈ P and the channels c ∈ {R, G, B}, N = 3·|P| values:
//   MSE    = 1/N Σ (a − b)²,                 RMSE = √MSE
//   relMSE = 1/N Σ (a − b)² / (b² + ε),      ε = 0.01 (the relative MSE of the denoising and
//            rendering literature, e.g. Rousselle et al. 2011, Bitterli et al. 2016: the error
//            relative to the reference's value, with ε keeping dark pixels from dominating)
//   MAE    = 1/N Σ |a − b|
//   PSNR   = 10 · log10(peak² / MSE) dB, peak = the largest reference value max_{p∈P, c} b
//            (HDR images have no fixed peak such as 255); +∞ when MSE = 0, undefined (NaN) when
//            peak <= 0.
//   SSIM   = the mean structural similarity of Wang, Bovik, Sheikh & Simoncelli (2004, IEEE TIP
//            13(4), eq. 13 and the MSSIM of eq. 17) on float luminance Y = 0.2126 R + 0.7152 G +
//            0.0722 B (no 8-bit quantisation), with an 11×11 Gaussian window of σ = 1.5 normalised
//            to sum 1 (the paper's window):
//              SSIM(x, y) = (2 μ_x μ_y + C1)(2 σ_xy + C2) / ((μ_x² + μ_y² + C1)(σ_x² + σ_y² + C2)),
//            μ, σ², σ_xy the window-weighted means, variances and covariance (no Bessel
//            correction), C1 = (0.01·L)², C2 = (0.03·L)², with L the dynamic range of the
//            reference's luminance over P: L = max Y_ref − min Y_ref (L = 1 if that is 0, a flat
//            reference). As in the paper's code (filter2 'valid'), the mean runs over window
//            centres whose whole window lies inside the image (at least 5 pixels from every
//            border) and that are in P. Images smaller than 11×11, or masks with no such centre,
//            fall back to every pixel of P with the window clipped at the image border and its
//            weights renormalised (SsimWindow::Clipped). The window covers masked-out pixels too
//            (the mask selects which centres are averaged).
//
// A reference in parts (compare_with_parts): n >= 1 independent renders b_1 … b_n of the same image
// (other seeds, same method and effort). The reference is their mean b = 1/n Σ_j b_j, and for
// n >= 2 its own noise is estimated from the parts' spread over the same pixels P:
//   s² = 1/(n−1) Σ_j (b_j − b)²   per value (the unbiased sample variance),
//   reference MSE = 1/N Σ s²/n,     reference_rmse = √(reference MSE)
// (for n = 2 that is RMSE(b_1, b_2)/2; a bias common to every part is not seen). The test image
// is independent of the parts, so E[MSE] = MSE against the truth + reference MSE for unbiased
// parts, and rmse_net = √max(MSE − reference MSE, 0) estimates the test's own RMSE.
#pragma once
#include <cstddef>
#include <limits>
#include <string>
#include <vector>

#include "photonflow/image/image.h"

namespace pf {

constexpr double kRelMseEpsilon = 0.01;  // ε of the relative MSE
constexpr int kSsimWindow = 11;          // Gaussian window, pixels across
constexpr double kSsimSigma = 1.5;       // its standard deviation, pixels

enum class SsimWindow { Valid, Clipped };
const char* ssim_window_name(SsimWindow w);

struct ImageMetrics {
  int width = 0, height = 0;
  size_t pixels = 0;           // |P|: pixels compared
  size_t masked_out = 0;       // pixels the mask left out
  size_t nonfinite = 0;        // pixels left out for a NaN or infinite channel
  double mse = 0, rmse = 0, rel_mse = 0, mae = 0;
  double psnr = 0;             // dB; +inf for identical images, NaN when peak <= 0
  double peak = 0;             // PSNR's peak: the largest reference value over P
  double ssim = 0;
  double ssim_range = 0;       // L of C1 and C2
  SsimWindow ssim_window = SsimWindow::Valid;
  size_t ssim_centres = 0;     // window centres averaged
  // A reference in parts (compare_with_parts); NaN with one part.
  int reference_parts = 1;
  double reference_rmse = std::numeric_limits<double>::quiet_NaN();  // the mean's own noise
  double rmse_net = std::numeric_limits<double>::quiet_NaN();        // √max(MSE − ref. MSE, 0)
};

// Compares `test` with `reference` (RGB only; layers are ignored). `mask`, when not null, selects
// the pixels whose mean of R, G, B is >= 0.5. Throws InputError (naming `test_name` etc.) when the
// sizes differ, the images are empty, or no pixel is left to compare.
ImageMetrics compare_images(const Image& test, const Image& reference, const Image* mask = nullptr,
                            const std::string& test_name = "test",
                            const std::string& reference_name = "reference",
                            const std::string& mask_name = "mask");

// The mean of `parts` (RGB; layers dropped): InputError naming the part when the sizes differ or
// there is no part.
Image mean_image(const std::vector<Image>& parts, const std::vector<std::string>& names);

// compare_images against the mean of `parts`, with reference_parts, reference_rmse and rmse_net
// (see the top of this file) over the same compared pixels. names[j] names parts[j].
ImageMetrics compare_with_parts(const Image& test, const std::vector<Image>& parts,
                                const Image* mask, const std::string& test_name,
                                const std::vector<std::string>& names,
                                const std::string& mask_name = "mask");

// A mask image from an OpenEXR (read_exr) or a PNG file (recognised by its signature; 8- and
// 16-bit grey, grey + alpha, RGB, RGBA and palette images, non-interlaced; values scaled to
// [0, 1], alpha ignored). InputError when it cannot be read.
Image read_mask(const std::string& path);

// The metrics as a JSON object (RFC 8259; +∞ and NaN become null):
//   {"test", "reference", "mask" (null without one), "width", "height", "pixels", "masked_out",
//    "nonfinite", "mse", "rmse", "relmse", "relmse_epsilon", "mae", "psnr", "psnr_peak", "ssim",
//    "ssim_dynamic_range", "ssim_window" ("valid" | "clipped"), "ssim_centres",
//    "reference_parts" (the paths), "reference_rmse", "rmse_net" (null with one part)}
// `reference_paths` are the reference's parts; "reference" is the first.
std::string metrics_json(const ImageMetrics& m, const std::string& test_path,
                         const std::vector<std::string>& reference_paths,
                         const std::string& mask_path);

// The metrics as text for a terminal, one metric per line.
std::string metrics_text(const ImageMetrics& m);

// Writes `text` to `path` atomically ("<path>.tmp.<pid>", then rename); InputError if it cannot.
void write_metrics_file(const std::string& path, const std::string& text);

}  // namespace pf
