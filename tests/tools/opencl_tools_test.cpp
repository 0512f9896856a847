// opencl_tools_test.cpp — the stage tools' OpenCL options (issue 4): --list-devices, the staged
// route trace-hitpoints → trace-photons → illuminate → synthesize with --device opencl gives the
// CPU route's image (relative RMSE <= 1e-3) and the render driver's, provenance names the backend,
// and bad device choices are one line with exit code 2. Skipped (WARN) without an OpenCL platform.
#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>

#include "photonflow/opencl/cl_runtime.h"
#include "photonflow/io/h5io.h"
#include "photonflow/image/image.h"
#include "photonflow/io/stage_files.h"
#include "photonflow/geometry/scene_file.h"
#include "support.h"

using namespace pf;
using namespace pf::test;

namespace {

size_t lines(const std::string& s) {
  size_t n = 0;
  for (char c : s) n += c == '\n';
  return n;
}

}  // namespace

TEST_CASE("OpenCL tools: staged route and render driver on the device", "[opencl][tools]") {
  TempDir tmp("cltools");
  {
    ToolRun r = run_tool("trace-photons", "--list-devices", tmp);
    CHECK(r.exit_code == 0);
    CHECK((r.out.find("platform 0 device 0") != std::string::npos ||
           r.out.find("no OpenCL platform") != std::string::npos));
  }
  if (cl_list_devices().empty()) {
    WARN("SKIPPED: no OpenCL platform with a device (install pocl-opencl-icd to run this test)");
    ToolRun r = run_tool("trace-photons", "--scene x.h5 -o y.h5 --device opencl", tmp);
    CHECK(r.exit_code == 2);
    return;
  }
  Scene scene = room_scene(PF_MAT_GLASS, 40, 30);
  const std::string sc = tmp / "scene.h5";
  Provenance prov;
  prov.tool = "test";
  save_scene(scene, sc, prov);

  auto staged = [&](const std::string& dev, const std::string& tag) {
    const std::string hp = tmp / (tag + "-hp.h5"), ph = tmp / (tag + "-ph.h5"),
                      il = tmp / (tag + "-il.h5"), img = tmp / (tag + ".exr");
    ToolRun a = run_tool("trace-hitpoints", "--estimator ppm --direct photons --scene " + sc + " -o " + hp + " --seed 4 " + dev, tmp);
    REQUIRE(a.exit_code == 0);
    ToolRun b = run_tool("trace-photons", "--scene " + sc + " -o " + ph +
                                              " --photons 3000 --passes 3 --seed 4 " + dev, tmp);
    REQUIRE(b.exit_code == 0);
    ToolRun c = run_tool("illuminate", "--estimator ppm --scene " + sc + " --hitpoints " + hp + " --photons " + ph +
                                           " -o " + il + " " + dev, tmp);
    REQUIRE(c.exit_code == 0);
    ToolRun d = run_tool("synthesize", "--hitpoints " + il + " -o " + img + " " + dev, tmp);
    REQUIRE(d.exit_code == 0);
    if (!dev.empty()) {
      CHECK(a.out.find("trace-hitpoints: device: opencl on") != std::string::npos);
      CHECK(c.out.find("illuminate: device: opencl on") != std::string::npos);
    }
    return read_exr(img);
  };
  Image cpu = staged("", "cpu");
  Image gpu = staged("--device opencl", "cl");
  double rmse = relative_rmse(gpu, cpu);
  INFO("staged opencl vs cpu, relative RMSE " << rmse);
  CHECK(rmse <= 1e-3);

  h5::Reader hp(tmp / "cl-hp.h5", "photonflow.hitpoints", 100);
  CHECK(hp.attr_string("/provenance/parameters", "backend").rfind("opencl: ", 0) == 0);
  h5::Reader hpc(tmp / "cpu-hp.h5", "photonflow.hitpoints", 100);
  CHECK(hpc.attr_string("/provenance/parameters", "backend") == "cpu");

  // The render driver on the device: the staged device route's image.
  ToolRun r = run_tool("render", "--scene " + sc + " -o " + (tmp / "render.exr") +
                                     " --estimator ppm --direct photons --photons 3000 --passes 3 --seed 4 --device auto"
                                     " --work-group 32",
                       tmp);
  REQUIRE(r.exit_code == 0);
  CHECK(r.out.find("render: device: ") != std::string::npos);
  CHECK(relative_rmse(read_exr(tmp / "render.exr"), gpu) <= 1e-3);

  // Bad choices: one line, exit 2.
  ToolRun bad = run_tool("trace-photons", "--scene " + sc + " -o " + (tmp / "x.h5") +
                                              " --device opencl --cl-platform 9", tmp);
  CHECK(bad.exit_code == 2);
  CHECK(lines(bad.err) == 1);
  CHECK(bad.err.find("no OpenCL device") != std::string::npos);
  ToolRun classic = run_tool("illuminate", "--scene " + sc + " --hitpoints " + (tmp / "cl-hp.h5") +
                                               " --photons " + (tmp / "cl-ph.h5") + " -o " +
                                               (tmp / "y.h5") + " --estimator classic --device opencl",
                             tmp);
  CHECK(classic.exit_code == 2);
  CHECK(lines(classic.err) == 1);
  // A kernel that does not build: one error line naming the saved log (the device line is on
  // stdout, with the other report lines).
  std::filesystem::create_directories(tmp / "broken/kernels");
  { std::ofstream(tmp / "broken/kernels/trace_photons.cl") << "__kernel void trace_photons( {"; }
  setenv("PHOTONFLOW_KERNEL_DIR", (tmp / "broken").c_str(), 1);
  ToolRun broken = run_tool("trace-photons", "--scene " + sc + " -o " + (tmp / "b.h5") +
                                                 " --device opencl", tmp);
  unsetenv("PHOTONFLOW_KERNEL_DIR");
  CHECK(broken.exit_code == 2);
  CHECK(lines(broken.err) == 1);
  CHECK(broken.out.find("trace-photons: device: opencl") != std::string::npos);
  CHECK(broken.err.find("trace-photons: OpenCL kernel build of trace_photons.cl failed") !=
        std::string::npos);
  CHECK(broken.err.find("build log: ") != std::string::npos);
  CHECK(!std::filesystem::exists(tmp / "b.h5"));
  ToolRun wg = run_tool("synthesize", "--hitpoints " + (tmp / "cl-il.h5") + " -o " + (tmp / "z.exr") +
                                          " --device opencl --work-group 100000", tmp);
  CHECK(wg.exit_code == 2);
  CHECK(lines(wg.err) == 1);
}

