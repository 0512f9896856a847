// photon_pass.h — photon tracing (thesis ch. 3.4 pass 1, ch. 7.2; Jensen 2001).
//
// Photons leave the lights in proportion to power: a light is picked from the scene's power CDF,
// then an area light emits from a uniform point on its triangle in a cosine-distributed direction
// around its front normal, and a point light emits uniformly over the sphere. Each photon starts
// with flux Φ = P_light / p_light (P_light the light's RGB power, p_light its selection
// probability); the estimate divides by the number of photons emitted (thesis eq. 3.19), so the
// stored flux is "watts per emitted photon × photons emitted".
//
// At every diffuse hit the photon is stored (position, incoming direction, flux, mesh, pass,
// flags: PF_PHOTON_DIRECT for L D, PF_PHOTON_CAUSTIC for L S+ D) and continues in a cosine
// direction with Russian roulette on the albedo (survival p = max(albedo), flux ·= albedo / p).
// Mirrors reflect (flux ·= reflectance); glass reflects with the Fresnel probability and refracts
// otherwise (flux ·= tint).
//
// PF_MAT_PBR (the glTF metallic-roughness BSDF, material/bsdf_shared.h) is a non-delta surface:
// the photon is stored there exactly as at a diffuse hit (the same record and flags), then
// continues by sampling the BSDF in importance-transport mode (pf_pbr_scatter,
// material/pbr_scatter_shared.h: the front shading frame, Veach's shading-normal adjoint
// |wo·ns||wi·ng|/(|wo·ng||wi·ns|) where ns ≠ ng, pairs that the geometric normal sees otherwise
// than the shading normal dropped). Random draws at a PBR bounce, in this order (the OpenCL
// tracer copies it): u1, u2, u3 → pf_pbr_scatter (u3 picks the lobe), then u_rr, always drawn.
// Russian roulette on the throughput: with Φ' = Φ·weight (weight = f·|cos|/pdf · adjoint, rgb),
//   q = min(1, max_c Φ'_c / max_c Φ_c),  continue when u_rr < q,  Φ ← Φ' · (1/q),
// so a bounce that keeps (or, at grazing angles of the glTF dielectric, gains: MATERIALS.md)
// the photon's power continues with probability 1 and its flux is never raised by the roulette,
// while a lossy one (rough metal, absorbing base colour) is thinned without changing the
// expectation E[Φ_next] = Φ·E[weight]. A lost BSDF sample (under the horizon, total internal
// reflection) ends the photon: the model's single-scattering loss.
// Flags: a glossy (PBR) bounce is not specular; it ends an L S+ chain, so photons after it are
// not PF_PHOTON_CAUSTIC (classic PM's fixed-radius caustic map holds L S+ D paths through delta
// surfaces only, and glossy-surface photons go to the global map); a photon stored on a PBR
// surface right after delta bounces is caustic like one on a diffuse surface.
// A diffuse bounce keeps its own draws and arithmetic: diffuse scenes trace the same bits.
//
// Randomness is counter-based: photon i of pass p uses the stream (seed, p, i), so the photons do
// not depend on the thread count (and equal the OpenCL backend's up to float rounding).
//
// One function traces a photon from a source of draws (its primary samples u, in the order
// above): the stream (seed, p, i) for uniform photons, or a stored vector u that a Markov chain
// mutates for `--photon-guide visibility` (photons where the camera looks, photon_guide.h).
#pragma once
#include <cstdint>
#include <vector>

#include "photonflow/stages/photon_grid.h"
#include "photonflow/stages/photon_guide.h"
#include "photonflow/geometry/scene.h"

namespace pf {

struct PhotonPassOptions {
  uint32_t photons = 100000;  // photons emitted in the pass
  uint32_t seed = 1;
  int max_bounces = 16;       // diffuse + specular bounces before a photon is dropped
  int threads = 0;            // 0 = all cores
  PhotonGuide guide = PhotonGuide::Uniform;  // uniform photons, or chains where the camera looks
                                             // (photon_guide.h)
};

struct PhotonPassResult {
  std::vector<pf_photon> photons;  // in emission order (photon index, then bounce)
  uint64_t emitted = 0;            // photons emitted in this pass
};

// InputError naming the option (--photons, --max-bounces, --threads) when one is out of range;
// trace-photons and render check their options with it.
void check_options(const PhotonPassOptions& opt);

// Pass indices are int32 in the files (a photon's `pass`, grid.h5's /pass<k>, the hitpoints'
// `passes`): passes first … first + count − 1 must end at 2^31 − 1 at most. InputError naming
// --first-pass and --passes otherwise (also for first < 0 or count < 0). Every trace_photons
// checks its own pass index.
void check_pass_range(int64_t first, int64_t count);
// Whether passes first … first + count − 1 (none when count ≤ 0) end at 2^31 − 1 at most; the
// files' readers (stage_files.cpp) check their first_pass and pass count with it.
inline bool pass_indices_fit(int64_t first, int64_t count) {
  return count <= 0 || first + count - 1 <= int64_t(INT32_MAX);
}

// With opt.guide visibility, `visible` holds the pass's visible points (std::invalid_argument
// without) and the photons are the chains' (photon_guide.h); `stats`, when given, gets what the
// pass did (all zero for uniform photons).
PhotonPassResult trace_photons(const Scene& scene, uint32_t pass, const PhotonPassOptions& opt,
                               const VisibleSet* visible = nullptr,
                               PhotonGuideStats* stats = nullptr);

// The photons of a pass as traced: one buffer per chunk of kChunk emitted photons (chunk c holds
// the photons of indices [kChunk·c, kChunk·(c+1)), in order; a guided pass: one buffer per chain,
// chain c's slots, photon_guide.h); their concatenation is PhotonPassResult::photons. Buffers keep their capacity from pass to pass.
struct PhotonBuffers {
  static constexpr uint32_t kChunk = 1024;
  std::vector<std::vector<pf_photon>> chunks;
  size_t size() const;                                 // photons stored, all chunks
  std::vector<PhotonSpan> spans() const;               // the chunks, for build_photon_grid_into
  void concatenate(std::vector<pf_photon>& out) const; // out = all photons, in order
};

// trace_photons into reusable buffers (no allocation once they have grown); returns the number
// of photons emitted.
uint64_t trace_photons_into(const Scene& scene, uint32_t pass, const PhotonPassOptions& opt,
                            PhotonBuffers& out, const VisibleSet* visible = nullptr,
                            PhotonGuideStats* stats = nullptr);

}  // namespace pf
