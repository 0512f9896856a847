// kdtree.cpp — SAH kd-tree build with split clipping, parallel deterministic assembly, and ropes.
//
// References: thesis ch. 4.3 and eq. 4.8 (SAH); I. Wald, V. Havran, "On building fast kd-trees
// for ray tracing, and on doing that in O(N log N)", 2006 (event sweep, planar triangles,
// split clipping); S. Popov et al., "Stackless kd-tree traversal for high performance GPU ray
// tracing", 2007 (ropes and their optimisation).
#include "photonflow/geometry/kdtree.h"
#include "photonflow/foundations/threads.h"

#include <omp.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <string>

namespace pf {

namespace {

// An axis-aligned box as plain arrays (indexing by axis in the inner loops).
struct Box {
  float lo[3];
  float hi[3];
};

float box_area(const Box& b) {
  const float ex = b.hi[0] - b.lo[0], ey = b.hi[1] - b.lo[1], ez = b.hi[2] - b.lo[2];
  return 2.f * (ex * ey + ey * ez + ez * ex);
}

// A triangle reference inside a node: the triangle and the bounds of its part inside the node.
struct Ref {
  int32_t tri;
  Box box;
};

// Side of a split plane a reference goes to.
enum Side : uint8_t { kLeft = 0, kRight = 1, kBoth = 2 };

// A candidate split: plane axis·x = pos, its SAH cost, and where triangles lying in the plane go.
struct Split {
  int axis = -1;
  float pos = 0.f;
  float cost = INFINITY;
  Side planar = kBoth;
};

// Sweep event of the exact SAH (Wald & Havran 2006, sec. 4): a triangle's clipped bounds start,
// end, or (flat on this axis) lie at `pos`. key = reference index << 2 | type; at equal position
// ends sort before planars before starts, which the sweep relies on.
struct Event {
  float pos;
  uint32_t key;
};
enum EventType : uint32_t { kEnd = 0, kPlanar = 1, kStart = 2 };
inline uint32_t ev_type(const Event& e) { return e.key & 3u; }
inline uint32_t ev_ref(const Event& e) { return e.key >> 2; }
inline bool operator<(const Event& a, const Event& b) {
  return a.pos < b.pos || (a.pos == b.pos && ev_type(a) < ev_type(b));
}

// Node contents during the exact phase: references and, per axis, their events in sorted order.
struct EventNode {
  std::vector<Ref> refs;
  std::array<std::vector<Event>, 3> ev;
};

// Appends the events of reference `index` (bounds b) to per-axis lists.
void add_events(const Box& b, uint32_t index, std::array<std::vector<Event>, 3>& ev) {
  for (int k = 0; k < 3; ++k) {
    if (b.lo[k] == b.hi[k]) {
      ev[k].push_back({b.lo[k], index << 2 | kPlanar});
    } else {
      ev[k].push_back({b.lo[k], index << 2 | kStart});
      ev[k].push_back({b.hi[k], index << 2 | kEnd});
    }
  }
}

float round_down(double x) {
  float f = float(x);
  return double(f) > x ? std::nextafter(f, -INFINITY) : f;
}
float round_up(double x) {
  float f = float(x);
  return double(f) < x ? std::nextafter(f, INFINITY) : f;
}

// Split clipping: bounds of the part of triangle t inside `box` (Sutherland–Hodgman against the
// six planes, in double), rounded outward and intersected with the box. Returns false when
// nothing of the triangle remains.
bool clip_triangle_bounds(const pf_triangle& t, const Box& box, Box& out) {
  double poly[9][3], next[9][3];
  int n = 3;
  for (int k = 0; k < 3; ++k) {
    poly[0][k] = t.v0[k];
    poly[1][k] = t.v1[k];
    poly[2][k] = t.v2[k];
  }
  for (int plane = 0; plane < 6 && n > 0; ++plane) {
    const int k = plane >> 1;
    const bool high = plane & 1;
    const double c = high ? box.hi[k] : box.lo[k];
    int m = 0;
    for (int i = 0; i < n; ++i) {
      const double* a = poly[i];
      const double* b = poly[(i + 1) % n];
      const double da = high ? c - a[k] : a[k] - c;  // >= 0: inside
      const double db = high ? c - b[k] : b[k] - c;
      if (da >= 0) std::copy(a, a + 3, next[m++]);
      if ((da >= 0) != (db >= 0)) {
        const double s = da / (da - db);
        for (int j = 0; j < 3; ++j) next[m][j] = a[j] + s * (b[j] - a[j]);
        next[m++][k] = c;
      }
    }
    n = m;
    std::copy(&next[0][0], &next[0][0] + 3 * m, &poly[0][0]);
  }
  if (n == 0) return false;
  for (int k = 0; k < 3; ++k) {
    double lo = poly[0][k], hi = poly[0][k];
    for (int i = 1; i < n; ++i) {
      lo = std::min(lo, poly[i][k]);
      hi = std::max(hi, poly[i][k]);
    }
    out.lo[k] = std::max(round_down(lo), box.lo[k]);
    out.hi[k] = std::min(round_up(hi), box.hi[k]);
    if (out.lo[k] > out.hi[k]) return false;
  }
  return true;
}

// Output of one (sub)tree build: nodes in preorder with local indices, and its leaf list.
struct Piece {
  std::vector<pf_kd_node> nodes;
  std::vector<int32_t> leaf_tris;
  int depth = 0;
};

// Appends `src` to `dst`, shifting its node and leaf-list indices.
void splice(Piece& dst, const Piece& src) {
  const int32_t node_off = int32_t(dst.nodes.size());
  const int32_t leaf_off = int32_t(dst.leaf_tris.size());
  for (pf_kd_node n : src.nodes) {
    if (n.axis == PF_KD_LEAF) {
      n.first += leaf_off;
    } else {
      n.left += node_off;
      n.right += node_off;
    }
    dst.nodes.push_back(n);
  }
  dst.leaf_tris.insert(dst.leaf_tris.end(), src.leaf_tris.begin(), src.leaf_tris.end());
  dst.depth = std::max(dst.depth, src.depth);
}

// Subtrees with at least this many references are built into their own Piece (as an OpenMP task)
// and spliced; the choice depends on the data only, never on the thread count.
constexpr size_t kSpliceMinRefs = 16384;

class Builder {
 public:
  Builder(const std::vector<pf_triangle>& tris, const KdBuildParams& p, int max_depth)
      : tris_(tris), p_(p), max_depth_(max_depth) {}

