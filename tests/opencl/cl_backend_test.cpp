// cl_backend_test.cpp — the OpenCL backend (issue 4) equals the CPU backend (PoCL in CI):
// hitpoints (same pixel, mesh, material for >= 99.9%, positions within 1e-4 relative), photons
// (>= 99% agree), image RMSE after 10 PPM passes <= 1e-3 relative, and the batched paths (forced
// small allocation limit) give the same results as one batch. Without any OpenCL platform every
// case WARNs "SKIPPED" and returns.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <map>
#include <string>
#include <vector>

#include "photonflow/opencl/cl_backend.h"
#include "photonflow/geometry/procedural.h"
#include "photonflow/geometry/raycast.h"
#include "photonflow/estimators/render_driver.h"
#include "photonflow/foundations/rng.h"
#include "photonflow/stages/synthesize.h"
#include "support.h"
#include "support_cl.h"

using namespace pf;
using namespace pf::test;

namespace {

float scene_diag(const Scene& s) { return length(s.bounds.extent()); }

struct Agreement {
  size_t matched = 0, total = 0;
  double fraction() const { return total ? double(matched) / double(total) : 1.0; }
};

// Hitpoints of one pixel in order; compares the k-th hitpoint of each pixel.
Agreement compare_hitpoints(const std::vector<pf_hitpoint>& a, const std::vector<pf_hitpoint>& b,
                            float tol) {
  std::map<std::pair<int, int>, std::vector<const pf_hitpoint*>> pa, pb;
  for (auto& h : a) pa[{h.pixel_y, h.pixel_x}].push_back(&h);
  for (auto& h : b) pb[{h.pixel_y, h.pixel_x}].push_back(&h);
  Agreement r;
  r.total = std::max(a.size(), b.size());
  for (auto& [pix, va] : pa) {
    auto it = pb.find(pix);
    if (it == pb.end()) continue;
    for (size_t k = 0; k < std::min(va.size(), it->second.size()); ++k) {
      const pf_hitpoint& x = *va[k];
      const pf_hitpoint& y = *it->second[k];
      float d = 0.f;
      for (int c = 0; c < 3; ++c) d = std::max(d, std::fabs(x.position[c] - y.position[c]));
      r.matched += x.mesh == y.mesh && x.material == y.material && d <= tol;
    }
  }
  return r;
}

bool same_photon(const pf_photon& a, const pf_photon& b, float tol) {
  if (a.mesh != b.mesh || a.flags != b.flags || a.pass != b.pass) return false;
  for (int c = 0; c < 3; ++c) {
    if (std::fabs(a.position[c] - b.position[c]) > tol) return false;
    if (std::fabs(a.flux[c] - b.flux[c]) > 1e-3f * std::fabs(b.flux[c]) + 1e-6f) return false;
  }
  return true;
}

// Photons in emission order; a path that diverged (rounding at a Russian-roulette or Fresnel
// threshold) stores a different number of photons, so the two sequences are aligned greedily with
// a small look-ahead before counting matches.
Agreement compare_photons(const std::vector<pf_photon>& a, const std::vector<pf_photon>& b,
                          float tol) {
  Agreement r;
  r.total = std::max(a.size(), b.size());
  size_t i = 0, j = 0;
  const size_t look = 32;
  while (i < a.size() && j < b.size()) {
    if (same_photon(a[i], b[j], tol)) {
      ++r.matched, ++i, ++j;
      continue;
    }
    bool found = false;
    for (size_t s = 1; s < look && !found; ++s) {
      for (size_t di = 0; di <= s && !found; ++di) {
        size_t ii = i + di, jj = j + (s - di);
        if (ii < a.size() && jj < b.size() && same_photon(a[ii], b[jj], tol)) {
          i = ii;
          j = jj;
          found = true;
        }
      }
    }
    if (!found) ++i, ++j;
  }
  return r;
}

}  // namespace

