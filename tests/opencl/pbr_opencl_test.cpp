// The OpenCL backend on PF_MAT_PBR surfaces (issue 32 items 2 and 6): the device's eye pass (the
// visible points, their pf_pbr_point table, the shadow-ray direct layer), photon pass (stored as
// at a diffuse hit, continued by pf_pbr_scatter with the CPU's draws and Russian roulette) and
// every device gather (f per photon at PBR hitpoints, HJ09 eq. 10–11) equal the CPU backend's
// (ggx-est's eye_pass.cpp, photon_pass.cpp, illuminate.cpp) up to float rounding, on an in-memory
// room with a textured PBR box (base colour and metallic-roughness maps), a rough-glass sphere
// with smooth shading normals and an untextured rough-metal block; and the render driver's SPPM
// and PPPM device routes give the CPU's images there. Runs on PoCL (skipped without a device).
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>

#include "photonflow/opencl/cl_backend.h"
#include "photonflow/opencl/cl_gather.h"
#include "photonflow/foundations/error.h"
#include "photonflow/stages/eye_pass.h"
#include "photonflow/stages/gather_method.h"
#include "photonflow/stages/illuminate.h"
#include "photonflow/stages/photon_pass.h"
#include "photonflow/geometry/procedural.h"
#include "photonflow/io/provenance.h"
#include "photonflow/estimators/render_driver.h"
#include "photonflow/estimators/sppm.h"
#include "photonflow/io/stage_files.h"
#include "photonflow/geometry/surface.h"
#include "photonflow/stages/synthesize.h"
#include "support.h"
#include "support_cl.h"

using namespace pf;

namespace {

// Materials (= meshes): 0 walls (diffuse), 1 box (PBR, textured), 2 sphere (PBR rough glass),
// 3 light, 4 block (PBR rough metal, untextured).
constexpr int kBox = 1, kSphere = 2, kBlock = 4;

pf_material material(int type, float r, float g, float b) {
  pf_material m{};
  m.type = type;
  m.ior = 1.f;
  m.color[0] = r;
  m.color[1] = g;
  m.color[2] = b;
  return m;
}

// `spot`: a spot light besides the lamp (two emitters: next-event estimation's local light
// choice, light_choice_shared.h).
Scene pbr_room(int width, int height, bool spot = false) {
  Scene s;
  s.triangles = make_cornell_room(400);
  auto light = make_box(Vec3(0.4f, 0.98f, 0.4f), Vec3(0.6f, 0.99f, 0.6f), false, {3, 3});
  s.triangles.insert(s.triangles.end(), light.begin(), light.end());
  auto block = make_box(Vec3(0.08f, 0.55f, 0.1f), Vec3(0.3f, 0.8f, 0.3f), false, {4, 4});
  s.triangles.insert(s.triangles.end(), block.begin(), block.end());
  s.mesh_names = {"walls", "box", "sphere", "light", "block"};
  pf_material walls = material(PF_MAT_DIFFUSE, 0.7f, 0.6f, 0.5f);
  pf_material box = material(PF_MAT_PBR, 0.9f, 0.8f, 0.6f);  // × the checker
  box.metallic = 1.f;    // × texel B
  box.roughness = 0.9f;  // × texel G
  box.ior = 1.5f;
  pf_material glass = material(PF_MAT_PBR, 0.95f, 0.95f, 0.9f);
  glass.roughness = 0.3f;
  glass.transmission = 1.f;
  glass.ior = 1.5f;
  pf_material light_m = material(PF_MAT_EMITTER, 0.f, 0.f, 0.f);
  for (float& e : light_m.emission) e = 20.f;
  pf_material metal = material(PF_MAT_PBR, 0.95f, 0.7f, 0.4f);
  metal.metallic = 1.f;
  metal.roughness = 0.35f;
  metal.ior = 1.5f;
  s.materials = {walls, box, glass, light_m, metal};
  s.material_names = {"walls", "box", "sphere", "light", "block"};
  // Textures: a 4×4 base-colour checker (repeat) and a 4×4 metallic-roughness map (G roughness,
  // B metallic; mirrored repeat in t), both bilinear.
  s.textures = {pf_texture{4, 4, 0, PF_TEX_WRAP_REPEAT, PF_TEX_WRAP_REPEAT, PF_TEX_FILTER_BILINEAR},
                pf_texture{4, 4, 16, PF_TEX_WRAP_REPEAT, PF_TEX_WRAP_MIRROR,
                           PF_TEX_FILTER_BILINEAR}};
  s.texture_names = {"checker.png", "mr.png"};
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 4; ++x) {
      const float v = (x + y) % 2 ? 1.f : 0.25f;
      s.texels.insert(s.texels.end(), {v, 0.5f + 0.5f * v, v, 1.f});
    }
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 4; ++x)
      s.texels.insert(s.texels.end(), {0.f, 0.2f + 0.2f * float(x), 0.3f * float(y), 1.f});
  s.material_texture = {-1, 0, -1, -1, -1};
  s.material_mr_texture = {-1, 1, -1, -1, -1};
  s.uvs.resize(s.triangles.size());
  for (size_t t = 0; t < s.triangles.size(); ++t) {
    const pf_triangle& tr = s.triangles[t];
    const float* v[3] = {tr.v0, tr.v1, tr.v2};
    for (int k = 0; k < 3; ++k) {
      s.uvs[t].uv[2 * k] = 3.f * v[k][0] + 1.5f * v[k][2];
      s.uvs[t].uv[2 * k + 1] = 3.f * v[k][1] - 1.5f * v[k][2];
    }
  }
  s.camera = pf_camera{{0.5f, 0.5f, 0.97f}, {0.5f, 0.45f, 0.f}, {0, 1, 0}, 70.f, width, height};
  if (spot) {
    pf_light l{};
    l.type = PF_LIGHT_SPOT;
    const float pos[3] = {0.75f, 0.9f, 0.6f}, dir[3] = {-0.3f, -0.9539392f, 0.f};
    for (int k = 0; k < 3; ++k) {
      l.position[k] = pos[k];
      l.direction[k] = dir[k];
      l.radiance[k] = 0.6f;
    }
    l.cos_inner = 0.9f;
    l.cos_outer = 0.8f;
    s.lights.push_back(l);
  }
  finish_scene(s);
  return s;
}

