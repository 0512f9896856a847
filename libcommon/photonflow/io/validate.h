// validate.h — the checks every loader runs on the values it reads (docs/FORMATS.md, "Values").
//
// The loaders (load_scene, load_hitpoints, load_photons, load_grids, load_clusters,
// load_photon_distribution) check the structure of their files (array lengths, indices); the
// helpers here check the VALUES: finite numbers within the ranges below, non-decreasing tables,
// unit vectors. A failed check throws pf::InputError with one line that names the file, the
// dataset or attribute, the first bad element and its value, e.g.
//   scene.h5: geometry/triangles[17].v1 is not finite (nan) (the file is damaged; rebake it ...)
// Every check is one pass over an array the loader holds anyway (no allocation).
//
// The ranges keep every later computation finite: a coordinate of 1e38 is finite, but the
// Havel–Herout plane distance d = −N·A (thesis eq. 4.3) is of order |v|³ and the scene's extent
// squared overflows float; a radius whose square is below float's smallest normal number makes
// the PPM update (eq. 3.16–3.18) divide 0 by 0.
#pragma once
#include <cstddef>
#include <cmath>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "photonflow/foundations/error.h"

namespace pf {

// Largest magnitude of a world coordinate in any file (vertices, light and camera positions,
// hitpoints, photons, grid corners, kd-tree boxes). Cubes stay below float's maximum.
constexpr float kMaxCoordinate = 1e12f;
// Largest radiance, intensity, image value, photon flux or accumulated flux τ, and largest
// accumulated photon count N: sums of many of them stay finite in float.
constexpr float kMaxValue = 1e30f;
// Smallest and largest gather radius (hitpoints' R and R0, grid default radius): R² and the PPM
// update's R'²/R² stay normal floats.
constexpr float kMinRadius = 1e-15f;
constexpr float kMaxRadius = kMaxCoordinate;
// Relative tolerance of a unit vector's length (shading normals, directions).
constexpr float kUnitTolerance = 1e-3f;
// Most photons one pass emits (--photons is a uint32). Every pass emits 1 … kMaxPhotonsPerPass,
// so a count of photons emitted is at most passes × kMaxPhotonsPerPass: with at most 2^31 − 1
// passes that stays below 2^63, and no sum of counts (a merge, a resumed run) can wrap an int64.
constexpr uint64_t kMaxPhotonsPerPass = 0xffffffffu;
// Largest end of a pass range (pass sums, pppm runs): passes [first, end) with end <= 2^31 − 1,
// so that the end itself is an int32.
constexpr int64_t kMaxPassEnd = 2147483647;

// The value as the messages print it: `digits` significant digits (9: a float's exact text),
// "nan", "inf", "-inf".
std::string value_text(double v, int digits = 9);

// The name of a checked value, made into text only when a check fails (the checks run on every
// element of large arrays): a whole name ("camera.eye", "attribute radius0") or element `index`
// of a dataset with an optional field ("geometry/triangles[17].v1"). It refers to the strings it
// is given: use it within the call it is made for.
class Name {
 public:
  Name(const std::string& whole) : dataset_(&whole) {}  // NOLINT: implicit on purpose
  Name(const char* whole) : literal_(whole) {}           // NOLINT
  Name(const std::string& dataset, size_t index, const char* field = nullptr)
      : dataset_(&dataset), field_(field), index_(index), indexed_(true) {}
  std::string str() const;

 private:
  const std::string* dataset_ = nullptr;
  const char* literal_ = nullptr;
  const char* field_ = nullptr;
  size_t index_ = 0;
  bool indexed_ = false;
};

// Checks with one file's name and the hint every message ends with.
class Validator {
 public:
  Validator(std::string file, std::string hint) : file_(std::move(file)), hint_(std::move(hint)) {}

  // Throws input_error(file, problem, hint).
  [[noreturn]] void fail(const std::string& problem) const;

  // Name of element i of a dataset, with an optional field: "geometry/triangles[17].v1".
  static std::string element(const std::string& dataset, size_t i, const char* field = nullptr);

