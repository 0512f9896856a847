// ga_clusters.cpp — evolutionary clustering of hitpoints (thesis ch. 8), see ga_clusters.h.
#include "photonflow/stages/ga_clusters.h"

#include "photonflow/stages/ga_internal.h"

#include <omp.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cfloat>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <cstring>
#include <exception>
#include <limits>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <thread>

#include "photonflow/opencl/cl_backend.h"
#include "photonflow/opencl/cl_gather.h"
#include "photonflow/io/h5io.h"
#include "photonflow/foundations/hash.h"
#include "photonflow/foundations/interrupt.h"
#include "photonflow/io/provenance.h"
#include "photonflow/foundations/threads.h"
#include "photonflow/io/validate.h"

namespace pf {

// ---- fitness names ------------------------------------------------------------------------------

namespace {
struct FitnessInfo {
  GaFitness f;
  const char* name;
  const char* unit;
};
const FitnessInfo kFitness[] = {
    {GaFitness::Filler, "filler", "filler hitpoints (eq. 8.1)"},
    {GaFitness::GridBins, "grid-bins", "bins x work-groups (eq. 8.2)"},
    {GaFitness::MemoryAccess, "memory-access", "photons per work-item x work-groups (eq. 8.3)"},
    {GaFitness::Work, "work", "photons read by hitpoints per pass"},
    {GaFitness::DeviceTime, "device-time", "us of the gather kernel (best of runs)"},
};
}  // namespace

const char* ga_fitness_name(GaFitness f) {
  for (const FitnessInfo& i : kFitness)
    if (i.f == f) return i.name;
  return "?";
}
const char* ga_fitness_unit(GaFitness f) {
  for (const FitnessInfo& i : kFitness)
    if (i.f == f) return i.unit;
  return "?";
}
std::string ga_fitness_choices() {
  std::string s;
  for (const FitnessInfo& i : kFitness) s += std::string(s.empty() ? "" : " | ") + i.name;
  return s;
}
GaFitness parse_ga_fitness(const std::string& name) {
  for (const FitnessInfo& i : kFitness)
    if (name == i.name) return i.f;
  throw input_error("", "--fitness must be one of " + ga_fitness_choices() + ", got '" + name + "'");
}
bool ga_fitness_needs_distribution(GaFitness f) {
  return f == GaFitness::GridBins || f == GaFitness::MemoryAccess || f == GaFitness::Work;
}

// ---- per-cluster fitness terms ------------------------------------------------------------------

namespace {

inline double dist2(const float* a, const float* b) {
  const double dx = double(a[0]) - double(b[0]), dy = double(a[1]) - double(b[1]),
               dz = double(a[2]) - double(b[2]);
  return dx * dx + dy * dy + dz * dz;
}

// The integer fitness term of one cluster (eq. 8.1–8.3, work), and the scale to the fitness unit.
struct TermCalc {
  GaFitness f = GaFitness::Filler;
  int64_t wg = 64;
  const DistributionSums* sums = nullptr;

