// gather_method_test.cpp — the OpenCL gather methods of issue 5 (gather_method.h, cl_gather.h;
// thesis ch. 7.3) on PoCL in CI:
//   - every method gathers exactly the photons the CPU grid gathers (same M per hitpoint, hence the
//     same radii and photon counts), with flux equal to float summation order, after one pass;
//   - over 20 passes (radii shrinking, cluster radii refreshed) every method's image equals naive's
//     within 1e-5 relative RMSE, and naive equals the CPU grid gather bit for bit;
//   - the device's grid build equals the CPU's build_photon_grid array for array (eq. 7.1), and the
//     device's per-mesh sort is the stable sort by mesh;
//   - a state kept on the device between passes (DevicePpmState) equals ppm_pass's, byte for byte,
//     and so does one fed photons that never left the device (trace_photons_device);
//   - hash-grid's two photon orderings (device kernels, host into mapped buffers) give the same
//     bytes, for the automatic table, one slot and a small table, and so do its two ways of reading
//     accepted photons (a private pending list of 4 or 32, or at once: PF_GATHER_LIST);
//   - the grid-cluster gather timer of the GA's device-time fitness gathers the same photons;
//   - hitpoint sorting's filler counts follow Table 7.5's definition;
//   - a method on the wrong backend, and an allocation the non-batching methods cannot make, are
//     refused with one line; a bad photon by either hash-grid ordering, the state untouched.
// Without an OpenCL platform every case WARNs "SKIPPED" and returns.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

#include "photonflow/opencl/cl_backend.h"
#include "photonflow/opencl/cl_gather.h"
#include "photonflow/stages/clusters.h"
#include "photonflow/foundations/error.h"
#include "photonflow/stages/eye_pass.h"
#include "photonflow/stages/photon_pass.h"
#include "photonflow/foundations/rng.h"
#include "photonflow/stages/synthesize.h"
#include "support.h"
#include "support_cl.h"

using namespace pf;
using namespace pf::test;

namespace {

// A fresh eye-pass state and `passes` photon passes of a room with a glass sphere (caustics:
// photons on four meshes) at w×h.
struct Fixture {
  Scene scene;
  HitpointSet fresh;
  std::vector<PhotonPassResult> passes;
};

Fixture make_fixture(int w, int h, int passes, uint32_t photons, DirectMode direct) {
  Fixture f{room_scene(PF_MAT_GLASS, w, h), {}, {}};
  EyePassOptions eye;
  eye.seed = 3;
  eye.direct = direct;
  f.fresh = make_hitpoint_set(trace_hitpoints(f.scene, eye), direct, f.scene.scene_id);
  PhotonPassOptions ph;
  ph.photons = photons;
  ph.seed = 3;
  for (int p = 0; p < passes; ++p) f.passes.push_back(trace_photons(f.scene, uint32_t(p), ph));
  return f;
}

std::vector<GatherMethod> device_methods() {
  std::vector<GatherMethod> m;
  for (const GatherMethodInfo& i : gather_methods())
    if (i.device) m.push_back(i.method);
  return m;
}

}  // namespace

