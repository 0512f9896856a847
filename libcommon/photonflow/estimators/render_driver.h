// render_driver.h — progressive photon mapping in one process (the `render` tool): the same stage
// functions as the staged route (trace_hitpoints, trace_photons, ppm_pass / sppm_pass /
// pppm_pass, synthesize), with no files between passes, an iteration interface (SmallVCM's
// RunIteration), atomic checkpoints of the state for --resume, a wall-clock budget, and
// progressive snapshots with a run record (the (passes, seconds) pairs of the speed–accuracy
// pipeline, pipelines/accuracy.mk). Three estimators (sppm.h): ppm (one fixed eye pass), sppm and
// pppm (a new eye pass before every photon pass).
//
// With the same scene, seed and options, pass p here traces exactly the photons that
// `trace-photons --first-pass p` writes, and gathers them exactly as `illuminate` does, so both
// routes give the same image. On the CPU, sppm and pppm trace each pass's photons first and then
// the eye pass pixel by pixel as they gather (sppm_pass_traced, pppm_pass_traced: no eye pass is
// kept), the same bits as the staged route's eye pass file read by illuminate. With
// --photon-guide visibility (photon_guide.h) the order turns round: the pass's eye pass first
// (trace_hitpoints_into), its visible points guide the photons, then sppm_pass / pppm_pass gather
// them (ppm's fixed hitpoints guide every pass); CPU only (check_options refuses a device).
#pragma once
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "photonflow/opencl/cl_gather.h"
#include "photonflow/opencl/cl_runtime.h"
#include "photonflow/stages/clusters.h"
#include "photonflow/stages/eye_pass.h"
#include "photonflow/stages/illuminate.h"
#include "photonflow/image/image.h"
#include "photonflow/estimators/pass_sums.h"
#include "photonflow/stages/photon_pass.h"
#include "photonflow/io/provenance.h"
#include "photonflow/estimators/sppm.h"
#include "photonflow/io/stage_files.h"

namespace pf {

struct RenderOptions {
  EyePassOptions eye;
  PhotonPassOptions photons;
  PpmOptions ppm;
  Estimator estimator = Estimator::Ppm;
  int passes = 16;                 // photon passes of the run in total (pppm: from first_pass)
  int first_pass = 0;              // pppm: the first pass of this run's range
  double time_budget = 0;          // seconds of rendering (RenderStatus::seconds); 0 = none: the
                                   // run ends after the pass that reaches it
  std::string checkpoint;          // hitpoint-state file ("" = none)
  int checkpoint_every = 10;       // passes between checkpoints
  int snapshot_every = 0;          // passes between snapshot callbacks (0 = none)
  std::vector<int> snapshot_at;    // further pass counts with a snapshot callback (any order)
  ClContext* device = nullptr;     // OpenCL backend (cl_backend.h, ppm.method); nullptr = CPU
};

// The ppm and sppm estimators, whose state is a HitpointSet (sppm: one hitpoint per pixel).
class ProgressiveRenderer {
 public:
  // Starts a run: ppm's eye pass, or sppm's empty per-pixel state; no photons yet.
  ProgressiveRenderer(const Scene& scene, const RenderOptions& opt);
  // Continues a run from a saved hitpoint state (a checkpoint), checked against the scene's
  // tables (check_against_scene); `path`, the file it came from, names it in the InputError.
  ProgressiveRenderer(const Scene& scene, const RenderOptions& opt, HitpointSet state,
                      const std::string& path = "");

  // One photon pass (trace photons of pass `passes_done()`) and its gather: ppm into the fixed
  // hitpoints; sppm into the pixels at the visible points of eye pass `passes_done()`, traced as
  // it gathers (sppm_pass_traced; on a device DevicePpmState::sppm_pass).
  void run_iteration();
  int passes_done() const { return state_.passes; }
  uint64_t photons_emitted() const { return state_.photons_emitted; }
  // The state after the last pass (brought back from the device first when it is kept there).
  const HitpointSet& state() const {
    if (device_state_) device_state_->sync();
    return state_;
  }
  uint64_t photons_traced() const { return photons_stored_; }
  // What the guided photon passes of this process did (photon_guide.h; zero when uniform).
  const PhotonGuideStats& guide_stats() const { return guide_; }