TEST_CASE("OpenCL: devices list, kernels build, failures are one line", "[opencl]") {
  auto dev = test_device();
  if (!dev) return;
  INFO(cl_describe_devices());
  CHECK(cl_describe_devices().find(dev->info().device_name) != std::string::npos);
  dev->build_all();
  CHECK(dev->build_seconds() >= 0.0);

  SECTION("a kernel that does not compile: InputError naming the saved build log") {
    test::TempDir tmp("clbad");
    std::filesystem::create_directories(tmp / "kernels");
    std::filesystem::create_directories(tmp / "libcommon");
    { std::ofstream(tmp / "kernels/trace_photons.cl") << "__kernel void trace_photons( { syntax"; }
    setenv("PHOTONFLOW_KERNEL_DIR", tmp.dir.c_str(), 1);
    ClContext ctx(dev->info(), 0);
    std::string msg;
    try {
      ctx.kernel("trace_photons", "trace_photons");
    } catch (const InputError& e) {
      msg = e.what();
    }
    unsetenv("PHOTONFLOW_KERNEL_DIR");
    CHECK(msg.find("OpenCL kernel build of trace_photons.cl failed") != std::string::npos);
    CHECK(msg.find("build log: ") != std::string::npos);
    CHECK(msg.find('\n') == std::string::npos);
    std::string log_path = msg.substr(msg.find("build log: ") + 11);
    log_path = log_path.substr(0, log_path.find(')'));
    CHECK(std::filesystem::exists(log_path));
  }
  SECTION("a device that does not exist") {
    DeviceOptions o;
    o.device = "opencl";
    o.platform = 99;
    CHECK_THROWS_AS(open_device(o, "test"), InputError);
  }
  SECTION("a mapping writes through and ends with its scope, also when an exception leaves it") {
    const ClBuffer b = dev->buffer(64 * sizeof(int));
    {
      ClMapping m(*dev, b, 64 * sizeof(int), ClMapping::Mode::Write);
      for (int i = 0; i < 64; ++i) m.as<int>()[i] = 3 * i;
    }
    std::vector<int> back(64);
    dev->read(b, back.size() * sizeof(int), back.data());
    for (int i = 0; i < 64; ++i) CHECK(back[size_t(i)] == 3 * i);
    uint64_t w = dev->host_waits();
    try {
      ClMapping m(*dev, b, sizeof(int), ClMapping::Mode::Write);
      m.as<int>()[0] = -7;
      throw std::runtime_error("a bad photon");
    } catch (const std::runtime_error&) {
    }
    CHECK(dev->host_waits() - w == 2);  // mapped and unmapped
    dev->read(b, sizeof(int), back.data());
    CHECK(back[0] == -7);
    w = dev->host_waits();
    {
      ClMapping m(*dev, b, 64 * sizeof(int), ClMapping::Mode::Read);
      CHECK(m.as<const int>()[63] == 3 * 63);
      m.unmap();
      CHECK(m.as<const int>() == nullptr);
    }
    CHECK(dev->host_waits() - w == 2);  // unmap() ended it, the scope's end did not again
  }
  SECTION("PF_CL_MAX_ALLOC lowers the allocation limit") {
    setenv("PF_CL_MAX_ALLOC", "65536", 1);
    ClContext ctx(dev->info(), 0);
    unsetenv("PF_CL_MAX_ALLOC");
    CHECK(ctx.max_alloc() == 65536);
    CHECK_THROWS_AS(ctx.buffer(65537), InputError);
  }
}

