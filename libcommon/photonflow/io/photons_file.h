// photons_file.h — photons.h5, format photonflow.photons (docs/FORMATS.md): the photons of one or
// more consecutive passes (trace-photons writes it). One of the three stage files; stage_files.h
// includes it.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "photonflow/foundations/shared_types.h"
#include "photonflow/io/provenance.h"

namespace pf {

struct Scene;  // scene.h

constexpr const char* kPhotonsFormat = "photonflow.photons";

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

Provenance load_photons_provenance(const std::string& path);
// The writers check what they write with the readers' checks (validate.h written_check).
void save_photons(const PhotonSet& p, const std::string& path, const Provenance& prov);
PhotonSet load_photons(const std::string& path);
// The checks of load_photons on what it reads (and of save_photons on what it writes): the pass
// table, pass indices, pass_emitted (validate.h kMaxPhotonsPerPass), every photon's values.
// InputError naming `path`.
void validate_photons(const PhotonSet& p, const std::string& path);

// check_against_scene (stage_files.h): a photon's mesh outside the scene's mesh_names.
void check_against_scene(const std::string& path, const PhotonSet& p, const Scene& scene);

}  // namespace pf
