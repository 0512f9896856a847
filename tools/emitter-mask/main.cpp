// emitter-mask — the mask of the pixels that see no light source (emitter_mask.h), for
// `imgcompare --mask`: error metrics of the speed–accuracy pipeline leave out the emitters seen
// by the camera, whose outline pixels measure pixel sampling rather than light transport.
//
//   emitter-mask --scene scene.h5 -o mask.exr [--spp 16] [--dilate 1]
#include <iostream>

#include "photonflow/stages/emitter_mask.h"
#include "photonflow/foundations/options.h"
#include "photonflow/geometry/scene.h"
#include "photonflow/geometry/scene_file.h"
#include "photonflow/foundations/tool_main.h"

int main(int argc, char** argv) {
  return pf::run_tool("emitter-mask", [&] {
    cxxopts::Options o("emitter-mask",
                       "Mask of the pixels that see no emitter (directly or through mirrors and "
                       "glass): 1 = compare, 0 = leave out; for imgcompare --mask.");
    // clang-format off
    o.add_options()
      ("scene", "baked scene (scene.h5 from scene-bake)", cxxopts::value<std::string>())
      ("o,output", "output mask (OpenEXR, RGB 1 or 0)", cxxopts::value<std::string>())
      ("spp", "eye samples per pixel looking for emitters", cxxopts::value<int>()->default_value("16"))
      ("dilate", "pixels added around the emitters' pixels", cxxopts::value<int>()->default_value("1"))
      ("max-depth", "specular bounces followed", cxxopts::value<int>()->default_value("16"))
      ("threads", "worker threads, 0 = all cores", cxxopts::value<int>()->default_value("0"))
      ("h,help", "print this help");
    // clang-format on
    auto a = pf::parse_options(o, argc, argv);
    if (a.count("help")) { std::cout << o.help() << "\n"; return 0; }
    pf::require_options(o, a, {"scene", "output"});
    pf::check_output_options(a, {"scene"}, {"output"});
    pf::EmitterMaskOptions opt;
    opt.spp = a["spp"].as<int>();
    opt.dilate = a["dilate"].as<int>();
    opt.max_depth = a["max-depth"].as<int>();
    opt.threads = a["threads"].as<int>();
    pf::require_positive("spp", opt.spp);
    if (opt.dilate < 0) throw pf::input_error("", "--dilate must be >= 0");
    const pf::Scene scene = pf::load_scene(a["scene"].as<std::string>());
    const pf::EmitterMask m = pf::emitter_mask(scene, opt);
    const std::string out = a["output"].as<std::string>();
    pf::write_exr(m.mask, out);
    std::cout << "emitter-mask: " << out << " (" << m.mask.width << "x" << m.mask.height << ", "
              << m.excluded << " pixels left out, " << m.seeing << " see an emitter)\n";
    return 0;
  });
}
