// The checks of a baked scene (validate_scene): table lengths, every index, material and light
// types, the camera, the kd-tree against the triangles, every value in range, the textures and the
// alpha cut-outs. load_scene runs them on what it read, save_scene on what it writes, bake_scene on
// what it baked, so a scene that passes cannot make a later stage index out of range.
#include "photonflow/geometry/scene_validate.h"

#include <algorithm>
#include <cmath>

#include "photonflow/geometry/camera.h"
#include "photonflow/io/validate.h"

namespace pf {

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
  if (l.type == PF_LIGHT_AREA || l.type == PF_LIGHT_POINT || l.type == PF_LIGHT_ENVIRONMENT) {
    if (!zero)
      v.fail(at + ": an area, point or environment light has a direction or cone (direction " + vec_text(f) +
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
             (l.type == PF_LIGHT_POINT         ? "point"
              : l.type == PF_LIGHT_ENVIRONMENT ? "environment"
                                               : "spot or directional") + " light is " +
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
  derive_lights(s.triangles, s.materials, s.lights, lights, cdf, &s.environment);
  if (lights.size() != s.lights.size())
    v.fail(L + " holds " + std::to_string(s.lights.size()) + " lights, the emitter triangles and "
           "point lights and the environment give " + std::to_string(lights.size()));
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
              : b.type == PF_LIGHT_ENVIRONMENT ? "map and the scene's bounds give"
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
    if (l.type < PF_LIGHT_AREA || l.type > PF_LIGHT_ENVIRONMENT)
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
  // The environment (format version 6): its map's shape and values (environment.h), before the
  // lights are compared with the ones it gives.
  if (s.environment.present() || !s.environment.texels.empty())
    check_environment(s.environment, path, "environment/texels");
  std::string problem = validate_kdtree(s.kd, s.triangles.size());
  if (!problem.empty()) throw input_error(path, "invalid kd-tree: " + problem, hint);
  check_scene_values(s, v);
  check_scene_alpha(s, v);  // first: the UVs' check counts its textures
  check_scene_textures(s, v);
}

}  // namespace pf
