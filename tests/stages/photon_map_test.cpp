// Tests of photon_map.h: k-nearest and radius queries against brute force, approximate search,
// concurrent queries, and the PPM gather agreeing exactly with the photon grid.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

#include "photonflow/stages/photon_grid.h"
#include "photonflow/stages/photon_map.h"
#include "photonflow/foundations/rng.h"

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

// Uniform photons in a box, mesh ids 0..meshes−1 at random.
std::vector<pf_photon> random_photons(int n, int meshes, pf_uint seed) {
  std::vector<pf_photon> v(n);
  for (int i = 0; i < n; ++i)
    v[i] = photon_at(pf_rng_float(seed, 0, i, 0) * 2.f - 1.f, pf_rng_float(seed, 0, i, 1),
                     pf_rng_float(seed, 0, i, 2) * 3.f,
                     static_cast<int>(pf_rng_float(seed, 0, i, 3) * meshes));
  return v;
}

float dist2(const float* q, const pf_photon& p) {
  return pf_ppm_dist2(q[0], q[1], q[2], p.position[0], p.position[1], p.position[2]);
}

std::vector<int32_t> brute_radius(const std::vector<pf_photon>& ph, const float q[3], float r,
                                  int mesh) {
  std::vector<int32_t> out;
  for (size_t i = 0; i < ph.size(); ++i)
    if ((mesh < 0 || ph[i].mesh == mesh) && pf_ppm_in_radius(dist2(q, ph[i]), r))
      out.push_back(static_cast<int32_t>(i));
  return out;
}