TEST_CASE("gather methods: every method gathers the CPU grid's photons", "[gather][opencl]") {
  auto dev = test_device();
  if (!dev) return;
  for (DirectMode direct : {DirectMode::Photons, DirectMode::ShadowRays}) {
    Fixture f = make_fixture(48, 40, 1, 6000, direct);
    PpmOptions cpu_opt;
    HitpointSet cpu = f.fresh;
    ppm_pass(f.scene, cpu, f.passes[0].photons, f.passes[0].emitted, cpu_opt);
    const size_t gathered = gathered_hitpoints(cpu.hitpoints);
    REQUIRE(gathered > cpu.hitpoints.size() / 4);  // the comparison is not vacuous
    for (GatherMethod m : device_methods()) {
      INFO("method " << gather_method_name(m) << ", direct "
                     << (direct == DirectMode::Photons ? "photons" : "shadow rays"));
      PpmOptions opt;
      opt.method = m;
      HitpointSet h = f.fresh;
      GatherTimes t = ppm_pass(f.scene, h, f.passes[0].photons, f.passes[0].emitted, opt, *dev);
      CHECK(t.work_items >= h.hitpoints.size());
      REQUIRE(h.hitpoints.size() == cpu.hitpoints.size());
      size_t same_m = 0, same_r = 0, flux_ok = 0;
      for (size_t i = 0; i < h.hitpoints.size(); ++i) {
        const pf_hitpoint &a = h.hitpoints[i], &b = cpu.hitpoints[i];
        same_m += a.n_photons == b.n_photons;
        same_r += a.radius == b.radius;
        bool ok = true;
        for (int c = 0; c < 3; ++c)
          ok &= std::fabs(a.flux[c] - b.flux[c]) <= 1e-5f * std::fabs(b.flux[c]) + 1e-30f;
        flux_ok += ok;
      }
      CHECK(same_m == h.hitpoints.size());
      CHECK(same_r == h.hitpoints.size());
      CHECK(flux_ok == h.hitpoints.size());
      if (m == GatherMethod::HashGrid) {
        // The device's and the host's photon ordering (hash_grid.h) build the same arrays, so
        // the states are the same bytes; with one slot (every cell shares it, each photon read
        // once) and 64 slots (rows wrap around the table, cells share slots) the same photons.
        for (int slots : {0, 1, 64}) {
          INFO("hash slots " << slots);
          HitpointSet by[2] = {f.fresh, f.fresh};
          for (int o = 0; o < 2; ++o) {
            opt.hash_slots = slots;
            opt.hash_order = o == 0 ? HashOrder::Device : HashOrder::Host;
            ppm_pass(f.scene, by[o], f.passes[0].photons, f.passes[0].emitted, opt, *dev);
          }
          CHECK(same_hitpoints(by[0].hitpoints, by[1].hitpoints));
          size_t same = 0;
          for (size_t i = 0; i < by[1].hitpoints.size(); ++i)
            same += by[1].hitpoints[i].n_photons == h.hitpoints[i].n_photons &&
                    by[1].hitpoints[i].radius == h.hitpoints[i].radius;
          CHECK(same == by[1].hitpoints.size());
        }
      }
      if (m == GatherMethod::Naive)  // the CPU's summation order: the same bytes
        CHECK(same_hitpoints(h.hitpoints, cpu.hitpoints));
    }
  }
}

TEST_CASE("gather methods: hash-grid with small tables reads every slot of a sphere's box once",
          "[gather][opencl][hash]") {
  // With fewer slots than cells, rows of a gather sphere's box share slots: gather_hash_grid
  // reads a slot only if no earlier row of the box read it (arithmetic on the slots, exact).
  // Over cell sizes and table sizes that make rows wrap around the table at many offsets, the
  // photons gathered must stay the CPU grid's.
  auto dev = test_device();
  if (!dev) return;
  Fixture f = make_fixture(24, 20, 1, 6000, DirectMode::Photons);
  HitpointSet cpu = f.fresh;
  ppm_pass(f.scene, cpu, f.passes[0].photons, f.passes[0].emitted, PpmOptions{});
  REQUIRE(gathered_hitpoints(cpu.hitpoints) > cpu.hitpoints.size() / 4);
  PpmOptions opt;
  opt.method = GatherMethod::HashGrid;
  opt.hash_order = HashOrder::Host;
  size_t differ = 0;
  for (float cell : {0.6f, 1.f, 1.5f, 2.f, 3.f})
    for (int slots : {4, 8, 16, 32}) {
      opt.hash_cell = cell;
      opt.hash_slots = slots;
      HitpointSet h = f.fresh;
      ppm_pass(f.scene, h, f.passes[0].photons, f.passes[0].emitted, opt, *dev);
      size_t same = 0;
      for (size_t i = 0; i < h.hitpoints.size(); ++i)
        same += h.hitpoints[i].n_photons == cpu.hitpoints[i].n_photons;
      if (same != h.hitpoints.size()) WARN("cell " << cell << " slots " << slots << ": " << h.hitpoints.size() - same << " differ");
      differ += same != h.hitpoints.size();
    }
  CHECK(differ == 0);
}

