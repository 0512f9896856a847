// Work in a child process (see isolate.h).
#include "photonflow/foundations/isolate.h"

#include <poll.h>
#include <sys/mman.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <thread>

namespace pf {

namespace {

constexpr size_t kConsoleTail = 64 * 1024;

// A memory file the child writes and the parent reads; closed on destruction.
struct MemFile {
  int fd = -1;
  explicit MemFile(const char* name) : fd(memfd_create(name, MFD_CLOEXEC)) {
    if (fd < 0)
      throw std::runtime_error(std::string("memfd_create failed: ") + std::strerror(errno));
  }
  ~MemFile() {
    if (fd >= 0) close(fd);
  }
  MemFile(const MemFile&) = delete;
  MemFile& operator=(const MemFile&) = delete;

  // Everything written, or its last `most` bytes.
  std::string read_all(size_t most = std::string::npos) const {
    const off_t size = lseek(fd, 0, SEEK_END);
    if (size <= 0) return {};
    const off_t from = most != std::string::npos && size_t(size) > most ? size - off_t(most) : 0;
    std::string out(size_t(size - from), '\0');
    size_t got = 0;
    while (got < out.size()) {
      const ssize_t n = pread(fd, &out[got], out.size() - got, from + off_t(got));
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) break;
      got += size_t(n);
    }
    out.resize(got);
    return out;
  }
};

void write_fully(int fd, const char* p, size_t n) {
  while (n > 0) {
    const ssize_t w = write(fd, p, n);
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) _exit(kIsolatedSendFailed);  // the memory file cannot grow: the parent reports it
    p += w;
    n -= size_t(w);
  }
}

// A file descriptor that becomes readable when process `pid` ends; -1 where the kernel has none.
int open_pidfd(pid_t pid) {
#ifdef SYS_pidfd_open
  return int(syscall(SYS_pidfd_open, pid, 0));
#else
  (void)pid;
  return -1;
#endif
}

[[noreturn]] void child(const std::function<void(const IsolatedSend&)>& work, int out, int con,
                        pid_t parent) {
  // Dies with the parent: a parent killed while waiting (a time limit of its own, ^C) must not
  // leave a looping child behind.
  prctl(PR_SET_PDEATHSIG, SIGKILL);
  if (getppid() != parent) _exit(72);  // the parent is already gone
  // The parent's handlers are not the child's: a crash ends it, and an interrupt (the terminal's
  // ^C reaches the whole process group) ends it without touching the parent's outputs (an
  // interrupt the parent ignores, e.g. SIGHUP under nohup, stays ignored).
  for (int s : {SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT, SIGTRAP, SIGSYS})
    std::signal(s, SIG_DFL);
  for (int s : {SIGINT, SIGTERM, SIGHUP})
    if (std::signal(s, SIG_DFL) == SIG_IGN) std::signal(s, SIG_IGN);
  const rlimit no_core{0, 0};
  setrlimit(RLIMIT_CORE, &no_core);
  dup2(con, STDOUT_FILENO);
  dup2(con, STDERR_FILENO);
  int code = 0;
  try {
    work([out](const std::string& bytes) { write_fully(out, bytes.data(), bytes.size()); });
  } catch (const std::exception& e) {
    const std::string line = std::string("exception: ") + e.what() + "\n";
    write_fully(STDERR_FILENO, line.data(), line.size());
    code = kIsolatedThrew;
  } catch (...) {
    code = kIsolatedThrew;
  }
  _exit(code);
}

}  // namespace

IsolatedRun run_isolated(const std::function<void(const IsolatedSend&)>& work,
                         double time_limit_s) {
  MemFile out("pf-isolated-output"), con("pf-isolated-console");
  std::fflush(nullptr);  // nothing buffered here is written twice by the child
  const auto start = std::chrono::steady_clock::now();
  const pid_t parent = getpid();
  const pid_t pid = fork();
  if (pid < 0) throw std::runtime_error(std::string("fork failed: ") + std::strerror(errno));
  if (pid == 0) child(work, out.fd, con.fd, parent);

  IsolatedRun run;
  const auto elapsed = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  };
  const auto kill_at_limit = [&] {
    if (time_limit_s > 0 && !run.timed_out && elapsed() >= time_limit_s) {
      kill(pid, SIGKILL);
      run.timed_out = true;
    }
  };
  // Wait for the child's end: on a pidfd (Linux 5.3+), which wakes the moment it ends, else by
  // polling waitpid every 2 ms at most.
  const int pidfd = open_pidfd(pid);
  bool ended = false;  // the pidfd said so: waitpid returns at once
  if (pidfd >= 0) {
    for (;;) {
      int timeout_ms = -1;
      if (time_limit_s > 0 && !run.timed_out)
        timeout_ms = int(std::clamp(std::ceil((time_limit_s - elapsed()) * 1e3), 0.0, 1e9));
      pollfd p{pidfd, POLLIN, 0};
      const int r = poll(&p, 1, timeout_ms);
      ended = r > 0;
      if (ended) break;
      if (r == 0) kill_at_limit();
      if (r < 0 && errno != EINTR) break;  // the waitpid loop below takes over, time limit too
    }
    close(pidfd);
  }
  int status = 0;
  auto wait_step = std::chrono::microseconds(100);
  for (;;) {
    const pid_t w = waitpid(pid, &status, ended ? 0 : WNOHANG);
    if (w == pid) break;
    if (w < 0 && errno != EINTR)
      throw std::runtime_error(std::string("waitpid failed: ") + std::strerror(errno));
    if (w == 0) {
      kill_at_limit();
      std::this_thread::sleep_for(wait_step);
      wait_step = std::min(wait_step * 2, std::chrono::microseconds(2000));
    }
  }
  run.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (WIFEXITED(status)) {
    run.exit_code = WEXITSTATUS(status);
  } else if (WIFSIGNALED(status)) {
    run.signal = WTERMSIG(status);
  }
  run.output = out.read_all();
  run.console = con.read_all(kConsoleTail);
  return run;
}

std::string signal_text(int signal) {
  switch (signal) {
    case SIGSEGV: return "SIGSEGV, segmentation fault";
    case SIGBUS: return "SIGBUS, bus error";
    case SIGFPE: return "SIGFPE, arithmetic exception";
    case SIGILL: return "SIGILL, illegal instruction";
    case SIGABRT: return "SIGABRT, aborted";
    case SIGKILL: return "SIGKILL, killed";
    case SIGTRAP: return "SIGTRAP, trap";
    case SIGSYS: return "SIGSYS, bad system call";
    default: return "signal " + std::to_string(signal);
  }
}

}  // namespace pf
