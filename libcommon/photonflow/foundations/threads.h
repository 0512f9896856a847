// threads.h — worker thread counts. Every stage's --threads option and every OpenMP region take
// their count from here, so a count is checked once (tools: one line, exit 2) and never reaches
// libgomp unchecked (libgomp crashes creating 100 000 threads instead of failing).
// Results never depend on the count: randomness is counter-based (rng.h) and every reduction has a
// fixed order.
#pragma once

namespace pf {

// Most worker threads a run may ask for (--threads or OMP_NUM_THREADS).
constexpr int kMaxThreads = 1024;

// requested > 0 → requested; 0 → OpenMP's default (OMP_NUM_THREADS, else the cores); at most
// kMaxThreads.
int worker_threads(int requested);

// InputError "--threads must be 0 (all cores) to 1024" unless 0 <= threads <= kMaxThreads.
void require_threads(int threads);

// InputError when OMP_NUM_THREADS asks for more than kMaxThreads (run_tool calls it first).
void check_thread_environment();

}  // namespace pf
