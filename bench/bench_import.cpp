// bench_import — the cost of importing in a child process (isolate.h, docs/SCENES.md): the
// overhead of run_isolated with empty work and with a 10 MB result (about a 90k-triangle scene),
// and bake_scene's import time (child process, assimp read, flattening, transfer) against a plain
// in-process assimp read of the same file with the same post-processing. Prints a markdown table.
//
//   build/bin/bench_import [--runs 15] [--mesh PATH ...]     (from the repository root)
//
// Without --mesh: the bundled Cornell box, and the meshes of ../shared/scenes/ inserted into it
// where they exist. Times are medians over --runs runs (ms).
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <assimp/Importer.hpp>
#include <cstdio>
#include <cxxopts.hpp>
#include <filesystem>
#include <string>
#include <vector>

#include "bench_common.h"
#include "photonflow/foundations/isolate.h"
#include "photonflow/geometry/scene_import.h"

using pf::bench::fmt_ms;
using pf::bench::median;
using pf::bench::now;

namespace {

double isolated_ms(size_t bytes) {
  const std::string payload(bytes, 'x');
  const double t = now();
  const pf::IsolatedRun run = pf::run_isolated([&](const pf::IsolatedSend& send) {
    if (bytes) send(payload);
  });
  const double ms = (now() - t) * 1e3;
  if (run.exit_code != 0 || run.output.size() != bytes) {
    std::fprintf(stderr, "bench_import: the isolated run failed\n");
    std::exit(1);
  }
  return ms;
}

double assimp_ms(const std::string& path) {
  Assimp::Importer importer;
  const double t = now();
  const aiScene* s =
      importer.ReadFile(path, aiProcess_Triangulate | aiProcess_ValidateDataStructure);
  const double ms = (now() - t) * 1e3;
  if (!s) {
    std::fprintf(stderr, "bench_import: %s: %s\n", path.c_str(), importer.GetErrorString());
    std::exit(1);
  }
  return ms;
}

}  // namespace

int main(int argc, char** argv) {
  cxxopts::Options o("bench_import", "Cost of importing scenes in a child process.");
  o.add_options()("runs", "runs per measurement (median)",
                  cxxopts::value<int>()->default_value("15"))(
      "mesh", "mesh files to insert into the Cornell box",
      cxxopts::value<std::vector<std::string>>());
  const auto a = o.parse(argc, argv);
  const int runs = std::max(1, a["runs"].as<int>());
  const std::string box = "data/cornell-box.dae";  // run from the repository root
  std::vector<std::string> meshes;
  if (a.count("mesh")) {
    meshes = a["mesh"].as<std::vector<std::string>>();
  } else {
    for (const char* m : {"teapot.obj", "spot.obj", "stanford-bunny.obj", "ogre.obj"}) {
      const std::string p = std::string("../shared/scenes/") + m;
      if (std::filesystem::exists(p)) meshes.push_back(p);
    }
  }

  std::printf("| run_isolated | median (ms) |\n|---|---:|\n");
  for (size_t bytes : {size_t(0), size_t(10) << 20}) {
    std::vector<double> t;
    for (int r = 0; r < runs; ++r) t.push_back(isolated_ms(bytes));
    std::printf("| empty work, %zu MB sent | %s |\n", bytes >> 20, fmt_ms(median(t)).c_str());
  }

  std::printf("\n| input | triangles | assimp read in-process (ms) | bake_scene import, in a child "
              "(ms) | difference (ms) |\n|---|---:|---:|---:|---:|\n");
  std::vector<std::string> inputs = {""};
  inputs.insert(inputs.end(), meshes.begin(), meshes.end());
  for (const std::string& mesh : inputs) {
    pf::BakeOptions opt;
    opt.input = box;
    if (!mesh.empty()) {
      pf::MeshInsert ins;
      ins.path = mesh;
      opt.inserts.push_back(ins);
    }
    std::vector<double> read, bake;
    size_t triangles = 0;
    for (int r = 0; r < runs; ++r) {
      double ms = assimp_ms(box);
      if (!mesh.empty()) ms += assimp_ms(mesh);
      read.push_back(ms);
      pf::BakeReport report;
      triangles = pf::bake_scene(opt, report).triangles.size();
      bake.push_back(report.import_seconds * 1e3);
    }
    const std::string name =
        mesh.empty() ? "cornell-box.dae" : "cornell-box.dae + " +
                                               std::filesystem::path(mesh).filename().string();
    std::printf("| %s | %zu | %s | %s | %s |\n", name.c_str(), triangles,
                fmt_ms(median(read)).c_str(), fmt_ms(median(bake)).c_str(),
                fmt_ms(median(bake) - median(read)).c_str());
  }
  return 0;
}
