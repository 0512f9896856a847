// raycast.h — ray casting over a baked scene: closest hit and any hit (shadow rays), single rays
// and multithreaded batches, with three traversals:
//   Ropes — stackless kd-tree traversal along ropes (Popov et al. 2007): the shared C routine of
//           intersect_shared.h, the code the GPU kernels run;
//   Stack — classic kd-tree traversal with an explicit stack over a host-only compact copy of the
//           tree (8-byte nodes, triangle planes in leaf order, four triangles per SSE test or
//           eight per AVX test where the CPU has it: set_kd_leaf_avx), built
//           on first use; the default on the CPU, 1.1–1.7× faster: it returns the same triangle,
//           t and barycentrics as Ropes bit for bit on rays in general position (tested on random
//           rays). A ray aimed exactly at a shared vertex or edge, where several triangles are hit
//           at one point, may get another of them from either traversal than the lowest index,
//           with a t that differs in the last bits: a triangle that merely touches a leaf is not
//           listed in it, and a walk through a leaf corner does not visit the diagonal leaf. Seen
//           on some of the vertex and edge rays of raycast_test's procedural meshes and on
//           251 of 2,048 rays at the vertices of a flat grid; those tests require only a hit;
//   Brute — every triangle (the reference).
// A secondary ray knows where its walk can start: its origin lies in the leaf where the ray
// before it found its hit (Hit::leaf, passed on as Ray::leaf by spawn_ray, surface.h; the camera
// rays get the eye point's leaf, photons their light's: RayCaster::leaf_at). The default
// traversal then walks the ropes from that leaf (pf_kd_traverse_ropes_compact_from) instead of
// descending from the root, about seven dependent node loads fewer per ray on a 200k-triangle
// scene, with the same hit bit for bit as the stack walk from the root (tested on bounce rays in
// three scenes), up to the degenerate kinds where Ropes and Stack may differ (above: vertex and
// edge ties); when the leaf's box does not hold the origin (a ray that crossed a surface into
// another leaf, a lens point off the eye) it walks from the root as before.
// Triangles are tested with the Havel–Herout test (thesis eq. 4.3–4.7). In a scene with alpha
// cut-outs (Scene::material_alpha, alpha_shared.h) every traversal skips the hits on cut-away
// points: a ray passes through them (closest and any hit).
#pragma once
#include <cmath>
#include <cstdint>
#include <vector>

#include "photonflow/geometry/scene.h"
#include "photonflow/foundations/vec.h"

namespace pf {

struct Ray {
  Vec3 o;
  Vec3 d;  // need not be unit length; t is measured in units of |d|
  float tmin = 0.f;
  float tmax = INFINITY;
  // A kd leaf the origin lies in, if known (−1: none): the Hit::leaf of the hit the ray leaves
  // from. The default traversal then starts the walk there along the ropes instead of descending
  // from the root; a leaf whose box does not hold o is ignored. It changes no result, only the
  // time to find it.
  int32_t leaf = -1;
};

struct Hit {
  float t = INFINITY;
  int32_t tri = -1;  // triangle index, −1 = no hit
  float u = 0, v = 0;  // barycentrics: P = (1−u−v)·v0 + u·v1 + v·v2
  int32_t leaf = -1;   // the kd leaf record the hit lies in (for Ray::leaf), −1 if not known
  bool hit() const { return tri >= 0; }
};

// Stack is the default: with a Ray::leaf whose box holds the origin it walks the ropes from there
// (above); Ropes always walks from the root.
enum class Traversal { Ropes, Stack, Brute };
const char* traversal_name(Traversal t);

// Closest hit with t in (tmin, tmax]. Returns hit.hit().
// The three traversals agree on every ray but one degenerate kind: a ray whose origin lies in a
// kd split plane that holds a triangle, and that leaves the plane on the side the build did not
// store the triangle on. Brute force can hit that triangle at t ≈ 0 (by rounding, a touch at the
// origin); the kd traversals start in the other child and do not see it. No ray the renderer
// casts starts that close to a surface (offset_origin moves it ray_epsilon away first).
bool intersect_closest(const Scene& scene, const Ray& ray, Hit& hit,
                       Traversal trav = Traversal::Stack);
// True if any triangle is hit with t in (tmin, tmax] (shadow rays; the same interval as
// intersect_closest, so a ray is occluded exactly when it has a closest hit).
bool intersect_any(const Scene& scene, const Ray& ray, Traversal trav = Traversal::Stack);

// Casts many rays through one scene with the default traversal (Stack), the scene's host copy
// of the kd-tree looked up once (intersect_closest and intersect_any look it up per ray): the
// renderer's tracers hold one. The same hits as intersect_closest / intersect_any with
// Traversal::Stack. The scene must outlive it and not change meanwhile.
class RayCaster {
 public:
  explicit RayCaster(const Scene& scene);
  bool closest(const Ray& ray, Hit& hit) const;
  bool any(const Ray& ray) const;
  // The kd leaf whose box holds p, as a Ray::leaf for rays leaving p (the camera's eye point, a
  // light), −1 outside the scene's box. A point on a split plane gets either side's leaf.
  int32_t leaf_at(const Vec3& p) const;

 private:
  const void* kd_;            // the scene's HostKd (raycast.cpp)
  const Scene* alpha_scene_;  // the scene when it has alpha masks (their test), else nullptr
};

// The stack traversal's leaf test takes eight triangles per AVX operation where the CPU has AVX
// (kd_leaf_avx_supported), four per SSE operation otherwise: the same hits bit for bit.
// set_kd_leaf_avx(false) keeps to SSE (tests compare the two; benchmarks time both);
// set_kd_leaf_avx(true) returns false, changing nothing, without AVX. Not for use while rays are
// being cast.
bool kd_leaf_avx_supported();
bool set_kd_leaf_avx(bool on);

// Batches over all cores (threads = 0) or the given count; results do not depend on threads.
void intersect_closest_batch(const Scene& scene, const std::vector<Ray>& rays,
                             std::vector<Hit>& hits, Traversal trav = Traversal::Stack,
                             int threads = 0);
void intersect_any_batch(const Scene& scene, const std::vector<Ray>& rays,
                         std::vector<uint8_t>& occluded, Traversal trav = Traversal::Stack,
                         int threads = 0);

}  // namespace pf
