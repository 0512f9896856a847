// Fuzz-style checks of the stage files' loaders (docs/FORMATS.md): a valid small file of every
// type has ONE integer field (an index, a count, a range) set out of range with the HDF5 C API,
// and the load — or, for indices into the scene's tables, accept_input / check_against_scene where
// the file meets its scene — must throw pf::InputError naming the file and what is wrong, never
// crash or read out of bounds. Covers scene.h5 (triangle mesh/material, lights, kd-tree nodes,
// ropes, leaf ranges, leaf_tris, material and light types, camera size), hitpoints.h5 (mesh,
// material, pixel, image size, pass count), photons.h5 (mesh, pass, first_pass), grid.h5 (mesh
// headers, cell_start, order, photons per mesh, the scene's mesh count), clusters.h5 (cluster
// ranges, order) and photon_distribution.h5 (grid headers that would wrap).
#include <catch2/catch.hpp>

#include <climits>
#include <cmath>
#include <cstddef>
#include <filesystem>
#include <functional>
#include <tuple>
#include <utility>

#include "photonflow/io/validate.h"
#include "photonflow/stages/clusters.h"
#include "photonflow/io/h5io.h"
#include "photonflow/stages/illuminate.h"
#include "photonflow/stages/photon_distribution.h"
#include "photonflow/stages/photon_pass.h"
#include "photonflow/io/stage_files.h"
#include "photonflow/geometry/scene_file.h"
#include "photonflow/io/h5_types.h"
#include "h5edit.h"
#include "support.h"

using namespace pf;
using test::TempDir;

namespace {

Provenance prov() {
  Provenance p;
  p.tool = "test";
  return p;
}

// A fresh copy of `src` in tmp (each case edits its own copy of the valid file).
std::string copy_of(const TempDir& tmp, const std::string& src) {
  static int n = 0;
  const std::string dst = tmp / ("case" + std::to_string(n++) + ".h5");
  std::filesystem::copy_file(src, dst);
  return dst;
}

using test::refused;

// The HDF5 records the tests edit whose compound types the library keeps to itself.
const h5::Compound& cluster_type() {
  static const h5::Compound t = [] {
    h5::Compound c(sizeof(pf_cluster));
    c.f32("centre", offsetof(pf_cluster, centre), 3).f32("radius", offsetof(pf_cluster, radius));
    c.i32("mesh", offsetof(pf_cluster, mesh)).i32("first", offsetof(pf_cluster, first));
    c.i32("count", offsetof(pf_cluster, count)).i32("padded_count", offsetof(pf_cluster, padded_count));
    return c;
  }();
  return t;
}

// Valid files of every stage of a small room (meshes 0 walls, 1 box, 2 sphere, 3 light).
struct Files {
  TempDir tmp{"inputs"};
  Scene scene = test::room_scene(PF_MAT_DIFFUSE, 16, 12);
  HitpointSet h;
  std::string scene_path, hp, ph, grid, clusters, dist, ppm;
  Files() {
    scene_path = tmp / "scene.h5";
    save_scene(scene, scene_path, prov());
    EyePassOptions eo;
    h = make_hitpoint_set(trace_hitpoints(scene, eo), eo.direct, scene.scene_id);
    hp = tmp / "hp.h5";
    save_hitpoints(h, hp, prov());
    PhotonSet p;
    p.first_pass = 0;
    p.scene_id = scene.scene_id;
    PhotonPassOptions po;
    po.photons = 2000;
    for (uint32_t pass = 0; pass < 2; ++pass) {
      PhotonPassResult r = trace_photons(scene, pass, po);
      p.append_pass(r.photons, r.emitted);
    }
    ph = tmp / "ph.h5";
    save_photons(p, ph, prov());
    GridSet g;
    g.pass_emitted = p.pass_emitted;
    g.scene_id = scene.scene_id;
    PhotonGridParams gp;
    gp.default_radius = 0.05f;
    gp.max_bins = 8;
    for (int k = 0; k < 2; ++k)
      g.grids.push_back(build_photon_grid(p.pass(k), int(scene.mesh_names.size()), gp));
    grid = tmp / "grid.h5";
    save_grids(g, grid, prov());
    clusters = tmp / "clusters.h5";
    save_clusters(cluster_kmeans(h, 8, 3, 1), clusters, prov());
    PhotonDistribution d = empty_photon_distribution(gp, scene.scene_id);
    for (int k = 0; k < 2; ++k) d.add_pass(p.pass(k), p.pass_emitted[size_t(k)], 4);
    dist = tmp / "dist.h5";
    save_photon_distribution(d, dist, prov());
    // A PPM state after the two passes (what illuminate and render --checkpoint write).
    HitpointSet state = h;
    for (int k = 0; k < 2; ++k) ppm_pass(scene, state, p.pass(k), p.pass_emitted[size_t(k)], {});
    ppm = tmp / "ppm.h5";
    save_hitpoints(state, ppm, prov());
  }
};

Files& files() {
  static Files f;
  return f;
}

// Loads a hitpoints file and accepts it for the room scene (where its indices meet the scene).
void accept_hitpoints(const std::string& path) {
  Files& f = files();
  HitpointSet h = load_hitpoints(path);
  Provenance p;
  accept_input(p, "hitpoints", path, h, f.scene, f.scene_path);
}
void accept_photons(const std::string& path) {
  Files& f = files();
  PhotonSet s = load_photons(path);
  Provenance p;
  accept_input(p, "photons", path, s, f.scene, f.scene_path);
}
void accept_grids(const std::string& path) {
  Files& f = files();
  GridSet g = load_grids(path);
  Provenance p;
  accept_input(p, "grid", path, g, f.scene, f.scene_path);
}

}  // namespace

