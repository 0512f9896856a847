// ga_centroid_grid.cpp — the uniform grid over one mesh's centroids (ga_chromosome.h,
// CentroidMesh) that the chromosome asks for the centroid nearest to a point and for the
// centroids near a point, so that adding or removing a centroid looks at its neighbours only.
#include "photonflow/stages/ga_chromosome.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>

namespace pf::ga {

void setup_centroid_grid(CentroidMesh& m, size_t k) {
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

int centroid_cell(const CentroidMesh& m, const float* p) {
  return pf_grid_coord(p[0], m.lo[0], m.s, m.n[0]) +
         (pf_grid_coord(p[1], m.lo[1], m.s, m.n[1]) +
          pf_grid_coord(p[2], m.lo[2], m.s, m.n[2]) * m.n[1]) * m.n[0];
}

void centroids_within(const CentroidMesh& m, const float c[3], double r,
                      std::vector<int32_t>& out) {
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

// The first candidate is taken whatever its distance (here and in the brute-force loops of
// Chromosome::remove_centroid and full_clusters), so that no comparison with an infinite or NaN
// distance can leave a hitpoint unassigned.
int32_t nearest_centroid(const CentroidMesh& m, const std::vector<Slot>& slots, const float* p,
                         int32_t exclude) {
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

}  // namespace pf::ga
