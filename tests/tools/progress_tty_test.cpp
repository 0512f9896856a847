// Long work shows progress on a terminal and stays quiet otherwise (progress.h, GaProgressLine in
// ga_clusters.h): each long-running tool runs once with its stderr on a pseudo-terminal and once
// with it in a file. On the terminal the line names the step count done of the total, a rate and
// an ETA, is rewritten in place ('\r') and ends with a newline after the last step; in a file
// stderr stays empty.
#include <catch2/catch.hpp>
#include <fcntl.h>
#include <pty.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <string>
#include <vector>

#include "support.h"

using pf::test::run_tool;
using pf::test::TempDir;

namespace {

struct TtyRun {
  int exit_code = -1;
  std::string tty;  // what the tool wrote to its terminal (stderr; stdout goes to /dev/null)
};

// Runs `tool args` with stdin and stderr on a new pseudo-terminal.
TtyRun run_on_tty(const std::string& tool, const std::string& args) {
  const std::string cmd = pf::test::bin_dir() + "/" + tool + " " + args + " >/dev/null";
  int master = -1;
  const pid_t pid = forkpty(&master, nullptr, nullptr, nullptr);
  REQUIRE(pid >= 0);
  if (pid == 0) {
    execl("/bin/sh", "sh", "-c", cmd.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  TtyRun r;
  char buf[4096];
  for (;;) {  // until the terminal closes (EIO once the tool and the shell have ended)
    const ssize_t n = read(master, buf, sizeof buf);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    r.tty.append(buf, size_t(n));
  }
  close(master);
  int status = 0;
  waitpid(pid, &status, 0);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

bool has(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

}  // namespace

TEST_CASE("progress: long stages show steps, rate and ETA on a terminal, nothing in a file",
          "[tools][progress]") {
  TempDir tmp("progress");
  const std::string scene = tmp / "scene.h5", hp = tmp / "hp.h5", ph = tmp / "ph.h5";
  REQUIRE(run_tool("scene-bake", pf::test::source_dir() + "/data/cornell-box.dae -o " + scene +
                                     " --width 16 --height 12",
                   tmp)
              .exit_code == 0);
  REQUIRE(run_tool("trace-hitpoints", "--estimator ppm --direct photons --scene " + scene + " -o " + hp, tmp).exit_code == 0);
  REQUIRE(run_tool("trace-photons", "--scene " + scene + " -o " + ph + " --photons 2000 --passes 3",
                   tmp)
              .exit_code == 0);
  REQUIRE(run_tool("photon-distribution",
                   "--scene " + scene + " --hitpoints " + hp + " --photons " + ph + " -o " +
                       (tmp / "dist.h5"),
                   tmp)
              .exit_code == 0);
  struct Case {
    std::string tool, args, last;  // `last`: the final step's count, e.g. "pass 3/3"
    std::string rate;              // the rate's unit, or "" for the GA's line
  };
  const std::string o = " -o " + (tmp / "out");
  const std::vector<Case> cases = {
      {"trace-photons", "--scene " + scene + " --photons 2000 --passes 3" + o + ".h5", "pass 3/3",
       "photons/s"},
      {"illuminate", "--estimator ppm --scene " + scene + " --hitpoints " + hp + " --photons " + ph + o + ".h5",
       "pass 3/3", "photons/s"},
      {"photon-distribution", "--scene " + scene + " --hitpoints " + hp + " --passes 2" + o + ".h5",
       "pass 2/2", "photons/s"},
      {"render", "--scene " + scene + " --photons 2000 --passes 4" + o + ".exr", "pass 4/4",
       "photons/s"},
      {"pathtrace", "--scene " + scene + " --spp 3" + o + ".exr", "sample 3/3", "paths/s"},
      {"cluster",
       "--scene " + scene + " --hitpoints " + hp + " --distribution " + (tmp / "dist.h5") +
           " --method ga --wg-size 16 --ga-iterations 5" + o + ".h5",
       "generation 6/6", ""},  // the initial population counts (GaProgress)
  };
  for (const Case& k : cases) {
    INFO(k.tool << " " << k.args);
    const TtyRun t = run_on_tty(k.tool, k.args);
    INFO("terminal: " << t.tty);
    CHECK(t.exit_code == 0);
    CHECK(has(t.tty, "\r"));
    CHECK(has(t.tty, k.last));
    CHECK(has(t.tty, "ETA "));
    if (!k.rate.empty()) CHECK(has(t.tty, k.rate));
    // The last step's line ends the line (the terminal shows "\r\n" for "\n").
    const size_t last = t.tty.rfind(k.last);
    REQUIRE(last != std::string::npos);
    CHECK(t.tty.find('\n', last) != std::string::npos);

    const pf::test::ToolRun f = run_tool(k.tool, k.args, tmp);
    CHECK(f.exit_code == 0);
    CHECK(f.err.empty());
  }
}
