// gather_area.h — the surface area a gather takes photons from: the normalisation of the photon
// density estimate where the gather region leaves the surface (creases, corners, mesh borders,
// thin parts).
//
// The estimators that trace a new eye pass every pass (sppm, pppm) gather at a visible point x with
// shading normal n the photons p of its mesh with |x_p − x| <= R, |n·(x_p − x)| <= κR (the slab,
// ppm.h) and dot(d_p, n) < 0 (arrived on x's side), and divide their flux by the disc area πR²
// (thesis eq. 3.17). That assumes the region holds a flat disc of the surface. Near
// a crease (a wall meets the floor, a block's edge), a mesh's border or a part thinner than R, it
// holds less: the estimate is too dark there by the missing fraction, a bias that does not shrink
// with more photons, only with R, and along the scene's edges it is most of the error of a render
// (docs/RESULTS.md section 8, "Gather area"). `--gather-area surface` divides instead by the
// measure of the surface the rule accepts photons from,
//
//   A(x, R) = Σ_T w_T · |T ∩ B(x, R) ∩ S(x, n, κR)|                                     (1)
//
// over the triangles T of x's mesh: B the ball, S the slab, |·| the area, and w_T the share of
// the photons arriving at T that pass the side rule. For photons arriving at T's lit side from a
// cosine-weighted hemisphere about its normal m_T (a diffuse neighbourhood),
//
//   w_T = P(ω·n > 0 | ω ~ cos about σ m_T) = (1 + σ m_T·n) / 2                          (2)
//
// (the view factor of a tilted plane to a uniform hemisphere), σ = ±1 the side of the mesh x lies
// on: the sign of m_T0·n for the triangle T0 that holds x. Photons are taken to arrive on the
// same side of the mesh as at x (a consistently wound mesh lit from one side). On the flat
// inside of a surface A = πR² exactly, so the estimate there is unchanged; at a crease (1) counts
// the disc's part on x's face and none of the other face's (another mesh) or its slab strip
// weighted by (2) (the same mesh); w_T = 1 for every T at a transmissive PBR point, which takes
// photons from both sides. The estimate divides by A instead of πR²:
//
//   L_r(x) ≈ Σ_p f_r Φ_p / (A(x, R) · N_e)                                                (3)
//
// With uniform irradiance E, E[Σ Φ_p] = E·A for (1)'s A under (2)'s model, so (3) is unbiased
// there; elsewhere its bias is that of the disc estimate on a flat surface (the second-order
// term of E's Taylor expansion), without the first-order loss at the region's border.
//
// Computing A: per mesh a bounding-volume hierarchy over its triangles whose nodes hold Σ|T| and
// Σ|T|·m_T, so a node inside the ball and the slab adds (Σ|T| + σ n·Σ|T| m_T)/2 at once (2); the
// triangles of the nodes the region's border crosses are clipped exactly: T's plane meets the
// ball in a disc of radius √(R² − h²) (h: x's distance to the plane), the slab in a strip, and
// the area of a convex polygon within a disc is the sum over its edges of the signed area of the
// disc within the triangle (centre, edge) (a circular sector where the edge runs outside the
// disc); a triangle within the ball that only the slab cuts takes the share of it between the
// slab's planes (n·(y − x) is linear on it), and one with a corner farther than R + its longest
// edge from x is none. Coplanar pairs of large triangles sharing an edge are merged into convex quads first
// (a wall, a box's face: one polygon, and a disc inside it needs no sectors). Cost: a lookup of
// the triangle holding x and a walk over the nodes the border crosses; flat scenes touch one to
// four polygons per gather; on fine meshes the corners' values are kept per vertex and radius
// level (SurfaceArea::area).
//
// Parameters:
// | option          | default | meaning                                                          |
// |-----------------|---------|------------------------------------------------------------------|
// | --gather-area   | auto    | surface: divide by (1); disc: by πR² (the thesis's eq. 3.17).     |
// |                 |         | auto: surface for sppm and pppm, disc for ppm (its fixed          |
// |                 |         | hitpoints keep the thesis's estimate)                            |
#pragma once
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "photonflow/geometry/scene.h"
#include "photonflow/foundations/shared_types.h"

namespace pf {

enum class GatherArea { Disc, Surface };

const char* gather_area_name(GatherArea a);

// --gather-area: "auto" (surface when new_eye_pass, i.e. sppm and pppm; disc for ppm), "surface"
// or "disc". InputError naming --gather-area otherwise, or for surface without new_eye_pass.
GatherArea parse_gather_area(const std::string& text, bool new_eye_pass);

// The measure (1) over one scene's meshes (the hierarchies, built once).
class SurfaceArea {
 public:
  explicit SurfaceArea(const Scene& scene);
  ~SurfaceArea();
  SurfaceArea(const SurfaceArea&) = delete;
  SurfaceArea& operator=(const SurfaceArea&) = delete;

  // A(x, R) of eq. (1) as the estimator uses it, for a gather at `site` (position, normal,
  // mesh) with radius R and slab κ (0: the ball alone); both_sides: w_T = 1 (a transmissive PBR
  // point). Where the triangle T0 holding x is small against R (its longest edge at most R),
  // πR² times the ratio A/(πR_L²) interpolated instead: linearly in log R between the two
  // radius levels R_L >= R > R_{L+1} of r_ref · 2^(−L/4) (r_ref the scene diagonal), and
  // linearly over T0 (x's barycentric weights) between its corners, each corner's ratio
  // evaluated there with its vertex normal and rounded to float. A corner's ratio depends on the
  // corner and L alone, so it is computed once per vertex and level (a fine mesh's region
  // covers a hundred triangles or more) and is the same for any thread count, pass order or
  // route. 0 when the site lies on no triangle of its mesh.
  double area(const pf_hitpoint& site, float radius, float slab, bool both_sides = false) const;

  // Eq. (1) at x itself by the hierarchy, whatever the triangles' size.
  double area_at(const pf_hitpoint& site, float radius, float slab, bool both_sides = false) const;

  // πR² / A(x, R): the factor that turns the disc estimate into (3). 1 where A is not positive
  // (the site lies on no triangle of its mesh, or R <= 0); at most kMaxScale, where the region
  // holds a sliver of surface (a needle's tip), and below 1 where it holds more than a disc
  // (a surface folded within the ball).
  double scale(const pf_hitpoint& site, float radius, float slab, bool both_sides = false) const;

  // Eq. (1) at x by clipping every triangle of the mesh (no hierarchy): the tests' reference.
  double area_brute(const pf_hitpoint& site, float radius, float slab,
                    bool both_sides = false) const;

  // Whether this was built from `scene`'s triangle array as it is now (surface_area's key).
  bool matches(const Scene& scene) const;

  static constexpr double kMaxScale = 16.0;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

// The scene's SurfaceArea, built on first use (thread-safe; later calls are an atomic load and a
// key check), like the kd-tree's host data.
const SurfaceArea& surface_area(const Scene& scene);

}  // namespace pf
