// cl_pass_inputs.cpp — what every device gather checks and writes before it runs: the checks of
// the photons, sizes and options, a pass's bookkeeping, the hitpoints split for the hashed-grid
// gather and the PBR sites the gathers read. Private to the gather files (cl_gather_internal.h),
// so that the methods, the resident state and the timer check and upload alike.
#include <algorithm>
#include <cmath>
#include <string>

#include "photonflow/foundations/error.h"
#include "photonflow/geometry/scene.h"
#include "photonflow/io/stage_files.h"
#include "photonflow/opencl/cl_gather_internal.h"
#include "photonflow/stages/gather_method.h"
#include "photonflow/stages/illuminate.h"
#include "photonflow/stages/photon_grid.h"

namespace pf::detail {

void check_photons(const pf_photon* photons, size_t n, int mesh_count) {
  check_photon_count(n, mesh_count);
  for (size_t i = 0; i < n; ++i)
    if (!photon_ok(photons[i], mesh_count)) throw_bad_photon(photons[i], i, mesh_count);
}

void check_photons(const std::vector<pf_photon>& photons, int mesh_count) {
  check_photons(photons.data(), photons.size(), mesh_count);
}

void require_one_buffer(const ClContext& dev, size_t count, size_t item, const char* what,
                        GatherMethod m) {
  if (count * item > dev.max_alloc())
    throw input_error("", std::string("the pass's ") + what + " (" + std::to_string(count * item) +
                              " bytes) exceed the device's largest allocation for --method " +
                              gather_method_name(m),
                      "use --method naive, which works in batches");
}

void write_split(ClContext& dev, const SplitHitpoints& d, const pf_hitpoint* src,
                 const int32_t* order, size_t n) {
  using Mode = ClMapping::Mode;
  ClMapping sites(dev, *d.sites, n * sizeof(pf_gather_site), Mode::Write);
  ClMapping states(dev, *d.states, n * sizeof(pf_ppm_state), Mode::Write);
  pf_gather_site* s = sites.as<pf_gather_site>();
  pf_ppm_state* t = states.as<pf_ppm_state>();
  for (size_t i = 0; i < n; ++i) {
    const pf_hitpoint& hp = src[order ? size_t(order[i]) : i];
    for (int a = 0; a < 3; ++a) {
      s[i].position[a] = hp.position[a];
      s[i].normal[a] = hp.normal[a];
      t[i].flux[a] = hp.flux[a];
    }
    s[i].mesh = hp.mesh;
    s[i].material = hp.material;
    t[i].radius = hp.radius;
    t[i].n_photons = hp.n_photons;
  }
  states.unmap();
  sites.unmap();
}

void read_split_states(ClContext& dev, const SplitHitpoints& d, pf_hitpoint* dst,
                       const int32_t* order, size_t n) {
  ClMapping states(dev, *d.states, n * sizeof(pf_ppm_state), ClMapping::Mode::Read);
  const pf_ppm_state* t = states.as<const pf_ppm_state>();
  for (size_t i = 0; i < n; ++i) {
    pf_hitpoint& hp = dst[order ? size_t(order[i]) : i];
    hp.radius = t[i].radius;
    hp.n_photons = t[i].n_photons;
    for (int a = 0; a < 3; ++a) hp.flux[a] = t[i].flux[a];
  }
  states.unmap();
}

float max_radius(const HitpointSet& h) {
  float rmax = 0.f;
  for (const pf_hitpoint& hp : h.hitpoints)
    if (std::isfinite(hp.radius)) rmax = std::max(rmax, hp.radius);
  return rmax;
}

void check_sizes(size_t hitpoints, size_t photons) {
  if (hitpoints > size_t(INT32_MAX) || photons > size_t(INT32_MAX))
    throw input_error("", "too many hitpoints or photons for the OpenCL backend");
}

void check_pass(const PpmOptions& opt, size_t hitpoints, size_t photons) {
  check_sizes(hitpoints, photons);
  if (!(opt.alpha > 0.f && opt.alpha <= 1.f))
    throw input_error("", "alpha must be in (0, 1], got " + std::to_string(opt.alpha));
  const GatherMethodInfo& mi = gather_method_info(opt.method);
  if (!mi.device)
    throw input_error("", std::string("--method ") + mi.name + " runs on the CPU backend",
                      "use --device cpu, or an OpenCL method such as grid-kmeans");
}

void count_pass(HitpointSet& h, uint64_t emitted) {
  h.photons_emitted += emitted;
  h.passes += 1;
  h.estimator = "ppm";
}

const ClBuffer& pbr_sites(ClContext& dev, const Scene& scene, const std::string& name,
                          const std::vector<pf_hitpoint>& hps,
                          const std::vector<pf_pbr_point>& table, const int32_t* order,
                          size_t first, size_t n, ClBuffer* own) {
  const bool has = scene.has_pbr() && n > 0;
  const size_t bytes = (has ? n : 1) * sizeof(pf_pbr_site);
  const ClBuffer* b;
  if (own) {
    if (own->bytes() < bytes) *own = dev.buffer(bytes);
    b = own;
  } else {
    b = &dev.scratch(name, bytes);
  }
  if (!has) return *b;
  ClMapping map(dev, *b, bytes, ClMapping::Mode::Write);
  pf_pbr_site* out = map.as<pf_pbr_site>();
  for (size_t i = 0; i < n; ++i) {
    const size_t j = order ? size_t(order[i]) : first + i;
    pf_pbr_site site{};
    if (j < table.size()) site.pt = table[j];
    for (int a = 0; a < 3; ++a) site.wo[a] = -hps[j].dir[a];
    out[i] = site;
  }
  map.unmap();
  return *b;
}

}  // namespace pf::detail
