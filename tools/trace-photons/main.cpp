// trace-photons — photon passes (thesis ch. 3.4 pass 1, ch. 7.2): photons leave the lights in
// proportion to power, bounce on diffuse (cosine, Russian roulette by albedo), mirror and glass
// (Fresnel), and are stored at diffuse hits. Writes photons.h5 (global map + caustic map, a pass
// table). Counter-based randomness: the same photons for any thread count.
#include <iostream>

#include "photonflow/opencl/cl_backend.h"
#include "photonflow/opencl/device_options.h"
#include "photonflow/foundations/options.h"
#include "photonflow/stages/photon_run.h"
#include "photonflow/foundations/progress.h"
#include "photonflow/estimators/render_defaults.h"
#include "photonflow/io/stage_files.h"
#include "photonflow/foundations/tool_main.h"
#include "photonflow/geometry/scene_file.h"

int main(int argc, char** argv) {
  return pf::run_tool("trace-photons", [&] {
    cxxopts::Options o("trace-photons",
                       "Trace photon passes from the lights and store photons at diffuse hits.");
    o.add_options()
      ("scene", "baked scene (scene.h5 from scene-bake)", cxxopts::value<std::string>())
      ("o,output", "output photons file (.h5)", cxxopts::value<std::string>())
      ("photons", "photons emitted per pass, or " + pf::auto_photons_rule() + " (render's "
       "default, render_defaults.h)", cxxopts::value<std::string>()->default_value("auto"))
      ("passes", "number of passes in this file", cxxopts::value<int>()->default_value("1"))
      ("first-pass", "index of the first pass (passes are numbered from 0 over a whole run; the "
       "random streams depend on it)", cxxopts::value<int>()->default_value("0"))
      ("max-bounces", "bounces before a photon is dropped",
       cxxopts::value<int>()->default_value("16"))
      ("seed", "random seed", cxxopts::value<uint32_t>()->default_value("1"))
      ("photon-guide", "uniform | visibility: photons as they come, or Markov chains of photon "
       "paths that reach the visible points of --hitpoints (Hachisuka & Jensen 2011; CPU only)",
       cxxopts::value<std::string>()->default_value("uniform"))
      ("hitpoints", "with --photon-guide visibility: the eye pass (trace-hitpoints) whose visible "
       "points guide the photons", cxxopts::value<std::string>())
      ("threads", "worker threads, 0 = all cores (results do not depend on it)",
       cxxopts::value<int>()->default_value("0"))
      ("h,help", "print this help");
    pf::add_device_options(o);
    auto a = pf::parse_options(o, argc, argv);
    if (a.count("help")) { std::cout << o.help() << "\n"; return 0; }
    if (pf::list_devices_requested(a)) return 0;
    pf::require_options(o, a, {"scene", "output"});
    pf::check_output_options(a, {"scene", "hitpoints"}, {"output"});
    // 0: automatic, chosen from the scene once it is read (render_defaults.h).
    const uint32_t given = pf::parse_photons_option(a["photons"].as<std::string>());
    int passes = a["passes"].as<int>(), first = a["first-pass"].as<int>();
    pf::require_positive("passes", passes);
    pf::check_pass_range(first, passes);  // >= 0, and int32 pass indices in the files
    pf::PhotonPassOptions opt;
    opt.photons = given > 0 ? given : pf::kMinAutoPhotons;  // auto: set once the scene is read
    opt.seed = a["seed"].as<uint32_t>();
    opt.max_bounces = a["max-bounces"].as<int>();
    opt.threads = a["threads"].as<int>();
    opt.guide = pf::parse_photon_guide(a["photon-guide"].as<std::string>());
    pf::check_options(opt);
    const bool guided = opt.guide == pf::PhotonGuide::Visibility;
    if (guided != (a.count("hitpoints") > 0))
      throw pf::input_error("", guided ? "--photon-guide visibility needs --hitpoints FILE"
                                       : "--hitpoints applies to --photon-guide visibility");

    pf::Stopwatch clock;
    std::string scene_path = a["scene"].as<std::string>();
    pf::Scene scene = pf::load_scene(scene_path);
    if (given == 0) opt.photons = pf::choose_defaults(scene).photons;
    const uint32_t photons = opt.photons;
    std::unique_ptr<pf::ClContext> dev = pf::open_device(pf::device_options(a), "trace-photons");
    std::string hitpoints_path;
    pf::HitpointSet eye;
    if (guided) {
      hitpoints_path = a["hitpoints"].as<std::string>();
      eye = pf::load_hitpoints(hitpoints_path);
    }
    pf::Progress progress("pass", passes, "photons");
    pf::PhotonRun run = pf::trace_photon_run(scene, first, passes, opt, dev.get(),
                                             guided ? &eye : nullptr, hitpoints_path, &progress);
    const pf::PhotonSet& set = run.set;
    const pf::PhotonGuideStats& guide = run.guide;
    pf::Provenance prov;
    prov.tool = "trace-photons";
    prov.seed = opt.seed;
    pf::record_options(prov, a);
    // The count used (render's state parameters and the pppm merge read it back), and whether it
    // was automatic.
    prov.parameters["photons"] = std::to_string(photons);
    prov.parameters["photons_auto"] = given == 0 ? "true" : "false";
    pf::record_backend(prov, dev.get());
    prov.command_line = pf::join_command_line(argc, argv);
    prov.add_input("scene", scene_path, pf::kSceneFormat, scene.scene_id);
    if (guided) {  // what the chains did, all passes of the file (photon_guide.h)
      prov.add_input("hitpoints", hitpoints_path, pf::kHitpointsFormat, eye.scene_id);
      prov.parameters["guide.visible_fraction"] = std::to_string(guide.visible_fraction());
      prov.parameters["guide.acceptance"] = std::to_string(guide.acceptance());
    }
    prov.wall_time_s = clock.seconds();
    pf::save_photons(set, a["output"].as<std::string>(), prov);
    std::cout << "trace-photons: " << passes << " pass(es) x " << photons << " photons, "
              << set.photons.size() << " stored, " << clock.seconds() << " s\n";
    if (guided)
      std::cout << "trace-photons: photon guide: visible fraction " << guide.visible_fraction()
                << " of the uniform photons, acceptance " << guide.acceptance() << "\n";
    return 0;
  });
}