TEST_CASE("the valid files of the fixture load and are accepted", "[inputs]") {
  Files& f = files();
  CHECK_NOTHROW(load_scene(f.scene_path));
  CHECK_NOTHROW(accept_hitpoints(f.hp));
  CHECK_NOTHROW(accept_photons(f.ph));
  CHECK_NOTHROW(accept_grids(f.grid));
  CHECK_NOTHROW(load_clusters(f.clusters, f.h));
  CHECK_NOTHROW(load_photon_distribution(f.dist));
  CHECK_NOTHROW(accept_hitpoints(f.ppm));
}

TEST_CASE("hitpoints.h5: indices out of range are refused", "[inputs][hitpoints]") {
  Files& f = files();
  const size_t K = f.scene.materials.size(), M = f.scene.mesh_names.size();
  auto hit = [&](const std::function<void(pf_hitpoint&)>& change) {
    const std::string p = copy_of(f.tmp, f.hp);
    test::edit_dataset<pf_hitpoint>(p, "/hitpoints", h5_type_hitpoint().id(),
                      [&](std::vector<pf_hitpoint>& v) { change(v[v.size() / 2]); });
    return p;
  };
  // The material index of the reviewer's crash (illuminate read materials[100000000]) and the
  // first index past the table; the same for mesh ids. The scene's tables bound them.
  for (int32_t bad : {int32_t(100000000), int32_t(K), int32_t(999)}) {
    const std::string p = hit([&](pf_hitpoint& x) { x.material = bad; });
    CHECK_NOTHROW(load_hitpoints(p));  // the file alone cannot know the scene's tables
    refused([&] { accept_hitpoints(p); }, p, "material id " + std::to_string(bad));
    refused([&] { check_against_scene(p, load_hitpoints(p), f.scene); }, p, "outside the scene's");
  }
  for (int32_t bad : {int32_t(M), int32_t(INT_MAX)}) {
    const std::string p = hit([&](pf_hitpoint& x) { x.mesh = bad; });
    refused([&] { accept_hitpoints(p); }, p, "mesh id " + std::to_string(bad));
  }
  // Negative ids, pixels outside the image, a non-finite position: refused by the load itself.
  refused([&] { load_hitpoints(hit([](pf_hitpoint& x) { x.mesh = -1; })); }, "case", "negative mesh");
  refused([&] { load_hitpoints(hit([](pf_hitpoint& x) { x.material = -7; })); }, "case",
          "negative material");
  // The first pixel past each edge of the 16 × 12 image (synthesis indexes y·width + x).
  REQUIRE((f.h.width == 16 && f.h.height == 12));
  refused([&] { load_hitpoints(hit([](pf_hitpoint& x) { x.pixel_y = 12; })); }, "case",
          "outside the image");
  refused([&] { load_hitpoints(hit([](pf_hitpoint& x) { x.pixel_x = 16; })); }, "case",
          "outside the image");
  refused([&] { load_hitpoints(hit([](pf_hitpoint& x) { x.pixel_x = -1; })); }, "case",
          "outside the image");
  refused([&] { load_hitpoints(hit([](pf_hitpoint& x) { x.pixel_y = -1; })); }, "case",
          "outside the image");
  refused([&] { load_hitpoints(hit([](pf_hitpoint& x) { x.position[1] = NAN; })); }, "case",
          "non-finite");
  // Attributes kept in an int: image size and pass count.
  const std::vector<std::pair<const char*, int64_t>> attrs = {
      {"width", 0},  {"width", int64_t(1) << 33},  {"height", -4},
      {"passes", -1}, {"passes", int64_t(1) << 32}, {"photons_emitted", -1}};
  for (auto [name, value] : attrs) {
    const std::string p = copy_of(f.tmp, f.hp);
    test::set_int_attr(p, "/", name, value);
    refused([&] { load_hitpoints(p); }, p, std::string("attribute ") + name);
  }
}

TEST_CASE("the gathers refuse hitpoints that index past the scene's tables", "[inputs][hitpoints]") {
  // In-process callers that skip accept_input: brdf() reads materials[hitpoint.material].
  Files& f = files();
  PhotonPassOptions po;
  po.photons = 2000;
  const PhotonPassResult pass = trace_photons(f.scene, 0, po);
  for (int32_t bad : {int32_t(f.scene.materials.size()), int32_t(100000000)}) {
    HitpointSet h = f.h;
    h.hitpoints[h.hitpoints.size() / 2].material = bad;
    PpmOptions ppm;
    for (GatherMethod m : {GatherMethod::Grid, GatherMethod::Flann}) {
      ppm.method = m;
      CHECK_THROWS_WITH(ppm_pass(f.scene, h, pass.photons, pass.emitted, ppm),
                        Catch::Contains("material id " + std::to_string(bad)));
    }
    CHECK_THROWS_WITH(classic_estimate(f.scene, h, pass.photons, pass.emitted, ClassicOptions{}),
                      Catch::Contains("material id " + std::to_string(bad)));
    CHECK(h.passes == 0);  // refused before any gather
  }
}

TEST_CASE("photons.h5: indices out of range are refused", "[inputs][photons]") {
  Files& f = files();
  const size_t M = f.scene.mesh_names.size();
  auto photon = [&](const std::function<void(pf_photon&)>& change) {
    const std::string p = copy_of(f.tmp, f.ph);
    test::edit_dataset<pf_photon>(p, "/photons", h5_type_photon().id(),
                    [&](std::vector<pf_photon>& v) { change(v[v.size() - 3]); });
    return p;
  };
  for (int32_t bad : {int32_t(M), int32_t(1000000)}) {
    const std::string p = photon([&](pf_photon& x) { x.mesh = bad; });
    CHECK_NOTHROW(load_photons(p));
    refused([&] { accept_photons(p); }, p, "mesh id " + std::to_string(bad));
  }
  refused([&] { load_photons(photon([](pf_photon& x) { x.mesh = -2; })); }, "case", "negative mesh");
  refused([&] { load_photons(photon([](pf_photon& x) { x.position[0] = INFINITY; })); }, "case",
          "non-finite");
  // The pass index the int32 overflow of `trace-photons --first-pass 2147483647 --passes 2` stored.
  refused([&] { load_photons(photon([](pf_photon& x) { x.pass = INT_MIN; })); }, "case",
          "is stored in pass 1");
  {
    const std::string p = copy_of(f.tmp, f.ph);
    test::set_int_attr(p, "/", "first_pass", -1);
    refused([&] { load_photons(p); }, p, "first_pass");
    const std::string q = copy_of(f.tmp, f.ph);
    test::set_int_attr(q, "/", "first_pass", INT_MAX);  // two passes: INT_MAX and INT_MAX + 1
    refused([&] { load_photons(q); }, q, "run past 2^31-1");
  }
  {
    const std::string p = copy_of(f.tmp, f.ph);
    test::edit_dataset<uint64_t>(p, "/pass_begin", H5T_NATIVE_UINT64, [](std::vector<uint64_t>& v) { v[1] = 1ull << 40; });
    refused([&] { load_photons(p); }, p, "pass table");
  }
}

