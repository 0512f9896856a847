// options_file.h — a file of tool options (NAME.bake-options beside a scene file: options that
// the scene format cannot carry, such as the thin lens), read as words by the tool itself; no
// shell ever sees the file, so nothing in it can run as a command.
//
// The syntax: words separated by whitespace (spaces, tabs, newlines); '#' outside quotes starts a
// comment to the end of the line; '...' or "..." quote a word's part (spaces and '#' included) up
// to the same quote on the same line, with no escapes (a backslash is an ordinary character).
// Nothing is expanded: $, `, ;, |, &, >, < and \ are ordinary characters of a word, so
// "; touch x" is a stray word (refused below) and "$(x)" or "0.1;" are values that the option's own
// parsing judges, as it would on the command line.
//
// The words form options: "--name value" or "--name=value", every name one of the `allowed`
// names (for a bake-options file: the bake options, bake_options.h). Refused, with one
// InputError "FILE:LINE: ..." naming the word: an output option (-o, --output, --keep-scene), an
// options file within an options file, a positional word (the scene is named on the command
// line), an option not allowed, an option without its value, an unclosed quote, a NUL byte.
#pragma once
#include <string>
#include <vector>

namespace pf {

// One word of an options file and the line (1-based) it starts on.
struct OptionsFileWord {
  std::string text;
  int line = 0;
};

// One option of an options file: its name without the dashes, its value, and its line.
struct OptionsFileOption {
  std::string name;
  std::string value;
  int line = 0;
};

// The largest options file read: a file of a few options is far smaller; a bigger one is not an
// options file (refused, naming it).
constexpr size_t kMaxOptionsFileBytes = 64 * 1024;

// The words of `text` (see the syntax above); `file` names it in the errors ("FILE:LINE: ...").
std::vector<OptionsFileWord> split_options_words(const std::string& text, const std::string& file);

// The options of `words`, checked: every name in `allowed` (names without dashes; every one
// takes a value), else one InputError "FILE:LINE: ..." (see above).
std::vector<OptionsFileOption> options_of_words(const std::vector<OptionsFileWord>& words,
                                                const std::vector<std::string>& allowed,
                                                const std::string& file);

// The options in the file `path`: it must be a regular file (not a pipe or device, which could
// block or never end) of at most kMaxOptionsFileBytes; split_options_words, options_of_words.
std::vector<OptionsFileOption> read_options_file(const std::string& path,
                                                 const std::vector<std::string>& allowed);

// The options file that belongs to the scene file `scene`: the scene's path with its extension
// replaced by ".bake-options" (data/showcase.gltf → data/showcase.bake-options; a name without
// an extension gets it appended), when such a file (or anything by that name) exists; else "".
std::string discover_options_file(const std::string& scene);

}  // namespace pf
