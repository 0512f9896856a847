// photon_guide.h — photons where the camera looks: `--photon-guide visibility` (Hachisuka &
// Jensen 2011, "Robust Adaptive Photon Tracing using Photon Path Visibility", ACM TOG 30(5);
// HJ11 below).
//
// A photon path is a function of its primary samples u ∈ [0,1)^d, the photon tracer's draws in
// their order (light pick, position, direction, then per bounce; photon_pass.h). Its visibility
// V(u) = 1 when one of its deposits is one that a visible point of the pass gathers (VisibleSet
// below), else 0 (HJ11's importance function). With `visibility` every photon slot i of a pass
//   1. traces the uniform photon of slot i (the stream (seed, pass, i): the very photon the
//      uniform route traces there); when it is visible, its chain jumps to it (HJ11's replica
//      exchange with the uniform photons: the chain reaches disconnected visible regions);
//   2. otherwise, when the chain has a state, proposes u' = u + δ·(2r − 1) per coordinate,
//      wrapped mod 1 (r from the stream (seed ^ kGuideMutationSalt, pass, i): HJ11's primary-sample mutation),
//      coordinates past the state's used prefix drawn afresh (r itself: unused coordinates are
//      independent uniforms under the target), and accepts when V(u') = 1 (the target is flat on
//      the visible set, so the Metropolis ratio is V(u'));
//   3. stores the chain's current path's deposits (once per slot, also after a rejection);
//      a chain that has found no visible photon yet stores nothing (its steps are not counted).
// δ adapts per chain towards the acceptance rate 0.234 (HJ11's adaptive Markov chain, after
// Andrieu & Thoms 2008, "A tutorial on adaptive MCMC": a Robbins–Monro step 1/n): δ ← δ + (A − 0.234)/n after the chain's n-th
// mutation (A = 1 when accepted), clamped to [kGuideDeltaMin, kGuideDeltaMax].
// Normalisation (HJ11 section 4): the uniform photons estimate the visible fraction
// Vc = visible / N (N = --photons, one uniform photon per slot), and the chain's measurement is
// Vc · (1/M) Σ W(u_j) over its M counted steps. The deposits are stored with the flux the
// uniform route gives them times visible / M = Vc · N / M, and the pass records N photons
// emitted, so every gather (flux / emitted) computes Vc · (1/M) Σ Φ with no change.
// A chain's state lives within one pass: each pass has its own chains from (seed, pass), and no
// pass depends on another (pppm ranges merge). The kGuideChains chains take contiguous runs of
// slots, chain c slots [c·N/C, (c+1)·N/C), each run in slot order, the chains spread over the
// threads as whole units: the photons, in slot order, do not depend on the thread count.
// CPU only: the OpenCL photon pass traces uniform photons (render refuses visibility with
// --device opencl).
#pragma once
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "photonflow/foundations/shared_types.h"
#include "photonflow/material/pbr_point_shared.h"

namespace pf {

enum class PhotonGuide { Uniform, Visibility };
// "uniform" | "visibility" (InputError naming --photon-guide otherwise).
PhotonGuide parse_photon_guide(const std::string& name);
const char* photon_guide_name(PhotonGuide g);

constexpr uint32_t kGuideChains = 64;          // chains per pass (fixed: results do not depend
                                               // on the thread count)
constexpr double kGuideTargetAcceptance = 0.234;
constexpr float kGuideDeltaStart = 0.1f;       // δ of a chain's first mutation
constexpr float kGuideDeltaMin = 1e-4f, kGuideDeltaMax = 0.5f;
constexpr uint32_t kGuideMutationSalt = 0x6d757461u;  // "muta": the mutation streams' seed

// The pass's visible points for V(u): "does photon deposit p land where a visible point gathers
// it". Point k with radius r_k takes p when pf_ppm_in_radius(pf_ppm_dist2(x_k, p), r_k) (ppm.h:
// the gathers' own test) and the gathers' acceptance holds (illuminate.h photon_accepted): p lies
// on k's mesh, arrives at k's front (p.dir · n_k < 0) unless k is a transmissive PBR point
// (pbr_two_sided_gather), and is not a direct photon when shadow rays give direct light. So V
// holds every photon a gather takes (V ⊇ what the gathers see; only the slab narrows them
// further), and no photon that no gather takes: a photon on the outside of a room's wall, a
// radius away from a visible point inside, is not visible. A hashed grid of cells twice the
// largest radius wide.
class VisibleSet {
 public:
  VisibleSet() = default;
  // Points with a negative mesh (a pixel without a visible point) or a non-finite position or
  // radius are left out; radius[k] is point k's (one entry per point) or, with radius.size() == 1,
  // every point's; bsdf[k] is point k's BSDF table entry (EyePassResult::bsdf; empty without PBR
  // materials); skip_direct: the gathers skip PF_PHOTON_DIRECT photons (DirectMode::ShadowRays).
  void build(const std::vector<pf_hitpoint>& points, const std::vector<float>& radius,
             const std::vector<pf_pbr_point>& bsdf, bool skip_direct);
  bool near(const pf_photon& p) const;
  size_t size() const { return pts_.size(); }
  float max_radius() const { return rmax_; }

 private:
  struct Point {
    float x[3], n[3], r;
    int32_t mesh;
    bool both_sides;
  };
  size_t slot_of(int64_t x, int64_t y, int64_t z) const;
  bool cell_of(const float p[3], float off, int64_t c[3]) const;
  float lo_[3] = {0, 0, 0};
  float cell_ = 1.f, rmax_ = 0.f;
  uint64_t mask_ = 0;
  bool skip_direct_ = false;
  std::vector<int32_t> start_;  // slot k: points start_[k] .. start_[k+1) − 1
  std::vector<Point> pts_;
};

struct HitpointSet;  // io/hitpoints_file.h

// The visible points of a hitpoint set, each at its own radius, under the set's direct mode
// (PPM's fixed hitpoints, whose R shrinks pass by pass, and trace-photons --hitpoints FILE).
void visible_at_own_radius(const HitpointSet& h, VisibleSet& out);

// The visible points of trace-photons --hitpoints FILE (each at its own radius, for pppm r_1 >=
// the pass's r_i: V is wider than the gather, never narrower): an eye pass of trace-hitpoints
// for the staged sppm and pppm routes, or PPM's fixed eye pass or state. An eye pass of pass
// p > 0 guides photon pass p alone: InputError naming `path` unless first_pass = p and
// passes = 1 (photons guided by another pass's points would miss this pass's).
void guide_points_from_file(const HitpointSet& h, const std::string& path, int first_pass,
                            int passes, VisibleSet& out);

// What a guided pass did (render's run record, trace-photons --stats).
struct PhotonGuideStats {
  uint64_t uniform = 0;        // uniform photons traced (N)
  uint64_t visible = 0;        // of them visible
  uint64_t mutations = 0;      // chain mutations proposed
  uint64_t accepted = 0;       // of them accepted
  uint64_t chain_photons = 0;  // counted chain steps (M)
  double visible_fraction() const { return uniform ? double(visible) / double(uniform) : 0.0; }
  double acceptance() const { return mutations ? double(accepted) / double(mutations) : 0.0; }
  void add(const PhotonGuideStats& o) {
    uniform += o.uniform;
    visible += o.visible;
    mutations += o.mutations;
    accepted += o.accepted;
    chain_photons += o.chain_photons;
  }
};

}  // namespace pf