std::vector<int32_t> grid_gather(const PhotonGrid& g, int mesh, const float q[3], float r) {
  std::vector<int32_t> out;
  for (int32_t i : g.gather(mesh, q, r)) out.push_back(g.order[i]);
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace

TEST_CASE("photon map: k nearest equal brute force (eq. 3.10 query)", "[photon_map]") {
  std::vector<pf_photon> ph = random_photons(20000, 1, 3);
  PhotonMap map(ph);
  REQUIRE(map.size() == ph.size());
  std::vector<int32_t> idx;
  std::vector<float> d2;
  int wrong = 0;
  for (int k : {1, 10, 200}) {
    for (int t = 0; t < 100; ++t) {
      float q[3] = {pf_rng_float(8, k, t, 0) * 2.5f - 1.25f, pf_rng_float(8, k, t, 1),
                    pf_rng_float(8, k, t, 2) * 3.f};
      float r2 = map.knn(q, k, idx, d2);
      std::vector<float> all(ph.size());
      for (size_t i = 0; i < ph.size(); ++i) all[i] = dist2(q, ph[i]);
      std::vector<float> sorted = all;
      std::partial_sort(sorted.begin(), sorted.begin() + k, sorted.end());
      sorted.resize(k);
      wrong += idx.size() != static_cast<size_t>(k) || d2 != sorted || r2 != sorted.back();
      for (size_t j = 0; j < idx.size(); ++j) wrong += all[idx[j]] != d2[j];  // index ↔ distance
    }
  }
  CHECK(wrong == 0);
  // More neighbours asked than photons: all of them.
  PhotonMap small(random_photons(5, 1, 4));
  const float q[3] = {0, 0, 0};
  small.knn(q, 10, idx, d2);
  CHECK(idx.size() == 5);
  CHECK(std::is_sorted(d2.begin(), d2.end()));
}

TEST_CASE("photon map: radius search equals brute force, eps gives a subset", "[photon_map]") {
  std::vector<pf_photon> ph = random_photons(20000, 3, 6);
  PhotonMap map(ph);
  std::vector<int32_t> got, approx;
  int wrong = 0, not_subset = 0;
  size_t exact_total = 0, approx_total = 0;
  for (int t = 0; t < 500; ++t) {
    float q[3] = {pf_rng_float(9, 0, t, 0) * 2.f - 1.f, pf_rng_float(9, 0, t, 1),
                  pf_rng_float(9, 0, t, 2) * 3.f};
    float r = 0.02f + 0.2f * pf_rng_float(9, 0, t, 3);
    map.radius_search(q, r, got);
    wrong += got != brute_radius(ph, q, r, -1);
    map.radius_search(q, r, approx, 2.f);
    not_subset += !std::includes(got.begin(), got.end(), approx.begin(), approx.end());
    exact_total += got.size();
    approx_total += approx.size();
  }
  CHECK(wrong == 0);
  CHECK(not_subset == 0);
  CHECK(exact_total > 5000);
  CHECK(approx_total <= exact_total);
}

TEST_CASE("photon map: an empty map answers nothing", "[photon_map]") {
  PhotonMap map(std::vector<pf_photon>{});
  PhotonMap def;
  const float q[3] = {0, 0, 0};
  std::vector<int32_t> idx = {1, 2};
  std::vector<float> d2 = {1};
  CHECK(map.knn(q, 5, idx, d2) == 0.f);
  CHECK(idx.empty());
  def.gather_radius(q, 1.f, 0, idx);
  CHECK(idx.empty());
}

TEST_CASE("photon map: gather_radius selects exactly the grid's photons", "[photon_map]") {
  // Three photon layouts: uniform random; an integer lattice (many photons exactly on the sphere:
  // distance² == R² ties, where `<` versus `<=` matters); clustered points with radii taken from
  // actual photon distances (boundary cases after rounding).
  std::vector<pf_photon> uniform = random_photons(30000, 4, 21);
  std::vector<pf_photon> lattice;
  for (int x = 0; x < 20; ++x)
    for (int y = 0; y < 20; ++y)
      for (int z = 0; z < 20; ++z)
        lattice.push_back(photon_at(x * 0.25f, y * 0.25f, z * 0.25f, (x + y + z) % 2));
  std::vector<pf_photon> clustered;
  for (int i = 0; i < 20000; ++i) {
    float c = static_cast<float>(i % 7);
    clustered.push_back(photon_at(c + 0.01f * pf_rng_float(4, 0, i, 0),
                                  100.f + 0.01f * pf_rng_float(4, 0, i, 1),
                                  -50.f + 0.01f * pf_rng_float(4, 0, i, 2), i % 3));
  }

  for (const auto* ph : {&uniform, &lattice, &clustered}) {
    const int meshes = 4;
    PhotonGridParams gp;
    gp.default_radius = 0.05f;
    PhotonGrid grid = build_photon_grid(*ph, meshes, gp);
    PhotonMap map(*ph);
    std::vector<int32_t> from_map;
    int differ = 0, brute_differ = 0, boundary_hits = 0;
    size_t total = 0;
    const int queries = 3000;
    for (int t = 0; t < queries; ++t) {
      const pf_photon& a = (*ph)[(t * 7919) % ph->size()];
      const pf_photon& b = (*ph)[(t * 104729 + 17) % ph->size()];
      float q[3];
      float r;
      switch (t % 3) {
        case 0:  // centred on a photon, radius = float distance to another photon
          std::copy(a.position, a.position + 3, q);
          r = std::sqrt(dist2(q, b));
          if (t % 2) r = std::min(r, 0.5f);
          break;
        case 1:  // lattice-friendly radii on lattice points (exact ties)
          std::copy(a.position, a.position + 3, q);
          r = 0.25f * static_cast<float>(1 + t % 4);
          break;
        default:  // random point near the photons, random radius
          for (int c = 0; c < 3; ++c)
            q[c] = a.position[c] + 0.2f * (pf_rng_float(5, 0, t, c) - 0.5f);
          r = 0.3f * pf_rng_float(5, 0, t, 3);
      }
      int mesh = t % meshes;
      map.gather_radius(q, r, mesh, from_map);
      std::vector<int32_t> from_grid = grid_gather(grid, mesh, q, r);
      differ += from_map != from_grid;
      brute_differ += from_grid != brute_radius(*ph, q, r, mesh);
      for (int32_t i : from_map) boundary_hits += dist2(q, (*ph)[i]) == r * r;
      total += from_map.size();
    }
    INFO("layout of " << ph->size() << " photons; total gathered " << total);
    CHECK(differ == 0);
    CHECK(brute_differ == 0);
    CHECK(total > 10000);
    if (ph == &lattice) CHECK(boundary_hits > 1000);  // the boundary case was really exercised
  }
}

TEST_CASE("photon map: concurrent queries from OpenMP threads match serial ones",
          "[photon_map]") {
  std::vector<pf_photon> ph = random_photons(50000, 2, 31);
  PhotonMap map(ph);
  const int n = 2000;
  std::vector<std::vector<int32_t>> serial(n), parallel(n), knn_serial(n), knn_parallel(n);
  auto query = [](int t, float q[3]) {
    for (int c = 0; c < 3; ++c) q[c] = pf_rng_float(12, 0, t, c) * (c == 2 ? 3.f : 1.f);
  };
  for (int t = 0; t < n; ++t) {
    float q[3];
    query(t, q);
    std::vector<float> d2;
    map.gather_radius(q, 0.1f, t % 2, serial[t]);
    map.knn(q, 50, knn_serial[t], d2);
  }
#pragma omp parallel for num_threads(4) schedule(dynamic, 7)
  for (int t = 0; t < n; ++t) {
    float q[3];
    query(t, q);
    std::vector<float> d2;
    map.gather_radius(q, 0.1f, t % 2, parallel[t]);
    map.knn(q, 50, knn_parallel[t], d2);
  }
  CHECK(serial == parallel);
  CHECK(knn_serial == knn_parallel);
}
