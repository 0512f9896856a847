// ga_clusters.h — evolutionary (genetic-algorithm) clustering of hitpoints, thesis ch. 8: `cluster
// --method ga`. Finds work-group clusters (clusters.h) that make the clustered grid gather
// (grid-kmeans, kernels/illuminate_methods.cl gather_grid_clusters) faster than k-means's.
//
// Chromosome (ch. 8.1): a set of centroids per mesh; every hitpoint belongs to the nearest centroid
// of its own mesh (squared distance in double, ties to the lower centroid id); a centroid that gets
// no hitpoint is dropped. The clusters written are those groups with centre = mean of the members
// and the shared radius of clusters.h (cluster_centre_radius), padded with fillers.
//
// Evolution (ch. 8.1, "Evolution configuration"): 1+λ, mutation only. Generation 0 is the
// initial population: the k-means clustering (cluster_kmeans; its cluster centres become the
// centroids) and population − 1 mutants of it; every later generation makes population − 1
// mutants of the parent, and the best of parent and children (lowest fitness; on equal fitness the
// lowest-numbered child, which replaces the parent) becomes the next parent. The parent is never
// replaced by a worse candidate, so the fitness never rises from generation to generation (for the
// CPU fitnesses, which are exact; device-time below).
//
// A child's mutations (ch. 8.1), in this order:
//   1. merge: pick a cluster A at random and the cluster B whose centroid is nearest to A's; with
//      s = |A| + |B|: merge if s < wg_size, never if s > 2·wg_size, otherwise with probability
//      (2·wg_size − s)/wg_size (falling from 1 to 0 as s nears 2·wg_size). The merged centroid is
//      the mean of all their hitpoints.
//   2. move (probability kGaMoveProbability, "rarely"): a random centroid moves by a uniform offset
//      within the box ±R of its cluster (R its shared radius), clamped to the mesh's hitpoint box.
//   3. remove (probability 1/2): 1–5 centroids; each is the smaller (fewer hitpoints) of two
//      clusters picked at random, so small clusters are removed more often; the last centroid of a
//      mesh is never removed.
//   4. add (probability 1/2): 1–5 centroids, each at a random hitpoint's position plus a uniform
//      offset within ±R0 (the hitpoints' initial radius), on that hitpoint's mesh.
// Random numbers: the counter-based generator of rng.h, stream (seed, generation, child), so the
// result depends on the inputs, the options and the seed only — not on the thread count (children
// are evaluated in parallel, each on its own copy of the parent).
//
// Fitness (to minimise; ch. 8.2, 8.3):
//   filler         eq. 8.1: Σ_c filler_hitpoints(c) = Σ (padded_count − count);
//   grid-bins      eq. 8.2: Σ_c bins(c)·workgroups(c), bins(c) = the grid bins the cluster's
//                  work-groups read: the box centre ± R·1.0001² of the photon grid (eq. 7.1), as
//                  gather_grid_clusters reads it (rows of bins); workgroups(c) = padded_count/wg;
//   memory-access  eq. 8.3: Σ_c workgroups(c)·Σ_{x∈bins(c)} photons_distribution(x)/wg_size, with
//                  the averaged photon-distribution map of photon_distribution.h;
//   work           (this project's, beyond the thesis) Σ_c count(c)·Σ_{x∈bins(c)}
//                  photons_distribution(x): photons read by the real work-items only. A device that
//                  runs a work-group's work-items as a loop (PoCL, CPUs) retires a filler at once,
//                  so it pays per hitpoint, not per padded slot;
//   device-time    the gather kernel of grid-kmeans (gather_grid_clusters) with the candidate's
//                  clusters on an OpenCL device, best of device_runs runs, in microseconds: what
//                  ppm_pass reports as GatherTimes::gather, measured by cl_gather.h's
//                  GridGatherTimer, which builds the photons' grid once per evolution. Noisy: not reproducible from the seed alone, and the
//                  parent is timed again in every generation together with its children (its
//                  older measurement is dropped), so "never worse" holds between measurements of
//                  one generation only.
// The CPU fitnesses are integers internally (photon counts summed over the map's passes), so the
// incremental evaluation (below) equals a full recomputation exactly.
//
// Incremental evaluation (the thesis's slowest step was re-sorting every hitpoint into clusters at
// every evaluation, ch. 8.4): a mutation changes only the clusters it touches. Removing a centroid
// moves just its hitpoints to their nearest remaining centroid (a uniform grid over the centroids);
// adding one takes over only hitpoints of clusters whose centroid lies within twice their farthest
// member (the only ones that can be nearer to it); merge and move are add + removes. Only touched
// clusters are re-evaluated; a child is evaluated and undone in place (an undo log), the chosen
// child is replayed on every thread's copy.
#pragma once
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "photonflow/stages/clusters.h"
#include "photonflow/stages/photon_distribution.h"
#include "photonflow/foundations/progress.h"
#include "photonflow/foundations/rng.h"
#include "photonflow/io/stage_files.h"

