// raycast_test.cpp — closest/any hit of the rope and stack kd traversals against brute force,
// hit interval, barycentrics, and watertightness on closed meshes.
#include <catch2/catch.hpp>
#include <cmath>
#include <cstring>
#include <random>

#include "photonflow/geometry/procedural.h"
#include "photonflow/geometry/raycast.h"
#include "photonflow/geometry/surface.h"

namespace {

using pf::Vec3;

pf::Scene make_scene(std::vector<pf_triangle> tris, const pf::KdBuildParams& params = {}) {
  pf::Scene s;
  s.triangles = std::move(tris);
  s.compute_hh();
  s.compute_bounds();
  s.kd = pf::build_kdtree(s.triangles, params);
  return s;
}

// The three scenes of the issue: Cornell-like room, random soup, ≥ 100k-triangle blob in a room.
const pf::Scene& room() {
  static const pf::Scene s = make_scene(pf::make_cornell_room(400));
  return s;
}
const pf::Scene& soup() {
  static const pf::Scene s = [] {
    pf::Bounds box;
    box.extend({0, 0, 0});
    box.extend({1, 1, 1});
    return make_scene(pf::make_triangle_soup(box, 1000, 0.1f, 5));
  }();
  return s;
}
const pf::Scene& blob() {
  static const pf::Scene s = [] {
    auto tris = pf::make_box({-2, -2, -2}, {2, 2, 2}, true, {0, 0});
    const auto b = pf::make_blob({0, 0, 0}, 1.f, 100000, 0.3f, 3, {1, 1});
    tris.insert(tris.end(), b.begin(), b.end());
    return make_scene(std::move(tris));
  }();
  return s;
}

Vec3 random_direction(std::mt19937& rng) {
  std::uniform_real_distribution<float> uni(-1.f, 1.f);
  for (;;) {
    // One draw per statement (z, y, x, the order GCC evaluated the former argument list in):
    // argument order is unspecified, and Clang made other rays from the same seed.
    const float z = uni(rng), y = uni(rng), x = uni(rng);
    const Vec3 d(x, y, z);
    const float l2 = pf::dot(d, d);
    if (l2 > 1e-4f && l2 <= 1.f) return d / std::sqrt(l2);
  }
}

// Origins uniform in the scene box (slightly enlarged, so some start outside), uniform directions;
// every 16th ray is axis-parallel (zero direction components), every 16th starts on a kd split
// plane; a third have a finite tmax.
std::vector<pf::Ray> random_rays(const pf::Scene& s, size_t n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> uni(0.f, 1.f);
  const Vec3 lo = s.bounds.lo - s.bounds.extent() * 0.05f;
  const Vec3 e = s.bounds.extent() * 1.1f;
  std::vector<pf::Ray> rays(n);
  for (size_t i = 0; i < n; ++i) {
    pf::Ray& r = rays[i];
    const float oz = uni(rng) * e.z, oy = uni(rng) * e.y, ox = uni(rng) * e.x;  // as above
    r.o = lo + Vec3(ox, oy, oz);
    const float scale = 0.5f + uni(rng);  // drawn before the direction, as GCC ordered them
    r.d = random_direction(rng) * scale;
    if (i % 16 == 3) {  // axis-parallel: one or two zero components
      const int k = int(rng() % 3);
      r.d[k] = 0.f;
      if (rng() % 2) r.d[(k + 1) % 3] = 0.f;
    }
    if (i % 16 == 7) {  // origin on the split plane of a random inner node
      const pf_kd_node& n = s.kd.nodes[rng() % s.kd.nodes.size()];
      if (n.axis != PF_KD_LEAF) r.o[n.axis] = n.split;
    }
    if (i % 3 == 0) r.tmax = uni(rng) * 2.f;
  }
  return rays;
}

// Both miss, or both hit at t within 1e-5 relative.
bool equal_t(const pf::Hit& a, const pf::Hit& b) {
  if (a.hit() != b.hit()) return false;
  return !a.hit() || std::fabs(a.t - b.t) <= 1e-5f * std::fmax(1.f, std::fabs(a.t));
}

// Closest hits equal up to ties: both miss, or both hit at t within 1e-5 relative, by the same
// triangle or by another one that the ray also hits at that t. A touch at the origin (t below
// ray_epsilon, seen by one side only: raycast.h) is a tie with the next hit beyond it, which the
// other side must have found.
bool same_hit(const pf::Scene& s, const pf::Ray& ray, const pf::Hit& a, const pf::Hit& b) {
  if (equal_t(a, b)) {
    if (!a.hit() || a.tri == b.tri) return true;
    // A tie: the ray must hit b's triangle at (nearly) a's t as well.
    pf::Scene one;
    one.hh = {s.hh[size_t(b.tri)]};
    pf::Hit h;
    pf::Ray r = ray;
    r.tmax = INFINITY;
    return pf::intersect_closest(one, r, h, pf::Traversal::Brute) && equal_t(h, a);
  }
  // A touch at the origin, seen by one side only: the other side has the next hit beyond it.
  const pf::Hit& near = a.t < b.t ? a : b;
  const pf::Hit& far = a.t < b.t ? b : a;
  if (!(near.t < pf::ray_epsilon(s))) return false;
  pf::Ray beyond = ray;
  beyond.tmin = near.t;
  pf::Hit h;
  pf::intersect_closest(s, beyond, h, pf::Traversal::Brute);
  return equal_t(h, far) && (!far.hit() || h.tri == far.tri);
}

size_t count_mismatches(const pf::Scene& s, const std::vector<pf::Ray>& rays,
                        const std::vector<pf::Hit>& a, const std::vector<pf::Hit>& b) {
  size_t bad = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    if (same_hit(s, rays[i], a[i], b[i])) continue;
    if (bad++ < 5)
      WARN("ray " << i << ": tri " << a[i].tri << " t " << a[i].t << " vs tri " << b[i].tri
                  << " t " << b[i].t);
  }
  return bad;
}

void check_against_brute(const pf::Scene& s, size_t n_rays, uint32_t seed) {
  const auto rays = random_rays(s, n_rays, seed);
  std::vector<pf::Hit> brute, ropes, stack;
  pf::intersect_closest_batch(s, rays, brute, pf::Traversal::Brute);
  pf::intersect_closest_batch(s, rays, ropes, pf::Traversal::Ropes);
  pf::intersect_closest_batch(s, rays, stack, pf::Traversal::Stack);
  size_t hits = 0;
  for (const pf::Hit& h : brute) hits += h.hit() ? 1 : 0;
  INFO(s.triangles.size() << " triangles, " << n_rays << " rays, " << hits << " hits");
  CHECK(hits > n_rays / 4);
  CHECK(count_mismatches(s, rays, brute, ropes) == 0);
  CHECK(count_mismatches(s, rays, brute, stack) == 0);
  CHECK(count_mismatches(s, rays, ropes, stack) == 0);
}

}  // namespace

