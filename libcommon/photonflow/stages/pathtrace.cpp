// Path tracing with next-event estimation: see pathtrace.h.
#include "photonflow/stages/pathtrace.h"

#include <omp.h>
#include <nlohmann/json.hpp>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "photonflow/geometry/camera.h"
#include "photonflow/geometry/light_shared.h"
#include "photonflow/foundations/error.h"
#include "photonflow/foundations/text_file.h"
#include "photonflow/io/provenance.h"
#include "photonflow/geometry/raycast.h"
#include "photonflow/foundations/rng.h"
#include "photonflow/sampling/path_sampler.h"
#include "photonflow/sampling/sampling.h"
#include "photonflow/geometry/surface.h"
#include "photonflow/foundations/threads.h"

namespace pf {

const char* mis_mode_name(MisMode m) { return m == MisMode::Off ? "off" : "power"; }

namespace {

// Camera paths per pass (at least one sample of every pixel): large enough that the per-pass
// cost (thread start, callbacks) is small, small enough for a responsive time limit. The image
// does not depend on it.
constexpr uint64_t kPathsPerPass = 1u << 16;

float max3(const Vec3& v) { return std::max(v.x, std::max(v.y, v.z)); }

// Diffuse as photon mapping defines it (eye_pass.cpp, photon_pass.cpp): Lambertian materials and
// emitters with a non-black colour under them.
bool is_diffuse(const pf_material& m) {
  return m.type == PF_MAT_DIFFUSE ||
         (m.type == PF_MAT_EMITTER && luminance(Vec3(m.color)) > 0.f);
}

// Power heuristic, β = 2 (Veach 1997, eq. 9.13): weight of the strategy with density `a` against
// one with density `b`.
float power_heuristic(float a, float b) {
  const float a2 = a * a, b2 = b * b;
  return a2 + b2 > 0.f ? a2 / (a2 + b2) : 0.f;
}

// Everything a path needs about the scene, computed once per run.
class PathTracer {
 public:
  PathTracer(const Scene& scene, const PathTraceOptions& opt)
      : scene_(scene),
        opt_(opt),
        eps_(ray_epsilon(scene)),
        caster_(scene),
        camera_leaf_(caster_.leaf_at(Vec3(scene.camera.eye))),
        env_(scene.environment.present()) {
    tri_light_.assign(scene.triangles.size(), -1);
    light_normal_.resize(scene.lights.size());
    for (size_t li = 0; li < scene.lights.size(); ++li) {
      const pf_light& l = scene.lights[li];
      if (l.type != PF_LIGHT_AREA) continue;
      const pf_triangle& t = scene.triangles[size_t(l.triangle)];
      light_normal_[li] = face_normal(t);
      tri_light_[size_t(l.triangle)] = int32_t(li);
    }
  }

  // The kd leaf of the eye point: the camera rays' Ray::leaf.
  int32_t camera_leaf() const { return camera_leaf_; }

