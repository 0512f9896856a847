// illuminate — hitpoint illumination. --estimator ppm: progressive photon mapping, one iteration
// per photon pass in the photons file (thesis eq. 3.14–3.18), writing the updated hitpoint state
// so that illuminate can be called pass after pass, with any --method of gather_method.h (the CPU
// grid/FLANN gathers or the OpenCL variants of thesis ch. 7.3; --clusters feeds the clustered
// ones). --estimator classic: classic photon mapping (k nearest global photons + fixed-radius
// caustic estimate, thesis eq. 3.10). --estimator sppm | pppm: one pass of the estimators that trace
// a new eye pass every pass (sppm.h): --hitpoints is eye pass p (trace-hitpoints --estimator sppm
// --pass p), --photons photon pass p, --state the state after passes < p (none for p = 0); writes
// the SPPM state (a hitpoints file) or the PPPM pass sums.
#include <iostream>
#include <memory>

#include "photonflow/opencl/cl_backend.h"
#include "photonflow/opencl/cl_gather.h"
#include "photonflow/stages/clusters.h"
#include "photonflow/opencl/device_options.h"
#include "photonflow/stages/illuminate.h"
#include "photonflow/foundations/options.h"
#include "photonflow/estimators/pass_sums.h"
#include "photonflow/foundations/progress.h"
#include "photonflow/estimators/render_defaults.h"
#include "photonflow/estimators/render_driver.h"
#include "photonflow/estimators/sppm.h"
#include "photonflow/foundations/tool_main.h"
#include "photonflow/geometry/scene_file.h"