TEST_CASE("kd traversals equal brute force on the Cornell room", "[raycast]") {
  check_against_brute(room(), 100000, 1);
}

TEST_CASE("kd traversals equal brute force on a random soup", "[raycast]") {
  check_against_brute(soup(), 100000, 2);
}

TEST_CASE("a ray from a triangle lying in a split plane: a touch at t = 0 or the next hit",
          "[raycast]") {
  // The degenerate case of raycast.h: every axis-aligned triangle of the room whose plane is a
  // split plane, rays from its centroid leaving either side. Brute force may touch the triangle
  // at t ≈ 0; a kd traversal starting in the other child gives the next hit instead, and
  // same_hit takes the two as a tie only when that next hit is brute force's beyond the touch.
  // A deep tree (C_ts 3, empty bonus 0.5: the defaults until December 2026), whose
  // splits lie in many of the walls' planes.
  pf::KdBuildParams deep;
  deep.cost_traversal = 3.f;
  deep.empty_bonus = 0.5f;
  const pf::Scene s = make_scene(pf::make_cornell_room(400), deep);
  size_t rays = 0, touches = 0;
  for (size_t i = 0; i < s.triangles.size(); ++i) {
    const pf_triangle& t = s.triangles[i];
    for (int k = 0; k < 3; ++k) {
      if (!(t.v0[k] == t.v1[k] && t.v0[k] == t.v2[k])) continue;
      bool split = false;
      for (const pf_kd_node& n : s.kd.nodes) split |= n.axis == k && n.split == t.v0[k];
      if (!split) continue;
      const Vec3 c = (Vec3(t.v0) + Vec3(t.v1) + Vec3(t.v2)) / 3.f;
      for (float side : {-1.f, 1.f}) {
        pf::Ray r;
        r.o = c;
        r.o[k] = t.v0[k];  // exactly in the plane
        r.d = Vec3(0.3f, 0.2f, 0.25f);
        r.d[k] = 0.5f * side;
        pf::Hit brute, ropes, stack;
        pf::intersect_closest(s, r, brute, pf::Traversal::Brute);
        pf::intersect_closest(s, r, ropes, pf::Traversal::Ropes);
        pf::intersect_closest(s, r, stack, pf::Traversal::Stack);
        INFO("triangle " << i << ", axis " << k << ", side " << side);
        CHECK(same_hit(s, r, brute, ropes));
        CHECK(same_hit(s, r, brute, stack));
        ++rays;
        touches += brute.hit() && brute.t < pf::ray_epsilon(s) && ropes.tri != brute.tri;
      }
    }
  }
  INFO(rays << " rays, " << touches << " touches seen by brute force only");
  CHECK(rays >= 8);
  CHECK(touches > 0);  // the case exists here, so the tie rule above is exercised
}

TEST_CASE("kd traversals equal brute force on a 100k-triangle blob", "[raycast]") {
  REQUIRE(blob().triangles.size() >= 100000);
  check_against_brute(blob(), 2000, 3);
}

TEST_CASE("ropes equal the stack traversal exactly on many rays", "[raycast]") {
  // Same triangles, same test, same tie rule: the two kd traversals agree bit for bit.
  for (const pf::Scene* s : {&room(), &blob()}) {
    const auto rays = random_rays(*s, 100000, 4);
    std::vector<pf::Hit> ropes, stack;
    pf::intersect_closest_batch(*s, rays, ropes, pf::Traversal::Ropes);
    pf::intersect_closest_batch(*s, rays, stack, pf::Traversal::Stack);
    CHECK(count_mismatches(*s, rays, ropes, stack) == 0);
  }
}

TEST_CASE("any hit agrees with closest hit", "[raycast]") {
  for (const pf::Scene* s : {&room(), &soup()}) {
    const auto rays = random_rays(*s, 20000, 5);
    for (pf::Traversal trav : {pf::Traversal::Ropes, pf::Traversal::Stack, pf::Traversal::Brute}) {
      std::vector<pf::Hit> closest;
      std::vector<uint8_t> occluded;
      pf::intersect_closest_batch(*s, rays, closest, trav);
      pf::intersect_any_batch(*s, rays, occluded, trav);
      size_t bad = 0;
      for (size_t i = 0; i < rays.size(); ++i)
        bad += (occluded[i] != 0) != closest[i].hit() ? 1 : 0;
      INFO(pf::traversal_name(trav));
      CHECK(bad == 0);
    }
  }
}

TEST_CASE("batches do not depend on the thread count", "[raycast]") {
  const auto rays = random_rays(room(), 20000, 6);
  std::vector<pf::Hit> one, two;
  pf::intersect_closest_batch(room(), rays, one, pf::Traversal::Ropes, 1);
  pf::intersect_closest_batch(room(), rays, two, pf::Traversal::Ropes, 2);
  size_t differ = 0;
  for (size_t i = 0; i < rays.size(); ++i)
    differ += (one[i].tri != two[i].tri || one[i].t != two[i].t) ? 1 : 0;
  CHECK(differ == 0);
}

TEST_CASE("hits are accepted for t in (tmin, tmax) and at tmax only", "[raycast]") {
  // The floor of the room at y = 0, seen from y = 0.5 straight down: t = 0.5.
  pf::Ray r;
  r.o = {0.3f, 0.5f, 0.2f};
  r.d = {0.f, -1.f, 0.f};
  for (pf::Traversal trav : {pf::Traversal::Ropes, pf::Traversal::Stack, pf::Traversal::Brute}) {
    INFO(pf::traversal_name(trav));
    pf::Hit h;
    REQUIRE(pf::intersect_closest(room(), r, h, trav));
    CHECK(h.t == Approx(0.5f));
    const float t = h.t;  // (a miss below resets h)
    pf::Ray at = r;
    at.tmax = t;  // tmax itself is included
    CHECK(pf::intersect_closest(room(), at, h, trav));
    CHECK(pf::intersect_any(room(), at, trav));
    pf::Ray before = r;
    before.tmax = std::nextafter(t, 0.f);
    CHECK_FALSE(pf::intersect_closest(room(), before, h, trav));
    CHECK_FALSE(pf::intersect_any(room(), before, trav));
    pf::Ray after = r;
    after.tmin = t;  // tmin itself is excluded
    CHECK_FALSE(pf::intersect_closest(room(), after, h, trav));
    CHECK_FALSE(pf::intersect_any(room(), after, trav));
    after.tmin = std::nextafter(t, 0.f);  // just before it: found
    CHECK(pf::intersect_closest(room(), after, h, trav));
    CHECK(h.t == t);
  }
}

