// Value checks of the loaders: see validate.h.
#include "photonflow/io/validate.h"

#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace pf {

std::string value_text(double v, int digits) {
  if (std::isnan(v)) return "nan";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.*g", digits, v);
  return buf;
}

void Validator::fail(const std::string& problem) const { throw input_error(file_, problem, hint_); }

std::string Validator::element(const std::string& dataset, size_t i, const char* field) {
  std::string s = dataset + "[" + std::to_string(i) + "]";
  if (field) s += std::string(".") + field;
  return s;
}

std::string Name::str() const {
  if (literal_) return literal_;
  std::string s = dataset_ ? *dataset_ : std::string();
  if (indexed_) s += "[" + std::to_string(index_) + "]";
  if (field_) s += std::string(".") + field_;
  return s;
}

void Validator::fail_value(const Name& what, int k, double v, double lo, double hi,
                           bool range) const {
  const std::string name = what.str() + (k >= 0 ? "[" + std::to_string(k) + "]" : "");
  if (!std::isfinite(v) || !range) fail(name + " is not finite (" + value_text(v) + ")");
  fail(name + " = " + value_text(v) + " is outside [" + value_text(lo, 6) + ", " +
       value_text(hi, 6) + "]");
}

void Validator::int_in_range(const Name& what, int64_t v, int64_t lo, int64_t hi) const {
  if (v < lo || v > hi)
    fail(what.str() + " = " + std::to_string(v) + " is outside [" + std::to_string(lo) + ", " +
         std::to_string(hi) + "]");
}

void Validator::photons_emitted(const Name& what, uint64_t emitted, int64_t passes) const {
  const uint64_t n = uint64_t(passes < 0 ? 0 : passes), most = n * kMaxPhotonsPerPass;
  if (emitted > most || emitted < n)
    fail(what.str() + " = " + std::to_string(emitted) + " is not the count of " +
         std::to_string(passes) + " passes of 1 to " + std::to_string(kMaxPhotonsPerPass) +
         " photons each (at most " + std::to_string(most) + ")");
}

namespace {
thread_local int unchecked_writes = 0;
}  // namespace

UncheckedWritesForTests::UncheckedWritesForTests() { ++unchecked_writes; }
UncheckedWritesForTests::~UncheckedWritesForTests() { --unchecked_writes; }

void written_check(const std::function<void()>& check) {
  if (unchecked_writes > 0) return;
  try {
    check();
  } catch (const InputError& e) {
    throw std::logic_error(std::string("about to write what its readers refuse: ") + e.what());
  }
}

void Validator::unit(const Name& what, const float* v) const {
  finite(what, v, 3);
  const double len =
      std::sqrt(double(v[0]) * v[0] + double(v[1]) * v[1] + double(v[2]) * v[2]);
  if (!(std::fabs(len - 1.0) <= double(kUnitTolerance)))
    fail(what.str() + " is not a unit vector (length " + value_text(len) + ")");
}

void Validator::image_in_range(const std::string& dataset, const std::vector<float>& v, int width,
                               double lo, double hi) const {
  const size_t row = size_t(width > 0 ? width : 1) * 3;
  for (size_t i = 0; i < v.size(); ++i)
    if (!(double(v[i]) >= lo && double(v[i]) <= hi))
      fail_value(dataset + "[y " + std::to_string(i / row) + ", x " + std::to_string(i % row / 3) +
                     ", channel " + std::to_string(i % 3) + "]",
                 -1, v[i], lo, hi, true);
}

bool nearly_equal(double a, double b, double rel, double abs) {
  return std::fabs(a - b) <= rel * (std::fabs(a) + std::fabs(b)) + abs;
}

}  // namespace pf
