// surface.h — what a ray hit: position, normals, side and material, and safe ray offsets.
#pragma once
#include "photonflow/material/bsdf_shared.h"
#include "photonflow/material/pbr_point_shared.h"
#include "photonflow/material/pbr_scatter_shared.h"
#include "photonflow/geometry/raycast.h"
#include "photonflow/foundations/rng.h"
#include "photonflow/sampling/sampling.h"
#include "photonflow/geometry/scene.h"
#include "photonflow/foundations/vec.h"

namespace pf {

struct SurfaceHit {
  Vec3 p;        // hit position
  Vec3 ng;       // unit geometric normal of the triangle (CCW front), not flipped
  Vec3 ns;       // unit shading normal, flipped to the same side as ng
  bool front;    // the ray arrived on the front side (dot(d, ng) < 0)
  int tri;
  int mesh;
  int material;
  float u, v;    // barycentrics of the hit (weights of v1 and v2), for the texture look-up
  int leaf = -1; // the kd leaf the hit lies in (Hit::leaf): rays from here start their walk there
};

inline SurfaceHit surface_at(const Scene& s, const Ray& ray, const Hit& h) {
  const pf_triangle& t = s.triangles[size_t(h.tri)];
  SurfaceHit sh;
  sh.p = ray.o + ray.d * h.t;
  sh.ng = s.normal_of(size_t(h.tri));
  float w = 1.f - h.u - h.v;
  Vec3 ns = normalize(Vec3(t.n0) * w + Vec3(t.n1) * h.u + Vec3(t.n2) * h.v);
  sh.ns = dot(ns, sh.ng) < 0.f ? -ns : ns;
  if (!finite(sh.ns) || dot(sh.ns, sh.ns) < 0.25f) sh.ns = sh.ng;  // |ns| < 1/2: degenerate
  sh.front = dot(ray.d, sh.ng) < 0.f;
  sh.tri = h.tri;
  sh.mesh = t.mesh;
  sh.material = t.material;
  sh.u = h.u;
  sh.v = h.v;
  sh.leaf = h.leaf;
  return sh;
}

// The diffuse colour at a hit (scene.h diffuse_color: m.color × the base-colour texture there).
inline Vec3 diffuse_color(const Scene& s, const pf_material& m, const SurfaceHit& sh) {
  return diffuse_color(s, m, sh.material, sh.tri, sh.u, sh.v);
}

// The BSDF parameters of a PF_MAT_PBR material at a hit (material/bsdf_shared.h): the glTF
// factors times the textures there (spec 3.9.2: baseColor = factor × sRGB-decoded texture,
// metallic = factor × texture.B, roughness = factor × texture.G).
inline pf_bsdf_params bsdf_params_at(const Scene& s, const pf_material& m, const SurfaceHit& sh) {
  // One definition for both backends (material/pbr_point_shared.h, the kernels call it too).
  const int bt = s.texture_of(sh.material), mt = s.mr_texture_of(sh.material);
  pf_bsdf_params p;
  pf_pbr_params_at(&m, s.textures.data(), s.texels.data(), bt, mt,
                   bt >= 0 || mt >= 0 ? s.uvs[size_t(sh.tri)].uv : nullptr, sh.u, sh.v, &p);
  return p;
}

// The BSDF at a visible point on a PF_MAT_PBR surface (material/pbr_point_shared.h): the textured
// parameters, and whether the facing normal (the hitpoint's normal: ns on the side the ray
// arrived from) is the outside, i.e. the front: pf_pbr_point_eval then works in the frame of the
// front shading normal, as the photon and path tracers do (pbr_scatter_shared.h).
inline pf_pbr_point pbr_point_at(const Scene& s, const pf_material& m, const SurfaceHit& sh) {
  pf_pbr_point pt;
  pt.params = bsdf_params_at(s, m, sh);
  pt.outside = sh.front ? PF_PBR_POINT_OUTSIDE : 0;
  return pt;
}

// Offset of new ray origins from a surface, relative to the scene size, to avoid self-hits.
inline float ray_epsilon(const Scene& s) { return 1e-5f * length(s.bounds.extent()) + 1e-7f; }

// Origin for a ray leaving `sh` in direction `d`: pushed off the surface on d's side.
inline Vec3 offset_origin(const SurfaceHit& sh, const Vec3& d, float eps) {
  return sh.p + sh.ng * (dot(d, sh.ng) >= 0.f ? eps : -eps);
}

// A ray leaving `sh` in direction `d` (offset_origin), its kd walk started in the hit's leaf.
inline Ray spawn_ray(const SurfaceHit& sh, const Vec3& d, float eps) {
  Ray r{offset_origin(sh, d, eps), d};
  r.leaf = sh.leaf;
  return r;
}

// Perfect specular scattering of a ray (direction d, unit) at a mirror or glass surface.
// Returns the new direction and multiplies `weight` by the material's colour when a mirror reflects
// or glass transmits. Glass reflects with the Fresnel probability F (one random number drawn from
// `rng`, and only for glass, so the kernels' draw order matches) and refracts otherwise; total
// internal reflection reflects. Choosing by probability needs no weight correction:
// F/F = (1 − F)/(1 − F) = 1.
// `next()` gives the one random number (specular_bounce_with: any source of draws, e.g. the
// photon tracer's stored primary samples, photon_pass.h; specular_bounce: a pf_rng stream).
template <class Next>
inline Vec3 specular_bounce_with(const pf_material& m, const SurfaceHit& sh, const Vec3& d,
                                 Next&& next, Vec3& weight) {
  Vec3 n = sh.front ? sh.ns : -sh.ns;  // facing the incoming ray
  if (m.type == PF_MAT_MIRROR) {
    weight = weight * Vec3(m.color);
    return reflect(d, n);
  }
  float eta_i = sh.front ? 1.f : m.ior, eta_t = sh.front ? m.ior : 1.f;
  float F = fresnel_dielectric(-dot(d, n), eta_i, eta_t);
  Vec3 t;
  if (next() < F || !refract(d, n, eta_i / eta_t, t)) return reflect(d, n);
  weight = weight * Vec3(m.color);
  return normalize(t);
}
inline Vec3 specular_bounce(const pf_material& m, const SurfaceHit& sh, const Vec3& d,
                            pf_rng* rng, Vec3& weight) {
  return specular_bounce_with(m, sh, d, [rng] { return pf_rng_next(rng); }, weight);
}

}  // namespace pf