TEST_CASE("grid.h5: headers, bin tables, order and mesh count out of range are refused",
          "[inputs][grid]") {
  Files& f = files();
  const GridSet valid = load_grids(f.grid);
  const std::vector<pf_mesh_grid>& mg = valid.grids[1].mesh_grid;
  size_t full = 0;  // a mesh with photons
  while (full < mg.size() && mg[full].photon_count == 0) ++full;
  REQUIRE(full < mg.size());
  auto header = [&](const std::function<void(pf_mesh_grid&)>& change, const std::string& needle) {
    const std::string p = copy_of(f.tmp, f.grid);
    test::edit_dataset<pf_mesh_grid>(p, "/pass1/mesh_grid", h5_type_mesh_grid().id(),
                       [&](std::vector<pf_mesh_grid>& v) { change(v[full]); });
    refused([&] { load_grids(p); }, p, needle);
  };
  header([](pf_mesh_grid& g) { g.nx += 1000000; }, "mesh");
  header([](pf_mesh_grid& g) { g.nx = g.ny = -1; }, "bins per axis");  // (−1)·(−1) = 1 bin
  header([](pf_mesh_grid& g) { g.nx = g.ny = g.nz = 1 << 22; }, "more than 2^28 bins");  // wraps
  header([](pf_mesh_grid& g) { g.first_bin = -5; }, "first_bin");
  header([](pf_mesh_grid& g) { g.first_bin += 1000000; }, "first_bin");
  header([](pf_mesh_grid& g) { g.first_photon += 7; }, "first_photon");
  header([](pf_mesh_grid& g) { g.photon_count += 100000; }, "");
  header([](pf_mesh_grid& g) { g.photon_count = 0; }, "photon_count");
  header([](pf_mesh_grid& g) { g.bin_size = 0.f; }, "bin size");
  auto ints = [&](const char* dset, const std::function<void(std::vector<int32_t>&)>& change,
                  const std::string& needle) {
    const std::string p = copy_of(f.tmp, f.grid);
    test::edit_dataset<int32_t>(p, dset, H5T_NATIVE_INT32, change);
    refused([&] { load_grids(p); }, p, needle);
  };
  const int32_t n = int32_t(valid.grids[1].photons.size());
  const size_t mid = size_t(mg[full].first_bin) + 1;  // an inner entry of a mesh with photons
  ints("/pass1/cell_start", [&](std::vector<int32_t>& v) { v[mid] = n + 5; }, "cell_start");
  ints("/pass1/cell_start", [&](std::vector<int32_t>& v) { v[mid] = -1; }, "cell_start");
  ints("/pass1/order", [&](std::vector<int32_t>& v) { v[0] = n; }, "order");
  ints("/pass1/order", [&](std::vector<int32_t>& v) { v[0] = -3; }, "order");
  ints("/pass1/order", [&](std::vector<int32_t>& v) { v[1] = v[0]; }, "order");
  {  // a photon sorted into another mesh's range
    const std::string p = copy_of(f.tmp, f.grid);
    test::edit_dataset<pf_photon>(p, "/pass1/photons", h5_type_photon().id(), [&](std::vector<pf_photon>& v) {
      v[size_t(mg[full].first_photon)].mesh = int32_t(full) + 1;
    });
    refused([&] { load_grids(p); }, p, "grid of another mesh");
  }
  const std::vector<std::tuple<const char*, const char*, int64_t>> attrs = {
      {"/", "first_pass", -1}, {"/", "first_pass", int64_t(1) << 31},
      {"/pass1", "max_bins", 0}, {"/pass1", "max_bins", int64_t(1) << 30}};
  for (auto [obj, name, value] : attrs) {
    const std::string p = copy_of(f.tmp, f.grid);
    test::set_int_attr(p, obj, name, value);
    refused([&] { load_grids(p); }, p, name);
  }
  {  // grids for more meshes than the scene has (a grid of another scene whose id was copied)
    GridSet g = valid;
    g.grids[0] = build_photon_grid(g.grids[0].photons, int(f.scene.mesh_names.size()) + 2,
                                   g.grids[0].params);
    const std::string p = f.tmp / "grid-meshes.h5";
    save_grids(g, p, prov());
    CHECK_NOTHROW(load_grids(p));
    refused([&] { accept_grids(p); }, p, "the scene has 4");
  }
}

