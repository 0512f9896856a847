// Text outputs: see text_file.h.
#include "photonflow/foundations/text_file.h"

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <utility>

#include "photonflow/foundations/version.h"

#include "photonflow/foundations/error.h"
#include "photonflow/io/output_file.h"

namespace pf {

Json json_value(double v) {
  if (!std::isfinite(v)) return nullptr;
  if (std::trunc(v) == v && std::fabs(v) < 1e17 && !(v == 0.0 && std::signbit(v)))
    return static_cast<int64_t>(v);
  return v;
}

std::string json_text(const Json& value) {
  std::string out;
  const char* sep = "";
  if (value.is_object()) {
    out = "{";
    for (const auto& [key, member] : value.items()) {
      out += sep + json_text(key) + ": " + json_text(member);
      sep = ", ";
    }
    return out + "}";
  }
  if (value.is_array()) {
    out = "[";
    for (const Json& element : value) {
      out += sep + json_text(element);
      sep = ", ";
    }
    return out + "]";
  }
  return value.dump(-1, ' ', false, Json::error_handler_t::replace);
}

std::string json_record_text(const Json& doc) {
  if (!doc.is_object()) throw std::invalid_argument("json_record_text: a record is an object");
  std::string out = "{";
  const char* sep = "";
  for (const auto& [key, member] : doc.items()) {
    out += sep;
    out += "\n  " + json_text(key) + ": ";
    const char* inner = "";
    if (member.is_object()) {
      out += "{";
      for (const auto& [k, v] : member.items()) {
        out += inner;
        out += "\n    " + json_text(k) + ": " + json_text(v);
        inner = ",";
      }
      out += "\n  }";
    } else if (member.is_array()) {
      out += "[";
      for (const Json& v : member) {
        out += inner;
        out += "\n    " + json_text(v);
        inner = ",";
      }
      out += "\n  ]";
    } else {
      out += json_text(member);
    }
    sep = ",";
  }
  return out + "\n}\n";
}

Json provenance_json(const Provenance& prov) {
  Json doc = Json::object();
  doc["tool"] = prov.tool;
  doc["version"] = PHOTONFLOW_VERSION;
  doc["git_hash"] = PHOTONFLOW_GIT_HASH;
  doc["seed"] = prov.seed;
  doc["command_line"] = prov.command_line;
  doc["wall_time_s"] = json_value(prov.wall_time_s);
  Json parameters = Json::object();
  for (const auto& [name, value] : prov.parameters) parameters[name] = value;
  doc["parameters"] = std::move(parameters);
  Json inputs = Json::array();
  for (const auto& in : prov.inputs)
    inputs.push_back({{"role", in.role},
                      {"path", in.path},
                      {"sha256", in.sha256},
                      {"format", in.format},
                      {"scene_id", in.scene_id}});
  doc["inputs"] = std::move(inputs);
  return doc;
}

std::string numbered_name(const std::string& pattern, const std::string& key, int n, int total) {
  std::string num = std::to_string(n);
  const std::string t = std::to_string(total);
  if (num.size() < t.size()) num.insert(0, t.size() - num.size(), '0');
  std::string out = pattern;
  for (size_t at = out.find(key); at != std::string::npos; at = out.find(key, at + num.size()))
    out.replace(at, key.size(), num);
  return out;
}

void write_text_atomic(const std::string& path, const std::string& text) {
  write_file_atomic(path, text.data(), text.size());
}

}  // namespace pf
