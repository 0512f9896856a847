// trace-hitpoints — the eye pass of progressive photon mapping (thesis ch. 3.5, 7.1).
//
// Reads scene.h5, traces camera rays through mirror and glass to the first diffuse surface, and
// writes hitpoints.h5: the hitpoints (R = R0, N = 0, τ = 0) and the emitted/direct image layers.
#include <iostream>

#include "photonflow/opencl/cl_backend.h"
#include "photonflow/opencl/device_options.h"
#include "photonflow/stages/eye_pass.h"
#include "photonflow/foundations/options.h"
#include "photonflow/estimators/render_defaults.h"
#include "photonflow/estimators/sppm.h"
#include "photonflow/io/stage_files.h"
#include "photonflow/foundations/tool_main.h"
#include "photonflow/geometry/scene_file.h"

int main(int argc, char** argv) {
  return pf::run_tool("trace-hitpoints", [&] {
    cxxopts::Options o("trace-hitpoints",
                       "Eye pass: store a hitpoint at the first diffuse surface seen through each "
                       "pixel sample (after mirror/glass bounces).");
    o.add_options()
      ("scene", "baked scene (scene.h5 from scene-bake)", cxxopts::value<std::string>())
      ("o,output", "output hitpoints file (.h5)", cxxopts::value<std::string>())
      ("spp", "eye samples per pixel (1 = pixel centre, n > 1 = stratified jitter)",
       cxxopts::value<int>()->default_value("1"))
      ("max-depth", "specular bounces before an eye path is dropped",
       cxxopts::value<int>()->default_value("16"))
      ("direct", "direct light: photons (all light from photons) | shadow-rays (area-light "
       "sampling; photons then carry indirect light only); the default is render's "
       "(render_defaults.h)",
       cxxopts::value<std::string>()->default_value(pf::direct_mode_name(pf::kDefaultDirect)))
      ("shadow-samples", "light samples per visible point with --direct shadow-rays, or auto: " +
       std::to_string(pf::kDefaultShadowSamples) + " for sppm and pppm (" +
       std::to_string(pf::kEnvironmentShadowSamples) + " in a scene with an environment light), " +
       std::to_string(pf::kPpmShadowSamples) + " for ppm (render's: render_defaults.h)",
       cxxopts::value<std::string>()->default_value("auto"))
      ("radius", "initial radius R0 in world units; 0 = automatic: 1.5 x max(scene diagonal / "
       "200, 4 pixel footprints at the look-at distance)",
       cxxopts::value<float>()->default_value("0"))
      ("estimator", "the estimator the hitpoints are for: ppm (one eye pass, pass 0, any --spp) | "
       "sppm | pppm (eye pass --pass of a run that traces one every pass, one sample per pixel); "
       "the default is render's (render_defaults.h): with no options, trace-hitpoints, "
       "trace-photons and illuminate make render's pass 0 (pass p: --pass p, trace-photons "
       "--first-pass p, illuminate --state)",
       cxxopts::value<std::string>()->default_value(pf::estimator_name(pf::kDefaultEstimator)))
      ("pass", "sppm/pppm: which eye pass (0-based; the photon pass it meets has the same index)",
       cxxopts::value<int>()->default_value("0"))
      ("glossy-merge", "at a glossy (PBR) point: first = make the visible point there; mis = "
       "share its light between the gather there and continuing the eye path (sppm and pppm, "
       "--direct shadow-rays); or auto: mis for sppm and pppm with shadow rays, else first",
       cxxopts::value<std::string>()->default_value("auto"))
      ("glossy-spp", "pppm: eye samples more per pass in the pixels that see a glossy point "
       "their eye paths go on from (--glossy-merge mis), or auto: " +
       std::to_string(pf::kDefaultGlossySpp) + " for pppm with --glossy-merge mis, else 0",
       cxxopts::value<std::string>()->default_value("auto"))
      ("emission-spp", "eye paths more per pass, through mirrors and glass only, in the pixels "
       "that see an emitter that way or directly (their emitted light converges faster; 0 = "
       "none), or auto: " + std::to_string(pf::kDefaultEmissionSpp) + " (render_defaults.h)",
       cxxopts::value<std::string>()->default_value("auto"))
      ("pixel-sampler", "where samples go in their pixel: auto (strata for ppm, sobol otherwise) "
       "| strata | random | sobol", cxxopts::value<std::string>()->default_value("auto"))
      ("seed", "random seed (jitter, glass choices, light samples)",
       cxxopts::value<uint32_t>()->default_value("1"))
      ("threads", "worker threads, 0 = all cores (results do not depend on it)",
       cxxopts::value<int>()->default_value("0"))
      ("h,help", "print this help");
    pf::add_device_options(o);
    auto a = pf::parse_options(o, argc, argv);
    if (a.count("help")) { std::cout << o.help() << "\n"; return 0; }
    if (pf::list_devices_requested(a)) return 0;
    pf::require_options(o, a, {"scene", "output"});
    pf::check_output_options(a, {"scene"}, {"output"});

    pf::EyePassOptions opt;
    opt.spp = a["spp"].as<int>();
    opt.max_depth = a["max-depth"].as<int>();
    std::string direct = a["direct"].as<std::string>();
    pf::require_choice("direct", direct, {"photons", "shadow-rays"});
    opt.direct = direct == "photons" ? pf::DirectMode::Photons : pf::DirectMode::ShadowRays;
    opt.radius = a["radius"].as<float>();
    opt.seed = a["seed"].as<uint32_t>();
    opt.threads = a["threads"].as<int>();
    const pf::Estimator estimator = pf::parse_estimator(a["estimator"].as<std::string>());
    const bool estimator_auto = !a.count("estimator");
    const int pass = a["pass"].as<int>();
    if (pass < 0) throw pf::input_error("", "--pass must be >= 0");
    if (pass > 0 && estimator == pf::Estimator::Ppm)
      throw pf::input_error("", "--pass applies to --estimator sppm or pppm (ppm has one eye pass)");
    if (estimator == pf::Estimator::Sppm && opt.spp != 1)
      throw pf::input_error("", std::string("--estimator sppm") + (estimator_auto ? " (the default)" : "") +
                                    " takes one eye sample per pixel and pass",
                            estimator_auto ? "drop --spp, or give --estimator ppm for one eye pass "
                                             "of several samples"
                                           : "drop --spp: every pass traces a new sample in each pixel");
    opt.pass = uint32_t(pass);
    const std::string sampler = a["pixel-sampler"].as<std::string>();
    opt.sampler = sampler != "auto" ? pf::parse_pixel_sampler(sampler)
                  : estimator == pf::Estimator::Ppm ? pf::PixelSampler::Strata
                                                    : pf::PixelSampler::Sobol;
    opt.glossy = pf::parse_glossy_merge_option(a["glossy-merge"].as<std::string>(), estimator,
                                               opt.direct);
    opt.emission_spp = pf::parse_emission_spp(a["emission-spp"].as<std::string>());
    opt.glossy_spp = pf::parse_glossy_spp(a["glossy-spp"].as<std::string>(), estimator, opt.glossy);
    if (opt.glossy_spp > 0 && estimator != pf::Estimator::Pppm)
      throw pf::input_error("", "--glossy-spp applies to --estimator pppm",
                            "sppm keeps one visible point per pixel and ppm one eye pass");
    // 0 (auto): a placeholder for check_options, chosen from the scene once it is read.
    const int shadow_samples = pf::parse_shadow_samples(a["shadow-samples"].as<std::string>());
    opt.shadow_samples = shadow_samples > 0 ? shadow_samples : 1;
    pf::check_options(opt);

    pf::Stopwatch clock;
    std::string scene_path = a["scene"].as<std::string>();
    pf::Scene scene = pf::load_scene(scene_path);
    if (shadow_samples == 0) opt.shadow_samples = pf::auto_shadow_samples(estimator, scene);
    std::unique_ptr<pf::ClContext> dev = pf::open_device(pf::device_options(a), "trace-hitpoints");
    pf::EyePassResult r = dev ? pf::trace_hitpoints(scene, opt, *dev) : pf::trace_hitpoints(scene, opt);

    pf::HitpointSet h = pf::make_hitpoint_set(std::move(r), opt.direct, scene.scene_id, pass);

    pf::Provenance prov;
    prov.tool = "trace-hitpoints";
    prov.seed = opt.seed;
    pf::record_options(prov, a);
    // Whether the estimator and direct light were render's defaults (render_defaults.h).
    prov.parameters["estimator_auto"] = estimator_auto ? "true" : "false";
    prov.parameters["direct_auto"] = a.count("direct") ? "false" : "true";
    prov.parameters["pixel-sampler"] = pf::pixel_sampler_name(opt.sampler);  // auto resolved
    prov.parameters["shadow-samples"] = std::to_string(opt.shadow_samples);  // likewise
    // auto resolved; only where it is used (render_driver.cpp state_parameters reads it back)
    prov.parameters.erase("glossy-merge");
    if (opt.glossy != pf::GlossyMerge::First)
      prov.parameters["glossy-merge"] = pf::glossy_merge_name(opt.glossy);
    prov.parameters.erase("glossy-spp");  // likewise: auto resolved, only where used
    if (opt.glossy_spp > 0) prov.parameters["glossy-spp"] = std::to_string(opt.glossy_spp);
    prov.parameters.erase("emission-spp");  // likewise: auto resolved, only where used
    if (opt.emission_spp > 0) prov.parameters["emission-spp"] = std::to_string(opt.emission_spp);
    pf::record_backend(prov, dev.get());
    prov.command_line = pf::join_command_line(argc, argv);
    prov.add_input("scene", scene_path, pf::kSceneFormat, scene.scene_id);
    prov.wall_time_s = clock.seconds();
    pf::save_hitpoints(h, a["output"].as<std::string>(), prov);
    std::cout << "trace-hitpoints: " << h.hitpoints.size() << " hitpoints for " << h.width << "x"
              << h.height << " pixels, R0 = " << h.radius0 << ", " << clock.seconds() << " s\n";
    return 0;
  });
}