  // One camera path starting with `ray` (unit direction), its numbers from `ps` (the bounce
  // dimensions of path_sampler.h). Returns its radiance estimate (W/(sr m²)); `rays` counts the
  // rays it cast.
  Vec3 radiance(Ray ray, const PathSampler& ps, uint64_t& rays) const {
    Vec3 L, T(1.f, 1.f, 1.f);  // radiance so far; throughput of the path prefix
    // How the current ray was generated: by the camera or a specular bounce (an emitter it hits
    // counts fully), or by a diffuse bounce with solid-angle density `bsdf_pdf` (an emitter it hits
    // counts only with MIS, weighted against the NEE that sampled it at the previous vertex;
    // `nee_could` is false when NEE there could not have produced this direction).
    bool specular = true, nee_could = false;
    float bsdf_pdf = 0.f;
    float eta_scale = 1.f;  // (η_i/η_o)² of the refractions so far (roulette)
    Vec3 nee_p;             // the previous vertex (its NEE's light choice, for MIS)
    for (int depth = 0;; ++depth) {
      Hit h;
      ++rays;
      if (!caster_.closest(ray, h)) {
        // The ray leaves the scene: the environment's radiance along it (0 without one;
        // environment_shared.h), fully after the camera or a specular bounce, MIS-weighted
        // against NEE (which samples the environment by pf_env_sample, density p_pick·pdf_ω)
        // after a diffuse or PBR bounce, and not at all there with MIS off (NEE alone).
        if (env_) {
          const Vec3 d = normalize(ray.d);
          const Vec3 le = scene_.environment_radiance(d);
          if (specular) {
            L += T * le;
          } else if (opt_.mis == MisMode::Power) {
            // NEE's density of d at the vertex the ray left, with that vertex's light choice.
            const float light_pdf = nee_could ? scene_.environment_light_pdf(d, nee_p) : 0.f;
            L += T * le * power_heuristic(bsdf_pdf, light_pdf);
          }
        }
        break;
      }
      const SurfaceHit sh = surface_at(scene_, ray, h);
      const pf_material& m = scene_.materials[size_t(sh.material)];
      const Vec3 d = normalize(ray.d);

      // Emitted radiance L_e (the first term of the rendering equation), one-sided.
      if (m.type == PF_MAT_EMITTER && sh.front) {
        const Vec3 le(m.emission);
        if (specular) {
          L += T * le;
        } else if (opt_.mis == MisMode::Power) {
          float w = 1.f;
          const int32_t li = tri_light_[size_t(sh.tri)];
          if (nee_could && li >= 0) {
            // The light-sampling density of this point, per unit solid angle at the previous
            // vertex: p_l · dist² / (A · cos θ_y).
            const pf_light& l = scene_.lights[size_t(li)];
            const float cos_l = -dot(d, light_normal_[size_t(li)]);
            const float p_pick = scene_.light_pick_probability(size_t(li), nee_p);
            const float dist = h.t * length(ray.d);
            const float light_pdf = cos_l > 0.f ? p_pick * dist * dist / (l.area * cos_l) : 0.f;
            w = power_heuristic(bsdf_pdf, light_pdf);
          }
          L += T * le * w;
        }
      }
      if (depth >= opt_.max_depth) break;

      if (is_diffuse(m)) {
        const Vec3 n = sh.front ? sh.ns : -sh.ns;   // shading normal facing the arriving ray
        const Vec3 ng = sh.front ? sh.ng : -sh.ng;  // geometric normal on the same side
        const Vec3 albedo = diffuse_color(scene_, m, sh);  // textured albedo
        // Next-event estimation: L_direct = f_r · (one light sample), f_r = ρ/π.
        L += T * albedo * kInvPi * sample_light(sh.p, n, ng, sh.leaf, ps, depth, rays);
        // Continue with f_r·cos/pdf = ρ (cosine sampling around n), after Russian roulette.
        T = T * albedo;
        if (!(max3(T) > 0.f) || !roulette(depth, T, eta_scale, ps)) break;
        float u1, u2;
        ps.get2(PathSampler::at(depth, PathSampler::kBsdfDirection), u1, u2);
        const Vec3 wi = sample_cosine_hemisphere(n, u1, u2);
        const float cos_x = dot(wi, n);
        if (!(cos_x > 0.f)) break;  // grazing: density 0
        bsdf_pdf = pdf_cosine_hemisphere(cos_x);
        nee_could = dot(wi, ng) > 0.f;  // sample_light refuses directions below the surface
        nee_p = sh.p;
        specular = false;
        ray = spawn_ray(sh, wi, eps_);
      } else if (m.type == PF_MAT_PBR) {
        // The glTF BSDF (bsdf_shared.h) in the front shading frame (pbr_scatter_shared.h):
        // NEE with f (the light dimensions, as sample_light), then the BSDF's sample (its
        // direction dimension u1, u2 and its lobe dimension u3), then Russian roulette.
        const pf_bsdf_params params = bsdf_params_at(scene_, m, sh);
        PbrFrame fr;
        sh.ns.store(fr.ns);
        sh.ng.store(fr.ng);
        (-d).store(fr.wo);
        L += T * sample_light_pbr(sh.p, sh.ng, sh.leaf, params, fr, ps, depth, rays);
        float u1, u2;
        ps.get2(PathSampler::at(depth, PathSampler::kBsdfDirection), u1, u2);
        const float u3 = ps.get1(PathSampler::at(depth, PathSampler::kLobe));
        float wi[3], w[3], pdf;
        if (!pf_pbr_scatter(&params, fr.ns, fr.ng, fr.wo, u1, u2, u3, PF_TRANSPORT_RADIANCE, wi,
                            w, &pdf))
          break;
        T = T * Vec3(w);
        const Vec3 dir(wi);
        if (params.transmission > 0.f && (dot(dir, sh.ng) > 0.f) != sh.front)  // refracted
          eta_scale *= sh.front ? params.ior * params.ior : 1.f / (params.ior * params.ior);
        if (!(max3(T) > 0.f) || !roulette(depth, T, eta_scale, ps)) break;
        bsdf_pdf = pdf;
        nee_could = true;  // NEE at a PBR point reaches every direction the BSDF samples
        nee_p = sh.p;
        specular = false;
        ray = spawn_ray(sh, dir, eps_);
      } else if (m.type == PF_MAT_MIRROR || m.type == PF_MAT_GLASS) {
        const uint32_t lobe = PathSampler::at(depth, PathSampler::kLobe);
        const Vec3 wo = specular_bounce_with(m, sh, d, [&] { return ps.get1(lobe); }, T);
        if (!(max3(T) > 0.f)) break;
        if (!roulette(depth, T, eta_scale, ps)) break;
        specular = true;
        ray = spawn_ray(sh, wo, eps_);
      } else {
        break;  // a black emitter absorbs
      }
    }
    return L;
  }

