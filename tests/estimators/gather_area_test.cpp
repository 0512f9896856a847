// The surface a gather takes photons from (estimators/gather_area.h): the disc–polygon area, the
// measure (1) with its weights (2) against closed forms and against the hierarchy-free sum, and
// the estimate (3) in a furnace whose corners the disc gets wrong.
#include <catch2/catch.hpp>

#include <cmath>
#include <thread>
#include <vector>

#include "photonflow/estimators/gather_area.h"
#include "photonflow/estimators/gather_area_clip.h"
#include "photonflow/stages/illuminate.h"
#include "photonflow/geometry/procedural.h"
#include "photonflow/estimators/render_driver.h"
#include "photonflow/estimators/sppm.h"
#include "photonflow/stages/synthesize.h"
#include "support.h"

using namespace pf;

namespace {

constexpr double kPi = 3.14159265358979323846;

// The part of a disc of radius rho beyond a chord at distance d from its centre (0 <= d <= rho).
double segment(double rho, double d) {
  return rho * rho * std::acos(d / rho) - d * std::sqrt(rho * rho - d * d);
}

// The area of the disc within the polygon by counting a fine grid of points (the closed forms'
// independent check for shapes without one).
double grid_area(const std::vector<double>& p, double rho, int n = 2000) {
  const int k = int(p.size() / 2);
  double inside = 0;
  const double h = 2 * rho / n;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const double x = -rho + (i + 0.5) * h, y = -rho + (j + 0.5) * h;
      if (x * x + y * y > rho * rho) continue;
      bool in = true;
      for (int e = 0; e < k && in; ++e) {
        const int f = (e + 1) % k;
        const double ex = p[2 * f] - p[2 * e], ey = p[2 * f + 1] - p[2 * e + 1];
        in = ex * (y - p[2 * e + 1]) - ey * (x - p[2 * e]) >= 0;  // left of a→b
      }
      inside += in ? 1 : 0;
    }
  return inside * h * h;
}

// A site on mesh `mesh` at p with normal n.
pf_hitpoint site(const Vec3& p, const Vec3& n, int mesh) {
  pf_hitpoint h{};
  p.store(h.position);
  n.store(h.normal);
  h.mesh = mesh;
  h.material = mesh;
  h.weight[0] = h.weight[1] = h.weight[2] = 1.f;
  return h;
}

// A scene of the given triangles (materials: one diffuse per mesh id used).
Scene scene_of(std::vector<pf_triangle> tris) {
  Scene s;
  int meshes = 0;
  for (const auto& t : tris) meshes = std::max(meshes, std::max(t.mesh, t.material) + 1);
  s.triangles = std::move(tris);
  for (int m = 0; m < meshes; ++m) {
    s.mesh_names.push_back("m" + std::to_string(m));
    pf_material mat{};
    mat.type = PF_MAT_DIFFUSE;
    mat.ior = 1.f;
    mat.color[0] = mat.color[1] = mat.color[2] = 0.5f;
    s.materials.push_back(mat);
    s.material_names.push_back("m" + std::to_string(m));
  }
  s.camera = pf_camera{{0.5f, 0.5f, 3.f}, {0.5f, 0.5f, 0.f}, {0, 1, 0}, 40.f, 8, 8};
  finish_scene(s);
  return s;
}

// ∫_0^{k} 2 sqrt(R² − d² − s²) ds: the strip of a face at right angles to x's face, within the
// ball of radius R about x (at distance d from the shared edge) and the slab of half-width k.
double strip_area(double R, double d, double k) {
  const int n = 200000;
  double a = 0;
  for (int i = 0; i < n; ++i) {
    const double s = (i + 0.5) * k / n;
    const double q = R * R - d * d - s * s;
    if (q > 0) a += 2 * std::sqrt(q) * k / n;
  }
  return a;
}

}  // namespace

