// Progressive snapshots and the run record of the render driver (render_driver.h: snapshot_every,
// snapshot_at, RenderStatus, render_record_json), the emitter mask (emitter_mask.h), and the
// tools' options that expose them (render --snapshot-every/--snapshot-at/--snapshot/--stats,
// emitter-mask) — what pipelines/accuracy.mk builds its charts on.
#include <catch2/catch.hpp>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include "photonflow/geometry/camera.h"
#include "photonflow/opencl/cl_backend.h"
#include "photonflow/opencl/cl_runtime.h"
#include "photonflow/stages/emitter_mask.h"
#include "photonflow/foundations/error.h"
#include "photonflow/image/image_metrics.h"
#include "photonflow/geometry/raycast.h"
#include "photonflow/estimators/render_driver.h"
#include "photonflow/stages/synthesize.h"
#include "support.h"
#include "support_cl.h"

using namespace pf;
using test::run_tool;
using test::TempDir;

namespace {

RenderOptions small_run(int passes) {
  RenderOptions o;
  o.passes = passes;
  o.photons.photons = 2000;
  return o;
}

size_t occurrences(const std::string& text, const std::string& needle) {
  size_t n = 0;
  for (size_t at = text.find(needle); at != std::string::npos; at = text.find(needle, at + 1)) ++n;
  return n;
}

}  // namespace

TEST_CASE("render driver: snapshots every K passes and at listed passes equal shorter runs",
          "[render][snapshots]") {
  const Scene s = test::room_scene(PF_MAT_DIFFUSE, 16, 12);
  RenderOptions opt = small_run(5);
  opt.snapshot_every = 2;
  opt.snapshot_at = {3, 3};  // duplicates are harmless
  std::vector<RenderStatus> seen;
  std::vector<Image> images;
  RenderStatus final_status;
  Provenance prov;
  const HitpointSet h = render_progressive(
      s, opt, false, prov, {},
      [&](const HitpointSet& state, const RenderStatus& st) {
        seen.push_back(st);
        images.push_back(synthesize(state));
      },
      &final_status);
  REQUIRE(seen.size() == 3);
  CHECK(seen[0].passes == 2);
  CHECK(seen[1].passes == 3);
  CHECK(seen[2].passes == 4);
  for (size_t i = 0; i < seen.size(); ++i) {
    CHECK(seen[i].target == 5);
    CHECK(seen[i].photons_emitted == uint64_t(seen[i].passes) * 2000u);
    CHECK(seen[i].photons_stored > 0);
    CHECK(seen[i].seconds > 0);
    CHECK_FALSE(seen[i].resumed);
    if (i > 0) {
      CHECK(seen[i].seconds >= seen[i - 1].seconds);
      CHECK(seen[i].photons_stored > seen[i - 1].photons_stored);
      CHECK(seen[i].mean_radius < seen[i - 1].mean_radius);  // eq. 3.16 with α < 1
    }
  }
  CHECK(final_status.passes == 5);
  CHECK(final_status.photons_emitted == h.photons_emitted);
  CHECK(final_status.seconds >= seen.back().seconds);
  double mean = 0;
  for (const pf_hitpoint& p : h.hitpoints) mean += p.radius;
  CHECK(final_status.mean_radius == Approx(mean / double(h.hitpoints.size())).epsilon(1e-9));
  // The snapshot after 3 passes is the image of a 3-pass run, bit for bit.
  RenderOptions three = small_run(3);
  const Image direct = synthesize(render_progressive(s, three, false, prov));
  CHECK(images[1].rgb == direct.rgb);
  // No snapshot options: no callback.
  int calls = 0;
  render_progressive(s, small_run(2), false, prov, {},
                     [&](const HitpointSet&, const RenderStatus&) { ++calls; });
  CHECK(calls == 0);
}