TEST_CASE("gather methods: images equal naive's over 20 passes", "[gather][opencl][passes]") {
  auto dev = test_device();
  if (!dev) return;
  Fixture f = make_fixture(40, 32, 20, 3000, DirectMode::Photons);
  auto run = [&](GatherMethod m, ClContext* d) {
    PpmOptions opt;
    opt.method = m;
    ClusterSet clusters;  // made once, radii refreshed by every pass (clusters.h)
    if (d && gather_method_info(m).clusters) {
      clusters = clusters_for_method(m, f.fresh, d->work_group(), opt);
      opt.clusters = &clusters;
    }
    HitpointSet h = f.fresh;
    for (const PhotonPassResult& p : f.passes) {
      if (d)
        ppm_pass(f.scene, h, p.photons, p.emitted, opt, *d);
      else
        ppm_pass(f.scene, h, p.photons, p.emitted, opt);
    }
    CHECK(h.passes == 20);
    return h;
  };
  const HitpointSet naive = run(GatherMethod::Naive, dev.get());
  const HitpointSet grid_cpu = run(GatherMethod::Grid, nullptr);
  CHECK(same_hitpoints(naive.hitpoints, grid_cpu.hitpoints));
  const Image ref = synthesize(naive);
  double r0 = 0;  // the radii did shrink: the refresh of cluster radii was exercised
  for (const pf_hitpoint& hp : naive.hitpoints) r0 = std::max(r0, double(hp.radius));
  CHECK(r0 < naive.radius0);
  for (GatherMethod m : device_methods()) {
    if (m == GatherMethod::Naive) continue;
    INFO("method " << gather_method_name(m));
    const HitpointSet h = run(m, dev.get());
    double e = relative_rmse(synthesize(h), ref);
    INFO("relative RMSE vs naive " << e);
    CHECK(e <= 1e-5);
    size_t same_r = 0;
    for (size_t i = 0; i < h.hitpoints.size(); ++i)
      same_r += h.hitpoints[i].radius == naive.hitpoints[i].radius &&
                h.hitpoints[i].n_photons == naive.hitpoints[i].n_photons;
    CHECK(same_r == h.hitpoints.size());
  }
}

TEST_CASE("gather methods: the device grid is the CPU's grid (eq. 7.1)", "[gather][opencl][grid]") {
  auto dev = test_device();
  if (!dev) return;
  Fixture f = make_fixture(16, 16, 1, 20000, DirectMode::Photons);
  const std::vector<pf_photon>& ph = f.passes[0].photons;
  const int meshes = int(f.scene.mesh_names.size());
  for (int max_bins : {1, 7, 64}) {
    INFO("max_bins " << max_bins);
    PhotonGridParams gp;
    gp.max_bins = max_bins;
    gp.default_radius = 0.01f;
    PhotonGrid a = build_photon_grid(ph, meshes, gp);
    PhotonGrid b = build_photon_grid(ph, meshes, gp, *dev);
    REQUIRE(a.mesh_grid.size() == b.mesh_grid.size());
    for (size_t m = 0; m < a.mesh_grid.size(); ++m) {
      const pf_mesh_grid &x = a.mesh_grid[m], &y = b.mesh_grid[m];
      CHECK((x.lo[0] == y.lo[0] && x.lo[1] == y.lo[1] && x.lo[2] == y.lo[2]));
      CHECK(x.bin_size == y.bin_size);
      CHECK((x.nx == y.nx && x.ny == y.ny && x.nz == y.nz));
      CHECK((x.first_bin == y.first_bin && x.first_photon == y.first_photon &&
             x.photon_count == y.photon_count));
    }
    CHECK(a.cell_start == b.cell_start);
    CHECK(a.order == b.order);
    REQUIRE(a.photons.size() == b.photons.size());
    CHECK(std::memcmp(a.photons.data(), b.photons.data(), a.photons.size() * sizeof(pf_photon)) == 0);
  }
  // A mesh without photons, and no photons at all.
  PhotonGridParams gp;
  gp.default_radius = 0.05f;
  std::vector<pf_photon> few(ph.begin(), ph.begin() + 10);
  for (pf_photon& p : few) p.mesh = 0;
  PhotonGrid a = build_photon_grid(few, 3, gp), b = build_photon_grid(few, 3, gp, *dev);
  CHECK(a.cell_start == b.cell_start);
  CHECK(a.order == b.order);
  CHECK(build_photon_grid({}, 3, gp, *dev).cell_start == build_photon_grid({}, 3, gp).cell_start);
  // The CPU build's refusals.
  few[4].mesh = 3;
  CHECK_THROWS_AS(build_photon_grid(few, 3, gp, *dev), std::invalid_argument);
}

