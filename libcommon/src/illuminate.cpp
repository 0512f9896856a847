// Hitpoint illumination: see illuminate.h.
#include "photonflow/illuminate.h"

#include <omp.h>

#include <algorithm>
#include <cmath>

#include "photonflow/ppm.h"
#include "photonflow/sampling.h"

namespace pf {

const char* gather_name(Gather g) { return g == Gather::Grid ? "grid" : "flann"; }

namespace {

int thread_count(int t) { return t > 0 ? t : omp_get_max_threads(); }

// f_r of the hitpoint's surface: Lambertian albedo / π.
Vec3 brdf(const Scene& s, const pf_hitpoint& hp) {
  return Vec3(s.materials[size_t(hp.material)].color) * kInvPi;
}

// Applies eq. 3.14–3.18 to hitpoint i given the photons `gather(i, visit)` reports.
template <class GatherFn>
void ppm_update_all(const Scene& scene, HitpointSet& h, const std::vector<pf_photon>& photons,
                    float alpha, int threads, GatherFn&& gather) {
  const bool skip_direct = h.direct_mode == DirectMode::ShadowRays;
#pragma omp parallel for schedule(dynamic, 256) num_threads(threads)
  for (size_t i = 0; i < h.hitpoints.size(); ++i) {
    pf_hitpoint& hp = h.hitpoints[i];
    Vec3 fr = brdf(scene, hp);
    int m = 0;
    double tau[3] = {0, 0, 0};  // summed in a fixed order (photon index order): reproducible
    gather(hp, [&](int32_t j) {
      const pf_photon& p = photons[size_t(j)];
      if (!photon_accepted(hp, p, skip_direct)) return;
      ++m;
      tau[0] += double(fr.x * p.flux[0]);
      tau[1] += double(fr.y * p.flux[1]);
      tau[2] += double(fr.z * p.flux[2]);
    });
    const float tau_m[3] = {float(tau[0]), float(tau[1]), float(tau[2])};
    pf_ppm_update(&hp, m, tau_m, alpha);  // eq. 3.14, 3.16, 3.18
  }
}

void finish_pass(HitpointSet& h, uint64_t emitted) {
  h.photons_emitted += emitted;
  h.passes += 1;
  h.estimator = "ppm";
}

void check_alpha(float alpha) {
  if (!(alpha > 0.f && alpha <= 1.f))
    throw input_error("", "alpha must be in (0, 1], got " + std::to_string(alpha));
}

}  // namespace

void ppm_pass_grid(const Scene& scene, HitpointSet& h, const PhotonGrid& grid, uint64_t emitted,
                   const PpmOptions& opt) {
  check_alpha(opt.alpha);
  // The grid's photons are sorted by bin; visiting them in sorted-index order would make the sum
  // order differ from FLANN's. Gather indices first, sort them by original photon index, then sum.
  ppm_update_all(scene, h, grid.photons, opt.alpha, thread_count(opt.threads),
                 [&](const pf_hitpoint& hp, auto&& visit) {
                   thread_local std::vector<int32_t> idx;
                   idx.clear();
                   grid.for_each_in_radius(hp.mesh, hp.position, hp.radius,
                                           [&](int i) { idx.push_back(i); });
                   std::sort(idx.begin(), idx.end(),
                             [&](int32_t a, int32_t b) { return grid.order[a] < grid.order[b]; });
                   for (int32_t i : idx) visit(i);
                 });
  finish_pass(h, emitted);
}

void ppm_pass(const Scene& scene, HitpointSet& h, const std::vector<pf_photon>& photons,
              uint64_t emitted, const PpmOptions& opt) {
  check_alpha(opt.alpha);
  if (opt.gather == Gather::Grid) {
    PhotonGridParams gp;
    gp.max_bins = opt.max_bins;
    gp.default_radius = h.radius0 > 0.f ? h.radius0 : 1e-3f;
    PhotonGrid grid = build_photon_grid(photons, int(scene.mesh_names.size()), gp);
    ppm_pass_grid(scene, h, grid, emitted, opt);
    return;
  }
  PhotonMap map(photons);
  ppm_update_all(scene, h, photons, opt.alpha, thread_count(opt.threads),
                 [&](const pf_hitpoint& hp, auto&& visit) {
                   thread_local std::vector<int32_t> idx;
                   map.gather_radius(hp.position, hp.radius, hp.mesh, idx);
                   std::sort(idx.begin(), idx.end());
                   for (int32_t i : idx) visit(i);
                 });
  finish_pass(h, emitted);
}

void classic_estimate(const Scene& scene, HitpointSet& h, const std::vector<pf_photon>& photons,
                      uint64_t emitted, const ClassicOptions& opt) {
  if (opt.k <= 0) throw input_error("", "k must be positive, got " + std::to_string(opt.k));
  const bool skip_direct = h.direct_mode == DirectMode::ShadowRays;
  std::vector<pf_photon> global, caustic;
  for (auto& p : photons) {
    if (p.flags & PF_PHOTON_CAUSTIC)
      caustic.push_back(p);
    else if (!(skip_direct && (p.flags & PF_PHOTON_DIRECT)))
      global.push_back(p);
  }
  PhotonMap gmap(global), cmap(caustic);
  const float rc = opt.caustic_radius > 0.f ? opt.caustic_radius : h.radius0;
  const int k = std::min<int>(opt.k, int(global.size()));
#pragma omp parallel for schedule(dynamic, 256) num_threads(thread_count(opt.threads))
  for (size_t i = 0; i < h.hitpoints.size(); ++i) {
    pf_hitpoint& hp = h.hitpoints[i];
    Vec3 fr = brdf(scene, hp);
    thread_local std::vector<int32_t> idx;
    thread_local std::vector<float> d2;
    double tau[3] = {0, 0, 0};
    int used = 0;
    float r2 = 0.f;
    if (k > 0) {
      r2 = gmap.knn(hp.position, k, idx, d2, opt.eps);  // squared distance of the k-th photon
      for (int32_t j : idx) {
        const pf_photon& p = global[size_t(j)];
        if (p.dir[0] * hp.normal[0] + p.dir[1] * hp.normal[1] + p.dir[2] * hp.normal[2] >= 0.f)
          continue;  // arrived from the other side
        ++used;
        for (int c = 0; c < 3; ++c) tau[c] += double(fr[c] * p.flux[c]);
      }
    }
    float rg = r2 > 0.f ? std::sqrt(r2) : rc;
    // Caustic map, fixed radius rc; rescaled by (rg/rc)² so one radius serves eq. 3.19.
    if (!caustic.empty()) {
      cmap.radius_search(hp.position, rc, idx, opt.eps);
      double scale = double(rg) * rg / (double(rc) * rc);
      for (int32_t j : idx) {
        const pf_photon& p = caustic[size_t(j)];
        if (p.dir[0] * hp.normal[0] + p.dir[1] * hp.normal[1] + p.dir[2] * hp.normal[2] >= 0.f)
          continue;
        ++used;
        for (int c = 0; c < 3; ++c) tau[c] += double(fr[c] * p.flux[c]) * scale;
      }
    }
    hp.radius = rg;
    hp.n_photons = float(used);
    for (int c = 0; c < 3; ++c) hp.flux[c] = float(tau[c]);
  }
  h.photons_emitted = emitted;
  h.passes = 1;
  h.estimator = "classic";
}

}  // namespace pf