  int64_t term(int mesh, const float centre[3], float radius, int64_t count) const {
    const int64_t groups = (count + wg - 1) / wg;  // workgroups(c)
    if (f == GaFitness::Filler || f == GaFitness::DeviceTime) return groups * wg - count;  // eq. 8.1
    int lo[3], hi[3];
    if (!sums->box(mesh, centre, radius, lo, hi)) return 0;  // a mesh without photons: no reads
    if (f == GaFitness::GridBins)  // eq. 8.2: bins(c)·workgroups(c)
      return int64_t(hi[0] - lo[0] + 1) * (hi[1] - lo[1] + 1) * (hi[2] - lo[2] + 1) * groups;
    const int64_t photons = int64_t(sums->photons(mesh, lo, hi));  // Σ over passes
    if (f == GaFitness::MemoryAccess) return photons * groups;  // eq. 8.3, × passes·wg_size
    return photons * count;                                    // work, × passes
  }
  double scale() const {
    const double passes = sums && sums->map() ? double(sums->map()->passes) : 1.0;
    if (f == GaFitness::MemoryAccess) return 1.0 / (passes * double(wg));
    if (f == GaFitness::Work) return 1.0 / passes;
    return 1.0;
  }
};

}  // namespace

namespace ga {

// The device-time fitness: the grid-cluster gather's kernel time in us, best of in.device_runs,
// on a timer that holds the photons' grid (built once per timer, cl_gather.h).
GridGatherTimer device_timer(const GaFitnessInputs& in) {
  if (!in.device || !in.scene || !in.photons)
    throw std::invalid_argument("device-time fitness needs a device, the scene and photons");
  PpmOptions opt;
  opt.method = GatherMethod::GridKmeans;
  opt.max_bins = in.max_bins;
  return GridGatherTimer(*in.scene, *in.hitpoints, *in.photons, opt, *in.device);
}

double measure_device_us(GridGatherTimer& timer, const ClusterSet& c, const GaFitnessInputs& in) {
  return timer.time(c, std::max(1, in.device_runs)) * 1e6;
}

void check_inputs(const GaFitnessInputs& in, GaFitness f) {
  if (!in.hitpoints) throw std::invalid_argument("ga: no hitpoints");
  if (in.wg_size < 1) throw std::invalid_argument("ga: work-group size must be >= 1");
  if (ga_fitness_needs_distribution(f) && !in.distribution)
    throw input_error("", std::string("--fitness ") + ga_fitness_name(f) +
                              " needs a photon-distribution map", "pass --distribution (photon-distribution makes it)");
  if (f == GaFitness::DeviceTime && (!in.device || !in.scene || !in.photons))
    throw input_error("", "--fitness device-time needs an OpenCL device and photons",
                      "pass --device opencl and --photons");
}

}  // namespace ga

using ga::check_inputs;
using ga::device_timer;
using ga::measure_device_us;

double cluster_fitness(const ClusterSet& c, const GaFitnessInputs& in, GaFitness f) {
  check_inputs(in, f);
  if (f == GaFitness::DeviceTime) {
    GridGatherTimer timer = device_timer(in);
    return measure_device_us(timer, c, in);
  }
  DistributionSums sums;
  if (ga_fitness_needs_distribution(f)) sums = DistributionSums(*in.distribution);
  TermCalc calc{f, c.wg_size, &sums};
  int64_t s = 0;
  for (const pf_cluster& cl : c.clusters) s += calc.term(cl.mesh, cl.centre, cl.radius, cl.count);
  return double(s) * calc.scale();
}

// ---- the chromosome -----------------------------------------------------------------------------

struct GaState::Impl {
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
  struct SlotCache {
    int32_t slot;
    int64_t term;
    double maxd;
    float centre[3];
    float radius;
  };
  struct Mesh {
    float lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};  // box of the mesh's hitpoints
    float s = 1;                                  // centroid-grid cell size
    int n[3] = {1, 1, 1};
    std::vector<std::vector<int32_t>> cells;
    std::vector<int32_t> alive;  // slots of live centroids
    int32_t hitpoints = 0;
    double maxd_bound = 0;       // ≥ every live slot's maxd (exact after a commit)
  };
  enum Op : uint8_t {
    kAssign, kMemberInsert, kMemberErase, kGridInsert, kGridErase, kAliveAdd, kAliveRemove,
    kAllocFresh
  };
  struct LogEntry {
    Op op;
    int32_t a, b;
  };
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
  // undo
  std::vector<LogEntry> log;
  std::vector<SlotCache> caches;
  std::vector<int32_t> touched;
  uint32_t epoch = 1;
  uint32_t saved_next_id = 0;
  int64_t saved_score = 0;
  std::vector<int32_t> scratch, scratch2, cand;  // work lists of add/remove (not state)

