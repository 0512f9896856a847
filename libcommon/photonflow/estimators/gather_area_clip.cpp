// gather_area_clip.cpp — the plane geometry of the surface gather area (gather_area_clip.h):
// the disc within a convex polygon, by its edges' sectors and triangles, and the cut of a
// polygon to a half-plane.
#include "photonflow/estimators/gather_area_clip.h"

#include <algorithm>
#include <cmath>

namespace pf {

namespace {

// The signed area of the disc of radius rho about the origin within the triangle (origin, a, b):
// positive for a counter-clockwise triangle. Where the edge ab runs outside the disc the region is
// the circular sector between the rays to a and b, r²θ/2; where it crosses, the sector up to the
// entry point, the triangle (origin, entry, exit) and the sector after the exit.
double disc_triangle(double ax, double ay, double bx, double by, double rho) {
  const double r2 = rho * rho;
  const auto sector = [r2](double px, double py, double qx, double qy) {
    return 0.5 * r2 * std::atan2(px * qy - py * qx, px * qx + py * qy);
  };
  const double aa = ax * ax + ay * ay, bb = bx * bx + by * by;
  if (aa <= r2 && bb <= r2) return 0.5 * (ax * by - ay * bx);
  const double dx = bx - ax, dy = by - ay;
  // |a + t·d|² = rho²: qa t² + 2 qb t + qc = 0.
  const double qa = dx * dx + dy * dy, qb = ax * dx + ay * dy, qc = aa - r2;
  const double disc = qb * qb - qa * qc;
  if (!(qa > 0.0) || disc <= 0.0) return sector(ax, ay, bx, by);
  const double sq = std::sqrt(disc);
  const double t1 = (-qb - sq) / qa, t2 = (-qb + sq) / qa;
  if (t2 <= 0.0 || t1 >= 1.0) return sector(ax, ay, bx, by);
  const double u1 = std::max(t1, 0.0), u2 = std::min(t2, 1.0);
  const double p1x = ax + u1 * dx, p1y = ay + u1 * dy;
  const double p2x = ax + u2 * dx, p2y = ay + u2 * dy;
  return sector(ax, ay, p1x, p1y) + 0.5 * (p1x * p2y - p1y * p2x) + sector(p2x, p2y, bx, by);
}

}  // namespace

int clip_half_plane(double* p, int n, double kx, double ky, double c) {
  double out[2 * 8];
  int m = 0;
  for (int i = 0; i < n; ++i) {
    const int j = (i + 1) % n;
    const double ax = p[2 * i], ay = p[2 * i + 1], bx = p[2 * j], by = p[2 * j + 1];
    const double fa = kx * ax + ky * ay - c, fb = kx * bx + ky * by - c;
    if (fa <= 0.0) {
      out[2 * m] = ax;
      out[2 * m + 1] = ay;
      ++m;
    }
    if ((fa < 0.0 && fb > 0.0) || (fa > 0.0 && fb < 0.0)) {
      const double t = fa / (fa - fb);
      out[2 * m] = ax + t * (bx - ax);
      out[2 * m + 1] = ay + t * (by - ay);
      ++m;
    }
  }
  std::copy(out, out + 2 * m, p);
  return m;
}

double disc_polygon_area(const double* p, int n, double rho) {
  if (n < 3 || !(rho > 0.0)) return 0.0;
  // The origin's distance to each edge's line, positive outside (counter-clockwise: the outward
  // normal of edge a→b is (e_y, −e_x)/|e|). A disc outside one edge misses the polygon; a disc
  // inside all of them, rho away from each, lies in it whole.
  bool whole = true;
  for (int i = 0; i < n; ++i) {
    const int j = (i + 1) % n;
    const double ax = p[2 * i], ay = p[2 * i + 1];
    const double ex = p[2 * j] - ax, ey = p[2 * j + 1] - ay;
    const double len = std::sqrt(ex * ex + ey * ey);
    if (!(len > 0.0)) continue;
    const double dist = (ay * ex - ax * ey) / len;
    if (dist >= rho) return 0.0;
    if (dist > -rho) whole = false;
  }
  if (whole) return kPiD * rho * rho;
  double s = 0.0;
  for (int i = 0; i < n; ++i) {
    const int j = (i + 1) % n;
    s += disc_triangle(p[2 * i], p[2 * i + 1], p[2 * j], p[2 * j + 1], rho);
  }
  return std::max(s, 0.0);
}

}  // namespace pf
