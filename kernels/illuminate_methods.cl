/*
 * illuminate_methods.cl — hitpoint illumination of progressive photon mapping on the device: the
 * naive gather (thesis ch. 7.2, Table 7.1) and the accelerated variants of thesis ch. 7.3
 * (Table 7.3), plus a hashed grid. gather_method.h lists them, cl_gather_methods.cpp runs them.
 *
 * Every kernel selects exactly the photons illuminate.h's rule selects (same mesh; not
 * PF_PHOTON_DIRECT when direct light came from shadow rays; dot(photon.dir, normal) < 0, except
 * at a transmissive PF_MAT_PBR point; pf_ppm_in_radius(pf_ppm_dist2(x, x_p), R)) and adds m and
 * Σ f_r·Φ_p (eq. 3.17; at a PBR hitpoint Σ f(x, ω_o, ω_p)·Φ_p per photon, HJ09 eq. 10–11, from
 * the kernel's `pbr` table of pf_pbr_site, pbr_point_shared.h) into
 * per-hitpoint accumulators acc_m / acc_tau (double where the device has fp64, PF_FP64);
 * ppm_apply then applies eq. 3.14, 3.16, 3.18 once per pass (gather_hash_grid, where one
 * work-item owns a hitpoint for the whole pass, applies them itself with the same arithmetic).
 * Only the order of the sum differs between kernels (each kernel's order is fixed, so every
 * kernel is deterministic).
 *
 * Distance tests. The thesis's kernels up to "hitpoint sorting + local memory" used OpenCL's
 * built-in distance(); "manual distance" replaced it by dx·dx + dy·dy + dz·dz. The kernels of
 * those rows call distance() too (pf_in_radius with builtin = 1), but only as a prefilter
 * distance <= 1.0001·R that the exact squared-distance rule then confirms: distance() may differ
 * from the exact value by a few ulps, far below the 1e-4 slack, so the prefilter never rejects
 * a photon the rule accepts and the selected set stays exact.
 *
 * Work-group layout. Kernels with local memory stage photons in tiles of the work-group size L.
 * Hitpoint orders (hitpoint sorting, clusters) come from the host (cl_gather_methods.cpp,
 * cl_clusters.cpp): entry s of `order` is a hitpoint index or −1 (a filler, idle), and work-group
 * g covers entries g·L … (g+1)·L − 1, all of one mesh (per-mesh runs and clusters are padded to
 * multiples of L).
 */
#pragma OPENCL FP_CONTRACT OFF
#include "photonflow/foundations/shared_types.h"
#include "photonflow/estimators/ppm.h"
#include "photonflow/stages/grid_shared.h"
#include "photonflow/material/pbr_point_shared.h"
#include "scene_features.h" /* PF_SCENE_PBR = 0: a scene without PBR gathers as before PBR */

#if defined(PF_FP64) && PF_FP64
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
typedef double pf_acc;
#else
typedef float pf_acc;
#endif

#define PF_K_INV_PI 0.318309886183790671538f
/* Relative slack of conservative tests (built-in distance prefilter, cluster spheres, bin boxes):
 * float rounding of a squared distance is ~1e-7 relative. */
#define PF_SLACK 1.0001f

/* A hitpoint's gather state in private memory. */
typedef struct {
  float x, y, z, nx, ny, nz, r;
  int mesh;
  float fr0, fr1, fr2;  /* f_r = albedo/π, eq. 3.17 (diffuse hitpoints) */
  int m;
  pf_acc t0, t1, t2;
  int pbr;         /* a PF_MAT_PBR hitpoint: f per photon from pt (HJ09 eq. 10–11) */
  int both;        /* a transmissive PBR point gathers from both sides (illuminate.h) */
#if PF_SCENE_PBR
  pf_pbr_point pt; /* read only when pbr */
  float wo[3];     /* ω_o = −hp.dir, only when pbr */
#endif
} pf_gather_hp;

/* A hitpoint's gather state from its fields, with zero accumulators (the loaders below call it
 * for whole and for split hitpoints). A hitpoint with a negative or NaN radius gathers nothing
 * (mesh −1 matches no photon), as on the CPU. A hitpoint on a PF_MAT_PBR material takes its
 * pf_pbr_site (entry hi of `pbr`, the pass's table parallel to the hitpoints; a one-element
 * stand-in, never read, when the scene has no PBR material). */
