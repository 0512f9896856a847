// render_defaults.h — the defaults of render and of the staged route, chosen by measurement (issue
// 34 item 1; docs/RESULTS.md "Defaults" has the scene set, the measurements and the commands).
// One place defines them: render, the staged route (trace-hitpoints --estimator and --direct,
// trace-photons --photons, illuminate --estimator) and pipelines/render.mk (which passes "auto")
// take them from here, so a run without flags gets the same numbers by either route.
//
//   estimator   pppm (a new eye pass every pass, independent passes with a global radius
//               schedule; mergeable). RESULTS.md section 6 (512×512, 30 s): sppm and pppm 7.9–14.6×
//               less RMSE than ppm on the three scenes of data/. Section 8 (the same, with shadow
//               rays, against Mitsuba references, medians of 3 runs): pppm below sppm on all
//               three scenes measured there, by 9 % (diffuse box), 1–2 % (mirror and glass
//               balls) and 5 % (the 205,663-triangle box) over all pixels and 4–10 % away from
//               the lights; section 9 has the glossy showcase scenes)
//   direct      shadow-rays (issue 34's side-by-side runs with sppm, 512×512, 30 s, 262,144
//               photons: diffuse box 0.0080 → 0.0066 RMSE over all pixels, 0.0076 → 0.0056 away
//               from the lights; 200k-triangle box 0.0132 → 0.0123 and 0.0120 → 0.0096)
//   photons     automatic, from the image size: twice the photons per pass at which tracing them
//               costs as long as the pass's eye paths (kEyePixelCostInPhotons, measured;
//               kAutoPhotonShare, measured; auto_photons)
//   shadow-samples  1 light sample per visible point and pass for sppm and pppm, whose samples
//               are a pixel's Sobol points over the passes (pixel_sampler.h pf_light_draws); 4 for
//               ppm, whose one eye pass keeps its samples (kDefaultShadowSamples)
//   radius      automatic, from the pixel footprint and the scene extent (default_radius,
//               eye_pass.h): R0 = s · max(scene diagonal / 200, 4 · pixel angle · look-at
//               distance), s = 2 in a scene of diffuse surfaces only, 1.5 with mirrors, glass
//               or PBR materials (radius_scale: kRadiusScaleDiffuse, kRadiusScale), the factors
//               since the surface gather area
//   gather-area surface for sppm and pppm (estimators/gather_area.h): the estimate divides by
//               the surface the gather region holds, unbiased at corners and edges; measured in
//               docs/RESULTS.md section 8, "Gather area"
//
// No double counting with direct light by shadow rays (thesis eq. 3.7: L = L_e + L_direct +
// L_specular + L_caustic + L_indirect; Hachisuka & Jensen 2009, section 4, SPPM's direct light
// by ray tracing): the paths are split between the three estimates by their first diffuse vertex
// seen from the eye, so no weights (MIS) are needed:
//   - emitted light seen from the eye directly or through mirrors and glass (L S* E) is added by
//     the eye path once, on the emitter it hits (EyeTracer::sample, `emitted`); the eye path ends
//     at its first diffuse surface, so no emitter behind one is ever added by it;
//   - light arriving straight from an emitter at that first diffuse surface (L D S* E) is the
//     shadow rays' (direct_light, `direct`); a shadow ray blocked by anything, glass included,
//     adds nothing, so light through glass or off a mirror (L S+ D) is left to the photons;
//   - every photon is stored with PF_PHOTON_DIRECT when its diffuse hit is the first surface it
//     meets after leaving the light (photon_pass.cpp: first_hit), and with shadow-rays the gather
//     skips exactly those (illuminate.cpp gather_site, photon_accepted; sppm.cpp skip_direct; the
//     OpenCL kernels' skip_direct): the photons carry L (S|D)+ D paths only.
#pragma once
#include <cstdint>
#include <map>
#include <string>

#include "photonflow/stages/eye_pass.h"
#include "photonflow/geometry/scene.h"
#include "photonflow/estimators/sppm.h"

