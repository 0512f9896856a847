// cl_gather_internal.h — private to the gather files of this folder: the helpers that two or
// more of them share (the sort primitives, the device photon orderings, a cluster set on the
// device, the checks and uploads of a pass, the hash-grid pass), declared once here in pf::detail
// so that no file keeps a copy. Each group names the file that defines it. Not part of the
// library's interface.
#pragma once
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "photonflow/foundations/shared_types.h"
#include "photonflow/material/pbr_point_shared.h"
#include "photonflow/opencl/cl_gather_methods.h"
#include "photonflow/opencl/cl_runtime.h"
#include "photonflow/stages/eye_pass.h"
#include "photonflow/stages/gather_method.h"
#include "photonflow/stages/hash_grid.h"
#include "photonflow/stages/photon_grid.h"

namespace pf {

struct ClusterSet;
struct HitpointSet;
struct PpmOptions;
struct Scene;

namespace detail {

// ---- the sort primitives (cl_scan_sort.cpp) ---------------------------------------------------

// Exclusive prefix sum of data[0 .. n) in place (build_grid.cl's scan_blocks / scan_add); the
// block sums of each level are scanned recursively.
void exclusive_scan(ClContext& dev, const ClBuffer& data, size_t n, int level = 0);

// Counting sort of photon indices by key (key[i] in [0, ranges), rank[i] its place among the
// photons of its key as the atomic counters gave it): counts → exclusive scan (the start table,
// ranges + 1 entries, the last = n) → scatter to start + rank → each range sorted ascending, so
// the order equals a stable sort. `counts` becomes the start table; `order` is the result.
void sort_by_key(ClContext& dev, const ClBuffer& key, const ClBuffer& rank, const ClBuffer& counts,
                 size_t n, size_t ranges, const ClBuffer& order);

// The n photons of `in` in the order `order` (input index of each output photon) into `out`.
void permute(ClContext& dev, const ClBuffer& in, const ClBuffer& order, size_t n,
             const ClBuffer& out);

// ---- the device photon orderings (cl_build_grid.cpp) ------------------------------------------

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
                       const PhotonGridParams& params, const std::string& ns = "grid");

// Photons stably sorted by mesh (the per-mesh arrays of "photon sorting"), on the device.
struct DeviceMeshSort {
  const ClBuffer* sorted = nullptr;
  const ClBuffer* order = nullptr;
  const ClBuffer* mesh_start = nullptr;  // mesh_count + 1 ints
};

DeviceMeshSort device_mesh_sort(ClContext& dev, const ClBuffer& photons, size_t n,
                                int mesh_count);

// The hashed grid of `hash-grid` (hash_grid.h) on the device: the sorted photons' keys and
// payloads and the slot-start table (slots + 1 entries), in the scratch buffers hash.keys,
// hash.payload and hash.start.
struct DeviceHashGrid {
  const ClBuffer* keys = nullptr;
  const ClBuffer* payload = nullptr;
  const ClBuffer* slot_start = nullptr;
};

// Built by the device's kernels from the n photons in `photons` (already uploaded).
DeviceHashGrid device_hash_grid(ClContext& dev, const ClBuffer& photons, size_t n,
                                const HashGridLayout& g);

// Built on the host (order_hash_grid, which also checks the photons) straight into the mapped
// device buffers: the photons never go up unsorted.
DeviceHashGrid host_hash_grid(ClContext& dev, const pf_photon* photons, size_t n,
                              int mesh_count, const HashGridLayout& g, int threads);

// ---- a cluster set on the device (cl_clusters.cpp) --------------------------------------------

// A cluster set on the device: the hitpoint order (fillers -1), the work-group → cluster table
// and the clusters, in the scratch buffers `ns`.order, .group_cluster, .clusters.
struct DeviceClusters {
  const ClBuffer* order = nullptr;
  const ClBuffer* groups = nullptr;
  const ClBuffer* clusters = nullptr;
  size_t items = 0;  // work-items: order.size()
  size_t wg = 0;     // work-group size
};

DeviceClusters upload_clusters(ClContext& dev, const ClusterSet& cs, const std::string& ns);

// The cluster set must belong to the pass's hitpoints.
void check_cluster_count(const ClusterSet& cs, size_t hitpoints);

// ---- the checks and uploads of a pass (cl_pass_inputs.cpp) ------------------------------------

// The host-side checks of the CPU grid build (photon_grid.cpp), so the device never indexes a
// mesh table out of range: every photon's mesh in [0, mesh_count), every position finite.
void check_photons(const pf_photon* photons, size_t n, int mesh_count);
void check_photons(const std::vector<pf_photon>& photons, int mesh_count);

// A device buffer for `count` items of `item` bytes, or InputError naming the batched method.
void require_one_buffer(const ClContext& dev, size_t count, size_t item, const char* what,
                        GatherMethod m);

// Hitpoint and photon counts that fit the kernels' int indices.
void check_sizes(size_t hitpoints, size_t photons);

// The checks every device pass makes before any work: sizes (check_sizes), alpha, a device method.
void check_pass(const PpmOptions& opt, size_t hitpoints, size_t photons);

// A pass's bookkeeping on the state (eq. 3.19's N_emitted, the pass count).
void count_pass(HitpointSet& h, uint64_t emitted);

// The largest finite positive radius of a state (the hash-grid cell size's unit).
float max_radius(const HitpointSet& h);

// The hashed-grid gather's split hitpoints (pf_gather_site, pf_ppm_state; shared_types.h) in two
// device buffers, the namespace's scratch buffers or a resident state's own.
struct SplitHitpoints {
  const ClBuffer* sites = nullptr;
  const ClBuffer* states = nullptr;
};

// Writes hitpoints src[order[i]] (src[i] without an order) as entry i of the split buffers, through
// mappings (no staging copy on a CPU device).
void write_split(ClContext& dev, const SplitHitpoints& d, const pf_hitpoint* src,
                 const int32_t* order, size_t n);

// The states of entry i back into dst[order[i]] (dst[i] without an order): R, N and τ, the only
// fields a hash-grid pass changes.
void read_split_states(ClContext& dev, const SplitHitpoints& d, pf_hitpoint* dst,
                       const int32_t* order, size_t n);

// The gathers' pf_pbr_site table (pbr_point_shared.h) of n hitpoints: entry i from hitpoint
// j = order[i] (first + i without an order) of `hps` and its record table[j] (zeros where the
// table ends: require_bsdf_table has checked that no PBR hitpoint lies there), ω_o = −dir, in the
// scratch buffer `name` (or `own`, a resident state's buffer, grown as needed). A scene without
// PBR material gets a one-element stand-in the kernels never read, and costs nothing more.
const ClBuffer& pbr_sites(ClContext& dev, const Scene& scene, const std::string& name,
                          const std::vector<pf_hitpoint>& hps,
                          const std::vector<pf_pbr_point>& table, const int32_t* order,
                          size_t first, size_t n, ClBuffer* own = nullptr);

// Kernel seconds since t0 (a ClContext::kernel_seconds reading).
inline double since(ClContext& dev, double t0) { return dev.kernel_seconds() - t0; }

// ---- the hash-grid pass (cl_gather_methods.cpp) -----------------------------------------------

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
                     const ClBuffer* weights = nullptr);

}  // namespace detail
}  // namespace pf
