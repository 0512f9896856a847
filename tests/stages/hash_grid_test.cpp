// hash_grid_test.cpp — the hashed photon grid's layout and host ordering (hash_grid.h), without
// OpenCL: the table size rule, and order_hash_grid against a reference stable sort by slot for
// several thread counts and table sizes. (test_gather_methods checks that the device's kernels
// build the same arrays.)
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <cstring>
#include <numeric>
#include <vector>

#include "photonflow/foundations/error.h"
#include "photonflow/stages/grid_shared.h"
#include "photonflow/stages/hash_grid.h"
#include "photonflow/foundations/morton.h"
#include "photonflow/foundations/rng.h"

using namespace pf;

namespace {

// n photons in [-0.1, 1.1]³ (some beyond the grid's box [0, 1]³: clamped into edge cells), on 5
// meshes, a third of them direct; dir and flux distinct per photon.
std::vector<pf_photon> random_photons(size_t n) {
  std::vector<pf_photon> v(n);
  for (size_t i = 0; i < n; ++i) {
    pf_rng r = pf_rng_start(7, 0, uint32_t(i));
    pf_photon& p = v[i];
    for (int a = 0; a < 3; ++a) {
      p.position[a] = -0.1f + 1.2f * pf_rng_next(&r);
      p.dir[a] = pf_rng_next(&r) - 0.5f;
      p.flux[a] = float(i) + 0.25f * float(a);
    }
    p.mesh = int(i % 5);
    p.pass = 0;
    p.flags = i % 3 == 0 ? PF_PHOTON_DIRECT : 0;
  }
  return v;
}

uint32_t slot_of(const HashGridLayout& g, const pf_photon& p) {
  const int x = pf_grid_coord(p.position[0], g.origin[0], g.cell, g.n[0]);
  const int y = pf_grid_coord(p.position[1], g.origin[1], g.cell, g.n[1]);
  const int z = pf_grid_coord(p.position[2], g.origin[2], g.cell, g.n[2]);
  return pf_hash_slot(x, y, z, uint32_t(g.n[0]), uint32_t(g.n[1]), g.mask);
}

}  // namespace

TEST_CASE("hash grid: table size and cells", "[hash_grid]") {
  const float o[3] = {0, 0, 0}, e[3] = {1, 0.5f, 0.25f};
  // 10 × 5 × 3 = 150 cells of 0.1 (ceil(2.5) = 3), 100 photons: 1024 slots, one per cell.
  HashGridLayout g = hash_grid_layout(o, e, 0.1f, 100, 0);
  CHECK(g.n[0] == 10);
  CHECK(g.n[1] == 5);
  CHECK(g.n[2] == 3);
  CHECK(g.slots() == 1024);
  CHECK(g.unique == 1);
  // 5000 photons, 150 cells: 8192 slots would do, but 1024 give every cell its own.
  CHECK(hash_grid_layout(o, e, 0.1f, 5000, 0).slots() == 1024);
  CHECK(hash_grid_layout(o, e, 0.1f, 5000, 0).unique == 1);
  // Cells of 1/64 (exact): 64 × 32 × 16 = 32,768 cells, 10,000 photons: 16,384 slots would
  // share cells, and 4 × 16,384 holds them all, so the table grows to 32,768 (unique).
  g = hash_grid_layout(o, e, 1.f / 64, 10000, 0);
  CHECK(g.n[0] * g.n[1] * g.n[2] == 32768);
  CHECK(g.slots() == 32768);
  CHECK(g.unique == 1);
  // 40,000 photons (65,536 slots), 32,768 cells: lowered to 32,768.
  g = hash_grid_layout(o, e, 1.f / 64, 40000, 0);
  CHECK(g.slots() == 32768);
  CHECK(g.unique == 1);
  // 1,000 photons, 32,768 cells > 4 × 1024: the table stays at 1024, cells share slots.
  g = hash_grid_layout(o, e, 1.f / 64, 1000, 0);
  CHECK(g.slots() == 1024);
  CHECK(g.unique == 0);
  // An explicit table size; not a power of two is refused.
  CHECK(hash_grid_layout(o, e, 0.1f, 100, 64).slots() == 64);
  CHECK(hash_grid_layout(o, e, 0.1f, 100, 64).unique == 0);
  CHECK_THROWS_AS(hash_grid_layout(o, e, 0.1f, 100, 48), InputError);
  CHECK_THROWS_AS(hash_grid_layout(o, e, 0.1f, 100, -4), InputError);
}

