// stage_file_checks.h — what the readers and checks of the three stage files share
// (hitpoints_file.cpp, photons_file.cpp, grid_file.cpp; defined in stage_files.cpp): attributes
// in range, pass indices, finite positions, the photons' values, and the messages' wording.
// Private to those files.
#pragma once
#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "photonflow/io/h5io.h"
#include "photonflow/io/stage_files.h"
#include "photonflow/io/validate.h"

namespace pf {

// An int64 attribute that must lie in [lo, hi] (it is kept in an int).
int64_t attr_in(const h5::Reader& r, const std::string& path, const std::string& obj,
                const std::string& name, int64_t lo, int64_t hi, const std::string& hint);

constexpr int64_t kIntMax = std::numeric_limits<int32_t>::max();

// first_pass of a file of `passes` passes: pass indices first_pass … first_pass + passes − 1 are
// int32 (the photons' `pass` field, the grid's /pass<k> groups, the hitpoints' pass count).
int check_first_pass(const h5::Reader& r, const std::string& path, size_t passes,
                     const std::string& hint);

bool finite3(const float* p);

// "<what> id <value> is outside the scene's <size> <table>", for the messages.
std::string out_of(const char* what, int32_t value, size_t size, const char* table);

// The photons of a pass (photons.h5 or a grid pass): position, unit direction, flux and flags.
void check_photon_values(const std::string& dataset, const std::vector<pf_photon>& photons,
                         size_t begin, size_t end, const Validator& v);

// pass_emitted of a photons or grid file: every pass emitted 1 … kMaxPhotonsPerPass photons
// (validate.h), the bound every count of photons emitted shares, so sums of them never wrap.
void check_pass_emitted(const std::vector<uint64_t>& emitted, const Validator& v);

}  // namespace pf
