// provenance.h — the /provenance group every photonflow HDF5 file carries.
//
//   /provenance              attrs: tool, version, git_hash, seed, wall_time_s, created_utc,
//                                   command_line
//   /provenance/parameters   one string attribute per tool parameter (the full option set)
//   /provenance/inputs/<role> attrs: path, sha256, format, scene_id   (one group per input file)
#pragma once
#include <chrono>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "photonflow/io/h5io.h"

namespace pf {

struct InputRef {
  std::string role;      // e.g. "scene", "hitpoints"
  std::string path;      // as given on the command line
  std::string sha256;    // content hash of the file
  std::string format;    // format name of a photonflow input; "" for a foreign source file
  std::string scene_id;  // scene_id of a photonflow input; "" otherwise
};

struct Provenance {
  std::string tool;
  std::map<std::string, std::string> parameters;
  uint64_t seed = 0;
  std::vector<InputRef> inputs;
  double wall_time_s = 0;
  std::string command_line;
  std::string version;   // filled by write_provenance / read_provenance
  std::string git_hash;  // filled by write_provenance / read_provenance
  std::string created_utc;

  // Records an input file: hashes it (throws InputError if unreadable).
  void add_input(const std::string& role, const std::string& path, const std::string& format = {},
                 const std::string& scene_id = {});
  template <class T> void param(const std::string& name, const T& value) {
    parameters[name] = to_text(value);
  }

 private:
  static std::string to_text(const std::string& s) { return s; }
  static std::string to_text(const char* s) { return s; }
  static std::string to_text(bool b) { return b ? "true" : "false"; }
  template <class T> static std::string to_text(const T& v) { return std::to_string(v); }
};

void write_provenance(h5::Writer& w, const Provenance& p);
Provenance read_provenance(const h5::Reader& r);

// Joins argv with spaces (quoted where needed) for the command_line attribute.
std::string join_command_line(int argc, char** argv);

// Wall-clock stopwatch.
class Stopwatch {
 public:
  Stopwatch() : t0_(std::chrono::steady_clock::now()) {}
  double seconds() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count();
  }

 private:
  std::chrono::steady_clock::time_point t0_;
};

}  // namespace pf
