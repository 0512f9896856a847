// test_kdtree.cpp — SAH kd-tree build: structure, coverage of every triangle, ropes, determinism.
#include <catch2/catch.hpp>
#include <cstring>
#include <random>

#include "photonflow/kdtree.h"
#include "photonflow/procedural.h"

namespace {

// Scenes of the tests: the Cornell-like room, a random soup, and a ≥ 100k-triangle blob in a room.
std::vector<pf_triangle> room() { return pf::make_cornell_room(400); }
std::vector<pf_triangle> soup() {
  pf::Bounds box;
  box.extend({0, 0, 0});
  box.extend({1, 1, 1});
  return pf::make_triangle_soup(box, 3000, 0.08f, 7);
}
std::vector<pf_triangle> big_blob() {
  auto tris = pf::make_box({-2, -2, -2}, {2, 2, 2}, true, {0, 0});
  auto blob = pf::make_blob({0, 0, 0}, 1.f, 100000, 0.3f, 3, {1, 1});
  tris.insert(tris.end(), blob.begin(), blob.end());
  return tris;
}

bool same_bytes(const pf::KdTree& a, const pf::KdTree& b) {
  return a.nodes.size() == b.nodes.size() && a.leaf_tris == b.leaf_tris &&
         std::memcmp(a.nodes.data(), b.nodes.data(), a.nodes.size() * sizeof(pf_kd_node)) == 0;
}

// True if a leaf whose closed box holds point p lists triangle `tri`. (A triangle lying in a split
// plane is kept on one side only, so a point on a split plane is looked up on both sides.)
bool leaf_lists(const pf::KdTree& tree, int32_t node, const float* p, int32_t tri) {
  const pf_kd_node& n = tree.nodes[size_t(node)];
  if (n.axis == PF_KD_LEAF) {
    for (int32_t j = n.first; j < n.first + n.count; ++j)
      if (tree.leaf_tris[size_t(j)] == tri) return true;
    return false;
  }
  const float x = p[n.axis];
  return (x <= n.split && leaf_lists(tree, n.left, p, tri)) ||
         (x >= n.split && leaf_lists(tree, n.right, p, tri));
}

}  // namespace

TEST_CASE("kd-tree of the test scenes is valid", "[kdtree]") {
  for (const auto& tris : {room(), soup(), big_blob()}) {
    const pf::KdTree tree = pf::build_kdtree(tris, {});
    INFO(tris.size() << " triangles, " << tree.nodes.size() << " nodes");
    CHECK(pf::validate_kdtree(tree, tris.size()) == "");
    CHECK(tree.depth <= pf::kKdMaxDepth);
    CHECK(tree.nodes.size() > 1);
    CHECK(tree.memory_bytes() ==
          tree.nodes.size() * sizeof(pf_kd_node) + tree.leaf_tris.size() * sizeof(int32_t));
  }
}

TEST_CASE("every point of every triangle lies in a leaf listing that triangle", "[kdtree]") {
  // Split clipping must never drop a triangle from a leaf it passes through.
  for (const auto& tris : {room(), soup(), big_blob()}) {
    const pf::KdTree tree = pf::build_kdtree(tris, {});
    std::mt19937 rng(11);
    std::uniform_real_distribution<float> uni(0.f, 1.f);
    size_t missing = 0;
    for (size_t i = 0; i < tris.size(); ++i) {
      const pf_triangle& t = tris[i];
      for (int s = 0; s < 4; ++s) {
        float u = uni(rng), v = uni(rng);
        if (u + v > 1.f) u = 1.f - u, v = 1.f - v;
        float p[3];
        for (int k = 0; k < 3; ++k) {
          p[k] = (1.f - u - v) * t.v0[k] + u * t.v1[k] + v * t.v2[k];
          if (t.v0[k] == t.v1[k] && t.v0[k] == t.v2[k]) p[k] = t.v0[k];  // exactly in its plane
        }
        missing += leaf_lists(tree, 0, p, int32_t(i)) ? 0 : 1;
      }
    }
    INFO(tris.size() << " triangles");
    CHECK(missing == 0);
  }
}