static inline void pf_gather_start(pf_gather_hp* h, __global const float* position,
                                   __global const float* normal, float radius, int mesh,
                                   int material, __global const pf_material* mats,
                                   __global const pf_pbr_site* pbr, int hi) {
  h->x = position[0];
  h->y = position[1];
  h->z = position[2];
  h->nx = normal[0];
  h->ny = normal[1];
  h->nz = normal[2];
  h->r = radius;
  h->mesh = radius >= 0.0f ? mesh : -1;
  __global const pf_material* mat = &mats[material];
  h->fr0 = mat->color[0] * PF_K_INV_PI;
  h->fr1 = mat->color[1] * PF_K_INV_PI;
  h->fr2 = mat->color[2] * PF_K_INV_PI;
  h->m = 0;
  h->t0 = 0;
  h->t1 = 0;
  h->t2 = 0;
  h->pbr = PF_SCENE_PBR && material >= 0 && mat->type == PF_MAT_PBR;
  h->both = 0;
#if PF_SCENE_PBR
  if (h->pbr) {
    __global const pf_pbr_site* ps = &pbr[hi];
    h->pt = ps->pt;
    h->wo[0] = ps->wo[0];
    h->wo[1] = ps->wo[1];
    h->wo[2] = ps->wo[2];
    /* illuminate.h pbr_two_sided_gather: the BSDF transmits at the point */
    h->both = h->pt.params.metallic < 1.0f && h->pt.params.transmission > 0.0f;
  }
#endif
}

/* Adds an accepted photon (direction d, flux f): f_r·Φ (eq. 3.17) at a diffuse hitpoint, at a PBR
 * hitpoint f(x, ω_o, ω_p)·Φ with ω_p = −d (HJ09 eq. 10–11; pbr_point_shared.h), each product one
 * float multiplication as on the CPU. */
static inline void pf_gather_add(pf_gather_hp* h, float dx, float dy, float dz, float f0, float f1,
                                 float f2) {
  h->m += 1;
#if PF_SCENE_PBR
  if (h->pbr) {
    const float n[3] = {h->nx, h->ny, h->nz};
    const float wi[3] = {-dx, -dy, -dz};
    float f[3];
    pf_pbr_point_eval(&h->pt, n, h->wo, wi, f);
    h->t0 += (pf_acc)(f[0] * f0);
    h->t1 += (pf_acc)(f[1] * f1);
    h->t2 += (pf_acc)(f[2] * f2);
    return;
  }
#endif
  h->t0 += (pf_acc)(h->fr0 * f0);
  h->t1 += (pf_acc)(h->fr1 * f1);
  h->t2 += (pf_acc)(h->fr2 * f2);
}

/* Loads hitpoint hi with zero accumulators. */
static inline void pf_gather_load_fresh(pf_gather_hp* h, __global const pf_hitpoint* hps, int hi,
                                        __global const pf_material* mats,
                                        __global const pf_pbr_site* pbr) {
  __global const pf_hitpoint* hp = &hps[hi];
  pf_gather_start(h, hp->position, hp->normal, hp->radius, hp->mesh, hp->material, mats, pbr, hi);
}

/* The same from a split hitpoint (pf_gather_site and pf_ppm_state, the hashed grid's). */
static inline void pf_gather_load_split(pf_gather_hp* h, __global const pf_gather_site* sites,
                                        __global const pf_ppm_state* states, int hi,
                                        __global const pf_material* mats,
                                        __global const pf_pbr_site* pbr) {
  __global const pf_gather_site* s = &sites[hi];
  pf_gather_start(h, s->position, s->normal, states[hi].radius, s->mesh, s->material, mats, pbr,
                  hi);
}

/* Loads hitpoint hi and resumes its accumulators (zero at the start of a pass; the naive
 * kernel's photon batches continue the same sum). */
static inline void pf_gather_load(pf_gather_hp* h, __global const pf_hitpoint* hps, int hi,
                                  __global const pf_material* mats, __global const pf_pbr_site* pbr,
                                  __global const int* acc_m, __global const pf_acc* acc_tau) {
  pf_gather_load_fresh(h, hps, hi, mats, pbr);
  h->m = acc_m[hi];
  h->t0 = acc_tau[3 * hi];
  h->t1 = acc_tau[3 * hi + 1];
  h->t2 = acc_tau[3 * hi + 2];
}

/* The distance part of the rule (see the file comment for `builtin`). */
static inline int pf_in_radius(const pf_gather_hp* h, float px, float py, float pz,
                               const int builtin) {
  if (builtin && !(distance((float3)(h->x, h->y, h->z), (float3)(px, py, pz)) <= h->r * PF_SLACK))
    return 0;
  return pf_ppm_in_radius(pf_ppm_dist2(h->x, h->y, h->z, px, py, pz), h->r);
}

/* The whole rule for one photon's fields; adds it when accepted. */
static inline void pf_gather_photon(pf_gather_hp* h, float px, float py, float pz, float dx,
                                    float dy, float dz, int mesh, int flags, float f0, float f1,
                                    float f2, const int skip_direct, const int builtin) {
  if (mesh != h->mesh) return;
  if (skip_direct && (flags & PF_PHOTON_DIRECT)) return;
  if (!(dx * h->nx + dy * h->ny + dz * h->nz < 0.0f) && !h->both) return;
  if (!pf_in_radius(h, px, py, pz, builtin)) return;
  pf_gather_add(h, dx, dy, dz, f0, f1, f2);
}