TEST_CASE("gather methods: a state kept on the device equals ppm_pass pass by pass",
          "[gather][opencl][resident]") {
  auto dev = test_device();
  if (!dev) return;
  for (DirectMode direct : {DirectMode::Photons, DirectMode::ShadowRays}) {
    Fixture f = make_fixture(40, 32, 6, 4000, direct);
    for (GatherMethod m : {GatherMethod::HashGrid, GatherMethod::GridKmeans}) {
      INFO("method " << gather_method_name(m));
      PpmOptions opt;
      opt.method = m;
      opt.alpha = 0.7f;
      HitpointSet copied = f.fresh, resident = f.fresh;
      DevicePpmState state(f.scene, resident, *dev);
      for (size_t p = 0; p < f.passes.size(); ++p) {
        ppm_pass(f.scene, copied, f.passes[p].photons, f.passes[p].emitted, opt, *dev);
        state.pass(f.passes[p].photons, f.passes[p].emitted, opt);
        CHECK(resident.passes == copied.passes);
        CHECK(resident.photons_emitted == copied.photons_emitted);
        if (m == GatherMethod::HashGrid) CHECK_FALSE(state.host_current());
        if (p == 2 || p + 1 == f.passes.size()) {  // mid-stream and at the end: the same bytes
          state.sync();
          CHECK(state.host_current());
          REQUIRE(resident.hitpoints.size() == copied.hitpoints.size());
          CHECK(same_hitpoints(resident.hitpoints, copied.hitpoints));
          if (m == GatherMethod::HashGrid) {  // the kernel's reduction = the host's maximum
            float rmax = 0.f;
            for (const pf_hitpoint& hp : resident.hitpoints)
              if (std::isfinite(hp.radius)) rmax = std::max(rmax, hp.radius);
            CHECK(rmax > 0.f);
            CHECK(state.device_max_radius() == rmax);
          }
        }
      }
      // The radii shrank (the passes did work).
      size_t shrunk = 0;
      for (size_t i = 0; i < copied.hitpoints.size(); ++i)
        shrunk += copied.hitpoints[i].radius < f.fresh.hitpoints[i].radius;
      CHECK(shrunk > copied.hitpoints.size() / 4);
      // Another method after a resident pass continues from the device's state.
      state.pass(f.passes[0].photons, f.passes[0].emitted, opt);
      ppm_pass(f.scene, copied, f.passes[0].photons, f.passes[0].emitted, opt, *dev);
      PpmOptions other = opt;
      other.method = m == GatherMethod::HashGrid ? GatherMethod::Naive : GatherMethod::HashGrid;
      state.pass(f.passes[1].photons, f.passes[1].emitted, other);
      ppm_pass(f.scene, copied, f.passes[1].photons, f.passes[1].emitted, other, *dev);
      state.sync();
      CHECK(same_hitpoints(resident.hitpoints, copied.hitpoints));
    }
  }
}

