/*
 * pixel_sampler.h — where inside its pixel an eye sample goes, shared by the C++ host
 * (eye_pass.cpp) and the OpenCL eye kernel (trace_hitpoints.cl), so both backends trace the same
 * camera rays.
 *
 * Three samplers (pf_int codes, EyePassOptions::sampler on the host):
 *   PF_SAMPLER_STRATA  the fixed eye pass of PPM: the pixel centre for one sample per pixel, else
 *                      one jittered sample per cell of a columns × rows grid (eye_strata_columns).
 *                      The jitter draws are the first two dimensions of the sample's eye stream.
 *   PF_SAMPLER_RANDOM  independent uniform jitter: dimensions 0 and 1 of the sample's eye stream,
 *                      which is (seed, eye stream + pass, pixel·spp + s) — a new position every
 *                      pass (SPPM and probabilistic PPM, whose every pass traces a new eye pass).
 *   PF_SAMPLER_SOBOL   a per-pixel scrambled (0,2)-sequence indexed by the sample's position in
 *                      the pixel's sample stream over passes, i = pass·spp + s: the first two
 *                      dimensions of Sobol's sequence (van der Corput in base 2, and the Pascal
 *                      matrix generator; Kollig & Keller 2002), each Owen-scrambled with its own
 *                      per-pixel seed by the hash-based nested uniform scramble of Burley (2020,
 *                      "Practical hash-based Owen scrambling"). Owen scrambling keeps the (0,2)
 *                      property: the first 2^k samples of every pixel put one sample in each of the
 *                      2^k elementary intervals of every shape (2^a × 2^b cells, a + b = k), so a
 *                      pixel's edge error falls faster than with independent jitter. The eye
 *                      stream's dimensions 0 and 1 are skipped (not drawn), so glass choices
 *                      use the same dimensions under every pass-based sampler. The light samples
 *                      of the pixel's shadow rays are Sobol points too (pf_light_draws_start):
 *                      a second per-pixel sequence, in three dimensions.
 * All integer arithmetic is 32-bit unsigned (exact and equal on both sides); the float of a sample
 * is its top 24 bits times 2^-24, as pf_rng_unit.
 */
#ifndef PHOTONFLOW_PIXEL_SAMPLER_H
#define PHOTONFLOW_PIXEL_SAMPLER_H

#include "photonflow/foundations/cl_compat.h"
#include "photonflow/foundations/rng.h"
#include "photonflow/sampling/sobol_shared.h"

#define PF_SAMPLER_STRATA 0
#define PF_SAMPLER_RANDOM 1
#define PF_SAMPLER_SOBOL 2

/* Dimension 0 of Sobol's sequence as 32 fraction bits: the radical inverse of i in base 2. */
PF_INLINE pf_uint pf_sobol_dim0(pf_uint i) { return pf_reverse_bits32(i); }

/* Dimension 1 of Sobol's sequence as 32 fraction bits (Pascal's triangle mod 2 as generator
 * matrix: sampling/sobol_shared.h's table, dimension 1). */
PF_INLINE pf_uint pf_sobol_dim1(pf_uint i) { return pf_sobol_bits(1U, i); }

/* Key of the scrambling seeds of a run (pass slot 0x50B0000, distinct from every stream the
 * renderer draws from); the seeds of a pixel's two dimensions are hashes of (key, pixel, dim). */
PF_INLINE pf_uint pf_sobol_key(pf_uint seed) { return pf_rng_key(seed, 0x50B0000U); }

/* Emission samples (eye_pass.h, EyePassOptions::emission_spp): eye paths that only follow
 * mirrors and glass to the emitters a pixel sees. Sample k of K of pixel `pixel` in pass `pass`
 * jitters by point pass·K + k of a second scrambled (0,2)-sequence of the pixel (key
 * pf_emission_sobol_key, pass slot 0x50B1000), so a pixel's emission samples of all passes
 * together are one low-discrepancy sequence; its lens point (a thin-lens camera) is
 * pf_eye_lens_keyed's SOBOL point pass·K + k under the same key (its seeds 2–4), so the lens is
 * stratified as the jitter (a defocused lamp's edge converges as the pixel's own does), and its
 * glass choices come from pf_emission_rng. */
