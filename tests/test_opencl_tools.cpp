// test_opencl_tools.cpp — the stage tools' OpenCL options (issue 4): --list-devices, the staged
// route trace-hitpoints → trace-photons → illuminate → synthesize with --device opencl gives the
// CPU route's image (relative RMSE <= 1e-3) and the render driver's, provenance names the backend,
// and bad device choices are one line with exit code 2. Skipped (WARN) without an OpenCL platform.
#include <catch2/catch.hpp>

#include <cmath>

#include "photonflow/cl_runtime.h"
#include "photonflow/h5io.h"
#include "photonflow/image.h"
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
    ToolRun a = run_tool("trace-hitpoints", "--scene " + sc + " -o " + hp + " --seed 4 " + dev, tmp);
    REQUIRE(a.exit_code == 0);
    ToolRun b = run_tool("trace-photons", "--scene " + sc + " -o " + ph +
                                              " --photons 3000 --passes 3 --seed 4 " + dev, tmp);
    REQUIRE(b.exit_code == 0);
    ToolRun c = run_tool("illuminate", "--scene " + sc + " --hitpoints " + hp + " --photons " + ph +
                                           " -o " + il + " " + dev, tmp);
    REQUIRE(c.exit_code == 0);
    ToolRun d = run_tool("synthesize", "--hitpoints " + il + " -o " + img + " " + dev, tmp);
    REQUIRE(d.exit_code == 0);
    if (!dev.empty()) {
      CHECK(a.err.find("trace-hitpoints: device: opencl on") != std::string::npos);
      CHECK(c.err.find("illuminate: device: opencl on") != std::string::npos);
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
                                     " --photons 3000 --passes 3 --seed 4 --device auto --work-group 32",
                       tmp);
  REQUIRE(r.exit_code == 0);
  CHECK(r.err.find("render: device: ") != std::string::npos);
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
  // A kernel that does not build: the device line, then one error line naming the saved log.
  std::filesystem::create_directories(tmp / "broken/kernels");
  { std::ofstream(tmp / "broken/kernels/trace_photons.cl") << "__kernel void trace_photons( {"; }
  setenv("PHOTONFLOW_KERNEL_DIR", (tmp / "broken").c_str(), 1);
  ToolRun broken = run_tool("trace-photons", "--scene " + sc + " -o " + (tmp / "b.h5") +
                                                 " --device opencl", tmp);
  unsetenv("PHOTONFLOW_KERNEL_DIR");
  CHECK(broken.exit_code == 2);
  CHECK(lines(broken.err) == 2);
  CHECK(broken.err.find("trace-photons: OpenCL kernel build of trace_photons.cl failed") !=
        std::string::npos);
  CHECK(broken.err.find("build log: ") != std::string::npos);
  CHECK(!std::filesystem::exists(tmp / "b.h5"));
  ToolRun wg = run_tool("synthesize", "--hitpoints " + (tmp / "cl-il.h5") + " -o " + (tmp / "z.exr") +
                                          " --device opencl --work-group 100000", tmp);
  CHECK(wg.exit_code == 2);
  CHECK(lines(wg.err) == 1);
}
