// options.h — parsing and checking of stage options shared by the tools.
#pragma once
#include <cstdint>
#include <string>

#include "photonflow/foundations/error.h"
#include "photonflow/foundations/vec.h"

namespace pf {

// "x,y,z" → Vec3; throws InputError naming the option on anything else.
Vec3 parse_vec3(const std::string& option, const std::string& text);

// The shortest text that reads back to `value` ("3", "0.5"), for cxxopts default_value() of an
// option whose default is a library struct's member, so --help and the tool cannot drift from it.
std::string default_text(float value);
std::string default_text(int value);

// Range checks with one-line InputErrors naming the option.
void require_positive(const std::string& option, double value);
// Whole-number options: the refusal echoes the integer ("got 0", not "got 0.000000").
void require_positive(const std::string& option, int64_t value);
inline void require_positive(const std::string& option, int value) {
  require_positive(option, int64_t(value));
}
void require_in_unit_interval(const std::string& option, double value);  // (0, 1]
void require_choice(const std::string& option, const std::string& value,
                    std::initializer_list<const char*> choices);

}  // namespace pf
