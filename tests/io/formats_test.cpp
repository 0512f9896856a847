// Round trip of every dataset of every intermediate (scene, hitpoints, photons, grid), and the
// readers' consistency checks.
#include <catch2/catch.hpp>

#include <cstring>

#include "photonflow/io/validate.h"
#include "photonflow/io/h5io.h"
#include "photonflow/stages/photon_pass.h"
#include "photonflow/io/stage_files.h"
#include "photonflow/geometry/scene_file.h"
#include "photonflow/io/h5_types.h"
#include "support.h"

using namespace pf;
using test::TempDir;

namespace {
template <class T> bool same_bytes(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0);
}
Provenance prov_for(const std::string& tool) {
  Provenance p;
  p.tool = tool;
  p.param("answer", 42);
  return p;
}
}  // namespace

TEST_CASE("scene.h5 round-trips every dataset", "[formats][scene]") {
  TempDir tmp("formats");
  Scene s = test::room_scene(PF_MAT_GLASS, 20, 10);
  pf_light point{};
  point.type = PF_LIGHT_POINT;
  point.triangle = -1;
  point.position[1] = 0.5f;
  point.radiance[0] = point.radiance[1] = point.radiance[2] = 2.f;
  s.lights.push_back(point);
  s.compute_light_cdf();
  s.compute_scene_id();
  s.source = "in-memory";
  save_scene(s, tmp / "scene.h5", prov_for("test"));
  Scene r = load_scene(tmp / "scene.h5");
  CHECK(same_bytes(r.triangles, s.triangles));
  CHECK(same_bytes(r.hh, s.hh));
  CHECK(r.mesh_names == s.mesh_names);
  CHECK(same_bytes(r.materials, s.materials));
  CHECK(r.material_names == s.material_names);
  CHECK(same_bytes(r.lights, s.lights));
  CHECK(r.light_cdf == s.light_cdf);
  CHECK(std::memcmp(&r.camera, &s.camera, sizeof s.camera) == 0);
  CHECK(same_bytes(r.kd.nodes, s.kd.nodes));
  CHECK(r.kd.leaf_tris == s.kd.leaf_tris);
  CHECK(r.kd.depth == s.kd.depth);
  CHECK(r.kd.params.cost_traversal == s.kd.params.cost_traversal);
  CHECK(r.scene_id == s.scene_id);
  CHECK(r.source == "in-memory");
  CHECK(read_provenance(h5::Reader(tmp / "scene.h5", kSceneFormat, kSceneFormatVersion))
            .parameters.at("answer") == "42");
  // Versions 1 (variable-length names, h5io.cpp reads both kinds), 2 (no textures), 3 (no
  // lens: the camera's pinhole fields only) and 4 (no alpha cut-outs, no spot/directional light
  // fields; the materials without the metallic-roughness fields of version 5: test_pbr_import)
  // are still read, and 5 (no environment); a later version is refused by its number.
  CHECK(kSceneFormatVersion == 6);
  test::set_int_attr(tmp / "scene.h5", "/", "format_version", 1);
  CHECK(load_scene(tmp / "scene.h5").mesh_names == s.mesh_names);
  test::set_int_attr(tmp / "scene.h5", "/", "format_version", 2);
  CHECK(load_scene(tmp / "scene.h5").mesh_names == s.mesh_names);
  test::set_int_attr(tmp / "scene.h5", "/", "format_version", 3);
  CHECK(load_scene(tmp / "scene.h5").camera.aperture == 0.f);
  test::set_int_attr(tmp / "scene.h5", "/", "format_version", 4);
  CHECK(load_scene(tmp / "scene.h5").scene_id == s.scene_id);
  CHECK(load_scene(tmp / "scene.h5").material_alpha.empty());
  CHECK(same_bytes(load_scene(tmp / "scene.h5").lights, s.lights));
  test::set_int_attr(tmp / "scene.h5", "/", "format_version", 5);
  CHECK(load_scene(tmp / "scene.h5").scene_id == s.scene_id);
  CHECK(!load_scene(tmp / "scene.h5").environment.present());
  test::set_int_attr(tmp / "scene.h5", "/", "format_version", 7);
  CHECK_THROWS_AS(load_scene(tmp / "scene.h5"), InputError);
}

