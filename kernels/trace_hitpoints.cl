/*
 * trace_hitpoints.cl — the eye pass of progressive photon mapping on an OpenCL device (thesis
 * ch. 7.2 "ray tracing" block; CPU twin: eye_pass.cpp). One work-item per pixel; each loops over
 * its eye samples and follows mirror/glass bounces iteratively (no recursion) to the first
 * non-delta surface (diffuse or PF_MAT_PBR), where it stores a hitpoint — and, in a scene with a
 * PBR material (has_pbr), the point's pf_pbr_point in the slot beside it (zeros at a diffuse one). Rays are traced by the stackless kd-tree traversal with
 * ropes (intersect_shared.h) — the spatial index the thesis's GPU tracer did not have.
 *
 * Random numbers: stream (seed, kEyeStream + pass, pixel·spp + s) for jitter (pixel_sampler.h)
 * and glass choices; the shadow rays' light samples by pf_light_draws_vertex (pixel_sampler.h: the
 * pixel's Sobol points under the SOBOL sampler, stream (seed, kShadowStream + pass, same index)
 * otherwise) — the CPU's streams and dimension order. PPM's one eye pass is pass 0; SPPM and
 * PPPM trace one per pass.
 *
 * Output per (pixel, sample) slot: the hitpoint and a used flag; the host compacts the used slots
 * in slot order (= the CPU's order: pixel row-major, then sample).
 */
#pragma OPENCL FP_CONTRACT OFF
#include "trace_common.h"
#include "photonflow/sampling/pixel_sampler.h"
#include "photonflow/material/lens_shared.h"

#define PF_EYE_STREAM 0xE7E0000u

/* Scene::light_incident on the device: one next-event sample of light li at p (light_shared.h
 * pf_light_incident, the host's sampling of every light type; the environment's
 * pf_env_incident; 0 from a cut-away texel of a masked emitter). Writes w, q and le (the
 * radiance arriving along w), returns G. */
static float pf_light_incident_at(const pf_scene_view* s, int li, const float* p, float u1,
                                  float u2, float* w, float* q, float* le) {
  __global const pf_light* l = &s->lights[li];
  if (l->type == PF_LIGHT_ENVIRONMENT) return pf_env_incident(s->env, p, u1, u2, w, q, le);
  for (int k = 0; k < 3; ++k) le[k] = l->radiance[k];
  float v0[3] = {0.0f, 0.0f, 0.0f}, v1[3] = {0.0f, 0.0f, 0.0f}, v2[3] = {0.0f, 0.0f, 0.0f};
  float nl[3] = {0.0f, 0.0f, 0.0f};
  if (l->type == PF_LIGHT_AREA) {
    __global const pf_triangle* t = &s->tris[l->triangle];
    for (int k = 0; k < 3; ++k) {
      v0[k] = t->v0[k];
      v1[k] = t->v1[k];
      v2[k] = t->v2[k];
    }
    float e1[3], e2[3];
    for (int k = 0; k < 3; ++k) {
      e1[k] = v1[k] - v0[k];
      e2[k] = v2[k] - v0[k];
    }
    pf_cross3(e1, e2, nl); /* face_normal (scene.h) */
    pf_normalize3(nl);
  }
  const float lp[3] = {l->position[0], l->position[1], l->position[2]};
  const float ld[3] = {l->direction[0], l->direction[1], l->direction[2]};
  const float g = pf_light_incident(l->type, lp, ld, l->cos_inner, l->cos_outer, l->area, v0, v1,
                                    v2, nl, p, u1, u2, w, q);
  /* Scene::light_incident: a cut-away texel of a masked emitter sends nothing */
  if (g > 0.0f && PF_SCENE_ALPHA && s->alpha_on && l->type == PF_LIGHT_AREA &&
      pf_alpha_light_point_cut_away(s->alpha.mats, s->tris, s->alpha.textures, s->alpha.texels,
                                    s->alpha.uvs, l->triangle, u1, u2))
    return 0.0f;
  return g;
}

/* eye_pass.cpp's direct_light: L_direct = (1/n) Σ ρ/π·L_e·cos θ_x·G/p_light at a diffuse point by
 * light sampling with shadow rays. Adds weight · L_direct to `direct`. `leaf`: p's kd leaf, where
 * the shadow rays start their walk (pf_trace_from). */
