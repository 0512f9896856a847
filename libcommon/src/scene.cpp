// Baked scene: derived data (planes, bounds, lights, identity) and scene.h5 reading/writing.
#include "photonflow/scene.h"

#include <algorithm>
#include <cmath>
#include <cstddef>

#include "photonflow/camera.h"
#include "photonflow/h5io.h"
#include "photonflow/hash.h"

namespace pf {

namespace {
float luminance(const float* c) { return 0.2126f * c[0] + 0.7152f * c[1] + 0.0722f * c[2]; }
constexpr float kPi = 3.14159265358979323846f;
}  // namespace

void Scene::compute_hh() {
  hh.resize(triangles.size());
  for (size_t i = 0; i < triangles.size(); ++i) hh[i] = make_hh_triangle(triangles[i]);
}

void Scene::compute_bounds() {
  bounds = Bounds();
  for (auto& t : triangles) {
    bounds.extend(Vec3(t.v0));
    bounds.extend(Vec3(t.v1));
    bounds.extend(Vec3(t.v2));
  }
}

void Scene::compute_light_cdf() {
  // Keep point lights, rebuild area lights from emitter triangles.
  std::vector<pf_light> kept;
  for (auto& l : lights)
    if (l.type == PF_LIGHT_POINT) kept.push_back(l);
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
  for (auto& l : kept) {
    l.power = 4.f * kPi * luminance(l.radiance);  // isotropic point light: Φ = 4π·I
    lights.push_back(l);
  }
  light_cdf.assign(lights.size(), 0.f);
  double total = 0;
  for (auto& l : lights) total += l.power;
  double acc = 0;
  for (size_t i = 0; i < lights.size(); ++i) {
    acc += lights[i].power;
    light_cdf[i] = total > 0 ? float(acc / total) : float(i + 1) / float(lights.size());
  }
  if (!light_cdf.empty()) light_cdf.back() = 1.f;
}

size_t Scene::pick_light(float u, float& p_light) const {
  size_t i = size_t(std::upper_bound(light_cdf.begin(), light_cdf.end(), u) - light_cdf.begin());
  i = std::min(i, lights.size() - 1);
  p_light = light_cdf[i] - (i ? light_cdf[i - 1] : 0.f);
  return i;
}

void Scene::compute_scene_id() {
  Sha256 h;
  auto feed = [&h](const auto& v) {
    uint64_t n = v.size();
    h.update(&n, sizeof n);
    if (n) h.update(v.data(), n * sizeof(v[0]));
  };
  feed(triangles);
  feed(materials);
  feed(lights);
  h.update(&camera, sizeof camera);
  scene_id = h.hex();
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

const h5::Compound& h5_type_material() {
  static const h5::Compound t = [] {
    h5::Compound c(sizeof(pf_material));
    c.PF_I32(pf_material, type).PF_F32(pf_material, ior, 1);
    c.PF_F32(pf_material, color, 3).PF_F32(pf_material, emission, 3);
    return c;
  }();
  return t;
}

const h5::Compound& h5_type_light() {
  static const h5::Compound t = [] {
    h5::Compound c(sizeof(pf_light));
    c.PF_I32(pf_light, type).PF_I32(pf_light, triangle);
    c.PF_F32(pf_light, area, 1).PF_F32(pf_light, power, 1);
    c.PF_F32(pf_light, position, 3).PF_F32(pf_light, radiance, 3);
    return c;
  }();
  return t;
}

const h5::Compound& h5_type_camera() {
  static const h5::Compound t = [] {
    h5::Compound c(sizeof(pf_camera));
    c.PF_F32(pf_camera, eye, 3).PF_F32(pf_camera, look_at, 3).PF_F32(pf_camera, up, 3);
    c.PF_F32(pf_camera, fov_y_deg, 1).PF_I32(pf_camera, width).PF_I32(pf_camera, height);
    return c;
  }();
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

#undef PF_F32
#undef PF_I32

// ---- scene.h5 -------------------------------------------------------------------------------

void save_scene(const Scene& s, const std::string& path, const Provenance& prov) {
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
  w.describe("/materials/materials", "color: 1, emission: W/(sr m^2)",
             "type 0 diffuse, 1 mirror, 2 glass, 3 emitter");
  w.write_strings("/materials/names", s.material_names);

  w.write("/lights/lights", h5_type_light(), s.lights);
  w.describe("/lights/lights", "area: m^2, power: W (luminance), radiance: W/(sr m^2) or W/sr",
             "type 0 area (emissive triangle), 1 point");
  w.write("/lights/cdf", s.light_cdf);
  w.describe("/lights/cdf", "1", "cumulative power fraction, sampling lights by power");

  w.write("/camera", h5_type_camera(), &s.camera, 1);
  w.describe("/camera", "world units, degrees, pixels", "pinhole camera, fov_y_deg vertical");

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

Scene load_scene(const std::string& path) {
  h5::Reader r(path, kSceneFormat, kSceneFormatVersion);
  Scene s;
  s.scene_id = r.scene_id();
  s.source = r.attr_string("/", "source");
  s.triangles = r.read<pf_triangle>("/geometry/triangles", h5_type_triangle());
  s.hh = r.read<pf_hh_triangle>("/geometry/hh", h5_type_hh_triangle());
  s.mesh_names = r.read_strings("/geometry/mesh_names");
  s.materials = r.read<pf_material>("/materials/materials", h5_type_material());
  s.material_names = r.read_strings("/materials/names");
  s.lights = r.read<pf_light>("/lights/lights", h5_type_light());
  s.light_cdf = r.read<float>("/lights/cdf");
  if (r.count("/camera") != 1) throw input_error(path, "/camera must hold exactly one camera");
  r.read("/camera", h5_type_camera(), &s.camera, 1);
  s.kd.nodes = r.read<pf_kd_node>("/kdtree/nodes", h5_type_kd_node());
  s.kd.leaf_tris = r.read<int32_t>("/kdtree/leaf_tris");
  s.kd.params.cost_traversal = float(r.attr_double("/kdtree", "cost_traversal"));
  s.kd.params.cost_intersect = float(r.attr_double("/kdtree", "cost_intersect"));
  s.kd.params.empty_bonus = float(r.attr_double("/kdtree", "empty_bonus"));
  s.kd.params.max_depth = int(r.attr_int("/kdtree", "max_depth"));
  s.kd.params.max_leaf_size = int(r.attr_int("/kdtree", "max_leaf_size"));
  s.kd.depth = int(r.attr_int("/kdtree", "depth"));
  s.kd.build_seconds = r.attr_double("/kdtree", "build_seconds");

  // Consistency: a file that passes these checks cannot make a later stage index out of range.
  const std::string hint = "the file is damaged; rebake it with scene-bake";
  if (s.hh.size() != s.triangles.size())
    throw input_error(path, "geometry/hh and geometry/triangles differ in length", hint);
  if (s.material_names.size() != s.materials.size())
    throw input_error(path, "materials/names and materials/materials differ in length", hint);
  if (s.light_cdf.size() != s.lights.size())
    throw input_error(path, "lights/cdf and lights/lights differ in length", hint);
  for (auto& t : s.triangles) {
    if (t.material < 0 || size_t(t.material) >= s.materials.size())
      throw input_error(path, "a triangle's material id is out of range", hint);
    if (t.mesh < 0 || size_t(t.mesh) >= s.mesh_names.size())
      throw input_error(path, "a triangle's mesh id is out of range", hint);
  }
  for (auto& m : s.materials)
    if (m.type < PF_MAT_DIFFUSE || m.type > PF_MAT_EMITTER)
      throw input_error(path, "a material has unknown type " + std::to_string(m.type), hint);
  for (auto& l : s.lights) {
    if (l.type != PF_LIGHT_AREA && l.type != PF_LIGHT_POINT)
      throw input_error(path, "a light has unknown type " + std::to_string(l.type), hint);
    if (l.type == PF_LIGHT_AREA && (l.triangle < 0 || size_t(l.triangle) >= s.triangles.size()))
      throw input_error(path, "an area light's triangle id is out of range", hint);
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
  if (!s.kd.nodes.empty()) {
    s.kd.bounds.lo = Vec3(s.kd.nodes[0].lo);
    s.kd.bounds.hi = Vec3(s.kd.nodes[0].hi);
  }
  s.compute_bounds();
  // The id names the content: a file edited after baking (or damaged) no longer matches it.
  std::string stored = s.scene_id;
  s.compute_scene_id();
  if (stored != s.scene_id)
    throw input_error(path, "scene_id does not match the scene's content", hint);
  return s;
}

}  // namespace pf
