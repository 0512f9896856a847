// make_depfile.h — a make dependency file (the `-MD` files of compilers): "target: the files it
// was made from", which a Makefile includes so that editing any of those files makes the target
// again (pipelines/render.mk includes scene-bake --depfile's, so a changed environment map,
// texture or glTF buffer bakes the scene again).
//
// Only names make reads as plain file names go in: the characters A–Z a–z 0–9 . _ / + ~ @ , - (the
// set pipelines/names.mk allows for SCENE), not starting with '-' (an option) or '~' (which make
// expands to a home folder there). A name with any other character (a space, '$', ':', '#', '%', '\', a
// quote, a newline) could be read by make as syntax; it is left out and counted, never written,
// so a file a stranger named cannot put make syntax into the Makefile that includes this one.
#pragma once
#include <string>
#include <vector>

namespace pf {

// Whether make reads `name` as one plain file name (the rule above).
bool make_safe_name(const std::string& name);

// The text of a dependency file: a comment line, "target: \" and one prerequisite per line, then
// an empty rule "name:" for each (so make does not stop when one is deleted: gcc's -MP). Names are
// written once each, in order. `left_out` (when given) gets how many names were not make-safe; the
// target must be make-safe (std::invalid_argument otherwise).
std::string make_depfile_text(const std::string& target, const std::vector<std::string>& inputs,
                              size_t* left_out = nullptr);

}  // namespace pf
