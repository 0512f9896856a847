// h5io.h — the HDF5 stage contract: atomic writers, format-checking readers, named compound types.
//
// Every intermediate file of photonflow (docs/FORMATS.md) has
//   /            attributes  format (string), format_version (int), scene_id (64 hex digits)
//   /provenance  group written by write_provenance() (provenance.h)
// and datasets whose element types are compounds with named fields (read as-is by h5dump and h5py).
// Writers write "<path>.tmp.<pid>" and rename it on commit(), so a killed stage never leaves a file
// that looks complete. Readers turn every HDF5 failure into one pf::InputError line.
#pragma once
#include <hdf5.h>

#include <cstdint>
#include <string>
#include <vector>

#include "photonflow/foundations/error.h"
#include "photonflow/io/output_file.h"

namespace pf::h5 {

// Owning handle for any hid_t; closes with H5Idec_ref.
class Handle {
 public:
  Handle() = default;
  explicit Handle(hid_t id) : id_(id) {}
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  Handle(Handle&& o) noexcept : id_(o.id_) { o.id_ = -1; }
  Handle& operator=(Handle&& o) noexcept;
  ~Handle();
  hid_t get() const { return id_; }
  bool valid() const { return id_ >= 0; }
  // Releases the id now; false when that failed (for a file: its last writes did not reach the
  // disk). The id is given up either way: HDF5 1.10 crashes when a file whose close failed is
  // closed again (h5io.cpp, "A full disk").
  bool close();

 private:
  hid_t id_ = -1;
};

// A compound type (memory layout = file layout: photonflow structs hold only 4-byte fields).
class Compound {
 public:
  explicit Compound(size_t size);
  // Adds field `name` at `offset`: `count` elements of `base` (count > 1 makes an array field).
  Compound& add(const char* name, size_t offset, hid_t base, int count = 1);
  Compound& f32(const char* name, size_t offset, int count = 1) {
    return add(name, offset, H5T_NATIVE_FLOAT, count);
  }
  Compound& i32(const char* name, size_t offset, int count = 1) {
    return add(name, offset, H5T_NATIVE_INT32, count);
  }
  Compound& u32(const char* name, size_t offset, int count = 1) {
    return add(name, offset, H5T_NATIVE_UINT32, count);
  }
  hid_t id() const { return type_.get(); }
  size_t size() const { return size_; }

 private:
  Handle type_;
  size_t size_;
};

// Element-type traits for plain numeric datasets.
template <class T> hid_t native_type();
template <> inline hid_t native_type<float>() { return H5T_NATIVE_FLOAT; }
template <> inline hid_t native_type<double>() { return H5T_NATIVE_DOUBLE; }
template <> inline hid_t native_type<int32_t>() { return H5T_NATIVE_INT32; }
template <> inline hid_t native_type<uint32_t>() { return H5T_NATIVE_UINT32; }
template <> inline hid_t native_type<int64_t>() { return H5T_NATIVE_INT64; }
template <> inline hid_t native_type<uint64_t>() { return H5T_NATIVE_UINT64; }
template <> inline hid_t native_type<uint8_t>() { return H5T_NATIVE_UINT8; }

// Base for Writer and Reader: attribute and group access on an open file.
class FileBase {
 public:
  const std::string& path() const { return path_; }
  hid_t id() const { return file_.get(); }
  bool exists(const std::string& obj) const;  // group or dataset at this path

 protected:
  std::string path_;
  Handle file_;
};

class Writer : public FileBase {
 public:
  // Opens "<final_path>.tmp.<pid>" and sets the root attributes format and format_version.
  // An output that cannot be created throws InputError naming final_path.
  Writer(const std::string& final_path, const std::string& format, int version);
  ~Writer();  // without commit(): closes and deletes the temporary file
  Writer(const Writer&) = delete;
  Writer& operator=(const Writer&) = delete;

  void group(const std::string& path);  // creates the group and its missing parents
  void attr(const std::string& obj, const std::string& name, const std::string& value);
  void attr(const std::string& obj, const std::string& name, const char* value) {
    attr(obj, name, std::string(value));
  }
  void attr(const std::string& obj, const std::string& name, int64_t value);
  void attr(const std::string& obj, const std::string& name, double value);
  void attr(const std::string& obj, const std::string& name, const std::vector<double>& value);

