// Worker thread counts: see threads.h.
#include "photonflow/foundations/threads.h"

#include <omp.h>

#include <algorithm>
#include <cstdlib>
#include <string>

#include "photonflow/foundations/error.h"

namespace pf {

int worker_threads(int requested) {
  const int n = requested > 0 ? requested : omp_get_max_threads();
  return std::clamp(n, 1, kMaxThreads);
}

void require_threads(int threads) {
  if (threads < 0 || threads > kMaxThreads)
    throw input_error("", "--threads must be 0 (all cores) to " + std::to_string(kMaxThreads) +
                              ", got " + std::to_string(threads));
}

void check_thread_environment() {
  if (omp_get_max_threads() > kMaxThreads) {
    const char* env = std::getenv("OMP_NUM_THREADS");
    throw input_error("", "OMP_NUM_THREADS=" + std::string(env ? env : "?") +
                              " asks for more than " + std::to_string(kMaxThreads) + " threads",
                      "unset it or lower it");
  }
}

}  // namespace pf