static void pf_direct_light(const pf_scene_view* s, const float* p, const float* ng,
                            const float* ns, __global const pf_material* m, int samples,
                            pf_light_draws* draws, float eps, const float* weight,
                            float* direct, int leaf) {
  if (s->light_count <= 0 || samples <= 0) return;
  float sum[3] = {0.0f, 0.0f, 0.0f};
  for (int smp = 0; smp < samples; ++smp) {
    float ul, u1, u2;
    pf_light_draws_next(draws, &ul, &u1, &u2);
    float p_light;
    const int li = pf_pick_nee_light(s, p, ul, &p_light);
    if (p_light <= 0.0f) continue;
    float q[3], w[3];
    float le[3];
    const float g = pf_light_incident_at(s, li, p, u1, u2, w, q, le);
    const float cos_x = pf_dot3(w, ns);
    if (!(g > 0.0f) || cos_x <= 0.0f || pf_dot3(w, ng) <= 0.0f) continue;
    float o[3], sd[3];
    for (int k = 0; k < 3; ++k) o[k] = p[k] + ng[k] * eps;
    for (int k = 0; k < 3; ++k) sd[k] = q[k] - o[k];
    pf_ray_hit hit;
    if (pf_trace_from(s, o, sd, 0.0f, 1.0f - 1e-4f, 1, &hit, leaf, 0)) continue;
    const float f = cos_x * g / p_light;
    for (int k = 0; k < 3; ++k) sum[k] = sum[k] + le[k] * f;
  }
  const float inv = 1.0f / (float)samples;
  for (int k = 0; k < 3; ++k)
    direct[k] = direct[k] + weight[k] * (m->color[k] * PF_S_INV_PI * sum[k] * inv);
}

/* eye_pass.cpp's direct_light_pbr: the same draws and shadow rays at a PF_MAT_PBR point, L_direct
 * = (1/n) Σ f(wo, w_l)·L_e·|cos θ_x|·G/p with the BSDF in radiance mode (pf_pbr_eval_world: front
 * shading normal ns, front geometric normal ng); light from behind counts where the BSDF
 * transmits, and the shadow ray leaves on w_l's side. Adds weight · L_direct to `direct`. The
 * numbers come from `draws` (the pixel's light draws at a visible point, the eye stream at a
 * glossy vertex an eye path goes on from); mis: an area light's sample is weighted against the
 * BSDF's sample by the power heuristic with n·p_light (eye_pass.h direct_light_pbr). */
static void pf_direct_light_pbr(const pf_scene_view* s, const float* p, const float* ng,
                                const float* ns, const pf_bsdf_params* bp, const float* wo,
                                int samples, pf_light_draws* draws, int mis, float eps,
                                const float* weight, float* direct, int leaf) {
  if (s->light_count <= 0 || samples <= 0) return;
  float sum[3] = {0.0f, 0.0f, 0.0f};
  for (int smp = 0; smp < samples; ++smp) {
    float ul, u1, u2;
    pf_light_draws_next(draws, &ul, &u1, &u2);
    float p_light;
    const int li = pf_pick_nee_light(s, p, ul, &p_light);
    if (p_light <= 0.0f) continue;
    float q[3], w[3];
    float le[3];
    const float g = pf_light_incident_at(s, li, p, u1, u2, w, q, le);
    if (!(g > 0.0f)) continue;
    float f[3];
    pf_pbr_eval_world(bp, ns, ng, wo, w, f); /* 0 for a pair the normals disagree on */
    if (!(f[0] > 0.0f || f[1] > 0.0f || f[2] > 0.0f)) continue;
    float wmis = 1.0f;
    if (mis && (s->lights[li].type == PF_LIGHT_AREA || s->lights[li].type == PF_LIGHT_ENVIRONMENT))
      wmis = pf_power_heuristic((float)samples * p_light / g,
                                pf_pbr_pdf_world(bp, ns, ng, wo, w));
    const float e = pf_dot3(w, ng) >= 0.0f ? eps : -eps;
    float o[3], sd[3];
    for (int k = 0; k < 3; ++k) o[k] = p[k] + ng[k] * e;
    for (int k = 0; k < 3; ++k) sd[k] = q[k] - o[k];
    pf_ray_hit hit;
    if (pf_trace_from(s, o, sd, 0.0f, 1.0f - 1e-4f, 1, &hit, leaf, 0)) continue;
    const float gp = fabs(pf_dot3(w, ns)) * g / p_light * wmis;
    for (int k = 0; k < 3; ++k) sum[k] = sum[k] + f[k] * le[k] * gp;
  }
  const float inv = 1.0f / (float)samples;
  for (int k = 0; k < 3; ++k) direct[k] = direct[k] + weight[k] * (sum[k] * inv);
}

