#include "photonflow/geometry/scene_source.h"
#include "photonflow/geometry/camera.h"

#include <unistd.h>

#include <cmath>
#include <cstring>
#include <fstream>

#include "photonflow/foundations/error.h"
#include "photonflow/geometry/kdtree.h"
#include "photonflow/foundations/options.h"
#include "photonflow/io/output_file.h"
#include "photonflow/geometry/scene_file.h"

namespace pf {

void check_bake_options(const BakeOptions& o) {
  if (!(o.import_seconds >= 0 && o.import_seconds < 1e9))
    throw input_error("", "--import-seconds must be >= 0", "give 0 for the automatic limit");
  if (o.import_memory_mb > (uint64_t(1) << 24))
    throw input_error("", "--import-memory-mb must be at most 16777216 (16 TiB)",
                      "give 0 for the automatic budget");
  require_positive("kd-ct", o.kd.cost_traversal);
  require_positive("kd-ci", o.kd.cost_intersect);
  if (!(o.kd.empty_bonus >= 0.f && o.kd.empty_bonus < 1.f))
    throw input_error("", "--kd-empty-bonus must be in [0, 1)");
  if (o.kd.max_depth < 0 || o.kd.max_depth > kKdMaxDepth)
    throw input_error("", "--kd-max-depth must be in 0.." + std::to_string(kKdMaxDepth));
  require_positive("kd-max-leaf", o.kd.max_leaf_size);
  if (!(std::isfinite(o.environment_strength) && o.environment_strength > 0.f))
    throw input_error("", "--environment-strength must be a finite number > 0");
  if (!(std::isfinite(o.environment_rotate_deg) && std::fabs(o.environment_rotate_deg) <= 1e6f))
    throw input_error("", "--environment-rotate must be a finite angle in degrees, |angle| <= 1e6");
  if (!(o.aperture >= 0.f && o.aperture <= kMaxLensLength))
    throw input_error("", "--aperture must be 0 (pinhole) or a lens radius in (0, 1e12] scene units",
                      "give the lens radius in scene units");
  if (o.focus_distance) {
    if (!(*o.focus_distance > 0.f && *o.focus_distance <= kMaxLensLength))
      throw input_error("", "--focus-distance must be a distance in (0, 1e12] scene units",
                        "give the distance of the sharp plane along the view axis");
    if (o.aperture == 0.f)
      throw input_error("", "--focus-distance needs a lens: a pinhole camera (--aperture 0) is "
                            "sharp everywhere", "give --aperture, the lens radius");
  }
}

namespace {

bool ends_with(const std::string& s, const char* suffix) {
  const size_t n = std::strlen(suffix);
  return s.size() >= n && s.compare(s.size() - n, n, suffix) == 0;
}

// The HDF5 format signature (HDF5 File Format Specification, "Format Signature"): at byte 0 or at
// 512, 1024, 2048, ... (a user block before the superblock).
bool has_hdf5_signature(std::ifstream& f) {
  static const char kSignature[8] = {'\x89', 'H', 'D', 'F', '\r', '\n', '\x1a', '\n'};
  f.seekg(0, std::ios::end);
  const std::streamoff size = f.tellg();
  for (std::streamoff at = 0; at + 8 <= size; at = at == 0 ? 512 : 2 * at) {
    char head[8];
    f.seekg(at);
    if (!f.read(head, 8)) return false;
    if (std::memcmp(head, kSignature, 8) == 0) return true;
  }
  return false;
}

}  // namespace

bool is_baked_scene(const std::string& path) {
  require_regular_input(path);
  if (path.empty()) throw input_error("", "--scene is empty", "give it a file name");
  if (access(path.c_str(), F_OK) != 0)
    throw input_error(path, "no such file",
                      "check the path; --scene takes a baked scene.h5 or a scene source "
                      "(.dae, .obj, .gltf, .glb, .ply, ...)");
  std::ifstream f(path, std::ios::binary);
  if (!f) throw input_error(path, "cannot read file", "check the path and its permissions");
  return has_hdf5_signature(f) || ends_with(path, ".h5") || ends_with(path, ".hdf5");
}

OpenedScene open_scene(const std::string& path, BakeOptions bake,
                       const std::string& given_bake_options) {
  OpenedScene s;
  if (is_baked_scene(path)) {
    if (!given_bake_options.empty())
      throw input_error(path, "is a baked scene, which the bake options " +
                                  given_bake_options + " cannot change",
                        "give the scene source instead, or drop them");
    s.scene = load_scene(path);
    return s;
  }
  bake.input = path;
  s.scene = bake_scene(bake, s.report);
  s.baked_here = true;
  return s;
}

void add_bake_inputs(Provenance& prov, const BakeOptions& bake) {
  prov.add_input("source", bake.input);
  float rgb[3];
  if (!bake.environment.empty() && !parse_environment_colour(bake.environment, rgb))
    prov.add_input("environment", bake.environment);
  for (size_t i = 0; i < bake.inserts.size(); ++i)
    prov.add_input("insert" + std::to_string(i), bake.inserts[i].path);
}

void add_scene_inputs(Provenance& prov, const std::string& path, const OpenedScene& s,
                      const BakeOptions& bake) {
  prov.add_input("scene", path, s.baked_here ? "" : kSceneFormat, s.scene.scene_id);
  if (s.baked_here) {
    for (size_t i = 0; i < bake.inserts.size(); ++i)
      prov.add_input("insert" + std::to_string(i), bake.inserts[i].path);
    float rgb[3];
    if (!bake.environment.empty() && !parse_environment_colour(bake.environment, rgb))
      prov.add_input("environment", bake.environment);
  }
}

std::vector<std::string> bake_warnings(const BakeOptions& bake, const BakeReport& report) {
  std::vector<std::string> lines;
  for (const std::string& w : report.warnings) lines.push_back("warning: " + w);
  if (report.degenerate_dropped)
    lines.push_back("warning: " + bake.input + ": dropped " +
                    std::to_string(report.degenerate_dropped) + " zero-area triangles");
  if (report.primitives_skipped)
    lines.push_back("warning: " + bake.input + ": ignored " +
                    std::to_string(report.primitives_skipped) + " point or line primitives");
  return lines;
}

}  // namespace pf
