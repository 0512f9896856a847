/*
 * illuminate_naive.cl — hitpoint illumination of progressive photon mapping, naive variant (thesis
 * ch. 7.2, Table 7.1 row "Hitpoint Illumination"): one work-item per hitpoint loops over all photons
 * of the pass. It is the baseline the accelerated gathers (thesis ch. 7.3) are measured against.
 *
 * The acceptance rule is illuminate.h's photon_accepted() plus ppm.h's distance rule, so the naive
 * gather selects exactly the photons the CPU grid/FLANN gathers select:
 *   same mesh; not PF_PHOTON_DIRECT when direct light came from shadow rays; arrived on the
 *   hitpoint's side (dot(photon.dir, hitpoint.normal) < 0); pf_ppm_in_radius(pf_ppm_dist2(...), R).
 * Photons are visited in index order and f_r·Φ is summed in double precision where the device has
 * it (PF_FP64, set by the host), like the CPU's sum: the same sums, bit for bit.
 *
 * The photons may come in several batches (device allocation limit): ppm_gather_naive adds each
 * batch into per-hitpoint accumulators, ppm_apply then applies eq. 3.14–3.18 once per pass.
 */
#pragma OPENCL FP_CONTRACT OFF
#include "photonflow/shared_types.h"
#include "photonflow/ppm.h"

#if defined(PF_FP64) && PF_FP64
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
typedef double pf_acc;
#else
typedef float pf_acc;
#endif

#define PF_K_INV_PI 0.318309886183790671538f

/* Hitpoints first .. first + count − 1 against photons [0, photon_count) of this batch. */
__kernel void ppm_gather_naive(__global const pf_hitpoint* hps, int first, int count,
                               __global const pf_photon* photons, int photon_count,
                               __global const pf_material* mats, int skip_direct,
                               __global int* acc_m, __global pf_acc* acc_tau) {
  const int li = (int)get_global_id(0);
  if (li >= count) return;
  __global const pf_hitpoint* hp = &hps[first + li];
  const float hx = hp->position[0], hy = hp->position[1], hz = hp->position[2];
  const float nx = hp->normal[0], ny = hp->normal[1], nz = hp->normal[2];
  const float radius = hp->radius;
  const int mesh = hp->mesh;
  __global const pf_material* mat = &mats[hp->material];
  const float fr0 = mat->color[0] * PF_K_INV_PI, fr1 = mat->color[1] * PF_K_INV_PI,
              fr2 = mat->color[2] * PF_K_INV_PI;
  int m = acc_m[li];
  pf_acc t0 = acc_tau[3 * li], t1 = acc_tau[3 * li + 1], t2 = acc_tau[3 * li + 2];
  for (int j = 0; j < photon_count; ++j) {
    __global const pf_photon* p = &photons[j];
    if (p->mesh != mesh) continue;
    if (skip_direct && (p->flags & PF_PHOTON_DIRECT)) continue;
    if (!(p->dir[0] * nx + p->dir[1] * ny + p->dir[2] * nz < 0.0f)) continue;
    const float d2 = pf_ppm_dist2(hx, hy, hz, p->position[0], p->position[1], p->position[2]);
    if (!pf_ppm_in_radius(d2, radius)) continue;
    ++m;
    t0 += (pf_acc)(fr0 * p->flux[0]);
    t1 += (pf_acc)(fr1 * p->flux[1]);
    t2 += (pf_acc)(fr2 * p->flux[2]);
  }
  acc_m[li] = m;
  acc_tau[3 * li] = t0;
  acc_tau[3 * li + 1] = t1;
  acc_tau[3 * li + 2] = t2;
}

/* Eq. 3.14, 3.16, 3.18 for hitpoints first .. first + count − 1 with the accumulated m and τ_M. */
__kernel void ppm_apply(__global pf_hitpoint* hps, int first, int count,
                        __global const int* acc_m, __global const pf_acc* acc_tau, float alpha) {
  const int li = (int)get_global_id(0);
  if (li >= count) return;
  const float tau_m[3] = {(float)acc_tau[3 * li], (float)acc_tau[3 * li + 1],
                          (float)acc_tau[3 * li + 2]};
  pf_ppm_update(&hps[first + li], acc_m[li], tau_m, alpha);
}
