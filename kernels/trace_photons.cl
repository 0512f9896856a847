/*
 * trace_photons.cl — photon tracing on an OpenCL device (thesis ch. 7.2 "photon tracing" block;
 * CPU twin: photon_pass.cpp). One work-item per emitted photon, an iterative bounce loop with the
 * fixed limit max_bounces, rays traced by the stackless rope traversal (intersect_shared.h).
 *
 * Random numbers: photon i of pass p uses the counter-based stream (seed, p, i) in the CPU's
 * dimension order (light choice, 2 position, 2 direction; then per bounce: Russian roulette and
 * two direction numbers at a diffuse hit, u1, u2, u3 for pf_pbr_scatter then the roulette's at a
 * PF_MAT_PBR hit, one Fresnel choice at glass), so both backends trace the same paths (thesis
 * ch. 7.2 kept LCG seeds per photon; a counter-based generator needs none).
 *
 * Storage: each photon owns max_bounces + 1 slots (one stored photon per diffuse or PBR hit, at
 * most one per bounce) and a count; the host concatenates the used slots in photon order, which is the CPU's
 * order (photon index, then bounce). Slots are stored slot-major — slot k of batch photon i at
 * [k·count + i] — so that neighbouring work-items write neighbouring photons (dense cache lines;
 * most photons use only their first slots).
 */
#pragma OPENCL FP_CONTRACT OFF
#include "trace_common.h"

