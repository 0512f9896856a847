// scene_file.h — writing and reading scene.h5, the file scene-bake writes and every later stage
// reads (docs/FORMATS.md); the Scene itself is scene.h, its checks scene_validate.h.
#pragma once
#include <string>

#include "photonflow/geometry/scene.h"
#include "photonflow/io/provenance.h"

namespace pf {

// Writes scene.h5 (atomically) with provenance; see docs/FORMATS.md.
void save_scene(const Scene& scene, const std::string& path, const Provenance& prov);
// Reads and checks scene.h5 (format, version, array consistency, kd-tree structure).
Scene load_scene(const std::string& path);

}  // namespace pf
