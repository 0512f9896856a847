// scene.h — a baked scene: what scene-bake writes to scene.h5 and every later stage reads.
#pragma once
#include <string>
#include <vector>

#include "photonflow/kdtree.h"
#include "photonflow/provenance.h"
#include "photonflow/shared_types.h"
#include "photonflow/vec.h"

namespace pf {

constexpr const char* kSceneFormat = "photonflow.scene";
constexpr int kSceneFormatVersion = 2;  // 2: names as fixed-length strings (1: variable-length, still read)

struct Scene {
  std::vector<pf_triangle> triangles;
  std::vector<pf_hh_triangle> hh;  // Havel–Herout planes, one per triangle (thesis eq. 4.3)
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

  // Precomputes hh[] from triangles[] (thesis eq. 4.3–4.7).
  void compute_hh();
  // Recomputes bounds from triangles.
  void compute_bounds();
  // Builds lights[] and light_cdf[] from emissive triangles (area lights) plus point lights
  // already in lights[] (kept), sampled in proportion to power.
  void compute_light_cdf();
  // Picks a light in proportion to power for a uniform u in [0, 1): the first i with
  // u < light_cdf[i]. Sets p_light to its probability. The scene must have lights.
  size_t pick_light(float u, float& p_light) const;
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