TEST_CASE("barycentrics reconstruct the hit point", "[raycast]") {
  const pf::Scene& s = room();
  const auto rays = random_rays(s, 20000, 7);
  std::vector<pf::Hit> hits;
  pf::intersect_closest_batch(s, rays, hits, pf::Traversal::Ropes);
  size_t bad = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    const pf::Hit& h = hits[i];
    if (!h.hit()) continue;
    const pf_triangle& t = s.triangles[size_t(h.tri)];
    const Vec3 p = Vec3(t.v0) * (1.f - h.u - h.v) + Vec3(t.v1) * h.u + Vec3(t.v2) * h.v;
    const Vec3 q = rays[i].o + rays[i].d * h.t;
    bad += pf::length(p - q) > 1e-4f ? 1 : 0;
    bad += (h.u < -1e-4f || h.v < -1e-4f || h.u + h.v > 1.0001f) ? 1 : 0;
  }
  CHECK(bad == 0);
}

TEST_CASE("closed meshes are watertight from inside", "[raycast]") {
  // Rays from inside a closed mesh must always hit it: through triangle interiors, exactly
  // through shared vertices and edges, and starting exactly on a triangle.
  const auto sphere = pf::make_sphere({0.1f, -0.2f, 0.3f}, 1.f, 20000);
  const auto lumpy = pf::make_blob({0, 0, 0}, 1.f, 20000, 0.3f, 9);
  for (const auto* tris : {&sphere, &lumpy}) {
    const pf::Scene s = make_scene(*tris);
    const Vec3 c = s.bounds.center();
    std::mt19937 rng(8);
    std::uniform_real_distribution<float> uni(-0.3f, 0.3f);
    std::vector<pf::Ray> rays;
    for (int i = 0; i < 100000; ++i) {  // random rays from near the centre
      pf::Ray r;
      const float z = uni(rng), y = uni(rng), x = uni(rng);  // as in random_direction
      r.o = c + Vec3(x, y, z);
      r.d = random_direction(rng);
      rays.push_back(r);
    }
    for (const pf_triangle& t : *tris) {  // exactly at vertices and edge midpoints
      for (const Vec3& target : {Vec3(t.v0), (Vec3(t.v0) + Vec3(t.v1)) * 0.5f}) {
        pf::Ray r;
        r.o = c;
        r.d = target - c;
        rays.push_back(r);
      }
    }
    for (size_t i = 0; i < tris->size(); i += 7) {  // from a triangle's centroid, inwards
      const pf_triangle& t = (*tris)[i];
      const Vec3 a(t.v0), b(t.v1), e(t.v2);
      pf::Ray r;
      r.o = (a + b + e) * (1.f / 3.f);
      r.d = random_direction(rng);
      if (pf::dot(r.d, pf::cross(b - a, e - a)) > 0) r.d = -r.d;  // against the geometric normal
      rays.push_back(r);
    }
    for (pf::Traversal trav : {pf::Traversal::Ropes, pf::Traversal::Stack}) {
      std::vector<pf::Hit> hits;
      pf::intersect_closest_batch(s, rays, hits, trav);
      size_t missed = 0;
      for (const pf::Hit& h : hits) missed += h.hit() ? 0 : 1;
      INFO(pf::traversal_name(trav) << ", " << rays.size() << " rays");
      CHECK(missed == 0);
    }
  }
}

TEST_CASE("rays aimed exactly at vertices and edges never slip through, from many origins",
          "[raycast]") {
  // Splits sit at vertex coordinates, so vertices lie on split planes and often at corners where
  // several leaves meet; a ray aimed at such a vertex passes a corner of the leaf arrangement,
  // where both traversals must still reach a leaf listing one of the triangles around it.
  const auto sphere = pf::make_sphere({0.f, 0.f, 0.f}, 1.f, 3000);
  const auto lumpy = pf::make_blob({0.2f, 0.1f, -0.1f}, 1.f, 5000, 0.3f, 5);
  const auto coarse = pf::make_sphere({0.5f, 0.5f, 0.5f}, 0.25f, 60);
  for (const auto* tris : {&sphere, &lumpy, &coarse}) {
    const pf::Scene s = make_scene(*tris);
    const Vec3 c = s.bounds.center();
    const Vec3 e = s.bounds.extent();
    std::vector<Vec3> origins = {c};
    for (int k = 0; k < 3; ++k) {  // origins on the axes through the centre (on split planes)
      Vec3 o = c;
      o[k] += 0.1f * e[k];
      origins.push_back(o);
      o[k] = c[k] - 0.13f * e[k];
      origins.push_back(o);
    }
    std::vector<pf::Ray> rays;
    for (const Vec3& o : origins)
      for (const pf_triangle& t : *tris)
        for (const Vec3& target : {Vec3(t.v0), Vec3(t.v1), Vec3(t.v2),
                                   (Vec3(t.v0) + Vec3(t.v1)) * 0.5f,
                                   (Vec3(t.v1) + Vec3(t.v2)) * 0.5f}) {
          pf::Ray r;
          r.o = o;
          r.d = target - o;
          rays.push_back(r);
        }
    for (pf::Traversal trav : {pf::Traversal::Ropes, pf::Traversal::Stack}) {
      std::vector<pf::Hit> hits;
      pf::intersect_closest_batch(s, rays, hits, trav);
      size_t missed = 0;
      for (const pf::Hit& h : hits) missed += h.hit() ? 0 : 1;
      INFO(pf::traversal_name(trav) << ", " << tris->size() << " triangles, " << rays.size()
                                    << " rays");
      CHECK(missed == 0);
    }
  }
}

