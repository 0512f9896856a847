// raycast.cpp — closest-hit and any-hit ray casting over a baked scene (raycast.h).
//
// All three traversals test triangles with the one Havel–Herout routine of intersect_shared.h
// (thesis eq. 4.3–4.7); the rope traversal is the shared routine itself, the same code the OpenCL
// kernels compile.
#include "photonflow/raycast.h"

#include <omp.h>

#include "photonflow/intersect_shared.h"

namespace pf {

namespace {

// Brute force: every triangle, the reference for tests.
bool traverse_brute(const Scene& scene, const float* o, const float* d, float tmin, bool any_hit,
                    pf_ray_hit& hit) {
  const int32_t n = int32_t(scene.hh.size());
  for (int32_t i = 0; i < n; ++i) {
    float t, u, v;
    if (!pf_hh_intersect(&scene.hh[size_t(i)], o, d, tmin, hit.t, &t, &u, &v)) continue;
    if (t == hit.t && hit.tri >= 0) continue;  // equal t: the lower index (found first) wins
    hit = {t, i, u, v};
    if (any_hit) return true;
  }
  return hit.tri >= 0;
}

// Classic front-to-back kd traversal with an explicit stack (pbrt's KdTreeAccel): each node is
// visited with the parametric interval [t0, t1] of the ray inside it; the near child is entered
// first and the far child pushed with its interval.
bool traverse_stack(const Scene& scene, const float* o, const float* d, float tmin, bool any_hit,
                    pf_ray_hit& hit) {
  const KdTree& kd = scene.kd;
  if (kd.nodes.empty()) return false;
  const float inv_d[3] = {1.f / d[0], 1.f / d[1], 1.f / d[2]};
  float t0, t1;
  if (!pf_kd_enter_root(kd.nodes.data(), o, d, inv_d, tmin, hit.t, &t0, &t1)) return false;
  struct Todo {
    int32_t node;
    float t0, t1;
  };
  Todo stack[kKdMaxDepth + 1];
  int top = 0;
  int32_t node = 0;
  for (;;) {
    if (hit.t < t0) break;  // closest hit lies before this node (stack intervals only grow)
    const pf_kd_node& n = kd.nodes[size_t(node)];
    if (n.axis != PF_KD_LEAF) {
      const int a = n.axis;
      // The child holding the ray's origin side is near; on the plane, the side it moves into.
      const bool left_first = o[a] < n.split || (o[a] == n.split && d[a] <= 0.f);
      const int32_t near = left_first ? n.left : n.right;
      const int32_t far = left_first ? n.right : n.left;
      const float t_plane = d[a] != 0.f ? (n.split - o[a]) * inv_d[a] : INFINITY;
      if (t_plane > t1 || t_plane <= 0.f) {
        node = near;  // never reaches the plane within the node (or moves away from it)
      } else if (t_plane < t0) {
        node = far;  // crossed the plane before entering the node
      } else {
        stack[top++] = {far, t_plane, t1};
        node = near;
        t1 = t_plane;
      }
      continue;
    }
    if (pf_kd_leaf_intersect(&n, kd.leaf_tris.data(), scene.hh.data(), o, d, tmin, any_hit, &hit))
      return true;
    if (top == 0) break;
    --top;
    node = stack[top].node;
    t0 = stack[top].t0;
    t1 = stack[top].t1;
  }
  return hit.tri >= 0;
}

bool cast(const Scene& scene, const Ray& ray, bool any_hit, Traversal trav, pf_ray_hit& hit) {
  const float o[3] = {ray.o.x, ray.o.y, ray.o.z};
  const float d[3] = {ray.d.x, ray.d.y, ray.d.z};
  hit = {ray.tmax, -1, 0.f, 0.f};
  switch (trav) {
    case Traversal::Ropes:
      return pf_kd_traverse_ropes(scene.kd.nodes.data(), pf_int(scene.kd.nodes.size()),
                                  scene.kd.leaf_tris.data(), scene.hh.data(), o, d, ray.tmin,
                                  any_hit, &hit) != 0;
    case Traversal::Stack:
      return traverse_stack(scene, o, d, ray.tmin, any_hit, hit);
    case Traversal::Brute:
      return traverse_brute(scene, o, d, ray.tmin, any_hit, hit);
  }
  return false;
}

int thread_count(int threads) { return threads > 0 ? threads : omp_get_max_threads(); }

}  // namespace

const char* traversal_name(Traversal t) {
  switch (t) {
    case Traversal::Ropes: return "ropes";
    case Traversal::Stack: return "stack";
    case Traversal::Brute: return "brute";
  }
  return "?";
}

bool intersect_closest(const Scene& scene, const Ray& ray, Hit& hit, Traversal trav) {
  pf_ray_hit h;
  hit = Hit{};
  if (!cast(scene, ray, false, trav, h)) return false;
  hit.t = h.t;
  hit.tri = h.tri;
  hit.u = h.u;
  hit.v = h.v;
  return true;
}

bool intersect_any(const Scene& scene, const Ray& ray, Traversal trav) {
  pf_ray_hit h;
  return cast(scene, ray, true, trav, h);
}

void intersect_closest_batch(const Scene& scene, const std::vector<Ray>& rays,
                             std::vector<Hit>& hits, Traversal trav, int threads) {
  hits.resize(rays.size());
  const int64_t n = int64_t(rays.size());
#pragma omp parallel for schedule(dynamic, 256) num_threads(thread_count(threads))
  for (int64_t i = 0; i < n; ++i) intersect_closest(scene, rays[size_t(i)], hits[size_t(i)], trav);
}

void intersect_any_batch(const Scene& scene, const std::vector<Ray>& rays,
                         std::vector<uint8_t>& occluded, Traversal trav, int threads) {
  occluded.resize(rays.size());
  const int64_t n = int64_t(rays.size());
#pragma omp parallel for schedule(dynamic, 256) num_threads(thread_count(threads))
  for (int64_t i = 0; i < n; ++i)
    occluded[size_t(i)] = intersect_any(scene, rays[size_t(i)], trav) ? 1 : 0;
}

}  // namespace pf
