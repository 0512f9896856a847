// Tests of photon_grid.h: the per-mesh grid of eq. 7.1 (layout, counting sort, hand-computed
// example) and its gather against brute force.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numeric>
#include <stdexcept>
#include <vector>

#include "photonflow/stages/photon_grid.h"
#include "photonflow/foundations/rng.h"
#include "support.h"

using namespace pf;

namespace {

pf_photon photon_at(float x, float y, float z, int mesh) {
  pf_photon p;
  std::memset(&p, 0, sizeof p);
  p.position[0] = x;
  p.position[1] = y;
  p.position[2] = z;
  p.mesh = mesh;
  return p;
}

// Photons of three meshes in different places (mesh 2 gets none): mesh 0 a floor plane, mesh 1 a
// wall plane, mesh 3 a box-shaped volume; interleaved in the input order.
std::vector<pf_photon> scene_photons(int n, pf_uint seed) {
  std::vector<pf_photon> v;
  for (int i = 0; i < n; ++i) {
    float u0 = pf_rng_float(seed, 0, i, 0), u1 = pf_rng_float(seed, 0, i, 1);
    float u2 = pf_rng_float(seed, 0, i, 2);
    switch (i % 3) {
      case 0: v.push_back(photon_at(-2.f + 4.f * u0, 0.f, -2.f + 4.f * u1, 0)); break;
      case 1: v.push_back(photon_at(-2.f + 4.f * u0, 3.f * u1, -2.f, 1)); break;
      default: v.push_back(photon_at(0.5f + u0, 0.2f * u1, -1.f + 0.5f * u2, 3)); break;
    }
  }
  return v;
}

// Brute-force reference of the gather: input indices of `mesh` inside the ppm.h rule.
std::vector<int32_t> brute_gather(const std::vector<pf_photon>& ph, int mesh, const float q[3],
                                  float r) {
  std::vector<int32_t> out;
  for (size_t i = 0; i < ph.size(); ++i) {
    const float* p = ph[i].position;
    if (ph[i].mesh == mesh &&
        pf_ppm_in_radius(pf_ppm_dist2(q[0], q[1], q[2], p[0], p[1], p[2]), r))
      out.push_back(static_cast<int32_t>(i));
  }
  return out;
}

// Grid gather mapped to input indices, sorted.
std::vector<int32_t> grid_gather(const PhotonGrid& g, int mesh, const float q[3], float r) {
  std::vector<int32_t> out;
  for (int32_t i : g.gather(mesh, q, r)) out.push_back(g.order[i]);
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace

TEST_CASE("photon grid: hand-computed example of eq. 7.1", "[grid]") {
  // Mesh 0: longest extent 2 (y), max_bins 64, default radius 0.5 → d = max(2/64, 0.5) = 0.5;
  // nx = ceil(1/0.5) = 2, ny = ceil(2/0.5) = 4, nz = 1 (flat).
  // Bins: (0,0,0) → 0; (1,0,0) → x = 2 clamped to 1 → 1; (0.5,0.5,0) → 1 + 1·2 = 3;
  // (0,2,0) → y = 4 clamped to 3 → 0 + 3·2 = 6.
  std::vector<pf_photon> in = {photon_at(0, 0, 0, 0), photon_at(0, 2, 0, 0), photon_at(1, 0, 0, 0),
                               photon_at(0.5f, 0.5f, 0, 0), photon_at(7, 7, 7, 1)};
  PhotonGridParams params;
  params.default_radius = 0.5f;
  PhotonGrid g = build_photon_grid(in, 3, params);
  REQUIRE(g.mesh_grid.size() == 3);
  const pf_mesh_grid& m0 = g.mesh_grid[0];
  CHECK(m0.bin_size == 0.5f);
  CHECK(m0.nx == 2);
  CHECK(m0.ny == 4);
  CHECK(m0.nz == 1);
  CHECK(m0.first_bin == 0);
  CHECK(m0.first_photon == 0);
  CHECK(m0.photon_count == 4);
  CHECK((m0.lo[0] == 0.f && m0.lo[1] == 0.f && m0.lo[2] == 0.f));
  CHECK(g.order == std::vector<int32_t>{0, 2, 3, 1, 4});
  // Mesh 0: 8 bins + end; mesh 1: one bin (single photon) + end; mesh 2: empty, one entry.
  CHECK(g.cell_start == std::vector<int32_t>{0, 1, 2, 2, 3, 3, 3, 4, 4, 4, 5, 5});
  const pf_mesh_grid& m1 = g.mesh_grid[1];
  CHECK((m1.nx == 1 && m1.ny == 1 && m1.nz == 1));
  CHECK(m1.first_bin == 9);
  CHECK(m1.first_photon == 4);
  const pf_mesh_grid& m2 = g.mesh_grid[2];
  CHECK((m2.nx == 0 && m2.photon_count == 0 && m2.first_bin == 11 && m2.first_photon == 5));
}

TEST_CASE("photon grid: max_bins caps the bin count along the longest extent", "[grid]") {
  std::vector<pf_photon> in = {photon_at(0, 0, 0, 0), photon_at(100, 10, 1, 0)};
  PhotonGridParams params;
  params.default_radius = 0.5f;
  params.max_bins = 10;
  PhotonGrid g = build_photon_grid(in, 1, params);
  CHECK(g.mesh_grid[0].bin_size == 10.f);  // max(100/10, 0.5)
  CHECK(g.mesh_grid[0].nx == 10);
  CHECK(g.mesh_grid[0].ny == 1);
  CHECK(g.mesh_grid[0].nz == 1);
}

TEST_CASE("photon grid: layout invariants and stable counting sort", "[grid]") {
  std::vector<pf_photon> in = scene_photons(30000, 11);
  PhotonGridParams params;
  params.default_radius = 0.05f;
  params.max_bins = 32;
  PhotonGrid g = build_photon_grid(in, 4, params);
  REQUIRE(g.photons.size() == in.size());

  // order is a permutation and photons[i] is in[order[i]].
  std::vector<int32_t> perm = g.order;
  std::sort(perm.begin(), perm.end());
  std::vector<int32_t> iota(in.size());
  std::iota(iota.begin(), iota.end(), 0);
  CHECK(perm == iota);
  int mismatched = 0;
  for (size_t i = 0; i < in.size(); ++i)
    mismatched += std::memcmp(&g.photons[i], &in[g.order[i]], sizeof(pf_photon)) != 0;
  CHECK(mismatched == 0);

  size_t entries = 0;
  int misplaced = 0, unstable = 0;
  for (int m = 0; m < 4; ++m) {
    const pf_mesh_grid& h = g.mesh_grid[m];
    INFO("mesh " << m);
    CHECK(h.first_bin == static_cast<int>(entries));
    const int bins = h.nx * h.ny * h.nz;
    entries += bins + 1;
    CHECK(g.cell_start[h.first_bin] == h.first_photon);
    CHECK(g.cell_start[h.first_bin + bins] == h.first_photon + h.photon_count);
    if (h.photon_count > 0) {
      CHECK(h.bin_size >= params.default_radius);
      CHECK(std::max({h.nx, h.ny, h.nz}) <= params.max_bins);
    }
    for (int b = 0; b < bins; ++b) {
      int begin = g.cell_start[h.first_bin + b], end = g.cell_start[h.first_bin + b + 1];
      REQUIRE(begin <= end);
      for (int i = begin; i < end; ++i) {
        const float* p = g.photons[i].position;
        int x = grid_coord(p[0], h.lo[0], h.bin_size, h.nx);
        int y = grid_coord(p[1], h.lo[1], h.bin_size, h.ny);
        int z = grid_coord(p[2], h.lo[2], h.bin_size, h.nz);
        misplaced += g.photons[i].mesh != m || x + y * h.nx + z * h.nx * h.ny != b;
        if (i > begin) unstable += g.order[i] < g.order[i - 1];
      }
    }
  }
  CHECK(entries == g.cell_start.size());
  CHECK(misplaced == 0);
  // Eq. 7.1 from the photons' own bounds: d = max(longest extent / max_bins, R0), and per axis
  // enough bins of size d to cover the extent, ceil(extent / d), at least 1, at most max_bins.
  for (int m : {0, 1, 3}) {
    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (const pf_photon& p : in)
      if (p.mesh == m)
        for (int a = 0; a < 3; ++a) {
          lo[a] = std::min(lo[a], p.position[a]);
          hi[a] = std::max(hi[a], p.position[a]);
        }
    const float ext[3] = {hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]};
    const float d = std::max(std::max({ext[0], ext[1], ext[2]}) / float(params.max_bins),
                             params.default_radius);
    const pf_mesh_grid& h = g.mesh_grid[size_t(m)];
    INFO("mesh " << m);
    CHECK(h.bin_size == d);
    CHECK(std::memcmp(h.lo, lo, sizeof lo) == 0);
    const int n[3] = {h.nx, h.ny, h.nz};
    for (int a = 0; a < 3; ++a)
      CHECK(n[a] == std::clamp(int(std::ceil(ext[a] / d)), 1, params.max_bins));
  }
  CHECK(unstable == 0);
  CHECK(g.mesh_grid[2].photon_count == 0);

  // Deterministic: a second build is identical.
  PhotonGrid g2 = build_photon_grid(in, 4, params);
  CHECK(g2.order == g.order);
  CHECK(g2.cell_start == g.cell_start);
  CHECK(std::memcmp(g2.mesh_grid.data(), g.mesh_grid.data(),
                    g.mesh_grid.size() * sizeof(pf_mesh_grid)) == 0);
}

TEST_CASE("photon grid: gather equals brute force and only returns the query's mesh", "[grid]") {
  std::vector<pf_photon> in = scene_photons(20000, 5);
  PhotonGridParams params;
  params.default_radius = 0.1f;
  params.max_bins = 48;
  PhotonGrid g = build_photon_grid(in, 4, params);
  int differ = 0;
  size_t total = 0;
  for (int k = 0; k < 1500; ++k) {
    // Queries around and outside the photons, radii from tiny to larger than the meshes.
    float q[3] = {-3.f + 6.f * pf_rng_float(99, 0, k, 0), -0.5f + 4.f * pf_rng_float(99, 0, k, 1),
                  -3.f + 4.f * pf_rng_float(99, 0, k, 2)};
    if (k % 4 == 0) std::copy(in[k].position, in[k].position + 3, q);  // on a photon
    float r = (k % 50 == 0) ? 5.f : 0.4f * pf_rng_float(99, 0, k, 3);
    int mesh = k % 5 - 1;  // includes −1 and the empty mesh 2
    std::vector<int32_t> got = grid_gather(g, mesh, q, r);
    differ += got != brute_gather(in, mesh, q, r);
    total += got.size();
  }
  CHECK(differ == 0);
  CHECK(total > 10000);  // the queries actually found photons
  const float q[3] = {0, 0, 0};
  CHECK(g.gather(7, q, 1.f).empty());   // unknown mesh
  CHECK(g.gather(0, q, -1.f).empty());  // negative radius
}

TEST_CASE("photon grid: bad input is refused", "[grid]") {
  PhotonGridParams params;
  params.default_radius = 0.1f;
  std::vector<pf_photon> in = {photon_at(0, 0, 0, 2)};
  CHECK_THROWS_AS(build_photon_grid(in, 2, params), std::invalid_argument);  // mesh out of range
  in[0].mesh = 0;
  in[0].position[1] = NAN;
  CHECK_THROWS_AS(build_photon_grid(in, 1, params), std::invalid_argument);
  in[0].position[1] = 0;
  params.default_radius = 0.f;
  CHECK_THROWS_AS(build_photon_grid(in, 1, params), std::invalid_argument);
  params.default_radius = 0.1f;
  params.max_bins = 0;
  CHECK_THROWS_AS(build_photon_grid(in, 1, params), std::invalid_argument);
  // No photons at all: every mesh empty, one entry each.
  params.max_bins = 8;
  PhotonGrid g = build_photon_grid({}, 3, params);
  CHECK(g.cell_start == std::vector<int32_t>{0, 0, 0});
}

TEST_CASE("photon grid: a photon on a bin edge that the distance rule accepts by rounding is found",
          "[grid]") {
  // pf_ppm_in_radius(pf_ppm_dist2(q, p), R) is evaluated in float: a photon a few ulps beyond
  // q + R (itself rounded) can pass it. When that photon sits exactly on the lower edge of the
  // next bin, the bins of the box [q − R, q + R] miss it; for_each_in_radius widens the box
  // (photon_grid.h) so that it equals the brute-force rule even then. Such q, R, p along x
  // (test::edge_photon), with p on a bin edge: d = p, bins [0, p) and [p, 2p).
  const test::EdgePhoton e = test::edge_photon();
  const float q = e.q, r = e.r, p = e.p;
  INFO("q " << q << " R " << r << " p " << p);
  // Mesh 0: photons at 0, p (the one in question) and 1.5p: extent 1.5p, d = R0 = p, two bins.
  std::vector<pf_photon> in = {photon_at(0, 0, 0, 0), photon_at(p, 0, 0, 0),
                               photon_at(1.5f * p, 0, 0, 0)};
  PhotonGridParams params;
  params.default_radius = p;
  params.max_bins = 64;
  const PhotonGrid g = build_photon_grid(in, 1, params);
  REQUIRE(g.mesh_grid[0].bin_size == p);
  REQUIRE(g.mesh_grid[0].nx == 2);
  const float qq[3] = {q, 0, 0};
  CHECK(grid_gather(g, 0, qq, r) == brute_gather(in, 0, qq, r));
  CHECK(brute_gather(in, 0, qq, r) == std::vector<int32_t>{0, 1});
}
