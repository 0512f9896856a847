/*
 * material/pbr_scatter_shared.h — one scattering event at a PF_MAT_PBR surface in WORLD space,
 * as the photon tracer (importance transport) and the path tracer (radiance transport) take it,
 * written once for the C++ host and the OpenCL C kernels (the rules of bsdf_shared.h: scalars and
 * float[3], no references, no std::, float contraction off).
 *
 * Frames: the BSDF's local frame has z = the shading normal ns of the surface's FRONT side (the
 * side the triangle's counter-clockwise winding faces, SurfaceHit::ns), so a transmissive
 * material's outside (+z, IOR 1) is the front; a reflective one is two-sided (bsdf_shared.h).
 * ng is the front geometric normal. wo and wi are unit world directions away from the surface.
 *
 * A direction pair is kept only when the geometric surface agrees with the shading frame about
 * whether it is a reflection or a transmission: (wo·ng > 0) == (wi·ng > 0) exactly when
 * (wo·ns > 0) == (wi·ns > 0). Otherwise a smooth shading normal would let light leak through the
 * geometric surface (or reflect off it from behind); such samples end the path (and NEE and the
 * gathers give them f = 0: pf_pbr_pair_consistent), which every estimator does alike.
 */
#ifndef PHOTONFLOW_MATERIAL_PBR_SCATTER_SHARED_H
#define PHOTONFLOW_MATERIAL_PBR_SCATTER_SHARED_H

#include "photonflow/material/bsdf_shared.h"

#ifdef __OPENCL_VERSION__
#pragma OPENCL FP_CONTRACT OFF
#endif

/* 1 when the geometric and the shading normal agree that (wo, wi) is a reflection (both on one
 * side) or a transmission (on opposite sides), and neither direction is tangent to the geometric
 * surface; 0 otherwise. */
PF_INLINE int pf_pbr_pair_consistent(const float* wo, const float* wi, const float* ns,
                                     const float* ng) {
  const float go = pf_dot3(wo, ng), gi = pf_dot3(wi, ng);
  const float so = pf_dot3(wo, ns), si = pf_dot3(wi, ns);
  if (go == 0.0f || gi == 0.0f || so == 0.0f || si == 0.0f) return 0;
  return ((go > 0.0f) == (gi > 0.0f)) == ((so > 0.0f) == (si > 0.0f));
}

/* 1 when ns differs from ng in any component (Veach's adjoint factor is needed). */
PF_INLINE int pf_normals_differ(const float* ns, const float* ng) {
  return ns[0] != ng[0] || ns[1] != ng[1] || ns[2] != ng[2];
}

/* Samples the continuation wi of a path at a PBR surface for transport `mode`
 * (PF_TRANSPORT_RADIANCE for eye paths, PF_TRANSPORT_IMPORTANCE for photons) with the random
 * numbers u1, u2, u3 of pf_bsdf_sample (u3 picks the lobe). weight = f·|cos θi|/pdf in the
 * shading frame, and for importance transport times Veach's shading-normal adjoint
 * |wo·ns||wi·ng| / (|wo·ng||wi·ns|) (Veach 1997 §5.3, pf_shading_normal_adjoint) wherever ns ≠ ng;
 * pdf the solid-angle mixture pdf (pf_bsdf_pdf, for MIS). Returns 0 (path ends) when the BSDF's
 * sample is lost (its single-scattering loss) or the pair is inconsistent (above). */
PF_INLINE int pf_pbr_scatter(const pf_bsdf_params* p, const float* ns, const float* ng,
                             const float* wo, float u1, float u2, float u3, int mode, float* wi,
                             float* weight, float* pdf) {
  float o[3];
  pf_bsdf_to_local(ns, wo, o);
  pf_bsdf_sample_rec rec;
  if (!pf_bsdf_sample(p, o, u1, u2, u3, mode, &rec)) return 0;
  pf_to_world(rec.wi, ns, wi);
  pf_normalize3(wi);
  if (!pf_pbr_pair_consistent(wo, wi, ns, ng)) return 0;
  float adj = 1.0f;
  if (mode == PF_TRANSPORT_IMPORTANCE && pf_normals_differ(ns, ng))
    adj = pf_shading_normal_adjoint(wo, wi, ns, ng);
  weight[0] = rec.weight[0] * adj;
  weight[1] = rec.weight[1] * adj;
  weight[2] = rec.weight[2] * adj;
  *pdf = rec.pdf;
  return weight[0] > 0.0f || weight[1] > 0.0f || weight[2] > 0.0f;
}

/* f(wo, wi) in radiance mode at a PBR surface (world directions, front shading normal ns),
 * 0 for an inconsistent pair (above). The shadow rays' direct light and NEE use it. */
PF_INLINE void pf_pbr_eval_world(const pf_bsdf_params* p, const float* ns, const float* ng,
                                 const float* wo, const float* wi, float* f) {
  f[0] = f[1] = f[2] = 0.0f;
  if (!pf_pbr_pair_consistent(wo, wi, ns, ng)) return;
  float o[3], i[3];
  pf_bsdf_to_local(ns, wo, o);
  pf_bsdf_to_local(ns, wi, i);
  pf_bsdf_eval(p, o, i, PF_TRANSPORT_RADIANCE, f);
}

/* pf_bsdf_pdf for world directions (the BSDF strategy's density for MIS), 0 for an inconsistent
 * pair, which pf_pbr_scatter never returns. */
PF_INLINE float pf_pbr_pdf_world(const pf_bsdf_params* p, const float* ns, const float* ng,
                                 const float* wo, const float* wi) {
  if (!pf_pbr_pair_consistent(wo, wi, ns, ng)) return 0.0f;
  float o[3], i[3];
  pf_bsdf_to_local(ns, wo, o);
  pf_bsdf_to_local(ns, wi, i);
  return pf_bsdf_pdf(p, o, i);
}

#endif /* PHOTONFLOW_MATERIAL_PBR_SCATTER_SHARED_H */
