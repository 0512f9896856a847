// text_file.h — small text outputs of the tools (JSON records of pathtrace and imgcompare): JSON
// literals and an atomic write (temporary name, then rename, like every other output).
#pragma once
#include <string>

#include "photonflow/provenance.h"

namespace pf {

// A JSON string literal (RFC 8259): quotes, backslash and control characters escaped.
std::string json_string(const std::string& text);
// A JSON number with 17 significant digits (doubles round-trip); non-finite values become null.
std::string json_number(double v);
// The provenance of a run as JSON object members (no braces), two-space indented: "tool",
// "version", "git_hash", "seed", "command_line", "wall_time_s", "parameters" {…}, "inputs" […]
// (role, path, sha256, format, scene_id) — the JSON twin of the HDF5 provenance group.
std::string provenance_json_fields(const Provenance& prov);
// `pattern` with every `key` (e.g. "{pass}") replaced by `n`, zero-padded to the digits of
// `total`, so that numbered snapshot names sort in order.
std::string numbered_name(const std::string& pattern, const std::string& key, int n, int total);
// Writes `text` to "<path>.tmp.<pid>" and renames it to `path`; InputError naming the file.
void write_text_atomic(const std::string& path, const std::string& text);

}  // namespace pf
