// cl_gather_methods.cpp — the gather methods of Table 7.3 on the device (gather_method.h,
// kernels/illuminate_methods.cl): ppm_pass (declared in cl_backend.h) with each method's
// ordering and kernel, the hash-grid pass that the resident state and the probabilistic-PPM
// gather share, and that gather.
#include "photonflow/opencl/cl_gather_methods.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "photonflow/estimators/sppm.h"
#include "photonflow/foundations/error.h"
#include "photonflow/geometry/scene.h"
#include "photonflow/io/provenance.h"
#include "photonflow/opencl/cl_backend.h"
#include "photonflow/opencl/cl_clusters.h"
#include "photonflow/opencl/cl_gather_internal.h"
#include "photonflow/stages/clusters.h"
#include "photonflow/stages/gather_method.h"
#include "photonflow/stages/hash_grid.h"
#include "photonflow/stages/illuminate.h"

namespace pf {

using namespace detail;

namespace {

constexpr float kSlack = 1.0001f;  // PF_SLACK of illuminate_methods.cl

// The local memory a launch's ClLocal arguments ask for, against the device's (32–48 KiB on GPUs,
// NVIDIA reports 48 KiB; PoCL 512 KiB): refused with the option that lowers it. Each kernel is
// checked for its own tiles (gather_clusters needs 2·wg photons + wg ints, the tile-staging
// kernels wg photons, the others none), so a work-group size is refused only where it matters.
void require_local(const ClContext& dev, size_t bytes, size_t wg, const std::string& fix) {
  if (bytes > dev.info().local_mem)
    throw input_error("", "work-group size " + std::to_string(wg) + " needs " +
                              std::to_string(bytes) + " bytes of local memory, the device has " +
                              std::to_string(dev.info().local_mem),
                      fix);
}

}  // namespace

namespace detail {

float hash_grid_pass(const Scene& scene, const SplitHitpoints& hps, const ClBuffer& mats,
                     const ClBuffer& pbr, size_t nh,
                     DirectMode direct, float rmax, const PassPhotons& photons,
                     const PpmOptions& opt, ClContext& dev, GatherTimes& times,
                     const ClBuffer* weights) {
  const size_t np = photons.n;
  require_one_buffer(dev, np, sizeof(pf_photon), "photons", opt.method);
  const int mesh_count = int(scene.mesh_names.size());
  const Vec3 ext = scene.bounds.hi - scene.bounds.lo;
  float floor_cell = std::max({ext.x, ext.y, ext.z, 1e-6f}) * 1e-6f;
  if (!std::isfinite(floor_cell)) floor_cell = 1e-6f;
  if (!(opt.hash_cell > 0.f)) throw input_error("", "hash-grid cell size must be > 0");
  const float cell = std::max(opt.hash_cell * rmax * kSlack * kSlack, floor_cell);
  // The grid spans the scene's bounds; photons and spheres beyond them (rounding) fall into
  // the edge cells, consistently for both (pf_grid_coord clamps monotonically).
  float origin[3] = {scene.bounds.lo.x, scene.bounds.lo.y, scene.bounds.lo.z};
  float extent[3] = {ext.x, ext.y, ext.z};
  for (int c = 0; c < 3; ++c)
    if (!std::isfinite(origin[c]) || !std::isfinite(extent[c])) origin[c] = extent[c] = 0.f;
  const HashGridLayout g = hash_grid_layout(origin, extent, cell, np, opt.hash_slots);
  const bool on_host = opt.hash_order == HashOrder::Host ||
                       (opt.hash_order == HashOrder::Auto && dev.info().type == "CPU");
  DeviceHashGrid d;
  if (on_host) {  // GatherTimes::order: the host's wall time
    Stopwatch sw;
    if (photons.device) {  // (np > 0: DevicePpmState::hash_grid skips empty passes)
      ClMapping p(dev, *photons.device, np * sizeof(pf_photon), ClMapping::Mode::Read);
      d = host_hash_grid(dev, p.as<const pf_photon>(), np, mesh_count, g, opt.threads);
      p.unmap();
    } else {
      d = host_hash_grid(dev, photons.host, np, mesh_count, g, opt.threads);
    }
    times.order = sw.seconds();
  } else {
    const ClBuffer* phs = photons.device;
    if (!phs) {
      check_photons(photons.host, np, mesh_count);
      phs = &dev.scratch("ppm.photons", np * sizeof(pf_photon));
      dev.write(*phs, np * sizeof(pf_photon), photons.host);
    }
    const double t0 = dev.kernel_seconds();
    d = device_hash_grid(dev, *phs, np, g);
    times.order = since(dev, t0);
  }
  const ClBuffer& next = dev.scratch("ppm.rmax", sizeof(cl_int));
  dev.fill_zero(next, sizeof(cl_int));
  const size_t L = size_t(dev.work_group());
  const double t0 = dev.kernel_seconds();
  cl_kernel k =
      dev.kernel("illuminate_methods", "gather_hash_grid", scene_kernel_variant(scene, dev));
  dev.args(k, *hps.sites, *hps.states, cl_int(nh), *d.payload, *d.keys, *d.slot_start, g.origin[0],
           g.origin[1], g.origin[2], g.cell, cl_int(g.n[0]), cl_int(g.n[1]), cl_int(g.n[2]),
           cl_uint(g.mask), cl_int(g.unique), mats, pbr,
           cl_int(direct == DirectMode::ShadowRays ? 1 : 0), opt.alpha, opt.slab,
           weights ? *weights : dev.scratch("ppm.no-weights", sizeof(float)),
           cl_int(weights ? 1 : 0), next, ClLocal{L * sizeof(cl_int)});
  dev.run(k, nh);
  times.gather = since(dev, t0);
  times.work_items = nh;
  cl_int r = 0;
  dev.read(next, sizeof r, &r);
  return pf_ordered_float(r);
}

}  // namespace detail

// ---- ppm_pass (declared in cl_backend.h) ------------------------------------------------------

GatherTimes ppm_pass(const Scene& scene, HitpointSet& h, const std::vector<pf_photon>& photons,
                     uint64_t emitted, const PpmOptions& opt, ClContext& dev) {
  Stopwatch wall;
  GatherTimes times;
  const size_t nh = h.hitpoints.size(), np = photons.size();
  check_pass(opt, nh, np);
  require_sphere(opt.slab);
  check_against_scene("", h, scene);  // the kernels index materials by hitpoint, unchecked
  require_bsdf_table(scene, h.hitpoints, h.bsdf);  // (MATERIALS.md: the gathers read it)
  const int mesh_count = int(scene.mesh_names.size());
  const cl_int skip_direct = h.direct_mode == DirectMode::ShadowRays ? 1 : 0;
  const size_t acc = dev.info().fp64 ? sizeof(double) : sizeof(float);
  const size_t L = size_t(dev.work_group());

  if (nh > 0 && np > 0) {
    const ClBuffer& mats = dev.scratch("ppm.materials", scene.materials.size() * sizeof(pf_material));
    dev.write(mats, scene.materials.size() * sizeof(pf_material), scene.materials.data());
    const std::string variant = scene_kernel_variant(scene, dev);  // kernels/scene_features.h
    cl_kernel apply = dev.kernel("illuminate_methods", "ppm_apply", variant);

    if (opt.method == GatherMethod::HashGrid) {
      require_one_buffer(dev, nh, sizeof(pf_gather_site), "hitpoints", opt.method);
      const SplitHitpoints hps{&dev.scratch("ppm.sites", nh * sizeof(pf_gather_site)),
                               &dev.scratch("ppm.states", nh * sizeof(pf_ppm_state))};
      write_split(dev, hps, h.hitpoints.data(), nullptr, nh);
      const ClBuffer& pbr = pbr_sites(dev, scene, "ppm.pbr", h.hitpoints, h.bsdf, nullptr, 0, nh);
      hash_grid_pass(scene, hps, mats, pbr, nh, h.direct_mode, max_radius(h),
                     PassPhotons{photons.data(), nullptr, np}, opt, dev, times);
      read_split_states(dev, hps, h.hitpoints.data(), nullptr, nh);
    } else if (opt.method == GatherMethod::Naive) {
      // Batches of hitpoints × batches of photons under the allocation limit, photons in index
      // order: the CPU's summation order, so the result equals the CPU gathers bit for bit.
      cl_kernel gather = dev.kernel("illuminate_methods", "gather_naive", variant);
      const size_t hb = dev.batch_items(std::max(sizeof(pf_hitpoint), 3 * acc), nh);
      const size_t pb = dev.batch_items(sizeof(pf_photon), np);
      const ClBuffer& hps = dev.scratch("ppm.hitpoints", hb * sizeof(pf_hitpoint));
      const ClBuffer& acc_m = dev.scratch("ppm.acc_m", hb * sizeof(cl_int));
      const ClBuffer& acc_tau = dev.scratch("ppm.acc_tau", hb * 3 * acc);
      const ClBuffer& phs = dev.scratch("ppm.photons", pb * sizeof(pf_photon));
      if (pb == np) dev.write(phs, np * sizeof(pf_photon), photons.data());
      for (size_t hoff = 0; hoff < nh; hoff += hb) {
        const cl_int hcount = cl_int(std::min(hb, nh - hoff));
        dev.write(hps, size_t(hcount) * sizeof(pf_hitpoint), &h.hitpoints[hoff]);
        const ClBuffer& pbr =
            pbr_sites(dev, scene, "ppm.pbr", h.hitpoints, h.bsdf, nullptr, hoff, size_t(hcount));
        dev.fill_zero(acc_m, size_t(hcount) * sizeof(cl_int));
        dev.fill_zero(acc_tau, size_t(hcount) * 3 * acc);
        for (size_t poff = 0; poff < np; poff += pb) {
          const cl_int pcount = cl_int(std::min(pb, np - poff));
          if (pb != np) dev.write(phs, size_t(pcount) * sizeof(pf_photon), &photons[poff]);
          dev.args(gather, hps, hcount, phs, pcount, mats, pbr, skip_direct, acc_m, acc_tau);
          const double t0 = dev.kernel_seconds();
          dev.run(gather, size_t(hcount));
          times.gather += since(dev, t0);
        }
        const double t0 = dev.kernel_seconds();
        dev.args(apply, hps, hcount, acc_m, acc_tau, opt.alpha);
        dev.run(apply, size_t(hcount));
        times.apply += since(dev, t0);
        dev.read(hps, size_t(hcount) * sizeof(pf_hitpoint), &h.hitpoints[hoff]);
      }
      times.work_items = nh;
    } else {
      require_one_buffer(dev, nh, sizeof(pf_hitpoint), "hitpoints", opt.method);
      require_one_buffer(dev, np, sizeof(pf_photon), "photons", opt.method);
      check_photons(photons, mesh_count);
      const ClBuffer& hps = dev.scratch("ppm.hitpoints", nh * sizeof(pf_hitpoint));
      const ClBuffer& acc_m = dev.scratch("ppm.acc_m", nh * sizeof(cl_int));
      const ClBuffer& acc_tau = dev.scratch("ppm.acc_tau", nh * 3 * acc);
      const ClBuffer& phs = dev.scratch("ppm.photons", np * sizeof(pf_photon));
      dev.write(hps, nh * sizeof(pf_hitpoint), h.hitpoints.data());
      const ClBuffer& pbr = pbr_sites(dev, scene, "ppm.pbr", h.hitpoints, h.bsdf, nullptr, 0, nh);
      dev.write(phs, np * sizeof(pf_photon), photons.data());
      dev.fill_zero(acc_m, nh * sizeof(cl_int));
      dev.fill_zero(acc_tau, nh * 3 * acc);
      double t0 = dev.kernel_seconds();
      const GatherMethod m = opt.method;
      if (m == GatherMethod::LocalMemory) {
        require_local(dev, L * sizeof(pf_photon), L, "pass a smaller --work-group");
        cl_kernel k = dev.kernel("illuminate_methods", "gather_local_memory", variant);
        dev.args(k, hps, cl_int(nh), phs, cl_int(np), mats, pbr, skip_direct, acc_m, acc_tau,
                 ClLocal{L * sizeof(pf_photon)});
        dev.run(k, nh);
        times.work_items = (nh + L - 1) / L * L;
      } else if (m == GatherMethod::PhotonSort || m == GatherMethod::HitpointSort ||
                 m == GatherMethod::HitpointSortLocal || m == GatherMethod::ManualDistance) {
        DeviceMeshSort s = device_mesh_sort(dev, phs, np, mesh_count);
        times.order = since(dev, t0);
        t0 = dev.kernel_seconds();
        if (m == GatherMethod::PhotonSort) {
          cl_kernel k = dev.kernel("illuminate_methods", "gather_photon_sort", variant);
          dev.args(k, hps, cl_int(nh), *s.sorted, *s.mesh_start, cl_int(mesh_count), mats, pbr,
                   skip_direct, acc_m, acc_tau);
          dev.run(k, nh);
          times.work_items = nh;
        } else {
          const std::vector<int32_t> order = mesh_sorted_order(h, int(L));
          const ClBuffer& ob = dev.scratch("ppm.order", order.size() * sizeof(cl_int));
          dev.write(ob, order.size() * sizeof(cl_int), order.data());
          t0 = dev.kernel_seconds();
          const char* name = m == GatherMethod::HitpointSort        ? "gather_hitpoint_sort"
                             : m == GatherMethod::HitpointSortLocal ? "gather_hitpoint_sort_local"
                                                                    : "gather_manual_distance";
          cl_kernel k = dev.kernel("illuminate_methods", name, variant);
          if (m == GatherMethod::HitpointSort)
            dev.args(k, hps, ob, cl_int(order.size()), *s.sorted, *s.mesh_start,
                     cl_int(mesh_count), mats, pbr, skip_direct, acc_m, acc_tau);
          else {
            require_local(dev, L * sizeof(pf_photon), L, "pass a smaller --work-group");
            dev.args(k, hps, ob, cl_int(order.size()), *s.sorted, *s.mesh_start,
                     cl_int(mesh_count), mats, pbr, skip_direct, acc_m, acc_tau,
                     ClLocal{L * sizeof(pf_photon)});
          }
          dev.run(k, order.size());
          times.work_items = order.size();
        }
      } else {  // kmeans-clusters, grid-kmeans, grid-gridclusters
        ClusterSet made;
        ClusterSet* cs = opt.clusters;
        if (!cs) {
          made = clusters_for_method(m, h, int(L), opt);
          cs = &made;
        } else {
          check_cluster_count(*cs, nh);
        }
        update_cluster_radii(*cs, h);  // R only tightens as PPM shrinks radii (clusters.h)
        const DeviceClusters dc = upload_clusters(dev, *cs, "ppm");
        const ClLocal tile{2 * dc.wg * sizeof(pf_photon)}, scan{dc.wg * sizeof(cl_int)};
        t0 = dev.kernel_seconds();
        if (m == GatherMethod::KmeansClusters) {
          DeviceMeshSort s = device_mesh_sort(dev, phs, np, mesh_count);
          times.order = since(dev, t0);
          t0 = dev.kernel_seconds();
          require_local(dev, tile.bytes + scan.bytes, dc.wg,
                        "make clusters with a smaller --wg-size");
          cl_kernel k = dev.kernel("illuminate_methods", "gather_clusters", variant);
          dev.args(k, hps, *dc.order, *dc.groups, *dc.clusters, *s.sorted, *s.mesh_start,
                   cl_int(mesh_count), mats, pbr, skip_direct, acc_m, acc_tau, tile, scan);
          dev.run(k, dc.items, dc.wg);
        } else {
          DeviceGrid g = device_grid(dev, phs, np, mesh_count, ppm_grid_params(h, opt));
          times.order = since(dev, t0);
          t0 = dev.kernel_seconds();
          cl_kernel k = dev.kernel("illuminate_methods", "gather_grid_clusters", variant);
          dev.args(k, hps, *dc.order, *dc.groups, *dc.clusters, *g.sorted, *g.mesh_grid,
                   *g.cell_start, cl_int(mesh_count), mats, pbr, skip_direct, acc_m, acc_tau);
          dev.run(k, dc.items, dc.wg);
        }
        times.work_items = dc.items;
      }
      times.gather = since(dev, t0);
      t0 = dev.kernel_seconds();
      dev.args(apply, hps, cl_int(nh), acc_m, acc_tau, opt.alpha);
      dev.run(apply, nh);
      times.apply = since(dev, t0);
      dev.read(hps, nh * sizeof(pf_hitpoint), h.hitpoints.data());
    }
  }
  count_pass(h, emitted);
  times.total = wall.seconds();
  return times;
}

std::vector<float> pppm_gather_device(const Scene& scene, const EyePassResult& eye, float radius,
                                      DirectMode direct, const DevicePhotons& photons,
                                      const PpmOptions& opt, ClContext& dev) {
  const size_t nh = eye.hitpoints.size(), np = photons.count;
  std::vector<float> tau_beta(nh * 3, 0.f);
  // One hashed-grid pass with α = 1 over fresh states (R = r_i, N = 0, τ = 0): eq. 3.14–3.18 then
  // leave R, set N = M and τ = β·τ_M exactly (ratio (0 + M)/(0 + M) = 1), which are read back.
  PpmOptions o = opt;
  o.method = GatherMethod::HashGrid;
  o.alpha = 1.f;
  check_pass(o, nh, np);
  check_slab(o.slab);
  if (nh == 0 || np == 0) return tau_beta;
  require_one_buffer(dev, nh, sizeof(pf_gather_site), "visible points", o.method);
  std::vector<pf_hitpoint> fresh(eye.hitpoints);
  std::vector<float> beta(nh * 3);
  require_bsdf_table(scene, eye.hitpoints, eye.bsdf);
  const bool pbr_scene = scene.has_pbr();
  for (size_t i = 0; i < nh; ++i) {
    fresh[i].radius = radius;
    fresh[i].n_photons = 0.f;
    for (int c = 0; c < 3; ++c) fresh[i].flux[c] = 0.f;
    // β, times πR²/A with --gather-area surface (pppm_pass's)
    gather_weight(scene, o, eye.hitpoints[i], radius,
                  pbr_scene ? pbr_of(scene, eye.hitpoints[i], eye.bsdf, i) : nullptr, &beta[i * 3]);
  }
  const SplitHitpoints hps{&dev.scratch("pppm.sites", nh * sizeof(pf_gather_site)),
                           &dev.scratch("pppm.states", nh * sizeof(pf_ppm_state))};
  write_split(dev, hps, fresh.data(), nullptr, nh);
  const ClBuffer& weights = dev.scratch("pppm.weights", nh * 3 * sizeof(float));
  dev.write(weights, nh * 3 * sizeof(float), beta.data());
  const ClBuffer& mats = dev.scratch("ppm.materials", scene.materials.size() * sizeof(pf_material));
  dev.write(mats, scene.materials.size() * sizeof(pf_material), scene.materials.data());
  const ClBuffer& pbr = pbr_sites(dev, scene, "pppm.pbr", eye.hitpoints, eye.bsdf, nullptr, 0, nh);
  GatherTimes times;
  hash_grid_pass(scene, hps, mats, pbr, nh, direct, radius,
                 PassPhotons{nullptr, photons.photons, np}, o, dev, times, &weights);
  read_split_states(dev, hps, fresh.data(), nullptr, nh);
  for (size_t i = 0; i < nh; ++i)
    for (int c = 0; c < 3; ++c) tau_beta[i * 3 + size_t(c)] = fresh[i].flux[c];
  return tau_beta;
}

}  // namespace pf