TEST_CASE("scene.h5: indices out of range are refused", "[inputs][scene]") {
  Files& f = files();
  const int32_t T = int32_t(f.scene.triangles.size()), N = int32_t(f.scene.kd.nodes.size());
  // Checked before scene_id (which every edit also breaks), so the needle names the field.
  auto field = [&](const char* dset, hid_t type, auto change, const std::string& needle) {
    const std::string p = copy_of(f.tmp, f.scene_path);
    change(p, dset, type);
    refused([&] { load_scene(p); }, p, needle);
  };
  auto tri = [&](const std::function<void(pf_triangle&)>& c, const std::string& needle) {
    field("/geometry/triangles", h5_type_triangle().id(),
          [&](const std::string& p, const char* d, hid_t t) {
            test::edit_dataset<pf_triangle>(p, d, t, [&](std::vector<pf_triangle>& v) { c(v[v.size() / 3]); });
          },
          needle);
  };
  tri([](pf_triangle& t) { t.material = 100000000; }, "material id is out of range");
  tri([](pf_triangle& t) { t.material = -1; }, "material id is out of range");
  tri([](pf_triangle& t) { t.mesh = 4; }, "mesh id is out of range");
  tri([](pf_triangle& t) { t.mesh = INT_MIN; }, "mesh id is out of range");
  auto node = [&](int32_t which, const std::function<void(pf_kd_node&)>& c) {
    field("/kdtree/nodes", h5_type_kd_node().id(),
          [&](const std::string& p, const char* d, hid_t t) {
            test::edit_dataset<pf_kd_node>(p, d, t, [&](std::vector<pf_kd_node>& v) { c(v[size_t(which)]); });
          },
          "invalid kd-tree");
  };
  int32_t leaf = 0, inner = 0;
  while (f.scene.kd.nodes[size_t(leaf)].axis != PF_KD_LEAF) ++leaf;
  REQUIRE(f.scene.kd.nodes[size_t(inner)].axis != PF_KD_LEAF);
  node(inner, [&](pf_kd_node& n) { n.left = N; });
  node(inner, [](pf_kd_node& n) { n.right = -5; });
  node(inner, [](pf_kd_node& n) { n.axis = 7; });
  node(leaf, [](pf_kd_node& n) { n.first = INT_MAX - 1; });
  node(leaf, [](pf_kd_node& n) { n.count = 1 << 30; });
  node(leaf, [](pf_kd_node& n) { n.first = -2; });
  for (int face = 0; face < 6; ++face) node(leaf, [&](pf_kd_node& n) { n.ropes[face] = N + face; });
  field("/kdtree/leaf_tris", H5T_NATIVE_INT32,
        [&](const std::string& p, const char* d, hid_t t) {
          test::edit_dataset<int32_t>(p, d, t, [&](std::vector<int32_t>& v) { v[0] = T; });
        },
        "triangle index out of range");
  field("/kdtree/leaf_tris", H5T_NATIVE_INT32,
        [&](const std::string& p, const char* d, hid_t t) {
          test::edit_dataset<int32_t>(p, d, t, [&](std::vector<int32_t>& v) { v.back() = -1; });
        },
        "triangle index out of range");
  auto light = [&](const std::function<void(pf_light&)>& c, const std::string& needle) {
    field("/lights/lights", h5_type_light().id(),
          [&](const std::string& p, const char* d, hid_t t) {
            test::edit_dataset<pf_light>(p, d, t, [&](std::vector<pf_light>& v) { c(v[0]); });
          },
          needle);
  };
  light([&](pf_light& l) { l.triangle = T; }, "triangle id is out of range");
  light([](pf_light& l) { l.triangle = -1; }, "triangle id is out of range");
  light([](pf_light& l) { l.type = 5; }, "unknown type 5");
  field("/materials/materials", h5_type_material().id(),
        [&](const std::string& p, const char* d, hid_t t) {
          test::edit_dataset<pf_material>(p, d, t, [](std::vector<pf_material>& v) { v[1].type = 42; });
        },
        "unknown type 42");
  for (int32_t w : {0, -640, 1 << 20})
    field("/camera", h5_type_camera().id(),
          [&](const std::string& p, const char* d, hid_t t) {
            test::edit_dataset<pf_camera>(p, d, t, [&](std::vector<pf_camera>& v) { v[0].width = w; });
          },
          "camera image size");
}

TEST_CASE("clusters.h5 and photon_distribution.h5: ranges out of bounds are refused",
          "[inputs][clusters]") {
  Files& f = files();
  const int32_t H = int32_t(f.h.hitpoints.size());
  auto cluster = [&](const std::function<void(pf_cluster&)>& c) {
    const std::string p = copy_of(f.tmp, f.clusters);
    test::edit_dataset<pf_cluster>(p, "/clusters", cluster_type().id(),
                     [&](std::vector<pf_cluster>& v) { c(v[v.size() / 2]); });
    refused([&] { load_clusters(p, f.h); }, p, "not a valid clustering");
  };
  cluster([](pf_cluster& c) { c.mesh = 99; });
  cluster([](pf_cluster& c) { c.mesh = -1; });
  cluster([](pf_cluster& c) { c.first = -1; });
  cluster([](pf_cluster& c) { c.first += 1 << 30; });
  cluster([](pf_cluster& c) { c.count = INT_MAX; });
  cluster([](pf_cluster& c) { c.padded_count = -8; });
  for (int32_t bad : {H, -7, INT_MAX}) {
    const std::string p = copy_of(f.tmp, f.clusters);
    test::edit_dataset<int32_t>(p, "/order", H5T_NATIVE_INT32, [&](std::vector<int32_t>& v) { v[0] = bad; });
    refused([&] { load_clusters(p, f.h); }, p, "not a valid clustering");
  }
  auto dist = [&](const std::function<void(pf_mesh_grid&)>& c, const std::string& needle) {
    const std::string p = copy_of(f.tmp, f.dist);
    test::edit_dataset<pf_mesh_grid>(p, "/mesh_grid", h5_type_mesh_grid().id(),
                       [&](std::vector<pf_mesh_grid>& v) { c(v[0]); });
    refused([&] { load_photon_distribution(p); }, p, needle);
  };
  dist([](pf_mesh_grid& g) { g.first_bin = -1; }, "not contiguous");
  dist([](pf_mesh_grid& g) { g.nx = -1; }, "malformed grid header");
  // 2^22 bins per axis: 2^66 bins, which a size_t product wraps to a small number.
  dist([](pf_mesh_grid& g) { g.nx = g.ny = g.nz = 1 << 22; }, "malformed grid header");
  const std::string p = copy_of(f.tmp, f.dist);
  test::set_int_attr(p, "/", "passes", int64_t(1) << 32);
  refused([&] { load_photon_distribution(p); }, p, "passes");
}

