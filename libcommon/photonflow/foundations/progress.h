// progress.h — progress of long work on a terminal: pass, rate, ETA. Silent when stderr is not a
// TTY (logs, CI, pipelines), so batch runs stay quiet.
#pragma once
#include <unistd.h>

#include <algorithm>
#include <cstdarg>
#include <cstdio>
#include <string>

#include "photonflow/foundations/interrupt.h"
#include "photonflow/io/provenance.h"

namespace pf {

// One line redrawn in place on a terminal (stderr, only when it is a TTY), for the progress of long
// work; it knows whether the line is still open, so a message can start on a line of its own.
class TerminalLine {
 public:
  TerminalLine() : tty_(isatty(2) != 0) {}
  bool tty() const { return tty_; }
  // Redraws the line (printf format); `final` ends it with a newline.
  __attribute__((format(printf, 3, 4))) void draw(bool final, const char* format, ...) {
    std::va_list args;
    va_start(args, format);
    std::fputc('\r', stderr);
    std::vfprintf(stderr, format, args);
    va_end(args);
    if (final) std::fputc('\n', stderr);
    std::fflush(stderr);
    open_ = !final;
    interrupted_when_drawn_ = interrupted();
  }
  // Ends a line left open by a run that stops early, so the next message starts on a line of its
  // own; not when an interrupt's notice (interrupt.h), written since the last draw, ended it.
  void end_line() {
    if (open_ && !(interrupted() && !interrupted_when_drawn_)) {
      std::fputc('\n', stderr);
      std::fflush(stderr);
    }
    open_ = false;
  }

 private:
  bool tty_;
  bool open_ = false;  // drawn without its newline
  bool interrupted_when_drawn_ = false;
};

class Progress {
 public:
  // `total` steps of `what` (e.g. "pass"); `unit` names the rate's unit (e.g. "photons").
  Progress(std::string what, long total, std::string unit)
      : what_(std::move(what)), unit_(std::move(unit)), total_(total) {}
  // A wall-clock budget in seconds (render --time): the ETA is then the earlier of the steps'
  // and the budget's end, and with steps past counting (`total` a mere cap) the line shows the
  // budget instead of the total.
  void set_budget(double seconds, bool steps_capped_only) {
    budget_ = seconds;
    no_total_ = steps_capped_only;
  }
  // Reports that `done` steps are finished and `amount` units were processed in all.
  void update(long done, double amount) {
    if (!line_.tty()) return;
    double t = clock_.seconds();
    if (done < total_ && t - last_ < 0.25) return;
    last_ = t;
    double rate = t > 0 ? amount / t : 0.0;
    double eta = done > 0 ? t * double(total_ - done) / double(done) : 0.0;
    if (budget_ > 0) eta = std::min(eta, std::max(0.0, budget_ - t));
    if (no_total_)
      line_.draw(done >= total_, "%s %ld (budget %.0f s)  %.3g %s/s  ETA %.0f s   ", what_.c_str(),
                 done, budget_, rate, unit_.c_str(), eta);
    else
      line_.draw(done >= total_, "%s %ld/%ld  %.3g %s/s  ETA %.0f s   ", what_.c_str(), done,
                 total_, rate, unit_.c_str(), eta);
  }
  // Ends a line left open by a run that stops early (an interrupt).
  void end_line() { line_.end_line(); }

 private:
  std::string what_, unit_;
  long total_;
  double budget_ = 0;
  bool no_total_ = false;
  TerminalLine line_;
  Stopwatch clock_;
  double last_ = -1.0;
};

}  // namespace pf
