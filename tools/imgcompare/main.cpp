// imgcompare — error metrics of a test image against a reference (image_metrics.h): RMSE,
// relative MSE, MAE, PSNR and SSIM over all pixels or a mask, printed and optionally written as
// JSON. Images of different sizes are refused (one line, exit 2). Several reference files are the
// parts of one reference (independent renders): the test is compared with their mean, and the
// reference's own noise is estimated from their spread (image_metrics.h).
//
//   imgcompare test.exr reference.exr [part2.exr ...] [--mask mask.exr|mask.png] [--json out.json]
#include <iostream>
#include <string>
#include <vector>

#include "photonflow/image/image_metrics.h"
#include "photonflow/foundations/tool_main.h"

int main(int argc, char** argv) {
  return pf::run_tool("imgcompare", [&] {
    cxxopts::Options o("imgcompare",
                       "Compare a test image with a reference: RMSE, relative MSE, MAE, PSNR, "
                       "SSIM.");
    // clang-format off
    o.add_options()
      ("test", "test image (OpenEXR; RGB channels, linear)", cxxopts::value<std::string>())
      ("reference", "reference image (OpenEXR, the same size); several: the parts of one "
       "reference, compared as their mean", cxxopts::value<std::vector<std::string>>())
      ("mask", "compare only pixels whose mask value (mean of R, G, B; PNG values scaled to "
       "[0, 1]) is >= 0.5; OpenEXR or PNG, the images' size; default: all pixels",
       cxxopts::value<std::string>()->default_value(""))
      ("json", "also write the metrics as JSON to this file ('-': standard output instead of "
       "the text table)", cxxopts::value<std::string>()->default_value(""))
      ("h,help", "print this help");
    // clang-format on
    o.parse_positional({"test", "reference"});
    o.positional_help("test.exr reference.exr [reference-part.exr ...]");
    auto a = pf::parse_options(o, argc, argv);
    if (a.count("help")) {
      std::cout << o.help()
                << "\nDefinitions (N = 3 x compared pixels, a = test, b = reference, per "
                   "channel):\n"
                   "  RMSE   = sqrt(1/N sum (a-b)^2)\n"
                   "  relMSE = 1/N sum (a-b)^2 / (b^2 + 0.01)\n"
                   "  MAE    = 1/N sum |a-b|\n"
                   "  PSNR   = 10 log10(peak^2 / MSE) dB, peak = largest reference value compared\n"
                   "  SSIM   = Wang et al. 2004 on luminance Y = 0.2126R + 0.7152G + 0.0722B,\n"
                   "           11x11 Gaussian window (sigma 1.5), C1 = (0.01 L)^2,\n"
                   "           C2 = (0.03 L)^2, L = max - min of the reference's Y (1 if flat);\n"
                   "           mean over window centres 5+ pixels inside the image (clipped\n"
                   "           windows for images under 11x11)\n"
                   "Pixels with a NaN or infinite channel in either image are left out and "
                   "counted.\n"
                   "A reference in n >= 2 parts b_j: b = their mean, s^2 = 1/(n-1) sum_j "
                   "(b_j - b)^2,\n"
                   "  reference RMSE = sqrt(1/N sum s^2/n) (its noise), RMSE net = sqrt(max(MSE - "
                   "reference MSE, 0)).\n";
      return 0;
    }
    if (!a.count("test") || !a.count("reference"))
      throw pf::input_error("", "two images are needed: imgcompare test.exr reference.exr");
    const std::string test_path = a["test"].as<std::string>();
    const auto ref_paths = a["reference"].as<std::vector<std::string>>();
    const std::string mask_path = a["mask"].as<std::string>();
    const std::string json = a["json"].as<std::string>();
    std::vector<std::string> inputs = {test_path, mask_path};
    inputs.insert(inputs.end(), ref_paths.begin(), ref_paths.end());
    pf::check_outputs(inputs, {json == "-" ? std::string() : json});

    const pf::Image test = pf::read_exr(test_path);
    std::vector<pf::Image> parts;
    for (const std::string& r : ref_paths) parts.push_back(pf::read_exr(r));
    pf::Image mask;
    if (!mask_path.empty()) mask = pf::read_mask(mask_path);
    const pf::ImageMetrics m = pf::compare_with_parts(
        test, parts, mask_path.empty() ? nullptr : &mask, test_path, ref_paths, mask_path);
    const std::string js = pf::metrics_json(m, test_path, ref_paths, mask_path);
    if (json == "-") {
      std::cout << js;
    } else {
      std::cout << "imgcompare: " << test_path << " vs " << ref_paths[0]
                << (ref_paths.size() > 1 ? " (+ " + std::to_string(ref_paths.size() - 1) +
                                               " parts)"
                                         : std::string())
                << "\n"
                << pf::metrics_text(m);
      if (!json.empty()) pf::write_metrics_file(json, js);
    }
    return 0;
  });
}
