// hash_grid.cpp — layout and host ordering of the hashed photon grid (hash_grid.h).
#include "photonflow/stages/hash_grid.h"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <climits>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <vector>

#include "photonflow/foundations/error.h"
#include "photonflow/stages/grid_shared.h"
#include "photonflow/foundations/morton.h"
#include "photonflow/stages/photon_grid.h"
#include "photonflow/foundations/threads.h"

namespace pf {

namespace {

// Below this many photons the ordering runs on the calling thread only.
constexpr size_t kParallelMin = 32768;

struct Scratch {
  std::vector<uint32_t> slot;                // slot of each photon
  std::vector<std::vector<int32_t>> cursor;  // per worker: counts, then write cursors
  std::vector<size_t> first_bad;             // per worker: first photon failing the check
};

Scratch& scratch() {
  thread_local Scratch s;
  return s;
}

}  // namespace

HashOrder parse_hash_order(const std::string& name) {
  if (name == "auto") return HashOrder::Auto;
  if (name == "device") return HashOrder::Device;
  if (name == "host") return HashOrder::Host;
  throw input_error("", "--hash-order must be one of auto, device, host, got '" + name + "'");
}

const char* hash_order_name(HashOrder o) {
  switch (o) {
    case HashOrder::Device: return "device";
    case HashOrder::Host: return "host";
    default: return "auto";
  }
}

HashGridLayout hash_grid_layout(const float origin[3], const float extent[3], float cell,
                                size_t photons, int slots) {
  HashGridLayout g;
  for (int a = 0; a < 3; ++a) {
    g.origin[a] = origin[a];
    const double cells = std::ceil(double(extent[a]) / double(cell));
    g.n[a] = int32_t(std::clamp(cells, 1.0, double(1 << 24)));
  }
  g.cell = cell;
  // Slots: a power of two >= the photons; fewer when fewer hold every cell, up to 4 times that
  // when that then holds every cell (no two cells share a slot: the gather reads whole rows as
  // runs, see gather_hash_grid). Never below 1024.
  size_t table = 1024;
  while (table < photons && table < (size_t(1) << 30)) table <<= 1;
  const double cells = double(g.n[0]) * double(g.n[1]) * double(g.n[2]);
  if (cells <= double(table)) {
    table = 1024;
    while (double(table) < cells) table <<= 1;
  } else if (cells <= 4.0 * double(table)) {
    while (double(table) < cells) table <<= 1;
  }
  if (slots < 0 || (slots & (slots - 1)))
    throw input_error("", "hash-grid slots must be a power of two, got " + std::to_string(slots));
  if (slots > 0) table = size_t(slots);
  g.unique = cells <= double(table) ? 1 : 0;
  g.mask = uint32_t(table - 1);
  return g;
}

void order_hash_grid(const HashGridLayout& g, const pf_photon* photons, size_t n, int mesh_count,
                     pf_photon_keys4* keys, pf_photon_payload* payload, int32_t* slot_start,
                     int threads) {
  check_photon_count(n, mesh_count);
  const size_t table = g.slots();
  Scratch& sc = scratch();
  if (sc.slot.size() < n) {
    std::vector<uint32_t>().swap(sc.slot);
    sc.slot.resize(n + n / 16);
  }
  int workers = worker_threads(threads);
  if (n < kParallelMin) workers = 1;
  workers = std::max(1, std::min<int>(workers, int(std::max<size_t>(n / 4096, 1))));
  // Worker w's run of photons. (Computed once per worker into locals: in the loops, the stores
  // through slot and count may alias captured variables, and recomputing the bound costs a
  // 64-bit division per photon.)
  auto begin = [n, workers](int w) {
    return size_t(uint64_t(n) * uint64_t(w) / uint64_t(workers));
  };
  uint32_t* const slot = sc.slot.data();
  const float ox = g.origin[0], oy = g.origin[1], oz = g.origin[2], cell = g.cell;
  const int32_t nx = g.n[0], ny = g.n[1], nz = g.n[2];
  const uint32_t mask = g.mask;
  if (int(sc.cursor.size()) < workers) sc.cursor.resize(size_t(workers));
  sc.first_bad.assign(size_t(workers), SIZE_MAX);

  // 1. Each worker's slots and counts (its run of photons, in order), and its first photon that
  //    fails the check (photon_grid.h) — this pass is the only one over the unsorted photons
  //    before the scatter, so it also does check_photons' work.
#pragma omp parallel for schedule(static, 1) num_threads(workers)
  for (int w = 0; w < workers; ++w) {
    std::vector<int32_t>& c = sc.cursor[size_t(w)];
    c.assign(table, 0);
    int32_t* const count = c.data();
    const size_t i0 = begin(w), i1 = begin(w + 1);
    for (size_t i = i0; i < i1; ++i) {
      if (!photon_ok(photons[i], mesh_count)) {
        sc.first_bad[size_t(w)] = i;  // later photons cannot be reported first: stop
        break;
      }
      const float* p = photons[i].position;
      const int32_t cx = pf_grid_coord(p[0], ox, cell, nx);
      const int32_t cy = pf_grid_coord(p[1], oy, cell, ny);
      const int32_t cz = pf_grid_coord(p[2], oz, cell, nz);
      const uint32_t s = pf_hash_slot(cx, cy, cz, uint32_t(nx), uint32_t(ny), mask);
      slot[i] = s;
      count[s] += 1;
    }
  }

  for (int w = 0; w < workers; ++w)  // the first bad photon is in the first worker that saw one
    if (sc.first_bad[size_t(w)] != SIZE_MAX)
      throw_bad_photon(photons[sc.first_bad[size_t(w)]], sc.first_bad[size_t(w)], mesh_count);

  // 2. Exclusive scan over the table, worker-major within a slot: slot k starts at the photons
  //    of all earlier slots; worker w writes after the photons workers 0 .. w−1 put in slot k.
  //    The counts become the workers' write cursors. slot_start[table] = n.
  {
    int32_t run = 0;
    for (size_t k = 0; k < table; ++k) {
      slot_start[k] = run;
      for (int w = 0; w < workers; ++w) {
        int32_t& c = sc.cursor[size_t(w)][k];
        const int32_t cw = c;
        c = run;
        run += cw;
      }
    }
    slot_start[table] = run;
  }

  // 3. Each worker scatters its run in order.
#pragma omp parallel for schedule(static, 1) num_threads(workers)
  for (int w = 0; w < workers; ++w) {
    int32_t* const cur = sc.cursor[size_t(w)].data();
    const size_t i0 = begin(w), i1 = begin(w + 1);
    for (size_t i = i0; i < i1; ++i) {
      const size_t j = size_t(cur[slot[i]]++);
      const pf_photon& p = photons[i];
      pf_photon_keys4& k = keys[j / 4];
      const size_t l = j % 4;
      k.x[l] = p.position[0];
      k.y[l] = p.position[1];
      k.z[l] = p.position[2];
      k.key[l] = pf_photon_hash_key(p.mesh, p.flags);
      pf_photon_payload& y = payload[j];
      std::memcpy(y.dir, p.dir, sizeof y.dir);
      std::memcpy(y.flux, p.flux, sizeof y.flux);
    }
  }
  // The last block's unused lanes.
  for (size_t j = n; j < 4 * hash_grid_key_blocks(n); ++j) {
    pf_photon_keys4& k = keys[j / 4];
    k.x[j % 4] = k.y[j % 4] = k.z[j % 4] = 0.f;
    k.key[j % 4] = 0;
  }
}

std::vector<int32_t> hitpoint_cell_order(const std::vector<pf_hitpoint>& hitpoints,
                                         const float origin[3], float cell) {
  const size_t n = hitpoints.size();
  if (n > size_t(INT32_MAX)) throw std::invalid_argument("hitpoint_cell_order: too many hitpoints");
  std::vector<int32_t> order(n);
  for (size_t i = 0; i < n; ++i) order[i] = int32_t(i);
  if (!(cell > 0.f) || !std::isfinite(cell)) return order;
  constexpr float kMaxCoord = float((1u << 21) - 1);
  std::vector<uint64_t> code(n);
  for (size_t i = 0; i < n; ++i) {
    uint64_t c[3];
    for (int a = 0; a < 3; ++a) {
      const float t = (hitpoints[i].position[a] - origin[a]) / cell;
      c[a] = uint64_t(std::isfinite(t) ? std::min(std::max(t, 0.f), kMaxCoord) : 0.f);
    }
    code[i] = morton3(c[0], c[1], c[2]);
  }
  std::stable_sort(order.begin(), order.end(),
                   [&](int32_t a, int32_t b) { return code[size_t(a)] < code[size_t(b)]; });
  return order;
}

}  // namespace pf
