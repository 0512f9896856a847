// Eye pass: see eye_pass.h.
#include "photonflow/stages/eye_pass.h"
#include "photonflow/io/validate.h"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "photonflow/geometry/camera.h"
#include "photonflow/geometry/light_shared.h"
#include "photonflow/material/merge_weight_shared.h"
#include "photonflow/material/pbr_scatter_shared.h"
#include "photonflow/foundations/options.h"
#include "photonflow/foundations/rng.h"
#include "photonflow/sampling/sampling.h"
#include "photonflow/geometry/surface.h"
#include "photonflow/foundations/threads.h"

namespace pf {

const char* direct_mode_name(DirectMode m) {
  return m == DirectMode::Photons ? "photons" : "shadow-rays";
}

const char* pixel_sampler_name(PixelSampler s) {
  switch (s) {
    case PixelSampler::Strata: return "strata";
    case PixelSampler::Random: return "random";
    case PixelSampler::Sobol: return "sobol";
  }
  return "?";
}

const char* glossy_merge_name(GlossyMerge g) { return g == GlossyMerge::First ? "first" : "mis"; }

GlossyMerge parse_glossy_merge(const std::string& name) {
  require_choice("glossy-merge", name, {"first", "mis"});
  return name == "first" ? GlossyMerge::First : GlossyMerge::Mis;
}

PixelSampler parse_pixel_sampler(const std::string& name) {
  require_choice("pixel-sampler", name, {"strata", "random", "sobol"});
  return name == "strata" ? PixelSampler::Strata
                          : name == "random" ? PixelSampler::Random : PixelSampler::Sobol;
}

int eye_strata_columns(int spp) {
  int rows = 1;
  for (int r = 1; int64_t(r) * r <= int64_t(spp); ++r)
    if (spp % r == 0) rows = r;
  return std::max(1, spp / rows);
}

float radius_scale(const Scene& scene) {
  // Every pass's eye tracer asks (default_radius): the triangles are scanned only when the
  // material table holds a material other than diffuse or emitter, up to its first user.
  std::vector<char> other(scene.materials.size());
  bool any = false;
  for (size_t i = 0; i < other.size(); ++i) {
    const int type = scene.materials[i].type;
    other[i] = type != PF_MAT_DIFFUSE && type != PF_MAT_EMITTER;
    any = any || other[i];
  }
  if (any)
    for (const pf_triangle& t : scene.triangles)
      if (other[size_t(t.material)]) return kRadiusScale;
  return kRadiusScaleDiffuse;
}

float default_radius(const Scene& scene) {
  CameraFrame cam(scene.camera);
  float dist = length(Vec3(scene.camera.look_at) - Vec3(scene.camera.eye));
  float diag = length(scene.bounds.extent());
  return radius_scale(scene) * std::max(diag / 200.f, 4.f * cam.pixel_angle() * dist);
}

namespace {
// Random stream of the eye pass: pass slot 0xE7E (distinct from photon passes 0, 1, 2, ...).
constexpr uint32_t kEyeStream = 0xE7E0000u;
constexpr uint32_t kShadowStream = PF_SHADOW_STREAM_SLOT;

Vec3 mat_color(const pf_material& m) { return Vec3(m.color); }
bool is_diffuse(const pf_material& m) {
  return m.type == PF_MAT_DIFFUSE || (m.type == PF_MAT_EMITTER && luminance(mat_color(m)) > 0.f);
}
}  // namespace

// L_direct at a diffuse point (thesis eq. 3.7; HJ09 section 4): (1/n) Σ ρ/π · L_e · cos θ_x · G /
// p_light over n light samples (Scene::light_incident), each behind an unblocked shadow ray; a
// light below the shading or the geometric normal sends nothing.
Vec3 direct_light(const Scene& scene, const Vec3& p, const Vec3& ng, const Vec3& ns,
                  const pf_material& m, int samples, pf_light_draws& draws, int32_t leaf) {
  if (scene.lights.empty() || samples <= 0) return {};
  const float eps = ray_epsilon(scene);
  Vec3 sum;
  for (int s = 0; s < samples; ++s) {
    float ul, u1, u2;
    pf_light_draws_next(&draws, &ul, &u1, &u2);
    Scene::LightSample ls;
    if (!scene.sample_light(ul, u1, u2, p, ls)) continue;
    const float cos_x = dot(ls.w, ns);
    if (cos_x <= 0.f || dot(ls.w, ng) <= 0.f) continue;
    const Vec3 o = p + ng * eps;
    if (intersect_any(scene, Ray{o, ls.q - o, 0.f, 1.f - 1e-4f, leaf})) continue;
    sum += ls.le * (cos_x * ls.g / ls.p_light);
  }
  return mat_color(m) * kInvPi * sum * (1.f / float(samples));
}

Vec3 direct_light(const Scene& scene, const Vec3& p, const Vec3& ng, const Vec3& ns,
                  const pf_material& m, int samples, uint32_t seed, uint32_t pass,
                  uint32_t index) {
  pf_light_draws draws = pf_light_draws_from(pf_rng_start(seed, kShadowStream + pass, index));
  return direct_light(scene, p, ng, ns, m, samples, draws);
}

// The same draws, light samples and shadow rays at a PF_MAT_PBR point: f(wo, w_l) of the BSDF
// in radiance mode instead of ρ/π and |cos θ_x| at the shading normal; a light behind the surface
// counts where the BSDF transmits (the shadow ray leaves on its side).
Vec3 direct_light_pbr(const Scene& scene, const Vec3& p, const Vec3& ng_front,
                      const Vec3& ns_front, const pf_bsdf_params& params, const Vec3& wo,
                      int samples, pf_light_draws& draws, bool mis, int32_t leaf) {
  if (scene.lights.empty() || samples <= 0) return {};
  const float eps = ray_epsilon(scene);
  float ns[3], ng[3], o[3];
  ns_front.store(ns);
  ng_front.store(ng);
  wo.store(o);
  Vec3 sum;
  for (int s = 0; s < samples; ++s) {
    float ul, u1, u2;
    pf_light_draws_next(&draws, &ul, &u1, &u2);
    Scene::LightSample ls;
    if (!scene.sample_light(ul, u1, u2, p, ls)) continue;
    float wl[3], f[3];
    ls.w.store(wl);
    pf_pbr_eval_world(&params, ns, ng, o, wl, f);  // 0 for a pair the normals disagree on
    if (!(f[0] > 0.f || f[1] > 0.f || f[2] > 0.f)) continue;
    float w = 1.f;
    const int type = scene.lights[ls.light].type;
    if (mis && (type == PF_LIGHT_AREA || type == PF_LIGHT_ENVIRONMENT))
      w = pf_power_heuristic(float(samples) * ls.p_light / ls.g,
                             pf_pbr_pdf_world(&params, ns, ng, o, wl));
    const Vec3 origin = p + ng_front * (dot(ls.w, ng_front) >= 0.f ? eps : -eps);
    if (intersect_any(scene, Ray{origin, ls.q - origin, 0.f, 1.f - 1e-4f, leaf})) continue;
    sum += Vec3(f) * ls.le * (std::fabs(dot(ls.w, ns_front)) * ls.g / ls.p_light * w);
  }
  return sum * (1.f / float(samples));
}

Vec3 direct_light_pbr(const Scene& scene, const Vec3& p, const Vec3& ng_front,
                      const Vec3& ns_front, const pf_bsdf_params& params, const Vec3& wo,
                      int samples, uint32_t seed, uint32_t pass, uint32_t index) {
  pf_light_draws draws = pf_light_draws_from(pf_rng_start(seed, kShadowStream + pass, index));
  return direct_light_pbr(scene, p, ng_front, ns_front, params, wo, samples, draws, false);
}

void check_options(const EyePassOptions& opt) {
  require_positive("spp", opt.spp);
  require_positive("max-depth", opt.max_depth);
  require_positive("shadow-samples", opt.shadow_samples);
  // Light samples per visible point and pass: more than kMaxShadowSamples converge no faster than
  // as many more passes, and 2^31 of them would keep one pass busy for days.
  if (opt.shadow_samples > kMaxShadowSamples)
    throw input_error("", "--shadow-samples must be at most " + std::to_string(kMaxShadowSamples) +
                              ", got " + std::to_string(opt.shadow_samples),
                      "run more passes instead");
  if (opt.glossy_spp < 0 || opt.glossy_spp > kMaxGlossySpp)
    throw input_error("", "--glossy-spp must be in [0, " + std::to_string(kMaxGlossySpp) +
                              "], got " + std::to_string(opt.glossy_spp),
                      "0 takes no glossy samples");
  if (opt.emission_spp < 0 || opt.emission_spp > kMaxEmissionSpp)
    throw input_error("", "--emission-spp must be in [0, " + std::to_string(kMaxEmissionSpp) +
                              "], got " + std::to_string(opt.emission_spp),
                      "0 leaves the emitted light to the eye samples");
  // The shared light of a glossy vertex leaves its direct light to next-event estimation there
  // (merge_weight_shared.h): photons that carry direct light would count it twice.
  if (opt.glossy == GlossyMerge::Mis && opt.direct != DirectMode::ShadowRays)
    throw input_error("", "--glossy-merge mis needs --direct shadow-rays",
                      "use --glossy-merge first with --direct photons");
  // R0² must stay a normal float (validate.h kMinRadius): 1e-23 squared is 0 in float, and
  // every radiance of eq. 3.19 would divide by it.
  if (!(opt.radius == 0.f || (opt.radius >= kMinRadius && opt.radius <= kMaxRadius)))
    throw input_error("", "--radius must be 0 (automatic) or a length in [" +
                              value_text(kMinRadius, 6) + ", " + value_text(kMaxRadius, 6) +
                              "], got " + value_text(opt.radius));
  require_threads(opt.threads);
}

EyePassResult trace_hitpoints(const Scene& scene, const EyePassOptions& opt) {
  EyePassResult res;
  EyePassWork work;
  trace_hitpoints_into(scene, opt, res, work);
  return res;
}

void check_eye_samples(const Scene& scene, const EyePassOptions& opt) {
  const uint64_t samples = uint64_t(scene.camera.width) * uint64_t(scene.camera.height) *
                           uint64_t(std::max(1, opt.spp));
  if (samples > uint64_t(UINT32_MAX) + 1)
    throw input_error("", "--spp " + std::to_string(opt.spp) + " gives " + std::to_string(samples) +
                              " eye samples for the " + std::to_string(scene.camera.width) + "x" +
                              std::to_string(scene.camera.height) +
                              " image, more than the 2^32 sample streams of a pass",
                      "lower --spp, or run more passes");
  const uint64_t glossy = uint64_t(scene.camera.width) * uint64_t(scene.camera.height) *
                          uint64_t(std::max(0, opt.glossy_spp));
  if (glossy > uint64_t(UINT32_MAX) + 1)
    throw input_error("", "--glossy-spp " + std::to_string(opt.glossy_spp) + " gives more than the "
                              "2^32 glossy sample streams of a pass for the " +
                              std::to_string(scene.camera.width) + "x" +
                              std::to_string(scene.camera.height) + " image",
                      "lower --glossy-spp");
}

EyeTracer::EyeTracer(const Scene& scene, const EyePassOptions& opt)
    : scene_(scene),
      opt_(opt),
      spp_(std::max(1, opt.spp)),
      columns_(eye_strata_columns(spp_)),
      radius_(opt.radius > 0.f ? opt.radius : default_radius(scene)),
      eps_(ray_epsilon(scene)),
      eye_key_(pf_rng_key(opt.seed, kEyeStream + opt.pass)),
      sobol_key_(pf_sobol_key(opt.seed)),
      emission_key_(pf_emission_sobol_key(opt.seed)),
      cam_(scene.camera),
      caster_(scene),
      camera_leaf_(caster_.leaf_at(Vec3(scene.camera.eye))),
      emit_pixels_(nullptr),
      glossy_pixels_(nullptr),
      glossy_key_(pf_glossy_sobol_key(opt.seed)) {
  check_eye_samples(scene, opt);
  if (opt.glossy_spp > 0 && opt.glossy == GlossyMerge::Mis && scene.has_pbr()) {
    const size_t n = size_t(scene.camera.width) * size_t(scene.camera.height);
    if (opt.glossy_pixels && opt.glossy_pixels->size() != n)
      throw std::invalid_argument("EyeTracer: glossy_pixels is not the image's size");
    if (!opt.glossy_pixels) own_glossy_ = glossy_pixels(scene);
    glossy_pixels_ = opt.glossy_pixels ? opt.glossy_pixels : &own_glossy_;
  }
  if (opt.glossy == GlossyMerge::Mis && scene.has_pbr()) {
    tri_light_.assign(scene.triangles.size(), -1);
    for (size_t li = 0; li < scene.lights.size(); ++li)
      if (scene.lights[li].type == PF_LIGHT_AREA)
        tri_light_[size_t(scene.lights[li].triangle)] = int32_t(li);
  }
  if (opt.emission_spp > 0) {
    const size_t n = size_t(scene.camera.width) * size_t(scene.camera.height);
    if (opt.emission_pixels && opt.emission_pixels->size() != n)
      throw std::invalid_argument("EyeTracer: emission_pixels is not the image's size");
    if (!opt.emission_pixels) own_pixels_ = emission_pixels(scene);
    emit_pixels_ = opt.emission_pixels ? opt.emission_pixels : &own_pixels_;
  }
}

bool EyeTracer::sample(int x, int y, int s, pf_hitpoint& hp, Vec3& emitted, Vec3& direct,
                       pf_pbr_point* pbr) const {
  const size_t pix = size_t(y) * size_t(scene_.camera.width) + size_t(x);
  const bool extra = s >= spp_;  // a glossy sample (EyePassOptions::glossy_spp)
  pf_rng rng;
  float jx, jy;
  float u1 = 0.5f, u2 = 0.5f;
  // The first glossy vertex's BSDF sample (pixel_sampler.h pf_eye_lobe_keyed): Sobol point
  // `lobe_index` of the pixel under `lobe_key` when the pixel positions are Sobol's.
  int lobe_sobol = 0;
  uint32_t lobe_key = 0, lobe_index = 0;
  if (!extra) {
    const uint32_t index = uint32_t(pix * size_t(spp_) + size_t(s));
    rng = pf_rng{eye_key_, index, 0};  // = pf_rng_start(seed, kEyeStream + pass, index)
    lobe_sobol = opt_.sampler == PixelSampler::Sobol;
    lobe_key = sobol_key_;
    lobe_index = opt_.pass * uint32_t(spp_) + uint32_t(s);
    pf_eye_jitter_keyed(int(opt_.sampler), sobol_key_, opt_.pass, uint32_t(pix), s, spp_,
                        columns_, &rng, &jx, &jy);
    // A thin lens draws its point on the lens next (pixel_sampler.h); a pinhole draws nothing,
    // so its streams (and images) are those of the pinhole eye pass.
    if (cam_.lens())
      pf_eye_lens_keyed(int(opt_.sampler), sobol_key_, opt_.pass, uint32_t(pix), s, spp_, &rng,
                        &u1, &u2);
  } else {
    const int G = opt_.glossy_spp, k = s - spp_;
    const uint32_t index = uint32_t(pix * size_t(G) + size_t(k));
    rng = pf_rng_start(opt_.seed, PF_GLOSSY_STREAM + opt_.pass, index);
    pf_sobol_pixel_sample_keyed(glossy_key_, uint32_t(pix), opt_.pass * uint32_t(G) + uint32_t(k),
                                &jx, &jy);
    lobe_sobol = 1;
    lobe_key = glossy_key_;
    lobe_index = opt_.pass * uint32_t(G) + uint32_t(k);
    if (cam_.lens()) {
      u1 = pf_rng_next(&rng);
      u2 = pf_rng_next(&rng);
    }
  }
  // The light samples of the path's vertices with next-event estimation, in order
  // (pixel_sampler.h pf_light_draws_vertex): Sobol points of the pixel (a glossy sample's under
  // its own key) at the first two, the eye stream after; `eye_draws` says the last call drew
  // from the eye stream, which then goes on from the draws' (nee_done).
  const int draws_sobol = extra || opt_.sampler == PixelSampler::Sobol;
  int nee = 0, eye_draws = 0;
  auto nee_draws = [&]() {
    return pf_light_draws_vertex(draws_sobol, lobe_key, opt_.seed, opt_.pass, uint32_t(pix), s,
                                 spp_, lobe_index, opt_.shadow_samples, nee++, rng, &eye_draws);
  };
  auto nee_done = [&](const pf_light_draws& d) {
    if (eye_draws) rng = d.rng;
  };
  Ray ray;
  cam_.ray(float(x) + jx, float(y) + jy, u1, u2, ray.o, ray.d);
  ray.leaf = camera_leaf_;
  const float w = 1.f / float(samples(x, y));
  Vec3 T(w, w, w);  // throughput × box filter weight
  // GlossyMerge::Mis: the ray was sampled by the BSDF at a PBR vertex (`from_glossy`), with
  // solid-angle density `glossy_pdf`; an emitter it hits adds its light times `T_direct` (the
  // throughput up to that vertex times the sample's weight, not shared with the gather) and the
  // power-heuristic weight. `last`: the ray was traced only for this (`merged`: that vertex made
  // the visible point; otherwise nothing was left for the path to carry). `glossy`: the path went
  // on through a PBR vertex; the emitters it finds then go to `direct`.
  bool from_glossy = false, last = false, merged = false, glossy = false;
  float glossy_pdf = 0.f;
  Vec3 T_direct, glossy_p;  // glossy_p: that vertex (its NEE's light choice, for the MIS weight)
  for (int depth = 0; depth <= opt_.max_depth; ++depth) {
    Hit h;
    if (!caster_.closest(ray, h)) {
      // The environment along the escaping ray (none: 0): seen directly or through mirrors and
      // glass it is emitted light, after a glossy vertex's BSDF sample it is that vertex's
      // direct light, weighted against next-event estimation of the environment there.
      if (scene_.environment.present()) {
        const Vec3 d = normalize(ray.d);
        const Vec3 le = scene_.environment_radiance(d);
        if (from_glossy)
          direct += T_direct * le *
                    pf_power_heuristic(glossy_pdf, float(opt_.shadow_samples) *
                                                       scene_.environment_light_pdf(d, glossy_p));
        else
          (glossy ? direct : emitted) += T * le;
      }
      return merged;
    }
    SurfaceHit sh = surface_at(scene_, ray, h);
    const pf_material& m = scene_.materials[size_t(sh.material)];
    if (m.type == PF_MAT_EMITTER && sh.front) {
      if (from_glossy)
        direct += T_direct * Vec3(m.emission) *
                  emitter_hit_weight(ray, h, sh, glossy_p, glossy_pdf);
      else
        (glossy ? direct : emitted) += T * Vec3(m.emission);
    }
    if (last) return merged;
    from_glossy = false;
    if (is_diffuse(m)) {
      Vec3 n = sh.front ? sh.ns : -sh.ns;  // facing the incoming ray
      // A textured material's texture value at the hit joins the weight: every gather's
      // f_r = color/π times the weight is then the textured f_r (docs/FORMATS.md, hitpoints),
      // and so is the direct light below. Without texture the weight is T as before.
      const int texture = scene_.texture_of(sh.material);
      if (texture >= 0) T = T * scene_.texture_value(texture, size_t(sh.tri), sh.u, sh.v);
      hp = pf_hitpoint{};
      sh.p.store(hp.position);
      n.store(hp.normal);
      (depth > 0 ? normalize(ray.d) : ray.d).store(hp.dir);  // camera rays are unit
      T.store(hp.weight);
      hp.radius = radius_;
      hp.pixel_x = x;
      hp.pixel_y = y;
      hp.mesh = sh.mesh;
      hp.material = sh.material;
      if (opt_.direct == DirectMode::ShadowRays) {
        pf_light_draws draws = nee_draws();
        direct += T * direct_light(scene_, sh.p, sh.front ? sh.ng : -sh.ng, n, m,
                                   opt_.shadow_samples, draws, sh.leaf);
        nee_done(draws);
      }
      if (pbr) *pbr = pf_pbr_point{};
      return true;
    }
    if (m.type == PF_MAT_PBR) {
      const Vec3 d = depth > 0 ? normalize(ray.d) : ray.d;  // camera rays are unit
      pf_pbr_point pt = pbr_point_at(scene_, m, sh);
      // The visible point's record (HJ09 section 4): the hitpoint as at a diffuse surface, its
      // weight the throughput alone, the BSDF's textured parameters beside it; every gather
      // evaluates f per photon (pbr_point_shared.h).
      auto visible_point = [&](const Vec3& weight) {
        const Vec3 n = sh.front ? sh.ns : -sh.ns;  // facing the incoming ray
        hp = pf_hitpoint{};
        sh.p.store(hp.position);
        n.store(hp.normal);
        d.store(hp.dir);
        weight.store(hp.weight);
        hp.radius = radius_;
        hp.pixel_x = x;
        hp.pixel_y = y;
        hp.mesh = sh.mesh;
        hp.material = sh.material;
        if (pbr) *pbr = pt;
      };
      if (opt_.glossy == GlossyMerge::First) {
        // No random number is drawn here; direct light by light sampling alone.
        visible_point(T);
        if (opt_.direct == DirectMode::ShadowRays) {
          pf_light_draws draws = nee_draws();
          direct += T * direct_light_pbr(scene_, sh.p, sh.ng, sh.ns, pt.params, -d,
                                         opt_.shadow_samples, draws, false, sh.leaf);
          nee_done(draws);
        }
        return true;
      }
      // GlossyMerge::Mis (merge_weight_shared.h). The merge probability q of the vertex, in the
      // BSDF's frame (the front shading normal), then the choice (one number of the eye stream).
      float ns[3], ng[3], wo[3], o[3];
      sh.ns.store(ns);
      sh.ng.store(ng);
      (-d).store(wo);
      pf_bsdf_to_local(ns, wo, o);
      const float q = pf_merge_probability(&pt.params, o);
      const float u_merge = pf_rng_next(&rng);
      const bool merge = q >= 1.f || (q > 0.f && u_merge < q);
      // Direct light: next-event estimation weighted against the BSDF's sample below, whether
      // the point is the visible point or the path goes on.
      {
        pf_light_draws draws = nee_draws();
        direct += T * direct_light_pbr(scene_, sh.p, sh.ng, sh.ns, pt.params, -d,
                                       opt_.shadow_samples, draws, true, sh.leaf);
        nee_done(draws);
      }
      // The BSDF's sample (radiance mode): the direct light's second strategy, and where the
      // path goes on; (u1, u2, u3) at the path's first glossy vertex by pf_eye_lobe_keyed, later
      // from the eye stream.
      float wi[3], wt[3], pdf;
      float u1, u2, u3;
      pf_eye_lobe_keyed(lobe_sobol, lobe_key, uint32_t(pix), lobe_index, &rng, &u1, &u2, &u3);
      lobe_sobol = 0;
      const bool sampled =
          pf_pbr_scatter(&pt.params, ns, ng, wo, u1, u2, u3, PF_TRANSPORT_RADIANCE, wi, wt, &pdf);
      if (merge) {
        // (3): the gather's share w_m per photon, the hitpoint's weight divided by q
        if (q < 1.f) pt.outside |= PF_PBR_POINT_MERGE_WEIGHTED;
        visible_point(q < 1.f ? T * (1.f / q) : T);
        if (!sampled) return true;
        T_direct = T * Vec3(wt);
        glossy_pdf = pdf;
        glossy_p = sh.p;
        from_glossy = last = merged = true;
        ray = spawn_ray(sh, Vec3(wi), eps_);
        continue;  // the next hit adds an emitter's MIS-weighted light, and returns
      }
      if (!sampled) return false;
      // (3): the continuation's share w_c of the sampled direction, divided by 1 − q
      float share = 1.f;
      if (q > 0.f) {
        float i[3];
        pf_bsdf_to_local(ns, wi, i);
        share = (1.f - pf_merge_weight(&pt.params, o, i)) / (1.f - q);
      }
      T_direct = T * Vec3(wt);
      T = T_direct * share;
      glossy_pdf = pdf;
      glossy_p = sh.p;
      from_glossy = glossy = true;
      if (!(luminance(T_direct) > 0.f)) return false;
      last = !(luminance(T) > 0.f);  // w_m = 1 here: only the emitter's light is left
      ray = spawn_ray(sh, Vec3(wi), eps_);
      continue;
    }
    if (m.type != PF_MAT_MIRROR && m.type != PF_MAT_GLASS) return false;  // black emitter
    Vec3 d = specular_bounce(m, sh, normalize(ray.d), &rng, T);
    if (luminance(T) <= 0.f) return false;
    ray = spawn_ray(sh, d, eps_);
  }
  return merged;
}

// The BSDF sample's weight against next-event estimation's n = shadow_samples light samples at
// the vertex it left (direct_light_pbr with mis): the power heuristic of the BSDF's density
// against n p_light, p_light = P(pick) · d² / (A cos θ_y) per unit solid angle (Veach 1997
// eq. 9.13; pathtrace.cpp's emitter hits), P(pick) that of NEE at the vertex `from` the sample
// left (Scene::light_pick_probability). An emitter triangle that is no light (none in
// Scene::lights) was not sampled by NEE: weight 1.
float EyeTracer::emitter_hit_weight(const Ray& ray, const Hit& h, const SurfaceHit& sh,
                                    const Vec3& from, float bsdf_pdf) const {
  const int32_t li = tri_light_.empty() ? -1 : tri_light_[size_t(sh.tri)];
  if (li < 0) return 1.f;
  const pf_light& l = scene_.lights[size_t(li)];
  const Vec3 d = normalize(ray.d);
  const float cos_l = -dot(d, sh.ng);
  if (!(cos_l > 0.f) || !(l.area > 0.f)) return 1.f;
  const float p_pick = scene_.light_pick_probability(size_t(li), from);
  const float dist = h.t * length(ray.d);
  const float p_light = p_pick * dist * dist / (l.area * cos_l);
  return pf_power_heuristic(bsdf_pdf, float(opt_.shadow_samples) * p_light);
}

// Emission sample k of pixel (x, y) (pixel_sampler.h PF_EMISSION_STREAM): the camera ray through
// its jitter (and lens point), followed through mirrors and glass as sample() follows it (the same
// specular_bounce), adding each emitter front it meets times the throughput. Unweighted.
Vec3 EyeTracer::emission_sample(int x, int y, int k) const {
  const int K = opt_.emission_spp;
  const uint32_t pix = uint32_t(size_t(y) * size_t(scene_.camera.width) + size_t(x));
  pf_rng rng = pf_emission_rng(opt_.seed, opt_.pass, pix, k, opt_.max_depth);
  float jx, jy;
  pf_sobol_pixel_sample_keyed(emission_key_, pix, opt_.pass * uint32_t(K) + uint32_t(k), &jx, &jy);
  float u1 = 0.5f, u2 = 0.5f;
  if (cam_.lens())  // the lens point stratified as the jitter (pixel_sampler.h)
    pf_eye_lens_keyed(PF_SAMPLER_SOBOL, emission_key_, opt_.pass, pix, k, K, &rng, &u1, &u2);
  Ray ray;
  cam_.ray(float(x) + jx, float(y) + jy, u1, u2, ray.o, ray.d);
  ray.leaf = camera_leaf_;
  Vec3 T(1.f, 1.f, 1.f), L;
  for (int depth = 0; depth <= opt_.max_depth; ++depth) {
    Hit h;
    if (!caster_.closest(ray, h)) {  // the environment, as sample() adds it to `emitted`
      if (scene_.environment.present()) L += T * scene_.environment_radiance(normalize(ray.d));
      break;
    }
    SurfaceHit sh = surface_at(scene_, ray, h);
    const pf_material& m = scene_.materials[size_t(sh.material)];
    if (m.type == PF_MAT_EMITTER && sh.front) L += T * Vec3(m.emission);
    if (m.type != PF_MAT_MIRROR && m.type != PF_MAT_GLASS) break;
    const Vec3 d = specular_bounce(m, sh, normalize(ray.d), &rng, T);
    if (luminance(T) <= 0.f) break;
    ray = spawn_ray(sh, d, eps_);
  }
  return L;
}

Vec3 EyeTracer::emitted_layer(int x, int y, const Vec3& emitted) const {
  if (!emit_pixels_ || !(*emit_pixels_)[size_t(y) * size_t(scene_.camera.width) + size_t(x)])
    return emitted;
  const int K = opt_.emission_spp;
  Vec3 sum;
  for (int k = 0; k < K; ++k) sum += emission_sample(x, y, k);
  const int n = samples(x, y);
  const float inv = 1.f / float(n + K);
  return emitted * (float(n) * inv) + sum * inv;
}

namespace {
// Whether a ray meets a surface that `found` accepts, directly or through mirrors and glass,
// following both branches at glass, reflection first: at most kEmissionDepth bounces deep and
// kEmissionRays rays per pixel in all (`rays` counts them down), so a scene full of glass costs
// a bounded, deterministic search; a chain past either bound counts as not meeting one.
// found(sh, m, d) is asked at every hit that is neither mirror nor glass (d the unit ray
// direction); the search ends there either way.
constexpr int kEmissionDepth = 8;
constexpr int kEmissionRays = 32;
template <class Found>
bool reaches(const Scene& scene, const RayCaster& caster, const Ray& ray, float eps, int depth,
             int& rays, const Found& found) {
  Hit h;
  if (depth > kEmissionDepth || rays <= 0) return false;
  --rays;
  if (!caster.closest(ray, h)) return false;
  const SurfaceHit sh = surface_at(scene, ray, h);
  const pf_material& m = scene.materials[size_t(sh.material)];
  const Vec3 d = normalize(ray.d);
  if (m.type != PF_MAT_MIRROR && m.type != PF_MAT_GLASS) return found(sh, m, d);
  const Vec3 n = sh.front ? sh.ns : -sh.ns;  // facing the ray
  if (reaches(scene, caster, spawn_ray(sh, reflect(d, n), eps), eps, depth + 1, rays, found))
    return true;
  if (m.type != PF_MAT_GLASS) return false;
  Vec3 t;
  const float eta = sh.front ? 1.f / m.ior : m.ior;
  if (!refract(d, n, eta, t)) return false;  // total internal reflection: the branch above
  return reaches(scene, caster, spawn_ray(sh, t, eps), eps, depth + 1, rays, found);
}

// The pixels whose centre ray (through the lens centre) `reaches` a surface `found` accepts, and
// their eight neighbours (an object's outline may cover a pixel whose centre misses it).
// Row-major, width × height, 1 = marked.
template <class Found>
std::vector<uint8_t> centre_ray_marks(const Scene& scene, const Found& found) {
  const int W = scene.camera.width, H = scene.camera.height;
  const CameraFrame cam(scene.camera);
  const RayCaster caster(scene);
  const int32_t camera_leaf = caster.leaf_at(Vec3(scene.camera.eye));
  const float eps = ray_epsilon(scene);
  std::vector<uint8_t> centre(size_t(W) * size_t(H), 0), marks(centre.size(), 0);
#pragma omp parallel for schedule(dynamic, 4) num_threads(worker_threads(0))
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      Ray ray;
      cam.ray(float(x) + 0.5f, float(y) + 0.5f, 0.5f, 0.5f, ray.o, ray.d);  // the lens centre
      ray.leaf = camera_leaf;
      int rays = kEmissionRays;
      centre[size_t(y) * size_t(W) + size_t(x)] = reaches(scene, caster, ray, eps, 0, rays, found);
    }
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      uint8_t m = 0;
      for (int yy = std::max(0, y - 1); yy <= std::min(H - 1, y + 1); ++yy)
        for (int xx = std::max(0, x - 1); xx <= std::min(W - 1, x + 1); ++xx)
          m |= centre[size_t(yy) * size_t(W) + size_t(xx)];
      marks[size_t(y) * size_t(W) + size_t(x)] = m;
    }
  return marks;
}
}  // namespace

