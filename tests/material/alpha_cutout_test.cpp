// Alpha cut-outs end to end (issue 32 items 3, 6, 7): scene.h5 format version 5's alpha table
// (materials/alpha_cutoff, alpha_factor, alpha_texture), the glTF alphaMode / alphaCutoff and OBJ
// map_d import, and the any-hit test in every traversal: a masked plane between a light and a
// floor passes the fraction of light its mask leaves open, to photons, eye rays, shadow rays, the
// path tracer and the SPPM, PPPM and PPM images; the OpenCL tracers agree with the CPU's.
//
// The masked scene: a 20×20 m floor (y = 0, albedo 0.5), a black (albedo 0) masked plane of the
// same size at y = 1, and a 2×2 m light at y = 2 facing down. The plane's alpha texture is 2×2
// texels, nearest filter, repeated kPeriods times over the plane: texel (0, 0) alpha 0, the others
// alpha 1, so exactly kOpen = 1/4 of the plane is cut away in every 2 cm period. The light's
// footprint on the plane (about 1 m for a floor point, several metres for photons) spans many
// periods, so a smooth distribution of rays meets the open texels with probability kOpen up to
// the partial periods at its edge (kEdgeBias below).
#include <catch2/catch.hpp>

#include <png.h>

#include <cmath>
#include <cstring>
#include <fstream>

#include "h5edit.h"
#include "photonflow/opencl/cl_backend.h"
#include "photonflow/foundations/error.h"
#include "photonflow/stages/eye_pass.h"
#include "photonflow/image/image.h"
#include "photonflow/stages/pathtrace.h"
#include "photonflow/stages/photon_pass.h"
#include "photonflow/geometry/raycast.h"
#include "photonflow/geometry/scene.h"
#include "photonflow/geometry/scene_file.h"
#include "photonflow/geometry/scene_import.h"
#include "photonflow/geometry/surface.h"
#include "support.h"
#include "support_cl.h"

using namespace pf;

