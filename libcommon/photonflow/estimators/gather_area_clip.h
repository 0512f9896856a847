// gather_area_clip.h — the plane geometry of the surface gather area (gather_area.h): the part of
// a disc inside a convex polygon, a convex polygon cut to a half-plane, and the share of a
// triangle on one side of a level line. They know nothing of meshes; the hierarchy and the
// per-vertex cache of gather_area.cpp call them for the triangles the region's border crosses.
#pragma once

namespace pf {

constexpr double kPiD = 3.14159265358979323846;

// The area of the part of the disc of radius `rho` about the origin that lies in the convex
// polygon p[0..n) (x, y pairs, counter-clockwise). Exact up to rounding; 0 for n < 3.
double disc_polygon_area(const double* p, int n, double rho);

// Sutherland–Hodgman: the convex polygon p[0..n) (x, y pairs, at most 6 vertices after clipping a
// quad twice) cut to kx·x + ky·y <= c, in place; returns the new vertex count.
int clip_half_plane(double* p, int n, double kx, double ky, double c);

// The share of a triangle's area on which a linear function is <= c, from its values at the
// corners sorted ascending g[0] <= g[1] <= g[2]. For c up to g[1] the part below the level line
// is a triangle at corner 0 whose sides along edges 0–1 and 0–2 are (c − g0)/(g1 − g0) and
// (c − g0)/(g2 − g0) of theirs: (c − g0)² / ((g2 − g0)(g1 − g0)) of the area; above g[1], one
// minus the same at corner 2 (every divisor is positive on its branch).
inline double share_below(const double* g, double c) {
  if (c <= g[0]) return 0.0;
  if (c >= g[2]) return 1.0;
  if (c <= g[1]) return (c - g[0]) * (c - g[0]) / ((g[2] - g[0]) * (g[1] - g[0]));
  return 1.0 - (g[2] - c) * (g[2] - c) / ((g[2] - g[0]) * (g[2] - g[1]));
}

}  // namespace pf