TEST_CASE("disc_polygon_area: closed forms, quick paths and a counted grid", "[gather-area]") {
  const double rho = 0.3;
  // A square around the disc: the whole disc; one far away: nothing.
  const std::vector<double> big = {-1, -1, 1, -1, 1, 1, -1, 1};
  CHECK(disc_polygon_area(big.data(), 4, rho) == Approx(kPi * rho * rho).epsilon(1e-12));
  const std::vector<double> far = {2, 2, 3, 2, 3, 3, 2, 3};
  CHECK(disc_polygon_area(far.data(), 4, rho) == 0.0);
  // A chord at distance d: the disc less its segment; the centre on an edge: half; on a corner:
  // a quarter.
  for (double d : {0.0, 0.05, 0.1, 0.2, 0.29}) {
    const std::vector<double> cut = {-1, -1, d, -1, d, 1, -1, 1};
    INFO("d " << d);
    CHECK(disc_polygon_area(cut.data(), 4, rho) ==
          Approx(kPi * rho * rho - segment(rho, d)).epsilon(1e-10));
  }
  const std::vector<double> corner = {0, 0, 1, 0, 1, 1, 0, 1};
  CHECK(disc_polygon_area(corner.data(), 4, rho) == Approx(kPi * rho * rho / 4).epsilon(1e-10));
  // A triangle inside the disc: its own area.
  const std::vector<double> small = {0, 0, 0.1, 0, 0, 0.1};
  CHECK(disc_polygon_area(small.data(), 3, rho) == Approx(0.005).epsilon(1e-12));
  // Triangles crossing the circle in every way (a corner out, two out, an edge grazing):
  // against a 2000² grid count (its error is below 1e-3 of the disc here).
  const std::vector<std::vector<double>> tris = {
      {-0.1, -0.1, 0.5, 0.0, 0.0, 0.2}, {-0.5, -0.2, 0.5, -0.2, 0.0, 0.6},
      {0.1, -0.4, 0.4, 0.4, -0.35, 0.1}, {-0.29, -0.5, -0.29, 0.5, -0.6, 0.0}};
  for (const auto& t : tris) {
    INFO("triangle " << t[0] << "," << t[1] << " " << t[2] << "," << t[3] << " " << t[4] << ","
                     << t[5]);
    CHECK(disc_polygon_area(t.data(), 3, rho) ==
          Approx(grid_area(t, rho)).margin(1e-3 * kPi * rho * rho));
  }
}

