// Small text helpers of text_file.h and options.h: JSON string literals decoded by an RFC 8259
// decoder written here, JSON numbers read back with strtod, the records' layout read back by
// nlohmann's parser, numbered snapshot names that sort in order, and parse_vec3's refusals.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <unistd.h>
#include <limits>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "photonflow/foundations/error.h"
#include "photonflow/foundations/options.h"
#include "photonflow/io/provenance.h"
#include "photonflow/foundations/text_file.h"

using namespace pf;

namespace {

// Decodes a JSON string literal (RFC 8259 §7) holding only ASCII/byte escapes; fails the test on
// anything a JSON parser would refuse (a raw control character, a lone backslash, a bad escape).
std::string json_decode(const std::string& lit) {
  REQUIRE(lit.size() >= 2);
  REQUIRE(lit.front() == '"');
  REQUIRE(lit.back() == '"');
  std::string out;
  for (size_t i = 1; i + 1 < lit.size(); ++i) {
    const unsigned char c = static_cast<unsigned char>(lit[i]);
    REQUIRE(c >= 0x20);  // control characters must be escaped
    REQUIRE(c != '"');   // an unescaped quote would end the string
    if (c != '\\') {
      out += char(c);
      continue;
    }
    REQUIRE(i + 2 < lit.size());
    const char e = lit[++i];
    switch (e) {
      case '"': out += '"'; break;
      case '\\': out += '\\'; break;
      case '/': out += '/'; break;
      case 'b': out += '\b'; break;
      case 'f': out += '\f'; break;
      case 'n': out += '\n'; break;
      case 'r': out += '\r'; break;
      case 't': out += '\t'; break;
      case 'u': {
        REQUIRE(i + 5 < lit.size());
        const std::string hex = lit.substr(i + 1, 4);
        REQUIRE(std::all_of(hex.begin(), hex.end(), [](char h) { return std::isxdigit(h); }));
        const long v = std::strtol(hex.c_str(), nullptr, 16);
        REQUIRE(v < 0x80);  // only what nlohmann escapes: control characters
        out += char(v);
        i += 4;
        break;
      }
      default: FAIL("bad escape \\" << e);
    }
  }
  return out;
}

}  // namespace

TEST_CASE("json_text: strings round-trip through an RFC 8259 decoder, non-UTF-8 bytes become U+FFFD",
          "[text]") {
  std::string ascii;
  for (int c = 1; c < 128; ++c) ascii += char(c);
  CHECK(json_decode(json_text(ascii)) == ascii);
  for (const std::string s : {std::string(), std::string("plain"), std::string("a\"b"),
                              std::string("back\\slash"), std::string("C:\\dir\\\"x\""),
                              std::string("line\nbreak\ttab\r"), std::string("\x01\x1f"),
                              std::string("gr\xc3\xbc\xc3\x9f" "e \xe6\x97\xa5 \xf0\x9f\x98\x80")}) {
    INFO(s);
    CHECK(json_decode(json_text(s)) == s);  // UTF-8 (the last one) is kept as it is
  }
  CHECK(json_text("abc") == "\"abc\"");
  // JSON text is UTF-8 (RFC 8259 §8.1): a byte that is not part of a UTF-8 sequence (a Latin-1
  // file name) is written as U+FFFD, so that the record stays readable by strict parsers.
  const std::string fffd = "\xef\xbf\xbd";
  CHECK(json_decode(json_text("caf\xe9.exr")) == "caf" + fffd + ".exr");
  CHECK(json_decode(json_text("\x80 \xff")) == fffd + " " + fffd);
  CHECK(json_decode(json_text("cut \xc3")) == "cut " + fffd);
}

