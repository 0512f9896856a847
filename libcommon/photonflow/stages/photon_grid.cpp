// photon_grid.cpp — per-mesh uniform photon grids (thesis ch. 7.3, eq. 7.1), built with a stable
// counting sort by (mesh, bin).
//
// The build is parallel and deterministic: the photons are cut into fixed blocks, each worker
// takes a contiguous run of blocks (so the workers' ranges are in photon order), and
//   1. bounds and counts per mesh are reduced from per-worker partials (min/max and integer sums
//      are exact, so the reduction order does not matter),
//   2. every worker computes its photons' keys and a histogram over all bins,
//   3. one pass over the bins turns the histograms into per-worker write cursors (the start of a
//      bin, plus the photons earlier workers put there),
//   4. every worker scatters its photons in order.
// A stable counting sort has exactly one result, so the arrays are the same bytes for any thread
// count. All buffers live in the PhotonGrid (and a per-calling-thread scratch) and are reused by
// the next build, so a steady stream of passes allocates nothing.
#include "photonflow/stages/photon_grid.h"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>

#include "photonflow/foundations/error.h"
#include "photonflow/foundations/threads.h"
#include "photonflow/foundations/vec.h"

namespace pf {

namespace {

// Linear bin offset of p in grid g (eq. 7.1): x + y·nx + z·nx·ny.
inline int bin_of(const pf_mesh_grid& g, const float* p) {
  int x = grid_coord(p[0], g.lo[0], g.bin_size, g.nx);
  int y = grid_coord(p[1], g.lo[1], g.bin_size, g.ny);
  int z = grid_coord(p[2], g.lo[2], g.bin_size, g.nz);
  return x + (y + z * g.ny) * g.nx;
}

// Bins along an extent: enough bins of size d to cover it, at least one and at most max_bins
// (extent/d can exceed max_bins by rounding; grid_coord clamps, so the last bin absorbs it).
int bins_along(float extent, float d, int max_bins) {
  return std::clamp(static_cast<int>(std::ceil(extent / d)), 1, max_bins);
}

// Photons per work block (a block never spans two input spans). Worker w (a loop index, not a
// thread id: any team size, nested regions included, runs every worker) owns a contiguous run.
constexpr size_t kBlock = 8192;
// Below this many photons the build runs on the calling thread only.
constexpr size_t kParallelMin = 32768;

// Resizes a buffer whose contents are about to be overwritten. Growing past the capacity frees
// the old array first (no copy, and the old and new arrays never coexist) and leaves a little
// headroom, so a stream of passes of nearly equal size settles on one allocation.
template <class T>
void resize_for_overwrite(std::vector<T>& v, size_t n) {
  if (n > v.capacity()) {
    std::vector<T>().swap(v);
    v.reserve(n + n / 16);
  }
  v.resize(n);
}

// Sizes the grid's position arrays for its photons (PhotonGrid::pos_x/y/z), the padding zeroed.
void size_positions(PhotonGrid& grid) {
  const size_t n = grid.photons.size();
  for (std::vector<float>* a : {&grid.pos_x, &grid.pos_y, &grid.pos_z}) {
    resize_for_overwrite(*a, n + PhotonGrid::kPositionPad);
    std::fill(a->begin() + long(n), a->end(), 0.f);  // loaded by masked-off lanes only
  }
}

struct Block {
  const pf_photon* data;
  size_t size;
  size_t base;  // photon index of data[0]
};

// Per-mesh bounds and count, reduced exactly like Bounds::extend with std::fmin / std::fmax:
// on equal values (±0) the earlier photon's value is kept.
struct MeshAcc {
  float lo[3], hi[3];
  int32_t count;
};

struct Scratch {
  std::vector<Block> blocks;
  std::vector<int32_t> key;                    // global bin of each photon
  std::vector<const pf_photon*> source;        // the photon each sorted slot takes
  std::vector<std::vector<MeshAcc>> acc;       // per worker
  std::vector<std::vector<int32_t>> hist;      // per worker: counts, then write cursors
  std::vector<size_t> first_bad;               // per worker: first invalid photon index
};

Scratch& scratch() {
  thread_local Scratch s;
  return s;
}

void reset_acc(std::vector<MeshAcc>& acc, int mesh_count) {
  acc.resize(size_t(mesh_count));
  for (MeshAcc& a : acc) {
    for (int k = 0; k < 3; ++k) {
      a.lo[k] = INFINITY;
      a.hi[k] = -INFINITY;
    }
    a.count = 0;
  }
}


}  // namespace

void throw_bad_photon(const pf_photon& p, size_t i, int mesh_count) {
  if (p.mesh < 0 || p.mesh >= mesh_count)
    throw std::invalid_argument("photon grid: photon " + std::to_string(i) + " has mesh id " +
                                std::to_string(p.mesh) + " outside [0, " +
                                std::to_string(mesh_count) + ")");
  throw std::invalid_argument("photon grid: photon " + std::to_string(i) +
                              " has a non-finite position");
}

void check_photon_count(size_t n, int mesh_count) {
  if (mesh_count < 0) throw std::invalid_argument("photon grid: negative mesh count");
  if (n > static_cast<size_t>(std::numeric_limits<int32_t>::max()))
    throw std::invalid_argument("photon grid: more than 2^31-1 photons");
}

std::string mesh_grid_problem(const pf_mesh_grid& g) {
  if (g.nx == 0 && g.ny == 0 && g.nz == 0) return "";
  for (int n : {g.nx, g.ny, g.nz})
    if (n < 1 || n > kMaxBinsPerAxis)
      return "bins per axis " + std::to_string(g.nx) + " x " + std::to_string(g.ny) + " x " +
             std::to_string(g.nz) + " outside 1 … 2^24";
  // nx·ny <= 2^48 fits; compare before multiplying by nz (2^72 would wrap).
  if (int64_t(g.nx) * g.ny > kMaxGridEntries / g.nz) return "more than 2^28 bins";
  if (!(g.bin_size > 0.f) || !std::isfinite(g.bin_size)) return "bin size not positive and finite";
  if (!std::isfinite(g.lo[0]) || !std::isfinite(g.lo[1]) || !std::isfinite(g.lo[2]))
    return "corner lo not finite";
  return "";
}

void check_max_bins(int max_bins, const std::string& what) {
  if (max_bins > kMaxBinsPerAxis)
    throw input_error("", "--max-bins " + std::to_string(max_bins) + " is too large for " + what +
                              ": at most 16777216 (2^24) bins per axis");
}

void check_photon_grid_params(const PhotonGridParams& params) {
  if (!(params.default_radius > 0.f) || !std::isfinite(params.default_radius))
    throw std::invalid_argument("photon grid: default_radius must be positive and finite");
  if (params.max_bins < 1) throw std::invalid_argument("photon grid: max_bins must be >= 1");
  check_max_bins(params.max_bins, "the photon grid");
}

void check_grid_entries(int64_t entries, const std::string& what, const std::string& hint) {
  if (entries > kMaxGridEntries)
    throw input_error("", what + " would have " + std::to_string(entries) +
                              " bins, more than 2^28 = 268435456", hint);
}

std::vector<int32_t> PhotonGrid::gather(int mesh, const float q[3], float radius) const {
  std::vector<int32_t> out;
  for_each_in_radius(mesh, q, radius, [&](int i) { out.push_back(i); });
  return out;
}

pf_mesh_grid mesh_grid_header(const float lo[3], const float hi[3], int32_t count,
                              const PhotonGridParams& params) {
  pf_mesh_grid g{};
  g.photon_count = count;
  if (count == 0) {
    g.bin_size = params.default_radius;
    return g;
  }
  Vec3 ext = Vec3(hi) - Vec3(lo);
  float longest = std::max(ext.x, std::max(ext.y, ext.z));
  float d = std::max(longest / static_cast<float>(params.max_bins), params.default_radius);
  for (int k = 0; k < 3; ++k) g.lo[k] = lo[k];
  g.bin_size = d;
  g.nx = bins_along(ext.x, d, params.max_bins);
  g.ny = bins_along(ext.y, d, params.max_bins);
  g.nz = bins_along(ext.z, d, params.max_bins);
  return g;
}

PhotonGrid build_photon_grid(const std::vector<pf_photon>& photons, int mesh_count,
                             const PhotonGridParams& params) {
  PhotonGrid grid;
  build_photon_grid_into(grid, photons, mesh_count, params);
  return grid;
}

void build_photon_grid_into(PhotonGrid& grid, const std::vector<pf_photon>& photons,
                            int mesh_count, const PhotonGridParams& params, int threads) {
  PhotonSpan span{photons.data(), photons.size()};
  build_photon_grid_into(grid, &span, 1, mesh_count, params, threads);
}

void build_photon_grid_into(PhotonGrid& grid, const PhotonSpan* spans, size_t span_count,
                            int mesh_count, const PhotonGridParams& params, int threads) {
  check_photon_grid_params(params);
  size_t n = 0;
  for (size_t s = 0; s < span_count; ++s) n += spans[s].size;
  check_photon_count(n, mesh_count);

  Scratch& sc = scratch();
  sc.blocks.clear();
  {
    size_t base = 0;
    for (size_t s = 0; s < span_count; ++s) {
      for (size_t b = 0; b < spans[s].size; b += kBlock)
        sc.blocks.push_back({spans[s].data + b, std::min(kBlock, spans[s].size - b), base + b});
      base += spans[s].size;
    }
  }
  const int nblocks = int(sc.blocks.size());
  int workers = worker_threads(threads);
  if (n < kParallelMin) workers = 1;
  workers = std::max(1, std::min(workers, nblocks));
  // Worker w owns blocks [block_begin(w), block_begin(w + 1)): contiguous, in photon order.
  auto block_begin = [&](int w) { return int(int64_t(nblocks) * w / workers); };
  if (int(sc.acc.size()) < workers) sc.acc.resize(size_t(workers));
  if (int(sc.hist.size()) < workers) sc.hist.resize(size_t(workers));
  sc.first_bad.assign(size_t(workers), SIZE_MAX);

  // 1. Bounds and count of each mesh's photons; the first invalid photon.
#pragma omp parallel for schedule(static, 1) num_threads(workers)
  for (int w = 0; w < workers; ++w) {
    std::vector<MeshAcc>& acc = sc.acc[size_t(w)];
    reset_acc(acc, mesh_count);
    for (int b = block_begin(w); b < block_begin(w + 1); ++b) {
      const Block& blk = sc.blocks[size_t(b)];
      for (size_t j = 0; j < blk.size; ++j) {
        const pf_photon& p = blk.data[j];
        const float* pos = p.position;
        if (!photon_ok(p, mesh_count)) {
          sc.first_bad[size_t(w)] = blk.base + j;
          b = block_begin(w + 1);  // stop this worker: later photons cannot be reported first
          break;
        }
        MeshAcc& a = acc[size_t(p.mesh)];
        for (int k = 0; k < 3; ++k) {
          a.lo[k] = pos[k] < a.lo[k] ? pos[k] : a.lo[k];
          a.hi[k] = pos[k] > a.hi[k] ? pos[k] : a.hi[k];
        }
        ++a.count;
      }
    }
  }
  for (int w = 0; w < workers; ++w) {
    size_t i = sc.first_bad[size_t(w)];
    if (i == SIZE_MAX) continue;
    for (const Block& blk : sc.blocks)
      if (i >= blk.base && i < blk.base + blk.size)
        throw_bad_photon(blk.data[i - blk.base], i, mesh_count);
  }
  std::vector<MeshAcc>& total = sc.acc[0];
  for (int w = 1; w < workers; ++w) {  // in worker order: earlier photons win ties, as in order
    for (int m = 0; m < mesh_count; ++m) {
      MeshAcc& a = total[size_t(m)];
      const MeshAcc& o = sc.acc[size_t(w)][size_t(m)];
      for (int k = 0; k < 3; ++k) {
        a.lo[k] = o.lo[k] < a.lo[k] ? o.lo[k] : a.lo[k];
        a.hi[k] = o.hi[k] > a.hi[k] ? o.hi[k] : a.hi[k];
      }
      a.count += o.count;
    }
  }

  // 2. Per-mesh headers: bin size and counts (eq. 7.1), bin and photon offsets.
  grid.params = params;
  grid.mesh_grid.resize(size_t(mesh_count));
  int64_t total_entries = 0;
  int32_t first_photon = 0;
  for (int m = 0; m < mesh_count; ++m) {
    pf_mesh_grid& g = grid.mesh_grid[size_t(m)];
    const MeshAcc& a = total[size_t(m)];
    g = mesh_grid_header(a.lo, a.hi, a.count, params);
    g.first_bin = static_cast<pf_int>(total_entries);
    g.first_photon = first_photon;
    total_entries += a.count == 0 ? 1 : mesh_grid_bins(g) + 1;
    // Checked before anything is allocated (photon_grid.h: kMaxGridEntries).
    check_grid_entries(total_entries, "the photon grid", kGridBinsHint);
    first_photon += a.count;
  }
  const size_t entries = size_t(total_entries);

  // 3. Keys (global bin = first_bin(mesh) + bin) and per-worker histograms. Each mesh's last entry
  // (its end marker) receives no photons, so one prefix sum over all entries gives every mesh's
  // bins+1 starts.
  resize_for_overwrite(sc.key, n);
  resize_for_overwrite(grid.cell_start, entries);
  resize_for_overwrite(grid.photons, n);
  resize_for_overwrite(grid.order, n);
  const pf_mesh_grid* mg = grid.mesh_grid.data();
#pragma omp parallel for schedule(static, 1) num_threads(workers)
  for (int w = 0; w < workers; ++w) {
    std::vector<int32_t>& hist = sc.hist[size_t(w)];
    resize_for_overwrite(hist, entries);
    std::fill(hist.begin(), hist.end(), 0);
    int32_t* key = sc.key.data();
    for (int b = block_begin(w); b < block_begin(w + 1); ++b) {
      const Block& blk = sc.blocks[size_t(b)];
      for (size_t j = 0; j < blk.size; ++j) {
        const pf_mesh_grid& g = mg[blk.data[j].mesh];
        const int32_t k = g.first_bin + bin_of(g, blk.data[j].position);
        key[blk.base + j] = k;
        ++hist[size_t(k)];
      }
    }
  }
  // Exclusive prefix over (bin, worker): cell_start[b] is the first photon of bin b, and worker w
  // writes its photons of bin b after those of workers 0..w−1.
  {
    int32_t running = 0;
    int32_t* cs = grid.cell_start.data();
    if (workers == 1) {
      int32_t* h0 = sc.hist[0].data();
      for (size_t e = 0; e < entries; ++e) {
        const int32_t c = h0[e];
        cs[e] = running;
        h0[e] = running;
        running += c;
      }
    } else {
      std::vector<int32_t*> h(static_cast<size_t>(workers));
      for (int w = 0; w < workers; ++w) h[size_t(w)] = sc.hist[size_t(w)].data();
      for (size_t e = 0; e < entries; ++e) {
        cs[e] = running;
        for (int w = 0; w < workers; ++w) {
          const int32_t c = h[size_t(w)][e];
          h[size_t(w)][e] = running;
          running += c;
        }
      }
    }
  }
  // 4. Stable scatter: every worker writes its photons' slots, in order, from its cursors; then
  // the photons are copied into their slots in slot order. Scattering 12 bytes (index and
  // address) and gathering the 48-byte photons with sequential writes costs less than
  // scattering the photons themselves: random writes must first read their cache lines.
  resize_for_overwrite(sc.source, n);
  int32_t* order = grid.order.data();
  const pf_photon** source = sc.source.data();
#pragma omp parallel for schedule(static, 1) num_threads(workers)
  for (int w = 0; w < workers; ++w) {
    int32_t* cursor = sc.hist[size_t(w)].data();
    const int32_t* key = sc.key.data();
    for (int b = block_begin(w); b < block_begin(w + 1); ++b) {
      const Block& blk = sc.blocks[size_t(b)];
      for (size_t j = 0; j < blk.size; ++j) {
        const size_t i = blk.base + j;
        const int32_t dst = cursor[key[i]]++;
        source[dst] = &blk.data[j];
        order[dst] = static_cast<int32_t>(i);
      }
    }
  }
  // The copy also fills the position arrays (PhotonGrid::index_positions).
  size_positions(grid);
  pf_photon* out = grid.photons.data();
  float* const px = grid.pos_x.data();
  float* const py = grid.pos_y.data();
  float* const pz = grid.pos_z.data();
  const int64_t count = int64_t(n);
#pragma omp parallel for schedule(static) num_threads(workers)
  for (int64_t k = 0; k < count; ++k) {
    std::memcpy(&out[k], source[k], sizeof(pf_photon));
    px[k] = out[k].position[0];
    py[k] = out[k].position[1];
    pz[k] = out[k].position[2];
  }
}

void PhotonGrid::index_positions(int threads) {
  const size_t n = photons.size();
  size_positions(*this);
  const pf_photon* p = photons.data();
  float* x = pos_x.data();
  float* y = pos_y.data();
  float* z = pos_z.data();
  const int64_t count = int64_t(n);
#pragma omp parallel for schedule(static) num_threads(worker_threads(threads)) if (n >= kParallelMin)
  for (int64_t i = 0; i < count; ++i) {
    x[i] = p[i].position[0];
    y[i] = p[i].position[1];
    z[i] = p[i].position[2];
  }
}

}  // namespace pf