 private:
  // Lights a BSDF-sampled ray can reach (area lights, the environment): their NEE samples are
  // MIS-weighted; the others are delta lights, NEE's alone.
  static bool hittable(const pf_light& l) {
    return l.type == PF_LIGHT_AREA || l.type == PF_LIGHT_ENVIRONMENT;
  }

  // Russian roulette after rr_depth bounces (Arvo & Kirk 1990): survive with probability
  // q = min(1, max channel of T·η_scale) and divide T by q. η_scale undoes the
  // radiance's (η_o/η_i)² at every rough-glass refraction (pbrt-v3's etaScale, Mitsuba 3's η²):
  // the roulette sees the path's energy throughput, so that a path which has just left a glass
  // object (T ×2.25 at η = 1.5) is not exempt from it, nor one inside it penalised.
  bool roulette(int depth, Vec3& T, float eta_scale, const PathSampler& ps) const {
    if (depth < opt_.rr_depth) return true;
    const float q = std::min(1.f, max3(T) * eta_scale);
    if (!(q > 0.f)) return false;
    if (q >= 1.f) return true;
    if (ps.get1(PathSampler::at(depth, PathSampler::kRoulette)) >= q) return false;
    T = T * (1.f / q);
    return true;
  }

  // The numbers of the light sample at bounce `depth`: the light's choice ul (1-D) and the point
  // on it (u1, u2; 2-D).
  static void light_numbers(const PathSampler& ps, int depth, float& ul, float& u1, float& u2) {
    ul = ps.get1(PathSampler::at(depth, PathSampler::kLightPick));
    ps.get2(PathSampler::at(depth, PathSampler::kLightPoint), u1, u2);
  }

  // One light sample for a diffuse point p (shading normal n and geometric normal ng on the side
  // of the arriving ray): incident radiance times cos θ_x over the sample's density (solid angle),
  // MIS-weighted for area lights and the environment under MisMode::Power. Multiply by f_r for
  // L_direct. The same estimator as eye_pass.cpp's direct_light (one sample; its shadow ray and
  // cut-offs), with the sample's radiance ls.le (the map's, for the environment).
  Vec3 sample_light(const Vec3& p, const Vec3& n, const Vec3& ng, int32_t leaf,
                    const PathSampler& ps, int depth, uint64_t& rays) const {
    float ul, u1, u2;
    light_numbers(ps, depth, ul, u1, u2);
    Scene::LightSample ls;
    if (!scene_.sample_light(ul, u1, u2, p, ls)) return {};  // light_shared.h
    const pf_light& l = scene_.lights[ls.light];
    const float cos_x = dot(ls.w, n);
    if (cos_x <= 0.f || dot(ls.w, ng) <= 0.f) return {};
    const float g = cos_x * ls.g / ls.p_light;  // cos θ_x / density, without visibility
    float w = 1.f;  // MIS weight; delta lights: NEE is their only strategy
    if (hittable(l) && opt_.mis == MisMode::Power)  // solid-angle densities
      w = power_heuristic(ls.p_light / ls.g, pdf_cosine_hemisphere(cos_x));
    const Vec3 o = p + ng * eps_;
    ++rays;
    if (caster_.any(Ray{o, ls.q - o, 0.f, 1.f - 1e-4f, leaf})) return {};
    return ls.le * (g * w);
  }

