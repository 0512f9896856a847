// morton.h — Morton (Z-order) codes of 3D cell coordinates: k-means seeding (clusters.cpp) and the
// resident hitpoints' cell order (hash_grid.h) sort by them.
#pragma once

#include <cstdint>

namespace pf {

// The low 21 bits of v spread to every third bit (bit i → bit 3i).
inline uint64_t morton_spread3(uint64_t v) {
  v &= 0x1fffff;
  v = (v | v << 32) & 0x1f00000000ffffull;
  v = (v | v << 16) & 0x1f0000ff0000ffull;
  v = (v | v << 8) & 0x100f00f00f00f00full;
  v = (v | v << 4) & 0x10c30c30c30c30c3ull;
  v = (v | v << 2) & 0x1249249249249249ull;
  return v;
}

// The Morton code of cell (x, y, z), each coordinate's low 21 bits; x in the lowest bit.
inline uint64_t morton3(uint64_t x, uint64_t y, uint64_t z) {
  return morton_spread3(x) | morton_spread3(y) << 1 | morton_spread3(z) << 2;
}

}  // namespace pf