TEST_CASE("json_value: numbers read back exactly, whole numbers without a fraction, non-finite "
          "values null", "[text]") {
  for (double v : {0.0, 1.0, -2.5, 0.1, 1.0 / 3.0, 6.02214076e23, 1e-300, 1e16, 1e17, -1e17,
                   std::numeric_limits<double>::max(), std::numeric_limits<double>::denorm_min()}) {
    INFO(v);
    const std::string t = json_text(json_value(v));
    char* end = nullptr;
    CHECK(std::strtod(t.c_str(), &end) == v);
    CHECK(*end == '\0');
  }
  // Whole numbers as printf's %.17g wrote them (the run records' earlier text).
  CHECK(json_text(json_value(0.0)) == "0");
  CHECK(json_text(json_value(2.0)) == "2");
  CHECK(json_text(json_value(-3.0)) == "-3");
  CHECK(json_text(json_value(1e16)) == "10000000000000000");
  CHECK(json_text(json_value(0.25)) == "0.25");
  CHECK(json_text(json_value(0.1)) == "0.1");  // the fewest digits that read back
  CHECK(json_text(json_value(std::numeric_limits<double>::infinity())) == "null");
  CHECK(json_text(json_value(-std::numeric_limits<double>::infinity())) == "null");
  CHECK(json_text(json_value(std::nan(""))) == "null");
}

TEST_CASE("json_record_text: one member per line, one line per list entry, a JSON parser reads "
          "it back", "[text]") {
  Json doc = Json::object();
  doc["name"] = "r \"1\"";
  doc["count"] = 3;
  doc["none"] = nullptr;
  doc["parameters"] = Json::object();
  doc["parameters"]["b"] = "2";
  doc["parameters"]["a"] = "1";  // kept in the order added
  doc["images"] = Json::array();
  doc["images"].push_back({{"path", "a.exr"}, {"passes", 4}, {"ok", true}});
  doc["images"].push_back({{"path", "b.exr"}, {"passes", 8}, {"ok", false}});
  doc["empty"] = Json::array();
  const std::string text = json_record_text(doc);
  CHECK(text ==
        "{\n"
        "  \"name\": \"r \\\"1\\\"\",\n"
        "  \"count\": 3,\n"
        "  \"none\": null,\n"
        "  \"parameters\": {\n"
        "    \"b\": \"2\",\n"
        "    \"a\": \"1\"\n"
        "  },\n"
        "  \"images\": [\n"
        "    {\"path\": \"a.exr\", \"passes\": 4, \"ok\": true},\n"
        "    {\"path\": \"b.exr\", \"passes\": 8, \"ok\": false}\n"
        "  ],\n"
        "  \"empty\": [\n"
        "  ]\n"
        "}\n");
  CHECK(Json::parse(text) == doc);
  CHECK_THROWS_AS(json_record_text(Json::array()), std::invalid_argument);
}

TEST_CASE("numbered_name: zero-padded to the total's digits, so the names sort in order",
          "[text]") {
  // Every key replaced, the rest kept.
  CHECK(numbered_name("a{n}b{n}.exr", "{n}", 7, 100) == "a007b007.exr");
  CHECK(numbered_name("x.exr", "{n}", 7, 100) == "x.exr");
  CHECK(numbered_name("{n}", "{n}", 12345, 99) == "12345");  // never cut
  for (int total : {9, 10, 64, 1000}) {
    INFO("total " << total);
    std::vector<std::string> names;
    for (int n = 1; n <= total; ++n) {
      names.push_back(numbered_name("snap_{spp}.exr", "{spp}", n, total));
      CHECK(names.back().size() == std::string("snap_.exr").size() + std::to_string(total).size());
      CHECK(std::stoi(names.back().substr(5)) == n);
    }
    CHECK(std::is_sorted(names.begin(), names.end()));
  }
}

TEST_CASE("parse_vec3: three finite numbers, anything else an InputError naming the option",
          "[options]") {
  const Vec3 v = parse_vec3("eye", "1,-2.5,3e2");
  CHECK(v.x == 1.f);
  CHECK(v.y == -2.5f);
  CHECK(v.z == 300.f);
  for (const char* bad : {"", "1,2", "1,2,3,4", "1,2,3,", "1,,3", "1,2,", ",1,2", "a,b,c", "1,2,3x",
                          "1,2,inf", "nan,0,0", "1 2 3"}) {
    INFO("'" << bad << "'");
    CHECK_THROWS_WITH(parse_vec3("look-at", bad), Catch::Contains("--look-at"));
    CHECK_THROWS_AS(parse_vec3("look-at", bad), InputError);
  }
}

