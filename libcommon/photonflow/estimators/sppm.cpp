// SPPM and probabilistic PPM: see sppm.h.
#include "photonflow/estimators/sppm.h"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "photonflow/foundations/error.h"
#include "photonflow/foundations/options.h"
#include "photonflow/estimators/pass_sums.h"
#include "photonflow/estimators/ppm.h"
#include "photonflow/sampling/sampling.h"
#include "photonflow/geometry/surface.h"
#include "photonflow/foundations/threads.h"

namespace pf {

const char* estimator_name(Estimator e) {
  switch (e) {
    case Estimator::Ppm: return "ppm";
    case Estimator::Sppm: return "sppm";
    case Estimator::Pppm: return "pppm";
  }
  return "?";
}

Estimator parse_estimator(const std::string& name) {
  require_choice("estimator", name, {"ppm", "sppm", "pppm"});
  return name == "ppm" ? Estimator::Ppm : name == "sppm" ? Estimator::Sppm : Estimator::Pppm;
}

bool is_sppm_state(const HitpointSet& h) { return h.estimator == "sppm"; }

HitpointSet make_sppm_state(const Scene& scene, float radius0, DirectMode mode) {
  HitpointSet h;
  h.width = scene.camera.width;
  h.height = scene.camera.height;
  h.direct_mode = mode;
  h.radius0 = radius0;
  h.estimator = "sppm";
  h.scene_id = scene.scene_id;
  const size_t n = size_t(h.width) * size_t(h.height);
  h.emitted.assign(n * 3, 0.f);
  h.direct.assign(n * 3, 0.f);
  h.hitpoints.resize(n);
  for (size_t i = 0; i < n; ++i) {
    pf_hitpoint hp{};
    hp.weight[0] = hp.weight[1] = hp.weight[2] = 1.f;  // β is inside τ (sppm.h)
    hp.radius = radius0;
    hp.pixel_x = int(i % size_t(h.width));
    hp.pixel_y = int(i / size_t(h.width));
    hp.mesh = -1;  // no visible point yet
    hp.material = -1;
    h.hitpoints[i] = hp;
  }
  // A PBR scene's state keeps each pixel's last visible point's BSDF beside its hitpoint (what
  // the file shows of the pass, as the geometry; the gather reads the pass's own).
  if (scene.has_pbr()) h.bsdf.assign(n, pf_pbr_point{});
  return h;
}

namespace {


// Pixel index of a visible point (check_visible_pixels checked it) in an image `width` wide.
inline size_t pixel_of(const pf_hitpoint& v, int width) {
  return size_t(v.pixel_y) * size_t(width) + size_t(v.pixel_x);
}

// InputError unless every visible point of `eye` lies in a width × height image (the state's);
// with one_per_pixel, also unless they come in strictly increasing pixel order (SPPM keeps one
// per pixel, and the eye pass lists them in pixel order).
void check_visible_pixels(const EyePassResult& eye, int width, int height, bool one_per_pixel) {
  if (eye.width != width || eye.height != height)
    throw input_error("", "the eye pass is " + std::to_string(eye.width) + "x" +
                              std::to_string(eye.height) + ", the state " + std::to_string(width) +
                              "x" + std::to_string(height));
  size_t last = 0;
  for (size_t i = 0; i < eye.hitpoints.size(); ++i) {
    const pf_hitpoint& v = eye.hitpoints[i];
    if (v.pixel_x < 0 || v.pixel_x >= width || v.pixel_y < 0 || v.pixel_y >= height)
      throw input_error("", "visible point " + std::to_string(i) + " lies outside the image");
    const size_t px = pixel_of(v, width);
    if (one_per_pixel && i > 0 && px <= last)
      throw input_error("", "SPPM takes one eye sample per pixel and pass",
                        "use --spp 1 (every pass traces a new sample)");
    last = px;
  }
}

// A pixel's hitpoint in the state takes the geometry of its pass's visible point (what the file
// shows of the pass; the gather reads the visible point itself).
inline void take_visible_point(pf_hitpoint& s, const pf_hitpoint& v) {
  for (int c = 0; c < 3; ++c) {
    s.position[c] = v.position[c];
    s.normal[c] = v.normal[c];
    s.dir[c] = v.dir[c];
  }
  s.mesh = v.mesh;
  s.material = v.material;
}

// take_visible_point for pixel px of `state`, with the visible point's BSDF (pbr, nullptr at a
// diffuse one) into the state's table; the table is made when a PBR point first needs it.
inline void take_visible_point(HitpointSet& state, size_t px, const pf_hitpoint& v,
                               const pf_pbr_point* pbr) {
  take_visible_point(state.hitpoints[px], v);
  if (state.bsdf.empty()) {
    if (!pbr) return;
    state.bsdf.assign(state.hitpoints.size(), pf_pbr_point{});
  }
  state.bsdf[px] = pbr ? *pbr : pf_pbr_point{};
}

// The BSDF of visible point i of an eye pass (pbr_of), nullptr for a diffuse one; `pbr`: the
// scene has a PBR material (Scene::has_pbr, asked once per pass).
inline const pf_pbr_point* eye_pbr(bool pbr, const Scene& scene, const EyePassResult& eye,
                                   size_t i) {
  return pbr ? pbr_of(scene, eye.hitpoints[i], eye.bsdf, i) : nullptr;
}

// The running mean of a layer's value over k passes, L̄_k = L̄_{k−1} + (L_d,k − L̄_{k−1}) · (1/k),
// value by value (any thread count gives the same bits).
inline void running_mean(float& mean, float value, float inv_k) { mean += (value - mean) * inv_k; }

// The pass is counted with its `emitted` photons.
void count_pass(HitpointSet& state, uint64_t emitted) {
  state.passes += 1;
  state.photons_emitted += emitted;
  state.estimator = "sppm";
}

// The emitted and direct layers take the eye pass's into their running mean; count_pass.
void average_layers(HitpointSet& state, const EyePassResult& eye, uint64_t emitted, int threads) {
  const float inv_k = 1.f / float(state.passes + 1);
  const int64_t n = int64_t(state.emitted.size());
  float* const e = state.emitted.data();
  float* const d = state.direct.data();
  const float* const pe = eye.emitted.data();
  const float* const pd = eye.direct.data();
#pragma omp parallel for schedule(static) num_threads(worker_threads(threads))
  for (int64_t j = 0; j < n; ++j) {
    running_mean(e[j], pe[j], inv_k);
    running_mean(d[j], pd[j], inv_k);
  }
  count_pass(state, emitted);
}

// One visible point v of pixel state s: the pass's photons around it, β-weighted into τ_M
// (HJ09 eq. 11), then thesis eq. 3.14, 3.16, 3.18, and s takes v's geometry.
// At a PBR visible point (pbr) the sum is Σ f(x_i, ω_o, ω_p) Φ_p (HJ09 eq. 10–11, illuminate.h).
inline void gather_visible_point(const Scene& scene, const PhotonGrid& grid, const pf_hitpoint& v,
                                 const pf_pbr_point* pbr, HitpointSet& state, size_t px,
                                 bool skip_direct, const PpmOptions& opt) {
  pf_hitpoint& s = state.hitpoints[px];
  float tau_m[3];
  const int m = gather_site(scene, grid, v, s.radius, skip_direct, opt.slab, tau_m, pbr);
  float w[3];  // β_i, times πR²/A with --gather-area surface (gather_area.h eq. 3)
  gather_weight(scene, opt, v, s.radius, pbr, w);
  for (int c = 0; c < 3; ++c) tau_m[c] *= w[c];  // τ_M = β_i Σ f_r Φ_p (HJ09 eq. 11)
  pf_ppm_update(&s, m, tau_m, opt.alpha);              // thesis eq. 3.14, 3.16, 3.18
  take_visible_point(state, px, v, pbr);
}

}  // namespace

void sppm_pass(const Scene& scene, HitpointSet& state, const EyePassResult& eye,
               const PhotonGrid& grid, uint64_t emitted, const PpmOptions& opt) {
  check_alpha(opt.alpha);
  check_slab(opt.slab);
  check_visible_pixels(eye, state.width, state.height, true);
  if (state.hitpoints.size() != size_t(state.width) * size_t(state.height))
    throw input_error("", "the SPPM state does not hold one hitpoint per pixel");
  const bool skip_direct = state.direct_mode == DirectMode::ShadowRays;
  const int64_t count = int64_t(eye.hitpoints.size());
  const bool pbr = scene.has_pbr();
  require_bsdf_table(scene, eye.hitpoints, eye.bsdf);  // not in the workers: no exceptions there
  if (state.bsdf.empty() && pbr)  // made here, not by the workers
    state.bsdf.assign(state.hitpoints.size(), pf_pbr_point{});
#pragma omp parallel for schedule(dynamic, 256) num_threads(worker_threads(opt.threads))
  for (int64_t i = 0; i < count; ++i) {
    const pf_hitpoint& v = eye.hitpoints[size_t(i)];
    gather_visible_point(scene, grid, v, eye_pbr(pbr, scene, eye, size_t(i)), state,
                         pixel_of(v, state.width), skip_direct, opt);
  }
  average_layers(state, eye, emitted, opt.threads);
}

void sppm_pass_traced(const Scene& scene, HitpointSet& state, const EyePassOptions& eye,
                      const PhotonGrid& grid, uint64_t emitted, const PpmOptions& opt) {
  check_alpha(opt.alpha);
  check_slab(opt.slab);
  const int W = state.width, H = state.height;
  if (W != scene.camera.width || H != scene.camera.height || eye.spp != 1 ||
      eye.pass != uint32_t(state.passes) || eye.direct != state.direct_mode)
    throw std::invalid_argument("sppm_pass_traced: the eye pass does not fit the state");
  if (state.hitpoints.size() != size_t(W) * size_t(H))
    throw input_error("", "the SPPM state does not hold one hitpoint per pixel");
  const EyeTracer tracer(scene, eye);
  const bool skip_direct = state.direct_mode == DirectMode::ShadowRays;
  const float inv_k = 1.f / float(state.passes + 1);
  const bool pbr_scene = scene.has_pbr();
  if (pbr_scene && state.bsdf.empty()) state.bsdf.assign(state.hitpoints.size(), pf_pbr_point{});
#pragma omp parallel for schedule(dynamic, 4) num_threads(worker_threads(opt.threads))
  for (int y = 0; y < H; ++y) {
    for (int x = 0; x < W; ++x) {
      const size_t px = size_t(y) * size_t(W) + size_t(x);
      pf_hitpoint v;
      pf_pbr_point pt;
      Vec3 e, d;
      if (tracer.sample(x, y, 0, v, e, d, pbr_scene ? &pt : nullptr)) {
        const bool on_pbr = pbr_scene && scene.materials[size_t(v.material)].type == PF_MAT_PBR;
        gather_visible_point(scene, grid, v, on_pbr ? &pt : nullptr, state, px, skip_direct,
                             opt);
      }
      e = tracer.emitted_layer(x, y, e);  // with the pixel's emission samples (eye_pass.h)
      for (int c = 0; c < 3; ++c) {
        running_mean(state.emitted[px * 3 + size_t(c)], e[c], inv_k);
        running_mean(state.direct[px * 3 + size_t(c)], d[c], inv_k);
      }
    }
  }
  count_pass(state, emitted);
}

void sppm_sites(const Scene& scene, const HitpointSet& state, const EyePassResult& eye,
                const PpmOptions& opt, std::vector<pf_hitpoint>& sites, std::vector<float>& beta) {
  check_visible_pixels(eye, state.width, state.height, true);
  const size_t n = size_t(state.width) * size_t(state.height);
  if (state.hitpoints.size() != n)
    throw input_error("", "the SPPM state does not hold one hitpoint per pixel");
  const bool pbr = scene.has_pbr();
  if (opt.gather_area == GatherArea::Surface) require_bsdf_table(scene, eye.hitpoints, eye.bsdf);
  pf_hitpoint none{};
  none.mesh = none.material = -1;
  sites.assign(n, none);
  beta.assign(n * 3, 0.f);
  for (size_t i = 0; i < eye.hitpoints.size(); ++i) {
    const pf_hitpoint& v = eye.hitpoints[i];
    const size_t px = pixel_of(v, state.width);
    sites[px] = v;
    // β, times πR²/A at the pixel's radius with --gather-area surface (gather_visible_point's)
    gather_weight(scene, opt, v, state.hitpoints[px].radius, eye_pbr(pbr, scene, eye, i),
                  &beta[px * 3]);
  }
}

void sppm_finish_pass(HitpointSet& state, const EyePassResult& eye, uint64_t emitted) {
  for (size_t i = 0; i < eye.hitpoints.size(); ++i) {  // check_visible_pixels checked the pixels
    const pf_hitpoint& v = eye.hitpoints[i];
    const pf_pbr_point* pbr = i < eye.bsdf.size() ? &eye.bsdf[i] : nullptr;
    if (pbr && !(pbr->params.ior >= 1.f)) pbr = nullptr;  // an all-zero (diffuse) entry
    take_visible_point(state, pixel_of(v, state.width), v, pbr);
  }
  average_layers(state, eye, emitted, 0);
}

float parse_slab(const std::string& text, bool new_eye_pass) {
  if (text == "auto") return new_eye_pass ? kDefaultSlab : 0.f;
  float v = 0.f;
  try {
    size_t used = 0;
    v = std::stof(text, &used);
    if (used != text.size()) throw std::invalid_argument(text);
  } catch (const std::exception&) {
    throw input_error("", "--slab must be auto or a number, got '" + text + "'");
  }
  check_slab(v);
  if (!new_eye_pass) require_sphere(v);
  return v;
}

namespace {
// g(n) = ln Γ(n + α) − ln Γ(n + 1) by Stirling's series (ln Γ(z) = (z − ½) ln z − z + ½ ln 2π
// + 1/(12z) − 1/(360z³) + 1/(1260z⁵) − …, Abramowitz & Stegun 6.1.41), with the two large
// (z − ½) ln z terms combined before they are evaluated: (n + α − ½) ln(n + α) − (n + ½) ln(n + 1)
// = (n + α − ½)·log1p((α − 1)/(n + 1)) + (α − 1)·ln(n + 1), so nothing of order n ln n cancels.
// For n >= kPppmLoopPasses the series' remainder is below 1e-26 and g is good to a few ulps.
double log_gamma_ratio(double n, double alpha) {
  const double a = n + alpha, b = n + 1.0;
  const double series = (1.0 / a - 1.0 / b) / 12.0 - (1.0 / (a * a * a) - 1.0 / (b * b * b)) / 360.0 +
                        (1.0 / (a * a * a * a * a) - 1.0 / (b * b * b * b * b)) / 1260.0;
  return (a - 0.5) * std::log1p((alpha - 1.0) / b) + (alpha - 1.0) * std::log(b) - (alpha - 1.0) +
         series;
}
}  // namespace

double pppm_radius(double r1, double alpha, int pass) {
  // r_i² = r1² Π_{j=1}^{i−1} (j + α)/(j + 1) (KZ11 eq. 19 unrolled), i = pass + 1. Up to pass
  // kPppmLoopPasses the product itself, multiplied in this order (the bits every earlier file
  // was made with); beyond, the product up to there times the rest in closed form,
  // Π_{j=K+1}^{i−1} (j + α)/(j + 1) = Γ(i + α) Γ(K + 2) / (Γ(K + 1 + α) Γ(i + 1))
  // = exp(g(i) − g(K + 1)): a pass near 2^31 costs what pass K does, not 2^31 multiplications.
  const int loop = std::min(pass, kPppmLoopPasses);
  double r2 = r1 * r1;
  for (int j = 1; j <= loop; ++j) r2 *= (double(j) + alpha) / (double(j) + 1.0);
  if (pass > loop)
    r2 *= std::exp(log_gamma_ratio(double(pass) + 1.0, alpha) -
                   log_gamma_ratio(double(loop) + 1.0, alpha));
  return std::sqrt(r2);
}

float pppm_pass_radius(const PassSums& sums) {
  return float(pppm_radius(sums.radius1, sums.alpha, sums.end_pass()));
}

void pppm_pass(const Scene& scene, PassSums& sums, const EyePassResult& eye,
               const PhotonGrid& grid, uint64_t emitted, const PpmOptions& opt) {
  check_alpha(sums.alpha);
  check_slab(opt.slab);
  const float r = pppm_pass_radius(sums);
  const bool skip = sums.direct_mode == DirectMode::ShadowRays;
  const int64_t count = int64_t(eye.hitpoints.size());
  const bool pbr = scene.has_pbr();
  require_bsdf_table(scene, eye.hitpoints, eye.bsdf);  // not in the workers: no exceptions there
  // The calling thread's buffer, kept from pass to pass (no allocation per pass); the workers
  // write it through `out` (a thread_local named inside the region would be each worker's own).
  thread_local std::vector<float> tau_beta;
  tau_beta.assign(size_t(count) * 3, 0.f);
  float* const out = tau_beta.data();
  if (emitted > 0) {
#pragma omp parallel for schedule(dynamic, 256) num_threads(worker_threads(opt.threads))
    for (int64_t i = 0; i < count; ++i) {
      const pf_hitpoint& v = eye.hitpoints[size_t(i)];
      float tau_m[3], w[3];
      const pf_pbr_point* at = eye_pbr(pbr, scene, eye, size_t(i));
      gather_site(scene, grid, v, r, skip, opt.slab, tau_m, at);
      gather_weight(scene, opt, v, r, at, w);
      for (int c = 0; c < 3; ++c) out[size_t(i) * 3 + size_t(c)] = tau_m[c] * w[c];
    }
  }
  pppm_accumulate(sums, eye, tau_beta, emitted);
}

void pppm_pass_traced(const Scene& scene, PassSums& sums, const EyePassOptions& eye,
                      const PhotonGrid& grid, uint64_t emitted, const PpmOptions& opt) {
  check_alpha(sums.alpha);
  check_slab(opt.slab);
  const int W = sums.width, H = sums.height;
  if (W != scene.camera.width || H != scene.camera.height ||
      eye.pass != uint32_t(sums.end_pass()) || eye.direct != sums.direct_mode)
    throw std::invalid_argument("pppm_pass_traced: the eye pass does not fit the sums");
  const EyeTracer tracer(scene, eye);
  const float r = pppm_pass_radius(sums);
  const bool pbr_scene = scene.has_pbr();
  const bool skip = sums.direct_mode == DirectMode::ShadowRays;
  // β Σ f_r Φ / (π r_i² N_p) of a visible point (pppm_accumulate's).
  const double norm = emitted > 0 ? 1.0 / (double(kPi) * double(r) * double(r) * double(emitted))
                                  : 0.0;
#pragma omp parallel for schedule(dynamic, 4) num_threads(worker_threads(opt.threads))
  for (int y = 0; y < H; ++y) {
    thread_local std::vector<float> tau_beta;  // β·τ_M of the pixel's visible samples, in order
    tau_beta.resize(size_t(tracer.max_samples()) * 3);
    for (int x = 0; x < W; ++x) {
      const size_t px = size_t(y) * size_t(W) + size_t(x);
      Vec3 e, d;
      int visible = 0;
      const int spp = tracer.samples(x, y);
      for (int s = 0; s < spp; ++s) {
        pf_hitpoint v;
        pf_pbr_point pt;
        if (!tracer.sample(x, y, s, v, e, d, pbr_scene ? &pt : nullptr)) continue;
        const bool on_pbr = pbr_scene && scene.materials[size_t(v.material)].type == PF_MAT_PBR;
        float tau_m[3] = {0.f, 0.f, 0.f}, w[3] = {0.f, 0.f, 0.f};
        if (emitted > 0) {
          gather_site(scene, grid, v, r, skip, opt.slab, tau_m, on_pbr ? &pt : nullptr);
          gather_weight(scene, opt, v, r, on_pbr ? &pt : nullptr, w);
        }
        for (int c = 0; c < 3; ++c) tau_beta[size_t(visible) * 3 + size_t(c)] = tau_m[c] * w[c];
        ++visible;
      }
      e = tracer.emitted_layer(x, y, e);  // with the pixel's emission samples (eye_pass.h)
      double* sum = &sums.sum[px * 3];
      for (int c = 0; c < 3; ++c) sum[c] += double(e[c]) + double(d[c]);  // L_d,i
      if (emitted == 0) continue;
      for (int k = 0; k < visible; ++k)
        for (int c = 0; c < 3; ++c) sum[c] += double(tau_beta[size_t(k) * 3 + size_t(c)]) * norm;
    }
  }
  sums.passes += 1;
  sums.photons_emitted += emitted;
}

void pppm_accumulate(PassSums& sums, const EyePassResult& eye, const std::vector<float>& tau_beta,
                     uint64_t emitted) {
  check_alpha(sums.alpha);
  check_visible_pixels(eye, sums.width, sums.height, false);
  if (tau_beta.size() != eye.hitpoints.size() * 3)
    throw std::invalid_argument("pppm_accumulate: one β·τ_M per visible point");
  const float r = pppm_pass_radius(sums);
  // L_d,i: light the eye paths saw directly.
  for (size_t j = 0; j < sums.sum.size(); ++j)
    sums.sum[j] += double(eye.emitted[j]) + double(eye.direct[j]);
  if (emitted > 0) {
    // β Σ f_r Φ / (π r_i² N_p) of every visible point, added to its pixel in order (several
    // samples of a pixel may share it).
    const double norm = 1.0 / (double(kPi) * double(r) * double(r) * double(emitted));
    for (size_t i = 0; i < eye.hitpoints.size(); ++i) {
      const size_t px = pixel_of(eye.hitpoints[i], sums.width);
      for (int c = 0; c < 3; ++c)
        sums.sum[px * 3 + size_t(c)] += double(tau_beta[i * 3 + size_t(c)]) * norm;
    }
  }
  sums.passes += 1;
  sums.photons_emitted += emitted;
}

namespace {

// Eye pass p of a trace-hitpoints file, checked against photon pass p of `photons`.
EyePassResult staged_eye_pass(const HitpointSet& eye, const std::string& eye_path, int pass,
                              DirectMode mode, const PhotonSet& photons,
                              const std::string& photons_path) {
  if (eye.estimator != "none")
    throw input_error(eye_path, "is a hitpoint state, not an eye pass",
                      "give trace-hitpoints --estimator sppm|pppm --pass " + std::to_string(pass));
  if (eye.eye_pass != pass)
    throw input_error(eye_path, "is eye pass " + std::to_string(eye.eye_pass) + ", the state needs pass " +
                                    std::to_string(pass),
                      "trace it with --pass " + std::to_string(pass));
  if (eye.direct_mode != mode)
    throw input_error(eye_path, std::string("was traced with --direct ") +
                                    direct_mode_name(eye.direct_mode) + ", the state has " +
                                    direct_mode_name(mode));
  if (photons.first_pass != pass || photons.pass_count() != 1)
    throw input_error(photons_path, "holds passes " + std::to_string(photons.first_pass) + " … " +
                                        std::to_string(photons.first_pass + photons.pass_count() - 1) +
                                        ", this step needs pass " + std::to_string(pass) + " alone",
                      "trace it with --first-pass " + std::to_string(pass) + " --passes 1");
  EyePassResult r;
  r.hitpoints = eye.hitpoints;
  r.bsdf = eye.bsdf;
  r.emitted = eye.emitted;
  r.direct = eye.direct;
  r.radius = eye.radius0;
  r.width = eye.width;
  r.height = eye.height;
  return r;
}

PhotonGrid staged_grid(const Scene& scene, const PhotonSet& photons, float radius0,
                       const PpmOptions& opt) {
  PhotonGridParams gp;
  gp.max_bins = opt.max_bins;
  gp.default_radius = radius0;
  return build_photon_grid(photons.photons, int(scene.mesh_names.size()), gp);
}

}  // namespace

void sppm_stage(const Scene& scene, HitpointSet& state, const HitpointSet& eye,
                const std::string& eye_path, const PhotonSet& photons,
                const std::string& photons_path, const PpmOptions& opt) {
  const EyePassResult r =
      staged_eye_pass(eye, eye_path, state.passes, state.direct_mode, photons, photons_path);
  sppm_pass(scene, state, r, staged_grid(scene, photons, state.radius0, opt),
            photons.pass_emitted[0], opt);
}

void pppm_stage(const Scene& scene, PassSums& sums, const HitpointSet& eye,
                const std::string& eye_path, const PhotonSet& photons,
                const std::string& photons_path, const PpmOptions& opt) {
  const EyePassResult r =
      staged_eye_pass(eye, eye_path, sums.end_pass(), sums.direct_mode, photons, photons_path);
  pppm_pass(scene, sums, r, staged_grid(scene, photons, sums.radius1, opt),
            photons.pass_emitted[0], opt);
}

}  // namespace pf