#define PF_EMISSION_STREAM 0xE3E0000U
PF_INLINE pf_uint pf_emission_sobol_key(pf_uint seed) { return pf_rng_key(seed, 0x50B1000U); }

/* Glossy samples (eye_pass.h, EyePassOptions::glossy_spp): eye samples more in the pixels whose
 * first glossy vertex continues. Sample k of G of pixel `pixel` in pass `pass` jitters by point
 * pass·G + k of a third scrambled (0,2)-sequence of the pixel (key pf_glossy_sobol_key, pass slot
 * 0x50B2000), takes its first glossy vertex's BSDF sample and the light samples of its first two
 * vertices with next-event estimation from the same key (pf_eye_lobe_keyed, pf_light_draws_vertex
 * at point pass·G + k), and draws everything else from stream (seed, PF_GLOSSY_STREAM + pass,
 * pixel·G + k). */
#define PF_GLOSSY_STREAM 0xE6E0000U
PF_INLINE pf_uint pf_glossy_sobol_key(pf_uint seed) { return pf_rng_key(seed, 0x50B2000U); }

/* The numbers of emission sample k of pixel `pixel`: stream (seed, PF_EMISSION_STREAM + pass,
 * pixel) from dimension k·(max_depth + 3). A sample draws at most two for the lens and one per
 * glass bounce (max_depth + 1 bounces), so the samples of a pixel never share a number, and the
 * stream index is the pixel's, below 2^32 for every image (no limit on K·pixels). */
PF_INLINE pf_rng pf_emission_rng(pf_uint seed, pf_uint pass, pf_uint pixel, pf_int k,
                                 pf_int max_depth) {
  pf_rng r = pf_rng_start(seed, PF_EMISSION_STREAM + pass, pixel);
  r.dim = (pf_uint)k * (pf_uint)(max_depth + 3);
  return r;
}

/* Sample i of pixel `pixel`'s scrambled (0,2)-sequence, in [0, 1)² with 24-bit resolution, under
 * the run's key pf_sobol_key(seed) (computed once by callers that draw many). */
PF_INLINE void pf_sobol_pixel_sample_keyed(pf_uint key, pf_uint pixel, pf_uint i, pf_float* jx,
                                           pf_float* jy) {
  *jx = pf_rng_unit(pf_owen_scramble(pf_sobol_dim0(i), pf_rng_bits(key, pixel, 0U)));
  *jy = pf_rng_unit(pf_owen_scramble(pf_sobol_dim1(i), pf_rng_bits(key, pixel, 1U)));
}

PF_INLINE void pf_sobol_pixel_sample(pf_uint seed, pf_uint pixel, pf_uint i, pf_float* jx,
                                     pf_float* jy) {
  pf_sobol_pixel_sample_keyed(pf_sobol_key(seed), pixel, i, jx, jy);
}

/* The sub-pixel position (jx, jy) in [0, 1)² of eye sample s (of spp) of pixel `pixel` in pass
 * `pass`, by `sampler`, with sobol_key = pf_sobol_key(seed). `rng` is the sample's eye stream,
 * started at dimension 0; it comes back advanced past the draws the sampler made (none for STRATA
 * with spp = 1, two otherwise; SOBOL skips its two without computing them). */
PF_INLINE void pf_eye_jitter_keyed(pf_int sampler, pf_uint sobol_key, pf_uint pass, pf_uint pixel,
                                   pf_int s, pf_int spp, pf_int columns, pf_rng* rng, pf_float* jx,
                                   pf_float* jy) {
  if (sampler == PF_SAMPLER_STRATA) {
    *jx = 0.5f;
    *jy = 0.5f;
    if (spp > 1) { /* one sample per cell of a columns × (spp / columns) grid */
      *jx = ((pf_float)(s % columns) + pf_rng_next(rng)) / (pf_float)columns;
      *jy = ((pf_float)(s / columns) + pf_rng_next(rng)) / (pf_float)(spp / columns);
    }
    return;
  }
  if (sampler == PF_SAMPLER_RANDOM) {
    *jx = pf_rng_next(rng);
    *jy = pf_rng_next(rng);
    return;
  }
  rng->dim += 2U; /* dimensions 0 and 1, unused */
  pf_sobol_pixel_sample_keyed(sobol_key, pixel, pass * (pf_uint)spp + (pf_uint)s, jx, jy);
}