namespace {

constexpr float kPeriods = 1000.f;  // mask periods over the plane's 20 m: 2 cm each
constexpr double kOpen = 0.25;      // open fraction of the mask (1 texel of 4)
// Bias allowance of a fraction measured over a footprint of >= 50 periods: at most one partial
// period at each edge is unbalanced, 2/50 of the fraction.
constexpr double kEdgeBias = kOpen * 2.0 / 50.0;
enum : int { kFloor = 0, kPlane = 1, kLight = 2 };

std::string q(const std::string& s) { return "'" + s + "'"; }

Provenance prov() {
  Provenance p;
  p.tool = "test";
  return p;
}

std::vector<pf_triangle> quad_y(float y, float h, int id, bool down) {
  // x, z in [−h, h] at height y, facing +y (or −y when `down`).
  const Vec3 a(-h, y, -h), b(-h, y, h), c(h, y, h), d(h, y, -h);
  return down ? test::quad(a, d, c, b, id) : test::quad(a, b, c, d, id);
}

// The glTF UV of a point of the plane (x, z in [−10, 10]).
void plane_uv(float x, float z, float& u, float& v) {
  u = (x + 10.f) / 20.f * kPeriods;
  v = (z + 10.f) / 20.f * kPeriods;
}

// 1 when the mask is cut away at plane UV (u, v) (texel (0, 0) of each 2×2 period), 0 opaque;
// −1 within 1e-3 texel of a texel edge (either may be seen there after rounding).
int cut_at(float u, float v) {
  const double x = 2.0 * double(u), y = 2.0 * double(v);
  const double fx = x - std::floor(x), fy = y - std::floor(y);
  if (fx < 1e-3 || fx > 1 - 1e-3 || fy < 1e-3 || fy > 1 - 1e-3) return -1;
  const long ix = long(std::floor(x)) % 2, iy = long(std::floor(y)) % 2;
  return ix == 0 && iy == 0 ? 1 : 0;
}

// The masked scene (with_plane false: the same without the plane), camera at `eye` looking down.
Scene masked_scene(bool with_plane, const Vec3& eye = Vec3(0, 0.5f, 0), int size = 16,
                   float cutoff = 0.5f) {
  Scene s;
  auto add = [&s](std::vector<pf_triangle> t, int id) {
    for (pf_triangle& x : t) x.mesh = x.material = id;
    s.triangles.insert(s.triangles.end(), t.begin(), t.end());
  };
  add(quad_y(0.f, 10.f, kFloor, false), kFloor);
  add(quad_y(1.f, 10.f, kPlane, false), kPlane);
  add(quad_y(2.f, 1.f, kLight, true), kLight);
  s.mesh_names = {"floor", "plane", "light"};
  s.material_names = {"floor", "plane", "light"};
  pf_material floor{}, plane{}, light{};
  floor.type = PF_MAT_DIFFUSE;
  floor.ior = 1.f;
  floor.color[0] = floor.color[1] = floor.color[2] = 0.5f;
  plane.type = PF_MAT_DIFFUSE;
  plane.ior = 1.f;  // black: absorbs, so the floor sees the light through the holes only
  light.type = PF_MAT_EMITTER;
  light.ior = 1.f;
  light.emission[0] = light.emission[1] = light.emission[2] = 1.f;
  s.materials = {floor, plane, light};
  // The mask: 2×2 RGBA texels, alpha 0 at (0, 0).
  pf_texture t{};
  t.width = t.height = 2;
  t.wrap_s = t.wrap_t = PF_TEX_WRAP_REPEAT;
  t.filter = PF_TEX_FILTER_NEAREST;
  s.textures = {t};
  s.texture_names = {"mask"};
  s.texels = {1, 1, 1, 0, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1};
  s.material_texture = {-1, -1, -1};
  for (const pf_triangle& tri : s.triangles) {
    TriangleUV uv{};
    if (tri.material == kPlane) {
      const float* v[3] = {tri.v0, tri.v1, tri.v2};
      for (int k = 0; k < 3; ++k) plane_uv(v[k][0], v[k][2], uv.uv[2 * k], uv.uv[2 * k + 1]);
    }
    s.uvs.push_back(uv);
  }
  const pf_alpha_material opaque{PF_ALPHA_OPAQUE, 1.f, -1, 0};
  s.material_alpha = {opaque, pf_alpha_material{cutoff, 1.f, 0, 0}, opaque};
  if (!with_plane) {  // the plane removed (its material stays, unused)
    std::vector<pf_triangle> kept;
    std::vector<TriangleUV> uvs;
    for (size_t i = 0; i < s.triangles.size(); ++i)
      if (s.triangles[i].material != kPlane) {
        kept.push_back(s.triangles[i]);
        uvs.push_back(s.uvs[i]);
      }
    s.triangles = kept;
    s.uvs = uvs;
  }
  s.camera.eye[0] = eye.x;
  s.camera.eye[1] = eye.y;
  s.camera.eye[2] = eye.z;
  s.camera.up[2] = -1.f;
  s.camera.fov_y_deg = 60.f;
  s.camera.width = s.camera.height = size;
  finish_scene(s);
  return s;
}

// Mean and standard error of the mean of the pixels' channel-0 values (independent pixels).
struct MeanSe {
  double mean = 0, se = 0;
};
MeanSe pixel_mean(const std::vector<float>& rgb) {
  const size_t n = rgb.size() / 3;
  double s = 0, s2 = 0;
  for (size_t i = 0; i < n; ++i) {
    s += rgb[3 * i];
    s2 += double(rgb[3 * i]) * rgb[3 * i];
  }
  MeanSe m;
  m.mean = s / double(n);
  m.se = std::sqrt(std::max(0.0, s2 / double(n) - m.mean * m.mean) / double(n - 1));
  return m;
}

// |a/b − expected| within 4 standard errors of the ratio plus the edge bias (expected: kOpen, or
// 1 − kOpen for a masked emitter).
void check_ratio(const MeanSe& a, const MeanSe& b, const char* what, double expected = kOpen) {
  REQUIRE(b.mean > 0);
  const double r = a.mean / b.mean;
  const double se = r * std::sqrt(std::pow(a.se / a.mean, 2) + std::pow(b.se / b.mean, 2));
  INFO(what << ": ratio " << r << " (expected " << expected << "), standard error " << se);
  CHECK(std::fabs(r - expected) <= 4 * se + kEdgeBias);
  CHECK(se < 0.1 * kOpen);  // precise enough to tell kOpen from 0 or from 1 − kOpen
}

// First hits: the counts of direct photons on the floor and on the plane whose path crossed
// y = 1 within |x|, |z| < 4 (a photon through a hole there lands within 2·4 + 1 < 10 m, on the
// floor; one through a hole near the plane's edge would leave the scene uncounted).
void direct_counts(const std::vector<pf_photon>& photons, size_t& floor, size_t& plane) {
  floor = plane = 0;
  for (const pf_photon& p : photons) {
    if (!(p.flags & PF_PHOTON_DIRECT) || !(p.dir[1] < 0.f)) continue;
    const float s = (1.f - p.position[1]) / -p.dir[1];  // back along the path to y = 1
    const float x = p.position[0] - p.dir[0] * s, z = p.position[2] - p.dir[2] * s;
    if (!(std::fabs(x) < 4.f && std::fabs(z) < 4.f)) continue;
    floor += p.mesh == kFloor;
    plane += p.mesh == kPlane;
  }
}

// The device's photons against the CPU's, index by index (emission order): ≥ 99 % on the same
// mesh with the same flags within `tol` of the same place, and as many of them within 1 %.
void check_same_photons(const std::vector<pf_photon>& cpu, const std::vector<pf_photon>& dev,
                        float tol) {
  size_t matched = 0;
  const size_t n = std::min(cpu.size(), dev.size());
  for (size_t i = 0; i < n; ++i) {
    const pf_photon &a = cpu[i], &b = dev[i];
    bool ok = a.mesh == b.mesh && a.flags == b.flags;
    for (int c = 0; c < 3; ++c) ok = ok && std::fabs(a.position[c] - b.position[c]) <= tol;
    matched += ok;
  }
  CHECK(matched >= cpu.size() * 99 / 100);
  CHECK(dev.size() == Approx(double(cpu.size())).epsilon(0.01));
}

// An 8-bit RGBA PNG (libpng's simplified API).
std::string rgba_png(int w, int h, const std::vector<uint8_t>& rgba) {
  png_image img;
  std::memset(&img, 0, sizeof img);
  img.version = PNG_IMAGE_VERSION;
  img.width = png_uint_32(w);
  img.height = png_uint_32(h);
  img.format = PNG_FORMAT_RGBA;
  png_alloc_size_t size = 0;
  REQUIRE(png_image_write_to_memory(&img, nullptr, &size, 0, rgba.data(), 0, nullptr));
  std::string out(size, '\0');
  REQUIRE(png_image_write_to_memory(&img, &out[0], &size, 0, rgba.data(), 0, nullptr));
  out.resize(size);
  return out;
}

void write_file(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary) << bytes;
}

}  // namespace

