// text_file.h — small text outputs of the tools (JSON records of pathtrace and imgcompare): JSON
// literals and an atomic write (temporary name, then rename, like every other output).
#pragma once
#include <string>

namespace pf {

// A JSON string literal (RFC 8259): quotes, backslash and control characters escaped.
std::string json_string(const std::string& text);
// A JSON number with 17 significant digits (doubles round-trip); non-finite values become null.
std::string json_number(double v);
// Writes `text` to "<path>.tmp.<pid>" and renames it to `path`; InputError naming the file.
void write_text_atomic(const std::string& path, const std::string& text);

}  // namespace pf
