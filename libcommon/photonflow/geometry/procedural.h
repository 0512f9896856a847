// procedural.h — procedural triangle meshes for tests and benchmarks (no mesh files needed).
//
// Every generator returns world-space pf_triangle with the given mesh and material ids, wound
// counter-clockwise seen from outside (geometric normal outward) unless asked for inward faces.
// Meshes built on a vertex grid (sphere, blob, height field, box) share their vertices bit for bit
// between neighbouring triangles, so they are watertight. Shading normals n0..n2 are the geometric
// normal except where noted. Random generators take a seed and give the same triangles on every
// platform and with every compiler (own PRNG, no std:: distributions, and one draw per statement
// in a fixed order; C++ leaves the order of draws inside one argument list unspecified):
// - noise (blob, height field): per wave its frequency, its direction (z in [−1, 1], then the
//   azimuth) and its phase;
// - triangle soup: per triangle the centre's z, y and x, then per vertex its distance from the
//   centre and its direction (as above); a triangle that is redrawn has used up its draws.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "photonflow/foundations/shared_types.h"
#include "photonflow/foundations/vec.h"

namespace pf {

// Ids stamped on generated triangles.
struct MeshIds {
  int32_t mesh = 0;
  int32_t material = 0;
};

// UV sphere with at least `min_triangles` triangles: the smallest grid of s ≥ 3 stacks and 2s
// slices (4s² − 4s triangles; single triangles at the poles) that reaches the count. Smooth
// shading normals (the radial direction at each vertex).
std::vector<pf_triangle> make_sphere(const Vec3& center, float radius, size_t min_triangles,
                                     MeshIds ids = {});

// "Blob": the UV sphere of make_sphere with its radius displaced along the normal by smooth noise
// (a sum of 8 random plane waves over the unit direction), r = radius·(1 + amplitude·noise),
// noise in [−1, 1]. At least `min_triangles` triangles. Geometric normals.
std::vector<pf_triangle> make_blob(const Vec3& center, float radius, size_t min_triangles,
                                   float amplitude, uint64_t seed, MeshIds ids = {});

// Height field over the rectangle [x0, x1] × [z0, z1] at height y = base + height·noise(x, z)
// (noise in [−1, 1], a sum of plane waves), facing +y, with cells² · 2 triangles.
std::vector<pf_triangle> make_heightfield(float x0, float x1, float z0, float z1, float base,
                                          float height, int cells, uint64_t seed,
                                          MeshIds ids = {});

// `count` random triangles inside `box`: centres uniform in the box, vertices within
// `size` (scene units) of the centre and clamped to the box; near-degenerate ones are redrawn.
std::vector<pf_triangle> make_triangle_soup(const Bounds& box, size_t count, float size,
                                            uint64_t seed, MeshIds ids = {});

// Axis-aligned box [lo, hi]: 6 quads as 12 triangles, normals outward (or inward for a room).
std::vector<pf_triangle> make_box(const Vec3& lo, const Vec3& hi, bool inward, MeshIds ids = {});

// Cornell-box-like room for tests and benchmarks: an inward-facing unit room [0, 1]³ (12
// triangles, mesh 0), an outward box standing on the floor (12 triangles, mesh 1) and a UV sphere
// of at least `sphere_triangles` triangles (mesh 2). Material id = mesh id.
std::vector<pf_triangle> make_cornell_room(size_t sphere_triangles);

// Writes a Wavefront OBJ (v, vn and f v//vn lines; identical vertices shared) atomically:
// "<path>.tmp.<pid>" then rename. Throws InputError if the file cannot be written.
void write_obj(const std::string& path, const std::vector<pf_triangle>& tris);

}  // namespace pf
