// Output files: see output_file.h.
#include "photonflow/output_file.h"

#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <system_error>

#include "photonflow/error.h"

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
    : final_(final_path), tmp_(temp_path(final_path)), slot_(track(tmp_)) {}

TempOutput::~TempOutput() {
  if (!done_) std::remove(tmp_.c_str());
  untrack(slot_);
}

void TempOutput::commit() {
  // Tracked until destruction: an interrupt after the rename unlinks a name that is gone.
  done_ = true;  // commit_temp removes the file when it fails
  commit_temp(tmp_, final_);
}

std::string temp_path(const std::string& path) {
  return path + ".tmp." + std::to_string(static_cast<long>(getpid()));
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