/* Photons first .. first + count − 1 of the pass form this batch; outputs indexed from 0. */
__kernel void trace_photons(PF_SCENE_PARAMS, PF_TEXTURE_PARAMS, PF_ALPHA_PARAMS, uint seed, uint pass, int max_bounces, float eps,
                            uint first, int count, __global pf_photon* slots,
                            __global int* stored) {
  const int local_i = (int)get_global_id(0);
  if (local_i >= count) return;
  PF_SCENE_VIEW(s);
  PF_ALPHA_VIEW(s);
  const uint i = first + (uint)local_i;
  int n_stored = 0;
  pf_rng rng = pf_rng_start(seed, pass, i);
  /* emit (photon_pass.cpp) */
  const float ul = pf_rng_next(&rng);
  const float u1 = pf_rng_next(&rng);
  const float u2 = pf_rng_next(&rng);
  const float u3 = pf_rng_next(&rng);
  const float u4 = pf_rng_next(&rng);
  if (s.light_count <= 0) { /* no light_cdf[-1] read, whatever the host launches */
    stored[local_i] = 0;
    return;
  }
  float p_light;
  const int li = pf_pick_light(&s, ul, &p_light);
  __global const pf_light* l = &s.lights[li];
  if (p_light <= 0.0f) {
    stored[local_i] = 0;
    return;
  }
  float o[3], d[3], flux[3];
  if (l->type == PF_LIGHT_AREA) {
    if (PF_SCENE_ALPHA && s.alpha_on &&
        pf_alpha_light_point_cut_away(alpha_mats, tris, textures, texels, uvs, l->triangle, u1,
                                      u2)) {
      stored[local_i] = 0; /* a cut-away texel emits nothing (photon_pass.cpp) */
      return;
    }
    __global const pf_triangle* t = &s.tris[l->triangle];
    const float v0[3] = {t->v0[0], t->v0[1], t->v0[2]};
    const float v1[3] = {t->v1[0], t->v1[1], t->v1[2]};
    const float v2[3] = {t->v2[0], t->v2[1], t->v2[2]};
    float p[3], e1[3], e2[3], n[3];
    pf_sample_triangle(v0, v1, v2, u1, u2, p);
    for (int k = 0; k < 3; ++k) {
      e1[k] = v1[k] - v0[k];
      e2[k] = v2[k] - v0[k];
    }
    pf_cross3(e1, e2, n);
    pf_normalize3(n);
    pf_sample_cosine_hemisphere(n, u3, u4, d);
    const float f = l->area * PF_S_PI / p_light;
    for (int k = 0; k < 3; ++k) {
      o[k] = p[k] + n[k] * eps;
      flux[k] = l->radiance[k] * f;
    }
  } else if (l->type == PF_LIGHT_ENVIRONMENT) {
    /* the map (environment_shared.h pf_env_emit; photon_pass.cpp's emit) */
    float power[3];
    if (!pf_env_emit(s.env, u1, u2, u3, u4, o, d, power)) {
      stored[local_i] = 0;
      return;
    }
    const float inv = 1.0f / p_light;
    for (int k = 0; k < 3; ++k) flux[k] = power[k] * inv;
  } else if (l->type != PF_LIGHT_POINT) { /* spot, directional (light_shared.h) */
    const float lp[3] = {l->position[0], l->position[1], l->position[2]};
    const float ld[3] = {l->direction[0], l->direction[1], l->direction[2]};
    const float f = pf_punctual_emit(l->type, lp, ld, l->cos_inner, l->cos_outer, l->area, u1,
                                     u2, o, d) / p_light;
    if (!(f > 0.0f)) {
      stored[local_i] = 0;
      return;
    }
    for (int k = 0; k < 3; ++k) flux[k] = l->radiance[k] * f;
  } else {
    pf_sample_uniform_sphere(u1, u2, d);
    const float f = 4.0f * PF_S_PI / p_light;
    for (int k = 0; k < 3; ++k) {
      o[k] = l->position[k];
      flux[k] = l->radiance[k] * f;
    }
  }
  int specular_only = 1, first_hit = 1;
  int leaf = -1; /* the kd leaf of the last hit: the next ray's start (pf_trace_from) */
  for (int bounce = 0; bounce <= max_bounces; ++bounce) {
    pf_ray_hit h;
    if (!pf_trace_from(&s, o, d, 0.0f, INFINITY, 0, &h, leaf, &leaf)) break;
    pf_surface sh;
    pf_surface_at(&s, o, d, &h, &sh);
    __global const pf_material* m = &s.mats[sh.material];
    pf_normalize3(d);
    float n[3];
    for (int k = 0; k < 3; ++k) n[k] = sh.front ? sh.ns[k] : -sh.ns[k];
    float c[3] = {m->color[0], m->color[1], m->color[2]};
    const int diffuse = pf_is_diffuse(m);
    if (diffuse || (PF_SCENE_PBR && m->type == PF_MAT_PBR)) { /* scene_features.h */
      /* stored at every non-delta hit, diffuse or PF_MAT_PBR (photon_pass.cpp) */
      pf_photon ph;
      for (int k = 0; k < 3; ++k) {
        ph.position[k] = sh.p[k];
        ph.dir[k] = d[k];
        ph.flux[k] = flux[k];
      }
      ph.mesh = sh.mesh;
      ph.pass = (int)pass;
      ph.flags = (first_hit ? PF_PHOTON_DIRECT : 0) |
                 (!first_hit && specular_only ? PF_PHOTON_CAUSTIC : 0);
      slots[(size_t)n_stored * (size_t)count + (size_t)local_i] = ph;
      ++n_stored;
      if (diffuse || !PF_SCENE_PBR) {
        float tf[3]; /* the textured albedo (photon_pass.cpp's diffuse_color) */
        if (pf_texture_factor(textures, texels, mat_tex, uvs, sh.material, &h, tf))
          for (int k = 0; k < 3; ++k) c[k] = c[k] * tf[k];
        /* Russian roulette by albedo: p = std::max(c0, std::max(c1, c2)) */
        const float m12 = c[1] < c[2] ? c[2] : c[1];
        const float p = c[0] < m12 ? m12 : c[0];
        if (pf_rng_next(&rng) >= p) break;
        const float inv_p = 1.0f / p;
        for (int k = 0; k < 3; ++k) flux[k] = flux[k] * c[k] * inv_p;
        const float b1 = pf_rng_next(&rng);
        const float b2 = pf_rng_next(&rng);
        pf_sample_cosine_hemisphere(n, b1, b2, d);
      } else {
        /* glTF metallic-roughness (photon_pass.cpp, photon_pass.h): continued by pf_pbr_scatter
         * (importance mode, the front shading frame, Veach's shading-normal adjoint;
         * pbr_scatter_shared.h); draws u1, u2, u3 for it, then u_rr (always drawn). */
        const float u1 = pf_rng_next(&rng);
        const float u2 = pf_rng_next(&rng);
        const float u3 = pf_rng_next(&rng);
        pf_bsdf_params bp;
        pf_pbr_params_hit(textures, texels, mat_tex, uvs, mr_tex, s.mats, sh.material, &h, &bp);
        const float wo[3] = {-d[0], -d[1], -d[2]};
        float wi[3], w[3], pdf;
        const int ok = pf_pbr_scatter(&bp, sh.ns, sh.ng, wo, u1, u2, u3, PF_TRANSPORT_IMPORTANCE,
                                      wi, w, &pdf);
        const float u_rr = pf_rng_next(&rng);
        if (!ok) break;
        /* Russian roulette on the throughput: q = min(1, max_c Φ'_c / max_c Φ_c), Φ' = Φ·w */
        float next[3];
        for (int k = 0; k < 3; ++k) next[k] = flux[k] * w[k];
        const float b12 = flux[1] < flux[2] ? flux[2] : flux[1];
        const float before = flux[0] < b12 ? b12 : flux[0];
        const float a12 = next[1] < next[2] ? next[2] : next[1];
        const float after = next[0] < a12 ? a12 : next[0];
        const float r = after / before;
        const float q = r < 1.0f ? r : 1.0f; /* std::min(1.f, r) */
        if (!(q > 0.0f) || u_rr >= q) break;
        const float inv_q = 1.0f / q;
        for (int k = 0; k < 3; ++k) {
          flux[k] = next[k] * inv_q;
          d[k] = wi[k];
        }
      }
      specular_only = 0;
    } else if (m->type == PF_MAT_MIRROR) {
      for (int k = 0; k < 3; ++k) flux[k] = flux[k] * c[k];
      pf_reflect(d, n, d);
    } else if (m->type == PF_MAT_GLASS) {
      const float u = pf_rng_next(&rng);
      pf_glass_bounce(m, &sh, n, u, d, flux);
    } else {
      break; /* a black emitter absorbs */
    }
    first_hit = 0;
    if (pf_luminance3(flux) <= 0.0f) break;
    pf_offset_origin(&sh, d, eps, o);
  }
  stored[local_i] = n_stored;
}

/* The used slots of a batch, concatenated in photon order (photon index, then bounce: the CPU's
 * order) on the device: start[0 .. count] is the exclusive prefix sum of the batch's `stored`
 * counts (start[count] = the total), so photon i owns out[start[i] .. start[i+1]). The host's
 * concatenation in trace_photons (cl_backend.cpp) gives the same array; trace_photons_device uses
 * this one so that a pass gathered on the device never copies its photons through the host. */
__kernel void compact_photons(__global const pf_photon* slots, __global const int* start,
                              int count, __global pf_photon* out) {
  const int i = (int)get_global_id(0);
  if (i >= count) return;
  const int s = start[i], n = start[i + 1] - s;
  for (int k = 0; k < n; ++k) out[s + k] = slots[(size_t)k * (size_t)count + (size_t)i];
}
