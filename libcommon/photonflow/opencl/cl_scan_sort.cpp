// cl_scan_sort.cpp — the sort primitives of the device photon orderings (kernels/build_grid.cl):
// the exclusive prefix sum, the counting sort by key and the permutation of photons, kept apart
// from the grids they build so that each grid build reads as its steps.
#include "photonflow/opencl/cl_scan_sort.h"

#include <climits>
#include <stdexcept>
#include <string>

#include "photonflow/opencl/cl_gather_internal.h"

namespace pf {

using namespace detail;

namespace {

constexpr size_t kScanItems = 16;  // PF_SCAN_ITEMS of build_grid.cl

}  // namespace

namespace detail {

void exclusive_scan(ClContext& dev, const ClBuffer& data, size_t n, int level) {
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

}  // namespace detail

void device_exclusive_scan(ClContext& dev, const ClBuffer& data, size_t n) {
  exclusive_scan(dev, data, n);
}

}  // namespace pf
