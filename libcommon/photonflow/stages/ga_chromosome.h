// ga_chromosome.h — the representation behind GaState (ga_clusters.h): centroid slots, the
// per-mesh centroid grids, the undo log, and ga::Chromosome, which keeps every hitpoint at its
// nearest centroid while mutations add and remove centroids. Private to the sources that
// implement GaState:
//   ga_chromosome.cpp     setup, the structural mutations (add / remove a centroid), evaluation;
//   ga_centroid_grid.cpp  the grid over a mesh's centroids (the nearest one, those near a point);
//   ga_undo.cpp           the logged primitive edits, commit and undo;
//   ga_mutations.cpp      the mutations of ch. 8.1 built from the structural ones;
//   ga_clusters.cpp       GaState itself and the clusters a chromosome gives.
#pragma once
#include <algorithm>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "photonflow/stages/ga_internal.h"

namespace pf::ga {

// One centroid of the chromosome and its cluster; slots are never reused (ga_undo.cpp, alloc).
struct Slot {
  float c[3] = {0, 0, 0};  // centroid
  int32_t mesh = 0;
  uint32_t id = 0;
  std::vector<int32_t> members;  // ascending hitpoint indices
  double maxd = 0;               // ≥ max |member − centroid| (exact after evaluate)
  int64_t term = 0;              // fitness term as last evaluated
  float centre[3] = {0, 0, 0};   // cluster centre (mean) and shared radius, as last evaluated
  float radius = 0;
  bool alive = false;
  int32_t pos = -1;   // index in its mesh's alive list
  int32_t cell = -1;  // cell of the centroid grid
  uint32_t epoch = 0; // last epoch it was touched in
};

// A mesh's live centroids, the box of its hitpoints and the uniform grid over its centroids.
struct CentroidMesh {
  float lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};  // box of the mesh's hitpoints
  float s = 1;                                  // centroid-grid cell size
  int n[3] = {1, 1, 1};
  std::vector<std::vector<int32_t>> cells;
  std::vector<int32_t> alive;  // slots of live centroids
  int32_t hitpoints = 0;
  double maxd_bound = 0;       // ≥ every live slot's maxd (exact after a commit)
};

// The grid of CentroidMesh (ga_centroid_grid.cpp).
// Sizes mesh m's centroid grid for k centroids (about two per cell) and empties it.
void setup_centroid_grid(CentroidMesh& m, size_t k);
// The grid cell of point p.
int centroid_cell(const CentroidMesh& m, const float* p);
// The slots of mesh m whose grid cells meet the box c ± r (a superset of the centroids within r
// of c; the margin covers the rounding of the box to float).
void centroids_within(const CentroidMesh& m, const float c[3], double r, std::vector<int32_t>& out);
// The slot of mesh m's centroid nearest to p other than `exclude` (grid search; ties to the lower
// id), -1 when there is none.
int32_t nearest_centroid(const CentroidMesh& m, const std::vector<Slot>& slots, const float* p,
                         int32_t exclude);

// The undo log of a chromosome: every primitive edit since the last commit with what undoes it,
// the touched slots' evaluated values, and the score and next id at the last commit
// (ga_undo.cpp).
struct UndoLog {
  enum Op : uint8_t {
    kAssign, kMemberInsert, kMemberErase, kGridInsert, kGridErase, kAliveAdd, kAliveRemove,
    kAllocFresh
  };
  struct LogEntry {
    Op op;
    int32_t a, b;
  };
  struct SlotCache {
    int32_t slot;
    int64_t term;
    double maxd;
    float centre[3];
    float radius;
  };

  std::vector<LogEntry> log;
  std::vector<SlotCache> caches;
  std::vector<int32_t> touched;
  uint32_t epoch = 1;
  uint32_t saved_next_id = 0;
  int64_t saved_score = 0;
};

// A chromosome with its clusters and fitness, mutated in place with undo (ga_clusters.h's file
// comment: the incremental evaluation).
struct Chromosome : UndoLog {
  using Mesh = CentroidMesh;
  // Shared, read-only between copies.
  struct Shared {
    const HitpointSet* h = nullptr;
    std::vector<float> pos;      // hitpoint positions, xyz
    std::vector<int32_t> mesh;   // hitpoint meshes
    float r0 = 0;
    std::string hitpoints_sha256;  // hitpoints_hash(*h), once
    DistributionSums sums;
  };

