// build-grid — per-mesh uniform grids over each pass's photons (thesis ch. 7.3, eq. 7.1):
// bin size d = max(longest extent / max_bins, default radius); photons reordered by bin with a
// bin-start table. Writes grid.h5, used by `illuminate --grid`. With --device opencl the grids are
// built on the device (cl_gather.h: bounds reduction, atomic bin counters, prefix sum, scatter
// kernel) and are the same arrays as the CPU build's.
#include <iostream>

#include "photonflow/opencl/cl_gather.h"
#include "photonflow/opencl/device_options.h"
#include "photonflow/foundations/options.h"
#include "photonflow/stages/photon_grid.h"
#include "photonflow/geometry/scene.h"
#include "photonflow/geometry/scene_file.h"
#include "photonflow/io/stage_files.h"
#include "photonflow/foundations/tool_main.h"

int main(int argc, char** argv) {
  return pf::run_tool("build-grid", [&] {
    cxxopts::Options o("build-grid", "Build per-mesh uniform photon grids (thesis eq. 7.1).");
    o.add_options()
      ("scene", "baked scene (scene.h5)", cxxopts::value<std::string>())
      ("photons", "photons file (photons.h5 from trace-photons)", cxxopts::value<std::string>())
      ("hitpoints", "hitpoints file whose initial radius R0 is the default radius",
       cxxopts::value<std::string>())
      ("o,output", "output grid file (.h5)", cxxopts::value<std::string>())
      ("max-bins", "bins along a mesh's longest extent, at most",
       cxxopts::value<int>()->default_value("64"))
      ("radius", "default radius in world units (lower bound of the bin size); 0 = R0 of "
       "--hitpoints (give one of the two)", cxxopts::value<float>()->default_value("0"))
      ("h,help", "print this help");
    pf::add_device_options(o);
    auto a = pf::parse_options(o, argc, argv);
    if (a.count("help")) { std::cout << o.help() << "\n"; return 0; }
    if (pf::list_devices_requested(a)) return 0;
    pf::require_options(o, a, {"scene", "photons", "output"});
    pf::check_output_options(a, {"scene", "photons", "hitpoints"}, {"output"});
    pf::PhotonGridParams gp;
    gp.max_bins = a["max-bins"].as<int>();
    gp.default_radius = a["radius"].as<float>();
    pf::require_positive("max-bins", gp.max_bins);
    if (!(gp.default_radius >= 0.f))
      throw pf::input_error("", "--radius must be >= 0 (0 = R0 of --hitpoints)");
    if (gp.default_radius > 0.f && a.count("hitpoints"))
      throw pf::input_error("", "give --radius or --hitpoints, not both (--radius 0 takes R0 of "
                                "--hitpoints)");

    std::unique_ptr<pf::ClContext> dev = pf::open_device(pf::device_options(a), "build-grid");
    pf::Stopwatch clock;
    std::string scene_path = a["scene"].as<std::string>(), photons_path = a["photons"].as<std::string>();
    pf::Scene scene = pf::load_scene(scene_path);
    pf::PhotonSet photons = pf::load_photons(photons_path);
    pf::Provenance prov;
    prov.add_input("scene", scene_path, pf::kSceneFormat, scene.scene_id);
    pf::accept_input(prov, "photons", photons_path, photons, scene, scene_path);
    if (gp.default_radius <= 0.f) {
      if (!a.count("hitpoints"))
        throw pf::input_error("", "give --radius or --hitpoints (whose R0 sets the bin size)");
      std::string hp_path = a["hitpoints"].as<std::string>();
      pf::HitpointSet h = pf::load_hitpoints(hp_path);
      pf::accept_input(prov, "hitpoints", hp_path, h, scene, scene_path);
      gp.default_radius = pf::hitpoints_radius0(hp_path, h);
    }
    pf::require_positive("radius", gp.default_radius);
    pf::GridSet grids;
    grids.first_pass = photons.first_pass;
    grids.pass_emitted = photons.pass_emitted;
    grids.scene_id = scene.scene_id;
    for (int k = 0; k < photons.pass_count(); ++k)
      grids.grids.push_back(
          dev ? pf::build_photon_grid(photons.pass(k), int(scene.mesh_names.size()), gp, *dev)
              : pf::build_photon_grid(photons.pass(k), int(scene.mesh_names.size()), gp));
    prov.tool = "build-grid";
    pf::record_options(prov, a);
    pf::record_backend(prov, dev.get());
    prov.parameters["radius"] = std::to_string(gp.default_radius);
    prov.command_line = pf::join_command_line(argc, argv);
    prov.wall_time_s = clock.seconds();
    pf::save_grids(grids, a["output"].as<std::string>(), prov);
    std::cout << "build-grid: " << grids.grids.size() << " pass grid(s), bin size >= "
              << gp.default_radius << ", " << clock.seconds() << " s\n";
    return 0;
  });
}
