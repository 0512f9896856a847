// Ctrl-C, SIGTERM and SIGHUP: see interrupt.h.
#include "photonflow/foundations/interrupt.h"

#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <cstring>

#include "photonflow/io/output_file.h"

namespace pf {

namespace {

std::atomic<const char*> g_notice{nullptr};  // set while a StopOnInterrupt scope is open
std::atomic<bool> g_tty{false};  // stderr is a terminal: the notice starts a new line after the
                                 // progress line (progress.h)
volatile sig_atomic_t g_interrupted = 0;

constexpr int kSignals[] = {SIGINT, SIGTERM, SIGHUP};

extern "C" void on_interrupt(int sig) {
  const char* notice = g_notice.load();
  if (notice && !g_interrupted) {  // the first signal in a stoppable loop: ask it to stop
    g_interrupted = 1;
    ssize_t ignored = g_tty.load() ? write(STDERR_FILENO, "\n", 1) : 0;
    ignored = write(STDERR_FILENO, notice, std::strlen(notice));
    (void)ignored;
    return;
  }
  remove_tracked_temps();
  // End by the same signal, with its default action.
  struct sigaction dfl {};
  dfl.sa_handler = SIG_DFL;
  sigemptyset(&dfl.sa_mask);
  sigaction(sig, &dfl, nullptr);
  raise(sig);  // pending until this handler returns: the process ends then
}

}  // namespace

void install_interrupt_handlers() {
  struct sigaction sa {};
  sa.sa_handler = on_interrupt;
  sigemptyset(&sa.sa_mask);
  for (int s : kSignals) sigaddset(&sa.sa_mask, s);  // one handler at a time
  sa.sa_flags = SA_RESTART;
  for (int s : kSignals) {
    struct sigaction old {};
    sigaction(s, nullptr, &old);
    // A signal the tool was started with ignored (nohup, a background job of a non-interactive
    // shell) stays ignored.
    if (old.sa_handler == SIG_IGN) continue;
    sigaction(s, &sa, nullptr);
  }
}

bool interrupted() { return g_interrupted != 0; }

StopOnInterrupt::StopOnInterrupt(const char* notice) {
  g_interrupted = 0;
  g_tty.store(isatty(STDERR_FILENO) != 0);
  g_notice.store(notice);
}

StopOnInterrupt::~StopOnInterrupt() { g_notice.store(nullptr); }

}  // namespace pf