namespace pf {

class ClContext;
struct Scene;

constexpr const char* kGaCheckpointFormat = "photonflow.ga_checkpoint";

// Probability of mutation 2 (move) per child ("performed with low probability", ch. 8.1).
constexpr float kGaMoveProbability = 0.1f;
// Probability of mutations 3 and 4 (remove, add) per child, and the most centroids each changes.
constexpr float kGaRemoveProbability = 0.5f;
constexpr float kGaAddProbability = 0.5f;
constexpr int kGaMaxRemoveAdd = 5;

enum class GaFitness { Filler, GridBins, MemoryAccess, Work, DeviceTime };

const char* ga_fitness_name(GaFitness f);
// "filler | grid-bins | memory-access | work | device-time"; InputError listing them otherwise.
GaFitness parse_ga_fitness(const std::string& name);
std::string ga_fitness_choices();
// True for the fitnesses that read the photon-distribution map.
bool ga_fitness_needs_distribution(GaFitness f);
// Unit of a fitness value ("filler hitpoints", "bins x work-groups", ...), for output.
const char* ga_fitness_unit(GaFitness f);

// What the fitness functions read.
struct GaFitnessInputs {
  const HitpointSet* hitpoints = nullptr;            // the eye pass's hitpoints (R = R0)
  int wg_size = 64;                                  // work-group size of the clusters
  const PhotonDistribution* distribution = nullptr;  // grid-bins, memory-access, work
  // device-time: one photon pass and the device.
  const Scene* scene = nullptr;
  const std::vector<pf_photon>* photons = nullptr;
  uint64_t emitted = 0;
  int max_bins = 64;       // the gather's photon-grid bins (PpmOptions::max_bins)
  ClContext* device = nullptr;
  int device_runs = 5;     // best of
};

// Fitness of any clustering of in.hitpoints (k-means, grid or GA clusters), computed from scratch
// from its clusters' centres and radii (the definitions above).
double cluster_fitness(const ClusterSet& c, const GaFitnessInputs& in, GaFitness f);

// One centroid of a chromosome (checkpoints, tests).
struct GaCentroid {
  float position[3];
  int32_t mesh;
  uint32_t id;  // ties of the nearest-centroid rule go to the lower id; new centroids get new ids
};

// A chromosome with its clusters and fitness, mutated in place with undo (see the file comment).
class GaState {
 public:
  enum class Mutation { Merge, Move, Remove, Add };

  // The chromosome whose centroids are the centres of `start`'s clusters (k-means), each hitpoint
  // assigned to its nearest one. For device-time the state tracks fillers; the caller measures.
  GaState(const GaFitnessInputs& in, GaFitness f, const ClusterSet& start);
  // A chromosome from centroids (a checkpoint): per mesh in the given order, ids kept.
  GaState(const GaFitnessInputs& in, GaFitness f, const std::vector<GaCentroid>& centroids,
          uint32_t next_id);
  GaState(const GaState& o);
  GaState& operator=(const GaState& o);
  ~GaState();

  // Applies one mutation with random numbers from `rng`; false when it changed nothing (e.g. the
  // merge rule said no). The clusters it touched are re-evaluated by evaluate().
  bool mutate(Mutation m, pf_rng& rng);
  // The mutations of one child (merge, then move, remove and add with their probabilities).
  bool mutate_child(pf_rng& rng);
  // Re-evaluates the touched clusters; returns the (integer) fitness score of the state.
  int64_t evaluate();
  // Keeps the changes since the last commit / undo, or reverts them exactly.
  void commit();
  void undo();