// ---- values (validate.h): non-finite, out of range, inconsistent with the rest of the file ----
// Each edit is one a user's script could make (h5edit.h); where the edited data is covered by the
// scene id, the id is recomputed as docs/FORMATS.md describes, so only the value checks can refuse.

namespace {

// A copy of the fixture's `src` with dataset `dset` edited; for scene.h5, the id recomputed.
template <class T>
std::string edited(const std::string& src, const char* dset, hid_t type,
                   const std::function<void(std::vector<T>&)>& change, bool refresh_id = false) {
  const std::string p = copy_of(files().tmp, src);
  test::edit_dataset<T>(p, dset, type, change);
  if (refresh_id) test::refresh_scene_id(p);
  return p;
}

std::string scene_edit_triangles(const std::function<void(std::vector<pf_triangle>&)>& c) {
  return edited<pf_triangle>(files().scene_path, "/geometry/triangles", h5_type_triangle().id(), c,
                             true);
}

}  // namespace

TEST_CASE("scene.h5: non-finite and huge vertices are refused by every stage, naming the element",
          "[inputs][scene][values]") {
  // Audit (issue 26) finding 2: render exited 1 with "internal error: photon grid: default_radius
  // must be positive and finite" and trace-hitpoints wrote non-finite radii.
  Files& f = files();
  const size_t k = f.scene.triangles.size() / 2;
  const std::string at = "geometry/triangles[" + std::to_string(k) + "]";
  const std::string nan_file = scene_edit_triangles([&](auto& v) { v[k].v1[0] = NAN; });
  refused([&] { load_scene(nan_file); }, nan_file, at + ".v1[0] is not finite (nan)");
  const std::string huge = scene_edit_triangles([&](auto& v) { v[k].v2[1] = 1e38f; });
  refused([&] { load_scene(huge); }, huge, at + ".v2[1] = 9.99999968e+37 is outside [-1e+12, 1e+12]");
  const std::string inf = scene_edit_triangles([&](auto& v) { v[k].v0[2] = -INFINITY; });
  refused([&] { load_scene(inf); }, inf, at + ".v0[2] is not finite (-inf)");
  const std::string normal = scene_edit_triangles([&](auto& v) { v[k].n1[0] = v[k].n1[1] = v[k].n1[2] = 0.f; });
  refused([&] { load_scene(normal); }, normal, at + ".n1 is not a unit vector");
  const std::string normal_nan = scene_edit_triangles([&](auto& v) { v[k].n2[2] = NAN; });
  refused([&] { load_scene(normal_nan); }, normal_nan, at + ".n2[2] is not finite");
  // The tools: one line naming the file, exit 2, no output.
  for (const std::string& scene : {nan_file, huge}) {
    for (const char* tool : {"trace-hitpoints", "render"}) {
      INFO(tool << " " << scene);
      const std::string out = f.tmp / (std::string(tool) + "-out") +
                              (std::string(tool) == "render" ? ".exr" : ".h5");
      const test::ToolRun r = test::run_tool(
          tool, "--scene " + scene + " -o " + out + (std::string(tool) == "render" ? " --passes 1 --photons 1000" : ""),
          f.tmp);
      CHECK(r.exit_code == kExitBadInput);
      CHECK(r.err.find(scene + ": " + at) != std::string::npos);
      CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
      CHECK_FALSE(std::filesystem::exists(out));
    }
  }
}

TEST_CASE("scene.h5: materials, lights, the light CDF and the camera must hold usable values",
          "[inputs][scene][values]") {
  Files& f = files();
  REQUIRE(f.scene.lights.size() >= 3);
  const size_t emitter = size_t(f.scene.triangles[size_t(f.scene.lights[0].triangle)].material);
  auto material = [&](const std::function<void(pf_material&)>& c, size_t which) {
    return edited<pf_material>(f.scene_path, "/materials/materials", h5_type_material().id(),
                               [&](auto& v) { c(v[which]); }, true);
  };
  const std::string m = "materials/materials[" + std::to_string(emitter) + "]";
  std::string p = material([](pf_material& x) { x.color[1] = NAN; }, emitter);
  refused([&] { load_scene(p); }, p, m + ".color[1] is not finite (nan)");
  p = material([](pf_material& x) { x.emission[0] = NAN; }, emitter);
  refused([&] { load_scene(p); }, p, m + ".emission[0] is not finite (nan)");
  p = material([](pf_material& x) { x.emission[2] = -1.f; }, emitter);
  refused([&] { load_scene(p); }, p, m + ".emission[2] = -1 is outside");
  p = material([](pf_material& x) { x.ior = 0.f; }, 0);
  refused([&] { load_scene(p); }, p, "materials/materials[0].ior = 0 is outside");

  auto light = [&](const std::function<void(pf_light&)>& c) {
    return edited<pf_light>(f.scene_path, "/lights/lights", h5_type_light().id(),
                            [&](auto& v) { c(v[1]); }, true);
  };
  p = light([](pf_light& x) { x.radiance[0] = NAN; });
  refused([&] { load_scene(p); }, p, "lights/lights[1].radiance[0] is not finite (nan)");
  p = light([](pf_light& x) { x.power *= 2.f; });
  refused([&] { load_scene(p); }, p, "lights/lights[1] (power");
  p = light([](pf_light& x) { x.position[0] += 0.25f; });
  refused([&] { load_scene(p); }, p, "differs from the light its triangle and material give");

  // The CDF is not covered by the scene id: no id to recompute.
  auto cdf = [&](const std::function<void(std::vector<float>&)>& c) {
    return edited<float>(f.scene_path, "/lights/cdf", H5T_NATIVE_FLOAT, c);
  };
  p = cdf([](std::vector<float>& v) { v[0] = NAN; });
  refused([&] { load_scene(p); }, p, "lights/cdf[0] is not finite (nan)");
  p = cdf([](std::vector<float>& v) { std::swap(v[0], v[1]); });
  refused([&] { load_scene(p); }, p, "lights/cdf[1] = ");
  refused([&] { load_scene(p); }, p, "is below lights/cdf[0]");
  p = cdf([](std::vector<float>& v) { v.back() = 0.999f; });
  refused([&] { load_scene(p); }, p, "the last entry must be 1");
  p = cdf([](std::vector<float>& v) { v[0] *= 0.5f; });  // still increasing, but not the powers
  refused([&] { load_scene(p); }, p, "lights/cdf[0] = ");
  refused([&] { load_scene(p); }, p, "differs from the lights' power fraction");

  auto camera = [&](const std::function<void(pf_camera&)>& c) {
    return edited<pf_camera>(f.scene_path, "/camera", h5_type_camera().id(),
                             [&](auto& v) { c(v[0]); }, true);
  };
  for (float fov : {NAN, 0.f, 180.f, -30.f}) {
    p = camera([&](pf_camera& c) { c.fov_y_deg = fov; });
    refused([&] { load_scene(p); }, p, "camera.fov_y_deg");
  }
  p = camera([](pf_camera& c) { std::copy(c.eye, c.eye + 3, c.look_at); });
  refused([&] { load_scene(p); }, p, "do not give a view direction");
  p = camera([](pf_camera& c) {
    for (int a = 0; a < 3; ++a) c.up[a] = c.look_at[a] - c.eye[a];
  });
  refused([&] { load_scene(p); }, p, "camera.up");
  refused([&] { load_scene(p); }, p, "is parallel to the view direction");
  p = camera([](pf_camera& c) { c.eye[1] = NAN; });
  refused([&] { load_scene(p); }, p, "camera.eye[1] is not finite");
}

