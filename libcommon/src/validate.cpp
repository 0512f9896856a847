// Value checks of the loaders: see validate.h.
#include "photonflow/validate.h"

#include <cmath>
#include <cstdio>

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

void Validator::finite(const std::string& what, const float* v, int n) const {
  for (int k = 0; k < n; ++k)
    if (!std::isfinite(v[k]))
      fail(what + (n > 1 ? "[" + std::to_string(k) + "]" : "") + " is not finite (" +
           value_text(v[k]) + ")");
}

void Validator::in_range(const std::string& what, const float* v, int n, double lo,
                         double hi) const {
  for (int k = 0; k < n; ++k) {
    const std::string name = what + (n > 1 ? "[" + std::to_string(k) + "]" : "");
    in_range(name, double(v[k]), lo, hi);
  }
}

void Validator::in_range(const std::string& what, double v, double lo, double hi) const {
  if (!std::isfinite(v)) fail(what + " is not finite (" + value_text(v) + ")");
  if (!(v >= lo && v <= hi))
    fail(what + " = " + value_text(v) + " is outside [" + value_text(lo, 6) + ", " +
         value_text(hi, 6) + "]");
}

void Validator::int_in_range(const std::string& what, int64_t v, int64_t lo, int64_t hi) const {
  if (v < lo || v > hi)
    fail(what + " = " + std::to_string(v) + " is outside [" + std::to_string(lo) + ", " +
         std::to_string(hi) + "]");
}

void Validator::position(const std::string& what, const float* v, int n) const {
  in_range(what, v, n, -double(kMaxCoordinate), double(kMaxCoordinate));
}

void Validator::unit(const std::string& what, const float* v) const {
  finite(what, v, 3);
  const double len =
      std::sqrt(double(v[0]) * v[0] + double(v[1]) * v[1] + double(v[2]) * v[2]);
  if (!(std::fabs(len - 1.0) <= double(kUnitTolerance)))
    fail(what + " is not a unit vector (length " + value_text(len) + ")");
}

void Validator::array_in_range(const std::string& dataset, const std::vector<float>& v, double lo,
                               double hi) const {
  for (size_t i = 0; i < v.size(); ++i)
    if (!(double(v[i]) >= lo && double(v[i]) <= hi)) in_range(element(dataset, i), v[i], lo, hi);
}

void Validator::image_in_range(const std::string& dataset, const std::vector<float>& v, int width,
                               double lo, double hi) const {
  const size_t row = size_t(width > 0 ? width : 1) * 3;
  for (size_t i = 0; i < v.size(); ++i)
    if (!(double(v[i]) >= lo && double(v[i]) <= hi))
      in_range(dataset + "[y " + std::to_string(i / row) + ", x " + std::to_string(i % row / 3) +
                   ", channel " + std::to_string(i % 3) + "]",
               v[i], lo, hi);
}

bool nearly_equal(double a, double b, double rel, double abs) {
  return std::fabs(a - b) <= rel * (std::fabs(a) + std::fabs(b)) + abs;
}

}  // namespace pf
