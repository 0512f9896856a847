// Photon tracing: see photon_pass.h.
#include "photonflow/stages/photon_pass.h"
#include "photonflow/foundations/memory_cap.h"

#include <omp.h>

#include <algorithm>
#include <climits>
#include <cmath>
#include <string>

#include "photonflow/foundations/error.h"
#include "photonflow/geometry/environment_shared.h"
#include "photonflow/geometry/light_shared.h"
#include "photonflow/foundations/options.h"
#include "photonflow/foundations/rng.h"
#include "photonflow/sampling/sampling.h"
#include "photonflow/geometry/surface.h"
#include "photonflow/foundations/threads.h"

namespace pf {

namespace {

// What emission needs of each light, computed once per pass (the same expressions as before,
// so the same bits): area lights' corners and unit front normal.
struct LightInfo {
  Vec3 v0, v1, v2, n;
  int32_t leaf = -1;  // the kd leaf of the light's centre (or position): its photons' Ray::leaf
};

// Emits photon `index`: picks a light by power and samples a ray and its flux.
bool emit(const Scene& scene, const std::vector<LightInfo>& info, pf_rng& rng, Ray& ray,
          Vec3& flux, float eps) {
  float ul = pf_rng_next(&rng), u1 = pf_rng_next(&rng), u2 = pf_rng_next(&rng);
  float u3 = pf_rng_next(&rng), u4 = pf_rng_next(&rng);
  float p_light;
  size_t li = scene.pick_light(ul, p_light);
  const pf_light& l = scene.lights[li];
  if (p_light <= 0.f) return false;
  if (l.type == PF_LIGHT_AREA) {
    if (scene.light_point_cut_away(li, u1, u2)) return false;  // a cut-away texel emits nothing
    const LightInfo& t = info[li];
    Vec3 p = sample_triangle(t.v0, t.v1, t.v2, u1, u2);
    Vec3 d = sample_cosine_hemisphere(t.n, u3, u4);
    ray = Ray{p + t.n * eps, d};
    ray.leaf = t.leaf;
    // Φ = L · A · π for a one-sided Lambertian emitter (cosine sampling: L·cos/pdf = L·π).
    flux = Vec3(l.radiance) * (l.area * kPi / p_light);
  } else if (l.type == PF_LIGHT_POINT) {
    ray = Ray{Vec3(l.position), sample_uniform_sphere(u1, u2)};
    ray.leaf = info[li].leaf;
    flux = Vec3(l.radiance) * (4.f * kPi / p_light);  // Φ = 4π · I
  } else if (l.type == PF_LIGHT_ENVIRONMENT) {
    // The map (environment_shared.h pf_env_emit, pbrt-v3 InfiniteAreaLight::Sample_Le): ω by
    // (u1, u2), the origin on the bounding sphere's disc by (u3, u4), flux L·πR²/(pdf_ω·p_light).
    float o[3], d[3], power[3];
    if (!pf_env_emit(scene.env_data(), u1, u2, u3, u4, o, d, power)) return false;
    ray = Ray{Vec3(o), Vec3(d)};
    ray.leaf = -1;  // outside the bounds, as a directional light's photons
    flux = Vec3(power) * (1.f / p_light);
  } else {  // spot or directional (light_shared.h; the kernel's twin in trace_photons.cl)
    float o[3], d[3];
    const float f = pf_punctual_emit(l.type, l.position, l.direction, l.cos_inner, l.cos_outer,
                                     l.area, u1, u2, o, d);
    if (!(f > 0.f)) return false;
    ray = Ray{Vec3(o), Vec3(d)};
    ray.leaf = info[li].leaf;  // a spot light's position; none for a directional light
    flux = Vec3(l.radiance) * (f / p_light);
  }
  return true;
}

std::vector<LightInfo> light_info(const Scene& scene, const RayCaster& caster, float eps) {
  std::vector<LightInfo> info(scene.lights.size());
  for (size_t li = 0; li < scene.lights.size(); ++li) {
    const pf_light& l = scene.lights[li];
    if (l.type == PF_LIGHT_POINT || l.type == PF_LIGHT_SPOT)
      info[li].leaf = caster.leaf_at(Vec3(l.position));
    if (l.type != PF_LIGHT_AREA) continue;
    const pf_triangle& t = scene.triangles[size_t(l.triangle)];
    info[li].v0 = Vec3(t.v0);
    info[li].v1 = Vec3(t.v1);
    info[li].v2 = Vec3(t.v2);
    info[li].n = face_normal(t);
    const Vec3 centre = (info[li].v0 + info[li].v1 + info[li].v2) * (1.f / 3.f);
    info[li].leaf = caster.leaf_at(centre + info[li].n * eps);
  }
  return info;
}

// Emitted photons per chunk: chunk c traces photon indices [c·kChunk, (c+1)·kChunk). The
// output does not depend on it (chunks are concatenated in index order); small chunks balance
// the threads' load at the end of a pass.
constexpr uint32_t kChunk = PhotonBuffers::kChunk;

// Appends to a chunk buffer. A buffer starts with room for 4 stored photons per emitted one
// (pages not written are not resident, so unused room costs address space only) and grows by a
// quarter: in a long run a pass that stores a few more photons than any before almost never
// reallocates, so the buffers do not leave freed blocks behind (heap fragmentation) pass after
// pass, and the run's memory stays where its first passes put it.
inline void append(std::vector<pf_photon>& out, const pf_photon& ph) {
  if (out.size() == out.capacity())
    out.reserve(std::max<size_t>(4 * kChunk, out.capacity() + out.capacity() / 4));
  out.push_back(ph);
}

}  // namespace

size_t PhotonBuffers::size() const {
  size_t n = 0;
  for (const auto& c : chunks) n += c.size();
  return n;
}

std::vector<PhotonSpan> PhotonBuffers::spans() const {
  std::vector<PhotonSpan> s;
  s.reserve(chunks.size());
  for (const auto& c : chunks) s.push_back({c.data(), c.size()});
  return s;
}

void PhotonBuffers::concatenate(std::vector<pf_photon>& out) const {
  out.clear();
  out.reserve(size());
  for (const auto& c : chunks) out.insert(out.end(), c.begin(), c.end());
}

void check_options(const PhotonPassOptions& opt) {
  require_positive("photons", int64_t(opt.photons));
  // A pass holds its stored photons (and their grid) at once: at one stored photon per emitted
  // photon (paths in a closed scene store several) a count whose photons exceed this machine's
  // memory cannot run; refused before any work rather than swapping or killed for memory.
  const uint64_t need = uint64_t(opt.photons) * sizeof(pf_photon), have = physical_memory_bytes();
  if (have > 0 && need > have)
    throw input_error("", "--photons " + std::to_string(opt.photons) + " stores at least " +
                              std::to_string(need >> 30) + " GiB of photons per pass, more than " +
                              "this machine's " + std::to_string(have >> 30) + " GiB of memory",
                      "lower --photons and run more passes");
  require_positive("max-bounces", opt.max_bounces);
  require_threads(opt.threads);
}

void check_pass_range(int64_t first, int64_t count) {
  if (first < 0 || count < 0)
    throw input_error("", "--first-pass and --passes must be >= 0");
  if (!pass_indices_fit(first, count))
    throw input_error("", "passes " + std::to_string(first) + " … " +
                              std::to_string(first + count - 1) +
                              " run past 2147483647 (2^31 - 1), the largest pass index",
                      "lower --first-pass or --passes");
}

PhotonPassResult trace_photons(const Scene& scene, uint32_t pass, const PhotonPassOptions& opt) {
  // The calling thread's chunk buffers, reused by its next pass.
  thread_local PhotonBuffers buffers;
  PhotonPassResult res;
  res.emitted = trace_photons_into(scene, pass, opt, buffers);
  buffers.concatenate(res.photons);
  return res;
}

uint64_t trace_photons_into(const Scene& scene, uint32_t pass, const PhotonPassOptions& opt,
                            PhotonBuffers& out_buffers) {
  check_pass_range(pass, 1);  // the photons' int32 `pass`
  // Fixed-size chunks of photon indices, kept in chunk order: the output order does not depend on
  // the thread count or on scheduling.
  const uint32_t nchunks = (scene.lights.empty() || opt.photons == 0)
                               ? 0
                               : uint32_t((uint64_t(opt.photons) + kChunk - 1) / kChunk);
  std::vector<std::vector<pf_photon>>& parts = out_buffers.chunks;
  parts.resize(nchunks);  // keeps the capacity of the chunks a previous pass grew
  for (auto& p : parts) p.clear();
  if (nchunks == 0) return opt.photons;
  const float eps = ray_epsilon(scene);
  const RayCaster caster(scene);
  const std::vector<LightInfo> info = light_info(scene, caster, eps);
  const int threads = worker_threads(opt.threads);
  const pf_uint key = pf_rng_key(opt.seed, pass);

#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
  for (uint32_t c = 0; c < nchunks; ++c) {
    // The chunk's buffer (with the capacity an earlier pass gave it) is filled through a local
    // vector: the chunks' vector headers sit side by side in `parts`, and appending through them
    // would make the threads write one cache line back and forth (false sharing).
    std::vector<pf_photon> out;
    out.swap(parts[c]);
    const uint32_t end = uint32_t(std::min<uint64_t>(opt.photons, uint64_t(c + 1) * kChunk));
    for (uint32_t i = c * kChunk; i < end; ++i) {
      pf_rng rng{key, i, 0};  // = pf_rng_start(opt.seed, pass, i), key computed once
      Ray ray;
      Vec3 flux;
      if (!emit(scene, info, rng, ray, flux, eps)) continue;
      bool specular_only = true;  // every bounce so far was specular (caustic path)
      bool first_hit = true;
      for (int bounce = 0; bounce <= opt.max_bounces; ++bounce) {
        Hit h;
        if (!caster.closest(ray, h)) break;
        SurfaceHit sh = surface_at(scene, ray, h);
        const pf_material& m = scene.materials[size_t(sh.material)];
        Vec3 d = normalize(ray.d);
        Vec3 n = sh.front ? sh.ns : -sh.ns;  // facing the incoming photon
        bool diffuse = m.type == PF_MAT_DIFFUSE ||
                       (m.type == PF_MAT_EMITTER && luminance(Vec3(m.color)) > 0.f);
        const bool pbr = m.type == PF_MAT_PBR;
        if (diffuse || pbr) {  // a non-delta surface: the photon is stored
          pf_photon ph{};
          sh.p.store(ph.position);
          d.store(ph.dir);
          flux.store(ph.flux);
          ph.mesh = sh.mesh;
          ph.pass = int32_t(pass);
          ph.flags = (first_hit ? PF_PHOTON_DIRECT : 0) |
                     (!first_hit && specular_only ? PF_PHOTON_CAUSTIC : 0);
          append(out, ph);
        }
        if (pbr) {
          // Continue by sampling the BSDF for importance transport in the front shading frame,
          // times Veach's adjoint where ns ≠ ng (pbr_scatter_shared.h); draws u1, u2, u3, then
          // u_rr (photon_pass.h). A glossy bounce ends the caustic chain (photon_pass.h).
          const float u1 = pf_rng_next(&rng);
          const float u2 = pf_rng_next(&rng);
          const float u3 = pf_rng_next(&rng);
          const pf_bsdf_params params = bsdf_params_at(scene, m, sh);
          float ns[3], ng[3], wo[3], wi[3], w[3], pdf;
          sh.ns.store(ns);
          sh.ng.store(ng);
          (-d).store(wo);
          const bool ok = pf_pbr_scatter(&params, ns, ng, wo, u1, u2, u3,
                                         PF_TRANSPORT_IMPORTANCE, wi, w, &pdf) != 0;
          const float u_rr = pf_rng_next(&rng);
          if (!ok) break;
          const Vec3 next = flux * Vec3(w);
          const float before = std::max(flux.x, std::max(flux.y, flux.z));
          const float after = std::max(next.x, std::max(next.y, next.z));
          const float q = std::min(1.f, after / before);
          if (!(q > 0.f) || u_rr >= q) break;
          flux = next * (1.f / q);
          d = Vec3(wi);
          specular_only = false;
        } else if (diffuse) {
          const Vec3 color = diffuse_color(scene, m, sh);  // textured albedo
          // Russian roulette by albedo.
          float p = std::max(color.x, std::max(color.y, color.z));
          if (pf_rng_next(&rng) >= p) break;
          flux = flux * color * (1.f / p);
          // Two draws in a fixed order (function arguments have none in C++): the OpenCL
          // kernel draws u1 then u2 too.
          const float u1 = pf_rng_next(&rng);
          const float u2 = pf_rng_next(&rng);
          d = sample_cosine_hemisphere(n, u1, u2);
          specular_only = false;
        } else if (m.type == PF_MAT_MIRROR || m.type == PF_MAT_GLASS) {
          d = specular_bounce(m, sh, d, &rng, flux);
        } else {
          break;  // black emitter absorbs
        }
        first_hit = false;
        if (luminance(flux) <= 0.f) break;
        ray = spawn_ray(sh, d, eps);
      }
    }
    parts[c].swap(out);
  }
  return opt.photons;
}

}  // namespace pf
