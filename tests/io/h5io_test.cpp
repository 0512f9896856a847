// Stage contract: atomic writes, format/version/scene checks, named compound fields, provenance.
#include <catch2/catch.hpp>
#include <unistd.h>

#include <algorithm>
#include <cstddef>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "photonflow/io/h5io.h"
#include "photonflow/foundations/hash.h"
#include "photonflow/io/provenance.h"
#include "photonflow/geometry/scene.h"
#include "photonflow/io/h5_types.h"
#include "support.h"

namespace fs = std::filesystem;
using namespace pf;

namespace {
// A fresh, empty temporary directory per test case.
struct TempDir {
  fs::path dir;
  TempDir() {
    dir = fs::temp_directory_path() / ("pf-h5io-" + std::to_string(getpid()) + "-" +
                                       std::to_string(counter()++));
    fs::remove_all(dir);
    fs::create_directories(dir);
  }
  ~TempDir() { fs::remove_all(dir); }
  std::string operator/(const std::string& name) const { return (dir / name).string(); }
  static int& counter() { static int c = 0; return c; }
  size_t file_count() const {
    return size_t(std::distance(fs::directory_iterator(dir), fs::directory_iterator()));
  }
};

void write_minimal(const std::string& path, const std::string& format, int version,
                   const std::string& scene_id) {
  h5::Writer w(path, format, version);
  w.attr("/", "scene_id", scene_id);
  w.commit();
}
// `p` written to a file at `path` and read back.
Provenance provenance_round_trip(const Provenance& p, const std::string& path) {
  {
    h5::Writer w(path, "photonflow.test", 1);
    write_provenance(w, p);
    w.commit();
  }
  return read_provenance(h5::Reader(path, "photonflow.test", 1));
}

// The InputError's line that fn() throws, or "<no error>".
std::string input_error_message(const std::function<void()>& fn) {
  try {
    fn();
  } catch (const InputError& e) {
    return e.what();
  }
  return "<no error>";
}
}  // namespace