// A resumed run continues the photon passes where the checkpoint left them (pass p's random
// streams are (seed, p, i) on both backends): it equals the uninterrupted run bit for bit, on the
// CPU and on every device route of the driver (hash-grid keeps the photons on the device, naive
// reads them back). A resumed device run restarting its pass counter at 0 reused passes 0.. and
// went unnoticed: the tools' resume tests run on the CPU only.
TEST_CASE("render driver: a resumed run equals the uninterrupted one on every route",
          "[render][resume][opencl]") {
  const Scene s = test::room_scene(PF_MAT_GLASS, 16, 12);
  TempDir tmp("resume-routes");
  std::unique_ptr<ClContext> dev = test::test_device();
  struct Route {
    const char* name;
    GatherMethod method;
    bool device;
  };
  std::vector<Route> routes = {{"cpu grid", GatherMethod::Grid, false},
                               {"cpu flann", GatherMethod::Flann, false}};
  if (dev) {
    routes.push_back({"opencl hash-grid", GatherMethod::HashGrid, true});
    routes.push_back({"opencl naive", GatherMethod::Naive, true});
  }
  Provenance prov;
  prov.tool = "test";
  for (const Route& route : routes) {
    INFO("route " << route.name);
    RenderOptions opt = small_run(4);
    opt.ppm.method = route.method;
    opt.device = route.device ? dev.get() : nullptr;
    RenderStatus full_st;
    const HitpointSet full = render_progressive(s, opt, false, prov, {}, {}, &full_st);
    REQUIRE(full.passes == 4);
    CHECK_FALSE(full_st.resumed);
    // photons_stored: the photons this process traced, i.e. those of its passes' photon maps.
    uint64_t stored[4] = {};
    for (uint32_t p = 0; p < 4; ++p)
      stored[p] = (route.device ? trace_photons(s, p, opt.photons, *dev)
                                : trace_photons(s, p, opt.photons)).photons.size();
    CHECK(full_st.photons_stored == stored[0] + stored[1] + stored[2] + stored[3]);
    CHECK(full_st.photons_emitted == 4u * opt.photons.photons);
    // Two passes with a checkpoint, then --resume to four.
    const std::string ck = tmp / (std::string(route.device ? "cl-" : "cpu-") +
                                  gather_method_name(route.method) + ".h5");
    RenderOptions first = opt;
    first.passes = 2;
    first.checkpoint = ck;
    first.checkpoint_every = 1;
    render_progressive(s, first, false, prov);
    REQUIRE(load_hitpoints(ck).passes == 2);
    RenderOptions rest = opt;
    rest.checkpoint = ck;
    rest.checkpoint_every = 1;
    RenderStatus st;
    const HitpointSet resumed = render_progressive(s, rest, true, prov, {}, {}, &st);
    CHECK(st.resumed);
    CHECK(st.photons_stored == stored[2] + stored[3]);  // passes 2 and 3 only
    CHECK(resumed.passes == 4);
    CHECK(resumed.photons_emitted == full.photons_emitted);
    CHECK(resumed.photons_emitted == 4u * opt.photons.photons);
    CHECK(test::same_hitpoints(resumed.hitpoints, full.hitpoints));
    CHECK(synthesize(resumed).rgb == synthesize(full).rgb);
    CHECK(load_hitpoints(ck).passes == 4);  // the last pass is checkpointed too
  }
}

// RenderStatus::build_seconds is the OpenCL program builds of this run (ClContext::build_seconds):
// positive on a context that builds its programs during the run, zero on one that built them
// before (programs are built once per context). Builds not counted made a first device run look
// slower than the CPU in the accuracy charts.
TEST_CASE("render driver: OpenCL program builds are counted apart, once per context",
          "[render][opencl]") {
  std::unique_ptr<ClContext> dev = test::test_device();
  if (!dev) return;
  const Scene s = test::room_scene(PF_MAT_DIFFUSE, 8, 6);
  ClContext fresh(dev->info(), 0);
  CHECK(fresh.build_seconds() == 0.0);
  RenderOptions opt = small_run(2);
  opt.device = &fresh;
  opt.ppm.method = GatherMethod::HashGrid;
  Provenance prov;
  RenderStatus first, second;
  render_progressive(s, opt, false, prov, {}, {}, &first);
  CHECK(first.build_seconds > 0.0);
  CHECK(first.build_seconds == Approx(fresh.build_seconds()).epsilon(1e-12));
  CHECK(first.seconds > 0.0);
  const double built = fresh.build_seconds();
  render_progressive(s, opt, false, prov, {}, {}, &second);
  CHECK(fresh.build_seconds() == built);  // nothing built again
  CHECK(second.build_seconds == 0.0);
}