TEST_CASE("gather methods: hash-grid's pending list and per-lane branches give the same bytes",
          "[gather][opencl][hash]") {
  // PF_GATHER_LIST (illuminate_methods.cl): 0 reads an accepted photon's payload at once, N >= 4
  // queues accepted photons in a private list of N and reads them when it may overflow and at the
  // end. Both must sum the same photons in the same order.
  auto dev = test_device();
  if (!dev) return;
  Fixture f = make_fixture(40, 32, 3, 20000, DirectMode::Photons);
  PpmOptions opt;
  opt.method = GatherMethod::HashGrid;
  opt.alpha = 0.7f;
  {  // the 32-entry list overflows mid-hitpoint: some hitpoint accepts more than 28 photons
    HitpointSet one = f.fresh;
    PpmOptions cpu = opt;
    cpu.method = GatherMethod::Grid;
    ppm_pass(f.scene, one, f.passes[0].photons, f.passes[0].emitted, cpu);
    float most = 0.f;  // M = N / α after the first pass (eq. 3.14 with N = 0)
    for (const pf_hitpoint& hp : one.hitpoints) most = std::max(most, hp.n_photons / opt.alpha);
    CHECK(most > 28.5f);
  }
  std::vector<HitpointSet> out;
  for (long list : {0L, 4L, 32L}) {
    INFO("PF_GATHER_LIST " << list);
    ClContext c(dev->info(), 0);
    c.define("PF_GATHER_LIST", list);
    HitpointSet s = f.fresh;
    for (const PhotonPassResult& p : f.passes) ppm_pass(f.scene, s, p.photons, p.emitted, opt, c);
    CHECK_THROWS_AS(c.define("PF_GATHER_LIST", 0), std::logic_error);  // programs are cached
    out.push_back(std::move(s));
  }
  const size_t gathered = gathered_hitpoints(out[0].hitpoints);
  CHECK(gathered > out[0].hitpoints.size() / 2);
  for (size_t k = 1; k < out.size(); ++k) {
    REQUIRE(out[k].hitpoints.size() == out[0].hitpoints.size());
    CHECK(same_hitpoints(out[k].hitpoints, out[0].hitpoints));
  }
}

TEST_CASE("gather methods: resident passes over device-traced photons, no waits, equal host photons'",
          "[gather][opencl][resident]") {
  auto dev = test_device();
  if (!dev) return;
  Fixture f = make_fixture(40, 32, 0, 0, DirectMode::Photons);
  PhotonPassOptions ph;
  ph.photons = 4000;
  ph.seed = 3;
  struct Case {
    GatherMethod m;
    HashOrder order;
  };
  for (Case c : {Case{GatherMethod::HashGrid, HashOrder::Device},
                 Case{GatherMethod::HashGrid, HashOrder::Host}, Case{GatherMethod::Naive, HashOrder::Auto}}) {
    INFO("method " << gather_method_name(c.m) << ", order " << hash_order_name(c.order));
    PpmOptions opt;
    opt.method = c.m;
    opt.hash_order = c.order;
    opt.alpha = 0.7f;
    HitpointSet a = f.fresh, b = f.fresh;
    DevicePpmState sa(f.scene, a, *dev), sb(f.scene, b, *dev);
    for (uint32_t p = 0; p < 4; ++p) {
      const PhotonPassResult host = trace_photons(f.scene, p, ph, *dev);
      sa.pass(host.photons, host.emitted, opt);
      const ClWaitScope no_wait(*dev, false);  // as the render driver runs it
      CHECK_FALSE(dev->wait_each());
      const uint64_t w0 = dev->host_waits();
      const DevicePhotons traced = trace_photons_device(f.scene, p, ph, *dev);
      const uint64_t w1 = dev->host_waits();
      sb.pass(traced, opt);
      if (c.m == GatherMethod::HashGrid && c.order == HashOrder::Device && p > 0) {
        // A GPU pays a round trip per host wait: the trace waits once (its photon count), the
        // pass once (the next radius). Pass 0 also uploads the state.
        CHECK(w1 - w0 == 1);
        CHECK(dev->host_waits() - w1 == 1);
      }
    }
    CHECK(dev->wait_each());  // the scope restored the waits
    sa.sync();
    sb.sync();
    CHECK(b.passes == a.passes);
    CHECK(b.photons_emitted == a.photons_emitted);
    const size_t gathered = gathered_hitpoints(a.hitpoints);
    CHECK(gathered > a.hitpoints.size() / 2);
    REQUIRE(b.hitpoints.size() == a.hitpoints.size());
    CHECK(same_hitpoints(b.hitpoints, a.hitpoints));
  }
}

