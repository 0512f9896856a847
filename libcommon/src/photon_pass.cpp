// Photon tracing: see photon_pass.h.
#include "photonflow/photon_pass.h"

#include <omp.h>

#include <algorithm>
#include <cmath>

#include "photonflow/rng.h"
#include "photonflow/sampling.h"
#include "photonflow/surface.h"

namespace pf {

namespace {

// Emits photon `index`: picks a light by power and samples a ray and its flux.
bool emit(const Scene& scene, pf_rng& rng, Ray& ray, Vec3& flux, float eps) {
  float ul = pf_rng_next(&rng), u1 = pf_rng_next(&rng), u2 = pf_rng_next(&rng);
  float u3 = pf_rng_next(&rng), u4 = pf_rng_next(&rng);
  size_t li = size_t(std::upper_bound(scene.light_cdf.begin(), scene.light_cdf.end(), ul) -
                     scene.light_cdf.begin());
  li = std::min(li, scene.lights.size() - 1);
  const pf_light& l = scene.lights[li];
  float p_light = scene.light_cdf[li] - (li ? scene.light_cdf[li - 1] : 0.f);
  if (p_light <= 0.f) return false;
  if (l.type == PF_LIGHT_AREA) {
    const pf_triangle& t = scene.triangles[size_t(l.triangle)];
    Vec3 p = sample_triangle(Vec3(t.v0), Vec3(t.v1), Vec3(t.v2), u1, u2);
    Vec3 n = normalize(cross(Vec3(t.v1) - Vec3(t.v0), Vec3(t.v2) - Vec3(t.v0)));
    Vec3 d = sample_cosine_hemisphere(n, u3, u4);
    ray = Ray{p + n * eps, d};
    // Φ = L · A · π for a one-sided Lambertian emitter (cosine sampling: L·cos/pdf = L·π).
    flux = Vec3(l.radiance) * (l.area * kPi / p_light);
  } else {
    ray = Ray{Vec3(l.position), sample_uniform_sphere(u1, u2)};
    flux = Vec3(l.radiance) * (4.f * kPi / p_light);  // Φ = 4π · I
  }
  return true;
}

}  // namespace

PhotonPassResult trace_photons(const Scene& scene, uint32_t pass, const PhotonPassOptions& opt) {
  PhotonPassResult res;
  res.emitted = opt.photons;
  if (scene.lights.empty() || opt.photons == 0) return res;
  const float eps = ray_epsilon(scene);
  // Fixed-size chunks of photon indices, concatenated in chunk order: the output order does not
  // depend on the thread count or on scheduling.
  const uint32_t chunk = 4096;
  const uint32_t nchunks = (opt.photons + chunk - 1) / chunk;
  std::vector<std::vector<pf_photon>> parts(nchunks);
  int threads = opt.threads > 0 ? opt.threads : omp_get_max_threads();

#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
  for (uint32_t c = 0; c < nchunks; ++c) {
    std::vector<pf_photon>& out = parts[c];
    uint32_t end = std::min(opt.photons, (c + 1) * chunk);
    for (uint32_t i = c * chunk; i < end; ++i) {
      pf_rng rng = pf_rng_start(opt.seed, pass, i);
      Ray ray;
      Vec3 flux;
      if (!emit(scene, rng, ray, flux, eps)) continue;
      bool specular_only = true;  // every bounce so far was specular (caustic path)
      bool first_hit = true;
      for (int bounce = 0; bounce <= opt.max_bounces; ++bounce) {
        Hit h;
        if (!intersect_closest(scene, ray, h)) break;
        SurfaceHit sh = surface_at(scene, ray, h);
        const pf_material& m = scene.materials[size_t(sh.material)];
        Vec3 d = normalize(ray.d);
        Vec3 n = sh.front ? sh.ns : -sh.ns;  // facing the incoming photon
        Vec3 color(m.color);
        bool diffuse = m.type == PF_MAT_DIFFUSE ||
                       (m.type == PF_MAT_EMITTER && luminance(color) > 0.f);
        if (diffuse) {
          pf_photon ph{};
          sh.p.store(ph.position);
          d.store(ph.dir);
          flux.store(ph.flux);
          ph.mesh = sh.mesh;
          ph.pass = int32_t(pass);
          ph.flags = (first_hit ? PF_PHOTON_DIRECT : 0) |
                     (!first_hit && specular_only ? PF_PHOTON_CAUSTIC : 0);
          out.push_back(ph);
          // Russian roulette by albedo.
          float p = std::max(color.x, std::max(color.y, color.z));
          if (pf_rng_next(&rng) >= p) break;
          flux = flux * color * (1.f / p);
          d = sample_cosine_hemisphere(n, pf_rng_next(&rng), pf_rng_next(&rng));
          specular_only = false;
        } else if (m.type == PF_MAT_MIRROR) {
          flux = flux * color;
          d = reflect(d, n);
        } else if (m.type == PF_MAT_GLASS) {
          float eta_i = sh.front ? 1.f : m.ior, eta_t = sh.front ? m.ior : 1.f;
          float F = fresnel_dielectric(-dot(d, n), eta_i, eta_t);
          Vec3 t;
          if (pf_rng_next(&rng) < F || !refract(d, n, eta_i / eta_t, t)) {
            d = reflect(d, n);
          } else {
            d = normalize(t);
            flux = flux * color;
          }
        } else {
          break;  // black emitter absorbs
        }
        first_hit = false;
        if (luminance(flux) <= 0.f) break;
        ray = Ray{offset_origin(sh, d, eps), d};
      }
    }
  }
  size_t total = 0;
  for (auto& p : parts) total += p.size();
  res.photons.reserve(total);
  for (auto& p : parts) res.photons.insert(res.photons.end(), p.begin(), p.end());
  return res;
}

}  // namespace pf
