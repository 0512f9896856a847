// Options files: see options_file.h.
#include "photonflow/foundations/options_file.h"

#include <sys/stat.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "photonflow/foundations/error.h"

namespace pf {

namespace {

InputError at_line(const std::string& file, int line, const std::string& problem,
                   const std::string& hint) {
  return input_error(file + ":" + std::to_string(line), problem, hint);
}

// The word as the error quotes it: at most 60 characters, so a long line stays one short line.
std::string quoted(const std::string& word) {
  return "'" + (word.size() > 60 ? word.substr(0, 57) + "..." : word) + "'";
}

bool is_output_option(const std::string& name) {
  return name == "o" || name == "output" || name == "keep-scene";
}

}  // namespace

std::vector<OptionsFileWord> split_options_words(const std::string& text, const std::string& file) {
  std::vector<OptionsFileWord> words;
  int line = 1;
  bool in_word = false;
  OptionsFileWord word;
  auto end_word = [&] {
    if (in_word) words.push_back(word);
    in_word = false;
    word = OptionsFileWord{};
  };
  for (size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '\0')
      throw at_line(file, line, "holds a NUL byte", "an options file is text: options and comments");
    if (c == '\n') {
      end_word();
      ++line;
    } else if (c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v') {
      end_word();
    } else if (c == '#') {  // a comment, to the end of the line
      end_word();
      while (i + 1 < text.size() && text[i + 1] != '\n') {
        if (text[i + 1] == '\0')
          throw at_line(file, line, "holds a NUL byte",
                        "an options file is text: options and comments");
        ++i;
      }
    } else if (c == '\'' || c == '"') {  // a quoted part, up to the same quote on this line
      if (!in_word) word.line = line;
      in_word = true;
      const size_t close = text.find_first_of(std::string(1, c) + "\n", i + 1);
      if (close == std::string::npos || text[close] == '\n')
        throw at_line(file, line, std::string("a ") + (c == '"' ? "double" : "single") +
                                      " quote is not closed on its line",
                      "close it, or remove it; quotes only join a word with spaces");
      const std::string part = text.substr(i + 1, close - i - 1);
      if (part.find('\0') != std::string::npos)
        throw at_line(file, line, "holds a NUL byte", "an options file is text: options and comments");
      word.text += part;
      i = close;
    } else {
      if (!in_word) word.line = line;
      in_word = true;
      word.text += c;
    }
  }
  end_word();
  return words;
}

std::vector<OptionsFileOption> options_of_words(const std::vector<OptionsFileWord>& words,
                                                const std::vector<std::string>& allowed,
                                                const std::string& file) {
  std::vector<OptionsFileOption> options;
  for (size_t i = 0; i < words.size(); ++i) {
    const OptionsFileWord& w = words[i];
    const std::string& t = w.text;
    std::string name, value;
    bool has_value = false;
    if (t.size() > 2 && t.compare(0, 2, "--") == 0) {
      const size_t eq = t.find('=');
      name = t.substr(2, eq == std::string::npos ? std::string::npos : eq - 2);
      if (eq != std::string::npos) {
        value = t.substr(eq + 1);
        has_value = true;
      }
    } else if (t.size() >= 2 && t[0] == '-' && t[1] != '-') {
      name = t.substr(1, 1);  // a short option: -o, -oFILE
      if (t.size() > 2) {
        value = t.substr(t[2] == '=' ? 3 : 2);
        has_value = true;
      }
      if (!is_output_option(name))
        throw at_line(file, w.line, quoted(t) + " is not a bake option",
                      "an options file holds bake options by their long names, e.g. --aperture 0.04");
    } else {
      throw at_line(file, w.line, quoted(t) + " is not an option",
                    "an options file holds bake options only, e.g. --aperture 0.04; the scene "
                    "file is named on the command line");
    }
    const std::string flag = (name.size() == 1 ? "-" : "--") + name;
    if (is_output_option(name))
      throw at_line(file, w.line, quoted(flag) + " is an output option and cannot be given in an "
                                                "options file",
                    "give it on the command line");
    if (name == "options-file" || name == "no-options-file")
      throw at_line(file, w.line, quoted(flag) + " cannot be given in an options file",
                    "an options file cannot name another; give it on the command line");
    if (std::find(allowed.begin(), allowed.end(), name) == allowed.end())
      throw at_line(file, w.line, quoted(flag) + " is not a bake option",
                    "an options file holds only the options that shape a bake, e.g. --aperture, "
                    "--focus-distance, --eye (see scene-bake --help)");
    if (!has_value) {
      if (i + 1 == words.size())
        throw at_line(file, w.line, quoted(flag) + " needs a value", "give it after the option");
      value = words[++i].text;
    }
    options.push_back({name, value, w.line});
  }
  return options;
}

std::vector<OptionsFileOption> read_options_file(const std::string& path,
                                                 const std::vector<std::string>& allowed) {
  if (path.empty()) throw input_error("", "--options-file is empty", "give it a file name");
  struct stat st {};
  if (stat(path.c_str(), &st) != 0)
    throw input_error(path, "no such options file", "check the path, or drop --options-file");
  if (!S_ISREG(st.st_mode))
    throw input_error(path, "is not a regular file",
                      "an options file is a text file, not a pipe, directory or device");
  if (uint64_t(st.st_size) > kMaxOptionsFileBytes)
    throw input_error(path, "is larger than " + std::to_string(kMaxOptionsFileBytes / 1024) +
                                " KiB, too large for an options file",
                      "an options file holds a few bake options");
  std::ifstream f(path, std::ios::binary);
  if (!f) throw input_error(path, "cannot read the options file", "check its permissions");
  std::string text;
  // Read at most one byte past the limit: the file may have grown since stat.
  text.resize(kMaxOptionsFileBytes + 1);
  f.read(&text[0], std::streamsize(text.size()));
  text.resize(size_t(f.gcount()));
  if (text.size() > kMaxOptionsFileBytes)
    throw input_error(path, "is larger than " + std::to_string(kMaxOptionsFileBytes / 1024) +
                                " KiB, too large for an options file",
                      "an options file holds a few bake options");
  return options_of_words(split_options_words(text, path), allowed, path);
}

std::string discover_options_file(const std::string& scene) {
  if (scene.empty()) return "";
  std::filesystem::path p(scene);
  if (p.filename().empty() || p.filename() == "." || p.filename() == "..") return "";
  p.replace_extension(".bake-options");
  const std::string candidate = p.string();
  if (candidate == scene) return "";  // the scene itself is named NAME.bake-options
  struct stat st {};
  return lstat(candidate.c_str(), &st) == 0 ? candidate : "";
}

}  // namespace pf
