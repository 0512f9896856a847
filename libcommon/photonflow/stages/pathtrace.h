// pathtrace.h — an unbiased path tracer over a baked scene: the reference and the baseline that
// photon mapping is measured against (docs/RESULTS.md "Speed against accuracy").
//
// It estimates the rendering equation (Kajiya 1986)
//   L_o(x, ω_o) = L_e(x, ω_o) + ∫_Ω f_r(x, ω_i, ω_o) L_i(x, ω_i) cos θ_i dω_i
// per pixel as the box-filtered mean of independent paths from the camera. The materials are
// exactly the ones photon mapping models (shared_types.h), evaluated by the same code
// (surface.h, sampling.h, camera.h, raycast.h), so both methods render the same radiometry:
//   diffuse   Lambertian, f_r = ρ/π, two-sided (it reflects on the side the ray arrives from);
//             the next direction is cosine-distributed around the shading normal, so
//             f_r·cos/pdf = ρ;
//   mirror    perfect reflection times its reflectance (specular_bounce);
//   glass     smooth dielectric: reflects with the Fresnel probability F, refracts otherwise
//             (times its tint), total internal reflection reflects (specular_bounce);
//   emitter   one-sided: emits radiance L_e along its geometric normal (front side) only, and
//             reflects diffusely with its colour when that is not black (a black emitter absorbs).
//   PBR       the glTF metallic-roughness BSDF (material/bsdf_shared.h, PF_MAT_PBR) in the front
//             shading frame: NEE with f(wo, w_l) (area lights MIS-weighted against pf_bsdf_pdf by
//             the power heuristic, point lights by NEE alone), then the BSDF's sample in radiance
//             mode (pf_pbr_scatter, material/pbr_scatter_shared.h; draws u1, u2, u3 after NEE's,
//             then the roulette's), and an emitter hit after it is MIS-weighted with that
//             sample's pdf. Pairs the geometric and shading normals disagree on end the path.
//
// Direct light by next-event estimation (Veach 1997, §9.2; the area form of the light transport
// integral, eq. 8.3 there): at every diffuse vertex x one light is picked (probability p_l: in
// proportion to power, Scene::pick_light, in a scene of one emitter or of many lights; else
// ½ by the light's unoccluded irradiance at x, ¼ by power, ¼ uniformly over the emitters,
// pathtrace.cpp) and one point y on it (uniform on its triangle, 1/A):
//   L_direct ≈ f_r · L_e(y → x) · V(x, y) · cos θ_x · cos θ_y / |x − y|² · A / p_l,
// and point lights (intensity I) give f_r · I · V · cos θ_x / |x − y|² / p_l, spot lights the same
// times the KHR_lights_punctual falloff, directional lights (irradiance E) f_r · E · V · cos θ_x / p_l
// (light_shared.h; delta lights, never hit by a path). Emission found by the
// path itself is then counted only where NEE could not have found it: on the camera ray and right
// after a mirror or glass bounce (specular chains: L S* E paths). After a diffuse bounce a hit
// emitter adds nothing (MisMode::Off), or — with multiple importance sampling (MisMode::Power,
// Veach 1997 §9.2.4, the power heuristic with β = 2) — both strategies count, weighted
//   w_light = p_light² / (p_light² + p_bsdf²),  w_bsdf = p_bsdf² / (p_light² + p_bsdf²),
// with both densities per unit solid angle: p_bsdf = cos θ_x / π, p_light = p_l · |x − y|² /
// (A · cos θ_y). Either way every path is counted exactly once in expectation.
//
// Russian roulette (Arvo & Kirk 1990): after `rr_depth` bounces a path survives a bounce with
// probability q = min(1, max channel of T·η_scale) and its throughput T is divided by q, which
// leaves the estimate unbiased. η_scale is the product of (η_i/η_o)² over the path's rough-glass
// refractions so far: it undoes the radiance's (η_o/η_i)² (pbrt-v3's etaScale; Mitsuba 3 applies
// η² likewise), so that the roulette weighs the energy a path carries: a path that has just left
// a glass object (T × 2.25 at η = 1.5) survives by that energy, not with certainty. `max_depth` bounds the scattering events of a path (light that
// needs more is dropped: a fraction ρ^(max_depth+1) of it in a closed room of albedo ρ, 0.1% at
// ρ = 0.9 and the default 64; photon mapping's defaults cut at 16 bounces).
//
// Random numbers are counter-based, by named dimension (sampling/path_sampler.h: the pixel
// position and the lens, then per bounce the light's choice and point, the BSDF direction, the
// lobe or glass choice, the roulette). PathSamplerKind::Sobol (the default) gives each dimension
// its own per-pixel Owen-scrambled (0,2)-sequence indexed by the sample number s, so a pixel's
// samples stratify every decision; Independent draws sample s of pixel p from the stream
// (seed, kPathStream + s, p). A pixel's samples are added in
// sample order, by whichever thread renders its row, in double precision: the image after n
// samples does not depend on the thread count, on how the samples were batched into passes, or
// on snapshots.
//
// Progressive: the image is refined pass after pass (each pass adds samples to every pixel);
// snapshots of the running mean can be taken every `snapshot_every` samples, and a time limit stops
// the run at the end of the pass in which it expires.
//
// The returned image is the per-pixel mean radiance (linear RGB, W/(sr m²)) with two AOV layers:
//   "samples"  — samples averaged into the pixel (the same for every pixel);
//   "variance" — estimated variance of the pixel's mean luminance: s²/n with s² the unbiased sample
//                variance of the n samples' luminance (0 when n < 2). Its square root is the
//                pixel's standard error, which tests and convergence studies use.
#pragma once
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "photonflow/image/image.h"
#include "photonflow/io/provenance.h"
#include "photonflow/geometry/scene.h"
#include "photonflow/sampling/path_sampler.h"

