// The genetic algorithm's evolution loop (thesis ch. 8; ga_clusters.h: evolve_clusters): the
// population, selection and mutation over GaState chromosomes (ga_chromosome.h), checkpoints
// (ga_checkpoint.h) and the worker pool that evaluates a generation.
#include "photonflow/stages/ga_clusters.h"

#include "photonflow/stages/ga_checkpoint.h"
#include "photonflow/stages/ga_internal.h"

#include <omp.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cfloat>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <cstring>
#include <exception>
#include <limits>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <thread>

#include "photonflow/opencl/cl_backend.h"
#include "photonflow/opencl/cl_gather.h"
#include "photonflow/io/h5io.h"
#include "photonflow/foundations/hash.h"
#include "photonflow/foundations/interrupt.h"
#include "photonflow/io/provenance.h"
#include "photonflow/foundations/threads.h"
#include "photonflow/io/validate.h"

namespace pf {

using ga::check_inputs;
using ga::device_timer;
using ga::measure_device_us;

// ---- the evolution --------------------------------------------------------------------------------

namespace {

// Runs f(worker, item) for the items 0 … n−1 on `workers` threads (worker 0 is the calling
// thread), handing items out one at a time, and returns when every item is done. Between calls
// the threads sleep on a condition variable. A generation is about a millisecond of work:
// OpenMP's spinning barriers (twice per generation) cost several times more than the work
// whenever another process holds one of the cores, which on a shared 2-core machine is most of the
// time; and the caller never waits for a worker that took no item (one that wakes late finds the
// round's items gone). Items carry their round in the ticket and a worker takes items only of the
// round it read (with that round's item count) under the lock, so a late worker can never take an
// item of a later round with an earlier round's view of it.
class WorkerPool {
 public:
  explicit WorkerPool(int workers) {
    for (int w = 1; w < workers; ++w) threads_.emplace_back([this, w] { loop(w); });
  }
  ~WorkerPool() {
    {
      std::lock_guard<std::mutex> lock(m_);
      stop_ = true;
    }
    wake_.notify_all();
    for (std::thread& t : threads_) t.join();
  }
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  void run(int n, const std::function<void(int, int)>& f) {
    if (n <= 0) return;
    uint64_t round;
    {
      std::lock_guard<std::mutex> lock(m_);
      job_ = &f;
      n_ = uint64_t(n);
      done_ = 0;
      error_ = nullptr;
      round = ++round_;
      ticket_.store(round << 32, std::memory_order_release);
    }
    wake_.notify_all();
    work(0, round, uint64_t(n));
    std::unique_lock<std::mutex> lock(m_);
    finished_.wait(lock, [&] { return done_ == uint64_t(n); });
    if (error_) std::rethrow_exception(error_);
  }

 private:
  // Takes and runs items of `round` (n items) until none is left.
  void work(int w, uint64_t round, uint64_t n) {
    for (;;) {
      uint64_t t = ticket_.load(std::memory_order_acquire);
      if ((t >> 32) != round || (t & 0xffffffffu) >= n) return;
      if (!ticket_.compare_exchange_weak(t, t + 1, std::memory_order_acq_rel)) continue;
      try {
        (*job_)(w, int(t & 0xffffffffu));
      } catch (...) {
        std::lock_guard<std::mutex> lock(m_);
        if (!error_) error_ = std::current_exception();
      }
      std::lock_guard<std::mutex> lock(m_);
      if (++done_ == n) finished_.notify_one();
    }
  }
  void loop(int w) {
    uint64_t seen = 0, n = 0;
    for (;;) {
      {
        std::unique_lock<std::mutex> lock(m_);
        wake_.wait(lock, [&] { return stop_ || round_ != seen; });
        if (stop_) return;
        seen = round_;
        n = n_;
      }
      work(w, seen, n);
    }
  }

