// cluster — group the hitpoints into work-group clusters for the clustered GPU gather (thesis
// ch. 7.3): k-means per mesh (K = hitpoints / work-group size) or clusters from the cells of a
// per-mesh uniform grid (eq. 7.1), each padded with filler hitpoints to a multiple of the
// work-group size. Writes clusters.h5 (docs/FORMATS.md).
#include <iostream>

#include "photonflow/clusters.h"
#include "photonflow/options.h"
#include "photonflow/scene.h"
#include "photonflow/stage_files.h"
#include "photonflow/tool_main.h"

int main(int argc, char** argv) {
  return pf::run_tool("cluster", [&] {
    cxxopts::Options o("cluster", "Group hitpoints into work-group clusters (thesis ch. 7.3).");
    o.add_options()
      ("scene", "baked scene (scene.h5); its scene_id must match the hitpoints'",
       cxxopts::value<std::string>())
      ("hitpoints", "hitpoints file (hitpoints.h5 from trace-hitpoints)",
       cxxopts::value<std::string>())
      ("o,output", "output clusters file (.h5)", cxxopts::value<std::string>())
      ("method", "kmeans (k-means per mesh, K = ceil(hitpoints / wg-size)) or grid (chunks of "
       "the cells of a per-mesh uniform grid, eq. 7.1)",
       cxxopts::value<std::string>()->default_value("kmeans"))
      ("wg-size", "work-group size in work-items; clusters are padded with fillers to a multiple",
       cxxopts::value<int>()->default_value("64"))
      ("iterations", "k-means: Lloyd iterations (count; stops early when nothing moves)",
       cxxopts::value<int>()->default_value("10"))
      ("max-bins", "grid: bins along a mesh's longest extent, at most (count); bin size is at "
       "least the hitpoints' initial radius R0; 0 = automatic per mesh (64, halved while cells "
       "hold fewer than 2 work-groups of hitpoints on average)",
       cxxopts::value<int>()->default_value("0"))
      ("seed", "k-means: random seed (recorded; the Morton seeding is deterministic)",
       cxxopts::value<uint32_t>()->default_value("1"))
      ("threads", "worker threads (count; 0 = all cores); results do not depend on it",
       cxxopts::value<int>()->default_value("0"))
      ("h,help", "print this help");
    auto a = o.parse(argc, argv);
    if (a.count("help")) { std::cout << o.help() << "\n"; return 0; }
    if (!a.count("scene") || !a.count("hitpoints") || !a.count("output"))
      throw pf::input_error("", "--scene, --hitpoints and --output are required");
    const std::string method = a["method"].as<std::string>();
    const int wg = a["wg-size"].as<int>(), iterations = a["iterations"].as<int>();
    const int max_bins = a["max-bins"].as<int>(), threads = a["threads"].as<int>();
    pf::require_choice("method", method, {"kmeans", "grid"});
    pf::require_positive("wg-size", wg);
    if (max_bins < 0) throw pf::input_error("", "--max-bins must be >= 0 (0 = automatic)");
    if (iterations < 0) throw pf::input_error("", "--iterations must be >= 0");
    if (threads < 0) throw pf::input_error("", "--threads must be >= 0");

    pf::Stopwatch clock;
    std::string scene_path = a["scene"].as<std::string>(), hp_path = a["hitpoints"].as<std::string>();
    pf::Scene scene = pf::load_scene(scene_path);
    pf::HitpointSet h = pf::load_hitpoints(hp_path);
    pf::require_scene(hp_path, h.scene_id, scene.scene_id, scene_path);
    pf::Provenance prov;
    prov.add_input("scene", scene_path, pf::kSceneFormat, scene.scene_id);
    prov.add_input("hitpoints", hp_path, pf::kHitpointsFormat, h.scene_id);

    pf::Stopwatch build;
    pf::ClusterSet c = method == "kmeans"
                           ? pf::cluster_kmeans(h, wg, iterations, a["seed"].as<uint32_t>(), threads)
                           : pf::cluster_grid(h, wg, max_bins);
    const double build_s = build.seconds();
    pf::ClusterStats s = pf::stats(c);

    prov.tool = "cluster";
    pf::record_options(prov, a);
    prov.seed = a["seed"].as<uint32_t>();
    prov.command_line = pf::join_command_line(argc, argv);
    prov.wall_time_s = clock.seconds();
    pf::save_clusters(c, a["output"].as<std::string>(), prov);
    std::cout << "cluster: " << method << ", " << s.clusters << " clusters, " << s.hitpoints
              << " hitpoints, " << s.fillers << " fillers, " << s.hitpoints_with_fillers
              << " hitpoints with fillers (wg " << wg << "), mean radius " << s.mean_radius
              << ", clustering " << build_s << " s, total " << clock.seconds() << " s\n";
    return 0;
  });
}
