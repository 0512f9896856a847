// Output files: see output_file.h.
#include "photonflow/output_file.h"

#include <unistd.h>

#include <cstdio>
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

}  // namespace

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
  const std::string tmp = temp_path(path);
  {
    std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
    if (!f)
      throw input_error(path, "cannot create the file", "check the directory and its permissions");
    f.write(data, static_cast<std::streamsize>(n));
    if (!f.flush()) {
      f.close();
      std::remove(tmp.c_str());
      throw input_error(path, "cannot write the file", "is the disk full?");
    }
  }
  commit_temp(tmp, path);
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