TEST_CASE("OpenCL: hitpoints agree with the CPU backend", "[opencl][eye]") {
  auto dev = test_device();
  if (!dev) return;
  // Glass sphere: specular chains with Fresnel choices; shadow rays: the direct layer too.
  Scene scene = test::room_scene(PF_MAT_GLASS, 96, 72);
  EyePassOptions opt;
  opt.spp = 4;
  opt.direct = DirectMode::ShadowRays;
  opt.shadow_samples = 2;
  opt.seed = 7;
  EyePassResult cpu = trace_hitpoints(scene, opt);
  EyePassResult gpu = trace_hitpoints(scene, opt, *dev);
  REQUIRE(cpu.hitpoints.size() > 20000);
  CHECK(gpu.radius == cpu.radius);
  CHECK(std::abs(double(gpu.hitpoints.size()) - double(cpu.hitpoints.size())) <=
        0.001 * double(cpu.hitpoints.size()));
  Agreement a = compare_hitpoints(cpu.hitpoints, gpu.hitpoints, 1e-4f * scene_diag(scene));
  INFO("hitpoints agreeing: " << a.matched << " of " << a.total);
  CHECK(a.fraction() >= 0.999);
  // Emitted and direct layers: per-pixel sums of the same paths.
  double se = 0, ref = 0;
  for (size_t i = 0; i < cpu.direct.size(); ++i) {
    double d = double(cpu.direct[i]) - gpu.direct[i] + double(cpu.emitted[i]) - gpu.emitted[i];
    se += d * d;
    ref += double(cpu.direct[i] + cpu.emitted[i]) * double(cpu.direct[i] + cpu.emitted[i]);
  }
  CHECK(std::sqrt(se / ref) <= 1e-3);
}

TEST_CASE("OpenCL: the eye pass stratifies any spp as the CPU does", "[opencl][eye]") {
  // spp that are not perfect squares (a columns × rows grid, eye_strata_columns) and a square one:
  // the kernel must put every sample at the CPU's pixel position.
  auto dev = test_device();
  if (!dev) return;
  Scene scene = test::room_scene(PF_MAT_DIFFUSE, 24, 16);
  for (int spp : {2, 3, 6, 8, 9}) {
    EyePassOptions opt;
    opt.spp = spp;
    opt.seed = 5;
    EyePassResult cpu = trace_hitpoints(scene, opt);
    EyePassResult gpu = trace_hitpoints(scene, opt, *dev);
    REQUIRE(cpu.hitpoints.size() == size_t(24 * 16 * spp));
    Agreement a = compare_hitpoints(cpu.hitpoints, gpu.hitpoints, 1e-4f * scene_diag(scene));
    INFO("spp " << spp << ": hitpoints agreeing " << a.matched << " of " << a.total);
    CHECK(a.fraction() >= 0.999);
  }
}

TEST_CASE("OpenCL: photons agree with the CPU backend", "[opencl][photons]") {
  auto dev = test_device();
  if (!dev) return;
  Scene scene = test::room_scene(PF_MAT_GLASS, 16, 16);
  PhotonPassOptions opt;
  opt.photons = 20000;
  opt.seed = 3;
  PhotonPassResult cpu = trace_photons(scene, 2, opt);
  PhotonPassResult gpu = trace_photons(scene, 2, opt, *dev);
  CHECK(gpu.emitted == cpu.emitted);
  REQUIRE(cpu.photons.size() > 20000);
  Agreement a = compare_photons(cpu.photons, gpu.photons, 1e-4f * scene_diag(scene));
  INFO("photons agreeing: " << a.matched << " of " << a.total << " (cpu " << cpu.photons.size()
                            << ", opencl " << gpu.photons.size() << ")");
  CHECK(a.fraction() >= 0.99);
  size_t caustic = 0;
  for (auto& p : gpu.photons) caustic += (p.flags & PF_PHOTON_CAUSTIC) != 0;
  CHECK(caustic > 0);  // the glass sphere's caustic made it through the device path
}

