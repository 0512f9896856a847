// pathtrace — unbiased path tracing of a baked scene (next-event estimation, optional MIS,
// Russian roulette; pathtrace.h): the reference images and the speed–accuracy baseline that photon
// mapping is compared against. Progressive, with EXR snapshots of the running mean.
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include "photonflow/foundations/options.h"
#include "photonflow/stages/pathtrace.h"
#include "photonflow/foundations/progress.h"
#include "photonflow/foundations/text_file.h"
#include "photonflow/foundations/tool_main.h"
#include "photonflow/geometry/scene_file.h"

namespace {

// The snapshot file name: `pattern` with "{spp}" replaced by the sample count, zero-padded to the
// digits of the total so that names sort in sample order.
std::string snapshot_name(const std::string& pattern, int samples, int total) {
  return pf::numbered_name(pattern, "{spp}", samples, total);
}

}  // namespace

int main(int argc, char** argv) {
  return pf::run_tool("pathtrace", [&] {
    cxxopts::Options o("pathtrace",
                       "Unbiased path tracing of a baked scene (next-event estimation on the "
                       "lights, Russian roulette); progressive, with EXR snapshots.");
    // clang-format off
    o.add_options()
      ("scene", "baked scene (scene.h5 from scene-bake)", cxxopts::value<std::string>())
      ("o,output", "output OpenEXR image: linear RGB radiance, W/(sr m^2), plus AOV layers "
       "'samples' (samples per pixel) and 'variance' (variance of the pixel's mean luminance)",
       cxxopts::value<std::string>())
      ("png", "sRGB PNG preview of the final image; default: the output with .png; 'none': no "
       "preview", cxxopts::value<std::string>()->default_value(""))
      ("exposure", "PNG exposure in stops (the EXR is never scaled)",
       cxxopts::value<float>()->default_value("0"))
      ("spp", "samples (camera paths) per pixel in total",
       cxxopts::value<int>()->default_value("64"))
      ("max-depth", "scattering events per path (diffuse, mirror and glass bounces); light that "
       "needs more is dropped; 0 = emitters seen directly only",
       cxxopts::value<int>()->default_value("64"))
      ("rr-depth", "bounces before Russian roulette starts (survival = max channel of the "
       "energy the path carries: its throughput without the radiance's (eta_o/eta_i)^2 at "
       "refractions)", cxxopts::value<int>()->default_value("3"))
      ("mis", "power: next-event estimation and emitters hit after a diffuse bounce combined by "
       "the power heuristic; off: after a diffuse bounce only next-event estimation counts",
       cxxopts::value<std::string>()->default_value("power"))
      ("sampler", "sobol: every decision of a path (pixel position, lens, light, BSDF "
       "direction, lobe, roulette) its own per-pixel Owen-scrambled Sobol sequence over the "
       "pixel's samples (stratified); independent: independent numbers",
       cxxopts::value<std::string>()->default_value("sobol"))
      ("seed", "random seed (with the pixel and sample number, it fixes every number a path draws)",
       cxxopts::value<uint32_t>()->default_value("1"))
      ("snapshot-every", "write the running image every K samples per pixel; 0 = no snapshots",
       cxxopts::value<int>()->default_value("0"))
      ("snapshot", "snapshot file pattern; {spp} becomes the samples so far (zero-padded); "
       "default: the output's name with -{spp}spp before the extension",
       cxxopts::value<std::string>()->default_value(""))
      ("time", "wall-clock budget in seconds: stop at the end of the pass in which this many "
       "seconds have passed, with fewer than --spp samples; 0 = none",
       cxxopts::value<double>()->default_value("0"))
      ("stats", "also write a JSON record of the run here: parameters, input scene and its "
       "SHA-256, and samples, seconds and rays of every image written",
       cxxopts::value<std::string>()->default_value(""))
      ("threads", "worker threads, 0 = all cores (results do not depend on it)",
       cxxopts::value<int>()->default_value("0"))
      ("h,help", "print this help");
    // clang-format on
    auto a = pf::parse_options(o, argc, argv, {{"time-limit", "time"}});
    if (a.count("help")) {
      std::cout << o.help() << "\nThe image after N samples is the same for any --threads, "
                               "--snapshot-every and --time.\n";
      return 0;
    }
    pf::require_options(o, a, {"scene", "output"});

    pf::PathTraceOptions opt;
    opt.spp = a["spp"].as<int>();
    opt.max_depth = a["max-depth"].as<int>();
    opt.rr_depth = a["rr-depth"].as<int>();
    opt.seed = a["seed"].as<uint32_t>();
    opt.threads = a["threads"].as<int>();
    opt.snapshot_every = a["snapshot-every"].as<int>();
    opt.time_limit_s = a["time"].as<double>();
    const std::string mis = a["mis"].as<std::string>();
    pf::require_choice("mis", mis, {"power", "off"});
    opt.mis = mis == "off" ? pf::MisMode::Off : pf::MisMode::Power;
    const std::string sampler = a["sampler"].as<std::string>();
    pf::require_choice("sampler", sampler, {"sobol", "independent"});
    opt.sampler = sampler == "independent" ? pf::PathSamplerKind::Independent
                                           : pf::PathSamplerKind::Sobol;
    pf::require_positive("spp", opt.spp);
    if (opt.max_depth < 0) throw pf::input_error("", "--max-depth must be >= 0");
    if (opt.rr_depth < 0) throw pf::input_error("", "--rr-depth must be >= 0");
    if (opt.snapshot_every < 0) throw pf::input_error("", "--snapshot-every must be >= 0");
    if (!(opt.time_limit_s >= 0.0)) throw pf::input_error("", "--time must be >= 0");

    const std::string out = a["output"].as<std::string>();
    const std::filesystem::path out_path(out);
    const std::string ext = out_path.extension().string();
    const std::string stem = std::filesystem::path(out_path).replace_extension().string();
    std::string png = a["png"].as<std::string>();
    if (png.empty()) png = stem + ".png";
    std::string pattern = a["snapshot"].as<std::string>();
    if (pattern.empty()) pattern = stem + "-{spp}spp" + (ext.empty() ? ".exr" : ext);
    const std::string stats = a["stats"].as<std::string>();
    pf::check_outputs({pf::path_option(a, "scene")},
                      {out, png == "none" ? "" : png, stats,
                       opt.snapshot_every > 0 ? snapshot_name(pattern, opt.spp, opt.spp) : ""});

    pf::Stopwatch clock;
    const std::string scene_path = a["scene"].as<std::string>();
    const pf::Scene scene = pf::load_scene(scene_path);
    pf::Provenance prov;
    prov.tool = "pathtrace";
    prov.seed = opt.seed;
    pf::record_options(prov, a);
    prov.command_line = pf::join_command_line(argc, argv);
    prov.add_input("scene", scene_path, pf::kSceneFormat, scene.scene_id);

    std::vector<pf::PathTraceImageRecord> written;
    pf::Progress progress("sample", opt.spp, "paths");
    pf::PathTraceCallbacks cb;
    cb.on_progress = [&](const pf::PathTraceStatus& s) {
      progress.update(s.samples, double(s.paths));
    };
    cb.on_snapshot = [&](const pf::Image& img, const pf::PathTraceStatus& s) {
      const std::string file = snapshot_name(pattern, s.samples, opt.spp);
      pf::write_exr(img, file);
      written.push_back({file, s});
      std::cout << "pathtrace: snapshot " << file << " (" << s.samples << " spp, " << s.seconds
                << " s)\n";
    };
    pf::PathTraceStatus status;
    const pf::Image img = pf::pathtrace(scene, opt, cb, &status);
    pf::write_exr(img, out);
    written.push_back({out, status});
    if (png != "none") pf::write_png(img, png, a["exposure"].as<float>());
    prov.wall_time_s = clock.seconds();
    if (!stats.empty()) pf::write_pathtrace_record(stats, prov, written);
    std::cout << "pathtrace: " << out << " (" << img.width << "x" << img.height << ", "
              << status.samples << " spp" << (status.timed_out ? " (--time reached)" : "") << ", "
              << status.rays << " rays, " << clock.seconds() << " s)\n";
    if (status.nonfinite > 0)
      std::cerr << "pathtrace: warning: " << status.nonfinite
                << " samples were NaN or infinite and counted as 0\n";
    return 0;
  });
}
