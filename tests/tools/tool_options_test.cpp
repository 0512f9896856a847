// One vocabulary across the tools (issue 34): an old option spelling (DeprecatedOption,
// tool_main.h) still works, says so in one line and means exactly the new one; both spellings at
// once are refused; every tool's --help shows a default for every option that has one, and the
// defaults render, pathtrace, scene-bake and trace-photons print are the ones their run record or
// provenance says they used.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cxxopts.hpp>
#include <map>
#include <nlohmann/json.hpp>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "photonflow/io/h5io.h"
#include "photonflow/io/provenance.h"
#include "photonflow/geometry/scene.h"
#include "photonflow/io/stage_files.h"
#include "photonflow/foundations/tool_main.h"
#include "support.h"

using namespace pf;

namespace {

size_t lines(const std::string& s) { return size_t(std::count(s.begin(), s.end(), '\n')); }

std::string q(const std::string& s) { return "'" + s + "'"; }

// Option name → the text of its help entry (continuation lines joined with single spaces), as
// cxxopts prints it: an option line starts "  -x, --name" or "      --name"; a line indented
// further continues it; anything else (a blank line, a group's title) ends it.
std::map<std::string, std::string> help_entries(const std::string& help) {
  static const std::regex option_line(R"(^  (?:-[A-Za-z], |    )--([A-Za-z0-9-]+)(.*)$)");
  static const std::regex continuation(R"(^ {8,}(\S.*)$)");
  std::map<std::string, std::string> entries;
  std::string current;
  std::istringstream in(help);
  for (std::string line; std::getline(in, line);) {
    std::smatch m;
    if (std::regex_match(line, m, option_line)) {
      current = m[1];
      entries[current] = m[2];
    } else if (!current.empty() && std::regex_match(line, m, continuation)) {
      entries[current] += " " + m[1].str();
    } else {
      current.clear();
    }
  }
  for (auto& kv : entries)  // squeeze the column padding
    kv.second = std::regex_replace(kv.second, std::regex(" +"), " ");
  return entries;
}

// Option name → the default its help entry prints ("(default: X)" at the entry's end; "" for
// `(default: "")`). Options without one are left out.
std::map<std::string, std::string> help_defaults(const std::string& help) {
  static const std::regex def(R"(\(default: (.*)\)\s*$)");
  std::map<std::string, std::string> out;
  for (const auto& [name, text] : help_entries(help)) {
    std::smatch m;
    if (std::regex_search(text, m, def)) out[name] = m[1] == "\"\"" ? "" : m[1].str();
  }
  return out;
}

// The options that take a value and have no default value: the files a run reads or must be
// told to write, and values taken from elsewhere when not given (a scene file's camera, the
// distribution); their help may say "(default: the file's camera ...)" in words.
const std::set<std::string> kNoDefault = {
    "scene", "output", "hitpoints", "photons", "grid", "state", "clusters", "distribution",
    "input", "eye", "look-at", "up", "fov", "focus-distance", "insert", "insert-box", "insert-material",
    "environment",
    "checkpoint", "sums", "range", "parts", "reference", "test", "mask", "json", "time-limit",
    "out", "options-file"};

// Every option of `help` with a printed default must be in `recorded` (the parameters of a run
// record or a provenance group) with that value; options given on the command line (`given`) and
// "auto" defaults (resolved at run time, e.g. render --method) are left out, and so are options of
// kNoDefault that the record does not hold (a default in words). Returns how many were compared.
size_t check_defaults(const std::string& tool, const std::string& help,
                      const std::map<std::string, std::string>& recorded,
                      const std::set<std::string>& given) {
  size_t compared = 0;
  for (const auto& [name, value] : help_defaults(help)) {
    if (given.count(name) || value == "auto") continue;
    if (!recorded.count(name) && kNoDefault.count(name)) continue;
    INFO(tool << " --" << name << ": --help says '" << value << "'");
    REQUIRE(recorded.count(name) == 1);
    CHECK(recorded.at(name) == value);
    ++compared;
  }
  return compared;
}

std::map<std::string, std::string> json_parameters(const std::string& file) {
  const nlohmann::json j = nlohmann::json::parse(test::file_bytes(file));
  std::map<std::string, std::string> out;
  for (const auto& [k, v] : j.at("parameters").items()) out[k] = v.get<std::string>();
  return out;
}

std::map<std::string, std::string> h5_parameters(const std::string& file, const char* format,
                                                 int version) {
  h5::Reader r(file, format, version);
  return read_provenance(r).parameters;
}

}  // namespace