/* EyeTracer::emitter_hit_weight: the BSDF sample's power-heuristic weight against next-event
 * estimation's n light samples at the vertex `from` it left, for an emitter hit at distance dist
 * along unit direction d (triangle tri, front geometric normal ng); 1 where the triangle is no
 * light. */
static float pf_emitter_hit_weight(const pf_scene_view* s, __global const int* tri_light, int tri,
                                   const float* from, const float* d, const float* ng,
                                   float dist, float bsdf_pdf, int samples) {
  const int li = tri_light[tri];
  if (li < 0) return 1.0f;
  __global const pf_light* l = &s->lights[li];
  const float cos_l = -pf_dot3(d, ng);
  if (!(cos_l > 0.0f) || !(l->area > 0.0f)) return 1.0f;
  const float p_pick = pf_nee_pick_probability(s, li, from);
  const float p_light = p_pick * dist * dist / (l->area * cos_l);
  return pf_power_heuristic(bsdf_pdf, (float)samples * p_light);
}

/* CameraFrame::ray: the ray through image point (px, py) (pixels, y down) and, for a thin lens
 * (cam[14] > 0), lens point (u1, u2); cam as trace_hitpoints' below. */
static void pf_camera_ray(__global const float* cam, int width, int height, float px, float py,
                          float u1, float u2, float* o, float* d) {
  const float eye[3] = {cam[0], cam[1], cam[2]};
  /* CameraFrame::direction */
  const float sx = (2.0f * px / (float)width - 1.0f) * cam[12];
  const float sy = (1.0f - 2.0f * py / (float)height) * cam[13];
  for (int k = 0; k < 3; ++k) {
    o[k] = eye[k];
    d[k] = cam[3 + k] + cam[6 + k] * sx + cam[9 + k] * sy;
  }
  pf_normalize3(d);
  if (cam[14] > 0.0f) {
    float pd[3], fw[3], rt[3], upv[3];
    for (int k = 0; k < 3; ++k) {
      pd[k] = d[k];
      fw[k] = cam[3 + k];
      rt[k] = cam[6 + k];
      upv[k] = cam[9 + k];
    }
    pf_thin_lens_ray(eye, pd, rt, upv, fw, cam[14], cam[15], u1, u2, o, d);
  }
}

/* EyeTracer::emission_sample: emission sample k of K of pixel pix (pixel_sampler.h
 * PF_EMISSION_STREAM), followed through mirrors and glass; adds the emitter fronts it meets times
 * the throughput to L (unweighted). */