TEST_CASE("alpha scene.h5: version 5 table kept, validated, in the id only with a mask",
          "[alpha]") {
  test::TempDir tmp("alpha-h5");
  const Scene s = masked_scene(true);
  REQUIRE(s.has_alpha_masks());
  save_scene(s, tmp / "s.h5", prov());
  const Scene r = load_scene(tmp / "s.h5");
  REQUIRE(r.material_alpha.size() == 3);
  for (size_t i = 0; i < 3; ++i) {
    CHECK(r.material_alpha[i].cutoff == s.material_alpha[i].cutoff);
    CHECK(r.material_alpha[i].factor == s.material_alpha[i].factor);
    CHECK(r.material_alpha[i].texture == s.material_alpha[i].texture);
  }
  CHECK(r.scene_id == s.scene_id);

  // Without a masked material: the id of format version 4 (the table is not hashed), whether the
  // table is absent or all opaque; with one, another id.
  Scene none = s;
  none.material_alpha.clear();
  none.compute_scene_id();
  Scene opaque = s;
  for (pf_alpha_material& a : opaque.material_alpha) a = {PF_ALPHA_OPAQUE, 1.f, -1, 0};
  opaque.compute_scene_id();
  CHECK(opaque.scene_id == none.scene_id);
  CHECK(none.scene_id != s.scene_id);
  // An all-opaque table (here without the alpha texture and its UVs) reads back as none.
  opaque.textures.clear();
  opaque.texels.clear();
  opaque.texture_names.clear();
  opaque.material_texture.clear();
  opaque.uvs.clear();
  opaque.compute_scene_id();
  save_scene(opaque, tmp / "o.h5", prov());
  CHECK(load_scene(tmp / "o.h5").material_alpha.empty());

  // Bad values in the file: refused on read (one line naming the file and the dataset).
  for (float bad : {std::nanf(""), -0.5f, 1.5f}) {
    INFO("cutoff " << bad);
    const std::string f = tmp / "bad.h5";
    save_scene(s, f, prov());
    test::edit_dataset<float>(f, "/materials/alpha_cutoff", H5T_NATIVE_FLOAT,
                              [bad](std::vector<float>& v) { v[kPlane] = bad; });
    test::refresh_scene_id(f);
    test::refused([&] { load_scene(f); }, f, "alpha_cutoff");
  }
  {
    const std::string f = tmp / "factor.h5";
    save_scene(s, f, prov());
    test::edit_dataset<float>(f, "/materials/alpha_factor", H5T_NATIVE_FLOAT,
                              [](std::vector<float>& v) { v[kPlane] = 2.f; });
    test::refresh_scene_id(f);
    test::refused([&] { load_scene(f); }, f, "alpha_factor");
  }
  {
    const std::string f = tmp / "texture.h5";
    save_scene(s, f, prov());
    test::edit_dataset<int32_t>(f, "/materials/alpha_texture", H5T_NATIVE_INT32,
                                [](std::vector<int32_t>& v) { v[kPlane] = 7; });
    test::refresh_scene_id(f);
    test::refused([&] { load_scene(f); }, f, "alpha_texture");
  }
  // The writer's own check refuses them too.
  Scene nan = s;
  nan.material_alpha[kPlane].cutoff = std::nanf("");
  CHECK_THROWS_WITH(save_scene(nan, tmp / "nan.h5", prov()), Catch::Contains("alpha_cutoff"));
  CHECK_FALSE(std::filesystem::exists(tmp / "nan.h5"));
}

TEST_CASE("alpha scene.h5: a version 4 file is read as opaque", "[alpha]") {
  // A masked plane without texture (factor 0.2 < cutoff 0.5: cut away everywhere), stored as
  // version 4: the alpha datasets are not read and the plane is opaque again.
  test::TempDir tmp("alpha-v4");
  Scene s = masked_scene(true);
  s.material_alpha[kPlane] = {0.5f, 0.2f, -1, 0};
  s.textures.clear();
  s.texels.clear();
  s.texture_names.clear();
  s.uvs.clear();
  s.compute_scene_id();
  const Ray down{Vec3(0.3f, 1.5f, 0.2f), Vec3(0, -1, 0)};
  Hit h;
  REQUIRE(intersect_closest(s, down, h));
  CHECK(s.triangles[size_t(h.tri)].mesh == kFloor);  // cut away: the floor
  const std::string f = tmp / "v4.h5";
  save_scene(s, f, prov());
  test::set_int_attr(f, "/", "format_version", 4);
  // The id a version-4 writer gave this content (no alpha table).
  Scene none = s;
  none.material_alpha.clear();
  none.compute_scene_id();
  test::set_string_attr(f, "/", "scene_id", none.scene_id);
  const Scene r2 = load_scene(f);
  CHECK(r2.material_alpha.empty());
  REQUIRE(intersect_closest(r2, down, h));
  CHECK(r2.triangles[size_t(h.tri)].mesh == kPlane);
}

