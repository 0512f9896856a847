// imgcompare — error metrics of a test image against a reference (image_metrics.h): RMSE,
// relative MSE, MAE, PSNR and SSIM over all pixels or a mask, printed and optionally written as
// JSON. Images of different sizes are refused (one line, exit 2).
//
//   imgcompare test.exr reference.exr [--mask mask.exr|mask.png] [--json out.json]
#include <iostream>
#include <string>

#include "photonflow/image_metrics.h"
#include "photonflow/tool_main.h"

int main(int argc, char** argv) {
  return pf::run_tool("imgcompare", [&] {
    cxxopts::Options o("imgcompare",
                       "Compare a test image with a reference: RMSE, relative MSE, MAE, PSNR, "
                       "SSIM.");
    // clang-format off
    o.add_options()
      ("test", "test image (OpenEXR; RGB channels, linear)", cxxopts::value<std::string>())
      ("reference", "reference image (OpenEXR, the same size)", cxxopts::value<std::string>())
      ("mask", "compare only pixels whose mask value (mean of R, G, B; PNG values scaled to "
       "[0, 1]) is >= 0.5; OpenEXR or PNG, the images' size; default: all pixels",
       cxxopts::value<std::string>()->default_value(""))
      ("json", "also write the metrics as JSON to this file ('-': standard output instead of "
       "the text table)", cxxopts::value<std::string>()->default_value(""))
      ("h,help", "print this help");
    // clang-format on
    o.parse_positional({"test", "reference"});
    o.positional_help("test.exr reference.exr");
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
                   "counted.\n";
      return 0;
    }
    if (!a.count("test") || !a.count("reference"))
      throw pf::input_error("", "two images are needed: imgcompare test.exr reference.exr");
    const std::string test_path = a["test"].as<std::string>();
    const std::string ref_path = a["reference"].as<std::string>();
    const std::string mask_path = a["mask"].as<std::string>();
    const std::string json = a["json"].as<std::string>();
    pf::check_outputs({test_path, ref_path, mask_path}, {json == "-" ? std::string() : json});

    const pf::Image test = pf::read_exr(test_path);
    const pf::Image ref = pf::read_exr(ref_path);
    pf::Image mask;
    if (!mask_path.empty()) mask = pf::read_mask(mask_path);
    const pf::ImageMetrics m = pf::compare_images(test, ref, mask_path.empty() ? nullptr : &mask,
                                                  test_path, ref_path, mask_path);
    const std::string js = pf::metrics_json(m, test_path, ref_path, mask_path);
    if (json == "-") {
      std::cout << js;
    } else {
      std::cout << "imgcompare: " << test_path << " vs " << ref_path << "\n" << pf::metrics_text(m);
      if (!json.empty()) pf::write_metrics_file(json, js);
    }
    return 0;
  });
}
