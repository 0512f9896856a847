// progress.h — progress of long work on a terminal: pass, rate, ETA. Silent when stderr is not a
// TTY (logs, CI, pipelines), so batch runs stay quiet.
#pragma once
#include <unistd.h>

#include <cstdio>
#include <string>

#include "photonflow/interrupt.h"
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
    if (interrupted() && !saw_interrupt_) open_ = false, saw_interrupt_ = true;  // its notice
                                                                                // ended the line
    double t = clock_.seconds();
    if (done < total_ && t - last_ < 0.25) return;
    last_ = t;
    double rate = t > 0 ? amount / t : 0.0;
    double eta = done > 0 ? t * double(total_ - done) / double(done) : 0.0;
    std::fprintf(stderr, "\r%s %ld/%ld  %.3g %s/s  ETA %.0f s   ", what_.c_str(), done, total_,
                 rate, unit_.c_str(), eta);
    open_ = done < total_;
    if (!open_) std::fprintf(stderr, "\n");
    std::fflush(stderr);
  }
  // Ends a line left open by a run that stops early (an interrupt), so the next message starts
  // on a line of its own.
  void end_line() {
    if (!open_) return;
    std::fprintf(stderr, "\n");
    open_ = false;
  }

 private:
  std::string what_, unit_;
  long total_;
  bool tty_;
  Stopwatch clock_;
  double last_ = -1.0;
  bool open_ = false;  // a line is shown without its newline
  bool saw_interrupt_ = false;
};

}  // namespace pf