  std::vector<std::thread> threads_;
  std::mutex m_;
  std::condition_variable wake_, finished_;
  const std::function<void(int, int)>* job_ = nullptr;  // set before the round's ticket
  uint64_t n_ = 0;                                     // items of the current round (under m_)
  uint64_t done_ = 0;                                  // items finished (under m_)
  uint64_t round_ = 0;                                 // under m_
  std::atomic<uint64_t> ticket_{0};                    // round << 32 | next item
  bool stop_ = false;
  std::exception_ptr error_;
};

}  // namespace

GaResult evolve_clusters(const GaFitnessInputs& in, const GaOptions& opt,
                         const std::function<bool(const GaProgress&)>& on_generation) {
  const GaFitness f = opt.fitness;
  check_inputs(in, f);
  if (opt.population < 2) throw input_error("", "--population must be >= 2 (parent + children)");
  if (opt.iterations < 0) throw input_error("", "--ga-iterations must be >= 0");
  if (opt.checkpoint_every < 1) throw input_error("", "--checkpoint-every must be >= 1");
  Stopwatch clock;
  const HitpointSet& h = *in.hitpoints;
  if (h.hitpoints.empty()) throw input_error("", "no hitpoints to cluster");
  GaResult res;
  const ClusterSet km = cluster_kmeans(h, in.wg_size, opt.kmeans_iterations, opt.seed, opt.threads);
  const bool device = f == GaFitness::DeviceTime;
  std::optional<GridGatherTimer> timer;  // device-time: the photons' grid, built once per run
  if (device) timer.emplace(device_timer(in));
  res.kmeans_fitness = device ? measure_device_us(*timer, km, in) : cluster_fitness(km, in, f);
  const int threads = device ? 1 : worker_threads(opt.threads);
  const std::string id = opt.checkpoint.empty() ? "" : ga::inputs_id(in, f);
  const std::string hp_hash = opt.checkpoint.empty() ? "" : hitpoints_hash(h);

  std::vector<GaState> copies;
  ga::Checkpoint ck;
  double prior_seconds = 0;
  if (opt.resume && !opt.checkpoint.empty() && access(opt.checkpoint.c_str(), F_OK) == 0) {
    ck = ga::load_checkpoint(opt.checkpoint, in, opt, hp_hash, id);
    copies.emplace_back(in, f, ck.centroids, ck.next_id);
    if (!device && copies[0].fitness() != ck.fitness)
      throw input_error(opt.checkpoint, "holds a chromosome whose fitness does not match its record",
                        "delete it and rerun");
    res.resumed_from = ck.generations;
    prior_seconds = ck.seconds;
  } else {
    copies.emplace_back(in, f, km);
    ck.fitness = device ? measure_device_us(*timer, copies[0].clusters(), in) : copies[0].fitness();
    ck.start_fitness = ck.fitness;
    ck.next_id = copies[0].next_id();
  }
  res.start_fitness = ck.start_fitness;
  for (int t = 1; t < threads; ++t) copies.push_back(copies[0]);

  const int lambda = opt.population - 1, total = opt.iterations + 1;
  WorkerPool pool(threads);
  std::vector<double> child(static_cast<size_t>(lambda));
  for (int g = ck.generations; g < total; ++g) {
    // Generation g: λ children of the parent (generation 0: of the k-means chromosome, the
    // initial population). Child c draws from the stream (seed, g, c).
    if (!device) {
      pool.run(lambda, [&](int w, int c) {
        GaState& st = copies[size_t(w)];
        pf_rng rng = pf_rng_start(opt.seed, uint32_t(g), uint32_t(c));
        st.mutate_child(rng);
        st.evaluate();
        child[size_t(c)] = st.fitness();
        st.undo();
      });
    } else {
      // A device time is noisy (on a shared machine by up to 2x, when other work takes a core):
      // the parent is timed again with its children, so that every generation compares
      // measurements taken together and one lucky measurement cannot stay the best for good.
      ck.fitness = measure_device_us(*timer, copies[0].clusters(), in);
      for (int c = 0; c < lambda; ++c) {
        GaState& st = copies[0];
        pf_rng rng = pf_rng_start(opt.seed, uint32_t(g), uint32_t(c));
        st.mutate_child(rng);
        st.evaluate();
        child[size_t(c)] = measure_device_us(*timer, st.clusters(), in);
        st.undo();
      }
    }
    const int best = int(std::min_element(child.begin(), child.end()) - child.begin());
    if (child[size_t(best)] <= ck.fitness) {  // 1+λ: never worse than the parent
      pool.run(threads, [&](int, int t) {  // every copy takes the same child
        pf_rng rng = pf_rng_start(opt.seed, uint32_t(g), uint32_t(best));
        copies[size_t(t)].mutate_child(rng);
        copies[size_t(t)].evaluate();
        copies[size_t(t)].commit();
      });
      ck.fitness = child[size_t(best)];
    }
    ck.history.push_back(ck.fitness);
    ck.evaluations += uint64_t(lambda);
    ck.generations = g + 1;
    ck.seconds = prior_seconds + clock.seconds();
    const bool last = g + 1 == total;
    bool stop = false;
    if (on_generation) {
      GaProgress p;
      p.generation = g + 1;
      p.total = total;
      p.best = ck.fitness;
      p.seconds = clock.seconds();
      p.resumed_from = res.resumed_from;
      stop = !on_generation(p);
    }
    if (!opt.checkpoint.empty() && (stop || last || (g + 1) % opt.checkpoint_every == 0))
      ga::save_checkpoint(opt.checkpoint, copies[0], in, opt, hp_hash, id, ck, clock.seconds());
    if (stop && !last) {
      res.interrupted = true;
      res.generations = ck.generations;
      res.history = ck.history;
      res.fitness = ck.fitness;
      res.evaluations = ck.evaluations;
      res.seconds = ck.seconds;
      return res;
    }
  }
  res.clusters = copies[0].clusters();
  res.fitness = ck.fitness;
  res.history = ck.history;
  res.generations = ck.generations;
  res.evaluations = ck.evaluations;
  res.seconds = prior_seconds + clock.seconds();
  return res;
}

void write_ga_record(h5::Writer& w, const GaResult& r, const GaOptions& opt) {
  w.group("/ga");
  w.attr("/ga", "fitness", ga_fitness_name(opt.fitness));
  w.attr("/ga", "fitness_unit", ga_fitness_unit(opt.fitness));
  w.attr("/ga", "seed", int64_t(opt.seed));
  w.attr("/ga", "population", int64_t(opt.population));
  w.attr("/ga", "iterations", int64_t(opt.iterations));
  w.attr("/ga", "generations", int64_t(r.generations));
  w.attr("/ga", "best_fitness", r.fitness);
  w.attr("/ga", "start_fitness", r.start_fitness);
  w.attr("/ga", "kmeans_fitness", r.kmeans_fitness);
  w.attr("/ga", "evaluations", int64_t(r.evaluations));
  w.attr("/ga", "seconds", r.seconds);
  w.attr("/ga", "resumed_from", int64_t(r.resumed_from));
  w.write("/ga/best_fitness", r.history);
  w.describe("/ga/best_fitness", ga_fitness_unit(opt.fitness),
             "best fitness after each generation; [0] = after the initial population (k-means and "
             "its mutants)");
}

GaProgressLine::GaProgressLine(std::string unit) : unit_(std::move(unit)) {}

void GaProgressLine::update(const GaProgress& p) {
  if (!line_.tty()) return;
  const bool done = p.generation >= p.total;
  if (!done && p.seconds - last_ < 0.25) return;
  last_ = p.seconds;
  const int ran = p.generation - p.resumed_from;
  const double eta = ran > 0 ? p.seconds * double(p.total - p.generation) / double(ran) : 0.0;
  line_.draw(done, "generation %d/%d  best %.6g %s  ETA %.0f s   ", p.generation, p.total, p.best,
             unit_.c_str(), eta);
}

}  // namespace pf