int main(int argc, char** argv) {
  return pf::run_tool("illuminate", [&] {
    cxxopts::Options o("illuminate", "Gather photons at hitpoints (PPM or classic PM).");
    o.add_options()
      ("scene", "baked scene (scene.h5)", cxxopts::value<std::string>())
      ("hitpoints", "hitpoint state (from trace-hitpoints or an earlier illuminate)",
       cxxopts::value<std::string>())
      ("photons", "photons file (from trace-photons)", cxxopts::value<std::string>())
      ("grid", "prebuilt photon grids (from build-grid; PPM with --method grid; instead of "
       "--photons)", cxxopts::value<std::string>())
      ("o,output", "output hitpoint state (.h5)", cxxopts::value<std::string>())
      ("estimator", "ppm | classic | sppm | pppm; the default is render's (render_defaults.h), "
       "so trace-hitpoints, trace-photons and illuminate with no options make render's pass 0. "
       "sppm and pppm take one eye pass and one photon pass per call (trace-hitpoints --pass p, "
       "trace-photons --first-pass p, the --state of passes < p); ppm and classic take the "
       "hitpoints of trace-hitpoints --estimator ppm (or a PPM state) and any number of photon "
       "passes, and are the estimators of --grid, --clusters, --method and --device",
       cxxopts::value<std::string>()->default_value(pf::estimator_name(pf::kDefaultEstimator)))
      ("state", "sppm: the SPPM state, pppm: the pass sums, after the passes before this one "
       "(an earlier illuminate's output); none for the first pass", cxxopts::value<std::string>())
      ("alpha", "PPM: fraction of new photons kept, in (0, 1] (eq. 3.14)",
       cxxopts::value<float>()->default_value("0.7"))
      ("slab", "sppm, pppm: count only photons within SLAB x R of the visible point's tangent "
       "plane (ppm.h); 0 = the sphere alone; auto = 0.25 for sppm and pppm, 0 otherwise",
       cxxopts::value<std::string>()->default_value("auto"))
      ("gather-area", "sppm, pppm: divide the gathered flux by the surface the gather region "
       "holds (surface, estimators/gather_area.h) or by the disc pi R^2 (disc, the thesis's eq. "
       "3.17); auto = surface for sppm and pppm, disc otherwise",
       cxxopts::value<std::string>()->default_value("auto"))
      ("clusters", "PPM, --method kmeans-clusters | grid-kmeans | grid-gridclusters: hitpoint "
       "clusters of these hitpoints (clusters.h5 from the cluster stage); without it they are "
       "made once here", cxxopts::value<std::string>())
      ("max-bins", "PPM grid: bins along a mesh's longest extent (photon grids, grid clusters)",
       cxxopts::value<int>()->default_value("64"))
      ("k", "classic: nearest global photons per estimate",
       cxxopts::value<int>()->default_value("100"))
      ("caustic-radius", "classic: caustic-map radius in world units; 0 = the hitpoints' R0",
       cxxopts::value<float>()->default_value("0"))
      ("eps", "classic: FLANN approximate-search epsilon (0 = exact)",
       cxxopts::value<float>()->default_value("0"))
      ("threads", "worker threads, 0 = all cores", cxxopts::value<int>()->default_value("0"))
      ("h,help", "print this help");
    pf::add_method_option(o);
    pf::add_device_options(o);
    auto a = pf::parse_options(o, argc, argv);
    if (a.count("help")) { std::cout << o.help() << "\n"; return 0; }
    if (pf::list_devices_requested(a)) return 0;
    pf::require_options(o, a, {"scene", "hitpoints", "output"});
    if (!a.count("photons") && !a.count("grid"))
      throw pf::input_error("", "--photons or --grid is required", "see illuminate --help");
    pf::require_not_both(a, "photons", "grid", "the grid's photons are gathered, --photons would "
                         "be ignored");
    pf::check_output_options(a, {"scene", "hitpoints", "photons", "grid", "clusters", "state"},
                             {"output"});
    std::string estimator = a["estimator"].as<std::string>();
    pf::require_choice("estimator", estimator, {"ppm", "classic", "sppm", "pppm"});
    const bool estimator_auto = !a.count("estimator");
    pf::PpmOptions ppm;
    ppm.alpha = a["alpha"].as<float>();
    ppm.max_bins = a["max-bins"].as<int>();
    ppm.threads = a["threads"].as<int>();
    pf::require_in_unit_interval("alpha", ppm.alpha);
    pf::require_positive("max-bins", ppm.max_bins);
    ppm.slab = pf::parse_slab(a["slab"].as<std::string>(),
                              estimator == "sppm" || estimator == "pppm");
    ppm.gather_area = pf::parse_gather_area(a["gather-area"].as<std::string>(),
                                            estimator == "sppm" || estimator == "pppm");
    if (estimator == "sppm" || estimator == "pppm") {
      // The per-pass visible points move, so the gather is the CPU grid's (render --device opencl
      // traces them on the device); prebuilt grids and clusters belong to fixed hitpoints.
      if (a.count("grid") || a.count("clusters") || a.count("method") ||
          pf::device_options(a).device != "cpu")
        throw pf::input_error("", "--estimator " + estimator + (estimator_auto ? " (the default)" : "") +
                                  " gathers with the CPU grid from --photons (no --grid, "
                                  "--clusters, --method or --device)",
                              estimator_auto ? "give --estimator ppm for PPM's gathers"
                                             : "render --estimator " + estimator +
                                                   " --device opencl runs its passes on a device");
      if (!a.count("photons")) throw pf::input_error("", "--photons is required here");
      pf::Stopwatch clock;
      const std::string scene_path = a["scene"].as<std::string>();
      const std::string eye_path = a["hitpoints"].as<std::string>();
      const std::string ph_path = a["photons"].as<std::string>();
      const pf::Scene scene = pf::load_scene(scene_path);
      const pf::HitpointSet eye = pf::load_hitpoints(eye_path);
      if (estimator_auto && eye.estimator == "ppm")
        throw pf::input_error(eye_path, "is a PPM state, and --estimator " + estimator +
                                            " (the default) takes an eye pass",
                              "give --estimator ppm to continue it");
      const pf::PhotonSet photons = pf::load_photons(ph_path);
      pf::Provenance prov;
      prov.tool = "illuminate";
      prov.add_input("scene", scene_path, pf::kSceneFormat, scene.scene_id);
      pf::accept_input(prov, "hitpoints", eye_path, eye, scene, scene_path);
      pf::accept_input(prov, "photons", ph_path, photons, scene, scene_path);
      pf::record_options(prov, a);
      prov.parameters["estimator_auto"] = estimator_auto ? "true" : "false";
      prov.command_line = pf::join_command_line(argc, argv);
      const std::string out = a["output"].as<std::string>();
      if (estimator == "sppm") {
        pf::HitpointSet state;
        if (a.count("state")) {
          const std::string sp = a["state"].as<std::string>();
          state = pf::load_hitpoints(sp);
          pf::accept_input(prov, "state", sp, state, scene, scene_path);
          if (!pf::is_sppm_state(state))
            throw pf::input_error(sp, "is not an SPPM state", "give an illuminate --estimator sppm output");
        } else {
          state = pf::make_sppm_state(scene, eye.radius0, eye.direct_mode);
        }
        pf::sppm_stage(scene, state, eye, eye_path, photons, ph_path, ppm);
        prov.wall_time_s = clock.seconds();
        pf::save_hitpoints(state, out, prov);
        std::cout << "illuminate: sppm, " << state.passes << " pass(es) in state, "
                  << state.photons_emitted << " photons emitted, " << clock.seconds() << " s\n";
        return 0;
      }
      const auto params = pf::staged_state_parameters(
          pf::Estimator::Pppm, pf::load_hitpoints_provenance(eye_path), eye_path,
          pf::load_photons_provenance(ph_path), ph_path, ppm.alpha, ppm.slab, ppm.gather_area);
      pf::PassSums sums;
      if (a.count("state")) {
        const std::string sp = a["state"].as<std::string>();
        sums = pf::load_pass_sums(sp);
        pf::require_scene(sp, sums.scene_id, scene.scene_id, scene_path);
        pf::require_same_state_parameters(sp, sums.parameters, params,
                                          "start a new range without --state");
        prov.add_input("state", sp, pf::kPassSumsFormat, sums.scene_id);
      } else {
        sums = pf::make_pass_sums(scene.camera.width, scene.camera.height, eye.eye_pass,
                                  eye.radius0, ppm.alpha, eye.direct_mode, scene.scene_id, params);
      }
      pf::pppm_stage(scene, sums, eye, eye_path, photons, ph_path, ppm);
      prov.wall_time_s = clock.seconds();
      pf::save_pass_sums(sums, out, prov);
      std::cout << "illuminate: pppm, passes [" << sums.first_pass << ", " << sums.end_pass()
                << "), " << sums.photons_emitted << " photons emitted, " << clock.seconds()
                << " s\n";
      return 0;
    }
    if (a.count("state"))
      throw pf::input_error("", "--state belongs to --estimator sppm and pppm");
    pf::ClassicOptions classic;
    classic.k = a["k"].as<int>();
    classic.caustic_radius = a["caustic-radius"].as<float>();
    classic.eps = a["eps"].as<float>();
    classic.threads = ppm.threads;
    pf::require_positive("k", classic.k);
    if (!(classic.caustic_radius >= 0.f) || !(classic.eps >= 0.f))
      throw pf::input_error("", "--caustic-radius and --eps must be >= 0");

    // The OpenCL backend gathers PPM passes from --photons with a device --method (the same
    // photons as the CPU's grid/flann). Classic estimates and prebuilt grids stay on the CPU.
    pf::DeviceOptions devopt = pf::device_options(a);
    const bool device_path = estimator == "ppm" && !a.count("grid");
    if (!device_path && devopt.device == "opencl")
      throw pf::input_error("", "--device opencl supports --estimator ppm with --photons; "
                            "classic estimates and --grid run with --device cpu");
    if (!device_path && devopt.device == "auto") {
      std::cerr << "illuminate: device: cpu backend (auto: no OpenCL path for "
                << (estimator == "ppm" ? "--grid" : "--estimator classic") << ")\n";
      devopt.device = "cpu";
    }
    std::unique_ptr<pf::ClContext> dev = pf::open_device(devopt, "illuminate");
    if (estimator == "ppm") ppm.method = pf::method_option(a, dev.get());
    if (estimator == "classic" && a.count("method"))
      throw pf::input_error("", "--method applies to --estimator ppm (classic estimates use FLANN k-NN)");
    if (a.count("grid") && ppm.method != pf::GatherMethod::Grid)
      throw pf::input_error("", "--grid is read by --method grid only");
    const char* cluster_kind = pf::gather_method_info(ppm.method).clusters;
    if (a.count("clusters") && (estimator != "ppm" || !cluster_kind))
      throw pf::input_error("", "--clusters is read by --method kmeans-clusters, grid-kmeans and "
                            "grid-gridclusters only");
    pf::Stopwatch clock;
    std::string scene_path = a["scene"].as<std::string>(), hp_path = a["hitpoints"].as<std::string>();
    pf::Scene scene = pf::load_scene(scene_path);
    pf::HitpointSet h = pf::load_hitpoints(hp_path);
    pf::Provenance prov;
    prov.add_input("scene", scene_path, pf::kSceneFormat, scene.scene_id);
    pf::accept_input(prov, "hitpoints", hp_path, h, scene, scene_path);
    if (estimator == "ppm" && h.estimator == "classic")
      throw pf::input_error(hp_path, "holds a classic estimate; PPM continues only a PPM state",
                            "start from trace-hitpoints' output");
    // Clusters of the clustered device methods: from the cluster stage (bound to these
    // hitpoints) or made once here; ppm_pass refreshes their radii every pass (clusters.h).
    pf::ClusterSet clusters;
    if (estimator == "ppm" && cluster_kind && dev) {
      if (a.count("clusters")) {
        std::string cpath = a["clusters"].as<std::string>();
        clusters = pf::load_clusters(cpath, h);
        if (clusters.method != cluster_kind && clusters.method != "ga")
          throw pf::input_error(cpath, "holds " + clusters.method + " clusters, --method " +
                                pf::gather_method_name(ppm.method) + " reads " + cluster_kind +
                                " clusters", "give the matching method or clusters file");
        prov.add_input("clusters", cpath, pf::kClustersFormat, clusters.scene_id);
      } else {
        pf::Stopwatch made;
        clusters = pf::clusters_for_method(ppm.method, h, dev->work_group(), ppm);
        std::cerr << "illuminate: " << clusters.clusters.size() << " " << cluster_kind
                  << " clusters made in " << made.seconds() << " s (the cluster stage caches them)\n";
      }
      ppm.clusters = &clusters;
    }

    if (a.count("grid") && estimator == "ppm") {
      std::string grid_path = a["grid"].as<std::string>();
      pf::GridSet grids = pf::load_grids(grid_path);
      pf::accept_input(prov, "grid", grid_path, grids, scene, scene_path);
      if (grids.first_pass != h.passes)
        throw pf::input_error(grid_path, "starts at pass " + std::to_string(grids.first_pass) +
                              " but the hitpoints have " + std::to_string(h.passes) + " passes",
                              "give the grid of the next pass");
      pf::Progress progress("pass", long(grids.grids.size()), "photons");
      for (size_t k = 0; k < grids.grids.size(); ++k) {
        pf::ppm_pass_grid(scene, h, grids.grids[k], grids.pass_emitted[k], ppm);
        progress.update(long(k + 1), double(h.photons_emitted));
      }
    } else {
      if (!a.count("photons")) throw pf::input_error("", "--photons is required here");
      std::string ph_path = a["photons"].as<std::string>();
      pf::PhotonSet photons = pf::load_photons(ph_path);
      pf::accept_input(prov, "photons", ph_path, photons, scene, scene_path);
      if (estimator == "ppm") {
        if (photons.first_pass != h.passes)
          throw pf::input_error(ph_path, "starts at pass " + std::to_string(photons.first_pass) +
                                " but the hitpoints have " + std::to_string(h.passes) + " passes",
                                "trace photons with --first-pass " + std::to_string(h.passes));
        pf::Progress progress("pass", photons.pass_count(), "photons");
        // On the device the state stays there between passes (hash-grid) and comes back once.
        std::unique_ptr<pf::DevicePpmState> on_device;
        if (dev) on_device = std::make_unique<pf::DevicePpmState>(scene, h, *dev);
        for (int k = 0; k < photons.pass_count(); ++k) {
          if (on_device)
            on_device->pass(photons.pass(k), photons.pass_emitted[size_t(k)], ppm);
          else
            pf::ppm_pass(scene, h, photons.pass(k), photons.pass_emitted[size_t(k)], ppm);
          progress.update(k + 1, double(h.photons_emitted));
        }
        if (on_device) on_device->sync();
      } else {
        uint64_t emitted = 0;
        for (auto e : photons.pass_emitted) emitted += e;
        pf::classic_estimate(scene, h, photons.photons, emitted, classic);
      }
    }
    prov.tool = "illuminate";
    pf::record_options(prov, a);
    prov.parameters["estimator_auto"] = estimator_auto ? "true" : "false";
    if (estimator == "ppm") prov.parameters["method"] = pf::gather_method_name(ppm.method);
    pf::record_backend(prov, dev.get());
    prov.command_line = pf::join_command_line(argc, argv);
    prov.wall_time_s = clock.seconds();
    pf::save_hitpoints(h, a["output"].as<std::string>(), prov);
    std::cout << "illuminate: " << estimator << ", " << h.passes << " pass(es) in state, "
              << h.photons_emitted << " photons emitted, " << clock.seconds() << " s\n";
    return 0;
  });
}