TEST_CASE("scene.h5: Havel-Herout planes and kd-tree leaves must match the triangles",
          "[inputs][scene][values]") {
  // Derived data the scene id does not cover: load_scene recomputes the planes and checks every
  // leaf's triangles against its box (docs/FORMATS.md).
  Files& f = files();
  auto hh = [&](const std::function<void(std::vector<pf_hh_triangle>&)>& c) {
    return edited<pf_hh_triangle>(f.scene_path, "/geometry/hh", h5_type_hh_triangle().id(), c);
  };
  std::string p = hh([](auto& v) { std::swap(v[3], v[40]); });
  refused([&] { load_scene(p); }, p, "geometry/hh[3].n does not match the Havel–Herout plane");
  p = hh([](auto& v) { v[7].n2[3] += 0.5f; });
  refused([&] { load_scene(p); }, p, "geometry/hh[7].n2 does not match");
  p = hh([](auto& v) { v[9].n1[0] = NAN; });
  refused([&] { load_scene(p); }, p, "geometry/hh[9].n1[0] is not finite");

  // A leaf entry replaced by a triangle far from the leaf's box.
  const KdTree& kd = f.scene.kd;
  const auto& tris = f.scene.triangles;
  auto apart = [&](const pf_triangle& t, const pf_kd_node& n) {
    for (int a = 0; a < 3; ++a) {
      const float lo = std::min({t.v0[a], t.v1[a], t.v2[a]}), hi = std::max({t.v0[a], t.v1[a], t.v2[a]});
      if (hi < n.lo[a] - 0.1f || lo > n.hi[a] + 0.1f) return true;
    }
    return false;
  };
  size_t entry = SIZE_MAX;
  int32_t far = -1;
  for (const pf_kd_node& n : kd.nodes) {
    if (n.axis != PF_KD_LEAF || n.count == 0) continue;
    for (size_t t = 0; t < tris.size() && far < 0; ++t)
      if (apart(tris[t], n)) far = int32_t(t);
    if (far >= 0) {
      entry = size_t(n.first);
      break;
    }
  }
  REQUIRE(far >= 0);
  p = edited<int32_t>(f.scene_path, "/kdtree/leaf_tris", H5T_NATIVE_INT32,
                      [&](std::vector<int32_t>& v) { v[entry] = far; });
  refused([&] { load_scene(p); }, p, "kdtree/leaf_tris[" + std::to_string(entry) + "] = " +
                                         std::to_string(far) + ": the triangle lies outside the box");
  // A triangle listed once, its entry replaced by another triangle of the same leaf: rays would
  // pass through it.
  std::vector<int> listed(tris.size(), 0);
  for (int32_t t : kd.leaf_tris) ++listed[size_t(t)];
  size_t from = SIZE_MAX, to = SIZE_MAX;
  for (const pf_kd_node& n : kd.nodes) {
    if (n.axis != PF_KD_LEAF || n.count < 2) continue;
    for (int32_t j = n.first; j < n.first + n.count && from == SIZE_MAX; ++j)
      if (listed[size_t(kd.leaf_tris[size_t(j)])] == 1) {
        from = size_t(j);
        to = size_t(j == n.first ? j + 1 : n.first);
      }
    if (from != SIZE_MAX) break;
  }
  REQUIRE(from != SIZE_MAX);
  const int32_t lost = kd.leaf_tris[from];
  p = edited<int32_t>(f.scene_path, "/kdtree/leaf_tris", H5T_NATIVE_INT32,
                      [&](std::vector<int32_t>& v) { v[from] = v[to]; });
  refused([&] { load_scene(p); }, p, "geometry/triangles[" + std::to_string(lost) + "] is in no kd-tree leaf");
}