static inline void pf_gather_global(pf_gather_hp* h, __global const pf_photon* p,
                                    const int skip_direct, const int builtin) {
  pf_gather_photon(h, p->position[0], p->position[1], p->position[2], p->dir[0], p->dir[1],
                   p->dir[2], p->mesh, p->flags, p->flux[0], p->flux[1], p->flux[2], skip_direct,
                   builtin);
}

static inline void pf_gather_local(pf_gather_hp* h, __local const pf_photon* p,
                                   const int skip_direct, const int builtin) {
  pf_gather_photon(h, p->position[0], p->position[1], p->position[2], p->dir[0], p->dir[1],
                   p->dir[2], p->mesh, p->flags, p->flux[0], p->flux[1], p->flux[2], skip_direct,
                   builtin);
}

/* The rest of the rule for a photon whose key and distance passed: the direction, then the sums
 * (from its payload, hash_grid.h). */
static inline void pf_gather_payload(pf_gather_hp* h, __global const pf_photon_payload* p) {
  if (!(p->dir[0] * h->nx + p->dir[1] * h->ny + p->dir[2] * h->nz < 0.0f) && !h->both) return;
  pf_gather_add(h, p->dir[0], p->dir[1], p->dir[2], p->flux[0], p->flux[1], p->flux[2]);
}

/* How the hashed-grid gather handles candidates whose key and distance passed (PF_GATHER_LIST, a
 * build define; cl_runtime.cpp sets PF_DEVICE_CPU):
 *   0      per lane, a branch on the lane's mask straight into pf_gather_payload (the default on
 *          a GPU, where a work-item's private array lives in off-chip memory);
 *   N >= 4 the passing lanes' photon indices are appended, without a branch, to a private list
 *          of N entries (pf_pending), whose payloads are read when the list may overflow and once
 *          when the hitpoint's rows are done (pf_pending_flush). The default on a CPU device
 *          (32): PoCL runs a work-item's loops as scalar code, and there the per-lane and
 *          per-block branches mispredict (at 1920×1080 a hitpoint tests 33 candidates in 10
 *          blocks of four and accepts 6, spread over the blocks); the list, to which a block's
 *          passing lanes go as one compacted vector, avoids those branches (docs/BENCHMARKS.md
 *          "How hash-grid's pass is built").
 * Both read the accepted photons in the same order (index order within a row, rows in box
 * order), so both give the same sums, byte for byte (tested with lists of 4 and 32). */
#ifndef PF_GATHER_LIST
#if defined(PF_DEVICE_CPU) && PF_DEVICE_CPU
#define PF_GATHER_LIST 32
#else
#define PF_GATHER_LIST 0
#endif
#endif
#if PF_GATHER_LIST != 0 && PF_GATHER_LIST < 4
#error "PF_GATHER_LIST must be 0 or at least 4 (a block of four appends up to four entries)"
#endif

/* For a 4-bit mask of passing lanes (bit i: lane i passed), the passing lanes in order, then
 * zeros: entry 0b1010 is (1, 3, 0, 0). */
__constant int4 pf_passing_lanes[16] = {
    (int4)(0, 0, 0, 0), (int4)(0, 0, 0, 0), (int4)(1, 0, 0, 0), (int4)(0, 1, 0, 0),
    (int4)(2, 0, 0, 0), (int4)(0, 2, 0, 0), (int4)(1, 2, 0, 0), (int4)(0, 1, 2, 0),
    (int4)(3, 0, 0, 0), (int4)(0, 3, 0, 0), (int4)(1, 3, 0, 0), (int4)(0, 1, 3, 0),
    (int4)(2, 3, 0, 0), (int4)(0, 2, 3, 0), (int4)(1, 2, 3, 0), (int4)(0, 1, 2, 3)};

typedef struct {
#if PF_GATHER_LIST > 0
  int j[PF_GATHER_LIST]; /* indices into payload, in the order they passed */
#endif
  int n;
} pf_pending;

/* Reads the pending photons' payloads in list order and empties the list. */
static inline void pf_pending_flush(pf_gather_hp* h, __global const pf_photon_payload* payload,
                                    pf_pending* pend) {
#if PF_GATHER_LIST > 0
  for (int i = 0; i < pend->n; ++i) pf_gather_payload(h, &payload[pend->j[i]]);
#endif
  pend->n = 0;
}

/* The rule over photons j0 .. j1 − 1 of the hashed grid's sorted arrays (hash_grid.h): mesh,
 * direct flag and distance are tested a block of four photons at a time (pf_photon_keys4: aligned
 * float4 / int4 loads; lanes outside j0 .. j1 − 1 are masked off), the direction and flux read
 * from the payload only for photons that passed, in index order (at once or through `pend`, see
 * PF_GATHER_LIST). Each lane computes pf_ppm_dist2 and pf_ppm_in_radius's operations in their
 * order (FP_CONTRACT OFF), so the same photons are selected and summed in the same order as
 * pf_gather_global would: the same sums. */