TEST_CASE("OpenCL tools: --method, --clusters and build-grid on the device", "[opencl][tools][gather]") {
  if (cl_list_devices().empty()) {
    WARN("SKIPPED: no OpenCL platform with a device (install pocl-opencl-icd to run this test)");
    return;
  }
  TempDir tmp("clgather");
  Scene scene = room_scene(PF_MAT_GLASS, 40, 30);
  const std::string sc = tmp / "scene.h5", hp = tmp / "hp.h5", ph = tmp / "ph.h5";
  Provenance prov;
  prov.tool = "test";
  save_scene(scene, sc, prov);
  REQUIRE(run_tool("trace-hitpoints", "--estimator ppm --direct photons --scene " + sc + " -o " + hp + " --seed 2", tmp).exit_code == 0);
  REQUIRE(run_tool("trace-photons", "--scene " + sc + " -o " + ph + " --photons 4000 --passes 3 --seed 2",
                   tmp).exit_code == 0);
  auto illuminate = [&](const std::string& args, const std::string& out) {
    return run_tool("illuminate", "--estimator ppm --scene " + sc + " --hitpoints " + hp + " -o " + (tmp / out) +
                                      " " + args, tmp);
  };
  auto image = [&](const std::string& state) {
    REQUIRE(run_tool("synthesize", "--hitpoints " + (tmp / state) + " -o " + (tmp / (state + ".exr")),
                     tmp).exit_code == 0);
    return read_exr(tmp / (state + ".exr"));
  };
  REQUIRE(illuminate("--photons " + ph, "cpu.h5").exit_code == 0);
  const Image ref = image("cpu.h5");

  // The cluster stage's k-means clusters feed grid-kmeans; the image is the CPU grid gather's.
  const std::string km = tmp / "kmeans.h5", gr = tmp / "grid.h5";
  REQUIRE(run_tool("cluster", "--scene " + sc + " --hitpoints " + hp + " -o " + km + " --method kmeans",
                   tmp).exit_code == 0);
  REQUIRE(run_tool("cluster", "--scene " + sc + " --hitpoints " + hp + " -o " + gr + " --method grid",
                   tmp).exit_code == 0);
  ToolRun k = illuminate("--photons " + ph + " --device opencl --method grid-kmeans --clusters " + km,
                         "km.h5");
  REQUIRE(k.exit_code == 0);
  CHECK(relative_rmse(image("km.h5"), ref) <= 1e-5);
  h5::Reader prov_km(tmp / "km.h5", "photonflow.hitpoints", 100);
  CHECK(prov_km.attr_string("/provenance/parameters", "method") == "grid-kmeans");
  REQUIRE(illuminate("--photons " + ph + " --device opencl --method grid-gridclusters --clusters " + gr,
                     "gr.h5").exit_code == 0);
  CHECK(relative_rmse(image("gr.h5"), ref) <= 1e-5);
  // Without --clusters the tool makes them (and says so).
  ToolRun made = illuminate("--photons " + ph + " --device opencl --method kmeans-clusters", "made.h5");
  REQUIRE(made.exit_code == 0);
  CHECK(made.err.find("kmeans clusters made in") != std::string::npos);
  CHECK(relative_rmse(image("made.h5"), ref) <= 1e-5);

  // Refusals: one line, exit 2, no output.
  auto refused = [&](const std::string& args, const std::string& what) {
    ToolRun r = illuminate(args, "bad.h5");
    INFO(args << " → " << r.err);
    CHECK(r.exit_code == 2);
    CHECK(lines(r.err) <= 2);  // the device line, then the error
    CHECK(r.err.find(what) != std::string::npos);
    CHECK(!std::filesystem::exists(tmp / "bad.h5"));
  };
  refused("--photons " + ph + " --method naive", "add --device opencl");
  refused("--photons " + ph + " --device opencl --method flann", "runs on the CPU backend");
  refused("--photons " + ph + " --device opencl --method grid-gridclusters --clusters " + km,
          "holds kmeans clusters");
  refused("--photons " + ph + " --method grid --clusters " + km, "--clusters is read by");
  refused("--photons " + ph + " --method warp-speed", "--method must be one of");
  {  // clusters of other hitpoints
    const std::string hp2 = tmp / "hp2.h5", km2 = tmp / "km2.h5";
    REQUIRE(run_tool("trace-hitpoints", "--estimator ppm --direct photons --scene " + sc + " -o " + hp2 + " --seed 9", tmp).exit_code == 0);
    REQUIRE(run_tool("cluster", "--scene " + sc + " --hitpoints " + hp2 + " -o " + km2, tmp).exit_code == 0);
    refused("--photons " + ph + " --device opencl --method grid-kmeans --clusters " + km2, km2);
  }

  // build-grid on the device writes the CPU's grids: --grid from either gives the same state.
  const std::string g_cpu = tmp / "g-cpu.h5", g_cl = tmp / "g-cl.h5";
  REQUIRE(run_tool("build-grid", "--scene " + sc + " --photons " + ph + " --hitpoints " + hp + " -o " + g_cpu,
                   tmp).exit_code == 0);
  ToolRun bg = run_tool("build-grid", "--scene " + sc + " --photons " + ph + " --hitpoints " + hp +
                                          " -o " + g_cl + " --device opencl", tmp);
  REQUIRE(bg.exit_code == 0);
  CHECK(bg.out.find("build-grid: device: opencl") != std::string::npos);
  REQUIRE(illuminate("--grid " + g_cpu, "from-cpu-grid.h5").exit_code == 0);
  REQUIRE(illuminate("--grid " + g_cl, "from-cl-grid.h5").exit_code == 0);
  CHECK(image("from-cl-grid.h5").rgb == image("from-cpu-grid.h5").rgb);
}