// --resume continues a checkpoint only when it records every option its state depends on
// (state_parameters) with this run's values: a hitpoint file written elsewhere (trace-hitpoints,
// illuminate: no state.* parameters) or one missing a single state option is refused, unchanged.
TEST_CASE("render driver: resume refuses a state that does not record its options",
          "[render][resume]") {
  const Scene s = test::room_scene(PF_MAT_DIFFUSE, 8, 6);
  TempDir tmp("resume-unrecorded");
  RenderOptions opt = small_run(3);
  opt.checkpoint = tmp / "ck.h5";
  opt.checkpoint_every = 1;
  Provenance prov;
  prov.tool = "test";
  RenderOptions two = opt;
  two.passes = 2;
  render_progressive(s, two, false, prov);
  const HitpointSet saved = load_hitpoints(opt.checkpoint);
  const Provenance made = load_hitpoints_provenance(opt.checkpoint);
  // Each state option left out in turn, and all of them.
  std::vector<std::string> names;
  for (const auto& [name, value] : state_parameters(opt)) names.push_back(name);
  REQUIRE(names.size() >= 5);
  names.push_back("");  // "": every state.* entry removed
  for (const std::string& left_out : names) {
    INFO("left out: " << (left_out.empty() ? "all" : left_out));
    Provenance p = made;
    for (auto it = p.parameters.begin(); it != p.parameters.end();)
      it = (it->first == "state." + left_out || (left_out.empty() && it->first.rfind("state.", 0) == 0))
               ? p.parameters.erase(it)
               : std::next(it);
    REQUIRE(p.parameters.size() < made.parameters.size());
    const std::string ck = tmp / "partial.h5";
    save_hitpoints(saved, ck, p);
    RenderOptions o = opt;
    o.checkpoint = ck;
    CHECK_THROWS_AS(render_progressive(s, o, true, prov), InputError);
    CHECK(load_hitpoints(ck).passes == 2);  // not continued
  }
  // The checkpoint as written resumes.
  CHECK(render_progressive(s, opt, true, prov).passes == 3);
}

// Checkpoints every checkpoint_every passes and after the last one, written before the pass's
// on_pass callback: the file holds the last multiple of checkpoint_every (or the final pass).
TEST_CASE("render driver: checkpoints every K passes and at the end", "[render][resume]") {
  const Scene s = test::room_scene(PF_MAT_DIFFUSE, 8, 6);
  TempDir tmp("checkpoint-every");
  for (int every : {1, 2, 3}) {
    INFO("checkpoint every " << every);
    RenderOptions opt = small_run(5);
    opt.checkpoint = tmp / ("ck" + std::to_string(every) + ".h5");
    opt.checkpoint_every = every;
    Provenance prov;
    std::vector<int> seen;  // the checkpoint's passes after each pass (0: none yet)
    render_progressive(s, opt, false, prov, [&](int done, double) {
      CHECK(done == int(seen.size()) + 1);
      seen.push_back(std::filesystem::exists(opt.checkpoint) ? load_hitpoints(opt.checkpoint).passes : 0);
      return true;
    });
    REQUIRE(seen.size() == 5);
    for (int done = 1; done <= 5; ++done) {
      const int expect = done == 5 ? 5 : done / every * every;
      CHECK(seen[size_t(done - 1)] == expect);
    }
  }
}

// A pass callback that returns false (render's Ctrl-C, interrupt.h) ends the run after that
// pass: the checkpoint is saved then, also between regular checkpoints, and --resume from it
// gives the uninterrupted run's state.
TEST_CASE("render driver: a stop after a pass saves the checkpoint, resuming gives the whole run",
          "[render][resume]") {
  const Scene s = test::room_scene(PF_MAT_DIFFUSE, 8, 6);
  TempDir tmp("stop");
  Provenance prov;
  RenderOptions opt = small_run(5);
  const HitpointSet whole = render_progressive(s, opt, false, prov);
  opt.checkpoint = tmp / "ck.h5";
  opt.checkpoint_every = 4;  // no regular checkpoint before the stop
  RenderStatus st;
  int calls = 0;
  const HitpointSet part = render_progressive(
      s, opt, false, prov, [&](int done, double) { return ++calls, done < 2; }, {}, &st);
  CHECK(calls == 2);
  CHECK(st.stopped);
  CHECK(st.passes == 2);
  CHECK(part.passes == 2);
  REQUIRE(std::filesystem::exists(opt.checkpoint));
  CHECK(load_hitpoints(opt.checkpoint).passes == 2);
  RenderStatus rest;
  const HitpointSet resumed = render_progressive(s, opt, true, prov, {}, {}, &rest);
  CHECK_FALSE(rest.stopped);
  CHECK(rest.resumed);
  CHECK(resumed.passes == 5);
  CHECK(test::same_hitpoints(resumed.hitpoints, whole.hitpoints));
  // A stop at the last pass is no stop; a stop without a checkpoint keeps nothing on disk.
  RenderStatus at_end;
  render_progressive(s, small_run(1), false, prov, [](int, double) { return false; }, {}, &at_end);
  CHECK_FALSE(at_end.stopped);
  RenderOptions bare = small_run(3);
  RenderStatus no_ck;
  CHECK(render_progressive(s, bare, false, prov, [](int, double) { return false; }, {}, &no_ck)
            .passes == 1);
  CHECK(no_ck.stopped);
}