static inline void pf_gather_keyed(pf_gather_hp* h, __global const pf_photon_keys4* keys,
                                   __global const pf_photon_payload* payload, int j0, int j1,
                                   const int skip_direct, const float slab, pf_pending* pend) {
  /* With skip_direct the key must be 2·mesh (mesh matches, not direct), otherwise key >> 1 must
   * be the mesh. A hitpoint with mesh −1 matches no key (keys >= 0). */
  const int shift = skip_direct ? 0 : 1;
  const int want = skip_direct ? 2 * h->mesh : h->mesh;
  const float r2 = h->r * h->r;
  const float4 hx = (float4)(h->x), hy = (float4)(h->y), hz = (float4)(h->z);
  const float4 nx = (float4)(h->nx), ny = (float4)(h->ny), nz = (float4)(h->nz);
  const float kr = slab * h->r; /* pf_ppm_in_slab's bound */
  const int4 lane = (int4)(0, 1, 2, 3);
#if PF_GATHER_LIST > 0
  int n = pend->n; /* <= PF_GATHER_LIST − 4 between blocks */
#endif
  for (int b = j0 >> 2; 4 * b < j1; ++b) {
    __global const float* k = (__global const float*)&keys[b];
    const float4 dx = hx - vload4(0, k);
    const float4 dy = hy - vload4(1, k);
    const float4 dz = hz - vload4(2, k);
    const float4 d2 = dx * dx + dy * dy + dz * dz;
    const int4 j = (int4)(4 * b) + lane;
    int4 ok = ((vload4(3, (__global const int*)k) >> shift) == (int4)(want)) &
              (d2 <= (float4)(r2)) & (j >= (int4)(j0)) & (j < (int4)(j1));
    if (slab > 0.0f) ok &= fabs(dx * nx + dy * ny + dz * nz) <= (float4)(kr); /* pf_ppm_in_slab */
#if PF_GATHER_LIST > 0
    /* The passing lanes' indices, compacted in lane order (pf_passing_lanes), are stored as one
     * vector at n, and n moves past those that passed: entries n .. n + 3 <= PF_GATHER_LIST − 1.
     * (Storing lane by lane with n −= ok.sK between the stores chained every store's address on
     * the previous lane's test, a slower gather on PoCL: docs/BENCHMARKS.md "How hash-grid's
     * pass is built".) */
    const int4 bit = ok & (int4)(1, 2, 4, 8); /* a vector comparison is −1 when true */
    const int passed = bit.s0 | bit.s1 | bit.s2 | bit.s3;
    vstore4((int4)(4 * b) + pf_passing_lanes[passed], 0, &pend->j[n]);
    n += popcount(passed);
    if (n > PF_GATHER_LIST - 4) {
      pend->n = n;
      pf_pending_flush(h, payload, pend);
      n = 0;
    }
#else
    if (!any(ok)) continue;
    if (ok.s0) pf_gather_payload(h, &payload[4 * b]);
    if (ok.s1) pf_gather_payload(h, &payload[4 * b + 1]);
    if (ok.s2) pf_gather_payload(h, &payload[4 * b + 2]);
    if (ok.s3) pf_gather_payload(h, &payload[4 * b + 3]);
#endif
  }
#if PF_GATHER_LIST > 0
  pend->n = n;
#endif
}

/* Stores a hitpoint's accumulators. */
static inline void pf_gather_store(const pf_gather_hp* h, int hi, __global int* acc_m,
                                   __global pf_acc* acc_tau) {
  acc_m[hi] = h->m;
  acc_tau[3 * hi] = h->t0;
  acc_tau[3 * hi + 1] = h->t1;
  acc_tau[3 * hi + 2] = h->t2;
}

/* ---- naive: one work-item per hitpoint, every photon of the batch, index order ---------------- */
__kernel void gather_naive(__global const pf_hitpoint* hps, int count,
                           __global const pf_photon* photons, int photon_count,
                           __global const pf_material* mats,
                           __global const pf_pbr_site* pbr, int skip_direct,
                           __global int* acc_m, __global pf_acc* acc_tau) {
  const int hi = (int)get_global_id(0);
  if (hi >= count) return;
  pf_gather_hp h;
  pf_gather_load(&h, hps, hi, mats, pbr, acc_m, acc_tau);
  for (int j = 0; j < photon_count; ++j) pf_gather_global(&h, &photons[j], skip_direct, 1);
  pf_gather_store(&h, hi, acc_m, acc_tau);
}