TEST_CASE("alpha: every traversal skips cut-away points, closest and any hit", "[alpha]") {
  const Scene s = masked_scene(true);
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> uni(-3.f, 3.f);
  int open = 0, closed = 0;
  for (int i = 0; i < 4000; ++i) {
    const float x = uni(rng), z = uni(rng);
    float u, v;
    plane_uv(x, z, u, v);
    const int cut = cut_at(u, v);
    if (cut < 0) continue;
    const Ray down{Vec3(x, 1.5f, z), Vec3(0, -1, 0)};
    const Ray shadow{Vec3(x, 0.01f, z), Vec3(0, 1.5f, 0), 0.f, 1.f};  // to y = 1.51: through the plane
    for (Traversal t : {Traversal::Stack, Traversal::Ropes, Traversal::Brute}) {
      Hit h;
      REQUIRE(intersect_closest(s, down, h, t));
      CHECK(s.triangles[size_t(h.tri)].mesh == (cut ? kFloor : kPlane));
      CHECK(intersect_any(s, shadow, t) == !cut);
    }
    const RayCaster caster(s);
    Hit h;
    REQUIRE(caster.closest(down, h));
    CHECK(s.triangles[size_t(h.tri)].mesh == (cut ? kFloor : kPlane));
    CHECK(caster.any(shadow) == !cut);
    (cut ? open : closed) += 1;
  }
  CHECK(double(open) / double(open + closed) == Approx(kOpen).margin(0.03));
}

TEST_CASE("alpha: photons pass the masked plane in exactly the open fraction", "[alpha]") {
  const Scene s = masked_scene(true);
  PhotonPassOptions po;
  po.photons = 200000;
  po.seed = 9;
  po.threads = 2;
  const PhotonPassResult r = trace_photons(s, 1, po);
  size_t floor, plane;
  direct_counts(r.photons, floor, plane);
  const double n = double(floor + plane), f = double(floor) / n;
  const double se = std::sqrt(kOpen * (1 - kOpen) / n);  // binomial
  INFO("floor " << floor << ", plane " << plane << ": fraction " << f << " ± " << se);
  REQUIRE(n > 0.5 * po.photons);  // most photons cross the plane's central 8×8 m
  CHECK(std::fabs(f - kOpen) <= 4 * se + kEdgeBias);
}

TEST_CASE("alpha: eye rays see the floor exactly through the cut-away texels", "[alpha][eye]") {
  const Vec3 eye(0, 1.5f, 0);
  const Scene s = masked_scene(true, eye, 64);
  EyePassOptions eo;
  eo.spp = 2;
  eo.seed = 4;
  const EyePassResult r = trace_hitpoints(s, eo);
  REQUIRE(r.hitpoints.size() == size_t(64 * 64 * 2));
  size_t on_floor = 0, checked = 0;
  for (const pf_hitpoint& h : r.hitpoints) {
    const Vec3 p(h.position);
    // Where the eye ray crossed y = 1.
    const float t = (eye.y - 1.f) / (eye.y - p.y);
    const Vec3 c = eye + (p - eye) * t;
    float u, v;
    plane_uv(c.x, c.z, u, v);
    const int cut = cut_at(u, v);
    if (cut < 0) continue;
    ++checked;
    CHECK(h.mesh == (cut ? kFloor : kPlane));
    on_floor += h.mesh == kFloor;
  }
  REQUIRE(checked > r.hitpoints.size() * 9 / 10);
  CHECK(double(on_floor) / double(checked) == Approx(kOpen).margin(0.05));
}

namespace {

// The floor's shadow-ray direct light (4 eye samples, 16 light samples, 32×32) and its path-traced
// image (64 spp, 24×24) of the scene make(true, ...) against make(false, ...): their ratios are
// `expected` (check_ratio).
template <class Make>
void check_direct_ratios(Make make, double expected) {
  EyePassOptions eo;
  eo.spp = 4;
  eo.direct = DirectMode::ShadowRays;
  eo.shadow_samples = 16;
  eo.seed = 6;
  eo.threads = 2;
  const EyePassResult masked = trace_hitpoints(make(true, Vec3(0, 0.5f, 0), 32), eo);
  const EyePassResult open = trace_hitpoints(make(false, Vec3(0, 0.5f, 0), 32), eo);
  check_ratio(pixel_mean(masked.direct), pixel_mean(open.direct), "shadow-ray direct light",
              expected);
  PathTraceOptions o;
  o.spp = 64;
  o.seed = 3;
  o.threads = 2;
  const Image pm = pathtrace(make(true, Vec3(0, 0.5f, 0), 24), o);
  const Image po = pathtrace(make(false, Vec3(0, 0.5f, 0), 24), o);
  check_ratio(pixel_mean(pm.rgb), pixel_mean(po.rgb), "path tracer", expected);
}

}  // namespace

TEST_CASE("alpha: shadow rays and the path tracer pass the masked plane in the open fraction",
          "[alpha][eye]") {
  check_direct_ratios([](bool plane, const Vec3& eye, int size) {
    return masked_scene(plane, eye, size);
  }, kOpen);
}