TEST_CASE("a large triangle is widened by its float precision only, not by a fraction of it",
          "[raycast]") {
  // The sign tests' slack bounds their rounding (PF_HH_ROUNDING), so a triangle's outline is
  // where its vertices put it: a ray aimed 4e-5 of the lamp's width outside an edge of the Cornell
  // box's lamp (two triangles, seen from the camera) misses, one aimed as far inside hits. A
  // slack of 1e-4 of the triangle drew the lamp that much wider on every side (a bright ring in
  // the image). The same at the scene's millimetre scale (555 units).
  for (float scale : {1.f, 555.f}) {
    const float y = 0.995f * scale, x0 = 0.381982f * scale, x1 = 0.616216f * scale;
    const float z0 = 0.401802f * scale, z1 = 0.590991f * scale;
    pf_triangle a{}, b{};
    const float v[4][3] = {{x0, y, z0}, {x1, y, z0}, {x1, y, z1}, {x0, y, z1}};
    std::memcpy(a.v0, v[0], sizeof v[0]);
    std::memcpy(a.v1, v[1], sizeof v[0]);
    std::memcpy(a.v2, v[2], sizeof v[0]);
    std::memcpy(b.v0, v[0], sizeof v[0]);
    std::memcpy(b.v1, v[2], sizeof v[0]);
    std::memcpy(b.v2, v[3], sizeof v[0]);
    const pf::Scene s = make_scene({a, b});
    const Vec3 eye(0.5f * scale, 0.5f * scale, 2.441441f * scale);
    const float delta = 4e-5f * (x1 - x0);
    size_t outside_hit = 0, inside_missed = 0, rays = 0;
    for (int i = 1; i < 64; ++i) {  // points along each of the four edges
      const float f = float(i) / 64.f;
      const float xm = x0 + f * (x1 - x0), zm = z0 + f * (z1 - z0);
      const Vec3 edge[4] = {{xm, y, z0}, {xm, y, z1}, {x0, y, zm}, {x1, y, zm}};
      const Vec3 out[4] = {{0, 0, -1}, {0, 0, 1}, {-1, 0, 0}, {1, 0, 0}};
      for (int e = 0; e < 4; ++e)
        for (int side : {1, -1}) {
          pf::Ray r;
          r.o = eye;
          r.d = edge[e] + out[e] * (float(side) * delta) - eye;
          for (pf::Traversal trav : {pf::Traversal::Ropes, pf::Traversal::Stack}) {
            pf::Hit h;
            const bool hit = pf::intersect_closest(s, r, h, trav);
            ++rays;
            if (side == 1) outside_hit += hit ? 1 : 0;
            else inside_missed += hit ? 0 : 1;
          }
        }
    }
    INFO("scale " << scale << ", " << rays << " rays");
    CHECK(outside_hit == 0);
    CHECK(inside_missed == 0);
  }
}

TEST_CASE("stack and ropes give the same triangle, t and barycentrics, bit for bit", "[raycast]") {
  // The host-only stack traversal (compact nodes, four-wide triangle tests) must return exactly
  // what the shared rope traversal (the GPU kernels' code) returns, so either can serve the CPU.
  for (const pf::Scene* s : {&room(), &soup(), &blob()}) {
    for (uint32_t seed : {9u, 10u}) {
      const auto rays = random_rays(*s, 100000, seed);
      std::vector<pf::Hit> ropes, stack;
      pf::intersect_closest_batch(*s, rays, ropes, pf::Traversal::Ropes);
      pf::intersect_closest_batch(*s, rays, stack, pf::Traversal::Stack);
      size_t differ = 0, scalar_differ = 0;
      for (size_t i = 0; i < rays.size(); ++i) {
        const pf::Hit& a = ropes[i];
        const pf::Hit& b = stack[i];
        const bool same = a.tri == b.tri && (!a.hit() || (a.t == b.t && a.u == b.u && a.v == b.v));
        if (!same && differ++ < 5)
          WARN("ray " << i << ": ropes tri " << a.tri << " t " << a.t << ", stack tri " << b.tri
                      << " t " << b.t);
        if (!a.hit()) continue;
        // Both use a four-wide leaf test; the scalar shared test on the hit triangle alone must
        // give the same bits.
        pf::Scene one;
        one.hh = {s->hh[size_t(a.tri)]};
        pf::Hit h;
        const bool scalar = pf::intersect_closest(one, rays[i], h, pf::Traversal::Brute);
        if (!(scalar && h.t == a.t && h.u == a.u && h.v == a.v) && scalar_differ++ < 5)
          WARN("ray " << i << ": tri " << a.tri << " t " << a.t << ", scalar test t " << h.t);
      }
      INFO(s->triangles.size() << " triangles, seed " << seed);
      CHECK(differ == 0);
      CHECK(scalar_differ == 0);
    }
  }
}

TEST_CASE("a tree stored in another node order gives the same hits", "[raycast]") {
  // The host copy of the tree renumbers nodes into left-first preorder; a valid tree stored
  // right-first (as another writer of scene.h5 might) must cast exactly like the original.
  const pf::Scene& s = room();
  pf::Scene p = s;
  const auto& nodes = s.kd.nodes;
  std::vector<int32_t> order, index(nodes.size());
  for (std::vector<int32_t> todo = {0}; !todo.empty();) {
    const int32_t i = todo.back();
    todo.pop_back();
    index[size_t(i)] = int32_t(order.size());
    order.push_back(i);
    if (nodes[size_t(i)].axis != PF_KD_LEAF) {
      todo.push_back(nodes[size_t(i)].left);  // right child first
      todo.push_back(nodes[size_t(i)].right);
    }
  }
  pf::KdTree t = s.kd;
  for (size_t i = 0; i < order.size(); ++i) {
    pf_kd_node n = nodes[size_t(order[i])];
    if (n.axis != PF_KD_LEAF) {
      n.left = index[size_t(n.left)];
      n.right = index[size_t(n.right)];
    }
    for (int32_t& r : n.ropes)
      if (r >= 0) r = index[size_t(r)];
    t.nodes[i] = n;
  }
  p.kd = t;
  REQUIRE(pf::validate_kdtree(p.kd, p.triangles.size()) == "");
  REQUIRE(p.kd.nodes[0].left != 1);
  const auto rays = random_rays(s, 20000, 12);
  for (pf::Traversal trav : {pf::Traversal::Ropes, pf::Traversal::Stack}) {
    std::vector<pf::Hit> a, b;
    pf::intersect_closest_batch(s, rays, a, trav);
    pf::intersect_closest_batch(p, rays, b, trav);
    size_t differ = 0;
    for (size_t i = 0; i < rays.size(); ++i)
      differ += (a[i].tri != b[i].tri || (a[i].hit() && a[i].t != b[i].t)) ? 1 : 0;
    INFO(pf::traversal_name(trav));
    CHECK(differ == 0);
  }
}