/* ---- local memory: the work-group stages all photons through local memory, L at a time ------ */
__kernel void gather_local_memory(__global const pf_hitpoint* hps, int count,
                                  __global const pf_photon* photons, int photon_count,
                                  __global const pf_material* mats,
                                  __global const pf_pbr_site* pbr, int skip_direct,
                                  __global int* acc_m, __global pf_acc* acc_tau,
                                  __local pf_photon* tile) {
  const int hi = (int)get_global_id(0), lid = (int)get_local_id(0), L = (int)get_local_size(0);
  const int active = hi < count;
  pf_gather_hp h;
  if (active) pf_gather_load(&h, hps, hi, mats, pbr, acc_m, acc_tau);
  for (int base = 0; base < photon_count; base += L) {
    if (base + lid < photon_count) tile[lid] = photons[base + lid];
    barrier(CLK_LOCAL_MEM_FENCE);
    const int n = min(L, photon_count - base);
    if (active)
      for (int j = 0; j < n; ++j) pf_gather_local(&h, &tile[j], skip_direct, 1);
    barrier(CLK_LOCAL_MEM_FENCE);
  }
  if (active) pf_gather_store(&h, hi, acc_m, acc_tau);
}

/* ---- photon sorting: one work-item per hitpoint, its mesh's photons only ------------------ */
__kernel void gather_photon_sort(__global const pf_hitpoint* hps, int count,
                                 __global const pf_photon* sorted, __global const int* mesh_start,
                                 int mesh_count, __global const pf_material* mats,
                                 __global const pf_pbr_site* pbr, int skip_direct,
                                 __global int* acc_m, __global pf_acc* acc_tau) {
  const int hi = (int)get_global_id(0);
  if (hi >= count) return;
  pf_gather_hp h;
  pf_gather_load(&h, hps, hi, mats, pbr, acc_m, acc_tau);
  if (h.mesh >= 0 && h.mesh < mesh_count) {
    const int end = mesh_start[h.mesh + 1];
    for (int j = mesh_start[h.mesh]; j < end; ++j)
      pf_gather_global(&h, &sorted[j], skip_direct, 1);
  }
  pf_gather_store(&h, hi, acc_m, acc_tau);
}

/* ---- hitpoint sorting: work-groups of one mesh (fillers idle), global photon reads ---------- */
__kernel void gather_hitpoint_sort(__global const pf_hitpoint* hps, __global const int* order,
                                   int order_count, __global const pf_photon* sorted,
                                   __global const int* mesh_start, int mesh_count,
                                   __global const pf_material* mats,
                                   __global const pf_pbr_site* pbr, int skip_direct,
                                   __global int* acc_m, __global pf_acc* acc_tau) {
  const int s = (int)get_global_id(0);
  if (s >= order_count) return;
  const int hi = order[s];
  if (hi < 0) return; /* filler */
  pf_gather_hp h;
  pf_gather_load(&h, hps, hi, mats, pbr, acc_m, acc_tau);
  if (h.mesh >= 0 && h.mesh < mesh_count) {
    const int end = mesh_start[h.mesh + 1];
    for (int j = mesh_start[h.mesh]; j < end; ++j)
      pf_gather_global(&h, &sorted[j], skip_direct, 1);
  }
  pf_gather_store(&h, hi, acc_m, acc_tau);
}

/* ---- hitpoint sorting + local memory (builtin = 1) / manual distance (builtin = 0) ---------- */
static inline void pf_hitpoint_sort_local(__global const pf_hitpoint* hps,
                                          __global const int* order, int order_count,
                                          __global const pf_photon* sorted,
                                          __global const int* mesh_start, int mesh_count,
                                          __global const pf_material* mats,
                                          __global const pf_pbr_site* pbr, int skip_direct,
                                          __global int* acc_m, __global pf_acc* acc_tau,
                                          __local pf_photon* tile, const int builtin) {
  const int s = (int)get_global_id(0), lid = (int)get_local_id(0), L = (int)get_local_size(0);
  const int g0 = (int)get_group_id(0) * L; /* the group's first entry: never a filler */
  if (g0 >= order_count) return;            /* whole group past the end: uniform */
  const int mesh = hps[order[g0]].mesh;
  if (mesh < 0 || mesh >= mesh_count) return; /* uniform */
  const int hi = s < order_count ? order[s] : -1;
  pf_gather_hp h;
  if (hi >= 0) pf_gather_load(&h, hps, hi, mats, pbr, acc_m, acc_tau);
  const int begin = mesh_start[mesh], end = mesh_start[mesh + 1];
  for (int base = begin; base < end; base += L) {
    if (base + lid < end) tile[lid] = sorted[base + lid];
    barrier(CLK_LOCAL_MEM_FENCE);
    const int n = min(L, end - base);
    if (hi >= 0)
      for (int j = 0; j < n; ++j) pf_gather_local(&h, &tile[j], skip_direct, builtin);
    barrier(CLK_LOCAL_MEM_FENCE);
  }
  if (hi >= 0) pf_gather_store(&h, hi, acc_m, acc_tau);
}

__kernel void gather_hitpoint_sort_local(__global const pf_hitpoint* hps,
                                         __global const int* order, int order_count,
                                         __global const pf_photon* sorted,
                                         __global const int* mesh_start, int mesh_count,
                                         __global const pf_material* mats,
                                         __global const pf_pbr_site* pbr, int skip_direct,
                                         __global int* acc_m, __global pf_acc* acc_tau,
                                         __local pf_photon* tile) {
  pf_hitpoint_sort_local(hps, order, order_count, sorted, mesh_start, mesh_count, mats, pbr,
                         skip_direct, acc_m, acc_tau, tile, 1);
}