  int64_t score() const;                 // integer fitness after evaluate()
  double fitness() const;                // score in the fitness's unit (score × scale)
  double scale() const;
  size_t cluster_count() const;

  // The clusters (method "ga"): per mesh ascending, clusters ordered by their lowest hitpoint.
  ClusterSet clusters() const;
  // The same chromosome evaluated from scratch: every hitpoint assigned to its nearest centroid by
  // brute force, every cluster's fitness term computed anew (tests: equals the incremental state).
  ClusterSet full_clusters() const;
  int64_t full_score() const;
  std::vector<GaCentroid> centroids() const;  // per mesh, in the state's order
  uint32_t next_id() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> p_;
};

struct GaOptions {
  GaFitness fitness = GaFitness::MemoryAccess;
  int population = 50;       // parent + (population − 1) children per generation (ch. 8.1)
  int iterations = 3000;     // generations after the initial population (ch. 8.1)
  uint32_t seed = 1;
  int kmeans_iterations = 10;  // Lloyd steps of the k-means start
  int threads = 0;             // 0 = all cores; results do not depend on it
  std::string checkpoint;      // checkpoint file ("" = none), written atomically
  int checkpoint_every = 50;   // generations between checkpoints (and after the last)
  // Continue from `checkpoint` when it exists. A checkpoint that has done more generations than
  // iterations + 1 is refused (InputError): the record would say fewer iterations than were run.
  bool resume = false;
  // The run's provenance (tool, parameters, seed, command line, inputs), written as /provenance
  // of every checkpoint with wall_time_s = its own wall_time_s (the caller's seconds before this
  // call) + the seconds of this call so far. nullptr: tool "cluster", the seed and the GA's
  // parameters, no inputs.
  const Provenance* provenance = nullptr;
};

struct GaProgress {
  int generation = 0;     // generations done (0 … iterations + 1, the initial population counts)
  int total = 0;          // iterations + 1
  double best = 0;        // best fitness so far
  double seconds = 0;     // since this call started
  int resumed_from = 0;   // generations already done when this call started
};

struct GaResult {
  ClusterSet clusters;            // method "ga"
  double fitness = 0;             // of `clusters`
  double start_fitness = 0;       // of the k-means chromosome (generation 0's parent)
  double kmeans_fitness = 0;      // of cluster_kmeans's own clusters
  std::vector<double> history;    // best fitness after each generation; [0] = initial population
  int generations = 0;            // generations done (history.size())
  int resumed_from = 0;           // 0 unless resumed from a checkpoint
  bool interrupted = false;       // on_generation asked to stop: checkpoint written, no result
  uint64_t evaluations = 0;       // children evaluated (this call and, resumed, before)
  double seconds = 0;             // evolution time (this call and, resumed, before)
};

// Runs the evolution. `on_generation` (optional) is called after every generation; returning
// false stops the run after writing the checkpoint (interrupted = true). InputError for a
// checkpoint of another run (other hitpoints, scene, distribution, fitness, seed, population or
// work-group size) and for missing fitness inputs.
GaResult evolve_clusters(const GaFitnessInputs& in, const GaOptions& opt,
                         const std::function<bool(const GaProgress&)>& on_generation = {});

// Writes the GA's record into an open clusters.h5 (save_clusters' `extra`): group /ga with
// attributes fitness, seed, population, iterations, generations, best_fitness, start_fitness,
// kmeans_fitness, evaluations, seconds, and dataset /ga/best_fitness (one per generation).
void write_ga_record(h5::Writer& w, const GaResult& r, const GaOptions& opt);

// One line on a terminal (stderr, only when it is a TTY): generation, best fitness, ETA.
class GaProgressLine {
 public:
  explicit GaProgressLine(std::string unit);
  void update(const GaProgress& p);
  void end_line() { line_.end_line(); }  // a line left open by an interrupted run

 private:
  std::string unit_;
  TerminalLine line_;
  double last_ = -1;
};

}  // namespace pf