TEST_CASE("hitpoints.h5: non-finite or negative PPM state, image layers and attributes are refused",
          "[inputs][hitpoints][values]") {
  // Audit finding 3: each of these gave NaN pixels with exit 0 (a negative N in a checkpoint
  // resumed into 769 NaN pixels).
  Files& f = files();
  const size_t i = f.h.hitpoints.size() / 2;
  const std::string at = "hitpoints[" + std::to_string(i) + "]";
  auto hit = [&](const std::string& src, const std::function<void(pf_hitpoint&)>& c) {
    return edited<pf_hitpoint>(src, "/hitpoints", h5_type_hitpoint().id(),
                               [&](auto& v) { c(v[i]); });
  };
  std::string p = hit(f.hp, [](pf_hitpoint& x) { x.radius = NAN; });
  refused([&] { load_hitpoints(p); }, p, at + ".radius is not finite (nan)");
  p = hit(f.ppm, [](pf_hitpoint& x) { x.n_photons = NAN; });
  refused([&] { load_hitpoints(p); }, p, at + ".n_photons is not finite (nan)");
  p = hit(f.ppm, [](pf_hitpoint& x) { x.n_photons = -1.f; });  // the checkpoint of the audit
  refused([&] { load_hitpoints(p); }, p, at + ".n_photons = -1 is outside");
  p = hit(f.ppm, [](pf_hitpoint& x) { x.flux[1] = NAN; });
  refused([&] { load_hitpoints(p); }, p, at + ".flux[1] is not finite (nan)");
  p = hit(f.ppm, [](pf_hitpoint& x) { x.radius = 0.f; });
  refused([&] { load_hitpoints(p); }, p, at + ".radius = 0 is outside");
  p = hit(f.ppm, [](pf_hitpoint& x) { x.radius = 1e-30f; });  // R² is 0 in float
  refused([&] { load_hitpoints(p); }, p, at + ".radius = ");
  p = hit(f.ppm, [](pf_hitpoint& x) { x.weight[2] = INFINITY; });
  refused([&] { load_hitpoints(p); }, p, at + ".weight[2] is not finite (inf)");
  p = hit(f.ppm, [](pf_hitpoint& x) { x.normal[0] = NAN; });
  refused([&] { load_hitpoints(p); }, p, at + ".normal[0] is not finite");
  p = hit(f.hp, [](pf_hitpoint& x) { x.n_photons = 3.f; });  // a fresh state has N = 0
  refused([&] { load_hitpoints(p); }, p, "of a fresh state");
  for (const char* layer : {"/image/emitted", "/image/direct"}) {
    p = edited<float>(f.ppm, layer, H5T_NATIVE_FLOAT, [](std::vector<float>& v) { v[5] = NAN; });
    refused([&] { load_hitpoints(p); }, p,
            std::string(layer + 1) + "[y 0, x 1, channel 2] is not finite (nan)");
  }
  for (double r0 : {double(NAN), 0.0, -0.5, 1e300}) {
    p = copy_of(f.tmp, f.ppm);
    test::set_double_attr(p, "/", "radius0", r0);
    refused([&] { load_hitpoints(p); }, p, "attribute radius0");
  }
  for (const char* name : {"bogus", "PPM", ""}) {
    p = copy_of(f.tmp, f.ppm);
    test::set_string_attr(p, "/", "estimator", name);
    refused([&] { load_hitpoints(p); }, p, "attribute estimator '" + std::string(name) + "'");
  }
  {  // a 2-pass state with 0 photons emitted; a fresh state with passes
    p = copy_of(f.tmp, f.ppm);
    test::set_int_attr(p, "/", "photons_emitted", 0);
    refused([&] { load_hitpoints(p); }, p, "photons_emitted = 0 is not the count of 2 passes");
    p = copy_of(f.tmp, f.hp);
    test::set_int_attr(p, "/", "passes", 2);
    refused([&] { load_hitpoints(p); }, p, "of a fresh state");
    p = copy_of(f.tmp, f.ppm);
    test::set_string_attr(p, "/", "estimator", "classic");  // a classic estimate has one pass
    refused([&] { load_hitpoints(p); }, p, "a classic estimate has exactly 1 pass");
  }
}

TEST_CASE("hitpoints.h5: estimator sppm holds one hitpoint per pixel and allows pixels without "
          "a surface", "[inputs][hitpoints][values]") {
  Files& f = files();
  HitpointSet s = f.h;
  s.estimator = "sppm";
  std::vector<pf_hitpoint> per_pixel(size_t(s.width) * size_t(s.height));
  std::vector<bool> have(per_pixel.size(), false);
  for (const pf_hitpoint& hp : s.hitpoints) {
    const size_t o = size_t(hp.pixel_y) * size_t(s.width) + size_t(hp.pixel_x);
    if (!have[o]) per_pixel[o] = hp;
    have[o] = true;
  }
  for (size_t o = 0; o < per_pixel.size(); ++o)
    if (!have[o] || o % 7 == 0) {  // a pixel whose eye path found no diffuse surface
      pf_hitpoint& hp = per_pixel[o];
      hp = pf_hitpoint{};
      hp.pixel_x = int32_t(o % size_t(s.width));
      hp.pixel_y = int32_t(o / size_t(s.width));
      hp.mesh = hp.material = -1;
      hp.radius = s.radius0;
    }
  s.hitpoints = per_pixel;
  const std::string ok = f.tmp / "sppm.h5";
  save_hitpoints(s, ok, prov());
  CHECK_NOTHROW(load_hitpoints(ok));
  auto bad = [&](const std::function<void(HitpointSet&)>& c, const std::string& needle) {
    HitpointSet b = s;
    c(b);
    const std::string p = f.tmp / "sppm-bad.h5";
    std::filesystem::remove(p);
    {
      const UncheckedWritesForTests damaged;  // the writer itself refuses these states
      save_hitpoints(b, p, prov());
    }
    refused([&] { load_hitpoints(p); }, p, needle);
  };
  bad([](HitpointSet& b) { b.hitpoints[0].n_photons = 1.f; }, "has no surface (mesh and material -1) but N or tau");
  bad([](HitpointSet& b) { b.hitpoints[7].flux[2] = 0.5f; }, "has no surface");
  bad([](HitpointSet& b) { b.hitpoints[0].material = 0; }, "negative mesh");
  bad([](HitpointSet& b) { b.hitpoints.pop_back(); }, "one hitpoint per pixel");
  bad([](HitpointSet& b) { b.hitpoints[1].pixel_x = 0; }, "has a second hitpoint");
  bad([](HitpointSet& b) { b.estimator = "ppm"; b.passes = 1; b.photons_emitted = 10; },
      "negative mesh");  // mesh -1 only in an SPPM state
}

