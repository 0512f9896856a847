// gen-mesh — writes a procedural test mesh (procedural.h) as a Wavefront OBJ file.
//
//   gen-mesh --shape blob --triangles 120000 -o out/data/blob.obj [--seed 1]
#include <filesystem>
#include <iostream>
#include <string>

#include "photonflow/geometry/procedural.h"
#include "photonflow/foundations/tool_main.h"

int main(int argc, char** argv) {
  return pf::run_tool("gen-mesh", [&]() {
    cxxopts::Options opts("gen-mesh", "Write a procedural triangle mesh as Wavefront OBJ.");
    // clang-format off
    opts.add_options()
      ("shape", "sphere | blob | heightfield | soup | box",
       cxxopts::value<std::string>()->default_value("blob"))
      ("triangles", "minimum triangle count (sphere, blob, heightfield: the smallest grid that "
       "reaches it; soup: exact; box: always 12)",
       cxxopts::value<size_t>()->default_value("10000"))
      ("radius", "sphere/blob radius, heightfield/soup/box half extent (soup triangles are "
       "0.05·radius across), in scene units",
       cxxopts::value<float>()->default_value("1"))
      ("amplitude", "blob displacement and heightfield relief, as a fraction of --radius",
       cxxopts::value<float>()->default_value("0.25"))
      ("seed", "random seed of blob, heightfield and soup",
       cxxopts::value<uint64_t>()->default_value("1"))
      ("o,output", "output OBJ path (required; missing directories are created; written atomically)",
       cxxopts::value<std::string>())
      ("h,help", "print this help");
    // clang-format on
    const auto args = pf::parse_options(opts, argc, argv, {{"out", "output"}});
    if (args.count("help")) {
      std::cout << opts.help() << "\nAll meshes are centred at the origin, outward-facing.\n";
      return 0;
    }
    pf::require_options(opts, args, {"output"});
    const std::string shape = args["shape"].as<std::string>();
    const size_t n = args["triangles"].as<size_t>();
    const float r = args["radius"].as<float>();
    const float amp = args["amplitude"].as<float>();
    const uint64_t seed = args["seed"].as<uint64_t>();
    if (!(r > 0.f)) throw pf::input_error("", "--radius must be positive");

    std::vector<pf_triangle> tris;
    if (shape == "sphere") {
      tris = pf::make_sphere({0, 0, 0}, r, n);
    } else if (shape == "blob") {
      tris = pf::make_blob({0, 0, 0}, r, n, amp, seed);
    } else if (shape == "heightfield") {
      int cells = 1;
      while (2 * size_t(cells) * size_t(cells) < n) ++cells;
      tris = pf::make_heightfield(-r, r, -r, r, 0.f, amp * r, cells, seed);
    } else if (shape == "soup") {
      pf::Bounds box;
      box.extend({-r, -r, -r});
      box.extend({r, r, r});
      tris = pf::make_triangle_soup(box, n, 0.05f * r, seed);
    } else if (shape == "box") {
      tris = pf::make_box({-r, -r, -r}, {r, r, r}, false);
    } else {
      throw pf::input_error("", "unknown --shape '" + shape + "'",
                            "use sphere, blob, heightfield, soup or box");
    }
    const std::string out = args["output"].as<std::string>();
    const std::filesystem::path dir = std::filesystem::path(out).parent_path();
    std::error_code ec;
    if (!dir.empty()) std::filesystem::create_directories(dir, ec);  // check_outputs reports it
    pf::check_outputs({}, {out});
    pf::write_obj(out, tris);
    std::cout << "gen-mesh: wrote " << tris.size() << " triangles to " << out << "\n";
    return 0;
  });
}