TEST_CASE("OpenCL: photons from an environment map agree with the CPU backend",
          "[opencl][photons][environment]") {
  auto dev = test_device();
  if (!dev) return;
  // A floor, a glass sphere and a diffuse box under a map with a gradient and a sun, rotated, and
  // a small area light beside it: the light pick, pf_env_emit's direction, disc origin and flux.
  Scene scene;
  scene.triangles = make_box(Vec3(-2, -0.1f, -2), Vec3(2, 0, 2), false, {0, 0});
  auto sphere = make_sphere(Vec3(0.5f, 0.6f, 0), 0.5f, 800, {1, 1});
  auto box = make_box(Vec3(-1.2f, 0, -0.4f), Vec3(-0.4f, 0.8f, 0.4f), false, {2, 0});
  auto lamp = make_box(Vec3(1.4f, 1.5f, 1.4f), Vec3(1.5f, 1.51f, 1.5f), false, {3, 2});
  for (auto* part : {&sphere, &box, &lamp})
    scene.triangles.insert(scene.triangles.end(), part->begin(), part->end());
  scene.mesh_names = {"floor", "sphere", "box", "lamp"};
  pf_material diffuse{}, glass{}, lamp_m{};
  diffuse.type = PF_MAT_DIFFUSE;
  diffuse.ior = 1.f;
  glass.type = PF_MAT_GLASS;
  glass.ior = 1.5f;
  lamp_m.type = PF_MAT_EMITTER;
  lamp_m.ior = 1.f;
  for (int c = 0; c < 3; ++c) {
    diffuse.color[c] = 0.7f;
    glass.color[c] = 1.f;
    lamp_m.emission[c] = 40.f;
  }
  scene.materials = {diffuse, glass, lamp_m};
  scene.material_names = {"diffuse", "glass", "lamp"};
  Environment& e = scene.environment;
  e.width = 64;
  e.height = 32;
  e.rotation_deg = 33.f;
  e.strength = 1.7f;
  e.texels.resize(64 * 32 * 3);
  for (int j = 0; j < 32; ++j)
    for (int i = 0; i < 64; ++i)
      for (int c = 0; c < 3; ++c)
        e.texels[3 * size_t(j * 64 + i) + size_t(c)] =
            (j < 6 && i > 20 && i < 23) ? 3000.f : 0.1f + 0.02f * float(i % 7) + 0.1f * float(c);
  scene.camera = pf_camera{{0, 1, 4}, {0, 0.4f, 0}, {0, 1, 0}, 50.f, 16, 16};
  finish_scene(scene);
  REQUIRE(scene.lights.back().type == PF_LIGHT_ENVIRONMENT);
  PhotonPassOptions opt;
  opt.photons = 30000;
  opt.seed = 8;
  PhotonPassResult cpu = trace_photons(scene, 1, opt);
  PhotonPassResult gpu = trace_photons(scene, 1, opt, *dev);
  CHECK(gpu.emitted == cpu.emitted);
  REQUIRE(cpu.photons.size() > 5000);
  Agreement a = compare_photons(cpu.photons, gpu.photons, 1e-4f * scene_diag(scene));
  INFO("photons agreeing: " << a.matched << " of " << a.total << " (cpu " << cpu.photons.size()
                            << ", opencl " << gpu.photons.size() << ")");
  CHECK(a.fraction() >= 0.99);
  // The first stored photons of the two backends, bit for bit (emission shares every bit).
  size_t exact = 0, n = std::min<size_t>(200, std::min(cpu.photons.size(), gpu.photons.size()));
  for (size_t i = 0; i < n; ++i)
    exact += std::memcmp(&cpu.photons[i], &gpu.photons[i], sizeof(pf_photon)) == 0;
  CHECK(exact >= n - 2);
}

TEST_CASE("OpenCL: photons compacted on the device equal the host's concatenation",
          "[opencl][photons]") {
  auto dev = test_device();
  if (!dev) return;
  Scene scene = test::room_scene(PF_MAT_GLASS, 16, 16);
  auto same = [&](const PhotonPassOptions& opt, uint32_t pass, ClContext& c) {
    const PhotonPassResult host = trace_photons(scene, pass, opt, c);
    const DevicePhotons on = trace_photons_device(scene, pass, opt, c);
    CHECK(on.emitted == host.emitted);
    const std::vector<pf_photon> down = download_photons(on, c);
    REQUIRE(down.size() == host.photons.size());
    // (memcmp may not be given the null data() of empty vectors, even for 0 bytes)
    CHECK((down.empty() ||
           std::memcmp(down.data(), host.photons.data(), down.size() * sizeof(pf_photon)) == 0));
    return down.size();
  };
  PhotonPassOptions opt;
  opt.photons = 20000;
  opt.seed = 3;
  CHECK(same(opt, 2, *dev) > 20000);  // glass: several slots per photon
  opt.photons = 500;                  // fewer than before: nothing stale from the larger pass
  CHECK(same(opt, 3, *dev) > 500);
  opt.max_bounces = 0;  // one slot per photon
  CHECK(same(opt, 4, *dev) > 0);
  opt.photons = 0;
  CHECK(same(opt, 5, *dev) == 0);
  // Slots for more than one batch under a small allocation limit: traced by the host route and
  // uploaded, the same photons.
  opt.photons = 3000;
  opt.max_bounces = 16;
  const size_t stored = trace_photons(scene, 6, opt, *dev).photons.size();
  size_t scene_max = std::max({scene.triangles.size() * sizeof(pf_triangle),
                               scene.hh.size() * sizeof(pf_hh_triangle),
                               scene.kd.nodes.size() * sizeof(pf_kd_node)});
  ClContext small(dev->info(), 0);
  small.set_max_alloc(std::max(scene_max, (stored + 1) * sizeof(pf_photon)) + 1024);
  REQUIRE(small.batch_items(17 * sizeof(pf_photon), opt.photons) < opt.photons);
  CHECK(same(opt, 6, small) == stored);
}

