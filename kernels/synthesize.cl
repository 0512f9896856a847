/*
 * synthesize.cl — image synthesis on an OpenCL device (thesis ch. 7.2, last block; CPU twin:
 * synthesize.cpp): every pixel sums weight · τ/(π R² N_emitted) (eq. 3.19) of its hitpoints on
 * top of the eye pass's emitted + direct layers, and the means of the AOV layers radius/photons
 * and their count (hitpoints).
 *
 * One work-item per pixel adds its hitpoints in their order in the hitpoint array (the host's
 * stable per-pixel start table), the order synthesize.cpp adds them in: with FP_CONTRACT off and
 * correctly rounded division the image is the CPU's bit for bit, on any device and for any work-
 * group or batch size. (An atomic add per hitpoint, the first version, left the order of a pixel's
 * hitpoints to the scheduler: a GPU could round the last bit differently from run to run.)
 */
#pragma OPENCL FP_CONTRACT OFF
#include "photonflow/foundations/shared_types.h"
#include "photonflow/estimators/ppm.h"

/* Pixels [first, first + n) of this batch; their hitpoints are hps[start[k], start[k + 1]) in
 * order (k = pixel - first, start rebased to the batch). */
__kernel void synth_pixels(__global const pf_hitpoint* hps, __global const int* start, int first,
                           int n, float n_emitted, int has_photons,
                           __global const float* emitted, __global const float* direct,
                           __global float* rgb, __global float* radius, __global float* photons,
                           __global float* count) {
  const int k = (int)get_global_id(0);
  if (k >= n) return;
  const int o = first + k;
  float c0 = emitted[3 * o + 0] + direct[3 * o + 0];
  float c1 = emitted[3 * o + 1] + direct[3 * o + 1];
  float c2 = emitted[3 * o + 2] + direct[3 * o + 2];
  float r = 0.0f, m = 0.0f, cnt = 0.0f;
  for (int i = start[k]; i < start[k + 1]; ++i) {
    __global const pf_hitpoint* hp = &hps[i];
    if (has_photons) {
      c0 += hp->weight[0] * pf_ppm_radiance(hp->flux[0], hp->radius, n_emitted);
      c1 += hp->weight[1] * pf_ppm_radiance(hp->flux[1], hp->radius, n_emitted);
      c2 += hp->weight[2] * pf_ppm_radiance(hp->flux[2], hp->radius, n_emitted);
    }
    r += hp->radius;
    m += hp->n_photons;
    cnt += 1.0f;
  }
  rgb[3 * o + 0] = c0;
  rgb[3 * o + 1] = c1;
  rgb[3 * o + 2] = c2;
  radius[o] = cnt > 0.0f ? r / cnt : 0.0f;
  photons[o] = cnt > 0.0f ? m / cnt : 0.0f;
  count[o] = cnt;
}
