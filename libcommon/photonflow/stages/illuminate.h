// illuminate.h — hitpoint illumination: the photon-density estimates of classic photon mapping
// (thesis ch. 3.4, eq. 3.10) and of progressive photon mapping (thesis eq. 3.14–3.18).
//
// Which photons a hitpoint gathers (the same rule for every gather method, so methods agree):
//   - |x_p − x|² ≤ R² (ppm.h's pf_ppm_in_radius),
//   - the photon lies on the hitpoint's mesh (the thesis's per-mesh gather, ch. 7.3),
//   - it arrived on the hitpoint's side of the surface: dot(photon.dir, hitpoint.normal) < 0,
//   - with DirectMode::ShadowRays, photons flagged PF_PHOTON_DIRECT are skipped (direct light
//     already came from shadow rays).
// Each gathered photon contributes f_r·Φ_p with the Lambertian f_r = albedo/π (eq. 3.17).
//
// At a hitpoint on a PF_MAT_PBR surface (its material's type; the hitpoints then carry the BSDF
// table, HitpointSet::bsdf / EyePassResult::bsdf, pbr_point_shared.h) the photon's term is
// f(x, ω_o, ω_p)·Φ_p with ω_o = −hitpoint.dir and ω_p = −photon.dir, the BSDF in radiance mode
// evaluated per photon (HJ09 eq. 10–11; thesis eq. 3.17 with the direction-dependent f_r):
//   τ_M = Σ_p f(x, −d_hp, −d_p) Φ_p,
// each term one float product per channel (f_c·Φ_c), summed in double in increasing photon index
// (or in any order when that sum is exact, as for diffuse hitpoints). The side rule is the same,
// except where the BSDF transmits (transmission > 0 and metallic < 1 at the point): photons from
// both sides are gathered there, and f (zero for the side a lobe cannot reach) weighs them.
// Diffuse hitpoints take exactly the code path (and bits) they took before.
#pragma once
#include <cstdint>
#include <vector>

#include "photonflow/estimators/gather_area.h"
#include "photonflow/stages/gather_method.h"
#include "photonflow/stages/hash_grid.h"
#include "photonflow/material/pbr_point_shared.h"
#include "photonflow/stages/photon_grid.h"
#include "photonflow/stages/photon_map.h"
#include "photonflow/geometry/scene.h"
#include "photonflow/io/stage_files.h"

