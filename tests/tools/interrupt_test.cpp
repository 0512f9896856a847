// Ctrl-C, SIGTERM and SIGHUP (interrupt.h):
//   - in forked children of this test: a signal removes the temporary outputs being written
//     (TempOutput) and ends the process by that signal; a committed output and other files stay;
//     a signal the process was started with ignored stays ignored; inside a StopOnInterrupt scope
//     the first signal only sets interrupted() and the second ends the process as above;
//   - through the tools: render stops after the pass in progress with its checkpoint saved
//     (exit 130, no final image, one line saying where the state is); cluster's GA stops after
//     the generation in progress with its checkpoint saved.
#include <catch2/catch.hpp>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <thread>

#include "photonflow/foundations/interrupt.h"
#include "photonflow/io/output_file.h"
#include "photonflow/io/stage_files.h"
#include "support.h"

using namespace pf;
using test::run_tool;
using test::TempDir;
namespace fs = std::filesystem;

namespace {

// Runs `body` in a forked child and returns its wait status.
int in_child(const std::function<void()>& body) {
  std::fflush(nullptr);
  const pid_t pid = fork();
  REQUIRE(pid >= 0);
  if (pid == 0) {
    body();
    _exit(0);
  }
  int status = 0;
  waitpid(pid, &status, 0);
  return status;
}

bool killed_by(int status, int sig) { return WIFSIGNALED(status) && WTERMSIG(status) == sig; }

void touch(const std::string& path) { std::ofstream(path) << "data"; }

// Starts `tool args` (stdout, stderr into files of `tmp`) and returns its pid.
pid_t start_tool(const std::string& tool, const std::string& args, const TempDir& tmp) {
  const std::string cmd = "exec " + test::bin_dir() + "/" + tool + " " + args + " >" +
                          (tmp / ".out") + " 2>" + (tmp / ".err");
  std::fflush(nullptr);
  const pid_t pid = fork();
  REQUIRE(pid >= 0);
  if (pid == 0) {
    execl("/bin/sh", "sh", "-c", cmd.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  return pid;
}

// Waits until `path` exists (at most 60 s).
bool wait_for(const std::string& path) {
  for (int i = 0; i < 6000; ++i) {
    if (fs::exists(path)) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return false;
}

int exit_code(pid_t pid) {
  int status = 0;
  waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

struct Interrupted {
  bool started = false;  // `ready` appeared before the signal
  int exit_code = -1;
  std::string err;
};

// Starts `tool args`, waits until the file `ready` exists (the tool is past its start), sends
// SIGINT and waits for the tool.
Interrupted interrupt_once(const std::string& tool, const std::string& args,
                           const std::string& ready, const TempDir& tmp) {
  const pid_t pid = start_tool(tool, args, tmp);
  Interrupted r;
  r.started = wait_for(ready);
  kill(pid, SIGINT);
  r.exit_code = exit_code(pid);
  r.err = test::file_bytes(tmp / ".err");
  return r;
}

void no_temporary_files(const TempDir& tmp) { CHECK(test::temporary_files(tmp.dir).empty()); }

}  // namespace

TEST_CASE("interrupts: a signal removes the outputs being written and ends the process by it",
          "[interrupt]") {
  TempDir tmp("interrupt-lib");
  for (int sig : {SIGINT, SIGTERM, SIGHUP}) {
    INFO("signal " << sig);
    std::string written, other = tmp / "other.txt", done = tmp / "done.h5";
    const int status = in_child([&] {
      install_interrupt_handlers();
      TempOutput finished(done);
      touch(finished.path());
      finished.commit();
      TempOutput t(tmp / "a.h5");
      touch(t.path());
      touch(other);
      raise(sig);
      _exit(3);  // not reached
    });
    CHECK(killed_by(status, sig));
    no_temporary_files(tmp);
    CHECK(fs::exists(other));
    CHECK(fs::exists(done));
    fs::remove(other);
    fs::remove(done);
  }
  // Without the handlers the temporary file stays (the check above can fail).
  const int bare = in_child([&] {
    TempOutput t(tmp / "b.h5");
    touch(t.path());
    raise(SIGTERM);
  });
  CHECK(killed_by(bare, SIGTERM));
  bool left = false;
  for (auto& e : fs::directory_iterator(tmp.dir))
    left = left || e.path().string().find("b.h5.tmp.") != std::string::npos;
  CHECK(left);
  // A signal ignored from the start (nohup) stays ignored.
  const int ignored = in_child([] {
    signal(SIGHUP, SIG_IGN);
    install_interrupt_handlers();
    raise(SIGHUP);
    _exit(0);
  });
  CHECK(WIFEXITED(ignored));
}

TEST_CASE("interrupts: in a StopOnInterrupt scope the first signal asks, the second ends",
          "[interrupt]") {
  TempDir tmp("interrupt-scope");
  const int status = in_child([&] {
    install_interrupt_handlers();
    TempOutput t(tmp / "a.h5");
    touch(t.path());
    const StopOnInterrupt scope("notice\n");
    if (interrupted()) _exit(3);
    raise(SIGINT);
    if (!interrupted()) _exit(4);  // the first signal only sets the flag
    raise(SIGINT);
    _exit(5);  // not reached: the second ends the process
  });
  INFO("exit " << (WIFEXITED(status) ? WEXITSTATUS(status) : -1));
  CHECK(killed_by(status, SIGINT));
  no_temporary_files(tmp);
  // After the scope, the first signal ends the process again.
  const int after = in_child([] {
    install_interrupt_handlers();
    { const StopOnInterrupt scope("notice\n"); }
    raise(SIGTERM);
    _exit(6);
  });
  CHECK(killed_by(after, SIGTERM));
}

TEST_CASE("interrupts: render and cluster's GA stop after the step in progress, state saved",
          "[interrupt][tools]") {
  TempDir tmp("interrupt-tools");
  const std::string scene = tmp / "scene.h5", hp = tmp / "hp.h5", ph = tmp / "ph.h5";
  REQUIRE(run_tool("scene-bake", test::source_dir() + "/data/cornell-box.dae -o " + scene +
                                     " --width 16 --height 12",
                   tmp)
              .exit_code == 0);

  SECTION("render") {
    const std::string ck = tmp / "ck.h5", out = tmp / "r.exr", snap = tmp / "s-{pass}.exr";
    const std::string stats = tmp / "run.json";
    // 100 000 passes: far more than the run gets to before the signal.
    const Interrupted r = interrupt_once(
        "render",
        "--scene " + scene + " -o " + out + " --estimator sppm --photons 200 --passes 100000" + " --checkpoint " +
            ck + " --checkpoint-every 100000 --snapshot-at 1" + " --snapshot " + snap +
            " --stats " + stats,
        tmp / "s-000001.exr", tmp);
    REQUIRE(r.started);
    const std::string& err = r.err;
    INFO("stderr: " << err);
    CHECK(r.exit_code == kExitInterrupted);
    CHECK(err.find("render: interrupted after ") != std::string::npos);
    CHECK(err.find("of 100000 passes; the state is saved in " + ck) != std::string::npos);
    REQUIRE(fs::exists(ck));
    const int passes = load_hitpoints(ck).passes;
    CHECK(passes >= 1);
    CHECK(passes < 100000);
    CHECK(err.find("interrupted after " + std::to_string(passes) + " of") != std::string::npos);
    CHECK_FALSE(fs::exists(out));
    CHECK_FALSE(fs::exists(tmp / "r.png"));
    // The run record lists what the run wrote: the snapshot of pass 1, not the final image.
    REQUIRE(fs::exists(stats));
    const std::string record = test::file_bytes(stats);
    CHECK(record.find("\"path\": \"" + (tmp / "s-000001.exr") + "\"") != std::string::npos);
    CHECK(record.find("\"path\": \"" + out + "\"") == std::string::npos);
    no_temporary_files(tmp);
  }

  SECTION("cluster --method ga") {
    REQUIRE(run_tool("trace-hitpoints", "--estimator ppm --direct photons --scene " + scene + " -o " + hp, tmp).exit_code == 0);
    REQUIRE(run_tool("trace-photons", "--scene " + scene + " -o " + ph + " --photons 2000", tmp)
                .exit_code == 0);
    const std::string dist = tmp / "dist.h5", ck = tmp / "ga-ck.h5", out = tmp / "c.h5";
    REQUIRE(run_tool("photon-distribution",
                     "--scene " + scene + " --hitpoints " + hp + " --photons " + ph + " -o " + dist,
                     tmp)
                .exit_code == 0);
    const Interrupted r = interrupt_once("cluster",
                                         "--scene " + scene + " --hitpoints " + hp +
                                             " --distribution " + dist +
                                             " --method ga --wg-size 16 --ga-iterations 10000000" +
                                             " --checkpoint " + ck + " --checkpoint-every 1 -o " +
                                             out,
                                         ck, tmp);
    REQUIRE(r.started);
    INFO("stderr: " << r.err);
    CHECK(r.exit_code == kExitInterrupted);
    CHECK(r.err.find("cluster: interrupted after generation ") != std::string::npos);
    CHECK(fs::exists(ck));
    CHECK_FALSE(fs::exists(out));
    no_temporary_files(tmp);
  }
}
