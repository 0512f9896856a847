// render_driver.h — progressive photon mapping in one process (the `render` tool): the same stage
// functions as the staged route (trace_hitpoints, trace_photons, ppm_pass, synthesize), with no
// files between passes, an iteration interface (SmallVCM's RunIteration) and atomic checkpoints
// of the hitpoint state for --resume.
//
// With the same scene, seed and options, pass p here traces exactly the photons that
// `trace-photons --first-pass p` writes, and gathers them exactly as `illuminate` does, so both
// routes give the same image.
#pragma once
#include <functional>
#include <memory>
#include <string>

#include "photonflow/cl_runtime.h"
#include "photonflow/clusters.h"
#include "photonflow/eye_pass.h"
#include "photonflow/illuminate.h"
#include "photonflow/image.h"
#include "photonflow/photon_pass.h"
#include "photonflow/provenance.h"
#include "photonflow/stage_files.h"

namespace pf {

struct RenderOptions {
  EyePassOptions eye;
  PhotonPassOptions photons;
  PpmOptions ppm;
  int passes = 16;                 // total photon passes of the run
  std::string checkpoint;          // hitpoint-state file ("" = none)
  int checkpoint_every = 10;       // passes between checkpoints
  ClContext* device = nullptr;     // OpenCL backend (cl_backend.h, ppm.method); nullptr = CPU
};

class ProgressiveRenderer {
 public:
  // Starts a run: the eye pass, no photons yet.
  ProgressiveRenderer(const Scene& scene, const RenderOptions& opt);
  // Continues a run from a saved hitpoint state (a checkpoint).
  ProgressiveRenderer(const Scene& scene, const RenderOptions& opt, HitpointSet state);

  // One photon pass (trace photons of pass `passes_done()`) and its PPM gather.
  void run_iteration();
  int passes_done() const { return state_.passes; }
  const HitpointSet& state() const { return state_; }
  uint64_t photons_traced() const { return photons_stored_; }

  // Writes the hitpoint state atomically to `path` with provenance `prov`.
  void save_state(const std::string& path, const Provenance& prov) const;

 private:
  const Scene& scene_;
  RenderOptions opt_;
  HitpointSet state_;
  uint64_t photons_stored_ = 0;
  // Per-pass work space, reused by every pass (the memory of a run does not grow with passes):
  PhotonBuffers photon_chunks_;   // the pass's photons, per chunk as traced
  PhotonGrid grid_;               // their grid (GatherMethod::Grid), built straight from the chunks
  std::vector<pf_photon> photons_;  // their concatenation (GatherMethod::Flann)
  // Clusters of a clustered device method, made once from the eye pass (or the checkpoint's
  // hitpoints, which have the same positions) when opt.ppm.clusters is not given.
  std::unique_ptr<ClusterSet> clusters_;
};

// The whole run: resumes from opt.checkpoint when `resume` (and the file exists), runs the
// remaining passes with checkpoints every opt.checkpoint_every passes, and returns the final
// state. `on_pass(done, photons)` is called after every pass (progress display).
HitpointSet render_progressive(const Scene& scene, const RenderOptions& opt, bool resume,
                               const Provenance& prov,
                               const std::function<void(int, double)>& on_pass = {});

}  // namespace pf
