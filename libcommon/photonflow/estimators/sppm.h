// sppm.h — the estimators that trace a new eye pass before every photon pass, so that pixels at
// a light's outline, at geometric edges and behind glass converge (a fixed eye pass keeps their
// one sample's value forever):
//
//   sppm  stochastic progressive photon mapping (Hachisuka & Jensen 2009, "Stochastic Progressive
//         Photon Mapping", section 4): PPM's statistics (N, R, τ; thesis eq. 3.14–3.18) kept per
//         PIXEL; every pass finds the pixel's new visible point x_i with eye-path throughput β_i,
//         gathers that pass's photons at x_i within the pixel's R, and updates the pixel with
//         τ_M = β_i · Σ f_r(x_i)·Φ_p (HJ09 eq. 9–11, the shared-region form of thesis eq. 3.17).
//         Light seen directly (emitters, and direct light by shadow rays) is averaged over passes.
//         L = L̄_d + τ / (π R² · N_emitted)  (thesis eq. 3.19; HJ09 eq. 12).
//   pppm  probabilistic PPM (Knaus & Zwicker 2011, "Progressive Photon Mapping: A Probabilistic
//         Approach", section 4.3): every pass i (1-based) is an independent density estimate with
//         one global radius,  L_i = L_d,i + Σ_{p within r_i} β f_r Φ_p / (π r_i² N_p,i),  with
//         r_{i+1}² = r_i² · (i + α)/(i + 1)  (KZ11 eq. 19), and the image is their mean
//         L̄_k = (1/k) Σ L_i (KZ11 eq. 8). The passes are independent, so sums over disjoint
//         pass ranges merge exactly (pass_sums.h).
//
// Visible points on PF_MAT_PBR surfaces (the glTF BSDF) gather τ_M = β_i Σ f(x_i, ω_o, ω_p) Φ_p
// with the BSDF evaluated per photon (HJ09 eq. 10–11; illuminate.h): the eye pass's BSDF table
// (EyePassResult::bsdf) gives f's parameters; an SPPM state of a PBR scene keeps each pixel's
// last visible point's entry in HitpointSet::bsdf, as it keeps its geometry.
//
// Both take the pass index p (0-based) for their eye pass (EyePassOptions::pass: streams of
// (seed, pass, pixel)) and their photon pass, so a pass is the same wherever it runs. The gather
// is illuminate.h's rule and order (gather_site), the photons those of trace_photons pass p, with
// the sphere cut to the slab |n·(x − x_p)| <= κ·R when PpmOptions::slab = κ > 0 (ppm.h,
// pf_ppm_in_slab; render's default 0.25).
//
// | parameter (render) | default | meaning |
// |--------------------|---------|---------|
// | --estimator        | ppm     | ppm, sppm or pppm |
// | --alpha            | 0.7     | α of eq. 3.14 (sppm) or of KZ11 eq. 19 (pppm) |
// | --radius           | 0 = auto| R_1 in world units (default_radius) |
// | --slab             | auto    | κ: 0.25 for sppm and pppm, 0 (the sphere) for ppm |
// | --gather-area      | auto    | surface for sppm and pppm (estimators/gather_area.h), disc for ppm |
// | --pixel-sampler    | auto    | sobol for sppm and pppm: where a pixel's eye samples go |
//
// | estimator | state                                    | memory      | passes merge |
// |-----------|------------------------------------------|-------------|--------------|
// | ppm       | hitpoints of one eye pass (HitpointSet)   | per sample  | no (ordered) |
// | sppm      | one pf_hitpoint per pixel (HitpointSet)   | per pixel   | no (ordered) |
// | pppm      | per-pixel sums of L_i (PassSums)          | per pixel   | yes          |
#pragma once
#include <string>

#include "photonflow/stages/eye_pass.h"
#include "photonflow/stages/illuminate.h"
#include "photonflow/stages/photon_grid.h"
#include "photonflow/io/stage_files.h"

