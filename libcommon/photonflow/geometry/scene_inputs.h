// scene_inputs.h — the files a scene source makes a bake read, found and checked before any loader
// opens one (docs/SCENES.md, "Files a scene references"). assimp opens a glTF's buffers and an
// OBJ's material libraries itself, and a read of a FIFO waits for ever, so they are found here
// from the scene's own text (glTF JSON, OBJ mtllib lines, COLLADA <init_from>) and checked first.
#pragma once
#include <string>
#include <vector>

namespace pf {

// How a bake treats the files a scene references (BakeOptions::inputs; bake_options.h).
struct InputPolicy {
  // --confine-inputs: every file (the inserted meshes and everything a scene or insert references)
  // must resolve, after symlinks, inside the scene file's folder.
  bool confine = false;
  // --missing-textures warn: a texture that cannot be read (missing, empty or bad URI, no image,
  // empty buffer view, undecodable) is dropped with a warning instead of refusing the bake.
  bool missing_textures_warn = false;
};

// One file a scene references.
struct SceneReference {
  std::string path;   // as it will be opened: relative to the scene's folder, percent-decoded
  std::string role;   // what it is, for messages: "glTF buffer 0", "glTF image 2", "OBJ mtllib"
  bool image = false; // a texture image (missing: --missing-textures decides)
};

// The files that `scene_file` references, from its own text: glTF `buffers[].uri` and
// `images[].uri` (not data: URIs), OBJ `mtllib` lines and the `map_*` images of those material
// libraries, COLLADA `<init_from>` image paths. InputError for a glTF whose JSON cannot be read
// and for a glTF texture a material uses that cannot be read (no image source, empty URI, bad
// data: URI, empty bufferView), unless policy.missing_textures_warn, which turns the latter into
// `warnings`. An OBJ's material libraries are checked (check_input_file, in `root`) before they
// are read for their images.
std::vector<SceneReference> scene_references(const std::string& scene_file,
                                             const InputPolicy& policy, const std::string& root,
                                             std::vector<std::string>& warnings);

// Refuses (InputError, one line naming `path`) a file that exists but is not a regular file — a
// FIFO, directory, device or socket — or a symlink loop; with policy.confine also one that does
// not resolve inside `root` (a folder, already resolved by realpath). The line names what the
// file is (`role` of `scene_file`) and never its size or contents. Returns false for a file that
// does not exist (a dangling link included); the caller decides.
bool check_input_file(const std::string& path, const std::string& role,
                      const std::string& scene_file, const InputPolicy& policy,
                      const std::string& root);

// The extension of `path`, lower-case, with its dot (".dae" for "dir/scene.DAE"); "" when the
// file name has none. The format of a scene file or a reference is told by it.
std::string lower_extension(const std::string& path);

// The folder that confines the inputs of `scene_file`: the realpath of its folder.
std::string input_root(const std::string& scene_file);

// True when `path` resolves (after symlinks) outside `root`.
bool outside_root(const std::string& path, const std::string& root);

// Checks every file a bake of `scene_file` with `inserts` would read, before any is opened: the
// scene file and each insert (check_input_file; a missing one refused), and everything each
// references (scene_references; a missing buffer or material library refused, a missing image
// left to the texture loader, which follows --missing-textures). Warnings go to `warnings`.
void check_scene_inputs(const std::string& scene_file, const std::vector<std::string>& inserts,
                        const InputPolicy& policy, std::vector<std::string>& warnings);

// Every file a finished bake read, for scene-bake --depfile (make_depfile.h): the scene file, the
// options file (when one was read), each insert, the existing files each of those references
// (scene_references), and the environment map (not a colour R,G,B), in that order. Paths as
// they were opened.
std::vector<std::string> bake_input_files(const std::string& scene_file,
                                          const std::vector<std::string>& inserts,
                                          const std::string& environment,
                                          const std::string& options_file);

}  // namespace pf
