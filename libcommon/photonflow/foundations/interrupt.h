// interrupt.h — Ctrl-C (SIGINT), SIGTERM and SIGHUP in the tools.
//
// Every tool installs these handlers (run_tool, tool_main.h). A signal removes the temporary
// output files being written (TempOutput, output_file.h) and then ends the process by the same
// signal, as it would have ended without the handler (exit status 128 + n in a shell). So an
// interrupted stage leaves no "<out>.tmp.<pid>" behind, and never a file that looks whole.
//
// A long loop that can stop cleanly opens a StopOnInterrupt scope: render between photon passes
// (it saves --checkpoint and exits 130), cluster between GA generations (it saves its
// checkpoint). Inside the scope the first signal only prints the scope's notice and sets the flag
// that interrupted() returns, which the loop polls between steps; a second signal ends the
// process at once, as above.
#pragma once

namespace pf {

// Installs the handlers (SA_RESTART: a stopping loop's system calls are not cut short).
void install_interrupt_handlers();

// A signal came while a StopOnInterrupt scope was open.
bool interrupted();

// Opens a scope in which the first signal asks the running loop to stop (interrupted()).
// `notice` is written to stderr when that signal comes, on a line of its own on a terminal
// (async-signal-safe: kept as given, so it must outlive the scope; a string literal).
class StopOnInterrupt {
 public:
  explicit StopOnInterrupt(const char* notice);
  ~StopOnInterrupt();
  StopOnInterrupt(const StopOnInterrupt&) = delete;
  StopOnInterrupt& operator=(const StopOnInterrupt&) = delete;
};

// The exit code of a tool that stopped on an interrupt after saving its state (128 + SIGINT).
constexpr int kExitInterrupted = 130;

}  // namespace pf