// A machine without any OpenCL driver (the ICD loader pointed at an empty vendors folder, so
// this runs also where PoCL is installed): --device opencl is one line and exit 2 before any
// work; --device auto (the default where a tool has one) falls back to the CPU backend, says so,
// and gives the CPU backend's result; --list-devices says what to install.
TEST_CASE("OpenCL tools: without an OpenCL driver, opencl is refused and auto runs on the CPU",
          "[opencl][tools]") {
  TempDir tmp("no-icd");
  const std::string vendors = tmp / "vendors";
  std::filesystem::create_directories(vendors);
  const std::string none = "OCL_ICD_VENDORS=" + vendors;
  Scene scene = room_scene(PF_MAT_GLASS, 12, 9);
  const std::string sc = tmp / "scene.h5", hp = tmp / "hp.h5", cpu = tmp / "cpu.h5";
  Provenance prov;
  prov.tool = "test";
  save_scene(scene, sc, prov);

  ToolRun list = run_tool("render", "--list-devices", tmp, none);
  CHECK(list.exit_code == 0);
  CHECK(list.out.find("no OpenCL platform or device found (install an OpenCL driver") !=
        std::string::npos);

  ToolRun refused = run_tool("trace-hitpoints", "--estimator ppm --direct photons --scene " + sc + " -o " + hp + " --device opencl",
                             tmp, none);
  INFO(refused.err);
  CHECK(refused.exit_code == 2);
  CHECK(lines(refused.err) == 1);
  CHECK(refused.err.find("--device opencl: no OpenCL platform or device found") !=
        std::string::npos);
  CHECK_FALSE(std::filesystem::exists(hp));

  ToolRun fallback =
      run_tool("trace-hitpoints", "--estimator ppm --direct photons --scene " + sc + " -o " + hp + " --device auto", tmp, none);
  INFO(fallback.out << fallback.err);
  REQUIRE(fallback.exit_code == 0);
  CHECK((fallback.out + fallback.err).find("cpu backend (auto: no OpenCL") != std::string::npos);
  REQUIRE(run_tool("trace-hitpoints", "--estimator ppm --direct photons --scene " + sc + " -o " + cpu + " --device cpu", tmp)
              .exit_code == 0);
  CHECK(same_hitpoints(load_hitpoints(hp).hitpoints, load_hitpoints(cpu).hitpoints));
  CHECK(h5::Reader(hp, kHitpointsFormat, 2).attr_string("/provenance/parameters", "backend") ==
        "cpu");
}
