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

#include "photonflow/clusters.h"
#include "photonflow/h5io.h"
#include "photonflow/illuminate.h"
#include "photonflow/photon_distribution.h"
#include "photonflow/photon_pass.h"
#include "photonflow/stage_files.h"
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

// `load()` throws an InputError whose one line names `file` and contains `needle`.
void refused(const std::function<void()>& load, const std::string& file, const std::string& needle) {
  try {
    load();
    FAIL_CHECK("accepted: " << file << " (expected '" << needle << "')");
  } catch (const InputError& e) {
    const std::string msg = e.what();
    INFO(msg);
    CHECK(msg.find(file) != std::string::npos);
    CHECK(msg.find(needle) != std::string::npos);
    CHECK(msg.find('\n') == std::string::npos);
  }
}

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
  std::string scene_path, hp, ph, grid, clusters, dist;
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