TEST_CASE("photons.h5 and grid.h5: non-finite flux, wrapping counts and photons outside their "
          "bins are refused", "[inputs][photons][grid][values]") {
  Files& f = files();
  std::string p = edited<pf_photon>(f.ph, "/photons", h5_type_photon().id(),
                                    [](auto& v) { v[10].flux[0] = NAN; });
  refused([&] { load_photons(p); }, p, "photons[10].flux[0] is not finite (nan)");
  p = edited<pf_photon>(f.ph, "/photons", h5_type_photon().id(), [](auto& v) { v[11].dir[0] = 7.f; });
  refused([&] { load_photons(p); }, p, "photons[11].dir is not a unit vector");
  p = edited<pf_photon>(f.ph, "/photons", h5_type_photon().id(), [](auto& v) { v[12].flags = 12; });
  refused([&] { load_photons(p); }, p, "photons[12].flags = 12");
  for (const std::string& file : {f.ph, f.grid}) {
    p = edited<uint64_t>(file, "/pass_emitted", H5T_NATIVE_UINT64,
                         [](std::vector<uint64_t>& v) { v[0] = UINT64_MAX; });  // 2^64 − 1
    const auto load = [&] { file == f.ph ? (void)load_photons(p) : (void)load_grids(p); };
    refused(load, p, "pass_emitted[0] = 18446744073709551615 is outside [1, 4294967295]");
    p = edited<uint64_t>(file, "/pass_emitted", H5T_NATIVE_UINT64,
                         [](std::vector<uint64_t>& v) { v[1] = 0; });  // stored photons, emitted none
    refused(load, p, "pass_emitted[1] = 0 is outside");
    p = edited<uint64_t>(file, "/pass_emitted", H5T_NATIVE_UINT64,
                         [](std::vector<uint64_t>& v) { v[1] = uint64_t(1) << 32; });
    // More than a pass's --photons (a uint32) can emit: counts bounded per pass never wrap.
    refused(load, p, "pass_emitted[1] = 4294967296 is outside [1, 4294967295]");
  }
  p = edited<pf_photon>(f.grid, "/pass1/photons", h5_type_photon().id(),
                        [](auto& v) { v[3].flux[2] = INFINITY; });
  refused([&] { load_grids(p); }, p, "pass1/photons[3].flux[2] is not finite (inf)");
  {  // a grid of two passes whose pass_emitted lists one: the second pass was dropped silently
    p = copy_of(f.tmp, f.grid);
    std::vector<uint64_t> e = test::read_dataset<uint64_t>(p, "/pass_emitted", H5T_NATIVE_UINT64);
    e.pop_back();
    test::rewrite_dataset(p, "/pass_emitted", H5T_NATIVE_UINT64, e);
    refused([&] { load_grids(p); }, p, "2 /pass<k> groups but pass_emitted has 1 entries");
  }
  {  // two photons of one mesh swapped between bins: each lies outside the bin that lists it
    const GridSet g = load_grids(f.grid);
    const PhotonGrid& grid = g.grids[1];
    int32_t a = -1, b = -1;
    for (const pf_mesh_grid& mg : grid.mesh_grid) {
      if (mg.photon_count < 2) continue;
      a = mg.first_photon;
      const int bin_a = pf_grid_bin(&mg, grid.photons[size_t(a)].position[0],
                                    grid.photons[size_t(a)].position[1], grid.photons[size_t(a)].position[2]);
      for (int32_t j = a + 1; j < mg.first_photon + mg.photon_count && b < 0; ++j)
        if (pf_grid_bin(&mg, grid.photons[size_t(j)].position[0], grid.photons[size_t(j)].position[1],
                        grid.photons[size_t(j)].position[2]) != bin_a)
          b = j;
      if (b >= 0) break;
    }
    REQUIRE(b >= 0);
    p = edited<pf_photon>(f.grid, "/pass1/photons", h5_type_photon().id(),
                          [&](auto& v) { std::swap(v[size_t(a)], v[size_t(b)]); });
    refused([&] { load_grids(p); }, p, "photon " + std::to_string(a) + " lies outside bin");
  }
}

TEST_CASE("clusters.h5 and photon_distribution.h5: non-finite centres and counts that do not add "
          "up are refused", "[inputs][clusters][values]") {
  Files& f = files();
  std::string p = edited<pf_cluster>(f.clusters, "/clusters", cluster_type().id(),
                                     [](auto& v) { v[2].centre[0] = NAN; });
  // Every method must gather the same photons: a NaN centre made the clustered gathers miss them.
  refused([&] { load_clusters(p, f.h); }, p, "clusters[2].centre[0] is not finite (nan)");
  p = edited<pf_cluster>(f.clusters, "/clusters", cluster_type().id(),
                         [](auto& v) { v[1].radius = -1.f; });
  refused([&] { load_clusters(p, f.h); }, p, "clusters[1].radius = -1 is outside");
  p = copy_of(f.tmp, f.clusters);
  test::set_int_attr(p, "/", "wg_size", (int64_t(1) << 32) + 8);  // int(...) was 8
  refused([&] { load_clusters(p, f.h); }, p, "attribute wg_size");
  p = copy_of(f.tmp, f.clusters);
  test::set_string_attr(p, "/", "method", "bogus");
  refused([&] { load_clusters(p, f.h); }, p, "attribute method 'bogus'");
  p = edited<pf_mesh_grid>(f.dist, "/mesh_grid", h5_type_mesh_grid().id(),
                           [](auto& v) { v[0].photon_count += 1; });
  refused([&] { load_photon_distribution(p); }, p, "mesh_grid[0].photon_count");
  refused([&] { load_photon_distribution(p); }, p, "is not the sum of its bins' counts");
  p = copy_of(f.tmp, f.dist);
  test::set_double_attr(p, "/", "default_radius", NAN);
  refused([&] { load_photon_distribution(p); }, p, "attribute default_radius");
}
