// eye_pass.h — the eye pass of progressive photon mapping (thesis ch. 3.5 and 7.1; Hachisuka et
// al. 2008, section 4.1): trace rays from the camera through each pixel, follow mirror reflection
// and glass refraction, and store a hitpoint at the first non-delta surface (diffuse or PF_MAT_PBR).
//
// Besides the hitpoints it produces two image layers (linear RGB, W/(sr m^2)):
//   emitted — emitters seen directly or through specular chains (photons never carry this);
//   direct  — direct light at the hitpoints by shadow rays, when DirectMode::ShadowRays; the photon
//             gather then skips photons flagged PF_PHOTON_DIRECT so nothing is counted twice.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "photonflow/geometry/camera.h"
#include "photonflow/material/pbr_point_shared.h"
#include "photonflow/sampling/pixel_sampler.h"
#include "photonflow/geometry/raycast.h"
#include "photonflow/foundations/rng.h"
#include "photonflow/geometry/scene.h"

namespace pf {

struct SurfaceHit;  // geometry/surface.h

enum class DirectMode {
  Photons,     // all light at hitpoints comes from photons (PPM's usual choice)
  ShadowRays,  // direct light by area-light sampling with shadow rays; photons carry the rest
};
const char* direct_mode_name(DirectMode m);

// Where eye samples go inside their pixel (pixel_sampler.h has the definitions).
enum class PixelSampler {
  Strata = PF_SAMPLER_STRATA,  // PPM's fixed eye pass: centre, or a stratified grid for spp > 1
  Random = PF_SAMPLER_RANDOM,  // independent jitter, new every pass
  Sobol = PF_SAMPLER_SOBOL,    // per-pixel scrambled (0,2)-sequence indexed by pass·spp + sample
};
const char* pixel_sampler_name(PixelSampler s);
// "strata" | "random" | "sobol" (InputError naming --pixel-sampler otherwise).
PixelSampler parse_pixel_sampler(const std::string& name);

// The visible point of an eye path at a PF_MAT_PBR surface.
enum class GlossyMerge {
  // At the first non-delta vertex, PBR or diffuse (HJ09 section 4); direct light there by
  // light sampling alone (DirectMode::ShadowRays).
  First,
  // At a PBR vertex the light is shared between gathering there and continuing by the BSDF's
  // sample, by the merge weight of each direction (material/merge_weight_shared.h): the path
  // makes its visible point there with the merge probability q, and goes on otherwise, to the
  // next diffuse or PBR vertex. Direct light at every PBR vertex by next-event estimation and
  // the BSDF's sample, weighted by the power heuristic (all light types; delta lights by
  // next-event estimation alone). Needs DirectMode::ShadowRays (check_options).
  Mis,
};
const char* glossy_merge_name(GlossyMerge g);
// "first" | "mis" (InputError naming --glossy-merge otherwise).
GlossyMerge parse_glossy_merge(const std::string& name);

struct EyePassOptions {
  int spp = 1;             // eye samples per pixel (1: pixel centre; n > 1: stratified jitter)
  int max_depth = 16;      // specular bounces before a path is dropped
  DirectMode direct = DirectMode::Photons;
  int shadow_samples = 4;  // light samples per hitpoint for DirectMode::ShadowRays
  float radius = 0.f;      // initial radius R0, world units; 0 = automatic (default_radius)
  uint32_t seed = 1;
  int threads = 0;         // 0 = all cores; results do not depend on it
  // Which eye pass this is: SPPM and probabilistic PPM trace a new one before every photon pass
  // (pass p uses eye stream (seed, 0xE7E0000 + p, pixel·spp + s), and for the light samples of
  // a path's vertices the pixel's Sobol points under PixelSampler::Sobol or the shadow stream
  // (seed, 0x5AD0000 + p, same index) otherwise: pixel_sampler.h pf_light_draws_vertex); PPM's
  // one eye pass is pass 0.
  uint32_t pass = 0;
  PixelSampler sampler = PixelSampler::Strata;
  // What an eye path does at a PF_MAT_PBR point (GlossyMerge below). render's and
  // trace-hitpoints' default: render_defaults.h kDefaultGlossyMerge for sppm and pppm; a fixed
  // eye pass (PPM) keeps First, since its one sample of a lobe would never converge.
  GlossyMerge glossy = GlossyMerge::First;
  // Emission samples: in each pixel that emission_pixels marks, this many eye paths more per pass
  // that only follow mirrors and glass to the emitters they see (no visible point, shadow ray or
  // gather), averaged with the pass's spp eye samples into the emitted layer:
  //   emitted = (Σ_s L_e,s + Σ_k L_e,k) / (spp + emission_spp)                (box filter)
  // Every sample is an unbiased estimate of the pixel's emitted light, and the marks depend on
  // the scene and camera only, so the layer stays unbiased; the samples of a pixel over the passes
  // form one (0,2)-sequence (pixel_sampler.h). Pixels that see a lamp's outline, or a lamp through
  // glass or in a mirror, otherwise converge only with the eye samples and hold much of a
  // scene's error; these samples cost one specular chain each, in the few pixels marked
  // (docs/RESULTS.md "Emission samples"). 0: none (the eye samples alone).
  // render's and trace-hitpoints' default: render_defaults.h kDefaultEmissionSpp.
  int emission_spp = 0;
  // emission_pixels(scene), kept by a caller that traces many eye passes (render); nullptr: the
  // eye pass computes it (when emission_spp > 0).
  const std::vector<uint8_t>* emission_pixels = nullptr;
  // Glossy samples (GlossyMerge::Mis, pppm only): in each pixel that glossy_pixels marks, this
  // many eye samples more per pass, full eye paths like the spp ones (visible points, shadow
  // rays, gathers), all of the pixel's samples weighted 1/(spp + glossy_spp) (box filter). A
  // glossy vertex that continues samples its lobe once per eye sample, which leaves the pixels
  // that see a narrow lobe with the noise of a path tracer of `passes` samples; these pixels are
  // few, and their samples cost eye paths only (docs/RESULTS.md "Glossy points"). The marks
  // depend on the scene and camera only, so the pass stays unbiased. 0: none.
  // render's and trace-hitpoints' default: render_defaults.h kDefaultGlossySpp.
  int glossy_spp = 0;
  // glossy_pixels(scene), kept by a caller that traces many eye passes; nullptr: computed here.
  const std::vector<uint8_t>* glossy_pixels = nullptr;
};

// --glossy-spp at most.
constexpr int kMaxGlossySpp = 64;

// The pixels that take glossy samples: those whose centre ray (through the lens centre) meets,
// directly or through mirrors and glass (both branches at glass, as emission_pixels), a PF_MAT_PBR
// vertex whose merge probability is below kGlossySampleMaxMerge (the eye path goes on from it in
// most passes: material/merge_weight_shared.h; a rough plastic floor, mostly gathered, is not
// marked), and their eight neighbours. Row-major, width × height.
constexpr float kGlossySampleMaxMerge = 0.5f;
std::vector<uint8_t> glossy_pixels(const Scene& scene);

// --emission-spp at most: more do not pay for their chains in any scene measured.
constexpr int kMaxEmissionSpp = 1024;

// The pixels that take emission samples: those whose centre ray reaches the front of an emitter
// directly or through mirrors and glass (both branches at glass: reflection and refraction,
// up to 8 bounces and 32 rays a pixel), and their eight neighbours (a lamp's outline may cover
// a pixel whose centre misses it). Row-major, width × height, 1 = marked. A deterministic function of the scene and its
// camera, so every eye pass and both routes (render, trace-hitpoints) mark the same pixels.
std::vector<uint8_t> emission_pixels(const Scene& scene);

struct EyePassResult {
  std::vector<pf_hitpoint> hitpoints;  // sorted by pixel (row-major), then sample
  // The BSDF at each hitpoint, parallel to `hitpoints` (material/pbr_point_shared.h): the
  // textured parameters at a PF_MAT_PBR hitpoint, all zero at any other. EMPTY when the scene has
  // no PBR material (Scene::has_pbr): other scenes keep and write nothing more.
  std::vector<pf_pbr_point> bsdf;
  std::vector<float> emitted;          // width × height × 3
  std::vector<float> direct;           // width × height × 3 (zero unless ShadowRays)
  float radius = 0.f;                  // R0 used
  int width = 0, height = 0;
};

// Columns of the eye pass's stratification grid for `spp` samples per pixel (both backends): the
// grid has columns × rows = spp cells exactly, rows being the largest divisor of spp not above
// √spp (a square grid when spp is a perfect square, one row of strips when it is prime), and
// sample s jitters within cell (s mod columns, s / columns). Every cell holding one sample makes
// the samples, taken together, uniform over the pixel, as the box filter weight 1/spp requires.
int eye_strata_columns(int spp);

// The automatic initial radius: a fraction of the scene, never below a few pixel footprints at
// the camera-to-scene distance:  R0 = s · max(diag / 200, 4 · pixel_angle · |look_at − eye|),
// s = kRadiusScaleDiffuse where every triangle is diffuse or an emitter (radius_scale), else
// kRadiusScale. The factors go with the surface gather area (estimators/gather_area.h), which
// removes the edge bias that holds a larger radius back: at equal time 1.5 lowers the error on
// the diffuse scenes and leaves the mirror-and-glass box's unchanged; 2 is better still on the
// diffuse scenes, but blurs the caustics that mirrors and glass focus, and PBR scenes (glossy
// caustics) were not measured at 2 (docs/RESULTS.md "Gather area" and "The lamp's outline and
// the radius of diffuse scenes"). ppm's fixed hitpoints start from the same R0 (not measured
// separately for ppm, which keeps the disc).
constexpr float kRadiusScale = 1.5f;
constexpr float kRadiusScaleDiffuse = 2.f;
float radius_scale(const Scene& scene);
float default_radius(const Scene& scene);

// InputError naming the option (--spp, --max-depth, --shadow-samples, --radius, --threads) when
// one is out of range; trace-hitpoints and render check their options with it.
constexpr int kMaxShadowSamples = 1024;  // --shadow-samples, per visible point and pass
void check_options(const EyePassOptions& opt);
// InputError naming --spp when width × height × spp eye samples exceed the 2^32 sample streams
// of a pass (a sample's stream index is a uint32: (seed, pass, pixel · spp + sample)). Every eye
// pass (EyeTracer, the device's) checks it.
void check_eye_samples(const Scene& scene, const EyePassOptions& opt);

EyePassResult trace_hitpoints(const Scene& scene, const EyePassOptions& opt);

// What trace_hitpoints_into keeps between calls: the visible points of each image row.
struct EyePassWork {
  std::vector<std::vector<pf_hitpoint>> rows;
  std::vector<std::vector<pf_pbr_point>> pbr_rows;  // the rows' BSDF tables (PBR scenes only)
};
// trace_hitpoints into `res`, reusing the storage of res's vectors and of `work` from the last
// call: the estimators that trace an eye pass every pass (sppm.h) allocate nothing after the
// first. The same result as trace_hitpoints.
void trace_hitpoints_into(const Scene& scene, const EyePassOptions& opt, EyePassResult& res,
                          EyePassWork& work);

// One eye sample at a time, as trace_hitpoints_into traces them all: the camera ray of sample s
// of pixel (x, y) in pass opt.pass, followed through mirrors and glass to its first non-delta
// surface (diffuse, or PF_MAT_PBR: the glossy BSDF, whose visible point sits there too; HJ09
// section 4, SPPM's visible points). At a PBR visible point `pbr` (when given) receives the BSDF
// there (pbr_point_at, surface.h) and the hitpoint's weight is the throughput alone (the texture
// is inside the parameters); at any other it is set to all zeros. No random number is drawn at
// the visible point, PBR or not. sample() adds the emitted light the path sees through mirrors
// and glass (times its throughput and the box filter weight 1/spp) to `emitted` and, with
// DirectMode::ShadowRays, the direct light at its visible point to `direct`; under
// GlossyMerge::Mis, the direct light of every PBR vertex and light from an emitter found after a
// glossy continuation go to `direct` too, since emission samples stand in only for the
// mirror-and-glass part (emitted_layer). It returns whether the path found a visible point, written to `hp`
// (radius R0 = radius()). The estimators that gather as they trace (sppm_pass_traced) call it
// pixel by pixel, then emitted_layer; the bits are those of trace_hitpoints_into.
class EyeTracer {
 public:
  EyeTracer(const Scene& scene, const EyePassOptions& opt);
  bool sample(int x, int y, int s, pf_hitpoint& hp, Vec3& emitted, Vec3& direct,
              pf_pbr_point* pbr = nullptr) const;
  // The pixel's emitted layer from its eye samples' sum `emitted` (each weighted 1/spp, as
  // sample() adds them): in a pixel with emission samples (EyePassOptions::emission_spp),
  // (spp · emitted + Σ_k L_e,k) / (spp + emission_spp); elsewhere `emitted` unchanged.
  Vec3 emitted_layer(int x, int y, const Vec3& emitted) const;
  float radius() const { return radius_; }
  int spp() const { return spp_; }
  // The eye samples of pixel (x, y) in this pass: spp, plus glossy_spp in a marked pixel.
  int samples(int x, int y) const {
    return glossy_pixels_ && (*glossy_pixels_)[size_t(y) * size_t(scene_.camera.width) + size_t(x)]
               ? spp_ + opt_.glossy_spp
               : spp_;
  }
  // The most samples a pixel takes (spp + glossy_spp where any pixel is marked).
  int max_samples() const { return glossy_pixels_ ? spp_ + opt_.glossy_spp : spp_; }

