// ch6_common.h — helpers shared by the thesis ch. 6 benchmarks (bench_ch6_index.cpp,
// bench_ch6_photonmap.cpp). Benchmarks only (not part of libcommon).
#pragma once
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "bench_common.h"

namespace pf::bench {

// "a,b,c" → values (std::stod, converted to T); empty items are skipped.
template <class T>
std::vector<T> parse_list(const std::string& s) {
  std::vector<T> out;
  for (const std::string& item : split_list(s)) out.push_back(T(std::stod(item)));
  return out;
}

// The 1-minute load average (/proc/loadavg), −1 if unreadable: printed with the tables, since
// the machine is shared and a load above the core count slows every timing.
inline double load_average() {
  std::ifstream f("/proc/loadavg");
  double l = -1;
  f >> l;
  return l;
}

}  // namespace pf::bench