TEST_CASE("OpenCL: image after 10 PPM passes equals the CPU backend's", "[opencl][ppm]") {
  auto dev = test_device();
  if (!dev) return;
  Scene scene = test::room_scene(PF_MAT_MIRROR, 64, 48);
  RenderOptions opt;
  opt.passes = 10;
  opt.photons.photons = 4000;
  opt.eye.seed = opt.photons.seed = 5;
  opt.eye.direct = DirectMode::ShadowRays;
  opt.ppm.alpha = 0.7f;
  Provenance prov;
  HitpointSet cpu = render_progressive(scene, opt, false, prov);
  opt.device = dev.get();
  opt.ppm.method = GatherMethod::GridKmeans;  // clusters made once by the driver
  HitpointSet gpu = render_progressive(scene, opt, false, prov);
  CHECK(gpu.passes == 10);
  CHECK(gpu.photons_emitted == cpu.photons_emitted);
  Image icpu = synthesize(cpu), igpu = synthesize(gpu, *dev);
  double rmse = relative_rmse(igpu, icpu);
  INFO("relative RMSE opencl vs cpu: " << rmse);
  CHECK(rmse <= 1e-3);
  // Synthesis alone gives the CPU's image for the same state: bit for bit where the device rounds
  // division correctly (synthesize.cl adds a pixel's hitpoints in the CPU's order).
  Image same = synthesize(cpu, *dev);
  CHECK(relative_rmse(same, icpu) <= 1e-6);
  CHECK(same.layers.at("hitpoints") == icpu.layers.at("hitpoints"));
  if (!cl_float_options(dev->info().device_id).empty()) {
    CHECK(same.rgb == icpu.rgb);
    CHECK(same.layers.at("radius") == icpu.layers.at("radius"));
    CHECK(same.layers.at("photons") == icpu.layers.at("photons"));
  }
}

