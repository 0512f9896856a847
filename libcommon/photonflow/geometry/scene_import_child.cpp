// The scene import in a child process (import_isolated, scene_import_internal.h): the bytes the
// child sends back over the pipe (the imported scene and report, an error, the file it reads) and
// how a child that crashed, aborted or ran past its time limit becomes an InputError.
//
// Isolation. Everything that touches assimp (import_scene: reading, flattening, lights, camera)
// runs in a child process (isolate.h, import_isolated), because assimp 5.2.5 crashes, aborts or
// loops on some damaged files; the child sends the flattened scene back as bytes (encode/decode)
// and bake_scene derives the rest (finish_scene: kd-tree, lights' CDF, scene id) in this process.
#include <sys/stat.h>

#include <cstring>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "photonflow/foundations/error.h"
#include "photonflow/foundations/isolate.h"
#include "photonflow/geometry/scene_import_internal.h"

namespace pf::import {

namespace {

// Automatic time limit of an import (bake_scene's child process): seconds, plus seconds per MB of
// the files named on the command line.
constexpr double kImportSecondsFloor = 60;
constexpr double kImportSecondsPerMB = 10;

// The imported scene and report as bytes, from the child to the parent: records of a tag byte, a
// 64-bit length and that many bytes.
enum RecordTag : char {
  kReading = 'F',     // the path assimp is about to read
  kScene = 'S',       // import_scene's result
  kInputError = 'I',  // an InputError's line
  kError = 'E',       // another exception's what()
};

class ByteWriter {
 public:
  template <class T> void pod(const T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    bytes_.append(reinterpret_cast<const char*>(&v), sizeof v);
  }
  template <class T> void pods(const std::vector<T>& v) {
    pod(uint64_t(v.size()));
    bytes_.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
  }
  void text(const std::string& s) {
    pod(uint64_t(s.size()));
    bytes_ += s;
  }
  void texts(const std::vector<std::string>& v) {
    pod(uint64_t(v.size()));
    for (const auto& s : v) text(s);
  }
  const std::string& bytes() const { return bytes_; }

 private:
  std::string bytes_;
};

class ByteReader {
 public:
  explicit ByteReader(const std::string& bytes) : bytes_(bytes) {}
  template <class T> T pod() {
    T v;
    std::memcpy(&v, take(sizeof v), sizeof v);
    return v;
  }
  template <class T> std::vector<T> pods() {
    const uint64_t n = pod<uint64_t>();
    if (n > (bytes_.size() - at_) / sizeof(T)) short_of_data();
    std::vector<T> v(n);
    if (n) std::memcpy(v.data(), take(n * sizeof(T)), n * sizeof(T));
    return v;
  }
  std::string text() {
    const uint64_t n = pod<uint64_t>();
    return std::string(take(n), n);
  }
  std::vector<std::string> texts() {
    const uint64_t n = pod<uint64_t>();
    std::vector<std::string> v;
    for (uint64_t i = 0; i < n; ++i) v.push_back(text());
    return v;
  }
  bool done() const { return at_ == bytes_.size(); }