TEST_CASE("SurfaceArea: the disc inside a face, cut by its border, and a box's edge with the slab",
          "[gather-area]") {
  // Mesh 0: the floor y = 0, [0, 1]²; mesh 1: a wall x = 0 (another mesh: never counted).
  std::vector<pf_triangle> tris = test::quad(Vec3(0, 0, 0), Vec3(0, 0, 1), Vec3(1, 0, 1),
                                             Vec3(1, 0, 0), 0);
  const auto wall = test::quad(Vec3(0, 0, 0), Vec3(0, 1, 0), Vec3(0, 1, 1), Vec3(0, 0, 1), 1);
  tris.insert(tris.end(), wall.begin(), wall.end());
  const Scene s = scene_of(tris);
  const SurfaceArea& a = surface_area(s);
  const float R = 0.1f;
  const double disc = kPi * double(R) * double(R);
  const Vec3 up(0, 1, 0);
  for (float slab : {0.f, 0.25f}) {
    INFO("slab " << slab);
    // Inside (across the quad's diagonal too): the disc, scale 1.
    for (const Vec3& p : {Vec3(0.5f, 0, 0.5f), Vec3(0.3f, 0, 0.31f)}) {
      CHECK(a.area(site(p, up, 0), R, slab) == Approx(disc).epsilon(1e-6));
      CHECK(a.scale(site(p, up, 0), R, slab) == Approx(1.0).epsilon(1e-6));
    }
    // Near the wall (x = d): the disc less its segment; at the corner (x = z = 0): a quarter.
    for (float d : {0.f, 0.03f, 0.07f}) {
      const pf_hitpoint h = site(Vec3(d, 0, 0.5f), up, 0);
      INFO("d " << d);
      CHECK(a.area(h, R, slab) == Approx(disc - segment(R, d)).epsilon(1e-5));
      CHECK(a.area_brute(h, R, slab) == Approx(a.area(h, R, slab)).epsilon(1e-9));
    }
    CHECK(a.area(site(Vec3(0, 0, 0), up, 0), R, slab) == Approx(disc / 4).epsilon(1e-5));
    // Seen from below (normal −y): the same measure (σ = −1 and the weights agree).
    CHECK(a.area(site(Vec3(0.03f, 0, 0.5f), -up, 0), R, slab) ==
          Approx(disc - segment(R, 0.03)).epsilon(1e-5));
  }
  // No mesh, no triangle at the site, R = 0: no area, scale 1.
  CHECK(a.area(site(Vec3(0.5f, 0, 0.5f), up, -1), R, 0.f) == 0.0);
  CHECK(a.area(site(Vec3(0.5f, 0.5f, 0.5f), up, 0), R, 0.f) == 0.0);
  CHECK(a.scale(site(Vec3(0.5f, 0.5f, 0.5f), up, 0), R, 0.f) == 1.0);
  CHECK(a.area(site(Vec3(0.5f, 0, 0.5f), up, 0), 0.f, 0.f) == 0.0);

  // One mesh: an outward box [0, 1]³. A site on its top face at distance d from the edge x = 1
  // counts the top's disc part whole and the side face x = 1 within the slab at weight
  // (1 + m·n)/2 = 1/2 (eq. 2); without the slab the side's whole part within the ball. The
  // bottom face never lies within R here; its weight would be 0.
  const Scene box = scene_of(make_box(Vec3(0, 0, 0), Vec3(1, 1, 1), false, {0, 0}));
  const SurfaceArea& b = surface_area(box);
  for (float d : {0.02f, 0.06f}) {
    const pf_hitpoint h = site(Vec3(1 - d, 1, 0.5f), up, 0);
    const double top = disc - segment(R, d);
    INFO("d " << d);
    CHECK(b.area(h, R, 0.25f) == Approx(top + 0.5 * strip_area(R, d, 0.25 * R)).epsilon(1e-4));
    CHECK(b.area(h, R, 0.f) == Approx(top + 0.5 * strip_area(R, d, R)).epsilon(1e-4));
    CHECK(b.area_brute(h, R, 0.25f) == Approx(b.area(h, R, 0.25f)).epsilon(1e-9));
    // A transmissive PBR point takes photons from both sides: weight 1.
    CHECK(b.area(h, R, 0.25f, true) == Approx(top + strip_area(R, d, 0.25 * R)).epsilon(1e-4));
  }
  // A slab thinner than a box of height 0.05: the site on its top does not count the bottom
  // (weight 0: photons there arrive from below).
  const Scene thin = scene_of(make_box(Vec3(0, 0, 0), Vec3(1, 0.05f, 1), false, {0, 0}));
  CHECK(surface_area(thin).area(site(Vec3(0.5f, 0.05f, 0.5f), up, 0), R, 0.f) ==
        Approx(disc).epsilon(1e-5));
}

