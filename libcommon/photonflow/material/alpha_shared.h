/*
 * material/alpha_shared.h — alpha cut-outs (glTF 2.0 alphaMode MASK, OBJ/MTL map_d), shared by
 * the C++ host and the OpenCL C 1.2 kernels.
 *
 * glTF 2.0 spec section 3.9.4 (alpha coverage): with alphaMode MASK, "the rendered output is
 * either fully opaque or fully transparent depending on the alpha value and the specified
 * alphaCutoff value": a point is opaque when alpha >= alphaCutoff and cut away (rays pass) when
 * alpha < alphaCutoff. alphaCutoff defaults to 0.5. Here alpha = baseColorFactor.a · texel.a of
 * the material's base-colour texture (linear: texture_shared.h stores alpha as read).
 *
 * Cut-off encoding: a material's cutoff in [0, 1] means "masked"; PF_ALPHA_OPAQUE (−1) means no
 * mask (the fast path: no texture lookup). Values read from a file are checked with
 * pf_alpha_cutoff_valid; NaN, negative or > 1 values are refused (the caller reports one line,
 * exit 2) rather than clamped.
 *
 * Where it is used: scene.h5 format version 5 stores one pf_alpha_material per material
 * (/materials/alpha_cutoff, alpha_factor, alpha_texture; scene.h); the host's leaf loops
 * (raycast.cpp) and the kernels' leaf test (kernels/trace_common.h) skip a hit for which
 * pf_alpha_hit_cut_away is 1, so eye rays, photons, shadow rays and the path tracer pass through
 * cut-away texels. Scenes without a masked material never call it.
 */
#ifndef PHOTONFLOW_MATERIAL_ALPHA_SHARED_H
#define PHOTONFLOW_MATERIAL_ALPHA_SHARED_H

#include "photonflow/foundations/cl_compat.h"
#include "photonflow/material/texture_shared.h"
#include "photonflow/sampling/sampling_shared.h"

#define PF_ALPHA_OPAQUE (-1.0f)
#define PF_ALPHA_DEFAULT_CUTOFF 0.5f /* glTF 2.0 alphaCutoff default */

/* 1 when a cutoff read from a file is usable for MASK: finite and in [0, 1] (NaN fails both). */
PF_INLINE int pf_alpha_cutoff_valid(float cutoff) { return cutoff >= 0.0f && cutoff <= 1.0f; }

/* 1 when a material with this cutoff is masked (not PF_ALPHA_OPAQUE). */
PF_INLINE int pf_alpha_masked(float cutoff) { return cutoff >= 0.0f; }

/* Coverage test of spec 3.9.4: 1 when alpha (factor · texel alpha) is below the cutoff, i.e. a
 * ray passes through this point. An opaque material (cutoff < 0) is never cut away. */
PF_INLINE int pf_alpha_cut_away(float alpha, float cutoff) {
  return pf_alpha_masked(cutoff) && alpha < cutoff;
}

/* The texel alpha at the barycentrics (u, v) (weights of v1 and v2) of a triangle with UVs
 * uv[6] = u0 v0 u1 v1 u2 v2 (pf_tex_sample_triangle, the lookup every texture uses), times the
 * factor's alpha. */
PF_INLINE float pf_alpha_at(const pf_texture* tex, PF_GLOBAL const float* pool,
                            PF_GLOBAL const float* uv, float u, float v, float factor_alpha) {
  float rgba[4];
  pf_tex_sample_triangle(tex, pool, uv, u, v, rgba);
  return factor_alpha * rgba[3];
}

/* Where a material's alpha comes from (scene.h5 version 5, one per material):
 *   cutoff  — PF_ALPHA_OPAQUE (−1, exactly): not masked, alpha never read; [0, 1]: masked with
 *             this alphaCutoff (any other value is refused on read);
 *   factor  — the constant alpha in [0, 1] (glTF baseColorFactor.a; 1 for OBJ map_d);
 *   texture — index into the scene's texture table whose texel ALPHA channel multiplies factor
 *             (glTF: the base-colour texture; OBJ: the map_d texture, its own entry), −1: none. */
typedef struct {
  pf_float cutoff;
  pf_float factor;
  pf_int texture;
  pf_int pad; /* 0 */
} pf_alpha_material;

#ifndef __OPENCL_VERSION__
static_assert(sizeof(pf_alpha_material) == 16, "pf_alpha_material layout");
#endif

/* The any-hit test of a hit on triangle `tri` at barycentrics (u, v) (weights of v1 and v2):
 * 1 when the triangle's material is masked and its alpha there is below the cutoff, so the hit
 * does not count (the ray goes on). uvs: six floats per triangle (needed only when some masked
 * material has a texture; scene.h5 guarantees them then). */
PF_INLINE int pf_alpha_hit_cut_away(PF_GLOBAL const pf_alpha_material* mats,
                                    PF_GLOBAL const pf_triangle* tris,
                                    PF_GLOBAL const pf_texture* textures,
                                    PF_GLOBAL const float* texels, PF_GLOBAL const float* uvs,
                                    int tri, float u, float v) {
  const pf_alpha_material a = mats[tris[tri].material];
  if (!pf_alpha_masked(a.cutoff)) return 0;
  float alpha = a.factor;
  if (a.texture >= 0) {
    const pf_texture t = textures[a.texture];
    alpha = pf_alpha_at(&t, texels, uvs + 6 * (long)tri, u, v, a.factor);
  }
  return pf_alpha_cut_away(alpha, a.cutoff);
}

/* An emitter's cut-away texels emit nothing (the eye sees through them, so light may not leave
 * them either): 1 when the point pf_sample_triangle(u1, u2) picks on area light triangle `tri`
 * is cut away. Photon emission then sends no photon and next-event estimation adds nothing for
 * that sample; both stay unbiased, as the light's sampling density over the whole triangle is
 * still the one used (light_cdf weighs the whole triangle's power: a mostly cut-away emitter
 * wastes samples, never energy). */
PF_INLINE int pf_alpha_light_point_cut_away(PF_GLOBAL const pf_alpha_material* mats,
                                            PF_GLOBAL const pf_triangle* tris,
                                            PF_GLOBAL const pf_texture* textures,
                                            PF_GLOBAL const float* texels,
                                            PF_GLOBAL const float* uvs, int tri, float u1,
                                            float u2) {
  float u, v;
  pf_sample_triangle_weights(u1, u2, &u, &v);
  return pf_alpha_hit_cut_away(mats, tris, textures, texels, uvs, tri, u, v);
}

#endif /* PHOTONFLOW_MATERIAL_ALPHA_SHARED_H */
