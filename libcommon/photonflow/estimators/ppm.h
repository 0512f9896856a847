/*
 * ppm.h — progressive photon mapping arithmetic shared by the C++ host and OpenCL C 1.2 kernels
 * (thesis ch. 3.4–3.5; Hachisuka et al. 2008):
 *   - the gather rule: a photon belongs to a hitpoint's disc when distance² <= R², with distance²
 *     computed by pf_ppm_dist2 (every gatherer — grid, FLANN map, kernels — uses these two
 *     functions, so they select exactly the same photons); sppm and pppm may cut the sphere to
 *     a slab about the tangent plane (pf_ppm_in_slab);
 *   - the per-pass hitpoint update, eq. 3.14, 3.16, 3.18;
 *   - the radiance estimates, eq. 3.19 (progressive) and eq. 3.10 (classic photon map).
 * Only a hitpoint's own mesh is gathered from (thesis ch. 7.3, photons sorted per mesh); see
 * photon_grid.h.
 */
#ifndef PHOTONFLOW_PPM_H
#define PHOTONFLOW_PPM_H

#include "photonflow/foundations/cl_compat.h"
#include "photonflow/foundations/shared_types.h"

/* Square root: the OpenCL built-in, std::sqrt (float overload) on the host. */
#ifdef __OPENCL_VERSION__
#define PF_SQRT(x) sqrt(x)
#else
#include <cmath>
#define PF_SQRT(x) std::sqrt(x)
#endif

#define PF_PI 3.14159265358979323846f

/* Squared distance between points a and b, evaluated as ((dx·dx + dy·dy) + dz·dz) with every
 * operation rounded to single precision — no fused multiply-add, so host and device agree to the
 * bit. OpenCL C contracts a·b + c into an FMA by default (PoCL does), hence the pragma, scoped to
 * this function body. The host relies on its target having no FMA by default (x86-64 baseline);
 * a host build with -march=native or -mfma must add -ffp-contract=off. */
PF_INLINE pf_float pf_ppm_dist2(pf_float ax, pf_float ay, pf_float az, pf_float bx, pf_float by,
                                pf_float bz) {
#ifdef __OPENCL_VERSION__
#pragma OPENCL FP_CONTRACT OFF
#endif
  pf_float dx = ax - bx;
  pf_float dy = ay - by;
  pf_float dz = az - bz;
  return dx * dx + dy * dy + dz * dz;
}

/* The gather rule: inside (boundary included) when distance² <= radius·radius. */
PF_INLINE int pf_ppm_in_radius(pf_float dist2, pf_float radius) {
  return dist2 <= radius * radius;
}

/* The slab of the estimators that trace a new eye pass every pass (sppm.h, `--slab κ`): with
 * κ > 0 a photon inside the sphere counts only when it also lies within κ·R of the visible
 * point's tangent plane, |n·(x − x_p)| <= κ·R, with (dx, dy, dz) = x − x_p and n the visible
 * point's normal, evaluated as ((dx·nx + dy·ny) + dz·nz) without FMA (as pf_ppm_dist2). The
 * sphere alone takes photons from another face of the same mesh — below a box's top edge, the
 * front face gathers the top face's photons as if they lay on its own plane, a bias that fades
 * only as R falls below the pixel — while a flat or gently curved surface keeps every photon of
 * the disc (a sphere of radius ρ departs from the tangent plane by R²/2ρ < κ·R while R < 2κρ).
 * κ = 0: no slab, the thesis's sphere (PPM's rule). The hashed-grid kernel tests its four lanes
 * with the same operations (illuminate_methods.cl, pf_gather_keyed). */
PF_INLINE int pf_ppm_in_slab(pf_float dx, pf_float dy, pf_float dz, pf_float nx, pf_float ny,
                             pf_float nz, pf_float slab, pf_float radius) {
#ifdef __OPENCL_VERSION__
#pragma OPENCL FP_CONTRACT OFF
#endif
  pf_float h = dx * nx + dy * ny + dz * nz;
  if (!(slab > 0.0f)) return 1;
  return (h < 0.0f ? -h : h) <= slab * radius;
}

