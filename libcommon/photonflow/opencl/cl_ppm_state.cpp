// cl_ppm_state.cpp — DevicePpmState: a PPM or SPPM state kept on the device between passes, so
// that a stream of hash-grid passes moves only photons across the bus and copies the hitpoints
// back only when the host asks for them.
#include "photonflow/opencl/cl_ppm_state.h"

#include <algorithm>
#include <stdexcept>
#include <vector>

#include "photonflow/estimators/sppm.h"
#include "photonflow/geometry/scene.h"
#include "photonflow/io/provenance.h"
#include "photonflow/io/stage_files.h"
#include "photonflow/opencl/cl_backend.h"
#include "photonflow/opencl/cl_gather_internal.h"
#include "photonflow/stages/hash_grid.h"
#include "photonflow/stages/illuminate.h"

namespace pf {

using namespace detail;

DevicePpmState::DevicePpmState(const Scene& scene, HitpointSet& h, ClContext& dev)
    : scene_(scene), h_(h), dev_(dev) {
  check_against_scene("", h, scene);  // the kernels index materials by hitpoint, unchecked
}

GatherTimes DevicePpmState::pass(const std::vector<pf_photon>& photons, uint64_t emitted,
                                 const PpmOptions& opt) {
  if (opt.method != GatherMethod::HashGrid) {  // the copying route
    sync();
    device_current_ = false;
    return ppm_pass(scene_, h_, photons, emitted, opt, dev_);
  }
  return hash_grid(photons.data(), nullptr, photons.size(), emitted, opt);
}

GatherTimes DevicePpmState::pass(const DevicePhotons& photons, const PpmOptions& opt) {
  if (opt.method != GatherMethod::HashGrid)
    return pass(download_photons(photons, dev_), photons.emitted, opt);
  return hash_grid(nullptr, photons.photons, photons.count, photons.emitted, opt);
}

GatherTimes DevicePpmState::hash_grid(const pf_photon* host, const ClBuffer* device, size_t np,
                                      uint64_t emitted, const PpmOptions& opt) {
  Stopwatch wall;
  GatherTimes times;
  const size_t nh = h_.hitpoints.size();
  check_pass(opt, nh, np);
  require_sphere(opt.slab);
  if (nh > 0 && np > 0) {
    upload();
    rmax_ = hash_grid_pass(scene_, SplitHitpoints{&sites_, &states_}, mats_, pbr_, nh,
                           h_.direct_mode, rmax_, PassPhotons{host, device, np}, opt, dev_, times);
    host_current_ = false;
  }
  count_pass(h_, emitted);
  times.total = wall.seconds();
  return times;
}

GatherTimes DevicePpmState::sppm_pass(const EyePassResult& eye, const std::vector<pf_photon>& photons,
                                      uint64_t emitted, const PpmOptions& opt) {
  return sppm_hash_grid(eye, photons.data(), nullptr, photons.size(), emitted, opt);
}

GatherTimes DevicePpmState::sppm_pass(const EyePassResult& eye, const DevicePhotons& photons,
                                      const PpmOptions& opt) {
  return sppm_hash_grid(eye, nullptr, photons.photons, photons.count, photons.emitted, opt);
}

GatherTimes DevicePpmState::sppm_hash_grid(const EyePassResult& eye, const pf_photon* host,
                                           const ClBuffer* device, size_t np, uint64_t emitted,
                                           const PpmOptions& opt) {
  Stopwatch wall;
  GatherTimes times;
  if (!is_sppm_state(h_))
    throw std::invalid_argument("DevicePpmState::sppm_pass: the state is not an SPPM state");
  PpmOptions o = opt;
  o.method = GatherMethod::HashGrid;
  const size_t nh = h_.hitpoints.size();
  check_pass(o, nh, np);
  check_slab(o.slab);
  // The pass's sites: each pixel's visible point (mesh −1 where the eye path found none) and its
  // throughput β; the host copy of the state takes the visible points too (sppm_pass's fields).
  std::vector<pf_hitpoint>& sites = sppm_sites_;
  std::vector<float>& beta = sppm_beta_;
  if (o.gather_area == GatherArea::Surface) sync();  // the pixels' radii (sppm_sites)
  sppm_sites(scene_, h_, eye, o, sites, beta);
  upload();
  if (nh > 0) {
    if (weights_.bytes() < nh * 3 * sizeof(float)) weights_ = dev_.buffer(nh * 3 * sizeof(float));
    dev_.write(weights_, nh * 3 * sizeof(float), beta.data());
    {  // the sites alone: the states stay where they are
      ClMapping m(dev_, sites_, nh * sizeof(pf_gather_site), ClMapping::Mode::Write);
      pf_gather_site* s = m.as<pf_gather_site>();
      for (size_t i = 0; i < nh; ++i) {
        for (int a = 0; a < 3; ++a) {
          s[i].position[a] = sites[i].position[a];
          s[i].normal[a] = sites[i].normal[a];
        }
        s[i].mesh = sites[i].mesh;
        s[i].material = sites[i].material;
      }
      m.unmap();
    }
    if (scene_.has_pbr()) {  // the PBR sites of the pass's visible points, by pixel
      require_bsdf_table(scene_, eye.hitpoints, eye.bsdf);
      std::vector<int32_t>& at = sppm_pbr_order_;  // (sppm_sites' placement)
      at.assign(nh, 0);  // a pixel without a visible point: entry 0, never read (material −1)
      for (size_t i = 0; i < eye.hitpoints.size(); ++i)
        at[size_t(eye.hitpoints[i].pixel_y) * size_t(h_.width) + size_t(eye.hitpoints[i].pixel_x)] =
            int32_t(i);
      pbr_sites(dev_, scene_, "", eye.hitpoints, eye.bsdf, at.data(), 0,
                eye.hitpoints.empty() ? 0 : nh, &pbr_);
    } else {  // the one-element stand-in, made once
      pbr_sites(dev_, scene_, "", eye.hitpoints, eye.bsdf, nullptr, 0, 0, &pbr_);
    }
    if (np > 0) {
      rmax_ = hash_grid_pass(scene_, SplitHitpoints{&sites_, &states_}, mats_, pbr_, nh,
                             h_.direct_mode, rmax_, PassPhotons{host, device, np}, o, dev_, times,
                             &weights_);
      host_current_ = false;
    }
  }
  sppm_finish_pass(h_, eye, emitted);
  times.total = wall.seconds();
  return times;
}

void DevicePpmState::upload() {
  if (device_current_) return;
  sync();  // never overwrite a newer device state with an older host copy
  const size_t nh = h_.hitpoints.size();
  rmax_ = max_radius(h_);
  if (nh > 0) {
    require_one_buffer(dev_, nh, sizeof(pf_gather_site), "hitpoints", GatherMethod::HashGrid);
    if (sites_.bytes() < nh * sizeof(pf_gather_site)) {
      sites_ = dev_.buffer(nh * sizeof(pf_gather_site));
      states_ = dev_.buffer(nh * sizeof(pf_ppm_state));
    }
    const size_t mat_bytes = scene_.materials.size() * sizeof(pf_material);
    if (!mats_.get()) mats_ = dev_.buffer(std::max<size_t>(mat_bytes, 4));
    dev_.write(mats_, mat_bytes, scene_.materials.data());
    const float origin[3] = {scene_.bounds.lo.x, scene_.bounds.lo.y, scene_.bounds.lo.z};
    // SPPM's sites move every pass (sppm_pass writes them): pixels stay in pixel order, which
    // keeps neighbouring pixels, mostly neighbouring sites, together.
    order_ = is_sppm_state(h_) ? std::vector<int32_t>()
                               : hitpoint_cell_order(h_.hitpoints, origin, kHitpointOrderCell * rmax_);
    write_split(dev_, SplitHitpoints{&sites_, &states_}, h_.hitpoints.data(),
                order_.empty() ? nullptr : order_.data(), nh);
    if (!is_sppm_state(h_)) {  // (SPPM's come with each pass's visible points)
      require_bsdf_table(scene_, h_.hitpoints, h_.bsdf);
      pbr_sites(dev_, scene_, "", h_.hitpoints, h_.bsdf, order_.empty() ? nullptr : order_.data(),
                0, nh, &pbr_);
    }
  }
  device_current_ = true;
}

void DevicePpmState::sync() {
  if (host_current_) return;
  const size_t nh = h_.hitpoints.size();
  if (nh > 0)
    read_split_states(dev_, SplitHitpoints{&sites_, &states_}, h_.hitpoints.data(),
                      order_.empty() ? nullptr : order_.data(), nh);
  host_current_ = true;
}

}  // namespace pf
