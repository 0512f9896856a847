// support.h — helpers shared by the tests: temporary folders, running tools, scenes in memory.
#pragma once
#include <hdf5.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

#include "photonflow/stages/clusters.h"
#include "photonflow/io/h5io.h"
#include "photonflow/foundations/hash.h"
#include "photonflow/stages/grid_shared.h"
#include "photonflow/image/image.h"
#include "photonflow/estimators/ppm.h"
#include "photonflow/geometry/procedural.h"
#include "photonflow/foundations/rng.h"
#include "photonflow/geometry/scene.h"
#include "photonflow/foundations/vec.h"

namespace pf::test {

// True in a ThreadSanitizer build (`make test-tsan`).
constexpr bool thread_sanitizer_build() {
#if defined(__SANITIZE_THREAD__)
  return true;
#elif defined(__has_feature)
#if __has_feature(thread_sanitizer)
  return true;
#else
  return false;
#endif
#else
  return false;
#endif
}

// Every byte of a file ("" when it cannot be read).
inline std::string file_bytes(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

// A fresh temporary folder, removed at the end of the scope.
struct TempDir {
  std::filesystem::path dir;
  explicit TempDir(const std::string& tag) {
    static int counter = 0;
    dir = std::filesystem::temp_directory_path() /
          ("pf-" + tag + "-" + std::to_string(getpid()) + "-" + std::to_string(counter++));
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
  }
  ~TempDir() { std::filesystem::remove_all(dir); }
  std::string operator/(const std::string& name) const { return (dir / name).string(); }
  size_t file_count() const {
    size_t n = 0;
    for (auto& e : std::filesystem::directory_iterator(dir)) n += e.is_regular_file();
    return n;
  }
};

// The temporary outputs ("<name>.tmp.<pid>", output_file.h) left anywhere under `dir`: a stage
// that failed or was interrupted must leave none.
inline std::vector<std::string> temporary_files(const std::filesystem::path& dir) {
  std::vector<std::string> left;
  for (auto& e : std::filesystem::recursive_directory_iterator(dir))
    if (e.path().filename().string().find(".tmp.") != std::string::npos)
      left.push_back(e.path().string());
  return left;
}

// The photonflow source folder: $PF_SOURCE_DIR when set (a copy of the tree somewhere else, as on
// the GPU machine that bench/gpu.sh carries the test binaries to), else the tree this test was
// built from.
// Whether n = 2^k points (xs, ys) in [0, 1)² put one point in each of the 2^k cells of every
// shape 2^a × 2^(k−a): a (0,k,2)-net (Sobol's first two dimensions, scrambled or not).
inline bool is_net(const std::vector<float>& xs, const std::vector<float>& ys, int k) {
  const int n = 1 << k;
  for (int a = 0; a <= k; ++a) {
    const int cols = 1 << a, rows = 1 << (k - a);
    std::vector<int> hits(size_t(n), 0);
    for (int i = 0; i < n; ++i) {
      const float x = xs[size_t(i)], y = ys[size_t(i)];
      if (!(x >= 0.f && x < 1.f && y >= 0.f && y < 1.f)) return false;
      if (++hits[size_t(int(y * float(rows)) * cols + int(x * float(cols)))] > 1) return false;
    }
  }
  return true;
}

inline std::string source_dir() {
  const char* s = std::getenv("PF_SOURCE_DIR");
  return s && *s ? s : std::string(PF_SOURCE_DIR);
}

// Folder of the built tools (ctest sets PF_BIN; else the build tree's bin/).
inline std::string bin_dir() {
  const char* b = std::getenv("PF_BIN");
  return b ? b : std::string(PF_BINARY_DIR) + "/bin";
}

struct ToolRun {
  int exit_code = -1;
  std::string out, err;
};

// Runs `tool args` from bin_dir(), capturing stdout and stderr; `env` ("NAME=value ...") is set
// for the tool alone. With `seconds` > 0 the tool is killed (SIGKILL) after that time and the run's
// exit code is 137: a test of a refusal that used to hang fails instead of hanging the suite.
inline ToolRun run_tool(const std::string& tool, const std::string& args, const TempDir& tmp,
                        const std::string& env = "", int seconds = 0) {
  std::string out = tmp / ".stdout", err = tmp / ".stderr";
  std::string cmd = (env.empty() ? "" : "env " + env + " ") +
                    (seconds > 0 ? "timeout -s KILL " + std::to_string(seconds) + " " : "") +
                    bin_dir() + "/" + tool + " " + args + " >" + out + " 2>" + err;
  int status = std::system(cmd.c_str());
  ToolRun r;
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.out = file_bytes(out);
  r.err = file_bytes(err);
  std::filesystem::remove(out);
  std::filesystem::remove(err);
  return r;
}

// Sets the checksum64 attribute of dataset `d` (h5io.cpp) to its current bytes, as a tool that
// edits a file consistently would: the edits below test the loaders' checks behind the checksum.
inline void refresh_checksum(hid_t d) {
  if (H5Aexists(d, "checksum64") <= 0) return;
  std::vector<unsigned char> raw;
  REQUIRE(h5::read_stored_bytes(d, raw));
  const int64_t sum = int64_t(checksum64(raw.data(), raw.size()));
  h5::Handle a(H5Aopen(d, "checksum64", H5P_DEFAULT));
  REQUIRE(H5Awrite(a.get(), H5T_NATIVE_INT64, &sum) >= 0);
}

// `f()` throws an InputError whose one line contains `file` (unless empty) and `needle`: a
// loader's or a check's refusal (Catch's CHECK: include catch.hpp first).
inline void refused(const std::function<void()>& f, const std::string& file,
                    const std::string& needle) {
  try {
    f();
    FAIL_CHECK("accepted: " << file << " (expected '" << needle << "')");
  } catch (const InputError& e) {
    const std::string msg = e.what();
    INFO(msg);
    if (!file.empty()) CHECK(msg.find(file) != std::string::npos);
    CHECK(msg.find(needle) != std::string::npos);
    CHECK(msg.find('\n') == std::string::npos);
  }
}

// Fuzz-style edits of a written file (Catch's REQUIRE: include catch.hpp first).
// Rewrites dataset `dset` of `file` in place: reads it as T (memory type `type`, fields matched by
// name), lets `edit` change it, writes it back.
template <class T>
void edit_dataset(const std::string& file, const std::string& dset, hid_t type,
                  const std::function<void(std::vector<T>&)>& change) {
  h5::Handle f(H5Fopen(file.c_str(), H5F_ACC_RDWR, H5P_DEFAULT));
  REQUIRE(f.valid());
  h5::Handle d(H5Dopen2(f.get(), dset.c_str(), H5P_DEFAULT));
  REQUIRE(d.valid());
  h5::Handle space(H5Dget_space(d.get()));
  std::vector<T> v(size_t(H5Sget_simple_extent_npoints(space.get())));
  REQUIRE(H5Dread(d.get(), type, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()) >= 0);
  change(v);
  REQUIRE(H5Dwrite(d.get(), type, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()) >= 0);
  refresh_checksum(d.get());
}

// Overwrites the existing attribute `name` of object `obj` of `file` with the value at `v`, of
// memory type `type`.
inline void write_attr(const std::string& file, const std::string& obj, const std::string& name,
                       hid_t type, const void* v) {
  h5::Handle f(H5Fopen(file.c_str(), H5F_ACC_RDWR, H5P_DEFAULT));
  REQUIRE(f.valid());
  // The object first, then its attribute: HDF5 1.10 cannot write an attribute opened with
  // H5Aopen_by_name on a group ("can't locate open attribute").
  h5::Handle o(H5Oopen(f.get(), obj.c_str(), H5P_DEFAULT));
  REQUIRE(o.valid());
  h5::Handle a(H5Aopen(o.get(), name.c_str(), H5P_DEFAULT));
  REQUIRE(a.valid());
  REQUIRE(H5Awrite(a.get(), type, v) >= 0);
}

// Sets the int64 attribute `name` of object `obj` of `file`.
inline void set_int_attr(const std::string& file, const std::string& obj, const std::string& name, int64_t v) {
  INFO("set " << file << " " << obj << "@" << name << " = " << v);
  write_attr(file, obj, name, H5T_NATIVE_INT64, &v);
}

// Reverses a triangle's winding (and its normals): an outward mesh becomes inward.
inline void flip(pf_triangle& t) {
  for (int k = 0; k < 3; ++k) {
    std::swap(t.v1[k], t.v2[k]);
    std::swap(t.n1[k], t.n2[k]);
    t.n0[k] = -t.n0[k];
    t.n1[k] = -t.n1[k];
    t.n2[k] = -t.n2[k];
  }
}

// Flat shading: every vertex normal becomes the geometric normal (smooth normals of a coarse
// tessellation lose a little energy through directions below the surface; flat ones are exact).
inline void make_flat(std::vector<pf_triangle>& tris) {
  for (auto& t : tris) {
    const Vec3 n = normalize(cross(Vec3(t.v1) - Vec3(t.v0), Vec3(t.v2) - Vec3(t.v0)));
    n.store(t.n0);
    n.store(t.n1);
    n.store(t.n2);
  }
}

// Quad a, b, c, d (counter-clockwise seen from its front) as two flat-shaded triangles of mesh and
// material `id`.
inline std::vector<pf_triangle> quad(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d,
                                     int id) {
  auto tri = [id](const Vec3& p, const Vec3& q, const Vec3& r) {
    pf_triangle t{};
    p.store(t.v0);
    q.store(t.v1);
    r.store(t.v2);
    t.mesh = id;
    t.material = id;
    return t;
  };
  std::vector<pf_triangle> out = {tri(a, b, c), tri(a, c, d)};
  make_flat(out);
  return out;
}

// A hitpoint at x = q of radius r and a photon at x = p, a few ulps beyond q + r (itself rounded),
// that the float distance rule pf_ppm_in_radius(pf_ppm_dist2(q, p), r) still accepts (y and z
// equal). With bins p wide from 0, q + r lies in bin 0 and the photon exactly on the lower edge of
// bin 1: a gather box of bins from q − r to q + r misses it unless it is widened. Found by a
// deterministic search (about one draw in 50 qualifies; the products use all mantissa bits).
struct EdgePhoton {
  float q = 0, r = 0, p = 0;
};
inline EdgePhoton edge_photon() {
  EdgePhoton e;
  bool found = false;
  for (uint32_t k = 0; k < 100000 && !found; ++k) {
    e.q = 0.1f + 0.3f * pf_rng_float(3, 0, k, 0);
    e.r = 0.2f + 0.2f * pf_rng_float(3, 0, k, 1);
    e.p = e.q + e.r;
    for (int ulps = 1; ulps <= 3 && !found; ++ulps) {
      e.p = std::nextafter(e.p, INFINITY);
      found = pf_ppm_in_radius(pf_ppm_dist2(e.q, 0, 0, e.p, 0, 0), e.r);
    }
  }
  REQUIRE(found);
  INFO("q " << e.q << " R " << e.r << " p " << e.p);
  REQUIRE(pf_grid_coord(e.q + e.r, 0.f, e.p, 2) == 0);  // the unwidened box ends in bin 0 ...
  REQUIRE(pf_grid_coord(e.p, 0.f, e.p, 2) == 1);        // ... and the photon lies in bin 1
  return e;
}

// A furnace's walls: emit `le` and reflect diffusely with albedo `rho`.
inline pf_material furnace_material(float rho, float le) {
  pf_material m{};
  m.type = PF_MAT_EMITTER;
  m.ior = 1.f;
  for (int c = 0; c < 3; ++c) {
    m.color[c] = rho;
    m.emission[c] = le;
  }
  return m;
}

// White furnace: the inside of a unit sphere whose walls all emit `le` and reflect diffusely with
// albedo `rho`; the camera sits at the centre. Every radiance inside is le / (1 − rho).
inline Scene furnace_scene(float rho, float le, int size, size_t triangles = 2000) {
  Scene s;
  s.triangles = make_sphere(Vec3(0, 0, 0), 1.f, triangles, {0, 0});
  for (auto& t : s.triangles) flip(t);
  s.mesh_names = {"sphere"};
  s.materials = {furnace_material(rho, le)};
  s.material_names = {"furnace"};
  s.camera = pf_camera{{0, 0, 0}, {0, 0, 1}, {0, 1, 0}, 60.f, size, size};
  finish_scene(s);
  return s;
}

// The unit Cornell-like room of procedural.h with a chosen material for the sphere, lit by a
// small downward-facing ceiling quad. Meshes: 0 walls, 1 box, 2 sphere, 3 light.
inline Scene room_scene(int sphere_material_type, int width, int height) {
  Scene s;
  s.triangles = make_cornell_room(400);
  auto light = make_box(Vec3(0.4f, 0.98f, 0.4f), Vec3(0.6f, 0.99f, 0.6f), false, {3, 3});
  s.triangles.insert(s.triangles.end(), light.begin(), light.end());
  s.mesh_names = {"walls", "box", "sphere", "light"};
  auto mat = [](int type, float r, float g, float b, float e) {
    pf_material m{};
    m.type = type;
    m.ior = type == PF_MAT_GLASS ? 1.5f : 1.f;
    m.color[0] = r; m.color[1] = g; m.color[2] = b;
    for (int c = 0; c < 3; ++c) m.emission[c] = e;
    return m;
  };
  s.materials = {mat(PF_MAT_DIFFUSE, 0.7f, 0.6f, 0.5f, 0), mat(PF_MAT_DIFFUSE, 0.5f, 0.5f, 0.8f, 0),
                 mat(sphere_material_type, 0.9f, 0.9f, 0.9f, 0),
                 mat(PF_MAT_EMITTER, 0.f, 0.f, 0.f, 20.f)};
  s.material_names = {"walls", "box", "sphere", "light"};
  // Inside the closed room, near the front wall, looking at the back wall.
  s.camera = pf_camera{{0.5f, 0.5f, 0.97f}, {0.5f, 0.45f, 0.f}, {0, 1, 0}, 70.f, width, height};
  finish_scene(s);
  return s;
}

// A w × w/2 sky of radiance `sky` (brighter towards the zenith) with a 2-texel sun of `sun` high
// in it (row w/16).
inline Environment sky_with_sun(int w, float sky, float sun) {
  Environment e;
  e.width = w;
  e.height = w / 2;
  e.texels.resize(size_t(w) * size_t(w / 2) * 3);
  for (int row = 0; row < w / 2; ++row)
    for (int col = 0; col < w; ++col) {
      const float v = (float(row) + 0.5f) / float(w / 2);
      const bool in_sun = row == w / 16 && (col == w / 3 || col == w / 3 + 1);
      const float r = in_sun ? sun : sky * (1.5f - v);
      for (int c = 0; c < 3; ++c)
        e.texels[3 * (size_t(row) * size_t(w) + size_t(col)) + size_t(c)] = r * (c == 2 ? 1.f : 0.8f);
    }
  e.source = "test sky";
  return e;
}

// Σ v² over all values of a layer (> 0: the layer is not black).
inline double sum_squares(const std::vector<float>& v) {
  double s = 0;
  for (float x : v) s += double(x) * double(x);
  return s;
}

// RMSE of the values a against the reference b, relative to b's RMS (b black: the plain root of
// the summed squared differences).
inline double relative_rmse(const std::vector<float>& a, const std::vector<float>& b) {
  double se = 0, ref = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    double d = double(a[i]) - double(b[i]);
    se += d * d;
    ref += double(b[i]) * double(b[i]);
  }
  return ref > 0 ? std::sqrt(se / ref) : std::sqrt(se);
}

// The same over all RGB values of two images.
inline double relative_rmse(const Image& a, const Image& b) { return relative_rmse(a.rgb, b.rgb); }

// The same clusters, byte for byte: records and order array.
inline bool same_clusters(const ClusterSet& a, const ClusterSet& b) {
  return a.order == b.order && a.clusters.size() == b.clusters.size() &&
         std::memcmp(a.clusters.data(), b.clusters.data(), a.clusters.size() * sizeof(pf_cluster)) == 0;
}

// The same hitpoint records, byte for byte (the same count first).
inline bool same_hitpoints(const std::vector<pf_hitpoint>& a, const std::vector<pf_hitpoint>& b) {
  return a.size() == b.size() &&
         std::memcmp(a.data(), b.data(), a.size() * sizeof(pf_hitpoint)) == 0;
}

// Hitpoints that have gathered at least one photon (a comparison of states is not vacuous).
inline size_t gathered_hitpoints(const std::vector<pf_hitpoint>& h) {
  size_t n = 0;
  for (const pf_hitpoint& hp : h) n += hp.n_photons > 0.f;
  return n;
}

}  // namespace pf::test
