/*
 * material/texture_shared.h — texel lookup shared by the C++ host and the OpenCL C 1.2 kernels:
 * wrap modes of glTF samplers, bilinear filtering, and the sRGB decode used at bake time.
 *
 * Layer: material model (libcommon/photonflow/material/); depends on cl_compat.h and
 * shared_types.h only. Used by the scene (geometry/scene.h: the texture pool and its lookups),
 * scene-bake's material and alpha import (material_import.cpp, alpha_import.cpp), alpha_shared.h,
 * pbr_point_shared.h and the OpenCL kernels (kernels/trace_common.h).
 *
 * Storage: every texture of a scene lives in one pool of linear RGBA float texels (4 floats per
 * texel, row-major, row 0 first), PF_GLOBAL on the device; a texture is a pf_texture header:
 *
 *   | field   | meaning                                                                   |
 *   |---------|---------------------------------------------------------------------------|
 *   | width   | texels per row (≥ 1)                                                      |
 *   | height  | rows (≥ 1)                                                                |
 *   | offset  | index of texel (0, 0) in the pool, in texels (floats = 4·offset)          |
 *   | wrap_s  | PF_TEX_WRAP_* along u (glTF sampler wrapS)                                |
 *   | wrap_t  | PF_TEX_WRAP_* along v (glTF sampler wrapT)                                |
 *   | filter  | PF_TEX_FILTER_BILINEAR (default) or PF_TEX_FILTER_NEAREST (glTF magFilter) |
 *
 * UV convention (glTF 2.0, "Texture data"): (u, v) = (0, 0) is the top-left corner of the image
 * as stored (its first row), u grows to the right and v DOWN, (1, 1) the bottom-right corner; no
 * flip. Texel (x, y) covers [x, x+1)/width × [y, y+1)/height, its centre at ((x + ½)/width,
 * (y + ½)/height) (the half-texel convention of GL/Vulkan bilinear filtering). Formats whose v
 * grows upwards (OBJ, COLLADA as assimp hands them without aiProcess_FlipUVs) are converted at
 * bake time with v' = 1 − v.
 *
 * Texels are linear: colour maps (baseColorTexture, map_Kd) are decoded from sRGB with
 * pf_srgb_to_linear when baked; data maps (metallicRoughnessTexture, alpha) are stored as read.
 */
#ifndef PHOTONFLOW_MATERIAL_TEXTURE_SHARED_H
#define PHOTONFLOW_MATERIAL_TEXTURE_SHARED_H

#include "photonflow/foundations/cl_compat.h"
#include "photonflow/foundations/shared_types.h"

#ifdef __OPENCL_VERSION__
#pragma OPENCL FP_CONTRACT OFF
#define PF_T_FLOOR(x) floor(x)
#define PF_T_POW(x, y) pow(x, y)
#else
#include <cmath>
#define PF_T_FLOOR(x) std::floor(x)
#define PF_T_POW(x, y) std::pow(x, y)
#endif

#define PF_TEX_WRAP_REPEAT 0
#define PF_TEX_WRAP_CLAMP 1  /* clamp to edge */
#define PF_TEX_WRAP_MIRROR 2 /* mirrored repeat */

#define PF_TEX_FILTER_BILINEAR 0
#define PF_TEX_FILTER_NEAREST 1

typedef struct {
  pf_int width;
  pf_int height;
  pf_int offset;
  pf_int wrap_s;
  pf_int wrap_t;
  pf_int filter;
} pf_texture;

#ifndef __OPENCL_VERSION__
static_assert(sizeof(pf_texture) == 24, "pf_texture layout");
#endif

/* glTF sampler wrap codes (the GL enums) → PF_TEX_WRAP_*; absent/unknown → REPEAT (the glTF
 * default). */
PF_INLINE int pf_tex_wrap_from_gltf(int code) {
  if (code == 33071) return PF_TEX_WRAP_CLAMP;  /* CLAMP_TO_EDGE */
  if (code == 33648) return PF_TEX_WRAP_MIRROR; /* MIRRORED_REPEAT */
  return PF_TEX_WRAP_REPEAT;                    /* 10497 REPEAT */
}

/* Integer texel index i wrapped into [0, n) (n ≥ 1). Mirrored repeat has period 2n:
 * 0 … n−1, n−1 … 0 (GL's MIRRORED_REPEAT at texel level). */
PF_INLINE int pf_tex_wrap_index(int i, int n, int mode) {
  if (mode == PF_TEX_WRAP_CLAMP) return i < 0 ? 0 : (i >= n ? n - 1 : i);
  if (mode == PF_TEX_WRAP_MIRROR) {
    const int p = 2 * n;
    int m = i % p;
    if (m < 0) m += p;
    return m < n ? m : p - 1 - m;
  }
  int m = i % n;
  return m < 0 ? m + n : m;
}

