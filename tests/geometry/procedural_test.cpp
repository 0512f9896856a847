// Procedural meshes (procedural.h) checked against their documented properties: triangle counts,
// outward (or inward) CCW winding, shading normals, vertices on the surface or inside the box,
// watertight vertex grids (every edge shared by exactly two triangles, bit for bit), determinism,
// and write_obj's shared vertices read back by a small OBJ parser.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "photonflow/foundations/hash.h"
#include "photonflow/geometry/procedural.h"
#include "support.h"

using namespace pf;

namespace {

Vec3 gnormal(const pf_triangle& t) {
  return normalize(cross(Vec3(t.v1) - Vec3(t.v0), Vec3(t.v2) - Vec3(t.v0)));
}
Vec3 centroid(const pf_triangle& t) { return (Vec3(t.v0) + Vec3(t.v1) + Vec3(t.v2)) / 3.f; }

// Exact vertex key (the float bits).
using Key = std::tuple<float, float, float>;
Key key(const float* p) { return {p[0], p[1], p[2]}; }

// Number of triangles using each undirected edge, and whether each directed edge occurs once:
// a closed, consistently wound mesh has every edge in exactly two triangles, once each way.
bool watertight(const std::vector<pf_triangle>& tris) {
  std::map<std::pair<Key, Key>, int> directed;
  for (const auto& t : tris) {
    const float* v[3] = {t.v0, t.v1, t.v2};
    for (int k = 0; k < 3; ++k) ++directed[{key(v[k]), key(v[(k + 1) % 3])}];
  }
  for (const auto& [e, n] : directed) {
    if (n != 1) return false;
    auto back = directed.find({e.second, e.first});
    if (back == directed.end() || back->second != 1) return false;
  }
  return true;
}

}  // namespace

TEST_CASE("procedural: sphere count, radius, outward winding, radial normals, watertight",
          "[procedural]") {
  const Vec3 c(0.5f, -1.f, 2.f);
  for (size_t want : {1u, 24u, 25u, 100u, 1000u}) {
    INFO("min_triangles " << want);
    const auto tris = make_sphere(c, 0.75f, want, {3, 4});
    // 4s² − 4s triangles for the smallest s ≥ 3 that reaches the count.
    size_t s = 3;
    while (4 * s * s - 4 * s < want) ++s;
    CHECK(tris.size() == 4 * s * s - 4 * s);
    CHECK(watertight(tris));
    for (const auto& t : tris) {
      CHECK(t.mesh == 3);
      CHECK(t.material == 4);
      for (const float* v : {t.v0, t.v1, t.v2}) CHECK(length(Vec3(v) - c) == Approx(0.75f).epsilon(1e-5));
      CHECK(dot(gnormal(t), centroid(t) - c) > 0.f);
      const float* n[3] = {t.n0, t.n1, t.n2};
      const float* v[3] = {t.v0, t.v1, t.v2};
      for (int k = 0; k < 3; ++k)
        CHECK(length(Vec3(n[k]) - normalize(Vec3(v[k]) - c)) < 1e-5f);
    }
  }
}

TEST_CASE("procedural: blob within radius·(1 ± amplitude), outward, flat, deterministic",
          "[procedural]") {
  const Vec3 c(0, 0, 0);
  const auto a = make_blob(c, 2.f, 2000, 0.25f, 17);
  const auto b = make_blob(c, 2.f, 2000, 0.25f, 17);
  const auto other = make_blob(c, 2.f, 2000, 0.25f, 18);
  REQUIRE(a.size() >= 2000);
  REQUIRE(a.size() == b.size());
  CHECK(std::memcmp(a.data(), b.data(), a.size() * sizeof(pf_triangle)) == 0);
  CHECK(std::memcmp(a.data(), other.data(), a.size() * sizeof(pf_triangle)) != 0);
  CHECK(watertight(a));
  float rmin = 1e30f, rmax = 0.f;
  for (const auto& t : a) {
    for (const float* v : {t.v0, t.v1, t.v2}) {
      rmin = std::min(rmin, length(Vec3(v)));
      rmax = std::max(rmax, length(Vec3(v)));
    }
    CHECK(length(Vec3(t.n0) - gnormal(t)) < 1e-5f);  // geometric normals
  }
  CHECK(rmin >= 2.f * 0.75f - 1e-4f);
  CHECK(rmax <= 2.f * 1.25f + 1e-4f);
  CHECK(rmax - rmin > 0.1f);  // displaced, not a sphere
}

