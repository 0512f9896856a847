// Reading and writing scene.h5 (docs/FORMATS.md): load_scene reads every format version still
// supported, then checks the result (validate_scene) and its scene id; save_scene writes every
// table of a Scene with its description and provenance.
#include "photonflow/geometry/scene_file.h"

#include <algorithm>

#include "photonflow/geometry/scene_validate.h"
#include "photonflow/io/h5_types.h"
#include "photonflow/io/h5io.h"
#include "photonflow/io/validate.h"

namespace pf {

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

  if (r.version() >= 6) {  // the environment light (versions 1-5: none)
    const std::vector<std::string> root = r.children("/");
    if (std::find(root.begin(), root.end(), "environment") != root.end()) {
      const std::vector<size_t> shape = r.shape("/environment/texels");
      // The shape first (a 2:1 map within the bound), so that no damaged file allocates more.
      if (shape.size() != 3 || shape[2] != 3 || shape[1] != 2 * shape[0] ||
          shape[1] > size_t(kMaxEnvironmentWidth) || shape[0] == 0)
        throw input_error(path, "dataset /environment/texels must be H x 2H x 3 with 2H at most " +
                                    std::to_string(kMaxEnvironmentWidth),
                          "the file is damaged; rebake it with scene-bake");
      s.environment.height = int(shape[0]);
      s.environment.width = int(shape[1]);
      s.environment.texels = r.read<float>("/environment/texels", shape);
      s.environment.strength = float(r.attr_double("/environment", "strength"));
      s.environment.rotation_deg = float(r.attr_double("/environment", "rotation_deg"));
      s.environment.source = r.attr_string("/environment", "source");
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
  s.pack_environment_buffer();  // derived: the sampling tables (environment_shared.h)
  s.derive_light_choice();      // derived: NEE's light choice (light_choice_shared.h)
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

  // Format version 6: the environment light, only when there is one.
  if (s.environment.present()) {
    const Environment& e = s.environment;
    w.write("/environment/texels", e.texels, {size_t(e.height), size_t(e.width), 3});
    w.describe("/environment/texels", "W/(sr m^2), before strength",
               "equirectangular RGB radiance, H x 2H x 3, row 0 = the top (v = 0, +y); u = "
               "atan2(d.x, -d.z)/2pi, v = acos(d.y)/pi of the direction turned back by "
               "rotation_deg about +y (docs/SCENES.md)");
    w.attr("/environment", "strength", double(e.strength));
    w.attr("/environment", "rotation_deg", double(e.rotation_deg));
    w.attr("/environment", "source", e.source);
  }

  w.write("/lights/lights", h5_type_light(), s.lights);
  w.describe("/lights/lights",
             "area: m^2, power: W (luminance), radiance: W/(sr m^2) (area), W/sr (point, spot) or "
             "W/m^2 (directional), direction: unit, cos_inner/cos_outer: 1",
             "type 0 area (emissive triangle), 1 point, 2 spot, 3 directional (format version 5: "
             "direction, cos_inner, cos_outer; docs/FORMATS.md), 4 environment (version 6: "
             "/environment; radiance 0, position and area its photons' disc)");
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

}  // namespace pf
