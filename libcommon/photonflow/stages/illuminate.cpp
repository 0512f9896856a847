// Hitpoint illumination: see illuminate.h.
#include "photonflow/stages/illuminate.h"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstring>

#ifdef __SSE2__
#include <immintrin.h>
#endif

#include "photonflow/estimators/ppm.h"
#include "photonflow/sampling/sampling.h"
#include "photonflow/geometry/surface.h"
#include "photonflow/foundations/threads.h"

namespace pf {

namespace {

// f_r of the hitpoint's surface: Lambertian albedo / π. Every entry point checks the hitpoints'
// material (and mesh) ids against the scene first (check_against_scene), so the index is valid.
Vec3 brdf(const Scene& s, const pf_hitpoint& hp) {
  return Vec3(s.materials[size_t(hp.material)].color) * kInvPi;
}

void finish_pass(HitpointSet& h, uint64_t emitted) {
  h.photons_emitted += emitted;
  h.passes += 1;
  h.estimator = "ppm";
}


// Eq. 3.17 over the m accepted photons photon(0), ..., photon(m−1), which the caller lists in
// increasing original photon index (the same order for every gather method and thread count, so
// the sums are reproducible and the grid and FLANN gathers agree to the bit): τ_M = Σ f_r·Φ_p,
// each term one float product summed in double, rounded to float at the end.
template <class PhotonAt>
inline void sum_flux(const Vec3& fr, size_t m, PhotonAt&& photon, float tau_m[3]) {
  double tau[3] = {0, 0, 0};
  for (size_t k = 0; k < m; ++k) {
    const pf_photon& p = photon(k);
    tau[0] += double(fr.x * p.flux[0]);
    tau[1] += double(fr.y * p.flux[1]);
    tau[2] += double(fr.z * p.flux[2]);
  }
  tau_m[0] = float(tau[0]);
  tau_m[1] = float(tau[1]);
  tau_m[2] = float(tau[2]);
}

// The sum of m float terms term(k, c), per channel c, in the order given (sum_flux's terms fr·Φ_p,
// sum_terms' f·Φ_p), when it is exact: then it equals the sum in every order,
// the plain sums' included, bit for bit. Each term is a float, a multiple of its ulp 2^(e−23) where
// 2^e is its binade; every partial sum of m terms is then a multiple of the smallest ulp and below
// m · 2^(E+1) for the largest binade 2^E, so it is exact in double's 53 bits when
// E − e_min + 24 + ⌈log2 m⌉ <= 53 (zero terms add nothing; the biased exponent field of a
// subnormal counts as 1, as its ulp does). Returns false, tau_m unset, otherwise — for a channel
// whose terms span more binades than that, or one that is not finite.
template <class TermAt>
inline bool sum_if_exact(size_t m, TermAt&& term, float tau_m[3]) {
  double tau[3] = {0, 0, 0};
  uint32_t lo[3] = {255, 255, 255}, hi[3] = {0, 0, 0};
  for (size_t k = 0; k < m; ++k) {
    for (int c = 0; c < 3; ++c) {
      const float t = term(k, c);
      tau[c] += double(t);
      uint32_t bits;
      std::memcpy(&bits, &t, 4);
      const uint32_t e = std::max<uint32_t>((bits >> 23) & 0xffu, 1u);
      if ((bits & 0x7fffffffu) == 0) continue;  // ±0
      lo[c] = std::min(lo[c], e);
      hi[c] = std::max(hi[c], e);
    }
  }
  uint32_t log2m = 0;
  while ((size_t(1) << log2m) < m) ++log2m;
  for (int c = 0; c < 3; ++c)
    if (hi[c] >= 255u || (hi[c] >= lo[c] && hi[c] - lo[c] + 24u + log2m > 53u)) return false;
  for (int c = 0; c < 3; ++c) tau_m[c] = float(tau[c]);
  return true;
}

// sum_flux's terms fr·Φ_p through sum_if_exact.
template <class PhotonAt>
inline bool sum_flux_if_exact(const Vec3& fr, size_t m, PhotonAt&& photon, float tau_m[3]) {
  const float f[3] = {fr.x, fr.y, fr.z};
  return sum_if_exact(m, [&](size_t k, int c) { return f[c] * photon(k).flux[c]; }, tau_m);
}

// Eq. 3.17 (sum_flux), then eq. 3.14, 3.16, 3.18.
template <class PhotonAt>
inline void gather_update(pf_hitpoint& hp, const Vec3& fr, size_t m, PhotonAt&& photon,
                          float alpha) {
  float tau_m[3];
  sum_flux(fr, m, photon, tau_m);
  pf_ppm_update(&hp, int(m), tau_m, alpha);  // eq. 3.14, 3.16, 3.18
}

// A PBR hitpoint's term for photon p (illuminate.h): f(x, ω_o = −hp.dir, ω_p = −p.dir)·Φ_p, one
// float product per channel (HJ09 eq. 10–11, thesis eq. 3.17).
inline void pbr_term(const pf_pbr_point& pt, const pf_hitpoint& hp, const pf_photon& p,
                     float t[3]) {
  const float wo[3] = {-hp.dir[0], -hp.dir[1], -hp.dir[2]};
  const float wi[3] = {-p.dir[0], -p.dir[1], -p.dir[2]};
  float f[3];
  pf_pbr_point_eval(&pt, hp.normal, wo, wi, f);
  for (int c = 0; c < 3; ++c) t[c] = f[c] * p.flux[c];
}

// Σ of m float terms (3 per term) in double, in the order given, rounded to float.
inline void sum_terms(const float* terms, size_t m, float tau_m[3]) {
  double tau[3] = {0, 0, 0};
  for (size_t k = 0; k < m; ++k)
    for (int c = 0; c < 3; ++c) tau[c] += double(terms[3 * k + size_t(c)]);
  for (int c = 0; c < 3; ++c) tau_m[c] = float(tau[c]);
}

// sum_terms when that sum is exact (the argument of sum_if_exact), false otherwise.
inline bool sum_terms_if_exact(const float* terms, size_t m, float tau_m[3]) {
  return sum_if_exact(m, [&](size_t k, int c) { return terms[3 * k + size_t(c)]; }, tau_m);
}

// Sorts distinct keys ascending. The lists are short (tens of photons) and made of a few
// ascending runs (one per grid bin), where insertion sort beats std::sort; long ones use the
// latter.
void sort_keys(uint64_t* k, size_t n) {
  if (n > 64) {
    std::sort(k, k + n);
    return;
  }
  for (size_t i = 1; i < n; ++i) {
    if (k[i - 1] < k[i]) continue;
    const uint64_t x = k[i];
    size_t j = i;
    do {
      k[j] = k[j - 1];
      --j;
    } while (j > 0 && k[j - 1] > x);
    k[j] = x;
  }
}

}  // namespace

void check_alpha(float alpha) {
  if (!(alpha > 0.f && alpha <= 1.f))
    throw input_error("", "alpha must be in (0, 1], got " + std::to_string(alpha));
}

void require_sphere(float slab) {
  if (slab != 0.f)
    throw input_error("", "--slab applies to --estimator sppm and pppm",
                      "ppm gathers in the sphere alone, the thesis's rule");
}

void check_slab(float slab) {
  if (!(slab >= 0.f) || !std::isfinite(slab))
    throw input_error("", "--slab must be 0 (the sphere alone) or a positive number, got " +
                              std::to_string(slab));
}

void ppm_pass_grid(const Scene& scene, HitpointSet& h, const PhotonGrid& grid, uint64_t emitted,
                   const PpmOptions& opt) {
  check_against_scene("", h, scene);
  ppm_pass_grid_prechecked(scene, h, grid, emitted, opt);
}

const pf_pbr_point* pbr_of(const Scene& scene, const pf_hitpoint& hp,
                           const std::vector<pf_pbr_point>& table, size_t i) {
  if (hp.material < 0 || scene.materials[size_t(hp.material)].type != PF_MAT_PBR) return nullptr;
  if (i >= table.size())
    throw input_error("", "hitpoint " + std::to_string(i) +
                              " lies on a PBR material but the hitpoints carry no BSDF for it",
                      "remake them with trace-hitpoints from this scene");
  return &table[i];
}

void require_bsdf_table(const Scene& scene, const std::vector<pf_hitpoint>& hitpoints,
                        const std::vector<pf_pbr_point>& table) {
  if (table.size() == hitpoints.size() || !scene.has_pbr()) return;
  for (size_t i = 0; i < hitpoints.size(); ++i) pbr_of(scene, hitpoints[i], table, i);
}

void gather_weight(const Scene& scene, const PpmOptions& opt, const pf_hitpoint& v, float radius,
                   const pf_pbr_point* pbr, float w[3]) {
  for (int c = 0; c < 3; ++c) w[c] = v.weight[c];
  if (opt.gather_area != GatherArea::Surface) return;
  const float g =
      float(surface_area(scene).scale(v, radius, opt.slab, pbr_two_sided_gather(pbr)));
  for (int c = 0; c < 3; ++c) w[c] *= g;
}

int gather_site(const Scene& scene, const PhotonGrid& grid, const pf_hitpoint& site, float radius,
                bool skip_direct, float slab, float tau_m[3], const pf_pbr_point* pbr) {
  tau_m[0] = tau_m[1] = tau_m[2] = 0.f;
  const int mesh = site.mesh;
  const int mesh_count = int(grid.mesh_grid.size());
  if (mesh < 0 || mesh >= mesh_count || !(radius >= 0.f)) return 0;  // nothing to gather
  const pf_mesh_grid& g = grid.mesh_grid[size_t(mesh)];
  if (g.photon_count == 0) return 0;
  const pf_photon* photons = grid.photons.data();
  const int32_t* order = grid.order.data();
  const int32_t* cell_start = grid.cell_start.data();
  // Per-thread work space, kept from call to call.
  thread_local std::vector<int32_t> cand;   // sorted-array indices of the accepted photons
  thread_local std::vector<uint64_t> keys;  // (original index << 32) | sorted index: sum order
  const float q[3] = {site.position[0], site.position[1], site.position[2]};
  const float nrm[3] = {site.normal[0], site.normal[1], site.normal[2]};
  // The bin box of PhotonGrid::for_each_in_radius (see there for the padding).
  const float pad = radius * 1.0001f;
  int lo[3], hi3[3];
  const int n[3] = {g.nx, g.ny, g.nz};
  for (int a = 0; a < 3; ++a) {
    lo[a] = grid_coord(q[a] - pad, g.lo[a], g.bin_size, n[a]);
    hi3[a] = grid_coord(q[a] + pad, g.lo[a], g.bin_size, n[a]);
  }
  // The rest of the rule for a photon inside the sphere. facing: its own mesh, not a direct
  // photon when shadow rays give direct light, arriving at the front (photon_accepted).
  // accepted: facing and, with a slab (κ > 0), within κR of the tangent plane (pf_ppm_in_slab).
  const bool both_sides = pbr_two_sided_gather(pbr);  // a transmissive PBR point (illuminate.h)
  const auto facing = [&](int32_t i) {
    const pf_photon& p = photons[i];
    if (skip_direct && (p.flags & PF_PHOTON_DIRECT) != 0) return false;
    return photon_faces(p, mesh, nrm, both_sides);
  };
  const auto accepted = [&](int32_t i) {
    const pf_photon& p = photons[i];
    return facing(i) &&
           (!(slab > 0.f) ||
            pf_ppm_in_slab(q[0] - p.position[0], q[1] - p.position[1], q[2] - p.position[2],
                           nrm[0], nrm[1], nrm[2], slab, radius) != 0);
  };
  size_t m = 0;
#ifdef __SSE2__
  // Four photons per instruction from the grid's position arrays: the lanes evaluate
  // pf_ppm_dist2's ((dx·dx + dy·dy) + dz·dz) and pf_ppm_in_radius's d² <= R·R, and with a slab
  // pf_ppm_in_slab's |(dx·nx + dy·ny) + dz·nz| <= κ·R, with the same single-precision operations,
  // so the photons inside are the same bit for bit; the few inside then take the rest of the
  // rule one by one (facing), the only reads of their pf_photon before the sum.
  const bool four = grid.has_positions();
  const float* const px = grid.pos_x.data();
  const float* const py = grid.pos_y.data();
  const float* const pz = grid.pos_z.data();
  const __m128 qx = _mm_set1_ps(q[0]), qy = _mm_set1_ps(q[1]), qz = _mm_set1_ps(q[2]);
  const __m128 r2 = _mm_set1_ps(radius * radius);
  const bool use_slab = slab > 0.f;
  const __m128 nx = _mm_set1_ps(nrm[0]), ny = _mm_set1_ps(nrm[1]), nz = _mm_set1_ps(nrm[2]);
  const __m128 half = _mm_set1_ps(slab * radius);
  const __m128 abs_mask = _mm_castsi128_ps(_mm_set1_epi32(0x7fffffff));
#else
  const bool four = false;
#endif
  for (int z = lo[2]; z <= hi3[2]; ++z) {
    for (int y = lo[1]; y <= hi3[1]; ++y) {
      const int row = g.first_bin + (y + z * g.ny) * g.nx;
      const int begin = cell_start[row + lo[0]];
      const int end = cell_start[row + hi3[0] + 1];  // bins lo..hi of a row are contiguous
      if (cand.size() < m + size_t(end - begin)) cand.resize(2 * (m + size_t(end - begin)));
      int32_t* out = cand.data();
      if (four) {
#ifdef __SSE2__
        for (int i = begin; i < end; i += 4) {  // lanes past `end` read the padding, masked off
          const __m128 dx = _mm_sub_ps(qx, _mm_loadu_ps(px + i));
          const __m128 dy = _mm_sub_ps(qy, _mm_loadu_ps(py + i));
          const __m128 dz = _mm_sub_ps(qz, _mm_loadu_ps(pz + i));
          const __m128 d2 = _mm_add_ps(_mm_add_ps(_mm_mul_ps(dx, dx), _mm_mul_ps(dy, dy)),
                                       _mm_mul_ps(dz, dz));
          __m128 in = _mm_cmple_ps(d2, r2);
          if (use_slab) {
            const __m128 h = _mm_add_ps(_mm_add_ps(_mm_mul_ps(dx, nx), _mm_mul_ps(dy, ny)),
                                        _mm_mul_ps(dz, nz));
            in = _mm_and_ps(in, _mm_cmple_ps(_mm_and_ps(h, abs_mask), half));
          }
          unsigned inside = unsigned(_mm_movemask_ps(in));
          if (end - i < 4) inside &= (1u << (end - i)) - 1u;
          for (; inside; inside &= inside - 1u) {
            const int32_t j = i + int32_t(__builtin_ctz(inside));
            _mm_prefetch(reinterpret_cast<const char*>(photons + j), _MM_HINT_T0);
            out[m++] = j;
          }
        }
#endif
        continue;
      }
      for (int i = begin; i < end; ++i) {
        const pf_photon& p = photons[i];
        out[m] = i;
        m += pf_ppm_in_radius(pf_ppm_dist2(q[0], q[1], q[2], p.position[0], p.position[1],
                                           p.position[2]),
                              radius) != 0 && accepted(i)
                 ? 1
                 : 0;
      }
    }
  }
  if (four) {  // the rest of the rule over the photons inside, whose lines are on their way
    size_t kept = 0;
    for (size_t j = 0; j < m; ++j) {
      cand[kept] = cand[j];
      kept += facing(cand[j]) ? 1 : 0;
    }
    m = kept;
  }
  if (m == 0) return 0;
  if (pbr) {
    // f·Φ per photon (HJ09 eq. 10–11), evaluated once per candidate; summed as below.
    thread_local std::vector<float> terms;
    if (terms.size() < 3 * m) terms.resize(6 * m);
    float* t = terms.data();
    for (size_t j = 0; j < m; ++j) pbr_term(*pbr, site, photons[cand[j]], t + 3 * j);
    if (sum_terms_if_exact(t, m, tau_m)) return int(m);
    // Sum order: original photon index; low bits: the candidate's slot j.
    if (keys.size() < m) keys.resize(2 * m);
    uint64_t* k = keys.data();
    for (size_t j = 0; j < m; ++j) k[j] = (uint64_t(uint32_t(order[cand[j]])) << 32) | uint32_t(j);
    sort_keys(k, m);
    thread_local std::vector<float> sorted;
    if (sorted.size() < 3 * m) sorted.resize(6 * m);
    for (size_t j = 0; j < m; ++j)
      for (int c = 0; c < 3; ++c) sorted[3 * j + size_t(c)] = t[3 * uint32_t(k[j]) + size_t(c)];
    sum_terms(sorted.data(), m, tau_m);
    return int(m);
  }
  // Eq. 3.17 as sum_flux sums it, in the candidates' order first: when that sum is exact it is
  // the sum in any order, so sum_flux's order (original photon index) gives the same bits and the
  // sort is not needed.
  const Vec3 fr = brdf(scene, site);
  if (sum_flux_if_exact(fr, m, [&](size_t j) -> const pf_photon& { return photons[cand[j]]; },
                        tau_m))
    return int(m);
  // Sum order: original photon index. The candidates come as one ascending run per bin.
  if (keys.size() < m) keys.resize(2 * m);
  uint64_t* k = keys.data();
  for (size_t j = 0; j < m; ++j)
    k[j] = (uint64_t(uint32_t(order[cand[j]])) << 32) | uint32_t(cand[j]);
  sort_keys(k, m);
  sum_flux(fr, m, [&](size_t j) -> const pf_photon& { return photons[uint32_t(k[j])]; }, tau_m);
  return int(m);
}

void ppm_pass_grid_prechecked(const Scene& scene, HitpointSet& h, const PhotonGrid& grid,
                              uint64_t emitted, const PpmOptions& opt) {
  check_alpha(opt.alpha);
  require_sphere(opt.slab);
  require_bsdf_table(scene, h.hitpoints, h.bsdf);
  const bool skip_direct = h.direct_mode == DirectMode::ShadowRays;
  const float alpha = opt.alpha;
  const int64_t count = int64_t(h.hitpoints.size());
  // The grid holds the photons sorted by bin. Each hitpoint scans the bins of its sphere's box
  // (the bins PhotonGrid::for_each_in_radius visits), keeps the photons that pass the gather rule
  // (pf_ppm_in_radius and photon_accepted) without branching, orders them by original photon
  // index (grid.order) and sums them in that order, exactly as the FLANN gather does.
#pragma omp parallel for schedule(dynamic, 256) num_threads(worker_threads(opt.threads))
  for (int64_t hi = 0; hi < count; ++hi) {
    pf_hitpoint& hp = h.hitpoints[size_t(hi)];
    float tau_m[3];
    const pf_pbr_point* pbr = h.bsdf.empty() ? nullptr : pbr_of(scene, hp, h.bsdf, size_t(hi));
    const int m = gather_site(scene, grid, hp, hp.radius, skip_direct, 0.f, tau_m, pbr);  // sphere
    pf_ppm_update(&hp, m, tau_m, alpha);  // eq. 3.14, 3.16, 3.18 (m = 0: unchanged)
  }
  finish_pass(h, emitted);
}

PhotonGridParams ppm_grid_params(const HitpointSet& h, const PpmOptions& opt) {
  PhotonGridParams gp;
  gp.max_bins = opt.max_bins;
  gp.default_radius = h.radius0 > 0.f ? h.radius0 : 1e-3f;
  return gp;
}

void ppm_pass(const Scene& scene, HitpointSet& h, const std::vector<pf_photon>& photons,
              uint64_t emitted, const PpmOptions& opt) {
  check_alpha(opt.alpha);
  require_sphere(opt.slab);
  if (opt.method != GatherMethod::Grid && opt.method != GatherMethod::Flann)
    throw input_error("", std::string("--method ") + gather_method_name(opt.method) +
                              " runs on the OpenCL backend", "add --device opencl, or use --method grid or flann");
  if (opt.method == GatherMethod::Grid) {
    const PhotonGridParams gp = ppm_grid_params(h, opt);
    // The calling thread's grid, reused by its next pass (no reallocation in a stream of passes).
    thread_local PhotonGrid grid;
    build_photon_grid_into(grid, photons, int(scene.mesh_names.size()), gp, opt.threads);
    ppm_pass_grid(scene, h, grid, emitted, opt);
    return;
  }
  check_against_scene("", h, scene);
  const bool skip_direct = h.direct_mode == DirectMode::ShadowRays;
  const float alpha = opt.alpha;
  const int64_t count = int64_t(h.hitpoints.size());
  PhotonMap map(photons);
#pragma omp parallel num_threads(worker_threads(opt.threads))
  {
    thread_local std::vector<int32_t> idx;  // per-thread work space, kept from pass to pass
    thread_local std::vector<float> terms;
#pragma omp for schedule(dynamic, 256)
    for (int64_t i = 0; i < count; ++i) {
      pf_hitpoint& hp = h.hitpoints[size_t(i)];
      const pf_pbr_point* pbr = h.bsdf.empty() ? nullptr : pbr_of(scene, hp, h.bsdf, size_t(i));
      map.gather_radius(hp.position, hp.radius, hp.mesh, idx);  // increasing photon index
      size_t m = 0;
      const bool both = pbr_two_sided_gather(pbr);
      for (int32_t j : idx)  // keep the accepted ones, in order
        if (photon_accepted(hp, photons[size_t(j)], skip_direct, both)) idx[m++] = j;
      if (pbr) {  // f·Φ per photon in increasing photon index (gather_site's sum)
        terms.resize(3 * m);
        for (size_t k = 0; k < m; ++k) pbr_term(*pbr, hp, photons[size_t(idx[k])], &terms[3 * k]);
        float tau_m[3];
        sum_terms(terms.data(), m, tau_m);
        pf_ppm_update(&hp, int(m), tau_m, alpha);  // eq. 3.14, 3.16, 3.18
        continue;
      }
      gather_update(hp, brdf(scene, hp), m,
                    [&](size_t k) -> const pf_photon& { return photons[size_t(idx[k])]; },
                    alpha);
    }
  }
  finish_pass(h, emitted);
}

void classic_estimate(const Scene& scene, HitpointSet& h, const std::vector<pf_photon>& photons,
                      uint64_t emitted, const ClassicOptions& opt) {
  if (opt.k <= 0) throw input_error("", "k must be positive, got " + std::to_string(opt.k));
  check_against_scene("", h, scene);
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
#pragma omp parallel for schedule(dynamic, 256) num_threads(worker_threads(opt.threads))
  for (size_t i = 0; i < h.hitpoints.size(); ++i) {
    pf_hitpoint& hp = h.hitpoints[i];
    Vec3 fr = brdf(scene, hp);
    // A PBR hitpoint's f depends on the photon's direction (illuminate.h): f·Φ per photon.
    const pf_pbr_point* pbr = h.bsdf.empty() ? nullptr : pbr_of(scene, hp, h.bsdf, i);
    const bool both = pbr_two_sided_gather(pbr);
    const auto terms = [&](const pf_photon& p, float t[3]) {
      if (pbr) {
        pbr_term(*pbr, hp, p, t);
        return;
      }
      for (int c = 0; c < 3; ++c) t[c] = fr[c] * p.flux[c];
    };
    thread_local std::vector<int32_t> idx;
    thread_local std::vector<float> d2;
    double tau[3] = {0, 0, 0};
    int used = 0;
    float r2 = 0.f;
    if (k > 0) {
      r2 = gmap.knn(hp.position, k, idx, d2, opt.eps);  // squared distance of the k-th photon
      for (int32_t j : idx) {
        const pf_photon& p = global[size_t(j)];
        if (!both &&
            p.dir[0] * hp.normal[0] + p.dir[1] * hp.normal[1] + p.dir[2] * hp.normal[2] >= 0.f)
          continue;  // arrived from the other side
        ++used;
        float t[3];
        terms(p, t);
        for (int c = 0; c < 3; ++c) tau[c] += double(t[c]);
      }
    }
    float rg = r2 > 0.f ? std::sqrt(r2) : rc;
    // Caustic map, fixed radius rc; rescaled by (rg/rc)² so one radius serves eq. 3.19.
    if (!caustic.empty()) {
      cmap.radius_search(hp.position, rc, idx, opt.eps);
      double scale = double(rg) * rg / (double(rc) * rc);
      for (int32_t j : idx) {
        const pf_photon& p = caustic[size_t(j)];
        if (!both &&
            p.dir[0] * hp.normal[0] + p.dir[1] * hp.normal[1] + p.dir[2] * hp.normal[2] >= 0.f)
          continue;
        ++used;
        float t[3];
        terms(p, t);
        for (int c = 0; c < 3; ++c) tau[c] += double(t[c]) * scale;
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
