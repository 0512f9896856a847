// clusters.cpp — k-means and grid clusters of hitpoints (thesis ch. 7.3), see clusters.h.
#include "photonflow/stages/clusters.h"

#include <omp.h>

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstddef>
#include <limits>
#include <stdexcept>

#include "photonflow/io/h5io.h"
#include "photonflow/foundations/hash.h"
#include "photonflow/foundations/morton.h"
#include "photonflow/stages/photon_grid.h"
#include "photonflow/foundations/threads.h"
#include "photonflow/io/validate.h"

namespace pf {

namespace {
constexpr int kClustersVersion = 1;
// Automatic grid-cluster bins (cluster_grid with max_bins = 0).
constexpr int kAutoBins = 64;
constexpr int kAutoFill = 2;

// The hitpoint indices of each mesh, ascending (mesh ids 0 … max).
std::vector<std::vector<int32_t>> split_by_mesh(const HitpointSet& h) {
  if (h.hitpoints.size() > size_t(std::numeric_limits<int32_t>::max()))
    throw std::invalid_argument("clusters: more than 2^31-1 hitpoints");
  int meshes = 0;
  for (size_t i = 0; i < h.hitpoints.size(); ++i) {
    const pf_hitpoint& p = h.hitpoints[i];
    if (p.mesh < 0)
      throw std::invalid_argument("clusters: hitpoint " + std::to_string(i) + " has mesh id " +
                                  std::to_string(p.mesh));
    if (!std::isfinite(p.position[0]) || !std::isfinite(p.position[1]) ||
        !std::isfinite(p.position[2]))
      throw std::invalid_argument("clusters: hitpoint " + std::to_string(i) +
                                  " has a non-finite position");
    meshes = std::max(meshes, p.mesh + 1);
  }
  std::vector<size_t> count(size_t(meshes), 0);
  for (const pf_hitpoint& p : h.hitpoints) ++count[size_t(p.mesh)];
  std::vector<std::vector<int32_t>> out;
  out.resize(size_t(meshes));
  for (int m = 0; m < meshes; ++m) out[size_t(m)].reserve(count[size_t(m)]);
  for (size_t i = 0; i < h.hitpoints.size(); ++i)
    out[size_t(h.hitpoints[i].mesh)].push_back(int32_t(i));
  return out;
}

struct Box {
  float lo[3] = {INFINITY, INFINITY, INFINITY};
  float hi[3] = {-INFINITY, -INFINITY, -INFINITY};
};

Box box_of(const HitpointSet& h, const std::vector<int32_t>& idx) {
  Box b;
  for (int32_t i : idx)
    for (int a = 0; a < 3; ++a) {
      float x = h.hitpoints[size_t(i)].position[a];
      b.lo[a] = std::min(b.lo[a], x);
      b.hi[a] = std::max(b.hi[a], x);
    }
  return b;
}

// Eq. 7.1 header over a box of `count` hitpoints.
pf_mesh_grid grid_header(const Box& b, size_t count, int max_bins, float radius0) {
  pf_mesh_grid g{};
  g.photon_count = pf_int(count);
  if (count == 0) {
    g.bin_size = radius0 > 0.f ? radius0 : 1.f;
    return g;
  }
  float ext[3];
  for (int a = 0; a < 3; ++a) {
    g.lo[a] = b.lo[a];
    ext[a] = b.hi[a] - b.lo[a];
  }
  float longest = std::max(ext[0], std::max(ext[1], ext[2]));
  float d = std::max(longest / float(max_bins), radius0 > 0.f ? radius0 : 0.f);
  if (!(d > 0.f)) d = 1.f;  // all hitpoints at one point and no R0: one bin
  g.bin_size = d;
  int* n[3] = {&g.nx, &g.ny, &g.nz};
  for (int a = 0; a < 3; ++a) *n[a] = std::clamp(int(std::ceil(ext[a] / d)), 1, max_bins);
  return g;
}

inline int cell_of(const pf_mesh_grid& g, const float* p) {
  return grid_coord(p[0], g.lo[0], g.bin_size, g.nx) +
         (grid_coord(p[1], g.lo[1], g.bin_size, g.ny) +
          grid_coord(p[2], g.lo[2], g.bin_size, g.nz) * g.ny) *
             g.nx;
}

// R = max(|x − c| + r) over the members, in double, rounded up to float.
float shared_radius(const float c[3], const int32_t* members, size_t n, const HitpointSet& h) {
  double m = 0;
  for (size_t k = 0; k < n; ++k) {
    const pf_hitpoint& p = h.hitpoints[size_t(members[k])];
    double dx = double(p.position[0]) - c[0], dy = double(p.position[1]) - c[1],
           dz = double(p.position[2]) - c[2];
    m = std::max(m, std::sqrt(dx * dx + dy * dy + dz * dz) + double(p.radius));
  }
  float r = float(m);
  if (double(r) < m) r = std::nextafter(r, INFINITY);
  return r;
}

// Uniform grid over the centres of one mesh, for nearest-centre queries.
struct CentreGrid {
  float lo[3];
  float s;
  int n[3];
  std::vector<int32_t> start;  // cells + 1
  std::vector<int32_t> items;  // centre indices, by cell then index
  std::vector<float> pos;      // centres, xyz interleaved (copy, in item order)

