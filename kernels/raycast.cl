/*
 * raycast.cl — closest-hit and any-hit ray casting over the baked scene with the kernels' rope
 * traversal (trace_common.h: intersect_shared.h's stackless traversal with the four-wide leaf
 * test). Used by tests to check the device traversal against the host's, ray by ray.
 * rays: 8 floats each (origin, direction, tmin, tmax). Alpha cut-outs apply (PF_ALPHA_PARAMS).
 */
#pragma OPENCL FP_CONTRACT OFF
#include "trace_common.h"

__kernel void cast_rays(PF_SCENE_PARAMS, PF_TEXTURE_PARAMS, PF_ALPHA_PARAMS,
                        __global const float* rays, int count, int any_hit,
                        __global pf_ray_hit* hits) {
  const int i = (int)get_global_id(0);
  if (i >= count) return;
  PF_SCENE_VIEW(s);
  PF_ALPHA_VIEW(s);
  __global const float* r = rays + 8 * (size_t)i;
  const float o[3] = {r[0], r[1], r[2]};
  const float d[3] = {r[3], r[4], r[5]};
  pf_ray_hit h;
  pf_trace(&s, o, d, r[6], r[7], any_hit, &h);
  hits[i] = h;
}