// The shared rope loops compiled here without the host's leaf-test substitutes (the default
// scalar pf_kd_leaf_intersect / pf_kd_cleaf_intersect), in a namespace of their own so that they
// do not collide with libcommon's (inline) instances.
namespace shared_plain {
#include "photonflow/geometry/intersect_shared.h"
}  // namespace shared_plain

namespace {

// Left-first depth-first preorder of a tree and its inverse (what pf_kd_compact_build expects).
void preorder(const std::vector<pf_kd_node>& nodes, std::vector<int32_t>& order,
              std::vector<int32_t>& index) {
  order.clear();
  index.assign(nodes.size(), 0);
  for (std::vector<int32_t> todo = {0}; !todo.empty();) {
    const int32_t i = todo.back();
    todo.pop_back();
    index[size_t(i)] = int32_t(order.size());
    order.push_back(i);
    if (nodes[size_t(i)].axis != PF_KD_LEAF) {
      todo.push_back(nodes[size_t(i)].right);
      todo.push_back(nodes[size_t(i)].left);
    }
  }
}

// Casts `rays` with pf_kd_traverse_ropes over `ref` and with pf_kd_traverse_ropes_compact over the
// compact copy of `tree` (the same tree, possibly stored in another node order); returns the
// number of rays (closest or any hit) whose return value, triangle, t, u or v differ.
size_t compact_differences(const pf::Scene& s, const std::vector<pf_kd_node>& ref,
                           const std::vector<pf_kd_node>& tree, const std::vector<pf::Ray>& rays,
                           size_t& hits) {
  std::vector<int32_t> order, index;
  preorder(tree, order, index);
  size_t n_leaves = 0;
  for (const pf_kd_node& n : tree) n_leaves += n.axis == PF_KD_LEAF ? 1 : 0;
  std::vector<shared_plain::pf_kd_cnode> cnodes(tree.size());
  std::vector<shared_plain::pf_kd_cleaf> cleaves(n_leaves);
  float root_box[6];
  REQUIRE(order.size() == tree.size());
  REQUIRE(shared_plain::pf_kd_compact_build(tree.data(), int32_t(tree.size()), order.data(),
                                            index.data(), cnodes.data(), cleaves.data(),
                                            root_box) == int32_t(n_leaves));
  size_t differ = 0;
  hits = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    const pf::Ray& r = rays[i];
    const float o[3] = {r.o.x, r.o.y, r.o.z}, d[3] = {r.d.x, r.d.y, r.d.z};
    for (int any = 0; any < 2; ++any) {
      shared_plain::pf_ray_hit a = {r.tmax, -1, 0.f, 0.f}, b = a;
      const int ra = shared_plain::pf_kd_traverse_ropes(ref.data(), int32_t(ref.size()),
                                                        s.kd.leaf_tris.data(), s.hh.data(), o, d,
                                                        r.tmin, any, &a);
      const int rb = shared_plain::pf_kd_traverse_ropes_compact(
          cnodes.data(), int32_t(cnodes.size()), cleaves.data(), root_box, s.kd.leaf_tris.data(),
          s.hh.data(), o, d, r.tmin, any, &b);
      hits += ra && !any ? 1 : 0;
      const bool same = ra == rb && a.tri == b.tri && std::memcmp(&a.t, &b.t, 4) == 0 &&
                        std::memcmp(&a.u, &b.u, 4) == 0 && std::memcmp(&a.v, &b.v, 4) == 0;
      if (!same && differ++ < 5)
        WARN("ray " << i << " any " << any << ": ropes " << ra << " tri " << a.tri << " t " << a.t
                    << ", compact " << rb << " tri " << b.tri << " t " << b.t);
    }
  }
  return differ;
}

}  // namespace

TEST_CASE("the compact rope loop equals pf_kd_traverse_ropes bit for bit", "[raycast]") {
  // pf_kd_traverse_ropes_compact (8-byte nodes, leaf records; Traversal::Ropes on the host) must
  // visit the same leaves as the original rope loop over the flat pf_kd_node array (the kernels'
  // code): same return value, triangle, t, u, v, for closest and any hit.
  for (const pf::Scene* s : {&room(), &soup(), &blob()}) {
    const auto rays = random_rays(*s, s->triangles.size() > 50000 ? 200000 : 50000, 21);
    size_t hits = 0;
    const size_t differ = compact_differences(*s, s->kd.nodes, s->kd.nodes, rays, hits);
    INFO(s->triangles.size() << " triangles, " << hits << " closest hits");
    CHECK(hits > rays.size() / 4);
    CHECK(differ == 0);
  }
}

TEST_CASE("the compact rope copy of a tree stored right-first casts the same", "[raycast]") {
  // pf_kd_compact_build renumbers nodes (children and ropes) into left-first preorder.
  const pf::Scene& s = room();
  const auto& nodes = s.kd.nodes;
  std::vector<int32_t> order, index(nodes.size());
  for (std::vector<int32_t> todo = {0}; !todo.empty();) {
    const int32_t i = todo.back();
    todo.pop_back();
    index[size_t(i)] = int32_t(order.size());
    order.push_back(i);
    if (nodes[size_t(i)].axis != PF_KD_LEAF) {
      todo.push_back(nodes[size_t(i)].left);  // right child first
      todo.push_back(nodes[size_t(i)].right);
    }
  }
  std::vector<pf_kd_node> moved(nodes.size());
  for (size_t i = 0; i < order.size(); ++i) {
    pf_kd_node n = nodes[size_t(order[i])];
    if (n.axis != PF_KD_LEAF) {
      n.left = index[size_t(n.left)];
      n.right = index[size_t(n.right)];
    }
    for (int32_t& r : n.ropes)
      if (r >= 0) r = index[size_t(r)];
    moved[i] = n;
  }
  REQUIRE(moved[0].left != 1);
  const auto rays = random_rays(s, 50000, 22);
  size_t hits = 0;
  CHECK(compact_differences(s, nodes, moved, rays, hits) == 0);
  CHECK(hits > rays.size() / 4);
}