TEST_CASE("gather methods: the grid-cluster gather timer gathers the pass's photons",
          "[gather][opencl][ga]") {
  auto dev = test_device();
  if (!dev) return;
  Fixture f = make_fixture(48, 40, 1, 6000, DirectMode::Photons);
  const std::vector<pf_photon>& ph = f.passes[0].photons;
  PpmOptions opt;
  opt.alpha = 1.f;  // one pass from the fresh state with alpha 1: N = M (eq. 3.15)
  HitpointSet cpu = f.fresh;
  ppm_pass(f.scene, cpu, ph, f.passes[0].emitted, opt);
  const size_t gathered = gathered_hitpoints(cpu.hitpoints);
  REQUIRE(gathered > cpu.hitpoints.size() / 4);
  opt.method = GatherMethod::GridKmeans;
  GridGatherTimer timer(f.scene, f.fresh, ph, opt, *dev);
  std::vector<int32_t> m = timer.photon_counts();
  REQUIRE(m.size() == f.fresh.hitpoints.size());
  CHECK(std::count(m.begin(), m.end(), 0) == std::ptrdiff_t(m.size()));  // nothing gathered yet
  const int wg = dev->work_group();
  const ClusterSet kmeans = cluster_kmeans(f.fresh, wg, 10, 1, 0), grid = cluster_grid(f.fresh, wg, 0);
  for (const ClusterSet* cs : {&kmeans, &grid}) {
    CHECK(timer.time(*cs, 2) > 0.0);
    // A ppm_pass on the same context in between must not disturb the timer's buffers.
    HitpointSet other = f.fresh;
    ppm_pass(f.scene, other, f.passes[0].photons, f.passes[0].emitted, opt, *dev);
    m = timer.photon_counts();
    size_t same = 0;
    for (size_t i = 0; i < m.size(); ++i) same += float(m[i]) == cpu.hitpoints[i].n_photons;
    CHECK(same == m.size());
    timer.time(*cs);
    CHECK(timer.photon_counts() == m);
  }
  // Clusters of other hitpoints are refused.
  Fixture g = make_fixture(40, 40, 1, 1000, DirectMode::Photons);
  CHECK_THROWS_AS(timer.time(cluster_grid(g.fresh, wg, 0)), InputError);
}

TEST_CASE("gather methods: a photon on a bin edge accepted by the float distance rule is gathered",
          "[gather][opencl][grid]") {
  // The rule pf_ppm_in_radius(pf_ppm_dist2(x, p), R) is evaluated in float, so a photon a few ulps
  // beyond x + R (itself rounded) can pass it; when it lies exactly on the lower edge of the next
  // grid bin, a box of bins from x − R to x + R misses it. The kernels widen their boxes
  // (PF_SLACK) as the CPU grid does: every method must gather what the CPU grid gathers. Such a
  // case along x (test::edge_photon); the bins are d = R0 = p wide, so p is the edge of bin 1.
  auto dev = test_device();
  if (!dev) return;
  const test::EdgePhoton e = test::edge_photon();
  const float q = e.q, r = e.r, p = e.p;
  INFO("x " << q << " R " << r << " photon " << p);
  const Scene scene = room_scene(PF_MAT_DIFFUSE, 4, 4);  // (materials and meshes only)
  HitpointSet h;
  h.scene_id = scene.scene_id;
  h.width = h.height = 1;
  h.radius0 = p;  // the grid's bin size: d = max(extent / max_bins, R0) = p
  pf_hitpoint hp{};
  hp.position[0] = q;
  hp.position[1] = hp.position[2] = 0.5f;
  hp.normal[1] = 1.f;
  hp.dir[1] = -1.f;
  hp.weight[0] = hp.weight[1] = hp.weight[2] = 1.f;
  hp.radius = r;
  h.hitpoints = {hp};
  std::vector<pf_photon> photons;
  for (float x : {p, 1.5f * p, 0.f}) {  // mesh 0's photons span [0, 1.5p] along x: two bins
    pf_photon ph{};
    ph.position[0] = x;
    ph.position[1] = ph.position[2] = 0.5f;
    ph.dir[1] = -1.f;
    ph.flux[0] = ph.flux[1] = ph.flux[2] = 1.f;
    photons.push_back(ph);
  }
  PpmOptions opt;
  opt.alpha = 1.f;  // N after one pass = M, the photons gathered
  HitpointSet cpu = h;
  ppm_pass(scene, cpu, photons, 100, opt);
  REQUIRE(cpu.hitpoints[0].n_photons >= 1.f);  // (the photon at p at least)
  for (GatherMethod m : device_methods()) {
    INFO("method " << gather_method_name(m));
    opt.method = m;
    HitpointSet d = h;
    ppm_pass(scene, d, photons, 100, opt, *dev);
    CHECK(d.hitpoints[0].n_photons == cpu.hitpoints[0].n_photons);
  }
  // hash-grid's cells start at the scene's corner and are hash_cell · R_max · 1.0001² wide
  // (hash_grid.h): a hash_cell that makes them p wide puts the photon on a cell edge as well.
  REQUIRE((scene.bounds.lo.x == 0.f && scene.bounds.hi.x > 2 * p));
  float hc = p / (r * 1.0001f * 1.0001f);
  for (int k = 0; k < 64 && hc * r * 1.0001f * 1.0001f != p; ++k)
    hc = std::nextafter(hc, hc * r * 1.0001f * 1.0001f < p ? INFINITY : 0.f);
  REQUIRE(hc * r * 1.0001f * 1.0001f == p);
  opt.method = GatherMethod::HashGrid;
  opt.hash_cell = hc;
  for (HashOrder order : {HashOrder::Device, HashOrder::Host}) {
    opt.hash_order = order;
    HitpointSet d = h;
    ppm_pass(scene, d, photons, 100, opt, *dev);
    CHECK(d.hitpoints[0].n_photons == cpu.hitpoints[0].n_photons);
  }
}