  // NEE at a PF_MAT_PBR point (radiance mode): sample_light's draws, light choice and point, and
  // its shadow ray, with f(wo, w_l) of the BSDF instead of ρ/π and |cos θ_x| at the shading
  // normal; a light behind the surface counts where the BSDF transmits (the shadow ray leaves on
  // its side). Area lights and the environment are MIS-weighted against the BSDF's density
  // pf_bsdf_pdf (power heuristic); point, spot and directional lights are NEE's alone. Returns
  // f·L_e·|cos θ_x|·w / density.
  struct PbrFrame {
    float ns[3], ng[3], wo[3];  // front shading and geometric normals, direction to the eye
  };
  Vec3 sample_light_pbr(const Vec3& p, const Vec3& ng_front, int32_t leaf,
                        const pf_bsdf_params& params, const PbrFrame& fr,
                        const PathSampler& ps, int depth, uint64_t& rays) const {
    float ul, u1, u2;
    light_numbers(ps, depth, ul, u1, u2);
    Scene::LightSample ls;
    if (!scene_.sample_light(ul, u1, u2, p, ls)) return {};  // light_shared.h
    const pf_light& l = scene_.lights[ls.light];
    float wv[3], f[3];
    ls.w.store(wv);
    pf_pbr_eval_world(&params, fr.ns, fr.ng, fr.wo, wv, f);
    if (!(f[0] > 0.f || f[1] > 0.f || f[2] > 0.f)) return {};
    const float g = std::fabs(dot(ls.w, Vec3(fr.ns))) * ls.g / ls.p_light;
    float w = 1.f;
    if (hittable(l) && opt_.mis == MisMode::Power)
      w = power_heuristic(ls.p_light / ls.g, pf_pbr_pdf_world(&params, fr.ns, fr.ng, fr.wo, wv));
    const Vec3 o = p + ng_front * (dot(ls.w, ng_front) >= 0.f ? eps_ : -eps_);
    ++rays;
    if (caster_.any(Ray{o, ls.q - o, 0.f, 1.f - 1e-4f, leaf})) return {};
    return Vec3(f) * ls.le * (g * w);
  }

