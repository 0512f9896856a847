// text_file.h — small text outputs of the tools (the JSON records of render, pathtrace and
// imgcompare, built as nlohmann::ordered_json documents) and an atomic write (temporary name, then
// rename, like every other output).
#pragma once
#include <nlohmann/json_fwd.hpp>

#include <string>

#include "photonflow/io/provenance.h"

namespace pf {

// A JSON document whose object members keep the order they were added in.
using Json = nlohmann::ordered_json;

// A double as a JSON value: null when it is not finite (JSON has no NaN or infinity); an integer
// when it is a whole number of magnitude below 1e17 (written "2", not "2.0": the digits printf's
// %.17g gave before nlohmann wrote the records); else the double, which nlohmann writes with the
// fewest digits that read back to the same double.
Json json_value(double v);

// One JSON value on one line, by nlohmann's serializer: strings escaped (RFC 8259 §7), bytes that
// are not UTF-8 replaced by U+FFFD (JSON text is UTF-8, §8.1); objects and arrays with ", " and
// ": " between their members, e.g. {"path": "a.exr", "passes": 4}.
std::string json_text(const Json& value);

// An object as the text of a record: "{", each member on its own line indented by two spaces,
// the members of an object or array member each on its own line indented by four (in json_text's
// one-line form), "}" and a newline. One line per image or input, so records read and grep well.
std::string json_record_text(const Json& doc);

// The provenance of a run as a JSON object: "tool", "version", "git_hash", "seed",
// "command_line", "wall_time_s", "parameters" {name: value, ...}, "inputs" [{"role", "path",
// "sha256", "format", "scene_id"}, ...] — the JSON twin of the HDF5 provenance group. Records add
// their own members ("images") after these.
Json provenance_json(const Provenance& prov);

// `pattern` with every `key` (e.g. "{pass}") replaced by `n`, zero-padded to the digits of
// `total`, so that numbered snapshot names sort in order.
std::string numbered_name(const std::string& pattern, const std::string& key, int n, int total);
// Writes `text` to "<path>.tmp.<pid>" and renames it to `path`; InputError naming the file.
void write_text_atomic(const std::string& path, const std::string& text);

}  // namespace pf