TEST_CASE("option checks: positive, in (0, 1) or 1, one of a list, defaults read back", "[options]") {
  CHECK_NOTHROW(require_positive("photons", 1e-300));
  CHECK_NOTHROW(require_positive("photons", 5));
  for (double bad : {0.0, -0.0, -1.0, std::nan("")}) {
    INFO(bad);
    CHECK_THROWS_WITH(require_positive("photons", bad), Catch::Contains("--photons must be positive"));
  }
  CHECK_NOTHROW(require_in_unit_interval("alpha", 1.0));  // closed at 1
  CHECK_NOTHROW(require_in_unit_interval("alpha", 1e-9));
  for (double bad : {0.0, -0.5, std::nextafter(1.0, 2.0), 2.0, std::nan("")}) {
    INFO(bad);
    CHECK_THROWS_WITH(require_in_unit_interval("alpha", bad), Catch::Contains("--alpha must be in (0, 1]"));
  }
  CHECK_NOTHROW(require_choice("method", "grid", {"kd", "grid", "hash"}));
  CHECK_NOTHROW(require_choice("method", "hash", {"kd", "grid", "hash"}));
  CHECK_THROWS_WITH(require_choice("method", "gridx", {"kd", "grid", "hash"}),
                    Catch::Contains("--method must be one of kd|grid|hash") && Catch::Contains("'gridx'"));
  CHECK_THROWS_AS(require_choice("method", "", {"kd"}), InputError);
  // default_text: the shortest text that reads back to the value.
  for (float f : {0.7f, 0.1f, 3.f, 1e-3f, 123456.79f, -2.5f}) {
    INFO(f);
    const std::string t = default_text(f);
    CHECK(std::strtof(t.c_str(), nullptr) == f);
    CHECK(t.size() <= 12);
  }
  CHECK(default_text(0.5f) == "0.5");
  CHECK(default_text(3.f) == "3");
  CHECK(default_text(-42) == "-42");
}

TEST_CASE("provenance_json: each input's members under their own names", "[text][provenance]") {
  const std::string dir = "/tmp/pf-text-prov-" + std::to_string(getpid());
  const std::string a = dir + "-a.txt", b = dir + "-b.txt";
  std::ofstream(a) << "abc";
  std::ofstream(b) << "";
  Provenance p;
  p.tool = "trace-photons";
  p.seed = 42;
  p.wall_time_s = 0.5;
  p.command_line = "trace-photons --x 'y z'";
  p.param("photons", 1000);
  p.param("method", "grid");
  p.add_input("scene", a, "photonflow.scene", "id-a");
  p.add_input("hitpoints", b, "photonflow.hitpoints", "id-b");
  const std::string js = json_record_text(provenance_json(p));
  std::remove(a.c_str());
  std::remove(b.c_str());
  CHECK(js.find("\"tool\": \"trace-photons\"") != std::string::npos);
  CHECK(js.find("\"seed\": 42") != std::string::npos);
  CHECK(js.find("\"command_line\": " + json_text(p.command_line)) != std::string::npos);
  CHECK(js.find("\"wall_time_s\": 0.5") != std::string::npos);
  CHECK(js.find("\"photons\": \"1000\"") != std::string::npos);
  CHECK(js.find("\"method\": \"grid\"") != std::string::npos);
  CHECK(js.find("{\"role\": \"scene\", \"path\": " + json_text(a) +
                ", \"sha256\": \"ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad\", "
                "\"format\": \"photonflow.scene\", \"scene_id\": \"id-a\"}") != std::string::npos);
  CHECK(js.find("{\"role\": \"hitpoints\", \"path\": " + json_text(b) +
                ", \"sha256\": \"e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855\", "
                "\"format\": \"photonflow.hitpoints\", \"scene_id\": \"id-b\"}") != std::string::npos);
}