TEST_CASE("a hit on a split plane goes on into the next leaf: ties to the lower index",
          "[raycast]") {
  // Two congruent coplanar triangles in the plane z = 0.5 share the edge x = 0.5, which is the
  // root's split plane: the left leaf lists triangle 1, the right leaf triangle 0 (a tree built by
  // hand, ropes included). A ray through the shared edge hits both at the same t, and the closest
  // hit is the lower index (intersect_shared.h) whichever leaf the ray meets first: a hit exactly
  // on the exit plane must not end the traversal (pf_kd_traverse_ropes; the stack traversal's
  // far node starting at that t).
  pf::Scene s;
  auto tri = [](Vec3 a, Vec3 b, Vec3 c) {
    pf_triangle t{};
    for (int k = 0; k < 3; ++k) {
      t.v0[k] = a[k];
      t.v1[k] = b[k];
      t.v2[k] = c[k];
      t.n0[k] = t.n1[k] = t.n2[k] = k == 2 ? 1.f : 0.f;
    }
    return t;
  };
  s.triangles = {tri({0.5f, 0, 0.5f}, {1, 0, 0.5f}, {0.5f, 1, 0.5f}),   // 0: right of x = 0.5
                 tri({0, 0, 0.5f}, {0.5f, 0, 0.5f}, {0.5f, 1, 0.5f})};  // 1: left of it
  s.compute_hh();
  s.compute_bounds();
  pf::KdTree& kd = s.kd;
  kd.nodes.resize(3);
  for (pf_kd_node& n : kd.nodes) {
    n = pf_kd_node{};
    for (int k = 0; k < 3; ++k) {
      n.lo[k] = 0.f;
      n.hi[k] = 1.f;
    }
    for (int32_t& r : n.ropes) r = -1;
  }
  kd.nodes[0].axis = 0;
  kd.nodes[0].split = 0.5f;
  kd.nodes[0].left = 1;
  kd.nodes[0].right = 2;
  kd.nodes[1].hi[0] = kd.nodes[2].lo[0] = 0.5f;
  for (int i : {1, 2}) {
    kd.nodes[size_t(i)].axis = PF_KD_LEAF;
    kd.nodes[size_t(i)].first = i - 1;
    kd.nodes[size_t(i)].count = 1;
    kd.nodes[size_t(i)].left = kd.nodes[size_t(i)].right = -1;
  }
  kd.nodes[1].ropes[1] = 2;  // face x high → the right leaf
  kd.nodes[2].ropes[0] = 1;  // face x low → the left leaf
  kd.leaf_tris = {1, 0};
  kd.bounds = pf::Bounds{Vec3(0, 0, 0), Vec3(1, 1, 1)};
  REQUIRE(pf::validate_kdtree(kd, s.triangles.size()) == "");
  std::vector<pf::Ray> rays;
  for (float ox : {0.1f, 0.3f, 0.7f, 0.95f})
    for (float oz : {0.f, 1.f})
      for (float y : {0.1f, 0.25f, 0.5f}) {
        pf::Ray r;
        r.o = Vec3(ox, 0.3f, oz);
        r.d = Vec3(0.5f, y, 0.5f) - r.o;
        rays.push_back(r);
      }
  size_t ties = 0;
  for (const pf::Ray& r : rays) {
    pf::Hit a, b;
    pf::Scene one;
    one.hh = {s.hh[0]};
    REQUIRE(pf::intersect_closest(one, r, a, pf::Traversal::Brute));
    one.hh = {s.hh[1]};
    REQUIRE(pf::intersect_closest(one, r, b, pf::Traversal::Brute));
    ties += a.t == b.t;
  }
  REQUIRE(ties == rays.size());  // both triangles at the same t: a tie on every ray
  for (pf::Traversal trav : {pf::Traversal::Brute, pf::Traversal::Ropes, pf::Traversal::Stack}) {
    INFO(pf::traversal_name(trav));
    size_t lowest = 0;
    for (const pf::Ray& r : rays) {
      pf::Hit h;
      lowest += pf::intersect_closest(s, r, h, trav) && h.tri == 0;
    }
    CHECK(lowest == rays.size());
  }
}

TEST_CASE("the AVX leaf test (eight triangles at a time) gives the SSE one's hits bit for bit",
          "[raycast]") {
  // Where the CPU has AVX the stack traversal tests two four-triangle packets per operation and
  // a last odd packet with SSE. Leaves of 1 to 40 triangles (trees built with large leaves) take
  // every path: one packet, two, two and a tail, many. Closest and any hit, both ways.
  if (!pf::kd_leaf_avx_supported()) {
    CHECK_FALSE(pf::set_kd_leaf_avx(true));  // refused, nothing changed
    return;
  }
  pf::Scene big = soup();
  pf::KdBuildParams params;
  params.max_leaf_size = GENERATE(1, 12, 40);
  big.kd = pf::build_kdtree(big.triangles, params);
  INFO("leaves of up to " << params.max_leaf_size << " triangles at least");
  for (const pf::Scene* s : {static_cast<const pf::Scene*>(&big), &room()}) {
    const auto rays = random_rays(*s, 50000, 11);
    // Both traversals take the AVX test (the rope loop for leaves of more than four).
    for (pf::Traversal trav : {pf::Traversal::Stack, pf::Traversal::Ropes}) {
      INFO(pf::traversal_name(trav));
      std::vector<pf::Hit> sse, avx;
      std::vector<uint8_t> sse_any, avx_any;
      REQUIRE(pf::set_kd_leaf_avx(false));
      pf::intersect_closest_batch(*s, rays, sse, trav);
      pf::intersect_any_batch(*s, rays, sse_any, trav);
      REQUIRE(pf::set_kd_leaf_avx(true));
      pf::intersect_closest_batch(*s, rays, avx, trav);
      pf::intersect_any_batch(*s, rays, avx_any, trav);
      size_t differ = 0, hits = 0;
      for (size_t i = 0; i < rays.size(); ++i) {
        const pf::Hit &a = sse[i], &b = avx[i];
        hits += a.hit() ? 1 : 0;
        differ += a.tri == b.tri && a.t == b.t && a.u == b.u && a.v == b.v ? 0 : 1;
      }
      CHECK(differ == 0);
      CHECK(sse_any == avx_any);
      CHECK(hits > rays.size() / 5);  // the soup is open: a quarter of its rays hit
    }
  }
}