TEST_CASE("ropes point at nodes covering the face, -1 only on the scene box", "[kdtree]") {
  const auto tris = big_blob();
  const pf::KdTree tree = pf::build_kdtree(tris, {});
  const pf_kd_node& root = tree.nodes[0];
  size_t bad = 0, optimised = 0;
  for (const pf_kd_node& n : tree.nodes) {
    if (n.axis != PF_KD_LEAF) continue;
    for (int f = 0; f < 6; ++f) {
      const int a = f / 2;
      const bool high = f % 2;
      const float face = high ? n.hi[a] : n.lo[a];
      if (n.ropes[f] < 0) {
        bad += face == (high ? root.hi[a] : root.lo[a]) ? 0 : 1;
        continue;
      }
      const pf_kd_node& r = tree.nodes[size_t(n.ropes[f])];
      bool touches = (high ? r.lo[a] : r.hi[a]) == face;
      for (int k = 0; k < 3; ++k)
        if (k != a) touches = touches && r.lo[k] <= n.lo[k] && r.hi[k] >= n.hi[k];
      bad += touches ? 0 : 1;
      optimised += r.axis == PF_KD_LEAF ? 1 : 0;
    }
  }
  CHECK(bad == 0);
  CHECK(optimised > 0);  // rope optimisation reached leaves
}

TEST_CASE("the build is deterministic, for any thread count", "[kdtree]") {
  const auto tris = big_blob();
  pf::KdBuildParams p1, p2;
  p1.threads = 1;
  p2.threads = 2;
  const pf::KdTree a = pf::build_kdtree(tris, p2);
  const pf::KdTree b = pf::build_kdtree(tris, p2);
  const pf::KdTree c = pf::build_kdtree(tris, p1);
  CHECK(same_bytes(a, b));
  CHECK(same_bytes(a, c));
  CHECK(a.depth == c.depth);
}

TEST_CASE("degenerate inputs give valid trees", "[kdtree]") {
  SECTION("no triangles: one empty leaf") {
    const pf::KdTree tree = pf::build_kdtree({}, {});
    REQUIRE(tree.nodes.size() == 1);
    CHECK(tree.nodes[0].axis == PF_KD_LEAF);
    CHECK(tree.nodes[0].count == 0);
    CHECK(pf::validate_kdtree(tree, 0) == "");
  }
  SECTION("a flat scene (one quad grid in a plane)") {
    const auto tris = pf::make_heightfield(0, 1, 0, 1, 0.5f, 0.f, 30, 1);
    const pf::KdTree tree = pf::build_kdtree(tris, {});
    CHECK(pf::validate_kdtree(tree, tris.size()) == "");
    CHECK(tree.nodes[0].lo[1] == tree.nodes[0].hi[1]);
  }
  SECTION("many copies of one triangle stay in one leaf") {
    const auto one = pf::make_box({0, 0, 0}, {1, 1, 1}, false);
    std::vector<pf_triangle> tris(50, one[0]);
    const pf::KdTree tree = pf::build_kdtree(tris, {});
    CHECK(pf::validate_kdtree(tree, tris.size()) == "");
  }
}

TEST_CASE("validate_kdtree reports broken trees", "[kdtree]") {
  const auto tris = room();
  const pf::KdTree good = pf::build_kdtree(tris, {});
  REQUIRE(good.nodes[0].axis != PF_KD_LEAF);
  pf::KdTree t = good;
  t.nodes[0].right = int32_t(t.nodes.size());
  CHECK(pf::validate_kdtree(t, tris.size()) != "");
  t = good;
  t.leaf_tris[0] = int32_t(tris.size());
  CHECK(pf::validate_kdtree(t, tris.size()) != "");
  t = good;
  t.nodes[1].ropes[2 * t.nodes[0].axis + 1] = 0;  // the root does not lie beyond a child's face
  CHECK(pf::validate_kdtree(t, tris.size()) != "");
}
