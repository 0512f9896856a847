// scene_import.h — baking a scene file (anything assimp reads: COLLADA, OBJ/MTL, glTF, PLY, ...)
// into a pf::Scene: one flat triangle array in world space, materials, lights, camera, derived
// data (Havel–Herout planes, bounds, light CDF, kd-tree) and scene_id. This is the library side of
// the scene-bake stage; the mapping from file materials to photonflow materials is documented in
// material_import.cpp and docs/SCENES.md, the import's parts at the top of scene_import.cpp.
#pragma once
#include <optional>
#include <string>
#include <vector>

#include "photonflow/geometry/scene_inputs.h"

#include "photonflow/geometry/kdtree.h"
#include "photonflow/geometry/scene.h"
#include "photonflow/foundations/vec.h"

namespace pf {

// The scene's up direction, along which inserted meshes stand: a world axis (0 x, 1 y, 2 z) and
// its sign; axis −1 = auto: the dominant axis of the camera's up vector (BakeOptions::up_axis).
struct UpAxis {
  int axis = -1;
  int sign = 1;
};
// "x", "y", "z", "-x", "-y", "-z" or "auto" (scene-bake --up-axis); InputError naming the option
// for anything else.
UpAxis parse_up_axis(const std::string& text);
// "+x" … "-z" ("auto" for axis −1).
std::string up_axis_name(UpAxis a);
// The axis along which `up` has its largest magnitude, with that component's sign: (0,1,0) → +y,
// (0.1,0.2,−0.9) → −z; ties go to the earlier axis; +y for a zero or non-finite vector.
UpAxis dominant_axis(const Vec3& up);

// An extra mesh file inserted into the scene (how the large benchmark scenes are made).
// The mesh, modelled y-up, is turned so that its +y points along the scene's up axis (a proper
// rotation by a multiple of 90°, identity for +y), scaled uniformly to the largest size that fits
// the target box, centred on the two other axes, with its lowest point along up on the box's
// bottom face (the face at the floor side: lo for +axis, hi for −axis): it stands on the box floor.
struct MeshInsert {
  std::string path;
  // Target box as fractions of the scene's bounds before insertion (0 = lo, 1 = hi per axis).
  // Unset: 0.3 … 0.7 on the two horizontal axes and the 40 % of the up axis at its floor side
  // (0 … 0.4 for +axis, 0.6 … 1 for −axis); for y up 0.3,0,0.3 … 0.7,0.4,0.7.
  std::optional<Vec3> box_lo;
  std::optional<Vec3> box_hi;
  // Name of a material of the main scene file for every inserted triangle; "" = a default
  // diffuse material (albedo kInsertAlbedo) named "insert-default".
  std::string material;
};

// Albedo of the default material of inserted meshes.
constexpr float kInsertAlbedo = 0.75f;

struct BakeOptions {
  std::string input;                // scene file
  std::vector<MeshInsert> inserts;  // extra meshes, in order
  // Camera overrides; unset = from the file's first camera, else the default framing camera.
  std::optional<Vec3> eye;
  std::optional<Vec3> look_at;
  std::optional<Vec3> up;
  std::optional<float> fov_y_deg;   // vertical field of view, degrees, in (0, 180)
  // Thin lens (depth of field): lens radius in world units, 0 = pinhole; focus distance along the
  // view axis, unset = the distance from the eye to the look-at point. assimp 5.2's aiCamera has
  // no aperture, so neither comes from the file.
  float aperture = 0.f;
  std::optional<float> focus_distance;
  UpAxis up_axis;                   // up for inserted meshes; auto: from the camera's up vector
  int width = 0;                    // pixels; 0 = 512, or derived from the other and the aspect
  int height = 0;                   // pixels; 0 = 512, or derived from the other and the aspect
  KdBuildParams kd;
  // Address-space budget of each assimp import in MiB (memory_cap.h); 0 = automatic: 256 MiB + 64 ×
  // the bytes of the files it opens. An import that needs more is refused (InputError).
  uint64_t import_memory_mb = 0;
  // Time limit of the import in seconds (bake_scene's child process); 0 = automatic: 60 s + 10 s
  // per MB of the input files. An import still running then is killed and refused (InputError).
  double import_seconds = 0;
  // What the bake does with the files the scene references (scene_inputs.h): --confine-inputs,
  // --missing-textures.
  InputPolicy inputs;
  // The environment light (environment.h load_environment): --environment, a .exr or .hdr map
  // or "R,G,B" ("" none), its --environment-strength and --environment-rotate (degrees about +y).
  // A scene with one needs no other light.
  std::string environment;
  float environment_strength = 1.f;
  float environment_rotate_deg = 0.f;
};

// What the bake found and did, for the tool's summary and warnings.
struct BakeReport {
  size_t triangles_read = 0;          // triangular faces in all input files
  size_t degenerate_dropped = 0;      // zero-area triangles removed (not in the scene)
  size_t primitives_skipped = 0;      // point and line primitives ignored
  size_t inserted_triangles = 0;      // triangles that came from BakeOptions::inserts
  bool camera_from_file = false;      // the file had a camera (before overrides)
  // Where each camera value came from: "eye, look-at from options; up, fov from file", with
  // "from options", "from file" and "from default framing" (no camera in the file, no option).
  std::string camera_source;
  UpAxis insert_up{1, 1};             // the up axis the inserted meshes stand on (resolved)
  std::vector<std::string> warnings;  // one line each (clamped albedo, ignored lights, ...)
  double import_seconds = 0;          // reading files, flattening, materials, lights, camera
};

// Default image size when neither the options nor the file's camera aspect say otherwise.
constexpr int kDefaultImageSize = 512;
// Vertical field of view of the default camera (no camera in the file), degrees.
constexpr float kDefaultFovYDeg = 40.f;

// Reads options.input (and the inserts), flattens the node graph into world-space triangles,
// maps materials, collects point lights, sets the camera, then derives hh, bounds, area lights and
// their CDF, kd-tree and scene_id (finish_scene). Throws InputError (one line: file, problem, what
// to do) for unreadable or unsupported files, no triangles, no light, non-finite coordinates,
// out-of-range indices and bad options. Zero-area triangles are dropped and counted in `report`.
// The files are read by assimp in a child process (isolate.h), which crashes, aborts or loops on
// some damaged files: that too is an InputError naming the file, as is an import past its memory
// budget (import_memory_mb) or time limit (import_seconds).
Scene bake_scene(const BakeOptions& options, BakeReport& report);

}  // namespace pf
