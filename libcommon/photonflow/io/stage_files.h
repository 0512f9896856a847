// stage_files.h — the render stages' intermediates (docs/FORMATS.md):
//   hitpoints.h5  photonflow.hitpoints — eye-pass hitpoints and their PPM state, plus the emitted and
//                 direct image layers (trace-hitpoints writes it, illuminate updates it)
//   photons.h5    photonflow.photons   — the photons of one or more consecutive passes
//   grid.h5       photonflow.grid      — per-mesh uniform grids over each pass's photons (eq. 7.1)
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "photonflow/stages/eye_pass.h"
#include "photonflow/stages/photon_grid.h"
#include "photonflow/io/provenance.h"

namespace pf {

namespace h5 {
class Compound;
}
struct Scene;  // scene.h

// HDF5 record type of pf_mesh_grid (grid.h5's mesh_grid; photon_distribution.h5).
const h5::Compound& h5_type_mesh_grid();
// HDF5 record type of pf_pbr_point (hitpoints.h5's /hitpoint_bsdf): fields base_color[3],
// metallic, roughness, transmission, ior (float) and outside (int32).
const h5::Compound& h5_type_pbr_point();

constexpr const char* kHitpointsFormat = "photonflow.hitpoints";
constexpr const char* kPhotonsFormat = "photonflow.photons";
constexpr const char* kGridFormat = "photonflow.grid";

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

// One or more consecutive photon passes.
struct PhotonSet {
  std::vector<pf_photon> photons;       // all passes, in pass order
  int first_pass = 0;                   // pass index of pass_begin[0]
  std::vector<uint64_t> pass_begin;     // index of each pass's first photon; one past the end last
  std::vector<uint64_t> pass_emitted;   // photons emitted in each pass
  uint32_t seed = 0;
  std::string scene_id;
  int pass_count() const { return int(pass_emitted.size()); }
  // Appends the next pass (index first_pass + pass_count()) as traced: its photons, its
  // pass_begin entry (the leading 0 too, on an empty set) and its photons emitted.
  void append_pass(const std::vector<pf_photon>& pass_photons, uint64_t emitted) {
    if (pass_begin.empty()) pass_begin.push_back(0);
    photons.insert(photons.end(), pass_photons.begin(), pass_photons.end());
    pass_begin.push_back(photons.size());
    pass_emitted.push_back(emitted);
  }
  // Photons of the k-th pass of the set (k from 0).
  std::vector<pf_photon> pass(int k) const {
    return {photons.begin() + long(pass_begin[size_t(k)]),
            photons.begin() + long(pass_begin[size_t(k) + 1])};
  }
};

// Per-pass photon grids.
struct GridSet {
  std::vector<PhotonGrid> grids;  // one per pass, in pass order
  int first_pass = 0;
  std::vector<uint64_t> pass_emitted;
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
Provenance load_photons_provenance(const std::string& path);
// The writers check what they write with the readers' checks (validate.h written_check).
void save_photons(const PhotonSet& p, const std::string& path, const Provenance& prov);
PhotonSet load_photons(const std::string& path);
void save_grids(const GridSet& g, const std::string& path, const Provenance& prov);
GridSet load_grids(const std::string& path);
// The checks of load_photons and load_grids on what they read (and of save_photons and save_grids
// on what they write): the pass table, pass indices, pass_emitted (validate.h
// kMaxPhotonsPerPass), every photon's values; for grids also the layout build_photon_grid makes
// (eq. 7.1 headers, cell_start, order, each photon in its bin). InputError naming `path`.
void validate_photons(const PhotonSet& p, const std::string& path);
void validate_grids(const GridSet& g, const std::string& path);

// The loaders check everything a file holds on its own: array lengths, the pass table, every
// index into the file's own arrays (pixels, bins, cell_start, order), finite positions, and
// attributes that must fit an int (passes, first_pass, image size). Indices into the SCENE's
// tables (a hitpoint's mesh and material, a photon's mesh, a grid's mesh count) can only be
// checked against the scene: check_against_scene does it, and accept_input calls it wherever a
// stage file meets its scene. Either throws InputError, one line naming `path`.

// Throws InputError (one line naming `path`) unless scene_id equals `expected` (the scene's).
void require_scene(const std::string& path, const std::string& scene_id,
                   const std::string& expected, const std::string& scene_path);

// Throws InputError naming `path` when the set indexes outside the scene's tables: a hitpoint's
// mesh (mesh_names) or material (materials), a photon's mesh, a grid set's mesh count (one
// mesh_grid per scene mesh) or one of its photons' meshes; and when a hitpoint's position lies far
// outside the scene's bounds (beyond the bounds grown on every side by their largest extent and
// coordinate magnitude: a surface point lies inside them).
void check_against_scene(const std::string& path, const HitpointSet& h, const Scene& scene);
void check_against_scene(const std::string& path, const PhotonSet& p, const Scene& scene);
void check_against_scene(const std::string& path, const GridSet& g, const Scene& scene);

// A stage's input set loaded from `path` meets the scene loaded from scene_path: refused unless
// made from that scene (require_scene) and its indices lie in the scene's tables
// (check_against_scene); then recorded in prov under `role` (hashed; InputError when unreadable).
void accept_input(Provenance& prov, const std::string& role, const std::string& path,
                  const HitpointSet& h, const Scene& scene, const std::string& scene_path);
void accept_input(Provenance& prov, const std::string& role, const std::string& path,
                  const PhotonSet& p, const Scene& scene, const std::string& scene_path);
void accept_input(Provenance& prov, const std::string& role, const std::string& path,
                  const GridSet& g, const Scene& scene, const std::string& scene_path);

}  // namespace pf