namespace {

// Whether p lies in the box [lo, hi] widened by `slack` on every side (indexable lo, hi: float
// arrays or Vec3).
template <class Lo, class Hi>
bool in_box(const Lo& lo, const Hi& hi, const Vec3& p, float slack = 0.f) {
  for (int k = 0; k < 3; ++k)
    if (!(p[k] >= lo[k] - slack && p[k] <= hi[k] + slack)) return false;
  return true;
}

// The compact rope copy of a scene's tree, as the host builds it (raycast.cpp): its leaf records
// are numbered as Hit::leaf and Ray::leaf number them.
struct CompactCopy {
  std::vector<shared_plain::pf_kd_cnode> cnodes;
  std::vector<shared_plain::pf_kd_cleaf> cleaves;
  std::vector<int32_t> node_of_leaf;  // the pf_kd_node of each leaf record
  float root_box[6];
  explicit CompactCopy(const pf::Scene& s) {
    std::vector<int32_t> order, index;
    preorder(s.kd.nodes, order, index);
    size_t n_leaves = 0;
    for (const pf_kd_node& n : s.kd.nodes) n_leaves += n.axis == PF_KD_LEAF ? 1 : 0;
    cnodes.resize(s.kd.nodes.size());
    cleaves.resize(n_leaves);
    shared_plain::pf_kd_compact_build(s.kd.nodes.data(), int32_t(s.kd.nodes.size()), order.data(),
                                      index.data(), cnodes.data(), cleaves.data(), root_box);
    node_of_leaf.resize(n_leaves);
    for (size_t i = 0; i < cnodes.size(); ++i)
      if ((cnodes[i].code & 3) == PF_KD_LEAF) node_of_leaf[size_t(cnodes[i].code >> 2)] = order[i];
  }
  // Whether leaf record `leaf`'s box holds p, widened by `slack` on every side.
  bool holds(int32_t leaf, const Vec3& p, float slack = 0.f) const {
    if (leaf < 0 || size_t(leaf) >= cleaves.size()) return false;
    const float* b = cleaves[size_t(leaf)].box;
    return in_box(b, b + 3, p, slack);
  }
};

bool inside_box(const pf::Scene& s, const Vec3& p) {
  return in_box(s.kd.bounds.lo, s.kd.bounds.hi, p);
}

bool same_bits(const pf::Hit& a, const pf::Hit& b) {
  return a.tri == b.tri && (!a.hit() || (std::memcmp(&a.t, &b.t, 4) == 0 &&
                                         std::memcmp(&a.u, &b.u, 4) == 0 &&
                                         std::memcmp(&a.v, &b.v, 4) == 0));
}

// Secondary rays as the tracers cast them: from the hits of random rays, through spawn_ray (the
// hit's leaf as Ray::leaf), in uniform directions, three in four back to the side the ray came
// from (reflection), the others through the surface (refraction: their origin crosses it, often
// into another leaf).
std::vector<pf::Ray> bounce_rays(const pf::Scene& s, size_t n, uint32_t seed) {
  const auto first = random_rays(s, n, seed);
  std::mt19937 rng(seed + 1000);
  const pf::RayCaster caster(s);
  const float eps = pf::ray_epsilon(s);
  std::vector<pf::Ray> out;
  for (const pf::Ray& r : first) {
    pf::Hit h;
    if (!caster.closest(r, h)) continue;
    const pf::SurfaceHit sh = pf::surface_at(s, r, h);
    Vec3 d = random_direction(rng);
    if ((pf::dot(d, sh.ng) > 0.f) == (pf::dot(r.d, sh.ng) > 0.f) && rng() % 4 != 0) d = -d;
    pf::Ray b = pf::spawn_ray(sh, d, eps);
    REQUIRE(b.leaf == h.leaf);
    if (out.size() % 3 == 0) b.tmax = 0.3f;  // some short, like shadow rays
    out.push_back(b);
  }
  return out;
}

}  // namespace

TEST_CASE("a closest hit reports the kd leaf it lies in", "[raycast]") {
  // Hit::leaf (the leaf record where the walk stopped) must hold the hit point, up to rounding
  // and the edge tolerance, for rays from inside the scene's box: the next ray from there starts
  // its walk in it. Both the stack walk and the rope walk report
  // it; any-hit queries and misses report none.
  for (const pf::Scene* s : {&room(), &soup(), &blob()}) {
    const CompactCopy copy(*s);
    const auto rays = random_rays(*s, 20000, 31);
    // Up to rounding and the edge tolerance of the triangle test (a hit just past an edge).
    const float slack = 2.f * PF_HH_EDGE_EPS * pf::length(s->bounds.extent());
    size_t hits = 0, outside = 0, no_leaf = 0;
    for (pf::Traversal trav : {pf::Traversal::Stack, pf::Traversal::Ropes}) {
      for (const pf::Ray& r : rays) {
        pf::Hit h;
        if (!pf::intersect_closest(*s, r, h, trav)) {
          no_leaf += h.leaf == -1 ? 0 : 1;  // a miss reports no leaf
          continue;
        }
        ++hits;
        if (inside_box(*s, r.o)) outside += copy.holds(h.leaf, r.o + r.d * h.t, slack) ? 0 : 1;
      }
    }
    INFO(s->triangles.size() << " triangles, " << hits << " hits");
    CHECK(hits > rays.size() / 2);
    CHECK(outside == 0);
    CHECK(no_leaf == 0);
  }
}

TEST_CASE("a secondary ray started in its origin's leaf gets the root walk's hit bit for bit",
          "[raycast]") {
  // Ray::leaf only saves the descent from the root: the closest hit (triangle, t, u, v) and the
  // any-hit answer must be exactly those of the same ray without it, through RayCaster and
  // intersect_closest / intersect_any alike. Most bounce origins lie in their hit's leaf (the
  // path is really taken); a hint whose box does not hold the origin, or that names no leaf at
  // all, must be ignored.
  for (const pf::Scene* s : {&room(), &soup(), &blob()}) {
    const CompactCopy copy(*s);
    const pf::RayCaster caster(*s);
    const auto rays = bounce_rays(*s, s->triangles.size() > 50000 ? 60000 : 20000, 32);
    std::mt19937 rng(33);
    size_t inside = 0, differ = 0, any_differ = 0, wrong_differ = 0, wrong_outside = 0, hits = 0;
    for (const pf::Ray& hinted : rays) {
      pf::Ray plain = hinted;
      plain.leaf = -1;
      inside += copy.holds(hinted.leaf, hinted.o) ? 1 : 0;
      pf::Hit a, b, c;
      caster.closest(plain, a);
      caster.closest(hinted, b);
      pf::intersect_closest(*s, hinted, c);
      hits += a.hit() ? 1 : 0;
      differ += same_bits(a, b) && same_bits(a, c) ? 0 : 1;
      any_differ += caster.any(plain) == caster.any(hinted) &&
                            caster.any(plain) == pf::intersect_any(*s, hinted)
                        ? 0
                        : 1;
      // Another leaf (almost never holding the origin), or an index past the last leaf.
      pf::Ray wrong = hinted;
      wrong.leaf = rng() % 8 == 0 ? int32_t(copy.cleaves.size() + rng() % 100)
                                  : int32_t(rng() % copy.cleaves.size());
      wrong_outside += copy.holds(wrong.leaf, wrong.o) ? 0 : 1;
      pf::Hit w;
      caster.closest(wrong, w);
      wrong_differ += same_bits(a, w) && caster.any(wrong) == caster.any(plain) ? 0 : 1;
    }
    INFO(s->triangles.size() << " triangles, " << rays.size() << " bounce rays, " << inside
                             << " origins in their leaf, " << hits << " hits");
    CHECK(hits > rays.size() / 5);  // the soup is open
    CHECK(inside > rays.size() * 2 / 3);
    CHECK(wrong_outside > rays.size() * 9 / 10);
    CHECK(differ == 0);
    CHECK(any_differ == 0);
    CHECK(wrong_differ == 0);
  }
}

