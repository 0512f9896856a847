// Photons where the camera looks (photon_guide.h): the uniform route unchanged, the visible set
// against brute force, the visible fraction, the chains' acceptance, thread independence, and the
// guided and uniform estimates agreeing in mean.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstring>
#include <vector>

#include "photonflow/estimators/render_driver.h"
#include "photonflow/estimators/sppm.h"
#include "photonflow/foundations/error.h"
#include "photonflow/foundations/rng.h"
#include "photonflow/sampling/sampling.h"
#include "photonflow/stages/eye_pass.h"
#include "photonflow/stages/illuminate.h"
#include "photonflow/stages/photon_guide.h"
#include "photonflow/stages/photon_pass.h"
#include "support.h"

using namespace pf;
using namespace pf::test;

namespace {

uint64_t fnv(const void* p, size_t n, uint64_t h) {
  const unsigned char* b = static_cast<const unsigned char*>(p);
  for (size_t i = 0; i < n; ++i) {
    h ^= b[i];
    h *= 1099511628211ull;
  }
  return h;
}

uint64_t photon_hash(const PhotonPassResult& r) {
  uint64_t h = fnv(r.photons.data(), r.photons.size() * sizeof(pf_photon), 1469598103934665603ull);
  return fnv(&r.emitted, sizeof(r.emitted), h);
}

// The closed room of support.h (all diffuse walls, a sphere of `type`) with a narrow camera on
// the far bottom-left corner: only the photons that land there are visible.
Scene corner_room(int type = PF_MAT_DIFFUSE, int size = 16) {
  Scene s = room_scene(type, size, size);
  s.camera = pf_camera{{0.5f, 0.5f, 0.97f}, {0.08f, 0.08f, 0.f}, {0, 1, 0}, 12.f, size, size};
  return s;
}

EyePassResult eye_pass_of(const Scene& s, uint32_t pass) {
  EyePassOptions eo;
  eo.pass = pass;
  eo.seed = 3;
  return trace_hitpoints(s, eo);
}

// Σ over visible points of the luminance of the photons of its mesh within r, over the pass's
// emitted photons: a linear measurement of the pass's photons (a gather without the BSDF).
double measure(const Scene& s, const EyePassResult& eye, const PhotonPassResult& ph, float r) {
  PhotonGridParams gp;
  gp.default_radius = r;
  const PhotonGrid g = build_photon_grid(ph.photons, int(s.mesh_names.size()), gp);
  double sum = 0;
  for (const pf_hitpoint& h : eye.hitpoints)
    g.for_each_in_radius(h.mesh, h.position, r, [&](int i) {
      const float* f = g.photons[size_t(i)].flux;
      sum += double(f[0] + f[1] + f[2]);
    });
  return sum / double(ph.emitted);
}

}  // namespace

TEST_CASE("photon guide: the uniform route traces the photons it traced before the refactor",
          "[photon_guide]") {
  // Hashes of trace_photons' output at c51a99e (before one function traced both routes), glass,
  // mirror and diffuse spheres in the room, passes 0 and 3.
  struct Golden {
    int type;
    uint32_t pass;
    size_t n;
    uint64_t hash;
  };
  const Golden golden[] = {{PF_MAT_GLASS, 0, 11827, 0xa12359def02d41d5ull},
                           {PF_MAT_GLASS, 3, 12341, 0xf565acaa00f67e1dull},
                           {PF_MAT_MIRROR, 0, 12063, 0x27cb5a2f9ebf6d03ull},
                           {PF_MAT_MIRROR, 3, 12369, 0xfadc759331bc7145ull},
                           {PF_MAT_DIFFUSE, 0, 12381, 0x89fa1ff259af845bull},
                           {PF_MAT_DIFFUSE, 3, 12857, 0x18a898360fb1e6e5ull}};
  for (const Golden& g : golden) {
    const Scene s = room_scene(g.type, 8, 8);
    PhotonPassOptions o;
    o.photons = 5000;
    o.seed = 7;
    o.threads = 2;
    const PhotonPassResult r = trace_photons(s, g.pass, o);
    INFO("type " << g.type << " pass " << g.pass);
    CHECK(r.photons.size() == g.n);
    CHECK(photon_hash(r) == g.hash);
    // A visible set given to the uniform route changes nothing, and its stats stay zero.
    VisibleSet vis;
    vis.build(eye_pass_of(s, g.pass).hitpoints, {0.05f}, {}, false);
    PhotonGuideStats st;
    st.uniform = 99;
    const PhotonPassResult r2 = trace_photons(s, g.pass, o, &vis, &st);
    CHECK(photon_hash(r2) == g.hash);
    CHECK(st.uniform == 0);
  }
}

