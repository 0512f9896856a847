// scene_validate.h — the checks of a baked scene's tables and values, shared by the reader, the
// writer and the importer of scene.h5, so that each applies the same ones.
#pragma once
#include <string>

#include "photonflow/geometry/scene.h"

namespace pf {

// The checks load_scene applies to a scene's tables and values (validate.h): table lengths, every
// index into them, material and light types, the camera's image size, the kd-tree, every value in
// range. `s` must have its bounds computed (compute_bounds). save_scene applies them to what it
// writes (written_check) and bake_scene to what it baked (InputError naming the source: a
// coordinate or camera option beyond kMaxCoordinate). InputError naming `path`.
void validate_scene(const Scene& s, const std::string& path);

}  // namespace pf