namespace pf {

struct ClusterSet;  // clusters.h

struct PpmOptions {
  float alpha = 0.7f;  // fraction of new photons kept, eq. 3.14 (0 < α ≤ 1)
  // sppm and pppm: the gather region's slab half-thickness κ in units of R (ppm.h,
  // pf_ppm_in_slab); 0 = the sphere alone (the thesis's rule, which ppm always uses).
  float slab = 0.f;
  // sppm and pppm: what the gathered flux is divided by (estimators/gather_area.h): the disc πR²
  // (the thesis's eq. 3.17, which ppm always uses) or the surface the gather region holds.
  GatherArea gather_area = GatherArea::Disc;
  // How photons are found (gather_method.h): grid | flann on the CPU backend, the thesis's
  // variants and hash-grid on the OpenCL backend (cl_backend.h). All select the same photons.
  GatherMethod method = GatherMethod::Grid;
  int max_bins = 64;   // grid bins along a mesh's longest extent (eq. 7.1)
  int threads = 0;     // 0 = all cores
  // Device cluster methods (kmeans-clusters, grid-kmeans, grid-gridclusters): the clusters of
  // these hitpoints (from the cluster stage or made once by the caller). ppm_pass refreshes their
  // radii from the hitpoints' current radii (update_cluster_radii) before it gathers. nullptr:
  // ppm_pass makes them for this pass only (cluster_kmeans with cluster_iterations Lloyd steps,
  // or cluster_grid with max_bins) with the context's work-group size.
  ClusterSet* clusters = nullptr;
  int cluster_iterations = 10;
  // hash-grid: slots of the hash table, a power of two; 0 = automatic (hash_grid_layout: about
  // the photon count, adjusted so that every cell gets a slot of its own where that is cheap).
  // Fewer slots mean more cells per slot (more photons read and skipped), never a wrong result.
  int hash_slots = 0;
  // hash-grid: cell side in units of the largest hitpoint radius (> 0). Smaller cells fit the
  // gather spheres tighter (fewer photons tested) but each sphere's box spans more cells.
  float hash_cell = 2.f;
  // hash-grid: who orders the photons (hash_grid.h): auto = the host on a CPU device (PoCL, which
  // shares the host's cores and memory), the device's kernels otherwise. Same arrays either way.
  HashOrder hash_order = HashOrder::Auto;
};

// One PPM iteration (eq. 3.14–3.18) of every hitpoint over one pass's photons, gathering through
// a grid (built here) or FLANN (opt.method grid | flann; InputError for a device method). Adds `emitted` to h.photons_emitted and counts the pass.
void ppm_pass(const Scene& scene, HitpointSet& h, const std::vector<pf_photon>& photons,
              uint64_t emitted, const PpmOptions& opt);
// The grid parameters ppm_pass builds its grid with for `h`: opt.max_bins, and the initial
// radius R0 as the smallest bin size (eq. 7.1).
PhotonGridParams ppm_grid_params(const HitpointSet& h, const PpmOptions& opt);
// The same iteration with a prebuilt grid (from build-grid).
void ppm_pass_grid(const Scene& scene, HitpointSet& h, const PhotonGrid& grid, uint64_t emitted,
                   const PpmOptions& opt);
// ppm_pass_grid without its check of the hitpoints' mesh and material ids against the scene
// (check_against_scene, O(hitpoints): 6 ms a pass at 1920×1080), for a caller that made that
// check once and then gathers pass after pass into the same hitpoints, whose ids a pass never
// changes: the render driver (ProgressiveRenderer).
void ppm_pass_grid_prechecked(const Scene& scene, HitpointSet& h, const PhotonGrid& grid,
                              uint64_t emitted, const PpmOptions& opt);

// InputError unless 0 < alpha <= 1 (eq. 3.14; the estimators of sppm.h too).
void check_alpha(float alpha);
// InputError naming --slab unless slab is 0 or a finite positive number.
void check_slab(float slab);
// InputError unless slab is 0: the PPM passes (ppm_pass, the device's) gather in the sphere.
void require_sphere(float slab);

// The slab of sppm and pppm when --slab is not given: measured on the diffuse box, it removes the
// bias of photons from a block's top face gathered below its edge (docs/RESULTS.md "A new eye pass every pass")
// and leaves the spheres and the pool unchanged.
constexpr float kDefaultSlab = 0.25f;

// The gather of one site from a prebuilt grid, the core of ppm_pass_grid and of the per-pixel
// estimators (sppm.h): the photons that `site` (its position, normal, mesh and material) accepts
// within `radius` (the rule above), and their τ_M = Σ f_r·Φ_p (eq. 3.17) into tau_m, summed in
// increasing photon index as every gather method sums. Returns M, the photons gathered. The
// caller has checked the site's material against the scene; a mesh outside the grid gathers none.
// `slab` > 0 cuts the sphere to the slab |n·(x − x_p)| <= slab·radius (pf_ppm_in_slab).
// `pbr`: the BSDF at a PF_MAT_PBR site (pbr_of), nullptr at a diffuse one.
int gather_site(const Scene& scene, const PhotonGrid& grid, const pf_hitpoint& site, float radius,
                bool skip_direct, float slab, float tau_m[3], const pf_pbr_point* pbr = nullptr);

// The throughput a visible point v's gathered τ_M is multiplied by, per channel: β = v.weight
// itself with the disc (the same bits as before the option existed), β·πR²/A(x, R) with
// opt.gather_area surface (gather_area.h eq. 3; A with opt.slab, both sides at a transmissive
// PBR point). Every route (CPU, device, staged) multiplies τ_M by these floats, so they agree.
void gather_weight(const Scene& scene, const PpmOptions& opt, const pf_hitpoint& v, float radius,
                   const pf_pbr_point* pbr, float w[3]);

// The BSDF entry of hitpoint i (`hp`) in `table` (parallel to the hitpoints) when hp lies on a
// PF_MAT_PBR material, nullptr otherwise (a diffuse hitpoint, or an SPPM pixel not reached yet).
// InputError when hp is on a PBR material but the table lacks the entry. hp.material must be a
// valid index or negative (check_against_scene).
const pf_pbr_point* pbr_of(const Scene& scene, const pf_hitpoint& hp,
                           const std::vector<pf_pbr_point>& table, size_t i);

// InputError (before any parallel gather, where an exception cannot travel) unless every
// hitpoint on a PF_MAT_PBR material has its entry in `table` (parallel to `hitpoints`); free
// when the table has one entry per hitpoint or the scene has no PBR material.
void require_bsdf_table(const Scene& scene, const std::vector<pf_hitpoint>& hitpoints,
                        const std::vector<pf_pbr_point>& table);

// Whether a PBR point gathers photons from both sides of its surface (its BSDF transmits).
inline bool pbr_two_sided_gather(const pf_pbr_point* pbr) {
  return pbr && pbr->params.metallic < 1.f && pbr->params.transmission > 0.f;
}

struct ClassicOptions {
  int k = 100;                  // nearest global photons per estimate (eq. 3.10)
  float caustic_radius = 0.f;   // fixed radius of the caustic estimate; 0 = the hitpoints' R0
  float eps = 0.f;              // FLANN approximate-search epsilon
  int threads = 0;
};

// Classic photon mapping (eq. 3.10): global map by k nearest neighbours (caustic photons
// excluded), caustic map by a fixed radius. Writes the estimate into the hitpoint state so that
// synthesis applies eq. 3.19 unchanged: radius = distance to the k-th photon, flux = the summed
// f_r·Φ with the caustic part rescaled to that radius, n_photons = photons used.
void classic_estimate(const Scene& scene, HitpointSet& h, const std::vector<pf_photon>& photons,
                      uint64_t emitted, const ClassicOptions& opt);

// True when photon `p` may contribute to hitpoint `hp` (the rule above, without the distance);
// both_sides: a transmissive PBR point (pbr_two_sided_gather) skips the side test.
// The mesh and side part of it: `p` lies on `mesh` and arrives at the front of unit normal `n`
// (or both_sides). The gathers and the photon guide's visible set (photon_guide.h) call it.
inline bool photon_faces(const pf_photon& p, int32_t mesh, const float n[3], bool both_sides) {
  if (p.mesh != mesh) return false;
  return both_sides || p.dir[0] * n[0] + p.dir[1] * n[1] + p.dir[2] * n[2] < 0.f;
}
inline bool photon_accepted(const pf_hitpoint& hp, const pf_photon& p, bool skip_direct,
                            bool both_sides = false) {
  if (skip_direct && (p.flags & PF_PHOTON_DIRECT)) return false;
  return photon_faces(p, hp.mesh, hp.normal, both_sides);
}

}  // namespace pf