TEST_CASE("photon guide: the visible set answers as brute force with the gathers' rule",
          "[photon_guide]") {
  // Points on two meshes with random normals, every third one transmissive PBR (gathers from both
  // sides); photons with random directions, meshes and direct flags. V must take exactly what
  // photon_accepted and the distance test take (illuminate.h), with and without skip_direct.
  std::vector<pf_hitpoint> pts(500);
  std::vector<pf_pbr_point> bsdf(pts.size());
  std::vector<float> radius(pts.size());
  auto unit = [](uint32_t key, uint32_t i, float out[3]) {
    const Vec3 v = sample_uniform_sphere(pf_rng_float(key, 0, i, 0), pf_rng_float(key, 0, i, 1));
    v.store(out);
  };
  for (size_t k = 0; k < pts.size(); ++k) {
    pts[k] = pf_hitpoint{};
    for (int a = 0; a < 3; ++a) pts[k].position[a] = pf_rng_float(5, 0, uint32_t(k), uint32_t(a));
    unit(8, uint32_t(k), pts[k].normal);
    pts[k].mesh = k % 17 == 0 ? -1 : int(k % 2);  // no visible point: left out
    radius[k] = 0.01f + 0.04f * pf_rng_float(5, 1, uint32_t(k), 0);
    bsdf[k] = pf_pbr_point{};
    if (k % 3 == 0) bsdf[k].params.transmission = 1.f;  // metallic 0: two-sided
  }
  for (bool skip_direct : {false, true}) {
    INFO("skip_direct " << skip_direct);
    VisibleSet vis;
    vis.build(pts, radius, bsdf, skip_direct);
    CHECK(vis.size() == pts.size() - (pts.size() + 16) / 17);
    int hits = 0, near_only = 0;
    for (uint32_t q = 0; q < 20000; ++q) {
      pf_photon ph{};
      for (int a = 0; a < 3; ++a) ph.position[a] = -0.1f + 1.2f * pf_rng_float(6, 0, q, uint32_t(a));
      unit(9, q, ph.dir);
      ph.mesh = int(q % 2);
      ph.flags = q % 5 == 0 ? PF_PHOTON_DIRECT : 0;
      bool brute = false, near = false;
      for (size_t k = 0; k < pts.size() && !brute; ++k) {
        if (pts[k].mesh < 0) continue;
        const bool in = pf_ppm_in_radius(pf_ppm_dist2(pts[k].position[0], pts[k].position[1],
                                                      pts[k].position[2], ph.position[0],
                                                      ph.position[1], ph.position[2]),
                                         radius[k]);
        near = near || in;
        brute = in && photon_accepted(pts[k], ph, skip_direct, pbr_two_sided_gather(&bsdf[k]));
      }
      hits += brute;
      near_only += near && !brute;
      REQUIRE(vis.near(ph) == brute);
    }
    CHECK(hits > 150);  // both answers occur (a quarter of the near photons pass the rule)
    CHECK(hits < 19000);
    CHECK(near_only > 500);  // the rule, not the distance alone, decides for many photons
  }
  // A photon on the float edge of a radius (support.h edge_photon) is near, as the gathers take it.
  const EdgePhoton e = edge_photon();
  pf_hitpoint h{};
  h.position[0] = e.q;
  h.normal[1] = 1.f;
  VisibleSet one;
  one.build({h}, {e.r}, {}, false);
  pf_photon at{};
  at.position[0] = e.p;
  at.dir[1] = -1.f;  // arriving at the front
  pf_photon past = at;
  past.position[0] = std::nextafter(e.q + 2 * e.r, INFINITY);
  CHECK(one.near(at));
  CHECK_FALSE(one.near(past));
  pf_photon nan = at;
  nan.position[0] = NAN;
  CHECK_FALSE(one.near(nan));
  pf_photon behind = at;  // the outside of a thin wall, the same place as the point
  behind.dir[1] = 1.f;
  CHECK_FALSE(one.near(behind));
  pf_photon other = at;
  other.mesh = 1;
  CHECK_FALSE(one.near(other));
}

