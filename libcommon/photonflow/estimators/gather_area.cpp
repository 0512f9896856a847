// The surface area a gather takes photons from: see estimators/gather_area.h (equation numbers
// refer to it). The plane geometry of its clipping is gather_area_clip.cpp's.
#include "photonflow/estimators/gather_area.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <unordered_map>

#include "photonflow/estimators/gather_area_clip.h"
#include "photonflow/foundations/error.h"
#include "photonflow/foundations/options.h"

namespace pf {

const char* gather_area_name(GatherArea a) {
  return a == GatherArea::Surface ? "surface" : "disc";
}

GatherArea parse_gather_area(const std::string& text, bool new_eye_pass) {
  require_choice("gather-area", text, {"auto", "surface", "disc"});
  if (text == "auto") return new_eye_pass ? GatherArea::Surface : GatherArea::Disc;
  if (text == "surface" && !new_eye_pass)
    throw input_error("", "--gather-area surface applies to --estimator sppm and pppm",
                      "ppm's fixed hitpoints divide by the disc, the thesis's eq. 3.17");
  return text == "surface" ? GatherArea::Surface : GatherArea::Disc;
}

namespace {

inline double dot3(const double* a, const double* b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

// The slab's half-width κR at radius r, or −1 for none (κ = 0: the ball alone).
inline double slab_reach(float slab, double r) { return slab > 0.f ? double(slab) * r : -1.0; }

// A triangle of a mesh, or two coplanar triangles sharing an edge whose union is convex (a
// quad: a box's face, a wall), with what eq. (1) needs of it. The quad's area within a disc is
// the two triangles' (their shared edge's terms cancel) at the cost of one polygon, and a disc
// inside it takes the whole-disc path where it spans the diagonal.
struct AreaTri {
  double v[4][3];  // corners, counter-clockwise about m
  int count;       // 3, or 4 for a merged quad
  double m[3];     // unit geometric normal, (v1 − v0) × (v2 − v0) normalised
  double u[3];     // unit vector along v1 − v0 (with m × u, the plane's frame)
  double area;     // |T|
  int32_t vid[4];  // its corners in SurfaceArea::Impl::verts (shared by the mesh's triangles)
  double edge;     // longest edge of a triangle (quads are never small: not used)
};

// Merges coplanar pairs of the mesh's triangles `list` (indices into src) that share an edge
// (the same two vertex ids, opposite directions) into convex quads, greedily in index order;
// `list` then holds each quad in its first triangle's place and drops the second. Only
// triangles whose longest edge reaches `min_edge`: a fine mesh's small triangles keep the
// interpolated rule of SurfaceArea::area (quads never take it).
void merge_coplanar_pairs(std::vector<int32_t>& list, std::vector<AreaTri>& src,
                          std::vector<double>& centroid, double min_edge) {
  std::unordered_map<uint64_t, int32_t> by_edge;  // directed edge (from, to) → triangle
  auto key = [](int32_t a, int32_t b) { return (uint64_t(uint32_t(a)) << 32) | uint32_t(b); };
  for (int32_t i : list) {
    const int32_t* vid = src[size_t(i)].vid;
    for (int e = 0; e < 3; ++e) by_edge.emplace(key(vid[e], vid[(e + 1) % 3]), i);
  }
  std::vector<char> gone(src.size(), 0);
  for (int32_t i : list) {
    AreaTri& a = src[size_t(i)];
    if (gone[size_t(i)] || a.count != 3 || a.edge < min_edge) continue;
    for (int e = 0; e < 3 && a.count == 3; ++e) {
      // A's edge p → q; B holds q → p and its third corner s: the quad p, s, q, r.
      const int32_t p = a.vid[e], q = a.vid[(e + 1) % 3];
      const auto it = by_edge.find(key(q, p));
      if (it == by_edge.end() || it->second == i || gone[size_t(it->second)]) continue;
      const AreaTri& b = src[size_t(it->second)];
      if (b.count != 3 || b.edge < min_edge || dot3(a.m, b.m) < 1.0 - 1e-12) continue;
      int bs = 0;
      while (bs < 3 && (b.vid[bs] == p || b.vid[bs] == q)) ++bs;
      const double* P = a.v[e];
      const double* Q = a.v[(e + 1) % 3];
      const double* R = a.v[(e + 2) % 3];
      const double* S = b.v[bs];
      const double* quad[4] = {P, S, Q, R};
      // Convex (every turn left about m) and flat (S on A's plane).
      double sp[3];
      for (int k = 0; k < 3; ++k) sp[k] = S[k] - P[k];
      bool ok = std::fabs(dot3(sp, a.m)) <= 1e-9 * std::sqrt(dot3(sp, sp));
      for (int j = 0; j < 4 && ok; ++j) {
        const double* o = quad[j];
        const double* v1 = quad[(j + 1) % 4];
        const double* v2 = quad[(j + 2) % 4];
        const double d1[3] = {v1[0] - o[0], v1[1] - o[1], v1[2] - o[2]};
        const double d2[3] = {v2[0] - v1[0], v2[1] - v1[1], v2[2] - v1[2]};
        const double c[3] = {d1[1] * d2[2] - d1[2] * d2[1], d1[2] * d2[0] - d1[0] * d2[2],
                             d1[0] * d2[1] - d1[1] * d2[0]};
        ok = dot3(c, a.m) > 0.0;
      }
      if (!ok) continue;
      AreaTri merged = a;
      const int32_t ids[4] = {p, b.vid[bs], q, a.vid[(e + 2) % 3]};
      for (int j = 0; j < 4; ++j) {
        for (int k = 0; k < 3; ++k) merged.v[j][k] = quad[j][k];
        merged.vid[j] = ids[j];
      }
      merged.count = 4;
      merged.area = a.area + b.area;
      double d[3];
      for (int k = 0; k < 3; ++k) d[k] = merged.v[1][k] - merged.v[0][k];
      const double len = std::sqrt(dot3(d, d));  // > 0: S lies off the edge P → Q
      for (int k = 0; k < 3; ++k) {
        merged.u[k] = d[k] / len;
        centroid[size_t(i) * 3 + size_t(k)] =
            (quad[0][k] + quad[1][k] + quad[2][k] + quad[3][k]) / 4.0;
      }
      gone[size_t(it->second)] = 1;
      a = merged;
    }
  }
  list.erase(std::remove_if(list.begin(), list.end(),
                            [&](int32_t i) { return gone[size_t(i)] != 0; }),
             list.end());
}

// A corner shared by triangles of one mesh (equal float position): where a fine mesh's ratios
// A/(πR_L²) are evaluated (SurfaceArea::area).
struct AreaVertex {
  double p[3];  // position
  double n[3];  // the first triangle's shading normal there, on that triangle's front side
  int32_t mesh;
};

// A node of a mesh's hierarchy: its box, Σ|T| and Σ|T|·m_T of its triangles; count > 0: a leaf of
// triangles [first, first + count); count == 0: children first and first + 1.
struct AreaNode {
  float lo[3], hi[3];
  double area;
  double an[3];
  int32_t first;
  int32_t count;
};

constexpr int kLeafSize = 4;
constexpr double kLevelsPerOctave = 4.0;  // radius levels R_L = r_ref · 2^(−L/4)
constexpr double kSmallEdge = 1.0;        // a triangle whose longest edge is <= R is small

}  // namespace

struct SurfaceArea::Impl {
  std::vector<AreaTri> tris;          // grouped by mesh, each mesh's in its hierarchy's order
  std::vector<AreaVertex> verts;      // the triangles' corners, shared within a mesh
  std::vector<AreaNode> nodes;
  std::vector<int32_t> root;          // per mesh: its root node, −1 for a mesh with no triangle
  std::vector<int32_t> tri_begin;     // per mesh: its triangles [tri_begin[m], tri_begin[m + 1])
  const void* key_tris = nullptr;     // the scene's triangle array it was built from
  size_t n_tris = 0;
  double tolerance = 0.0;             // how far off its triangle a site may lie (rounding)
  double r_ref = 1.0;                 // the radius levels' reference length (the scene diagonal)
  // The ratios A/(πR_L²) at the corners of small triangles (area's interpolated rule), one cache
  // per slab value (the first kCaches slabs asked for; others compute every time), two slots per
  // vertex (even and odd levels: a query reads two adjacent ones): (key << 32) | the ratio's
  // float bits, key = 2^31 | both_sides << 16 | level + 32768.
  static constexpr int kCaches = 4;
  struct Cache {
    std::atomic<uint32_t> slab{0};
    std::atomic<bool> claimed{false};
    std::atomic<bool> ready{false};
    std::unique_ptr<std::atomic<uint64_t>[]> slots;
  };
  mutable Cache caches[kCaches];