TEST_CASE("render driver: time spent in snapshot callbacks is not rendering time",
          "[render][snapshots]") {
  const Scene s = test::room_scene(PF_MAT_DIFFUSE, 16, 12);
  RenderOptions opt = small_run(4);
  opt.snapshot_every = 1;
  Provenance prov;
  RenderStatus st;
  Stopwatch wall;
  render_progressive(
      s, opt, false, prov, {},
      [](const HitpointSet&, const RenderStatus&) {
        std::this_thread::sleep_for(std::chrono::milliseconds(150));
      },
      &st);
  const double total = wall.seconds();
  INFO("rendering seconds " << st.seconds << ", wall " << total);
  CHECK(total >= 0.6);
  CHECK(st.seconds > 0);
  CHECK(st.seconds < total - 0.55);  // the 4 × 150 ms asleep are taken off
}

TEST_CASE("render driver: pass lists and snapshot names", "[render][snapshots]") {
  CHECK(parse_pass_list("", "snapshot-at").empty());
  CHECK(parse_pass_list("1,2,16", "snapshot-at") == std::vector<int>{1, 2, 16});
  CHECK(parse_pass_list("7", "snapshot-at") == std::vector<int>{7});
  for (const char* bad : {"0", "-3", "a", "1,,2", "1,2,", ",1", "1.5", "1 2", "99999999999"}) {
    INFO(bad);
    CHECK_THROWS_AS(parse_pass_list(bad, "snapshot-at"), InputError);
  }
  CHECK(render_snapshot_name("a-{pass}p.exr", 3, 128) == "a-003p.exr");
  CHECK(render_snapshot_name("{pass}/{pass}.exr", 12, 12) == "12/12.exr");
  CHECK(render_snapshot_name("fixed.exr", 3, 10) == "fixed.exr");
  RenderOptions o;
  o.snapshot_every = 4;
  o.snapshot_at = {1, 6};
  std::vector<int> due;
  for (int p = 1; p <= 9; ++p)
    if (snapshot_due(o, p)) due.push_back(p);
  CHECK(due == std::vector<int>{1, 4, 6, 8});

  // A pattern without {pass} names one file: refused when more than one snapshot is due.
  o.passes = 9;
  CHECK_NOTHROW(check_snapshot_pattern("s-{pass}.exr", o));
  CHECK_THROWS_WITH(check_snapshot_pattern("fixed.exr", o),
                    Catch::Contains("--snapshot 'fixed.exr' has no {pass}: its 4 snapshots"));
  o.snapshot_every = 0;
  o.snapshot_at = {6, 6};  // one snapshot, listed twice: one file is right
  CHECK_NOTHROW(check_snapshot_pattern("fixed.exr", o));
  o.snapshot_every = 5;  // 5 and 6
  CHECK_THROWS_AS(check_snapshot_pattern("fixed.exr", o), InputError);
  o.snapshot_at = {5};  // 5 only
  CHECK_NOTHROW(check_snapshot_pattern("fixed.exr", o));
}

TEST_CASE("render driver: the run record lists every image with its status",
          "[render][snapshots]") {
  Provenance prov;
  prov.tool = "render";
  prov.seed = 5;
  prov.command_line = "render --x \"y\"";
  prov.parameters["passes"] = "8";
  RenderStatus a;
  a.passes = 4;
  a.target = 8;
  a.photons_emitted = 400;
  a.photons_stored = 700;
  a.seconds = 1.5;
  a.build_seconds = 0.25;
  a.mean_radius = 0.125;
  RenderStatus b = a;
  b.passes = 8;
  b.resumed = true;
  const std::string j = render_record_json(prov, {{"a-4p.exr", a}, {"a.exr", b}});
  CHECK_THAT(j, Catch::Contains("\"tool\": \"render\""));
  CHECK_THAT(j, Catch::Contains("\"command_line\": \"render --x \\\"y\\\"\""));
  CHECK_THAT(j, Catch::Contains("\"passes\": \"8\""));
  CHECK_THAT(j, Catch::Contains("{\"path\": \"a-4p.exr\", \"passes\": 4, \"target\": 8, "
                                "\"photons_emitted\": 400, \"photons_stored\": 700, "
                                "\"seconds\": 1.5, \"build_seconds\": 0.25, "
                                "\"mean_radius\": 0.125, \"resumed\": false}"));
  CHECK_THAT(j, Catch::Contains("\"path\": \"a.exr\", \"passes\": 8"));
  CHECK_THAT(j, Catch::Contains("\"resumed\": true}"));
}

