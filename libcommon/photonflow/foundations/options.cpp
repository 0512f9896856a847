#include "photonflow/foundations/options.h"

#include <charconv>
#include <cmath>
#include <cstdlib>
#include <sstream>

namespace pf {

Vec3 parse_vec3(const std::string& option, const std::string& text) {
  float v[3];
  std::istringstream in(text);
  std::string part;
  int n = 0;
  while (std::getline(in, part, ',')) {
    char* end = nullptr;
    double d = std::strtod(part.c_str(), &end);
    if (n >= 3 || part.empty() || *end != '\0' || !std::isfinite(d))
      throw input_error("", "--" + option + " must be three finite numbers x,y,z, got '" + text + "'");
    v[n++] = float(d);
  }
  // getline drops an empty last field, so "1,2,3," would read as three numbers: refuse it.
  if (n != 3 || text.back() == ',')
    throw input_error("", "--" + option + " must be three finite numbers x,y,z, got '" + text + "'");
  return Vec3(v);
}

std::string default_text(float value) {
  char buf[32];
  auto r = std::to_chars(buf, buf + sizeof buf, value);  // shortest round-trip form
  return std::string(buf, r.ptr);
}

std::string default_text(int value) { return std::to_string(value); }

namespace {
// The value as the user wrote it: whole numbers without a fraction ("0", "-1"), others in the
// shortest form that reads back ("1e-300", "0.5"), "nan" and "inf" as such.
std::string option_value_text(double value) {
  if (std::isnan(value)) return "nan";
  if (std::isinf(value)) return value > 0 ? "inf" : "-inf";
  char buf[40];
  auto r = std::to_chars(buf, buf + sizeof buf, value);
  return std::string(buf, r.ptr);
}
}  // namespace

void require_positive(const std::string& option, double value) {
  if (!(value > 0.0))
    throw input_error("", "--" + option + " must be positive, got " + option_value_text(value));
}

void require_positive(const std::string& option, int64_t value) {
  if (!(value > 0))
    throw input_error("", "--" + option + " must be positive, got " + std::to_string(value));
}

void require_in_unit_interval(const std::string& option, double value) {
  if (!(value > 0.0 && value <= 1.0))
    throw input_error("", "--" + option + " must be in (0, 1], got " + option_value_text(value));
}

void require_choice(const std::string& option, const std::string& value,
                    std::initializer_list<const char*> choices) {
  std::string list;
  for (const char* c : choices) {
    if (value == c) return;
    list += list.empty() ? c : std::string("|") + c;
  }
  throw input_error("", "--" + option + " must be one of " + list + ", got '" + value + "'");
}

}  // namespace pf