namespace pf {

struct PassSums;  // pass_sums.h

enum class Estimator { Ppm, Sppm, Pppm };
const char* estimator_name(Estimator e);
// "ppm" | "sppm" | "pppm" (InputError naming --estimator otherwise).
Estimator parse_estimator(const std::string& name);
// The --slab option of render and illuminate (PpmOptions::slab): "auto" is kDefaultSlab for the
// estimators with a new eye pass every pass (`new_eye_pass`) and 0 for ppm and classic; a number
// must be >= 0, and 0 unless new_eye_pass. InputError naming --slab otherwise.
float parse_slab(const std::string& text, bool new_eye_pass);
// Estimator of a hitpoints file's `estimator` attribute for a state that continues: "sppm" is
// SPPM, everything else a fixed eye pass.
bool is_sppm_state(const HitpointSet& h);

// The fresh SPPM state of a scene: one pf_hitpoint per pixel in row-major order, radius R0,
// N = τ = 0, weight 1, mesh = material = −1 (no visible point yet), zero image layers, passes 0.
HitpointSet make_sppm_state(const Scene& scene, float radius0, DirectMode mode);

// One SPPM iteration: `eye` is eye pass p (EyePassOptions::pass = state.passes, spp 1) and
// `grid` holds photon pass p's photons, `emitted` of them emitted. Updates every pixel that has a
// visible point (its hitpoint takes the visible point's position, normal, direction, mesh and
// material; weight stays 1 since β is inside τ), averages the emitted and direct layers over the
// passes, adds `emitted` to photons_emitted and counts the pass. InputError when the eye pass does
// not fit the state (size, more than one sample per pixel).
void sppm_pass(const Scene& scene, HitpointSet& state, const EyePassResult& eye,
               const PhotonGrid& grid, uint64_t emitted, const PpmOptions& opt);

// sppm_pass with eye pass p traced as it gathers, pixel by pixel (EyeTracer with `eye`, whose
// pass must be state.passes and spp 1): no eye pass is kept, written or read back. The render
// driver's CPU route; the same bits as trace_hitpoints_into + sppm_pass, which the staged route
// (trace-hitpoints, then illuminate) runs.
void sppm_pass_traced(const Scene& scene, HitpointSet& state, const EyePassOptions& eye,
                      const PhotonGrid& grid, uint64_t emitted, const PpmOptions& opt);

// The two halves of sppm_pass around the gather, for the device's SPPM pass (cl_gather.h,
// DevicePpmState::sppm_pass), which gathers on the device in between:
//   sppm_sites: one site per pixel of `state` — the pixel's visible point in `eye`, or a site
//     with mesh −1 where the eye path found none — and its throughput β (3 floats, 0 without one;
//     gather_weight's, which with opt.gather_area surface reads the pixel's radius in `state`, so
//     a device state must be read back first); InputError as sppm_pass when the eye pass does
//     not fit the state;
//   sppm_finish_pass: every pixel with a visible point takes its position, normal, direction, mesh
//     and material; the emitted and direct layers take the pass's into their running mean; the
//     pass is counted with its `emitted` photons.
void sppm_sites(const Scene& scene, const HitpointSet& state, const EyePassResult& eye,
                const PpmOptions& opt, std::vector<pf_hitpoint>& sites, std::vector<float>& beta);
void sppm_finish_pass(HitpointSet& state, const EyePassResult& eye, uint64_t emitted);

// r_i of pass p (0-based; i = p + 1) for initial radius r1: r_i² = r1² · Π_{j=1..i−1} (j + α)/(j + 1)
// (KZ11 eq. 19 unrolled), evaluated in double in that order up to pass kPppmLoopPasses, so every
// machine gets the same radius for the same pass; past it, the rest of the product in closed form
// (a ratio of Gamma functions, by Stirling's series), so that any pass up to 2^31 − 1 costs at most
// kPppmLoopPasses multiplications. Relative error against the exact product below 1e-12.
constexpr int kPppmLoopPasses = 1 << 16;
double pppm_radius(double r1, double alpha, int pass);

// One PPPM pass p = sums.first_pass + sums.passes: adds L_p (above) of every pixel to sums.sum
// and counts the pass. `eye` is eye pass p, `grid` photon pass p's photons, `emitted` of them
// emitted.
void pppm_pass(const Scene& scene, PassSums& sums, const EyePassResult& eye,
               const PhotonGrid& grid, uint64_t emitted, const PpmOptions& opt);
// pppm_pass with eye pass p traced as it gathers, pixel by pixel (EyeTracer with `eye`, whose
// pass must be p): render's CPU route, the same bits as trace_hitpoints_into + pppm_pass (each
// pixel's sum takes its L_d, then its samples' β·τ_M in sample order, as there).
void pppm_pass_traced(const Scene& scene, PassSums& sums, const EyePassOptions& eye,
                      const PhotonGrid& grid, uint64_t emitted, const PpmOptions& opt);
// The radius r_i of the pass pppm_pass applies next, as the float the gather uses.
float pppm_pass_radius(const PassSums& sums);
// pppm_pass after its gather: tau_beta holds β·τ_M (float products, 3 per visible point of `eye`,
// τ_M gathered within pppm_pass_radius(sums)); adds L_p of every pixel to the sums and counts the
// pass. The device's gather (cl_gather.h, pppm_gather_device) ends here too.
void pppm_accumulate(PassSums& sums, const EyePassResult& eye, const std::vector<float>& tau_beta,
                     uint64_t emitted);

// The staged route of both (illuminate --estimator sppm | pppm): `eye` is a trace-hitpoints file
// of eye pass p (estimator "none", eye_pass p) and `photons` holds photon pass p alone; the grid is
// built here (opt.max_bins) and the pass applied as render applies it, so both routes give the
// same state. InputError naming eye_path or photons_path when the passes do not line up
// (p = state.passes, or sums.end_pass()) or the direct modes differ.
void sppm_stage(const Scene& scene, HitpointSet& state, const HitpointSet& eye,
                const std::string& eye_path, const PhotonSet& photons,
                const std::string& photons_path, const PpmOptions& opt);
void pppm_stage(const Scene& scene, PassSums& sums, const HitpointSet& eye,
                const std::string& eye_path, const PhotonSet& photons,
                const std::string& photons_path, const PpmOptions& opt);

}  // namespace pf
