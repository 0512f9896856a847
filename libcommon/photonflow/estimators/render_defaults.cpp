// render's defaults: see render_defaults.h.
#include "photonflow/estimators/render_defaults.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "photonflow/foundations/error.h"
#include "photonflow/foundations/options.h"

namespace pf {

uint32_t auto_photons(int width, int height) {
  const double pixels = double(std::max(width, 0)) * double(std::max(height, 0));
  const double want =
      kAutoPhotonShare / (1.0 - kAutoPhotonShare) * kEyePixelCostInPhotons * pixels;
  const double steps = std::round(want / double(kAutoPhotonsStep));
  const double n = std::clamp(steps * double(kAutoPhotonsStep), double(kMinAutoPhotons),
                              double(kMaxAutoPhotons));
  return uint32_t(n);
}

std::string auto_photons_rule() {
  char buf[256];
  std::snprintf(buf, sizeof buf,
                "auto: %g x width x height (photon tracing about %g%% of a pass), a multiple of "
                "%u in [%u, %u]; %u at 512x512",
                kAutoPhotonShare / (1.0 - kAutoPhotonShare) * kEyePixelCostInPhotons,
                100.0 * kAutoPhotonShare, kAutoPhotonsStep, kMinAutoPhotons, kMaxAutoPhotons,
                auto_photons(512, 512));
  return buf;
}

std::string auto_radius_rule() {
  return "auto: 2 (a scene of diffuse surfaces only) or 1.5 (with mirrors, glass or PBR "
         "materials) x max(scene diagonal / 200, 4 pixel footprints at the look-at distance)";
}

RenderDefaults choose_defaults(const Scene& scene) {
  RenderDefaults d;
  d.photons = auto_photons(scene.camera.width, scene.camera.height);
  d.radius = default_radius(scene);
  return d;
}

uint32_t parse_photons_option(const std::string& text) {
  if (text == "auto") return 0;
  size_t used = 0;
  long long n = 0;
  try {
    n = std::stoll(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != text.size())
    throw input_error("", "--photons must be a count or auto, got '" + text + "'");
  require_positive("photons", int64_t(n));
  if (n > int64_t(UINT32_MAX)) throw input_error("", "--photons must be below 2^32 per pass");
  return uint32_t(n);
}

namespace {
// `text` as a float when all of it is one (std::stof alone accepts a number's prefix: "0.3r").
bool whole_float(const std::string& text, float& out) {
  size_t used = 0;
  try {
    out = std::stof(text, &used);
  } catch (const std::exception&) {
    return false;
  }
  return used != 0 && used == text.size();
}
}  // namespace

GlossyMerge parse_glossy_merge_option(const std::string& text, Estimator e, DirectMode d) {
  if (text == "auto")
    return e == Estimator::Ppm || d != DirectMode::ShadowRays ? GlossyMerge::First
                                                               : kDefaultGlossyMerge;
  const GlossyMerge g = parse_glossy_merge(text);
  if (g == GlossyMerge::Mis && e == Estimator::Ppm)
    throw input_error("", "--glossy-merge mis needs a new eye pass every pass (sppm or pppm)",
                      "ppm's one eye pass would keep one sample of each glossy lobe for good");
  return g;
}

namespace {
// "auto" (returns auto_value) or a whole count in [lo, hi]; InputError naming --<option> otherwise.
int count_or_auto(const std::string& text, const char* option, long lo, long hi, int auto_value) {
  if (text == "auto") return auto_value;
  size_t used = 0;
  long v = -1;
  try {
    v = std::stol(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != text.size() || v < lo || v > hi)
    throw input_error("", std::string("--") + option + " must be auto or a count in [" +
                              std::to_string(lo) + ", " + std::to_string(hi) + "], got '" + text +
                              "'");
  return int(v);
}
}  // namespace

int parse_glossy_spp(const std::string& text, Estimator e, GlossyMerge g) {
  const int automatic = e == Estimator::Pppm && g == GlossyMerge::Mis ? kDefaultGlossySpp : 0;
  return count_or_auto(text, "glossy-spp", 0, kMaxGlossySpp, automatic);
}

int parse_emission_spp(const std::string& text) {
  return count_or_auto(text, "emission-spp", 0, kMaxEmissionSpp, kDefaultEmissionSpp);
}

float parse_radius_option(const std::string& text) {
  if (text == "auto") return 0.f;
  float r = 0.f;
  if (!whole_float(text, r))
    throw input_error("", "--radius must be a length in world units or auto, got '" + text + "'");
  return r;
}

int parse_shadow_samples(const std::string& text) {
  return count_or_auto(text, "shadow-samples", 1, kMaxShadowSamples, 0);
}

int auto_shadow_samples(Estimator e, const Scene& scene) {
  if (e == Estimator::Ppm) return kPpmShadowSamples;
  return scene.environment.present() ? kEnvironmentShadowSamples : kDefaultShadowSamples;
}

std::string describe_choices(const RenderChoices& c) {
  auto how = [](bool automatic) { return std::string(automatic ? " (auto)" : ""); };
  const std::string shadow =
      c.direct == DirectMode::ShadowRays
          ? ", " + std::to_string(c.shadow_samples) +
                (c.shadow_samples == 1 ? " shadow sample" : " shadow samples") +
                how(c.shadow_samples_auto)
          : std::string();
  return std::string(estimator_name(c.estimator)) + how(c.estimator_auto) + ", direct " +
         direct_mode_name(c.direct) + how(c.direct_auto) + shadow + ", " +
         std::to_string(c.photons) +
         " photons/pass" + how(c.photons_auto) + ", R0 " + default_text(c.radius) +
         how(c.radius_auto) + ", " + std::to_string(c.emission_spp) + " emission samples" +
         how(c.emission_spp_auto) + ", gather area " + gather_area_name(c.gather_area) +
         how(c.gather_area_auto);
}

void record_choices(std::map<std::string, std::string>& p, const RenderChoices& c) {
  auto flag = [](bool b) { return std::string(b ? "true" : "false"); };
  p["estimator"] = estimator_name(c.estimator);
  p["estimator_auto"] = flag(c.estimator_auto);
  p["direct"] = direct_mode_name(c.direct);
  p["direct_auto"] = flag(c.direct_auto);
  p["photons"] = std::to_string(c.photons);
  p["photons_auto"] = flag(c.photons_auto);
  p["radius"] = default_text(c.radius);
  p["radius_auto"] = flag(c.radius_auto);
  p["emission-spp"] = std::to_string(c.emission_spp);
  p["emission-spp_auto"] = flag(c.emission_spp_auto);
  p["shadow-samples"] = std::to_string(c.shadow_samples);
  p["shadow-samples_auto"] = flag(c.shadow_samples_auto);
  p["gather-area"] = gather_area_name(c.gather_area);
  p["gather-area_auto"] = flag(c.gather_area_auto);
}

}  // namespace pf
