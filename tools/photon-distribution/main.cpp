// photon-distribution — the photon-distribution map of thesis ch. 8.2 (eq. 8.3): photons per bin of
// the per-mesh photon grid (eq. 7.1), averaged over many photon passes, for the memory-access
// fitness of `cluster --method ga` (photon_distribution.h). Reads the passes of a photons file, or
// traces them here without storing them (the thesis averaged a thousand passes: far more photons
// than a photons file should hold). Writes photon_distribution.h5 (docs/FORMATS.md).
#include <iostream>

#include "photonflow/opencl/cl_backend.h"
#include "photonflow/opencl/device_options.h"
#include "photonflow/stages/illuminate.h"
#include "photonflow/foundations/options.h"
#include "photonflow/stages/photon_distribution.h"
#include "photonflow/stages/photon_pass.h"
#include "photonflow/foundations/progress.h"
#include "photonflow/io/stage_files.h"
#include "photonflow/foundations/tool_main.h"
#include "photonflow/geometry/scene_file.h"

int main(int argc, char** argv) {
  return pf::run_tool("photon-distribution", [&] {
    cxxopts::Options o("photon-distribution",
                       "Average photons per grid bin over many passes (thesis eq. 8.3 map).");
    o.add_options()
      ("scene", "baked scene (scene.h5)", cxxopts::value<std::string>())
      ("hitpoints", "hitpoints (hitpoints.h5): their R0 is the bins' smallest size, as in the "
       "gather", cxxopts::value<std::string>())
      ("photons", "photons file (photons.h5): use its passes; without it the passes are traced "
       "here and not stored", cxxopts::value<std::string>())
      ("o,output", "output map (.h5)", cxxopts::value<std::string>())
      ("passes", "passes to trace (without --photons)", cxxopts::value<int>()->default_value("100"))
      ("emit", "photons emitted per traced pass", cxxopts::value<int64_t>()->default_value("100000"))
      ("first-pass", "index of the first traced pass (its grid fixes the bins)",
       cxxopts::value<int>()->default_value("0"))
      ("seed", "random seed of the traced passes", cxxopts::value<uint32_t>()->default_value("1"))
      ("max-bounces", "bounces before a traced photon is dropped",
       cxxopts::value<int>()->default_value("16"))
      ("max-bins", "photon-grid bins along a mesh's longest extent (the gather's --max-bins)",
       cxxopts::value<int>()->default_value("64"))
      ("threads", "worker threads, 0 = all cores (results do not depend on it)",
       cxxopts::value<int>()->default_value("0"))
      ("h,help", "print this help");
    pf::add_device_options(o);
    auto a = pf::parse_options(o, argc, argv);
    if (a.count("help")) { std::cout << o.help() << "\n"; return 0; }
    if (pf::list_devices_requested(a)) return 0;
    pf::require_options(o, a, {"scene", "hitpoints", "output"});
    pf::check_output_options(a, {"scene", "hitpoints", "photons"}, {"output"});
    const int passes = a["passes"].as<int>(), first = a["first-pass"].as<int>();
    const int max_bins = a["max-bins"].as<int>();
    const int64_t emit = a["emit"].as<int64_t>();
    pf::require_positive("passes", passes);
    pf::require_positive("max-bins", max_bins);
    pf::require_positive("emit", int64_t(emit));
    if (emit > int64_t(UINT32_MAX)) throw pf::input_error("", "--emit must be below 2^32");
    if (first < 0) throw pf::input_error("", "--first-pass must be >= 0");

    pf::Stopwatch clock;
    const std::string scene_path = a["scene"].as<std::string>(),
                      hp_path = a["hitpoints"].as<std::string>();
    pf::Scene scene = pf::load_scene(scene_path);
    pf::HitpointSet h = pf::load_hitpoints(hp_path);
    pf::Provenance prov;
    prov.add_input("scene", scene_path, pf::kSceneFormat, scene.scene_id);
    pf::accept_input(prov, "hitpoints", hp_path, h, scene, scene_path);

    pf::PpmOptions ppm;
    ppm.max_bins = max_bins;
    const int mesh_count = int(scene.mesh_names.size());
    pf::PhotonDistribution d = pf::empty_photon_distribution(pf::ppm_grid_params(h, ppm), scene.scene_id);
    if (a.count("photons")) {
      const std::string ph_path = a["photons"].as<std::string>();
      pf::PhotonSet ps = pf::load_photons(ph_path);
      pf::accept_input(prov, "photons", ph_path, ps, scene, scene_path);
      prov.seed = ps.seed;
      d.first_pass = ps.first_pass;
      for (int p = 0; p < ps.pass_count(); ++p)
        d.add_pass(ps.pass(p), ps.pass_emitted[size_t(p)], mesh_count);
    } else {
      pf::PhotonPassOptions opt;
      opt.photons = uint32_t(emit);
      opt.seed = a["seed"].as<uint32_t>();
      opt.max_bounces = a["max-bounces"].as<int>();
      opt.threads = a["threads"].as<int>();
      prov.seed = opt.seed;
      std::unique_ptr<pf::ClContext> dev = pf::open_device(pf::device_options(a), "photon-distribution");
      pf::record_backend(prov, dev.get());
      d.first_pass = first;
      pf::Progress progress("pass", passes, "photons");
      for (int p = 0; p < passes; ++p) {
        pf::PhotonPassResult r = dev ? pf::trace_photons(scene, uint32_t(first + p), opt, *dev)
                                     : pf::trace_photons(scene, uint32_t(first + p), opt);
        d.add_pass(r.photons, r.emitted, mesh_count);
        progress.update(p + 1, double(emit) * (p + 1));
      }
    }
    prov.tool = "photon-distribution";
    pf::record_options(prov, a);
    prov.command_line = pf::join_command_line(argc, argv);
    prov.wall_time_s = clock.seconds();
    pf::save_photon_distribution(d, a["output"].as<std::string>(), prov);
    std::cout << "photon-distribution: " << d.passes << " passes, " << d.bins() << " bins over "
              << d.mesh_count() << " meshes, " << clock.seconds() << " s\n";
    return 0;
  });
}