bool close(float a, float b, float rel) {
  return std::fabs(a - b) <= rel * std::max(std::fabs(a), std::fabs(b)) + 1e-12f;
}

// Photon lists in emission order, aligned greedily past paths that diverged at a threshold
// (test_textures' rule); returns how many agree.
size_t aligned_photons(const std::vector<pf_photon>& a, const std::vector<pf_photon>& b, float tol) {
  auto same = [&](const pf_photon& p, const pf_photon& q) {
    for (int c = 0; c < 3; ++c)
      if (std::fabs(p.position[c] - q.position[c]) > tol ||
          std::fabs(p.flux[c] - q.flux[c]) > 1e-3f * std::fabs(p.flux[c]) + 1e-9f)
        return false;
    return p.flags == q.flags && p.mesh == q.mesh;
  };
  size_t matched = 0, i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    if (same(a[i], b[j])) {
      ++matched, ++i, ++j;
      continue;
    }
    bool found = false;
    for (size_t step = 1; step < 32 && !found; ++step)
      for (size_t di = 0; di <= step && !found; ++di)
        if (i + di < a.size() && j + step - di < b.size() && same(a[i + di], b[j + step - di])) {
          i += di;
          j += step - di;
          found = true;
        }
    if (!found) ++i, ++j;
  }
  return matched;
}

}  // namespace

