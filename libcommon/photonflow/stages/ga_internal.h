// ga_internal.h — what ga_clusters.cpp (fitness and chromosome) shares with ga_evolution.cpp (the
// evolution loop); not part of the library's interface.
#pragma once
#include "photonflow/opencl/cl_gather.h"
#include "photonflow/stages/ga_clusters.h"

namespace pf::ga {

// The device-time fitness: the grid-cluster gather's kernel time in us, best of in.device_runs,
// on a timer that holds the photons' grid (built once per timer, cl_gather.h).
GridGatherTimer device_timer(const GaFitnessInputs& in);
double measure_device_us(GridGatherTimer& timer, const ClusterSet& c, const GaFitnessInputs& in);
// Refuses inputs fitness f cannot use (InputError for a missing map or device; invalid_argument
// for a caller's mistake).
void check_inputs(const GaFitnessInputs& in, GaFitness f);

}  // namespace pf::ga