 private:
  const char* take(uint64_t n) {
    if (n > bytes_.size() - at_) short_of_data();
    const char* p = bytes_.data() + at_;
    at_ += n;
    return p;
  }
  [[noreturn]] static void short_of_data() {
    throw std::runtime_error("scene import: the child's record is shorter than its contents");
  }
  const std::string& bytes_;
  size_t at_ = 0;
};

std::string record(char tag, const std::string& bytes) {
  ByteWriter w;
  w.pod(tag);
  w.text(bytes);
  return w.bytes();
}

// The records of a child's output. A child killed while sending leaves its last record cut short;
// that one is dropped.
std::vector<std::pair<char, std::string>> split_records(const std::string& output) {
  std::vector<std::pair<char, std::string>> records;
  size_t at = 0;
  while (output.size() - at >= 1 + sizeof(uint64_t)) {
    uint64_t n = 0;
    std::memcpy(&n, output.data() + at + 1, sizeof n);
    if (n > output.size() - at - 1 - sizeof n) break;
    records.emplace_back(output[at], output.substr(at + 1 + sizeof n, n));
    at += 1 + sizeof n + n;
  }
  return records;
}

std::string encode(const Scene& s, const BakeReport& r) {
  ByteWriter w;
  w.pods(s.triangles);
  w.texts(s.mesh_names);
  w.pods(s.materials);
  w.texts(s.material_names);
  w.pods(s.lights);
  w.pod(s.camera);
  w.text(s.source);
  w.pods(s.textures);
  w.pods(s.texels);
  w.texts(s.texture_names);
  w.pods(s.material_texture);
  w.pods(s.material_mr_texture);
  w.pods(s.uvs);
  w.pods(s.material_alpha);
  w.pod(uint64_t(r.triangles_read));
  w.pod(uint64_t(r.degenerate_dropped));
  w.pod(uint64_t(r.primitives_skipped));
  w.pod(uint64_t(r.inserted_triangles));
  w.pod(r.camera_from_file);
  w.text(r.camera_source);
  w.pod(r.insert_up);
  w.texts(r.warnings);
  return w.bytes();
}

Scene decode(const std::string& bytes, BakeReport& r) {
  ByteReader in(bytes);
  Scene s;
  s.triangles = in.pods<pf_triangle>();
  s.mesh_names = in.texts();
  s.materials = in.pods<pf_material>();
  s.material_names = in.texts();
  s.lights = in.pods<pf_light>();
  s.camera = in.pod<pf_camera>();
  s.source = in.text();
  s.textures = in.pods<pf_texture>();
  s.texels = in.pods<float>();
  s.texture_names = in.texts();
  s.material_texture = in.pods<int32_t>();
  s.material_mr_texture = in.pods<int32_t>();
  s.uvs = in.pods<TriangleUV>();
  s.material_alpha = in.pods<pf_alpha_material>();
  r.triangles_read = size_t(in.pod<uint64_t>());
  r.degenerate_dropped = size_t(in.pod<uint64_t>());
  r.primitives_skipped = size_t(in.pod<uint64_t>());
  r.inserted_triangles = size_t(in.pod<uint64_t>());
  r.camera_from_file = in.pod<bool>();
  r.camera_source = in.text();
  r.insert_up = in.pod<UpAxis>();
  r.warnings = in.texts();
  if (!in.done()) throw std::runtime_error("scene import: the child's record has extra bytes");
  return s;
}

// The last line of a console text (what an aborting assimp printed), at most 200 characters.
std::string last_line(const std::string& console) {
  const size_t end = console.find_last_not_of(" \n\r");
  if (end == std::string::npos) return {};
  const size_t nl = console.find_last_of('\n', end);
  const size_t from = nl == std::string::npos ? 0 : nl + 1;
  const std::string s = one_line(console.substr(from, end + 1 - from));
  return s.size() > 200 ? s.substr(0, 200) + "..." : s;
}

// Time limit of the child: a floor plus a rate per byte of the files named (measured: the Cornell
// box with the 3.7 MB ogre.obj inserted imports in 0.14 s here, docs/BENCHMARKS.md), or
// BakeOptions::import_seconds.
double import_time_limit(const BakeOptions& o) {
  if (o.import_seconds > 0) return o.import_seconds;
  uint64_t bytes = 0;
  struct stat st {};
  if (stat(o.input.c_str(), &st) == 0) bytes += uint64_t(st.st_size);
  for (const auto& ins : o.inserts)
    if (stat(ins.path.c_str(), &st) == 0) bytes += uint64_t(st.st_size);
  return kImportSecondsFloor + kImportSecondsPerMB * double(bytes) / 1e6;
}

}  // namespace

Scene import_isolated(const BakeOptions& options, BakeReport& report) {
  const double limit = import_time_limit(options);
  const IsolatedRun run = run_isolated(
      [&](const IsolatedSend& send) {
        try {
          ImportContext ctx;
          ctx.memory_mb = options.import_memory_mb;
          ctx.reading = [&](const std::string& path) { send(record(kReading, path)); };
          BakeReport r;
          const Scene s = import_scene(options, r, ctx);
          send(record(kScene, encode(s, r)));
        } catch (const InputError& e) {
          send(record(kInputError, e.what()));
        } catch (const std::exception& e) {
          send(record(kError, e.what()));
        }
      },
      limit);
  std::string reading = options.input;
  for (const auto& [tag, bytes] : split_records(run.output)) {
    if (tag == kReading) reading = bytes;
    if (tag == kScene && run.exit_code == 0) return decode(bytes, report);
    if (tag == kInputError) throw InputError(bytes);
    if (tag == kError) throw std::runtime_error(bytes);
  }
  const std::string hint = "the file is damaged, or assimp mishandles it: check it or export it "
                           "again";
  if (run.timed_out)
    throw input_error(reading, "assimp did not finish reading it in " +
                                   fmt_float(float(limit)) + " s (an assimp loader loops on some "
                                   "damaged files)",
                      hint + "; if it is whole and large, raise --import-seconds");
  if (run.exit_code == kIsolatedSendFailed)
    throw input_error(reading, "the importing child process could not pass the scene back: its "
                               "memory file could not grow",
                      "no memory left, or a file-size limit (ulimit -f) too small");
  const std::string said = last_line(run.console);
  throw input_error(reading, "assimp crashed reading it (" +
                                 (run.signal ? signal_text(run.signal)
                                             : "exit code " + std::to_string(run.exit_code)) +
                                 (said.empty() ? "" : ": " + said) + ")",
                    hint);
}

}  // namespace pf::import
