// path_sampler.h — the numbers of one camera path of the path tracer (stages/pathtrace.cpp), by
// named dimension, from one of two samplers:
//
//   Independent  every number its own counter-based draw: dimension d of sample s of pixel p is
//                pf_rng_bits(pf_rng_key(seed, kPathStream + s), p, d) (foundations/rng.h).
//   Sobol        padded, Owen-scrambled Sobol points (pbrt-v4's PaddedSobolSampler; Kollig &
//                Keller 2002 for the padding): each dimension of the path — a 1-D one (the light
//                choice, a lobe choice, the roulette) or a 2-D one (the pixel position, the lens,
//                a point on a light, a BSDF direction) — is its own per-pixel scrambled
//                (0,2)-sequence (1-D: van der Corput), indexed by the pixel's sample number s
//                after a per-pixel, per-dimension nested permutation of s's bits
//                (pf_owen_scramble on the index's low 16 bits, as the eye pass's lens samples,
//                pixel_sampler.h, on all 32). The permutation maps every aligned block of 2^k indices onto
//                an aligned block, which the sequence fills as a (0,k,2)-net (stratified in every
//                2^a × 2^b elementary interval, a + b = k); it decorrelates the dimensions from
//                one another. So at a diffuse or glossy vertex the first 2^k samples of a pixel
//                stratify the light's area and the BSDF's directions, where independent numbers
//                clump: Mitsuba 3's multijitter and pbrt-v4's samplers owe their lower error per
//                sample to this (docs/RESULTS.md, section 10).
//
// Every number is uniform on [0, 1) (Owen scrambling is a uniform random permutation of the
// digits) and the numbers of one sample in different dimensions are independent (independent
// scrambles), so every estimate stays unbiased whatever a path draws, and a pixel's samples stay
// independent of every other pixel's. A sample's numbers depend on (seed, pixel, s, dimension)
// only: the image does not depend on the thread count or on how samples are batched.
//
// Dimensions: kCameraPixel, kCameraLens, then kPerBounce per scattering event (light choice, light
// point, BSDF direction, lobe choice, roulette), so a dimension means the same thing in every
// sample of a pixel (the stratification holds per decision). The "variance" layer of pathtrace
// (s²/n of the samples) is then an estimate of the error of independent samples, an upper bound
// in practice for the scrambled ones.
#pragma once
#include <cstdint>

#include "photonflow/foundations/rng.h"
#include "photonflow/sampling/sobol_shared.h"

namespace pf {

// Sobol's dimension 1 (pf_sobol_bits(1, i), the same bits) by four lookups: the sequence is linear
// over GF(2), so point i is the XOR of the points of i's four bytes, each from a 256-entry table
// built once from sobol_shared.h's generator matrix. The loop over i's set bits cost three
// quarters of a padded 2-D sample.
struct SobolDim1Table {
  uint32_t t[4][256];
  SobolDim1Table() {
    for (uint32_t b = 0; b < 4; ++b)
      for (uint32_t v = 0; v < 256; ++v) t[b][v] = pf_sobol_bits(1u, v << (8u * b));
  }
  uint32_t operator()(uint32_t i) const {
    return t[0][i & 0xFFu] ^ t[1][(i >> 8) & 0xFFu] ^ t[2][(i >> 16) & 0xFFu] ^ t[3][i >> 24];
  }
};
inline const SobolDim1Table kSobolDim1;

enum class PathSamplerKind { Independent, Sobol };
const char* path_sampler_name(PathSamplerKind k);

class PathSampler {
 public:
  // The dimensions of a path: the camera's two, then per bounce `depth` (0 = the camera ray's
  // hit) kPerBounce more.
  enum Bounce : uint32_t { kLightPick = 0, kLightPoint, kBsdfDirection, kLobe, kRoulette, kPerBounce };
  static constexpr uint32_t kCameraPixel = 0, kCameraLens = 1, kCameraDims = 2;
  static constexpr uint32_t at(int depth, Bounce b) {
    return kCameraDims + uint32_t(depth) * kPerBounce + uint32_t(b);
  }