/* Progressive update of one hitpoint after a photon pass that put `m` new photons carrying the
 * summed BRDF-weighted flux tau_m = Σ f_r·Φ_p (eq. 3.17) inside its radius R:
 *   ratio = (N + αM)/(N + M)
 *   N̂ = N + αM            (eq. 3.14)
 *   R̂ = R·sqrt(ratio)      (eq. 3.16)
 *   τ̂ = (τ_N + τ_M)·ratio  (eq. 3.18)
 * α ∈ (0, 1] is the fraction of new photons kept (0.7 is usual; α = 1 keeps R fixed). A pass that
 * found no photons (m = 0) leaves the hitpoint unchanged. The device gives the host's bits where
 * it rounds division and sqrt correctly (cl_float_options adds the build option that asks for
 * it): N + αM is not contracted into an FMA (the pragma, as in pf_ppm_dist2), every other step
 * is one rounded operation. */
PF_INLINE pf_ppm_state pf_ppm_updated(pf_ppm_state s, pf_int m, const pf_float tau_m[3],
                                      pf_float alpha) {
#ifdef __OPENCL_VERSION__
#pragma OPENCL FP_CONTRACT OFF
#endif
  if (m <= 0) return s;
  pf_float n = s.n_photons;
  pf_float mf = (pf_float)m;
  pf_float n_new = n + alpha * mf;
  pf_float ratio = n_new / (n + mf);
  s.n_photons = n_new;
  s.radius = s.radius * PF_SQRT(ratio);
  s.flux[0] = (s.flux[0] + tau_m[0]) * ratio;
  s.flux[1] = (s.flux[1] + tau_m[1]) * ratio;
  s.flux[2] = (s.flux[2] + tau_m[2]) * ratio;
  return s;
}

/* The same update on a hitpoint's fields, and on a split state (pf_ppm_state, the hashed-grid
 * gather's): one arithmetic, so both give the same bits. */
PF_INLINE void pf_ppm_update(PF_GLOBAL pf_hitpoint* hp, pf_int m, const pf_float tau_m[3],
                             pf_float alpha) {
  if (m <= 0) return;
  pf_ppm_state s = {hp->radius, hp->n_photons, {hp->flux[0], hp->flux[1], hp->flux[2]}};
  s = pf_ppm_updated(s, m, tau_m, alpha);
  hp->radius = s.radius;
  hp->n_photons = s.n_photons;
  hp->flux[0] = s.flux[0];
  hp->flux[1] = s.flux[1];
  hp->flux[2] = s.flux[2];
}

PF_INLINE void pf_ppm_update_state(PF_GLOBAL pf_ppm_state* st, pf_int m, const pf_float tau_m[3],
                                   pf_float alpha) {
  if (m <= 0) return;
  *st = pf_ppm_updated(*st, m, tau_m, alpha);
}

/* Reflected radiance of one channel of a hitpoint, eq. 3.19: L = τ / (π R² N_emitted), where
 * N_emitted counts the photons emitted in all passes so far (photon fluxes are not divided by the
 * photon count when they are emitted). Returns 0 before any photon was emitted. */
PF_INLINE pf_float pf_ppm_radiance(pf_float tau, pf_float radius, pf_float n_emitted) {
  if (n_emitted <= 0.0f || radius <= 0.0f) return 0.0f;
  return tau / (PF_PI * radius * radius * n_emitted);
}

/* Classic photon-map radiance estimate of one channel, eq. 3.10: L ≈ Σ f_r·ΔΦ_p / (π r²) over the
 * N nearest photons, r² being the squared distance of the farthest of them (as a k-nearest query
 * returns it). The photons' ΔΦ_p are their flux shares (light power / photons emitted). */
PF_INLINE pf_float pf_pm_estimate(pf_float sum_fr_flux, pf_float r2) {
  if (r2 <= 0.0f) return 0.0f;
  return sum_fr_flux / (PF_PI * r2);
}

#endif /* PHOTONFLOW_PPM_H */