/* The lens sample (u1, u2) in [0, 1)² of eye sample s of pixel `pixel` in pass `pass`, drawn
 * only for a thin-lens camera (pf_camera.aperture > 0), right after pf_eye_jitter_keyed, so a
 * pinhole camera's streams are unchanged. `rng` advances by two dimensions under every sampler.
 *   STRATA  the next two dimensions of the sample's eye stream. PPM traces its eye pass once, so
 *           each pixel keeps its spp lens points for the whole run: its blur is the mean over those
 *           few lens positions and never converges to the lens integral (SPPM's reason to exist,
 *           Hachisuka & Jensen 2009, section 1).
 *   RANDOM  the next two dimensions of the eye stream (a new lens point every pass).
 *   SOBOL   a second scrambled (0,2)-sequence, as pbrt-v4's padded Sobol sampler: the index
 *           i = pass·spp + s is shuffled by a nested permutation of its bits (pf_owen_scramble
 *           on the index: bit j flips by a hash of the bits above it, so every aligned block of
 *           2^k indices, in particular the first 2^k samples of the pixel, maps onto an aligned
 *           block, which Sobol's (0,2)-sequence fills as a (0,k,2)-net), then dimensions 0 and 1
 *           of the shuffled index, each Owen-scrambled with the pixel's own lens seeds. The lens
 *           points are stratified like the pixel positions but in an order uncorrelated with
 *           theirs (the shuffle), so the 4D samples do not line up.
 * Seeds: pf_rng_bits(sobol_key, pixel, 2, 3, 4): dimensions 0 and 1 of the pixel position use
 * 0 and 1. */
PF_INLINE void pf_eye_lens_keyed(pf_int sampler, pf_uint sobol_key, pf_uint pass, pf_uint pixel,
                                 pf_int s, pf_int spp, pf_rng* rng, pf_float* u1, pf_float* u2) {
  if (sampler != PF_SAMPLER_SOBOL) {
    *u1 = pf_rng_next(rng);
    *u2 = pf_rng_next(rng);
    return;
  }
  rng->dim += 2U;
  const pf_uint i = pass * (pf_uint)spp + (pf_uint)s;
  const pf_uint shuffled = pf_owen_scramble(i, pf_rng_bits(sobol_key, pixel, 2U));
  *u1 = pf_rng_unit(pf_owen_scramble(pf_sobol_dim0(shuffled), pf_rng_bits(sobol_key, pixel, 3U)));
  *u2 = pf_rng_unit(pf_owen_scramble(pf_sobol_dim1(shuffled), pf_rng_bits(sobol_key, pixel, 4U)));
}

PF_INLINE void pf_eye_jitter(pf_int sampler, pf_uint seed, pf_uint pass, pf_uint pixel, pf_int s,
                             pf_int spp, pf_int columns, pf_rng* rng, pf_float* jx,
                             pf_float* jy) {
  pf_eye_jitter_keyed(sampler, pf_sobol_key(seed), pass, pixel, s, spp, columns, rng, jx, jy);
}

/* The BSDF sample (u1, u2, u3) at the first glossy vertex of an eye path (GlossyMerge::Mis,
 * eye_pass.cpp: the direction drawn there serves the vertex's direct light by MIS and the path's
 * continuation), eye sample i = pass·spp + s of pixel `pixel` (a glossy sample: i = pass·G + k
 * under pf_glossy_sobol_key). `sobol` 0: the next three dimensions of the eye stream `rng`, as at
 * every later glossy vertex. `sobol` 1: a padded scrambled Sobol sequence, as pf_eye_lens_keyed:
 * the index Owen-scrambled by the pixel's seed 9, then dimensions 0, 1 (the direction: a
 * (0,2)-sequence) and 2 (the lobe choice) of sampling/sobol_shared.h, each Owen-scrambled with
 * the pixel's seeds 10, 11, 12; `rng` skips the three dimensions it would have drawn. The
 * pixel's lobe directions over all its passes then stratify the lobe as its positions stratify
 * the pixel; each is uniform, so the estimates stay unbiased. */