TEST_CASE("gather methods: photon sorting is the stable sort by mesh", "[gather][opencl]") {
  auto dev = test_device();
  if (!dev) return;
  Fixture f = make_fixture(16, 16, 1, 5000, DirectMode::Photons);
  const std::vector<pf_photon>& ph = f.passes[0].photons;
  const int meshes = int(f.scene.mesh_names.size());
  std::vector<pf_photon> sorted;
  std::vector<int32_t> start;
  sort_photons_by_mesh(ph, meshes, *dev, sorted, start);
  std::vector<pf_photon> expect = ph;
  std::stable_sort(expect.begin(), expect.end(),
                   [](const pf_photon& a, const pf_photon& b) { return a.mesh < b.mesh; });
  REQUIRE(sorted.size() == expect.size());
  CHECK(std::memcmp(sorted.data(), expect.data(), sorted.size() * sizeof(pf_photon)) == 0);
  REQUIRE(start.size() == size_t(meshes) + 1);
  for (int m = 0; m <= meshes; ++m) {
    const auto first = std::find_if(expect.begin(), expect.end(),
                                    [&](const pf_photon& p) { return p.mesh >= m; });
    CHECK(start[size_t(m)] == first - expect.begin());
  }
}

TEST_CASE("gather methods: hitpoint sorting pads each mesh to work-group multiples",
          "[gather][fillers]") {
  HitpointSet h;
  const int per_mesh[3] = {5, 0, 130};
  for (int m = 0; m < 3; ++m)
    for (int k = 0; k < per_mesh[m]; ++k) {
      pf_hitpoint hp{};
      hp.mesh = m;
      hp.position[0] = float(k);
      h.hitpoints.push_back(hp);
    }
  std::swap(h.hitpoints[1], h.hitpoints[100]);  // meshes interleaved in the input
  for (int wg : {1, 32, 64}) {
    INFO("wg " << wg);
    const std::vector<int32_t> order = mesh_sorted_order(h, wg);
    // Table 7.5 definition: Σ over meshes of ceil(n_mesh / wg) · wg.
    size_t expect = 0;
    for (int n : per_mesh) expect += size_t((n + wg - 1) / wg) * size_t(wg);
    CHECK(order.size() == expect);
    CHECK(size_t(std::count(order.begin(), order.end(), -1)) == expect - h.hitpoints.size());
    // Every work-group: one mesh, fillers only at its mesh's tail, every hitpoint once.
    std::vector<int> seen(h.hitpoints.size(), 0);
    for (size_t g = 0; g < order.size(); g += size_t(wg)) {
      REQUIRE(order[g] >= 0);
      const int mesh = h.hitpoints[size_t(order[g])].mesh;
      bool filler = false;
      for (size_t s = g; s < g + size_t(wg); ++s) {
        if (order[s] < 0) { filler = true; continue; }
        CHECK_FALSE(filler);
        CHECK(h.hitpoints[size_t(order[s])].mesh == mesh);
        ++seen[size_t(order[s])];
      }
    }
    CHECK(std::count(seen.begin(), seen.end(), 1) == long(seen.size()));
  }
}

