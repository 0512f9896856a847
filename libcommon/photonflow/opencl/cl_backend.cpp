// OpenCL backend of the render stages: see cl_backend.h.
#include "photonflow/opencl/cl_backend.h"

#include <algorithm>
#include <stdexcept>
#include <cmath>
#include <cstring>
#include <limits>

#include "photonflow/geometry/camera.h"
#include "photonflow/foundations/error.h"
#include "photonflow/geometry/surface.h"

namespace pf {

// The baked scene on the device, uploaded once per context (and again when the scene changes).
struct ClSceneBuffers {
  ClBuffer tris, hh, nodes, leaf_tris, group_of_first, leaf_groups, mats, lights, light_cdf;
  ClBuffer env;  // the environment's packed buffer (environment_shared.h), the header alone without
  ClBuffer textures, texels, mat_tex, uvs, mr_tex;  // textures (PF_TEXTURE_PARAMS)
  bool has_pbr = false;  // a PF_MAT_PBR material: the eye pass writes a pf_pbr_point table
  ClBuffer alpha_mats;   // alpha cut-outs (PF_ALPHA_PARAMS)
  cl_int alpha_on = 0;
  ClBuffer light_choice;  // NEE's light choice (Scene::light_choice), or a one-entry stand-in
  cl_int light_choice_on = 0;
  cl_int node_count = 0, light_count = 0;
  std::string scene_id;
  size_t triangle_count = 0;
};

namespace {

template <class T>
ClBuffer upload_array(ClContext& dev, const std::vector<T>& v, const char* what) {
  const size_t bytes = v.size() * sizeof(T);
  if (bytes > dev.max_alloc())
    throw input_error("", std::string("the scene's ") + what + " (" + std::to_string(bytes) +
                              " bytes) exceed the device's largest allocation (" +
                              std::to_string(dev.max_alloc()) + " bytes)",
                      "use --device cpu");
  return dev.buffer(bytes, v.empty() ? nullptr : v.data(), CL_MEM_READ_ONLY);
}

ClSceneBuffers& scene_buffers(const Scene& scene, ClContext& dev) {
  ClSceneBuffers* c = dev.scene_cache.get();
  if (c && dev.scene_cache_key == &scene && c->scene_id == scene.scene_id &&
      c->triangle_count == scene.triangles.size())
    return *c;
  auto s = std::make_shared<ClSceneBuffers>();
  s->tris = upload_array(dev, scene.triangles, "triangles");
  s->hh = upload_array(dev, scene.hh, "Havel-Herout planes");
  s->nodes = upload_array(dev, scene.kd.nodes, "kd-tree nodes");
  s->leaf_tris = upload_array(dev, scene.kd.leaf_tris, "kd-tree leaf lists");
  {  // Leaf-ordered planes in groups of four for the kernels' vector leaf test (trace_common.h):
     // per group 12 float4 (n, n1, n2 transposed: x of 4 triangles, y, z, w) + 4 triangle ids.
    std::vector<int32_t> group_of_first(scene.kd.leaf_tris.size() + 1, 0);
    std::vector<int32_t> longest(scene.kd.leaf_tris.size() + 1, 0);
    for (const pf_kd_node& n : scene.kd.nodes)  // leaves starting at one index share its groups
      if (n.axis == PF_KD_LEAF && n.count > 0)
        longest[size_t(n.first)] = std::max(longest[size_t(n.first)], n.count);
    std::vector<float> groups;
    int32_t next = 0;
    for (size_t f = 0; f < longest.size(); ++f) {
      if (longest[f] <= 0) continue;
      group_of_first[f] = next;
      for (int32_t b = 0; b < longest[f]; b += 4, ++next) {
        float g[52] = {};
        int32_t ids[4] = {-1, -1, -1, -1};
        for (int k = 0; k < 4 && b + k < longest[f]; ++k) {
          const int32_t tri = scene.kd.leaf_tris[f + size_t(b + k)];
          const pf_hh_triangle& h = scene.hh[size_t(tri)];
          ids[k] = tri;
          for (int c = 0; c < 4; ++c) {
            g[c * 4 + k] = h.n[c];
            g[16 + c * 4 + k] = h.n1[c];
            g[32 + c * 4 + k] = h.n2[c];
          }
        }
        std::memcpy(&g[48], ids, sizeof ids);
        groups.insert(groups.end(), g, g + 52);
      }
    }
    s->group_of_first = upload_array(dev, group_of_first, "kd-tree leaf groups");
    s->leaf_groups = upload_array(dev, groups, "leaf-ordered triangle planes");
  }
  s->mats = upload_array(dev, scene.materials, "materials");
  s->lights = upload_array(dev, scene.lights, "lights");
  s->light_cdf = upload_array(dev, scene.light_cdf, "light CDF");
  {
    std::vector<pf_light_choice> choice = scene.light_choice;
    s->light_choice_on = choice.empty() ? 0 : 1;
    if (choice.empty()) choice.resize(1);  // never read (light_choice_on 0)
    s->light_choice = upload_array(dev, choice, "light choice");
  }
  {
    std::vector<float> env = scene.env_packed;
    if (env.empty()) env.assign(Scene::kNoEnvironment, Scene::kNoEnvironment + 16);
    s->env = upload_array(dev, env, "environment map");
  }
  {  // Textures: every material's entry (−1 without), and one-element stand-ins where the scene
     // has no textures or UVs (a buffer is never empty; the kernels read them only through a
     // material whose entry is ≥ 0, and load_scene guarantees the UVs then).
    std::vector<int32_t> mat_tex(scene.materials.size(), -1), mr_tex(scene.materials.size(), -1);
    for (size_t m = 0; m < mat_tex.size(); ++m) {
      mat_tex[m] = scene.texture_of(int(m));
      mr_tex[m] = scene.mr_texture_of(int(m));
    }
    s->has_pbr = scene.has_pbr();
    if (mat_tex.empty()) mat_tex.push_back(-1);
    if (mr_tex.empty()) mr_tex.push_back(-1);
    std::vector<pf_texture> textures = scene.textures;
    if (textures.empty()) textures.push_back(pf_texture{1, 1, 0, 0, 0, 0});
    std::vector<float> texels = scene.texels;
    if (texels.empty()) texels.assign(4, 0.f);
    std::vector<float> uvs(std::max<size_t>(1, scene.uvs.size()) * 6, 0.f);
    if (!scene.uvs.empty()) std::memcpy(uvs.data(), scene.uvs.data(), uvs.size() * sizeof(float));
    s->textures = upload_array(dev, textures, "texture headers");
    s->texels = upload_array(dev, texels, "texels");
    s->mat_tex = upload_array(dev, mat_tex, "materials' textures");
    s->uvs = upload_array(dev, uvs, "texture coordinates");
    s->mr_tex = upload_array(dev, mr_tex, "materials' metallic-roughness textures");
    // Alpha cut-outs: the per-material table where some material is masked, else one opaque
    // stand-in with alpha_on = 0 (the kernels' leaf test then never reads it).
    std::vector<pf_alpha_material> alpha = scene.material_alpha;
    s->alpha_on = alpha.empty() ? 0 : 1;
    if (alpha.empty()) alpha.push_back(pf_alpha_material{PF_ALPHA_OPAQUE, 1.f, -1, 0});
    s->alpha_mats = upload_array(dev, alpha, "materials' alpha cut-outs");
  }
  s->node_count = cl_int(scene.kd.nodes.size());
  s->light_count = cl_int(scene.lights.size());
  s->scene_id = scene.scene_id;
  s->triangle_count = scene.triangles.size();
  dev.scene_cache = s;
  dev.scene_cache_key = &scene;
  return *s;
}

// The camera basis the eye-pass kernel reads (16 floats): eye, forward, right, up, tan_half_x,
// tan_half_y, aperture, focus_distance — taken from camera.h's CameraFrame, so both backends use
// one frame.
std::vector<float> camera_frame(const pf_camera& c) {
  CameraFrame f(c);
  const Vec3 &e = f.eye(), &fw = f.forward(), &r = f.right(), &u = f.up();
  return {e.x, e.y, e.z, fw.x, fw.y, fw.z, r.x, r.y, r.z, u.x, u.y, u.z,
          f.tan_half_x(), f.tan_half_y(), f.aperture(), f.focus_distance()};
}

}  // namespace

std::string scene_kernel_variant(const Scene& scene, const ClContext& dev) {
  std::string v;
  if (!dev.scene_variants()) return v;
  if (!scene.has_pbr()) v += " -DPF_SCENE_PBR=0";
  if (scene.textures.empty()) v += " -DPF_SCENE_TEXTURES=0";
  if (!scene.has_alpha_masks()) v += " -DPF_SCENE_ALPHA=0";
  return v;
}

// ---- eye pass ----------------------------------------------------------------------------------

EyePassResult trace_hitpoints(const Scene& scene, const EyePassOptions& opt, ClContext& dev) {
  check_eye_samples(scene, opt);
  const int W = scene.camera.width, H = scene.camera.height, spp = std::max(1, opt.spp);
  const int columns = eye_strata_columns(spp);  // the CPU eye pass's grid
  EyePassResult res;
  res.width = W;
  res.height = H;
  res.radius = opt.radius > 0.f ? opt.radius : default_radius(scene);
  const size_t npix = size_t(W) * size_t(H);
  res.emitted.assign(npix * 3, 0.f);
  res.direct.assign(npix * 3, 0.f);
  if (npix == 0) return res;
  const float eps = ray_epsilon(scene);
  ClSceneBuffers& sb = scene_buffers(scene, dev);
  // Glossy samples (eye_pass.h EyePassOptions::glossy_spp): the marked pixels (computed on the
  // host, as EyeTracer does), or a one-byte stand-in; every pixel gets spp + G slots.
  const bool glossy_on = opt.glossy_spp > 0 && opt.glossy == GlossyMerge::Mis && sb.has_pbr;
  std::vector<uint8_t> own_glossy;
  const std::vector<uint8_t>* gmarks = opt.glossy_pixels;
  if (glossy_on && !gmarks) gmarks = &(own_glossy = glossy_pixels(scene));
  if (glossy_on && gmarks->size() != npix)
    throw std::invalid_argument("trace_hitpoints: glossy_pixels is not the image's size");
  const uint8_t gnone = 0;
  ClBuffer glossy_marks = dev.buffer(glossy_on ? npix : 1, glossy_on ? gmarks->data() : &gnone,
                                     CL_MEM_READ_ONLY);
  const int G = glossy_on ? opt.glossy_spp : 0;
  const int per_pixel = spp + G;  // slots per pixel
  if (npix * size_t(per_pixel) > size_t(INT32_MAX))
    throw input_error("", "too many pixel samples for the OpenCL backend", "use --device cpu");
  std::vector<float> frame = camera_frame(scene.camera);
  ClBuffer cam = dev.buffer(frame.size() * sizeof(float), frame.data(), CL_MEM_READ_ONLY);
  cl_kernel k = dev.kernel("trace_hitpoints", "trace_hitpoints",
                           scene_kernel_variant(scene, dev));

  // Batches of pixels: the slot array (spp + G hitpoints per pixel) is the largest buffer.
  const size_t batch = dev.batch_items(size_t(per_pixel) * sizeof(pf_hitpoint), npix);
  const ClBuffer& slots = dev.scratch("eye.slots", batch * size_t(per_pixel) * sizeof(pf_hitpoint));
  const ClBuffer& used = dev.scratch("eye.used", batch * size_t(per_pixel) * sizeof(cl_int));
  const ClBuffer& emitted = dev.scratch("eye.emitted", batch * 3 * sizeof(float));
  const ClBuffer& direct = dev.scratch("eye.direct", batch * 3 * sizeof(float));
  // The PBR table (parallel to the hitpoints) only for a scene with a PF_MAT_PBR material; else a
  // one-element stand-in the kernel never writes.
  const ClBuffer& pbr =
      dev.scratch("eye.pbr", (sb.has_pbr ? batch * size_t(per_pixel) : 1) * sizeof(pf_pbr_point));
  // The pixels with emission samples (eye_pass.h emission_pixels; computed on the host), or a
  // one-byte stand-in the kernel never reads.
  std::vector<uint8_t> own_marks;
  const std::vector<uint8_t>* marks = opt.emission_pixels;
  if (opt.emission_spp > 0 && !marks) marks = &(own_marks = emission_pixels(scene));
  if (opt.emission_spp > 0 && marks->size() != npix)
    throw std::invalid_argument("trace_hitpoints: emission_pixels is not the image's size");
  const uint8_t none = 0;
  ClBuffer emit_pixels = dev.buffer(opt.emission_spp > 0 ? npix : 1,
                                    opt.emission_spp > 0 ? marks->data() : &none,
                                    CL_MEM_READ_ONLY);
  // The area light of each emissive triangle (EyeTracer's tri_light_) for the MIS weight of an
  // emitter that a glossy vertex's BSDF sample hits; a one-element stand-in otherwise.
  const cl_int glossy_mis = opt.glossy == GlossyMerge::Mis && sb.has_pbr ? 1 : 0;
  std::vector<cl_int> tri_light_host(glossy_mis ? scene.triangles.size() : 1, -1);
  if (glossy_mis)
    for (size_t li = 0; li < scene.lights.size(); ++li)
      if (scene.lights[li].type == PF_LIGHT_AREA)
        tri_light_host[size_t(scene.lights[li].triangle)] = cl_int(li);
  ClBuffer tri_light = dev.buffer(tri_light_host.size() * sizeof(cl_int), tri_light_host.data(),
                                  CL_MEM_READ_ONLY);
  std::vector<cl_int> flags;
  res.hitpoints.reserve(npix * size_t(spp));
  if (sb.has_pbr) res.bsdf.reserve(npix * size_t(spp));
  const cl_int shadow = opt.direct == DirectMode::ShadowRays ? 1 : 0;
  for (size_t off = 0; off < npix; off += batch) {
    const cl_int count = cl_int(std::min(batch, npix - off));
    dev.args(k, sb.tris, sb.hh, sb.nodes, sb.node_count, sb.leaf_tris, sb.group_of_first,
             sb.leaf_groups, sb.mats, sb.lights,
             sb.light_cdf, sb.light_count, sb.env, sb.textures, sb.texels, sb.mat_tex, sb.uvs, sb.mr_tex,
             sb.alpha_mats, sb.alpha_on, cam, cl_int(W), cl_int(H), cl_int(spp), cl_int(columns),
             cl_int(opt.max_depth), shadow, cl_int(opt.shadow_samples), res.radius,
             glossy_mis, cl_uint(opt.seed), cl_uint(opt.pass), cl_int(int(opt.sampler)), eps,
             cl_int(off), count, slots, used, emitted, direct, cl_int(sb.has_pbr ? 1 : 0), pbr,
             emit_pixels, cl_int(opt.emission_spp), tri_light, glossy_marks, cl_int(G),
             sb.light_choice, sb.light_choice_on);
    dev.run(k, size_t(count));
    const size_t nslots = size_t(count) * size_t(per_pixel);
    flags.resize(nslots);
    dev.read(used, nslots * sizeof(cl_int), flags.data());
    ClMapping map(dev, slots, nslots * sizeof(pf_hitpoint), ClMapping::Mode::Read);
    const auto* hp = map.as<const pf_hitpoint>();
    for (size_t i = 0; i < nslots; ++i)
      if (flags[i]) res.hitpoints.push_back(hp[i]);
    map.unmap();
    if (sb.has_pbr) {
      ClMapping pmap(dev, pbr, nslots * sizeof(pf_pbr_point), ClMapping::Mode::Read);
      const auto* pp = pmap.as<const pf_pbr_point>();
      for (size_t i = 0; i < nslots; ++i)
        if (flags[i]) res.bsdf.push_back(pp[i]);
      pmap.unmap();
    }
    dev.read(emitted, size_t(count) * 3 * sizeof(float), &res.emitted[off * 3]);
    dev.read(direct, size_t(count) * 3 * sizeof(float), &res.direct[off * 3]);
  }
  return res;
}

// ---- photon pass -------------------------------------------------------------------------------

namespace {

// Checks a photon pass for the device (InputError); false when there is nothing to trace.
bool photon_pass_work(const Scene& scene, uint32_t pass, const PhotonPassOptions& opt) {
  check_pass_range(pass, 1);  // the photons' int32 `pass`, as on the CPU
  if (scene.lights.empty() || opt.photons == 0) return false;
  if (opt.photons > uint32_t(INT32_MAX))
    throw input_error("", "--photons must be below 2^31 per pass with --device opencl");
  return true;
}

// Slots per emitted photon: one stored photon per bounce at most.
size_t photon_slots(const PhotonPassOptions& opt) { return size_t(std::max(0, opt.max_bounces)) + 1; }

// Traces photons first .. first + count − 1 of the pass into `slots` (slot-major) and their
// stored counts into stored[0 .. count).
void trace_photon_batch(const Scene& scene, uint32_t pass, const PhotonPassOptions& opt,
                        size_t first, size_t count, const ClBuffer& slots, const ClBuffer& stored,
                        ClContext& dev) {
  ClSceneBuffers& sb = scene_buffers(scene, dev);
  cl_kernel k = dev.kernel("trace_photons", "trace_photons",
                           scene_kernel_variant(scene, dev));
  dev.args(k, sb.tris, sb.hh, sb.nodes, sb.node_count, sb.leaf_tris, sb.group_of_first,
           sb.leaf_groups, sb.mats, sb.lights, sb.light_cdf, sb.light_count, sb.env, sb.textures,
           sb.texels, sb.mat_tex, sb.uvs, sb.mr_tex, sb.alpha_mats, sb.alpha_on, cl_uint(opt.seed),
           cl_uint(pass), cl_int(opt.max_bounces), ray_epsilon(scene), cl_uint(first),
           cl_int(count), slots, stored);
  dev.run(k, count);
}

}  // namespace

PhotonPassResult trace_photons(const Scene& scene, uint32_t pass, const PhotonPassOptions& opt,
                               ClContext& dev) {
  PhotonPassResult res;
  res.emitted = opt.photons;
  if (!photon_pass_work(scene, pass, opt)) return res;
  const size_t per = photon_slots(opt);
  const size_t batch = dev.batch_items(per * sizeof(pf_photon), opt.photons);
  const ClBuffer& slots = dev.scratch("photon.slots", batch * per * sizeof(pf_photon));
  const ClBuffer& stored = dev.scratch("photon.stored", batch * sizeof(cl_int));
  std::vector<cl_int> counts;
  for (size_t first = 0; first < opt.photons; first += batch) {
    const size_t count = std::min(batch, size_t(opt.photons) - first);
    trace_photon_batch(scene, pass, opt, first, count, slots, stored, dev);
    counts.resize(count);
    dev.read(stored, count * sizeof(cl_int), counts.data());
    size_t total = 0;
    for (cl_int c : counts) total += size_t(c);
    res.photons.reserve(res.photons.size() + total);
    ClMapping map(dev, slots, count * per * sizeof(pf_photon), ClMapping::Mode::Read);
    const auto* ph = map.as<const pf_photon>();
    for (size_t i = 0; i < count; ++i)  // slot-major: slot k of photon i at k·count + i
      for (size_t k = 0; k < size_t(counts[i]); ++k) res.photons.push_back(ph[k * count + i]);
    map.unmap();
  }
  return res;
}

DevicePhotons trace_photons_device(const Scene& scene, uint32_t pass, const PhotonPassOptions& opt,
                                   ClContext& dev) {
  DevicePhotons out;
  out.emitted = opt.photons;
  out.photons = &dev.scratch("photon.compact", sizeof(pf_photon));
  if (!photon_pass_work(scene, pass, opt)) return out;
  const size_t per = photon_slots(opt), n = opt.photons;
  // (One batch of slots fits, so do the n + 1 counts and the compacted photons: both are smaller.)
  if (dev.batch_items(per * sizeof(pf_photon), n) < n) {  // more than one batch: the host concatenates
    const PhotonPassResult r = trace_photons(scene, pass, opt, dev);
    out.photons = &dev.scratch("photon.compact", std::max<size_t>(r.photons.size(), 1) * sizeof(pf_photon));
    dev.write(*out.photons, r.photons.size() * sizeof(pf_photon), r.photons.data());
    out.count = r.photons.size();
    return out;
  }
  const ClBuffer& slots = dev.scratch("photon.slots", n * per * sizeof(pf_photon));
  const ClBuffer& start = dev.scratch("photon.start", (n + 1) * sizeof(cl_int));
  trace_photon_batch(scene, pass, opt, 0, n, slots, start, dev);
  dev.fill_zero(start, sizeof(cl_int), n * sizeof(cl_int));  // start[n]: the total after the scan
  device_exclusive_scan(dev, start, n + 1);
  cl_int total = 0;
  dev.read(start, sizeof total, &total, n * sizeof(cl_int));
  out.count = size_t(total);
  out.photons = &dev.scratch("photon.compact", std::max<size_t>(out.count, 1) * sizeof(pf_photon));
  cl_kernel k = dev.kernel("trace_photons", "compact_photons",
                           scene_kernel_variant(scene, dev));
  dev.args(k, slots, start, cl_int(n), *out.photons);
  dev.run(k, n);
  return out;
}

std::vector<pf_photon> download_photons(const DevicePhotons& p, ClContext& dev) {
  std::vector<pf_photon> v(p.count);
  if (p.count > 0) dev.read(*p.photons, p.count * sizeof(pf_photon), v.data());
  return v;
}

// ---- synthesis ---------------------------------------------------------------------------------

Image synthesize(const HitpointSet& h, ClContext& dev) {
  Image img(h.width, h.height);
  std::vector<float>& radius = img.layer("radius");
  std::vector<float>& photons = img.layer("photons");
  std::vector<float>& count = img.layer("hitpoints");
  const size_t npix = img.pixel_count();
  if (npix == 0) return img;
  if (npix * 3 * sizeof(float) > dev.max_alloc())
    throw input_error("", "the image (" + std::to_string(npix) + " pixels) exceeds the device's "
                          "largest allocation", "use --device cpu");
  if (h.emitted.size() < npix * 3 || h.direct.size() < npix * 3)
    throw input_error("", "hitpoint state without emitted/direct layers of the image size");
  const size_t nh = h.hitpoints.size();
  if (nh > size_t(std::numeric_limits<cl_int>::max()))
    throw input_error("", "more than 2^31 hitpoints", "use --device cpu");

  // Stable counting sort by pixel (synthesize.cl): start[o] is the first of pixel o's hitpoints in
  // `order`, which keeps the array order within a pixel. Hitpoints the eye pass wrote are already
  // in pixel order; then `order` is the identity and is not built.
  std::vector<cl_int> start(npix + 1, 0);
  bool sorted = true;
  size_t prev = 0;
  for (const pf_hitpoint& hp : h.hitpoints) {
    if (hp.pixel_x < 0 || hp.pixel_x >= h.width || hp.pixel_y < 0 || hp.pixel_y >= h.height)
      throw input_error("", "a hitpoint's pixel lies outside the " + std::to_string(h.width) +
                                "x" + std::to_string(h.height) + " image");
    const size_t o = img.offset(hp.pixel_x, hp.pixel_y);
    sorted = sorted && o >= prev;
    prev = o;
    ++start[o + 1];
  }
  for (size_t o = 0; o < npix; ++o) start[o + 1] += start[o];
  std::vector<size_t> order;
  if (!sorted) {
    order.resize(nh);
    std::vector<cl_int> next(start.begin(), start.end() - 1);
    for (size_t i = 0; i < nh; ++i) {
      const pf_hitpoint& hp = h.hitpoints[i];
      order[size_t(next[img.offset(hp.pixel_x, hp.pixel_y)]++)] = i;
    }
  }

  const ClBuffer& em = dev.scratch("synth.emitted", npix * 3 * sizeof(float));
  const ClBuffer& di = dev.scratch("synth.direct", npix * 3 * sizeof(float));
  const ClBuffer& rgb = dev.scratch("synth.rgb", npix * 3 * sizeof(float));
  const ClBuffer& rad = dev.scratch("synth.radius", npix * sizeof(float));
  const ClBuffer& pho = dev.scratch("synth.photons", npix * sizeof(float));
  const ClBuffer& cnt = dev.scratch("synth.count", npix * sizeof(float));
  dev.write(em, npix * 3 * sizeof(float), h.emitted.data());
  dev.write(di, npix * 3 * sizeof(float), h.direct.data());
  cl_kernel k = dev.kernel("synthesize", "synth_pixels");

  // Batches of whole pixels whose hitpoints fit one allocation (every pixel's hitpoints in one).
  const size_t hb = dev.batch_items(sizeof(pf_hitpoint), std::max<size_t>(nh, 1));
  const size_t pb = dev.batch_items(sizeof(cl_int), npix + 1) - 1;
  size_t max_pixel = 0;
  for (size_t o = 0; o < npix; ++o)
    max_pixel = std::max(max_pixel, size_t(start[o + 1] - start[o]));
  if (max_pixel > hb)
    throw input_error("", "one pixel's hitpoints exceed the device's largest allocation",
                      "use --device cpu");
  const ClBuffer& hps = dev.scratch("synth.hitpoints",
                                    std::max<size_t>(1, std::min(hb, nh)) * sizeof(pf_hitpoint));
  const ClBuffer& sb = dev.scratch("synth.start", (std::min(pb, npix) + 1) * sizeof(cl_int));
  const float n_emitted = float(h.photons_emitted);
  const cl_int has = h.photons_emitted > 0 ? 1 : 0;
  std::vector<pf_hitpoint> staged;
  std::vector<cl_int> local_start;
  for (size_t p0 = 0; p0 < npix;) {
    size_t p1 = p0 + 1;
    while (p1 < npix && p1 - p0 < pb && size_t(start[p1 + 1] - start[p0]) <= hb) ++p1;
    const size_t h0 = size_t(start[p0]), hn = size_t(start[p1]) - h0;
    local_start.assign(start.begin() + long(p0), start.begin() + long(p1) + 1);
    for (cl_int& v : local_start) v -= cl_int(h0);
    if (hn > 0) {
      const pf_hitpoint* src = &h.hitpoints[h0];
      if (!sorted) {
        staged.resize(hn);
        for (size_t j = 0; j < hn; ++j) staged[j] = h.hitpoints[order[h0 + j]];
        src = staged.data();
      }
      dev.write(hps, hn * sizeof(pf_hitpoint), src);
    }
    dev.write(sb, local_start.size() * sizeof(cl_int), local_start.data());
    dev.args(k, hps, sb, cl_int(p0), cl_int(p1 - p0), n_emitted, has, em, di, rgb, rad, pho, cnt);
    dev.run(k, p1 - p0);
    p0 = p1;
  }
  dev.read(rgb, npix * 3 * sizeof(float), img.rgb.data());
  dev.read(rad, npix * sizeof(float), radius.data());
  dev.read(pho, npix * sizeof(float), photons.data());
  dev.read(cnt, npix * sizeof(float), count.data());
  return img;
}

// ---- ray casting (tests) -------------------------------------------------------------------------

std::vector<ClRayHit> cast_rays(const Scene& scene, const std::vector<float>& rays, bool any_hit,
                                ClContext& dev) {
  static_assert(sizeof(ClRayHit) == 16, "ClRayHit mirrors pf_ray_hit");
  const size_t n = rays.size() / 8;
  std::vector<ClRayHit> hits(n);
  if (n == 0) return hits;
  ClSceneBuffers& sb = scene_buffers(scene, dev);
  cl_kernel k = dev.kernel("raycast", "cast_rays", scene_kernel_variant(scene, dev));
  const size_t batch = dev.batch_items(8 * sizeof(float), n);
  const ClBuffer& rb = dev.scratch("cast.rays", batch * 8 * sizeof(float));
  const ClBuffer& hb = dev.scratch("cast.hits", batch * sizeof(ClRayHit));
  for (size_t off = 0; off < n; off += batch) {
    const cl_int count = cl_int(std::min(batch, n - off));
    dev.write(rb, size_t(count) * 8 * sizeof(float), &rays[off * 8]);
    dev.args(k, sb.tris, sb.hh, sb.nodes, sb.node_count, sb.leaf_tris, sb.group_of_first,
             sb.leaf_groups, sb.mats, sb.lights, sb.light_cdf, sb.light_count, sb.env, sb.textures,
             sb.texels, sb.mat_tex, sb.uvs, sb.mr_tex, sb.alpha_mats, sb.alpha_on, rb, count,
             cl_int(any_hit ? 1 : 0), hb);
    dev.run(k, size_t(count));
    dev.read(hb, size_t(count) * sizeof(ClRayHit), &hits[off]);
  }
  return hits;
}

}  // namespace pf
