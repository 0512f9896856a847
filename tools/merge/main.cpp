// merge — combines the partial results of probabilistic PPM (`render --estimator pppm --sums`,
// pass_sums.h) of disjoint, adjacent pass ranges into one range: the merged sums (--sums, which
// merge again, as a tree) and the image of their mean (-o, KZ11 eq. 8), equal to one run of all
// the passes up to the order of the additions. Parts of another scene, seed or option set, and
// overlapping, duplicate or missing ranges are refused, naming the part.
//
//   merge parts/*.h5 --range 0:400 -o image.exr --stats run.json
#include <charconv>
#include <iostream>
#include <string>
#include <vector>

#include "photonflow/image/image.h"
#include "photonflow/io/output_file.h"
#include "photonflow/estimators/pass_sums.h"
#include "photonflow/estimators/render_driver.h"
#include "photonflow/foundations/tool_main.h"

int main(int argc, char** argv) {
  return pf::run_tool("merge", [&] {
    cxxopts::Options o("merge", "Merge pppm partial results (pass sums) of disjoint pass ranges.");
    // clang-format off
    o.add_options()
      ("parts", "pass-sums files (render --estimator pppm --sums), any order",
       cxxopts::value<std::vector<std::string>>())
      ("range", "the passes the parts must cover exactly, A:B = passes A .. B-1; default: any "
       "contiguous range", cxxopts::value<std::string>()->default_value(""))
      ("sums", "write the merged pass sums here (to merge again)",
       cxxopts::value<std::string>()->default_value(""))
      ("o,output", "write the image (OpenEXR; a PNG preview beside it)",
       cxxopts::value<std::string>()->default_value(""))
      ("stats", "write a JSON run record (the parts with their SHA-256, passes, photons)",
       cxxopts::value<std::string>()->default_value(""))
      ("exposure", "PNG exposure in stops", cxxopts::value<float>()->default_value("0"))
      ("h,help", "print this help");
    // clang-format on
    o.parse_positional({"parts"});
    o.positional_help("PART.h5 [PART.h5 ...]");
    auto a = pf::parse_options(o, argc, argv);
    if (a.count("help")) { std::cout << o.help() << "\n"; return 0; }
    if (!a.count("parts")) throw pf::input_error("", "no parts given", "name the pass-sums files");
    const std::vector<std::string> parts = a["parts"].as<std::vector<std::string>>();
    const std::string sums = a["sums"].as<std::string>(), out = a["output"].as<std::string>();
    const std::string stats = a["stats"].as<std::string>();
    if (sums.empty() && out.empty())
      throw pf::input_error("", "nothing to write", "give -o IMAGE.exr and/or --sums FILE.h5");
    int first = -1, end = -1;
    if (!a["range"].as<std::string>().empty())
      std::tie(first, end) = pf::parse_pass_range(a["range"].as<std::string>());
    const std::string png = out.empty() ? "" : pf::preview_path(out);
    pf::check_outputs(parts, {sums, out, png, stats});

    pf::Stopwatch clock;
    pf::PassSums merged = pf::merge_pass_sum_files(parts, first, end);
    pf::Provenance prov;
    prov.tool = "merge";
    pf::record_options(prov, a);
    prov.command_line = pf::join_command_line(argc, argv);
    for (const std::string& part : parts)
      prov.add_input("part", part, pf::kPassSumsFormat, merged.scene_id);
    const auto seed = merged.parameters.find("seed");
    // The parts' recorded seed ("1", or "eye/photon" as "1/2"): its leading number, if any (a
    // seed the parts record as text that is no number stays in their parameters only).
    if (seed != merged.parameters.end())
      std::from_chars(seed->second.data(), seed->second.data() + seed->second.size(), prov.seed);
    prov.wall_time_s = clock.seconds();
    if (!sums.empty()) pf::save_pass_sums(merged, sums, prov);
    std::vector<pf::RenderImageRecord> written;
    if (!out.empty()) {
      const pf::Image img = pf::synthesize(merged);
      pf::write_exr(img, out);
      pf::write_png(img, png, a["exposure"].as<float>());
      pf::RenderStatus st;
      st.passes = st.target = merged.passes;
      st.photons_emitted = merged.photons_emitted;
      st.mean_radius = pf::pppm_radius(merged.radius1, merged.alpha, merged.end_pass() - 1);
      written.push_back({out, st});
    }
    prov.wall_time_s = clock.seconds();
    if (!stats.empty()) pf::write_render_record(stats, prov, written);
    std::cout << "merge: " << parts.size() << " part(s), passes [" << merged.first_pass << ", "
              << merged.end_pass() << "), " << merged.photons_emitted << " photons -> "
              << (out.empty() ? sums : out) << "\n";
    return 0;
  });
}