  // Writes the hitpoint state atomically to `path` with provenance `prov`.
  void save_state(const std::string& path, const Provenance& prov) const;

 private:
  const Scene& scene_;
  RenderOptions opt_;
  // emission_pixels, once per run; opt_.eye points at it (on the heap: stays put when moved)
  std::shared_ptr<const std::vector<uint8_t>> emission_marks_;
  HitpointSet state_;
  uint64_t photons_stored_ = 0;
  // Per-pass work space, reused by every pass (the memory of a run does not grow with passes):
  PhotonBuffers photon_chunks_;   // the pass's photons, per chunk as traced
  PhotonGrid grid_;               // their grid (GatherMethod::Grid), built straight from the chunks
  std::vector<pf_photon> photons_;  // their concatenation (GatherMethod::Flann)
  // --photon-guide visibility: sppm's eye pass (traced before the photons), the visible points
  PhotonGuideStats guide_;
  EyePassResult eye_;
  EyePassWork eye_work_;
  VisibleSet visible_;
  // Clusters of a clustered device method, made once from the eye pass (or the checkpoint's
  // hitpoints, which have the same positions) when opt.ppm.clusters is not given.
  std::unique_ptr<ClusterSet> clusters_;
  // The OpenCL backend's state on the device (cl_gather.h): with hash-grid the hitpoints stay
  // there between passes and come back only when state() is read (snapshots, checkpoints, end).
  std::unique_ptr<DevicePpmState> device_state_;
};

// Traces photon pass `pass` on the CPU and sorts its photons into `grid` (bins at least radius0
// wide): the photons of an sppm or pppm pass, before sppm_pass_traced or pppm_pass_traced traces
// the eye pass as it gathers.
// Returns the photons emitted; `stored` gets the photons stored. The buffers (chunks, grid) keep
// their storage from the last pass, so a pass allocates nothing new.
// With opt.photons.guide visibility, `visible` holds the pass's visible points and `stats` gets
// what the chains did (photon_guide.h).
uint64_t trace_photon_pass(const Scene& scene, const RenderOptions& opt, uint32_t pass,
                           float radius0, PhotonBuffers& chunks, PhotonGrid& grid, size_t& stored,
                           const VisibleSet* visible = nullptr, PhotonGuideStats* stats = nullptr);

// The pppm estimator: sums of the pass estimates over passes [first_pass, first_pass + passes).
class PppmRenderer {
 public:
  // A fresh range starting at opt.first_pass.
  PppmRenderer(const Scene& scene, const RenderOptions& opt);
  // Continues a saved range (a checkpoint); `path` names it in errors.
  PppmRenderer(const Scene& scene, const RenderOptions& opt, PassSums sums,
               const std::string& path = "");
  void run_iteration();                        // pass first_pass + passes_done()
  int passes_done() const { return sums_.passes; }
  uint64_t photons_emitted() const { return sums_.photons_emitted; }
  uint64_t photons_traced() const { return photons_stored_; }
  const PhotonGuideStats& guide_stats() const { return guide_; }
  const PassSums& state() const { return sums_; }
  void save_state(const std::string& path, const Provenance& prov) const;

