// render_defaults.h — the defaults of render and of the staged route, chosen by measurement at
// equal time (docs/RESULTS.md "Defaults" has the scene set, the measurement behind each and the
// commands).
// One place defines them: render, the staged route (trace-hitpoints --estimator and --direct,
// trace-photons --photons, illuminate --estimator) and pipelines/render.mk (which passes "auto")
// take them from here, so a run without flags gets the same numbers by either route.
//
//   estimator   pppm (a new eye pass every pass, independent passes with a global radius
//               schedule; mergeable): the lowest error of ppm, sppm and pppm at equal time
//   direct      shadow-rays: less error than direct light by photons at equal time
//   photons     automatic, from the image size: twice the photons per pass at which tracing them
//               costs as long as the pass's eye paths (kEyePixelCostInPhotons, measured;
//               kAutoPhotonShare, measured; auto_photons)
//   shadow-samples  1 light sample per visible point and pass for sppm and pppm, whose samples
//               are a pixel's Sobol points over the passes (pixel_sampler.h pf_light_draws), 4
//               where an environment lights the scene; 4 for ppm, whose one eye pass keeps its
//               samples (kDefaultShadowSamples, auto_shadow_samples)
//   radius      automatic, from the pixel footprint and the scene extent (default_radius,
//               eye_pass.h): R0 = s · max(scene diagonal / 200, 4 · pixel angle · look-at
//               distance), s = 2 in a scene of diffuse surfaces only, 1.5 with mirrors, glass
//               or PBR materials (radius_scale: kRadiusScaleDiffuse, kRadiusScale), the factors
//               measured with the surface gather area
//   gather-area surface for sppm and pppm (estimators/gather_area.h): the estimate divides by
//               the surface the gather region holds, unbiased at corners and edges (docs/RESULTS.md
//               "Gather area")
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

// What SPPM's and PPPM's eye paths do at a glossy (PBR) vertex (EyePassOptions::glossy,
// eye_pass.h GlossyMerge): share its light between the gather there and the continuation by the
// merge weight (material/merge_weight_shared.h), with direct light by next-event estimation and
// the BSDF's sample under MIS (docs/RESULTS.md "Glossy points"). PPM's fixed eye pass keeps
// GlossyMerge::First.
constexpr GlossyMerge kDefaultGlossyMerge = GlossyMerge::Mis;

// Glossy samples per pass in each pixel whose first glossy vertex continues (EyePassOptions::
// glossy_spp, eye_pass.h glossy_pixels), pppm with GlossyMerge::Mis only (docs/RESULTS.md
// "Glossy points").
constexpr int kDefaultGlossySpp = 8;

// Emission samples per pass in each pixel that sees an emitter directly or through mirrors and
// glass (EyePassOptions::emission_spp, eye_pass.h emission_pixels), every estimator. 8: they lower
// the error over all pixels at equal time and leave the pass rate and the error away from the
// lights unchanged (docs/RESULTS.md "Emission samples").
constexpr int kDefaultEmissionSpp = 8;

// Light samples per visible point and pass with shadow rays (EyePassOptions::shadow_samples;
// render's and trace-hitpoints' --shadow-samples auto, auto_shadow_samples). sppm and pppm: 1,
// since the pixel's Sobol points over the passes are its light samples, and at equal time one a
// pass does as well as more (docs/RESULTS.md "Light samples and the photon share"); 4 in a scene
// with an environment light, whose direct light (a sky over the whole hemisphere, half of it
// hidden at a point near an object) is most of the image and most of its noise, and the photons
// take none of it: at 30 s the error of hdri-object and window-room falls by 42 % and 20 % from
// 1 to 4, and rises again at 8 and 16 (docs/RESULTS.md "Light from outside"). ppm: 4 (its one
// eye pass keeps them: they are the direct light's only samples for the whole run).
constexpr int kDefaultShadowSamples = 1;
constexpr int kEnvironmentShadowSamples = 4;
constexpr int kPpmShadowSamples = 4;

// The eye pass of one pixel (one eye sample, its shadow rays and its gather: render's default
// estimator and direct light) costs as much time as this many photons (each emitted, traced and
// sorted into the pass's grid): the median over the three scenes of data/, rounded, measured by
// bench/photon_balance.sh (docs/RESULTS.md "Defaults", the photon count per pass).
constexpr double kEyePixelCostInPhotons = 0.7;
// The automatic count spends this share of a pass's time tracing photons (the rest on the eye
// pass): photons = share / (1 − share) · kEyePixelCostInPhotons · pixels. 2/3 (twice the
// photons of an even split), chosen at equal time against 1/2 and 3/4 (docs/RESULTS.md "Light
// samples and the photon share"): with the emission samples the pixels that see a lamp converge
// quickly, and more photons a pass pay on the rest of the image. The optimum is flat and
// scene-dependent.
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
// --glossy-merge of render and trace-hitpoints: "auto" (kDefaultGlossyMerge for sppm and pppm
// with direct light by shadow rays, First for ppm or direct light by photons), "first" or "mis"
// (not with ppm); InputError naming --glossy-merge otherwise.
GlossyMerge parse_glossy_merge_option(const std::string& text, Estimator e, DirectMode d);
// --emission-spp of render and trace-hitpoints: "auto" (kDefaultEmissionSpp) or a count (its range
// is check_options' of eye_pass.h); InputError naming --emission-spp for what is not an integer.
int parse_emission_spp(const std::string& text);
// --glossy-spp of render and trace-hitpoints: "auto" (kDefaultGlossySpp for pppm with
// GlossyMerge::Mis, else 0) or a count (its range is check_options' of eye_pass.h, and only pppm
// takes more than 0: render_driver.h check_options); InputError naming --glossy-spp otherwise.
int parse_glossy_spp(const std::string& text, Estimator e, GlossyMerge g);
// --shadow-samples of render and trace-hitpoints: "auto" (returns 0: auto_shadow_samples once
// the scene is read) or a count (its range is check_options' of eye_pass.h); InputError naming
// --shadow-samples for what is not an integer.
int parse_shadow_samples(const std::string& text);
// --shadow-samples auto: kPpmShadowSamples for ppm; kEnvironmentShadowSamples for sppm and pppm
// in a scene with an environment light, kDefaultShadowSamples otherwise.
int auto_shadow_samples(Estimator e, const Scene& scene);
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