TEST_CASE("OpenCL: synthesis adds a pixel's hitpoints in array order, in any batch",
          "[opencl][synthesize]") {
  auto dev = test_device();
  if (!dev) return;
  // A state whose hitpoints are not in pixel order (shuffled): the device must still add each
  // pixel's hitpoints in their array order, as synthesize.cpp does.
  HitpointSet h;
  h.width = 7;
  h.height = 5;
  const size_t npix = 35;
  h.emitted.assign(npix * 3, 0.f);
  h.direct.assign(npix * 3, 0.f);
  for (size_t i = 0; i < npix * 3; ++i) {
    h.emitted[i] = 0.01f * float(i % 7);
    h.direct[i] = 0.1f + 0.003f * float(i);
  }
  h.photons_emitted = 12345;
  for (int i = 0; i < 300; ++i) {
    pf_hitpoint hp{};
    const uint32_t r = uint32_t(i) * 2654435761u;
    hp.pixel_x = int(r % 7u);
    hp.pixel_y = int((r >> 8) % 5u);
    hp.radius = 0.05f + 0.001f * float(i % 13);
    hp.n_photons = float(i % 17) * 0.7f;
    for (int c = 0; c < 3; ++c) {
      hp.weight[c] = 0.3f + 0.01f * float((i + c) % 11);
      hp.flux[c] = 1.f / float(3 + (i * 7 + c) % 29);  // values whose sums round
    }
    h.hitpoints.push_back(hp);
  }
  const Image cpu = synthesize(h);
  const Image one = synthesize(h, *dev);
  // A limit that forces batches of a few pixels.
  ClContext small(dev->info(), 0);
  small.set_max_alloc(20 * sizeof(pf_hitpoint));
  const Image batched = synthesize(h, small);
  const bool exact = !cl_float_options(dev->info().device_id).empty();
  for (const Image* img : {&one, &batched}) {
    CHECK(img->layers.at("hitpoints") == cpu.layers.at("hitpoints"));
    CHECK(relative_rmse(*img, cpu) <= 1e-6);
    if (exact) {
      CHECK(img->rgb == cpu.rgb);
      CHECK(img->layers.at("radius") == cpu.layers.at("radius"));
      CHECK(img->layers.at("photons") == cpu.layers.at("photons"));
    }
  }
  CHECK(one.rgb == batched.rgb);
  // A state before its first photon pass (the eye pass's, N_emitted = 0): no photon term, the
  // image is emitted + direct by definition, on both backends (not τ/(π R² · 0) = inf or NaN).
  {
    HitpointSet fresh = h;
    fresh.photons_emitted = 0;
    fresh.passes = 0;
    for (pf_hitpoint& hp : fresh.hitpoints)
      for (float& f : hp.flux) f = 0.f;
    const Image dimg = synthesize(fresh, *dev);
    const Image cimg = synthesize(fresh);
    REQUIRE(dimg.rgb.size() == npix * 3);
    for (size_t i = 0; i < npix * 3; ++i) {
      INFO("channel " << i);
      CHECK(dimg.rgb[i] == h.emitted[i] + h.direct[i]);
      CHECK(cimg.rgb[i] == h.emitted[i] + h.direct[i]);
    }
    CHECK(dimg.layers.at("radius") == cimg.layers.at("radius"));
  }
  // A hitpoint outside the image is refused, not written out of bounds.
  h.hitpoints[5].pixel_x = 7;
  CHECK_THROWS_AS(synthesize(h, *dev), InputError);
}

TEST_CASE("OpenCL: buffers over the allocation limit are processed in batches", "[opencl][batch]") {
  auto dev = test_device();
  if (!dev) return;
  Scene scene = test::room_scene(PF_MAT_GLASS, 48, 40);
  EyePassOptions eye;
  eye.spp = 2;
  eye.seed = 11;
  PhotonPassOptions ph;
  ph.photons = 3000;
  ph.seed = 11;
  PpmOptions ppm;
  ppm.method = GatherMethod::Naive;  // the method that batches

  // One batch each.
  EyePassResult e1 = trace_hitpoints(scene, eye, *dev);
  PhotonPassResult p1 = trace_photons(scene, 0, ph, *dev);
  HitpointSet h1;
  h1.hitpoints = e1.hitpoints;
  h1.emitted = e1.emitted;
  h1.direct = e1.direct;
  h1.width = e1.width;
  h1.height = e1.height;
  ppm_pass(scene, h1, p1.photons, p1.emitted, ppm, *dev);
  Image i1 = synthesize(h1, *dev);

  // A limit just above the largest scene array: hitpoints, photon slots, photons and hitpoint
  // state all need several batches.
  size_t scene_max = std::max({scene.triangles.size() * sizeof(pf_triangle),
                               scene.hh.size() * sizeof(pf_hh_triangle),
                               scene.kd.nodes.size() * sizeof(pf_kd_node),
                               scene.kd.leaf_tris.size() * sizeof(int32_t)});
  size_t groups = 0;  // the kernels' leaf-ordered plane groups: 13 float4 per 4 triangles
  for (const pf_kd_node& n : scene.kd.nodes)
    if (n.axis == PF_KD_LEAF) groups += size_t((n.count + 3) / 4) * 13 * 16;
  scene_max = std::max(scene_max, groups);
  ClContext small(dev->info(), 0);
  small.set_max_alloc(scene_max + 1024);
  INFO("forced allocation limit " << small.max_alloc() << " bytes");
  REQUIRE(e1.hitpoints.size() * sizeof(pf_hitpoint) > 2 * small.max_alloc());
  REQUIRE(size_t(ph.photons) * 17 * sizeof(pf_photon) > 2 * small.max_alloc());
  REQUIRE(p1.photons.size() * sizeof(pf_photon) > small.max_alloc());
  EyePassResult e2 = trace_hitpoints(scene, eye, small);
  PhotonPassResult p2 = trace_photons(scene, 0, ph, small);
  HitpointSet h2 = h1;
  h2.hitpoints = e2.hitpoints;
  h2.photons_emitted = 0;
  h2.passes = 0;
  h2.estimator = "none";
  ppm_pass(scene, h2, p2.photons, p2.emitted, ppm, small);
  Image i2 = synthesize(h2, small);

  REQUIRE(e2.hitpoints.size() == e1.hitpoints.size());
  CHECK(same_hitpoints(e2.hitpoints, e1.hitpoints));
  CHECK(e2.emitted == e1.emitted);
  REQUIRE(p2.photons.size() == p1.photons.size());
  CHECK(std::memcmp(p2.photons.data(), p1.photons.data(), p1.photons.size() * sizeof(pf_photon)) ==
        0);
  REQUIRE(h2.hitpoints.size() == h1.hitpoints.size());
  CHECK(same_hitpoints(h2.hitpoints, h1.hitpoints));
  CHECK(i2.rgb == i1.rgb);
}

