// cl_gather.h — hitpoint illumination on the OpenCL device (thesis ch. 7.3): the device
// photon orderings (kernels/build_grid.cl) and the gather methods of gather_method.h
// (kernels/illuminate_methods.cl), behind cl_backend.h's ppm_pass(…, ClContext&).
//
// What each method builds before it gathers (all deterministic):
//   naive, local-memory                 nothing (photons in pass order);
//   photon-sort … kmeans-clusters       per-mesh photon arrays: a stable counting sort by mesh;
//   grid-kmeans, grid-gridclusters      the per-mesh uniform grid of eq. 7.1: bounds reduced on the
//                                       device, headers by photon_grid.h's mesh_grid_header, bins
//                                       counted with atomic counters, a prefix sum (the bin-start
//                                       table), a separate scatter kernel, bins sorted by photon
//                                       index — the same arrays as the CPU's build_photon_grid;
//   hash-grid                           one grid of cells hash_cell·max R (default 2, times a
//                                       1e-4 slack) over the scene, its cells hashed by linear
//                                       index into a power-of-two table (hash_grid.h), built by
//                                       the same count / scan / scatter / sort kernels — or, on a
//                                       CPU device, by the host straight into the mapped buffers
//                                       (PpmOptions::hash_order; the same bytes) — as the photons'
//                                       keys (position, mesh, direct flag, in blocks of four that
//                                       the gather tests per float4) and payloads (direction,
//                                       flux); its gather kernel also applies eq. 3.14–3.18 and
//                                       reduces the next max R.
// The host supplies the hitpoint orders: mesh_sorted_order (hitpoint sorting, fillers) and the
// clusters' order (clusters.h), one work-group per cluster.
//
// Limits: every method but naive keeps the pass's hitpoints and photons in one device buffer
// each (InputError naming --method naive, which batches, when they exceed the device's largest
// allocation).
//
// The parts, one header each (this header includes them all):
//   cl_gather_methods.h     GatherTimes, DevicePhotons and the probabilistic-PPM gather; the
//                           methods themselves run behind ppm_pass (cl_backend.h);
//   cl_build_grid.h         the device photon orderings, downloaded (build-grid, tests);
//   cl_scan_sort.h          the device's exclusive prefix sum;
//   cl_clusters.h           the clusters a clustered method reads;
//   cl_ppm_state.h          DevicePpmState, the PPM state kept on the device between passes;
//   cl_grid_gather_timer.h  GridGatherTimer, the grid-cluster gather alone (the GA's fitness).
// Private to their sources: cl_gather_internal.h.
#pragma once
#include "photonflow/opencl/cl_build_grid.h"
#include "photonflow/opencl/cl_clusters.h"
#include "photonflow/opencl/cl_gather_methods.h"
#include "photonflow/opencl/cl_grid_gather_timer.h"
#include "photonflow/opencl/cl_ppm_state.h"
#include "photonflow/opencl/cl_scan_sort.h"