TEST_CASE("OpenCL PBR: visible points, their BSDF table and the direct layer equal the CPU's",
          "[pbr][opencl]") {
  auto dev = test::test_device();
  if (!dev) return;
  const Scene s = pbr_room(48, 36);
  const float tol = 1e-4f * length(s.bounds.extent());
  EyePassOptions eo;
  eo.spp = 2;
  eo.direct = DirectMode::ShadowRays;
  eo.shadow_samples = 3;
  eo.seed = 7;
  // The light samples: the shadow stream (strata), or the pixel's Sobol points (pixel_sampler.h
  // pf_light_draws), in pass 5 so the points are not the sequence's first.
  eo.sampler = GENERATE(PixelSampler::Strata, PixelSampler::Sobol);
  eo.pass = eo.sampler == PixelSampler::Sobol ? 5 : 0;
  INFO("sampler " << pixel_sampler_name(eo.sampler));
  const EyePassResult cpu = trace_hitpoints(s, eo);
  const EyePassResult gpu = trace_hitpoints(s, eo, *dev);
  REQUIRE(cpu.hitpoints.size() == gpu.hitpoints.size());
  REQUIRE(cpu.bsdf.size() == cpu.hitpoints.size());
  REQUIRE(gpu.bsdf.size() == gpu.hitpoints.size());
  size_t same = 0, on[5] = {0, 0, 0, 0, 0}, textured_differ = 0;
  for (size_t i = 0; i < cpu.hitpoints.size(); ++i) {
    const pf_hitpoint &a = cpu.hitpoints[i], &b = gpu.hitpoints[i];
    const pf_pbr_point &pa = cpu.bsdf[i], &pb = gpu.bsdf[i];
    bool ok = a.pixel_x == b.pixel_x && a.pixel_y == b.pixel_y && a.material == b.material &&
              a.mesh == b.mesh && pa.outside == pb.outside;
    for (int c = 0; c < 3; ++c)
      ok = ok && std::fabs(a.position[c] - b.position[c]) <= tol &&
           std::fabs(a.normal[c] - b.normal[c]) <= 1e-4f &&
           std::fabs(a.dir[c] - b.dir[c]) <= 1e-4f && close(a.weight[c], b.weight[c], 1e-5f) &&
           close(pa.params.base_color[c], pb.params.base_color[c], 1e-5f);
    ok = ok && close(pa.params.metallic, pb.params.metallic, 1e-5f) &&
         close(pa.params.roughness, pb.params.roughness, 1e-5f) &&
         pa.params.transmission == pb.params.transmission && pa.params.ior == pb.params.ior;
    same += ok;
    if (a.material >= 0 && a.material < 5) ++on[a.material];
    // The table holds the textured parameters (the box's vary over it).
    if (a.material == kBox && pa.params.roughness != s.materials[kBox].roughness) ++textured_differ;
  }
  INFO("hitpoints " << cpu.hitpoints.size() << ": walls " << on[0] << ", box " << on[kBox]
                    << ", sphere " << on[kSphere] << ", block " << on[kBlock]);
  CHECK(same >= cpu.hitpoints.size() * 999 / 1000);
  CHECK(on[0] > 0);
  CHECK(on[kBox] > 20);
  CHECK(on[kSphere] > 20);
  CHECK(on[kBlock] > 20);
  CHECK(textured_differ > on[kBox] / 2);
  REQUIRE(test::sum_squares(cpu.direct) > 0);
  const double direct_diff = test::relative_rmse(gpu.direct, cpu.direct);
  INFO("direct layer: relative RMS difference " << direct_diff);
  CHECK(direct_diff <= 1e-3);
  double pbr_direct = 0;  // the PBR points' direct light is there (the BSDF, not color/π)
  for (size_t i = 0; i < cpu.hitpoints.size(); ++i)
    if (cpu.hitpoints[i].material == kBlock) {
      const size_t px = size_t(cpu.hitpoints[i].pixel_y) * 48 + size_t(cpu.hitpoints[i].pixel_x);
      pbr_direct += double(gpu.direct[3 * px]);
    }
  CHECK(pbr_direct > 0);

  // A scene without PBR material: no table on either backend.
  const Scene diffuse = test::room_scene(PF_MAT_GLASS, 16, 12);
  CHECK(trace_hitpoints(diffuse, eo, *dev).bsdf.empty());
  CHECK(trace_hitpoints(diffuse, eo).bsdf.empty());
}