  std::shared_ptr<const Shared> sh;
  GaFitness f = GaFitness::Filler;
  int wg = 64;
  TermCalc calc;
  std::vector<Slot> slots;
  std::vector<int32_t> assign;  // hitpoint → slot
  std::vector<Mesh> meshes;
  uint32_t next_id = 0;
  int64_t score = 0;
  std::vector<int32_t> scratch, scratch2, cand;  // work lists of add/remove (not state)

  Chromosome() = default;
  Chromosome(const Chromosome& o) { *this = o; }
  Chromosome& operator=(const Chromosome& o) {
    sh = o.sh;
    f = o.f;
    wg = o.wg;
    calc = o.calc;
    calc.sums = &sh->sums;
    slots = o.slots;
    assign = o.assign;
    meshes = o.meshes;
    next_id = o.next_id;
    score = o.score;
    log = o.log;
    caches = o.caches;
    touched = o.touched;
    epoch = o.epoch;
    saved_next_id = o.saved_next_id;
    saved_score = o.saved_score;
    return *this;
  }

  const float* hp(int32_t i) const { return &sh->pos[3 * size_t(i)]; }

  // ---- setup (ga_chromosome.cpp) ----
  void setup(const GaFitnessInputs& in, GaFitness fit);
  // Builds the state from centroids (per mesh in the given order): every hitpoint to its nearest
  // centroid, centroids without hitpoints dropped, every cluster evaluated.
  void build(const std::vector<GaCentroid>& cs, uint32_t nid);

  // ---- the centroid grids (ga_centroid_grid.cpp) ----
  void setup_grid(Mesh& m, size_t k) { setup_centroid_grid(m, k); }
  int cell_of(const Mesh& m, const float* p) const { return centroid_cell(m, p); }
  void within(int mesh, const float c[3], double r, std::vector<int32_t>& out) const {
    centroids_within(meshes[size_t(mesh)], c, r, out);
  }
  int32_t nearest(int mesh, const float* p, int32_t exclude) const {
    return nearest_centroid(meshes[size_t(mesh)], slots, p, exclude);
  }

  void clamp_to_mesh(int mesh, float* p) const {
    const Mesh& m = meshes[size_t(mesh)];
    for (int a = 0; a < 3; ++a) p[a] = std::clamp(p[a], m.lo[a], m.hi[a]);
  }

  // ---- logged primitive operations (ga_undo.cpp) ----
  void touch(int32_t k);
  void grid_insert(int32_t k);
  void grid_remove(int32_t k);
  void grid_erase(int32_t k);
  void alive_add(int32_t k);
  void alive_remove(int32_t k);
  // A new slot. Slots are never reused (a dead slot keeps its position and cell, which the undo
  // of its removal needs); a run creates a few per generation.
  int32_t alloc();
  void move_hitpoint(int32_t i, int32_t to);
  // A new centroid (no members yet).
  int32_t create(int mesh, const float pos[3]);
  // Drops a centroid without members.
  void destroy(int32_t k, bool in_grid);
  // Keeps the changes since the last commit / undo, or reverts them exactly.
  void commit();
  void undo();

  // ---- the structural mutations (ga_chromosome.cpp; each keeps: every hitpoint at its nearest
  // centroid) ----
  // Adds a centroid at pos on `mesh`: it takes over the hitpoints nearer to it than to their own.
  bool add_centroid(int mesh, const float pos[3]);
  // Removes a centroid: its hitpoints go to their nearest remaining centroid. Never the last one
  // of a mesh.
  bool remove_centroid(int32_t k);
  // Re-evaluates the touched clusters; returns the (integer) fitness score.
  int64_t evaluate();

  size_t live_count() const {
    size_t n = 0;
    for (const Mesh& m : meshes) n += m.alive.size();
    return n;
  }
  bool alive_with_id(int32_t k, uint32_t id) const {
    return slots[size_t(k)].alive && slots[size_t(k)].id == id;
  }
};

// ---- the mutations of ch. 8.1 (ga_mutations.cpp) ----
// A live centroid chosen uniformly.
int32_t random_slot(const Chromosome& st, pf_rng& rng);
// One mutation with random numbers from `rng`; false when it changed nothing.
bool mutate(Chromosome& st, GaState::Mutation mu, pf_rng& rng);
// The mutations of one child (merge, then move, remove and add with their probabilities).
bool mutate_child(Chromosome& st, pf_rng& rng);

}  // namespace pf::ga