  void setup(const Box& b, size_t k) {
    float ext[3];
    for (int a = 0; a < 3; ++a) {
      lo[a] = b.lo[a];
      ext[a] = b.hi[a] - b.lo[a];
    }
    float longest = std::max(ext[0], std::max(ext[1], ext[2]));
    // About two centres per cell: shrink the cell until the grid has >= k/2 cells.
    const double target = std::max(1.0, double(k) / 2.0);
    s = longest > 0.f ? longest : 1.f;
    auto cells = [&](float sz) {
      double c = 1;
      for (int a = 0; a < 3; ++a) c *= std::clamp(std::ceil(double(ext[a]) / sz), 1.0, 4096.0);
      return c;
    };
    while (longest > 0.f && cells(s) < target && s > longest * 1e-4f) s *= 0.9f;
    for (int a = 0; a < 3; ++a) n[a] = std::clamp(int(std::ceil(ext[a] / s)), 1, 4096);
  }
  int coord(float x, int a) const { return grid_coord(x, lo[a], s, n[a]); }

  void build(const std::vector<float>& centres) {
    const size_t k = centres.size() / 3;
    const size_t cells = size_t(n[0]) * size_t(n[1]) * size_t(n[2]);
    start.assign(cells + 1, 0);
    std::vector<int32_t> key(k);
    for (size_t j = 0; j < k; ++j) {
      const float* c = &centres[3 * j];
      key[j] = coord(c[0], 0) + (coord(c[1], 1) + coord(c[2], 2) * n[1]) * n[0];
      ++start[size_t(key[j]) + 1];
    }
    for (size_t e = 0; e < cells; ++e) start[e + 1] += start[e];
    std::vector<int32_t> cur(start.begin(), start.end() - 1);
    items.resize(k);
    pos.resize(3 * k);
    for (size_t j = 0; j < k; ++j) {
      int32_t at = cur[size_t(key[j])]++;
      items[size_t(at)] = int32_t(j);
      for (int a = 0; a < 3; ++a) pos[3 * size_t(at) + size_t(a)] = centres[3 * j + size_t(a)];
    }
  }