TEST_CASE("OpenCL PBR: photons are stored at PBR hits and continue as on the CPU",
          "[pbr][opencl]") {
  auto dev = test::test_device();
  if (!dev) return;
  const Scene s = pbr_room(16, 12);
  const float tol = 1e-4f * length(s.bounds.extent());
  PhotonPassOptions po;
  po.photons = 20000;
  po.seed = 3;
  const PhotonPassResult pc = trace_photons(s, 2, po);
  const PhotonPassResult pg = trace_photons(s, 2, po, *dev);
  size_t on_pbr = 0, after_pbr = 0;
  for (size_t i = 0; i < pc.photons.size(); ++i) {
    const int mesh = pc.photons[i].mesh;
    on_pbr += mesh == kBox || mesh == kSphere || mesh == kBlock;
    // A photon stored right after one on a PBR mesh (the same path: not a direct photon) was
    // carried on by the BSDF.
    if (i > 0 && !(pc.photons[i].flags & PF_PHOTON_DIRECT)) {
      const int prev = pc.photons[i - 1].mesh;
      after_pbr += prev == kBox || prev == kSphere || prev == kBlock;
    }
  }
  const size_t matched = aligned_photons(pc.photons, pg.photons, tol);
  INFO("photons agreeing: " << matched << " of " << pc.photons.size() << " (opencl "
                            << pg.photons.size() << "); on PBR meshes " << on_pbr
                            << ", after a PBR bounce " << after_pbr);
  CHECK(on_pbr > pc.photons.size() / 20);
  CHECK(after_pbr > on_pbr / 10);
  CHECK(matched >= pc.photons.size() * 99 / 100);
  CHECK(std::fabs(double(pg.photons.size()) - double(pc.photons.size())) <=
        0.01 * double(pc.photons.size()));
  // The device-compacted route gives the same photons as the host-concatenated one.
  const DevicePhotons dp = trace_photons_device(s, 2, po, *dev);
  const std::vector<pf_photon> down = download_photons(dp, *dev);
  REQUIRE(down.size() == pg.photons.size());
  CHECK(std::memcmp(down.data(), pg.photons.data(), down.size() * sizeof(pf_photon)) == 0);
}

TEST_CASE("OpenCL PBR: every device gather evaluates the BSDF per photon as the CPU's gather does",
          "[pbr][opencl]") {
  auto dev = test::test_device();
  if (!dev) return;
  const Scene s = pbr_room(32, 24);
  EyePassOptions eo;
  eo.spp = 1;
  EyePassResult eye = trace_hitpoints(s, eo);  // the CPU's, as input to both backends
  const HitpointSet h0 = make_hitpoint_set(std::move(eye), DirectMode::Photons, s.scene_id);
  PhotonPassOptions po;
  po.photons = 30000;
  const PhotonPassResult ph = trace_photons(s, 0, po);
  PpmOptions ref_opt;
  HitpointSet ref = h0;
  ppm_pass(s, ref, ph.photons, ph.emitted, ref_opt);  // the CPU
  size_t pbr_gathered = 0, glass_gathered = 0;
  for (size_t i = 0; i < ref.hitpoints.size(); ++i) {
    const pf_hitpoint& hp = ref.hitpoints[i];
    if (hp.n_photons > 0 && s.materials[size_t(hp.material)].type == PF_MAT_PBR) ++pbr_gathered;
    if (hp.n_photons > 0 && hp.material == kSphere) ++glass_gathered;
  }
  INFO("PBR hitpoints that gathered: " << pbr_gathered << " (glass " << glass_gathered << ")");
  REQUIRE(pbr_gathered > 50);
  REQUIRE(glass_gathered > 10);
  for (GatherMethod m :
       {GatherMethod::Naive, GatherMethod::LocalMemory, GatherMethod::PhotonSort,
        GatherMethod::HitpointSort, GatherMethod::HitpointSortLocal, GatherMethod::ManualDistance,
        GatherMethod::KmeansClusters, GatherMethod::GridKmeans, GatherMethod::GridGridClusters,
        GatherMethod::HashGrid}) {
    PpmOptions opt;
    opt.method = m;
    HitpointSet h = h0;
    ppm_pass(s, h, ph.photons, ph.emitted, opt, *dev);
    REQUIRE(h.hitpoints.size() == ref.hitpoints.size());
    size_t count_differ = 0;
    double worst = 0;
    for (size_t i = 0; i < h.hitpoints.size(); ++i) {
      const pf_hitpoint &a = ref.hitpoints[i], &b = h.hitpoints[i];
      count_differ += a.n_photons != b.n_photons;
      worst = std::max(worst, std::fabs(double(a.radius) - b.radius) / a.radius);
      for (int c = 0; c < 3; ++c)
        worst = std::max(worst, std::fabs(double(a.flux[c]) - b.flux[c]) /
                                    (std::fabs(double(a.flux[c])) + 1e-30));
    }
    INFO(gather_method_name(m) << ": " << count_differ << " hitpoints with another N, largest "
                               << "relative difference of R or τ " << worst);
    CHECK(count_differ == 0);
    CHECK(worst <= 1e-5);
  }
  // PBR hitpoints without their BSDF entries are refused before any kernel runs.
  HitpointSet bare = h0;
  bare.bsdf.clear();
  PpmOptions hash;
  hash.method = GatherMethod::HashGrid;
  CHECK_THROWS_AS(ppm_pass(s, bare, ph.photons, ph.emitted, hash, *dev), InputError);
  CHECK(bare.passes == 0);
}