static void pf_emission_sample(const pf_scene_view* s, __global const float* cam, int width,
                               int height, int pix, int k, int K, uint seed, uint pass,
                               int max_depth, float eps, float* L) {
  pf_rng rng = pf_emission_rng(seed, pass, (uint)pix, k, max_depth);
  float jx, jy;
  pf_sobol_pixel_sample_keyed(pf_emission_sobol_key(seed), (uint)pix, pass * (uint)K + (uint)k,
                              &jx, &jy);
  float u1 = 0.5f, u2 = 0.5f;
  if (cam[14] > 0.0f) /* the lens point stratified as the jitter (pixel_sampler.h) */
    pf_eye_lens_keyed(PF_SAMPLER_SOBOL, pf_emission_sobol_key(seed), pass, (uint)pix, k, K, &rng,
                      &u1, &u2);
  float o[3], d[3];
  pf_camera_ray(cam, width, height, (float)(pix % width) + jx, (float)(pix / width) + jy, u1, u2,
                o, d);
  float T[3] = {1.0f, 1.0f, 1.0f};
  int leaf = -1; /* the kd leaf of the last hit: the next ray's start (pf_trace_from) */
  for (int depth = 0; depth <= max_depth; ++depth) {
    pf_ray_hit h;
    if (!pf_trace_from(s, o, d, 0.0f, INFINITY, 0, &h, leaf, &leaf)) {
      if (pf_env_width(s->env) > 0) { /* the environment, as the eye samples add it */
        float dn[3] = {d[0], d[1], d[2]}, le[3];
        pf_normalize3(dn);
        pf_env_radiance(s->env, dn, le);
        for (int c = 0; c < 3; ++c) L[c] = L[c] + T[c] * le[c];
      }
      break;
    }
    pf_surface sh;
    pf_surface_at(s, o, d, &h, &sh);
    __global const pf_material* m = &s->mats[sh.material];
    if (m->type == PF_MAT_EMITTER && sh.front)
      for (int c = 0; c < 3; ++c) L[c] = L[c] + T[c] * m->emission[c];
    if (m->type != PF_MAT_MIRROR && m->type != PF_MAT_GLASS) break;
    float n[3];
    for (int c = 0; c < 3; ++c) n[c] = sh.front ? sh.ns[c] : -sh.ns[c];
    pf_normalize3(d);
    if (m->type == PF_MAT_MIRROR) {
      for (int c = 0; c < 3; ++c) T[c] = T[c] * m->color[c];
      pf_reflect(d, n, d);
    } else {
      const float u = pf_rng_next(&rng);
      pf_glass_bounce(m, &sh, n, u, d, T);
    }
    if (pf_luminance3(T) <= 0.0f) break;
    pf_offset_origin(&sh, d, eps, o);
  }
}

/* cam: eye[3], forward[3], right[3], up[3], tan_half_x, tan_half_y, aperture, focus_distance
 * (camera.h's CameraFrame; aperture > 0: a thin lens, lens_shared.h, as CameraFrame::ray).
 * Pixels pixel_offset .. pixel_offset + pixel_count − 1 (row-major) form this batch; outputs are
 * indexed from the batch's start. */