TEST_CASE("procedural: height field over its rectangle, facing +y, within base ± height",
          "[procedural]") {
  const int cells = 12;
  const auto tris = make_heightfield(-1.f, 3.f, 2.f, 4.f, 0.5f, 0.2f, cells, 5, {1, 2});
  REQUIRE(tris.size() == size_t(2 * cells * cells));
  float ymin = 1e30f, ymax = -1e30f;
  Bounds xz;
  std::map<std::pair<Key, Key>, int> directed;
  for (const auto& t : tris) {
    CHECK(gnormal(t).y > 0.f);
    CHECK(t.mesh == 1);
    CHECK(t.material == 2);
    const float* v[3] = {t.v0, t.v1, t.v2};
    for (int k = 0; k < 3; ++k) {
      ymin = std::min(ymin, v[k][1]);
      ymax = std::max(ymax, v[k][1]);
      xz.extend(Vec3(v[k][0], 0.f, v[k][2]));
      ++directed[{key(v[k]), key(v[(k + 1) % 3])}];
    }
  }
  CHECK(xz.lo.x == -1.f);
  CHECK(xz.hi.x == 3.f);
  CHECK(xz.lo.z == 2.f);
  CHECK(xz.hi.z == 4.f);
  CHECK(ymin >= 0.5f - 0.2f - 1e-6f);
  CHECK(ymax <= 0.5f + 0.2f + 1e-6f);
  CHECK(ymax - ymin > 0.01f);
  // Relief along both axes (noise over the unit square): heights differ along some line of
  // constant x and along some line of constant z.
  std::map<float, std::vector<float>> along_z, along_x;  // keyed by x, by z
  for (const auto& t : tris)
    for (const float* v : {t.v0, t.v1, t.v2}) {
      along_z[v[0]].push_back(v[1]);
      along_x[v[2]].push_back(v[1]);
    }
  auto varies = [](const std::map<float, std::vector<float>>& m) {
    for (const auto& [k, ys] : m)
      if (*std::max_element(ys.begin(), ys.end()) - *std::min_element(ys.begin(), ys.end()) > 1e-3f)
        return true;
    return false;
  };
  CHECK(varies(along_z));
  CHECK(varies(along_x));
  // Shared vertices: no directed edge twice (consistent winding), and the interior edges
  // (3 per cell pair, minus the border) are each used once in each direction.
  size_t twice = 0;
  for (const auto& [e, n] : directed) {
    CHECK(n == 1);
    twice += directed.count({e.second, e.first});
  }
  // Undirected edges of a cells×cells grid with diagonals: 2c(c+1) + c²; border edges 4c.
  const size_t edges = size_t(2 * cells * (cells + 1) + cells * cells);
  CHECK(twice / 2 == edges - size_t(4 * cells));
}

TEST_CASE("procedural: triangle soup inside its box, no slivers, deterministic", "[procedural]") {
  Bounds box;
  box.extend(Vec3(-1, 0, 2));
  box.extend(Vec3(1, 0.5f, 3));
  const auto tris = make_triangle_soup(box, 500, 0.3f, 9, {0, 5});
  const auto again = make_triangle_soup(box, 500, 0.3f, 9, {0, 5});
  REQUIRE(tris.size() == 500);
  CHECK(std::memcmp(tris.data(), again.data(), tris.size() * sizeof(pf_triangle)) == 0);
  for (const auto& t : tris) {
    for (const float* v : {t.v0, t.v1, t.v2})
      for (int a = 0; a < 3; ++a) {
        CHECK(v[a] >= box.lo[a]);
        CHECK(v[a] <= box.hi[a]);
      }
    const float area2 = length(cross(Vec3(t.v1) - Vec3(t.v0), Vec3(t.v2) - Vec3(t.v0)));
    CHECK(area2 > 1e-4f * 0.3f * 0.3f);
    CHECK(t.material == 5);
  }
}

// The generator's stream replayed here in the order procedural.h documents. A draw made inside
// a call's argument list or an operator's operands would follow the compiler's evaluation
// order (unspecified in C++): GCC and Clang then made different meshes from one seed.
struct ReplayRng {
  uint64_t s;
  float uniform() { return float(splitmix64_mix(s += 0x9E3779B97F4A7C15ull) >> 40) * (1.f / 16777216.f); }
  float uniform(float a, float b) { return a + (b - a) * uniform(); }
  Vec3 unit_vector() {
    const float z = uniform(-1.f, 1.f);
    const float phi = uniform(0.f, 2.f * 3.14159265358979323846f);
    const float r = std::sqrt(std::fmax(0.f, 1.f - z * z));
    return {r * std::cos(phi), r * std::sin(phi), z};
  }
};

