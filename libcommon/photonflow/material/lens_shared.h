/*
 * material/lens_shared.h — thin-lens camera rays for depth of field, shared by the C++ host and
 * the OpenCL C 1.2 kernels.
 *
 * Layer: camera/material model (libcommon/photonflow/material/); depends on sampling_shared.h
 * (Shirley–Chiu concentric disc, vector helpers). Used by the host's camera (geometry/camera.h,
 * CameraFrame::ray) and the OpenCL eye pass (kernels/trace_hitpoints.cl) when --aperture > 0.
 *
 *   | parameter      | units        | meaning                                                |
 *   |----------------|--------------|--------------------------------------------------------|
 *   | aperture       | world        | lens radius a (0: the pinhole camera, rays unchanged)  |
 *   | focus_distance | world        | d, distance along the view axis of the sharp plane     |
 *   | right, up      | unit vectors | the camera's image axes (the lens disc's plane)        |
 *   | forward        | unit vector  | the view axis (normal of the focus plane)              |
 *   | u1, u2         | [0, 1)       | the lens sample (two low-discrepancy dimensions)       |
 *
 * Model: the pinhole ray o + t·dir meets the plane {p : (p − o)·forward = d} at
 * P = o + dir·d/(dir·forward). The lens point is L = o + a·(x·right + y·up) with (x, y) uniform on
 * the unit disc (concentric mapping, Shirley & Chiu 1997), and the thin-lens ray is L + t·(P − L)
 * normalized. Every lens sample of a pixel passes through the same P, so the focus plane is sharp;
 * a point at depth z ≠ d is smeared over a disc whose diameter, measured on the focus plane, is
 * the circle of confusion c(z) = 2a·|z − d| / z (pf_lens_coc_diameter). Divide by the focus
 * plane's pixel footprint (2 d tan(fov_y/2) / height) to get it in pixels.
 */
#ifndef PHOTONFLOW_MATERIAL_LENS_SHARED_H
#define PHOTONFLOW_MATERIAL_LENS_SHARED_H

#include "photonflow/foundations/cl_compat.h"
#include "photonflow/sampling/sampling_shared.h"

#ifdef __OPENCL_VERSION__
#pragma OPENCL FP_CONTRACT OFF
#endif

/* Thin-lens ray for the pinhole ray (o, dir) (dir not necessarily unit, dir·forward > 0).
 * Writes out_o (on the lens) and out_d (unit). Returns 0 and the pinhole ray (dir normalized)
 * when aperture ≤ 0, focus_distance ≤ 0 or dir·forward ≤ 0; 1 otherwise. */
PF_INLINE int pf_thin_lens_ray(const float* o, const float* dir, const float* right,
                               const float* up, const float* forward, float aperture,
                               float focus_distance, float u1, float u2, float* out_o,
                               float* out_d) {
  const float df = pf_dot3(dir, forward);
  if (!(aperture > 0.0f) || !(focus_distance > 0.0f) || !(df > 0.0f)) {
    for (int k = 0; k < 3; ++k) {
      out_o[k] = o[k];
      out_d[k] = dir[k];
    }
    pf_normalize3(out_d);
    return 0;
  }
  float x, y;
  pf_sample_concentric_disc(u1, u2, &x, &y);
  const float t = focus_distance / df;
  for (int k = 0; k < 3; ++k) {
    const float p = o[k] + dir[k] * t;                               /* on the focus plane */
    const float l = o[k] + (right[k] * x + up[k] * y) * aperture;    /* on the lens */
    out_o[k] = l;
    out_d[k] = p - l;
  }
  pf_normalize3(out_d);
  return 1;
}

/* Diameter of the circle of confusion of a point at depth z (distance along the view axis, > 0)
 * for lens radius `aperture` focused at `focus_distance`, measured on the focus plane (world
 * units): 2a·|z − d| / z. 0 for z = d; → 2a for z → ∞. */
PF_INLINE float pf_lens_coc_diameter(float aperture, float focus_distance, float z) {
  if (!(z > 0.0f)) return 0.0f;
  return 2.0f * aperture * PF_S_FABS(z - focus_distance) / z;
}

#endif /* PHOTONFLOW_MATERIAL_LENS_SHARED_H */
