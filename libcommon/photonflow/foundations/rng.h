/*
 * rng.h — counter-based (stateless) random numbers shared by the C++ host and OpenCL C 1.2 kernels.
 *
 * A sample is a pure function of four 32-bit words: (seed, pass, index, dim) — e.g. dimension k
 * of photon i in photon pass p of a run with seed s. Nothing is carried between samples, so a
 * result never depends on thread count, work-group size, scheduling or backend (the thesis's GPU
 * version kept per-photon LCG seeds between passes, ch. 7.2; a counter-based generator needs no
 * such state and gives the same photons on the CPU and on a device).
 *
 * Construction: a chain of "lowbias32" integer hashes (C. Wellons, 2018: xorshift-multiply
 * permutation of 32-bit words with measured avalanche bias ~0.17):
 *   key = H(H(seed ^ K0) ^ pass)            (pf_rng_key: once per pass)
 *   u   = H(H(key ^ index) ^ dim·φ32)        (φ32 = 0x9E3779B9, an odd constant: spreads dims)
 * H is a bijection of 32-bit words, so for a fixed (seed, pass, dim) the map index → u is a
 * bijection, and likewise dim → u for a fixed (seed, pass, index): no two photons of one pass (or
 * two dimensions of one photon) ever get the same 32-bit word.
 * Floats have 24 bits of resolution: pf_rng_unit(u) = (u >> 8)·2^−24 ∈ [0, 1 − 2^−24], never 1.
 *
 * Only 32-bit unsigned integer arithmetic is used (wrap-around multiplication and shifts), which
 * is exact and identical in C++ and OpenCL C.
 */
#ifndef PHOTONFLOW_RNG_H
#define PHOTONFLOW_RNG_H

#include "photonflow/foundations/cl_compat.h"
#include "photonflow/foundations/shared_types.h"

/* "lowbias32" 32-bit integer hash (bijective). */
PF_INLINE pf_uint pf_hash32(pf_uint x) {
  x ^= x >> 16;
  x *= 0x7feb352dU;
  x ^= x >> 15;
  x *= 0x846ca68bU;
  x ^= x >> 16;
  return x;
}

/* Per-pass key of a run: compute once per pass and reuse for all its samples. */
PF_INLINE pf_uint pf_rng_key(pf_uint seed, pf_uint pass) {
  return pf_hash32(pf_hash32(seed ^ 0x2545f491U) ^ pass);
}

/* 32 random bits for sample `dim` of item `index` under a pass key. */
PF_INLINE pf_uint pf_rng_bits(pf_uint key, pf_uint index, pf_uint dim) {
  return pf_hash32(pf_hash32(key ^ index) ^ (dim * 0x9e3779b9U));
}

/* Maps 32 random bits to a float in [0, 1) with 24-bit resolution: the top 24 bits times 2^-24.
 * Every value k·2^-24 (k < 2^24) is exact in single precision, so the result is never 1.0. */
PF_INLINE pf_float pf_rng_unit(pf_uint bits) {
  return (pf_float)(bits >> 8) * (1.0f / 16777216.0f);
}

/* Sample `dim` of item `index` in pass `pass` of the run with `seed`, uniform in [0, 1). */
PF_INLINE pf_float pf_rng_float(pf_uint seed, pf_uint pass, pf_uint index, pf_uint dim) {
  return pf_rng_unit(pf_rng_bits(pf_rng_key(seed, pass), index, dim));
}

/* Sequential view of one item's dimensions: pf_rng_next returns dimensions dim, dim+1, ... of
 * (key, index). It is only a cursor over the stateless function above: the k-th call returns
 * exactly pf_rng_float(seed, pass, index, k) for a stream started at dim 0. */
typedef struct {
  pf_uint key;
  pf_uint index;
  pf_uint dim;
} pf_rng;

PF_INLINE pf_rng pf_rng_start(pf_uint seed, pf_uint pass, pf_uint index) {
  pf_rng r;
  r.key = pf_rng_key(seed, pass);
  r.index = index;
  r.dim = 0;
  return r;
}

PF_INLINE pf_float pf_rng_next(pf_rng* r) {
  pf_float u = pf_rng_unit(pf_rng_bits(r->key, r->index, r->dim));
  r->dim += 1;
  return u;
}

#endif /* PHOTONFLOW_RNG_H */
