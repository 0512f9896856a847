// kdtree_test.cpp — SAH kd-tree build: structure, coverage of every triangle, ropes, determinism.
#include <catch2/catch.hpp>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <random>

#include "photonflow/geometry/kdtree.h"
#include "photonflow/geometry/procedural.h"

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
  size_t bad = 0, optimised = 0, shallow = 0;
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
      // Popov et al. 2007, sec. 4.1: the rope goes down to the deepest node covering the whole
      // face, so an inner target's children do not: its plane cuts across the face.
      if (r.axis != PF_KD_LEAF)
        shallow += (r.axis != a && n.lo[r.axis] < r.split && n.hi[r.axis] > r.split) ? 0 : 1;
    }
  }
  CHECK(bad == 0);
  CHECK(shallow == 0);
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

namespace {

// Eq. 4.8 in double for the plane axis·x = pos over triangles with bounds lo..hi inside `box`:
// C_ts + C_i·(A_L·N_L + A_R·N_R)/A, times (1 − empty_bonus) when a side is empty. Triangles lying
// in the plane go to the cheaper side; a triangle only touching the plane stays on its own side
// (kdtree.h).
double brute_sah(const pf::KdBuildParams& p, const float* blo, const float* bhi,
                 const std::vector<std::array<float, 6>>& b, int axis, float pos) {
  size_t nl = 0, nr = 0, np = 0;
  for (const auto& t : b) {
    const float lo = t[size_t(axis)], hi = t[size_t(3 + axis)];
    if (lo == pos && hi == pos) ++np;
    else {
      nl += lo < pos;
      nr += hi > pos;
    }
  }
  auto area = [](const double* lo, const double* hi) {
    const double ex = hi[0] - lo[0], ey = hi[1] - lo[1], ez = hi[2] - lo[2];
    return 2 * (ex * ey + ey * ez + ez * ex);
  };
  double lo[3], hi[3], lhi[3], rlo[3];
  for (int k = 0; k < 3; ++k) {
    lo[k] = blo[k];
    hi[k] = bhi[k];
    lhi[k] = k == axis ? pos : hi[k];
    rlo[k] = k == axis ? pos : lo[k];
  }
  const double a = area(lo, hi), al = area(lo, lhi), ar = area(rlo, hi);
  auto cost = [&](size_t l, size_t r) {
    double c = p.cost_traversal + p.cost_intersect * (al * double(l) + ar * double(r)) / a;
    return (l == 0 || r == 0) ? c * (1.0 - p.empty_bonus) : c;
  };
  return std::min(cost(nl + np, nr), cost(nl, nr + np));
}

}  // namespace

// The triangles listed in the leaves of node i's subtree, ascending, and the subtree's depth below i.
void subtree_triangles(const pf::KdTree& tree, int32_t i, std::vector<int32_t>& out) {
  const pf_kd_node& n = tree.nodes[size_t(i)];
  if (n.axis == PF_KD_LEAF) {
    out.insert(out.end(), tree.leaf_tris.begin() + n.first, tree.leaf_tris.begin() + n.first + n.count);
    return;
  }
  subtree_triangles(tree, n.left, out);
  subtree_triangles(tree, n.right, out);
}

