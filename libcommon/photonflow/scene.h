// scene.h — a baked scene: what scene-bake writes to scene.h5 and every later stage reads.
#pragma once
#include <algorithm>
#include <string>
#include <vector>

#include "photonflow/kdtree.h"
#include "photonflow/provenance.h"
#include "photonflow/shared_types.h"
#include "photonflow/vec.h"

namespace pf {

constexpr const char* kSceneFormat = "photonflow.scene";
constexpr int kSceneFormatVersion = 2;  // 2: names as fixed-length strings (1: variable-length, still read)

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
  pf_camera camera{};
  KdTree kd;
  Bounds bounds;                   // of all triangles
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
  // already in lights[] (kept), sampled in proportion to power.
  void compute_light_cdf();
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
  // scene_id = SHA-256 over triangles, materials, lights and camera: two bakes of the same input
  // with the same options have the same id; any change of geometry, material, light or camera
  // changes it.
  void compute_scene_id();
};

// Derives everything a baked scene holds beyond triangles, materials, mesh/material names, point
// lights and camera: Havel–Herout planes, bounds, area lights and their CDF, the kd-tree and the
// scene id. scene-bake calls it after importing; tests call it on scenes built in memory.
void finish_scene(Scene& scene, const KdBuildParams& kd = {});

// The lights and their CDF that compute_light_cdf makes from triangles, materials and the point
// lights among `given` (kept in their order): area lights of emitter triangles first, in triangle
// order, then the point lights; load_scene compares a file's lights and CDF with them.
void derive_lights(const std::vector<pf_triangle>& triangles,
                   const std::vector<pf_material>& materials, const std::vector<pf_light>& given,
                   std::vector<pf_light>& lights, std::vector<float>& cdf);

// Havel–Herout precomputation for one triangle (thesis eq. 4.3–4.7).
pf_hh_triangle make_hh_triangle(const pf_triangle& t);

// Writes scene.h5 (atomically) with provenance; see docs/FORMATS.md.
void save_scene(const Scene& scene, const std::string& path, const Provenance& prov);
// Reads and checks scene.h5 (format, version, array consistency, kd-tree structure).
Scene load_scene(const std::string& path);
// The checks load_scene applies to a scene's tables and values (validate.h): table lengths, every
// index into them, material and light types, the camera's image size, the kd-tree, every value in
// range. `s` must have its bounds and face normals computed. save_scene applies them to what it
// writes (written_check) and bake_scene to what it baked (InputError naming the source: a
// coordinate or camera option beyond kMaxCoordinate). InputError naming `path`.
void validate_scene(const Scene& s, const std::string& path);

// HDF5 compound types of the shared structs (named fields for h5dump/h5py).
namespace h5 { class Compound; }
const h5::Compound& h5_type_triangle();
const h5::Compound& h5_type_hh_triangle();
const h5::Compound& h5_type_material();
const h5::Compound& h5_type_light();
const h5::Compound& h5_type_camera();
const h5::Compound& h5_type_kd_node();
const h5::Compound& h5_type_hitpoint();
const h5::Compound& h5_type_photon();

}  // namespace pf