TEST_CASE("alpha: SPPM, PPPM and PPM render the floor at the open fraction", "[alpha]") {
  // Pixels share photons, so the standard error of an image mean comes from independent runs:
  // kSeeds seeds per scene, the error of the mean over them.
  test::TempDir tmp("alpha-est");
  save_scene(masked_scene(true), tmp / "masked.h5", prov());
  save_scene(masked_scene(false), tmp / "open.h5", prov());
  constexpr int kSeeds = 4;
  for (const char* est : {"sppm", "pppm", "ppm"}) {
    MeanSe m[2];
    for (int k = 0; k < 2; ++k) {
      std::vector<double> means;
      for (int seed = 1; seed <= kSeeds; ++seed) {
        const std::string in = tmp / (k == 0 ? "masked.h5" : "open.h5");
        const std::string out = tmp / "img.exr";
        const test::ToolRun run = test::run_tool(
            "render", "--scene " + q(in) + " -o " + q(out) + " --estimator " + est +
                          " --passes 8 --photons 40000 --threads 2 --seed " +
                          std::to_string(seed),
            tmp);
        INFO(run.err);
        REQUIRE(run.exit_code == 0);
        means.push_back(pixel_mean(read_exr(out).rgb).mean);
      }
      double s = 0, s2 = 0;
      for (double x : means) s += x;
      m[k].mean = s / kSeeds;
      for (double x : means) s2 += (x - m[k].mean) * (x - m[k].mean);
      m[k].se = std::sqrt(s2 / (kSeeds - 1) / kSeeds);
    }
    INFO(est);
    check_ratio(m[0], m[1], est);
  }
}

TEST_CASE("alpha: OpenCL hitpoints, direct light and photons equal the CPU's on a masked scene",
          "[alpha][opencl]") {
  auto dev = test::test_device();
  if (!dev) return;
  const Scene s = masked_scene(true, Vec3(0, 1.5f, 0), 32);
  const float tol = 1e-4f * length(s.bounds.extent());
  EyePassOptions eo;
  eo.spp = 2;
  eo.direct = DirectMode::ShadowRays;
  eo.seed = 5;
  const EyePassResult cpu = trace_hitpoints(s, eo);
  const EyePassResult gpu = trace_hitpoints(s, eo, *dev);
  REQUIRE(gpu.hitpoints.size() == cpu.hitpoints.size());
  size_t same = 0, floor = 0;
  for (size_t i = 0; i < cpu.hitpoints.size(); ++i) {
    const pf_hitpoint &a = cpu.hitpoints[i], &b = gpu.hitpoints[i];
    bool ok = a.pixel_x == b.pixel_x && a.pixel_y == b.pixel_y && a.mesh == b.mesh;
    for (int c = 0; c < 3; ++c) ok = ok && std::fabs(a.position[c] - b.position[c]) <= tol;
    same += ok;
    floor += a.mesh == kFloor;
  }
  CHECK(same >= cpu.hitpoints.size() * 999 / 1000);
  CHECK(floor > cpu.hitpoints.size() / 8);  // eye rays went through
  REQUIRE(test::sum_squares(cpu.direct) > 0);
  CHECK(test::relative_rmse(gpu.direct, cpu.direct) <= 1e-3);

  // The ray casts themselves, ray by ray (kernels/raycast.cl).
  std::vector<float> rays;
  std::vector<Ray> host;
  std::mt19937 rng(2);
  std::uniform_real_distribution<float> uni(-3.f, 3.f);
  for (int i = 0; i < 2000; ++i) {
    const Ray r{Vec3(uni(rng), 1.5f, uni(rng)), Vec3(0.1f * uni(rng), -1, 0.1f * uni(rng))};
    host.push_back(r);
    rays.insert(rays.end(), {r.o.x, r.o.y, r.o.z, r.d.x, r.d.y, r.d.z, 0.f, INFINITY});
  }
  for (bool any : {false, true}) {
    const std::vector<ClRayHit> hits = cast_rays(s, rays, any, *dev);
    size_t agree = 0;
    for (size_t i = 0; i < host.size(); ++i) {
      Hit h;
      const bool hh = any ? intersect_any(s, host[i], Traversal::Ropes)
                          : intersect_closest(s, host[i], h, Traversal::Ropes);
      agree += hh == (hits[i].tri >= 0) && (any || h.tri == hits[i].tri);
    }
    CHECK(agree >= host.size() * 999 / 1000);
  }

  PhotonPassOptions po;
  po.photons = 50000;
  po.seed = 3;
  const PhotonPassResult pc = trace_photons(s, 1, po);
  const PhotonPassResult pg = trace_photons(s, 1, po, *dev);
  size_t fc, pc_plane, fg, pg_plane;
  direct_counts(pc.photons, fc, pc_plane);
  direct_counts(pg.photons, fg, pg_plane);
  INFO("cpu floor/plane " << fc << "/" << pc_plane << ", opencl " << fg << "/" << pg_plane);
  REQUIRE(fc > 0);
  // Photon by photon in emission order (one stored per photon: black plane, no floor bounce
  // comes back through... most do not), matched where both stored one.
  check_same_photons(pc.photons, pg.photons, tol);
}