TEST_CASE("splits minimise the SAH of eq. 4.8 over every candidate plane", "[kdtree]") {
  // Nodes with fewer than kKdExactMaxTriangles references are split by a sweep over every
  // triangle bound (Wald & Havran 2006): a node's plane must be the brute-force minimum of eq. 4.8
  // over all those planes, and a node with more than max_leaf_size triangles a leaf only when no
  // plane beats C_i·N. Checked at every node whose triangles lie inside its box (their references
  // are the triangles' own bounds, never clipped): the root, and nodes that hold whole clusters.
  pf::KdBuildParams params;
  size_t split_nodes = 0, inner_nodes = 0, checked_leaves = 0, scenes = 0;
  auto check_tree = [&](const std::vector<pf_triangle>& tris) {
    ++scenes;
    REQUIRE(tris.size() < pf::kKdExactMaxTriangles);
    const pf::KdTree tree = pf::build_kdtree(tris, params);
    REQUIRE(pf::validate_kdtree(tree, tris.size()) == "");
    std::vector<std::array<float, 6>> bounds;
    for (const pf_triangle& t : tris)
      bounds.push_back({std::min({t.v0[0], t.v1[0], t.v2[0]}), std::min({t.v0[1], t.v1[1], t.v2[1]}),
                        std::min({t.v0[2], t.v1[2], t.v2[2]}), std::max({t.v0[0], t.v1[0], t.v2[0]}),
                        std::max({t.v0[1], t.v1[1], t.v2[1]}), std::max({t.v0[2], t.v1[2], t.v2[2]})});
    const int max_depth = int(8.0 + 1.3 * std::log2(double(tris.size())) + 0.5);
    std::vector<int> depth(tree.nodes.size(), 0);
    for (size_t i = 0; i < tree.nodes.size(); ++i) {
      const pf_kd_node& node = tree.nodes[i];
      if (node.axis != PF_KD_LEAF) depth[size_t(node.left)] = depth[size_t(node.right)] = depth[i] + 1;
      std::vector<int32_t> ids;
      subtree_triangles(tree, int32_t(i), ids);
      std::sort(ids.begin(), ids.end());
      ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
      std::vector<std::array<float, 6>> b;
      bool inside = true;
      for (int32_t t : ids) {
        b.push_back(bounds[size_t(t)]);
        for (int k = 0; k < 3; ++k)
          inside = inside && b.back()[size_t(k)] >= node.lo[k] && b.back()[size_t(3 + k)] <= node.hi[k];
      }
      if (!inside) continue;
      if (node.axis == PF_KD_LEAF && (b.size() <= size_t(params.max_leaf_size) || depth[i] >= max_depth))
        continue;
      double best = INFINITY;
      for (int k = 0; k < 3; ++k)
        for (const auto& t : b)
          for (float pos : {t[size_t(k)], t[size_t(3 + k)]})
            if (pos > node.lo[k] && pos < node.hi[k])
              best = std::min(best, brute_sah(params, node.lo, node.hi, b, k, pos));
      const double leaf = params.cost_intersect * double(b.size());
      INFO("scene " << scenes << ", node " << i << " of " << tree.nodes.size() << ", " << b.size()
                    << " triangles, best SAH " << best << ", leaf " << leaf);
      if (node.axis == PF_KD_LEAF) {
        ++checked_leaves;
        CHECK(best >= leaf * (1 - 1e-5));
        continue;
      }
      ++inner_nodes;
      const double chosen = brute_sah(params, node.lo, node.hi, b, node.axis, node.split);
      INFO("chosen axis " << node.axis << " at " << node.split << ": SAH " << chosen);
      CHECK(chosen <= best * (1 + 1e-5));
      split_nodes += i == 0 ? 0 : 1;
    }
  };
  for (uint32_t seed = 1; seed <= 24; ++seed) {
    pf::Bounds box;
    box.extend({0, 0, 0});
    box.extend({1.f + 0.1f * float(seed % 5), 1, 0.5f + 0.05f * float(seed % 7)});
    std::vector<pf_triangle> tris =
        pf::make_triangle_soup(box, 20 + 37 * seed, 0.05f + 0.02f * float(seed % 4), seed);
    if (seed % 3 == 0) {  // a flat floor too: planar triangles in a candidate plane
      const auto floor = pf::make_heightfield(0, 1, 0, 0.5f, 0.25f, 0.f, 4, 1);
      tris.insert(tris.end(), floor.begin(), floor.end());
    }
    check_tree(tris);
  }
  // Sandwiches: a flat grid in the plane y = 0.5 between two soups; the best plane is the grid's
  // own, with the grid on one side (its triangles counted once).
  for (int cells : {6, 10}) {
    pf::Bounds below, above;
    below.extend({0, 0, 0});
    below.extend({1, 0.45f, 1});
    above.extend({0, 0.55f, 0});
    above.extend({1, 1, 1});
    std::vector<pf_triangle> tris = pf::make_heightfield(0, 1, 0, 1, 0.5f, 0.f, cells, 1);
    for (const pf::Bounds& box : {below, above}) {
      const auto soup = pf::make_triangle_soup(box, 150, 0.03f, uint32_t(cells));
      tris.insert(tris.end(), soup.begin(), soup.end());
    }
    check_tree(tris);
  }
  // Clusters apart: below the root, nodes holding one cluster and empty space, where eq. 4.8's
  // empty-space bonus decides between cutting the space off and splitting the cluster.
  for (uint32_t seed = 1; seed <= 12; ++seed) {
    std::vector<pf_triangle> tris;
    for (int c = 0; c < 3; ++c) {
      const float x = 0.4f * float(c) + 0.03f * float(seed % 5);
      const float w = 0.05f + 0.04f * float((seed + uint32_t(c)) % 4);
      pf::Bounds box;
      box.extend({x, 0.1f * float(c), 0});
      box.extend({x + w, 0.1f * float(c) + 2 * w, 3 * w});
      const auto soup = pf::make_triangle_soup(box, 40 + 10 * seed, 0.4f * w, seed * 3 + uint32_t(c));
      tris.insert(tris.end(), soup.begin(), soup.end());
    }
    check_tree(tris);
  }
  INFO(inner_nodes << " inner nodes checked, " << split_nodes << " below the root, "
                   << checked_leaves << " leaves");
  CHECK(inner_nodes > 40);
  CHECK(split_nodes > 10);
}

