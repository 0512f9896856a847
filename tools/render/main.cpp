// render — progressive photon mapping in one process: `--passes` photon passes with their
// gathers, no files between passes, by one of three estimators (--estimator; sppm.h): ppm (one
// eye pass first, fixed hitpoints), sppm (a new eye pass every pass, statistics per pixel), pppm
// (independent passes with a shrinking global radius; --first-pass and --sums make the partial
// results that `merge` combines). Checkpoints of the state every --checkpoint-every passes
// (atomic) and --resume to continue a killed run; a wall-clock budget (--time); snapshots of the
// image every --snapshot-every passes and a JSON run record (--stats) for convergence charts.
// Same stage functions as trace-hitpoints → trace-photons → illuminate → synthesize, so both
// routes give one image. --scene is a baked scene.h5 or a scene source, baked here by scene-bake's
// function with scene-bake's options (scene_source.h, bake_options.h; --keep-scene keeps it).
#include <algorithm>
#include <filesystem>
#include <limits>
#include <iostream>
#include <vector>

#include "photonflow/geometry/bake_options.h"
#include "photonflow/opencl/cl_backend.h"
#include "photonflow/opencl/device_options.h"
#include "photonflow/foundations/options.h"
#include "photonflow/foundations/progress.h"
#include "photonflow/estimators/render_defaults.h"
#include "photonflow/estimators/render_driver.h"
#include "photonflow/geometry/scene_source.h"
#include "photonflow/stages/synthesize.h"
#include "photonflow/foundations/tool_main.h"
#include "photonflow/geometry/scene_file.h"