TEST_CASE("SurfaceArea: the hierarchy's sum equals every triangle clipped, on fine meshes",
          "[gather-area]") {
  // A bumpy closed mesh (blob, geometric normals) and a smooth sphere: sites at triangle
  // centroids, radii from a tenth of the object to larger than it, with and without the slab.
  for (int which = 0; which < 2; ++which) {
    const Scene s = scene_of(which == 0 ? make_blob(Vec3(0.5f, 0.5f, 0.5f), 0.4f, 3000, 0.2f, 7)
                                        : make_sphere(Vec3(0.5f, 0.5f, 0.5f), 0.4f, 2000));
    const SurfaceArea& a = surface_area(s);
    int checked = 0;
    for (size_t i = 0; i < s.triangles.size(); i += 97) {
      const pf_triangle& t = s.triangles[i];
      const Vec3 c = (Vec3(t.v0) + Vec3(t.v1) + Vec3(t.v2)) * (1.f / 3.f);
      const pf_hitpoint h = site(c, s.normal_of(i), 0);
      for (float R : {0.04f, 0.15f, 0.5f})
        for (float slab : {0.f, 0.25f}) {
          INFO("mesh " << which << " triangle " << i << " R " << R << " slab " << slab);
          const double brute = a.area_brute(h, R, slab);
          CHECK(brute > 0);
          CHECK(a.area_at(h, R, slab) == Approx(brute).epsilon(1e-9));
          ++checked;
        }
    }
    CHECK(checked > 100);
  }
}

TEST_CASE("SurfaceArea: a fine flat mesh under a tilted normal: the slab's strip within the disc",
          "[gather-area]") {
  // The floor y = 0 over [0, 1]² in 150² cells of two triangles (too small to merge into quads),
  // seen with a shading normal tilted by θ about z: the slab |n·(y − x)| <= κR cuts the plane in
  // the strip |s| <= κR / sin θ across x, so A = w · 2 ∫_0^min(κR/sinθ, R) 2 sqrt(R² − s²) ds with
  // the weight w = (1 + cos θ)/2 of eq. (2). Most triangles near x lie in the ball and cross
  // the strip's border (clipped's closed form for the slab alone); those on the ball's border,
  // and those beyond it in the leaves it opens, take the polygon clip and the far-corner test.
  const int cells = 150;
  std::vector<pf_triangle> tris;
  for (int i = 0; i < cells; ++i)
    for (int j = 0; j < cells; ++j) {
      const float x0 = float(i) / cells, x1 = float(i + 1) / cells;
      const float z0 = float(j) / cells, z1 = float(j + 1) / cells;
      const auto q = test::quad(Vec3(x0, 0, z0), Vec3(x0, 0, z1), Vec3(x1, 0, z1), Vec3(x1, 0, z0), 0);
      tris.insert(tris.end(), q.begin(), q.end());
    }
  const Scene s = scene_of(tris);
  const SurfaceArea& a = surface_area(s);
  for (double theta : {0.3, 0.5236, 1.2})
    for (float R : {0.02f, 0.05f})
      for (const Vec3& p : {Vec3(0.5f, 0, 0.5f), Vec3(0.4137f, 0, 0.6021f)}) {
        const Vec3 n(float(std::sin(theta)), float(std::cos(theta)), 0.f);
        const double half = std::min(0.25 * double(R) / double(n.x), double(R));
        const double w = 0.5 * (1.0 + double(n.y));
        INFO("theta " << theta << " R " << R << " x " << p.x);
        const double expect = w * 2.0 * strip_area(R, 0.0, half);
        CHECK(a.area_at(site(p, n, 0), R, 0.25f) == Approx(expect).epsilon(1e-6));
        CHECK(a.area_brute(site(p, n, 0), R, 0.25f) == Approx(expect).epsilon(1e-6));
        // Without the slab: the whole disc at that weight.
        CHECK(a.area_at(site(p, n, 0), R, 0.f) == Approx(w * kPi * R * R).epsilon(1e-9));
      }
}