  // Compound dataset of n elements (1-D), or with an explicit shape (row-major).
  void write(const std::string& path, const Compound& type, const void* data, size_t n);
  template <class S>
  void write(const std::string& path, const Compound& type, const std::vector<S>& v) {
    write(path, type, v.data(), v.size());
  }
  // Numeric dataset with the given shape (empty shape = 1-D of v.size()).
  template <class T>
  void write(const std::string& path, const std::vector<T>& v, std::vector<size_t> shape = {}) {
    if (shape.empty()) shape = {v.size()};
    write_raw(path, native_type<T>(), v.data(), shape);
  }
  void write_strings(const std::string& path, const std::vector<std::string>& v);
  // Sets an attribute on a dataset already written: unit, description.
  void describe(const std::string& path, const std::string& unit, const std::string& description);

  // Flushes, closes and renames the temporary file to the final path.
  void commit();
  const std::string& final_path() const { return final_path_; }

 private:
  void write_raw(const std::string& path, hid_t type, const void* data,
                 const std::vector<size_t>& shape);
  std::string final_path_;
  TempOutput temp_;  // the file path_ names (its temporary name), removed unless committed
  bool committed_ = false;
};

class Reader : public FileBase {
 public:
  // Opens an existing file and checks its root attributes: format must equal `format`, and
  // format_version must be in [1, max_version]. Every failure is one InputError line.
  Reader(const std::string& path, const std::string& format, int max_version);
  int version() const { return version_; }
  std::string scene_id() const;  // root attribute scene_id ("" if absent)

  std::string attr_string(const std::string& obj, const std::string& name) const;
  int64_t attr_int(const std::string& obj, const std::string& name) const;
  double attr_double(const std::string& obj, const std::string& name) const;
  std::vector<double> attr_doubles(const std::string& obj, const std::string& name) const;
  bool has_attr(const std::string& obj, const std::string& name) const;
  std::vector<std::string> attr_names(const std::string& obj) const;
  std::vector<std::string> children(const std::string& group) const;

  size_t count(const std::string& path) const;  // number of elements of a dataset
  std::vector<size_t> shape(const std::string& path) const;
  // Reads a compound dataset; fields are matched by name (HDF5 converts), so a file whose
  // compound lacks a field of `type` is refused.
  void read(const std::string& path, const Compound& type, void* out, size_t n) const;
  // The dataset must be one-dimensional (a list of records).
  template <class S> std::vector<S> read(const std::string& path, const Compound& type) const {
    require_shape(path, {});
    std::vector<S> v(count(path));
    read(path, type, v.data(), v.size());
    return v;
  }
  // Reads a numeric dataset stored as exactly T (class, size and sign: a dataset a script retyped,
  // float32 for float64 or int64 for float64, is refused, never converted) of exactly `shape`
  // (rank and every dimension; an empty shape: one-dimensional, any length). A dataset of the
  // right element count but another shape (3×64×64 for 64×64×3) is refused.
  template <class T>
  std::vector<T> read(const std::string& path, const std::vector<size_t>& shape = {}) const {
    require_shape(path, shape);
    std::vector<T> v(count(path));
    read_raw(path, native_type<T>(), v.data());
    return v;
  }
  // InputError unless dataset `path` has exactly `shape` (empty: rank 1, any length).
  void require_shape(const std::string& path, const std::vector<size_t>& shape) const;
  std::vector<std::string> read_strings(const std::string& path) const;

  // Throws InputError unless this file and `other` were made from the same scene.
  void require_same_scene(const Reader& other) const;

 private:
  void read_raw(const std::string& path, hid_t type, void* out) const;
  // Refuses dataset `path` (open as `dataset`) when its checksum64 attribute, where it has one,
  // differs from the checksum of the n elements read as `type` into `data`.
  void verify(const std::string& path, hid_t dataset, hid_t type, const void* data, size_t n) const;
  Handle open_dataset(const std::string& path) const;
  int version_ = 0;
};

// Silences HDF5's own error printing (we report errors ourselves). Idempotent.
void quiet_hdf5();

// Every element of an open dataset in its own file type, unconverted (the bytes checksum64 covers,
// h5io.cpp); false when HDF5 cannot read them.
bool read_stored_bytes(hid_t dataset, std::vector<unsigned char>& out);

}  // namespace pf::h5