  // `run_key` = key(kind, seed) (computed once per run), `stream_key` = pf_rng_key(seed,
  // stream + s) for Independent (unused by Sobol), the pixel and its sample number s.
  static uint32_t key(PathSamplerKind kind, uint32_t seed) {
    return kind == PathSamplerKind::Sobol ? pf_rng_key(seed, 0x50B3000u) : 0u;
  }
  PathSampler(PathSamplerKind kind, uint32_t run_key, uint32_t stream_key, uint32_t pixel,
              uint32_t sample)
      : sobol_(kind == PathSamplerKind::Sobol),
        key_(sobol_ ? run_key : stream_key),
        pixel_(pixel),
        sample_(sample),
        pixel_hash_(sobol_ ? pf_hash32(run_key ^ pixel) : 0u),
        sample_hash_(sobol_ ? pf_hash32(pixel_hash_ ^ (sample * 0x85ebca6bu)) : 0u) {}

  // Sobol points serve the camera and the first kSobolBounces bounces; deeper dimensions take
  // independent numbers (a hash of the sample's hash and the dimension), where stratifying one
  // decision of a long path gains next to nothing and the scrambles would cost (measured:
  // docs/RESULTS.md section 10).
  static constexpr int kSobolBounces = 3;
  static constexpr uint32_t kSobolDims = kCameraDims + kSobolBounces * kPerBounce;

  // Dimension `dim`'s number (a 1-D dimension).
  float get1(uint32_t dim) const {
    if (!sobol_) return pf_rng_unit(pf_rng_bits(key_, pixel_, 2u * dim));
    if (dim >= kSobolDims) return deep(2u * dim);
    const uint32_t i = index(dim);
    return pf_rng_unit(pf_owen_scramble(pf_reverse_bits32(i), seed(dim, 1u)));
  }
  // Dimension `dim`'s pair of numbers (a 2-D dimension).
  void get2(uint32_t dim, float& u1, float& u2) const {
    if (!sobol_) {
      u1 = pf_rng_unit(pf_rng_bits(key_, pixel_, 2u * dim));
      u2 = pf_rng_unit(pf_rng_bits(key_, pixel_, 2u * dim + 1u));
      return;
    }
    if (dim >= kSobolDims) {
      u1 = deep(2u * dim);
      u2 = deep(2u * dim + 1u);
      return;
    }
    const uint32_t i = index(dim);
    u1 = pf_rng_unit(pf_owen_scramble(pf_reverse_bits32(i), seed(dim, 1u)));
    u2 = pf_rng_unit(pf_owen_scramble(kSobolDim1(i), seed(dim, 2u)));
  }

 private:
  // The pixel's seeds of dimension `dim`: 0 its index permutation, 1 and 2 its two digits' scrambles.
  // The sample's index in dimension `dim`'s sequence: the nested permutation of its bits
  // (pf_owen_scramble on the index: bit j flips by a hash of the bits above it), applied to its
  // low 16 bits only, so that the index stays below 2^16 for the first 65,536 samples and Sobol's
  // second dimension (one XOR per set bit) stays cheap; the blocks of 2^16 samples keep their
  // order, each shuffled within.
  uint32_t index(uint32_t dim) const {
    return sample_ ^ ((pf_owen_scramble(sample_, seed(dim, 0u)) ^ sample_) & 0xFFFFu);
  }

  // One hash of the pixel's hash and the seed's number (pf_rng_bits with the pixel's part hashed
  // once, in the constructor).
  uint32_t seed(uint32_t dim, uint32_t which) const {
    return pf_hash32(pixel_hash_ ^ ((3u * dim + which) * 0x9e3779b9u));
  }

  float deep(uint32_t n) const { return pf_rng_unit(pf_hash32(sample_hash_ ^ (n * 0x9e3779b9u))); }

  bool sobol_;
  uint32_t key_, pixel_, sample_;
  uint32_t pixel_hash_;   // Sobol: pf_hash32(run key ^ pixel)
  uint32_t sample_hash_;  // Sobol: pf_hash32(pixel hash ^ sample·c), the deep dimensions' key
};

inline const char* path_sampler_name(PathSamplerKind k) {
  return k == PathSamplerKind::Sobol ? "sobol" : "independent";
}

}  // namespace pf
