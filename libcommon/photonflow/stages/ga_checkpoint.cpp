// The GA's checkpoint file: see ga_checkpoint.h.
#include "photonflow/stages/ga_checkpoint.h"

#include <cstddef>
#include <limits>

#include "photonflow/io/h5io.h"
#include "photonflow/foundations/hash.h"
#include "photonflow/io/validate.h"

namespace pf::ga {

constexpr int kCheckpointVersion = 1;

static const h5::Compound& h5_type_centroid() {
  static const h5::Compound t = [] {
    h5::Compound c(sizeof(GaCentroid));
    c.f32("position", offsetof(GaCentroid, position), 3).i32("mesh", offsetof(GaCentroid, mesh));
    c.u32("id", offsetof(GaCentroid, id));
    return c;
  }();
  return t;
}

// Identity of what the fitness reads besides the hitpoints: the distribution map's content, and
// for device-time the photons and grid bins.
std::string inputs_id(const GaFitnessInputs& in, GaFitness f) {
  Sha256 s;
  const int64_t head[2] = {int64_t(in.wg_size), int64_t(f)};
  s.update(head, sizeof head);
  if (ga_fitness_needs_distribution(f) && in.distribution) {
    const PhotonDistribution& d = *in.distribution;
    const int64_t dh[2] = {d.passes, int64_t(d.counts.size())};
    s.update(dh, sizeof dh);
    s.update(d.mesh_grid.data(), d.mesh_grid.size() * sizeof(pf_mesh_grid));
    s.update(d.counts.data(), d.counts.size() * sizeof(uint64_t));
  }
  if (f == GaFitness::DeviceTime && in.photons) {
    const int64_t ph[2] = {int64_t(in.emitted), int64_t(in.max_bins)};
    s.update(ph, sizeof ph);
    s.update(in.photons->data(), in.photons->size() * sizeof(pf_photon));
  }
  return s.hex();
}


// The checkpoint's /provenance (GaOptions::provenance): the run's, or a minimal one.
static Provenance checkpoint_provenance(const GaFitnessInputs& in, const GaOptions& opt, double seconds) {
  Provenance p;
  if (opt.provenance) {
    p = *opt.provenance;
  } else {
    p.tool = "cluster";
    p.param("method", "ga");
    p.param("fitness", ga_fitness_name(opt.fitness));
    p.param("population", opt.population);
    p.param("ga-iterations", opt.iterations);
    p.param("seed", int64_t(opt.seed));
    p.param("iterations", opt.kmeans_iterations);
    p.param("wg-size", in.wg_size);
    p.param("checkpoint-every", opt.checkpoint_every);
    p.seed = opt.seed;
  }
  p.wall_time_s += seconds;
  return p;
}

// The values and the chromosome's meshes of a checkpoint: what load_checkpoint checks after
// reading and save_checkpoint before writing (validate.h written_check). InputError naming path.
void validate_checkpoint(const Checkpoint& ck, const GaFitnessInputs& in, const std::string& path) {
  const std::string hint = "delete it, or rerun with the options and inputs of that run";
  if (ck.generations < 1 || size_t(ck.generations) != ck.history.size() || ck.centroids.empty())
    throw input_error(path, "is a damaged checkpoint (generation count and history disagree)", hint);
  // Values (validate.h): centroids are world positions, fitness values and seconds finite and
  // not negative (every fitness of ga_clusters.h counts or times something).
  const Validator v(path, "the file is damaged; delete it and rerun");
  static const std::string kCentroids = "centroids", kHistory = "best_fitness";
  for (size_t k = 0; k < ck.centroids.size(); ++k)
    v.position(Name(kCentroids, k, "position"), ck.centroids[k].position);
  for (size_t k = 0; k < ck.history.size(); ++k)
    v.in_range(Name(kHistory, k), ck.history[k], 0.0, double(kMaxValue));
  v.in_range("attribute best_fitness", ck.fitness, 0.0, double(kMaxValue));
  v.in_range("attribute start_fitness", ck.start_fitness, 0.0, double(kMaxValue));
  v.in_range("attribute seconds", ck.seconds, 0.0, double(kMaxValue));
  v.int_in_range("attribute evaluations", int64_t(ck.evaluations), 0,
                 std::numeric_limits<int64_t>::max());
  // The chromosome indexes the hitpoints' meshes: every centroid on a mesh with hitpoints, every
  // such mesh with a centroid (what GaState's constructor assumes).
  const HitpointSet& h = *in.hitpoints;
  std::vector<size_t> hitpoints_of, centroids_of;
  for (const pf_hitpoint& p : h.hitpoints) {
    if (p.mesh < 0) continue;  // refused by the GA itself
    if (size_t(p.mesh) >= hitpoints_of.size()) hitpoints_of.resize(size_t(p.mesh) + 1, 0);
    ++hitpoints_of[size_t(p.mesh)];
  }
  centroids_of.assign(hitpoints_of.size(), 0);
  for (size_t k = 0; k < ck.centroids.size(); ++k) {
    const GaCentroid& c = ck.centroids[k];
    if (c.mesh < 0 || size_t(c.mesh) >= hitpoints_of.size() || hitpoints_of[size_t(c.mesh)] == 0)
      throw input_error(path, "centroid " + std::to_string(k) + " lies on mesh " +
                                  std::to_string(c.mesh) + ", which has no hitpoints",
                        "the file is damaged; delete it and rerun");
    ++centroids_of[size_t(c.mesh)];
  }
  for (size_t m = 0; m < hitpoints_of.size(); ++m)
    if (hitpoints_of[m] > 0 && centroids_of[m] == 0)
      throw input_error(path, "mesh " + std::to_string(m) + " has hitpoints but no centroid",
                        "the file is damaged; delete it and rerun");
}

// evaluations is kept as a uint64: refused as an int64 out of range before it is converted.
static void v_evaluations_in_range(const h5::Reader& r, const std::string& path) {
  const Validator v(path, "the file is damaged; delete it and rerun");
  v.int_in_range("attribute evaluations", r.attr_int("/", "evaluations"), 0,
                 std::numeric_limits<int64_t>::max());
}

void save_checkpoint(const std::string& path, const GaState& st, const GaFitnessInputs& in,
                     const GaOptions& opt, const std::string& hp_hash, const std::string& id,
                     const Checkpoint& ck, double call_seconds) {
  written_check([&] {
    Checkpoint written = ck;  // as load_checkpoint will read it back
    written.centroids = st.centroids();
    written.next_id = st.next_id();
    validate_checkpoint(written, in, path);
  });
  h5::Writer w(path, kGaCheckpointFormat, kCheckpointVersion);
  w.attr("/", "scene_id", in.hitpoints->scene_id);
  w.attr("/", "hitpoints_sha256", hp_hash);
  w.attr("/", "inputs_sha256", id);
  w.attr("/", "fitness", ga_fitness_name(opt.fitness));
  w.attr("/", "seed", int64_t(opt.seed));
  w.attr("/", "population", int64_t(opt.population));
  w.attr("/", "wg_size", int64_t(in.wg_size));
  w.attr("/", "generations", int64_t(ck.generations));
  w.attr("/", "next_id", int64_t(st.next_id()));
  w.attr("/", "best_fitness", ck.fitness);
  w.attr("/", "start_fitness", ck.start_fitness);
  w.attr("/", "evaluations", int64_t(ck.evaluations));
  w.attr("/", "seconds", ck.seconds);
  w.write("/centroids", h5_type_centroid(), st.centroids());
  w.describe("/centroids", "world units", "the parent chromosome: centroids per mesh in order");
  w.write("/best_fitness", ck.history);
  w.describe("/best_fitness", ga_fitness_unit(opt.fitness), "best fitness after each generation");
  write_provenance(w, checkpoint_provenance(in, opt, call_seconds));
  w.commit();
}

Checkpoint load_checkpoint(const std::string& path, const GaFitnessInputs& in, const GaOptions& opt,
                           const std::string& hp_hash, const std::string& id) {
  h5::Reader r(path, kGaCheckpointFormat, kCheckpointVersion);
  const std::string hint = "delete it, or rerun with the options and inputs of that run";
  if (r.scene_id() != in.hitpoints->scene_id)
    throw input_error(path, "is a checkpoint of another scene", hint);
  if (r.attr_string("/", "hitpoints_sha256") != hp_hash)
    throw input_error(path, "is a checkpoint for other hitpoints", hint);
  if (r.attr_string("/", "fitness") != ga_fitness_name(opt.fitness) ||
      r.attr_int("/", "seed") != int64_t(opt.seed) ||
      r.attr_int("/", "population") != int64_t(opt.population) ||
      r.attr_int("/", "wg_size") != int64_t(in.wg_size))
    throw input_error(path, "is a checkpoint of a run with another fitness, seed, population or work-group size (" +
                                r.attr_string("/", "fitness") + ", seed " +
                                std::to_string(r.attr_int("/", "seed")) + ", population " +
                                std::to_string(r.attr_int("/", "population")) + ", wg " +
                                std::to_string(r.attr_int("/", "wg_size")) + ")", hint);
  if (r.attr_string("/", "inputs_sha256") != id)
    throw input_error(path, "is a checkpoint made with another photon distribution (or photons)", hint);
  Checkpoint ck;
  ck.centroids = r.read<GaCentroid>("/centroids", h5_type_centroid());
  ck.history = r.read<double>("/best_fitness");
  ck.next_id = uint32_t(r.attr_int("/", "next_id"));
  ck.generations = int(r.attr_int("/", "generations"));
  ck.fitness = r.attr_double("/", "best_fitness");
  ck.start_fitness = r.attr_double("/", "start_fitness");
  ck.evaluations = uint64_t(r.attr_int("/", "evaluations"));
  ck.seconds = r.attr_double("/", "seconds");
  v_evaluations_in_range(r, path);
  validate_checkpoint(ck, in, path);
  const int64_t next_id = r.attr_int("/", "next_id");
  if (next_id < 0 || next_id > int64_t(UINT32_MAX))
    throw input_error(path, "next_id " + std::to_string(next_id) + " is outside [0, 2^32)",
                      "the file is damaged; delete it and rerun");
  // A resumed run continues to opt.iterations; its record must not claim fewer iterations than
  // the checkpoint has already run (generations = iterations + 1 when finished).
  if (ck.generations > opt.iterations + 1)
    throw input_error(path, "has already run " + std::to_string(ck.generations - 1) +
                                " iterations, more than --ga-iterations " +
                                std::to_string(opt.iterations),
                      "resume with --ga-iterations " + std::to_string(ck.generations - 1) +
                          " or more, or delete it to start over");
  return ck;
}

}  // namespace pf::ga