TEST_CASE("OpenCL PBR: the render driver's SPPM, PPPM and PPM device routes give the CPU's images",
          "[pbr][opencl][sppm]") {
  // SPPM: DevicePpmState::sppm_pass (the pass's PBR sites by pixel); PPPM: pppm_gather_device;
  // PPM: the resident hashed-grid state (its sites in cell order, the PBR table permuted with
  // them) and the copying route of another method (grid-kmeans).
  auto dev = test::test_device();
  if (!dev) return;
  const Scene s = pbr_room(40, 30);
  test::check_device_route(s, Estimator::Sppm, GatherMethod::HashGrid, 4, 6000, *dev);
  test::check_device_route(s, Estimator::Pppm, GatherMethod::HashGrid, 4, 6000, *dev);
  test::check_device_route(s, Estimator::Ppm, GatherMethod::HashGrid, 4, 6000, *dev);
  test::check_device_route(s, Estimator::Ppm, GatherMethod::GridKmeans, 4, 6000, *dev);
  // Eye paths that share the glass sphere's and the metal block's light with their continuation
  // (eye_pass.h GlossyMerge::Mis) on both backends.
  test::check_device_route(s, Estimator::Sppm, GatherMethod::HashGrid, 4, 6000, *dev,
                           GlossyMerge::Mis);
  test::check_device_route(s, Estimator::Pppm, GatherMethod::HashGrid, 4, 6000, *dev,
                           GlossyMerge::Mis);
}

