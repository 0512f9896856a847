// Progressive render driver: see render_driver.h.
#include "photonflow/render_driver.h"

#include <unistd.h>

#include <algorithm>
#include <climits>
#include <cstdint>
#include <sstream>

#include "photonflow/cl_backend.h"
#include "photonflow/options.h"
#include "photonflow/text_file.h"

namespace pf {

namespace {
HitpointSet fresh_state(const Scene& scene, const EyePassOptions& eye, ClContext* device) {
  EyePassResult r = device ? trace_hitpoints(scene, eye, *device) : trace_hitpoints(scene, eye);
  return make_hitpoint_set(std::move(r), eye.direct, scene.scene_id);
}
}  // namespace

// Both constructors check the state's ids against the scene once; a pass never changes them, so
// the CPU grid gather of every pass skips that check (ppm_pass_grid_prechecked).
ProgressiveRenderer::ProgressiveRenderer(const Scene& scene, const RenderOptions& opt)
    : scene_(scene), opt_(opt), state_(fresh_state(scene, opt.eye, opt.device)) {
  check_against_scene("", state_, scene_);
}

ProgressiveRenderer::ProgressiveRenderer(const Scene& scene, const RenderOptions& opt,
                                         HitpointSet state, const std::string& path)
    : scene_(scene), opt_(opt), state_(std::move(state)) {
  check_against_scene(path, state_, scene_);
}

void ProgressiveRenderer::run_iteration() {
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
  const uint64_t emitted =
      trace_photons_into(scene_, uint32_t(state_.passes), opt_.photons, photon_chunks_);
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

void ProgressiveRenderer::save_state(const std::string& path, const Provenance& prov) const {
  save_hitpoints(state(), path, prov);
}

void check_options(const RenderOptions& opt) {
  check_options(opt.eye);
  check_options(opt.photons);
  require_positive("passes", opt.passes);
  require_in_unit_interval("alpha", opt.ppm.alpha);
  require_positive("max-bins", opt.ppm.max_bins);
  if (!opt.checkpoint.empty()) require_positive("checkpoint-every", opt.checkpoint_every);
  if (opt.snapshot_every < 0) throw input_error("", "--snapshot-every must be >= 0");
  for (int p : opt.snapshot_at)
    if (p < 1 || p > opt.passes)
      throw input_error("", "--snapshot-at " + std::to_string(p) +
                                " is not a pass of this run (1.." + std::to_string(opt.passes) + ")",
                        "list passes up to --passes");
}

std::map<std::string, std::string> state_parameters(const RenderOptions& opt) {
  return {{"spp", std::to_string(opt.eye.spp)},
          {"max-depth", std::to_string(opt.eye.max_depth)},
          {"direct", direct_mode_name(opt.eye.direct)},
          {"shadow-samples", std::to_string(opt.eye.shadow_samples)},
          {"radius", default_text(opt.eye.radius)},
          {"seed", opt.eye.seed == opt.photons.seed  // render's one --seed
                       ? std::to_string(opt.eye.seed)
                       : std::to_string(opt.eye.seed) + "/" + std::to_string(opt.photons.seed)},
          {"photons", std::to_string(opt.photons.photons)},
          {"max-bounces", std::to_string(opt.photons.max_bounces)},
          {"alpha", default_text(opt.ppm.alpha)}};
}

namespace {

// Refuses a checkpoint whose recorded state options differ from this run's (state_parameters).
void require_same_state(const std::string& checkpoint, const RenderOptions& opt) {
  const Provenance made = load_hitpoints_provenance(checkpoint);
  for (const auto& [name, value] : state_parameters(opt)) {
    const auto it = made.parameters.find("state." + name);
    if (it == made.parameters.end())
      throw input_error(checkpoint, "records no '" + name + "' of the run that wrote it, so it "
                                    "cannot be resumed safely",
                        "start without --resume");
    if (it->second != value)
      throw input_error(checkpoint, "was made with --" + name + " " + it->second +
                                        ", this run has " + value,
                        "use the checkpoint's options or start without --resume");
  }
}

}  // namespace

HitpointSet render_progressive(
    const Scene& scene, const RenderOptions& opt, bool resume, const Provenance& prov,
    const std::function<bool(int, double)>& on_pass,
    const std::function<void(const HitpointSet&, const RenderStatus&)>& on_snapshot,
    RenderStatus* status) {
  check_options(opt);
  // Wall-clock seconds of the run, for the checkpoints' provenance (prov.wall_time_s holds the
  // caller's seconds before this call).
  Stopwatch wall;
  bool from_checkpoint = resume && !opt.checkpoint.empty() && access(opt.checkpoint.c_str(), F_OK) == 0;
  std::unique_ptr<ProgressiveRenderer> r;
  if (from_checkpoint) {
    HitpointSet loaded = load_hitpoints(opt.checkpoint);
    require_scene(opt.checkpoint, loaded.scene_id, scene.scene_id, scene.source);
    // Checks the state's indices against the scene's tables; no work yet (that is run_iteration).
    r = std::make_unique<ProgressiveRenderer>(scene, opt, std::move(loaded), opt.checkpoint);
    const HitpointSet& state = r->state();
    if (state.estimator == "classic")
      throw input_error(opt.checkpoint, "holds a classic photon-mapping estimate, not a PPM state",
                        "delete it or pass another --checkpoint");
    if (state.passes > opt.passes)
      throw input_error(opt.checkpoint,
                        "already has " + std::to_string(state.passes) + " passes, more than --passes",
                        "raise --passes or start without --resume");
    require_same_state(opt.checkpoint, opt);
  }
  Provenance checkpoint_prov = prov;  // the run's, with the options its state depends on
  for (const auto& [name, value] : state_parameters(opt))
    checkpoint_prov.parameters["state." + name] = value;
  // The rendering clock (RenderStatus::seconds): starts before the eye pass; the time spent in
  // checkpoints, snapshot callbacks and OpenCL program builds is taken off it.
  Stopwatch clock;
  double aside = 0;
  const double build0 = opt.device ? opt.device->build_seconds() : 0.0;
  if (!from_checkpoint) r = std::make_unique<ProgressiveRenderer>(scene, opt);  // the eye pass
  RenderStatus st;
  st.target = opt.passes;
  st.resumed = from_checkpoint;
  auto update_status = [&] {
    st.passes = r->passes_done();
    st.photons_emitted = r->photons_emitted();
    st.photons_stored = r->photons_traced();
    st.build_seconds = opt.device ? opt.device->build_seconds() - build0 : 0.0;
    st.seconds = clock.seconds() - aside - st.build_seconds;
  };
  // The hitpoints' mean radius, for the record (outside the rendering clock).
  auto mean_radius = [&] {
    const std::vector<pf_hitpoint>& hp = r->state().hitpoints;
    double sum = 0;
    for (const pf_hitpoint& x : hp) sum += double(x.radius);
    return hp.empty() ? 0.0 : sum / double(hp.size());
  };
  update_status();
  st.mean_radius = mean_radius();
  double photons = 0;
  while (r->passes_done() < opt.passes) {
    r->run_iteration();
    if (r->passes_done() == opt.passes) r->state();  // the last state back from the device, on the clock
    photons += double(opt.photons.photons);
    update_status();
    // Time outside the rendering clock; a program built inside (the device synthesis of a first
    // snapshot) is already in build_seconds and is not taken off twice.
    Stopwatch outside;
    const double built_before = opt.device ? opt.device->build_seconds() : 0.0;
    const bool last = r->passes_done() == opt.passes;
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
    if (snapshot || last) st.mean_radius = mean_radius();
    if (snapshot) on_snapshot(r->state(), st);
    aside += outside.seconds() - ((opt.device ? opt.device->build_seconds() : 0.0) - built_before);
    if (on_pass && !on_pass(r->passes_done(), photons) && !last) {
      // Asked to stop: the passes so far are kept in the checkpoint, for --resume.
      if (!opt.checkpoint.empty() && !saved) save_checkpoint();
      st.mean_radius = mean_radius();
      st.stopped = true;
      break;
    }
  }
  if (status) *status = st;
  return r->state();
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
  std::ostringstream o;
  o << "{\n" << provenance_json_fields(prov) << ",\n  \"images\": [";
  const char* sep = "";
  for (const auto& im : images) {
    const RenderStatus& s = im.status;
    o << sep << "\n    {\"path\": " << json_string(im.path) << ", \"passes\": " << s.passes
      << ", \"target\": " << s.target << ", \"photons_emitted\": " << s.photons_emitted
      << ", \"photons_stored\": " << s.photons_stored
      << ", \"seconds\": " << json_number(s.seconds)
      << ", \"build_seconds\": " << json_number(s.build_seconds)
      << ", \"mean_radius\": " << json_number(s.mean_radius)
      << ", \"resumed\": " << (s.resumed ? "true" : "false") << "}";
    sep = ",";
  }
  o << "\n  ]\n}\n";
  return o.str();
}

void write_render_record(const std::string& path, const Provenance& prov,
                         const std::vector<RenderImageRecord>& images) {
  write_text_atomic(path, render_record_json(prov, images));
}

}  // namespace pf
