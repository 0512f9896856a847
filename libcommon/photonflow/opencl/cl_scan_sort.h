// cl_scan_sort.h — the device's exclusive prefix sum, the primitive under the photon orderings
// (cl_build_grid.h) and the device compaction of traced photons (cl_backend.cpp).
#pragma once
#include <cstddef>

#include "photonflow/opencl/cl_runtime.h"

namespace pf {

// Exclusive prefix sum of the n ints of `data`, in place, on the device (kernels/build_grid.cl,
// scan_blocks and scan_add; the block sums of each level scanned recursively).
void device_exclusive_scan(ClContext& dev, const ClBuffer& data, size_t n);

}  // namespace pf