namespace pf {

// The estimator and direct light of a run that does not name them (render --estimator, --direct;
// trace-hitpoints --estimator, --direct; illuminate --estimator).
constexpr Estimator kDefaultEstimator = Estimator::Pppm;
constexpr DirectMode kDefaultDirect = DirectMode::ShadowRays;

// Roughness below which SPPM's and PPPM's eye paths continue through a glossy point without a
// diffuse base (a metal, or glass that transmits fully) by sampling its BSDF rather than making
// their visible point there (EyePassOptions::glossy_threshold, pf_pbr_eye_continues); PPM's fixed
// eye pass keeps 0. 0 (never) by measurement, docs/RESULTS.md section 9: on the showcase scenes at
// equal time, thresholds 0.5 and 1 raised the RMSE 1.5–1.9× on data/showcase.gltf (rare, very
// bright samples through the rough-glass sphere, e.g. one pass adding ~10^4 to a pixel) and
// 1.03–1.08× on showcase-caustics; the option stays for scenes of smooth metal.
constexpr float kDefaultGlossyThreshold = 0.f;

// Emission samples per pass in each pixel that sees an emitter directly or through mirrors and
// glass (EyePassOptions::emission_spp, eye_pass.h emission_pixels), every estimator. 8 by
// measurement, docs/RESULTS.md sections 7 and 8 (2026-12-03, 30 s at 512×512 against the Mitsuba
// references, 2 runs a scene): the all-pixel RMSE of the mirror-and-glass box 0.73× (16: 0.72×),
// the diffuse box 0.89×, the pass rate and the error away from the lights unchanged (±2 %).
constexpr int kDefaultEmissionSpp = 8;

// Light samples per visible point and pass with shadow rays (EyePassOptions::shadow_samples;
// render's and trace-hitpoints' --shadow-samples auto). sppm and pppm: 1, by measurement
// (docs/RESULTS.md sections 7 and 8, "Light samples", 2026-12-04, 30 s at 512×512 against the
// Mitsuba references, medians of 3): with the pixel's Sobol points as light samples the variance
// away from the lights at equal passes falls 2.3× at 1 sample a pass (1.4× at 4) on the diffuse
// box (with 4× the photons, so that the light samples' share shows);
// 1 sample against 4 at equal time, both with 366,592 photons: 0.99 / 0.99 (diffuse box, all
// pixels / away from the lights), 1.00 / 1.00 (mirror and glass balls), 0.95 / 0.95 (205,663
// triangles, where 1 sample runs 6–10 % more passes); 2 samples were worse than 1 on all three
// (1.02–1.05). ppm: 4 (its one eye pass keeps them: they are the direct light's only samples for
// the whole run).
constexpr int kDefaultShadowSamples = 1;
constexpr int kPpmShadowSamples = 4;

// The eye pass of one pixel (one eye sample, its shadow rays and its gather: render's default
// estimator and direct light) costs as much time as this many photons (each emitted, traced and
// sorted into the pass's grid). Measured with
//   bench/photon_balance.sh build        (WIDTH=512 HEIGHT=512 PASSES=12 FEW=16384 MANY=524288)
// on the three scenes of data/, 2026-12-02, the 2-core machine at load 3.5–4 from other jobs: the
// eye pass of a pixel cost 0.712 / 0.722 photons on cornell-box (two runs; eye pass 0.123 / 0.178
// s, 0.66 / 0.94 µs a photon), 0.540 / 0.498 on cornell-spheres, 2.357 / 0.930 on sds-pool; the
// median over the scenes, 0.712 / 0.722, rounded (docs/RESULTS.md section 7).
constexpr double kEyePixelCostInPhotons = 0.7;
// The automatic count spends this share of a pass's time tracing photons (the rest on the eye
// pass): photons = share / (1 − share) · kEyePixelCostInPhotons · pixels. 2/3 (twice the
// photons of an even split) by measurement, docs/RESULTS.md section 7 (2026-12-04, with emission
// samples; 30 s at 512×512 against the Mitsuba references, medians of 3 runs): against 1/2,
// 0.92 / 0.90 (diffuse box, all pixels / away from the lights), 1.01 / 0.98 (mirror and glass
// balls), 0.97 / 0.94 (205,663 triangles); 3/4 gave 0.90 / 0.87, 1.07 / 1.00, 0.94 / 0.92. Before
// the emission samples (section 7, 2026-12-03) the pixels that see a lamp converged only with the
// passes and an even split was best over all pixels; they now converge 9× as densely, and more
// photons a pass pay on the rest of the image. The optimum is flat and scene-dependent (issue 34:
// 100,000 against 262,144 photons changed the error by 10–15 %, better or worse by scene).
constexpr double kAutoPhotonShare = 2.0 / 3.0;
// The automatic count is a multiple of kAutoPhotonsStep within [kMinAutoPhotons, kMaxAutoPhotons].
constexpr uint32_t kAutoPhotonsStep = 1024;
constexpr uint32_t kMinAutoPhotons = 16384;
constexpr uint32_t kMaxAutoPhotons = 1u << 24;

// The automatic photon count per pass for a width × height image (one eye sample per pixel and
// pass): round(kAutoPhotonShare / (1 − kAutoPhotonShare) · kEyePixelCostInPhotons · width ·
// height) to a multiple of kAutoPhotonsStep, clamped to [kMinAutoPhotons, kMaxAutoPhotons].
// Deterministic (no timing at run time): the same scene always gets the same count.
uint32_t auto_photons(int width, int height);
// The rule in words, for --help ("auto: ...").
std::string auto_photons_rule();
// The rule of the automatic radius in words, for --help.
std::string auto_radius_rule();

// Everything automatic a run without options gets for `scene`.
struct RenderDefaults {
  Estimator estimator = kDefaultEstimator;
  DirectMode direct = kDefaultDirect;
  uint32_t photons = 0;  // per pass, auto_photons(camera width, height)
  float radius = 0.f;    // R0, default_radius(scene)
};
RenderDefaults choose_defaults(const Scene& scene);

// --photons of render and trace-photons: "auto" (returns 0: choose_defaults decides once the
// scene is read) or a count in [1, 2^32); InputError naming --photons otherwise.
uint32_t parse_photons_option(const std::string& text);
// --glossy-threshold of render and trace-hitpoints: "auto" (kDefaultGlossyThreshold for sppm and
// pppm, 0 for ppm) or a number (its range is check_options' of eye_pass.h); InputError naming
// --glossy-threshold for what is not a number.
float parse_glossy_threshold(const std::string& text, Estimator e);
// --emission-spp of render and trace-hitpoints: "auto" (kDefaultEmissionSpp) or a count (its range
// is check_options' of eye_pass.h); InputError naming --emission-spp for what is not an integer.
int parse_emission_spp(const std::string& text);
// --shadow-samples of render and trace-hitpoints: "auto" (kDefaultShadowSamples for sppm and
// pppm, kPpmShadowSamples for ppm) or a count (its range is check_options' of eye_pass.h);
// InputError naming --shadow-samples for what is not an integer.
int parse_shadow_samples(const std::string& text, Estimator e);
// --radius of render: "auto" or 0 (returns 0: default_radius) or a length (its range is
// check_options' of eye_pass.h); InputError naming --radius for what is not a number.
float parse_radius_option(const std::string& text);

// The choices a run made, each with whether it was automatic (the option not given).
struct RenderChoices {
  Estimator estimator = kDefaultEstimator;
  bool estimator_auto = true;
  DirectMode direct = kDefaultDirect;
  bool direct_auto = true;
  uint32_t photons = 0;
  bool photons_auto = true;
  float radius = 0.f;  // the R0 used
  bool radius_auto = true;
  int emission_spp = kDefaultEmissionSpp;  // EyePassOptions::emission_spp used
  bool emission_spp_auto = true;
  int shadow_samples = kDefaultShadowSamples;  // EyePassOptions::shadow_samples used
  bool shadow_samples_auto = true;
  GatherArea gather_area = GatherArea::Surface;  // PpmOptions::gather_area used
  bool gather_area_auto = true;
};
// "pppm (auto), direct shadow-rays (auto), 1 shadow sample (auto), 366592 photons/pass (auto),
// R0 0.0123 (auto), 8 emission samples (auto), gather area surface (auto)": render's summary line
// (the shadow samples only with direct shadow-rays).
std::string describe_choices(const RenderChoices& c);
// Writes the choices into a run record's parameters (provenance.h): the values used, and
// "<name>_auto": "true" | "false" for estimator, direct, shadow-samples, photons, radius,
// emission-spp and gather-area.
void record_choices(std::map<std::string, std::string>& parameters, const RenderChoices& c);

}  // namespace pf
