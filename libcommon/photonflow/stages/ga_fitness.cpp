// ga_fitness.cpp — the GA's fitness functions (thesis ch. 8.2, 8.3; ga_clusters.h): their names
// and units, the checks of their inputs, the device-time timer, and the fitness of a whole
// clustering computed from scratch. The per-cluster terms the chromosome sums incrementally are
// ga_internal.h's TermCalc.
#include "photonflow/stages/ga_clusters.h"

#include "photonflow/stages/ga_internal.h"

#include <algorithm>
#include <stdexcept>
#include <string>

#include "photonflow/foundations/error.h"
#include "photonflow/stages/illuminate.h"

namespace pf {

// ---- fitness names ------------------------------------------------------------------------------

namespace {
struct FitnessInfo {
  GaFitness f;
  const char* name;
  const char* unit;
};
const FitnessInfo kFitness[] = {
    {GaFitness::Filler, "filler", "filler hitpoints (eq. 8.1)"},
    {GaFitness::GridBins, "grid-bins", "bins x work-groups (eq. 8.2)"},
    {GaFitness::MemoryAccess, "memory-access", "photons per work-item x work-groups (eq. 8.3)"},
    {GaFitness::Work, "work", "photons read by hitpoints per pass"},
    {GaFitness::DeviceTime, "device-time", "us of the gather kernel (best of runs)"},
};
}  // namespace

const char* ga_fitness_name(GaFitness f) {
  for (const FitnessInfo& i : kFitness)
    if (i.f == f) return i.name;
  return "?";
}
const char* ga_fitness_unit(GaFitness f) {
  for (const FitnessInfo& i : kFitness)
    if (i.f == f) return i.unit;
  return "?";
}
std::string ga_fitness_choices() {
  std::string s;
  for (const FitnessInfo& i : kFitness) s += std::string(s.empty() ? "" : " | ") + i.name;
  return s;
}
GaFitness parse_ga_fitness(const std::string& name) {
  for (const FitnessInfo& i : kFitness)
    if (name == i.name) return i.f;
  throw input_error("", "--fitness must be one of " + ga_fitness_choices() + ", got '" + name + "'");
}
bool ga_fitness_needs_distribution(GaFitness f) {
  return f == GaFitness::GridBins || f == GaFitness::MemoryAccess || f == GaFitness::Work;
}

namespace ga {


GridGatherTimer device_timer(const GaFitnessInputs& in) {
  if (!in.device || !in.scene || !in.photons)
    throw std::invalid_argument("device-time fitness needs a device, the scene and photons");
  PpmOptions opt;
  opt.method = GatherMethod::GridKmeans;
  opt.max_bins = in.max_bins;
  return GridGatherTimer(*in.scene, *in.hitpoints, *in.photons, opt, *in.device);
}

double measure_device_us(GridGatherTimer& timer, const ClusterSet& c, const GaFitnessInputs& in) {
  return timer.time(c, std::max(1, in.device_runs)) * 1e6;
}

void check_inputs(const GaFitnessInputs& in, GaFitness f) {
  if (!in.hitpoints) throw std::invalid_argument("ga: no hitpoints");
  if (in.wg_size < 1) throw std::invalid_argument("ga: work-group size must be >= 1");
  if (ga_fitness_needs_distribution(f) && !in.distribution)
    throw input_error("", std::string("--fitness ") + ga_fitness_name(f) +
                              " needs a photon-distribution map", "pass --distribution (photon-distribution makes it)");
  if (f == GaFitness::DeviceTime && (!in.device || !in.scene || !in.photons))
    throw input_error("", "--fitness device-time needs an OpenCL device and photons",
                      "pass --device opencl and --photons");
}

}  // namespace ga

using ga::check_inputs;
using ga::device_timer;
using ga::measure_device_us;
using ga::TermCalc;

double cluster_fitness(const ClusterSet& c, const GaFitnessInputs& in, GaFitness f) {
  check_inputs(in, f);
  if (f == GaFitness::DeviceTime) {
    GridGatherTimer timer = device_timer(in);
    return measure_device_us(timer, c, in);
  }
  DistributionSums sums;
  if (ga_fitness_needs_distribution(f)) sums = DistributionSums(*in.distribution);
  TermCalc calc{f, c.wg_size, &sums};
  int64_t s = 0;
  for (const pf_cluster& cl : c.clusters) s += calc.term(cl.mesh, cl.centre, cl.radius, cl.count);
  return double(s) * calc.scale();
}

}  // namespace pf