TEST_CASE("render tool: snapshots and run record", "[render][snapshots][tools]") {
  TempDir tmp("render-snap");
  REQUIRE(run_tool("scene-bake", std::string(PF_SOURCE_DIR) + "/data/cornell-box.dae -o " +
                                     (tmp / "s.h5") + " --width 24 --height 24", tmp)
              .exit_code == 0);
  // ppm with direct light from photons, as written before sppm became render's default.
  const std::string base = "--scene " + (tmp / "s.h5") +
                           " --estimator ppm --direct photons --photons 3000 --passes 4 ";
  auto r = run_tool("render", base + "-o " + (tmp / "r.exr") +
                                  " --snapshot-every 2 --snapshot-at 1 --stats " + (tmp / "r.json"),
                    tmp);
  INFO(r.err);
  REQUIRE(r.exit_code == 0);
  CHECK(r.err.empty());  // the progress line is for terminals only (progress.h): stderr is a file
  for (const char* f : {"r-1p.exr", "r-2p.exr", "r-4p.exr", "r.exr", "r.png", "r.json"})
    CHECK(std::filesystem::exists(tmp / f));
  CHECK_FALSE(std::filesystem::exists(tmp / "r-3p.exr"));
  CHECK(read_exr(tmp / "r-4p.exr").rgb == read_exr(tmp / "r.exr").rgb);
  const std::string j = test::file_bytes(tmp / "r.json");
  CHECK(occurrences(j, "{\"path\": ") == 4);  // three snapshots and the final image
  CHECK_THAT(j, Catch::Contains("r-1p.exr\", \"passes\": 1,"));
  CHECK_THAT(j, Catch::Contains("\"snapshot-at\": \"1\""));
  CHECK_THAT(j, Catch::Contains("\"role\": \"scene\""));
  // A pattern of its own, with a folder.
  std::filesystem::create_directories(tmp / "snaps");
  REQUIRE(run_tool("render", base + "-o " + (tmp / "q.exr") + " --snapshot-at 3 --snapshot " +
                                 (tmp / "snaps") + "/{pass}.exr", tmp)
              .exit_code == 0);
  CHECK(std::filesystem::exists(tmp / "snaps/3.exr"));
  // A pattern without {pass} for one snapshot is one file; for more, refused before any work
  // (before: every snapshot overwrote the one before).
  REQUIRE(run_tool("render", base + "-o " + (tmp / "one.exr") + " --snapshot-at 2 --snapshot " +
                                 (tmp / "one-snap.exr"), tmp)
              .exit_code == 0);
  CHECK(std::filesystem::exists(tmp / "one-snap.exr"));
  auto same = run_tool("render", base + "-o " + (tmp / "same.exr") + " --snapshot-every 1 " +
                                     "--snapshot " + (tmp / "same-snap.exr"), tmp);
  INFO(same.err);
  CHECK(same.exit_code == kExitBadInput);
  CHECK(same.err == "render: --snapshot '" + (tmp / "same-snap.exr") + "' has no {pass}: its 4 "
                    "snapshots would overwrite each other (put {pass} in the name, e.g. "
                    "snap-{pass}.exr)\n");
  CHECK_FALSE(std::filesystem::exists(tmp / "same.exr"));
  CHECK_FALSE(std::filesystem::exists(tmp / "same-snap.exr"));
  // Bad options: one line, exit 2, no image.
  for (const std::string& bad : {std::string("--snapshot-at 0"), std::string("--snapshot-at 1,x"),
                                 std::string("--snapshot-every -1"),
                                 "--stats " + (tmp / "nodir") + "/r.json"}) {
    auto b = run_tool("render", base + "-o " + (tmp / "bad.exr") + " " + bad, tmp);
    INFO(bad << ": " << b.err);
    CHECK(b.exit_code == kExitBadInput);
    CHECK(std::count(b.err.begin(), b.err.end(), '\n') == 1);
    CHECK_FALSE(std::filesystem::exists(tmp / "bad.exr"));
  }
}