TEST_CASE("SHA-256 matches the FIPS 180-4 test vectors", "[hash]") {
  Sha256 empty;
  CHECK(empty.hex() == "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  Sha256 abc;
  abc.update("abc", 3);
  CHECK(abc.hex() == "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  // Two-block message, fed in uneven pieces.
  const char* m = "abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq";
  Sha256 two;
  two.update(m, 5);
  two.update(m + 5, 51);
  CHECK(two.hex() == "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
}

TEST_CASE("SHA-256: long messages fed in one piece, FIPS 180-2 vectors", "[hash]") {
  // 112-byte message (two blocks in one update) and one million 'a' (FIPS 180-2, appendix B.3),
  // each given to update() whole, so that a copy loop that does not advance through its input
  // (invisible with pieces shorter than a block) is caught.
  const std::string m112 =
      "abcdefghbcdefghicdefghijdefghijkefghijklfghijklmghijklmnhijklmnoijklmnopjklmnopqklmnopqrlmnopq"
      "rsmnopqrstnopqrstu";
  REQUIRE(m112.size() == 112);
  Sha256 a;
  a.update(m112.data(), m112.size());
  CHECK(a.hex() == "cf5b16a778af8380036ce59e7b0492370b249b11e8f07a51afac45037afee9d1");
  const std::string million(1000000, 'a');
  Sha256 b;
  b.update(million.data(), million.size());
  CHECK(b.hex() == "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0");
}

TEST_CASE("SHA-256: a moved hash goes on where it was", "[hash]") {
  Sha256 a;
  a.update("ab", 2);
  Sha256 b(std::move(a));  // the digest in progress moves with it
  b.update("c", 1);
  Sha256 c;
  c = std::move(b);
  CHECK(c.hex() == "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");  // "abc"
}

TEST_CASE("SHA-256 of files of every length around the padding boundaries equals sha256sum",
          "[hash]") {
  // Lengths 0..130 cover 55/56 (one or two padding blocks), 63/64/65 and 119/120; 200000 bytes
  // span several of sha256_file's 64 KiB reads. The reference is coreutils' sha256sum.
  TempDir tmp;
  std::vector<size_t> lengths;
  for (size_t n = 0; n <= 130; ++n) lengths.push_back(n);
  lengths.push_back(200000);
  std::string cmd = "cd '" + tmp.dir.string() + "' && sha256sum";
  for (size_t n : lengths) {
    std::ofstream f(tmp / ("m" + std::to_string(n)), std::ios::binary);
    for (size_t i = 0; i < n; ++i) f.put(char((i * 131 + 7) % 251));
    cmd += " m" + std::to_string(n);
  }
  std::map<std::string, std::string> ref;
  if (FILE* p = popen((cmd + " 2>/dev/null").c_str(), "r")) {
    char line[256];
    while (fgets(line, sizeof line, p)) {
      std::string l(line);
      if (l.size() > 66) ref[l.substr(66, l.find_first_of("\n", 66) - 66)] = l.substr(0, 64);
    }
    pclose(p);
  }
  if (ref.empty()) {
    WARN("sha256sum not available: reference hashes skipped");
    return;
  }
  REQUIRE(ref.size() == lengths.size());
  for (size_t n : lengths) {
    const std::string name = "m" + std::to_string(n);
    INFO("length " << n);
    CHECK(sha256_file(tmp / name) == ref.at(name));
  }
}

TEST_CASE("checksum64 changes with any flipped bit, the order of words and the length", "[hash]") {
  std::vector<unsigned char> b(300);
  for (size_t i = 0; i < b.size(); ++i) b[i] = static_cast<unsigned char>(i * 37 + 11);
  for (size_t n : {size_t(0), size_t(1), size_t(7), size_t(8), size_t(31), size_t(32), size_t(33),
                   size_t(100), size_t(300)}) {
    INFO("n = " << n);
    const uint64_t h = checksum64(b.data(), n);
    CHECK(checksum64(b.data(), n) == h);
    std::vector<unsigned char> zeros(n + 1, 0);
    CHECK(checksum64(zeros.data(), n) != checksum64(zeros.data(), n + 1));  // length counts
    for (size_t i = 0; i < n; ++i)
      for (int bit = 0; bit < 8; ++bit) {
        std::vector<unsigned char> c(b.begin(), b.begin() + long(n));
        c[i] ^= static_cast<unsigned char>(1u << bit);
        if (checksum64(c.data(), n) == h) FAIL("flip of byte " << i << " bit " << bit << " unseen");
      }
  }
  // Two words swapped, within a lane and across lanes.
  std::vector<unsigned char> c = b;
  std::swap_ranges(c.begin(), c.begin() + 8, c.begin() + 32);
  CHECK(checksum64(c.data(), 64) != checksum64(b.data(), 64));
  c = b;
  std::swap_ranges(c.begin(), c.begin() + 8, c.begin() + 8 + 8);
  CHECK(checksum64(c.data(), 64) != checksum64(b.data(), 64));
}

TEST_CASE("datasets and attributes round-trip with named fields", "[h5io]") {
  TempDir tmp;
  std::string path = tmp / "a.h5";
  std::vector<pf_photon> photons(1000);
  for (size_t i = 0; i < photons.size(); ++i) {
    pf_photon& p = photons[i];
    for (int k = 0; k < 3; ++k) {
      p.position[k] = float(i) * 0.5f + float(k);
      p.dir[k] = -float(k);
      p.flux[k] = 1e-3f * float(i + k);
    }
    p.mesh = int(i % 7);
    p.pass = 3;
    p.flags = int(i % 2);
  }
  std::vector<float> numbers{1.5f, -2.f, 3.25f, 4.f, 5.f, 6.f};
  {
    h5::Writer w(path, "photonflow.test", 2);
    w.attr("/", "scene_id", "abc");
    w.write("/data/photons", h5_type_photon(), photons);
    w.write("/data/matrix", numbers, {2, 3});
    w.write_strings("/names", {"floor", "", "ceiling light"});
    w.attr("/data", "pi", 3.25);
    w.attr("/data", "count", int64_t(-7));
    w.attr("/data", "box", std::vector<double>{1, 2, 3});
    w.describe("/data/photons", "W", "stored photons");
    w.commit();
  }
  h5::Reader r(path, "photonflow.test", 2);
  CHECK(r.version() == 2);
  CHECK(r.scene_id() == "abc");
  auto back = r.read<pf_photon>("/data/photons", h5_type_photon());
  REQUIRE(back.size() == photons.size());
  CHECK(std::memcmp(back.data(), photons.data(), photons.size() * sizeof(pf_photon)) == 0);
  CHECK(r.shape("/data/matrix") == std::vector<size_t>{2, 3});
  CHECK(r.read<float>("/data/matrix", {2, 3}) == numbers);
  // Another shape of the same element count, another rank, or another element type is refused,
  // never reinterpreted or converted.
  CHECK_THROWS_WITH(r.read<float>("/data/matrix"), Catch::Contains("has shape 2×3, not one dimension"));
  CHECK_THROWS_WITH(r.read<float>("/data/matrix", {3, 2}), Catch::Contains("has shape 2×3, not 3×2"));
  CHECK_THROWS_WITH(r.read<float>("/data/matrix", std::vector<size_t>{6}), Catch::Contains("not 6"));
  CHECK_THROWS_WITH(r.read<double>("/data/matrix", {2, 3}),
                    Catch::Contains("is stored as float32, not float64"));
  CHECK_THROWS_WITH(r.read<int32_t>("/data/matrix", {2, 3}),
                    Catch::Contains("is stored as float32, not int32"));
  CHECK(r.read_strings("/names") == std::vector<std::string>{"floor", "", "ceiling light"});
  CHECK(r.attr_double("/data", "pi") == 3.25);
  CHECK(r.attr_int("/data", "count") == -7);
  CHECK(r.attr_doubles("/data", "box") == std::vector<double>{1, 2, 3});
  CHECK(r.attr_string("/data/photons", "unit") == "W");
  CHECK(r.children("/data") == std::vector<std::string>{"matrix", "photons"});
}

TEST_CASE("a writer that is not committed leaves no file behind", "[h5io]") {
  TempDir tmp;
  std::string path = tmp / "never.h5";
  {
    h5::Writer w(path, "photonflow.test", 1);
    w.write("/x", std::vector<float>{1, 2, 3});
    CHECK(w.path() != path);  // writing goes to a temporary name
    CHECK(fs::exists(w.path()));
    CHECK_FALSE(fs::exists(path));
  }
  CHECK_FALSE(fs::exists(path));
  CHECK(tmp.file_count() == 0);
}

TEST_CASE("committing replaces an older file atomically", "[h5io]") {
  TempDir tmp;
  std::string path = tmp / "x.h5";
  write_minimal(path, "photonflow.test", 1, "old");
  write_minimal(path, "photonflow.test", 1, "new");
  CHECK(h5::Reader(path, "photonflow.test", 1).scene_id() == "new");
  CHECK(tmp.file_count() == 1);
}

TEST_CASE("readers refuse wrong, foreign, damaged and missing files with one line", "[h5io]") {
  TempDir tmp;
  const auto message = input_error_message;
  std::string good = tmp / "good.h5";
  write_minimal(good, "photonflow.hitpoints", 1, "s1");

  std::string m = message([&] { h5::Reader(good, "photonflow.photons", 1); });
  CHECK(m.find(good) == 0);
  CHECK(m.find("photonflow.hitpoints") != std::string::npos);
  CHECK(m.find("photonflow.photons") != std::string::npos);
  CHECK(m.find('\n') == std::string::npos);

  std::string newer = tmp / "newer.h5";
  write_minimal(newer, "photonflow.hitpoints", 9, "s1");
  CHECK(message([&] { h5::Reader(newer, "photonflow.hitpoints", 1); }).find("version 9") !=
        std::string::npos);
  // Versions start at 1: a version 0 (or negative) is not one this build wrote.
  std::string zero = tmp / "zero.h5";
  write_minimal(zero, "photonflow.hitpoints", 0, "s1");
  CHECK(message([&] { h5::Reader(zero, "photonflow.hitpoints", 1); }).find("version 0") !=
        std::string::npos);
  std::string negative = tmp / "negative.h5";
  write_minimal(negative, "photonflow.hitpoints", -1, "s1");
  CHECK(message([&] { h5::Reader(negative, "photonflow.hitpoints", 3); }).find("version -1") !=
        std::string::npos);
  CHECK_NOTHROW(h5::Reader(newer, "photonflow.hitpoints", 9));  // the limit itself is read

  std::string missing = tmp / "missing.h5";
  CHECK(message([&] { h5::Reader(missing, "photonflow.hitpoints", 1); }).find("cannot read") !=
        std::string::npos);

  std::string text = tmp / "text.h5";
  std::ofstream(text) << "not hdf5 at all\n";
  CHECK(message([&] { h5::Reader(text, "photonflow.hitpoints", 1); }).find("not a readable HDF5") !=
        std::string::npos);

  // A truncated copy of a real file.
  std::string big = tmp / "big.h5";
  {
    h5::Writer w(big, "photonflow.hitpoints", 1);
    w.write("/x", std::vector<float>(200000, 1.f));
    w.commit();
  }
  std::string cut = tmp / "cut.h5";
  fs::copy_file(big, cut);
  fs::resize_file(cut, fs::file_size(big) / 2);
  std::string mc = message([&] {
    h5::Reader r(cut, "photonflow.hitpoints", 1);
    r.read<float>("/x");
  });
  CHECK(mc.find(cut) == 0);

  // A foreign HDF5 file: valid HDF5 without photonflow's format attribute.
  std::string foreign = tmp / "foreign.h5";
  {
    hid_t f = H5Fcreate(foreign.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    H5Fclose(f);
  }
  CHECK(message([&] { h5::Reader(foreign, "photonflow.hitpoints", 1); }).find("not a photonflow") !=
        std::string::npos);

  // Missing dataset and missing field.
  h5::Reader r(good, "photonflow.hitpoints", 1);
  CHECK(message([&] { r.read<float>("/nope"); }).find("missing dataset /nope") != std::string::npos);
  // A compound without a field the reader asks for: HDF5 itself would leave that field untouched
  // (it converts the members both types have), so the reader must refuse it by name.
  std::string partial = tmp / "partial.h5";
  {
    struct OnlyPosition {
      float position[3];
    };
    h5::Compound t(sizeof(OnlyPosition));
    t.f32("position", offsetof(OnlyPosition, position), 3);
    h5::Writer w(partial, "photonflow.photons", 1);
    w.write("/photons", t, std::vector<OnlyPosition>{{{1, 2, 3}}, {{4, 5, 6}}});
    w.commit();
  }
  h5::Reader rp(partial, "photonflow.photons", 1);
  std::string mf = message([&] { rp.read<pf_photon>("/photons", h5_type_photon()); });
  CHECK(mf.find(partial) == 0);
  CHECK(mf.find("lacks field 'dir'") != std::string::npos);
}

TEST_CASE("damaged shapes, compound types and attribute extents are refused, never read past a "
          "buffer", "[h5io][damaged]") {
  // Each of these crashed a stage or made it allocate terabytes when a fuzzer flipped bytes of a
  // real file (a segfault inside HDF5's conversion, a std::bad_alloc): now each is one InputError.
  TempDir tmp;
  const auto message = input_error_message;
  const std::string path = tmp / "d.h5";
  struct Rec {
    float a;
    int32_t zzzzzzz;
  };
  {
    h5::Writer w(path, "photonflow.test", 1);
    h5::Compound t(sizeof(Rec));
    t.f32("a", offsetof(Rec, a)).i32("zzzzzzz", offsetof(Rec, zzzzzzz));
    w.write("/rec", t, std::vector<Rec>{{1.f, 2}, {3.f, 4}});
    w.attr("/", "box", std::vector<double>{1, 2, 3});
    w.commit();
  }
  h5::Compound t(sizeof(Rec));
  t.f32("a", offsetof(Rec, a)).i32("zzzzzzz", offsetof(Rec, zzzzzzz));
  {
    h5::Reader r(path, "photonflow.test", 1);
    const auto back = r.read<Rec>("/rec", t);
    REQUIRE(back.size() == 2);
    CHECK(back[1].zzzzzzz == 4);
    // A list attribute read as one value: H5Aread would write three values into one.
    CHECK(message([&] { r.attr_int("/", "box"); }).find("@box is not a single value") !=
          std::string::npos);
    CHECK(message([&] { r.attr_double("/", "box"); }).find("is not a single value") !=
          std::string::npos);
  }
  // A shape larger than the bytes stored: a dataset created and never written stores none.
  {
    hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    hsize_t dims[1] = {hsize_t(1) << 40};
    hid_t space = H5Screate_simple(1, dims, nullptr);
    hid_t d = H5Dcreate2(f, "/huge", H5T_NATIVE_FLOAT, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    REQUIRE(d >= 0);
    H5Dclose(d);
    H5Sclose(space);
    H5Fclose(f);
    h5::Reader r(path, "photonflow.test", 1);
    const std::string m = message([&] { r.read<float>("/huge"); });
    CHECK(m.find(path) == 0);
    CHECK(m.find("claims more elements than the file stores") != std::string::npos);
    CHECK(r.shape("/rec") == std::vector<size_t>{2});  // a whole dataset passes
  }
  // A compound whose field lies past the end of its record, in a file of the earliest HDF5 format
  // (which photonflow wrote before it chose the 1.8 format, and which other tools still write):
  // HDF5's API refuses to make such a type, so the field's offset is patched in the file. In that
  // format's datatype message the member's name, padded with NULs to a multiple of 8 bytes, is
  // followed by its 4-byte offset, and no checksum covers it.
  {
    const std::string old = tmp / "old-format.h5";
    hid_t f = H5Fcreate(old.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    auto string_attr = [&](const char* name, const std::string& value) {
      hid_t st = H5Tcopy(H5T_C_S1);
      H5Tset_size(st, value.size() + 1);
      hid_t sp = H5Screate(H5S_SCALAR);
      hid_t a = H5Acreate2(f, name, st, sp, H5P_DEFAULT, H5P_DEFAULT);
      H5Awrite(a, st, value.c_str());
      H5Aclose(a);
      H5Sclose(sp);
      H5Tclose(st);
    };
    string_attr("format", "photonflow.test");
    {
      const int64_t v = 1;
      hid_t sp = H5Screate(H5S_SCALAR);
      hid_t a = H5Acreate2(f, "format_version", H5T_NATIVE_INT64, sp, H5P_DEFAULT, H5P_DEFAULT);
      H5Awrite(a, H5T_NATIVE_INT64, &v);
      H5Aclose(a);
      H5Sclose(sp);
    }
    const std::vector<Rec> recs = {{1.f, 2}, {3.f, 4}};
    hsize_t n = recs.size();
    hid_t sp = H5Screate_simple(1, &n, nullptr);
    hid_t d = H5Dcreate2(f, "/rec", t.id(), sp, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    REQUIRE(H5Dwrite(d, t.id(), H5S_ALL, H5S_ALL, H5P_DEFAULT, recs.data()) >= 0);
    H5Dclose(d);
    H5Sclose(sp);
    H5Fclose(f);
    REQUIRE(h5::Reader(old, "photonflow.test", 1).read<Rec>("/rec", t).at(1).zzzzzzz == 4);

    std::string bytes = test::file_bytes(old);
    const std::string name("zzzzzzz\0", 8);
    const size_t at = bytes.find(name);
    REQUIRE(at != std::string::npos);
    uint32_t offset = 0;
    std::memcpy(&offset, &bytes[at + 8], 4);
    REQUIRE(offset == offsetof(Rec, zzzzzzz));  // the layout this patch assumes
    offset = 4096;
    std::memcpy(&bytes[at + 8], &offset, 4);
    std::ofstream(old, std::ios::binary | std::ios::trunc) << bytes;
    h5::Reader r(old, "photonflow.test", 1);
    const std::string m = message([&] { r.read<Rec>("/rec", t); });
    CHECK(m.find("/rec has a damaged compound type") != std::string::npos);
  }
}

TEST_CASE("written files carry checksums: a damaged value or header is refused, not read",
          "[h5io][damaged]") {
  // The 1.8 file format checksums the object headers (attributes included), and every dataset
  // carries checksum64 of its bytes, verified on every read (h5io.cpp).
  TempDir tmp;
  const std::string path = tmp / "c.h5";
  const std::vector<float> values(1000, 1234.5f);
  {
    h5::Writer w(path, "photonflow.test", 1);
    w.write("/values", values);
    w.attr("/values", "label", std::string("MARKER-LABEL"));
    w.commit();
  }
  {
    h5::Reader r(path, "photonflow.test", 1);
    CHECK(r.read<float>("/values") == values);
    CHECK(r.attr_string("/values", "label") == "MARKER-LABEL");
  }
  const std::string bytes = test::file_bytes(path);
  auto damaged = [&](size_t at) {
    std::string copy = bytes;
    copy[at] = char(copy[at] ^ 0x10);
    const std::string p = tmp / ("d" + std::to_string(at) + ".h5");
    std::ofstream(p, std::ios::binary) << copy;
    return p;
  };
  auto refused = [](const std::function<void()>& fn) {
    return input_error_message(fn) != "<no error>";
  };
  float one = 1234.5f;
  const size_t value_at = bytes.find(std::string(reinterpret_cast<char*>(&one), 4));
  REQUIRE(value_at != std::string::npos);
  const std::string v = damaged(value_at + 500 * 4);  // a value in the middle
  CHECK(refused([&] { h5::Reader(v, "photonflow.test", 1).read<float>("/values"); }));
  const size_t label_at = bytes.find("MARKER-LABEL");
  REQUIRE(label_at != std::string::npos);
  const std::string l = damaged(label_at + 3);  // one letter of an attribute
  CHECK(refused([&] { h5::Reader(l, "photonflow.test", 1).attr_string("/values", "label"); }));
}

TEST_CASE("names are fixed-length strings, variable-length ones (older files) still read",
          "[h5io]") {
  // Variable-length strings live in HDF5's global heap, whose reader (H5HG_read, HDF5 1.10)
  // copied past its buffer on a damaged scene.h5; fixed-length ones are stored in the dataset.
  TempDir tmp;
  const std::string path = tmp / "s.h5";
  const std::vector<std::string> names = {"floor", "", "ceiling light", "a much longer name"};
  {
    h5::Writer w(path, "photonflow.test", 1);
    w.write_strings("/names", names);
    w.commit();
  }
  {
    hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    hid_t d = H5Dopen2(f, "/names", H5P_DEFAULT);
    hid_t ft = H5Dget_type(d);
    CHECK(H5Tget_class(ft) == H5T_STRING);
    CHECK(H5Tis_variable_str(ft) == 0);
    CHECK(H5Tget_size(ft) == names.back().size() + 1);
    H5Tclose(ft);
    H5Dclose(d);
    // The old layout, as builds before this one wrote it.
    hid_t vt = H5Tcopy(H5T_C_S1);
    H5Tset_size(vt, H5T_VARIABLE);
    H5Tset_cset(vt, H5T_CSET_UTF8);
    hsize_t n = names.size();
    hid_t space = H5Screate_simple(1, &n, nullptr);
    hid_t v = H5Dcreate2(f, "/old", vt, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    std::vector<const char*> ptrs;
    for (const auto& s : names) ptrs.push_back(s.c_str());
    REQUIRE(H5Dwrite(v, vt, H5S_ALL, H5S_ALL, H5P_DEFAULT, ptrs.data()) >= 0);
    H5Dclose(v);
    H5Sclose(space);
    H5Tclose(vt);
    H5Fclose(f);
  }
  h5::Reader r(path, "photonflow.test", 1);
  CHECK(r.read_strings("/names") == names);
  CHECK(r.read_strings("/old") == names);
}

// h5py writes every str it is given as a variable-length string: a file whose string attributes
// a user rewrote with h5py (f.attrs['note'] = 'x', or the same value again) still reads, the
// format check included.
TEST_CASE("string attributes rewritten as variable-length strings (h5py's way) still read",
          "[h5io]") {
  TempDir tmp;
  const std::string path = tmp / "v.h5";
  {
    h5::Writer w(path, "photonflow.test", 1);
    w.attr("/", "estimator", "ppm");
    w.write("/x", std::vector<float>{1.f, 2.f});
    w.commit();
  }
  auto set_vlen = [&](const char* name, const std::string& value) {
    hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    REQUIRE(f >= 0);
    if (H5Aexists(f, name) > 0) H5Adelete(f, name);
    hid_t vt = H5Tcopy(H5T_C_S1);
    H5Tset_size(vt, H5T_VARIABLE);
    H5Tset_cset(vt, H5T_CSET_UTF8);
    hid_t space = H5Screate(H5S_SCALAR);
    hid_t a = H5Acreate2(f, name, vt, space, H5P_DEFAULT, H5P_DEFAULT);
    const char* p = value.c_str();
    REQUIRE(H5Awrite(a, vt, &p) >= 0);
    H5Aclose(a);
    H5Sclose(space);
    H5Tclose(vt);
    H5Fclose(f);
  };
  set_vlen("format", "photonflow.test");
  set_vlen("estimator", "ppm");
  set_vlen("note", "looked at by hand");
  {
    h5::Reader r(path, "photonflow.test", 1);  // the format check reads the rewritten attribute
    CHECK(r.attr_string("/", "estimator") == "ppm");
    CHECK(r.attr_string("/", "note") == "looked at by hand");
    CHECK(r.read<float>("/x") == std::vector<float>{1.f, 2.f});
  }
  set_vlen("format", "photonflow.other");
  CHECK_THROWS_AS(h5::Reader(path, "photonflow.test", 1), InputError);
}

TEST_CASE("files from different scenes are refused", "[h5io]") {
  TempDir tmp;
  write_minimal(tmp / "a.h5", "photonflow.hitpoints", 1, "aaaa");
  write_minimal(tmp / "b.h5", "photonflow.photons", 1, "bbbb");
  write_minimal(tmp / "c.h5", "photonflow.photons", 1, "aaaa");
  h5::Reader a(tmp / "a.h5", "photonflow.hitpoints", 1);
  h5::Reader b(tmp / "b.h5", "photonflow.photons", 1);
  h5::Reader c(tmp / "c.h5", "photonflow.photons", 1);
  CHECK_THROWS_AS(a.require_same_scene(b), InputError);
  CHECK_NOTHROW(a.require_same_scene(c));
}

TEST_CASE("an output that cannot be created is one InputError", "[h5io]") {
  CHECK_THROWS_WITH(h5::Writer("/nonexistent-dir/x.h5", "photonflow.test", 1),
                    Catch::Contains("/nonexistent-dir/x.h5") && Catch::Contains("cannot create"));
}

TEST_CASE("provenance round-trips with input hashes", "[h5io][provenance]") {
  TempDir tmp;
  std::string input = tmp / "input.txt";
  std::ofstream(input) << "abc";
  Provenance p;
  p.tool = "test-tool";
  p.seed = 1234567890123ull;
  p.param("photons", 100000);
  p.param("alpha", 0.7);
  p.param("method", "grid");
  p.param("verbose", true);
  p.add_input("source", input);
  p.wall_time_s = 1.25;
  p.command_line = "test-tool --photons 100000";
  const Provenance q = provenance_round_trip(p, tmp / "p.h5");
  CHECK(q.tool == "test-tool");
  CHECK(q.seed == p.seed);
  CHECK(q.parameters == p.parameters);
  CHECK(q.parameters.at("photons") == "100000");
  CHECK(q.wall_time_s == 1.25);
  CHECK(q.command_line == p.command_line);
  CHECK_FALSE(q.version.empty());
  CHECK_FALSE(q.git_hash.empty());
  // created_utc: ISO 8601 UTC "YYYY-MM-DDTHH:MM:SSZ", the time of writing (within a minute).
  {
    std::tm t{};
    REQUIRE(q.created_utc.size() == 20);
    CHECK(q.created_utc[10] == 'T');
    CHECK(q.created_utc.back() == 'Z');
    REQUIRE(strptime(q.created_utc.c_str(), "%Y-%m-%dT%H:%M:%SZ", &t) != nullptr);
    const double age = std::difftime(std::time(nullptr), timegm(&t));
    CHECK(age >= -1.0);
    CHECK(age < 60.0);
  }
  // The hash is the source tree's current commit (regenerated at every build, git_version.cmake),
  // not the one cmake was first run at; "-dirty" with uncommitted changes to tracked files.
  std::string head;
  if (FILE* g = popen(("git -C '" + std::string(PF_SOURCE_DIR) +
                       "' rev-parse --short=12 HEAD 2>/dev/null").c_str(), "r")) {
    char buf[64] = {0};
    if (fgets(buf, sizeof buf, g)) head = buf;
    pclose(g);
  }
  if (!head.empty() && head.back() == '\n') head.pop_back();
  if (!head.empty()) {
    INFO("HEAD " << head << ", recorded " << q.git_hash << " (rebuild after committing)");
    CHECK(q.git_hash.rfind(head, 0) == 0);
  }
  REQUIRE(q.inputs.size() == 1);
  CHECK(q.inputs[0].role == "source");
  CHECK(q.inputs[0].sha256 == "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
}

TEST_CASE("the recorded command line reads back as the same arguments in a POSIX shell",
          "[provenance]") {
  // join_command_line's text is meant to be pasted into a shell to repeat the run: /bin/sh must
  // split it back into exactly the original arguments (no expansion, globbing, comments, ...).
  TempDir tmp;
  std::vector<std::string> args = {"trace-photons", "--scene", "plain/path.h5", "a b", "it's",
                                   "$HOME", "", "x;rm -rf y", "a*b", "back\\slash", "tab\there",
                                   "new\nline", "`id`", "q\"uote", "p|q&r", "(x)", "~user",
                                   "#hash", "--seed=1", "'both' \"kinds\""};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  const std::string line = join_command_line(int(argv.size()), argv.data());
  CHECK(line.find("--scene plain/path.h5") != std::string::npos);  // plain words stay plain
  std::ofstream(tmp / "echo.sh") << "printf '%s\\0' " << line << "\n";
  std::string out;
  if (FILE* p = popen(("/bin/sh '" + (tmp / "echo.sh") + "' 2>&1").c_str(), "r")) {
    char buf[4096];
    size_t n;
    while ((n = fread(buf, 1, sizeof buf, p)) > 0) out.append(buf, n);
    pclose(p);
  }
  std::vector<std::string> back;
  size_t at = 0;
  for (size_t z; (z = out.find('\0', at)) != std::string::npos; at = z + 1)
    back.push_back(out.substr(at, z - at));
  INFO("command line: " << line);
  CHECK(back == args);
}

TEST_CASE("provenance keeps each input's path, hash, format and scene_id apart", "[h5io][provenance]") {
  TempDir tmp;
  std::string a = tmp / "a.txt", b = tmp / "b.txt";
  std::ofstream(a) << "abc";
  std::ofstream(b) << "";
  Provenance p;
  p.tool = "t";
  p.add_input("scene", a, "photonflow.scene", "id-of-a");
  p.add_input("hitpoints", b, "photonflow.hitpoints", "id-of-b");
  const Provenance q = provenance_round_trip(p, tmp / "p.h5");
  REQUIRE(q.inputs.size() == 2);
  for (const auto& in : q.inputs) {
    INFO("role " << in.role);
    if (in.role == "scene") {
      CHECK(in.path == a);
      CHECK(in.sha256 == "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
      CHECK(in.format == "photonflow.scene");
      CHECK(in.scene_id == "id-of-a");
    } else {
      CHECK(in.role == "hitpoints");
      CHECK(in.path == b);
      CHECK(in.sha256 == "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
      CHECK(in.format == "photonflow.hitpoints");
      CHECK(in.scene_id == "id-of-b");
    }
  }
  // A file without the group is refused, naming the file.
  std::string bare = tmp / "bare.h5";
  write_minimal(bare, "photonflow.test", 1, "s");
  CHECK_THROWS_WITH(read_provenance(h5::Reader(bare, "photonflow.test", 1)),
                    Catch::Contains(bare) && Catch::Contains("no provenance"));
}