namespace {

// A .gltf (external .bin and PNG) of three quads side by side, materials "mask" (alphaMode MASK,
// alphaCutoff `cutoff`), "blend" (BLEND) and "opaque" (OPAQUE), each with baseColorFactor alpha
// 0.8 and the RGBA texture, and an emitting ceiling.
void write_gltf(const std::string& dir, const std::string& cutoff) {
  std::string bin;
  auto floats = [&bin](std::initializer_list<float> v) {
    for (float f : v) bin.append(reinterpret_cast<const char*>(&f), 4);
  };
  floats({-3, 0, -1, -3, 0, 1, 3, 0, 1, 3, 0, -1});  // 0: positions (48 bytes), one quad
  floats({0, 0, 0, 1, 1, 1, 1, 0});                  // 48: uvs (32 bytes)
  const uint16_t idx[6] = {0, 1, 2, 0, 2, 3};
  bin.append(reinterpret_cast<const char*>(idx), 12);  // 80: indices
  floats({-5, 3, -5, 5, 3, -5, 5, 3, 5, -5, 3, 5});    // 92: ceiling (48 bytes)
  write_file(dir + "/s.bin", bin);
  // 2×2 texels, alpha 0, 64, 191, 255.
  write_file(dir + "/tex.png", rgba_png(2, 2, {255, 255, 255, 0, 255, 255, 255, 64, 255, 255,
                                               255, 191, 255, 255, 255, 255}));
  auto material = [](const std::string& name, const std::string& mode, const std::string& extra) {
    return R"({"name":")" + name + R"(","alphaMode":")" + mode + "\"" + extra +
           R"(,"pbrMetallicRoughness":{"baseColorFactor":[1,1,1,0.8],"baseColorTexture":{"index":0},"metallicFactor":0}})";
  };
  const std::string mask_extra = cutoff.empty() ? "" : R"(,"alphaCutoff":)" + cutoff;
  const std::string json =
      R"({"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0,1,2,3]}],)"
      R"("nodes":[{"mesh":0,"name":"m"},{"mesh":1,"name":"b","translation":[0,0,3]},)"
      R"({"mesh":2,"name":"o","translation":[0,0,6]},{"mesh":3,"name":"ceiling"}],)"
      R"("meshes":[)"
      R"({"primitives":[{"attributes":{"POSITION":0,"TEXCOORD_0":1},"indices":2,"material":0}]},)"
      R"({"primitives":[{"attributes":{"POSITION":0,"TEXCOORD_0":1},"indices":2,"material":1}]},)"
      R"({"primitives":[{"attributes":{"POSITION":0,"TEXCOORD_0":1},"indices":2,"material":2}]},)"
      R"({"primitives":[{"attributes":{"POSITION":3},"indices":2,"material":3}]}],)"
      R"("materials":[)" +
      material("mask", "MASK", mask_extra) + "," + material("blend", "BLEND", "") + "," +
      material("opaque", "OPAQUE", R"(,"alphaCutoff":-3)") + R"(,{"name":"light","emissiveFactor":[1,1,1]}],)"
      R"("textures":[{"source":0,"sampler":0}],"samplers":[{"magFilter":9728}],)"
      R"("images":[{"uri":"tex.png"}],)"
      R"("accessors":[)"
      R"({"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[-3,0,-1],"max":[3,0,1]},)"
      R"({"bufferView":1,"componentType":5126,"count":4,"type":"VEC2"},)"
      R"({"bufferView":2,"componentType":5123,"count":6,"type":"SCALAR"},)"
      R"({"bufferView":3,"componentType":5126,"count":4,"type":"VEC3","min":[-5,3,-5],"max":[5,3,5]}],)"
      R"("bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":48},{"buffer":0,"byteOffset":48,"byteLength":32},)"
      R"({"buffer":0,"byteOffset":80,"byteLength":12},{"buffer":0,"byteOffset":92,"byteLength":48}],)"
      R"("buffers":[{"uri":"s.bin","byteLength":)" +
      std::to_string(bin.size()) + "}]}";
  write_file(dir + "/s.gltf", json);
}

BakeOptions bake_options(const std::string& input) {
  BakeOptions o;
  o.input = input;
  o.eye = Vec3(0, 2.5f, 0);
  o.look_at = Vec3(0, 0, 0);
  o.up = Vec3(0, 0, -1);
  o.width = o.height = 8;
  return o;
}

size_t material_named(const Scene& s, const std::string& name) {
  size_t m = 0;
  while (m < s.material_names.size() && s.material_names[m] != name) ++m;
  REQUIRE(m < s.materials.size());
  return m;
}

}  // namespace