TEST_CASE("photon guide: the visible fraction is that of the uniform photons that reach a "
          "visible point",
          "[photon_guide]") {
  // All-diffuse room: every path with a deposit starts with a PF_PHOTON_DIRECT one, so the
  // uniform photons split into paths, and each path is tested against every visible point.
  const Scene s = corner_room();
  const EyePassResult eye = eye_pass_of(s, 2);
  const float r = 0.04f;
  VisibleSet vis;
  vis.build(eye.hitpoints, {r}, {}, false);
  PhotonPassOptions o;
  o.photons = 6000;
  o.seed = 11;
  const PhotonPassResult uni = trace_photons(s, 2, o);
  uint64_t visible = 0;
  bool this_path = false;
  for (size_t i = 0; i <= uni.photons.size(); ++i) {
    const bool starts = i == uni.photons.size() || (uni.photons[i].flags & PF_PHOTON_DIRECT);
    if (starts) {
      visible += this_path;
      this_path = false;
    }
    if (i == uni.photons.size()) break;
    const float* p = uni.photons[i].position;
    for (const pf_hitpoint& h : eye.hitpoints)
      if (h.mesh >= 0 && photon_accepted(h, uni.photons[i], false) &&
          pf_ppm_in_radius(pf_ppm_dist2(h.position[0], h.position[1], h.position[2], p[0], p[1],
                                        p[2]),
                           r))
        this_path = true;
  }
  o.guide = PhotonGuide::Visibility;
  PhotonGuideStats st;
  const PhotonPassResult g = trace_photons(s, 2, o, &vis, &st);
  CHECK(g.emitted == o.photons);  // the gathers' normaliser: the slots
  CHECK(st.uniform == o.photons);
  CHECK(st.visible == visible);
  CHECK(st.visible_fraction() > 0.005);  // the camera sees a corner: few photons reach it
  CHECK(st.visible_fraction() < 0.3);
  CHECK(st.chain_photons <= o.photons);
  CHECK(st.chain_photons >= st.visible);  // every visible slot is a chain step
}

TEST_CASE("photon guide: the chains' acceptance rate adapts toward 0.234", "[photon_guide]") {
  const Scene s = corner_room();
  PhotonPassOptions o;
  o.photons = 40000;
  o.guide = PhotonGuide::Visibility;
  PhotonGuideStats total;
  for (uint32_t pass = 0; pass < 2; ++pass) {
    VisibleSet vis;
    vis.build(eye_pass_of(s, pass).hitpoints, {0.03f}, {}, false);
    PhotonGuideStats st;
    trace_photons(s, pass, o, &vis, &st);
    total.add(st);
  }
  INFO("acceptance " << total.acceptance() << " visible " << total.visible_fraction());
  REQUIRE(total.mutations > 10000);
  CHECK(std::fabs(total.acceptance() - kGuideTargetAcceptance) < 0.06);
}

TEST_CASE("photon guide: guided photons do not depend on the thread count", "[photon_guide]") {
  const Scene s = corner_room(PF_MAT_GLASS);
  VisibleSet vis;
  vis.build(eye_pass_of(s, 1).hitpoints, {0.04f}, {}, false);
  PhotonPassOptions o;
  o.photons = 7000;
  o.guide = PhotonGuide::Visibility;
  PhotonGuideStats s1, s2;
  o.threads = 1;
  const PhotonPassResult a = trace_photons(s, 1, o, &vis, &s1);
  o.threads = 2;
  const PhotonPassResult b = trace_photons(s, 1, o, &vis, &s2);
  REQUIRE(a.photons.size() == b.photons.size());
  CHECK(a.photons.size() > 1000);
  CHECK(std::memcmp(a.photons.data(), b.photons.data(), a.photons.size() * sizeof(pf_photon)) == 0);
  CHECK(s1.accepted == s2.accepted);
  CHECK(s1.visible == s2.visible);
  // Another pass has other chains (its own streams).
  const PhotonPassResult c = trace_photons(s, 2, o, &vis);
  CHECK(photon_hash(c) != photon_hash(b));
  // Without its visible points a guided pass is refused.
  CHECK_THROWS_AS(trace_photons(s, 1, o), std::invalid_argument);
}

