// Hitpoint illumination on the OpenCL device: see cl_gather.h, gather_method.h and
// kernels/illuminate_methods.cl, kernels/build_grid.cl.
#include "photonflow/opencl/cl_gather.h"

#include <algorithm>
#include <climits>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "photonflow/opencl/cl_backend.h"
#include "photonflow/stages/clusters.h"
#include "photonflow/foundations/error.h"
#include "photonflow/stages/gather_method.h"
#include "photonflow/stages/grid_shared.h"
#include "photonflow/stages/hash_grid.h"
#include "photonflow/stages/illuminate.h"
#include "photonflow/io/provenance.h"
#include "photonflow/estimators/sppm.h"
#include "photonflow/geometry/surface.h"

namespace pf {

namespace {

constexpr size_t kChunk = 256;     // PF_CHUNK of build_grid.cl
constexpr size_t kScanItems = 16;  // PF_SCAN_ITEMS of build_grid.cl
constexpr float kSlack = 1.0001f;  // PF_SLACK of illuminate_methods.cl

// The host-side checks of the CPU grid build (photon_grid.cpp), so the device never indexes a
// mesh table out of range: every photon's mesh in [0, mesh_count), every position finite.
void check_photons(const pf_photon* photons, size_t n, int mesh_count) {
  check_photon_count(n, mesh_count);
  for (size_t i = 0; i < n; ++i)
    if (!photon_ok(photons[i], mesh_count)) throw_bad_photon(photons[i], i, mesh_count);
}

void check_photons(const std::vector<pf_photon>& photons, int mesh_count) {
  check_photons(photons.data(), photons.size(), mesh_count);
}

// A device buffer for `count` items of `item` bytes, or InputError naming the batched method.
void require_one_buffer(const ClContext& dev, size_t count, size_t item, const char* what,
                        GatherMethod m) {
  if (count * item > dev.max_alloc())
    throw input_error("", std::string("the pass's ") + what + " (" + std::to_string(count * item) +
                              " bytes) exceed the device's largest allocation for --method " +
                              gather_method_name(m),
                      "use --method naive, which works in batches");
}

// Exclusive prefix sum of data[0 .. n) in place (build_grid.cl's scan_blocks / scan_add); the
// block sums of each level are scanned recursively.
void exclusive_scan(ClContext& dev, const ClBuffer& data, size_t n, int level = 0) {
  if (n == 0) return;
  if (n > size_t(INT_MAX)) throw std::invalid_argument("device scan: more than 2^31-1 entries");
  const size_t L = size_t(dev.work_group());
  const size_t per_group = kScanItems * L;
  const size_t groups = (n + per_group - 1) / per_group;
  const ClBuffer& sums = dev.scratch("scan.sums." + std::to_string(level), groups * sizeof(cl_int));
  cl_kernel k = dev.kernel("build_grid", "scan_blocks");
  dev.args(k, data, cl_int(n), sums, ClLocal{L * sizeof(cl_int)});
  dev.run(k, groups * L);
  if (groups > 1) {
    exclusive_scan(dev, sums, groups, level + 1);
    cl_kernel add = dev.kernel("build_grid", "scan_add");
    dev.args(add, data, cl_int(n), sums);
    dev.run(add, n);
  }
}

// Counting sort of photon indices by key (key[i] in [0, ranges), rank[i] its place among the
// photons of its key as the atomic counters gave it): counts → exclusive scan (the start table,
// ranges + 1 entries, the last = n) → scatter to start + rank → each range sorted ascending, so
// the order equals a stable sort. `counts` becomes the start table; `order` is the result.
void sort_by_key(ClContext& dev, const ClBuffer& key, const ClBuffer& rank, const ClBuffer& counts,
                 size_t n, size_t ranges, const ClBuffer& order) {
  exclusive_scan(dev, counts, ranges + 1);
  cl_kernel scatter = dev.kernel("build_grid", "scatter_keys");
  dev.args(scatter, key, rank, cl_int(n), counts, order);
  dev.run(scatter, n);
  cl_kernel sort = dev.kernel("build_grid", "sort_ranges");
  dev.args(sort, counts, cl_int(ranges), cl_int(n), order);
  dev.run(sort, ranges);
}

void permute(ClContext& dev, const ClBuffer& in, const ClBuffer& order, size_t n,
             const ClBuffer& out) {
  cl_kernel k = dev.kernel("build_grid", "permute_photons");
  dev.args(k, in, order, cl_int(n), out);
  dev.run(k, n);
}

// The per-mesh grid of eq. 7.1 over the n photons in `photons`, on the device.
struct DeviceGrid {
  std::vector<pf_mesh_grid> headers;
  size_t entries = 0;
  const ClBuffer* sorted = nullptr;      // photons by (mesh, bin, index)
  const ClBuffer* order = nullptr;       // input index of each sorted photon
  const ClBuffer* cell_start = nullptr;  // entries + 1 ints
  const ClBuffer* mesh_grid = nullptr;   // headers on the device
};

// Its lasting buffers are the device's scratch buffers `ns`.headers, .cell_start, .order, .photons.
DeviceGrid device_grid(ClContext& dev, const ClBuffer& photons, size_t n, int mesh_count,
                       const PhotonGridParams& params, const std::string& ns = "grid") {
  check_photon_grid_params(params);  // as the CPU build
  DeviceGrid g;
  const size_t meshes = size_t(mesh_count);
  // 1. Per-mesh bounds and counts (local reduction, then one atomic per mesh and work-group).
  std::vector<cl_int> bounds(8 * std::max<size_t>(meshes, 1), 0);
  for (size_t m = 0; m < meshes; ++m)
    for (int f = 0; f < 7; ++f) bounds[8 * m + size_t(f)] = f < 3 ? INT_MAX : (f < 6 ? INT_MIN : 0);
  const ClBuffer& bb = dev.scratch("grid.bounds", bounds.size() * sizeof(cl_int));
  dev.write(bb, bounds.size() * sizeof(cl_int), bounds.data());
  if (n > 0 && meshes > 0) {
    const size_t local_ints = std::max<uint64_t>(dev.info().local_mem, 1024) / 2 / sizeof(cl_int);
    const size_t span = std::clamp<size_t>(local_ints / 7, 1, meshes);
    cl_kernel k = dev.kernel("build_grid", "grid_bounds");
    for (size_t m0 = 0; m0 < meshes; m0 += span) {
      const size_t s = std::min(span, meshes - m0);
      dev.args(k, photons, cl_int(n), cl_int(m0), cl_int(s), bb, ClLocal{7 * s * sizeof(cl_int)});
      dev.run(k, n);
    }
    dev.read(bb, bounds.size() * sizeof(cl_int), bounds.data());
  }
  // 2. Headers: the CPU's function on the reduced bounds, so both builds make the same grids.
  g.headers.resize(meshes);
  int64_t entries = 0;
  int32_t first_photon = 0;
  for (size_t m = 0; m < meshes; ++m) {
    float lo[3], hi[3];
    for (int a = 0; a < 3; ++a) {
      lo[a] = pf_ordered_float(bounds[8 * m + size_t(a)]);
      hi[a] = pf_ordered_float(bounds[8 * m + 3 + size_t(a)]);
    }
    const int32_t count = bounds[8 * m + 6];
    pf_mesh_grid& h = g.headers[m];
    h = mesh_grid_header(lo, hi, count, params);
    h.first_bin = pf_int(entries);
    h.first_photon = first_photon;
    entries += count == 0 ? 1 : mesh_grid_bins(h) + 1;
    check_grid_entries(entries, "the photon grid", kGridBinsHint);  // as the CPU build
    first_photon += count;
  }
  g.entries = size_t(entries);
  const ClBuffer& mg = dev.scratch(ns + ".headers", std::max<size_t>(meshes, 1) * sizeof(pf_mesh_grid));
  dev.write(mg, meshes * sizeof(pf_mesh_grid), g.headers.data());
  // 3. Keys and counts with atomic counters; 4. the bin-start table and the sorted order.
  const ClBuffer& counts = dev.scratch(ns + ".cell_start", (g.entries + 1) * sizeof(cl_int));
  dev.fill_zero(counts, (g.entries + 1) * sizeof(cl_int));
  const ClBuffer& key = dev.scratch(ns + ".key", n * sizeof(cl_int));
  const ClBuffer& rank = dev.scratch(ns + ".rank", n * sizeof(cl_int));
  const ClBuffer& order = dev.scratch(ns + ".order", n * sizeof(cl_int));
  const ClBuffer& sorted = dev.scratch(ns + ".photons", n * sizeof(pf_photon));
  if (n > 0) {
    cl_kernel k = dev.kernel("build_grid", "key_grid_bin");
    dev.args(k, photons, cl_int(n), mg, key, rank, counts);
    dev.run(k, n);
  }
  sort_by_key(dev, key, rank, counts, n, g.entries, order);
  permute(dev, photons, order, n, sorted);
  g.sorted = &sorted;
  g.order = &order;
  g.cell_start = &counts;
  g.mesh_grid = &mg;
  return g;
}

// Photons stably sorted by mesh (the per-mesh arrays of "photon sorting"), on the device.
struct DeviceMeshSort {
  const ClBuffer* sorted = nullptr;
  const ClBuffer* order = nullptr;
  const ClBuffer* mesh_start = nullptr;  // mesh_count + 1 ints
};

DeviceMeshSort device_mesh_sort(ClContext& dev, const ClBuffer& photons, size_t n,
                                int mesh_count) {
  DeviceMeshSort s;
  const size_t meshes = size_t(mesh_count);
  const ClBuffer& start = dev.scratch("msort.start", (meshes + 1) * sizeof(cl_int));
  const ClBuffer& order = dev.scratch("msort.order", n * sizeof(cl_int));
  const ClBuffer& sorted = dev.scratch("msort.photons", n * sizeof(pf_photon));
  s.sorted = &sorted;
  s.order = &order;
  s.mesh_start = &start;
  if (n == 0 || meshes == 0) {
    dev.fill_zero(start, (meshes + 1) * sizeof(cl_int));
    return s;
  }
  const size_t chunks = (n + kChunk - 1) / kChunk;
  if (chunks * meshes > size_t(INT_MAX))
    throw std::invalid_argument("photon sort: meshes × photon chunks exceed 2^31-1");
  const ClBuffer& offsets = dev.scratch("msort.offsets", chunks * meshes * sizeof(cl_int));
  dev.fill_zero(offsets, chunks * meshes * sizeof(cl_int));
  cl_kernel count = dev.kernel("build_grid", "mesh_chunk_count");
  dev.args(count, photons, cl_int(n), cl_int(chunks), offsets);
  dev.run(count, chunks);
  exclusive_scan(dev, offsets, chunks * meshes);
  cl_kernel starts = dev.kernel("build_grid", "mesh_starts");
  dev.args(starts, offsets, cl_int(chunks), cl_int(meshes), cl_int(n), start);
  dev.run(starts, meshes + 1);
  cl_kernel scatter = dev.kernel("build_grid", "mesh_chunk_scatter");
  dev.args(scatter, photons, cl_int(n), cl_int(chunks), offsets, order);
  dev.run(scatter, chunks);
  permute(dev, photons, order, n, sorted);
  return s;
}

// The hashed grid of `hash-grid` (hash_grid.h) on the device: the sorted photons' keys and
// payloads and the slot-start table (slots + 1 entries), in the scratch buffers hash.keys,
// hash.payload and hash.start.
struct DeviceHashGrid {
  const ClBuffer* keys = nullptr;
  const ClBuffer* payload = nullptr;
  const ClBuffer* slot_start = nullptr;
};

DeviceHashGrid hash_grid_buffers(ClContext& dev, size_t n, const HashGridLayout& g) {
  DeviceHashGrid d;
  d.slot_start = &dev.scratch("hash.start", (g.slots() + 1) * sizeof(cl_int));
  d.keys = &dev.scratch("hash.keys", hash_grid_key_blocks(n) * sizeof(pf_photon_keys4));
  d.payload = &dev.scratch("hash.payload", n * sizeof(pf_photon_payload));
  return d;
}

// Built by the device's kernels from the n photons in `photons` (already uploaded).
DeviceHashGrid device_hash_grid(ClContext& dev, const ClBuffer& photons, size_t n,
                                const HashGridLayout& g) {
  const DeviceHashGrid d = hash_grid_buffers(dev, n, g);
  const size_t table = g.slots();
  dev.fill_zero(*d.slot_start, (table + 1) * sizeof(cl_int));
  const ClBuffer& key = dev.scratch("hash.key", n * sizeof(cl_int));
  const ClBuffer& rank = dev.scratch("hash.rank", n * sizeof(cl_int));
  const ClBuffer& order = dev.scratch("hash.order", n * sizeof(cl_int));
  if (n > 0) {
    cl_kernel k = dev.kernel("build_grid", "key_hash_cell");
    dev.args(k, photons, cl_int(n), g.origin[0], g.origin[1], g.origin[2], g.cell, cl_int(g.n[0]),
             cl_int(g.n[1]), cl_int(g.n[2]), cl_uint(g.mask), key, rank, *d.slot_start);
    dev.run(k, n);
  }
  sort_by_key(dev, key, rank, *d.slot_start, n, table, order);
  if (n > 0) {
    cl_kernel k = dev.kernel("build_grid", "permute_photons_keys");
    dev.args(k, photons, order, cl_int(n), *d.keys, *d.payload);
    dev.run(k, 4 * hash_grid_key_blocks(n));
  }
  return d;
}

// Built on the host (order_hash_grid, which also checks the photons) straight into the mapped
// device buffers: the photons never go up unsorted.
DeviceHashGrid host_hash_grid(ClContext& dev, const pf_photon* photons, size_t n,
                              int mesh_count, const HashGridLayout& g, int threads) {
  const DeviceHashGrid d = hash_grid_buffers(dev, n, g);
  const size_t start_bytes = (g.slots() + 1) * sizeof(cl_int);
  using Mode = ClMapping::Mode;
  // (A bad photon throws: the mappings end before the error goes on.)
  ClMapping keys(dev, *d.keys, hash_grid_key_blocks(n) * sizeof(pf_photon_keys4), Mode::Write);
  ClMapping payload(dev, *d.payload, n * sizeof(pf_photon_payload), Mode::Write);
  ClMapping start(dev, *d.slot_start, start_bytes, Mode::Write);
  order_hash_grid(g, photons, n, mesh_count, keys.as<pf_photon_keys4>(),
                  payload.as<pf_photon_payload>(), start.as<int32_t>(), threads);
  start.unmap();
  payload.unmap();
  keys.unmap();
  return d;
}

// Work-group → cluster table of a cluster set (work-group g covers order[g·wg, (g+1)·wg)).
std::vector<cl_int> group_clusters(const ClusterSet& cs) {
  std::vector<cl_int> t(cs.order.size() / size_t(cs.wg_size));
  for (size_t c = 0; c < cs.clusters.size(); ++c) {
    const pf_cluster& k = cs.clusters[c];
    for (int g = k.first / cs.wg_size; g < (k.first + k.padded_count) / cs.wg_size; ++g)
      t[size_t(g)] = cl_int(c);
  }
  return t;
}

// A cluster set on the device: the hitpoint order (fillers -1), the work-group → cluster table
// and the clusters, in the scratch buffers `ns`.order, .group_cluster, .clusters.
struct DeviceClusters {
  const ClBuffer* order = nullptr;
  const ClBuffer* groups = nullptr;
  const ClBuffer* clusters = nullptr;
  size_t items = 0;  // work-items: order.size()
  size_t wg = 0;     // work-group size
};

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

DeviceClusters upload_clusters(ClContext& dev, const ClusterSet& cs, const std::string& ns) {
  DeviceClusters d;
  d.wg = size_t(cs.wg_size);
  d.items = cs.order.size();
  const std::vector<cl_int> groups = group_clusters(cs);
  d.order = &dev.scratch(ns + ".order", cs.order.size() * sizeof(cl_int));
  d.groups = &dev.scratch(ns + ".group_cluster", groups.size() * sizeof(cl_int));
  d.clusters = &dev.scratch(ns + ".clusters", cs.clusters.size() * sizeof(pf_cluster));
  dev.write(*d.order, cs.order.size() * sizeof(cl_int), cs.order.data());
  dev.write(*d.groups, groups.size() * sizeof(cl_int), groups.data());
  dev.write(*d.clusters, cs.clusters.size() * sizeof(pf_cluster), cs.clusters.data());
  return d;
}

// The cluster set must belong to the pass's hitpoints.
void check_cluster_count(const ClusterSet& cs, size_t hitpoints) {
  if (cs.hitpoint_count != hitpoints)
    throw input_error("", "the clusters were made for " + std::to_string(cs.hitpoint_count) +
                              " hitpoints, the state has " + std::to_string(hitpoints),
                      "run the cluster stage on these hitpoints");
}

double since(ClContext& dev, double t0) { return dev.kernel_seconds() - t0; }

// The hashed-grid gather's split hitpoints (pf_gather_site, pf_ppm_state; shared_types.h) in two
// device buffers, the namespace's scratch buffers or a resident state's own.
struct SplitHitpoints {
  const ClBuffer* sites = nullptr;
  const ClBuffer* states = nullptr;
};

// Writes hitpoints src[order[i]] (src[i] without an order) as entry i of the split buffers, through
// mappings (no staging copy on a CPU device).
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

// The states of entry i back into dst[order[i]] (dst[i] without an order): R, N and τ, the only
// fields a hash-grid pass changes.
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

// A pass's photons for hash_grid_pass: n records on the host, or on the device (trace_photons_device).
struct PassPhotons {
  const pf_photon* host = nullptr;
  const ClBuffer* device = nullptr;
  size_t n = 0;
};

// One hash-grid pass over nh split hitpoints already in `hps` (the scene's materials in `mats`,
// their pf_pbr_site table in `pbr`, pbr_sites),
// rmax being their largest finite positive radius as max_radius computes it (the cell side is
// hash_cell·rmax): builds the hashed grid — on the host into mapped buffers (photons on the
// device are mapped, no copy on a CPU device; order_hash_grid checks them), or with the device's
// kernels (host photons are checked and uploaded; device photons, made by trace_photons_device
// from the checked scene, are used where they are): opt.hash_order — then gathers and applies
// eq. 3.14–3.18 in one kernel. Returns the new state's rmax (reduced by the kernel, so a state
// kept on the device needs no copy to the host between passes).
// With `weights` (SPPM, DevicePpmState::sppm_pass), τ_M of hitpoint i is multiplied by
// weights[3i .. 3i + 2] before the update.
float hash_grid_pass(const Scene& scene, const SplitHitpoints& hps, const ClBuffer& mats,
                     const ClBuffer& pbr, size_t nh,
                     DirectMode direct, float rmax, const PassPhotons& photons,
                     const PpmOptions& opt, ClContext& dev, GatherTimes& times,
                     const ClBuffer* weights = nullptr) {
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

// The largest finite positive radius of a state (the hash-grid cell size's unit).
float max_radius(const HitpointSet& h) {
  float rmax = 0.f;
  for (const pf_hitpoint& hp : h.hitpoints)
    if (std::isfinite(hp.radius)) rmax = std::max(rmax, hp.radius);
  return rmax;
}

// Hitpoint and photon counts that fit the kernels' int indices.
void check_sizes(size_t hitpoints, size_t photons) {
  if (hitpoints > size_t(INT32_MAX) || photons > size_t(INT32_MAX))
    throw input_error("", "too many hitpoints or photons for the OpenCL backend");
}

// The checks every device pass makes before any work: sizes (check_sizes), alpha, a device method.
void check_pass(const PpmOptions& opt, size_t hitpoints, size_t photons) {
  check_sizes(hitpoints, photons);
  if (!(opt.alpha > 0.f && opt.alpha <= 1.f))
    throw input_error("", "alpha must be in (0, 1], got " + std::to_string(opt.alpha));
  const GatherMethodInfo& mi = gather_method_info(opt.method);
  if (!mi.device)
    throw input_error("", std::string("--method ") + mi.name + " runs on the CPU backend",
                      "use --device cpu, or an OpenCL method such as grid-kmeans");
}

// A pass's bookkeeping on the state (eq. 3.19's N_emitted, the pass count).
void count_pass(HitpointSet& h, uint64_t emitted) {
  h.photons_emitted += emitted;
  h.passes += 1;
  h.estimator = "ppm";
}

// The gathers' pf_pbr_site table (pbr_point_shared.h) of n hitpoints: entry i from hitpoint
// j = order[i] (first + i without an order) of `hps` and its record table[j] (zeros where the
// table ends: require_bsdf_table has checked that no PBR hitpoint lies there), ω_o = −dir, in the
// scratch buffer `name` (or `own`, a resident state's buffer, grown as needed). A scene without
// PBR material gets a one-element stand-in the kernels never read, and costs nothing more.
const ClBuffer& pbr_sites(ClContext& dev, const Scene& scene, const std::string& name,
                          const std::vector<pf_hitpoint>& hps,
                          const std::vector<pf_pbr_point>& table, const int32_t* order,
                          size_t first, size_t n, ClBuffer* own = nullptr) {
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

}  // namespace

void device_exclusive_scan(ClContext& dev, const ClBuffer& data, size_t n) {
  exclusive_scan(dev, data, n);
}

ClusterSet clusters_for_method(GatherMethod m, const HitpointSet& h, int wg_size,
                               const PpmOptions& opt) {
  const char* kind = gather_method_info(m).clusters;
  if (!kind) throw std::invalid_argument(std::string("method ") + gather_method_name(m) + " reads no clusters");
  return std::string(kind) == "kmeans" ? cluster_kmeans(h, wg_size, opt.cluster_iterations, 1, opt.threads)
                                       : cluster_grid(h, wg_size, 0);
}

PhotonGrid build_photon_grid(const std::vector<pf_photon>& photons, int mesh_count,
                             const PhotonGridParams& params, ClContext& dev) {
  check_photons(photons, mesh_count);
  const size_t n = photons.size();
  if (n * sizeof(pf_photon) > dev.max_alloc())
    throw input_error("", "the photons (" + std::to_string(n * sizeof(pf_photon)) +
                              " bytes) exceed the device's largest allocation", "use --device cpu");
  const ClBuffer& in = dev.scratch("ppm.photons", n * sizeof(pf_photon));
  dev.write(in, n * sizeof(pf_photon), photons.data());
  DeviceGrid d = device_grid(dev, in, n, mesh_count, params);
  PhotonGrid g;
  g.params = params;
  g.mesh_grid = d.headers;
  g.cell_start.resize(d.entries);
  g.photons.resize(n);
  g.order.resize(n);
  dev.read(*d.cell_start, d.entries * sizeof(cl_int), g.cell_start.data());
  dev.read(*d.sorted, n * sizeof(pf_photon), g.photons.data());
  dev.read(*d.order, n * sizeof(cl_int), g.order.data());
  return g;
}

void sort_photons_by_mesh(const std::vector<pf_photon>& photons, int mesh_count, ClContext& dev,
                          std::vector<pf_photon>& sorted, std::vector<int32_t>& mesh_start) {
  check_photons(photons, mesh_count);
  const size_t n = photons.size();
  const ClBuffer& in = dev.scratch("ppm.photons", n * sizeof(pf_photon));
  dev.write(in, n * sizeof(pf_photon), photons.data());
  DeviceMeshSort s = device_mesh_sort(dev, in, n, mesh_count);
  sorted.resize(n);
  mesh_start.resize(size_t(mesh_count) + 1);
  dev.read(*s.sorted, n * sizeof(pf_photon), sorted.data());
  dev.read(*s.mesh_start, mesh_start.size() * sizeof(cl_int), mesh_start.data());
}

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

// ---- DevicePpmState ---------------------------------------------------------------------------

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

// ---- GridGatherTimer ----------------------------------------------------------------------------

GridGatherTimer::GridGatherTimer(const Scene& scene, const HitpointSet& h,
                                 const std::vector<pf_photon>& photons, const PpmOptions& opt,
                                 ClContext& dev)
    : dev_(dev), h_(h), variant_(scene_kernel_variant(scene, dev)) {
  nh_ = h.hitpoints.size();
  np_ = photons.size();
  check_sizes(nh_, np_);
  require_one_buffer(dev, nh_, sizeof(pf_hitpoint), "hitpoints", GatherMethod::GridKmeans);
  require_one_buffer(dev, np_, sizeof(pf_photon), "photons", GatherMethod::GridKmeans);
  mesh_count_ = int(scene.mesh_names.size());
  check_photons(photons, mesh_count_);
  skip_direct_ = h.direct_mode == DirectMode::ShadowRays ? 1 : 0;
  acc_bytes_ = dev.info().fp64 ? sizeof(double) : sizeof(float);
  const size_t nh1 = std::max<size_t>(nh_, 1), np1 = std::max<size_t>(np_, 1);
  mats_ = &dev.scratch("timer.materials", std::max<size_t>(scene.materials.size(), 1) * sizeof(pf_material));
  dev.write(*mats_, scene.materials.size() * sizeof(pf_material), scene.materials.data());
  hps_ = &dev.scratch("timer.hitpoints", nh1 * sizeof(pf_hitpoint));
  dev.write(*hps_, nh_ * sizeof(pf_hitpoint), h.hitpoints.data());
  require_bsdf_table(scene, h.hitpoints, h.bsdf);
  pbr_ = &pbr_sites(dev, scene, "timer.pbr", h.hitpoints, h.bsdf, nullptr, 0, nh_);
  acc_m_ = &dev.scratch("timer.acc_m", nh1 * sizeof(cl_int));
  acc_tau_ = &dev.scratch("timer.acc_tau", nh1 * 3 * acc_bytes_);
  dev.fill_zero(*acc_m_, nh1 * sizeof(cl_int));
  const ClBuffer& phs = dev.scratch("timer.photons_in", np1 * sizeof(pf_photon));
  dev.write(phs, np_ * sizeof(pf_photon), photons.data());
  const DeviceGrid g = device_grid(dev, phs, np_, mesh_count_, ppm_grid_params(h, opt), "timer.grid");
  sorted_ = g.sorted;
  mesh_grid_ = g.mesh_grid;
  cell_start_ = g.cell_start;
}

double GridGatherTimer::time(const ClusterSet& c, int runs) {
  check_cluster_count(c, nh_);
  if (nh_ == 0 || np_ == 0) return 0.0;
  ClusterSet cs = c;
  update_cluster_radii(cs, h_);
  const DeviceClusters dc = upload_clusters(dev_, cs, "timer");
  cl_kernel k = dev_.kernel("illuminate_methods", "gather_grid_clusters", variant_);
  double best = INFINITY;
  for (int r = 0; r < std::max(1, runs); ++r) {
    dev_.fill_zero(*acc_m_, nh_ * sizeof(cl_int));
    dev_.fill_zero(*acc_tau_, nh_ * 3 * acc_bytes_);
    dev_.args(k, *hps_, *dc.order, *dc.groups, *dc.clusters, *sorted_, *mesh_grid_, *cell_start_,
              cl_int(mesh_count_), *mats_, *pbr_, cl_int(skip_direct_), *acc_m_, *acc_tau_);
    const double t0 = dev_.kernel_seconds();
    dev_.run(k, dc.items, dc.wg);
    best = std::min(best, since(dev_, t0));
  }
  return best;
}

std::vector<int32_t> GridGatherTimer::photon_counts() {
  std::vector<int32_t> m(nh_, 0);
  if (nh_ > 0) dev_.read(*acc_m_, nh_ * sizeof(cl_int), m.data());
  return m;
}

}  // namespace pf
