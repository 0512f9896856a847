// scene_source.h — a scene named on the command line: a baked scene.h5 or a scene source (any file
// scene-bake reads: COLLADA, OBJ/MTL, glTF, PLY, ...), which is baked in this process with the
// same options and the same function as scene-bake (bake_options.h, bake_scene). `render --scene`
// takes either, so one command renders any scene.
#pragma once
#include <string>
#include <vector>

#include "photonflow/io/provenance.h"
#include "photonflow/geometry/scene.h"
#include "photonflow/geometry/scene_import.h"

namespace pf {

// Refuses bake options out of range with one InputError naming the option (scene-bake's checks:
// --import-seconds, --import-memory-mb, --kd-ct, --kd-ci, --kd-empty-bonus, --kd-max-depth,
// --kd-max-leaf).
void check_bake_options(const BakeOptions& o);

// True when `path` is a baked scene file: it starts with the HDF5 signature (at byte 0, or at 512,
// 1024, 2048, ... after a user block), or its name ends in .h5 or .hdf5 (a damaged scene.h5 then
// gets the HDF5 reader's message, not an importer's). A missing or unreadable file is an
// InputError naming it, a FIFO or directory too (require_regular_input).
bool is_baked_scene(const std::string& path);

struct OpenedScene {
  Scene scene;
  bool baked_here = false;  // true: baked from a scene source in this process
  BakeReport report;        // the bake's report (baked_here only)
};

// The scene at `path`: a baked scene is loaded (load_scene); anything else is baked as
// scene-bake would bake it with `bake` (its input set to `path`). `given_bake_options` names the
// bake options given on the command line ("--width, --kd-ct"; "" none): they are refused for a
// baked scene, which they cannot change. One-line InputErrors for every bad input.
OpenedScene open_scene(const std::string& path, BakeOptions bake,
                       const std::string& given_bake_options);

// The scene's input records of a run's provenance: role "scene" (path, SHA-256, scene_id; format
// kSceneFormat for a baked scene, "" for a source) and, for a source, "insert<i>" per inserted mesh.
void add_scene_inputs(Provenance& prov, const std::string& path, const OpenedScene& s,
                      const BakeOptions& bake);

// The inputs scene-bake records for a bake: "source" and "insert<i>".
void add_bake_inputs(Provenance& prov, const BakeOptions& bake);

// The bake's warnings, one line each without the tool's prefix: the importer's, zero-area
// triangles dropped, point or line primitives ignored.
std::vector<std::string> bake_warnings(const BakeOptions& bake, const BakeReport& report);

}  // namespace pf
