// ga_checkpoint.h — the GA's checkpoint file (photonflow.ga_checkpoint, docs/FORMATS.md), for
// ga_evolution.cpp's evolution loop only: the chromosome and history of a run written every
// --checkpoint-every generations and read back by --resume, checked on read and before it is
// written with the same function (validate_checkpoint; validate.h written_check).
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "photonflow/stages/ga_clusters.h"
#include "photonflow/io/provenance.h"

namespace pf::ga {

struct Checkpoint {
  std::vector<GaCentroid> centroids;
  uint32_t next_id = 0;
  int generations = 0;
  double fitness = 0, start_fitness = 0, seconds = 0;
  uint64_t evaluations = 0;
  std::vector<double> history;
};

// Identity of what the fitness reads besides the hitpoints: the distribution map's content, and
// for device-time the photons and grid bins.
std::string inputs_id(const GaFitnessInputs& in, GaFitness f);
// The values and the chromosome's meshes of a checkpoint (InputError naming path).
void validate_checkpoint(const Checkpoint& ck, const GaFitnessInputs& in, const std::string& path);
// Writes the checkpoint of state `st` (its centroids and next id) with `ck`'s history, atomically.
void save_checkpoint(const std::string& path, const GaState& st, const GaFitnessInputs& in,
                     const GaOptions& opt, const std::string& hp_hash, const std::string& id,
                     const Checkpoint& ck, double call_seconds);
// Reads a checkpoint of a run with these inputs and options (InputError otherwise).
Checkpoint load_checkpoint(const std::string& path, const GaFitnessInputs& in, const GaOptions& opt,
                           const std::string& hp_hash, const std::string& id);

}  // namespace pf::ga
