// HDF5 stage contract: see h5io.h.
#include "photonflow/io/h5io.h"

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstring>

#include "photonflow/foundations/hash.h"
#include "photonflow/io/output_file.h"

namespace pf::h5 {

// A full disk. When a write fails (ENOSPC, or EFBIG under `ulimit -f`), the file's close fails
// too, and HDF5 1.10 keeps the file in its table of open ids: its exit handler (H5_term_library)
// then closes it again and crashes in H5F__close_cb (SIGSEGV, after the tool had printed its one
// line). So HDF5 gets no exit handler; it must be told before its first call, hence at static
// initialisation. Nothing is lost: every file and object is closed by its Handle, and a Writer
// that was not committed deletes its file. A failed close gives its id up (Handle::close).
namespace {
[[maybe_unused]] const bool kNoHdf5ExitHandler = H5dont_atexit() >= 0;
}  // namespace

void quiet_hdf5() {
  static bool done = false;
  if (!done) {
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
    done = true;
  }
}

Handle& Handle::operator=(Handle&& o) noexcept {
  if (this != &o) {
    if (id_ >= 0) H5Idec_ref(id_);
    id_ = o.id_;
    o.id_ = -1;
  }
  return *this;
}

Handle::~Handle() {
  if (id_ >= 0) H5Idec_ref(id_);
}

bool Handle::close() {
  const bool ok = id_ < 0 || H5Idec_ref(id_) >= 0;
  id_ = -1;
  return ok;
}

Compound::Compound(size_t size) : type_(H5Tcreate(H5T_COMPOUND, size)), size_(size) {}

Compound& Compound::add(const char* name, size_t offset, hid_t base, int count) {
  if (count == 1) {
    H5Tinsert(type_.get(), name, offset, base);
  } else {
    hsize_t dims[1] = {hsize_t(count)};
    Handle arr(H5Tarray_create2(base, 1, dims));
    H5Tinsert(type_.get(), name, offset, arr.get());
  }
  return *this;
}

bool FileBase::exists(const std::string& obj) const {
  if (obj == "/") return true;
  // Check each prefix: H5Lexists fails on a path whose parent is missing.
  size_t pos = 0;
  while (true) {
    pos = obj.find('/', pos + 1);
    std::string prefix = obj.substr(0, pos);
    if (H5Lexists(file_.get(), prefix.c_str(), H5P_DEFAULT) <= 0) return false;
    if (pos == std::string::npos) return true;
  }
}

// ---- Writer ----------------------------------------------------------------------------------

Writer::Writer(const std::string& final_path, const std::string& format, int version)
    : final_path_(final_path), temp_(final_path) {
  quiet_hdf5();
  path_ = temp_.path();
  // The HDF5 1.8 file format, not the earliest: its superblock and object headers carry checksums,
  // which HDF5 verifies on open, so a damaged header or attribute is refused there. With the
  // earliest format, a damaged attribute message crashed HDF5 1.10 inside H5Aiterate2 (fuzzing,
  // docs/FORMATS.md). Readable by HDF5 1.8 and later (h5py, h5dump).
  Handle fapl(H5Pcreate(H5P_FILE_ACCESS));
  H5Pset_libver_bounds(fapl.get(), H5F_LIBVER_V18, H5F_LIBVER_V18);
  file_ = Handle(H5Fcreate(path_.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, fapl.get()));
  if (!file_.valid())
    throw input_error(final_path, "cannot create output file",
                      "check that the directory exists and is writable");
  attr("/", "format", format);
  attr("/", "format_version", int64_t(version));
}

Writer::~Writer() {
  // May fail after a failed write; temp_ removes the file all the same.
  if (!committed_) file_.close();
}

void Writer::group(const std::string& path) {
  if (exists(path)) return;
  Handle lcpl(H5Pcreate(H5P_LINK_CREATE));
  H5Pset_create_intermediate_group(lcpl.get(), 1);
  Handle g(H5Gcreate2(file_.get(), path.c_str(), lcpl.get(), H5P_DEFAULT, H5P_DEFAULT));
  if (!g.valid()) throw input_error(final_path_, "cannot create group " + path);
}

namespace {
Handle open_object(hid_t file, const std::string& obj) {
  return Handle(H5Oopen(file, obj.c_str(), H5P_DEFAULT));
}
void write_attr(hid_t file, const std::string& obj, const std::string& name, hid_t type,
                const void* data, hsize_t n, bool scalar, const std::string& path) {
  Handle o = open_object(file, obj);
  if (!o.valid()) throw input_error(path, "cannot open " + obj + " to set attribute " + name);
  if (H5Aexists(o.get(), name.c_str()) > 0) H5Adelete(o.get(), name.c_str());
  Handle space(scalar ? H5Screate(H5S_SCALAR) : H5Screate_simple(1, &n, nullptr));
  Handle a(H5Acreate2(o.get(), name.c_str(), type, space.get(), H5P_DEFAULT, H5P_DEFAULT));
  if (!a.valid() || H5Awrite(a.get(), type, data) < 0)
    throw input_error(path, "cannot write attribute " + obj + "@" + name);
}
Handle string_type(size_t len) {
  Handle t(H5Tcopy(H5T_C_S1));
  H5Tset_size(t.get(), len > 0 ? len : 1);
  H5Tset_strpad(t.get(), H5T_STR_NULLTERM);
  H5Tset_cset(t.get(), H5T_CSET_UTF8);
  return t;
}
}  // namespace

void Writer::attr(const std::string& obj, const std::string& name, const std::string& value) {
  Handle t = string_type(value.size() + 1);
  write_attr(file_.get(), obj, name, t.get(), value.c_str(), 1, true, final_path_);
}
void Writer::attr(const std::string& obj, const std::string& name, int64_t value) {
  write_attr(file_.get(), obj, name, H5T_NATIVE_INT64, &value, 1, true, final_path_);
}
void Writer::attr(const std::string& obj, const std::string& name, double value) {
  write_attr(file_.get(), obj, name, H5T_NATIVE_DOUBLE, &value, 1, true, final_path_);
}
void Writer::attr(const std::string& obj, const std::string& name, const std::vector<double>& v) {
  write_attr(file_.get(), obj, name, H5T_NATIVE_DOUBLE, v.data(), v.size(), false, final_path_);
}

void Writer::write_raw(const std::string& path, hid_t type, const void* data,
                       const std::vector<size_t>& shape) {
  auto slash = path.rfind('/');
  if (slash != std::string::npos && slash > 0) group(path.substr(0, slash));
  std::vector<hsize_t> dims(shape.begin(), shape.end());
  hsize_t total = 1;
  for (auto d : dims) total *= d;
  Handle space(H5Screate_simple(int(dims.size()), dims.data(), nullptr));
  Handle dcpl(H5Pcreate(H5P_DATASET_CREATE));
  // Large 1-D datasets are chunked (64 Ki elements a chunk) so readers such as h5py can read part
  // of them; small ones stay contiguous.
  if (total * H5Tget_size(type) > (1u << 20) && dims.size() == 1) {
    hsize_t chunk = std::min<hsize_t>(dims[0], 1u << 16);
    H5Pset_chunk(dcpl.get(), 1, &chunk);
  }
  Handle d(H5Dcreate2(file_.get(), path.c_str(), type, space.get(), H5P_DEFAULT, dcpl.get(),
                      H5P_DEFAULT));
  if (!d.valid()) throw input_error(final_path_, "cannot create dataset " + path);
  if (total > 0 && H5Dwrite(d.get(), type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0)
    throw input_error(final_path_, "cannot write dataset " + path, "is the disk full?");
  // The checksum of the bytes as written (file type = this memory type), which every read
  // verifies (Reader::verify): data damaged in the file, or a damaged chunk index that makes HDF5
  // return fill values instead of the data, is refused instead of read. The attribute itself sits
  // in the dataset's object header, which the 1.8 format checksums.
  if (H5Tdetect_class(type, H5T_VLEN) <= 0 && H5Tis_variable_str(type) <= 0)
    attr(path, "checksum64", int64_t(checksum64(data, size_t(total) * H5Tget_size(type))));
}

void Writer::write(const std::string& path, const Compound& type, const void* data, size_t n) {
  write_raw(path, type.id(), data, {n});
}

// Fixed-length strings (the longest plus its NUL), stored inside the dataset: variable-length
// strings live in HDF5's global heap, whose reader (H5HG_read, HDF5 1.10) copies past its buffer
// when a damaged file gives a wrong length; a fuzzed scene.h5 crashed trace-hitpoints there.
void Writer::write_strings(const std::string& path, const std::vector<std::string>& v) {
  size_t width = 1;
  for (const auto& s : v) width = std::max(width, s.size() + 1);
  std::vector<char> packed(v.size() * width, '\0');
  for (size_t i = 0; i < v.size(); ++i) std::memcpy(&packed[i * width], v[i].data(), v[i].size());
  Handle t = string_type(width);
  write_raw(path, t.get(), packed.data(), {v.size()});
}

void Writer::describe(const std::string& path, const std::string& unit,
                      const std::string& description) {
  if (!unit.empty()) attr(path, "unit", unit);
  if (!description.empty()) attr(path, "description", description);
}

void Writer::commit() {
  if (H5Fflush(file_.get(), H5F_SCOPE_GLOBAL) < 0)
    throw input_error(final_path_, "cannot flush output", "is the disk full?");
  // The close writes too (the superblock's end of file, the file truncated to it): a file whose
  // close failed is not whole, and the destructor removes it.
  if (!file_.close()) throw input_error(final_path_, "cannot close output", "is the disk full?");
  committed_ = true;
  temp_.commit();  // removes the temporary file if it fails
}

// ---- Reader ----------------------------------------------------------------------------------

Reader::Reader(const std::string& path, const std::string& format, int max_version) {
  quiet_hdf5();
  path_ = path;
  require_regular_input(path);  // before H5Fis_hdf5, which would wait for ever on a FIFO
  if (access(path.c_str(), R_OK) != 0)
    throw input_error(path, "cannot read file", "check the path; run the stage that makes it");
  if (H5Fis_hdf5(path.c_str()) <= 0)
    throw input_error(path, "not a readable HDF5 file (truncated or foreign)",
                      "remake it with the stage that writes " + format);
  file_ = Handle(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT));
  if (!file_.valid())
    throw input_error(path, "cannot open HDF5 file (truncated or damaged)",
                      "remake it with the stage that writes " + format);
  if (!has_attr("/", "format"))
    throw input_error(path, "not a photonflow file (no format attribute), expected " + format);
  std::string f = attr_string("/", "format");
  if (f != format)
    throw input_error(path, "is a " + f + " file, expected " + format,
                      "pass the right file to this option");
  version_ = int(attr_int("/", "format_version"));
  if (version_ < 1 || version_ > max_version)
    throw input_error(path, format + " version " + std::to_string(version_) +
                                " is not supported (this build reads 1.." +
                                std::to_string(max_version) + ")",
                      "remake the file with this build");
}

std::string Reader::scene_id() const {
  return has_attr("/", "scene_id") ? attr_string("/", "scene_id") : std::string();
}

bool Reader::has_attr(const std::string& obj, const std::string& name) const {
  if (!exists(obj)) return false;
  return H5Aexists_by_name(file_.get(), obj.c_str(), name.c_str(), H5P_DEFAULT) > 0;
}

namespace {
Handle open_attr(const FileBase& f, const std::string& obj, const std::string& name) {
  Handle a(H5Aopen_by_name(f.id(), obj.c_str(), name.c_str(), H5P_DEFAULT, H5P_DEFAULT));
  if (!a.valid())
    throw input_error(f.path(), "missing attribute " + obj + "@" + name,
                      "the file is damaged or from another tool");
  return a;
}

// A single-valued attribute: H5Aread writes every element of the attribute's dataspace, and the
// readers below give it room for one.
Handle open_scalar_attr(const FileBase& f, const std::string& obj, const std::string& name) {
  Handle a = open_attr(f, obj, name);
  Handle s(H5Aget_space(a.get()));
  if (H5Sget_simple_extent_npoints(s.get()) != 1)
    throw input_error(f.path(), "attribute " + obj + "@" + name + " is not a single value",
                      "the file is damaged or from another tool");
  return a;
}
}  // namespace

std::string Reader::attr_string(const std::string& obj, const std::string& name) const {
  Handle a = open_scalar_attr(*this, obj, name);
  Handle t(H5Aget_type(a.get()));
  if (H5Tget_class(t.get()) != H5T_STRING)
    throw input_error(path_, "attribute " + obj + "@" + name + " is not a string");
  if (H5Tis_variable_str(t.get()) > 0) {
    char* s = nullptr;
    Handle mt(H5Tcopy(H5T_C_S1));
    H5Tset_size(mt.get(), H5T_VARIABLE);
    H5Tset_cset(mt.get(), H5Tget_cset(t.get()));
    if (H5Aread(a.get(), mt.get(), &s) < 0 || !s)
      throw input_error(path_, "cannot read attribute " + obj + "@" + name);
    std::string out(s);
    H5free_memory(s);
    return out;
  }
  size_t n = H5Tget_size(t.get());
  std::string buf(n, '\0');
  if (H5Aread(a.get(), t.get(), buf.data()) < 0)
    throw input_error(path_, "cannot read attribute " + obj + "@" + name);
  buf.resize(std::strlen(buf.c_str()));
  return buf;
}

int64_t Reader::attr_int(const std::string& obj, const std::string& name) const {
  Handle a = open_scalar_attr(*this, obj, name);
  int64_t v = 0;
  if (H5Aread(a.get(), H5T_NATIVE_INT64, &v) < 0)
    throw input_error(path_, "attribute " + obj + "@" + name + " is not an integer");
  return v;
}

double Reader::attr_double(const std::string& obj, const std::string& name) const {
  Handle a = open_scalar_attr(*this, obj, name);
  double v = 0;
  if (H5Aread(a.get(), H5T_NATIVE_DOUBLE, &v) < 0)
    throw input_error(path_, "attribute " + obj + "@" + name + " is not a number");
  return v;
}

std::vector<double> Reader::attr_doubles(const std::string& obj, const std::string& name) const {
  Handle a = open_attr(*this, obj, name);
  Handle s(H5Aget_space(a.get()));
  hssize_t n = H5Sget_simple_extent_npoints(s.get());
  std::vector<double> v(n > 0 ? size_t(n) : 0);
  if (!v.empty() && H5Aread(a.get(), H5T_NATIVE_DOUBLE, v.data()) < 0)
    throw input_error(path_, "attribute " + obj + "@" + name + " is not numeric");
  return v;
}

namespace {
herr_t collect_attr(hid_t, const char* name, const H5A_info_t*, void* op) {
  static_cast<std::vector<std::string>*>(op)->push_back(name);
  return 0;
}
herr_t collect_link(hid_t, const char* name, const H5L_info_t*, void* op) {
  static_cast<std::vector<std::string>*>(op)->push_back(name);
  return 0;
}
}  // namespace

std::vector<std::string> Reader::attr_names(const std::string& obj) const {
  std::vector<std::string> names;
  Handle o = open_object(file_.get(), obj);
  if (!o.valid()) return names;
  hsize_t idx = 0;
  H5Aiterate2(o.get(), H5_INDEX_NAME, H5_ITER_INC, &idx, collect_attr, &names);
  return names;
}

std::vector<std::string> Reader::children(const std::string& group) const {
  std::vector<std::string> names;
  if (!exists(group)) return names;
  Handle g(H5Gopen2(file_.get(), group.c_str(), H5P_DEFAULT));
  if (!g.valid()) return names;
  hsize_t idx = 0;
  H5Literate(g.get(), H5_INDEX_NAME, H5_ITER_INC, &idx, collect_link, &names);
  return names;
}

Handle Reader::open_dataset(const std::string& path) const {
  if (!exists(path))
    throw input_error(path_, "missing dataset " + path, "the file is incomplete or of another kind");
  Handle d(H5Dopen2(file_.get(), path.c_str(), H5P_DEFAULT));
  if (!d.valid()) throw input_error(path_, "cannot open dataset " + path);
  return d;
}

std::vector<size_t> Reader::shape(const std::string& path) const {
  Handle d = open_dataset(path);
  Handle s(H5Dget_space(d.get()));
  int nd = H5Sget_simple_extent_ndims(s.get());
  if (nd < 0) throw input_error(path_, "dataset " + path + " has no readable shape (damaged)");
  std::vector<hsize_t> dims(size_t(nd), 0);
  if (nd > 0 && H5Sget_simple_extent_dims(s.get(), dims.data(), nullptr) < 0)
    throw input_error(path_, "dataset " + path + " has no readable shape (damaged)");
  // The shape sizes the readers' buffers: it must fit the bytes the file stores for the dataset,
  // or a damaged shape (a flipped bit in a dimension) would ask for terabytes. Without filters the
  // storage holds every element (chunked: whole chunks, so at least); a filter such as deflate
  // (which h5py users may add) compresses at most about 1032:1 (RFC 1951's longest match).
  Handle ft(H5Dget_type(d.get()));
  const size_t elem = H5Tget_size(ft.get());
  long double bytes = elem;
  for (hsize_t n : dims) bytes *= n;
  if (bytes > 0) {
    Handle dcpl(H5Dget_create_plist(d.get()));
    const int filters = dcpl.valid() ? H5Pget_nfilters(dcpl.get()) : 0;
    const long double stored = (long double)H5Dget_storage_size(d.get());
    if (elem == 0 || bytes > stored * (filters > 0 ? 1100.0L : 1.0L))
      throw input_error(path_, "dataset " + path + " claims more elements than the file stores",
                        "the file is damaged or truncated: remake it");
  }
  return std::vector<size_t>(dims.begin(), dims.end());
}

size_t Reader::count(const std::string& path) const {
  size_t n = 1;
  for (auto d : shape(path)) n *= d;
  return n;
}

bool read_stored_bytes(hid_t dataset, std::vector<unsigned char>& out) {
  Handle ft(H5Dget_type(dataset));
  Handle space(H5Dget_space(dataset));
  const hssize_t n = H5Sget_simple_extent_npoints(space.get());
  if (!ft.valid() || n < 0) return false;
  out.assign(size_t(n) * H5Tget_size(ft.get()), 0);
  return n == 0 || H5Dread(dataset, ft.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data()) >= 0;
}

void Reader::verify(const std::string& path, hid_t dataset, hid_t type, const void* data,
                    size_t n) const {
  if (H5Aexists(dataset, "checksum64") <= 0) return;  // files of builds before the checksum
  const int64_t want = attr_int(path, "checksum64");
  Handle ft(H5Dget_type(dataset));
  uint64_t have = 0;
  if (H5Tequal(ft.get(), type) > 0) {
    have = checksum64(data, n * H5Tget_size(type));
  } else {  // read as another type (a subset of fields, a conversion): the file's bytes again
    std::vector<unsigned char> raw;
    if (!read_stored_bytes(dataset, raw))
      throw input_error(path_, "cannot read dataset " + path + " (truncated or damaged)");
    have = checksum64(raw.data(), raw.size());
  }
  if (have != uint64_t(want))
    throw input_error(path_, "dataset " + path + " is damaged (its checksum does not match)",
                      "remake the file with the stage that wrote it");
}

void Reader::read(const std::string& path, const Compound& type, void* out, size_t n) const {
  Handle d = open_dataset(path);
  if (count(path) != n) throw input_error(path_, "dataset " + path + " has an unexpected size");
  // Every field the caller asks for must exist in the file's compound.
  Handle ft(H5Dget_type(d.get()));
  if (H5Tget_class(ft.get()) != H5T_COMPOUND)
    throw input_error(path_, "dataset " + path + " is not a compound of named fields");
  // HDF5 converts field by field at the offsets the file's type declares: each of its fields must
  // lie inside the record, or the conversion reads past its buffer (a damaged type crashed it).
  const size_t record = H5Tget_size(ft.get());
  const int fm = H5Tget_nmembers(ft.get());
  if (record == 0 || fm <= 0)
    throw input_error(path_, "dataset " + path + " has a damaged compound type");
  for (int i = 0; i < fm; ++i) {
    Handle mt(H5Tget_member_type(ft.get(), unsigned(i)));
    const size_t size = mt.valid() ? H5Tget_size(mt.get()) : 0;
    if (size == 0 || H5Tget_member_offset(ft.get(), unsigned(i)) + size > record)
      throw input_error(path_, "dataset " + path + " has a damaged compound type",
                        "remake the file");
  }
  // Every field the caller asks for must exist in the file's compound, of the same class (HDF5
  // converts sizes, e.g. a float64 written by h5py into float32, but not integers into arrays).
  int nm = H5Tget_nmembers(type.id());
  for (int i = 0; i < nm; ++i) {
    char* name = H5Tget_member_name(type.id(), unsigned(i));
    const int at = H5Tget_member_index(ft.get(), name);
    std::string field(name);
    H5free_memory(name);
    if (at < 0)
      throw input_error(path_, "dataset " + path + " lacks field '" + field + "'",
                        "remake the file with this build");
    Handle want(H5Tget_member_type(type.id(), unsigned(i)));
    Handle have(H5Tget_member_type(ft.get(), unsigned(at)));
    if (H5Tget_class(want.get()) != H5Tget_class(have.get()))
      throw input_error(path_, "dataset " + path + " field '" + field + "' has another type",
                        "remake the file with this build");
  }
  if (n > 0 && H5Dread(d.get(), type.id(), H5S_ALL, H5S_ALL, H5P_DEFAULT, out) < 0)
    throw input_error(path_, "cannot read dataset " + path + " (truncated or damaged)");
  verify(path, d.get(), type.id(), out, n);
}

namespace {
// "float32", "int64", "uint8", ... of a numeric type; "a compound" etc. otherwise.
std::string type_name(hid_t t) {
  const H5T_class_t c = H5Tget_class(t);
  const std::string bits = std::to_string(8 * H5Tget_size(t));
  if (c == H5T_FLOAT) return "float" + bits;
  if (c == H5T_INTEGER) return (H5Tget_sign(t) == H5T_SGN_NONE ? "uint" : "int") + bits;
  if (c == H5T_COMPOUND) return "a compound";
  if (c == H5T_STRING) return "strings";
  return "a non-numeric type";
}

std::string shape_text(const std::vector<size_t>& shape) {
  std::string s;
  for (size_t d : shape) s += (s.empty() ? "" : "×") + std::to_string(d);
  return s.empty() ? "a scalar" : s;
}
}  // namespace

void Reader::require_shape(const std::string& path, const std::vector<size_t>& want) const {
  const std::vector<size_t> have = shape(path);
  if (want.empty() ? have.size() == 1 : have == want) return;
  throw input_error(path_, "dataset " + path + " has shape " + shape_text(have) + ", not " +
                               (want.empty() ? std::string("one dimension") : shape_text(want)),
                    "the file is damaged or was edited; remake it with the stage that wrote it");
}

void Reader::read_raw(const std::string& path, hid_t type, void* out) const {
  Handle d = open_dataset(path);
  Handle ft(H5Dget_type(d.get()));
  H5T_class_t c = H5Tget_class(ft.get());
  if (c != H5T_INTEGER && c != H5T_FLOAT)
    throw input_error(path_, "dataset " + path + " is not numeric");
  // Stored as exactly the type asked for: HDF5 would convert another one (float64 into float32
  // rounds, int64 into float64 drops bits) and the values would no longer be what was written.
  if (c != H5Tget_class(type) || H5Tget_size(ft.get()) != H5Tget_size(type) ||
      (c == H5T_INTEGER && H5Tget_sign(ft.get()) != H5Tget_sign(type)))
    throw input_error(path_, "dataset " + path + " is stored as " + type_name(ft.get()) +
                                 ", not " + type_name(type),
                      "the file is damaged or was edited; remake it with the stage that wrote it");
  const size_t n = count(path);
  if (n > 0 && H5Dread(d.get(), type, H5S_ALL, H5S_ALL, H5P_DEFAULT, out) < 0)
    throw input_error(path_, "cannot read dataset " + path + " (truncated or damaged)");
  verify(path, d.get(), type, out, n);
}

std::vector<std::string> Reader::read_strings(const std::string& path) const {
  Handle d = open_dataset(path);
  const size_t n = count(path);  // checked against the bytes stored (shape)
  Handle ft(H5Dget_type(d.get()));
  if (H5Tget_class(ft.get()) != H5T_STRING)
    throw input_error(path_, "dataset " + path + " is not a list of strings");
  std::vector<std::string> out;
  if (H5Tis_variable_str(ft.get()) > 0) {
    // Variable-length strings: written by builds before fixed-length names (and by h5py's
    // default); read for compatibility.
    Handle t(H5Tcopy(H5T_C_S1));
    H5Tset_size(t.get(), H5T_VARIABLE);
    H5Tset_cset(t.get(), H5Tget_cset(ft.get()));
    std::vector<char*> ptrs(n, nullptr);
    if (n > 0 && H5Dread(d.get(), t.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, ptrs.data()) < 0)
      throw input_error(path_, "cannot read strings " + path);
    for (char* p : ptrs) {
      out.emplace_back(p ? p : "");
      if (p) H5free_memory(p);
    }
    return out;
  }
  const size_t width = H5Tget_size(ft.get());
  if (width == 0) throw input_error(path_, "dataset " + path + " has a damaged string type");
  Handle t(H5Tcopy(H5T_C_S1));
  H5Tset_size(t.get(), width);
  H5Tset_strpad(t.get(), H5T_STR_NULLPAD);
  H5Tset_cset(t.get(), H5Tget_cset(ft.get()));
  std::vector<char> packed(n * width, '\0');
  if (n > 0 && H5Dread(d.get(), t.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, packed.data()) < 0)
    throw input_error(path_, "cannot read strings " + path);
  verify(path, d.get(), t.get(), packed.data(), n);
  for (size_t i = 0; i < n; ++i) {
    const char* p = &packed[i * width];
    out.emplace_back(p, strnlen(p, width));
  }
  return out;
}

void Reader::require_same_scene(const Reader& other) const {
  std::string a = scene_id(), b = other.scene_id();
  if (a.empty() || b.empty() || a != b)
    throw input_error(other.path(),
                      "was made from a different scene than " + path_ + " (scene_id " +
                          b.substr(0, 12) + " vs " + a.substr(0, 12) + ")",
                      "rerun the stages from the same scene.h5");
}

}  // namespace pf::h5