 private:
  const Scene& scene_;
  const EyePassOptions opt_;
  int spp_, columns_;
  float radius_, eps_;
  pf_uint eye_key_, sobol_key_;  // the pass's eye stream key, the run's scrambling key
  pf_uint emission_key_;         // the emission samples' scrambling key
  CameraFrame cam_;
  RayCaster caster_;
  int32_t camera_leaf_;  // the kd leaf of the eye point: the camera rays' Ray::leaf
  std::vector<uint8_t> own_pixels_;          // emission_pixels, when the caller gave none
  const std::vector<uint8_t>* emit_pixels_;  // the marks in use (nullptr: no emission samples)
  std::vector<int32_t> tri_light_;  // area light of an emissive triangle, −1 otherwise (Mis)
  std::vector<uint8_t> own_glossy_;            // glossy_pixels, when the caller gave none
  const std::vector<uint8_t>* glossy_pixels_;  // the marks in use (nullptr: no glossy samples)
  pf_uint glossy_key_;                         // the glossy samples' scrambling key
  Vec3 emission_sample(int x, int y, int k) const;
  // The power-heuristic weight of an emitter hit by a glossy vertex's BSDF sample (GlossyMerge::
  // Mis): against the shadow_samples light samples next-event estimation drew at `from`, the
  // vertex the sample left.
  float emitter_hit_weight(const Ray& ray, const Hit& h, const SurfaceHit& sh, const Vec3& from,
                           float bsdf_pdf) const;
};

// Irradiance-weighted direct radiance L_direct = ρ/π · E at a diffuse point, by light sampling with
// shadow rays (`samples` per call, each drawing (ul, u1, u2) from `draws`: pixel_sampler.h
// pf_light_draws, Sobol points under PF_SAMPLER_SOBOL, the shadow stream otherwise): area, point,
// spot and directional lights (light_shared.h) and the environment, each sample's light picked by
// Scene::sample_light (by power, or p's local choice: light_choice_shared.h).
// `leaf`: the kd leaf p lies in (SurfaceHit::leaf), where the shadow rays start their walk.
Vec3 direct_light(const Scene& scene, const Vec3& p, const Vec3& ng, const Vec3& ns,
                  const pf_material& m, int samples, pf_light_draws& draws, int32_t leaf = -1);
// The same with the shadow stream (seed, 0x5AD0000 + pass, index): independent draws. For tests.
Vec3 direct_light(const Scene& scene, const Vec3& p, const Vec3& ng, const Vec3& ns,
                  const pf_material& m, int samples, uint32_t seed, uint32_t pass, uint32_t index);
// The same estimator (the same draws and shadow rays) at a PF_MAT_PBR point: L_direct =
// (1/n) Σ f(wo, w_l)·L_e·|cos θ_x|·G/p, with f the BSDF in radiance mode (pf_pbr_eval_world:
// front shading normal ns_front, front geometric normal ng_front, wo towards the eye). Light
// from behind the surface counts where the BSDF transmits; the shadow ray leaves on w_l's side.
Vec3 direct_light_pbr(const Scene& scene, const Vec3& p, const Vec3& ng_front,
                      const Vec3& ns_front, const pf_bsdf_params& params, const Vec3& wo,
                      int samples, uint32_t seed, uint32_t pass, uint32_t index);
// The same sum with `samples` light samples from `draws` (ul, u1, u2 each); with `mis` each
// sample of an area light is weighted against the BSDF's sample of the same point by the power
// heuristic (Veach 1997 eq. 9.13, with n light samples against one BSDF sample):
//   w_light = (n p_light)² / ((n p_light)² + p_bsdf²),  p_light per unit solid angle,
// the BSDF sample that hits the light taking the complement (EyeTracer::emitter_hit_weight);
// point, spot and directional lights keep weight 1 (no BSDF sample hits them).
Vec3 direct_light_pbr(const Scene& scene, const Vec3& p, const Vec3& ng_front,
                      const Vec3& ns_front, const pf_bsdf_params& params, const Vec3& wo,
                      int samples, pf_light_draws& draws, bool mis, int32_t leaf = -1);

}  // namespace pf
