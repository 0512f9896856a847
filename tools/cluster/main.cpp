// cluster — group the hitpoints into work-group clusters for the clustered GPU gather (thesis
// ch. 7.3): k-means per mesh (K = hitpoints / work-group size), clusters from the cells of a
// per-mesh uniform grid (eq. 7.1), or evolutionary clustering (thesis ch. 8, ga_clusters.h: 1+λ
// evolution from k-means, fitness eq. 8.1–8.3 or the gather's device time), each padded with filler
// hitpoints to a multiple of the work-group size. Writes clusters.h5 (docs/FORMATS.md).
#include <iostream>

#include "photonflow/opencl/cl_backend.h"
#include "photonflow/stages/clusters.h"
#include "photonflow/opencl/device_options.h"
#include "photonflow/stages/ga_clusters.h"
#include "photonflow/foundations/options.h"
#include "photonflow/stages/photon_distribution.h"
#include "photonflow/geometry/scene.h"
#include "photonflow/geometry/scene_file.h"
#include "photonflow/io/stage_files.h"
#include "photonflow/foundations/tool_main.h"

int main(int argc, char** argv) {
  return pf::run_tool("cluster", [&] {
    cxxopts::Options o("cluster", "Group hitpoints into work-group clusters (thesis ch. 7.3, 8). "
                       "Clusters belong to fixed hitpoints (PPM's one eye pass); SPPM and PPPM "
                       "trace new visible points every pass and take none.");
    o.add_options()
      ("scene", "baked scene (scene.h5); its scene_id must match the hitpoints'",
       cxxopts::value<std::string>())
      ("hitpoints", "hitpoints file (hitpoints.h5 from trace-hitpoints)",
       cxxopts::value<std::string>())
      ("o,output", "output clusters file (.h5)", cxxopts::value<std::string>())
      ("method", "kmeans (k-means per mesh, K = ceil(hitpoints / wg-size)), grid (chunks of "
       "the cells of a per-mesh uniform grid, eq. 7.1) or ga (evolutionary clustering, thesis "
       "ch. 8, starting from k-means)",
       cxxopts::value<std::string>()->default_value("kmeans"))
      ("wg-size", "work-group size in work-items; clusters are padded with fillers to a multiple",
       cxxopts::value<int>()->default_value("64"))
      ("iterations", "k-means (and the GA's k-means start): Lloyd iterations (count; stops early "
       "when nothing moves)", cxxopts::value<int>()->default_value("10"))
      ("max-bins", "grid: bins along a mesh's longest extent, at most (count); bin size is at "
       "least the hitpoints' initial radius R0; 0 = automatic per mesh (64, halved while cells "
       "hold fewer than 2 work-groups of hitpoints on average)",
       cxxopts::value<int>()->default_value("0"))
      ("seed", "random seed (ga: the evolution's random streams; k-means: recorded, its Morton "
       "seeding is deterministic)", cxxopts::value<uint32_t>()->default_value("1"))
      ("threads", "worker threads (count; 0 = all cores); results do not depend on it",
       cxxopts::value<int>()->default_value("0"))
      ("h,help", "print this help");
    o.add_options("Evolutionary clustering (--method ga)")
      ("fitness", "what the evolution minimises: " + pf::ga_fitness_choices() + " (filler: eq. 8.1; "
       "grid-bins: eq. 8.2; memory-access: eq. 8.3; work: photons read by real work-items; "
       "device-time: the grid-kmeans gather kernel on --device, best of --device-runs, in us)",
       cxxopts::value<std::string>()->default_value("memory-access"))
      ("distribution", "photon-distribution map (photon_distribution.h5 from photon-distribution) "
       "for grid-bins, memory-access and work", cxxopts::value<std::string>())
      ("photons", "device-time: photons file; its first pass is gathered",
       cxxopts::value<std::string>())
      ("population", "parent + children per generation (1+lambda, lambda = population - 1)",
       cxxopts::value<int>()->default_value("50"))
      ("ga-iterations", "generations after the initial population",
       cxxopts::value<int>()->default_value("3000"))
      ("device-runs", "device-time: runs per evaluation, the fastest counts",
       cxxopts::value<int>()->default_value("5"))
      ("gather-max-bins", "device-time: photon-grid bins of the gather (illuminate --max-bins); "
       "0 = the distribution's, else 64", cxxopts::value<int>()->default_value("0"))
      ("checkpoint", "checkpoint file, written atomically every --checkpoint-every generations "
       "and on Ctrl-C; default <output>.checkpoint.h5", cxxopts::value<std::string>())
      ("checkpoint-every", "generations between checkpoints",
       cxxopts::value<int>()->default_value("50"))
      ("resume", "continue the evolution from the checkpoint when it exists (same inputs, "
       "fitness, seed, population and work-group size; --ga-iterations at least the iterations "
       "it has run)");
    pf::add_device_options(o);
    auto a = pf::parse_options(o, argc, argv);
    if (a.count("help")) { std::cout << o.help() << "\n"; return 0; }
    if (pf::list_devices_requested(a)) return 0;
    pf::require_options(o, a, {"scene", "hitpoints", "output"});
    const std::string method = a["method"].as<std::string>();
    const int wg = a["wg-size"].as<int>(), iterations = a["iterations"].as<int>();
    const int max_bins = a["max-bins"].as<int>(), threads = a["threads"].as<int>();
    pf::require_choice("method", method, {"kmeans", "grid", "ga"});
    pf::require_positive("wg-size", wg);
    if (max_bins < 0) throw pf::input_error("", "--max-bins must be >= 0 (0 = automatic)");
    if (iterations < 0) throw pf::input_error("", "--iterations must be >= 0");
    const std::string out_path = a["output"].as<std::string>();

    pf::GaOptions ga;
    pf::GaFitnessInputs in;
    if (method == "ga") {
      ga.fitness = pf::parse_ga_fitness(a["fitness"].as<std::string>());
      ga.population = a["population"].as<int>();
      ga.iterations = a["ga-iterations"].as<int>();
      ga.seed = a["seed"].as<uint32_t>();
      ga.kmeans_iterations = iterations;
      ga.threads = threads;
      ga.checkpoint = a.count("checkpoint") ? a["checkpoint"].as<std::string>()
                                            : out_path + ".checkpoint.h5";
      ga.checkpoint_every = a["checkpoint-every"].as<int>();
      ga.resume = a.count("resume") > 0;
      in.wg_size = wg;
      in.device_runs = a["device-runs"].as<int>();
      if (ga.population < 2) throw pf::input_error("", "--population must be >= 2");
      if (ga.iterations < 0) throw pf::input_error("", "--ga-iterations must be >= 0");
      pf::require_positive("checkpoint-every", ga.checkpoint_every);
      pf::require_positive("device-runs", in.device_runs);
      if (pf::ga_fitness_needs_distribution(ga.fitness) && !a.count("distribution"))
        throw pf::input_error("", std::string("--fitness ") + pf::ga_fitness_name(ga.fitness) +
                                      " needs --distribution", "make one with photon-distribution");
      if (ga.fitness == pf::GaFitness::DeviceTime && !a.count("photons"))
        throw pf::input_error("", "--fitness device-time needs --photons (and --device opencl)");
    }

    // The GA checkpoint is read back by --resume: an output here, never one of the other inputs.
    pf::check_outputs({pf::path_option(a, "scene"), pf::path_option(a, "hitpoints"),
                       pf::path_option(a, "distribution"), pf::path_option(a, "photons")},
                      {out_path, method == "ga" ? ga.checkpoint : ""});

    pf::Stopwatch clock;
    std::string scene_path = a["scene"].as<std::string>(), hp_path = a["hitpoints"].as<std::string>();
    pf::Scene scene = pf::load_scene(scene_path);
    pf::HitpointSet h = pf::load_hitpoints(hp_path);
    pf::Provenance prov;
    prov.tool = "cluster";
    pf::record_options(prov, a);
    prov.seed = a["seed"].as<uint32_t>();
    prov.command_line = pf::join_command_line(argc, argv);
    ga.provenance = &prov;  // the GA checkpoints carry it (inputs as added below)
    prov.add_input("scene", scene_path, pf::kSceneFormat, scene.scene_id);
    pf::accept_input(prov, "hitpoints", hp_path, h, scene, scene_path);

    pf::ClusterSet c;
    pf::GaResult result;
    double build_s = 0;
    if (method != "ga") {
      pf::Stopwatch build;
      c = method == "kmeans" ? pf::cluster_kmeans(h, wg, iterations, a["seed"].as<uint32_t>(), threads)
                             : pf::cluster_grid(h, wg, max_bins);
      build_s = build.seconds();
    } else {
      pf::PhotonDistribution dist;
      if (a.count("distribution")) {
        const std::string dpath = a["distribution"].as<std::string>();
        dist = pf::load_photon_distribution(dpath);
        pf::require_distribution_for(dist, dpath, h);
        prov.add_input("distribution", dpath, pf::kPhotonDistributionFormat, dist.scene_id);
        in.distribution = &dist;
      }
      std::vector<pf_photon> photons;
      std::unique_ptr<pf::ClContext> dev;
      if (ga.fitness == pf::GaFitness::DeviceTime) {
        const std::string ppath = a["photons"].as<std::string>();
        pf::PhotonSet ps = pf::load_photons(ppath);
        pf::accept_input(prov, "photons", ppath, ps, scene, scene_path);
        if (ps.pass_count() < 1) throw pf::input_error(ppath, "holds no photon pass");
        photons = ps.pass(0);
        in.emitted = ps.pass_emitted[0];
        dev = pf::open_device(pf::device_options(a), "cluster");
        if (!dev) throw pf::input_error("", "--fitness device-time needs --device opencl or auto");
        pf::record_backend(prov, dev.get());
        const int gmb = a["gather-max-bins"].as<int>();
        in.max_bins = gmb > 0 ? gmb : (in.distribution ? dist.params.max_bins : 64);
      }
      in.hitpoints = &h;
      in.scene = &scene;
      in.photons = &photons;
      in.device = dev.get();
      const pf::StopOnInterrupt stop(
          "cluster: stopping after this generation (interrupt again to stop at once)\n");
      pf::GaProgressLine line(pf::ga_fitness_unit(ga.fitness));
      result = pf::evolve_clusters(in, ga, [&](const pf::GaProgress& p) {
        line.update(p);
        return !pf::interrupted();
      });
      if (result.interrupted) {
        line.end_line();
        std::cerr << "cluster: interrupted after generation " << result.generations
                  << "; the evolution is saved in " << ga.checkpoint
                  << " (rerun the same command with --resume to continue)\n";
        return pf::kExitInterrupted;
      }
      c = std::move(result.clusters);
      build_s = result.seconds;
    }
    pf::ClusterStats s = pf::stats(c);

    prov.wall_time_s = clock.seconds();
    if (method == "ga") {
      prov.param("best_fitness", result.fitness);
      pf::save_clusters(c, out_path, prov, [&](pf::h5::Writer& w) { pf::write_ga_record(w, result, ga); });
    } else {
      pf::save_clusters(c, out_path, prov);
    }
    std::cout << "cluster: " << method << ", " << s.clusters << " clusters, " << s.hitpoints
              << " hitpoints, " << s.fillers << " fillers, " << s.hitpoints_with_fillers
              << " hitpoints with fillers (wg " << wg << "), mean radius " << s.mean_radius
              << ", clustering " << build_s << " s, total " << clock.seconds() << " s\n";
    if (method == "ga")
      std::cout << "cluster: ga fitness " << pf::ga_fitness_name(ga.fitness) << " = "
                << result.fitness << " " << pf::ga_fitness_unit(ga.fitness) << " after "
                << result.generations << " generations (k-means clusters " << result.kmeans_fitness
                << ", k-means start " << result.start_fitness << "), " << result.evaluations
                << " evaluations\n";
    return 0;
  });
}