TEST_CASE("parse_options reads a deprecated spelling as the new one, with one notice",
          "[tool_options]") {
  auto parse = [](std::vector<std::string> args) {
    cxxopts::Options o("tool", "test");
    o.add_options()("time", "budget", cxxopts::value<double>()->default_value("0"))(
        "o,output", "out", cxxopts::value<std::string>());
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    return parse_options(o, int(argv.size()), argv.data(), {{"time-limit", "time"}});
  };
  CHECK(parse({"tool", "--time-limit", "2.5"})["time"].as<double>() == 2.5);
  CHECK(parse({"tool", "--time-limit=3"})["time"].as<double>() == 3.0);
  CHECK(parse({"tool", "--time", "4"})["time"].as<double>() == 4.0);
  // A value that merely starts like the old name is not rewritten.
  CHECK(parse({"tool", "-o", "--time-limitless"})["output"].as<std::string>() == "--time-limitless");
  CHECK_THROWS_AS(parse({"tool", "--time-limit", "1", "--time", "2"}), InputError);
  CHECK(deprecation_notice("pathtrace", {"time-limit", "time"}) ==
        "pathtrace: --time-limit is deprecated, use --time (accepted until the next release)");
}

TEST_CASE("pathtrace --time-limit and gen-mesh --out: the old spellings warn and work",
          "[tool_options]") {
  test::TempDir tmp("tool-options-old");
  REQUIRE(test::run_tool("scene-bake", q(test::source_dir() + "/data/cornell-box.dae") + " -o " +
                                           q(tmp / "scene.h5") + " --width 24 --height 20",
                         tmp)
              .exit_code == 0);
  const std::string common = "--scene " + q(tmp / "scene.h5") + " --spp 2 --png none ";
  const auto now = test::run_tool(
      "pathtrace", common + "-o " + q(tmp / "new.exr") + " --time 100 --stats " + q(tmp / "new.json"), tmp);
  REQUIRE(now.exit_code == 0);
  CHECK(now.err.empty());
  const auto old = test::run_tool(
      "pathtrace", common + "-o " + q(tmp / "old.exr") + " --time-limit 100 --stats " + q(tmp / "old.json"), tmp);
  INFO(old.err);
  REQUIRE(old.exit_code == 0);
  CHECK(old.err ==
        "pathtrace: --time-limit is deprecated, use --time (accepted until the next release)\n");
  CHECK(test::file_bytes(tmp / "old.exr") == test::file_bytes(tmp / "new.exr"));
  const auto rec = json_parameters(tmp / "old.json");
  CHECK(rec.at("time") == "100");
  CHECK(rec.count("time-limit") == 0);
  // Both spellings: one line, exit 2, no output.
  const auto both = test::run_tool(
      "pathtrace", common + "-o " + q(tmp / "both.exr") + " --time-limit 1 --time 2", tmp);
  CHECK(both.exit_code == 2);
  CHECK(lines(both.err) == 1);
  CHECK(both.err.find("--time-limit") != std::string::npos);
  CHECK_FALSE(std::filesystem::exists(tmp / "both.exr"));
  // The old spelling is listed in --help, as deprecated.
  const auto help = test::run_tool("pathtrace", "--help", tmp);
  CHECK(help_entries(help.out).count("time-limit") == 1);
  CHECK(help_entries(help.out).count("time") == 1);

  const auto mesh_new = test::run_tool("gen-mesh", "--shape box -o " + q(tmp / "new.obj"), tmp);
  REQUIRE(mesh_new.exit_code == 0);
  CHECK(mesh_new.err.empty());
  const auto mesh_old = test::run_tool("gen-mesh", "--shape box --out " + q(tmp / "old.obj"), tmp);
  REQUIRE(mesh_old.exit_code == 0);
  CHECK(mesh_old.err ==
        "gen-mesh: --out is deprecated, use --output (accepted until the next release)\n");
  CHECK(test::file_bytes(tmp / "old.obj") == test::file_bytes(tmp / "new.obj"));
  CHECK_FALSE(test::file_bytes(tmp / "new.obj").empty());
}

TEST_CASE("every tool's --help prints a default for every option that has one",
          "[tool_options]") {
  test::TempDir tmp("tool-options-help");
  for (const char* tool : {"build-grid", "cluster", "emitter-mask", "gen-mesh", "illuminate",
                           "imgcompare", "merge", "pathtrace", "photon-distribution", "render",
                           "scene-bake", "synthesize", "trace-hitpoints", "trace-photons"}) {
    const auto help = test::run_tool(tool, "--help", tmp);
    REQUIRE(help.exit_code == 0);
    const auto entries = help_entries(help.out);
    REQUIRE(entries.size() >= 2);
    const auto defaults = help_defaults(help.out);
    for (const auto& [name, text] : entries) {
      // Flags (no " arg") have no value; the others print "(default: ...)" or say in their text
      // where the value comes from when not given.
      if (text.compare(0, 4, " arg") != 0 || kNoDefault.count(name)) continue;
      INFO(tool << " --" << name << ":" << text);
      CHECK(defaults.count(name) == 1);
    }
  }
}

