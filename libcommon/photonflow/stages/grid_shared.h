/*
 * grid_shared.h — grid arithmetic shared by the host (photon_grid.h, clusters.h, cl_build_grid.cpp)
 * and the OpenCL kernels (kernels/build_grid.cl, kernels/illuminate_methods.cl), compiled as C++
 * and as OpenCL C 1.2 so that both sides put every photon into the same bin, bit for bit:
 *
 *   - pf_grid_coord / pf_grid_bin: the per-mesh uniform grid of thesis eq. 7.1,
 *       c = clamp(floor((x − lo)/d), 0, n − 1) per axis, offset = cx + cy·nx + cz·nx·ny;
 *   - pf_hash_slot: the hashed grid of the `hash-grid` gather (one grid over all meshes, its
 *     cells hashed into a power-of-two table by their linear index, so that neighbouring cells
 *     stay neighbours in memory — unlike the XOR-of-primes hash of Teschner et al. 2003, which
 *     scatters them and made each cell visit a cache miss here);
 *   - pf_float_ordered / pf_ordered_float: a monotone map of floats to signed ints, so that
 *     atomic_min/atomic_max on ints compute float minima/maxima on the device (grid bounds).
 *
 * Division must be correctly rounded on the device for the bins to agree with the host; the
 * runtime builds kernels with -cl-fp32-correctly-rounded-divide-sqrt where the device offers it
 * (cl_runtime.cpp).
 */
#ifndef PHOTONFLOW_GRID_SHARED_H
#define PHOTONFLOW_GRID_SHARED_H

#include "photonflow/foundations/cl_compat.h"
#include "photonflow/foundations/shared_types.h"

#ifndef __OPENCL_VERSION__
#include <cmath>
#include <cstring>
#if defined(__SSE__)
#include <xmmintrin.h>
#endif
#endif

/* c clamped to [0, top], NaN → 0, without branches. OpenCL compilers turn the comparisons into
 * selects; GCC keeps branches for them (maxss / minss would change which compares raise FP
 * exceptions, and it branches on which value to convert), so the host uses maxss / minss
 * themselves, whose NaN rule (the second operand) gives the same result. */
PF_INLINE pf_float pf_grid_clamp(pf_float c, pf_float top) {
#if !defined(__OPENCL_VERSION__) && defined(__SSE__)
  return _mm_cvtss_f32(_mm_min_ss(_mm_max_ss(_mm_set_ss(c), _mm_setzero_ps()), _mm_set_ss(top)));
#else
  c = c > 0.0f ? c : 0.0f;
  return c < top ? c : top;
#endif
}

/* Bin coordinate of x along one axis (eq. 7.1), clamped to [0, n−1]. Monotone in x, so the bins
 * overlapping an interval [x0, x1] are those from coord(x0) to coord(x1). NaN maps to 0.
 * The clamps are selects, not branches: photons on a scene's walls lie on the grid's faces, so
 * which side of a clamp a coordinate falls on is unpredictable, and branches mispredict on a
 * third of them (docs/BENCHMARKS.md "How hash-grid's pass is built"). */
PF_INLINE pf_int pf_grid_coord(pf_float x, pf_float lo, pf_float bin_size, pf_int n) {
  return (pf_int)pf_grid_clamp((x - lo) / bin_size, (pf_float)(n - 1)); /* n − 1 exact: n <= 2^24 */
}

/* Linear bin offset of point p in the grid of g (eq. 7.1): x + y·nx + z·nx·ny. */
PF_INLINE pf_int pf_grid_bin(const PF_GLOBAL pf_mesh_grid* g, pf_float px, pf_float py,
                             pf_float pz) {
  pf_int x = pf_grid_coord(px, g->lo[0], g->bin_size, g->nx);
  pf_int y = pf_grid_coord(py, g->lo[1], g->bin_size, g->ny);
  pf_int z = pf_grid_coord(pz, g->lo[2], g->bin_size, g->nz);
  return x + (y + z * g->ny) * g->nx;
}

/* Table slot of cell (x, y, z) of the hashed grid (cells of a grid of nx × ny × nz cubes over the
 * scene, coordinates from pf_grid_coord): the linear cell index x + nx·(y + ny·z) modulo the table
 * size mask + 1 (a power of two; uint arithmetic wraps modulo 2^32, which the table size divides).
 * Cells next to each other along x get consecutive slots, so a gather sphere's row of cells reads
 * one contiguous run of slots and photons. */
PF_INLINE pf_uint pf_hash_slot(pf_int x, pf_int y, pf_int z, pf_uint nx, pf_uint ny, pf_uint mask) {
  return ((pf_uint)x + nx * ((pf_uint)y + ny * (pf_uint)z)) & mask;
}

/* The key the hashed-grid gather tests for a photon (pf_photon_keys4): 2·mesh + 1 when the photon
 * is PF_PHOTON_DIRECT, so one integer compare checks the mesh (key >> 1) or mesh and flag (key). */
PF_INLINE pf_int pf_photon_hash_key(pf_int mesh, pf_int flags) {
  return 2 * mesh + ((flags & PF_PHOTON_DIRECT) ? 1 : 0);
}

/* Monotone float → int: a < b (floats, not NaN) ⇔ pf_float_ordered(a) < pf_float_ordered(b),
 * with −0 ordered just below +0. pf_ordered_float inverts it. */
PF_INLINE pf_int pf_float_ordered(pf_float f) {
#ifdef __OPENCL_VERSION__
  pf_int i = as_int(f);
#else
  pf_int i;
  std::memcpy(&i, &f, sizeof i);
#endif
  return i >= 0 ? i : (pf_int)(i ^ 0x7fffffff);
}
PF_INLINE pf_float pf_ordered_float(pf_int i) {
  pf_int b = i >= 0 ? i : (pf_int)(i ^ 0x7fffffff);
#ifdef __OPENCL_VERSION__
  return as_float(b);
#else
  pf_float f;
  std::memcpy(&f, &b, sizeof f);
  return f;
#endif
}

#endif /* PHOTONFLOW_GRID_SHARED_H */
