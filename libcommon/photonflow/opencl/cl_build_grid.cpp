// cl_build_grid.cpp — the photon orderings built on the device (kernels/build_grid.cl): the
// per-mesh uniform grid of eq. 7.1, the stable sort by mesh of photon sorting and the hashed grid
// of hash-grid (by the device's kernels or by the host into mapped buffers), and the downloads of
// the first two for build-grid and the tests. One file, because the three share their steps.
#include "photonflow/opencl/cl_build_grid.h"

#include <algorithm>
#include <climits>
#include <stdexcept>
#include <string>

#include "photonflow/foundations/error.h"
#include "photonflow/opencl/cl_gather_internal.h"
#include "photonflow/stages/grid_shared.h"
#include "photonflow/stages/hash_grid.h"
#include "photonflow/stages/photon_grid.h"

namespace pf {

using namespace detail;

namespace {

constexpr size_t kChunk = 256;     // PF_CHUNK of build_grid.cl

DeviceHashGrid hash_grid_buffers(ClContext& dev, size_t n, const HashGridLayout& g) {
  DeviceHashGrid d;
  d.slot_start = &dev.scratch("hash.start", (g.slots() + 1) * sizeof(cl_int));
  d.keys = &dev.scratch("hash.keys", hash_grid_key_blocks(n) * sizeof(pf_photon_keys4));
  d.payload = &dev.scratch("hash.payload", n * sizeof(pf_photon_payload));
  return d;
}

}  // namespace

namespace detail {

DeviceGrid device_grid(ClContext& dev, const ClBuffer& photons, size_t n, int mesh_count,
                       const PhotonGridParams& params, const std::string& ns) {
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

}  // namespace detail

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

}  // namespace pf