__kernel void gather_manual_distance(__global const pf_hitpoint* hps, __global const int* order,
                                     int order_count, __global const pf_photon* sorted,
                                     __global const int* mesh_start, int mesh_count,
                                     __global const pf_material* mats,
                                     __global const pf_pbr_site* pbr, int skip_direct,
                                     __global int* acc_m, __global pf_acc* acc_tau,
                                     __local pf_photon* tile) {
  pf_hitpoint_sort_local(hps, order, order_count, sorted, mesh_start, mesh_count, mats, pbr,
                         skip_direct, acc_m, acc_tau, tile, 0);
}

/* ---- clusters: the work-group culls photons by its cluster's sphere into a local tile ------- */

/* Appends the photons of sorted[base .. base + L) ∩ [.., end) that lie inside the cluster sphere
 * (with slack, so no photon a member gathers is lost) to tile[*fill ..], in index order: a
 * work-group-wide exclusive scan of the keep flags (Hillis–Steele in `scan`, L ints) gives each
 * kept photon its slot, so the tile's order is deterministic. All work-items must call it. */
static inline void pf_tile_append(__global const pf_photon* sorted, int base, int end,
                                  float cx, float cy, float cz, float r2, __local pf_photon* tile,
                                  __local int* scan, int* fill) {
  const int lid = (int)get_local_id(0), L = (int)get_local_size(0);
  const int j = base + lid;
  int keep = 0;
  pf_photon p;
  if (j < end) {
    p = sorted[j];
    keep = pf_ppm_dist2(cx, cy, cz, p.position[0], p.position[1], p.position[2]) <= r2;
  }
  scan[lid] = keep;
  barrier(CLK_LOCAL_MEM_FENCE);
  for (int off = 1; off < L; off <<= 1) {
    const int t = lid >= off ? scan[lid - off] : 0;
    barrier(CLK_LOCAL_MEM_FENCE);
    scan[lid] += t;
    barrier(CLK_LOCAL_MEM_FENCE);
  }
  if (keep) tile[*fill + scan[lid] - 1] = p;
  const int added = scan[L - 1];
  barrier(CLK_LOCAL_MEM_FENCE);
  *fill += added;
}

/* Every member gathers from tile[0 .. fill). All work-items must call it. */
static inline void pf_tile_flush(pf_gather_hp* h, int active, __local const pf_photon* tile,
                                 int fill, int skip_direct) {
  if (active)
    for (int j = 0; j < fill; ++j) pf_gather_local(h, &tile[j], skip_direct, 0);
  barrier(CLK_LOCAL_MEM_FENCE);
}

/* Loads the work-group's cluster and this work-item's member (hi < 0: filler). */
static inline int pf_cluster_member(__global const pf_hitpoint* hps, __global const int* order,
                                    __global const pf_material* mats,
                                    __global const pf_pbr_site* pbr, __global const int* acc_m,
                                    __global const pf_acc* acc_tau, pf_gather_hp* h) {
  const int hi = order[get_global_id(0)];
  if (hi >= 0) pf_gather_load(h, hps, hi, mats, pbr, acc_m, acc_tau);
  return hi;
}

/* k-means clusters over the per-mesh photon arrays: the tile (2L photons of local memory) keeps
 * only photons inside the cluster's sphere; members gather when it holds L or more. */
__kernel void gather_clusters(__global const pf_hitpoint* hps, __global const int* order,
                              __global const int* group_cluster,
                              __global const pf_cluster* clusters,
                              __global const pf_photon* sorted, __global const int* mesh_start,
                              int mesh_count, __global const pf_material* mats,
                              __global const pf_pbr_site* pbr, int skip_direct,
                              __global int* acc_m, __global pf_acc* acc_tau,
                              __local pf_photon* tile, __local int* scan) {
  const int L = (int)get_local_size(0);
  __global const pf_cluster* c = &clusters[group_cluster[get_group_id(0)]];
  const int mesh = c->mesh;
  if (mesh < 0 || mesh >= mesh_count) return; /* uniform */
  pf_gather_hp h;
  const int hi = pf_cluster_member(hps, order, mats, pbr, acc_m, acc_tau, &h);
  const float cx = c->centre[0], cy = c->centre[1], cz = c->centre[2];
  const float rc = c->radius * PF_SLACK, r2 = rc * rc;
  const int begin = mesh_start[mesh], end = mesh_start[mesh + 1];
  int fill = 0;
  for (int base = begin; base < end; base += L) {
    pf_tile_append(sorted, base, end, cx, cy, cz, r2, tile, scan, &fill);
    if (fill >= L) {
      pf_tile_flush(&h, hi >= 0, tile, fill, skip_direct);
      fill = 0;
    }
  }
  pf_tile_flush(&h, hi >= 0, tile, fill, skip_direct);
  if (hi >= 0) pf_gather_store(&h, hi, acc_m, acc_tau);
}