TEST_CASE("hash grid: the host ordering is the stable sort by slot", "[hash_grid]") {
  const std::vector<pf_photon> ph = random_photons(70001);  // above the parallel threshold; a partial last key block
  const float o[3] = {0, 0, 0}, e[3] = {1, 1, 1};
  for (int slots : {0, 64, 1}) {
    const HashGridLayout g = hash_grid_layout(o, e, 0.03f, ph.size(), slots);
    INFO("slots " << g.slots());
    // Reference: photon indices stably sorted by slot; the start of every slot.
    std::vector<uint32_t> order(ph.size());
    std::iota(order.begin(), order.end(), 0u);
    std::stable_sort(order.begin(), order.end(),
                     [&](uint32_t a, uint32_t b) { return slot_of(g, ph[a]) < slot_of(g, ph[b]); });
    std::vector<int32_t> start(g.slots() + 1, 0);
    for (const pf_photon& p : ph) start[slot_of(g, p) + 1] += 1;
    std::partial_sum(start.begin(), start.end(), start.begin());
    size_t used = 0;
    for (size_t k = 0; k < g.slots(); ++k) used += start[k + 1] > start[k];
    CHECK(used > std::min<size_t>(g.slots() / 2, 1000));  // photons spread over the table
    for (int threads : {1, 2, 3}) {
      INFO("threads " << threads);
      std::vector<pf_photon_keys4> keys(hash_grid_key_blocks(ph.size()));
      std::vector<pf_photon_payload> payload(ph.size());
      std::vector<int32_t> got(g.slots() + 1, -1);
      order_hash_grid(g, ph.data(), ph.size(), 5, keys.data(), payload.data(), got.data(),
                      threads);
      CHECK(got == start);
      size_t same = 0;
      for (size_t j = 0; j < ph.size(); ++j) {
        const pf_photon& p = ph[order[j]];
        const pf_photon_keys4& k = keys[j / 4];
        const size_t l = j % 4;
        same += k.x[l] == p.position[0] && k.y[l] == p.position[1] && k.z[l] == p.position[2] &&
                k.key[l] == 2 * p.mesh + ((p.flags & PF_PHOTON_DIRECT) ? 1 : 0) &&
                std::memcmp(payload[j].dir, p.dir, sizeof p.dir) == 0 &&
                std::memcmp(payload[j].flux, p.flux, sizeof p.flux) == 0;
      }
      CHECK(same == ph.size());
      for (size_t j = ph.size(); j < 4 * keys.size(); ++j) {  // unused lanes: zero
        const pf_photon_keys4& k = keys[j / 4];
        CHECK((k.x[j % 4] == 0.f && k.y[j % 4] == 0.f && k.z[j % 4] == 0.f && k.key[j % 4] == 0));
      }
    }
  }
  // No photons: every slot starts (and ends) at 0.
  const HashGridLayout g = hash_grid_layout(o, e, 0.1f, 0, 0);
  std::vector<int32_t> got(g.slots() + 1, -1);
  order_hash_grid(g, nullptr, 0, 5, nullptr, nullptr, got.data(), 2);
  CHECK(std::all_of(got.begin(), got.end(), [](int32_t v) { return v == 0; }));
}

