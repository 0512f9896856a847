// Progressive render driver: see render_driver.h.
#include "photonflow/estimators/render_driver.h"

#include <unistd.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <optional>
#include <set>

#include "photonflow/opencl/cl_backend.h"
#include "photonflow/foundations/options.h"
#include "photonflow/foundations/text_file.h"
#include "photonflow/io/validate.h"

namespace pf {

namespace {
EyePassResult eye_pass(const Scene& scene, const EyePassOptions& eye, ClContext* device) {
  return device ? trace_hitpoints(scene, eye, *device) : trace_hitpoints(scene, eye);
}

float initial_radius(const Scene& scene, const EyePassOptions& eye) {
  return eye.radius > 0.f ? eye.radius : default_radius(scene);
}

// The pixels with emission samples, computed once for all the run's eye passes (eye_pass.h),
// PPM's first one included: returns them, and opt.eye points at them (null where none are needed
// or the caller gave its own).
std::shared_ptr<const std::vector<uint8_t>> keep_emission_pixels(const Scene& scene,
                                                                 RenderOptions& opt) {
  if (opt.eye.emission_spp <= 0 || opt.eye.emission_pixels) return nullptr;
  auto marks = std::make_shared<const std::vector<uint8_t>>(emission_pixels(scene));
  opt.eye.emission_pixels = marks.get();
  return marks;
}

// The pixels with glossy samples, likewise once for all of a pppm run's eye passes.
std::shared_ptr<const std::vector<uint8_t>> keep_glossy_pixels(const Scene& scene,
                                                               RenderOptions& opt) {
  if (opt.eye.glossy_spp <= 0 || opt.eye.glossy != GlossyMerge::Mis || opt.eye.glossy_pixels ||
      !scene.has_pbr())
    return nullptr;
  auto marks = std::make_shared<const std::vector<uint8_t>>(glossy_pixels(scene));
  opt.eye.glossy_pixels = marks.get();
  return marks;
}

HitpointSet fresh_state(const Scene& scene, const RenderOptions& opt) {
  if (opt.estimator == Estimator::Sppm)
    return make_sppm_state(scene, initial_radius(scene, opt.eye), opt.eye.direct);
  return make_hitpoint_set(eye_pass(scene, opt.eye, opt.device), opt.eye.direct, scene.scene_id);
}
}  // namespace

uint64_t trace_photon_pass(const Scene& scene, const RenderOptions& opt, uint32_t pass,
                           float radius0, PhotonBuffers& chunks, PhotonGrid& grid, size_t& stored,
                           const VisibleSet* visible, PhotonGuideStats* stats) {
  PhotonGridParams gp;
  gp.max_bins = opt.ppm.max_bins;
  gp.default_radius = radius0;  // the smallest bin size, as ppm_grid_params
  const uint64_t emitted = trace_photons_into(scene, pass, opt.photons, chunks, visible, stats);
  stored = chunks.size();
  const std::vector<PhotonSpan> spans = chunks.spans();
  build_photon_grid_into(grid, spans.data(), spans.size(), int(scene.mesh_names.size()), gp,
                         opt.ppm.threads);
  return emitted;
}

namespace {
// The pass's visible points for --photon-guide visibility (photon_guide.h), each with the radius
// its gather uses: an SPPM pixel's own R (`state`, one hitpoint per pixel), a PPPM pass's r_i
// (`radius`), PPM's fixed hitpoints their own R.
void sppm_visible(const EyePassResult& eye, const HitpointSet& state, VisibleSet& out) {
  std::vector<float> r(eye.hitpoints.size());
  for (size_t i = 0; i < r.size(); ++i) {
    const pf_hitpoint& v = eye.hitpoints[i];
    r[i] = state.hitpoints[size_t(v.pixel_y) * size_t(state.width) + size_t(v.pixel_x)].radius;
  }
  out.build(eye.hitpoints, r, eye.bsdf, state.direct_mode == DirectMode::ShadowRays);
}
bool guided(const RenderOptions& opt) { return opt.photons.guide == PhotonGuide::Visibility; }
}  // namespace

// Both constructors check the state's ids against the scene once; a pass never changes them, so
// the CPU grid gather of every pass skips that check (ppm_pass_grid_prechecked).
ProgressiveRenderer::ProgressiveRenderer(const Scene& scene, const RenderOptions& opt)
    : scene_(scene),
      opt_(opt),
      emission_marks_(keep_emission_pixels(scene, opt_)),
      state_(fresh_state(scene, opt_)) {
  check_against_scene("", state_, scene_);
}

ProgressiveRenderer::ProgressiveRenderer(const Scene& scene, const RenderOptions& opt,
                                         HitpointSet state, const std::string& path)
    : scene_(scene),
      opt_(opt),
      emission_marks_(keep_emission_pixels(scene, opt_)),
      state_(std::move(state)) {
  check_against_scene(path, state_, scene_);
  if (is_sppm_state(state_) &&
      state_.hitpoints.size() != size_t(state_.width) * size_t(state_.height))
    throw input_error(path, "is an SPPM state without one hitpoint per pixel",
                      "the file is damaged; start without --resume");
}

void ProgressiveRenderer::run_iteration() {
  if (opt_.estimator == Estimator::Sppm && opt_.device) {
    // OpenCL: eye pass and photons traced on the device, the photons never leave it, and the
    // pixels' R, N, τ stay there between passes (DevicePpmState::sppm_pass).
    EyePassOptions eo = opt_.eye;
    eo.pass = uint32_t(state_.passes);
    const EyePassResult eye = trace_hitpoints(scene_, eo, *opt_.device);
    if (!device_state_) device_state_ = std::make_unique<DevicePpmState>(scene_, state_, *opt_.device);
    const ClWaitScope no_wait(*opt_.device, false);
    const DevicePhotons pass =
        trace_photons_device(scene_, uint32_t(state_.passes), opt_.photons, *opt_.device);
    photons_stored_ += pass.count;
    device_state_->sppm_pass(eye, pass, opt_.ppm);
    return;
  }
  if (opt_.estimator == Estimator::Sppm && guided(opt_)) {
    // Photons where the camera looks: the eye pass first, its visible points (each at its
    // pixel's R) guide the photons, then the gather (sppm_pass: the bits of sppm_pass_traced).
    size_t stored = 0;
    const uint32_t pass = uint32_t(state_.passes);
    EyePassOptions eo = opt_.eye;
    eo.pass = pass;
    trace_hitpoints_into(scene_, eo, eye_, eye_work_);
    sppm_visible(eye_, state_, visible_);
    PhotonGuideStats gs;
    const uint64_t emitted = trace_photon_pass(scene_, opt_, pass, state_.radius0, photon_chunks_,
                                               grid_, stored, &visible_, &gs);
    guide_.add(gs);
    photons_stored_ += stored;
    sppm_pass(scene_, state_, eye_, grid_, emitted, opt_.ppm);
    return;
  }
  if (opt_.estimator == Estimator::Sppm) {  // the pass's photons, then a new eye pass gathering
    size_t stored = 0;
    const uint32_t pass = uint32_t(state_.passes);
    const uint64_t emitted =
        trace_photon_pass(scene_, opt_, pass, state_.radius0, photon_chunks_, grid_, stored);
    photons_stored_ += stored;
    EyePassOptions eo = opt_.eye;
    eo.pass = pass;
    sppm_pass_traced(scene_, state_, eo, grid_, emitted, opt_.ppm);
    return;
  }
  if (opt_.device) {  // OpenCL backend: device photon tracing and opt.ppm.method's gather
    if (gather_method_info(opt_.ppm.method).clusters && !opt_.ppm.clusters) {
      clusters_ = std::make_unique<ClusterSet>(
          clusters_for_method(opt_.ppm.method, state_, opt_.device->work_group(), opt_.ppm));
      opt_.ppm.clusters = clusters_.get();
    }
    if (!device_state_) device_state_ = std::make_unique<DevicePpmState>(scene_, state_, *opt_.device);
    if (opt_.ppm.method == GatherMethod::HashGrid) {  // the photons never leave the device
      // and the host waits only where it reads (photon count, next radius): no round trip per kernel
      const ClWaitScope no_wait(*opt_.device, false);
      const DevicePhotons pass =
          trace_photons_device(scene_, uint32_t(state_.passes), opt_.photons, *opt_.device);
      photons_stored_ += pass.count;
      device_state_->pass(pass, opt_.ppm);
      return;
    }
    // Other methods read host photons (naive batches them past the allocation limit).
    PhotonPassResult pass =
        trace_photons(scene_, uint32_t(state_.passes), opt_.photons, *opt_.device);
    photons_stored_ += pass.photons.size();
    device_state_->pass(pass.photons, pass.emitted, opt_.ppm);
    return;
  }
  // The same photons and the same gather as trace_photons + ppm_pass, without the copies: the
  // grid is sorted straight out of the per-chunk buffers, and every buffer is reused.
  PhotonGuideStats gs;
  if (guided(opt_)) visible_at_own_radius(state_, visible_);  // R shrinks pass by pass
  const uint64_t emitted =
      trace_photons_into(scene_, uint32_t(state_.passes), opt_.photons, photon_chunks_,
                         guided(opt_) ? &visible_ : nullptr, &gs);
  guide_.add(gs);
  photons_stored_ += photon_chunks_.size();
  if (opt_.ppm.method == GatherMethod::Grid) {
    const std::vector<PhotonSpan> spans = photon_chunks_.spans();
    build_photon_grid_into(grid_, spans.data(), spans.size(), int(scene_.mesh_names.size()),
                           ppm_grid_params(state_, opt_.ppm), opt_.ppm.threads);
    ppm_pass_grid_prechecked(scene_, state_, grid_, emitted, opt_.ppm);
  } else {
    photon_chunks_.concatenate(photons_);
    ppm_pass(scene_, state_, photons_, emitted, opt_.ppm);
  }
}

PppmRenderer::PppmRenderer(const Scene& scene, const RenderOptions& opt)
    : scene_(scene),
      opt_(opt),
      emission_marks_(keep_emission_pixels(scene, opt_)),
      glossy_marks_(keep_glossy_pixels(scene, opt_)),
      sums_(make_pass_sums(scene.camera.width, scene.camera.height, opt.first_pass,
                           initial_radius(scene, opt.eye), opt.ppm.alpha, opt.eye.direct,
                           scene.scene_id, state_parameters(opt))) {}

PppmRenderer::PppmRenderer(const Scene& scene, const RenderOptions& opt, PassSums sums,
                           const std::string& path)
    : scene_(scene),
      opt_(opt),
      emission_marks_(keep_emission_pixels(scene, opt_)),
      glossy_marks_(keep_glossy_pixels(scene, opt_)),
      sums_(std::move(sums)) {
  if (sums_.width != scene.camera.width || sums_.height != scene.camera.height)
    throw input_error(path, "is " + std::to_string(sums_.width) + "x" +
                                std::to_string(sums_.height) + ", the scene's camera " +
                                std::to_string(scene.camera.width) + "x" +
                                std::to_string(scene.camera.height));
}

void PppmRenderer::run_iteration() {
  if (opt_.device) {  // eye pass, photons and gather on the device; the sums on the host
    EyePassOptions eo = opt_.eye;
    eo.pass = uint32_t(sums_.end_pass());
    eye_ = trace_hitpoints(scene_, eo, *opt_.device);
    const ClWaitScope no_wait(*opt_.device, false);
    const DevicePhotons pass =
        trace_photons_device(scene_, uint32_t(sums_.end_pass()), opt_.photons, *opt_.device);
    photons_stored_ += pass.count;
    pppm_accumulate(sums_, eye_,
                    pppm_gather_device(scene_, eye_, pppm_pass_radius(sums_), sums_.direct_mode,
                                       pass, opt_.ppm, *opt_.device),
                    pass.emitted);
    return;
  }
  size_t stored = 0;  // the pass's photons, then a new eye pass gathering
  const uint32_t pass = uint32_t(sums_.end_pass());
  if (guided(opt_)) {
    // Photons where the camera looks: the eye pass first, its visible points at r_i guide the
    // photons, then the gather (pppm_pass: the bits of pppm_pass_traced).
    EyePassOptions eo = opt_.eye;
    eo.pass = pass;
    trace_hitpoints_into(scene_, eo, eye_, eye_work_);
    visible_.build(eye_.hitpoints, {pppm_pass_radius(sums_)}, eye_.bsdf,
                   opt_.eye.direct == DirectMode::ShadowRays);
    PhotonGuideStats gs;
    const uint64_t emitted = trace_photon_pass(scene_, opt_, pass, sums_.radius1, photon_chunks_,
                                               grid_, stored, &visible_, &gs);
    guide_.add(gs);
    photons_stored_ += stored;
    pppm_pass(scene_, sums_, eye_, grid_, emitted, opt_.ppm);
    return;
  }
  const uint64_t emitted =
      trace_photon_pass(scene_, opt_, pass, sums_.radius1, photon_chunks_, grid_, stored);
  photons_stored_ += stored;
  EyePassOptions eo = opt_.eye;
  eo.pass = pass;
  pppm_pass_traced(scene_, sums_, eo, grid_, emitted, opt_.ppm);
}

void PppmRenderer::save_state(const std::string& path, const Provenance& prov) const {
  save_pass_sums(sums_, path, prov);
}

void ProgressiveRenderer::save_state(const std::string& path, const Provenance& prov) const {
  save_hitpoints(state(), path, prov);
}

void check_options(const RenderOptions& opt) {
  check_options(opt.eye);
  check_options(opt.photons);
  require_positive("passes", opt.passes);
  require_in_unit_interval("alpha", opt.ppm.alpha);
  check_slab(opt.ppm.slab);
  if (opt.estimator == Estimator::Ppm) require_sphere(opt.ppm.slab);
  if (opt.estimator == Estimator::Ppm && opt.ppm.gather_area == GatherArea::Surface)
    throw input_error("", "--gather-area surface applies to --estimator sppm and pppm",
                      "ppm's fixed hitpoints divide by the disc, the thesis's eq. 3.17");
  require_positive("max-bins", opt.ppm.max_bins);
  if (opt.device && opt.photons.guide == PhotonGuide::Visibility)
    throw input_error("", "--photon-guide visibility traces photons on the CPU only",
                      "drop --device opencl, or use --photon-guide uniform");
  if (!opt.checkpoint.empty()) require_positive("checkpoint-every", opt.checkpoint_every);
  if (opt.snapshot_every < 0) throw input_error("", "--snapshot-every must be >= 0");
  if (!(opt.time_budget >= 0) || !std::isfinite(opt.time_budget))
    throw input_error("", "--time must be a number of seconds >= 0 (0: no budget)");
  if (opt.first_pass < 0) throw input_error("", "--first-pass must be >= 0");
  if (opt.first_pass > 0 && opt.estimator != Estimator::Pppm)
    throw input_error("", "--first-pass applies to --estimator pppm, whose passes are independent",
                      "continue a ppm or sppm run with --checkpoint and --resume");
  if (!pass_indices_fit(opt.first_pass, opt.passes))
    throw input_error("", "--first-pass + --passes runs past pass 2^31-1");
  // A pppm range [first, end) is written with its end, which must be an int32 (pass_sums.h).
  if (opt.estimator == Estimator::Pppm && int64_t(opt.first_pass) + opt.passes > kMaxPassEnd)
    throw input_error("", "--first-pass " + std::to_string(opt.first_pass) + " + --passes " +
                              std::to_string(opt.passes) + " ends past 2^31-1",
                      "a pppm range ends at most at pass 2147483647");
  if (opt.estimator == Estimator::Sppm && opt.eye.spp != 1)
    throw input_error("", "--estimator sppm takes one eye sample per pixel and pass",
                      "drop --spp: every pass traces a new sample in each pixel");
  if (opt.eye.glossy_spp > 0 && opt.estimator != Estimator::Pppm)
    throw input_error("", "--glossy-spp applies to --estimator pppm",
                      "sppm keeps one visible point per pixel and ppm one eye pass");
  for (int p : opt.snapshot_at)
    if (p < 1 || p > opt.passes)
      throw input_error("", "--snapshot-at " + std::to_string(p) +
                                " is not a pass of this run (1.." + std::to_string(opt.passes) + ")",
                        "list passes up to --passes");
}

std::map<std::string, std::string> state_parameters(const RenderOptions& opt) {
  std::map<std::string, std::string> p{{"spp", std::to_string(opt.eye.spp)},
          {"max-depth", std::to_string(opt.eye.max_depth)},
          {"direct", direct_mode_name(opt.eye.direct)},
          {"shadow-samples", std::to_string(opt.eye.shadow_samples)},
          {"radius", default_text(opt.eye.radius)},
          {"seed", opt.eye.seed == opt.photons.seed  // render's one --seed
                       ? std::to_string(opt.eye.seed)
                       : std::to_string(opt.eye.seed) + "/" + std::to_string(opt.photons.seed)},
          {"photons", std::to_string(opt.photons.photons)},
          {"max-bounces", std::to_string(opt.photons.max_bounces)},
          {"alpha", default_text(opt.ppm.alpha)},
          // ppm too: its one eye pass, and so its hitpoints, depend on where the samples went.
          {"pixel-sampler", pixel_sampler_name(opt.eye.sampler)}};
  if (opt.estimator != Estimator::Ppm) {
    p["estimator"] = estimator_name(opt.estimator);
    p["slab"] = default_text(opt.ppm.slab);
    // Only with the surface (states and sums made before the option existed divided by the disc).
    if (opt.ppm.gather_area == GatherArea::Surface) p["gather-area"] = "surface";
  }
  // Only where glossy vertices share their light with the continuation (eye_pass.h GlossyMerge):
  // the states and sums of runs without it, and those written before it existed, keep their
  // parameters.
  if (opt.eye.glossy != GlossyMerge::First) p["glossy-merge"] = glossy_merge_name(opt.eye.glossy);
  // Likewise only where eye passes take emission samples (files made before them have none).
  if (opt.eye.emission_spp > 0) p["emission-spp"] = std::to_string(opt.eye.emission_spp);
  if (opt.eye.glossy_spp > 0) p["glossy-spp"] = std::to_string(opt.eye.glossy_spp);
  // Only for guided photons (photon_guide.h): every file before the option had uniform ones.
  if (opt.photons.guide != PhotonGuide::Uniform)
    p["photon-guide"] = photon_guide_name(opt.photons.guide);
  return p;
}

const char* const kStateParameterPrefix = "state.";

std::optional<std::string> state_parameter_unrecorded_value(const std::string& name) {
  // The options state_parameters leaves out at these values (above): a file without the entry
  // was made with them (or before the option existed, which is the same).
  if (name == "glossy-merge") return std::string("first");
  if (name == "emission-spp") return std::string("0");
  if (name == "glossy-spp") return std::string("0");
  if (name == "gather-area") return std::string("disc");
  if (name == "estimator") return std::string("ppm");  // ppm's record has no estimator
  if (name == "photon-guide") return std::string("uniform");
  return std::nullopt;
}

void require_same_state_parameters(const std::string& file,
                                   const std::map<std::string, std::string>& recorded,
                                   const std::map<std::string, std::string>& run,
                                   const std::string& fresh) {
  if (recorded.empty())
    throw input_error(file, "records none of the options its state was made with (no " +
                                std::string(kStateParameterPrefix) + "* attributes), so it "
                                "cannot be continued safely",
                      fresh);
  // Every name either side records, in order: a new option of state_parameters is checked here
  // without a line more.
  std::set<std::string> names;
  for (const auto& kv : recorded) names.insert(kv.first);
  for (const auto& kv : run) names.insert(kv.first);
  for (const std::string& name : names) {
    const auto in_file = recorded.find(name);
    const auto in_run = run.find(name);
    const std::optional<std::string> unrecorded = state_parameter_unrecorded_value(name);
    const std::string attr = kStateParameterPrefix + name;
    if ((in_file == recorded.end() || in_run == run.end()) && !unrecorded) {
      if (in_run == run.end())
        throw input_error(file, "records " + attr + " = " + in_file->second +
                                    ", a setting this run does not have (made by another "
                                    "version or estimator)",
                          fresh);
      throw input_error(file, "records no " + attr + " (made by another version), so its --" +
                                  name + " is not known",
                        fresh);
    }
    const std::string theirs = in_file != recorded.end() ? in_file->second : *unrecorded;
    const std::string ours = in_run != run.end() ? in_run->second : *unrecorded;
    if (theirs != ours)
      throw input_error(file, "--" + name + " " + ours + " differs from the checkpoint's " +
                                  theirs + " (" + attr + ")",
                        "rerun with --" + name + " " + theirs + ", the checkpoint's, or " + fresh);
  }
}

std::map<std::string, std::string> staged_state_parameters(
    Estimator e, const Provenance& eye, const std::string& eye_path, const Provenance& photons,
    const std::string& photons_path, float alpha, float slab, GatherArea area) {
  auto text = [](const Provenance& p, const std::string& path, const char* name) {
    const auto it = p.parameters.find(name);
    if (it == p.parameters.end())
      throw input_error(path, std::string("records no --") + name + " of the tool that wrote it",
                        "remake it with this version");
    return it->second;
  };
  auto number = [&](const Provenance& p, const std::string& path, const char* name) {
    const std::string t = text(p, path, name);
    try {
      return std::stod(t);
    } catch (const std::exception&) {
      throw input_error(path, std::string("records --") + name + " '" + t + "', not a number");
    }
  };
  RenderOptions o;
  o.estimator = e;
  o.eye.spp = int(number(eye, eye_path, "spp"));
  o.eye.max_depth = int(number(eye, eye_path, "max-depth"));
  o.eye.direct = text(eye, eye_path, "direct") == "shadow-rays" ? DirectMode::ShadowRays
                                                                 : DirectMode::Photons;
  o.eye.shadow_samples = int(number(eye, eye_path, "shadow-samples"));
  o.eye.radius = float(number(eye, eye_path, "radius"));
  o.eye.seed = uint32_t(number(eye, eye_path, "seed"));
  o.eye.sampler = parse_pixel_sampler(text(eye, eye_path, "pixel-sampler"));
  if (eye.parameters.count("glossy-merge"))  // absent from files made before it existed
    o.eye.glossy = parse_glossy_merge(text(eye, eye_path, "glossy-merge"));
  if (eye.parameters.count("emission-spp"))  // absent from files made before it existed
    o.eye.emission_spp = int(number(eye, eye_path, "emission-spp"));
  if (eye.parameters.count("glossy-spp"))  // likewise
    o.eye.glossy_spp = int(number(eye, eye_path, "glossy-spp"));
  o.photons.photons = uint32_t(number(photons, photons_path, "photons"));
  o.photons.max_bounces = int(number(photons, photons_path, "max-bounces"));
  o.photons.seed = uint32_t(number(photons, photons_path, "seed"));
  if (photons.parameters.count("photon-guide"))  // absent from files made before it existed
    o.photons.guide = parse_photon_guide(text(photons, photons_path, "photon-guide"));
  o.ppm.alpha = alpha;
  o.ppm.slab = slab;
  o.ppm.gather_area = area;
  return state_parameters(o);
}

namespace {

// Refuses a checkpoint whose own attributes disagree with this run's options: its direct mode
// (a state of shadow-ray direct light gathering photons that carry direct light would count it
// twice), its initial radius and, for pass sums, α. require_same_state compares the options the
// checkpoint's provenance records; these are the values the state itself holds.
void require_state_agrees(const std::string& checkpoint, const RenderOptions& opt, DirectMode mode,
                          float radius, float radius_run, const char* radius_name) {
  if (mode != opt.eye.direct)
    throw input_error(checkpoint,
                      std::string("holds a state of direct mode ") + direct_mode_name(mode) +
                          ", this run has --direct " + direct_mode_name(opt.eye.direct),
                      "use the checkpoint's --direct or start without --resume");
  if (radius != radius_run)
    throw input_error(checkpoint,
                      std::string("holds a state of ") + radius_name + " " + default_text(radius) +
                          ", this run starts from " + default_text(radius_run),
                      "use the checkpoint's --radius or start without --resume");
}

// Refuses a checkpoint whose recorded state options differ from this run's: one walk of the
// state.* attributes of the file and of the run's own record (require_same_state_parameters).
void require_same_state(const std::string& checkpoint, const RenderOptions& opt) {
  const Provenance made = opt.estimator == Estimator::Pppm ? load_pass_sums_provenance(checkpoint)
                                                           : load_hitpoints_provenance(checkpoint);
  std::map<std::string, std::string> recorded;
  for (const auto& [key, value] : made.parameters)
    if (key.rfind(kStateParameterPrefix, 0) == 0)
      recorded[key.substr(std::strlen(kStateParameterPrefix))] = value;
  require_same_state_parameters(checkpoint, recorded, state_parameters(opt),
                                "start without --resume");
}

}  // namespace

namespace {

// Mean gather radius of a state, for the run record.
double mean_radius(const HitpointSet& h) {
  double sum = 0;
  for (const pf_hitpoint& x : h.hitpoints) sum += double(x.radius);
  return h.hitpoints.empty() ? 0.0 : sum / double(h.hitpoints.size());
}
double mean_radius(const PassSums& s) {  // r_i of the last pass summed
  return s.passes > 0 ? pppm_radius(s.radius1, s.alpha, s.end_pass() - 1) : double(s.radius1);
}

// The pass loop every estimator shares: `r` continues a checkpoint (from_checkpoint) or is made
// by make() on the rendering clock (ppm's eye pass); passes until opt.passes, opt.time_budget or
// an on_pass that says stop; checkpoints every opt.checkpoint_every passes and at the end;
// snapshots; the status.
template <class Renderer, class State, class Make>
State drive(const RenderOptions& opt, std::unique_ptr<Renderer> r, Make&& make,
            const Provenance& checkpoint_prov, const Stopwatch& wall,
            const std::function<bool(int, double)>& on_pass,
            const std::function<void(const State&, const RenderStatus&)>& on_snapshot,
            RenderStatus* status) {
  // The rendering clock (RenderStatus::seconds): starts before the eye pass; the time spent in
  // checkpoints, snapshot callbacks and OpenCL program builds is taken off it.
  Stopwatch clock;
  double aside = 0;
  const double build0 = opt.device ? opt.device->build_seconds() : 0.0;
  RenderStatus st;
  st.target = opt.passes;
  st.resumed = r != nullptr;
  if (!r) r = make();
  auto update_status = [&] {
    st.passes = r->passes_done();
    st.photons_emitted = r->photons_emitted();
    st.photons_stored = r->photons_traced();
    st.guide = r->guide_stats();
    st.build_seconds = opt.device ? opt.device->build_seconds() - build0 : 0.0;
    st.seconds = clock.seconds() - aside - st.build_seconds;
  };
  update_status();
  st.mean_radius = mean_radius(r->state());
  double photons = 0;
  while (r->passes_done() < opt.passes) {
    r->run_iteration();
    photons += double(opt.photons.photons);
    update_status();
    st.budget_reached = opt.time_budget > 0 && st.seconds >= opt.time_budget &&
                        r->passes_done() < opt.passes;
    const bool last = r->passes_done() == opt.passes || st.budget_reached;
    if (last) {  // the last state back from the device, on the clock
      r->state();
      update_status();
    }
    // Time outside the rendering clock; a program built inside (the device synthesis of a first
    // snapshot) is already in build_seconds and is not taken off twice.
    Stopwatch outside;
    const double built_before = opt.device ? opt.device->build_seconds() : 0.0;
    bool saved = false;
    auto save_checkpoint = [&] {
      Provenance at = checkpoint_prov;
      at.wall_time_s += wall.seconds();
      r->save_state(opt.checkpoint, at);
      saved = true;
    };
    if (!opt.checkpoint.empty() && opt.checkpoint_every > 0 &&
        (r->passes_done() % opt.checkpoint_every == 0 || last))
      save_checkpoint();
    const bool snapshot = on_snapshot && snapshot_due(opt, r->passes_done());
    if (snapshot || last) st.mean_radius = mean_radius(r->state());
    if (snapshot) on_snapshot(r->state(), st);
    aside += outside.seconds() - ((opt.device ? opt.device->build_seconds() : 0.0) - built_before);
    if (on_pass && !on_pass(r->passes_done(), photons) && !last) {
      // Asked to stop: the passes so far are kept in the checkpoint, for --resume.
      if (!opt.checkpoint.empty() && !saved) save_checkpoint();
      st.mean_radius = mean_radius(r->state());
      st.stopped = true;
      break;
    }
    if (last) break;
  }
  if (status) *status = st;
  return r->state();
}

// The checkpoint's provenance: the run's, with the options its state depends on.
Provenance with_state_parameters(const Provenance& prov, const RenderOptions& opt) {
  Provenance p = prov;
  for (const auto& [name, value] : state_parameters(opt))
    p.parameters[kStateParameterPrefix + name] = value;
  return p;
}

// Refuses a checkpoint that already holds more passes than the run asks for.
void require_passes_left(const RenderOptions& opt, int passes) {
  if (passes > opt.passes)
    throw input_error(opt.checkpoint,
                      "already has " + std::to_string(passes) + " passes, more than --passes",
                      "raise --passes or start without --resume");
}

// Loads the checkpoint with `load`; a checkpoint of the other kind (pass sums where ppm and sppm
// keep hitpoints, or the other way round) is refused as a changed --estimator, by the record of
// the kind it is (require_same_state_parameters), when that record can be read.
template <class Load>
auto load_checkpoint(const RenderOptions& opt, Load&& load) {
  try {
    return load(opt.checkpoint);
  } catch (const InputError&) {
    std::optional<Provenance> other;
    try {
      other = opt.estimator == Estimator::Pppm ? load_hitpoints_provenance(opt.checkpoint)
                                               : load_pass_sums_provenance(opt.checkpoint);
    } catch (const InputError&) {
    }
    if (!other) throw;
    std::map<std::string, std::string> recorded;
    for (const auto& [key, value] : other->parameters)
      if (key.rfind(kStateParameterPrefix, 0) == 0)
        recorded[key.substr(std::strlen(kStateParameterPrefix))] = value;
    require_same_state_parameters(opt.checkpoint, recorded, state_parameters(opt),
                                  "start without --resume");
    throw;
  }
}

bool checkpoint_exists(const RenderOptions& opt, bool resume) {
  return resume && !opt.checkpoint.empty() && access(opt.checkpoint.c_str(), F_OK) == 0;
}

}  // namespace

HitpointSet render_progressive(
    const Scene& scene, const RenderOptions& opt, bool resume, const Provenance& prov,
    const std::function<bool(int, double)>& on_pass,
    const std::function<void(const HitpointSet&, const RenderStatus&)>& on_snapshot,
    RenderStatus* status) {
  check_options(opt);
  if (opt.estimator == Estimator::Pppm)
    throw std::invalid_argument("render_progressive: the pppm estimator runs in render_pppm");
  // Wall-clock seconds of the run, for the checkpoints' provenance (prov.wall_time_s holds the
  // caller's seconds before this call).
  Stopwatch wall;
  std::unique_ptr<ProgressiveRenderer> r;
  if (checkpoint_exists(opt, resume)) {
    HitpointSet loaded =
        load_checkpoint(opt, [](const std::string& path) { return load_hitpoints(path); });
    require_scene(opt.checkpoint, loaded.scene_id, scene.scene_id, scene.source);
    // Checks the state's indices against the scene's tables; no work yet (that is run_iteration).
    r = std::make_unique<ProgressiveRenderer>(scene, opt, std::move(loaded), opt.checkpoint);
    const HitpointSet& state = r->state();
    if (state.estimator == "classic")
      throw input_error(opt.checkpoint, "holds a classic photon-mapping estimate, not a PPM state",
                        "delete it or pass another --checkpoint");
    require_same_state(opt.checkpoint, opt);  // names a changed --estimator too
    if (is_sppm_state(state) != (opt.estimator == Estimator::Sppm))
      throw input_error(opt.checkpoint,
                        std::string("holds ") + (is_sppm_state(state) ? "an SPPM" : "a PPM") +
                            " state, this run is --estimator " + estimator_name(opt.estimator),
                        "use the checkpoint's estimator or start without --resume");
    require_passes_left(opt, state.passes);
    require_state_agrees(opt.checkpoint, opt, state.direct_mode, state.radius0,
                         initial_radius(scene, opt.eye), "radius0");
  }
  return drive<ProgressiveRenderer, HitpointSet>(
      opt, std::move(r), [&] { return std::make_unique<ProgressiveRenderer>(scene, opt); },
      with_state_parameters(prov, opt), wall, on_pass, on_snapshot, status);
}

PassSums render_pppm(const Scene& scene, const RenderOptions& opt, bool resume,
                     const Provenance& prov, const std::function<bool(int, double)>& on_pass,
                     const std::function<void(const PassSums&, const RenderStatus&)>& on_snapshot,
                     RenderStatus* status) {
  check_options(opt);
  if (opt.estimator != Estimator::Pppm)
    throw std::invalid_argument("render_pppm: the estimator must be pppm");
  Stopwatch wall;
  std::unique_ptr<PppmRenderer> r;
  if (checkpoint_exists(opt, resume)) {
    PassSums loaded =
        load_checkpoint(opt, [](const std::string& path) { return load_pass_sums(path); });
    require_scene(opt.checkpoint, loaded.scene_id, scene.scene_id, scene.source);
    if (loaded.first_pass != opt.first_pass)
      throw input_error(opt.checkpoint,
                        "starts at pass " + std::to_string(loaded.first_pass) +
                            ", this run at --first-pass " + std::to_string(opt.first_pass),
                        "use the checkpoint's --first-pass or start without --resume");
    require_passes_left(opt, loaded.passes);
    require_same_state(opt.checkpoint, opt);
    require_state_agrees(opt.checkpoint, opt, loaded.direct_mode, loaded.radius1,
                         initial_radius(scene, opt.eye), "radius1");
    if (loaded.alpha != opt.ppm.alpha)
      throw input_error(opt.checkpoint,
                        "holds sums of alpha " + default_text(loaded.alpha) + ", this run has " +
                            "--alpha " + default_text(opt.ppm.alpha),
                        "use the checkpoint's --alpha or start without --resume");
    r = std::make_unique<PppmRenderer>(scene, opt, std::move(loaded), opt.checkpoint);
  }
  return drive<PppmRenderer, PassSums>(
      opt, std::move(r), [&] { return std::make_unique<PppmRenderer>(scene, opt); },
      with_state_parameters(prov, opt), wall, on_pass, on_snapshot, status);
}

bool snapshot_due(const RenderOptions& opt, int passes) {
  if (opt.snapshot_every > 0 && passes % opt.snapshot_every == 0) return true;
  return std::find(opt.snapshot_at.begin(), opt.snapshot_at.end(), passes) != opt.snapshot_at.end();
}

std::vector<int> parse_pass_list(const std::string& text, const std::string& option) {
  std::vector<int> out;
  size_t at = 0;
  while (at <= text.size() && !text.empty()) {
    size_t end = text.find(',', at);
    if (end == std::string::npos) end = text.size();
    const std::string item = text.substr(at, end - at);
    size_t used = 0;
    long v = 0;
    try {
      v = std::stol(item, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (item.empty() || used != item.size() || v <= 0 || v > INT32_MAX)
      throw input_error("", "--" + option + " takes positive pass counts separated by commas, got '" +
                                text + "'");
    out.push_back(int(v));
    at = end + 1;
  }
  return out;
}

std::string render_snapshot_name(const std::string& pattern, int passes, int total) {
  return numbered_name(pattern, "{pass}", passes, total);
}

void check_snapshot_pattern(const std::string& pattern, const RenderOptions& opt) {
  if (pattern.find("{pass}") != std::string::npos) return;
  // Snapshots due in 1..passes: the multiples of snapshot_every, then the other listed passes.
  int64_t due = opt.snapshot_every > 0 ? opt.passes / opt.snapshot_every : 0;
  std::vector<int> extra;
  for (int p : opt.snapshot_at)
    if (p >= 1 && p <= opt.passes && !(opt.snapshot_every > 0 && p % opt.snapshot_every == 0) &&
        std::find(extra.begin(), extra.end(), p) == extra.end())
      extra.push_back(p);
  due += int64_t(extra.size());
  if (due > 1)
    throw input_error("", "--snapshot '" + pattern + "' has no {pass}: its " +
                              std::to_string(due) + " snapshots would overwrite each other",
                      "put {pass} in the name, e.g. snap-{pass}.exr");
}

std::string render_record_json(const Provenance& prov, const std::vector<RenderImageRecord>& images) {
  Json doc = provenance_json(prov);
  Json list = Json::array();
  for (const auto& im : images) {
    const RenderStatus& s = im.status;
    Json entry = Json::object();
    entry["path"] = im.path;
    entry["passes"] = s.passes;
    entry["target"] = s.target;
    entry["photons_emitted"] = s.photons_emitted;
    entry["photons_stored"] = s.photons_stored;
    entry["seconds"] = json_value(s.seconds);
    entry["build_seconds"] = json_value(s.build_seconds);
    entry["mean_radius"] = json_value(s.mean_radius);
    entry["resumed"] = s.resumed;
    if (s.guide.uniform > 0) {  // --photon-guide visibility (photon_guide.h)
      entry["visible_fraction"] = json_value(s.guide.visible_fraction());
      entry["acceptance"] = json_value(s.guide.acceptance());
    }
    list.push_back(std::move(entry));
  }
  doc["images"] = std::move(list);
  return json_record_text(doc);
}

void write_render_record(const std::string& path, const Provenance& prov,
                         const std::vector<RenderImageRecord>& images) {
  write_text_atomic(path, render_record_json(prov, images));
}

}  // namespace pf
