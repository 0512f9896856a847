// ga_internal.h — what the genetic algorithm's sources share beyond ga_clusters.h: the fitness
// terms of one cluster, the device-time timer and the input checks (ga_fitness.cpp), read by the
// chromosome (ga_chromosome.h) and the evolution loop (ga_evolution.cpp); not part of the
// library's interface.
#pragma once
#include <cstdint>

#include "photonflow/opencl/cl_gather.h"
#include "photonflow/stages/ga_clusters.h"

namespace pf::ga {

// Squared distance in double (the nearest-centroid rule's metric, ga_clusters.h).
inline double dist2(const float* a, const float* b) {
  const double dx = double(a[0]) - double(b[0]), dy = double(a[1]) - double(b[1]),
               dz = double(a[2]) - double(b[2]);
  return dx * dx + dy * dy + dz * dz;
}

// The integer fitness term of one cluster (eq. 8.1–8.3, work), and the scale to the fitness unit.
struct TermCalc {
  GaFitness f = GaFitness::Filler;
  int64_t wg = 64;
  const DistributionSums* sums = nullptr;

  int64_t term(int mesh, const float centre[3], float radius, int64_t count) const {
    const int64_t groups = (count + wg - 1) / wg;  // workgroups(c)
    if (f == GaFitness::Filler || f == GaFitness::DeviceTime) return groups * wg - count;  // eq. 8.1
    int lo[3], hi[3];
    if (!sums->box(mesh, centre, radius, lo, hi)) return 0;  // a mesh without photons: no reads
    if (f == GaFitness::GridBins)  // eq. 8.2: bins(c)·workgroups(c)
      return int64_t(hi[0] - lo[0] + 1) * (hi[1] - lo[1] + 1) * (hi[2] - lo[2] + 1) * groups;
    const int64_t photons = int64_t(sums->photons(mesh, lo, hi));  // Σ over passes
    if (f == GaFitness::MemoryAccess) return photons * groups;  // eq. 8.3, × passes·wg_size
    return photons * count;                                    // work, × passes
  }
  double scale() const {
    const double passes = sums && sums->map() ? double(sums->map()->passes) : 1.0;
    if (f == GaFitness::MemoryAccess) return 1.0 / (passes * double(wg));
    if (f == GaFitness::Work) return 1.0 / passes;
    return 1.0;
  }
};

// The device-time fitness: the grid-cluster gather's kernel time in us, best of in.device_runs,
// on a timer that holds the photons' grid (built once per timer, cl_gather.h).
GridGatherTimer device_timer(const GaFitnessInputs& in);
double measure_device_us(GridGatherTimer& timer, const ClusterSet& c, const GaFitnessInputs& in);
// Refuses inputs fitness f cannot use (InputError for a missing map or device; invalid_argument
// for a caller's mistake).
void check_inputs(const GaFitnessInputs& in, GaFitness f);

}  // namespace pf::ga