int main(int argc, char** argv) {
  return pf::run_tool("render", [&] {
    cxxopts::Options o("render", "Progressive photon mapping render driver.");
    o.add_options()
      ("scene", "the scene: a baked scene.h5 (from scene-bake), or a scene source (any file "
       "scene-bake reads: .dae, .obj, .gltf, .glb, .ply, ...), baked here with scene-bake's "
       "options (\"Scene source options\" below)", cxxopts::value<std::string>())
      ("keep-scene", "with a scene source: also write the baked scene here (scene.h5, as "
       "scene-bake writes it)", cxxopts::value<std::string>()->default_value(""))
      ("o,output", "output OpenEXR image; a PNG preview goes beside it",
       cxxopts::value<std::string>())
      ("estimator", "ppm (one fixed eye pass) | sppm (new eye pass every pass, per-pixel "
       "statistics) | pppm (independent passes, global radius; mergeable); the default measures "
       "best (render_defaults.h)",
       cxxopts::value<std::string>()->default_value(pf::estimator_name(pf::kDefaultEstimator)))
      ("passes", "photon passes in total (pppm: from --first-pass); with --time the most passes",
       cxxopts::value<int>()->default_value("16"))
      ("time", "rendering budget in seconds: stop after the pass that reaches it, then write the "
       "image and the run record; 0 = none", cxxopts::value<double>()->default_value("0"))
      ("first-pass", "pppm: index of the first pass of this run's range (0-based)",
       cxxopts::value<int>()->default_value("0"))
      ("sums", "pppm: write the partial result (per-pixel sums of the passes, for merge) here",
       cxxopts::value<std::string>()->default_value(""))
      ("glossy-merge", "at a glossy (PBR) point: first = make the visible point there; mis = "
       "share its light between the gather there and continuing the eye path, by the merge "
       "weight of each direction, with direct light by MIS (sppm and pppm, --direct "
       "shadow-rays); or auto: mis for sppm and pppm with shadow rays, else first "
       "(render_defaults.h)",
       cxxopts::value<std::string>()->default_value("auto"))
      ("glossy-spp", "pppm: eye samples more per pass in the pixels that see a glossy point "
       "their eye paths go on from (--glossy-merge mis), or auto: " +
       std::to_string(pf::kDefaultGlossySpp) + " for pppm with --glossy-merge mis, else 0 "
       "(render_defaults.h)",
       cxxopts::value<std::string>()->default_value("auto"))
      ("emission-spp", "eye paths more per pass, through mirrors and glass only, in the pixels "
       "that see an emitter that way or directly (their emitted light converges faster; 0 = "
       "none), or auto: " + std::to_string(pf::kDefaultEmissionSpp) + " (render_defaults.h)",
       cxxopts::value<std::string>()->default_value("auto"))
      ("pixel-sampler", "where eye samples go in their pixel: auto (strata for ppm, sobol "
       "otherwise) | strata | random | sobol", cxxopts::value<std::string>()->default_value("auto"))
      ("photons", "photons emitted per pass, or " + pf::auto_photons_rule(),
       cxxopts::value<std::string>()->default_value("auto"))
      ("alpha", "fraction of new photons kept, in (0, 1] (eq. 3.14)",
       cxxopts::value<float>()->default_value("0.7"))
      ("slab", "sppm, pppm: count only photons within SLAB x R of the visible point's tangent "
       "plane (ppm.h); 0 = the sphere alone; auto = 0.25 for sppm and pppm, 0 for ppm",
       cxxopts::value<std::string>()->default_value("auto"))
      ("gather-area", "sppm, pppm: divide the gathered flux by the surface the gather region "
       "holds (surface: corners and edges come out unbiased, estimators/gather_area.h) or by "
       "the disc pi R^2 (disc, the thesis's eq. 3.17); auto = surface for sppm and pppm, disc "
       "for ppm", cxxopts::value<std::string>()->default_value("auto"))
      ("max-bins", "grid bins along a mesh's longest extent", cxxopts::value<int>()->default_value("64"))
      ("spp", "eye samples per pixel (ppm; pppm: per pass; sppm: 1)",
       cxxopts::value<int>()->default_value("1"))
      ("max-depth", "specular bounces of eye paths", cxxopts::value<int>()->default_value("16"))
      ("max-bounces", "bounces of photon paths", cxxopts::value<int>()->default_value("16"))
      ("photon-guide", "uniform | visibility: photons from the lights as they come, or Markov "
       "chains of photon paths that reach the pass's visible points (Hachisuka & Jensen 2011; "
       "CPU only)", cxxopts::value<std::string>()->default_value("uniform"))
      ("direct", "direct light: photons | shadow-rays (light sampling at the visible points; "
       "photons then carry the rest, nothing counted twice)",
       cxxopts::value<std::string>()->default_value(pf::direct_mode_name(pf::kDefaultDirect)))
      ("shadow-samples", "light samples per visible point and pass with --direct shadow-rays, "
       "or auto: " + std::to_string(pf::kDefaultShadowSamples) + " for sppm and pppm (a pixel's "
       "samples over the passes are Sobol points), " +
       std::to_string(pf::kEnvironmentShadowSamples) + " in a scene with an environment light, " +
       std::to_string(pf::kPpmShadowSamples) + " for ppm (render_defaults.h)", cxxopts::value<std::string>()->default_value("auto"))
      ("radius", "initial radius R0 in world units, or " + pf::auto_radius_rule() + " (0 is "
       "auto too)", cxxopts::value<std::string>()->default_value("auto"))
      ("seed", "random seed", cxxopts::value<uint32_t>()->default_value("1"))
      ("checkpoint", "hitpoint-state file written every --checkpoint-every passes",
       cxxopts::value<std::string>()->default_value(""))
      ("checkpoint-every", "passes between checkpoints", cxxopts::value<int>()->default_value("10"))
      ("resume", "continue from --checkpoint if it exists")
      ("snapshot-every", "write the image every K passes; 0 = no snapshots",
       cxxopts::value<int>()->default_value("0"))
      ("snapshot-at", "also write the image after these passes (comma-separated, e.g. 1,2,4,8)",
       cxxopts::value<std::string>()->default_value(""))
      ("snapshot", "snapshot file pattern; {pass} becomes the passes so far (zero-padded); "
       "default: the output's name with -{pass}p before the extension",
       cxxopts::value<std::string>()->default_value(""))
      ("stats", "also write a JSON record of the run here: parameters, input scene and its "
       "SHA-256, and passes, photons and rendering seconds of every image written",
       cxxopts::value<std::string>()->default_value(""))
      ("exposure", "PNG exposure in stops", cxxopts::value<float>()->default_value("0"))
      ("threads", "worker threads, 0 = all cores", cxxopts::value<int>()->default_value("0"))
      ("h,help", "print this help");
    pf::add_method_option(o);
    pf::add_device_options(o);
    // scene-bake's options, the same names and checks (bake_options.h); --threads is the kd-tree
    // build's too.
    pf::add_bake_options(o, "Scene source");
    pf::add_options_file_options(o, "Scene source");
    // A scene source's options file (NAME.bake-options beside it) is read as scene-bake reads it.
    auto a = pf::parse_bake_command_line(o, argc, argv, "scene", true);
    if (a.count("help")) { std::cout << o.help() << "\n"; return 0; }
    if (pf::list_devices_requested(a)) return 0;
    pf::RenderOptions opt;
    opt.estimator = pf::parse_estimator(a["estimator"].as<std::string>());
    const bool pppm = opt.estimator == pf::Estimator::Pppm;
    const std::string sums = a["sums"].as<std::string>();
    if (!sums.empty() && !pppm)
      throw pf::input_error("", "--sums writes the partial result of --estimator pppm");
    // A pppm range may write only its sums (the parts of a merge); every other run an image.
    if (sums.empty())
      pf::require_options(o, a, {"scene", "output"});
    else
      pf::require_options(o, a, {"scene"});
    opt.passes = a["passes"].as<int>();
    opt.time_budget = a["time"].as<double>();
    opt.first_pass = a["first-pass"].as<int>();
    if (opt.time_budget > 0 && a.count("passes") == 0)  // the budget alone ends the run
      opt.passes = std::numeric_limits<int>::max() - std::max(0, opt.first_pass);
    const std::string sampler = a["pixel-sampler"].as<std::string>();
    // 0: automatic, chosen from the scene once it is read (render_defaults.h).
    const uint32_t photons = pf::parse_photons_option(a["photons"].as<std::string>());
    std::string direct = a["direct"].as<std::string>();
    pf::require_choice("direct", direct, {"photons", "shadow-rays"});
    int threads = a["threads"].as<int>();
    const std::string scene_path = pf::path_option(a, "scene");
    const pf::BakeOptions bake = pf::bake_options(a, scene_path, threads);
    const std::string keep_scene = a["keep-scene"].as<std::string>();
    uint32_t seed = a["seed"].as<uint32_t>();
    opt.eye.spp = a["spp"].as<int>();
    opt.eye.max_depth = a["max-depth"].as<int>();
    opt.eye.direct = direct == "photons" ? pf::DirectMode::Photons : pf::DirectMode::ShadowRays;
    // 0 (auto): a placeholder for check_options, chosen from the scene once it is read.
    const int shadow_samples = pf::parse_shadow_samples(a["shadow-samples"].as<std::string>());
    opt.eye.shadow_samples = shadow_samples > 0 ? shadow_samples : 1;
    opt.eye.radius = pf::parse_radius_option(a["radius"].as<std::string>());
    opt.eye.seed = seed;
    opt.eye.threads = threads;
    opt.eye.glossy = pf::parse_glossy_merge_option(a["glossy-merge"].as<std::string>(),
                                                   opt.estimator, opt.eye.direct);
    opt.eye.emission_spp = pf::parse_emission_spp(a["emission-spp"].as<std::string>());
    opt.eye.glossy_spp = pf::parse_glossy_spp(a["glossy-spp"].as<std::string>(), opt.estimator,
                                              opt.eye.glossy);
    opt.eye.sampler = sampler == "auto" ? (opt.estimator == pf::Estimator::Ppm
                                               ? pf::PixelSampler::Strata
                                               : pf::PixelSampler::Sobol)
                                        : pf::parse_pixel_sampler(sampler);
    opt.photons.photons = photons > 0 ? photons : pf::kMinAutoPhotons;  // auto: set below
    opt.photons.seed = seed;
    opt.photons.max_bounces = a["max-bounces"].as<int>();
    opt.photons.guide = pf::parse_photon_guide(a["photon-guide"].as<std::string>());
    opt.photons.threads = threads;
    opt.ppm.alpha = a["alpha"].as<float>();
    opt.ppm.slab = pf::parse_slab(a["slab"].as<std::string>(), opt.estimator != pf::Estimator::Ppm);
    opt.ppm.gather_area = pf::parse_gather_area(a["gather-area"].as<std::string>(),
                                                opt.estimator != pf::Estimator::Ppm);
    opt.ppm.max_bins = a["max-bins"].as<int>();
    opt.ppm.threads = threads;
    opt.checkpoint = a["checkpoint"].as<std::string>();
    opt.checkpoint_every = a["checkpoint-every"].as<int>();
    if (a.count("resume") && opt.checkpoint.empty())
      throw pf::input_error("", "--resume needs --checkpoint FILE");
    opt.snapshot_every = a["snapshot-every"].as<int>();
    opt.snapshot_at = pf::parse_pass_list(a["snapshot-at"].as<std::string>(), "snapshot-at");
    pf::check_options(opt);
    const std::string out = pf::path_option(a, "output");
    std::string pattern = a["snapshot"].as<std::string>();
    if (pattern.empty()) {
      const std::filesystem::path p(out);
      pattern = std::filesystem::path(p).replace_extension().string() + "-{pass}p" +
                (p.extension().empty() ? std::string(".exr") : p.extension().string());
    }
    pf::check_snapshot_pattern(pattern, opt);
    const std::string stats = a["stats"].as<std::string>();
    const std::string png = out.empty() ? "" : pf::preview_path(out);
    const bool snapshots = opt.snapshot_every > 0 || !opt.snapshot_at.empty();
    // The last snapshot's name stands for all of them (same directory); the checkpoint is read
    // back by --resume, an output all the same.
    std::vector<std::string> inputs = {scene_path};
    for (const pf::MeshInsert& ins : bake.inserts) inputs.push_back(ins.path);
    pf::check_outputs(inputs,
                      {out, png, stats, opt.checkpoint, sums, keep_scene,
                       snapshots ? pf::render_snapshot_name(pattern, opt.passes, opt.passes) : ""});
    if (!keep_scene.empty() && pf::is_baked_scene(scene_path))
      throw pf::input_error(scene_path, "is a baked scene already; --keep-scene keeps the scene "
                                        "baked from a scene source", "drop --keep-scene");

    pf::Stopwatch clock;
    pf::OpenedScene opened = pf::open_scene(scene_path, bake, pf::given_bake_options(a));
    const pf::Scene& scene = opened.scene;
    // The automatic choices, from the scene (render_defaults.h): every one overridable.
    const pf::RenderDefaults defaults = pf::choose_defaults(scene);
    pf::RenderChoices chosen;
    chosen.estimator = opt.estimator;
    chosen.estimator_auto = a.count("estimator") == 0;
    chosen.direct = opt.eye.direct;
    chosen.direct_auto = a.count("direct") == 0;
    chosen.photons_auto = photons == 0;
    chosen.photons = chosen.photons_auto ? defaults.photons : photons;
    chosen.radius_auto = !(opt.eye.radius > 0.f);
    chosen.radius = chosen.radius_auto ? defaults.radius : opt.eye.radius;
    chosen.emission_spp = opt.eye.emission_spp;
    chosen.emission_spp_auto = a["emission-spp"].as<std::string>() == "auto";
    chosen.shadow_samples_auto = shadow_samples == 0;
    if (chosen.shadow_samples_auto)
      opt.eye.shadow_samples = pf::auto_shadow_samples(opt.estimator, scene);
    chosen.shadow_samples = opt.eye.shadow_samples;
    chosen.gather_area = opt.ppm.gather_area;
    chosen.gather_area_auto = a["gather-area"].as<std::string>() == "auto";
    opt.photons.photons = chosen.photons;
    if (opened.baked_here) {
      for (const std::string& w : pf::bake_warnings(bake, opened.report))
        std::cerr << "render: " << w << "\n";
      std::cout << "render: baked " << scene_path << " (" << scene.triangles.size()
                << " triangles, " << scene.camera.width << "x" << scene.camera.height << ", "
                << clock.seconds() << " s)\n";
    }
    // --keep-scene is written with the run's other outputs (after every check, also the
    // render's own), like them atomically.
    const double bake_seconds = clock.seconds();
    auto keep = [&] {
      if (keep_scene.empty()) return;
      pf::Provenance kept =
          pf::bake_provenance(a, bake, keep_scene, pf::join_command_line(argc, argv));
      kept.wall_time_s = bake_seconds;
      pf::save_scene(scene, keep_scene, kept);
    };
    pf::Provenance prov;
    prov.tool = "render";
    prov.seed = seed;
    pf::record_options(prov, a);
    pf::record_choices(prov.parameters, chosen);
    // OpenCL backend: device eye pass, photon passes, --method gather and synthesis.
    std::unique_ptr<pf::ClContext> dev = pf::open_device(pf::device_options(a), "render");
    opt.device = dev.get();
    opt.ppm.method = pf::method_option(a, dev.get());
    // The gather methods of gather_method.h work on fixed hitpoints (clusters, device-resident
    // state); sppm and pppm gather each pass's new visible points through the CPU grid.
    if (opt.estimator != pf::Estimator::Ppm && a.count("method") &&
        opt.ppm.method != pf::GatherMethod::Grid)
      throw pf::input_error("", "--estimator " + a["estimator"].as<std::string>() +
                                    " gathers through each pass's CPU grid; --method " +
                                    pf::gather_method_name(opt.ppm.method) +
                                    " belongs to ppm's fixed hitpoints",
                            "drop --method (--device opencl still traces the passes there)");
    prov.parameters["method"] = pf::gather_method_name(opt.ppm.method);
    pf::record_backend(prov, dev.get());
    prov.command_line = pf::join_command_line(argc, argv);
    pf::record_scene(prov, a, scene_path, opened, bake);

    prov.wall_time_s = clock.seconds();  // so far; checkpoints add the run's (render_driver.cpp)
    pf::Progress progress("pass", opt.passes, "photons");
    if (opt.time_budget > 0) progress.set_budget(opt.time_budget, a.count("passes") == 0);
    std::vector<pf::RenderImageRecord> written;
    auto image_of = [&](const pf::HitpointSet& h) {
      return dev ? pf::synthesize(h, *dev) : pf::synthesize(h);
    };
    auto snapshot = [&](const pf::Image& img, const pf::RenderStatus& s) {
      const std::string file = pf::render_snapshot_name(pattern, s.passes, opt.passes);
      pf::write_exr(img, file);
      written.push_back({file, s});
      std::cout << "render: snapshot " << file << " (" << s.passes << " passes, " << s.seconds
                << " s)\n";
    };
    auto on_pass = [&](int done, double n) {
      progress.update(done, n);
      return !pf::interrupted();
    };
    pf::RenderStatus status;
    // Ctrl-C (or SIGTERM) ends the run after the pass in progress, with the checkpoint saved.
    const pf::StopOnInterrupt stop(
        "render: stopping after this pass (interrupt again to stop at once)\n");
    pf::Image img;
    pf::PassSums range;
    const bool resume = a.count("resume") > 0;
    if (pppm) {
      range = pf::render_pppm(
          scene, opt, resume, prov, on_pass,
          [&](const pf::PassSums& state, const pf::RenderStatus& s) {
            snapshot(pf::synthesize(state), s);
          },
          &status);
    } else {
      const pf::HitpointSet h = pf::render_progressive(
          scene, opt, resume, prov, on_pass,
          [&](const pf::HitpointSet& state, const pf::RenderStatus& s) {
            snapshot(image_of(state), s);
          },
          &status);
      if (!status.stopped) img = image_of(h);
    }
    prov.wall_time_s = clock.seconds();
    if (status.stopped) {
      progress.end_line();
      keep();
      // The run record still lists what the run wrote (its snapshots).
      if (!stats.empty()) pf::write_render_record(stats, prov, written);
      std::cerr << "render: interrupted after " << status.passes << " of " << opt.passes
                << " passes; "
                << (opt.checkpoint.empty()
                        ? "nothing saved (--checkpoint FILE keeps a run's state for --resume)"
                        : "the state is saved in " + opt.checkpoint +
                              " (rerun the same command with --resume to continue)")
                << "\n";
      return pf::kExitInterrupted;
    }
    progress.end_line();
    if (pppm) {
      if (!sums.empty()) pf::save_pass_sums(range, sums, prov);
      img = pf::synthesize(range);
    }
    keep();
    if (!out.empty()) {
      pf::write_exr(img, out);
      written.push_back({out, status});
      pf::write_png(img, png, a["exposure"].as<float>());
    }
    prov.wall_time_s = clock.seconds();
    if (!stats.empty()) pf::write_render_record(stats, prov, written);
    std::cout << "render: " << (out.empty() ? sums : out) << " (" << scene.camera.width << "x"
              << scene.camera.height << ", " << pf::describe_choices(chosen) << ", "
              << status.passes << " passes" << (status.budget_reached ? " (--time reached)" : "")
              << ", " << status.photons_emitted << " photons, " << clock.seconds() << " s)\n";
    if (status.guide.uniform > 0)
      std::cout << "render: photon guide: visible fraction " << status.guide.visible_fraction()
                << " of the uniform photons, acceptance " << status.guide.acceptance() << "\n";
    return 0;
  });
}
