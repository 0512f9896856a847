// octree.h — a standard octree over a scene's triangles, the comparator of the thesis's Table 6.1
// (spatial index: brute force, octree, kd-tree with ropes). Benchmarks only (not part of
// libcommon); bench_ch6_index.cpp checks it against brute force on every ray it times.
//
// Build: the root is the cube around the scene bounds; a node is split into its eight octants at
// its centre until it holds at most `max_leaf` triangles or reaches `max_depth`. A triangle is
// stored in every leaf it overlaps (exact triangle–box test by the separating-axis theorem,
// Akenine-Möller 2001), so no triangle is clipped or split and the same triangle may be tested in
// several leaves (no mailboxing).
//
// Traversal: recursive and front to back. At an inner node the ray's parameters at the three
// centre planes decide the first child (the octant the ray is in at its entry) and the order of
// the rest (each plane crossed flips one bit of the octant index), as in the parametric traversal
// of Revelles et al. 2000. A leaf tests its triangles with the Havel–Herout test (thesis eq.
// 4.3–4.7, intersect_shared.h, the same test the kd-tree uses), and traversal stops at the first
// leaf whose exit lies beyond the closest hit found. Ties (equal t) go to the lower triangle
// index, as in raycast.cpp's traversals, so every index returns the same triangle.
#pragma once
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "photonflow/geometry/intersect_shared.h"
#include "photonflow/geometry/raycast.h"
#include "photonflow/geometry/scene.h"
#include "bench_common.h"

namespace pf::bench {

struct OctreeParams {
  int max_depth = 8;  // the root has depth 0
  int max_leaf = 8;   // nodes with this many triangles or fewer are not split
};

class Octree {
 public:
  // Builds the octree over scene.triangles (the scene's hh planes are used by the traversal, so
  // the scene must outlive the octree).
  Octree(const Scene& scene, const OctreeParams& params) : scene_(scene), params_(params) {
    const double t0 = now();
    // The cube around the scene bounds, widened like the kd-tree's root box
    // (pf_kd_enter_root): the triangle test accepts hits a few float roundoffs outside
    // a triangle (PF_HH_ROUNDING).
    const Vec3 c = scene.bounds.center();
    const Vec3 e = scene.bounds.extent();
    const float half = 0.5f * std::max({e.x, e.y, e.z}) * (1.f + 4.f * PF_HH_EDGE_EPS);
    lo_ = c - Vec3(half, half, half);
    hi_ = c + Vec3(half, half, half);
    std::vector<int32_t> all(scene.triangles.size());
    for (size_t i = 0; i < all.size(); ++i) all[i] = int32_t(i);
    nodes_.push_back({});
    build(0, lo_, hi_, all, 0);
    build_seconds_ = now() - t0;
  }

  // Closest hit with t in (ray.tmin, ray.tmax]; the same contract as intersect_closest.
  bool intersect(const Ray& ray, Hit& out) const {
    Ctx r;
    r.o[0] = ray.o.x, r.o[1] = ray.o.y, r.o[2] = ray.o.z;
    r.d[0] = ray.d.x, r.d[1] = ray.d.y, r.d[2] = ray.d.z;
    for (int a = 0; a < 3; ++a) r.inv_d[a] = 1.f / r.d[a];
    r.tmin = ray.tmin;
    pf_ray_hit hit{ray.tmax, -1, 0.f, 0.f};
    const float lo[3] = {lo_.x, lo_.y, lo_.z}, hi[3] = {hi_.x, hi_.y, hi_.z};
    float t0, t1;
    if (pf_ray_box(lo, hi, r.o, r.d, r.inv_d, ray.tmin, ray.tmax, &t0, &t1))
      traverse(0, lo_, hi_, t0, t1, r, hit);
    out = Hit{};
    if (hit.tri < 0) return false;
    out.t = hit.t;
    out.tri = hit.tri;
    out.u = hit.u;
    out.v = hit.v;
    return true;
  }

  double build_seconds() const { return build_seconds_; }
  size_t nodes() const { return nodes_.size(); }
  size_t leaves() const { return leaves_; }
  size_t references() const { return refs_.size(); }  // triangle references in all leaves
  int depth() const { return depth_; }                  // deepest leaf
  size_t memory_bytes() const {
    return nodes_.size() * sizeof(Node) + refs_.size() * sizeof(int32_t);
  }

 private:
  // Inner node: count < 0 and children nodes_[first .. first + 8), child index = octant bits
  // (bit a set = the upper half along axis a). Leaf: refs_[first .. first + count).
  struct Node {
    int32_t first = 0;
    int32_t count = 0;
  };
  struct Ctx {
    float o[3], d[3], inv_d[3];
    float tmin;
  };

