// Progressive render driver: see render_driver.h.
#include "photonflow/render_driver.h"

#include <unistd.h>

#include "photonflow/cl_backend.h"

namespace pf {

namespace {
HitpointSet fresh_state(const Scene& scene, const EyePassOptions& eye, ClContext* device) {
  EyePassResult r = device ? trace_hitpoints(scene, eye, *device) : trace_hitpoints(scene, eye);
  return make_hitpoint_set(std::move(r), eye.direct, scene.scene_id);
}
}  // namespace

ProgressiveRenderer::ProgressiveRenderer(const Scene& scene, const RenderOptions& opt)
    : scene_(scene), opt_(opt), state_(fresh_state(scene, opt.eye, opt.device)) {}

ProgressiveRenderer::ProgressiveRenderer(const Scene& scene, const RenderOptions& opt,
                                         HitpointSet state)
    : scene_(scene), opt_(opt), state_(std::move(state)) {}

void ProgressiveRenderer::run_iteration() {
  if (opt_.device) {  // OpenCL backend: device photon tracing and opt.ppm.method's gather
    if (gather_method_info(opt_.ppm.method).clusters && !opt_.ppm.clusters) {
      clusters_ = std::make_unique<ClusterSet>(
          clusters_for_method(opt_.ppm.method, state_, opt_.device->work_group(), opt_.ppm));
      opt_.ppm.clusters = clusters_.get();
    }
    PhotonPassResult pass =
        trace_photons(scene_, uint32_t(state_.passes), opt_.photons, *opt_.device);
    photons_stored_ += pass.photons.size();
    ppm_pass(scene_, state_, pass.photons, pass.emitted, opt_.ppm, *opt_.device);
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
    ppm_pass_grid(scene_, state_, grid_, emitted, opt_.ppm);
  } else {
    photon_chunks_.concatenate(photons_);
    ppm_pass(scene_, state_, photons_, emitted, opt_.ppm);
  }
}

void ProgressiveRenderer::save_state(const std::string& path, const Provenance& prov) const {
  save_hitpoints(state_, path, prov);
}

HitpointSet render_progressive(const Scene& scene, const RenderOptions& opt, bool resume,
                               const Provenance& prov,
                               const std::function<void(int, double)>& on_pass) {
  bool from_checkpoint = resume && !opt.checkpoint.empty() && access(opt.checkpoint.c_str(), F_OK) == 0;
  std::unique_ptr<ProgressiveRenderer> r;
  if (from_checkpoint) {
    HitpointSet state = load_hitpoints(opt.checkpoint);
    require_scene(opt.checkpoint, state.scene_id, scene.scene_id, scene.source);
    if (state.estimator == "classic")
      throw input_error(opt.checkpoint, "holds a classic photon-mapping estimate, not a PPM state",
                        "delete it or pass another --checkpoint");
    if (state.passes > opt.passes)
      throw input_error(opt.checkpoint,
                        "already has " + std::to_string(state.passes) + " passes, more than --passes",
                        "raise --passes or start without --resume");
    r = std::make_unique<ProgressiveRenderer>(scene, opt, std::move(state));
  } else {
    r = std::make_unique<ProgressiveRenderer>(scene, opt);
  }
  double photons = 0;
  while (r->passes_done() < opt.passes) {
    r->run_iteration();
    photons += double(opt.photons.photons);
    if (!opt.checkpoint.empty() && opt.checkpoint_every > 0 &&
        (r->passes_done() % opt.checkpoint_every == 0 || r->passes_done() == opt.passes))
      r->save_state(opt.checkpoint, prov);
    if (on_pass) on_pass(r->passes_done(), photons);
  }
  return r->state();
}

}  // namespace pf
