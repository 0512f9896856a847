/*
 * synthesize.cl — image synthesis on an OpenCL device (thesis ch. 7.2, last block; CPU twin:
 * synthesize.cpp): every hitpoint adds weight · τ/(π R² N_emitted) (eq. 3.19) to its pixel with an
 * atomic float add — a compare-and-swap loop, OpenCL 1.2 having no float atomics — on top of the
 * eye pass's emitted + direct layers; the AOV layers radius/photons (means) and hitpoints (count)
 * are accumulated the same way.
 */
#pragma OPENCL FP_CONTRACT OFF
#include "photonflow/shared_types.h"
#include "photonflow/ppm.h"

static inline void pf_atomic_add_float(volatile __global float* p, float v) {
  union {
    unsigned int u;
    float f;
  } old_v, new_v;
  do {
    old_v.f = *p;
    new_v.f = old_v.f + v;
  } while (atomic_cmpxchg((volatile __global unsigned int*)p, old_v.u, new_v.u) != old_v.u);
}

/* rgb = emitted + direct; AOV layers zero. */
__kernel void synth_init(__global const float* emitted, __global const float* direct,
                         int pixel_count, __global float* rgb, __global float* radius,
                         __global float* photons, __global float* count) {
  const int o = (int)get_global_id(0);
  if (o >= pixel_count) return;
  for (int c = 0; c < 3; ++c) rgb[3 * o + c] = emitted[3 * o + c] + direct[3 * o + c];
  radius[o] = 0.0f;
  photons[o] = 0.0f;
  count[o] = 0.0f;
}

/* Hitpoints [0, n) of this batch. */
__kernel void synth_splat(__global const pf_hitpoint* hps, int n, int width, float n_emitted,
                          int has_photons, __global float* rgb, __global float* radius,
                          __global float* photons, __global float* count) {
  const int i = (int)get_global_id(0);
  if (i >= n) return;
  __global const pf_hitpoint* hp = &hps[i];
  const int o = hp->pixel_y * width + hp->pixel_x;
  if (has_photons) {
    for (int c = 0; c < 3; ++c)
      pf_atomic_add_float(&rgb[3 * o + c],
                          hp->weight[c] * pf_ppm_radiance(hp->flux[c], hp->radius, n_emitted));
  }
  pf_atomic_add_float(&radius[o], hp->radius);
  pf_atomic_add_float(&photons[o], hp->n_photons);
  pf_atomic_add_float(&count[o], 1.0f);
}

/* Means of the AOV layers. */
__kernel void synth_finish(int pixel_count, __global float* radius, __global float* photons,
                           __global const float* count) {
  const int o = (int)get_global_id(0);
  if (o >= pixel_count) return;
  const float c = count[o];
  if (c > 0.0f) {
    radius[o] = radius[o] / c;
    photons[o] = photons[o] / c;
  }
}