 private:
  const Scene& scene_;
  RenderOptions opt_;
  // emission_pixels, once per run; opt_.eye points at it (on the heap: stays put when moved)
  std::shared_ptr<const std::vector<uint8_t>> emission_marks_;
  std::shared_ptr<const std::vector<uint8_t>> glossy_marks_;  // glossy_pixels, likewise
  PassSums sums_;
  uint64_t photons_stored_ = 0;
  EyePassResult eye_;  // the device's eye pass; the CPU's with --photon-guide visibility
  PhotonBuffers photon_chunks_;
  PhotonGuideStats guide_;
  EyePassWork eye_work_;
  VisibleSet visible_;
  PhotonGrid grid_;
};

// Where a run stands after a pass (snapshot callbacks and the run record).
//   seconds: wall time of this process's rendering work — the eye pass (unless the run resumed
//   from a checkpoint) and every photon pass with its gather — without the time spent in snapshot
//   callbacks, in checkpoint writes and in building OpenCL programs (a one-off cost, cached by the
//   driver; build_seconds says how much it was). These are the seconds a speed–accuracy chart
//   puts on its time axis: the cost of the image, not of watching it.
struct RenderStatus {
  int passes = 0;                 // photon passes in the state
  int target = 0;                 // passes asked for (opt.passes)
  uint64_t photons_emitted = 0;   // N_emitted of eq. 3.19, all passes in the state
  uint64_t photons_stored = 0;    // photons stored by the passes this process traced
  double seconds = 0;             // rendering wall time (above)
  double build_seconds = 0;       // OpenCL program builds so far (not in `seconds`)
  double mean_radius = 0;         // mean gather radius R of the hitpoints or pixels (eq. 3.16),
                                  // pppm: r_i of the last pass (KZ11 eq. 19), world units
  bool resumed = false;           // the run continued a checkpoint
  PhotonGuideStats guide;         // --photon-guide visibility: this process's passes together
                                  // (visible fraction of the uniform photons, acceptance rate)
  bool stopped = false;           // on_pass asked to stop before opt.passes (an interrupt)
  bool budget_reached = false;    // the run ended at opt.time_budget before opt.passes
};

// InputError naming the option when one is out of range: the eye and photon pass options
// (check_options), --passes > 0, --alpha in (0, 1], --max-bins > 0, --checkpoint-every > 0 with
// a checkpoint, --snapshot-every >= 0, --snapshot-at within 1..--passes, --time >= 0 and finite,
// --first-pass >= 0 (pppm only) with the range's passes int32 indices, --spp 1 with sppm.
// render_progressive and render_pppm call it first.
void check_options(const RenderOptions& opt);

// The options a PPM state depends on, as canonical text under their tool option names ("alpha" →
// "0.7", "seed", "photons", "spp", "max-depth", "max-bounces", "direct", "shadow-samples",
// "radius", "pixel-sampler"; with sppm and pppm also "estimator" and "slab", and "gather-area"
// when it is the surface; "glossy-merge" when not "first", "emission-spp" and "glossy-spp" when above 0). render_progressive
// records them in every checkpoint's provenance parameters as
// "state.<name>" and resumes only a checkpoint whose record equals this run's
// (require_same_state_parameters): a state continued under other options would be neither run's
// image. (Passes, snapshots, threads, device, method and work-group size may change: every gather
// method gathers the same photons.)
std::map<std::string, std::string> state_parameters(const RenderOptions& opt);

// "state.", the prefix of state_parameters' names among a checkpoint's provenance parameters.
extern const char* const kStateParameterPrefix;

// The value an option that state_parameters leaves out of the record at its "off" value stands
// for when a file has no entry for it ("emission-spp" → "0", "glossy-merge" → "first",
// "gather-area" → "disc", "estimator" → "ppm"); nullopt for an option that every record has.
std::optional<std::string> state_parameter_unrecorded_value(const std::string& name);

// The one check of a recorded state against a run (render --resume, illuminate --state): walks
// every name in `recorded` (the state.* entries of `file`, prefix removed) and in `run` (this
// run's state_parameters) and refuses, with one InputError line naming the option, a value that
// differs ("ck.h5: --emission-spp 4 differs from the checkpoint's 1 (state.emission-spp) (rerun
// with --emission-spp 1, the checkpoint's, or start without --resume)"), an entry only one side
// has that has no unrecorded value (a file of another version), and a file with no entry at all.
// `fresh` is the way out besides the checkpoint's value ("start without --resume").
void require_same_state_parameters(const std::string& file,
                                   const std::map<std::string, std::string>& recorded,
                                   const std::map<std::string, std::string>& run,
                                   const std::string& fresh);
// The same record for the staged route (illuminate --estimator pppm), from the options recorded in
// the provenance of its eye pass (trace-hitpoints: spp, max-depth, direct, shadow-samples, radius,
// seed, pixel-sampler) and photon pass (trace-photons: photons, max-bounces, seed) and its alpha,
// slab and gather area: equal to render's for the same options, so parts of either route merge.
// InputError naming the file whose provenance lacks one.
std::map<std::string, std::string> staged_state_parameters(
    Estimator e, const Provenance& eye, const std::string& eye_path, const Provenance& photons,
    const std::string& photons_path, float alpha, float slab, GatherArea area);

// The whole run: resumes from opt.checkpoint when `resume` (and the file exists), runs the
// remaining passes with checkpoints every opt.checkpoint_every passes, and returns the final
// state. Each checkpoint carries `prov` with wall_time_s = prov.wall_time_s (the caller's seconds
// before the call, 0 if it does not say) + the wall-clock seconds of this call so far.
// `on_snapshot(state, status)` is called after every pass whose count is a multiple of
// opt.snapshot_every (> 0) or is listed in opt.snapshot_at, including the last when it is one;
// `on_pass(done, photons)` after every pass (progress display): when it returns false the run
// stops there (render on Ctrl-C, interrupt.h), saving opt.checkpoint first when one is named, and
// the status says `stopped`. `status`, when given, receives the final status.
HitpointSet render_progressive(
    const Scene& scene, const RenderOptions& opt, bool resume, const Provenance& prov,
    const std::function<bool(int, double)>& on_pass = {},
    const std::function<void(const HitpointSet&, const RenderStatus&)>& on_snapshot = {},
    RenderStatus* status = nullptr);

// The pppm run: as render_progressive, over passes [opt.first_pass, opt.first_pass + opt.passes),
// its checkpoint a pass-sums file (pass_sums.h) that --resume continues when its range starts at
// opt.first_pass and its options equal this run's. Returns the sums.
PassSums render_pppm(const Scene& scene, const RenderOptions& opt, bool resume,
                     const Provenance& prov, const std::function<bool(int, double)>& on_pass = {},
                     const std::function<void(const PassSums&, const RenderStatus&)>& on_snapshot = {},
                     RenderStatus* status = nullptr);

// One image a run wrote (a snapshot or the final image) and the run's status when it was taken.
struct RenderImageRecord {
  std::string path;
  RenderStatus status;
};

// True when a snapshot is due after `passes` passes (opt.snapshot_every, opt.snapshot_at).
bool snapshot_due(const RenderOptions& opt, int passes);

// A list of pass counts "1,2,4,8" (comma-separated positive integers, no spaces needed) as
// --snapshot-at takes it; InputError naming `option` for anything else.
std::vector<int> parse_pass_list(const std::string& text, const std::string& option);

// The snapshot file name: `pattern` with every "{pass}" replaced by `passes`, zero-padded to the
// digits of `total` so that names sort in pass order.
std::string render_snapshot_name(const std::string& pattern, int passes, int total);

// Refuses (InputError, before any work) a snapshot pattern without "{pass}" when opt asks for
// more than one snapshot in its opt.passes passes (--snapshot-every, --snapshot-at): every
// snapshot would overwrite the one before under the same name.
void check_snapshot_pattern(const std::string& pattern, const RenderOptions& opt);

// The run record (render's images carry no provenance) as a JSON object:
//   {"tool", "version", "git_hash", "seed", "command_line", "wall_time_s",
//    "parameters": {name: value, ...}, "inputs": [{"role", "path", "sha256", "format",
//    "scene_id"}, ...], "images": [{"path", "passes", "target", "photons_emitted",
//    "photons_stored", "seconds", "build_seconds", "mean_radius", "resumed"}, ...]}
// `images` in the order written: (passes, seconds) pairs for convergence charts.
std::string render_record_json(const Provenance& prov, const std::vector<RenderImageRecord>& images);
// Writes it to `path` atomically; InputError if it cannot.
void write_render_record(const std::string& path, const Provenance& prov,
                         const std::vector<RenderImageRecord>& images);

}  // namespace pf