  // Builds the subtree of a node with box `box` and references `refs` (consumed) into `out`.
  void build_binned(Piece& out, const Box& box, std::vector<Ref>& refs, int depth) {
    const size_t n = refs.size();
    if (n < kKdExactMaxTriangles || depth >= max_depth_) {
      build_exact_from_refs(out, box, refs, depth);
      return;
    }
    const Split s = find_split_binned(box, refs);
    if (s.axis < 0 || s.cost >= p_.cost_intersect * float(n)) {
      // Binning found nothing worth it; the exact sweep decides between a split and a leaf.
      build_exact_from_refs(out, box, refs, depth);
      return;
    }
    Box lbox = box, rbox = box;
    lbox.hi[s.axis] = s.pos;
    rbox.lo[s.axis] = s.pos;
    std::vector<Ref> lrefs, rrefs;
    partition(refs, s, lbox, rbox, lrefs, rrefs);
    std::vector<Ref>().swap(refs);

    const int32_t idx = emit_inner(out, box, s, depth);
    if (n >= kSpliceMinRefs) {
      Piece lp, rp;
#pragma omp task default(shared)
      build_binned(lp, lbox, lrefs, depth + 1);
      build_binned(rp, rbox, rrefs, depth + 1);
#pragma omp taskwait
      splice(out, lp);
      out.nodes[idx].right = int32_t(out.nodes.size());
      splice(out, rp);
    } else {
      build_binned(out, lbox, lrefs, depth + 1);
      out.nodes[idx].right = int32_t(out.nodes.size());
      build_binned(out, rbox, rrefs, depth + 1);
    }
  }