PF_INLINE void pf_eye_lobe_keyed(pf_int sobol, pf_uint key, pf_uint pixel, pf_uint i, pf_rng* rng,
                                 pf_float* u1, pf_float* u2, pf_float* u3) {
  if (!sobol) {
    *u1 = pf_rng_next(rng);
    *u2 = pf_rng_next(rng);
    *u3 = pf_rng_next(rng);
    return;
  }
  rng->dim += 3U;
  const pf_uint j = pf_owen_scramble(i, pf_rng_bits(key, pixel, 9U));
  *u1 = pf_rng_unit(pf_owen_scramble(pf_sobol_bits(0U, j), pf_rng_bits(key, pixel, 10U)));
  *u2 = pf_rng_unit(pf_owen_scramble(pf_sobol_bits(1U, j), pf_rng_bits(key, pixel, 11U)));
  *u3 = pf_rng_unit(pf_owen_scramble(pf_sobol_bits(2U, j), pf_rng_bits(key, pixel, 12U)));
}

/* The numbers of a visible point's light samples (the shadow rays of DirectMode::ShadowRays,
 * eye_pass.h; (ul, u1, u2) per sample: the light picked by power with ul, its point with u1, u2).
 *   STRATA, RANDOM  the shadow stream (seed, 0x5AD0000 + pass, pixel·spp + s), three dimensions a
 *                   sample: independent numbers every pass.
 *   SOBOL           sample k of the S samples of eye sample s in pass `pass` is point
 *                   j = (pass·spp + s)·S + k of a per-pixel scrambled Sobol sequence in three
 *                   dimensions: dimensions 0, 1, 2 of sampling/sobol_shared.h give u1, u2, ul,
 *                   each Owen-scrambled with the pixel's own seed, at an index that is itself
 *                   Owen-scrambled per pixel first (pbrt-v4's padding, as pf_eye_lens_keyed: the
 *                   points keep their stratification but lose their order's correlation with the
 *                   pixel positions, which are dimensions 0 and 1 of i = pass·spp + s). The
 *                   samples of a pixel over all passes then stratify the light's area (u1, u2,
 *                   a (0,2)-sequence) and the choice among lights (ul) together, so a soft shadow
 *                   converges faster than with independent samples (docs/RESULTS.md "Light
 *                   samples and the photon share"; tests/sampling/sobol_shared_test.cpp). Each
 *                   point is uniform (Owen scrambling), so every estimate stays unbiased. j wraps past 2^32 samples per pixel (the
 *                   sequence then repeats: after 10^9 passes of 4 samples).
 * Seeds: pf_rng_bits(sobol_key, pixel, 5) for the index, 6, 7, 8 for the three dimensions (0–4
 * serve the pixel position and the lens, 9–12 the first glossy vertex's BSDF sample, 13–16 the
 * light samples of a path's second vertex with next-event estimation, pf_light_draws_vertex). */
typedef struct {
  pf_rng rng;        /* STRATA, RANDOM: the shadow stream */
  pf_uint sobol;     /* 1: Sobol points (SOBOL) */
  pf_uint next;      /* SOBOL: the next point's index j */
  pf_uint seeds[4];  /* SOBOL: the pixel's seeds for the index, u1, u2, ul (computed once) */
} pf_light_draws;

/* Random stream of the shadow rays: pass slot 0x5AD (eye_pass.cpp kShadowStream). */
#define PF_SHADOW_STREAM_SLOT 0x5AD0000U

/* Sobol draws under `key` from point (i·samples) on; `set` 0 takes seeds 5–8, set 1 seeds 13–16
 * (an independently scrambled second sequence of the pixel). */