TEST_CASE("photon guide: guided and uniform photons agree in mean where the camera looks",
          "[photon_guide]") {
  const Scene s = corner_room();
  const float r = 0.04f;
  PhotonPassOptions uo;
  uo.photons = 20000;
  PhotonPassOptions go = uo;
  go.guide = PhotonGuide::Visibility;
  const int passes = 10;
  std::vector<double> mu, mg;
  for (int p = 0; p < passes; ++p) {
    const EyePassResult eye = eye_pass_of(s, uint32_t(p));
    VisibleSet vis;
    vis.build(eye.hitpoints, {r}, {}, false);
    mu.push_back(measure(s, eye, trace_photons(s, uint32_t(p), uo), r));
    mg.push_back(measure(s, eye, trace_photons(s, uint32_t(p), go, &vis), r));
  }
  auto mean_se = [](const std::vector<double>& v, double& se) {
    double m = 0, q = 0;
    for (double x : v) m += x;
    m /= double(v.size());
    for (double x : v) q += (x - m) * (x - m);
    se = std::sqrt(q / double(v.size() - 1) / double(v.size()));
    return m;
  };
  double se_u = 0, se_g = 0;
  const double m_u = mean_se(mu, se_u), m_g = mean_se(mg, se_g);
  INFO("uniform " << m_u << " ± " << se_u << ", visibility " << m_g << " ± " << se_g);
  REQUIRE(m_u > 0);
  CHECK(std::fabs(m_u - m_g) < 4 * std::sqrt(se_u * se_u + se_g * se_g));
  CHECK(std::fabs(m_u - m_g) < 0.05 * m_u);
  CHECK(se_g < se_u);  // the point of it: more photons where the camera looks
}

TEST_CASE("photon guide: render's pppm with guided photons agrees with uniform photons, and its "
          "record says what the chains did",
          "[photon_guide]") {
  const Scene s = corner_room(PF_MAT_DIFFUSE, 12);
  RenderOptions o;
  o.estimator = Estimator::Pppm;
  o.passes = 6;
  o.photons.photons = 15000;
  o.eye.radius = 0.04f;
  o.ppm.slab = kDefaultSlab;
  Provenance prov;
  RenderStatus su, sg;
  const PassSums u = render_pppm(s, o, false, prov, {}, {}, &su);
  o.photons.guide = PhotonGuide::Visibility;
  const PassSums g = render_pppm(s, o, false, prov, {}, {}, &sg);
  double tu = 0, tg = 0;
  for (size_t i = 0; i < u.sum.size(); ++i) {
    tu += u.sum[i];
    tg += g.sum[i];
  }
  INFO("uniform " << tu << " visibility " << tg);
  REQUIRE(tu > 0);
  CHECK(std::fabs(tg - tu) < 0.05 * tu);
  CHECK(su.guide.uniform == 0);
  CHECK(sg.guide.uniform == uint64_t(o.passes) * o.photons.photons);
  CHECK(sg.guide.visible_fraction() > 0);
  CHECK(sg.guide.acceptance() > 0);
  const std::string json = render_record_json(prov, {{"x.exr", sg}});
  CHECK(json.find("\"visible_fraction\"") != std::string::npos);
  CHECK(render_record_json(prov, {{"x.exr", su}}).find("visible_fraction") == std::string::npos);
  // sppm runs the eye pass first too.
  o.estimator = Estimator::Sppm;
  o.passes = 2;
  RenderStatus ss;
  const HitpointSet h = render_progressive(s, o, false, prov, {}, {}, &ss);
  CHECK(h.passes == 2);
  CHECK(ss.guide.uniform == 2u * o.photons.photons);
}

TEST_CASE("photon guide: the option parses, and only visibility enters the state parameters",
          "[photon_guide]") {
  CHECK(parse_photon_guide("uniform") == PhotonGuide::Uniform);
  CHECK(parse_photon_guide("visibility") == PhotonGuide::Visibility);
  CHECK_THROWS_AS(parse_photon_guide("metropolis"), InputError);
  RenderOptions o;
  o.estimator = Estimator::Pppm;
  CHECK(state_parameters(o).count("photon-guide") == 0);  // old checkpoints resume
  o.photons.guide = PhotonGuide::Visibility;
  CHECK(state_parameters(o).at("photon-guide") == "visibility");
  CHECK(state_parameter_unrecorded_value("photon-guide") == std::string("uniform"));
}