std::vector<uint8_t> glossy_pixels(const Scene& scene) {
  if (!scene.has_pbr())
    return std::vector<uint8_t>(size_t(scene.camera.width) * size_t(scene.camera.height), 0);
  // A PF_MAT_PBR vertex whose merge probability is below kGlossySampleMaxMerge.
  return centre_ray_marks(scene, [&](const SurfaceHit& sh, const pf_material& m, const Vec3& d) {
    if (m.type != PF_MAT_PBR) return false;
    const pf_pbr_point pt = pbr_point_at(scene, m, sh);
    float ns[3], wo[3], o[3];
    sh.ns.store(ns);
    (-d).store(wo);
    pf_bsdf_to_local(ns, wo, o);
    return pf_merge_probability(&pt.params, o) < kGlossySampleMaxMerge;
  });
}

std::vector<uint8_t> emission_pixels(const Scene& scene) {
  // An emitter's front.
  return centre_ray_marks(scene, [](const SurfaceHit& sh, const pf_material& m, const Vec3&) {
    return m.type == PF_MAT_EMITTER && sh.front;
  });
}

void trace_hitpoints_into(const Scene& scene, const EyePassOptions& opt, EyePassResult& res,
                          EyePassWork& work) {
  const int W = scene.camera.width, H = scene.camera.height;
  const EyeTracer tracer(scene, opt);
  res.width = W;
  res.height = H;
  res.radius = tracer.radius();
  res.emitted.resize(size_t(W) * H * 3);  // every pixel writes its own below
  res.direct.resize(size_t(W) * H * 3);

  // Each image row collects its hitpoints in (pixel, sample) order; the rows are concatenated in
  // order afterwards, so the result does not depend on the thread count.
  std::vector<std::vector<pf_hitpoint>>& rows = work.rows;
  rows.resize(size_t(std::max(H, 0)));
  // The BSDF table only for a scene with a PBR material (eye_pass.h, EyePassResult::bsdf).
  const bool pbr = scene.has_pbr();
  std::vector<std::vector<pf_pbr_point>>& pbr_rows = work.pbr_rows;
  pbr_rows.resize(pbr ? rows.size() : 0);
  int threads = worker_threads(opt.threads);

#pragma omp parallel for schedule(dynamic, 4) num_threads(threads)
  for (int y = 0; y < H; ++y) {
    std::vector<pf_hitpoint>& row_buf = rows[size_t(y)];  // kept from the last call (work)
    row_buf.clear();
    std::vector<pf_pbr_point>* pbr_buf = pbr ? &pbr_rows[size_t(y)] : nullptr;
    if (pbr_buf) pbr_buf->clear();
    for (int x = 0; x < W; ++x) {
      Vec3 emitted, direct;
      const int spp = tracer.samples(x, y);
      for (int s = 0; s < spp; ++s) {
        pf_hitpoint& hp = row_buf.emplace_back();  // written in place (no copy of a temporary)
        if (pbr_buf) {
          pf_pbr_point pt;
          if (tracer.sample(x, y, s, hp, emitted, direct, &pt))
            pbr_buf->push_back(pt);
          else
            row_buf.pop_back();
          continue;
        }
        if (!tracer.sample(x, y, s, hp, emitted, direct)) row_buf.pop_back();
      }
      const size_t pix = size_t(y) * W + x;
      tracer.emitted_layer(x, y, emitted).store(&res.emitted[pix * 3]);
      direct.store(&res.direct[pix * 3]);
    }
  }
  std::vector<size_t> offset(rows.size() + 1, 0);
  for (size_t y = 0; y < rows.size(); ++y) offset[y + 1] = offset[y] + rows[y].size();
  res.hitpoints.resize(offset.back());
  res.bsdf.resize(pbr ? offset.back() : 0);
#pragma omp parallel for schedule(static) num_threads(threads)
  for (int y = 0; y < H; ++y) {
    std::copy(rows[size_t(y)].begin(), rows[size_t(y)].end(),
              res.hitpoints.begin() + long(offset[size_t(y)]));
    if (pbr)
      std::copy(pbr_rows[size_t(y)].begin(), pbr_rows[size_t(y)].end(),
                res.bsdf.begin() + long(offset[size_t(y)]));
  }
}

}  // namespace pf