  // True when the triangle overlaps the box [lo, hi]: separating-axis test over the three box
  // axes, the triangle's normal and the nine edge × box-axis products (Akenine-Möller 2001).
  // The triangle is first scaled about its centroid by 1 + 4·PF_HH_EDGE_EPS: every leaf holding
  // a point the Havel–Herout test accepts must list the triangle, and the test's slack (a few
  // float roundoffs of the coordinates, PF_HH_ROUNDING) is below 1e-4 of every triangle larger
  // than about a thousandth of a unit-sized scene.
  static bool overlaps(const pf_triangle& t, const Vec3& lo, const Vec3& hi) {
    const Vec3 c = (lo + hi) * 0.5f;
    const Vec3 h = (hi - lo) * (0.5f * (1.f + 1e-5f));  // and a few ulps of slack on the box
    const Vec3 g = (Vec3(t.v0) + Vec3(t.v1) + Vec3(t.v2)) * (1.f / 3.f);
    const float s = 1.f + 4.f * PF_HH_EDGE_EPS;
    const Vec3 v[3] = {g + (Vec3(t.v0) - g) * s - c, g + (Vec3(t.v1) - g) * s - c,
                       g + (Vec3(t.v2) - g) * s - c};
    auto separated = [&](const Vec3& axis) {
      const float p0 = dot(axis, v[0]), p1 = dot(axis, v[1]), p2 = dot(axis, v[2]);
      const float r = h.x * std::fabs(axis.x) + h.y * std::fabs(axis.y) + h.z * std::fabs(axis.z);
      return std::min({p0, p1, p2}) > r || std::max({p0, p1, p2}) < -r;
    };
    const Vec3 box_axes[3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    for (const Vec3& a : box_axes)
      if (separated(a)) return false;
    const Vec3 edges[3] = {v[1] - v[0], v[2] - v[1], v[0] - v[2]};
    if (separated(cross(edges[0], edges[1]))) return false;
    for (const Vec3& e : edges)
      for (const Vec3& a : box_axes)
        if (separated(cross(a, e))) return false;
    return true;
  }

  void build(size_t node, const Vec3& lo, const Vec3& hi, const std::vector<int32_t>& tris,
             int depth) {
    if (int(tris.size()) <= params_.max_leaf || depth >= params_.max_depth) {
      nodes_[node] = {int32_t(refs_.size()), int32_t(tris.size())};
      refs_.insert(refs_.end(), tris.begin(), tris.end());
      ++leaves_;
      depth_ = std::max(depth_, depth);
      return;
    }
    const size_t first = nodes_.size();
    nodes_[node] = {int32_t(first), -1};
    nodes_.resize(first + 8);
    const Vec3 c = (lo + hi) * 0.5f;
    std::vector<int32_t> sub;
    for (int oct = 0; oct < 8; ++oct) {
      Vec3 clo = lo, chi = c;
      for (int a = 0; a < 3; ++a)
        if (oct >> a & 1) clo[a] = c[a], chi[a] = hi[a];
      sub.clear();
      for (int32_t t : tris)
        if (overlaps(scene_.triangles[size_t(t)], clo, chi)) sub.push_back(t);
      build(first + size_t(oct), clo, chi, sub, depth + 1);
    }
  }

  // Visits the node's part of the ray, [t0, t1]. Returns true when the closest hit is final
  // (found at or before t1), which ends the traversal.
  bool traverse(size_t node, const Vec3& lo, const Vec3& hi, float t0, float t1, const Ctx& r,
                pf_ray_hit& hit) const {
    const Node& n = nodes_[node];
    if (n.count >= 0) {
      for (int32_t i = n.first; i < n.first + n.count; ++i) {
        const int32_t tri = refs_[size_t(i)];
        float t, u, v;
        if (!pf_hh_intersect(&scene_.hh[size_t(tri)], r.o, r.d, r.tmin, hit.t, &t, &u, &v))
          continue;
        if (t == hit.t && hit.tri >= 0 && tri > hit.tri) continue;  // tie: lower index wins
        hit = {t, tri, u, v};
      }
      return hit.tri >= 0 && hit.t <= t1;
    }
    const Vec3 c = (lo + hi) * 0.5f;
    // Parameters of the three centre planes (never crossed when the ray is parallel to one) and
    // the octant at t0: above the plane if the ray moves up and has crossed it already, or moves
    // down and has not crossed it yet.
    float tc[3];
    int oct = 0;
    for (int a = 0; a < 3; ++a) {
      tc[a] = r.d[a] != 0.f ? (c[a] - r.o[a]) * r.inv_d[a] : INFINITY;
      const bool upper = r.d[a] != 0.f ? (tc[a] <= t0) == (r.d[a] > 0.f) : r.o[a] >= c[a];
      oct |= int(upper) << a;
    }
    int axes[3] = {0, 1, 2};  // planes in the order the ray crosses them
    std::sort(axes, axes + 3, [&](int a, int b) { return tc[a] < tc[b]; });
    float ts = t0;
    for (int i = 0; i <= 3; ++i) {
      const bool crosses = i < 3 && tc[axes[i]] > t0 && tc[axes[i]] < t1;
      if (i < 3 && !crosses) continue;
      const float te = i < 3 ? tc[axes[i]] : t1;
      Vec3 clo = lo, chi = c;
      for (int a = 0; a < 3; ++a)
        if (oct >> a & 1) clo[a] = c[a], chi[a] = hi[a];
      if (traverse(size_t(n.first + oct), clo, chi, ts, te, r, hit)) return true;
      if (i < 3) oct ^= 1 << axes[i];
      ts = te;
    }
    return false;
  }

  const Scene& scene_;
  OctreeParams params_;
  Vec3 lo_, hi_;
  std::vector<Node> nodes_;
  std::vector<int32_t> refs_;
  size_t leaves_ = 0;
  int depth_ = 0;
  double build_seconds_ = 0;
};

}  // namespace pf::bench