TEST_CASE("OpenCL: the kernels' rope traversal returns the host's hits bit for bit",
          "[opencl][raycast]") {
  auto dev = test_device();
  if (!dev) return;
  // The room with a glass sphere (many small triangles), and the furnace sphere seen from inside.
  for (int which = 0; which < 2; ++which) {
    Scene scene = which == 0 ? test::room_scene(PF_MAT_GLASS, 8, 8) : test::furnace_scene(0.5f, 1.f, 8);
    std::vector<float> rays;
    std::vector<Ray> host;
    const Vec3 lo = scene.bounds.lo, ext = scene.bounds.extent();
    for (uint32_t i = 0; i < 20000; ++i) {
      Ray r;
      r.o = Vec3(lo.x + ext.x * (0.05f + 0.9f * pf_rng_float(9, 0, i, 0)),
                 lo.y + ext.y * (0.05f + 0.9f * pf_rng_float(9, 0, i, 1)),
                 lo.z + ext.z * (0.05f + 0.9f * pf_rng_float(9, 0, i, 2)));
      r.d = Vec3(pf_rng_float(9, 0, i, 3) - 0.5f, pf_rng_float(9, 0, i, 4) - 0.5f,
                 pf_rng_float(9, 0, i, 5) - 0.5f);
      if (i % 7 == 0) r.d.x = 0.f;  // axis-parallel components
      r.tmax = i % 4 == 0 ? 0.3f : INFINITY;
      host.push_back(r);
      rays.insert(rays.end(), {r.o.x, r.o.y, r.o.z, r.d.x, r.d.y, r.d.z, r.tmin, r.tmax});
    }
    std::vector<ClRayHit> closest = cast_rays(scene, rays, false, *dev);
    std::vector<ClRayHit> any = cast_rays(scene, rays, true, *dev);
    size_t differ = 0, any_differ = 0, hits = 0;
    for (size_t i = 0; i < host.size(); ++i) {
      Hit h;
      bool hit = intersect_closest(scene, host[i], h, Traversal::Ropes);
      hits += hit;
      const ClRayHit& c = closest[i];
      differ += hit ? !(c.tri == h.tri && c.t == h.t && c.u == h.u && c.v == h.v) : c.tri != -1;
      any_differ += intersect_any(scene, host[i], Traversal::Ropes) != (any[i].tri >= 0);
    }
    INFO("scene " << which << ": " << hits << " of " << host.size() << " rays hit");
    CHECK(hits > host.size() / 2);
    CHECK(differ == 0);
    CHECK(any_differ == 0);
  }
}