  const Scene& scene_;
  const PathTraceOptions& opt_;
  const float eps_;
  const RayCaster caster_;
  const int32_t camera_leaf_;
  const bool env_;                  // the scene has an environment light
  std::vector<int32_t> tri_light_;  // light index of an emissive triangle, −1 otherwise
  std::vector<Vec3> light_normal_;  // unit front normal of each area light
};

void check_options(const PathTraceOptions& opt) {
  if (opt.spp < 1) throw input_error("", "--spp must be positive, got " + std::to_string(opt.spp));
  if (opt.max_depth < 0)
    throw input_error("", "--max-depth must be >= 0, got " + std::to_string(opt.max_depth));
  if (opt.rr_depth < 0)
    throw input_error("", "--rr-depth must be >= 0, got " + std::to_string(opt.rr_depth));
  if (opt.snapshot_every < 0)
    throw input_error("", "--snapshot-every must be >= 0, got " +
                              std::to_string(opt.snapshot_every));
  if (!(opt.time_limit_s >= 0.0))
    throw input_error("", "--time must be >= 0, got " + std::to_string(opt.time_limit_s));
}

}  // namespace

Image pathtrace(const Scene& scene, const PathTraceOptions& opt,
                const PathTraceCallbacks& callbacks, PathTraceStatus* status_out) {
  check_options(opt);
  const int W = scene.camera.width, H = scene.camera.height;
  const char* why = nullptr;
  if (!camera_valid(scene.camera, &why)) throw input_error(scene.source, why);
  const size_t npix = size_t(W) * size_t(H);
  const CameraFrame cam(scene.camera);
  const PathTracer tracer(scene, opt);
  const int threads = worker_threads(opt.threads);

  // Per-pixel sums in double: RGB, and luminance and its square (for the variance layer).
  std::vector<double> sum(3 * npix, 0.0), lum(npix, 0.0), lum2(npix, 0.0);
  PathTraceStatus st;
  st.target = opt.spp;
  Stopwatch clock;

  auto make_image = [&]() {
    Image img(W, H);
    std::vector<float>& samples = img.layer("samples");
    std::vector<float>& var = img.layer("variance");
    const double n = double(st.samples);
    for (size_t i = 0; i < npix; ++i) {
      for (int c = 0; c < 3; ++c) img.rgb[3 * i + size_t(c)] = float(sum[3 * i + size_t(c)] / n);
      samples[i] = float(st.samples);
      if (st.samples >= 2) {
        const double mean = lum[i] / n;
        const double s2 = std::max(0.0, (lum2[i] - n * mean * mean) / (n - 1.0));
        var[i] = float(s2 / n);
      }
    }
    return img;
  };

  const uint32_t sampler_key = PathSampler::key(opt.sampler, opt.seed);
  const int per_pass = int(std::max<uint64_t>(1, kPathsPerPass / std::max<size_t>(npix, 1)));
  while (st.samples < opt.spp) {
    int batch = std::min(per_pass, opt.spp - st.samples);
    if (opt.snapshot_every > 0)  // end passes on snapshot boundaries
      batch = std::min(batch, opt.snapshot_every - st.samples % opt.snapshot_every);
    const int s0 = st.samples;
    uint64_t rays = 0, nonfinite = 0;
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads) reduction(+ : rays, nonfinite)
    for (int y = 0; y < H; ++y) {
      for (int x = 0; x < W; ++x) {
        const size_t pix = size_t(y) * size_t(W) + size_t(x);
        for (int s = s0; s < s0 + batch; ++s) {
          const PathSampler ps(opt.sampler, sampler_key,
                               pf_rng_key(opt.seed, kPathStream + uint32_t(s)), uint32_t(pix),
                               uint32_t(s));
          // Box filter: a uniform point in the pixel; a thin lens: a uniform point on the lens.
          float jx, jy, u1 = 0.5f, u2 = 0.5f;
          ps.get2(PathSampler::kCameraPixel, jx, jy);
          if (cam.lens()) ps.get2(PathSampler::kCameraLens, u1, u2);
          Ray ray;
          cam.ray(float(x) + jx, float(y) + jy, u1, u2, ray.o, ray.d);
          ray.leaf = tracer.camera_leaf();
          Vec3 v = tracer.radiance(ray, ps, rays);
          if (!finite(v)) {
            ++nonfinite;
            v = Vec3();
          }
          const double l = double(luminance(v));
          sum[3 * pix] += v.x;
          sum[3 * pix + 1] += v.y;
          sum[3 * pix + 2] += v.z;
          lum[pix] += l;
          lum2[pix] += l * l;
        }
      }
    }
    st.samples += batch;
    st.paths += uint64_t(batch) * npix;
    st.rays += rays;
    st.nonfinite += nonfinite;
    st.seconds = clock.seconds();
    if (callbacks.on_progress) callbacks.on_progress(st);
    if (opt.snapshot_every > 0 && st.samples % opt.snapshot_every == 0 && callbacks.on_snapshot)
      callbacks.on_snapshot(make_image(), st);
    if (opt.time_limit_s > 0.0 && st.seconds >= opt.time_limit_s && st.samples < opt.spp) {
      st.timed_out = true;
      break;
    }
  }
  if (status_out) *status_out = st;
  return make_image();
}


std::string pathtrace_record_json(const Provenance& prov,
                                  const std::vector<PathTraceImageRecord>& images) {
  Json doc = provenance_json(prov);
  Json list = Json::array();
  for (const auto& im : images) {
    const PathTraceStatus& s = im.status;
    Json entry = Json::object();
    entry["path"] = im.path;
    entry["samples"] = s.samples;
    entry["target"] = s.target;
    entry["seconds"] = json_value(s.seconds);
    entry["paths"] = s.paths;
    entry["rays"] = s.rays;
    entry["nonfinite"] = s.nonfinite;
    entry["timed_out"] = s.timed_out;
    list.push_back(std::move(entry));
  }
  doc["images"] = std::move(list);
  return json_record_text(doc);
}

void write_pathtrace_record(const std::string& path, const Provenance& prov,
                            const std::vector<PathTraceImageRecord>& images) {
  const std::string text = pathtrace_record_json(prov, images);
  write_text_atomic(path, text);
}

}  // namespace pf