TEST_CASE("OpenCL PBR: eye paths share glossy vertices' light with their continuation as on the "
          "CPU",
          "[pbr][opencl][glossy-merge]") {
  // GlossyMerge::Mis: at the rough glass sphere (0.3, transmission 1) and the metal block (0.35,
  // metallic 1) an eye path makes its visible point with the merge probability (marked
  // merge-weighted) or goes on by the BSDF's sample to the walls and the box. The device's
  // hitpoints, their BSDF records with the marks, and the direct layer (next-event estimation
  // and BSDF samples under MIS) equal the CPU's one for one (the same draws from the eye stream).
  auto dev = test::test_device();
  if (!dev) return;
  const bool spot = GENERATE(false, true);  // with a spot: the local light choice
  INFO((spot ? "lamp and spot" : "lamp"));
  const Scene s = pbr_room(48, 36, spot);
  REQUIRE(s.light_choice.empty() == !spot);
  EyePassOptions eo;
  eo.direct = DirectMode::ShadowRays;
  eo.seed = 3;
  eo.pass = 2;
  eo.sampler = PixelSampler::Sobol;
  const EyePassResult stop = trace_hitpoints(s, eo);
  eo.glossy = GlossyMerge::Mis;
  eo.glossy_spp = GENERATE(0, 3);  // glossy samples: more slots in the marked pixels
  INFO("glossy samples " << eo.glossy_spp);
  const EyePassResult cpu = trace_hitpoints(s, eo);
  const EyePassResult gpu = trace_hitpoints(s, eo, *dev);
  REQUIRE(cpu.hitpoints.size() == gpu.hitpoints.size());
  REQUIRE(gpu.bsdf.size() == gpu.hitpoints.size());
  const float tol = 1e-4f * length(s.bounds.extent());
  size_t same = 0, on_glossy = 0, stopped_glossy = 0, weighted = 0;
  for (const pf_hitpoint& h : stop.hitpoints)
    stopped_glossy += h.material == kSphere || h.material == kBlock;
  for (size_t i = 0; i < cpu.hitpoints.size(); ++i) {
    const pf_hitpoint &a = cpu.hitpoints[i], &b = gpu.hitpoints[i];
    on_glossy += a.material == kSphere || a.material == kBlock || b.material == kSphere ||
                 b.material == kBlock;
    bool ok = a.pixel_x == b.pixel_x && a.pixel_y == b.pixel_y && a.material == b.material &&
              cpu.bsdf[i].outside == gpu.bsdf[i].outside;
    weighted += (cpu.bsdf[i].outside & PF_PBR_POINT_MERGE_WEIGHTED) != 0;
    for (int c = 0; c < 3; ++c)
      ok = ok && std::fabs(a.position[c] - b.position[c]) <= tol &&
           close(a.weight[c], b.weight[c], 1e-4f);
    same += ok;
  }
  INFO("hitpoints " << cpu.hitpoints.size() << ", of which the same on the device " << same
                    << "; with the first rule " << stopped_glossy << " on the sphere and block, "
                    << "with mis " << on_glossy << " (" << weighted << " merge-weighted)");
  CHECK(stopped_glossy > 40);
  if (eo.glossy_spp == 0)
    CHECK(on_glossy < stopped_glossy);  // many paths go on from the narrow lobes
  else
    CHECK(cpu.hitpoints.size() > stop.hitpoints.size());  // the marked pixels' extra samples
  CHECK(weighted > 0);
  CHECK(same >= cpu.hitpoints.size() * 995 / 1000);
  REQUIRE(test::sum_squares(cpu.direct) > 0);
  CHECK(test::relative_rmse(gpu.direct, cpu.direct) <= 1e-3);
  // Light seen through the glass and in the metal, if any (the light is not in view here: then
  // both layers must be black alike).
  CHECK(test::relative_rmse(gpu.emitted, cpu.emitted) <=
        (test::sum_squares(cpu.emitted) > 0 ? 1e-3 : 0.0));
}

TEST_CASE("OpenCL: a scene's kernel variant compiles away what the scene lacks and renders the "
          "same image bit for bit",
          "[opencl][variants]") {
  // Issue 32 item 9: the tracing and gather kernels are built per scene with its features as
  // constants (kernels/scene_features.h). A diffuse room drops PBR, textures and alpha; the PBR
  // room (textured, no masks) drops alpha only. Each renders, on the same device, exactly what
  // the kernels with every feature compiled in render (a second context, variants off).
  auto dev = test::test_device();
  if (!dev) return;
  ClContext all(dev->info(), 0);
  all.set_scene_variants(false);
  const Scene diffuse = test::room_scene(PF_MAT_GLASS, 40, 30);
  const Scene pbr = pbr_room(40, 30);
  CHECK(scene_kernel_variant(diffuse, *dev) ==
        " -DPF_SCENE_PBR=0 -DPF_SCENE_TEXTURES=0 -DPF_SCENE_ALPHA=0");
  CHECK(scene_kernel_variant(pbr, *dev) == " -DPF_SCENE_ALPHA=0");
  CHECK(scene_kernel_variant(pbr, all).empty());
  for (const Scene* s : {&diffuse, &pbr})
    for (Estimator e : {Estimator::Sppm, Estimator::Pppm, Estimator::Ppm}) {
      RenderOptions opt;
      opt.estimator = e;
      opt.passes = 3;
      opt.photons.photons = 6000;
      opt.eye.direct = DirectMode::ShadowRays;
      opt.ppm.method = GatherMethod::HashGrid;
      const Provenance prov;
      auto image = [&](ClContext& d) {
        opt.device = &d;
        return e == Estimator::Pppm ? synthesize(render_pppm(*s, opt, false, prov))
                                    : synthesize(render_progressive(*s, opt, false, prov));
      };
      const Image variant = image(*dev), every = image(all);
      INFO(estimator_name(e) << (s == &pbr ? " on the PBR room" : " on the diffuse room"));
      double sum = 0;
      for (float v : every.rgb) sum += double(v);
      CHECK(sum > 0);
      CHECK(variant.rgb == every.rgb);
    }
}
