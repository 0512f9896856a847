// Photon tracing: see photon_pass.h.
#include "photonflow/stages/photon_pass.h"
#include "photonflow/foundations/memory_cap.h"

#include <omp.h>

#include <algorithm>
#include <climits>
#include <cmath>
#include <stdexcept>
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

// The photon tracer's random numbers, in the order it draws them (photon_pass.h): a photon path
// is a function of them (its primary samples, photon_guide.h). Two sources:
//   StreamSource  the counter-based stream (seed, pass, photon index): the uniform photons;
//   ChainSource   (trace_guided below) a stored vector u, mutated or drawn afresh past its end.
struct StreamSource {
  pf_rng rng;
  float next() { return pf_rng_next(&rng); }
};

// Emits photon `index`: picks a light by power and samples a ray and its flux.
template <class Source>
bool emit(const Scene& scene, const std::vector<LightInfo>& info, Source& src, Ray& ray,
          Vec3& flux, float eps) {
  float ul = src.next(), u1 = src.next(), u2 = src.next();
  float u3 = src.next(), u4 = src.next();
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

// What tracing a photon needs of its pass, the same for every photon.
struct TraceContext {
  const Scene& scene;
  const RayCaster& caster;
  const std::vector<LightInfo>& info;
  float eps;
  uint32_t pass;
  int max_bounces;
};

// Traces one photon from `src`'s draws (photon_pass.h: emission, then per bounce), calling
// store(photon) at every non-delta hit in path order. The uniform route and the guided chains
// (photon_guide.h) both trace here: the same draws in the same order, the same arithmetic.
template <class Source, class Store>
void trace_path(const TraceContext& ctx, Source& src, Store&& store) {
  const Scene& scene = ctx.scene;
  const RayCaster& caster = ctx.caster;
  const std::vector<LightInfo>& info = ctx.info;
  const float eps = ctx.eps;
  const uint32_t pass = ctx.pass;
  const int max_bounces = ctx.max_bounces;
  Ray ray;
  Vec3 flux;
  if (!emit(scene, info, src, ray, flux, eps)) return;
  bool specular_only = true;  // every bounce so far was specular (caustic path)
  bool first_hit = true;
  for (int bounce = 0; bounce <= max_bounces; ++bounce) {
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
      store(ph);
    }
    if (pbr) {
      // Continue by sampling the BSDF for importance transport in the front shading frame,
      // times Veach's adjoint where ns ≠ ng (pbr_scatter_shared.h); draws u1, u2, u3, then
      // u_rr (photon_pass.h). A glossy bounce ends the caustic chain (photon_pass.h).
      const float u1 = src.next();
      const float u2 = src.next();
      const float u3 = src.next();
      const pf_bsdf_params params = bsdf_params_at(scene, m, sh);
      float ns[3], ng[3], wo[3], wi[3], w[3], pdf;
      sh.ns.store(ns);
      sh.ng.store(ng);
      (-d).store(wo);
      const bool ok = pf_pbr_scatter(&params, ns, ng, wo, u1, u2, u3,
                                     PF_TRANSPORT_IMPORTANCE, wi, w, &pdf) != 0;
      const float u_rr = src.next();
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
      if (src.next() >= p) break;
      flux = flux * color * (1.f / p);
      // Two draws in a fixed order (function arguments have none in C++): the OpenCL
      // kernel draws u1 then u2 too.
      const float u1 = src.next();
      const float u2 = src.next();
      d = sample_cosine_hemisphere(n, u1, u2);
      specular_only = false;
    } else if (m.type == PF_MAT_MIRROR || m.type == PF_MAT_GLASS) {
      d = specular_bounce_with(m, sh, d, [&src] { return src.next(); }, flux);
    } else {
      break;  // black emitter absorbs
    }
    first_hit = false;
    if (luminance(flux) <= 0.f) break;
    ray = spawn_ray(sh, d, eps);
  }
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


// The uniform photon of a slot, its draws recorded: the chain's state when it is visible.
struct RecordingSource {
  StreamSource stream;
  std::vector<float>* u;
  float next() {
    const float v = stream.next();
    u->push_back(v);
    return v;
  }
};

// A proposal from the chain's state `base` (photon_guide.h step 2): coordinate k is
// u_k + δ·(2r_k − 1) wrapped into [0, 1) for k within base's used prefix, r_k itself past it,
// r_k = dimension k of the slot's mutation stream; the draws are recorded into `u`.
struct ChainSource {
  const std::vector<float>* base;
  float delta;
  pf_rng rng;
  std::vector<float>* u;
  float next() {
    const size_t k = u->size();
    const float r = pf_rng_next(&rng);  // dimension k: the stream's position is u's length
    float v = r;
    if (k < base->size()) {
      v = (*base)[k] + delta * (2.f * r - 1.f);
      v -= std::floor(v);     // mod 1
      if (!(v < 1.f)) v = 0.f;  // -tiny + 1 rounds to 1; 1 ≡ 0 (mod 1)
    }
    u->push_back(v);
    return v;
  }
};

// V(u) of a traced path (photon_guide.h): one of its deposits lies near a visible point.
bool path_visible(const VisibleSet& visible, const std::vector<pf_photon>& path) {
  for (const pf_photon& ph : path)
    if (visible.near(ph)) return true;
  return false;
}

// One chain's run of slots [begin, end) (photon_guide.h steps 1–3), its deposits appended to
// `out` with the uniform route's flux (trace_guided scales them), its counts into `st`.
void run_chain(const TraceContext& ctx, const VisibleSet& visible, pf_uint key, pf_uint mkey,
               uint32_t begin, uint32_t end, std::vector<pf_photon>& out, PhotonGuideStats& st) {
  std::vector<float> cur, cand;
  std::vector<pf_photon> cur_path, cand_path;
  bool has_state = false;
  float delta = kGuideDeltaStart;
  uint64_t mutations = 0;
  auto keep = [&cand_path](const pf_photon& ph) { cand_path.push_back(ph); };
  for (uint32_t i = begin; i < end; ++i) {
    cand.clear();
    cand_path.clear();
    RecordingSource uniform{StreamSource{pf_rng{key, i, 0}}, &cand};
    trace_path(ctx, uniform, keep);
    st.uniform += 1;
    if (path_visible(visible, cand_path)) {  // replica exchange: the chain jumps to it
      st.visible += 1;
      cur.swap(cand);
      cur_path.swap(cand_path);
      has_state = true;
    } else if (has_state) {
      cand.clear();
      cand_path.clear();
      ChainSource mutate{&cur, delta, pf_rng{mkey, i, 0}, &cand};
      trace_path(ctx, mutate, keep);
      mutations += 1;
      st.mutations += 1;
      const bool accepted = path_visible(visible, cand_path);  // Metropolis ratio V(u')
      if (accepted) {
        st.accepted += 1;
        cur.swap(cand);
        cur_path.swap(cand_path);
      }
      // Adaptive MCMC (Andrieu & Thoms 2008; HJ11): δ ← δ + (A − 0.234)/n, clamped.
      delta = float(double(delta) +
                    ((accepted ? 1.0 : 0.0) - kGuideTargetAcceptance) / double(mutations));
      delta = std::min(kGuideDeltaMax, std::max(kGuideDeltaMin, delta));
    }
    if (!has_state) continue;  // nothing found yet: the step is not counted
    st.chain_photons += 1;
    for (const pf_photon& ph : cur_path) append(out, ph);
  }
}

// The guided pass (photon_guide.h): kGuideChains chains over contiguous runs of slots, then the
// deposits' flux times visible / M (Vc · N / M, HJ11 section 4).
void trace_guided(const TraceContext& ctx, const VisibleSet& visible, uint32_t seed,
                  uint32_t photons, int threads, std::vector<std::vector<pf_photon>>& parts,
                  PhotonGuideStats* stats) {
  const uint32_t chains = std::min(kGuideChains, photons);
  parts.resize(chains);
  for (auto& p : parts) p.clear();
  std::vector<PhotonGuideStats> per(chains);
  const pf_uint key = pf_rng_key(seed, ctx.pass);
  const pf_uint mkey = pf_rng_key(seed ^ kGuideMutationSalt, ctx.pass);
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
  for (uint32_t c = 0; c < chains; ++c) {
    const uint32_t begin = uint32_t(uint64_t(photons) * c / chains);
    const uint32_t end = uint32_t(uint64_t(photons) * (c + 1) / chains);
    std::vector<pf_photon> out;
    out.swap(parts[c]);
    run_chain(ctx, visible, key, mkey, begin, end, out, per[c]);
    parts[c].swap(out);
  }
  PhotonGuideStats total;
  for (const PhotonGuideStats& s : per) total.add(s);
  if (total.chain_photons > 0) {
    const float scale = float(double(total.visible) / double(total.chain_photons));
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
    for (uint32_t c = 0; c < chains; ++c)
      for (pf_photon& ph : parts[c])
        for (int k = 0; k < 3; ++k) ph.flux[k] *= scale;
  }
  if (stats) *stats = total;
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

PhotonPassResult trace_photons(const Scene& scene, uint32_t pass, const PhotonPassOptions& opt,
                               const VisibleSet* visible, PhotonGuideStats* stats) {
  // The calling thread's chunk buffers, reused by its next pass.
  thread_local PhotonBuffers buffers;
  PhotonPassResult res;
  res.emitted = trace_photons_into(scene, pass, opt, buffers, visible, stats);
  buffers.concatenate(res.photons);
  return res;
}

uint64_t trace_photons_into(const Scene& scene, uint32_t pass, const PhotonPassOptions& opt,
                            PhotonBuffers& out_buffers, const VisibleSet* visible,
                            PhotonGuideStats* stats) {
  check_pass_range(pass, 1);  // the photons' int32 `pass`
  if (opt.guide == PhotonGuide::Visibility && !visible)
    throw std::invalid_argument("trace_photons_into: --photon-guide visibility needs the pass's "
                                "visible points");
  if (stats) *stats = PhotonGuideStats{};
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
  const TraceContext ctx{scene, caster, info, eps, pass, opt.max_bounces};
  if (opt.guide == PhotonGuide::Visibility) {
    trace_guided(ctx, *visible, opt.seed, opt.photons, threads, parts, stats);
    return opt.photons;
  }

#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
  for (uint32_t c = 0; c < nchunks; ++c) {
    // The chunk's buffer (with the capacity an earlier pass gave it) is filled through a local
    // vector: the chunks' vector headers sit side by side in `parts`, and appending through them
    // would make the threads write one cache line back and forth (false sharing).
    std::vector<pf_photon> out;
    out.swap(parts[c]);
    const uint32_t end = uint32_t(std::min<uint64_t>(opt.photons, uint64_t(c + 1) * kChunk));
    for (uint32_t i = c * kChunk; i < end; ++i) {
      StreamSource src{pf_rng{key, i, 0}};  // = pf_rng_start(opt.seed, pass, i), key once
      trace_path(ctx, src, [&out](const pf_photon& ph) { append(out, ph); });
    }
    parts[c].swap(out);
  }
  return opt.photons;
}

}  // namespace pf