TEST_CASE("procedural: a seed gives the documented draws, whatever the compiler", "[procedural]") {
  SECTION("triangle soup: centre z, y, x, then each vertex's reach and direction") {
    Bounds box;
    box.extend(Vec3(-1, 0, 2));
    box.extend(Vec3(1, 0.5f, 3));
    const float size = 0.3f;
    const auto tris = make_triangle_soup(box, 40, size, 11);
    ReplayRng rng{11};
    size_t done = 0;
    while (done < tris.size()) {
      const float cz = rng.uniform(box.lo.z, box.hi.z);
      const float cy = rng.uniform(box.lo.y, box.hi.y);
      const float cx = rng.uniform(box.lo.x, box.hi.x);
      Vec3 v[3];
      for (Vec3& x : v) {
        const float reach = size * rng.uniform();
        x = vmin(vmax(Vec3(cx, cy, cz) + rng.unit_vector() * reach, box.lo), box.hi);
      }
      if (!(length(cross(v[1] - v[0], v[2] - v[0])) > 1e-4f * size * size)) continue;
      const pf_triangle& t = tris[done++];
      INFO("triangle " << done - 1);
      CHECK(std::memcmp(t.v0, &v[0].x, sizeof t.v0) == 0);
      CHECK(std::memcmp(t.v1, &v[1].x, sizeof t.v1) == 0);
      CHECK(std::memcmp(t.v2, &v[2].x, sizeof t.v2) == 0);
    }
  }
  SECTION("height field: per wave its frequency, direction and phase") {
    const int cells = 8;
    const float base = 0.25f, height = 0.5f;
    const auto tris = make_heightfield(0.f, 1.f, 0.f, 1.f, base, height, cells, 5);
    ReplayRng rng{5};
    struct Wave {
      Vec3 k;
      float phase;
    } waves[8];
    for (Wave& w : waves) {
      const float f = rng.uniform(2.f, 5.f);
      w.k = rng.unit_vector() * f;
      w.phase = rng.uniform(0.f, 2.f * 3.14159265358979323846f);
    }
    for (int i = 0; i < cells; ++i)
      for (int j = 0; j < cells; ++j) {
        const Vec3 q(float(i) / float(cells), 0.f, float(j) / float(cells));
        float sum = 0.f;
        for (const Wave& w : waves) sum += std::sin(dot(w.k, q) + w.phase);
        // Cell (i, j)'s first triangle starts at vertex (i, j).
        INFO("vertex " << i << ", " << j);
        CHECK(tris[size_t(2 * (i * cells + j))].v0[1] == base + height * (sum / 8.f));
      }
  }
}

TEST_CASE("procedural: box faces outward or inward, closed, on its corners", "[procedural]") {
  const Vec3 lo(-1, 0, 1), hi(2, 0.5f, 4);
  const Vec3 mid = (lo + hi) * 0.5f;
  for (bool inward : {false, true}) {
    INFO("inward " << inward);
    const auto tris = make_box(lo, hi, inward);
    REQUIRE(tris.size() == 12);
    CHECK(watertight(tris));
    double area = 0;
    for (const auto& t : tris) {
      const float side = dot(gnormal(t), centroid(t) - mid);
      CHECK((inward ? side < 0.f : side > 0.f));
      // Axis-aligned faces: the normal is a unit axis.
      const Vec3 n = gnormal(t);
      CHECK(std::fabs(n.x) + std::fabs(n.y) + std::fabs(n.z) == Approx(1.f));
      for (const float* v : {t.v0, t.v1, t.v2})
        for (int a = 0; a < 3; ++a) CHECK((v[a] == lo[a] || v[a] == hi[a]));
      area += 0.5 * length(cross(Vec3(t.v1) - Vec3(t.v0), Vec3(t.v2) - Vec3(t.v0)));
    }
    const Vec3 e = hi - lo;
    CHECK(area == Approx(2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)).epsilon(1e-6));
  }
}

TEST_CASE("procedural: write_obj shares identical vertices and reads back", "[procedural]") {
  test::TempDir tmp("procedural-obj");
  const auto tris = make_box({0, 0, 0}, {1, 2, 3}, false);
  const std::string path = tmp / "box.obj";
  write_obj(path, tris);
  CHECK(tmp.file_count() == 1);  // no temporary left
  std::ifstream f(path);
  std::vector<Vec3> v, vn;
  std::vector<pf_triangle> back;
  std::string line;
  while (std::getline(f, line)) {
    std::istringstream in(line);
    std::string tag;
    in >> tag;
    if (tag == "v" || tag == "vn") {
      float x, y, z;
      in >> x >> y >> z;
      (tag == "v" ? v : vn).push_back(Vec3(x, y, z));
    } else if (tag == "f") {
      pf_triangle t{};
      float* pv[3] = {t.v0, t.v1, t.v2};
      float* pn[3] = {t.n0, t.n1, t.n2};
      for (int k = 0; k < 3; ++k) {
        std::string ref;
        in >> ref;
        const size_t s = ref.find("//");
        REQUIRE(s != std::string::npos);
        const size_t vi = std::stoul(ref.substr(0, s)), ni = std::stoul(ref.substr(s + 2));
        REQUIRE(vi >= 1);
        REQUIRE(vi <= v.size());
        REQUIRE(ni >= 1);
        REQUIRE(ni <= vn.size());
        v[vi - 1].store(pv[k]);
        vn[ni - 1].store(pn[k]);
      }
      back.push_back(t);
    }
  }
  CHECK(v.size() == 8);   // a box's corners, each once
  CHECK(vn.size() == 6);  // one normal per face
  REQUIRE(back.size() == tris.size());
  for (size_t i = 0; i < tris.size(); ++i) {
    const float* a[6] = {tris[i].v0, tris[i].v1, tris[i].v2, tris[i].n0, tris[i].n1, tris[i].n2};
    const float* b[6] = {back[i].v0, back[i].v1, back[i].v2, back[i].n0, back[i].n1, back[i].n2};
    for (int k = 0; k < 6; ++k) CHECK(length(Vec3(a[k]) - Vec3(b[k])) < 1e-6f);
  }
}