 private:
  // SAH cost of eq. 4.8, C_ts + C_i·(A_L/A·N_L + A_R/A·N_R), reduced by the empty-space bonus
  // when one side holds no triangles.
  float sah(const Box& box, int axis, float pos, size_t nl, size_t nr, float inv_area) const {
    Box l = box, r = box;
    l.hi[axis] = pos;
    r.lo[axis] = pos;
    float cost = p_.cost_traversal + p_.cost_intersect * inv_area *
                                         (box_area(l) * float(nl) + box_area(r) * float(nr));
    if (nl == 0 || nr == 0) cost *= 1.f - p_.empty_bonus;
    return cost;
  }

  // Binned SAH over kKdBins planes per axis. A reference counts on the left of a plane when its
  // lower bound lies in a bin below the plane, on the right when its upper bound does not.
  Split find_split_binned(const Box& box, const std::vector<Ref>& refs) const {
    const float area = box_area(box);
    Split best;
    if (!(area > 0.f)) return best;
    const float inv_area = 1.f / area;
    std::array<std::array<uint32_t, kKdBins>, 3> starts{}, ends{};
    float scale[3];
    for (int k = 0; k < 3; ++k) {
      const float ext = box.hi[k] - box.lo[k];
      scale[k] = ext > 0.f ? float(kKdBins) / ext : 0.f;
    }
    auto bin = [&](float x, int k) {
      const int b = int((x - box.lo[k]) * scale[k]);
      return std::min(std::max(b, 0), kKdBins - 1);
    };
    for (const Ref& r : refs) {
      for (int k = 0; k < 3; ++k) {
        ++starts[k][bin(r.box.lo[k], k)];
        ++ends[k][bin(r.box.hi[k], k)];
      }
    }
    const size_t n = refs.size();
    for (int k = 0; k < 3; ++k) {
      if (scale[k] == 0.f) continue;
      const float ext = box.hi[k] - box.lo[k];
      size_t nl = 0, ended = 0;
      for (int i = 1; i < kKdBins; ++i) {
        nl += starts[k][i - 1];
        ended += ends[k][i - 1];
        const float pos = box.lo[k] + ext * float(i) / float(kKdBins);
        if (!(pos > box.lo[k] && pos < box.hi[k])) continue;
        const float c = sah(box, k, pos, nl, n - ended, inv_area);
        if (c < best.cost) best = {k, pos, c, kBoth};
      }
    }
    return best;
  }

  // Exact SAH by one sweep per axis over the sorted events (Wald & Havran 2006, alg. 4). Triangles
  // lying in a candidate plane are tried on either side and the cheaper placement is kept.
  Split find_split_exact(const Box& box, const EventNode& node) const {
    const float area = box_area(box);
    Split best;
    if (!(area > 0.f)) return best;
    const float inv_area = 1.f / area;
    const size_t n = node.refs.size();
    for (int k = 0; k < 3; ++k) {
      if (!(box.hi[k] > box.lo[k])) continue;
      const std::vector<Event>& ev = node.ev[k];
      size_t nl = 0, nr = n;
      for (size_t i = 0; i < ev.size();) {
        const float pos = ev[i].pos;
        size_t n_end = 0, n_planar = 0, n_start = 0;
        while (i < ev.size() && ev[i].pos == pos && ev_type(ev[i]) == kEnd) ++n_end, ++i;
        while (i < ev.size() && ev[i].pos == pos && ev_type(ev[i]) == kPlanar) ++n_planar, ++i;
        while (i < ev.size() && ev[i].pos == pos && ev_type(ev[i]) == kStart) ++n_start, ++i;
        // References touching the plane from one side stay on that side (see classify).
        const size_t left = nl, right = nr - n_planar - n_end;
        if (pos > box.lo[k] && pos < box.hi[k]) {
          const float cl = sah(box, k, pos, left + n_planar, right, inv_area);
          const float cr = sah(box, k, pos, left, right + n_planar, inv_area);
          if (cl < best.cost) best = {k, pos, cl, kLeft};
          if (cr < best.cost) best = {k, pos, cr, kRight};
        }
        nr -= n_planar + n_end;
        nl += n_start + n_planar;
      }
    }
    return best;
  }

