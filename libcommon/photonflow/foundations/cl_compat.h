/*
 * cl_compat.h — the few macros that let one C source compile both as C++ (host) and as OpenCL C
 * 1.2 (kernels): every header the kernels compile from the host's tree (the *_shared.h headers,
 * rng.h, ppm.h, pixel_sampler.h) includes it.
 *
 *   PF_INLINE  function qualifier: `static inline` in OpenCL C (C99 inline semantics would
 *              otherwise ask for an external definition), `inline` in C++ (one definition across
 *              translation units).
 *   PF_GLOBAL  address space of scene/photon buffers: `__global` in kernels, nothing on the host.
 */
#ifndef PHOTONFLOW_CL_COMPAT_H
#define PHOTONFLOW_CL_COMPAT_H

#ifdef __OPENCL_VERSION__
#define PF_INLINE static inline
#define PF_GLOBAL __global
#else
#define PF_INLINE inline
#define PF_GLOBAL
#endif

#endif /* PHOTONFLOW_CL_COMPAT_H */
