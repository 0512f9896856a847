// trace-photons — photon passes (thesis ch. 3.4 pass 1, ch. 7.2): photons leave the lights in
// proportion to power, bounce on diffuse (cosine, Russian roulette by albedo), mirror and glass
// (Fresnel), and are stored at diffuse hits. Writes photons.h5 (global map + caustic map, a pass
// table). Counter-based randomness: the same photons for any thread count.
#include <iostream>

#include "photonflow/cl_backend.h"
#include "photonflow/device_options.h"
#include "photonflow/options.h"
#include "photonflow/photon_pass.h"
#include "photonflow/progress.h"
#include "photonflow/stage_files.h"
#include "photonflow/tool_main.h"

int main(int argc, char** argv) {
  return pf::run_tool("trace-photons", [&] {
    cxxopts::Options o("trace-photons",
                       "Trace photon passes from the lights and store photons at diffuse hits.");
    o.add_options()
      ("scene", "baked scene (scene.h5 from scene-bake)", cxxopts::value<std::string>())
      ("o,output", "output photons file (.h5)", cxxopts::value<std::string>())
      ("photons", "photons emitted per pass", cxxopts::value<int64_t>()->default_value("100000"))
      ("passes", "number of passes in this file", cxxopts::value<int>()->default_value("1"))
      ("first-pass", "index of the first pass (passes are numbered from 0 over a whole run; the "
       "random streams depend on it)", cxxopts::value<int>()->default_value("0"))
      ("max-bounces", "bounces before a photon is dropped",
       cxxopts::value<int>()->default_value("16"))
      ("seed", "random seed", cxxopts::value<uint32_t>()->default_value("1"))
      ("threads", "worker threads, 0 = all cores (results do not depend on it)",
       cxxopts::value<int>()->default_value("0"))
      ("h,help", "print this help");
    pf::add_device_options(o);
    auto a = pf::parse_options(o, argc, argv);
    if (a.count("help")) { std::cout << o.help() << "\n"; return 0; }
    if (pf::list_devices_requested(a)) return 0;
    pf::require_options(o, a, {"scene", "output"});
    pf::check_output_options(a, {"scene"}, {"output"});
    int64_t photons = a["photons"].as<int64_t>();
    int passes = a["passes"].as<int>(), first = a["first-pass"].as<int>();
    pf::require_positive("photons", int64_t(photons));
    if (photons > int64_t(UINT32_MAX))
      throw pf::input_error("", "--photons must be below 2^32 per pass");
    pf::require_positive("passes", passes);
    pf::check_pass_range(first, passes);  // >= 0, and int32 pass indices in the files
    pf::PhotonPassOptions opt;
    opt.photons = uint32_t(photons);
    opt.seed = a["seed"].as<uint32_t>();
    opt.max_bounces = a["max-bounces"].as<int>();
    opt.threads = a["threads"].as<int>();
    pf::check_options(opt);

    pf::Stopwatch clock;
    std::string scene_path = a["scene"].as<std::string>();
    pf::Scene scene = pf::load_scene(scene_path);
    std::unique_ptr<pf::ClContext> dev = pf::open_device(pf::device_options(a), "trace-photons");
    pf::PhotonSet set;
    set.first_pass = first;
    set.seed = opt.seed;
    set.scene_id = scene.scene_id;
    pf::Progress progress("pass", passes, "photons");
    for (int p = 0; p < passes; ++p) {
      pf::PhotonPassResult r = dev ? pf::trace_photons(scene, uint32_t(first + p), opt, *dev)
                                   : pf::trace_photons(scene, uint32_t(first + p), opt);
      set.append_pass(r.photons, r.emitted);
      progress.update(p + 1, double(photons) * (p + 1));
    }
    pf::Provenance prov;
    prov.tool = "trace-photons";
    prov.seed = opt.seed;
    pf::record_options(prov, a);
    pf::record_backend(prov, dev.get());
    prov.command_line = pf::join_command_line(argc, argv);
    prov.add_input("scene", scene_path, pf::kSceneFormat, scene.scene_id);
    prov.wall_time_s = clock.seconds();
    pf::save_photons(set, a["output"].as<std::string>(), prov);
    std::cout << "trace-photons: " << passes << " pass(es) x " << photons << " photons, "
              << set.photons.size() << " stored, " << clock.seconds() << " s\n";
    return 0;
  });
}
