// scene.h — a baked scene: what scene-bake writes to scene.h5 and every later stage reads.
#pragma once
#include <algorithm>
#include <string>
#include <vector>

#include "photonflow/geometry/environment.h"
#include "photonflow/geometry/kdtree.h"
#include "photonflow/geometry/light_choice_shared.h"
#include "photonflow/material/alpha_shared.h"
#include "photonflow/material/texture_shared.h"
#include "photonflow/foundations/shared_types.h"
#include "photonflow/foundations/vec.h"

namespace pf {

constexpr const char* kSceneFormat = "photonflow.scene";
// 6: the environment light (/environment: texels, strength, rotation; a PF_LIGHT_ENVIRONMENT
// light last in lights; only in a scene baked with --environment, so a scene without one differs
// from version 5 in its version number alone); 5: metallic-roughness materials (PF_MAT_PBR; materials metallic, roughness, transmission;
// materials/metallic_roughness_texture), alpha cut-outs (materials/alpha_cutoff, alpha_factor,
// alpha_texture; only when some material is masked) and spot and directional lights (lights
// direction, cos_inner, cos_outer); 4: the thin-lens camera (camera aperture, focus_distance);
// 3: base-colour textures (textures/*, materials/texture, geometry/uvs); 2: names as fixed-length
// strings; 1: variable-length names. Versions 1 to 4 are still read (no PBR fields: read as 0;
// opaque; lights all area or point through h5_type_light_v4; versions 1-3 a pinhole camera;
// versions 1 and 2 without textures; versions 1 to 5 without an environment).
constexpr int kSceneFormatVersion = 6;

// A directional light's emitting disc lies this many bounding-sphere radii before the bounds'
// centre, against the light (> 1: outside the bounds; derive_lights).
constexpr float kDirectionalDiscMargin = 1.01f;

// Largest side of a texture, and most texels of all of a scene's textures together (each texel is
// 4 floats: 2^26 texels are 1 GiB in memory and in scene.h5). scene-bake refuses a larger image,
// load_scene a larger table.
constexpr int kMaxTextureSide = 16384;
constexpr uint64_t kMaxTextureTexels = uint64_t(1) << 26;
// Largest magnitude of a texture coordinate (repeat and mirror keep any value in the texture;
// this keeps a float's fraction meaningful).
constexpr float kMaxUV = 1e6f;

// Texture coordinates of a triangle's three corners in the glTF convention (texture_shared.h:
// (0, 0) the top-left of the image, v down), in the order v0, v1, v2 of its pf_triangle.
struct TriangleUV {
  float uv[6];  // u0, v0, u1, v1, u2, v2
};

// Unit geometric normal of a triangle; its front is the side from which v0, v1, v2 run
// counter-clockwise.
inline Vec3 face_normal(const pf_triangle& t) {
  return normalize(cross(Vec3(t.v1) - Vec3(t.v0), Vec3(t.v2) - Vec3(t.v0)));
}

struct Scene {
  std::vector<pf_triangle> triangles;
  std::vector<pf_hh_triangle> hh;  // Havel–Herout planes, one per triangle (thesis eq. 4.3)
  std::vector<Vec3> normals;       // face_normal of every triangle, derived (not in scene.h5)
  std::vector<std::string> mesh_names;
  std::vector<pf_material> materials;
  std::vector<std::string> material_names;
  std::vector<pf_light> lights;
  std::vector<float> light_cdf;    // cumulative power, light_cdf.back() == 1 (sampling by power)
  // Next-event estimation's light choice (light_choice_shared.h): one entry per light where the
  // local choice applies, empty for the power choice. Derived (derive_light_choice, by
  // compute_light_cdf and load_scene; not serialised).
  std::vector<pf_light_choice> light_choice;
  pf_camera camera{};
  KdTree kd;
  Bounds bounds;                   // of all triangles
  // Derived data of --gather-area surface (estimators/gather_area.h, surface_area), built on
  // first use and keyed on triangles[]; not serialised, and copies start without it.
  KdHostCache gather_area_cache;
  // Base-colour textures (format version 3): headers over one pool of linear RGBA texels (4 floats
  // each; a texture used by several materials is stored once), each material's texture (−1 none;
  // empty = none for every material) and, when some material has one, every triangle's UVs.
  std::vector<pf_texture> textures;
  std::vector<float> texels;
  std::vector<std::string> texture_names;  // the image file, or "<scene>#<n>" for embedded ones
  std::vector<int32_t> material_texture;
  std::vector<TriangleUV> uvs;
  // Metallic-roughness textures (format version 5; glTF metallicRoughnessTexture: B = metallic,
  // G = roughness, linear): each material's texture in the same table as the base-colour ones
  // (−1 none; empty = none for every material). Read only for PF_MAT_PBR materials (validate_scene
  // refuses one on another type). Its texels are stored linear (not sRGB-decoded): an image used
  // as colour and as metallic-roughness is two textures.
  std::vector<int32_t> material_mr_texture;
  // Alpha cut-outs (format version 5; alpha_shared.h): one entry per material (cutoff −1 = not
  // masked), or empty when no material is masked (the rays' fast path: no alpha test at all).
  // A masked material's alpha texture needs uvs, like a base-colour texture.
  std::vector<pf_alpha_material> material_alpha;
  // The environment light (format version 6; environment.h): the map, or !present() for none;
  // with one, lights holds a PF_LIGHT_ENVIRONMENT light last (derive_lights). env_packed is
  // derived (pack_environment, by compute_light_cdf and load_scene; not serialised): the buffer
  // the shared sampling reads (environment_shared.h), the header alone without an environment.
  Environment environment;
  std::vector<float> env_packed;
  std::string scene_id;            // SHA-256 of the baked content (see compute_scene_id)
  std::string source;              // path of the file it was baked from

