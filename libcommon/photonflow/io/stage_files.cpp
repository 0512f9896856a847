// Render-stage intermediates: see stage_files.h and docs/FORMATS.md. This file holds what the
// three formats share (stage_file_checks.h), require_scene and accept_input; each format's
// reading, writing and checks are in its own file (hitpoints_file.cpp, photons_file.cpp, grid_file.cpp).
#include "photonflow/io/stage_files.h"

#include <cmath>

#include "photonflow/geometry/scene.h"
#include "photonflow/io/h5io.h"
#include "photonflow/io/stage_file_checks.h"
#include "photonflow/io/validate.h"
#include "photonflow/stages/photon_pass.h"

namespace pf {

int64_t attr_in(const h5::Reader& r, const std::string& path, const std::string& obj,
                const std::string& name, int64_t lo, int64_t hi, const std::string& hint) {
  const int64_t v = r.attr_int(obj, name);
  if (v < lo || v > hi)
    throw input_error(path,
                      "attribute " + (obj == "/" ? "" : obj + "/") + name + " = " +
                          std::to_string(v) + " is outside [" + std::to_string(lo) + ", " +
                          std::to_string(hi) + "]",
                      hint);
  return v;
}

int check_first_pass(const h5::Reader& r, const std::string& path, size_t passes,
                     const std::string& hint) {
  const int64_t first = attr_in(r, path, "/", "first_pass", 0, kIntMax, hint);
  if (!pass_indices_fit(first, int64_t(passes)))
    throw input_error(path, "its passes " + std::to_string(first) + " … " +
                                std::to_string(first + int64_t(passes) - 1) + " run past 2^31-1",
                      hint);
  return int(first);
}

bool finite3(const float* p) {
  return std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]);
}

std::string out_of(const char* what, int32_t value, size_t size, const char* table) {
  return std::string(what) + " id " + std::to_string(value) + " is outside the scene's " +
         std::to_string(size) + " " + table;
}

void check_photon_values(const std::string& dataset, const std::vector<pf_photon>& photons,
                         size_t begin, size_t end, const Validator& v) {
  for (size_t i = begin; i < end; ++i) {
    const pf_photon& p = photons[i];
    v.position(Name(dataset, i, "position"), p.position);
    v.unit(Name(dataset, i, "dir"), p.dir);
    v.in_range(Name(dataset, i, "flux"), p.flux, 3, 0.0, kMaxValue);
    if (p.flags & ~(PF_PHOTON_CAUSTIC | PF_PHOTON_DIRECT))
      v.fail(Validator::element(dataset, i, "flags") + " = " + std::to_string(p.flags) +
             " has bits other than 1 (caustic) and 2 (direct)");
  }
}

void check_pass_emitted(const std::vector<uint64_t>& emitted, const Validator& v) {
  for (size_t k = 0; k < emitted.size(); ++k)
    if (emitted[k] < 1 || emitted[k] > kMaxPhotonsPerPass)
      v.fail(Validator::element("pass_emitted", k) + " = " + std::to_string(emitted[k]) +
             " is outside [1, " + std::to_string(kMaxPhotonsPerPass) + "]");
}

void require_scene(const std::string& path, const std::string& scene_id,
                   const std::string& expected, const std::string& scene_path) {
  if (scene_id != expected)
    throw input_error(path,
                      "was made from a different scene than " + scene_path + " (scene_id " +
                          scene_id.substr(0, 12) + " vs " + expected.substr(0, 12) + ")",
                      "rerun the stages from the same scene.h5");
}

namespace {
template <class Set>
void accept_set(Provenance& prov, const std::string& role, const std::string& path, const Set& set,
                const char* format, const Scene& scene, const std::string& scene_path) {
  require_scene(path, set.scene_id, scene.scene_id, scene_path);
  check_against_scene(path, set, scene);
  prov.add_input(role, path, format, set.scene_id);
}
}  // namespace

void accept_input(Provenance& prov, const std::string& role, const std::string& path,
                  const HitpointSet& h, const Scene& scene, const std::string& scene_path) {
  accept_set(prov, role, path, h, kHitpointsFormat, scene, scene_path);
}
void accept_input(Provenance& prov, const std::string& role, const std::string& path,
                  const PhotonSet& p, const Scene& scene, const std::string& scene_path) {
  accept_set(prov, role, path, p, kPhotonsFormat, scene, scene_path);
}
void accept_input(Provenance& prov, const std::string& role, const std::string& path,
                  const GridSet& g, const Scene& scene, const std::string& scene_path) {
  accept_set(prov, role, path, g, kGridFormat, scene, scene_path);
}

}  // namespace pf