TEST_CASE("the shared rope loops started in a leaf equal their root walks (the kernels' test)",
          "[raycast]") {
  // pf_kd_traverse_ropes_compact_from and pf_kd_traverse_ropes_from (over pf_kd_node, what the
  // kernels run) with the scalar leaf test, as a kernel compiles them: started in the origin's
  // leaf they return the root walk's bits and report the leaf the hit lies in; started in a leaf
  // that does not hold the origin (or, over pf_kd_node, at an inner node), they walk from the
  // root.
  for (const pf::Scene* s : {&room(), &blob()}) {
    const CompactCopy c(*s);
    const std::vector<pf_kd_node>& nodes = s->kd.nodes;
    const auto rays = bounce_rays(*s, 20000, 34);
    // Up to rounding and the edge tolerance of the triangle test (a hit just past an edge).
    const float slack = 2.f * PF_HH_EDGE_EPS * pf::length(s->bounds.extent());
    auto node_holds = [&](int32_t n, const Vec3& p) {
      if (n < 0 || size_t(n) >= nodes.size() || nodes[size_t(n)].axis != PF_KD_LEAF) return false;
      return in_box(nodes[size_t(n)].lo, nodes[size_t(n)].hi, p, slack);
    };
    size_t differ = 0, bad_end = 0, started = 0, hits = 0;
    for (const pf::Ray& r : rays) {
      const float o[3] = {r.o.x, r.o.y, r.o.z}, d[3] = {r.d.x, r.d.y, r.d.z};
      started += c.holds(r.leaf, r.o) ? 1 : 0;
      const int32_t wrong_leaf = int32_t((r.leaf + 1) % int32_t(c.cleaves.size()));
      for (int any = 0; any < 2; ++any) {
        for (int32_t start : {r.leaf, wrong_leaf}) {
          shared_plain::pf_ray_hit a = {r.tmax, -1, 0.f, 0.f}, b = a, e = a;
          int32_t end_a = 7, end_b = 7, end_e = 7;
          const int ra = shared_plain::pf_kd_traverse_ropes_compact_from(
              c.cnodes.data(), int32_t(c.cnodes.size()), c.cleaves.data(), c.root_box,
              s->kd.leaf_tris.data(), s->hh.data(), o, d, r.tmin, any, &a, -1, &end_a);
          const int rb = shared_plain::pf_kd_traverse_ropes_compact_from(
              c.cnodes.data(), int32_t(c.cnodes.size()), c.cleaves.data(), c.root_box,
              s->kd.leaf_tris.data(), s->hh.data(), o, d, r.tmin, any, &b, start, &end_b);
          // The pf_kd_node loop from the same leaf (or from the root's first child, an inner
          // node, which it must ignore).
          const int32_t node_start =
              start == wrong_leaf && (r.leaf & 1) ? 0 : c.node_of_leaf[size_t(start)];
          const int re = shared_plain::pf_kd_traverse_ropes_from(
              nodes.data(), int32_t(nodes.size()), s->kd.leaf_tris.data(), s->hh.data(), o, d,
              r.tmin, any, &e, node_start, &end_e);
          auto same = [&](int rx, const shared_plain::pf_ray_hit& x) {
            return ra == rx && a.tri == x.tri && std::memcmp(&a.t, &x.t, 4) == 0 &&
                   std::memcmp(&a.u, &x.u, 4) == 0 && std::memcmp(&a.v, &x.v, 4) == 0;
          };
          differ += same(rb, b) && same(re, e) ? 0 : 1;
          if (any || !ra) {
            bad_end += end_a == -1 && end_b == -1 && end_e == -1 ? 0 : 1;
            continue;
          }
          hits += 1;
          // A ray from outside the scene's box may run in the margin around it and hit a wall
          // there by the edge tolerance, far from the leaf it stopped in (its next ray then
          // starts from the root): the leaf holds the hit for rays from inside.
          if (!inside_box(*s, r.o)) continue;
          const Vec3 p = r.o + r.d * a.t;
          bad_end += c.holds(end_a, p, slack) && c.holds(end_b, p, slack) && node_holds(end_e, p)
                         ? 0
                         : 1;
        }
      }
    }
    INFO(s->triangles.size() << " triangles, " << rays.size() << " rays, " << started
                             << " started in their leaf");
    CHECK(started > rays.size() * 2 / 3);
    CHECK(hits > rays.size() / 3);
    CHECK(differ == 0);
    CHECK(bad_end == 0);
  }
}

TEST_CASE("leaf_at finds the leaf that holds a point", "[raycast]") {
  for (const pf::Scene* s : {&room(), &blob()}) {
    const CompactCopy c(*s);
    const pf::RayCaster caster(*s);
    std::mt19937 rng(35);
    std::uniform_real_distribution<float> uni(0.f, 1.f);
    size_t wrong = 0;
    for (int i = 0; i < 20000; ++i) {
      const float x = uni(rng), y = uni(rng), z = uni(rng);
      const Vec3 p = s->bounds.lo + Vec3(x, y, z) * s->bounds.extent();
      wrong += c.holds(caster.leaf_at(p), p) ? 0 : 1;
    }
    CHECK(wrong == 0);
    CHECK(caster.leaf_at(s->bounds.hi + s->bounds.extent()) == -1);
    CHECK(caster.leaf_at(Vec3(NAN, 0.f, 0.f)) == -1);
  }
}
