// synthesize — image synthesis (thesis eq. 3.19): L = τ/(π R² N_emitted) per hitpoint, times its
// weight, plus the emitted and direct layers; writes an OpenEXR (linear RGB + AOV layers radius,
// photons, hitpoints) and an sRGB PNG preview. With --sums instead of --hitpoints: the mean of the
// pass estimates of a probabilistic PPM range (pass_sums.h; render --sums or merge --sums).
#include <iostream>

#include "photonflow/opencl/cl_backend.h"
#include "photonflow/opencl/device_options.h"
#include "photonflow/estimators/pass_sums.h"
#include "photonflow/io/stage_files.h"
#include "photonflow/stages/synthesize.h"
#include "photonflow/foundations/tool_main.h"

int main(int argc, char** argv) {
  return pf::run_tool("synthesize", [&] {
    cxxopts::Options o("synthesize", "Turn a hitpoint state into an image (EXR + PNG preview).");
    o.add_options()
      ("hitpoints", "hitpoint state (from illuminate)", cxxopts::value<std::string>())
      ("sums", "pppm pass sums instead (from render --sums, merge --sums or illuminate "
       "--estimator pppm)", cxxopts::value<std::string>())
      ("o,output", "output OpenEXR image (linear RGB, W/(sr m^2))", cxxopts::value<std::string>())
      ("png", "sRGB PNG preview; default: the output with .png; 'none': no preview",
       cxxopts::value<std::string>()->default_value(""))
      ("exposure", "PNG exposure in stops (the EXR is never scaled)",
       cxxopts::value<float>()->default_value("0"))
      ("h,help", "print this help");
    pf::add_device_options(o);
    auto a = pf::parse_options(o, argc, argv);
    if (a.count("help")) { std::cout << o.help() << "\n"; return 0; }
    if (pf::list_devices_requested(a)) return 0;
    const bool from_sums = a.count("sums") > 0;
    if (from_sums && a.count("hitpoints"))
      throw pf::input_error("", "give --hitpoints or --sums, not both");
    if (from_sums)
      pf::require_options(o, a, {"sums", "output"});
    else
      pf::require_options(o, a, {"hitpoints", "output"});
    std::string out = a["output"].as<std::string>();
    std::string png = a["png"].as<std::string>();
    if (png.empty()) png = pf::preview_path(out);
    pf::check_outputs({pf::path_option(a, from_sums ? "sums" : "hitpoints")},
                      {out, png == "none" ? "" : png});
    if (from_sums) {
      const pf::PassSums s = pf::load_pass_sums(a["sums"].as<std::string>());
      if (s.passes == 0)
        throw pf::input_error(a["sums"].as<std::string>(), "holds no pass", "render passes first");
      const pf::Image img = pf::synthesize(s);
      pf::write_exr(img, out);
      if (png != "none") pf::write_png(img, png, a["exposure"].as<float>());
      std::cout << "synthesize: " << out << (png != "none" ? " and " + png : "") << " ("
                << s.width << "x" << s.height << ", passes [" << s.first_pass << ", "
                << s.end_pass() << "), " << s.photons_emitted << " photons)\n";
      return 0;
    }
    pf::HitpointSet h = pf::load_hitpoints(a["hitpoints"].as<std::string>());
    if (h.estimator == "none")
      throw pf::input_error(a["hitpoints"].as<std::string>(), "has no photons gathered yet",
                            "run illuminate on it first");
    std::unique_ptr<pf::ClContext> dev = pf::open_device(pf::device_options(a), "synthesize");
    pf::Image img = dev ? pf::synthesize(h, *dev) : pf::synthesize(h);
    pf::write_exr(img, out);
    if (png != "none") pf::write_png(img, png, a["exposure"].as<float>());
    std::cout << "synthesize: " << out << (png != "none" ? " and " + png : "") << " ("
              << h.width << "x" << h.height
              << ", " << h.passes << " pass(es), " << h.photons_emitted << " photons)\n";
    return 0;
  });
}
