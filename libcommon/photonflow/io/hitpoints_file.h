// hitpoints_file.h — hitpoints.h5, format photonflow.hitpoints (docs/FORMATS.md): eye-pass
// hitpoints and their PPM state, plus the emitted and direct image layers (trace-hitpoints
// writes it, illuminate updates it). One of the three stage files; stage_files.h includes it.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "photonflow/geometry/scene.h"
#include "photonflow/stages/eye_pass.h"
#include "photonflow/io/provenance.h"

namespace pf {

// HDF5 record type of pf_pbr_point (hitpoints.h5's /hitpoint_bsdf): fields base_color[3],
// metallic, roughness, transmission, ior (float) and outside (int32).
const h5::Compound& h5_type_pbr_point();

constexpr const char* kHitpointsFormat = "photonflow.hitpoints";

// Hitpoints with their accumulated state.
struct HitpointSet {
  std::vector<pf_hitpoint> hitpoints;
  // The BSDF at each hitpoint (EyePassResult::bsdf): parallel to `hitpoints`, all zero at a
  // hitpoint that is not on a PF_MAT_PBR material; empty when the scene has none. File: the
  // optional dataset /hitpoint_bsdf (docs/FORMATS.md), format version 2.
  std::vector<pf_pbr_point> bsdf;
  std::vector<float> emitted;  // width × height × 3, W/(sr m^2)
  std::vector<float> direct;   // width × height × 3, W/(sr m^2)
  int width = 0, height = 0;
  DirectMode direct_mode = DirectMode::Photons;
  float radius0 = 0.f;           // initial radius R0
  std::string estimator = "none";  // "none" (fresh), "ppm" or "classic"
  uint64_t photons_emitted = 0;  // N_emitted of eq. 3.19, all passes applied so far
  int passes = 0;                // photon passes applied so far (PPM)
  int eye_pass = 0;              // the eye pass the hitpoints came from (EyePassOptions::pass;
                                 // sppm and pppm trace eye pass p for photon pass p)
  std::string scene_id;
};

// The fresh hitpoint state of an eye pass (estimator "none", no photons yet).
HitpointSet make_hitpoint_set(EyePassResult&& eye, DirectMode mode, const std::string& scene_id,
                              int eye_pass = 0);

// save_hitpoints checks the set with validate_hitpoints before it writes (validate.h
// written_check): a hitpoint state a stage writes is one the next stage accepts.
void save_hitpoints(const HitpointSet& h, const std::string& path, const Provenance& prov);
// Reads a hitpoints file (datasets of exactly their shapes and types, h5io.h) and checks it with
// validate_hitpoints.
HitpointSet load_hitpoints(const std::string& path);
// The checks of a hitpoint set's values that load_hitpoints and save_hitpoints apply (below, and
// docs/FORMATS.md): attributes in range, counts that agree with the estimator (photons_emitted a
// count of `passes` passes, validate.h kMaxPhotonsPerPass), image layers, every hitpoint's values (R in [kMinRadius, kMaxRadius]
// for every pixel of an SPPM state too), one hitpoint per pixel for SPPM. InputError naming path.
void validate_hitpoints(const HitpointSet& h, const std::string& path);
// The initial radius R0 of a hitpoints file (attribute radius0) as a length other stages take
// (build-grid's default radius): InputError naming `path` and the attribute unless it is positive
// and finite.
float hitpoints_radius0(const std::string& path, const HitpointSet& h);
// The provenance group of a hitpoints file (the render driver checks a checkpoint's with it).
Provenance load_hitpoints_provenance(const std::string& path);

// check_against_scene (stage_files.h): a hitpoint's mesh (mesh_names) or material (materials)
// outside the scene's tables, or its position far outside the scene's bounds (beyond the bounds
// grown on every side by their largest extent and coordinate magnitude: a surface point lies
// inside them).
void check_against_scene(const std::string& path, const HitpointSet& h, const Scene& scene);

}  // namespace pf
