// photon_run.h — the photon passes of one trace-photons run: passes first … first + passes − 1,
// each traced by trace_photons (photon_pass.h) on the CPU or on an OpenCL device
// (cl_backend.h), uniform or guided by an eye pass's visible points (photon_guide.h), appended
// in order to one PhotonSet (photons_file.h). The staged route's photon stage; render traces its
// passes one by one between eye passes instead (render_driver.cpp).
#ifndef PHOTONFLOW_PHOTON_RUN_H
#define PHOTONFLOW_PHOTON_RUN_H

#include <string>

#include "photonflow/foundations/progress.h"
#include "photonflow/geometry/scene.h"
#include "photonflow/io/hitpoints_file.h"
#include "photonflow/io/photons_file.h"
#include "photonflow/stages/photon_guide.h"
#include "photonflow/stages/photon_pass.h"

namespace pf {

class ClContext;

struct PhotonRun {
  PhotonSet set;            // the passes, scene_id and seed set
  PhotonGuideStats guide;   // what the chains did over all passes (zero for uniform photons)
};

// With opt.guide visibility, `eye` (read from `eye_path`) gives the visible points
// (guide_points_from_file: InputError naming eye_path when it is from another scene or does not
// fit the passes), and `dev` must be null (InputError: guided photons are traced on the CPU
// only); with uniform photons `eye` must be null. `progress`, when given, is updated per pass.
PhotonRun trace_photon_run(const Scene& scene, int first, int passes,
                           const PhotonPassOptions& opt, ClContext* dev,
                           const HitpointSet* eye, const std::string& eye_path,
                           Progress* progress);

}  // namespace pf

#endif  // PHOTONFLOW_PHOTON_RUN_H
