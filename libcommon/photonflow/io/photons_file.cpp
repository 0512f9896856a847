// photons_file.cpp — photons.h5 (photons_file.h): the photon passes' writing, reading and checks,
// on their own and against their scene.
#include "photonflow/io/photons_file.h"

#include <limits>
#include <string>

#include "photonflow/io/h5io.h"
#include "photonflow/geometry/scene.h"
#include "photonflow/io/h5_types.h"
#include "photonflow/io/stage_file_checks.h"
#include "photonflow/io/validate.h"
#include "photonflow/stages/photon_pass.h"

namespace pf {

namespace {
constexpr int kPhotonsVersion = 1;
}  // namespace

void save_photons(const PhotonSet& p, const std::string& path, const Provenance& prov) {
  written_check([&] { validate_photons(p, path); });
  h5::Writer w(path, kPhotonsFormat, kPhotonsVersion);
  w.attr("/", "scene_id", p.scene_id);
  w.attr("/", "first_pass", int64_t(p.first_pass));
  w.attr("/", "seed", int64_t(p.seed));
  w.write("/photons", h5_type_photon(), p.photons);
  w.describe("/photons", "world units; flux W (divide by photons emitted)",
             "photons stored at diffuse hits: the global map; flags 1 = caustic (L S+ D), "
             "2 = direct (L D)");
  std::vector<pf_photon> caustic;
  for (auto& ph : p.photons)
    if (ph.flags & PF_PHOTON_CAUSTIC) caustic.push_back(ph);
  w.write("/caustic", h5_type_photon(), caustic);
  w.describe("/caustic", "as /photons", "the caustic map: photons of L S+ D paths only");
  w.write("/pass_begin", p.pass_begin);
  w.describe("/pass_begin", "", "index in /photons of each pass's first photon, then the end");
  w.write("/pass_emitted", p.pass_emitted);
  w.describe("/pass_emitted", "photons", "photons emitted in each pass");
  write_provenance(w, prov);
  w.commit();
}

Provenance load_photons_provenance(const std::string& path) {
  return read_provenance(h5::Reader(path, kPhotonsFormat, kPhotonsVersion));
}

PhotonSet load_photons(const std::string& path) {
  h5::Reader r(path, kPhotonsFormat, kPhotonsVersion);
  const std::string hint = "the file is damaged; remake it with trace-photons";
  PhotonSet p;
  p.scene_id = r.scene_id();
  p.seed = uint32_t(attr_in(r, path, "/", "seed", 0, std::numeric_limits<uint32_t>::max(), hint));
  p.photons = r.read<pf_photon>("/photons", h5_type_photon());
  p.pass_begin = r.read<uint64_t>("/pass_begin");
  p.pass_emitted = r.read<uint64_t>("/pass_emitted");
  p.first_pass = check_first_pass(r, path, p.pass_emitted.size(), hint);
  validate_photons(p, path);
  return p;
}

void validate_photons(const PhotonSet& p, const std::string& path) {
  const std::string hint = "the file is damaged; remake it with trace-photons";
  if (p.first_pass < 0 || !pass_indices_fit(p.first_pass, int64_t(p.pass_emitted.size())))
    throw input_error(path, "its passes run past 2^31-1", hint);
  bool ok = p.pass_begin.size() == p.pass_emitted.size() + 1 && !p.pass_begin.empty() &&
            p.pass_begin.front() == 0 && p.pass_begin.back() == p.photons.size();
  for (size_t i = 1; ok && i < p.pass_begin.size(); ++i) ok = p.pass_begin[i - 1] <= p.pass_begin[i];
  if (!ok) throw input_error(path, "pass table does not match the photons", hint);
  // Every photon: mesh id not negative (its upper bound is the scene's: check_against_scene),
  // finite position, and the pass index of the pass it is stored in.
  for (size_t k = 0; k < p.pass_emitted.size(); ++k)
    for (uint64_t i = p.pass_begin[k]; i < p.pass_begin[k + 1]; ++i) {
      const pf_photon& ph = p.photons[size_t(i)];
      const std::string which = "photon " + std::to_string(i);
      if (ph.mesh < 0) throw input_error(path, which + " has a negative mesh id", hint);
      if (!finite3(ph.position)) throw input_error(path, which + " has a non-finite position", hint);
      if (int64_t(ph.pass) != int64_t(p.first_pass) + int64_t(k))
        throw input_error(path, which + " has pass " + std::to_string(ph.pass) + " but is stored in pass " +
                                    std::to_string(int64_t(p.first_pass) + int64_t(k)), hint);
    }
  const Validator v(path, hint);
  check_pass_emitted(p.pass_emitted, v);
  check_photon_values("photons", p.photons, 0, p.photons.size(), v);
}

void check_against_scene(const std::string& path, const PhotonSet& p, const Scene& scene) {
  const size_t meshes = scene.mesh_names.size();
  for (size_t i = 0; i < p.photons.size(); ++i)
    if (p.photons[i].mesh < 0 || size_t(p.photons[i].mesh) >= meshes)
      throw input_error(path, "photon " + std::to_string(i) + ": " +
                                  out_of("mesh", p.photons[i].mesh, meshes, "meshes"),
                        "the file does not belong to this scene or is damaged; remake it with "
                        "trace-photons");
}

}  // namespace pf