/* Grid + clusters (k-means or grid clusters): the work-group reads only the bins of its cluster
 * sphere's box in the mesh's grid (eq. 7.1; the same padded box as PhotonGrid::for_each_in_radius,
 * around the cluster centre), row by row (bins lo..hi of a row are contiguous). Every work-item of
 * the group walks the same bins in the same order, so their global reads hit the same addresses
 * (one fetch serves the group: a broadcast on a GPU, one cache line on a CPU); staging them through
 * local memory, as the mesh-wide variants do, only adds barriers here (the runs are short). */
__kernel void gather_grid_clusters(__global const pf_hitpoint* hps, __global const int* order,
                                   __global const int* group_cluster,
                                   __global const pf_cluster* clusters,
                                   __global const pf_photon* sorted,
                                   __global const pf_mesh_grid* mesh_grid,
                                   __global const int* cell_start, int mesh_count,
                                   __global const pf_material* mats,
                                   __global const pf_pbr_site* pbr, int skip_direct,
                                   __global int* acc_m, __global pf_acc* acc_tau) {
  __global const pf_cluster* c = &clusters[group_cluster[get_group_id(0)]];
  const int mesh = c->mesh;
  if (mesh < 0 || mesh >= mesh_count) return;
  __global const pf_mesh_grid* g = &mesh_grid[mesh];
  if (g->photon_count == 0) return;
  const int hi = order[get_global_id(0)];
  if (hi < 0) return; /* filler */
  pf_gather_hp h;
  pf_gather_load(&h, hps, hi, mats, pbr, acc_m, acc_tau);
  const float cx = c->centre[0], cy = c->centre[1], cz = c->centre[2];
  const float pad = c->radius * PF_SLACK * PF_SLACK;
  const int x0 = pf_grid_coord(cx - pad, g->lo[0], g->bin_size, g->nx);
  const int x1 = pf_grid_coord(cx + pad, g->lo[0], g->bin_size, g->nx);
  const int y0 = pf_grid_coord(cy - pad, g->lo[1], g->bin_size, g->ny);
  const int y1 = pf_grid_coord(cy + pad, g->lo[1], g->bin_size, g->ny);
  const int z0 = pf_grid_coord(cz - pad, g->lo[2], g->bin_size, g->nz);
  const int z1 = pf_grid_coord(cz + pad, g->lo[2], g->bin_size, g->nz);
  for (int z = z0; z <= z1; ++z) {
    for (int y = y0; y <= y1; ++y) {
      const int row = g->first_bin + (y + z * g->ny) * g->nx;
      const int end = cell_start[row + x1 + 1];
      for (int j = cell_start[row + x0]; j < end; ++j)
        pf_gather_global(&h, &sorted[j], skip_direct, 0);
    }
  }
  pf_gather_store(&h, hi, acc_m, acc_tau);
}

/* ---- hashed grid over all meshes: one work-item per hitpoint --------------------------------
 * Cells of side `cell` (a multiple of the largest R, PpmOptions::hash_cell) of an nx × ny × nz grid
 * over the scene, hashed into mask + 1 slots by their linear index (pf_hash_slot); slot k holds
 * photons slot_start[k] .. slot_start[k+1] − 1 of keys / payload (hash_grid.h) in photon-index
 * order. A hitpoint reads each distinct slot of its sphere box's cells once, row by row (a row's
 * slots are consecutive modulo the table size). That is exact: a photon within R lies in a cell
 * of the box, so its slot is read, once; photons of other cells that share a slot lie outside
 * the box, farther than R, and the rule rejects them. A slot repeats within the box only when two
 * of its cells' linear indices are congruent modulo the table size: along a row when the row is
 * longer than the table, across rows when row offsets are congruent — both tested arithmetically.
 * When the grid has no more cells than the table has slots (`unique`, the host's choice of table
 * size makes that the common case) no two cells share a slot, and a row is one run of photons
 * (two if it wraps around the table).
 *
 * The hitpoints come split (pf_gather_site, read; pf_ppm_state, read and rewritten:
 * cl_pass_inputs.cpp splits and merges them): 72 bytes of traffic per hitpoint instead of 168 for
 * whole pf_hitpoint records (docs/BENCHMARKS.md "How hash-grid's pass is built").
 * One work-item owns one hitpoint for the whole pass, so the kernel also applies eq. 3.14–3.18 to
 * it (pf_ppm_update_state, the arithmetic of ppm_apply on the same sums: the same state) instead of
 * leaving m and τ_M in accumulators for ppm_apply, and it reduces the largest finite positive
 * new radius (order-preserving ints, grid_shared.h) into rmax_next[0] (zero on entry): the next
 * pass's cell size, so that a state kept on the device needs no copy to the host between passes
 * (cl_gather.h, DevicePpmState). `lmax` holds one int per work-item. With `weighted` (SPPM: the
 * states are pixels, the sites that pass's visible points) τ_M is multiplied by the site's eye-path
 * throughput β (weights[3·i .. 3·i + 2]) before the update, as sppm_pass does (sppm.h). `slab`
 * > 0 (sppm and pppm, PpmOptions::slab) cuts each sphere to pf_ppm_in_slab's slab. */
