// Baked scene: derived data (planes, bounds, lights, identity) and scene.h5 reading/writing.
#include "photonflow/geometry/scene.h"

#include <algorithm>
#include <cmath>
#include <cstddef>

#include "photonflow/geometry/camera.h"
#include "photonflow/io/h5io.h"
#include "photonflow/foundations/hash.h"
#include "photonflow/geometry/light_shared.h"
#include "photonflow/io/validate.h"

namespace pf {

namespace {
float luminance(const float* c) { return 0.2126f * c[0] + 0.7152f * c[1] + 0.0722f * c[2]; }
constexpr float kPi = 3.14159265358979323846f;
}  // namespace

void Scene::compute_hh() {
  hh.resize(triangles.size());
  for (size_t i = 0; i < triangles.size(); ++i) hh[i] = make_hh_triangle(triangles[i]);
  compute_normals();
}

void Scene::compute_normals() {
  normals.resize(triangles.size());
  for (size_t i = 0; i < triangles.size(); ++i) normals[i] = face_normal(triangles[i]);
}

void Scene::compute_bounds() {
  bounds = Bounds();
  for (auto& t : triangles) {
    bounds.extend(Vec3(t.v0));
    bounds.extend(Vec3(t.v1));
    bounds.extend(Vec3(t.v2));
  }
}

void derive_lights(const std::vector<pf_triangle>& triangles,
                   const std::vector<pf_material>& materials, const std::vector<pf_light>& given,
                   std::vector<pf_light>& lights, std::vector<float>& cdf) {
  // Keep point, spot and directional lights, rebuild area lights from emitter triangles.
  std::vector<pf_light> kept;
  for (auto& l : given)
    if (l.type == PF_LIGHT_POINT || l.type == PF_LIGHT_SPOT || l.type == PF_LIGHT_DIRECTIONAL)
      kept.push_back(l);
  lights.clear();
  for (size_t i = 0; i < triangles.size(); ++i) {
    const pf_triangle& t = triangles[i];
    if (t.material < 0 || size_t(t.material) >= materials.size()) continue;
    const pf_material& m = materials[size_t(t.material)];
    if (m.type != PF_MAT_EMITTER || luminance(m.emission) <= 0.f) continue;
    pf_light l{};
    l.type = PF_LIGHT_AREA;
    l.triangle = int32_t(i);
    l.area = 0.5f * length(cross(Vec3(t.v1) - Vec3(t.v0), Vec3(t.v2) - Vec3(t.v0)));
    // One-sided Lambertian emitter: Φ = π·A·L.
    l.power = kPi * l.area * luminance(m.emission);
    Vec3 c = (Vec3(t.v0) + Vec3(t.v1) + Vec3(t.v2)) / 3.f;
    c.store(l.position);
    for (int k = 0; k < 3; ++k) l.radiance[k] = m.emission[k];
    lights.push_back(l);
  }
  // A directional light's disc (format version 5): the scene's bounding sphere (centre c, radius
  // R) seen along the light, the disc's centre R·kDirectionalDiscMargin before c against the light
  // (outside the bounds), area π·R².
  Bounds b;
  for (const pf_triangle& t : triangles) {
    b.extend(Vec3(t.v0));
    b.extend(Vec3(t.v1));
    b.extend(Vec3(t.v2));
  }
  const Vec3 centre = b.empty() ? Vec3() : (b.lo + b.hi) * 0.5f;
  const float radius = b.empty() ? 0.f : 0.5f * length(b.hi - b.lo);
  for (auto& l : kept) {
    if (l.type == PF_LIGHT_POINT) {
      l.power = 4.f * kPi * luminance(l.radiance);  // isotropic point light: Φ = 4π·I
    } else if (l.type == PF_LIGHT_SPOT) {
      // Φ = ∫ I·falloff dω = 2π·I·∫ falloff d(cos θ) (light_shared.h)
      l.power = float(2.0 * double(kPi) * double(luminance(l.radiance)) *
                      pf_spot_cone_integral(l.cos_inner, l.cos_outer));
    } else {
      (centre - Vec3(l.direction) * (radius * kDirectionalDiscMargin)).store(l.position);
      l.area = kPi * radius * radius;
      l.power = luminance(l.radiance) * l.area;  // Φ = E·π·R²
    }
    lights.push_back(l);
  }
  cdf.assign(lights.size(), 0.f);
  double total = 0;
  for (auto& l : lights) total += l.power;
  double acc = 0;
  for (size_t i = 0; i < lights.size(); ++i) {
    acc += lights[i].power;
    cdf[i] = total > 0 ? float(acc / total) : float(i + 1) / float(lights.size());
  }
  if (!cdf.empty()) cdf.back() = 1.f;
}

void Scene::compute_light_cdf() {
  std::vector<pf_light> given;
  given.swap(lights);
  derive_lights(triangles, materials, given, lights, light_cdf);
}

float Scene::light_incident(size_t li, const Vec3& p, float u1, float u2, Vec3& w,
                           Vec3& q) const {
  const pf_light& l = lights[li];
  const float fp[3] = {p.x, p.y, p.z};
  float fw[3], fq[3], nl[3] = {0.f, 0.f, 0.f};
  const float none[3] = {0.f, 0.f, 0.f};
  const float *v0 = none, *v1 = none, *v2 = none;
  if (l.type == PF_LIGHT_AREA) {
    const pf_triangle& t = triangles[size_t(l.triangle)];
    v0 = t.v0;
    v1 = t.v1;
    v2 = t.v2;
    normal_of(size_t(l.triangle)).store(nl);
  }
  const float g = pf_light_incident(l.type, l.position, l.direction, l.cos_inner, l.cos_outer,
                                    l.area, v0, v1, v2, nl, fp, u1, u2, fw, fq);
  w = Vec3(fw);
  q = Vec3(fq);
  return g > 0.f && light_point_cut_away(li, u1, u2) ? 0.f : g;
}

bool Scene::light_point_cut_away(size_t li, float u1, float u2) const {
  const pf_light& l = lights[li];
  if (!has_alpha_masks() || l.type != PF_LIGHT_AREA) return false;
  return pf_alpha_light_point_cut_away(material_alpha.data(), triangles.data(), textures.data(),
                                       texels.data(), uvs.empty() ? nullptr : uvs[0].uv,
                                       l.triangle, u1, u2) != 0;
}

bool Scene::sample_light(float ul, float u1, float u2, const Vec3& p, LightSample& s) const {
  if (lights.empty()) return false;
  s.light = pick_light(ul, s.p_light);
  if (!(s.p_light > 0.f)) return false;
  s.g = light_incident(s.light, p, u1, u2, s.w, s.q);
  return s.g > 0.f;
}

size_t Scene::pick_light_search(float u) const {
  return size_t(std::upper_bound(light_cdf.begin(), light_cdf.end(), u) - light_cdf.begin());
}

void Scene::compute_scene_id() {
  Sha256 h;
  auto feed = [&h](const auto& v) {
    uint64_t n = v.size();
    h.update(&n, sizeof n);
    if (n) h.update(v.data(), n * sizeof(v[0]));
  };
  feed(triangles);
  // Materials: the fields of format versions 1-4 (the first 32 bytes of each pf_material, the
  // bytes this hashed before version 5 grew the struct), so that a scene without a PBR material
  // keeps its id; the metallic-roughness fields (validate_scene: 0 on every other type) and
  // materials/metallic_roughness_texture only when some material is PF_MAT_PBR.
  constexpr size_t kLegacyMaterialBytes = offsetof(pf_material, metallic);
  static_assert(kLegacyMaterialBytes == 32, "pf_material: the version 1-4 fields come first");
  {
    const uint64_t n = materials.size();
    h.update(&n, sizeof n);
    for (const pf_material& m : materials) h.update(&m, kLegacyMaterialBytes);
  }
  // Lights: the fields of format versions 1-4 always (the same bytes as hashing the old 40-byte
  // lights), the spot/directional fields of version 5 only where a scene has such a light, so
  // that a scene of area and point lights keeps its id (validate_scene requires those fields 0).
  const uint64_t n_lights = lights.size();
  h.update(&n_lights, sizeof n_lights);
  bool punctual = false;
  for (const pf_light& l : lights) {
    h.update(&l, offsetof(pf_light, direction));
    punctual = punctual || l.type == PF_LIGHT_SPOT || l.type == PF_LIGHT_DIRECTIONAL;
  }
  if (punctual)
    for (const pf_light& l : lights)
      h.update(&l.direction, sizeof(pf_light) - offsetof(pf_light, direction));
  // The pinhole fields always; the lens only when there is one, so that a pinhole scene keeps
  // the id it had before format version 4 added the lens.
  h.update(&camera, offsetof(pf_camera, aperture));
  if (camera.aperture > 0.f) {
    h.update(&camera.aperture, sizeof camera.aperture);
    h.update(&camera.focus_distance, sizeof camera.focus_distance);
  }
  // Textures (format version 3): only where there are some, so that a scene without textures
  // keeps its version-2 id (its materials/texture is all −1 and it has no UVs: nothing to cover).
  if (!textures.empty()) {
    feed(textures);
    feed(texels);
    feed(material_texture);
    feed(uvs);
  }
  if (has_pbr()) {
    for (const pf_material& m : materials) {
      const float mr[3] = {m.metallic, m.roughness, m.transmission};
      h.update(mr, sizeof mr);
    }
    std::vector<int32_t> mr_texture = material_mr_texture;
    mr_texture.resize(materials.size(), -1);
    feed(mr_texture);
  }
  // Alpha cut-outs (format version 5): only when some material is masked, so that every scene
  // without masks keeps its version-4 id.
  bool masked = false;
  for (const pf_alpha_material& a : material_alpha) masked = masked || pf_alpha_masked(a.cutoff);
  if (masked) feed(material_alpha);
  scene_id = h.hex();
}

Vec3 Scene::texture_value(int texture, size_t tri, float u, float v) const {
  float rgba[4];
  pf_tex_sample_triangle(&textures[size_t(texture)], texels.data(), uvs[tri].uv, u, v, rgba);
  return {rgba[0], rgba[1], rgba[2]};
}

void finish_scene(Scene& s, const KdBuildParams& kd) {
  s.compute_hh();
  s.compute_bounds();
  s.compute_light_cdf();
  s.kd = build_kdtree(s.triangles, kd);
  s.compute_scene_id();
}

// ---- HDF5 compound types --------------------------------------------------------------------

#define PF_F32(T, f, n) f32(#f, offsetof(T, f), n)
#define PF_I32(T, f) i32(#f, offsetof(T, f))

const h5::Compound& h5_type_triangle() {
  static const h5::Compound t = [] {
    h5::Compound c(sizeof(pf_triangle));
    c.PF_F32(pf_triangle, v0, 3).PF_F32(pf_triangle, v1, 3).PF_F32(pf_triangle, v2, 3);
    c.PF_F32(pf_triangle, n0, 3).PF_F32(pf_triangle, n1, 3).PF_F32(pf_triangle, n2, 3);
    c.PF_I32(pf_triangle, mesh).PF_I32(pf_triangle, material);
    return c;
  }();
  return t;
}

const h5::Compound& h5_type_hh_triangle() {
  static const h5::Compound t = [] {
    h5::Compound c(sizeof(pf_hh_triangle));
    c.PF_F32(pf_hh_triangle, n, 4).PF_F32(pf_hh_triangle, n1, 4).PF_F32(pf_hh_triangle, n2, 4);
    return c;
  }();
  return t;
}

namespace {
// The material's fields, with the metallic-roughness ones (format version 5) or without
// (versions 1-4: they read as the 0 the vector was made with).
h5::Compound material_compound(bool pbr) {
  h5::Compound c(sizeof(pf_material));
  c.PF_I32(pf_material, type).PF_F32(pf_material, ior, 1);
  c.PF_F32(pf_material, color, 3).PF_F32(pf_material, emission, 3);
  if (pbr) {
    c.PF_F32(pf_material, metallic, 1).PF_F32(pf_material, roughness, 1);
    c.PF_F32(pf_material, transmission, 1);
  }
  return c;
}
}  // namespace

const h5::Compound& h5_type_material() {
  static const h5::Compound t = material_compound(true);
  return t;
}

const h5::Compound& h5_type_material_v4() {
  static const h5::Compound t = material_compound(false);
  return t;
}

namespace {
// The light's fields, with the spot/directional fields of format version 5 or without (1-4).
h5::Compound light_compound(bool punctual) {
  h5::Compound c(sizeof(pf_light));
  c.PF_I32(pf_light, type).PF_I32(pf_light, triangle);
  c.PF_F32(pf_light, area, 1).PF_F32(pf_light, power, 1);
  c.PF_F32(pf_light, position, 3).PF_F32(pf_light, radiance, 3);
  if (punctual)
    c.PF_F32(pf_light, direction, 3).PF_F32(pf_light, cos_inner, 1).PF_F32(pf_light, cos_outer, 1);
  return c;
}
}  // namespace

const h5::Compound& h5_type_light() {
  static const h5::Compound t = light_compound(true);
  return t;
}

const h5::Compound& h5_type_light_v4() {
  static const h5::Compound t = light_compound(false);
  return t;
}

namespace {
// The camera's fields, with the thin lens (format version 4) or without (versions 1-3).
h5::Compound camera_compound(bool lens) {
  h5::Compound c(sizeof(pf_camera));
  c.PF_F32(pf_camera, eye, 3).PF_F32(pf_camera, look_at, 3).PF_F32(pf_camera, up, 3);
  c.PF_F32(pf_camera, fov_y_deg, 1).PF_I32(pf_camera, width).PF_I32(pf_camera, height);
  if (lens) c.PF_F32(pf_camera, aperture, 1).PF_F32(pf_camera, focus_distance, 1);
  return c;
}
}  // namespace

const h5::Compound& h5_type_camera() {
  static const h5::Compound t = camera_compound(true);
  return t;
}

const h5::Compound& h5_type_camera_pinhole() {
  static const h5::Compound t = camera_compound(false);
  return t;
}

const h5::Compound& h5_type_kd_node() {
  static const h5::Compound t = [] {
    h5::Compound c(sizeof(pf_kd_node));
    c.PF_F32(pf_kd_node, lo, 3).PF_F32(pf_kd_node, hi, 3);
    c.PF_I32(pf_kd_node, axis).PF_F32(pf_kd_node, split, 1);
    c.PF_I32(pf_kd_node, left).PF_I32(pf_kd_node, right);
    c.PF_I32(pf_kd_node, first).PF_I32(pf_kd_node, count);
    c.i32("ropes", offsetof(pf_kd_node, ropes), 6);
    return c;
  }();
  return t;
}

const h5::Compound& h5_type_hitpoint() {
  static const h5::Compound t = [] {
    h5::Compound c(sizeof(pf_hitpoint));
    c.PF_F32(pf_hitpoint, position, 3).PF_F32(pf_hitpoint, normal, 3);
    c.PF_F32(pf_hitpoint, dir, 3).PF_F32(pf_hitpoint, weight, 3);
    c.PF_F32(pf_hitpoint, radius, 1).PF_F32(pf_hitpoint, n_photons, 1);
    c.PF_F32(pf_hitpoint, flux, 3);
    c.PF_I32(pf_hitpoint, pixel_x).PF_I32(pf_hitpoint, pixel_y);
    c.PF_I32(pf_hitpoint, mesh).PF_I32(pf_hitpoint, material);
    return c;
  }();
  return t;
}

const h5::Compound& h5_type_photon() {
  static const h5::Compound t = [] {
    h5::Compound c(sizeof(pf_photon));
    c.PF_F32(pf_photon, position, 3).PF_F32(pf_photon, dir, 3).PF_F32(pf_photon, flux, 3);
    c.PF_I32(pf_photon, mesh).PF_I32(pf_photon, pass).PF_I32(pf_photon, flags);
    return c;
  }();
  return t;
}

const h5::Compound& h5_type_texture() {
  static const h5::Compound t = [] {
    h5::Compound c(sizeof(pf_texture));
    c.PF_I32(pf_texture, width).PF_I32(pf_texture, height).PF_I32(pf_texture, offset);
    c.PF_I32(pf_texture, wrap_s).PF_I32(pf_texture, wrap_t).PF_I32(pf_texture, filter);
    return c;
  }();
  return t;
}

#undef PF_F32
#undef PF_I32

// ---- scene.h5 -------------------------------------------------------------------------------

namespace {

// "x,y,z" of a stored vector, for the messages.
std::string vec_text(const float* p) {
  return value_text(p[0]) + "," + value_text(p[1]) + "," + value_text(p[2]);
}

// One Havel–Herout plane of the file against the one recomputed from the triangle (eq. 4.3–4.7):
// N within 1e-5 of its largest component, d within 1e-5 of |N|·(largest |vertex coordinate|),
// so a file baked by another compiler (other rounding of the same double expressions) passes and
// planes of another triangle, or of a moved one, do not.
bool same_plane(const float* stored, const float* derived, double coordinate) {
  const double m = std::max({std::fabs(derived[0]), std::fabs(derived[1]), std::fabs(derived[2])});
  for (int k = 0; k < 3; ++k)
    if (!nearly_equal(stored[k], derived[k], 0.0, 1e-5 * m)) return false;
  return nearly_equal(stored[3], derived[3], 1e-5, 1e-5 * m * coordinate);
}

// A light's format-version-5 fields (shared_types.h): a spot's unit axis and its cone, 1 >=
// cos_inner > cos_outer >= 0 (KHR_lights_punctual: 0 <= innerConeAngle < outerConeAngle <= π/2),
// a directional light's unit direction and no cone, all 0 for area and point lights (the scene id
// leaves them out for such scenes: Scene::compute_scene_id).
void check_light_cone(const pf_light& l, const Validator& v, const std::string& at) {
  const float* f = l.direction;
  const bool zero = f[0] == 0.f && f[1] == 0.f && f[2] == 0.f && l.cos_inner == 0.f &&
                    l.cos_outer == 0.f;
  if (l.type == PF_LIGHT_AREA || l.type == PF_LIGHT_POINT) {
    if (!zero)
      v.fail(at + ": an area or point light has a direction or cone (direction " + vec_text(f) +
             ", cos_inner " + value_text(l.cos_inner) + ", cos_outer " + value_text(l.cos_outer) +
             "); they must be 0");
    return;
  }
  v.unit(at + ".direction", f);
  if (l.type == PF_LIGHT_DIRECTIONAL) {
    if (l.cos_inner != 0.f || l.cos_outer != 0.f)
      v.fail(at + ": a directional light has a cone (cos_inner " + value_text(l.cos_inner) +
             ", cos_outer " + value_text(l.cos_outer) + "); they must be 0");
    return;
  }
  v.in_range(at + ".cos_outer", &l.cos_outer, 1, 0.0, 1.0);
  v.in_range(at + ".cos_inner", &l.cos_inner, 1, 0.0, 1.0);
  if (!(l.cos_inner > l.cos_outer) || !(l.cos_outer < 1.f))
    v.fail(at + ": a spot light's cone has cos_inner " + value_text(l.cos_inner) +
           " <= cos_outer " + value_text(l.cos_outer) +
           " (the outer cone must be wider than the inner one and wider than 0)");
}

// The values of a scene whose arrays and indices load_scene has checked (docs/FORMATS.md,
// "Values"): triangles, planes, materials, lights and their CDF, camera, kd-tree boxes and leaves.
// s.bounds holds the triangles' bounds.
void check_scene_values(const Scene& s, const Validator& v) {
  const std::string T = "geometry/triangles";
  for (size_t i = 0; i < s.triangles.size(); ++i) {
    const pf_triangle& t = s.triangles[i];
    v.position(Name(T, i, "v0"), t.v0);
    v.position(Name(T, i, "v1"), t.v1);
    v.position(Name(T, i, "v2"), t.v2);
    v.unit(Name(T, i, "n0"), t.n0);
    v.unit(Name(T, i, "n1"), t.n1);
    v.unit(Name(T, i, "n2"), t.n2);
  }
  // Derived data: the planes recomputed from the triangles (linear; see docs/FORMATS.md).
  const std::string H = "geometry/hh";
  for (size_t i = 0; i < s.triangles.size(); ++i) {
    const pf_triangle& t = s.triangles[i];
    const pf_hh_triangle& h = s.hh[i];
    const pf_hh_triangle d = make_hh_triangle(t);
    double c = 0;
    for (const float* p : {t.v0, t.v1, t.v2})
      for (int k = 0; k < 3; ++k) c = std::max(c, double(std::fabs(p[k])));
    const struct {
      const char* name;
      const float* stored;
      const float* derived;
    } planes[3] = {{"n", h.n, d.n}, {"n1", h.n1, d.n1}, {"n2", h.n2, d.n2}};
    for (const auto& p : planes) {
      v.finite(Name(H, i, p.name), p.stored, 4);
      if (!same_plane(p.stored, p.derived, c))
        v.fail(Validator::element(H, i, p.name) + " does not match the Havel–Herout plane of " + Validator::element(T, i) +
               " (thesis eq. 4.3–4.7)");
    }
  }
  const std::string M = "materials/materials";
  for (size_t i = 0; i < s.materials.size(); ++i) {
    const pf_material& m = s.materials[i];
    v.in_range(Name(M, i, "ior"), &m.ior, 1, 1.0, 1000.0);
    v.in_range(Name(M, i, "color"), m.color, 3, 0.0, 1.0);
    v.in_range(Name(M, i, "emission"), m.emission, 3, 0.0, kMaxValue);
    // Metallic-roughness (format version 5, material/bsdf_shared.h): factors in [0, 1] on a PBR
    // material, and an ior above 1 where it transmits (ior 1 is index-matched: the surface would
    // pass light straight through, a delta the BSDF does not represent); 0 on every other type.
    const struct {
      const char* name;
      float value;
    } mr[3] = {{"metallic", m.metallic}, {"roughness", m.roughness},
               {"transmission", m.transmission}};
    for (const auto& f : mr) {
      if (m.type == PF_MAT_PBR)
        v.in_range(Name(M, i, f.name), &f.value, 1, 0.0, 1.0);
      else if (f.value != 0.f)
        v.fail(Validator::element(M, i, f.name) + " = " + value_text(f.value) +
               " on a material of type " + std::to_string(m.type) +
               ", which has none (only PF_MAT_PBR, type " + std::to_string(PF_MAT_PBR) +
               ", reads it; it must be 0)");
    }
    if (m.type == PF_MAT_PBR && m.transmission > 0.f && !(m.ior > 1.f))
      v.fail(Validator::element(M, i, "ior") + " = " + value_text(m.ior) +
             " with transmission " + value_text(m.transmission) +
             ": a transmitting PBR material needs an ior above 1 (ior 1 is index-matched, "
             "material/bsdf_shared.h)");
  }
  // Lights: values, then the whole table and its CDF against the ones derived from the triangles,
  // materials and point lights (Scene::compute_light_cdf), which the scene id does not cover.
  const std::string L = "lights/lights";
  for (size_t i = 0; i < s.lights.size(); ++i) {
    const pf_light& l = s.lights[i];
    v.position(Name(L, i, "position"), l.position);
    v.in_range(Name(L, i, "radiance"), l.radiance, 3, 0.0, kMaxValue);
    v.in_range(Name(L, i, "area"), &l.area, 1, 0.0, kMaxValue);
    v.in_range(Name(L, i, "power"), &l.power, 1, 0.0, kMaxValue);
    if (l.type != PF_LIGHT_AREA && l.triangle != -1)
      v.fail(Validator::element(L, i, "triangle") + " of a " +
             (l.type == PF_LIGHT_POINT ? "point" : "spot or directional") + " light is " +
             std::to_string(l.triangle) + ", not -1");
    check_light_cone(l, v, Validator::element(L, i));
  }
  const std::string C = "lights/cdf";
  for (size_t i = 0; i < s.light_cdf.size(); ++i)
    v.in_range(Name(C, i), &s.light_cdf[i], 1, 0.0, 1.0);
  v.non_decreasing(C, s.light_cdf);
  if (!s.light_cdf.empty() && s.light_cdf.back() != 1.f)
    v.fail(Validator::element(C, s.light_cdf.size() - 1) + " = " +
           value_text(s.light_cdf.back()) + ", the last entry must be 1");
  std::vector<pf_light> lights;
  std::vector<float> cdf;
  derive_lights(s.triangles, s.materials, s.lights, lights, cdf);
  if (lights.size() != s.lights.size())
    v.fail(L + " holds " + std::to_string(s.lights.size()) + " lights, the emitter triangles and "
           "point lights give " + std::to_string(lights.size()));
  const bool none = s.bounds.empty();  // no triangles
  const double reach =
      1e-5 * (1.0 + (none ? 0.0 : std::max(length(s.bounds.lo), length(s.bounds.hi))));
  double total = 0;
  for (size_t i = 0; i < lights.size(); ++i) {
    const pf_light& a = s.lights[i];
    const pf_light& b = lights[i];
    const std::string at = Validator::element(L, i);
    if (a.type != b.type || a.triangle != b.triangle)
      v.fail(at + " is not the light the triangles and materials give (type " +
             std::to_string(b.type) + ", triangle " + std::to_string(b.triangle) + ")");
    bool same = nearly_equal(a.area, b.area, 1e-5) && nearly_equal(a.power, b.power, 1e-5);
    for (int k = 0; k < 3; ++k)
      same = same && nearly_equal(a.position[k], b.position[k], 1e-5, reach) &&
             nearly_equal(a.radiance[k], b.radiance[k], 1e-6) &&
             a.direction[k] == b.direction[k];
    same = same && a.cos_inner == b.cos_inner && a.cos_outer == b.cos_outer;
    if (!same)
      v.fail(at + " (power " + value_text(a.power) + ") differs from the light its " +
             (b.type == PF_LIGHT_AREA          ? "triangle and material give"
              : b.type == PF_LIGHT_DIRECTIONAL ? "irradiance and the scene's bounds give"
                                               : "intensity and cone give") +
             " (power " + value_text(b.power) + ")");
    if (!nearly_equal(s.light_cdf[i], cdf[i], 0.0, 1e-5))
      v.fail(Validator::element(C, i) + " = " + value_text(s.light_cdf[i]) +
             " differs from the lights' power fraction " + value_text(cdf[i]));
    total += double(b.power);
  }
  if (!(total <= double(kMaxValue)))
    v.fail(L + ": the lights' total power " + value_text(total) + " exceeds " +
           value_text(kMaxValue));
  // Camera: the values scene-bake refuses (camera_import.cpp).
  const pf_camera& cam = s.camera;
  v.position("camera.eye", cam.eye);
  v.position("camera.look_at", cam.look_at);
  v.position("camera.up", cam.up);
  if (!(cam.fov_y_deg > 0.f && cam.fov_y_deg < 180.f))
    v.fail("camera.fov_y_deg = " + value_text(cam.fov_y_deg) + " is outside (0, 180) degrees");
  const Vec3 eye(cam.eye), dir = Vec3(cam.look_at) - eye;
  const float min_dist = 1e-5f * std::max({1.f, none ? 0.f : length(s.bounds.extent()), length(eye)});
  if (!(length(dir) > min_dist))
    v.fail("camera.eye " + vec_text(cam.eye) + " and camera.look_at " + vec_text(cam.look_at) +
           " do not give a view direction");
  if (!(length(cross(normalize(dir), normalize(Vec3(cam.up)))) > 1e-4f))
    v.fail("camera.up " + vec_text(cam.up) + " is parallel to the view direction");
  // Thin lens (format version 4): a pinhole has aperture 0 and focus_distance 0; a lens has both
  // in (0, kMaxLensLength] (camera_lens_problem, the check scene-bake makes too).
  if (const char* why = camera_lens_problem(cam.aperture, cam.focus_distance))
    v.fail("camera.aperture = " + value_text(cam.aperture) + ", camera.focus_distance = " +
           value_text(cam.focus_distance) + ": " + why);
  // kd-tree: validate_kdtree checked the structure; here the boxes against the triangles. Every
  // triangle a leaf lists overlaps the leaf's box, the root box holds every triangle, and every
  // triangle of non-zero area is listed by some leaf (else rays pass through it).
  const std::string N = "kdtree/nodes";
  for (size_t i = 0; i < s.kd.nodes.size(); ++i) {
    v.position(Name(N, i, "lo"), s.kd.nodes[i].lo);
    v.position(Name(N, i, "hi"), s.kd.nodes[i].hi);
  }
  const pf_kd_node& root = s.kd.nodes[0];
  float slack = 0.f;
  for (int k = 0; k < 3; ++k) slack = std::max(slack, root.hi[k] - root.lo[k]);
  slack = 1e-4f * slack + 1e-30f;
  auto overlaps = [&](const pf_triangle& t, const pf_kd_node& n) {
    for (int k = 0; k < 3; ++k) {
      const float lo = std::min({t.v0[k], t.v1[k], t.v2[k]});
      const float hi = std::max({t.v0[k], t.v1[k], t.v2[k]});
      if (hi < n.lo[k] - slack || lo > n.hi[k] + slack) return false;
    }
    return true;
  };
  auto inside = [&](const pf_triangle& t, const pf_kd_node& n) {
    for (const float* p : {t.v0, t.v1, t.v2})
      for (int k = 0; k < 3; ++k)
        if (p[k] < n.lo[k] - slack || p[k] > n.hi[k] + slack) return false;
    return true;
  };
  std::vector<uint8_t> listed(s.triangles.size(), 0);
  for (size_t i = 0; i < s.kd.nodes.size(); ++i) {
    const pf_kd_node& n = s.kd.nodes[i];
    if (n.axis != PF_KD_LEAF) continue;
    for (int32_t j = n.first; j < n.first + n.count; ++j) {
      const int32_t t = s.kd.leaf_tris[size_t(j)];
      if (!overlaps(s.triangles[size_t(t)], n))
        v.fail(Validator::element("kdtree/leaf_tris", size_t(j)) + " = " + std::to_string(t) +
               ": the triangle lies outside the box of leaf " + Validator::element(N, i) +
               " (the kd-tree does not match the triangles)");
      listed[size_t(t)] = 1;
    }
  }
  for (size_t i = 0; i < s.triangles.size(); ++i) {
    const pf_triangle& t = s.triangles[i];
    if (!inside(t, root))
      v.fail(Validator::element(T, i) + " lies outside the kd-tree's root box " +
             "(the kd-tree does not match the triangles)");
    const pf_hh_triangle& h = s.hh[i];
    if (!listed[i] && (h.n[0] != 0.f || h.n[1] != 0.f || h.n[2] != 0.f))
      v.fail(Validator::element(T, i) + " is in no kd-tree leaf " +
             "(the kd-tree does not match the triangles)");
  }
}

// The textures of a scene (format version 3, docs/FORMATS.md): the table against the pool and the
// limits, the texels' values, the materials' texture ids, and the UVs where a material has a
// texture. Part of validate_scene: load_scene runs it on what it read, save_scene (written_check)
// on what it writes, bake_scene on what it baked.
bool alpha_textured(const Scene& s);
void check_scene_textures(const Scene& s, const Validator& v) {
  if (s.texture_names.size() != s.textures.size())
    v.fail("textures/names holds " + std::to_string(s.texture_names.size()) +
           " names for " + std::to_string(s.textures.size()) + " textures");
  if (s.texels.size() % 4 != 0) v.fail("textures/texels is not a list of RGBA texels");
  const uint64_t pool = s.texels.size() / 4;
  if (pool > kMaxTextureTexels)
    v.fail("textures/texels holds " + std::to_string(pool) + " texels, more than the " +
           std::to_string(kMaxTextureTexels) + " a scene may have");
  const std::string X = "textures/textures";
  for (size_t i = 0; i < s.textures.size(); ++i) {
    const pf_texture& t = s.textures[i];
    v.int_in_range(Name(X, i, "width"), t.width, 1, kMaxTextureSide);
    v.int_in_range(Name(X, i, "height"), t.height, 1, kMaxTextureSide);
    v.int_in_range(Name(X, i, "offset"), t.offset, 0, int64_t(pool));
    if (uint64_t(t.offset) + uint64_t(t.width) * uint64_t(t.height) > pool)
      v.fail(Validator::element(X, i) + ": its " + std::to_string(t.width) + "x" +
             std::to_string(t.height) + " texels from offset " + std::to_string(t.offset) +
             " run past the " + std::to_string(pool) + " texels of textures/texels");
    v.int_in_range(Name(X, i, "wrap_s"), t.wrap_s, PF_TEX_WRAP_REPEAT, PF_TEX_WRAP_MIRROR);
    v.int_in_range(Name(X, i, "wrap_t"), t.wrap_t, PF_TEX_WRAP_REPEAT, PF_TEX_WRAP_MIRROR);
    v.int_in_range(Name(X, i, "filter"), t.filter, PF_TEX_FILTER_BILINEAR, PF_TEX_FILTER_NEAREST);
  }
  const std::string P = "textures/texels";
  for (size_t i = 0; i < pool; ++i) v.in_range(Name(P, i), &s.texels[4 * i], 4, 0.0, 1.0);
  bool textured = false;
  if (!s.material_texture.empty() && s.material_texture.size() != s.materials.size())
    v.fail("materials/texture holds " + std::to_string(s.material_texture.size()) +
           " entries for " + std::to_string(s.materials.size()) + " materials");
  const std::string M = "materials/texture";
  for (size_t i = 0; i < s.material_texture.size(); ++i) {
    v.int_in_range(Name(M, i), s.material_texture[i], -1, int64_t(s.textures.size()) - 1);
    textured = textured || s.material_texture[i] >= 0;
  }
  // Format version 5: the metallic-roughness textures, in the same table (PF_MAT_PBR only).
  if (!s.material_mr_texture.empty() && s.material_mr_texture.size() != s.materials.size())
    v.fail("materials/metallic_roughness_texture holds " +
           std::to_string(s.material_mr_texture.size()) + " entries for " +
           std::to_string(s.materials.size()) + " materials");
  const std::string R = "materials/metallic_roughness_texture";
  for (size_t i = 0; i < s.material_mr_texture.size(); ++i) {
    const int32_t t = s.material_mr_texture[i];
    v.int_in_range(Name(R, i), t, -1, int64_t(s.textures.size()) - 1);
    if (t >= 0 && s.materials[i].type != PF_MAT_PBR)
      v.fail(Validator::element(R, i) + " = " + std::to_string(t) + " on a material of type " +
             std::to_string(s.materials[i].type) + " (only PF_MAT_PBR, type " +
             std::to_string(PF_MAT_PBR) + ", has a metallic-roughness texture; it must be -1)");
    textured = textured || t >= 0;
  }
  textured = textured || alpha_textured(s);  // a masked material's alpha texture (version 5)
  const std::string U = "geometry/uvs";
  if (!textured && !s.uvs.empty())
    v.fail(U + " is present but no material has a texture");
  if (textured && s.uvs.size() != s.triangles.size())
    v.fail(U + " holds " + std::to_string(s.uvs.size()) + " rows for " +
           std::to_string(s.triangles.size()) + " triangles (a material has a texture)");
  for (size_t i = 0; i < s.uvs.size(); ++i) v.in_range(Name(U, i), s.uvs[i].uv, 6, -kMaxUV, kMaxUV);
}

// The alpha cut-outs of a scene (format version 5, docs/FORMATS.md): one entry per material;
// cutoff exactly −1 (not masked) or in [0, 1]; factor in [0, 1]; texture −1 or a texture of the
// table, and then the UVs (check_scene_textures demands them for it). Part of validate_scene.
void check_scene_alpha(const Scene& s, const Validator& v) {
  if (s.material_alpha.empty()) return;
  if (s.material_alpha.size() != s.materials.size())
    v.fail("materials/alpha_cutoff holds " + std::to_string(s.material_alpha.size()) +
           " entries for " + std::to_string(s.materials.size()) + " materials");
  for (size_t i = 0; i < s.material_alpha.size(); ++i) {
    const pf_alpha_material& a = s.material_alpha[i];
    if (!(a.cutoff == PF_ALPHA_OPAQUE || pf_alpha_cutoff_valid(a.cutoff)))
      v.fail(Validator::element("materials/alpha_cutoff", i) + ": alpha cutoff " +
             std::to_string(a.cutoff) + " is neither -1 (not masked) nor in [0, 1]");
    if (!(a.factor >= 0.f && a.factor <= 1.f))
      v.fail(Validator::element("materials/alpha_factor", i) + ": alpha factor " +
             std::to_string(a.factor) + " is outside [0, 1]");
    v.int_in_range(Name("materials/alpha_texture", i), a.texture, -1,
                   int64_t(s.textures.size()) - 1);
    if (a.pad != 0) v.fail(Validator::element("materials/alpha_texture", i) + ": padding is not 0");
  }
}

// Whether some material's alpha names a texture (then the UVs must be there).
bool alpha_textured(const Scene& s) {
  for (const pf_alpha_material& a : s.material_alpha)
    if (a.texture >= 0) return true;
  return false;
}

}  // namespace


void save_scene(const Scene& s, const std::string& path, const Provenance& prov) {
  // What load_scene will check: validate_scene reads the bounds, which this writer writes too
  // (geometry bounds_lo/hi), so they must be the scene's own already.
  written_check([&] { validate_scene(s, path); });
  h5::Writer w(path, kSceneFormat, kSceneFormatVersion);
  w.attr("/", "scene_id", s.scene_id);
  w.attr("/", "source", s.source);

  w.write("/geometry/triangles", h5_type_triangle(), s.triangles);
  w.describe("/geometry/triangles", "world units",
             "v0..v2 vertices (CCW = front), n0..n2 unit shading normals, mesh and material ids");
  w.write("/geometry/hh", h5_type_hh_triangle(), s.hh);
  w.describe("/geometry/hh", "",
             "Havel-Herout planes (N,d), (N1,d1), (N2,d2) per triangle, thesis eq. 4.3-4.7");
  w.write_strings("/geometry/mesh_names", s.mesh_names);
  w.attr("/geometry", "bounds_lo", std::vector<double>{s.bounds.lo.x, s.bounds.lo.y, s.bounds.lo.z});
  w.attr("/geometry", "bounds_hi", std::vector<double>{s.bounds.hi.x, s.bounds.hi.y, s.bounds.hi.z});

  w.write("/materials/materials", h5_type_material(), s.materials);
  w.describe("/materials/materials", "color: 1, emission: W/(sr m^2), metallic, roughness, "
             "transmission: 1",
             "type 0 diffuse, 1 mirror, 2 glass, 3 emitter, 4 glTF metallic-roughness (PBR); "
             "metallic, roughness (perceptual, alpha = roughness^2), transmission: PBR only, 0 "
             "otherwise");
  w.write_strings("/materials/names", s.material_names);

  // Format version 3: the materials' textures always (−1 = none), the texture datasets and the
  // UVs only where there are textures (written_check above covers them: validate_scene).
  std::vector<int32_t> material_texture = s.material_texture;
  material_texture.resize(s.materials.size(), -1);
  w.write("/materials/texture", material_texture);
  w.describe("/materials/texture", "", "base-colour texture of each material (textures/textures), -1 = none");
  // Format version 5: the metallic-roughness textures always (−1 = none), like materials/texture.
  std::vector<int32_t> mr_texture = s.material_mr_texture;
  mr_texture.resize(s.materials.size(), -1);
  w.write("/materials/metallic_roughness_texture", mr_texture);
  w.describe("/materials/metallic_roughness_texture", "",
             "metallic-roughness texture of each PBR material (textures/textures, linear texels: "
             "B = metallic, G = roughness factors), -1 = none");
  if (!s.textures.empty()) {
    w.write("/textures/textures", h5_type_texture(), s.textures);
    w.describe("/textures/textures", "texels",
               "width, height, offset (texels into textures/texels), wrap_s, wrap_t (0 repeat, 1 "
               "clamp, 2 mirror), filter (0 bilinear, 1 nearest)");
    w.write_strings("/textures/names", s.texture_names);
    w.write("/textures/texels", s.texels, {s.texels.size() / 4, 4});
    w.describe("/textures/texels", "1", "linear RGBA texels of every texture, row-major, row 0 = top");
  }
  if (!s.uvs.empty()) {
    std::vector<float> uv(s.uvs.size() * 6);
    for (size_t i = 0; i < s.uvs.size(); ++i) std::copy(s.uvs[i].uv, s.uvs[i].uv + 6, &uv[6 * i]);
    w.write("/geometry/uvs", uv, {s.uvs.size(), 6});
    w.describe("/geometry/uvs", "1", "u0,v0,u1,v1,u2,v2 per triangle (glTF convention: v down)");
  }

  // Format version 5: alpha cut-outs, only when some material is masked (pf_alpha_material as
  // three datasets, one entry per material).
  if (s.has_alpha_masks()) {
    std::vector<float> cutoff, factor;
    std::vector<int32_t> texture;
    for (const pf_alpha_material& a : s.material_alpha) {
      cutoff.push_back(a.cutoff);
      factor.push_back(a.factor);
      texture.push_back(a.texture);
    }
    w.write("/materials/alpha_cutoff", cutoff);
    w.describe("/materials/alpha_cutoff", "1",
               "alpha cut-out (glTF alphaMode MASK): cut away where alpha < cutoff; -1 = not masked");
    w.write("/materials/alpha_factor", factor);
    w.describe("/materials/alpha_factor", "1", "constant alpha (glTF baseColorFactor.a)");
    w.write("/materials/alpha_texture", texture);
    w.describe("/materials/alpha_texture", "",
               "texture (textures/textures) whose alpha channel multiplies alpha_factor, -1 = none");
  }

  w.write("/lights/lights", h5_type_light(), s.lights);
  w.describe("/lights/lights",
             "area: m^2, power: W (luminance), radiance: W/(sr m^2) (area), W/sr (point, spot) or "
             "W/m^2 (directional), direction: unit, cos_inner/cos_outer: 1",
             "type 0 area (emissive triangle), 1 point, 2 spot, 3 directional (format version 5: "
             "direction, cos_inner, cos_outer; docs/FORMATS.md)");
  w.write("/lights/cdf", s.light_cdf);
  w.describe("/lights/cdf", "1", "cumulative power fraction, sampling lights by power");

  w.write("/camera", h5_type_camera(), &s.camera, 1);
  w.describe("/camera", "world units, degrees, pixels",
             "fov_y_deg vertical; aperture = thin-lens radius (0 = pinhole), focus_distance = "
             "distance of the sharp plane along the view axis");

  w.write("/kdtree/nodes", h5_type_kd_node(), s.kd.nodes);
  w.describe("/kdtree/nodes", "world units",
             "SAH kd-tree with ropes; axis 3 = leaf; ropes[2*axis+side], -1 = outside");
  w.write("/kdtree/leaf_tris", s.kd.leaf_tris);
  w.describe("/kdtree/leaf_tris", "", "triangle indices of leaves: [first, first+count)");
  const KdBuildParams& p = s.kd.params;
  w.attr("/kdtree", "cost_traversal", double(p.cost_traversal));
  w.attr("/kdtree", "cost_intersect", double(p.cost_intersect));
  w.attr("/kdtree", "empty_bonus", double(p.empty_bonus));
  w.attr("/kdtree", "max_depth", int64_t(p.max_depth));
  w.attr("/kdtree", "max_leaf_size", int64_t(p.max_leaf_size));
  w.attr("/kdtree", "depth", int64_t(s.kd.depth));
  w.attr("/kdtree", "build_seconds", s.kd.build_seconds);

  write_provenance(w, prov);
  w.commit();
}

void validate_scene(const Scene& s, const std::string& path) {
  // Consistency: a file that passes these checks cannot make a later stage index out of range,
  // nor compute a non-finite value (validate.h).
  const std::string hint = "the file is damaged; rebake it with scene-bake";
  if (s.hh.size() != s.triangles.size())
    throw input_error(path, "geometry/hh and geometry/triangles differ in length", hint);
  if (s.material_names.size() != s.materials.size())
    throw input_error(path, "materials/names and materials/materials differ in length", hint);
  if (s.light_cdf.size() != s.lights.size())
    throw input_error(path, "lights/cdf and lights/lights differ in length", hint);
  const Validator v(path, hint);
  for (size_t i = 0; i < s.triangles.size(); ++i) {
    const pf_triangle& t = s.triangles[i];
    const auto at = [i] { return Validator::element("geometry/triangles", i); };
    if (t.material < 0 || size_t(t.material) >= s.materials.size())
      v.fail(at() + ": a triangle's material id is out of range (" + std::to_string(t.material) +
             ", the scene has " + std::to_string(s.materials.size()) + " materials)");
    if (t.mesh < 0 || size_t(t.mesh) >= s.mesh_names.size())
      v.fail(at() + ": a triangle's mesh id is out of range (" + std::to_string(t.mesh) +
             ", the scene has " + std::to_string(s.mesh_names.size()) + " meshes)");
  }
  for (size_t i = 0; i < s.materials.size(); ++i)
    if (s.materials[i].type < PF_MAT_DIFFUSE || s.materials[i].type > PF_MAT_PBR)
      v.fail(Validator::element("materials/materials", i) + ": a material has unknown type " +
             std::to_string(s.materials[i].type));
  for (size_t i = 0; i < s.lights.size(); ++i) {
    const pf_light& l = s.lights[i];
    const std::string at = Validator::element("lights/lights", i);
    if (l.type < PF_LIGHT_AREA || l.type > PF_LIGHT_DIRECTIONAL)
      v.fail(at + ": a light has unknown type " + std::to_string(l.type));
    if (l.type == PF_LIGHT_AREA && (l.triangle < 0 || size_t(l.triangle) >= s.triangles.size()))
      v.fail(at + ": an area light's triangle id is out of range (" + std::to_string(l.triangle) +
             ")");
  }
  // The image size sizes every image buffer.
  if (s.camera.width < 1 || s.camera.width > kMaxImageSide || s.camera.height < 1 ||
      s.camera.height > kMaxImageSide)
    throw input_error(path, "camera image size " + std::to_string(s.camera.width) + "x" +
                                std::to_string(s.camera.height) + " is outside 1 … " +
                                std::to_string(kMaxImageSide) + " pixels",
                      hint);
  std::string problem = validate_kdtree(s.kd, s.triangles.size());
  if (!problem.empty()) throw input_error(path, "invalid kd-tree: " + problem, hint);
  check_scene_values(s, v);
  check_scene_alpha(s, v);  // first: the UVs' check counts its textures
  check_scene_textures(s, v);
}

Scene load_scene(const std::string& path) {
  h5::Reader r(path, kSceneFormat, kSceneFormatVersion);
  Scene s;
  s.scene_id = r.scene_id();
  s.source = r.attr_string("/", "source");
  s.triangles = r.read<pf_triangle>("/geometry/triangles", h5_type_triangle());
  s.hh = r.read<pf_hh_triangle>("/geometry/hh", h5_type_hh_triangle());
  s.mesh_names = r.read_strings("/geometry/mesh_names");
  // Format version 5 added the metallic-roughness fields; older files read them as 0.
  s.materials = r.read<pf_material>("/materials/materials",
                                    r.version() >= 5 ? h5_type_material() : h5_type_material_v4());
  s.material_names = r.read_strings("/materials/names");
  // Format version 5 added the spot/directional fields; older lights have them 0 (area, point).
  s.lights = r.read<pf_light>("/lights/lights", r.version() >= 5 ? h5_type_light() : h5_type_light_v4());
  s.light_cdf = r.read<float>("/lights/cdf");
  if (r.count("/camera") != 1) throw input_error(path, "/camera must hold exactly one camera");
  // Format version 4 added the thin lens (aperture, focus_distance); older files are pinholes.
  r.read("/camera", r.version() >= 4 ? h5_type_camera() : h5_type_camera_pinhole(), &s.camera, 1);
  s.kd.nodes = r.read<pf_kd_node>("/kdtree/nodes", h5_type_kd_node());
  s.kd.leaf_tris = r.read<int32_t>("/kdtree/leaf_tris");
  s.kd.params.cost_traversal = float(r.attr_double("/kdtree", "cost_traversal"));
  s.kd.params.cost_intersect = float(r.attr_double("/kdtree", "cost_intersect"));
  s.kd.params.empty_bonus = float(r.attr_double("/kdtree", "empty_bonus"));
  s.kd.params.max_depth = int(r.attr_int("/kdtree", "max_depth"));
  s.kd.params.max_leaf_size = int(r.attr_int("/kdtree", "max_leaf_size"));
  s.kd.depth = int(r.attr_int("/kdtree", "depth"));
  s.kd.build_seconds = r.attr_double("/kdtree", "build_seconds");
  if (r.version() >= 3) {  // textures (versions 1 and 2 have none)
    s.material_texture = r.read<int32_t>("/materials/texture");
    if (r.version() >= 5)
      s.material_mr_texture = r.read<int32_t>("/materials/metallic_roughness_texture");
    const std::vector<std::string> root = r.children("/");
    if (std::find(root.begin(), root.end(), "textures") != root.end()) {
      s.textures = r.read<pf_texture>("/textures/textures", h5_type_texture());
      s.texture_names = r.read_strings("/textures/names");
      const std::vector<size_t> shape = r.shape("/textures/texels");
      s.texels = r.read<float>("/textures/texels", {shape.empty() ? 0 : shape[0], 4});
    }
    const std::vector<std::string> geometry = r.children("/geometry");
    if (std::find(geometry.begin(), geometry.end(), "uvs") != geometry.end()) {
      const std::vector<size_t> shape = r.shape("/geometry/uvs");
      const std::vector<float> uv = r.read<float>("/geometry/uvs", {shape.empty() ? 0 : shape[0], 6});
      s.uvs.resize(uv.size() / 6);
      for (size_t i = 0; i < s.uvs.size(); ++i) std::copy(&uv[6 * i], &uv[6 * i] + 6, s.uvs[i].uv);
    }
  }

  if (r.version() >= 5) {  // alpha cut-outs (versions 1-4: every material opaque)
    const std::vector<std::string> mats = r.children("/materials");
    if (std::find(mats.begin(), mats.end(), "alpha_cutoff") != mats.end()) {
      const std::vector<float> cutoff = r.read<float>("/materials/alpha_cutoff");
      const std::vector<float> factor = r.read<float>("/materials/alpha_factor");
      const std::vector<int32_t> texture = r.read<int32_t>("/materials/alpha_texture");
      if (factor.size() != cutoff.size() || texture.size() != cutoff.size())
        throw input_error(path, "materials/alpha_cutoff, alpha_factor and alpha_texture differ in length",
                          "the file is damaged; rebake it with scene-bake");
      s.material_alpha.resize(cutoff.size());
      for (size_t i = 0; i < cutoff.size(); ++i)
        s.material_alpha[i] = pf_alpha_material{cutoff[i], factor[i], texture[i], 0};
    }
  }

  // Bounds and face normals first (plain arithmetic on any values), then the checks, which
  // read them (validate_scene).
  s.compute_bounds();
  s.compute_normals();
  validate_scene(s, path);
  // No masked material: no alpha table (has_alpha_masks, the rays' fast path).
  bool masked = false;
  for (const pf_alpha_material& a : s.material_alpha) masked = masked || pf_alpha_masked(a.cutoff);
  if (!masked) s.material_alpha.clear();
  s.kd.bounds.lo = Vec3(s.kd.nodes[0].lo);
  s.kd.bounds.hi = Vec3(s.kd.nodes[0].hi);
  // The id names the content: a file edited after baking (or damaged) no longer matches it.
  std::string stored = s.scene_id;
  s.compute_scene_id();
  if (stored != s.scene_id)
    throw input_error(path, "scene_id does not match the scene's content",
                      "the file is damaged; rebake it with scene-bake");
  return s;
}

}  // namespace pf