TEST_CASE("hash grid: the host ordering refuses bad photons, naming the first", "[hash_grid]") {
  std::vector<pf_photon> ph = random_photons(70001);
  const float o[3] = {0, 0, 0}, e[3] = {1, 1, 1};
  const HashGridLayout g = hash_grid_layout(o, e, 0.03f, ph.size(), 0);
  std::vector<pf_photon_keys4> keys(hash_grid_key_blocks(ph.size()));
  std::vector<pf_photon_payload> payload(ph.size());
  std::vector<int32_t> start(g.slots() + 1);
  auto message = [&](int threads) {
    try {
      order_hash_grid(g, ph.data(), ph.size(), 5, keys.data(), payload.data(), start.data(),
                      threads);
    } catch (const std::invalid_argument& x) {
      return std::string(x.what());
    }
    return std::string("no error");
  };
  ph[60000].position[1] = NAN;  // in the second worker's half
  ph[50000].mesh = 5;           // the first bad photon: in the second half too with 2 threads
  for (int threads : {1, 2, 3}) {
    INFO("threads " << threads);
    CHECK(message(threads) == "photon grid: photon 50000 has mesh id 5 outside [0, 5)");
  }
  ph[50000].mesh = 0;
  ph[10].mesh = -1;  // now the first, in the first worker's run
  for (int threads : {1, 2}) CHECK(message(threads).find("photon 10 has mesh id -1") != std::string::npos);
  ph[10].mesh = 0;
  for (int threads : {1, 2}) CHECK(message(threads) == "photon grid: photon 60000 has a non-finite position");
}

TEST_CASE("hash grid: ordering names", "[hash_grid]") {
  for (HashOrder o : {HashOrder::Auto, HashOrder::Device, HashOrder::Host})
    CHECK(parse_hash_order(hash_order_name(o)) == o);
  CHECK_THROWS_AS(parse_hash_order("gpu"), InputError);
}

TEST_CASE("hash grid: hitpoints in cell order (Z-order of cells, stable)", "[hash_grid]") {
  // A 64 × 48 "image" of hitpoints on the plane z = 0.5 of [0, 1]³, in scanline order, as the eye
  // pass writes them; cells of 1/8.
  const int w = 64, hgt = 48;
  std::vector<pf_hitpoint> hps(size_t(w) * hgt);
  for (int y = 0; y < hgt; ++y)
    for (int x = 0; x < w; ++x) {
      pf_hitpoint& hp = hps[size_t(y) * w + size_t(x)];
      std::memset(&hp, 0, sizeof hp);
      hp.position[0] = (x + 0.5f) / w;
      hp.position[1] = (y + 0.5f) / hgt;
      hp.position[2] = 0.5f;
    }
  const float origin[3] = {0.f, 0.f, 0.f};
  const float cell = 0.125f;
  const std::vector<int32_t> order = hitpoint_cell_order(hps, origin, cell);

  // A permutation of the indices.
  std::vector<int32_t> sorted = order;
  std::sort(sorted.begin(), sorted.end());
  std::vector<int32_t> identity(hps.size());
  std::iota(identity.begin(), identity.end(), 0);
  CHECK(sorted == identity);
  CHECK(order != identity);  // scanline order is not cell order

  // Each cell's hitpoints form one run, in index order; the cells come in Z-order (x, y, z
  // interleaved from the lowest bit): the cell of (x, y) precedes (x + 1, y) within a 2 × 2 block,
  // and (x, y + 1) follows both.
  auto cell_of = [&](int32_t i) {
    const int cx = int(hps[size_t(i)].position[0] / cell), cy = int(hps[size_t(i)].position[1] / cell);
    return std::pair<int, int>(cx, cy);
  };
  auto z = [](int cx, int cy) {  // reference Z-order code of two coordinates (z = 4 for all)
    uint64_t c = 0;
    for (int b = 0; b < 8; ++b)
      c |= uint64_t((cx >> b) & 1) << (3 * b) | uint64_t((cy >> b) & 1) << (3 * b + 1) |
           uint64_t((4 >> b) & 1) << (3 * b + 2);
    return c;
  };
  for (size_t k = 1; k < order.size(); ++k) {
    const auto a = cell_of(order[k - 1]), b = cell_of(order[k]);
    const uint64_t za = z(a.first, a.second), zb = z(b.first, b.second);
    REQUIRE(za <= zb);
    if (za == zb) REQUIRE(order[k - 1] < order[k]);
  }
  CHECK(cell_of(order.front()) == std::pair<int, int>(0, 0));
  CHECK(cell_of(order[size_t(8 * 6)]) == std::pair<int, int>(1, 0));  // 8 × 6 hitpoints per cell
  CHECK(cell_of(order[size_t(2 * 8 * 6)]) == std::pair<int, int>(0, 1));

  // No usable cell side: the identity. Non-finite positions count as coordinate 0.
  CHECK(hitpoint_cell_order(hps, origin, 0.f) == identity);
  CHECK(hitpoint_cell_order(hps, origin, std::nanf("")) == identity);
  CHECK(hitpoint_cell_order(hps, origin, INFINITY) == identity);
  REQUIRE(cell_of(20).first == 2);
  hps[20].position[0] = std::nanf("");
  hps[20].position[1] = INFINITY;
  const std::vector<int32_t> with_nan = hitpoint_cell_order(hps, origin, cell);
  // Hitpoint 20 joins cell (0, 0)'s run (then 49 long), in index order after 0..7.
  const std::vector<int32_t> run(with_nan.begin(), with_nan.begin() + 8 * 6 + 1);
  CHECK(std::is_sorted(run.begin(), run.end()));
  CHECK(std::find(run.begin(), run.end(), 20) != run.end());
  CHECK(with_nan[8] == 20);
}