  // Precomputes hh[] (thesis eq. 4.3–4.7) and normals[] from triangles[].
  void compute_hh();
  // Recomputes normals[] from triangles[] (load_scene: the file holds hh[] but not these).
  void compute_normals();
  // face_normal of triangle `tri`: precomputed (every hit of every ray asks; it saves a cross
  // product, a square root and three divisions per hit), or computed when triangles[] has
  // changed size since (the same expression, so the same bits either way).
  Vec3 normal_of(size_t tri) const {
    return normals.size() == triangles.size() ? normals[tri] : face_normal(triangles[tri]);
  }
  // Recomputes bounds from triangles.
  void compute_bounds();
  // Builds lights[] and light_cdf[] from emissive triangles (area lights) plus point lights
  // already in lights[] (kept) and the environment, sampled in proportion to power; then
  // env_packed (pack_environment_buffer).
  void compute_light_cdf();
  // env_packed from environment, bounds, lights and light_cdf.
  void pack_environment_buffer();
  // light_choice from lights, light_cdf and triangles: the local choice (light_choice_shared.h
  // eq. 1) in a scene of 2 to PF_LIGHT_CHOICE_MAX lights with at least two emitters (area lights
  // grouped by material, every other light its own), else empty (the power choice).
  void derive_light_choice();
  // The packed environment buffer for the shared functions (environment_shared.h), never null
  // once compute_light_cdf or load_scene ran (the header alone, width 0, without an environment).
  const float* env_data() const { return env_packed.empty() ? kNoEnvironment : env_packed.data(); }
  static const float kNoEnvironment[16];  // PF_ENV_HEADER zeros, light −1
  // For the eye pass (and any ray that leaves the scene): the radiance the environment sends
  // along the unit direction d of an escaping ray (pf_env_radiance: texel-constant × strength;
  // 0 without an environment), and the density with which next-event estimation (sample_light)
  // draws d, per unit solid angle, including the environment's pick probability
  // (pf_env_light_pdf), for weighing an escaping BSDF sample against NEE by MIS.
  Vec3 environment_radiance(const Vec3& d) const;
  float environment_light_pdf(const Vec3& d) const;
  // The same density for NEE at point x, with x's light choice (light_pick_probability).
  float environment_light_pdf(const Vec3& d, const Vec3& x) const;
  // The probability that next-event estimation at x picks light li (sample_light's choice): its
  // power share, or p_l(x) of light_choice_shared.h eq. 1 where light_choice is not empty.
  float light_pick_probability(size_t li, const Vec3& x) const;
  // p_l(x) of every light into pr[0 .. lights.size()) (light_choice_shared.h eq. 1); only where
  // light_choice is not empty.
  void light_choice_at(const Vec3& x, float* pr) const;
  // One next-event sample of light `li` at point p from two uniform numbers (light_shared.h
  // pf_light_incident, the one sampling of every light type for host and kernels): writes w (unit,
  // p → light) and q (the shadow ray's end) and returns G, with L_direct ≈ L_e·f·|cos θ_x|·G /
  // p_light; 0 when the light sends nothing to p. The environment (PF_LIGHT_ENVIRONMENT):
  // pf_env_incident (environment_shared.h), G = 1/pdf_ω, q beyond the scene's bounding sphere.
  // le (optional): the radiance arriving along w — the light's `radiance` for every type but the
  // environment, whose radiance is the map's along w.
  float light_incident(size_t li, const Vec3& p, float u1, float u2, Vec3& w, Vec3& q,
                       Vec3* le = nullptr) const;
  // True when area light li's point for (u1, u2) (sample_triangle's) lies on a cut-away texel of
  // its alpha-masked material (pf_alpha_light_point_cut_away): no light leaves it, so
  // light_incident gives 0 there and photon emission sends nothing. False in a scene without
  // masks and for other light types.
  bool light_point_cut_away(size_t li, float u1, float u2) const;
  // One next-event light sample at p from three uniform numbers: the light picked by ul (in
  // proportion to power, pick_light, or by p's local choice where light_choice is not empty;
  // light_pick_probability), then its light_incident (u1, u2). False when the scene has no
  // light, the pick's probability is 0 or the light sends nothing to p (G = 0).
  struct LightSample {
    size_t light = 0;
    float p_light = 0.f;  // the pick's probability
    float g = 0.f;        // light_incident's G
    Vec3 w, q;            // unit direction to the light, the shadow ray's end
    Vec3 le;              // radiance arriving along w (light_incident's le): multiply by this,
                          // not by lights[light].radiance, which is 0 for the environment
  };
  bool sample_light(float ul, float u1, float u2, const Vec3& p, LightSample& s) const;
  // Picks a light in proportion to power for a uniform u in [0, 1): the first i with
  // u < light_cdf[i]. Sets p_light to its probability. The scene must have lights.
  size_t pick_light(float u, float& p_light) const {
    // Every photon asks, and scenes have few lights: a linear scan (the same index as a binary
    // search) up to 8 of them.
    size_t i = 0;
    const size_t n = light_cdf.size();
    if (n <= 8) {
      while (i < n && !(u < light_cdf[i])) ++i;
    } else {
      i = pick_light_search(u);
    }
    i = std::min(i, lights.size() - 1);
    p_light = light_cdf[i] - (i ? light_cdf[i - 1] : 0.f);
    return i;
  }
  size_t pick_light_search(float u) const;  // upper_bound over light_cdf
  // True when the ray casters test alpha (raycast.cpp, kernels): material_alpha is not empty.
  // load_scene and the importer leave it empty when no material is masked; a table without a
  // masked entry (a scene built in memory) gives the same hits, only through the slower path.
  bool has_alpha_masks() const { return !material_alpha.empty(); }
  // Base-colour texture of material `material`, −1 for none.
  int texture_of(int material) const {
    return size_t(material) < material_texture.size() ? material_texture[size_t(material)] : -1;
  }
  // Metallic-roughness texture of material `material`, −1 for none.
  int mr_texture_of(int material) const {
    return size_t(material) < material_mr_texture.size() ? material_mr_texture[size_t(material)]
                                                         : -1;
  }
  // Whether some material is PF_MAT_PBR (format version 5): the scene id covers the
  // metallic-roughness fields and materials/metallic_roughness_texture only then, and only then
  // do the eye passes keep a pf_pbr_point per hitpoint (EyePassResult::bsdf, HitpointSet::bsdf).
  bool has_pbr() const {
    return std::any_of(materials.begin(), materials.end(),
                       [](const pf_material& m) { return m.type == PF_MAT_PBR; });
  }
  // The texture factor of a diffuse colour at barycentrics (u, v) (weights of v1 and v2, as Hit
  // gives them) of triangle `tri`, whose material's texture is `texture` (≥ 0): the bilinear texel
  // value (texture_shared.h) at the interpolated UV, RGB. Needs uvs (load_scene ensures it).
  Vec3 texture_value(int texture, size_t tri, float u, float v) const;
  // scene_id = SHA-256 over triangles, materials, lights and camera: two bakes of the same input
  // with the same options have the same id; any change of geometry, material, light or camera
  // changes it. With textures, also over the texture table, texels, the materials' textures and
  // the UVs (a scene without textures keeps the id of format version 2). With a masked material,
  // also over material_alpha (a scene without masks keeps the id of format version 4).
  void compute_scene_id();
};

// Derives everything a baked scene holds beyond triangles, materials, mesh/material names, point
// lights and camera: Havel–Herout planes, bounds, area lights and their CDF, the kd-tree and the
// scene id. scene-bake calls it after importing; tests call it on scenes built in memory.
void finish_scene(Scene& scene, const KdBuildParams& kd = {});

// The lights and their CDF that compute_light_cdf makes from triangles, materials and the point,
// spot and directional lights among `given` (kept in their order): area lights of emitter
// triangles first, in triangle order, then the others, their power derived (a directional light's
// disc too, from the triangles' bounds: shared_types.h); load_scene compares a file's lights and
// CDF with them.
// With an environment (env present), a PF_LIGHT_ENVIRONMENT light comes last: position the
// bounding sphere's centre, area π·R², power π·R²·∫ L dω (environment_luminance_integral).
void derive_lights(const std::vector<pf_triangle>& triangles,
                   const std::vector<pf_material>& materials, const std::vector<pf_light>& given,
                   std::vector<pf_light>& lights, std::vector<float>& cdf,
                   const Environment* env = nullptr);

// Havel–Herout precomputation for one triangle (thesis eq. 4.3–4.7).
pf_hh_triangle make_hh_triangle(const pf_triangle& t);

// The diffuse colour of material m (index `material`) at a hit on triangle `tri` with barycentrics
// (u, v): m.color, times the base-colour texture's value there when the material has one (glTF's
// baseColorFactor × baseColorTexture). The photon bounces and the path tracer ask this; the eye
// pass multiplies the texture's value alone (texture_value) into the hitpoint's weight, so that
// the gathers' f_r = color/π times the weight, and the shadow-ray direct light, are textured. A
// material without texture costs one table look-up more than reading m.color.
inline Vec3 diffuse_color(const Scene& s, const pf_material& m, int material, int tri, float u,
                          float v) {
  const int t = s.texture_of(material);
  if (t < 0) return Vec3(m.color);
  return Vec3(m.color) * s.texture_value(t, size_t(tri), u, v);
}

}  // namespace pf
