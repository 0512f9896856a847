/*
 * material/pbr_point_shared.h — the BSDF at a visible point (a hitpoint) on a PF_MAT_PBR surface,
 * as every gather evaluates it per photon, written once for the C++ host and the OpenCL C kernels
 * (the rules of bsdf_shared.h).
 *
 * A hitpoint on a diffuse surface needs nothing beyond pf_hitpoint: f_r = color/π does not depend
 * on directions and its texture factor rides in the weight. A PF_MAT_PBR surface's f depends on the
 * photon's direction and on its textured parameters at the point, so the eye pass records one
 * pf_pbr_point per hitpoint (a table parallel to the hitpoints, present only when the scene has a
 * PBR material; hitpoints.h5 /hitpoints/bsdf). The gather then forms
 *   τ += weight · Σ_p f(x, ω_o, ω_p) Φ_p                          (HJ09 eq. 10–11, thesis eq. 3.17)
 * with ω_o = −hp.dir (towards the camera) and ω_p = −photon.dir (towards where the photon came
 * from), both in world space, in radiance mode (pf_bsdf_eval's PF_TRANSPORT_RADIANCE).
 *
 * The side: pf_hitpoint.normal faces the incoming ray (as for diffuse hitpoints, so the gathers'
 * normal tests are unchanged). A transmissive surface has sides (bsdf_shared.h: +z outside, IOR 1),
 * so `outside`'s bit PF_PBR_POINT_OUTSIDE says whether the facing normal is the outside or the
 * inside. Its bit PF_PBR_POINT_MERGE_WEIGHTED marks a point where the eye pass shares the light
 * between this gather and the continuation of its path (merge_weight_shared.h): the gather then
 * weights each photon's f by w_m(ω_o, ω_p).
 */
#ifndef PHOTONFLOW_MATERIAL_PBR_POINT_SHARED_H
#define PHOTONFLOW_MATERIAL_PBR_POINT_SHARED_H

#include "photonflow/material/bsdf_shared.h"
#include "photonflow/material/merge_weight_shared.h"
#include "photonflow/material/texture_shared.h"

#ifdef __OPENCL_VERSION__
#pragma OPENCL FP_CONTRACT OFF
#endif

/* pf_pbr_point::outside's bits. */
#define PF_PBR_POINT_OUTSIDE 1 /* the hitpoint's (facing) normal is the outside (else the inside) */
#define PF_PBR_POINT_MERGE_WEIGHTED 2 /* the gather weights each photon by w_m of its direction
                                       * (merge_weight_shared.h (1)); the eye pass has divided the
                                       * hitpoint's weight by the merge probability q */

typedef struct {
  pf_bsdf_params params; /* textures applied (surface.h bsdf_params_at) */
  pf_int outside;        /* PF_PBR_POINT_* bits */
} pf_pbr_point;

#ifndef __OPENCL_VERSION__
static_assert(sizeof(pf_pbr_point) == 32, "pf_pbr_point layout");
#endif

/* The BSDF parameters of PF_MAT_PBR material m at barycentrics (u, v) (the weights of v1 and v2)
 * of a triangle: the glTF factors times the textures there (glTF 2.0 spec 3.9.2: baseColor =
 * factor × the (linear) base-colour texel, metallic = factor × texel.B, roughness = factor ×
 * texel.G). base_tex / mr_tex: the material's base-colour and metallic-roughness textures (−1
 * none) in `textures`/`texels` (scene.h); uv: the triangle's six UVs (u0 v0 u1 v1 u2 v2), read
 * only when a texture is present. The one definition of the parameters at a hit: the host's
 * bsdf_params_at (surface.h) and the tracing kernels (trace_common.h) both call it, so both
 * backends shade with the same bits (each product one rounded float multiplication, as
 * diffuse_color's m.color × texture_value). */
PF_INLINE void pf_pbr_params_at(PF_GLOBAL const pf_material* m, PF_GLOBAL const pf_texture* textures,
                                PF_GLOBAL const float* texels, int base_tex, int mr_tex,
                                PF_GLOBAL const float* uv, float u, float v, pf_bsdf_params* p) {
  p->base_color[0] = m->color[0];
  p->base_color[1] = m->color[1];
  p->base_color[2] = m->color[2];
  p->metallic = m->metallic;
  p->roughness = m->roughness;
  p->transmission = m->transmission;
  p->ior = m->ior;
  float rgba[4];
  if (base_tex >= 0) {
    const pf_texture t = textures[base_tex];
    pf_tex_sample_triangle(&t, texels, uv, u, v, rgba);
    p->base_color[0] = m->color[0] * rgba[0];
    p->base_color[1] = m->color[1] * rgba[1];
    p->base_color[2] = m->color[2] * rgba[2];
  }
  if (mr_tex >= 0) {
    const pf_texture t = textures[mr_tex];
    pf_tex_sample_triangle(&t, texels, uv, u, v, rgba);
    p->metallic = m->metallic * rgba[2];
    p->roughness = m->roughness * rgba[1];
  }
}

/* A PBR visible point as the device gathers read it (kernels/illuminate_methods.cl): its BSDF
 * and ω_o = −hp.dir (the split hitpoints of the hashed grid carry no direction). One per hitpoint
 * of a pass, built by the host (cl_pass_inputs.cpp) from the hitpoints and their pf_pbr_point
 * table; entries of diffuse hitpoints are never read. 48 bytes. */
typedef struct {
  pf_pbr_point pt;
  pf_float wo[3];
  pf_int pad;
} pf_pbr_site;

#ifndef __OPENCL_VERSION__
static_assert(sizeof(pf_pbr_site) == 48, "pf_pbr_site layout");
#endif

/* f(ω_o, ω_i) at the point, rgb, radiance mode, times w_m(ω_o, ω_i) at a merge-weighted point
 * (the photon's share of merge_weight_shared.h (2)). n_facing: the hitpoint's unit normal (facing
 * the incoming ray); wo, wi: unit world directions away from the surface. */
PF_INLINE void pf_pbr_point_eval(const pf_pbr_point* pt, const float* n_facing, const float* wo,
                                 const float* wi, float* f) {
  float n[3] = {n_facing[0], n_facing[1], n_facing[2]};
  if (!(pt->outside & PF_PBR_POINT_OUTSIDE)) {
    n[0] = -n[0];
    n[1] = -n[1];
    n[2] = -n[2];
  }
  float o[3], i[3];
  pf_bsdf_to_local(n, wo, o);
  pf_bsdf_to_local(n, wi, i);
  pf_bsdf_eval(&pt->params, o, i, PF_TRANSPORT_RADIANCE, f);
  if (pt->outside & PF_PBR_POINT_MERGE_WEIGHTED) {
    if (!(f[0] > 0.0f || f[1] > 0.0f || f[2] > 0.0f)) return;
    const float w = pf_merge_weight(&pt->params, o, i);
    f[0] = f[0] * w;
    f[1] = f[1] * w;
    f[2] = f[2] * w;
  }
}

#endif /* PHOTONFLOW_MATERIAL_PBR_POINT_SHARED_H */