  // Every one of the n values at v is finite: "<what> is not finite (<value>)".
  void finite(const Name& what, const float* v, int n = 1) const {
    for (int k = 0; k < n; ++k)
      if (!std::isfinite(v[k])) fail_value(what, n > 1 ? k : -1, v[k], 0, 0, false);
  }
  // Every value lies in [lo, hi] (NaN fails): "<what> is not finite (nan)" or
  // "<what> = <value> is outside [lo, hi]".
  void in_range(const Name& what, const float* v, int n, double lo, double hi) const {
    for (int k = 0; k < n; ++k)
      if (!(double(v[k]) >= lo && double(v[k]) <= hi))
        fail_value(what, n > 1 ? k : -1, v[k], lo, hi, true);
  }
  void in_range(const Name& what, double v, double lo, double hi) const {
    if (!(v >= lo && v <= hi)) fail_value(what, -1, v, lo, hi, true);
  }
  // A float64 of a file that the program keeps as a float: both v and float(v) lie in [lo, hi]
  // (NaN fails), so a value that narrowing turns into 0 or inf (1e-300, 1e300) is refused with the
  // file's name rather than failing later, nameless, where the float is used. Returns float(v).
  float to_float(const Name& what, double v, double lo, double hi) const {
    in_range(what, v, lo, hi);
    const float f = float(v);
    if (!(double(f) >= lo && double(f) <= hi))
      fail(what.str() + " = " + value_text(v) + " is " + value_text(double(f), 6) +
           " as a float, outside [" + value_text(lo, 6) + ", " + value_text(hi, 6) + "]");
    return f;
  }
  // An integer in [lo, hi].
  void int_in_range(const Name& what, int64_t v, int64_t lo, int64_t hi) const;
  // A count of photons emitted by `passes` passes (each emits 1 … kMaxPhotonsPerPass): in
  // [passes, passes × kMaxPhotonsPerPass], and 0 exactly when passes is 0.
  void photons_emitted(const Name& what, uint64_t emitted, int64_t passes) const;
  // A world position: finite, |each coordinate| <= kMaxCoordinate.
  void position(const Name& what, const float* v, int n = 3) const {
    in_range(what, v, n, -double(kMaxCoordinate), double(kMaxCoordinate));
  }
  // A unit vector (|length − 1| <= kUnitTolerance), finite.
  void unit(const Name& what, const float* v) const;

  // An image layer of height × width × 3 values, each in [lo, hi]: names the pixel and channel,
  // "image/direct[y 3, x 5, channel 1]".
  void image_in_range(const std::string& dataset, const std::vector<float>& v, int width,
                      double lo, double hi) const;
  // A table that must not decrease: "<dataset>[i] = a is below <dataset>[i-1] = b".
  template <class T>
  void non_decreasing(const std::string& dataset, const std::vector<T>& v) const {
    for (size_t i = 1; i < v.size(); ++i)
      if (!(v[i] >= v[i - 1]))
        fail(element(dataset, i) + " = " + value_text(double(v[i])) + " is below " +
             element(dataset, i - 1) + " = " + value_text(double(v[i - 1])));
  }

 private:
  // Throws the message of a value that failed finite() or in_range() (component k >= 0 of an
  // array field).
  [[noreturn]] void fail_value(const Name& what, int k, double v, double lo, double hi,
                               bool range) const;
  std::string file_, hint_;
};

// Every writer checks what it is about to write with the checks its readers apply (the readers'
// validate_* functions): a file a stage writes is one the next stage accepts. `check` throws
// InputError when the data would be refused; written_check turns that into an internal error
// (std::logic_error, exit 1, caught by the tests), since the data came from this program and
// not from an input: "internal error: about to write what its readers refuse: <file>: ...".
void written_check(const std::function<void()>& check);
// Within this scope (on this thread) written_check checks nothing: the one way to make a damaged
// file with a stage's own writer, for the tests of the readers' refusals. Nothing else uses it.
class UncheckedWritesForTests {
 public:
  UncheckedWritesForTests();
  ~UncheckedWritesForTests();
  UncheckedWritesForTests(const UncheckedWritesForTests&) = delete;
  UncheckedWritesForTests& operator=(const UncheckedWritesForTests&) = delete;
};

// True when a and b agree within rel·(|a| + |b|) + abs (NaN never agrees).
bool nearly_equal(double a, double b, double rel, double abs = 0.0);

}  // namespace pf