TEST_CASE("scene.h5 whose content was changed after baking is refused", "[formats][scene]") {
  TempDir tmp("formats");
  const UncheckedWritesForTests damaged;  // save_scene itself refuses these scenes
  Scene s = test::room_scene(PF_MAT_DIFFUSE, 8, 8);
  SECTION("geometry edited: scene_id no longer matches") {
    std::string id = s.scene_id;
    s.triangles[0].v0[0] += 0.01f;
    s.compute_hh();
    s.scene_id = id;
    save_scene(s, tmp / "s.h5", prov_for("test"));
    CHECK_THROWS_WITH(load_scene(tmp / "s.h5"), Catch::Contains("scene_id does not match"));
  }
  SECTION("material index out of range") {
    s.triangles[3].material = 99;
    s.compute_scene_id();
    save_scene(s, tmp / "s.h5", prov_for("test"));
    CHECK_THROWS_WITH(load_scene(tmp / "s.h5"), Catch::Contains("material id is out of range"));
  }
  SECTION("lights or camera edited: scene_id no longer matches") {
    // The id names the lights and the camera too (scene.h: the scene's content), not only the
    // geometry and materials.
    const std::string id = s.scene_id;
    // (A light that no longer matches its material is refused before the id: load_scene derives
    // the lights again, validate.h; here light and material change together.)
    SECTION("a light's emission") {
      const size_t m = size_t(s.triangles[size_t(s.lights[0].triangle)].material);
      s.materials[m].emission[0] *= 2.f;
      s.compute_light_cdf();
    }
    SECTION("the camera") { s.camera.fov_y_deg += 1.f; }
    s.scene_id = id;
    save_scene(s, tmp / "s.h5", prov_for("test"));
    CHECK_THROWS_WITH(load_scene(tmp / "s.h5"), Catch::Contains("scene_id does not match"));
  }
  SECTION("tables of different lengths") {
    // Not covered by scene_id: each must still match its table, or a later stage indexes past it.
    SECTION("light cdf") { s.light_cdf.pop_back(); }
    SECTION("hh planes") { s.hh.pop_back(); }
    SECTION("material names") { s.material_names.push_back("extra"); }
    save_scene(s, tmp / "s.h5", prov_for("test"));
    CHECK_THROWS_WITH(load_scene(tmp / "s.h5"), Catch::Contains("differ in length"));
  }
  SECTION("broken kd-tree") {
    s.kd.nodes[0].left = 100000;
    save_scene(s, tmp / "s.h5", prov_for("test"));
    CHECK_THROWS_WITH(load_scene(tmp / "s.h5"), Catch::Contains("invalid kd-tree"));
  }
}

