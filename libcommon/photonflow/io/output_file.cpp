// Output files: see output_file.h.
#include "photonflow/io/output_file.h"

#include <sys/stat.h>
#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <system_error>
#include <utility>

#include "photonflow/foundations/error.h"
#include "photonflow/foundations/hash.h"

namespace pf {

namespace fs = std::filesystem;

namespace {

// Exists and is not a regular file (symlinks followed: a link to a regular file is fine).
bool exists_not_regular(const std::string& path) {
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  return !ec && fs::exists(st) && !fs::is_regular_file(st);
}

// The same file: equivalent when both exist, else the same absolute, lexically normal path.
bool same_file(const std::string& a, const std::string& b) {
  std::error_code ec;
  if (fs::exists(a, ec) && fs::exists(b, ec)) {
    const bool eq = fs::equivalent(a, b, ec);
    if (!ec) return eq;
  }
  const fs::path pa = fs::absolute(a, ec).lexically_normal();
  const fs::path pb = fs::absolute(b, ec).lexically_normal();
  return pa == pb;
}

// The table of temporary outputs the interrupt handler removes: a slot is free (0), being filled
// (1) or holds a path (2); the handler reads only slots in state 2, whose path is complete.
// A path too long for a slot, or a 17th file open at once, is not tracked (it is still removed by
// its TempOutput; only an interrupt would leave it).
struct TempSlot {
  std::atomic<int> state{0};
  char path[4096];
};
TempSlot g_temps[16];

int track(const std::string& path) {
  if (path.size() >= sizeof(TempSlot::path)) return -1;
  for (int i = 0; i < int(std::size(g_temps)); ++i) {
    int expected = 0;
    if (!g_temps[i].state.compare_exchange_strong(expected, 1)) continue;
    std::memcpy(g_temps[i].path, path.c_str(), path.size() + 1);
    g_temps[i].state.store(2);
    return i;
  }
  return -1;
}

void untrack(int slot) {
  if (slot >= 0) g_temps[slot].state.store(0);
}

}  // namespace

void remove_tracked_temps() noexcept {
  for (TempSlot& t : g_temps)
    if (t.state.load() == 2) unlink(t.path);
}

TempOutput::TempOutput(const std::string& final_path)
    : final_(final_path), tmp_(temp_path(final_path)), slot_(track(tmp_)) {
  remove_stale_temps(final_path);  // left by a killed run writing the same output
}

TempOutput::~TempOutput() {
  if (!done_) std::remove(tmp_.c_str());
  untrack(slot_);
}

void TempOutput::commit() {
  // Tracked until destruction: an interrupt after the rename unlinks a name that is gone.
  done_ = true;  // commit_temp removes the file when it fails
  commit_temp(tmp_, final_);
}

namespace {
// The file system's limit on one name (NAME_MAX of Linux file systems), and the longest suffix
// ".tmp.<pid>" (pids below 2^31: ten digits).
constexpr size_t kNameMax = 255;
constexpr size_t kSuffixMax = 15;

// "<dir>/<name>" → {"<dir>/", "<name>"} ("" for a name without a directory).
std::pair<std::string, std::string> split_name(const std::string& path) {
  const size_t slash = path.rfind('/');
  if (slash == std::string::npos) return {"", path};
  return {path.substr(0, slash + 1), path.substr(slash + 1)};
}

// The temporary names' stem of `path`: "<path>.tmp.", or, when the file name with the longest
// suffix would pass kNameMax bytes, "<dir>/<first bytes of the name>~<16 hex digits>.tmp." with
// the digits a checksum of the whole name (outputs that share the first bytes stay apart).
std::string temp_stem(const std::string& path) {
  const auto [dir, name] = split_name(path);
  if (name.size() + kSuffixMax <= kNameMax) return path + ".tmp.";
  size_t keep = kNameMax - kSuffixMax - 17;  // 17: "~" and 16 hex digits
  while (keep > 0 && (static_cast<unsigned char>(name[keep]) & 0xC0) == 0x80) --keep;  // UTF-8
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx",
                static_cast<unsigned long long>(checksum64(name.data(), name.size())));
  return dir + name.substr(0, keep) + "~" + hex + ".tmp.";
}
}  // namespace

