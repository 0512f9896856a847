// progress.h — progress of long work on a terminal: pass, rate, ETA. Silent when stderr is not a
// TTY (logs, CI, pipelines), so batch runs stay quiet.
#pragma once
#include <unistd.h>

#include <cstdio>
#include <string>

#include "photonflow/provenance.h"

namespace pf {

class Progress {
 public:
  // `total` steps of `what` (e.g. "pass"); `unit` names the rate's unit (e.g. "photons").
  Progress(std::string what, long total, std::string unit)
      : what_(std::move(what)), unit_(std::move(unit)), total_(total), tty_(isatty(2) != 0) {}
  // Reports that `done` steps are finished and `amount` units were processed in all.
  void update(long done, double amount) {
    if (!tty_) return;
    double t = clock_.seconds();
    if (done < total_ && t - last_ < 0.25) return;
    last_ = t;
    double rate = t > 0 ? amount / t : 0.0;
    double eta = done > 0 ? t * double(total_ - done) / double(done) : 0.0;
    std::fprintf(stderr, "\r%s %ld/%ld  %.3g %s/s  ETA %.0f s   ", what_.c_str(), done, total_,
                 rate, unit_.c_str(), eta);
    if (done >= total_) std::fprintf(stderr, "\n");
    std::fflush(stderr);
  }

 private:
  std::string what_, unit_;
  long total_;
  bool tty_;
  Stopwatch clock_;
  double last_ = -1.0;
};

}  // namespace pf