TEST_CASE("SurfaceArea: small triangles interpolate cached corner values, the same in any thread",
          "[gather-area]") {
  // A fine sphere (triangles far smaller than R): area() interpolates the ratios of the corners
  // (gather_area.h); on the smooth sphere that stays within a few percent of the value at the
  // site, it does not depend on who computed a corner first, and it is below 1 in scale (a
  // curved surface holds more than the disc) only where the slab lets it.
  const Scene s = scene_of(make_sphere(Vec3(0.5f, 0.5f, 0.5f), 0.4f, 20000));
  const float R = 0.08f;
  std::vector<pf_hitpoint> sites;
  for (size_t i = 0; i < s.triangles.size(); i += 13) {
    const pf_triangle& t = s.triangles[i];
    const Vec3 p = Vec3(t.v0) * 0.2f + Vec3(t.v1) * 0.5f + Vec3(t.v2) * 0.3f;
    sites.push_back(site(p, s.normal_of(i), 0));
  }
  std::vector<double> first(sites.size()), second(sites.size());
  {
    const SurfaceArea fresh(s);  // its own cache, filled by two threads in opposite orders
    std::thread t1([&] {
      for (size_t i = 0; i < sites.size(); ++i) first[i] = fresh.area(sites[i], R, 0.25f);
    });
    std::thread t2([&] {
      for (size_t i = sites.size(); i-- > 0;) second[i] = fresh.area(sites[i], R, 0.25f);
    });
    t1.join();
    t2.join();
  }
  const SurfaceArea other(s);
  double worst = 0;
  for (size_t i = 0; i < sites.size(); ++i) {
    REQUIRE(first[i] == second[i]);
    REQUIRE(other.area(sites[i], R, 0.25f) == first[i]);
    worst = std::max(worst, std::fabs(first[i] / other.area_at(sites[i], R, 0.25f) - 1));
  }
  INFO("worst relative difference to the value at the site " << worst);
  CHECK(worst < 0.03);
}

TEST_CASE("furnace in a cube: the surface estimate is unbiased at the edges where the disc's "
          "is dark", "[gather-area][furnace]") {
  // Inside a cube whose six faces (six meshes, then one mesh) emit Le and reflect ρ, the
  // radiance is Le/(1 − ρ) everywhere, corners included. The camera looks into a corner, so a
  // good share of the pixels see points within R of an edge: with the disc those lose up to
  // three quarters of their photons' area (the mean falls), with the surface none.
  const float rho = 0.5f, le = 1.f, expected = le / (1.f - rho);
  for (int meshes : {6, 1}) {
    std::vector<pf_triangle> tris = make_box(Vec3(0, 0, 0), Vec3(1, 1, 1), true, {0, 0});
    if (meshes == 6)
      for (size_t i = 0; i < tris.size(); ++i) tris[i].mesh = int(i / 2);
    Scene s;
    s.triangles = tris;
    for (int m = 0; m < meshes; ++m) s.mesh_names.push_back("face" + std::to_string(m));
    s.materials = {test::furnace_material(rho, le)};
    s.material_names = {"furnace"};
    s.camera = pf_camera{{0.75f, 0.7f, 0.75f}, {0.f, 0.f, 0.f}, {0, 1, 0}, 70.f, 16, 16};
    finish_scene(s);
    double mean[2];
    for (int k = 0; k < 2; ++k) {
      RenderOptions opt;
      opt.estimator = Estimator::Pppm;
      opt.passes = 8;
      opt.photons.photons = 40000;
      opt.photons.max_bounces = 64;
      opt.eye.radius = 0.12f;
      opt.ppm.slab = 0.25f;
      opt.ppm.gather_area = k == 0 ? GatherArea::Disc : GatherArea::Surface;
      const Image img = synthesize(render_pppm(s, opt, false, Provenance{}, {}, {}, nullptr));
      double sum = 0;
      for (float v : img.rgb) sum += v;
      mean[k] = sum / double(img.rgb.size()) / expected;
    }
    INFO(meshes << " meshes: mean / expected, disc " << mean[0] << ", surface " << mean[1]);
    // Half the radiance is the walls' own emission (Le of Le/(1 − ρ) at ρ = 1/2), seen by the
    // eye paths; the photons carry the other half, and the disc loses 2.4–3.6 % of it.
    CHECK(mean[0] < 0.992);                    // the disc's edges are dark
    CHECK(std::fabs(mean[1] - 1.0) < 0.004);   // the surface's are not
  }
}
