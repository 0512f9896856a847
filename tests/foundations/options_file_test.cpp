// The options-file reader (options_file.h): words, '#' comments and quotes with no shell
// expansion; the refusals (output options, an options file in an options file, positional words,
// options not allowed, a missing value, an unclosed quote, a NUL byte, a pipe, a large file), each
// one InputError naming the file and line; and the discovery rule NAME.bake-options.
#include <catch2/catch.hpp>

#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "photonflow/foundations/error.h"
#include "photonflow/foundations/options_file.h"
#include "support.h"

using namespace pf;

namespace {

const std::vector<std::string> kAllowed = {"aperture", "focus-distance", "eye", "insert",
                                           "insert-material", "width"};

std::vector<std::string> texts(const std::vector<OptionsFileWord>& words) {
  std::vector<std::string> t;
  for (const OptionsFileWord& w : words) t.push_back(w.text);
  return t;
}

// The InputError's message for `text` as the options file "f.bake-options" ("" none).
std::string refusal(const std::string& text) {
  try {
    options_of_words(split_options_words(text, "f.bake-options"), kAllowed, "f.bake-options");
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

void write(const std::string& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

}  // namespace

TEST_CASE("options file: words, comments, quotes and lines", "[options-file]") {
  const auto w = split_options_words(
      "# a comment line\n"
      "--aperture 0.04   --focus-distance\t2.4 # trailing comment --eye 9,9,9\n"
      "\n"
      "--insert 'my mesh.obj' --insert-material \"mat #1\"\r\n"
      "--eye=a'b c'd\n",
      "f");
  REQUIRE(texts(w) == std::vector<std::string>{"--aperture", "0.04", "--focus-distance", "2.4",
                                               "--insert", "my mesh.obj", "--insert-material",
                                               "mat #1", "--eye=ab cd"});
  CHECK(w[0].line == 2);
  CHECK(w[3].line == 2);
  CHECK(w[4].line == 4);
  CHECK(w[8].line == 5);
  CHECK(split_options_words("", "f").empty());
  CHECK(split_options_words("# only\n   \n", "f").empty());
  // An empty quoted word is a word (an empty value the option's own check judges).
  REQUIRE(texts(split_options_words("--eye ''", "f")) == std::vector<std::string>{"--eye", ""});
}

TEST_CASE("options file: shell syntax is ordinary text, never expanded", "[options-file]") {
  for (const std::string& s :
       {std::string("0.1;touch"), std::string("$(touch)"), std::string("`touch`"),
        std::string("0.1&&touch"), std::string("0.1|tee"), std::string(">x"), std::string("$HOME"),
        std::string("a\\b")}) {
    INFO(s);
    const auto w = split_options_words("--aperture " + s, "f");
    REQUIRE(w.size() == 2);
    CHECK(w[1].text == s);
  }
  // Spaces around shell operators make separate words: a positional word, refused.
  CHECK(refusal("--aperture 0.1 ; touch CANARY") ==
        "f.bake-options:1: ';' is not an option (an options file holds bake options only, e.g. "
        "--aperture 0.04; the scene file is named on the command line)");
}

TEST_CASE("options file: options, values and =", "[options-file]") {
  const auto o = options_of_words(
      split_options_words("--aperture 0.04\n--eye=-1,2,3 --width\n64", "f"), kAllowed, "f");
  REQUIRE(o.size() == 3);
  CHECK((o[0].name == "aperture" && o[0].value == "0.04" && o[0].line == 1));
  CHECK((o[1].name == "eye" && o[1].value == "-1,2,3" && o[1].line == 2));
  CHECK((o[2].name == "width" && o[2].value == "64" && o[2].line == 2));
  // A value that looks like an option is the option's value (its check refuses it if wrong).
  const auto v = options_of_words(split_options_words("--eye -1,0,0", "f"), kAllowed, "f");
  REQUIRE(v.size() == 1);
  CHECK(v[0].value == "-1,0,0");
}

TEST_CASE("options file: output options, options files, strays: one line naming file and line",
          "[options-file]") {
  CHECK(refusal("--aperture 0.1\n\n-o elsewhere.h5\n") ==
        "f.bake-options:3: '-o' is an output option and cannot be given in an options file (give "
        "it on the command line)");
  CHECK(refusal("-oelsewhere.h5").rfind("f.bake-options:1: '-o' is an output option", 0) == 0);
  CHECK(refusal("--output=x.h5").rfind("f.bake-options:1: '--output' is an output option", 0) == 0);
  CHECK(refusal("# c\n--keep-scene k.h5").rfind("f.bake-options:2: '--keep-scene' is an output option", 0) == 0);
  CHECK(refusal("--options-file other").rfind("f.bake-options:1: '--options-file' cannot be given", 0) == 0);
  CHECK(refusal("--no-options-file").rfind("f.bake-options:1: '--no-options-file' cannot be given", 0) == 0);
  CHECK(refusal("scene.gltf").rfind("f.bake-options:1: 'scene.gltf' is not an option", 0) == 0);
  CHECK(refusal("--passes 4").rfind("f.bake-options:1: '--passes' is not a bake option", 0) == 0);
  CHECK(refusal("-x").rfind("f.bake-options:1: '-x' is not a bake option", 0) == 0);
  CHECK(refusal("\n--aperture").rfind("f.bake-options:2: '--aperture' needs a value", 0) == 0);
  CHECK(refusal("--insert 'a b").rfind("f.bake-options:1: a single quote is not closed", 0) == 0);
  CHECK(refusal("--insert \"a\nb\"").rfind("f.bake-options:1: a double quote is not closed", 0) == 0);
  CHECK(refusal(std::string("--aperture 0.1\n--eye 1\0,2", 25)).rfind("f.bake-options:2: holds a NUL", 0) == 0);
  CHECK(refusal("# \"unclosed in a comment is fine\n--aperture 0.1").empty());
  // Every refusal is one line.
  for (const std::string& t : {"-o x", "--insert 'a", "stray", "--bogus 1"})
    CHECK(refusal(t).find('\n') == std::string::npos);
}

TEST_CASE("options file: read from disk, regular files only", "[options-file]") {
  test::TempDir tmp("options-file");
  write(tmp / "a.bake-options", "--aperture 0.04 # lens\n--focus-distance 2\n");
  const auto o = read_options_file(tmp / "a.bake-options", kAllowed);
  REQUIRE(o.size() == 2);
  CHECK(o[1].name == "focus-distance");
  auto message = [&](const std::string& path) {
    try {
      read_options_file(path, kAllowed);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  CHECK(message(tmp / "missing").find("no such options file") != std::string::npos);
  CHECK(message(tmp.dir.string()).find("is not a regular file") != std::string::npos);
  REQUIRE(mkfifo((tmp / "fifo").c_str(), 0600) == 0);
  CHECK(message(tmp / "fifo").find("is not a regular file") != std::string::npos);  // no hang
  CHECK(message("/dev/zero").find("is not a regular file") != std::string::npos);
  write(tmp / "big", std::string(kMaxOptionsFileBytes + 1, ' '));
  CHECK(message(tmp / "big").find("too large") != std::string::npos);
  write(tmp / "out", "--aperture 0.1\n-o elsewhere.h5\n");
  CHECK(message(tmp / "out") == tmp / "out" + ":2: '-o' is an output option and cannot be given in "
                                              "an options file (give it on the command line)");
}

TEST_CASE("options file: NAME.bake-options beside the scene is discovered", "[options-file]") {
  test::TempDir tmp("options-discover");
  CHECK(discover_options_file(tmp / "showcase.gltf").empty());  // none there
  write(tmp / "showcase.bake-options", "--aperture 0.04\n");
  CHECK(discover_options_file(tmp / "showcase.gltf") == tmp / "showcase.bake-options");
  CHECK(discover_options_file(tmp / "showcase") == tmp / "showcase.bake-options");
  CHECK(discover_options_file(tmp / "showcase.bake-options").empty());  // not itself
  CHECK(discover_options_file(tmp / "other.gltf").empty());
  // Only the last extension goes: a.b.glb → a.b.bake-options.
  write(tmp / "a.b.bake-options", "");
  CHECK(discover_options_file(tmp / "a.b.glb") == tmp / "a.b.bake-options");
  CHECK(discover_options_file("").empty());
}