  void build(int32_t slot, std::vector<int32_t>& idx, int begin, int end,
             const std::vector<AreaTri>& src, const std::vector<double>& centroid);
  int sign_at(int mesh, const double* x, const double* n, int32_t* tri) const;
  // Where eq. (1) is asked at `site` with R: x, n, the triangle T0 holding x and σ (1 with
  // both_sides, where eq. 2 does not use it); false when there is no area (no mesh of this
  // scene, R <= 0, or x on no triangle of its mesh).
  struct Site {
    double x[3], n[3];
    int32_t tri;
    int sigma;
  };
  bool locate(const pf_hitpoint& site, float radius, bool both_sides, Site& at) const;
  // Depth first over `mesh`'s hierarchy: open(node) says whether to go into the node (a query
  // that skips it, or takes it whole itself, returns false); the triangles of the leaves it
  // opens go to leaf(triangle index).
  template <class Open, class Leaf>
  void walk(int mesh, Open&& open, Leaf&& leaf) const {
    int32_t stack[64];
    int top = 0;
    stack[top++] = root[size_t(mesh)];
    while (top > 0) {
      const AreaNode& nd = nodes[size_t(stack[--top])];
      if (!open(nd)) continue;
      if (nd.count == 0) {
        stack[top++] = nd.first;
        stack[top++] = nd.first + 1;
        continue;
      }
      for (int32_t i = nd.first; i < nd.first + nd.count; ++i) leaf(i);
    }
  }
  double sum(int mesh, const double* x, const double* n, double r, double kr, int sigma,
             bool both_sides) const;
  double vertex_ratio(int32_t vertex, int level, float slab, bool both_sides) const;
  std::atomic<uint64_t>* cache_for(float slab) const;
  double clipped(const AreaTri& t, const double* x, const double* n, double r, double kr) const;
  double weight(const AreaTri& t, const double* n, int sigma, bool both_sides) const {
    if (both_sides) return 1.0;
    return std::clamp(0.5 * (1.0 + double(sigma) * dot3(t.m, n)), 0.0, 1.0);  // eq. (2)
  }
};

// Builds the subtree over src[idx[begin..end)] into nodes[slot] (median split of the centroids
// along their widest axis); the triangles of its leaves are appended to `tris` in leaf order.
void SurfaceArea::Impl::build(int32_t slot, std::vector<int32_t>& idx, int begin, int end,
                              const std::vector<AreaTri>& src,
                              const std::vector<double>& centroid) {
  AreaNode nd{};
  for (int k = 0; k < 3; ++k) {
    nd.lo[k] = INFINITY;
    nd.hi[k] = -INFINITY;
  }
  double clo[3] = {INFINITY, INFINITY, INFINITY}, chi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (int i = begin; i < end; ++i) {
    const AreaTri& t = src[size_t(idx[size_t(i)])];
    for (int v = 0; v < t.count; ++v)
      for (int k = 0; k < 3; ++k) {
        // The box of the vertices, rounded outwards to float.
        nd.lo[k] = std::min(nd.lo[k], std::nextafter(float(t.v[v][k]), -INFINITY));
        nd.hi[k] = std::max(nd.hi[k], std::nextafter(float(t.v[v][k]), INFINITY));
      }
    nd.area += t.area;
    for (int k = 0; k < 3; ++k) {
      nd.an[k] += t.area * t.m[k];
      const double c = centroid[size_t(idx[size_t(i)]) * 3 + size_t(k)];
      clo[k] = std::min(clo[k], c);
      chi[k] = std::max(chi[k], c);
    }
  }
  if (end - begin <= kLeafSize) {
    nd.first = int32_t(tris.size());
    nd.count = end - begin;
    for (int i = begin; i < end; ++i) tris.push_back(src[size_t(idx[size_t(i)])]);
    nodes[size_t(slot)] = nd;
    return;
  }
  int axis = 0;
  for (int k = 1; k < 3; ++k)
    if (chi[k] - clo[k] > chi[axis] - clo[axis]) axis = k;
  const int mid = begin + (end - begin) / 2;
  std::nth_element(idx.begin() + begin, idx.begin() + mid, idx.begin() + end,
                   [&](int32_t a, int32_t b) {
                     const double ca = centroid[size_t(a) * 3 + size_t(axis)];
                     const double cb = centroid[size_t(b) * 3 + size_t(axis)];
                     return ca < cb || (ca == cb && a < b);
                   });
  const int32_t left = int32_t(nodes.size());  // the children side by side
  nodes.resize(nodes.size() + 2);
  nd.first = left;
  nd.count = 0;
  nodes[size_t(slot)] = nd;
  build(left, idx, begin, mid, src, centroid);
  build(left + 1, idx, mid, end, src, centroid);
}

SurfaceArea::SurfaceArea(const Scene& scene) : impl_(std::make_unique<Impl>()) {
  Impl& I = *impl_;
  I.key_tris = scene.triangles.data();
  I.n_tris = scene.triangles.size();
  const Vec3 ext = scene.bounds.hi - scene.bounds.lo;
  const double diag = std::sqrt(double(dot(ext, ext)));
  I.r_ref = std::isfinite(diag) && diag > 0.0 ? diag : 1.0;
  I.tolerance = 1e-5 * I.r_ref;
  int meshes = int(scene.mesh_names.size());
  for (const pf_triangle& t : scene.triangles) meshes = std::max(meshes, t.mesh + 1);
  std::vector<std::vector<int32_t>> of_mesh(size_t(std::max(meshes, 0)));
  std::vector<AreaTri> src(scene.triangles.size());
  struct VertexKey {
    int32_t mesh;
    uint32_t bits[3];
    bool operator==(const VertexKey& o) const {
      return mesh == o.mesh && bits[0] == o.bits[0] && bits[1] == o.bits[1] && bits[2] == o.bits[2];
    }
  };
  struct VertexHash {
    size_t operator()(const VertexKey& k) const {
      uint64_t h = uint64_t(uint32_t(k.mesh)) * 0x9E3779B97F4A7C15ull;
      for (uint32_t b : k.bits) h = (h ^ b) * 0xff51afd7ed558ccdull;
      return size_t(h ^ (h >> 29));
    }
  };
  std::unordered_map<VertexKey, int32_t, VertexHash> vertex_ids;
  std::vector<double> centroid(scene.triangles.size() * 3);
  for (size_t i = 0; i < scene.triangles.size(); ++i) {
    const pf_triangle& t = scene.triangles[i];
    AreaTri& a = src[i];
    a.count = 3;
    const float* v[3] = {t.v0, t.v1, t.v2};
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k) a.v[j][k] = double(v[j][k]);
    double e1[3], e2[3], c[3];
    for (int k = 0; k < 3; ++k) {
      e1[k] = a.v[1][k] - a.v[0][k];
      e2[k] = a.v[2][k] - a.v[0][k];
      centroid[i * 3 + size_t(k)] = (a.v[0][k] + a.v[1][k] + a.v[2][k]) / 3.0;
    }
    c[0] = e1[1] * e2[2] - e1[2] * e2[1];
    c[1] = e1[2] * e2[0] - e1[0] * e2[2];
    c[2] = e1[0] * e2[1] - e1[1] * e2[0];
    const double twice = std::sqrt(dot3(c, c)), len1 = std::sqrt(dot3(e1, e1));
    if (!(twice > 0.0) || !(len1 > 0.0) || t.mesh < 0) continue;  // degenerate: no area
    a.area = 0.5 * twice;
    double e3[3];
    for (int k = 0; k < 3; ++k) {
      a.m[k] = c[k] / twice;
      a.u[k] = e1[k] / len1;
      e3[k] = a.v[2][k] - a.v[1][k];
    }
    a.edge = std::sqrt(std::max({dot3(e1, e1), dot3(e2, e2), dot3(e3, e3)}));
    const float* vn[3] = {t.n0, t.n1, t.n2};
    for (int j = 0; j < 3; ++j) {
      VertexKey key{t.mesh, {0, 0, 0}};
      std::memcpy(key.bits, v[j], sizeof key.bits);
      const auto found = vertex_ids.emplace(key, int32_t(I.verts.size()));
      a.vid[j] = found.first->second;
      if (!found.second) continue;
      AreaVertex nv{};
      double nn[3] = {vn[j][0], vn[j][1], vn[j][2]};
      const double len = std::sqrt(dot3(nn, nn));
      const double side = dot3(nn, a.m) < 0.0 ? -1.0 : 1.0;
      for (int k = 0; k < 3; ++k) {
        nv.p[k] = a.v[j][k];
        nv.n[k] = len > 0.0 && std::isfinite(len) ? side * nn[k] / len : a.m[k];
      }
      nv.mesh = t.mesh;
      I.verts.push_back(nv);
    }
    of_mesh[size_t(t.mesh)].push_back(int32_t(i));
  }
  // Quads of triangles longer than a hundredth of the scene's diagonal (walls, boxes: beyond
  // the automatic radius's scale, eye_pass.h default_radius).
  for (auto& list : of_mesh) merge_coplanar_pairs(list, src, centroid, I.r_ref / 100.0);
  I.root.assign(of_mesh.size(), -1);
  I.tri_begin.assign(of_mesh.size() + 1, 0);
  I.tris.reserve(scene.triangles.size());
  for (size_t m = 0; m < of_mesh.size(); ++m) {
    I.tri_begin[m] = int32_t(I.tris.size());
    if (of_mesh[m].empty()) continue;
    I.root[m] = int32_t(I.nodes.size());
    I.nodes.emplace_back();
    I.build(I.root[m], of_mesh[m], 0, int(of_mesh[m].size()), src, centroid);
  }
  I.tri_begin[of_mesh.size()] = int32_t(I.tris.size());
}

SurfaceArea::~SurfaceArea() = default;

bool SurfaceArea::matches(const Scene& scene) const {
  return impl_->key_tris == scene.triangles.data() && impl_->n_tris == scene.triangles.size();
}

// σ of eq. (2): the sign of m_T0·n for the triangle T0 of `mesh` that holds x (the nearest
// plane among those whose triangle holds x's projection, within the rounding tolerance), and T0
// into *tri; 0 when none does.
int SurfaceArea::Impl::sign_at(int mesh, const double* x, const double* n, int32_t* tri) const {
  const double tol = tolerance;
  double best = INFINITY;
  int sigma = 0;
  walk(
      mesh,
      [&](const AreaNode& nd) {
        bool inside = true;
        for (int k = 0; k < 3; ++k)
          inside = inside && x[k] >= double(nd.lo[k]) - tol && x[k] <= double(nd.hi[k]) + tol;
        return inside;
      },
      [&](int32_t i) {
        const AreaTri& t = tris[size_t(i)];
        double d[3];
        for (int k = 0; k < 3; ++k) d[k] = x[k] - t.v[0][k];
        const double h = std::fabs(dot3(t.m, d));
        if (h > tol || h >= best) return;
        // x's projection inside the triangle: on the inner side of its edges, within tol.
        bool in = true;
        for (int e = 0; e < t.count && in; ++e) {
          const double* a = t.v[e];
          const double* b = t.v[(e + 1) % t.count];
          const double ed[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
          const double xa[3] = {x[0] - a[0], x[1] - a[1], x[2] - a[2]};
          // (ed × xa)·m >= −tol·|ed|
          const double cx = ed[1] * xa[2] - ed[2] * xa[1];
          const double cy = ed[2] * xa[0] - ed[0] * xa[2];
          const double cz = ed[0] * xa[1] - ed[1] * xa[0];
          in = cx * t.m[0] + cy * t.m[1] + cz * t.m[2] >= -tol * std::sqrt(dot3(ed, ed));
        }
        if (!in) return;
        best = h;
        sigma = dot3(t.m, n) >= 0.0 ? 1 : -1;
        *tri = i;
      });
  return sigma;
}

// |T ∩ B(x, r) ∩ S|, S the slab |n·(y − x)| <= kr (kr < 0: no slab).
double SurfaceArea::Impl::clipped(const AreaTri& t, const double* x, const double* n, double r,
                                  double kr) const {
  // The corners against the ball and the slab (both convex): the whole polygon when all of them
  // lie in both.
  const double r2 = r * r, reach = r + t.edge;
  double g[4];  // n·(v_j − x): the corners' heights over x's tangent plane
  bool in_ball = true, in_slab = true, far = false;
  for (int j = 0; j < t.count; ++j) {
    const double q[3] = {t.v[j][0] - x[0], t.v[j][1] - x[1], t.v[j][2] - x[2]};
    const double d2 = dot3(q, q);
    g[j] = dot3(q, n);
    in_ball = in_ball && d2 <= r2;
    in_slab = in_slab && (kr < 0.0 || std::fabs(g[j]) <= kr);
    far = far || d2 > reach * reach;
  }
  if (in_ball && in_slab) return t.area;
  if (t.count == 3) {
    // Every point of a triangle lies within its longest edge of each corner, so a corner farther
    // than r + edge from x leaves none of it in the ball (a fine mesh's leaves along the ball's
    // border hold such triangles).
    if (far) return 0.0;
    // In the ball, cut by the slab alone (a fine curved mesh, most of its triangles near x): the
    // share of T between the slab's planes, from the corners' heights (n·(y − x) is linear on T).
    if (in_ball) {
      if (g[0] > g[1]) std::swap(g[0], g[1]);
      if (g[1] > g[2]) std::swap(g[1], g[2]);
      if (g[0] > g[1]) std::swap(g[0], g[1]);
      return t.area * (share_below(g, kr) - share_below(g, -kr));
    }
  }
  double d[3];
  for (int k = 0; k < 3; ++k) d[k] = x[k] - t.v[0][k];
  const double h = dot3(t.m, d);  // x's height over T's plane
  if (std::fabs(h) >= r) return 0.0;
  const double rho = std::sqrt(r * r - h * h);  // the ball's disc in the plane
  double c0[3], v[3];
  for (int k = 0; k < 3; ++k) c0[k] = x[k] - h * t.m[k];  // its centre
  v[0] = t.m[1] * t.u[2] - t.m[2] * t.u[1];
  v[1] = t.m[2] * t.u[0] - t.m[0] * t.u[2];
  v[2] = t.m[0] * t.u[1] - t.m[1] * t.u[0];
  double p[2 * 8];
  for (int j = 0; j < t.count; ++j) {
    double q[3];
    for (int k = 0; k < 3; ++k) q[k] = t.v[j][k] - c0[k];
    p[2 * j] = dot3(q, t.u);
    p[2 * j + 1] = dot3(q, v);  // counter-clockwise: u × v = m
  }
  int count = t.count;
  if (kr >= 0.0) {
    // n·(y − x) over the plane: g0 + s·(n·u) + t·(n·v), g0 = n·(c0 − x) = −h·(n·m).
    const double g0 = -h * dot3(n, t.m), nu = dot3(n, t.u), nv = dot3(n, v);
    if (nu * nu + nv * nv < 1e-18) {
      if (std::fabs(g0) > kr) return 0.0;  // parallel to the tangent plane, outside the slab
    } else {
      count = clip_half_plane(p, count, nu, nv, kr - g0);
      if (count >= 3) count = clip_half_plane(p, count, -nu, -nv, kr + g0);
    }
  }
  return disc_polygon_area(p, count, rho);
}

// Eq. (1) at x (normal n, side σ) by the mesh's hierarchy: whole nodes by their sums, the
// triangles of the nodes the region's border crosses clipped.
double SurfaceArea::Impl::sum(int mesh, const double* x, const double* n, double r, double kr,
                              int sigma, bool both_sides) const {
  const double r2 = r * r;
  double A = 0.0;
  walk(
      mesh,
      [&](const AreaNode& nd) {
        // The box against the ball (nearest and farthest points) and the slab (its extent
        // along n).
        double near2 = 0.0, far2 = 0.0, centre = 0.0, extent = 0.0;
        for (int k = 0; k < 3; ++k) {
          const double lo = nd.lo[k], hi = nd.hi[k];
          const double gap = std::max(0.0, std::max(lo - x[k], x[k] - hi));
          near2 += gap * gap;
          const double far = std::max(std::fabs(x[k] - lo), std::fabs(hi - x[k]));
          far2 += far * far;
          centre += n[k] * (0.5 * (lo + hi) - x[k]);
          extent += std::fabs(n[k]) * 0.5 * (hi - lo);
        }
        if (near2 > r2) return false;
        if (kr >= 0.0 && (centre - extent > kr || centre + extent < -kr)) return false;
        const bool in_slab = kr < 0.0 || (centre + extent <= kr && centre - extent >= -kr);
        if (far2 <= r2 && in_slab) {  // the whole node: Σ w_T |T| by its sums (eq. 2)
          A += both_sides ? nd.area
                          : std::max(0.0, 0.5 * (nd.area + double(sigma) * dot3(nd.an, n)));
          return false;
        }
        return true;
      },
      [&](int32_t i) {
        const AreaTri& t = tris[size_t(i)];
        const double w = weight(t, n, sigma, both_sides);
        if (w > 0.0) A += w * clipped(t, x, n, r, kr);
      });
  return A;
}

// The cache of slab value `slab` (its slots, one per vertex), claimed on first use; nullptr
// when kCaches other slabs hold them all.
std::atomic<uint64_t>* SurfaceArea::Impl::cache_for(float slab) const {
  uint32_t bits;
  std::memcpy(&bits, &slab, 4);
  for (Cache& c : caches) {
    if (!c.claimed.load(std::memory_order_acquire)) {
      bool expected = false;
      if (c.claimed.compare_exchange_strong(expected, true, std::memory_order_acq_rel)) {
        // Two slots per vertex, for even and odd levels: a query reads two adjacent ones.
        const size_t n = 2 * std::max<size_t>(verts.size(), 1);
        auto slots = std::make_unique<std::atomic<uint64_t>[]>(n);
        for (size_t i = 0; i < n; ++i) slots[i].store(0, std::memory_order_relaxed);
        c.slots = std::move(slots);
        c.slab.store(bits, std::memory_order_relaxed);
        c.ready.store(true, std::memory_order_release);
      }
    }
    while (!c.ready.load(std::memory_order_acquire)) {
    }  // another thread is filling it (once per slab per scene)
    if (c.slab.load(std::memory_order_relaxed) == bits) return c.slots.get();
  }
  return nullptr;
}

// A(p, R_L) / (π R_L²) at vertex p with its normal (a pure function of the vertex, the level,
// the slab and both_sides, rounded to float; cached).
double SurfaceArea::Impl::vertex_ratio(int32_t vertex, int level, float slab,
                                       bool both_sides) const {
  const uint32_t key =
      0x80000000u | (both_sides ? 0x10000u : 0u) | (uint32_t(level + 32768) & 0xffffu);
  std::atomic<uint64_t>* slots = cache_for(slab);
  const size_t slot = 2 * size_t(vertex) + size_t(level & 1);
  if (slots) {
    const uint64_t v = slots[slot].load(std::memory_order_relaxed);
    if (uint32_t(v >> 32) == key) {
      float f;
      const uint32_t b = uint32_t(v);
      std::memcpy(&f, &b, 4);
      return double(f);
    }
  }
  const AreaVertex& p = verts[size_t(vertex)];
  const double rl = r_ref * std::exp2(-double(level) / kLevelsPerOctave);
  const double a = sum(p.mesh, p.p, p.n, rl, slab_reach(slab, rl), 1, both_sides);
  const float f = float(a / (kPiD * rl * rl));
  if (slots) {
    uint32_t b;
    std::memcpy(&b, &f, 4);
    slots[slot].store((uint64_t(key) << 32) | b, std::memory_order_relaxed);
  }
  return double(f);
}

bool SurfaceArea::Impl::locate(const pf_hitpoint& site, float radius, bool both_sides,
                               Site& at) const {
  const int mesh = site.mesh;
  if (mesh < 0 || size_t(mesh) >= root.size() || root[size_t(mesh)] < 0 || !(radius > 0.f))
    return false;
  for (int k = 0; k < 3; ++k) {
    at.x[k] = site.position[k];
    at.n[k] = site.normal[k];
  }
  at.tri = -1;
  at.sigma = sign_at(mesh, at.x, at.n, &at.tri);
  if (at.sigma == 0) return false;
  if (both_sides) at.sigma = 1;
  return true;
}

double SurfaceArea::area(const pf_hitpoint& site, float radius, float slab,
                         bool both_sides) const {
  const Impl& I = *impl_;
  Impl::Site at;
  if (!I.locate(site, radius, both_sides, at)) return 0.0;
  const double* x = at.x;
  const double r = radius;
  // A triangle small against R: its corners' ratios at the two radius levels around R,
  // interpolated linearly in log R and then at x.
  const double l = -kLevelsPerOctave * std::log2(r / I.r_ref);  // R = R_l
  const AreaTri& t = I.tris[size_t(at.tri)];
  if (t.count == 3 && t.edge <= kSmallEdge * r && l > -32768.0 && l < 32766.0) {
    const int L = int(std::floor(l));  // R_{L+1} < R <= R_L
    const double u = l - double(L);
    // x's barycentric weights in T0 (clamped: x may lie a rounding error outside).
    double e1[3], e2[3], q[3];
    for (int k = 0; k < 3; ++k) {
      e1[k] = t.v[1][k] - t.v[0][k];
      e2[k] = t.v[2][k] - t.v[0][k];
      q[k] = x[k] - t.v[0][k];
    }
    const double d11 = dot3(e1, e1), d12 = dot3(e1, e2), d22 = dot3(e2, e2);
    const double q1 = dot3(q, e1), q2 = dot3(q, e2), det = d11 * d22 - d12 * d12;
    double b[3];
    b[1] = std::clamp((d22 * q1 - d12 * q2) / det, 0.0, 1.0);
    b[2] = std::clamp((d11 * q2 - d12 * q1) / det, 0.0, 1.0);
    if (b[1] + b[2] > 1.0) {
      const double s12 = b[1] + b[2];
      b[1] /= s12;
      b[2] /= s12;
    }
    b[0] = 1.0 - b[1] - b[2];
    double ratio = 0.0;
    for (int j = 0; j < 3; ++j)
      ratio += b[j] * ((1.0 - u) * I.vertex_ratio(t.vid[j], L, slab, both_sides) +
                       u * I.vertex_ratio(t.vid[j], L + 1, slab, both_sides));
    return ratio * kPiD * r * r;
  }
  return I.sum(site.mesh, x, at.n, r, slab_reach(slab, r), at.sigma, both_sides);
}

double SurfaceArea::area_at(const pf_hitpoint& site, float radius, float slab,
                            bool both_sides) const {
  const Impl& I = *impl_;
  Impl::Site at;
  if (!I.locate(site, radius, both_sides, at)) return 0.0;
  return I.sum(site.mesh, at.x, at.n, radius, slab_reach(slab, radius), at.sigma, both_sides);
}

double SurfaceArea::area_brute(const pf_hitpoint& site, float radius, float slab,
                               bool both_sides) const {
  const Impl& I = *impl_;
  Impl::Site at;
  if (!I.locate(site, radius, both_sides, at)) return 0.0;
  const int mesh = site.mesh;
  const double kr = slab_reach(slab, radius);
  double A = 0.0;
  for (int32_t i = I.tri_begin[size_t(mesh)]; i < I.tri_begin[size_t(mesh) + 1]; ++i)
    A += I.weight(I.tris[size_t(i)], at.n, at.sigma, both_sides) *
         I.clipped(I.tris[size_t(i)], at.x, at.n, double(radius), kr);
  return A;
}

double SurfaceArea::scale(const pf_hitpoint& site, float radius, float slab,
                          bool both_sides) const {
  const double a = area(site, radius, slab, both_sides);
  if (!(a > 0.0)) return 1.0;
  const double disc = kPiD * double(radius) * double(radius);
  return std::min(disc / a, kMaxScale);
}

const SurfaceArea& surface_area(const Scene& s) {
  return s.gather_area_cache.get<SurfaceArea>(
      s, [&] { return std::make_shared<const SurfaceArea>(s); });
}

}  // namespace pf