PF_INLINE pf_light_draws pf_light_draws_sobol(pf_uint key, pf_uint pixel, pf_uint i, pf_int samples,
                                              pf_uint set) {
  pf_light_draws d;
  d.rng.key = d.rng.index = d.rng.dim = 0U;
  d.sobol = 1U;
  d.next = i * (pf_uint)samples;
  const pf_uint slot = set == 0U ? 5U : 13U;
  for (pf_uint k = 0U; k < 4U; ++k) d.seeds[k] = pf_rng_bits(key, pixel, slot + k);
  return d;
}

PF_INLINE pf_light_draws pf_light_draws_start(pf_int sampler, pf_uint seed, pf_uint sobol_key,
                                              pf_uint pass, pf_uint pixel, pf_int s, pf_int spp,
                                              pf_int samples) {
  const pf_uint i = pass * (pf_uint)spp + (pf_uint)s;
  if (sampler == PF_SAMPLER_SOBOL) return pf_light_draws_sobol(sobol_key, pixel, i, samples, 0U);
  /* Only the draws in use are keyed: the shadow stream. */
  pf_light_draws d;
  d.sobol = 0U;
  d.rng = pf_rng_start(seed, PF_SHADOW_STREAM_SLOT + pass, pixel * (pf_uint)spp + (pf_uint)s);
  d.next = i * (pf_uint)samples;
  for (pf_uint k = 0U; k < 4U; ++k) d.seeds[k] = 0U;
  return d;
}

/* Draws from an existing stream (a glossy point's light samples come from the eye stream). */
PF_INLINE pf_light_draws pf_light_draws_from(pf_rng rng) {
  pf_light_draws d;
  d.rng = rng;
  d.sobol = 0U;
  d.next = 0U;
  for (pf_uint k = 0U; k < 4U; ++k) d.seeds[k] = 0U;
  return d;
}

/* The light draws at the `vertex`-th vertex of eye sample s's path that estimates direct light
 * (0 = the first; an eye path through glossy points estimates it at each, eye_pass.cpp). With
 * Sobol draws (`sobol`: the pixel sampler is SOBOL, or a glossy sample) vertex 0 takes the
 * pixel's set 0 under `key` and vertex 1 its set 1, both from point i·samples on (i = pass·spp +
 * s, or pass·G + k for glossy sample k, under its own key); so the light samples of the first two
 * vertices both stratify over the passes. Otherwise vertex 0 takes the shadow stream
 * (pf_light_draws_start). Later vertices draw from the eye stream `eye`: *from_eye is then 1, and
 * the caller's eye stream goes on from the returned draws' rng after their use. */
PF_INLINE pf_light_draws pf_light_draws_vertex(pf_int sobol, pf_uint key, pf_uint seed,
                                               pf_uint pass, pf_uint pixel, pf_int s, pf_int spp,
                                               pf_uint i, pf_int samples, pf_int vertex,
                                               pf_rng eye, pf_int* from_eye) {
  *from_eye = 0;
  if (sobol && vertex < 2) return pf_light_draws_sobol(key, pixel, i, samples, (pf_uint)vertex);
  if (vertex == 0) return pf_light_draws_start(PF_SAMPLER_RANDOM, seed, 0U, pass, pixel, s, spp,
                                               samples);
  *from_eye = 1;
  return pf_light_draws_from(eye);
}

/* The next light sample's (ul, u1, u2). */
PF_INLINE void pf_light_draws_next(pf_light_draws* d, pf_float* ul, pf_float* u1, pf_float* u2) {
  if (!d->sobol) {
    *ul = pf_rng_next(&d->rng);
    *u1 = pf_rng_next(&d->rng);
    *u2 = pf_rng_next(&d->rng);
    return;
  }
  const pf_uint j = pf_owen_scramble(d->next, d->seeds[0]);
  d->next += 1U;
  *u1 = pf_rng_unit(pf_owen_scramble(pf_sobol_bits(0U, j), d->seeds[1]));
  *u2 = pf_rng_unit(pf_owen_scramble(pf_sobol_bits(1U, j), d->seeds[2]));
  *ul = pf_rng_unit(pf_owen_scramble(pf_sobol_bits(2U, j), d->seeds[3]));
}

#endif /* PHOTONFLOW_PIXEL_SAMPLER_H */