  // Side of split s for a reference with bounds b. A reference that only touches the plane (a
  // vertex or an edge on it) stays on its own side: the Havel–Herout test accepts hits anywhere
  // along the ray, and both traversals visit the leaves on either side of a plane that the ray
  // crosses exactly at a corner or edge of the leaf arrangement (the stack traversal visits
  // zero-length intervals; the rope descent goes to the side the ray comes from on a tie, see
  // pf_kd_traverse_ropes), so a ray through a vertex on a split plane still meets the leaf that
  // holds the vertex's triangles. (Keeping touching references on both sides instead doubled
  // the triangle tests per ray on meshes whose vertices lie on split planes.)
  static Side classify(const Box& b, const Split& s) {
    const float lo = b.lo[s.axis], hi = b.hi[s.axis];
    if (lo == s.pos && hi == s.pos) return s.planar;
    if (hi <= s.pos) return kLeft;
    if (lo >= s.pos) return kRight;
    return kBoth;
  }

  // Bounds of reference r inside child box `child` (r straddles the plane).
  bool clip_ref(const Ref& r, const Box& child, Box& out) const {
    if (clip_triangle_bounds(tris_[size_t(r.tri)], child, out)) return true;
    // The polygon vanished in rounding: keep the (conservative) box overlap instead.
    for (int k = 0; k < 3; ++k) {
      out.lo[k] = std::max(r.box.lo[k], child.lo[k]);
      out.hi[k] = std::min(r.box.hi[k], child.hi[k]);
    }
    return true;
  }

  void partition(const std::vector<Ref>& refs, const Split& s, const Box& lbox, const Box& rbox,
                 std::vector<Ref>& lrefs, std::vector<Ref>& rrefs) const {
    for (const Ref& r : refs) {
      const Side side = classify(r.box, s);
      if (side == kLeft) {
        lrefs.push_back(r);
      } else if (side == kRight) {
        rrefs.push_back(r);
      } else {
        Ref c{r.tri, {}};
        if (clip_ref(r, lbox, c.box)) lrefs.push_back(c);
        if (clip_ref(r, rbox, c.box)) rrefs.push_back(c);
      }
    }
  }

  // Enters the exact phase: generates and sorts the events of `refs` (consumed), then recurses.
  void build_exact_from_refs(Piece& out, const Box& box, std::vector<Ref>& refs, int depth) {
    EventNode node;
    node.refs.swap(refs);
    add_all_events(node.refs, 0, node.ev);
    build_exact(out, box, node, depth);
  }

  void build_exact(Piece& out, const Box& box, EventNode& node, int depth) {
    const size_t n = node.refs.size();
    Split s;
    if (n > size_t(p_.max_leaf_size) && depth < max_depth_) s = find_split_exact(box, node);
    if (s.axis < 0 || s.cost >= p_.cost_intersect * float(n)) {
      emit_leaf(out, box, node.refs, depth);
      return;
    }
    Box lbox = box, rbox = box;
    lbox.hi[s.axis] = s.pos;
    rbox.lo[s.axis] = s.pos;
    EventNode left, right;
    split_events(node, s, lbox, rbox, left, right);
    node = EventNode();

    const int32_t idx = emit_inner(out, box, s, depth);
    build_exact(out, lbox, left, depth + 1);
    out.nodes[idx].right = int32_t(out.nodes.size());
    build_exact(out, rbox, right, depth + 1);
  }