TEST_CASE("a triangle is listed only on the sides of a split plane that it reaches", "[kdtree]") {
  // kdtree.h: a triangle that only touches a split plane (a vertex or an edge on it) stays on its
  // own side; one lying in the plane goes to one side. So below the plane axis = split, the left
  // subtree lists only triangles reaching below it (min < split) or lying in it, the right subtree
  // only triangles reaching above it. (Listing touching triangles on both sides is still a valid
  // tree, but doubled the triangle tests per ray on meshes with vertices on split planes.)
  const auto sphere = pf::make_sphere({0.f, 0.f, 0.f}, 1.f, 3000);
  for (const auto& tris : {room(), soup(), sphere}) {
    const pf::KdTree tree = pf::build_kdtree(tris, {});
    size_t wrong = 0, touching = 0;
    for (const pf_kd_node& n : tree.nodes) {
      if (n.axis == PF_KD_LEAF) continue;
      const int a = n.axis;
      for (int side = 0; side < 2; ++side) {
        std::vector<int32_t> ids;
        subtree_triangles(tree, side == 0 ? n.left : n.right, ids);
        for (int32_t i : ids) {
          const pf_triangle& t = tris[size_t(i)];
          const float lo = std::min({t.v0[a], t.v1[a], t.v2[a]});
          const float hi = std::max({t.v0[a], t.v1[a], t.v2[a]});
          if (lo == n.split && hi == n.split) continue;  // in the plane: one side, either
          const bool reaches = side == 0 ? lo < n.split : hi > n.split;
          wrong += reaches ? 0 : 1;
        }
      }
      for (const pf_triangle& t : tris) {  // the case in question occurs
        const float lo = std::min({t.v0[a], t.v1[a], t.v2[a]});
        const float hi = std::max({t.v0[a], t.v1[a], t.v2[a]});
        touching += (lo < hi && (lo == n.split || hi == n.split)) ? 1 : 0;
      }
    }
    INFO(tris.size() << " triangles, " << tree.nodes.size() << " nodes, " << touching
                     << " triangles touching a split plane");
    CHECK(touching > 0);
    CHECK(wrong == 0);
  }
}