TEST_CASE("alpha import: glTF MASK with its cutoff, BLEND as MASK 0.5, OPAQUE ignored",
          "[alpha][import]") {
  test::TempDir tmp("alpha-gltf");
  write_gltf(tmp.dir, "0.3");
  BakeReport report;
  const Scene s = bake_scene(bake_options(tmp / "s.gltf"), report);
  REQUIRE(s.material_alpha.size() == s.materials.size());
  const pf_alpha_material mask = s.material_alpha[material_named(s, "mask")];
  const pf_alpha_material blend = s.material_alpha[material_named(s, "blend")];
  const pf_alpha_material opaque = s.material_alpha[material_named(s, "opaque")];
  CHECK(mask.cutoff == 0.3f);
  CHECK(mask.factor == 0.8f);
  REQUIRE(mask.texture >= 0);
  CHECK(mask.texture == s.material_texture[material_named(s, "mask")]);
  CHECK(s.materials[material_named(s, "mask")].type == PF_MAT_DIFFUSE);  // not glass
  // The texture's alpha as stored (linear, not sRGB-decoded).
  const pf_texture& t = s.textures[size_t(mask.texture)];
  CHECK(s.texels[4 * size_t(t.offset) + 3] == 0.f);
  CHECK(s.texels[4 * size_t(t.offset) + 7] == Approx(64.f / 255.f));
  CHECK(s.texels[4 * size_t(t.offset) + 11] == Approx(191.f / 255.f));
  CHECK(blend.cutoff == 0.5f);
  CHECK(blend.factor == 0.8f);
  CHECK(opaque.cutoff == PF_ALPHA_OPAQUE);
  // OPAQUE ignores the base colour's alpha 0.8: the material is not a glass (glTF 2.0 3.9.4).
  CHECK(s.materials[material_named(s, "opaque")].type == PF_MAT_DIFFUSE);
  REQUIRE(s.material_texture[material_named(s, "opaque")] >= 0);  // its colour map is read
  bool warned = false;
  for (const std::string& w : report.warnings) warned = warned || w.find("BLEND") != std::string::npos;
  CHECK(warned);
  // Texels of the MASK quad: alpha·0.8 = 0, 0.2, 0.6, 0.8 against 0.3: two of four cut away;
  // a ray down through each texel centre (the quad spans x −3..3, z −1..1; uv = ((x+3)/6, (z+1)/2)
  // with v flipped by the importer: texel (i, j) at uv ((i+½)/2, (j+½)/2)).
  const Vec3 origin(0, 1, 0);
  for (int j = 0; j < 2; ++j)
    for (int i = 0; i < 2; ++i) {
      // Find the point of the mask quad with this UV from its triangles' UVs.
      const float u = (i + 0.5f) / 2.f, v = (j + 0.5f) / 2.f;
      bool found = false;
      for (size_t k = 0; k < s.triangles.size() && !found; ++k) {
        if (s.triangles[k].material != int(material_named(s, "mask"))) continue;
        const float* uv = s.uvs[k].uv;
        // Solve for barycentrics (b1, b2) with uv0 + b1 (uv1 − uv0) + b2 (uv2 − uv0) = (u, v).
        const float a = uv[2] - uv[0], b = uv[4] - uv[0], c = uv[3] - uv[1], d = uv[5] - uv[1];
        const float det = a * d - b * c;
        const float b1 = ((u - uv[0]) * d - b * (v - uv[1])) / det;
        const float b2 = (a * (v - uv[1]) - c * (u - uv[0])) / det;
        if (b1 < 0 || b2 < 0 || b1 + b2 > 1) continue;
        found = true;
        const pf_triangle& tr = s.triangles[k];
        const Vec3 p = Vec3(tr.v0) * (1 - b1 - b2) + Vec3(tr.v1) * b1 + Vec3(tr.v2) * b2;
        const float alpha = 0.8f * std::array<float, 4>{0.f, 64.f / 255, 191.f / 255, 1.f}[size_t(2 * j + i)];
        Hit h;
        const bool hit = intersect_closest(s, Ray{p + Vec3(0, 1, 0), Vec3(0, -1, 0)}, h);
        INFO("texel " << i << "," << j << " alpha " << alpha);
        CHECK(hit == (alpha >= 0.3f));
      }
      CHECK(found);
    }
  (void)origin;
}

TEST_CASE("alpha import: a bad alphaCutoff is refused with one line, exit 2", "[alpha][import]") {
  for (const char* bad : {"-0.5", "1.5"}) {
    test::TempDir tmp("alpha-gltf-bad");
    write_gltf(tmp.dir, bad);
    const test::ToolRun run =
        test::run_tool("scene-bake", q(tmp / "s.gltf") + " -o " + q(tmp / "s.h5"), tmp);
    INFO(run.err);
    CHECK(run.exit_code == 2);
    CHECK(run.err.find("alphaCutoff") != std::string::npos);
    CHECK(run.err.find("mask") != std::string::npos);
    CHECK(std::count(run.err.begin(), run.err.end(), '\n') == 1);
    CHECK_FALSE(std::filesystem::exists(tmp / "s.h5"));
  }
}

TEST_CASE("alpha import: OBJ map_d is a mask at 0.5 on the map's value, its own texture",
          "[alpha][import]") {
  test::TempDir tmp("alpha-obj");
  // Grey map_d (values 0, 100, 200, 255) on a quad that also has a colour map.
  std::vector<uint8_t> grey;
  for (int v : {0, 100, 200, 255}) grey.insert(grey.end(), {uint8_t(v), uint8_t(v), uint8_t(v), 255});
  write_file(tmp / "d.png", rgba_png(2, 2, grey));
  write_file(tmp / "c.png", rgba_png(2, 2, std::vector<uint8_t>(16, 200)));
  write_file(tmp / "s.mtl",
             "newmtl leaf\nKd 1 1 1\nmap_Kd c.png\nmap_d d.png\n"
             "newmtl light\nKd 0 0 0\nKe 1 1 1\n");
  write_file(tmp / "s.obj",
             "mtllib s.mtl\nv -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\n"
             "v -5 3 -5\nv 5 3 -5\nv 5 3 5\nv -5 3 5\n"
             "vt 0 1\nvt 1 1\nvt 1 0\nvt 0 0\n"
             "o leaf\nusemtl leaf\nf 1/1 4/4 3/3\nf 1/1 3/3 2/2\n"
             "o ceiling\nusemtl light\nf 5 6 7\nf 5 7 8\n");
  BakeReport report;
  const Scene s = bake_scene(bake_options(tmp / "s.obj"), report);
  const size_t leaf = material_named(s, "leaf");
  REQUIRE(s.material_alpha.size() == s.materials.size());
  const pf_alpha_material a = s.material_alpha[leaf];
  CHECK(a.cutoff == 0.5f);
  CHECK(a.factor == 1.f);
  REQUIRE(a.texture >= 0);
  CHECK(a.texture != s.material_texture[leaf]);  // its own entry, not the colour map
  CHECK(s.materials[leaf].type == PF_MAT_DIFFUSE);
  const pf_texture& t = s.textures[size_t(a.texture)];
  const float expect[4] = {0.f, 100.f / 255, 200.f / 255, 1.f};
  for (int i = 0; i < 4; ++i)
    for (int c = 0; c < 4; ++c) CHECK(s.texels[4 * (size_t(t.offset) + size_t(i)) + size_t(c)] == expect[i]);
  CHECK(s.material_alpha[material_named(s, "light")].cutoff == PF_ALPHA_OPAQUE);
  // Through scene.h5 and back.
  test::TempDir out("alpha-obj-h5");
  save_scene(s, out / "s.h5", prov());
  CHECK(load_scene(out / "s.h5").material_alpha[leaf].texture == a.texture);
}