  Impl() = default;
  Impl(const Impl& o) { *this = o; }
  Impl& operator=(const Impl& o) {
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

  // ---- setup ----
  void setup(const GaFitnessInputs& in, GaFitness fit) {
    check_inputs(in, fit);
    auto s = std::make_shared<Shared>();
    s->h = in.hitpoints;
    const HitpointSet& h = *in.hitpoints;
    s->pos.resize(3 * h.hitpoints.size());
    s->mesh.resize(h.hitpoints.size());
    int mesh_count = 0;
    for (size_t i = 0; i < h.hitpoints.size(); ++i) {
      const pf_hitpoint& p = h.hitpoints[i];
      if (p.mesh < 0) throw std::invalid_argument("ga: a hitpoint without mesh");
      for (int a = 0; a < 3; ++a) {
        if (!std::isfinite(p.position[a])) throw std::invalid_argument("ga: non-finite hitpoint");
        s->pos[3 * i + size_t(a)] = p.position[a];
      }
      s->mesh[i] = p.mesh;
      mesh_count = std::max(mesh_count, p.mesh + 1);
    }
    s->r0 = h.radius0 > 0.f ? h.radius0 : 1e-3f;
    s->hitpoints_sha256 = hitpoints_hash(h);
    if (ga_fitness_needs_distribution(fit)) s->sums = DistributionSums(*in.distribution);
    sh = s;
    f = fit;
    wg = in.wg_size;
    calc = TermCalc{fit, wg, &sh->sums};
    meshes.assign(size_t(mesh_count), Mesh{});
    for (Mesh& m : meshes)
      for (int a = 0; a < 3; ++a) {
        m.lo[a] = INFINITY;
        m.hi[a] = -INFINITY;
      }
    for (size_t i = 0; i < h.hitpoints.size(); ++i) {
      Mesh& m = meshes[size_t(sh->mesh[i])];
      ++m.hitpoints;
      for (int a = 0; a < 3; ++a) {
        m.lo[a] = std::min(m.lo[a], hp(int32_t(i))[a]);
        m.hi[a] = std::max(m.hi[a], hp(int32_t(i))[a]);
      }
    }
    assign.assign(h.hitpoints.size(), -1);
  }

  // Centroid grid of mesh m sized for k centroids (about two per cell).
  void setup_grid(Mesh& m, size_t k) {
    if (m.hitpoints == 0) return;
    float ext[3];
    for (int a = 0; a < 3; ++a) ext[a] = m.hi[a] - m.lo[a];
    const float longest = std::max(ext[0], std::max(ext[1], ext[2]));
    const double target = std::max(1.0, double(k) / 2.0);
    auto cells = [&](float sz) {
      double c = 1;
      for (int a = 0; a < 3; ++a) c *= std::clamp(std::ceil(double(ext[a]) / sz), 1.0, 256.0);
      return c;
    };
    m.s = longest > 0.f ? longest : 1.f;
    while (longest > 0.f && cells(m.s) < target && m.s > longest * 1e-3f) m.s *= 0.8f;
    for (int a = 0; a < 3; ++a) m.n[a] = std::clamp(int(std::ceil(ext[a] / m.s)), 1, 256);
    m.cells.assign(size_t(m.n[0]) * size_t(m.n[1]) * size_t(m.n[2]), {});
  }

  int cell_of(const Mesh& m, const float* p) const {
    return pf_grid_coord(p[0], m.lo[0], m.s, m.n[0]) +
           (pf_grid_coord(p[1], m.lo[1], m.s, m.n[1]) +
            pf_grid_coord(p[2], m.lo[2], m.s, m.n[2]) * m.n[1]) * m.n[0];
  }

  void clamp_to_mesh(int mesh, float* p) const {
    const Mesh& m = meshes[size_t(mesh)];
    for (int a = 0; a < 3; ++a) p[a] = std::clamp(p[a], m.lo[a], m.hi[a]);
  }

  // Builds the state from centroids (per mesh in the given order): every hitpoint to its nearest
  // centroid, centroids without hitpoints dropped, every cluster evaluated.
  void build(const std::vector<GaCentroid>& cs, uint32_t nid) {
    std::vector<size_t> per_mesh(meshes.size(), 0);
    for (const GaCentroid& c : cs) {
      if (c.mesh < 0 || size_t(c.mesh) >= meshes.size() || meshes[size_t(c.mesh)].hitpoints == 0)
        throw std::invalid_argument("ga: a centroid on a mesh without hitpoints");
      ++per_mesh[size_t(c.mesh)];
    }
    for (size_t m = 0; m < meshes.size(); ++m) {
      if (meshes[m].hitpoints > 0 && per_mesh[m] == 0)
        throw std::invalid_argument("ga: mesh " + std::to_string(m) + " has hitpoints but no centroid");
      setup_grid(meshes[m], per_mesh[m]);
    }
    slots.clear();
    next_id = nid;
    for (const GaCentroid& c : cs) {
      Slot s;
      for (int a = 0; a < 3; ++a) s.c[a] = c.position[a];
      clamp_to_mesh(c.mesh, s.c);
      s.mesh = c.mesh;
      s.id = c.id;
      if (c.id >= next_id) next_id = c.id + 1;
      s.alive = true;
      Mesh& m = meshes[size_t(c.mesh)];
      s.cell = cell_of(m, s.c);
      m.cells[size_t(s.cell)].push_back(int32_t(slots.size()));
      slots.push_back(std::move(s));
    }
    for (size_t i = 0; i < assign.size(); ++i) {
      const int32_t k = nearest(sh->mesh[i], hp(int32_t(i)), -1);
      assign[i] = k;
      slots[size_t(k)].members.push_back(int32_t(i));  // ascending: i ascends
    }
    // Live list per mesh in the given order, without the empty centroids.
    for (Mesh& m : meshes)
      for (auto& cell : m.cells) cell.clear();
    for (size_t k = 0; k < slots.size(); ++k) {
      Slot& s = slots[k];
      Mesh& m = meshes[size_t(s.mesh)];
      if (s.members.empty()) {
        s.alive = false;
        continue;
      }
      s.pos = int32_t(m.alive.size());
      m.alive.push_back(int32_t(k));
      m.cells[size_t(s.cell)].push_back(int32_t(k));
    }
    score = 0;
    for (size_t k = 0; k < slots.size(); ++k)
      if (slots[k].alive) touch(int32_t(k));
    evaluate();
    commit();
  }

  // The slots of mesh m whose grid cells meet the box c ± r (a superset of the centroids within r
  // of c; the margin covers the rounding of the box to float).
  void within(int mesh, const float c[3], double r, std::vector<int32_t>& out) const {
    const Mesh& m = meshes[size_t(mesh)];
    int lo[3], hi[3];
    for (int a = 0; a < 3; ++a) {
      const double pad = r + 1e-4 * double(m.s) + 1e-6 * std::fabs(double(c[a]));
      lo[a] = pf_grid_coord(float(double(c[a]) - pad), m.lo[a], m.s, m.n[a]);
      hi[a] = pf_grid_coord(float(double(c[a]) + pad), m.lo[a], m.s, m.n[a]);
    }
    out.clear();
    for (int z = lo[2]; z <= hi[2]; ++z)
      for (int y = lo[1]; y <= hi[1]; ++y)
        for (int x = lo[0]; x <= hi[0]; ++x) {
          const auto& cell = m.cells[size_t(x + (y + z * m.n[1]) * m.n[0])];
          out.insert(out.end(), cell.begin(), cell.end());
        }
  }

  // ---- nearest centroid (grid search; ties to the lower id) ----
  // The first candidate is taken whatever its distance (here and in the brute-force loops below),
  // so that no comparison with an infinite or NaN distance can leave a hitpoint unassigned.
  int32_t nearest(int mesh, const float* p, int32_t exclude) const {
    const Mesh& m = meshes[size_t(mesh)];
    int c[3];
    for (int a = 0; a < 3; ++a) c[a] = pf_grid_coord(p[a], m.lo[a], m.s, m.n[a]);
    double best = INFINITY;
    uint32_t best_id = UINT32_MAX;
    int32_t best_slot = -1;
    const int maxr = std::max(m.n[0], std::max(m.n[1], m.n[2]));
    for (int r = 0; r <= maxr; ++r) {
      const int z0 = std::max(0, c[2] - r), z1 = std::min(m.n[2] - 1, c[2] + r);
      const int y0 = std::max(0, c[1] - r), y1 = std::min(m.n[1] - 1, c[1] + r);
      const int x0 = std::max(0, c[0] - r), x1 = std::min(m.n[0] - 1, c[0] + r);
      for (int z = z0; z <= z1; ++z) {
        const bool zs = std::abs(z - c[2]) == r;
        for (int y = y0; y <= y1; ++y) {
          const bool shell = zs || std::abs(y - c[1]) == r;
          const int row = (y + z * m.n[1]) * m.n[0];
          auto visit = [&](int x) {
            for (int32_t k : m.cells[size_t(row + x)]) {
              if (k == exclude) continue;
              const Slot& s = slots[size_t(k)];
              const double d = dist2(p, s.c);
              if (best_slot < 0 || d < best || (d == best && s.id < best_id)) {
                best = d;
                best_id = s.id;
                best_slot = k;
              }
            }
          };
          if (shell) {  // the whole row lies on the shell
            for (int x = x0; x <= x1; ++x) visit(x);
          } else {      // only the row's two ends do
            if (c[0] - r >= 0) visit(c[0] - r);
            if (r > 0 && c[0] + r < m.n[0]) visit(c[0] + r);
          }
        }
      }
      // Every centroid not seen yet lies in a cell outside the searched block [c − r, c + r] (per
      // axis, clamped to the grid): beyond one of the block's faces that has cells behind it.
      // Stop when the best is nearer than every such face (a 1e-4 cell margin covers rounding in
      // the cell coordinates).
      if (best_slot >= 0) {
        double lb = INFINITY;
        for (int a = 0; a < 3; ++a) {
          if (c[a] - r > 0)
            lb = std::min(lb, double(p[a]) - (double(m.lo[a]) + double(c[a] - r) * double(m.s)));
          if (c[a] + r < m.n[a] - 1)
            lb = std::min(lb, double(m.lo[a]) + double(c[a] + r + 1) * double(m.s) - double(p[a]));
        }
        lb -= 1e-4 * double(m.s);
        if (lb == INFINITY || (lb > 0 && best < lb * lb)) break;
      }
    }
    return best_slot;
  }

  // ---- logged primitive operations ----
  void touch(int32_t k) {
    Slot& s = slots[size_t(k)];
    if (s.epoch == epoch) return;
    s.epoch = epoch;
    caches.push_back({k, s.term, s.maxd, {s.centre[0], s.centre[1], s.centre[2]}, s.radius});
    touched.push_back(k);
  }
  static void insert_sorted(std::vector<int32_t>& v, int32_t i) {
    v.insert(std::lower_bound(v.begin(), v.end(), i), i);
  }
  static void erase_sorted(std::vector<int32_t>& v, int32_t i) {
    auto it = std::lower_bound(v.begin(), v.end(), i);
    if (it == v.end() || *it != i) throw std::logic_error("ga: member not found");
    v.erase(it);
  }
  void grid_insert(int32_t k) {
    Slot& s = slots[size_t(k)];
    Mesh& m = meshes[size_t(s.mesh)];
    s.cell = cell_of(m, s.c);
    m.cells[size_t(s.cell)].push_back(k);
    log.push_back({kGridInsert, k, 0});
  }
  void grid_remove(int32_t k) {
    Slot& s = slots[size_t(k)];
    auto& cell = meshes[size_t(s.mesh)].cells[size_t(s.cell)];
    auto it = std::find(cell.begin(), cell.end(), k);
    *it = cell.back();
    cell.pop_back();
  }
  void grid_erase(int32_t k) {
    grid_remove(k);
    log.push_back({kGridErase, k, 0});
  }
  void alive_add(int32_t k) {
    Slot& s = slots[size_t(k)];
    auto& list = meshes[size_t(s.mesh)].alive;
    s.pos = int32_t(list.size());
    s.alive = true;
    list.push_back(k);
    log.push_back({kAliveAdd, k, 0});
  }
  void alive_remove(int32_t k) {
    Slot& s = slots[size_t(k)];
    auto& list = meshes[size_t(s.mesh)].alive;
    const int32_t pos = s.pos, last = list.back();
    list[size_t(pos)] = last;
    slots[size_t(last)].pos = pos;
    list.pop_back();
    s.alive = false;
    s.pos = -1;
    log.push_back({kAliveRemove, k, pos});
  }
  // A new slot. Slots are never reused (a dead slot keeps its position and cell, which the undo
  // of its removal needs); a run creates a few per generation.
  int32_t alloc() {
    slots.emplace_back();
    log.push_back({kAllocFresh, int32_t(slots.size() - 1), 0});
    return int32_t(slots.size() - 1);
  }
  void move_hitpoint(int32_t i, int32_t to) {
    const int32_t from = assign[size_t(i)];
    touch(from);
    touch(to);
    erase_sorted(slots[size_t(from)].members, i);
    log.push_back({kMemberErase, from, i});
    insert_sorted(slots[size_t(to)].members, i);
    log.push_back({kMemberInsert, to, i});
    assign[size_t(i)] = to;
    log.push_back({kAssign, i, from});
    Slot& t = slots[size_t(to)];
    t.maxd = std::max(t.maxd, std::sqrt(dist2(hp(i), t.c)));
    Mesh& m = meshes[size_t(t.mesh)];
    m.maxd_bound = std::max(m.maxd_bound, t.maxd);
  }

  // A new centroid (no members yet).
  int32_t create(int mesh, const float pos[3]) {
    const int32_t k = alloc();
    touch(k);
    Slot& s = slots[size_t(k)];
    for (int a = 0; a < 3; ++a) s.c[a] = pos[a];
    clamp_to_mesh(mesh, s.c);
    s.mesh = mesh;
    s.id = next_id++;
    s.members.clear();
    s.maxd = 0;
    s.term = 0;
    s.radius = 0;
    alive_add(k);
    grid_insert(k);
    return k;
  }
  // Drops a centroid without members.
  void destroy(int32_t k, bool in_grid) {
    touch(k);
    Slot& s = slots[size_t(k)];
    score -= s.term;
    s.term = 0;
    if (in_grid) grid_erase(k);
    alive_remove(k);
  }

  // ---- the structural mutations (each keeps: every hitpoint at its nearest centroid) ----
  // Adds a centroid at pos on `mesh`: it takes over the hitpoints nearer to it than to their own.
  bool add_centroid(int mesh, const float pos[3]) {
    const int32_t k = create(mesh, pos);
    const float* c = slots[size_t(k)].c;
    std::vector<int32_t>& sw = scratch;    // hitpoints that switch to k
    std::vector<int32_t>& losers = scratch2;  // clusters they leave
    sw.clear();
    losers.clear();
    // Only clusters whose centroid lies within 2·maxd of c can lose members (below); 2·maxd_bound
    // bounds every maxd of the mesh.
    within(mesh, c, 2.0 * meshes[size_t(mesh)].maxd_bound * (1 + 1e-9), cand);
    for (int32_t j : cand) {
      if (j == k) continue;
      const Slot& s = slots[size_t(j)];
      // A member x of j can be nearer to c only if |c − cj| ≤ |c − x| + |x − cj| < 2|x − cj|.
      const double lim = 2.0 * s.maxd * (1 + 1e-9) + 1e-30;
      if (dist2(c, s.c) > lim * lim) continue;
      bool any = false;
      for (int32_t i : s.members)
        if (dist2(hp(i), c) < dist2(hp(i), s.c)) {  // ties stay: the new id is the highest
          sw.push_back(i);
          any = true;
        }
      if (any) losers.push_back(j);
    }
    for (int32_t i : sw) move_hitpoint(i, k);
    // Destroy emptied clusters in id order: the order of the grid cells' lists differs between
    // copies (undo re-inserts at the end), the live lists' order must not.
    std::sort(losers.begin(), losers.end(),
              [&](int32_t x, int32_t y) { return slots[size_t(x)].id < slots[size_t(y)].id; });
    for (int32_t j : losers)
      if (slots[size_t(j)].members.empty()) destroy(j, true);
    if (slots[size_t(k)].members.empty()) {
      destroy(k, true);
      return false;
    }
    return true;
  }
  // Removes a centroid: its hitpoints go to their nearest remaining centroid. Never the last one
  // of a mesh.
  bool remove_centroid(int32_t k) {
    Slot& s0 = slots[size_t(k)];
    if (!s0.alive || meshes[size_t(s0.mesh)].alive.size() <= 1) return false;
    const int mesh = s0.mesh;
    touch(k);
    grid_erase(k);
    // Every member x has |x − ck| ≤ maxd. With j0 the centroid nearest to ck (at D0), x's new
    // nearest centroid j satisfies |x − cj| ≤ |x − cj0| ≤ maxd + D0, so |ck − cj| ≤ 2·maxd + D0:
    // one search for the candidates, then each member picks among them (ties: lower id).
    const float ck[3] = {s0.c[0], s0.c[1], s0.c[2]};
    const int32_t j0 = nearest(mesh, ck, -1);
    const double lim = (2.0 * s0.maxd + std::sqrt(dist2(ck, slots[size_t(j0)].c))) * (1 + 1e-9) + 1e-30;
    within(mesh, ck, lim, cand);
    size_t n = 0;
    for (int32_t j : cand)
      if (dist2(ck, slots[size_t(j)].c) <= lim * lim) cand[n++] = j;
    cand.resize(n);
    const std::vector<int32_t> members = slots[size_t(k)].members;
    for (auto it = members.rbegin(); it != members.rend(); ++it) {
      const float* x = hp(*it);
      double best = INFINITY;
      uint32_t best_id = UINT32_MAX;
      int32_t to = -1;
      for (int32_t j : cand) {
        const double d = dist2(x, slots[size_t(j)].c);
        if (to < 0 || d < best || (d == best && slots[size_t(j)].id < best_id)) {
          best = d;
          best_id = slots[size_t(j)].id;
          to = j;
        }
      }
      move_hitpoint(*it, to);
    }
    destroy(k, false);
    return true;
  }

  size_t live_count() const {
    size_t n = 0;
    for (const Mesh& m : meshes) n += m.alive.size();
    return n;
  }
  // A live centroid chosen uniformly.
  int32_t random_slot(pf_rng& rng) const {
    const size_t total = live_count();
    size_t k = std::min(total - 1, size_t(double(pf_rng_next(&rng)) * double(total)));
    for (const Mesh& m : meshes) {
      if (k < m.alive.size()) return m.alive[k];
      k -= m.alive.size();
    }
    return -1;
  }
  bool alive_with_id(int32_t k, uint32_t id) const {
    return slots[size_t(k)].alive && slots[size_t(k)].id == id;
  }

  // ---- the mutations of ch. 8.1 ----
  bool mutate(Mutation mu, pf_rng& rng) {
    switch (mu) {
      case Mutation::Merge: {
        const int32_t a = random_slot(rng);
        const float u = pf_rng_next(&rng);
        const Slot& A = slots[size_t(a)];
        const int32_t b = nearest(A.mesh, A.c, a);
        if (b < 0) return false;
        const Slot& B = slots[size_t(b)];
        const int64_t s = int64_t(A.members.size() + B.members.size());
        if (s > 2 * int64_t(wg)) return false;
        if (s >= wg && !(double(u) < double(2 * wg - s) / double(wg))) return false;
        double sum[3] = {0, 0, 0};
        for (const std::vector<int32_t>* ms : {&A.members, &B.members})
          for (int32_t i : *ms)
            for (int a3 = 0; a3 < 3; ++a3) sum[a3] += hp(i)[a3];
        float pos[3];
        for (int a3 = 0; a3 < 3; ++a3) pos[a3] = float(sum[a3] / double(s));
        const int mesh = A.mesh;
        const uint32_t ida = A.id, idb = B.id;
        add_centroid(mesh, pos);
        if (alive_with_id(a, ida)) remove_centroid(a);
        if (alive_with_id(b, idb)) remove_centroid(b);
        return true;
      }
      case Mutation::Move: {
        const int32_t k = random_slot(rng);
        float off[3];
        for (float& o : off) o = 2.f * pf_rng_next(&rng) - 1.f;
        const Slot& s = slots[size_t(k)];
        const float r = s.radius > 0.f ? s.radius : sh->r0;
        float pos[3];
        for (int a3 = 0; a3 < 3; ++a3) pos[a3] = s.c[a3] + off[a3] * r;
        const int mesh = s.mesh;
        const uint32_t id = s.id;
        const bool added = add_centroid(mesh, pos);
        bool removed = false;
        if (alive_with_id(k, id)) removed = remove_centroid(k);
        return added || removed;
      }
      case Mutation::Remove: {
        const int count = 1 + std::min(kGaMaxRemoveAdd - 1, int(pf_rng_next(&rng) * float(kGaMaxRemoveAdd)));
        bool changed = false;
        for (int t = 0; t < count; ++t) {
          const int32_t a = random_slot(rng), b = random_slot(rng);
          const int32_t k = slots[size_t(b)].members.size() < slots[size_t(a)].members.size() ? b : a;
          changed |= remove_centroid(k);
        }
        return changed;
      }
      case Mutation::Add: {
        const int count = 1 + std::min(kGaMaxRemoveAdd - 1, int(pf_rng_next(&rng) * float(kGaMaxRemoveAdd)));
        bool changed = false;
        const size_t n = assign.size();
        for (int t = 0; t < count; ++t) {
          const int32_t i = int32_t(std::min(n - 1, size_t(double(pf_rng_next(&rng)) * double(n))));
          float pos[3];
          for (int a3 = 0; a3 < 3; ++a3)
            pos[a3] = hp(i)[a3] + (2.f * pf_rng_next(&rng) - 1.f) * sh->r0;
          changed |= add_centroid(sh->mesh[size_t(i)], pos);
        }
        return changed;
      }
    }
    return false;
  }

  bool mutate_child(pf_rng& rng) {
    const float u_move = pf_rng_next(&rng), u_remove = pf_rng_next(&rng), u_add = pf_rng_next(&rng);
    bool changed = mutate(Mutation::Merge, rng);
    if (u_move < kGaMoveProbability) changed |= mutate(Mutation::Move, rng);
    if (u_remove < kGaRemoveProbability) changed |= mutate(Mutation::Remove, rng);
    if (u_add < kGaAddProbability) changed |= mutate(Mutation::Add, rng);
    return changed;
  }

  int64_t evaluate() {
    const HitpointSet& h = *sh->h;
    for (int32_t k : touched) {
      Slot& s = slots[size_t(k)];
      if (!s.alive) continue;
      cluster_centre_radius(h, s.members.data(), s.members.size(), s.centre, &s.radius);
      const int64_t t = calc.term(s.mesh, s.centre, s.radius, int64_t(s.members.size()));
      score += t - s.term;
      s.term = t;
      double md = 0;
      for (int32_t i : s.members) md = std::max(md, dist2(hp(i), s.c));
      s.maxd = std::sqrt(md);
    }
    return score;
  }

  void commit() {
    for (Mesh& m : meshes) {  // tighten the bound to the exact maximum
      m.maxd_bound = 0;
      for (int32_t k : m.alive) m.maxd_bound = std::max(m.maxd_bound, slots[size_t(k)].maxd);
    }
    log.clear();
    caches.clear();
    touched.clear();
    ++epoch;
    saved_score = score;
    saved_next_id = next_id;
  }

  void undo() {
    for (auto it = caches.rbegin(); it != caches.rend(); ++it) {
      Slot& s = slots[size_t(it->slot)];
      s.term = it->term;
      s.maxd = it->maxd;
      for (int a = 0; a < 3; ++a) s.centre[a] = it->centre[a];
      s.radius = it->radius;
    }
    for (auto it = log.rbegin(); it != log.rend(); ++it) {
      const int32_t k = it->a;
      switch (it->op) {
        case kAssign: assign[size_t(k)] = it->b; break;
        case kMemberInsert: erase_sorted(slots[size_t(k)].members, it->b); break;
        case kMemberErase: insert_sorted(slots[size_t(k)].members, it->b); break;
        case kGridInsert: grid_remove(k); break;
        case kGridErase: {
          Slot& s = slots[size_t(k)];
          meshes[size_t(s.mesh)].cells[size_t(s.cell)].push_back(k);
          break;
        }
        case kAliveAdd: {
          Slot& s = slots[size_t(k)];
          meshes[size_t(s.mesh)].alive.pop_back();
          s.alive = false;
          s.pos = -1;
          break;
        }
        case kAliveRemove: {
          Slot& s = slots[size_t(k)];
          auto& list = meshes[size_t(s.mesh)].alive;
          const int32_t pos = it->b;
          if (size_t(pos) == list.size()) {
            list.push_back(k);
          } else {
            const int32_t moved = list[size_t(pos)];
            list.push_back(moved);
            slots[size_t(moved)].pos = int32_t(list.size() - 1);
            list[size_t(pos)] = k;
          }
          s.pos = pos;
          s.alive = true;
          break;
        }
        case kAllocFresh: slots.pop_back(); break;
      }
    }
    log.clear();
    caches.clear();
    touched.clear();
    ++epoch;
    score = saved_score;
    next_id = saved_next_id;
  }

  // ---- outputs ----
  ClusterSet to_set(const std::vector<std::vector<int32_t>>& groups,
                    const std::vector<int32_t>& group_mesh) const {
    ClusterSet c;  // empty_cluster_set's bindings, with the hash computed once
    c.wg_size = wg;
    c.method = "ga";
    c.scene_id = sh->h->scene_id;
    c.hitpoint_count = sh->h->hitpoints.size();
    c.hitpoints_sha256 = sh->hitpoints_sha256;
    std::vector<size_t> idx;
    for (size_t g = 0; g < groups.size(); ++g)
      if (!groups[g].empty()) idx.push_back(g);
    std::sort(idx.begin(), idx.end(), [&](size_t a, size_t b) {
      if (group_mesh[a] != group_mesh[b]) return group_mesh[a] < group_mesh[b];
      return groups[a].front() < groups[b].front();
    });
    c.order.reserve(assign.size() + assign.size() / 4);
    for (size_t g : idx)
      append_cluster(c, group_mesh[g], groups[g].data(), groups[g].size(), *sh->h);
    return c;
  }
  ClusterSet clusters() const {
    std::vector<std::vector<int32_t>> groups;
    std::vector<int32_t> mesh;
    for (const Mesh& m : meshes)
      for (int32_t k : m.alive) {
        groups.push_back(slots[size_t(k)].members);
        mesh.push_back(slots[size_t(k)].mesh);
      }
    return to_set(groups, mesh);
  }
  ClusterSet full_clusters() const {
    std::vector<std::vector<int32_t>> groups(slots.size());
    std::vector<int32_t> mesh(slots.size(), 0);
    for (size_t k = 0; k < slots.size(); ++k) mesh[k] = slots[k].mesh;
    for (size_t i = 0; i < assign.size(); ++i) {  // brute force over the mesh's centroids
      const Mesh& m = meshes[size_t(sh->mesh[i])];
      double best = INFINITY;
      uint32_t best_id = UINT32_MAX;
      int32_t best_slot = -1;
      for (int32_t k : m.alive) {
        const double d = dist2(hp(int32_t(i)), slots[size_t(k)].c);
        if (best_slot < 0 || d < best || (d == best && slots[size_t(k)].id < best_id)) {
          best = d;
          best_id = slots[size_t(k)].id;
          best_slot = k;
        }
      }
      groups[size_t(best_slot)].push_back(int32_t(i));
    }
    return to_set(groups, mesh);
  }
};

GaState::GaState(const GaFitnessInputs& in, GaFitness f, const ClusterSet& start)
    : p_(std::make_unique<Impl>()) {
  p_->setup(in, f);
  if (start.wg_size != in.wg_size)
    throw std::invalid_argument("ga: the start clusters have another work-group size");
  std::vector<GaCentroid> cs;
  for (const pf_cluster& c : start.clusters) {
    GaCentroid g{};
    for (int a = 0; a < 3; ++a) g.position[a] = c.centre[a];
    g.mesh = c.mesh;
    g.id = uint32_t(cs.size());
    cs.push_back(g);
  }
  p_->build(cs, uint32_t(cs.size()));
}

GaState::GaState(const GaFitnessInputs& in, GaFitness f, const std::vector<GaCentroid>& centroids,
                 uint32_t next_id)
    : p_(std::make_unique<Impl>()) {
  p_->setup(in, f);
  p_->build(centroids, next_id);
}

GaState::GaState(const GaState& o) : p_(std::make_unique<Impl>(*o.p_)) {}
GaState& GaState::operator=(const GaState& o) {
  if (this != &o) *p_ = *o.p_;
  return *this;
}
GaState::~GaState() = default;

bool GaState::mutate(Mutation m, pf_rng& rng) { return p_->mutate(m, rng); }
bool GaState::mutate_child(pf_rng& rng) { return p_->mutate_child(rng); }
int64_t GaState::evaluate() { return p_->evaluate(); }
void GaState::commit() { p_->commit(); }
void GaState::undo() { p_->undo(); }
int64_t GaState::score() const { return p_->score; }
double GaState::fitness() const { return double(p_->score) * p_->calc.scale(); }
double GaState::scale() const { return p_->calc.scale(); }
size_t GaState::cluster_count() const { return p_->live_count(); }
ClusterSet GaState::clusters() const { return p_->clusters(); }
ClusterSet GaState::full_clusters() const { return p_->full_clusters(); }
int64_t GaState::full_score() const {
  const ClusterSet c = p_->full_clusters();
  int64_t s = 0;
  for (const pf_cluster& cl : c.clusters) s += p_->calc.term(cl.mesh, cl.centre, cl.radius, cl.count);
  return s;
}
std::vector<GaCentroid> GaState::centroids() const {
  std::vector<GaCentroid> out;
  for (const Impl::Mesh& m : p_->meshes)
    for (int32_t k : m.alive) {
      const Impl::Slot& s = p_->slots[size_t(k)];
      GaCentroid g{};
      for (int a = 0; a < 3; ++a) g.position[a] = s.c[a];
      g.mesh = s.mesh;
      g.id = s.id;
      out.push_back(g);
    }
  return out;
}
uint32_t GaState::next_id() const { return p_->next_id; }

}  // namespace pf