TEST_CASE("emitter mask: the pixels that see the lamp are left out", "[emitter-mask]") {
  Scene s = test::room_scene(PF_MAT_DIFFUSE, 32, 32);
  // Looking up at the ceiling lamp (a 0.2 × 0.2 quad at y = 0.98, facing down) from the centre.
  s.camera = pf_camera{{0.5f, 0.3f, 0.5f}, {0.5f, 1.f, 0.5f}, {0, 0, 1}, 60.f, 32, 32};
  const int lamp = 3;  // mesh and material id of the lamp (support.h)
  EmitterMaskOptions o;
  o.dilate = 0;
  const EmitterMask m0 = emitter_mask(s, o);
  o.dilate = 1;
  const EmitterMask m1 = emitter_mask(s, o);
  CHECK(m0.seeing > 20);
  CHECK(m0.excluded == m0.seeing);
  CHECK(m1.seeing == m0.seeing);
  CHECK(m1.excluded > m0.excluded);
  CameraFrame cam(s.camera);
  size_t centre_on_lamp = 0;
  for (int y = 0; y < 32; ++y)
    for (int x = 0; x < 32; ++x) {
      Hit hit;
      Ray r{cam.eye(), cam.direction(x + 0.5f, y + 0.5f)};
      const bool on_lamp =
          intersect_closest(s, r, hit) && s.triangles[size_t(hit.tri)].material == lamp;
      const float v0 = m0.mask.get(x, y).x, v1 = m1.mask.get(x, y).x;
      CHECK((v0 == 0.f || v0 == 1.f));
      if (on_lamp) {
        ++centre_on_lamp;
        CHECK(v0 == 0.f);  // a pixel whose centre sees the lamp is always left out
      }
      // Dilation by one pixel: left out exactly when a neighbour (or the pixel) sees the lamp.
      bool near = false;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int xx = x + dx, yy = y + dy;
          if (xx >= 0 && yy >= 0 && xx < 32 && yy < 32) near = near || m0.mask.get(xx, yy).x == 0.f;
        }
      CHECK(v1 == (near ? 0.f : 1.f));
    }
  CHECK(centre_on_lamp > 10);
  CHECK(m0.mask.get(0, 0).x == 1.f);  // the corner of the view sees the ceiling
  // The test room's usual view (towards the back wall) sees no emitter; a mirror sphere there
  // shows the lamp's reflection, which is left out too.
  const EmitterMask none = emitter_mask(test::room_scene(PF_MAT_DIFFUSE, 32, 24), {});
  CHECK(none.excluded == 0);
  const EmitterMask mirror = emitter_mask(test::room_scene(PF_MAT_MIRROR, 32, 24), {});
  CHECK(mirror.seeing > 0);
  CHECK_THROWS_AS(emitter_mask(s, EmitterMaskOptions{0, 1}), InputError);
  CHECK_THROWS_AS(emitter_mask(s, EmitterMaskOptions{4, -1}), InputError);
}

TEST_CASE("emitter-mask tool writes the mask imgcompare reads", "[emitter-mask][tools]") {
  TempDir tmp("emitter-mask");
  REQUIRE(run_tool("scene-bake", std::string(PF_SOURCE_DIR) + "/data/cornell-box.dae -o " +
                                     (tmp / "s.h5") + " --width 32 --height 32", tmp)
              .exit_code == 0);
  auto r = run_tool("emitter-mask", "--scene " + (tmp / "s.h5") + " -o " + (tmp / "m.exr"), tmp);
  INFO(r.err);
  REQUIRE(r.exit_code == 0);
  CHECK_THAT(r.out, Catch::Contains("pixels left out"));
  const Image m = read_mask(tmp / "m.exr");
  size_t out = 0;
  for (size_t i = 0; i < m.pixel_count(); ++i) out += m.rgb[3 * i] < 0.5f;
  CHECK(out > 0);             // the Cornell box's lamp is in view
  CHECK(out < m.pixel_count() / 10);
  auto bad = run_tool("emitter-mask", "--scene " + (tmp / "s.h5") + " -o " + (tmp / "x.exr") +
                                          " --spp 0", tmp);
  CHECK(bad.exit_code == kExitBadInput);
  CHECK_FALSE(std::filesystem::exists(tmp / "x.exr"));
  auto missing = run_tool("emitter-mask", "--scene " + (tmp / "none.h5") + " -o " + (tmp / "x.exr"), tmp);
  CHECK(missing.exit_code == kExitBadInput);
}