namespace pf {

enum class MisMode {
  Off,    // after a diffuse bounce only NEE counts direct light
  Power,  // NEE and hit emitters combined by the power heuristic (β = 2)
};
const char* mis_mode_name(MisMode m);

struct PathTraceOptions {
  int spp = 64;             // samples per pixel in total (>= 1)
  int max_depth = 64;       // scattering events per path (0: emitters seen directly only)
  int rr_depth = 3;         // bounces before Russian roulette starts
  MisMode mis = MisMode::Power;
  PathSamplerKind sampler = PathSamplerKind::Sobol;  // path_sampler.h
  uint32_t seed = 1;
  int threads = 0;          // 0 = all cores; results do not depend on it
  int snapshot_every = 0;   // samples per pixel between snapshot callbacks; 0 = none
  double time_limit_s = 0;  // stop at the end of the pass in which this wall time passes; 0 = none
};

// Where a run stands (given to the callbacks and returned).
struct PathTraceStatus {
  int samples = 0;          // samples per pixel done
  int target = 0;           // samples per pixel asked for (opt.spp)
  double seconds = 0;       // wall time since the run started
  uint64_t paths = 0;       // camera paths traced (samples × pixels)
  uint64_t rays = 0;        // rays cast: path segments plus shadow rays
  uint64_t nonfinite = 0;   // samples dropped because their value was NaN or infinite
  bool timed_out = false;   // stopped by the time limit before `target`
};

struct PathTraceCallbacks {
  // Called with the running image every opt.snapshot_every samples (not for the final image,
  // which pathtrace returns, unless the count falls on a multiple).
  std::function<void(const Image&, const PathTraceStatus&)> on_snapshot;
  // Called after every pass (progress display).
  std::function<void(const PathTraceStatus&)> on_progress;
};

// Renders `scene` from its camera. Throws InputError for options out of range (spp < 1,
// max_depth < 0, rr_depth < 0, snapshot_every < 0, time_limit_s < 0).
Image pathtrace(const Scene& scene, const PathTraceOptions& opt,
                const PathTraceCallbacks& callbacks = {}, PathTraceStatus* status = nullptr);

// One image a run wrote: a snapshot or the final image, with the run's state when it was taken.
struct PathTraceImageRecord {
  std::string path;
  PathTraceStatus status;
};

// The run record (the path tracer's provenance; EXR files carry none) as a JSON object:
//   {"tool", "version", "git_hash", "seed", "command_line", "wall_time_s",
//    "parameters": {name: value, ...}, "inputs": [{"role", "path", "sha256", "format",
//    "scene_id"}, ...], "images": [{"path", "samples", "target", "seconds", "paths", "rays",
//    "nonfinite", "timed_out"}, ...]}
// `images` in the order written, so (samples, seconds) pairs chart convergence against time.
std::string pathtrace_record_json(const Provenance& prov,
                                  const std::vector<PathTraceImageRecord>& images);
// Writes it to `path` atomically ("<path>.tmp.<pid>", then rename); InputError if it cannot.
void write_pathtrace_record(const std::string& path, const Provenance& prov,
                            const std::vector<PathTraceImageRecord>& images);

// The random stream slot of the path tracer: sample s uses pass slot kPathStream + s of rng.h
// (the eye pass uses 0xE7E0000, photon passes 0, 1, 2, ...).
constexpr uint32_t kPathStream = 0x9A700000u;

}  // namespace pf
