// grid_file.h — grid.h5, format photonflow.grid (docs/FORMATS.md): per-mesh uniform grids over
// each pass's photons (eq. 7.1; build-grid writes it). One of the three stage files;
// stage_files.h includes it.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "photonflow/stages/photon_grid.h"
#include "photonflow/io/provenance.h"

namespace pf {

namespace h5 {
class Compound;
}
struct Scene;  // scene.h

// HDF5 record type of pf_mesh_grid (grid.h5's mesh_grid; photon_distribution.h5).
const h5::Compound& h5_type_mesh_grid();

constexpr const char* kGridFormat = "photonflow.grid";

// Per-pass photon grids.
struct GridSet {
  std::vector<PhotonGrid> grids;  // one per pass, in pass order
  int first_pass = 0;
  std::vector<uint64_t> pass_emitted;
  std::string scene_id;
};

// The writers check what they write with the readers' checks (validate.h written_check).
void save_grids(const GridSet& g, const std::string& path, const Provenance& prov);
GridSet load_grids(const std::string& path);
// The checks of load_grids on what it reads (and of save_grids on what it writes): the pass
// table, pass indices, pass_emitted (validate.h kMaxPhotonsPerPass), every photon's values, and
// the layout build_photon_grid makes (eq. 7.1 headers, cell_start, order, each photon in its
// bin). InputError naming `path`.
void validate_grids(const GridSet& g, const std::string& path);

// check_against_scene (stage_files.h): a grid set's mesh count (one mesh_grid per scene mesh)
// or one of its photons' meshes outside the scene's.
void check_against_scene(const std::string& path, const GridSet& g, const Scene& scene);

}  // namespace pf