  // Nearest centre of p (ties: lower index). Searches shells of cells around p's cell until the
  // best distance is no larger than the distance from p to the unsearched cells. Distances are in
  // double, where the square of any float difference is finite, and the first centre seen is
  // taken whatever its distance: a float square overflowed to infinity for a hitpoint 1e20 away,
  // no centre was ever nearer than FLT_MAX, and the index stayed INT32_MAX (a write out of
  // bounds in the caller).
  int32_t nearest(const float* p) const {
    int c[3];
    for (int a = 0; a < 3; ++a) c[a] = coord(p[a], a);
    double best = INFINITY;
    int32_t besti = -1;
    const int maxr = std::max(n[0], std::max(n[1], n[2]));
    for (int r = 0; r <= maxr; ++r) {
      int z0 = std::max(0, c[2] - r), z1 = std::min(n[2] - 1, c[2] + r);
      int y0 = std::max(0, c[1] - r), y1 = std::min(n[1] - 1, c[1] + r);
      int x0 = std::max(0, c[0] - r), x1 = std::min(n[0] - 1, c[0] + r);
      for (int z = z0; z <= z1; ++z) {
        const bool zin = std::abs(z - c[2]) == r;
        for (int y = y0; y <= y1; ++y) {
          const bool yzin = zin || std::abs(y - c[1]) == r;
          const int row = (y + z * n[1]) * n[0];
          // on an inner row only the two end cells x = c ± r are on the shell
          for (int x = x0; x <= x1; ++x) {
            if (!yzin && std::abs(x - c[0]) != r) {
              if (x < c[0] + r) x = std::min(c[0] + r, x1 + 1) - 1;
              continue;
            }
            const int e = row + x;
            for (int32_t t = start[size_t(e)]; t < start[size_t(e) + 1]; ++t) {
              const float* q = &pos[3 * size_t(t)];
              const double dx = double(p[0]) - q[0], dy = double(p[1]) - q[1],
                           dz = double(p[2]) - q[2];
              const double d2 = dx * dx + dy * dy + dz * dz;
              const int32_t j = items[size_t(t)];
              if (besti < 0 || d2 < best || (d2 == best && j < besti)) {
                best = d2;
                besti = j;
              }
            }
          }
        }
      }
      // Distance from p to the cells outside the searched cube.
      double bound = INFINITY;
      for (int a = 0; a < 3; ++a) {
        if (c[a] - r > 0) bound = std::min(bound, double(p[a]) - (double(lo[a]) + double(c[a] - r) * s));
        if (c[a] + r < n[a] - 1)
          bound = std::min(bound, (double(lo[a]) + double(c[a] + r + 1) * s) - double(p[a]));
      }
      if (bound == INFINITY) break;  // the whole grid was searched
      bound = std::max(0.0, bound - 1e-5 * double(s));
      if (besti >= 0 && best <= bound * bound) break;
    }
    return besti;
  }
};

void kmeans_mesh(ClusterSet& out, int mesh, const std::vector<int32_t>& idx, const HitpointSet& h,
                 int iterations, int threads) {
  const size_t n = idx.size();
  if (n == 0) return;
  const size_t wg = size_t(out.wg_size);
  const size_t k = (n + wg - 1) / wg;
  const Box b = box_of(h, idx);
  // Seeding: Morton order over the box, K runs of nearly equal size, centre = run mean.
  std::vector<std::pair<uint64_t, int32_t>> keyed(n);
  {
    double ext[3];  // in double: a float extent of hitpoints near ±FLT_MAX overflows
    for (int a = 0; a < 3; ++a) ext[a] = double(b.hi[a]) - double(b.lo[a]);
#pragma omp parallel for schedule(static) num_threads(threads)
    for (int64_t t = 0; t < int64_t(n); ++t) {
      const float* p = h.hitpoints[size_t(idx[size_t(t)])].position;
      uint64_t code = 0;
      for (int a = 0; a < 3; ++a) {
        uint64_t q = ext[a] > 0 ? uint64_t((double(p[a]) - b.lo[a]) / ext[a] * 2097151.0) : 0;
        code |= morton_spread3(std::min<uint64_t>(q, 2097151)) << a;
      }
      keyed[size_t(t)] = {code, idx[size_t(t)]};
    }
  }
  std::sort(keyed.begin(), keyed.end());
  std::vector<float> centres(3 * k);
  for (size_t j = 0; j < k; ++j) {
    size_t b0 = n * j / k, b1 = n * (j + 1) / k;
    double s[3] = {0, 0, 0};
    for (size_t t = b0; t < b1; ++t)
      for (int a = 0; a < 3; ++a) s[a] += h.hitpoints[size_t(keyed[t].second)].position[a];
    for (int a = 0; a < 3; ++a) centres[3 * j + size_t(a)] = float(s[a] / double(b1 - b0));
  }
  std::vector<std::pair<uint64_t, int32_t>>().swap(keyed);

  std::vector<int32_t> assign(n, -1);
  CentreGrid grid;
  grid.setup(b, k);
  std::vector<double> sum(3 * k);
  std::vector<int64_t> cnt(k);
  for (int it = 0; it <= iterations; ++it) {
    grid.build(centres);
    int64_t changed = 0;
#pragma omp parallel for schedule(static) num_threads(threads) reduction(+ : changed)
    for (int64_t t = 0; t < int64_t(n); ++t) {
      int32_t j = grid.nearest(h.hitpoints[size_t(idx[size_t(t)])].position);
      if (j != assign[size_t(t)]) {
        assign[size_t(t)] = j;
        ++changed;
      }
    }
    if (it == iterations || changed == 0) break;
    // Update: means in double, summed in hitpoint order (independent of the thread count).
    std::fill(sum.begin(), sum.end(), 0.0);
    std::fill(cnt.begin(), cnt.end(), 0);
    for (size_t t = 0; t < n; ++t) {
      const size_t j = size_t(assign[t]);
      const float* p = h.hitpoints[size_t(idx[t])].position;
      for (int a = 0; a < 3; ++a) sum[3 * j + size_t(a)] += p[a];
      ++cnt[j];
    }
    for (size_t j = 0; j < k; ++j)
      if (cnt[j] > 0)  // an empty cluster keeps its centre (and is dropped at the end if still empty)
        for (int a = 0; a < 3; ++a) centres[3 * j + size_t(a)] = float(sum[3 * j + size_t(a)] / double(cnt[j]));
  }
  // Members per centre, ascending hitpoint index (stable counting sort).
  std::vector<int32_t> start(k + 1, 0);
  for (size_t t = 0; t < n; ++t) ++start[size_t(assign[t]) + 1];
  for (size_t j = 0; j < k; ++j) start[j + 1] += start[j];
  std::vector<int32_t> members(n);
  {
    std::vector<int32_t> cur(start.begin(), start.end() - 1);
    for (size_t t = 0; t < n; ++t) members[size_t(cur[size_t(assign[t])]++)] = idx[t];
  }
  for (size_t j = 0; j < k; ++j)
    append_cluster(out, mesh, members.data() + start[j], size_t(start[j + 1] - start[j]), h);
}

}  // namespace

namespace {
// Work-group sizes the clusterings take (clusters.h: kMaxWorkGroupSize).
void check_wg_size(int wg_size) {
  if (wg_size < 1) throw std::invalid_argument("clusters: work-group size must be >= 1");
  if (wg_size > kMaxWorkGroupSize)
    throw input_error("", "work-group size " + std::to_string(wg_size) + " is too large: at most " +
                              std::to_string(kMaxWorkGroupSize) + " work-items",
                      "give a smaller --wg-size or --work-group");
}

// An order array growing from `size` by `more` entries stays within kMaxOrderEntries.
void check_order_size(size_t size, size_t more, int wg_size) {
  if (int64_t(size) + int64_t(more) > kMaxOrderEntries)
    throw input_error("", "the clusters padded to work-groups of " + std::to_string(wg_size) +
                              " need more than 2^28 = 268435456 hitpoint and filler entries",
                      "lower --wg-size (or --max-bins of grid clusters)");
}
}  // namespace

ClusterSet empty_cluster_set(const HitpointSet& h, int wg_size, const std::string& method) {
  check_wg_size(wg_size);
  ClusterSet c;
  c.wg_size = wg_size;
  c.method = method;
  c.scene_id = h.scene_id;
  c.hitpoint_count = h.hitpoints.size();
  c.hitpoints_sha256 = hitpoints_hash(h);
  return c;
}

void cluster_centre_radius(const HitpointSet& h, const int32_t* members, size_t n, float centre[3],
                           float* radius) {
  double s[3] = {0, 0, 0};
  for (size_t k = 0; k < n; ++k)
    for (int a = 0; a < 3; ++a) s[a] += h.hitpoints[size_t(members[k])].position[a];
  for (int a = 0; a < 3; ++a) centre[a] = n ? float(s[a] / double(n)) : 0.f;
  *radius = shared_radius(centre, members, n, h);
}

// Appends one cluster of `members` (ascending hitpoint indices) with centre = their mean.
void append_cluster(ClusterSet& c, int mesh, const int32_t* members, size_t n, const HitpointSet& h) {
  if (n == 0) return;
  pf_cluster cl{};
  cluster_centre_radius(h, members, n, cl.centre, &cl.radius);
  cl.mesh = mesh;
  cl.first = pf_int(c.order.size());
  cl.count = pf_int(n);
  const size_t wg = size_t(c.wg_size);
  const size_t padded = (n + wg - 1) / wg * wg;
  check_order_size(c.order.size(), padded, c.wg_size);
  cl.padded_count = pf_int(padded);
  c.order.insert(c.order.end(), members, members + n);
  c.order.insert(c.order.end(), size_t(cl.padded_count) - n, -1);
  c.clusters.push_back(cl);
}

std::vector<int32_t> mesh_sorted_order(const HitpointSet& h, int wg_size) {
  check_wg_size(wg_size);
  std::vector<int32_t> order;
  for (const std::vector<int32_t>& idx : split_by_mesh(h)) {
    if (idx.empty()) continue;
    const size_t padded = (idx.size() + size_t(wg_size) - 1) / size_t(wg_size) * size_t(wg_size);
    check_order_size(order.size(), padded, wg_size);
    order.insert(order.end(), idx.begin(), idx.end());
    order.insert(order.end(), padded - idx.size(), -1);
  }
  return order;
}

std::string hitpoints_hash(const HitpointSet& h) {
  Sha256 s;
  int64_t head[3] = {h.width, h.height, int64_t(h.hitpoints.size())};
  s.update(head, sizeof head);
  for (const pf_hitpoint& p : h.hitpoints) {
    s.update(p.position, sizeof p.position);
    s.update(&p.pixel_x, sizeof p.pixel_x);
    s.update(&p.pixel_y, sizeof p.pixel_y);
    s.update(&p.mesh, sizeof p.mesh);
  }
  return s.hex();
}

ClusterSet cluster_kmeans(const HitpointSet& h, int wg_size, int iterations, uint32_t seed,
                          int threads) {
  (void)seed;  // the Morton seeding is deterministic (clusters.h)
  if (iterations < 0) throw std::invalid_argument("clusters: negative iteration count");
  ClusterSet c = empty_cluster_set(h, wg_size, "kmeans");
  const int nt = worker_threads(threads);
  auto per_mesh = split_by_mesh(h);
  c.order.reserve(h.hitpoints.size() + h.hitpoints.size() / 4);
  for (size_t m = 0; m < per_mesh.size(); ++m)
    kmeans_mesh(c, int(m), per_mesh[m], h, iterations, nt);
  return c;
}

pf_mesh_grid hitpoint_mesh_grid(const HitpointSet& h, int mesh, int max_bins) {
  if (max_bins < 1) throw std::invalid_argument("clusters: max_bins must be >= 1");
  check_max_bins(max_bins, "grid clusters");
  std::vector<int32_t> idx;
  for (size_t i = 0; i < h.hitpoints.size(); ++i)
    if (h.hitpoints[i].mesh == mesh) idx.push_back(int32_t(i));
  return grid_header(box_of(h, idx), idx.size(), max_bins, h.radius0);
}

// Non-empty cells of grid g over the hitpoints idx.
size_t occupied_cells(const pf_mesh_grid& g, const HitpointSet& h, const std::vector<int32_t>& idx) {
  std::vector<uint8_t> used(size_t(g.nx) * size_t(g.ny) * size_t(g.nz), 0);
  size_t n = 0;
  for (int32_t i : idx) {
    uint8_t& u = used[size_t(cell_of(g, h.hitpoints[size_t(i)].position))];
    n += u == 0;
    u = 1;
  }
  return n;
}

ClusterSet cluster_grid(const HitpointSet& h, int wg_size, int max_bins) {
  if (max_bins < 0) throw std::invalid_argument("clusters: max_bins must be >= 0");
  check_max_bins(max_bins, "grid clusters");
  ClusterSet c = empty_cluster_set(h, wg_size, "grid");
  auto per_mesh = split_by_mesh(h);
  c.order.reserve(h.hitpoints.size() + h.hitpoints.size() / 8);
  for (size_t m = 0; m < per_mesh.size(); ++m) {
    const auto& idx = per_mesh[m];
    if (idx.empty()) continue;
    const Box box = box_of(h, idx);
    pf_mesh_grid g;
    if (max_bins > 0) {
      g = grid_header(box, idx.size(), max_bins, h.radius0);
    } else {  // automatic: halve from kAutoBins until cells hold kAutoFill work-groups on average
      int bins = kAutoBins;
      g = grid_header(box, idx.size(), bins, h.radius0);
      while (bins > 1 && idx.size() < size_t(kAutoFill) * size_t(wg_size) * occupied_cells(g, h, idx)) {
        bins /= 2;
        g = grid_header(box, idx.size(), bins, h.radius0);
      }
    }
    // Before the cell table is allocated (photon_grid.h: kMaxGridEntries).
    check_grid_entries(mesh_grid_bins(g) + 1,
                       "the grid of mesh " + std::to_string(m) + "'s hitpoints",
                       "lower --max-bins, or trace the hitpoints with a larger --radius: the "
                       "cells are at least R0 wide");
    const size_t cells = size_t(mesh_grid_bins(g));
    std::vector<int32_t> key(idx.size()), start(cells + 1, 0);
    for (size_t t = 0; t < idx.size(); ++t) {
      key[t] = cell_of(g, h.hitpoints[size_t(idx[t])].position);
      ++start[size_t(key[t]) + 1];
    }
    for (size_t e = 0; e < cells; ++e) start[e + 1] += start[e];
    std::vector<int32_t> sorted(idx.size());
    {
      std::vector<int32_t> cur(start.begin(), start.end() - 1);
      for (size_t t = 0; t < idx.size(); ++t) sorted[size_t(cur[size_t(key[t])]++)] = idx[t];
    }
    const size_t wg = size_t(wg_size);
    for (size_t e = 0; e < cells; ++e)
      for (size_t b = size_t(start[e]); b < size_t(start[e + 1]); b += wg)
        append_cluster(c, int(m), sorted.data() + b, std::min(wg, size_t(start[e + 1]) - b), h);
  }
  return c;
}

ClusterStats stats(const ClusterSet& c) {
  ClusterStats s;
  s.clusters = c.clusters.size();
  double r = 0;
  for (const pf_cluster& cl : c.clusters) {
    s.hitpoints += size_t(cl.count);
    s.hitpoints_with_fillers += size_t(cl.padded_count);
    r += cl.radius;
  }
  s.fillers = s.hitpoints_with_fillers - s.hitpoints;
  s.mean_radius = s.clusters ? r / double(s.clusters) : 0.0;
  return s;
}

std::string check_clusters(const ClusterSet& c, const HitpointSet& h) {
  if (c.wg_size < 1) return "work-group size " + std::to_string(c.wg_size) + " is not positive";
  const int64_t n = int64_t(h.hitpoints.size());
  std::vector<uint8_t> seen(size_t(n), 0);
  int64_t next = 0;
  for (size_t k = 0; k < c.clusters.size(); ++k) {
    const pf_cluster& cl = c.clusters[k];
    const std::string which = "cluster " + std::to_string(k);
    if (cl.first != next) return which + " does not start where the previous one ends";
    if (cl.count < 1) return which + " is empty";
    if (int64_t(cl.padded_count) != (int64_t(cl.count) + c.wg_size - 1) / c.wg_size * c.wg_size)
      return which + ": padded_count is not count rounded up to the work-group size";
    if (int64_t(cl.first) + cl.padded_count > int64_t(c.order.size()))
      return which + " runs past the order array";
    for (int64_t t = cl.first; t < int64_t(cl.first) + cl.padded_count; ++t) {
      const int32_t i = c.order[size_t(t)];
      if (t >= int64_t(cl.first) + cl.count) {
        if (i != -1) return which + ": a hitpoint after the fillers began";
        continue;
      }
      if (i < 0 || i >= n) return which + ": hitpoint index " + std::to_string(i) + " out of range";
      if (seen[size_t(i)]++) return "hitpoint " + std::to_string(i) + " is in more than one cluster";
      if (h.hitpoints[size_t(i)].mesh != cl.mesh)
        return which + " mixes meshes (hitpoint " + std::to_string(i) + ")";
    }
    next += cl.padded_count;
  }
  if (next != int64_t(c.order.size())) return "the order array is longer than the clusters";
  for (int64_t i = 0; i < n; ++i)
    if (!seen[size_t(i)]) return "hitpoint " + std::to_string(i) + " is in no cluster";
  return "";
}

void update_cluster_radii(ClusterSet& c, const HitpointSet& h) {
#pragma omp parallel for schedule(dynamic, 64)
  for (int64_t k = 0; k < int64_t(c.clusters.size()); ++k) {
    pf_cluster& cl = c.clusters[size_t(k)];
    cl.radius = shared_radius(cl.centre, c.order.data() + cl.first, size_t(cl.count), h);
  }
}

// ---- clusters.h5 ----------------------------------------------------------------------------

namespace {
const h5::Compound& h5_type_cluster() {
  static const h5::Compound t = [] {
    h5::Compound c(sizeof(pf_cluster));
    c.f32("centre", offsetof(pf_cluster, centre), 3).f32("radius", offsetof(pf_cluster, radius));
    c.i32("mesh", offsetof(pf_cluster, mesh)).i32("first", offsetof(pf_cluster, first));
    c.i32("count", offsetof(pf_cluster, count));
    c.i32("padded_count", offsetof(pf_cluster, padded_count));
    return c;
  }();
  return t;
}
}  // namespace

void save_clusters(const ClusterSet& c, const std::string& path, const Provenance& prov,
                   const std::function<void(h5::Writer&)>& extra) {
  // The checks that need no hitpoints (the writer has none; load_clusters also checks the
  // clustering against them, check_clusters).
  written_check([&] { validate_cluster_values(c, path); });
  h5::Writer w(path, kClustersFormat, kClustersVersion);
  w.attr("/", "scene_id", c.scene_id);
  w.attr("/", "wg_size", int64_t(c.wg_size));
  w.attr("/", "method", c.method);
  w.attr("/", "hitpoint_count", int64_t(c.hitpoint_count));
  w.attr("/", "hitpoints_sha256", c.hitpoints_sha256);
  w.write("/clusters", h5_type_cluster(), c.clusters);
  w.describe("/clusters", "world units",
             "work-group clusters of one mesh each: centre, shared radius R = max(|x - centre| + r) "
             "over the members, mesh, first, count and padded_count in /order");
  w.write("/order", c.order);
  w.describe("/order", "", "hitpoint index of each work-item, -1 = filler (cluster tails)");
  if (extra) extra(w);
  write_provenance(w, prov);
  w.commit();
}

ClusterSet load_clusters(const std::string& path, const HitpointSet& h) {
  h5::Reader r(path, kClustersFormat, kClustersVersion);
  const Validator v(path, "the file is damaged; remake it with cluster");
  ClusterSet c;
  c.scene_id = r.scene_id();
  const int64_t wg_size = r.attr_int("/", "wg_size");
  v.int_in_range("attribute wg_size", wg_size, 1, kMaxWorkGroupSize);
  c.wg_size = int(wg_size);
  c.method = r.attr_string("/", "method");
  if (c.method != "kmeans" && c.method != "grid" && c.method != "ga")
    v.fail("attribute method '" + c.method + "' is none of \"kmeans\", \"grid\" and \"ga\"");
  c.hitpoint_count = uint64_t(r.attr_int("/", "hitpoint_count"));
  c.hitpoints_sha256 = r.attr_string("/", "hitpoints_sha256");
  if (c.scene_id != h.scene_id)
    throw input_error(path,
                      "was made for the hitpoints of a different scene (scene_id " +
                          c.scene_id.substr(0, 12) + " vs " + h.scene_id.substr(0, 12) + ")",
                      "rerun cluster on these hitpoints");
  if (c.hitpoint_count != h.hitpoints.size() || c.hitpoints_sha256 != hitpoints_hash(h))
    throw input_error(path,
                      "was made for other hitpoints (" + std::to_string(c.hitpoint_count) +
                          " hitpoints, sha256 " + c.hitpoints_sha256.substr(0, 12) + ") than these (" +
                          std::to_string(h.hitpoints.size()) + ", " +
                          hitpoints_hash(h).substr(0, 12) + ")",
                      "rerun cluster with the hitpoints of this eye pass");
  c.clusters = r.read<pf_cluster>("/clusters", h5_type_cluster());
  c.order = r.read<int32_t>("/order");
  std::string bad = check_clusters(c, h);
  if (!bad.empty())
    throw input_error(path, "is not a valid clustering: " + bad, "the file is damaged; remake it with cluster");
  validate_cluster_values(c, path);
  return c;
}

void validate_cluster_values(const ClusterSet& c, const std::string& path) {
  const Validator v(path, "the file is damaged; remake it with cluster");
  v.int_in_range("attribute wg_size", c.wg_size, 1, kMaxWorkGroupSize);
  if (c.method != "kmeans" && c.method != "grid" && c.method != "ga")
    v.fail("attribute method '" + c.method + "' is none of \"kmeans\", \"grid\" and \"ga\"");
  // Centres and radii: the clustered gathers read the bins of the sphere (centre, R), so a
  // non-finite centre would make them miss the photons every other method gathers. R is
  // refreshed from the hitpoints before use (update_cluster_radii) but must be a length.
  for (size_t k = 0; k < c.clusters.size(); ++k) {
    v.position(Name("clusters", k, "centre"), c.clusters[k].centre);
    v.in_range(Name("clusters", k, "radius"), &c.clusters[k].radius, 1, 0.0,
               4.0 * kMaxCoordinate);
  }
}

}  // namespace pf
