// Text outputs: see text_file.h.
#include "photonflow/text_file.h"

#include <cmath>
#include <cstdio>
#include <sstream>

#include "photonflow/version.h"

#include "photonflow/error.h"
#include "photonflow/output_file.h"

namespace pf {

std::string json_string(const std::string& text) {
  std::string out = "\"";
  for (unsigned char c : text) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += char(c);
    } else if (c < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\u%04x", c);
      out += buf;
    } else {
      out += char(c);
    }
  }
  return out + "\"";
}

std::string json_number(double v) {
  if (!std::isfinite(v)) return "null";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

std::string provenance_json_fields(const Provenance& prov) {
  std::ostringstream o;
  o << "  \"tool\": " << json_string(prov.tool)
    << ",\n  \"version\": " << json_string(PHOTONFLOW_VERSION)
    << ",\n  \"git_hash\": " << json_string(PHOTONFLOW_GIT_HASH)
    << ",\n  \"seed\": " << prov.seed
    << ",\n  \"command_line\": " << json_string(prov.command_line)
    << ",\n  \"wall_time_s\": " << json_number(prov.wall_time_s) << ",\n  \"parameters\": {";
  const char* sep = "";
  for (const auto& [k, v] : prov.parameters) {
    o << sep << "\n    " << json_string(k) << ": " << json_string(v);
    sep = ",";
  }
  o << "\n  },\n  \"inputs\": [";
  sep = "";
  for (const auto& in : prov.inputs) {
    o << sep << "\n    {\"role\": " << json_string(in.role) << ", \"path\": " << json_string(in.path)
      << ", \"sha256\": " << json_string(in.sha256) << ", \"format\": " << json_string(in.format)
      << ", \"scene_id\": " << json_string(in.scene_id) << "}";
    sep = ",";
  }
  o << "\n  ]";
  return o.str();
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