TEST_CASE("hitpoints, photons and grid files round-trip every dataset", "[formats][stages]") {
  TempDir tmp("formats");
  Scene s = test::room_scene(PF_MAT_MIRROR, 24, 16);
  EyePassOptions eo;
  eo.direct = DirectMode::ShadowRays;
  HitpointSet h = make_hitpoint_set(trace_hitpoints(s, eo), eo.direct, s.scene_id);
  h.estimator = "ppm";
  h.photons_emitted = 123456789012ull;  // more than 2^32: needs 29 passes of at most 2^32 − 1
  h.passes = 29;
  h.scene_id = s.scene_id;
  h.hitpoints[0].flux[1] = 3.5f;
  h.hitpoints[0].n_photons = 2.25f;
  save_hitpoints(h, tmp / "hp.h5", prov_for("hp"));
  HitpointSet hr = load_hitpoints(tmp / "hp.h5");
  CHECK(same_bytes(hr.hitpoints, h.hitpoints));
  CHECK(hr.emitted == h.emitted);
  CHECK(hr.direct == h.direct);
  CHECK(hr.width == h.width);
  CHECK(hr.height == h.height);
  CHECK(hr.direct_mode == h.direct_mode);
  CHECK(hr.radius0 == h.radius0);
  CHECK(hr.estimator == "ppm");
  CHECK(hr.photons_emitted == h.photons_emitted);
  CHECK(hr.passes == 29);
  CHECK(hr.scene_id == s.scene_id);
  // Both direct modes read back as themselves (the round trip above is shadow-rays).
  h.direct_mode = DirectMode::Photons;
  save_hitpoints(h, tmp / "hp2.h5", prov_for("hp"));
  CHECK(load_hitpoints(tmp / "hp2.h5").direct_mode == DirectMode::Photons);
  CHECK(h5::Reader(tmp / "hp2.h5", kHitpointsFormat, 2).attr_string("/", "direct_mode") ==
        "photons");
  CHECK(h5::Reader(tmp / "hp.h5", kHitpointsFormat, 2).attr_string("/", "direct_mode") ==
        "shadow-rays");

  PhotonSet p;
  p.first_pass = 5;
  p.seed = 77;
  p.scene_id = s.scene_id;
  PhotonPassOptions po;
  po.photons = 3000;
  for (uint32_t pass = 5; pass < 7; ++pass) {
    PhotonPassResult r = trace_photons(s, pass, po);
    p.append_pass(r.photons, r.emitted);
  }
  save_photons(p, tmp / "ph.h5", prov_for("ph"));
  PhotonSet pr = load_photons(tmp / "ph.h5");
  CHECK(same_bytes(pr.photons, p.photons));
  CHECK(pr.pass_begin == p.pass_begin);
  CHECK(pr.pass_emitted == p.pass_emitted);
  CHECK(pr.first_pass == 5);
  CHECK(pr.seed == 77);
  CHECK(same_bytes(pr.pass(1), p.pass(1)));
  // The caustic dataset is exactly the caustic-flagged photons.
  h5::Reader reader(tmp / "ph.h5", kPhotonsFormat, 1);
  auto caustic = reader.read<pf_photon>("/caustic", h5_type_photon());
  size_t expected = 0;
  for (auto& ph : p.photons) expected += (ph.flags & PF_PHOTON_CAUSTIC) != 0;
  CHECK(caustic.size() == expected);
  CHECK(expected > 0);

  GridSet g;
  g.first_pass = 5;
  g.pass_emitted = p.pass_emitted;
  g.scene_id = s.scene_id;
  PhotonGridParams gp;
  gp.default_radius = 0.02f;
  for (int k = 0; k < 2; ++k) g.grids.push_back(build_photon_grid(p.pass(k), 4, gp));
  save_grids(g, tmp / "grid.h5", prov_for("grid"));
  GridSet gr = load_grids(tmp / "grid.h5");
  REQUIRE(gr.grids.size() == 2);
  CHECK(gr.first_pass == 5);
  CHECK(gr.pass_emitted == g.pass_emitted);
  for (int k = 0; k < 2; ++k) {
    CHECK(same_bytes(gr.grids[k].mesh_grid, g.grids[k].mesh_grid));
    CHECK(gr.grids[k].cell_start == g.grids[k].cell_start);
    CHECK(same_bytes(gr.grids[k].photons, g.grids[k].photons));
    CHECK(gr.grids[k].order == g.grids[k].order);
    CHECK(gr.grids[k].params.max_bins == g.grids[k].params.max_bins);
    CHECK(gr.grids[k].params.default_radius == g.grids[k].params.default_radius);
  }
}

TEST_CASE("damaged stage files are refused with one line", "[formats][stages]") {
  TempDir tmp("formats");
  const UncheckedWritesForTests damaged;  // files the writers themselves would refuse to write
  SECTION("a pass table that does not match the photons") {
    PhotonSet p;
    p.photons.resize(10);
    p.pass_begin = {0, 20};
    p.pass_emitted = {100};
    save_photons(p, tmp / "ph.h5", prov_for("ph"));
    CHECK_THROWS_WITH(load_photons(tmp / "ph.h5"), Catch::Contains("pass table"));
  }
  SECTION("a hitpoint outside the image") {
    HitpointSet h;
    h.width = 2;
    h.height = 2;
    h.radius0 = 0.1f;  // a valid R0 (0 is refused first)
    h.emitted.assign(12, 0.f);
    h.direct.assign(12, 0.f);
    h.hitpoints.resize(1);
    h.hitpoints[0].pixel_x = 5;
    save_hitpoints(h, tmp / "hp.h5", prov_for("hp"));
    CHECK_THROWS_WITH(load_hitpoints(tmp / "hp.h5"), Catch::Contains("outside the image"));
  }
}
