// isolate.h — runs work that may crash or hang (a third-party parser on untrusted input) in a
// child process, so that a crash, an abort or an endless loop there becomes an error report here.
//
// assimp 5.2.5 (Debian 12) crashes on damaged files: its PLY reader dereferences a bad pointer
// (SIGSEGV) or loops forever on a damaged binary header, and a failed internal assertion
// (ai_assert, e.g. TriangulateProcess.cpp:238) prints to stderr and aborts. None of these can be
// caught in-process. scene-bake therefore imports in a child (scene_import_child.cpp) and receives
// the imported scene as bytes.
//
// The child is a fork() of this process: it sees this process's memory as it was (copy-on-write)
// and changes none of it. Its results travel through `send` into a memory file (memfd) that the
// parent reads after the child has ended, so a child that dies mid-way leaves what it sent before.
// Its stdout and stderr go to a second memory file, returned as `console`. In the child, the fatal
// signals' handlers are reset to the default (a test framework's handler would report there), core
// dumps are off, it is killed when the thread that made it dies (PR_SET_PDEATHSIG; that thread
// waits for it), and it ends with _exit (no atexit handlers, which belong to this process: HDF5's,
// the sanitizers' leak check). fork() copies only the calling thread; the glibc allocator and
// stdio are safe in the child, other libraries' locks held by other threads would not be: call it
// where the child's work needs none of them.
#pragma once
#include <functional>
#include <string>

namespace pf {

// The child's exit codes besides 0: `work` threw, or `send` could not write its bytes: the
// memory file could not grow (no memory left, or a file-size limit: `ulimit -f` applies to memory
// files too).
constexpr int kIsolatedThrew = 70;      // EX_SOFTWARE
constexpr int kIsolatedSendFailed = 71; // EX_OSERR

struct IsolatedRun {
  std::string output;        // the bytes the child passed to `send`, in order
  std::string console;       // its stdout and stderr, at most the last 64 KiB
  int exit_code = -1;        // 0 after the work returned, else kIsolated*; -1: a signal
  int signal = 0;            // the signal that ended the child, else 0
  bool timed_out = false;    // killed (SIGKILL) at the time limit
  double seconds = 0;        // wall time of the child
};

using IsolatedSend = std::function<void(const std::string&)>;

// Runs work(send) in a forked child and waits for it, at most `time_limit_s` seconds (0 = no
// limit), then kills it. An exception escaping `work` ends the child with kIsolatedThrew, its
// what() on the console; a `send` that cannot write ends it with kIsolatedSendFailed. Throws
// std::runtime_error if no child can be made (fork or memfd_create fail).
IsolatedRun run_isolated(const std::function<void(const IsolatedSend& send)>& work,
                         double time_limit_s = 0);

// "SIGSEGV, segmentation fault" for a signal number; "signal N" for one it does not know.
std::string signal_text(int signal);

}  // namespace pf
