// hh_triangle.cpp — Havel–Herout plane precomputation for one triangle (thesis eq. 4.3–4.7).
#include "photonflow/geometry/scene.h"

namespace pf {

namespace {

struct D3 {
  double x, y, z;
};
D3 sub(const float* a, const float* b) {
  return {double(a[0]) - b[0], double(a[1]) - b[1], double(a[2]) - b[2]};
}
D3 cross(const D3& a, const D3& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
double dot(const D3& a, const float* b) { return a.x * b[0] + a.y * b[1] + a.z * b[2]; }

// Stores the plane (n, −n·a) into out[4].
void store_plane(const D3& n, const float* a, float* out) {
  out[0] = float(n.x);
  out[1] = float(n.y);
  out[2] = float(n.z);
  out[3] = float(-dot(n, a));
}

}  // namespace

// The planes are computed in double and rounded once, which keeps the barycentrics of points on
// an edge shared by two triangles within a few ulps of each other (see PF_HH_ROUNDING).
pf_hh_triangle make_hh_triangle(const pf_triangle& t) {
  const D3 ab = sub(t.v1, t.v0);
  const D3 ac = sub(t.v2, t.v0);
  const D3 n = cross(ab, ac);  // N = (B−A)×(C−A), eq. 4.3
  const double nn = n.x * n.x + n.y * n.y + n.z * n.z;
  const double inv = nn > 0 ? 1.0 / nn : 0.0;
  const D3 n1r = cross(ac, n);  // N1 = ((C−A)×N)/|N|²: u = 1 at B, 0 on edge AC
  const D3 n2r = cross(n, ab);  // N2 = (N×(B−A))/|N|²: v = 1 at C, 0 on edge AB
  const D3 n1{n1r.x * inv, n1r.y * inv, n1r.z * inv};
  const D3 n2{n2r.x * inv, n2r.y * inv, n2r.z * inv};
  pf_hh_triangle h{};
  store_plane(n, t.v0, h.n);
  store_plane(n1, t.v0, h.n1);
  store_plane(n2, t.v0, h.n2);
  return h;
}

}  // namespace pf