TEST_CASE("the defaults --help prints are the ones the run record says were used",
          "[tool_options]") {
  test::TempDir tmp("tool-options-defaults");
  const std::string dae = test::source_dir() + "/data/cornell-box.dae";

  // render, from a scene source (so the bake options are recorded too), tiny.
  const std::set<std::string> render_given = {"scene", "output", "stats", "passes", "photons",
                                              "width", "height"};
  const auto r = test::run_tool("render", "--scene " + q(dae) + " -o " + q(tmp / "r.exr") +
                                              " --stats " + q(tmp / "r.json") +
                                              " --passes 1 --photons 500 --width 16 --height 12",
                                tmp);
  INFO(r.err);
  REQUIRE(r.exit_code == 0);
  const auto render_help = test::run_tool("render", "--help", tmp).out;
  CHECK(check_defaults("render", render_help, json_parameters(tmp / "r.json"), render_given) >= 30);

  // scene-bake and trace-photons: the provenance of the file they write.
  REQUIRE(test::run_tool("scene-bake", q(dae) + " -o " + q(tmp / "s.h5"), tmp).exit_code == 0);
  CHECK(check_defaults("scene-bake", test::run_tool("scene-bake", "--help", tmp).out,
                       h5_parameters(tmp / "s.h5", kSceneFormat, kSceneFormatVersion),
                       {"input", "output"}) >= 10);
  REQUIRE(test::run_tool("scene-bake", q(dae) + " -o " + q(tmp / "small.h5") +
                                           " --width 16 --height 12",
                         tmp)
              .exit_code == 0);
  REQUIRE(test::run_tool("trace-photons", "--scene " + q(tmp / "small.h5") + " -o " +
                                              q(tmp / "p.h5") + " --photons 500",
                         tmp)
              .exit_code == 0);
  CHECK(check_defaults("trace-photons", test::run_tool("trace-photons", "--help", tmp).out,
                       load_photons_provenance(tmp / "p.h5").parameters,
                       {"scene", "output", "photons"}) >= 4);

  // pathtrace.
  const auto p = test::run_tool("pathtrace", "--scene " + q(tmp / "small.h5") + " -o " +
                                                 q(tmp / "p.exr") + " --spp 1 --stats " +
                                                 q(tmp / "p.json"),
                                tmp);
  REQUIRE(p.exit_code == 0);
  CHECK(check_defaults("pathtrace", test::run_tool("pathtrace", "--help", tmp).out,
                       json_parameters(tmp / "p.json"), {"scene", "output", "stats", "spp"}) >= 8);
}

TEST_CASE("a number option's value is a number to its last character", "[tool_options]") {
  test::TempDir tmp("tool-options-number");
  const std::string scene = std::string(PF_SOURCE_DIR) + "/data/cornell-box.dae";
  // cxxopts alone reads the number at the front and drops the rest without a word.
  for (const std::string& bad : {"0.1;", "0.1x", "0.1;touch", "1e-2.5"}) {
    const auto bake = test::run_tool(
        "scene-bake", "'" + scene + "' -o '" + (tmp / "s.h5") + "' --aperture '" + bad + "'", tmp);
    INFO(bad << ": " << bake.err);
    CHECK(bake.exit_code == 2);
    CHECK(std::count(bake.err.begin(), bake.err.end(), '\n') == 1);
    CHECK(bake.err.find("--aperture") != std::string::npos);
    CHECK_FALSE(std::filesystem::exists(tmp / "s.h5"));
  }
  const auto alpha = test::run_tool("render", "--scene '" + scene + "' -o '" + (tmp / "r.exr") +
                                                  "' --passes 1 --width 8 --height 8 --alpha 0.7x",
                                    tmp);
  CHECK(alpha.exit_code == 2);
  CHECK(alpha.err.find("--alpha must be a number, got '0.7x'") != std::string::npos);
  // The same values written whole are taken.
  const auto good = test::run_tool(
      "scene-bake", "'" + scene + "' -o '" + (tmp / "s.h5") + "' --aperture 0.1", tmp);
  CHECK(good.exit_code == 0);
  CHECK(std::filesystem::exists(tmp / "s.h5"));
}