std::string temp_path(const std::string& path, long pid) {
  return temp_stem(path) + std::to_string(pid);
}

std::string temp_path(const std::string& path) {
  return temp_path(path, static_cast<long>(getpid()));
}

size_t remove_stale_temps(const std::string& path) {
  const std::string stem = temp_stem(path);
  const auto [dir, prefix] = split_name(stem);
  std::error_code ec;
  size_t removed = 0;
  for (fs::directory_iterator it(dir.empty() ? "." : dir, ec), end; !ec && it != end;
       it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.size() <= prefix.size() || name.size() > prefix.size() + 10 ||
        name.compare(0, prefix.size(), prefix) != 0)
      continue;
    const std::string digits = name.substr(prefix.size());
    if (digits.find_first_not_of("0123456789") != std::string::npos || digits[0] == '0') continue;
    const long pid = std::stol(digits);
    if (pid > std::numeric_limits<pid_t>::max() || pid == static_cast<long>(getpid())) continue;
    std::error_code e2;
    if (!fs::is_regular_file(fs::symlink_status(it->path(), e2))) continue;
    // Gone: no such process (a live one of another user answers EPERM and keeps its file).
    if (kill(static_cast<pid_t>(pid), 0) == -1 && errno == ESRCH &&
        unlink((dir + name).c_str()) == 0)
      ++removed;
  }
  return removed;
}

void require_regular_input(const std::string& path) {
  struct stat st {};
  if (!path.empty() && stat(path.c_str(), &st) == 0 && !S_ISREG(st.st_mode))
    throw input_error(path, "is not a regular file",
                      "give a file, not a pipe, directory or device; a pipe's reader would wait "
                      "for ever");
}

void commit_temp(const std::string& tmp, const std::string& path) {
  if (exists_not_regular(path)) {
    std::remove(tmp.c_str());
    throw input_error(path, "exists and is not a regular file", "choose another output name");
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    std::remove(tmp.c_str());
    throw input_error(path, "cannot rename the temporary output into place",
                      "check the directory and its permissions");
  }
}

void write_file_atomic(const std::string& path, const char* data, size_t n) {
  TempOutput tmp(path);
  {
    std::ofstream f(tmp.path(), std::ios::binary | std::ios::trunc);
    if (!f)
      throw input_error(path, "cannot create the file", "check the directory and its permissions");
    f.write(data, static_cast<std::streamsize>(n));
    if (!f.flush()) throw input_error(path, "cannot write the file", "is the disk full?");
  }
  tmp.commit();
}

void check_outputs(const std::vector<std::string>& inputs,
                   const std::vector<std::string>& outputs) {
  for (const std::string& in : inputs) require_regular_input(in);
  for (size_t i = 0; i < outputs.size(); ++i) {
    const std::string& out = outputs[i];
    if (out.empty()) continue;
    for (const std::string& in : inputs)
      if (!in.empty() && same_file(in, out))
        throw input_error(out, "is also an input of this run", "write the output elsewhere");
    for (size_t j = 0; j < i; ++j)
      if (!outputs[j].empty() && same_file(outputs[j], out))
        throw input_error(out, "is named for two outputs of this run", "give them different names");
    if (exists_not_regular(out))
      throw input_error(out, "exists and is not a regular file", "choose another output name");
    const fs::path dir = fs::path(out).parent_path();
    std::error_code ec;
    if (!dir.empty() && !fs::is_directory(dir, ec))
      throw input_error(out, "its directory does not exist", "create it first");
    const std::string probe = temp_path(out);
    {
      std::ofstream f(probe, std::ios::binary | std::ios::trunc);
      if (!f)
        throw input_error(out, "cannot be created", "check the directory and its permissions");
    }
    std::remove(probe.c_str());
  }
}

std::string preview_path(const std::string& image) {
  return fs::path(image).replace_extension(".png").string();
}

}  // namespace pf