__kernel void trace_hitpoints(PF_SCENE_PARAMS, PF_TEXTURE_PARAMS, PF_ALPHA_PARAMS,
                              __global const float* cam,
                              int width, int height,
                              int spp, int columns, int max_depth, int shadow_rays,
                              int shadow_samples, float radius, int glossy_mis,
                              uint seed, uint pass,
                              int sampler, float eps,
                              int pixel_offset, int pixel_count, __global pf_hitpoint* slots,
                              __global int* used, __global float* emitted_out,
                              __global float* direct_out, int has_pbr,
                              __global pf_pbr_point* pbr_slots,
                              __global const uchar* emit_pixels, int emission_spp,
                              __global const int* tri_light, __global const uchar* glossy_pixels,
                              int glossy_spp, __global const pf_light_choice* light_choice,
                              int light_choice_on) {
  const int local_pix = (int)get_global_id(0);
  if (local_pix >= pixel_count) return;
  PF_SCENE_VIEW(s);
  PF_ALPHA_VIEW(s);
  s.choice = light_choice;
  s.choice_on = light_choice_on;
  const int pix = pixel_offset + local_pix;
  const int x = pix % width, y = pix / width;
  float emitted[3] = {0.0f, 0.0f, 0.0f}, direct[3] = {0.0f, 0.0f, 0.0f};
  /* EyeTracer::samples: spp, and glossy_spp more in a marked pixel; slots per pixel: spp +
   * glossy_spp (the host's layout), the unused ones flagged 0 */
  const int slots_per_pixel = spp + glossy_spp;
  const int n_samples = spp + (glossy_spp > 0 && glossy_pixels[pix] ? glossy_spp : 0);
  for (int smp = spp; smp < slots_per_pixel; ++smp)
    used[(size_t)local_pix * (size_t)slots_per_pixel + (size_t)smp] = 0;
  for (int smp = 0; smp < n_samples; ++smp) {
    const size_t slot = (size_t)local_pix * (size_t)slots_per_pixel + (size_t)smp;
    used[slot] = 0;
    pf_rng rng;
    float jx, jy;
    /* thin lens: its point is drawn after the jitter (pixel_sampler.h) */
    float u1 = 0.5f, u2 = 0.5f;
    const int extra = smp >= spp;
    /* the first glossy vertex's BSDF sample (pixel_sampler.h pf_eye_lobe_keyed) */
    int lobe_sobol;
    uint lobe_key, lobe_index;
    if (!extra) {
      const uint index = (uint)pix * (uint)spp + (uint)smp;
      rng = pf_rng_start(seed, PF_EYE_STREAM + pass, index);
      lobe_sobol = sampler == PF_SAMPLER_SOBOL;
      lobe_key = pf_sobol_key(seed);
      lobe_index = pass * (uint)spp + (uint)smp;
      pf_eye_jitter(sampler, seed, pass, (uint)pix, smp, spp, columns, &rng, &jx, &jy);
      if (cam[14] > 0.0f)
        pf_eye_lens_keyed(sampler, pf_sobol_key(seed), pass, (uint)pix, smp, spp, &rng, &u1, &u2);
    } else { /* a glossy sample (pixel_sampler.h PF_GLOSSY_STREAM) */
      const int k = smp - spp;
      const uint index = (uint)pix * (uint)glossy_spp + (uint)k;
      rng = pf_rng_start(seed, PF_GLOSSY_STREAM + pass, index);
      pf_sobol_pixel_sample_keyed(pf_glossy_sobol_key(seed), (uint)pix,
                                  pass * (uint)glossy_spp + (uint)k, &jx, &jy);
      lobe_sobol = 1;
      lobe_key = pf_glossy_sobol_key(seed);
      lobe_index = pass * (uint)glossy_spp + (uint)k;
      if (cam[14] > 0.0f) {
        u1 = pf_rng_next(&rng);
        u2 = pf_rng_next(&rng);
      }
    }
    /* eye_pass.cpp nee_draws: the light draws of the path's vertices with next-event
     * estimation, in order (pixel_sampler.h pf_light_draws_vertex) */
    const int draws_sobol = extra || sampler == PF_SAMPLER_SOBOL;
    int nee = 0, eye_draws = 0;
    float o[3], d[3];
    pf_camera_ray(cam, width, height, (float)x + jx, (float)y + jy, u1, u2, o, d);
    const float w0 = 1.0f / (float)n_samples;
    float T[3] = {w0, w0, w0};
    /* eye_pass.cpp EyeTracer::sample: from_glossy, last, merged, glossy, glossy_pdf, T_direct */
    int from_glossy = 0, last = 0, merged = 0, glossy = 0;
    float glossy_pdf = 0.0f;
    float Td[3] = {0.0f, 0.0f, 0.0f};
    float glossy_p[3] = {0.0f, 0.0f, 0.0f}; /* that vertex (its NEE's light choice) */
    int leaf = -1;  /* the kd leaf of the last hit: the next ray's start (pf_trace_from) */
    for (int depth = 0; depth <= max_depth; ++depth) {
      pf_ray_hit h;
      if (!pf_trace_from(&s, o, d, 0.0f, INFINITY, 0, &h, leaf, &leaf)) {
        /* eye_pass.cpp: the environment along the escaping ray */
        if (pf_env_width(s.env) > 0) {
          float dn[3] = {d[0], d[1], d[2]}, le[3];
          pf_normalize3(dn);
          pf_env_radiance(s.env, dn, le);
          if (from_glossy) {
            const float wl = pf_power_heuristic(
                glossy_pdf, (float)shadow_samples * pf_env_light_pdf_at(&s, dn, glossy_p));
            for (int k = 0; k < 3; ++k) direct[k] = direct[k] + Td[k] * le[k] * wl;
          } else {
            float* layer = glossy ? direct : emitted;
            for (int k = 0; k < 3; ++k) layer[k] = layer[k] + T[k] * le[k];
          }
        }
        break;
      }
      pf_surface sh;
      pf_surface_at(&s, o, d, &h, &sh);
      __global const pf_material* m = &s.mats[sh.material];
      if (m->type == PF_MAT_EMITTER && sh.front) {
        if (from_glossy) {
          const float wl = pf_emitter_hit_weight(&s, tri_light, h.tri, glossy_p, d, sh.ng, h.t,
                                                 glossy_pdf, shadow_samples);
          for (int k = 0; k < 3; ++k) direct[k] = direct[k] + Td[k] * m->emission[k] * wl;
        } else {
          float* layer = glossy ? direct : emitted;
          for (int k = 0; k < 3; ++k) layer[k] = layer[k] + T[k] * m->emission[k];
        }
      }
      if (last) break; /* the ray was traced for the emitter's light only */
      from_glossy = 0;
      float n[3];
      for (int k = 0; k < 3; ++k) n[k] = sh.front ? sh.ns[k] : -sh.ns[k];
      const int pbr = PF_SCENE_PBR && m->type == PF_MAT_PBR; /* scene_features.h */
      if (pbr || pf_is_diffuse(m)) {
        /* Diffuse: the texture's value joins the weight (eye_pass.cpp): the gathers' f_r =
         * color/π. PBR: the weight carries no texture factor; the point's BSDF parameters do
         * (pbr_point_shared.h, a table parallel to the hitpoints, written for every hitpoint of a
         * scene with a PBR material). */
        float tf[3];
        pf_pbr_point pt;
        float hw[3] = {T[0], T[1], T[2]}; /* the hitpoint's weight */
        float nd[3] = {d[0], d[1], d[2]};
        if (depth > 0) pf_normalize3(nd); /* the camera ray's is unit already */
        const float wo[3] = {-nd[0], -nd[1], -nd[2]};
        int merge = 1;
        float q = 1.0f, o_loc[3];
        if (pbr) {
          pf_pbr_params_hit(textures, texels, mat_tex, uvs, mr_tex, s.mats, sh.material, &h,
                            &pt.params);
          pt.outside = sh.front ? PF_PBR_POINT_OUTSIDE : 0;
          if (glossy_mis) {
            /* merge_weight_shared.h: the merge probability, then the choice */
            pf_bsdf_to_local(sh.ns, wo, o_loc);
            q = pf_merge_probability(&pt.params, o_loc);
            const float u_merge = pf_rng_next(&rng);
            merge = q >= 1.0f || (q > 0.0f && u_merge < q);
            pf_light_draws draws =
                pf_light_draws_vertex(draws_sobol, lobe_key, seed, pass, (uint)pix, smp, spp,
                                      lobe_index, shadow_samples, nee++, rng, &eye_draws);
            pf_direct_light_pbr(&s, sh.p, sh.ng, sh.ns, &pt.params, wo, shadow_samples, &draws, 1,
                                eps, T, direct, leaf);
            if (eye_draws) rng = draws.rng;
          }
        } else if (pf_texture_factor(textures, texels, mat_tex, uvs, sh.material, &h, tf)) {
          for (int k = 0; k < 3; ++k) T[k] = T[k] * tf[k];
          for (int k = 0; k < 3; ++k) hw[k] = T[k];
        }
        /* the BSDF's sample at a glossy vertex (GlossyMerge::Mis) */
        float wi[3], wt[3], pdf = 0.0f;
        int sampled = 0;
        if (pbr && glossy_mis) {
          float u1, u2, u3;
          pf_eye_lobe_keyed(lobe_sobol, lobe_key, (uint)pix, lobe_index, &rng, &u1, &u2, &u3);
          lobe_sobol = 0;
          sampled = pf_pbr_scatter(&pt.params, sh.ns, sh.ng, wo, u1, u2, u3,
                                   PF_TRANSPORT_RADIANCE, wi, wt, &pdf);
        }
        if (!merge) {
          if (!sampled) break;
          float share = 1.0f;
          if (q > 0.0f) {
            float il[3];
            pf_bsdf_to_local(sh.ns, wi, il);
            share = (1.0f - pf_merge_weight(&pt.params, o_loc, il)) / (1.0f - q);
          }
          for (int k = 0; k < 3; ++k) {
            Td[k] = T[k] * wt[k];
            T[k] = Td[k] * share;
          }
          glossy_pdf = pdf;
          for (int k = 0; k < 3; ++k) glossy_p[k] = sh.p[k];
          from_glossy = glossy = 1;
          if (!(pf_luminance3(Td) > 0.0f)) break;
          last = !(pf_luminance3(T) > 0.0f);
          for (int k = 0; k < 3; ++k) d[k] = wi[k];
          pf_offset_origin(&sh, d, eps, o);
          continue;
        }
        if (pbr && glossy_mis && q < 1.0f) {
          pt.outside |= PF_PBR_POINT_MERGE_WEIGHTED;
          for (int k = 0; k < 3; ++k) hw[k] = T[k] * (1.0f / q);
        }
        pf_hitpoint hp;
        for (int k = 0; k < 3; ++k) {
          hp.position[k] = sh.p[k];
          hp.normal[k] = n[k];
          hp.dir[k] = nd[k];
          hp.weight[k] = hw[k];
          hp.flux[k] = 0.0f;
        }
        hp.radius = radius;
        hp.n_photons = 0.0f;
        hp.pixel_x = x;
        hp.pixel_y = y;
        hp.mesh = sh.mesh;
        hp.material = sh.material;
        slots[slot] = hp;
        used[slot] = 1;
        if (PF_SCENE_PBR && has_pbr) {
          if (!pbr) { /* a diffuse hitpoint's entry: zeros, never read */
            for (int k = 0; k < 3; ++k) pt.params.base_color[k] = 0.0f;
            pt.params.metallic = pt.params.roughness = pt.params.transmission = pt.params.ior = 0.0f;
            pt.outside = 0;
          }
          pbr_slots[slot] = pt;
        }
        if (pbr && glossy_mis) {
          /* the BSDF's sample is traced for the emitter it may hit (its MIS-weighted light) */
          if (!sampled) break;
          for (int k = 0; k < 3; ++k) Td[k] = T[k] * wt[k];
          glossy_pdf = pdf;
          for (int k = 0; k < 3; ++k) glossy_p[k] = sh.p[k];
          from_glossy = last = merged = 1;
          for (int k = 0; k < 3; ++k) d[k] = wi[k];
          pf_offset_origin(&sh, d, eps, o);
          continue;
        }
        if (shadow_rays) {
          pf_light_draws draws =
              pf_light_draws_vertex(draws_sobol, lobe_key, seed, pass, (uint)pix, smp, spp,
                                    lobe_index, shadow_samples, nee++, rng, &eye_draws);
          if (pbr) {
            pf_direct_light_pbr(&s, sh.p, sh.ng, sh.ns, &pt.params, wo, shadow_samples, &draws, 0,
                                eps, T, direct, leaf);
          } else {
            float ng[3];
            for (int k = 0; k < 3; ++k) ng[k] = sh.front ? sh.ng[k] : -sh.ng[k];
            pf_direct_light(&s, sh.p, ng, n, m, shadow_samples, &draws, eps, T, direct, leaf);
          }
        }
        break;
      }
      pf_normalize3(d);
      if (m->type == PF_MAT_MIRROR) {
        for (int k = 0; k < 3; ++k) T[k] = T[k] * m->color[k];
        pf_reflect(d, n, d);
      } else if (m->type == PF_MAT_GLASS) {
        const float u = pf_rng_next(&rng);
        pf_glass_bounce(m, &sh, n, u, d, T);
      } else {
        break; /* an emitter that does not reflect */
      }
      if (pf_luminance3(T) <= 0.0f) break;
      pf_offset_origin(&sh, d, eps, o);
    }
  }
  if (emission_spp > 0 && emit_pixels[pix]) { /* EyeTracer::emitted_layer */
    float sum[3] = {0.0f, 0.0f, 0.0f};
    for (int k = 0; k < emission_spp; ++k)
      pf_emission_sample(&s, cam, width, height, pix, k, emission_spp, seed, pass, max_depth, eps,
                         sum);
    const float inv = 1.0f / (float)(n_samples + emission_spp);
    for (int k = 0; k < 3; ++k) emitted[k] = emitted[k] * ((float)n_samples * inv) + sum[k] * inv;
  }
  for (int k = 0; k < 3; ++k) {
    emitted_out[3 * (size_t)local_pix + k] = emitted[k];
    direct_out[3 * (size_t)local_pix + k] = direct[k];
  }
}
