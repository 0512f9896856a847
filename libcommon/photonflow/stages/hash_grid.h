// hash_grid.h — the hashed photon grid of the `hash-grid` gather (gather_method.h): its layout and
// its photon ordering on the host.
//
// The grid: nx × ny × nz cubes of side `cell` from `origin` over the scene (pf_grid_coord clamps
// positions beyond it into the edge cells), cell (x, y, z) hashed to table slot
// pf_hash_slot = (x + nx·(y + ny·z)) mod (mask + 1) (grid_shared.h). The ordering is a stable
// counting sort of the photons by slot: slot k holds photons slot_start[k] .. slot_start[k+1] − 1
// in photon-index order, as keys (position, 2·mesh + direct flag: what the gather tests for every
// candidate, in pf_photon_keys4 blocks of four photons) and a pf_photon_payload per photon
// (direction and flux, read only for photons that passed) — shared_types.h.
//
// Two builders give these arrays byte for byte (tested):
//   device  build_grid.cl's key_hash_cell, scan, scatter, per-slot sort and permute_photons_keys
//           (cl_build_grid.cpp) — atomic counters, so the per-slot sort restores index order;
//   host    order_hash_grid below — a sequential-per-worker counting sort over contiguous runs of
//           photons, written straight into the (mapped) device buffers: no photon upload apart
//           from it, and no atomics. On a CPU device (PoCL) the kernels and the host share the
//           same cores and memory, so this route saves the raw-photon copy and the atomic traffic
//           (docs/BENCHMARKS.md "How hash-grid's pass is built"); on a GPU the device builds it.
//
// Parameters (PpmOptions, illuminate.h):
// | option      | default | meaning                                                            |
// |-------------|---------|--------------------------------------------------------------------|
// | hash_cell   | 2       | cell side in units of the largest hitpoint radius (× 1.0001²)      |
// | hash_slots  | 0       | table size, a power of two; 0 = automatic (hash_grid_layout)       |
// | hash_order  | auto    | who orders the photons: auto (host on a CPU device, else device),  |
// |             |         | device, host                                                       |
#pragma once
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "photonflow/foundations/shared_types.h"

namespace pf {

enum class HashOrder { Auto, Device, Host };

// "auto" | "device" | "host" (InputError for anything else).
HashOrder parse_hash_order(const std::string& name);
const char* hash_order_name(HashOrder o);

struct HashGridLayout {
  float origin[3] = {0, 0, 0};
  float cell = 1.f;
  int32_t n[3] = {1, 1, 1};
  uint32_t mask = 0;   // table of mask + 1 slots
  int32_t unique = 0;  // every cell has a slot of its own (cells <= slots): rows are runs
  size_t slots() const { return size_t(mask) + 1; }
};

// The layout over the box origin + [0, extent] for `photons` photons: cells of side `cell`
// (ceil(extent / cell) per axis, 1 .. 2^24), and a table of `slots` slots (a power of two,
// InputError otherwise) or, with slots = 0, the smallest power of two ≥ max(1024, photons), raised
// to hold every cell when up to 4 times that does, lowered (not below 1024) when fewer slots hold
// every cell (no two cells share a slot then: `unique`).
HashGridLayout hash_grid_layout(const float origin[3], const float extent[3], float cell,
                                size_t photons, int slots);

// The host ordering of photons[0 .. n) into keys (hash_grid_key_blocks(n) blocks; the last
// block's unused lanes zero), payload (n) and slot_start (slots() + 1 entries, the last = n).
// Checks the photons as build_photon_grid does (photon_grid.h: mesh in [0, mesh_count), finite
// position; std::invalid_argument naming the first bad photon, before anything is written but
// slot_start). Deterministic for any thread
// count (threads 0 = OpenMP's default): worker w takes a contiguous run of photons, counts its
// slots, one pass over the table turns the counts into per-worker cursors, and each worker
// scatters its run in order.
void order_hash_grid(const HashGridLayout& g, const pf_photon* photons, size_t n, int mesh_count,
                     pf_photon_keys4* keys, pf_photon_payload* payload, int32_t* slot_start,
                     int threads = 0);

// Key blocks for n photons: ceil(n / 4).
inline size_t hash_grid_key_blocks(size_t n) { return (n + 3) / 4; }

// The order in which a resident state keeps its hitpoints on the device (DevicePpmState): by the
// Morton code (Z-order; x in the lowest bit) of the cell of side `cell` over `origin` that holds
// each hitpoint's position, stably (equal codes keep their index order). Hitpoints gathered one
// after another then read the same rows of the hashed grid, where image order scatters the
// rows of one work-group along a scanline (the clusters' idea, without fillers). A hitpoint's
// gather does not depend on the others, so the order changes no result. Coordinates are clamped
// to [0, 2^21); a non-finite position counts as coordinate 0. Returns order[i] = the index of the
// hitpoint stored at position i; the identity when cell is not finite and positive.
std::vector<int32_t> hitpoint_cell_order(const std::vector<pf_hitpoint>& hitpoints,
                                         const float origin[3], float cell);

// The cell side of DevicePpmState's hitpoint order, in units of the largest radius: cells of 2
// and 8 radii gather as fast on PoCL (docs/BENCHMARKS.md "How hash-grid's pass is built"); larger
// blocks keep more of a scanline together.
constexpr float kHitpointOrderCell = 8.f;


}  // namespace pf