  // Distributes a node's references and sorted events to its children in O(N + K log K), K the
  // number of straddling references (Wald & Havran 2006, sec. 5.2): events of one-sided
  // references are filtered in order; straddling references are clipped, their new events sorted
  // and merged in.
  void split_events(const EventNode& node, const Split& s, const Box& lbox, const Box& rbox,
                    EventNode& left, EventNode& right) const {
    const size_t n = node.refs.size();
    std::vector<uint32_t> remap(n);  // index in the child of a one-sided reference
    std::vector<Side> side(n);
    for (size_t i = 0; i < n; ++i) {
      side[i] = classify(node.refs[i].box, s);
      if (side[i] == kLeft) {
        remap[i] = uint32_t(left.refs.size());
        left.refs.push_back(node.refs[i]);
      } else if (side[i] == kRight) {
        remap[i] = uint32_t(right.refs.size());
        right.refs.push_back(node.refs[i]);
      }
    }
    const size_t l_one = left.refs.size(), r_one = right.refs.size();
    for (size_t i = 0; i < n; ++i) {
      if (side[i] != kBoth) continue;
      const Ref& r = node.refs[i];
      Ref c{r.tri, {}};
      if (clip_ref(r, lbox, c.box)) left.refs.push_back(c);
      if (clip_ref(r, rbox, c.box)) right.refs.push_back(c);
    }
    std::array<std::vector<Event>, 3> lnew, rnew;
    add_all_events(left.refs, l_one, lnew);
    add_all_events(right.refs, r_one, rnew);
    for (int k = 0; k < 3; ++k) {
      // Events of one-sided references keep their order; count them first to size the lists.
      size_t nl = 0, nr = 0;
      for (const Event& e : node.ev[k]) {
        const Side sd = side[ev_ref(e)];
        nl += sd == kLeft;
        nr += sd == kRight;
      }
      std::vector<Event>& lev = left.ev[k];
      std::vector<Event>& rev = right.ev[k];
      lev.resize(nl + lnew[k].size());
      rev.resize(nr + rnew[k].size());
      Event* lo = lev.data() + lnew[k].size();  // filtered events go behind room for the merge
      Event* ro = rev.data() + rnew[k].size();
      for (const Event& e : node.ev[k]) {
        const uint32_t i = ev_ref(e);
        const Event moved{e.pos, remap[i] << 2 | ev_type(e)};
        if (side[i] == kLeft) *lo++ = moved;
        else if (side[i] == kRight) *ro++ = moved;
      }
      merge_in(lnew[k], lev);
      merge_in(rnew[k], rev);
    }
  }

  // Events of refs[first..] appended to per-axis lists, each list sorted.
  static void add_all_events(const std::vector<Ref>& refs, size_t first,
                             std::array<std::vector<Event>, 3>& ev) {
    for (auto& e : ev) e.reserve(2 * (refs.size() - first));
    for (size_t i = first; i < refs.size(); ++i) add_events(refs[i].box, uint32_t(i), ev);
    for (auto& e : ev) std::sort(e.begin(), e.end());
  }

  // `dst` holds |fresh| unused slots followed by a sorted run; merges the sorted `fresh` in, front
  // to back (the write position never overtakes the unread part of the run, and once `fresh` is
  // used up the rest of the run is already in place).
  static void merge_in(const std::vector<Event>& fresh, std::vector<Event>& dst) {
    size_t w = 0, a = fresh.size(), b = 0;
    while (b < fresh.size()) {
      if (a < dst.size() && !(fresh[b] < dst[a])) dst[w++] = dst[a++];
      else dst[w++] = fresh[b++];
    }
  }

  static pf_kd_node make_node(const Box& box) {
    pf_kd_node nd{};
    for (int k = 0; k < 3; ++k) {
      nd.lo[k] = box.lo[k];
      nd.hi[k] = box.hi[k];
    }
    for (int& r : nd.ropes) r = -1;
    return nd;
  }

  // Appends an inner node; its left child is the next node, `right` is set by the caller.
  static int32_t emit_inner(Piece& out, const Box& box, const Split& s, int depth) {
    pf_kd_node nd = make_node(box);
    nd.axis = s.axis;
    nd.split = s.pos;
    const int32_t idx = int32_t(out.nodes.size());
    nd.left = idx + 1;
    out.nodes.push_back(nd);
    out.depth = std::max(out.depth, depth);
    return idx;
  }

