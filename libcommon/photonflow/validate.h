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
#include <string>
#include <vector>

#include "photonflow/error.h"

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
  // An integer in [lo, hi].
  void int_in_range(const Name& what, int64_t v, int64_t lo, int64_t hi) const;
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

// True when a and b agree within rel·(|a| + |b|) + abs (NaN never agrees).
bool nearly_equal(double a, double b, double rel, double abs = 0.0);

}  // namespace pf
