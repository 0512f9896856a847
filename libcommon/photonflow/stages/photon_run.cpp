// photon_run.cpp — the passes of a trace-photons run (photon_run.h).
#include "photonflow/stages/photon_run.h"

#include <stdexcept>

#include "photonflow/foundations/error.h"
#include "photonflow/io/stage_files.h"
#include "photonflow/opencl/cl_backend.h"

namespace pf {

PhotonRun trace_photon_run(const Scene& scene, int first, int passes,
                           const PhotonPassOptions& opt, ClContext* dev,
                           const HitpointSet* eye, const std::string& eye_path,
                           Progress* progress) {
  check_pass_range(first, passes);
  const bool guided = opt.guide == PhotonGuide::Visibility;
  if (guided != (eye != nullptr))
    throw std::invalid_argument("trace_photon_run: visible points iff the photons are guided");
  if (guided && dev)
    throw input_error("", "--photon-guide visibility traces photons on the CPU only",
                      "drop --device opencl, or use --photon-guide uniform");
  VisibleSet visible;
  if (guided) {
    require_scene(eye_path, eye->scene_id, scene.scene_id, scene.source);
    guide_points_from_file(*eye, eye_path, first, passes, visible);
  }
  PhotonRun run;
  run.set.first_pass = first;
  run.set.seed = opt.seed;
  run.set.scene_id = scene.scene_id;
  for (int p = 0; p < passes; ++p) {
    PhotonGuideStats gs;
    PhotonPassResult r = dev ? trace_photons(scene, uint32_t(first + p), opt, *dev)
                             : trace_photons(scene, uint32_t(first + p), opt,
                                             guided ? &visible : nullptr, &gs);
    run.guide.add(gs);
    run.set.append_pass(r.photons, r.emitted);
    if (progress) progress->update(p + 1, double(opt.photons) * (p + 1));
  }
  return run;
}

}  // namespace pf