// ---- a masked emitter: its cut-away texels emit nothing ---------------------------------------

namespace {

// The floor under the 2×2 m light without the plane; `masked`: the light's material carries the
// plane's mask (UVs by plane_uv: 100 periods across the light), so 1 − kOpen of it is left.
Scene masked_light_scene(bool masked, const Vec3& eye = Vec3(0, 0.5f, 0), int size = 16) {
  Scene s = masked_scene(false, eye, size);
  const pf_alpha_material opaque{PF_ALPHA_OPAQUE, 1.f, -1, 0};
  s.material_alpha = {opaque, opaque, masked ? pf_alpha_material{0.5f, 1.f, 0, 0} : opaque};
  for (size_t i = 0; i < s.triangles.size(); ++i) {
    const pf_triangle& t = s.triangles[i];
    if (t.material != kLight) continue;
    const float* v[3] = {t.v0, t.v1, t.v2};
    for (int k = 0; k < 3; ++k) plane_uv(v[k][0], v[k][2], s.uvs[i].uv[2 * k], s.uvs[i].uv[2 * k + 1]);
  }
  return s;
}

// The photons' first hits of scene s traced back to where they left the light (y = 2 − ε: the
// ray's origin is offset by ray_epsilon below the sampled point, which at grazing angles moves it
// by a sizeable part of a texel): `cut` counts those that left a cut-away texel, `total` those
// clear of a texel edge.
void light_origins(const Scene& s, const std::vector<pf_photon>& photons, size_t& cut,
                   size_t& total) {
  cut = total = 0;
  const double y0 = 2.0 - double(ray_epsilon(s));
  for (const pf_photon& p : photons) {
    if (!(p.flags & PF_PHOTON_DIRECT) || !(p.dir[1] < 0.f)) continue;
    const float t = float((y0 - double(p.position[1])) / -double(p.dir[1]));
    float u, v;
    plane_uv(p.position[0] - p.dir[0] * t, p.position[2] - p.dir[2] * t, u, v);
    const int c = cut_at(u, v);
    if (c < 0) continue;
    ++total;
    cut += c;
  }
}

}  // namespace

TEST_CASE("alpha: a masked emitter's cut-away texels send no photons", "[alpha][emitter]") {
  PhotonPassOptions po;
  po.photons = 100000;
  po.seed = 12;
  po.threads = 2;
  const Scene sm = masked_light_scene(true), so = masked_light_scene(false);
  const PhotonPassResult masked = trace_photons(sm, 1, po);
  const PhotonPassResult open = trace_photons(so, 1, po);
  size_t cut_m, total_m, cut_o, total_o;
  light_origins(sm, masked.photons, cut_m, total_m);
  light_origins(so, open.photons, cut_o, total_o);
  INFO("masked: " << cut_m << " of " << total_m << " from cut-away texels; open: " << cut_o
                  << " of " << total_o);
  REQUIRE(total_o > po.photons / 2);
  CHECK(cut_o > total_o / 5);  // the test sees cut-away texels where the light is open
  CHECK(cut_m == 0);
  // the rest leave as before: 1 − kOpen of the open light's photons (binomial)
  const double f = double(total_m) / double(total_o);
  const double se = std::sqrt(kOpen * (1 - kOpen) / double(total_o));
  CHECK(std::fabs(f - (1 - kOpen)) <= 4 * se + kEdgeBias);
  CHECK(masked.emitted == open.emitted);  // the power per emitted photon is unchanged
}

TEST_CASE("alpha: shadow rays and the path tracer see 1 - the cut-away fraction of a masked "
          "emitter",
          "[alpha][emitter]") {
  check_direct_ratios([](bool masked, const Vec3& eye, int size) {
    return masked_light_scene(masked, eye, size);
  }, 1 - kOpen);
}

TEST_CASE("alpha: OpenCL photons and shadow rays leave a masked emitter as on the CPU",
          "[alpha][emitter][opencl]") {
  auto dev = test::test_device();
  if (!dev) return;
  const Scene s = masked_light_scene(true, Vec3(0, 0.5f, 0), 32);
  PhotonPassOptions po;
  po.photons = 50000;
  po.seed = 3;
  const PhotonPassResult pc = trace_photons(s, 1, po);
  const PhotonPassResult pg = trace_photons(s, 1, po, *dev);
  size_t cut, total;
  light_origins(s, pg.photons, cut, total);
  CHECK(cut == 0);
  REQUIRE(!pc.photons.empty());
  const float tol = 1e-4f * length(s.bounds.extent());
  check_same_photons(pc.photons, pg.photons, tol);
  EyePassOptions eo;
  eo.spp = 2;
  eo.direct = DirectMode::ShadowRays;
  eo.shadow_samples = 8;
  eo.seed = 5;
  const EyePassResult cpu = trace_hitpoints(s, eo);
  const EyePassResult gpu = trace_hitpoints(s, eo, *dev);
  REQUIRE(test::sum_squares(cpu.direct) > 0);
  CHECK(test::relative_rmse(gpu.direct, cpu.direct) <= 1e-3);
}
