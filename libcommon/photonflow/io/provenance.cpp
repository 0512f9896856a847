#include "photonflow/io/provenance.h"

#include <ctime>

#include "photonflow/foundations/hash.h"
#include "photonflow/foundations/version.h"

namespace pf {

void Provenance::add_input(const std::string& role, const std::string& path,
                           const std::string& format, const std::string& scene_id) {
  inputs.push_back({role, path, sha256_file(path), format, scene_id});
}

void write_provenance(h5::Writer& w, const Provenance& p) {
  w.group("/provenance/parameters");
  w.group("/provenance/inputs");
  w.attr("/provenance", "tool", p.tool);
  w.attr("/provenance", "version", std::string(PHOTONFLOW_VERSION));
  w.attr("/provenance", "git_hash", std::string(PHOTONFLOW_GIT_HASH));
  w.attr("/provenance", "seed", int64_t(p.seed));
  w.attr("/provenance", "wall_time_s", p.wall_time_s);
  w.attr("/provenance", "command_line", p.command_line);
  char buf[32];
  std::time_t now = std::time(nullptr);
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&now));
  w.attr("/provenance", "created_utc", std::string(buf));
  for (auto& [k, v] : p.parameters) w.attr("/provenance/parameters", k, v);
  for (auto& in : p.inputs) {
    std::string g = "/provenance/inputs/" + in.role;
    w.group(g);
    w.attr(g, "path", in.path);
    w.attr(g, "sha256", in.sha256);
    w.attr(g, "format", in.format);
    w.attr(g, "scene_id", in.scene_id);
  }
}

Provenance read_provenance(const h5::Reader& r) {
  Provenance p;
  if (!r.exists("/provenance"))
    throw input_error(r.path(), "has no provenance group", "remake it with this build");
  p.tool = r.attr_string("/provenance", "tool");
  p.version = r.attr_string("/provenance", "version");
  p.git_hash = r.attr_string("/provenance", "git_hash");
  p.seed = uint64_t(r.attr_int("/provenance", "seed"));
  p.wall_time_s = r.attr_double("/provenance", "wall_time_s");
  p.command_line = r.attr_string("/provenance", "command_line");
  p.created_utc = r.attr_string("/provenance", "created_utc");
  for (auto& k : r.attr_names("/provenance/parameters"))
    p.parameters[k] = r.attr_string("/provenance/parameters", k);
  for (auto& role : r.children("/provenance/inputs")) {
    std::string g = "/provenance/inputs/" + role;
    p.inputs.push_back({role, r.attr_string(g, "path"), r.attr_string(g, "sha256"),
                        r.attr_string(g, "format"), r.attr_string(g, "scene_id")});
  }
  return p;
}

std::string join_command_line(int argc, char** argv) {
  // POSIX shell quoting: words of only safe characters stay as they are; any other word is put in
  // single quotes (inside which nothing is special), each ' in it written as '\'' (close the
  // quotes, an escaped quote, reopen). Before, only blanks, " ' and $ led to quoting and a ' was
  // not escaped, so "it's", a;b, *, `…`, # or a newline did not read back as the same argument.
  static const char* safe =
      "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_-+=.,/:@%";
  std::string out;
  for (int i = 0; i < argc; ++i) {
    const std::string a = argv[i];
    if (i) out += ' ';
    if (!a.empty() && a.find_first_not_of(safe) == std::string::npos) {
      out += a;
      continue;
    }
    out += '\'';
    for (char c : a) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
    out += '\'';
  }
  return out;
}

}  // namespace pf