// NVIDIA reports 48 KiB of local memory. A work-group of 512 fits every kernel's tiles there except
// gather_clusters's (2·512 photons + 512 ints = 50 KiB): only kmeans-clusters may be refused.
TEST_CASE("gather methods: local memory is checked per kernel (48 KiB, as on NVIDIA)",
          "[gather][opencl]") {
  auto dev = test_device();
  if (!dev) return;
  ClDeviceInfo info = dev->info();
  if (info.local_mem < 64 * 1024) return;  // the device itself has less: nothing to emulate
  info.local_mem = 48 * 1024;
  ClContext nv(info, 512);
  Fixture f = make_fixture(24, 20, 1, 2000, DirectMode::Photons);
  for (GatherMethod m : device_methods()) {
    INFO(gather_method_name(m));
    PpmOptions opt;
    opt.method = m;
    HitpointSet h = f.fresh;
    if (m == GatherMethod::KmeansClusters) {
      try {
        ppm_pass(f.scene, h, f.passes[0].photons, f.passes[0].emitted, opt, nv);
        FAIL("no error");
      } catch (const InputError& e) {
        CHECK(std::string(e.what()).find("--wg-size") != std::string::npos);
      }
    } else {
      ppm_pass(f.scene, h, f.passes[0].photons, f.passes[0].emitted, opt, nv);
      CHECK(h.passes == 1);
    }
  }
}

TEST_CASE("gather methods: wrong backend and oversized passes are refused", "[gather][opencl]") {
  Fixture f = make_fixture(16, 16, 1, 2000, DirectMode::Photons);
  PpmOptions opt;
  opt.method = GatherMethod::GridKmeans;
  HitpointSet h = f.fresh;
  CHECK_THROWS_AS(ppm_pass(f.scene, h, f.passes[0].photons, f.passes[0].emitted, opt), InputError);
  auto dev = test_device();
  if (!dev) return;
  opt.method = GatherMethod::Flann;
  CHECK_THROWS_AS(ppm_pass(f.scene, h, f.passes[0].photons, f.passes[0].emitted, opt, *dev),
                  InputError);
  ClContext small(dev->info(), 0);
  small.set_max_alloc(f.passes[0].photons.size() * sizeof(pf_photon) / 2);
  opt.method = GatherMethod::HashGrid;
  try {
    ppm_pass(f.scene, h, f.passes[0].photons, f.passes[0].emitted, opt, small);
    FAIL("no error");
  } catch (const InputError& e) {
    CHECK(std::string(e.what()).find("--method naive") != std::string::npos);
  }
  CHECK(h.passes == 0);  // nothing was applied
  // A bad photon is refused by either hash-grid ordering, before the state changes.
  std::vector<pf_photon> bad = f.passes[0].photons;
  bad[bad.size() / 2].mesh = int(f.scene.mesh_names.size());
  for (HashOrder order : {HashOrder::Device, HashOrder::Host}) {
    INFO("hash order " << hash_order_name(order));
    opt.hash_order = order;
    HitpointSet b = f.fresh;
    CHECK_THROWS_AS(ppm_pass(f.scene, b, bad, f.passes[0].emitted, opt, *dev), std::invalid_argument);
    CHECK(b.passes == 0);
    CHECK(same_hitpoints(b.hitpoints, f.fresh.hitpoints));
    // The context still works after the refusal (the host ordering gave its buffers back).
    ppm_pass(f.scene, b, f.passes[0].photons, f.passes[0].emitted, opt, *dev);
    CHECK(b.passes == 1);
  }
}