  static void emit_leaf(Piece& out, const Box& box, const std::vector<Ref>& refs, int depth) {
    pf_kd_node nd = make_node(box);
    nd.axis = PF_KD_LEAF;
    nd.first = int32_t(out.leaf_tris.size());
    nd.count = int32_t(refs.size());
    nd.left = nd.right = -1;
    for (const Ref& r : refs) out.leaf_tris.push_back(r.tri);
    out.nodes.push_back(nd);
    out.depth = std::max(out.depth, depth);
  }

  const std::vector<pf_triangle>& tris_;
  const KdBuildParams& p_;
  const int max_depth_;
};

// Popov et al. 2007, sec. 4.1: a rope may point deeper than the neighbour of the parent's face —
// down to the deepest node that still covers the whole face of `box`.
int32_t optimize_rope(const std::vector<pf_kd_node>& nodes, int32_t rope, int face,
                      const pf_kd_node& box) {
  const int a = face >> 1;
  const bool high = face & 1;
  while (rope >= 0 && nodes[size_t(rope)].axis != PF_KD_LEAF) {
    const pf_kd_node& r = nodes[size_t(rope)];
    const int b = r.axis;
    if (b == a) {
      rope = high ? r.left : r.right;  // the child that touches the face
    } else if (box.hi[b] <= r.split) {
      rope = r.left;  // the face lies wholly below the split
    } else if (box.lo[b] >= r.split) {
      rope = r.right;  // ... or wholly above
    } else {
      break;
    }
  }
  return rope;
}

// Ropes of every node, top-down (preorder puts parents first): a child inherits its parent's
// ropes, its face towards the sibling points at the sibling, and each rope is then optimised.
void build_ropes(std::vector<pf_kd_node>& nodes) {
  for (size_t i = 0; i < nodes.size(); ++i) {
    const pf_kd_node& n = nodes[i];
    if (n.axis == PF_KD_LEAF) continue;
    const int a = n.axis;
    pf_kd_node& l = nodes[size_t(n.left)];
    pf_kd_node& r = nodes[size_t(n.right)];
    for (int f = 0; f < 6; ++f) l.ropes[f] = r.ropes[f] = n.ropes[f];
    l.ropes[2 * a + 1] = n.right;
    r.ropes[2 * a] = n.left;
    for (int f = 0; f < 6; ++f) {
      l.ropes[f] = optimize_rope(nodes, l.ropes[f], f, l);
      r.ropes[f] = optimize_rope(nodes, r.ropes[f], f, r);
    }
  }
}

int auto_max_depth(size_t n, int requested) {
  int d = requested > 0 ? requested
                        : int(8.0 + 1.3 * std::log2(double(std::max<size_t>(n, 1))) + 0.5);
  return std::min(d, kKdMaxDepth);
}

}  // namespace

KdTree build_kdtree(const std::vector<pf_triangle>& tris, const KdBuildParams& params) {
  const auto t0 = std::chrono::steady_clock::now();
  KdTree tree;
  tree.params = params;

  std::vector<Ref> refs(tris.size());
  Box root{{INFINITY, INFINITY, INFINITY}, {-INFINITY, -INFINITY, -INFINITY}};
  for (size_t i = 0; i < tris.size(); ++i) {
    const pf_triangle& t = tris[i];
    Ref& r = refs[i];
    r.tri = int32_t(i);
    for (int k = 0; k < 3; ++k) {
      r.box.lo[k] = std::min({t.v0[k], t.v1[k], t.v2[k]});
      r.box.hi[k] = std::max({t.v0[k], t.v1[k], t.v2[k]});
      root.lo[k] = std::min(root.lo[k], r.box.lo[k]);
      root.hi[k] = std::max(root.hi[k], r.box.hi[k]);
    }
  }
  if (tris.empty()) root = Box{{0, 0, 0}, {0, 0, 0}};
  tree.bounds = Bounds{Vec3(root.lo), Vec3(root.hi)};

  Piece piece;
  Builder builder(tris, params, auto_max_depth(tris.size(), params.max_depth));
  const int threads = worker_threads(params.threads);
#pragma omp parallel num_threads(threads)
#pragma omp single
  builder.build_binned(piece, root, refs, 0);

  tree.nodes = std::move(piece.nodes);
  tree.leaf_tris = std::move(piece.leaf_tris);
  tree.depth = piece.depth;
  build_ropes(tree.nodes);
  tree.build_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return tree;
}

std::string validate_kdtree(const KdTree& tree, size_t triangle_count) {
  const auto& nodes = tree.nodes;
  const size_t n = nodes.size();
  if (n == 0) return "kd-tree has no nodes";
  auto at = [](size_t i, const std::string& what) {
    return "kd node " + std::to_string(i) + ": " + what;
  };
  std::vector<uint8_t> parents(n, 0);
  for (size_t i = 0; i < n; ++i) {
    const pf_kd_node& nd = nodes[i];
    for (int k = 0; k < 3; ++k)
      if (!(nd.lo[k] <= nd.hi[k])) return at(i, "box is empty or not finite");
    if (nd.axis == PF_KD_LEAF) {
      if (nd.first < 0 || nd.count < 0 ||
          size_t(nd.first) + size_t(nd.count) > tree.leaf_tris.size())
        return at(i, "leaf range outside leaf_tris");
      for (int32_t j = nd.first; j < nd.first + nd.count; ++j) {
        const int32_t t = tree.leaf_tris[size_t(j)];
        if (t < 0 || size_t(t) >= triangle_count) return at(i, "triangle index out of range");
      }
    } else if (nd.axis >= 0 && nd.axis < 3) {
      const int a = nd.axis;
      if (!(nd.split > nd.lo[a] && nd.split < nd.hi[a])) return at(i, "split outside its box");
      for (int32_t c : {nd.left, nd.right}) {
        if (c <= int32_t(i) || size_t(c) >= n) return at(i, "child index out of range");
        if (++parents[size_t(c)] > 1) return at(size_t(c), "node has two parents");
      }
      const pf_kd_node& l = nodes[size_t(nd.left)];
      const pf_kd_node& r = nodes[size_t(nd.right)];
      for (int k = 0; k < 3; ++k) {
        const float lhi = k == a ? nd.split : nd.hi[k];
        const float rlo = k == a ? nd.split : nd.lo[k];
        if (l.lo[k] != nd.lo[k] || l.hi[k] != lhi || r.lo[k] != rlo || r.hi[k] != nd.hi[k])
          return at(i, "children's boxes are not the halves of the node's box");
      }
    } else {
      return at(i, "bad axis " + std::to_string(nd.axis));
    }
    for (int f = 0; f < 6; ++f) {
      const int a = f >> 1;
      const bool high = f & 1;
      const float face = high ? nd.hi[a] : nd.lo[a];
      const int32_t rope = nd.ropes[f];
      if (rope < 0) {
        if (face != (high ? nodes[0].hi[a] : nodes[0].lo[a]))
          return at(i, "rope " + std::to_string(f) + " is −1 inside the scene box");
        continue;
      }
      if (size_t(rope) >= n) return at(i, "rope " + std::to_string(f) + " out of range");
      const pf_kd_node& r = nodes[size_t(rope)];
      bool covers = (high ? r.lo[a] : r.hi[a]) == face;
      for (int k = 0; k < 3; ++k)
        if (k != a) covers = covers && r.lo[k] <= nd.lo[k] && r.hi[k] >= nd.hi[k];
      if (!covers) return at(i, "rope " + std::to_string(f) + " target does not cover the face");
    }
  }
  for (size_t i = 1; i < n; ++i)
    if (parents[i] != 1) return at(i, "node is not reached from the root");
  return "";
}

}  // namespace pf