TEST_CASE("hash grid: a cell's slot is its linear index modulo the table (grid_shared.h)",
          "[hash_grid]") {
  // pf_hash_slot(x, y, z) = (x + nx·(y + ny·z)) mod (mask + 1): the linear index of eq. 7.1's
  // offset, so that cells next to each other along x get consecutive slots, and a table with at
  // least as many slots as cells (`unique`) gives every cell a slot of its own — which the gather
  // relies on when it reads a row of cells as one run of slots. Checked on a grid that is not a
  // cube (nx, ny, nz all different).
  const float o[3] = {0, 0, 0}, e[3] = {1, 0.5f, 0.25f};
  for (int slots : {0, 4096}) {
    const HashGridLayout g = hash_grid_layout(o, e, 1.f / 64, 10000, slots);
    INFO("slots " << g.slots());
    REQUIRE((g.n[0] == 64 && g.n[1] == 32 && g.n[2] == 16));
    const uint32_t nx = uint32_t(g.n[0]), ny = uint32_t(g.n[1]);
    std::vector<uint8_t> taken(g.slots(), 0);
    size_t wrong = 0, shared = 0;
    for (int z = 0; z < g.n[2]; ++z)
      for (int y = 0; y < g.n[1]; ++y)
        for (int x = 0; x < g.n[0]; ++x) {
          const uint32_t linear = uint32_t(x) + uint32_t(y) * nx + uint32_t(z) * nx * ny;
          const uint32_t s = pf_hash_slot(x, y, z, nx, ny, g.mask);
          wrong += s != linear % uint32_t(g.slots());
          shared += taken[s]++ > 0;
        }
    CHECK(wrong == 0);
    if (g.unique) CHECK(shared == 0);
    else CHECK(shared == size_t(g.n[0]) * g.n[1] * g.n[2] - g.slots());  // every slot used
  }
}

TEST_CASE("Morton codes interleave all 21 bits of each coordinate (morton.h)", "[hash_grid]") {
  // Bit i of x goes to bit 3i, of y to 3i + 1, of z to 3i + 2 (x in the lowest bit), for every
  // i < 21; higher bits are ignored. Reference: the interleaving bit by bit.
  auto reference = [](uint64_t x, uint64_t y, uint64_t z) {
    uint64_t c = 0;
    for (int b = 0; b < 21; ++b)
      c |= ((x >> b) & 1) << (3 * b) | ((y >> b) & 1) << (3 * b + 1) | ((z >> b) & 1) << (3 * b + 2);
    return c;
  };
  size_t wrong = 0;
  for (uint32_t k = 0; k < 20000; ++k) {
    pf_rng r = pf_rng_start(11, 0, k);
    uint64_t c[3];
    for (uint64_t& v : c) v = uint64_t(pf_rng_next(&r) * 16777216.f);  // 24 random bits
    if (k < 64) c[k % 3] = (uint64_t(1) << 21) - 1 - (k / 3);          // near the top bit
    wrong += morton3(c[0], c[1], c[2]) != reference(c[0], c[1], c[2]);
    wrong += morton_spread3(c[k % 3]) != reference(c[k % 3], 0, 0);
  }
  CHECK(wrong == 0);
  CHECK(morton3(0x1fffff, 0x1fffff, 0x1fffff) == (uint64_t(1) << 63) - 1);
}