/* A texture coordinate brought into a range where texel indices fit in an int, without changing
 * the lookup: repeat by whole periods of 1, mirror by whole periods of 2, clamp to [−1, 2]
 * (all beyond the edge texel's centre read the edge). NaN → 0. */
PF_INLINE float pf_tex_reduce(float u, int mode) {
  if (!(u == u)) return 0.0f;
  if (mode == PF_TEX_WRAP_CLAMP) return u < -1.0f ? -1.0f : (u > 2.0f ? 2.0f : u);
  if (mode == PF_TEX_WRAP_MIRROR) return u - 2.0f * PF_T_FLOOR(0.5f * u);
  return u - PF_T_FLOOR(u);
}

/* Texel (x, y) of `tex` with the texture's wrap modes applied; rgba out. */
PF_INLINE void pf_tex_fetch(const pf_texture* tex, PF_GLOBAL const float* pool, int x, int y,
                            float* rgba) {
  const int xi = pf_tex_wrap_index(x, tex->width, tex->wrap_s);
  const int yi = pf_tex_wrap_index(y, tex->height, tex->wrap_t);
  PF_GLOBAL const float* t = pool + 4 * (tex->offset + yi * tex->width + xi);
  rgba[0] = t[0];
  rgba[1] = t[1];
  rgba[2] = t[2];
  rgba[3] = t[3];
}

/* Filtered lookup at (u, v) (glTF convention above): bilinear between the four texel centres
 * around x = u·width − ½, y = v·height − ½, weights (1 − fx, fx) × (1 − fy, fy); or the texel
 * containing (u, v) for PF_TEX_FILTER_NEAREST. rgba out. */
PF_INLINE void pf_tex_sample(const pf_texture* tex, PF_GLOBAL const float* pool, float u, float v,
                             float* rgba) {
  u = pf_tex_reduce(u, tex->wrap_s);
  v = pf_tex_reduce(v, tex->wrap_t);
  const float x = u * (float)tex->width;
  const float y = v * (float)tex->height;
  if (tex->filter == PF_TEX_FILTER_NEAREST) {
    pf_tex_fetch(tex, pool, (int)PF_T_FLOOR(x), (int)PF_T_FLOOR(y), rgba);
    return;
  }
  const float xs = x - 0.5f, ys = y - 0.5f;
  const float x0f = PF_T_FLOOR(xs), y0f = PF_T_FLOOR(ys);
  const float fx = xs - x0f, fy = ys - y0f;
  const int x0 = (int)x0f, y0 = (int)y0f;
  float a[4], b[4], c[4], d[4];
  pf_tex_fetch(tex, pool, x0, y0, a);
  pf_tex_fetch(tex, pool, x0 + 1, y0, b);
  pf_tex_fetch(tex, pool, x0, y0 + 1, c);
  pf_tex_fetch(tex, pool, x0 + 1, y0 + 1, d);
  for (int k = 0; k < 4; ++k) {
    const float top = a[k] * (1.0f - fx) + b[k] * fx;
    const float bottom = c[k] * (1.0f - fx) + d[k] * fx;
    rgba[k] = top * (1.0f - fy) + bottom * fy;
  }
}

/* The texel at barycentrics (u, v) (the weights of v1 and v2) of a triangle whose corners have
 * the UVs uv[6] = u0 v0 u1 v1 u2 v2: the UVs interpolated, then pf_tex_sample. The one lookup of
 * a triangle's texture for the host (Scene::texture_value), the OpenCL tracers
 * (pf_texture_factor) and the alpha test (alpha_shared.h). */
PF_INLINE void pf_tex_sample_triangle(const pf_texture* tex, PF_GLOBAL const float* pool,
                                      PF_GLOBAL const float* uv, float u, float v, float* rgba) {
  const float w = 1.0f - u - v;
  const float s = w * uv[0] + u * uv[2] + v * uv[4];
  const float r = w * uv[1] + u * uv[3] + v * uv[5];
  pf_tex_sample(tex, pool, s, r, rgba);
}

/* The sRGB EOTF (IEC 61966-2-1): encoded c in [0, 1] → linear,
 *   c ≤ 0.04045: c / 12.92;   else ((c + 0.055) / 1.055)^2.4.
 * Inputs outside [0, 1] are clamped (NaN → 0). */
PF_INLINE float pf_srgb_to_linear(float c) {
  c = 0.0f < c ? c : 0.0f;
  c = c < 1.0f ? c : 1.0f;
  if (c <= 0.04045f) return c / 12.92f;
  return PF_T_POW((c + 0.055f) / 1.055f, 2.4f);
}

/* An 8-bit sRGB-encoded channel value (0..255) → linear. */
PF_INLINE float pf_srgb8_to_linear(int v) { return pf_srgb_to_linear((float)v / 255.0f); }

#endif /* PHOTONFLOW_MATERIAL_TEXTURE_SHARED_H */