__kernel void gather_hash_grid(__global const pf_gather_site* sites,
                               __global pf_ppm_state* states, int count,
                               __global const pf_photon_payload* payload,
                               __global const pf_photon_keys4* keys, __global const int* slot_start,
                               float ox, float oy, float oz, float cell, int nx, int ny, int nz,
                               uint mask, int unique, __global const pf_material* mats,
                               __global const pf_pbr_site* pbr,
                               int skip_direct, float alpha, float slab,
                               __global const float* weights,
                               int weighted, __global int* rmax_next, __local int* lmax) {
  const int hi = (int)get_global_id(0), lid = (int)get_local_id(0), L = (int)get_local_size(0);
  int r_next = 0; /* pf_float_ordered(0.0f) */
  pf_gather_hp h;
  if (hi < count) pf_gather_load_split(&h, sites, states, hi, mats, pbr);
  if (hi < count && h.mesh >= 0) {
    const float pad = h.r * PF_SLACK;
    const int x0 = pf_grid_coord(h.x - pad, ox, cell, nx), x1 = pf_grid_coord(h.x + pad, ox, cell, nx);
    const int y0 = pf_grid_coord(h.y - pad, oy, cell, ny), y1 = pf_grid_coord(h.y + pad, oy, cell, ny);
    const int z0 = pf_grid_coord(h.z - pad, oz, cell, nz), z1 = pf_grid_coord(h.z + pad, oz, cell, nz);
    const uint len = (uint)(x1 - x0 + 1); /* cells per row */
    pf_pending pend;
    pend.n = 0;
    for (int z = z0; z <= z1; ++z)
      for (int y = y0; y <= y1; ++y) {
        const uint first = pf_hash_slot(x0, y, z, (uint)nx, (uint)ny, mask);
        if (unique) { /* the row's slots first .. first + len − 1 (mod table): 1 or 2 runs */
          const uint stop = first + len <= mask + 1 ? first + len : mask + 1;
          pf_gather_keyed(&h, keys, payload, slot_start[first], slot_start[stop], skip_direct,
                          slab, &pend);
          if (first + len > mask + 1)
            pf_gather_keyed(&h, keys, payload, 0, slot_start[first + len - (mask + 1)], skip_direct,
                            slab, &pend);
          continue;
        }
        for (uint dx = 0; dx < len && dx <= mask; ++dx) { /* dx > mask: repeats within the row */
          const uint k = (first + dx) & mask;
          int seen = 0; /* read by an earlier row of the box? */
          for (int zz = z0; zz <= z && !seen; ++zz)
            for (int yy = y0; yy <= y1; ++yy) {
              if (zz == z && yy >= y) break;
              const uint f = pf_hash_slot(x0, yy, zz, (uint)nx, (uint)ny, mask);
              if (((k - f) & mask) < len) { seen = 1; break; }
            }
          if (seen) continue;
          pf_gather_keyed(&h, keys, payload, slot_start[k], slot_start[k + 1], skip_direct, slab,
                          &pend);
        }
      }
    pf_pending_flush(&h, payload, &pend);
  }
  if (hi < count) {
    float tau_m[3] = {(float)h.t0, (float)h.t1, (float)h.t2};
    if (weighted)
      for (int c = 0; c < 3; ++c) tau_m[c] = tau_m[c] * weights[3 * hi + c];
    pf_ppm_update_state(&states[hi], h.m, tau_m, alpha);
    const float r = states[hi].radius;
    if (isfinite(r) && r > 0.0f) r_next = pf_float_ordered(r);
  }
  lmax[lid] = r_next;
  barrier(CLK_LOCAL_MEM_FENCE);
  for (int s = 1; s < L; s <<= 1) {
    if ((lid & (2 * s - 1)) == 0 && lid + s < L) lmax[lid] = max(lmax[lid], lmax[lid + s]);
    barrier(CLK_LOCAL_MEM_FENCE);
  }
  if (lid == 0) atomic_max(rmax_next, lmax[0]);
}

/* Eq. 3.14, 3.16, 3.18 for hitpoints 0 .. count − 1 with the accumulated m and τ_M. */
__kernel void ppm_apply(__global pf_hitpoint* hps, int count, __global const int* acc_m,
                        __global const pf_acc* acc_tau, float alpha) {
  const int hi = (int)get_global_id(0);
  if (hi >= count) return;
  const float tau_m[3] = {(float)acc_tau[3 * hi], (float)acc_tau[3 * hi + 1],
                          (float)acc_tau[3 * hi + 2]};
  pf_ppm_update(&hps[hi], acc_m[hi], tau_m, alpha);
}
