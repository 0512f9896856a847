// Tests of run_isolated (isolate.h): what the child sends comes back in order, also from a child
// that then crashes; a crash, an abort, an exception and an endless loop are reported (signal,
// exit code, console, time limit); the child's writes to memory stay in the child; a child whose
// parent is killed dies with it.
#include <catch2/catch.hpp>

#include <signal.h>
#include <sys/resource.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <stdexcept>
#include <thread>

#include "photonflow/foundations/isolate.h"
#include "support.h"

using namespace pf;

TEST_CASE("run_isolated: the child's sends come back in order, its memory stays its own",
          "[isolate]") {
  int x = 1;
  const IsolatedRun run = run_isolated([&](const IsolatedSend& send) {
    x = 2;
    send("abc");
    send(std::string(200000, 'z'));  // more than a pipe's buffer
    send("def");
  });
  CHECK(run.exit_code == 0);
  CHECK(run.signal == 0);
  CHECK_FALSE(run.timed_out);
  CHECK(run.output == "abc" + std::string(200000, 'z') + "def");
  CHECK(x == 1);
}

TEST_CASE("run_isolated: a crash, an abort and an exception are reported, not suffered",
          "[isolate]") {
  const IsolatedRun segv = run_isolated([](const IsolatedSend& send) {
    send("before");
    std::raise(SIGSEGV);
    send("after");
  });
  CHECK(segv.signal == SIGSEGV);
  CHECK(segv.exit_code == -1);
  CHECK(segv.output == "before");
  CHECK(signal_text(segv.signal) == "SIGSEGV, segmentation fault");

  const IsolatedRun abrt = run_isolated([](const IsolatedSend&) {
    std::fprintf(stderr, "a library's last words\n");
    std::abort();
  });
  CHECK(abrt.signal == SIGABRT);
  CHECK(abrt.console.find("a library's last words") != std::string::npos);

  const IsolatedRun threw =
      run_isolated([](const IsolatedSend&) { throw std::runtime_error("boom"); });
  CHECK(threw.exit_code == kIsolatedThrew);
  CHECK(threw.signal == 0);
  CHECK(threw.console.find("boom") != std::string::npos);
}

TEST_CASE("run_isolated: a send that cannot write ends the child with kIsolatedSendFailed",
          "[isolate]") {
  const IsolatedRun run = run_isolated([](const IsolatedSend& send) {
    // A file-size limit applies to the memory file too (as `ulimit -f` would).
    const rlimit cap{4096, RLIM_INFINITY};
    setrlimit(RLIMIT_FSIZE, &cap);
    std::signal(SIGXFSZ, SIG_IGN);
    send(std::string(100000, 'z'));
    send("never");
  });
  CHECK(run.exit_code == kIsolatedSendFailed);
  CHECK(run.signal == 0);
  CHECK(run.output.size() <= 4096);
  CHECK(run.output.find("never") == std::string::npos);
}

TEST_CASE("run_isolated: a child past its time limit is killed", "[isolate]") {
  const IsolatedRun run = run_isolated(
      [](const IsolatedSend& send) {
        send("started");
        for (volatile bool forever = true; forever;) {
        }
      },
      0.3);
  CHECK(run.timed_out);
  CHECK(run.signal == SIGKILL);
  CHECK(run.output == "started");
  CHECK(run.seconds >= 0.3);
  CHECK(run.seconds < 30);
}

TEST_CASE("run_isolated: a child dies with the process that waits for it", "[isolate]") {
  test::TempDir tmp("isolate");
  const std::string pid_file = tmp / "inner.pid";
  // The outer child waits for an inner one that never ends; the outer is killed at its time
  // limit (2 s: the inner writes its pid in milliseconds, also on a loaded machine), and the
  // inner must go with it.
  const IsolatedRun outer = run_isolated(
      [&](const IsolatedSend&) {
        run_isolated([&](const IsolatedSend&) {
          std::ofstream(pid_file) << getpid() << "\n";
          for (volatile bool forever = true; forever;) {
          }
        });
      },
      2.0);
  CHECK(outer.signal == SIGKILL);
  pid_t inner = 0;
  REQUIRE((std::ifstream(pid_file) >> inner));
  REQUIRE(inner > 0);
  // Gone, or a zombie waiting for a reaper (PID 1 of a container may not reap).
  auto alive = [&] {
    std::ifstream stat("/proc/" + std::to_string(inner) + "/stat");
    std::string pid, name, state;
    if (!(stat >> pid >> name >> state)) return false;
    return state != "Z" && state != "X";
  };
  for (int i = 0; i < 200 && alive(); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  CHECK_FALSE(alive());
  if (alive()) kill(inner, SIGKILL);
}
