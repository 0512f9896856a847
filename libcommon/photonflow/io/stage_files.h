// stage_files.h — the render stages' intermediates (docs/FORMATS.md), one header per format:
//   hitpoints.h5  photonflow.hitpoints — eye-pass hitpoints and their PPM state, plus the emitted
//                 and direct image layers (trace-hitpoints writes it, illuminate updates it):
//                 hitpoints_file.h
//   photons.h5    photonflow.photons   — the photons of one or more consecutive passes:
//                 photons_file.h
//   grid.h5       photonflow.grid      — per-mesh uniform grids over each pass's photons
//                 (eq. 7.1): grid_file.h
// This header includes the three and says what every stage file meets where it meets its scene.
#pragma once
#include <string>

#include "photonflow/io/grid_file.h"
#include "photonflow/io/hitpoints_file.h"
#include "photonflow/io/photons_file.h"
#include "photonflow/io/provenance.h"

namespace pf {

// The loaders check everything a file holds on its own: array lengths, the pass table, every
// index into the file's own arrays (pixels, bins, cell_start, order), finite positions, and
// attributes that must fit an int (passes, first_pass, image size). Indices into the SCENE's
// tables (a hitpoint's mesh and material, a photon's mesh, a grid's mesh count) can only be
// checked against the scene: check_against_scene does it, and accept_input calls it wherever a
// stage file meets its scene. Either throws InputError, one line naming `path`.

// Throws InputError (one line naming `path`) unless scene_id equals `expected` (the scene's).
void require_scene(const std::string& path, const std::string& scene_id,
                   const std::string& expected, const std::string& scene_path);

// check_against_scene(path, set, scene), one per format (its header says what it checks):
// throws InputError naming `path` when the set indexes outside the scene's tables.

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
