// Render-stage intermediates: see stage_files.h and docs/FORMATS.md.
#include "photonflow/io/stage_files.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <limits>
#include <sstream>

#include "photonflow/geometry/camera.h"
#include "photonflow/io/h5io.h"
#include "photonflow/stages/photon_pass.h"
#include "photonflow/estimators/ppm.h"
#include "photonflow/geometry/scene.h"
#include "photonflow/io/h5_types.h"
#include "photonflow/geometry/surface.h"
#include "photonflow/io/validate.h"

namespace pf {

namespace {
// Version 2 (issue 32): the optional dataset /hitpoint_bsdf (PF_MAT_PBR visible points). Version
// 1 files are read as before (no table: refused by check_against_scene where the scene's
// hitpoints need one).
constexpr int kHitpointsVersion = 2;
constexpr const char* kHitpointBsdf = "/hitpoint_bsdf";

// The "no BSDF" entry of a hitpoint that is not on a PBR material: every byte zero.
bool empty_pbr_point(const pf_pbr_point& b) {
  static const pf_pbr_point zero{};
  return std::memcmp(&b, &zero, sizeof b) == 0;
}

// Largest IOR a /hitpoint_bsdf entry may hold (diamond is 2.42; bsdf_shared.h takes any > 1).
constexpr double kMaxPbrIor = 10.0;

// The table's own checks (docs/FORMATS.md): one entry per hitpoint; each entry all zero or the
// parameters of a PBR point in range (base colour, metallic, roughness, transmission in [0, 1],
// ior in [1, kMaxPbrIor], outside 0 or 1). Which entries must be zero is the scene's
// (check_against_scene).
void check_bsdf_table(const HitpointSet& h, const Validator& v) {
  if (h.bsdf.empty()) return;
  if (h.bsdf.size() != h.hitpoints.size())
    v.fail("hitpoint_bsdf has " + std::to_string(h.bsdf.size()) + " entries for " +
           std::to_string(h.hitpoints.size()) + " hitpoints");
  const std::string B = "hitpoint_bsdf";
  for (size_t i = 0; i < h.bsdf.size(); ++i) {
    const pf_pbr_point& b = h.bsdf[i];
    if (empty_pbr_point(b)) continue;
    v.in_range(Name(B, i, "base_color"), b.params.base_color, 3, 0.0, 1.0);
    v.in_range(Name(B, i, "metallic"), &b.params.metallic, 1, 0.0, 1.0);
    v.in_range(Name(B, i, "roughness"), &b.params.roughness, 1, 0.0, 1.0);
    v.in_range(Name(B, i, "transmission"), &b.params.transmission, 1, 0.0, 1.0);
    v.in_range(Name(B, i, "ior"), &b.params.ior, 1, 1.0, kMaxPbrIor);
    if (b.outside != 0 && b.outside != 1)
      v.fail(Validator::element(B, i, "outside") + " = " + std::to_string(b.outside) +
             " is neither 0 nor 1");
  }
}
constexpr int kPhotonsVersion = 1;
constexpr int kGridVersion = 1;

DirectMode parse_direct(const std::string& s, const std::string& path) {
  if (s == "photons") return DirectMode::Photons;
  if (s == "shadow-rays") return DirectMode::ShadowRays;
  throw input_error(path, "unknown direct mode '" + s + "'");
}

void check_image(const std::string& path, const std::vector<float>& v, int w, int h,
                 const char* name) {
  if (v.size() != size_t(w) * size_t(h) * 3)
    throw input_error(path, std::string("image layer ") + name + " does not match width × height",
                      "the file is damaged; remake it");
}

// An int64 attribute that must lie in [lo, hi] (it is kept in an int).
int64_t attr_in(const h5::Reader& r, const std::string& path, const std::string& obj,
                const std::string& name, int64_t lo, int64_t hi, const std::string& hint) {
  const int64_t v = r.attr_int(obj, name);
  if (v < lo || v > hi)
    throw input_error(path,
                      "attribute " + (obj == "/" ? "" : obj + "/") + name + " = " +
                          std::to_string(v) + " is outside [" + std::to_string(lo) + ", " +
                          std::to_string(hi) + "]",
                      hint);
  return v;
}

constexpr int64_t kIntMax = std::numeric_limits<int32_t>::max();

// first_pass of a file of `passes` passes: pass indices first_pass … first_pass + passes − 1 are
// int32 (the photons' `pass` field, the grid's /pass<k> groups, the hitpoints' pass count).
int check_first_pass(const h5::Reader& r, const std::string& path, size_t passes,
                     const std::string& hint) {
  const int64_t first = attr_in(r, path, "/", "first_pass", 0, kIntMax, hint);
  if (!pass_indices_fit(first, int64_t(passes)))
    throw input_error(path, "its passes " + std::to_string(first) + " … " +
                                std::to_string(first + int64_t(passes) - 1) + " run past 2^31-1",
                      hint);
  return int(first);
}

bool finite3(const float* p) {
  return std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]);
}

// A point of the scene's surfaces (a hitpoint) lies in its bounds up to rounding. Refused only far
// outside: beyond the bounds grown on every side by their largest extent and largest coordinate
// magnitude (a hitpoint at 1e20 in a unit room made k-means' float distances overflow, clusters.cpp).
bool near_bounds(const float* p, const Bounds& b) {
  if (b.empty()) return true;
  double margin = 0;
  for (int a = 0; a < 3; ++a)
    margin = std::max({margin, double(b.hi[a]) - double(b.lo[a]), std::fabs(double(b.lo[a])),
                       std::fabs(double(b.hi[a]))});
  for (int a = 0; a < 3; ++a)
    if (!(double(p[a]) >= double(b.lo[a]) - margin && double(p[a]) <= double(b.hi[a]) + margin))
      return false;
  return true;
}

std::string fmt3(const Vec3& p) {
  std::ostringstream o;
  o << p.x << "," << p.y << "," << p.z;
  return o.str();
}

// A pixel of an SPPM state that no eye path has reached yet (sppm.h: make_sppm_state): mesh and
// material −1, nothing gathered. The only hitpoint whose ids may lie outside the scene's tables.
bool unreached_sppm_pixel(const HitpointSet& h, const pf_hitpoint& hp) {
  return h.estimator == "sppm" && hp.mesh == -1 && hp.material == -1 && hp.n_photons == 0.f &&
         hp.flux[0] == 0.f && hp.flux[1] == 0.f && hp.flux[2] == 0.f;
}

// "<what> id <value> is outside the scene's <size> <table>", for the messages.
std::string out_of(const char* what, int32_t value, size_t size, const char* table) {
  return std::string(what) + " id " + std::to_string(value) + " is outside the scene's " +
         std::to_string(size) + " " + table;
}

// The counts of a hitpoint state and its estimator agree (docs/FORMATS.md): a fresh state
// ("none") has no passes and no photons; a classic estimate one pass; a PPM state at least one
// pass; every pass emitted at least one photon (so N_emitted of eq. 3.19 is not 0 once a pass
// was applied, and not more than 0 before).
void check_state_counts(const HitpointSet& h, const Validator& v) {
  const std::string counts = "attributes passes = " + std::to_string(h.passes) +
                             " and photons_emitted = " + std::to_string(h.photons_emitted);
  if (h.estimator == "none" && (h.passes != 0 || h.photons_emitted != 0))
    v.fail(counts + " of a fresh state (estimator \"none\") are not 0");
  if (h.estimator == "classic" && h.passes != 1)
    v.fail(counts + ": a classic estimate has exactly 1 pass");
  if (h.estimator == "ppm" && h.passes < 1)
    v.fail(counts + ": a PPM state (estimator \"ppm\") has at least 1 pass");
  v.photons_emitted("attribute photons_emitted", h.photons_emitted, h.passes);
  // A PPM state without hitpoints is legitimate: a camera that sees only emitters and the
  // background finds no diffuse surface, and its image is the emitted and direct layers.
}

// One hitpoint's values (validate.h): directions, weight finite and ≥ 0 (the eye path's
// throughput times the pixel filter weight: at most 1 through mirrors and glass, but a BSDF's
// sampled continuation through a glossy point (EyePassOptions::glossy_threshold) weighs
// f·|cos|/pdf, which may exceed 1), R, N and τ of eq. 3.14–3.18, and its radiance of eq. 3.19
// finite. A fresh state has R = R0, N = 0, τ = 0; an SPPM pixel without a diffuse
// surface (no_surface) has N = 0 and τ = 0 and no normal.
void check_hitpoint_values(const HitpointSet& h, size_t i, bool no_surface, const Validator& v) {
  const pf_hitpoint& hp = h.hitpoints[i];
  const std::string H = "hitpoints";
  v.position(Name(H, i, "position"), hp.position);
  if (no_surface) {
    v.finite(Name(H, i, "normal"), hp.normal, 3);
    v.finite(Name(H, i, "dir"), hp.dir, 3);
  } else {
    v.unit(Name(H, i, "normal"), hp.normal);
    v.unit(Name(H, i, "dir"), hp.dir);
  }
  v.in_range(Name(H, i, "weight"), hp.weight, 3, 0.0, kMaxValue);
  v.in_range(Name(H, i, "n_photons"), &hp.n_photons, 1, 0.0, kMaxValue);
  v.in_range(Name(H, i, "flux"), hp.flux, 3, 0.0, kMaxValue);
  // Every pixel's R, reached or not, is a gather radius: R0 until its first visible point, and the
  // one it then gathers with (R² must stay a normal float, validate.h kMinRadius).
  v.in_range(Name(H, i, "radius"), &hp.radius, 1, kMinRadius, kMaxRadius);
  if (no_surface) {
    if (hp.n_photons != 0.f || hp.flux[0] != 0.f || hp.flux[1] != 0.f || hp.flux[2] != 0.f)
      v.fail(Validator::element(H, i) + " has no surface (mesh and material -1) but N or tau "
             "is not 0");
    return;
  }
  if (h.estimator == "none" &&
      (hp.radius != h.radius0 || hp.n_photons != 0.f || hp.flux[0] != 0.f || hp.flux[1] != 0.f ||
       hp.flux[2] != 0.f))
    v.fail(Validator::element(H, i) + " of a fresh state (estimator \"none\") has R " +
           value_text(hp.radius) + ", N " + value_text(hp.n_photons) +
           " or tau not R0, 0 and 0");
  for (int c = 0; c < 3 && h.photons_emitted > 0; ++c) {
    const float l = hp.weight[c] * pf_ppm_radiance(hp.flux[c], hp.radius, float(h.photons_emitted));
    if (!(l <= kMaxValue))
      v.fail(Validator::element(H, i) + ": its radiance (eq. 3.19, channel " + std::to_string(c) +
             ") " + value_text(l) + " from tau " + value_text(hp.flux[c]) + " and R " +
             value_text(hp.radius) + " is not finite or exceeds " + value_text(kMaxValue));
  }
}

// An SPPM state holds exactly one hitpoint per pixel.
void check_one_per_pixel(const HitpointSet& h, const Validator& v) {
  const size_t pixels = size_t(h.width) * size_t(h.height);
  if (h.hitpoints.size() != pixels)
    v.fail("an SPPM state (estimator \"sppm\") holds one hitpoint per pixel: " +
           std::to_string(h.hitpoints.size()) + " hitpoints for " + std::to_string(pixels) +
           " pixels");
  std::vector<uint8_t> seen(pixels, 0);
  for (size_t i = 0; i < h.hitpoints.size(); ++i) {
    const pf_hitpoint& hp = h.hitpoints[i];
    if (seen[size_t(hp.pixel_y) * size_t(h.width) + size_t(hp.pixel_x)]++)
      v.fail(Validator::element("hitpoints", i) + ": pixel (" + std::to_string(hp.pixel_x) + ", " +
             std::to_string(hp.pixel_y) + ") has a second hitpoint in an SPPM state");
  }
}

// The photons of a pass (photons.h5 or a grid pass): position, unit direction, flux and flags.
void check_photon_values(const std::string& dataset, const std::vector<pf_photon>& photons,
                         size_t begin, size_t end, const Validator& v) {
  for (size_t i = begin; i < end; ++i) {
    const pf_photon& p = photons[i];
    v.position(Name(dataset, i, "position"), p.position);
    v.unit(Name(dataset, i, "dir"), p.dir);
    v.in_range(Name(dataset, i, "flux"), p.flux, 3, 0.0, kMaxValue);
    if (p.flags & ~(PF_PHOTON_CAUSTIC | PF_PHOTON_DIRECT))
      v.fail(Validator::element(dataset, i, "flags") + " = " + std::to_string(p.flags) +
             " has bits other than 1 (caustic) and 2 (direct)");
  }
}

// pass_emitted of a photons or grid file: every pass emitted 1 … kMaxPhotonsPerPass photons
// (validate.h), the bound every count of photons emitted shares, so sums of them never wrap.
void check_pass_emitted(const std::vector<uint64_t>& emitted, const Validator& v) {
  for (size_t k = 0; k < emitted.size(); ++k)
    if (emitted[k] < 1 || emitted[k] > kMaxPhotonsPerPass)
      v.fail(Validator::element("pass_emitted", k) + " = " + std::to_string(emitted[k]) +
             " is outside [1, " + std::to_string(kMaxPhotonsPerPass) + "]");
}
}  // namespace

// HDF5 record type of pf_pbr_point (pbr_point_shared.h), named fields for h5py.
const h5::Compound& h5_type_pbr_point() {
  static const h5::Compound t = [] {
    h5::Compound c(sizeof(pf_pbr_point));
    c.f32("base_color", offsetof(pf_pbr_point, params.base_color), 3);
    c.f32("metallic", offsetof(pf_pbr_point, params.metallic));
    c.f32("roughness", offsetof(pf_pbr_point, params.roughness));
    c.f32("transmission", offsetof(pf_pbr_point, params.transmission));
    c.f32("ior", offsetof(pf_pbr_point, params.ior));
    c.i32("outside", offsetof(pf_pbr_point, outside));
    return c;
  }();
  return t;
}

const h5::Compound& h5_type_mesh_grid() {
  static const h5::Compound t = [] {
    h5::Compound c(sizeof(pf_mesh_grid));
    c.f32("lo", offsetof(pf_mesh_grid, lo), 3).f32("bin_size", offsetof(pf_mesh_grid, bin_size));
    c.i32("nx", offsetof(pf_mesh_grid, nx)).i32("ny", offsetof(pf_mesh_grid, ny));
    c.i32("nz", offsetof(pf_mesh_grid, nz)).i32("first_bin", offsetof(pf_mesh_grid, first_bin));
    c.i32("first_photon", offsetof(pf_mesh_grid, first_photon));
    c.i32("photon_count", offsetof(pf_mesh_grid, photon_count));
    return c;
  }();
  return t;
}

void require_scene(const std::string& path, const std::string& scene_id,
                   const std::string& expected, const std::string& scene_path) {
  if (scene_id != expected)
    throw input_error(path,
                      "was made from a different scene than " + scene_path + " (scene_id " +
                          scene_id.substr(0, 12) + " vs " + expected.substr(0, 12) + ")",
                      "rerun the stages from the same scene.h5");
}

void check_against_scene(const std::string& path, const HitpointSet& h, const Scene& scene) {
  const size_t meshes = scene.mesh_names.size(), materials = scene.materials.size();
  const std::string hint = "the file does not belong to this scene or is damaged; remake it with "
                           "trace-hitpoints";
  for (size_t i = 0; i < h.hitpoints.size(); ++i) {
    const pf_hitpoint& hp = h.hitpoints[i];
    if (unreached_sppm_pixel(h, hp)) continue;
    if (hp.mesh < 0 || size_t(hp.mesh) >= meshes)
      throw input_error(path, "hitpoint " + std::to_string(i) + ": " +
                                  out_of("mesh", hp.mesh, meshes, "meshes"), hint);
    if (hp.material < 0 || size_t(hp.material) >= materials)
      throw input_error(path, "hitpoint " + std::to_string(i) + ": " +
                                  out_of("material", hp.material, materials, "materials"), hint);
    if (!near_bounds(hp.position, scene.bounds))
      throw input_error(path, "/hitpoints[" + std::to_string(i) + "]: position " +
                                  fmt3(Vec3(hp.position)) + " lies far outside the scene's bounds " +
                                  fmt3(scene.bounds.lo) + " .. " + fmt3(scene.bounds.hi),
                        hint);
  }
  // The BSDF table (hitpoint_bsdf): an entry exactly at the hitpoints on PBR materials. A PBR
  // hitpoint without one cannot be gathered (its f depends on the parameters there).
  if (h.bsdf.empty() && !scene.has_pbr()) return;  // a diffuse scene: nothing to check
  for (size_t i = 0; i < h.hitpoints.size(); ++i) {
    const pf_hitpoint& hp = h.hitpoints[i];
    const bool pbr = hp.material >= 0 && scene.materials[size_t(hp.material)].type == PF_MAT_PBR;
    if (pbr && h.bsdf.empty())
      throw input_error(path, "hitpoint " + std::to_string(i) + " lies on PBR material " +
                                  std::to_string(hp.material) + " but the file has no " +
                                  "/hitpoint_bsdf (made before format version 2, or damaged)",
                        "remake it with trace-hitpoints");
    if (h.bsdf.empty()) continue;
    if (pbr == empty_pbr_point(h.bsdf[i]))
      throw input_error(path, "/hitpoint_bsdf[" + std::to_string(i) + "] " +
                                  (pbr ? "is empty at a hitpoint on a PBR material"
                                       : "holds a BSDF at a hitpoint that is not on a PBR material"),
                        hint);
  }
}

void check_against_scene(const std::string& path, const PhotonSet& p, const Scene& scene) {
  const size_t meshes = scene.mesh_names.size();
  for (size_t i = 0; i < p.photons.size(); ++i)
    if (p.photons[i].mesh < 0 || size_t(p.photons[i].mesh) >= meshes)
      throw input_error(path, "photon " + std::to_string(i) + ": " +
                                  out_of("mesh", p.photons[i].mesh, meshes, "meshes"),
                        "the file does not belong to this scene or is damaged; remake it with "
                        "trace-photons");
}

void check_against_scene(const std::string& path, const GridSet& g, const Scene& scene) {
  const size_t meshes = scene.mesh_names.size();
  // load_grids checked that every photon lies in the range of its own mesh's grid, so one grid
  // per scene mesh bounds the photons' meshes too.
  for (size_t k = 0; k < g.grids.size(); ++k)
    if (g.grids[k].mesh_grid.size() != meshes)
      throw input_error(path, "pass " + std::to_string(g.first_pass + int(k)) + " has grids for " +
                                  std::to_string(g.grids[k].mesh_grid.size()) +
                                  " meshes, the scene has " + std::to_string(meshes),
                        "the file does not belong to this scene or is damaged; remake it with "
                        "build-grid");
}

namespace {
template <class Set>
void accept_set(Provenance& prov, const std::string& role, const std::string& path, const Set& set,
                const char* format, const Scene& scene, const std::string& scene_path) {
  require_scene(path, set.scene_id, scene.scene_id, scene_path);
  check_against_scene(path, set, scene);
  prov.add_input(role, path, format, set.scene_id);
}
}  // namespace

void accept_input(Provenance& prov, const std::string& role, const std::string& path,
                  const HitpointSet& h, const Scene& scene, const std::string& scene_path) {
  accept_set(prov, role, path, h, kHitpointsFormat, scene, scene_path);
}
void accept_input(Provenance& prov, const std::string& role, const std::string& path,
                  const PhotonSet& p, const Scene& scene, const std::string& scene_path) {
  accept_set(prov, role, path, p, kPhotonsFormat, scene, scene_path);
}
void accept_input(Provenance& prov, const std::string& role, const std::string& path,
                  const GridSet& g, const Scene& scene, const std::string& scene_path) {
  accept_set(prov, role, path, g, kGridFormat, scene, scene_path);
}

// ---- hitpoints.h5 ---------------------------------------------------------------------------

HitpointSet make_hitpoint_set(EyePassResult&& eye, DirectMode mode, const std::string& scene_id,
                              int eye_pass) {
  HitpointSet h;
  h.eye_pass = eye_pass;
  h.hitpoints = std::move(eye.hitpoints);
  h.bsdf = std::move(eye.bsdf);
  h.emitted = std::move(eye.emitted);
  h.direct = std::move(eye.direct);
  h.width = eye.width;
  h.height = eye.height;
  h.direct_mode = mode;
  h.radius0 = eye.radius;
  h.scene_id = scene_id;
  return h;
}

void save_hitpoints(const HitpointSet& h, const std::string& path, const Provenance& prov) {
  written_check([&] { validate_hitpoints(h, path); });
  h5::Writer w(path, kHitpointsFormat, kHitpointsVersion);
  w.attr("/", "scene_id", h.scene_id);
  w.write("/hitpoints", h5_type_hitpoint(), h.hitpoints);
  w.describe("/hitpoints", "world units; flux W/sr",
             "PPM hitpoints: position, normal (facing the eye ray), dir, weight, radius R, "
             "n_photons N, flux tau, pixel, mesh, material (thesis ch. 3.5)");
  if (!h.bsdf.empty()) {
    w.write(kHitpointBsdf, h5_type_pbr_point(), h.bsdf);
    w.describe(kHitpointBsdf, "",
               "the BSDF at each hitpoint (parallel to /hitpoints): glTF metallic-roughness "
               "parameters with textures applied and outside (1: the hitpoint's normal is the "
               "outside) at a PBR hitpoint, all zero at any other (material/pbr_point_shared.h)");
  }
  std::vector<size_t> shape{size_t(h.height), size_t(h.width), 3};
  w.write("/image/emitted", h.emitted, shape);
  w.describe("/image/emitted", "W/(sr m^2)", "emitters seen directly or via specular chains");
  w.write("/image/direct", h.direct, shape);
  w.describe("/image/direct", "W/(sr m^2)", "direct light by shadow rays (direct_mode shadow-rays)");
  w.attr("/", "width", int64_t(h.width));
  w.attr("/", "height", int64_t(h.height));
  w.attr("/", "direct_mode", direct_mode_name(h.direct_mode));
  w.attr("/", "radius0", double(h.radius0));
  w.attr("/", "estimator", h.estimator);
  w.attr("/", "photons_emitted", int64_t(h.photons_emitted));
  w.attr("/", "passes", int64_t(h.passes));
  w.attr("/", "eye_pass", int64_t(h.eye_pass));
  write_provenance(w, prov);
  w.commit();
}

float hitpoints_radius0(const std::string& path, const HitpointSet& h) {
  if (!(h.radius0 > 0.f && std::isfinite(h.radius0))) {
    std::ostringstream v;
    v << h.radius0;
    throw input_error(path, "attribute radius0 = " + v.str() + " is not a positive finite radius",
                      "remake the file with trace-hitpoints, or give build-grid --radius");
  }
  return h.radius0;
}

Provenance load_hitpoints_provenance(const std::string& path) {
  return read_provenance(h5::Reader(path, kHitpointsFormat, kHitpointsVersion));
}

HitpointSet load_hitpoints(const std::string& path) {
  h5::Reader r(path, kHitpointsFormat, kHitpointsVersion);
  const std::string hint = "the file is damaged; remake it with trace-hitpoints";
  const Validator v(path, hint);
  HitpointSet h;
  h.scene_id = r.scene_id();
  // The camera's image size.
  h.width = int(attr_in(r, path, "/", "width", 1, kMaxImageSide, hint));
  h.height = int(attr_in(r, path, "/", "height", 1, kMaxImageSide, hint));
  h.direct_mode = parse_direct(r.attr_string("/", "direct_mode"), path);
  h.radius0 = v.to_float("attribute radius0", r.attr_double("/", "radius0"), kMinRadius, kMaxRadius);
  h.estimator = r.attr_string("/", "estimator");
  h.photons_emitted = uint64_t(attr_in(r, path, "/", "photons_emitted", 0,
                                       std::numeric_limits<int64_t>::max(), hint));
  h.passes = int(attr_in(r, path, "/", "passes", 0, kIntMax, hint));
  // Files written before the estimators with a new eye pass every pass hold eye pass 0.
  if (r.has_attr("/", "eye_pass")) h.eye_pass = int(attr_in(r, path, "/", "eye_pass", 0, kIntMax, hint));
  h.hitpoints = r.read<pf_hitpoint>("/hitpoints", h5_type_hitpoint());
  if (r.version() >= 2 && r.exists(kHitpointBsdf)) {
    h.bsdf = r.read<pf_pbr_point>(kHitpointBsdf, h5_type_pbr_point());
    if (h.bsdf.empty())
      v.fail("hitpoint_bsdf is present but empty (a file without PBR hitpoints has none)");
  }
  const std::vector<size_t> layer{size_t(h.height), size_t(h.width), 3};
  h.emitted = r.read<float>("/image/emitted", layer);
  h.direct = r.read<float>("/image/direct", layer);
  validate_hitpoints(h, path);
  return h;
}

void validate_hitpoints(const HitpointSet& h, const std::string& path) {
  const std::string hint = "the file is damaged; remake it with trace-hitpoints";
  const Validator v(path, hint);
  v.int_in_range("attribute width", h.width, 1, kMaxImageSide);
  v.int_in_range("attribute height", h.height, 1, kMaxImageSide);
  if (h.direct_mode != DirectMode::Photons && h.direct_mode != DirectMode::ShadowRays)
    v.fail("attribute direct_mode is no direct mode");
  v.in_range("attribute radius0", h.radius0, kMinRadius, kMaxRadius);
  if (h.estimator != "none" && h.estimator != "ppm" && h.estimator != "classic" &&
      h.estimator != "sppm")
    v.fail("attribute estimator '" + h.estimator +
           "' is none of \"none\", \"ppm\", \"classic\" and \"sppm\"");
  v.int_in_range("attribute passes", h.passes, 0, kIntMax);
  v.int_in_range("attribute eye_pass", h.eye_pass, 0, kIntMax);
  check_state_counts(h, v);
  check_image(path, h.emitted, h.width, h.height, "emitted");
  check_image(path, h.direct, h.width, h.height, "direct");
  v.image_in_range("image/emitted", h.emitted, h.width, 0.0, kMaxValue);
  v.image_in_range("image/direct", h.direct, h.width, 0.0, kMaxValue);
  for (size_t i = 0; i < h.hitpoints.size(); ++i) {
    const pf_hitpoint& hp = h.hitpoints[i];
    if (hp.pixel_x < 0 || hp.pixel_x >= h.width || hp.pixel_y < 0 || hp.pixel_y >= h.height)
      throw input_error(path, "a hitpoint's pixel lies outside the image", hint);
    // mesh and material index the scene's tables: their upper bounds are check_against_scene's.
    // A pixel of an SPPM state that no eye path has reached (sppm.h) has mesh = material = -1;
    // check_hitpoint_values refuses one that gathered anything (unreached_sppm_pixel).
    const bool no_surface = h.estimator == "sppm" && hp.mesh == -1 && hp.material == -1;
    if ((hp.mesh < 0 || hp.material < 0) && !no_surface)
      throw input_error(path, "hitpoint " + std::to_string(i) + " has a negative " +
                                  (hp.mesh < 0 ? "mesh" : "material") + " id", hint);
    if (!finite3(hp.position))
      throw input_error(path, "hitpoint " + std::to_string(i) + " has a non-finite position",
                        hint);
    check_hitpoint_values(h, i, no_surface, v);
  }
  if (h.estimator == "sppm") check_one_per_pixel(h, v);
  check_bsdf_table(h, v);
}

// ---- photons.h5 -----------------------------------------------------------------------------

void save_photons(const PhotonSet& p, const std::string& path, const Provenance& prov) {
  written_check([&] { validate_photons(p, path); });
  h5::Writer w(path, kPhotonsFormat, kPhotonsVersion);
  w.attr("/", "scene_id", p.scene_id);
  w.attr("/", "first_pass", int64_t(p.first_pass));
  w.attr("/", "seed", int64_t(p.seed));
  w.write("/photons", h5_type_photon(), p.photons);
  w.describe("/photons", "world units; flux W (divide by photons emitted)",
             "photons stored at diffuse hits: the global map; flags 1 = caustic (L S+ D), "
             "2 = direct (L D)");
  std::vector<pf_photon> caustic;
  for (auto& ph : p.photons)
    if (ph.flags & PF_PHOTON_CAUSTIC) caustic.push_back(ph);
  w.write("/caustic", h5_type_photon(), caustic);
  w.describe("/caustic", "as /photons", "the caustic map: photons of L S+ D paths only");
  w.write("/pass_begin", p.pass_begin);
  w.describe("/pass_begin", "", "index in /photons of each pass's first photon, then the end");
  w.write("/pass_emitted", p.pass_emitted);
  w.describe("/pass_emitted", "photons", "photons emitted in each pass");
  write_provenance(w, prov);
  w.commit();
}

Provenance load_photons_provenance(const std::string& path) {
  return read_provenance(h5::Reader(path, kPhotonsFormat, kPhotonsVersion));
}

PhotonSet load_photons(const std::string& path) {
  h5::Reader r(path, kPhotonsFormat, kPhotonsVersion);
  const std::string hint = "the file is damaged; remake it with trace-photons";
  PhotonSet p;
  p.scene_id = r.scene_id();
  p.seed = uint32_t(attr_in(r, path, "/", "seed", 0, std::numeric_limits<uint32_t>::max(), hint));
  p.photons = r.read<pf_photon>("/photons", h5_type_photon());
  p.pass_begin = r.read<uint64_t>("/pass_begin");
  p.pass_emitted = r.read<uint64_t>("/pass_emitted");
  p.first_pass = check_first_pass(r, path, p.pass_emitted.size(), hint);
  validate_photons(p, path);
  return p;
}

void validate_photons(const PhotonSet& p, const std::string& path) {
  const std::string hint = "the file is damaged; remake it with trace-photons";
  if (p.first_pass < 0 || !pass_indices_fit(p.first_pass, int64_t(p.pass_emitted.size())))
    throw input_error(path, "its passes run past 2^31-1", hint);
  bool ok = p.pass_begin.size() == p.pass_emitted.size() + 1 && !p.pass_begin.empty() &&
            p.pass_begin.front() == 0 && p.pass_begin.back() == p.photons.size();
  for (size_t i = 1; ok && i < p.pass_begin.size(); ++i) ok = p.pass_begin[i - 1] <= p.pass_begin[i];
  if (!ok) throw input_error(path, "pass table does not match the photons", hint);
  // Every photon: mesh id not negative (its upper bound is the scene's: check_against_scene),
  // finite position, and the pass index of the pass it is stored in.
  for (size_t k = 0; k < p.pass_emitted.size(); ++k)
    for (uint64_t i = p.pass_begin[k]; i < p.pass_begin[k + 1]; ++i) {
      const pf_photon& ph = p.photons[size_t(i)];
      const std::string which = "photon " + std::to_string(i);
      if (ph.mesh < 0) throw input_error(path, which + " has a negative mesh id", hint);
      if (!finite3(ph.position)) throw input_error(path, which + " has a non-finite position", hint);
      if (int64_t(ph.pass) != int64_t(p.first_pass) + int64_t(k))
        throw input_error(path, which + " has pass " + std::to_string(ph.pass) + " but is stored in pass " +
                                    std::to_string(int64_t(p.first_pass) + int64_t(k)), hint);
    }
  const Validator v(path, hint);
  check_pass_emitted(p.pass_emitted, v);
  check_photon_values("photons", p.photons, 0, p.photons.size(), v);
}

// ---- grid.h5 --------------------------------------------------------------------------------

void save_grids(const GridSet& g, const std::string& path, const Provenance& prov) {
  written_check([&] { validate_grids(g, path); });
  h5::Writer w(path, kGridFormat, kGridVersion);
  w.attr("/", "scene_id", g.scene_id);
  w.attr("/", "first_pass", int64_t(g.first_pass));
  w.write("/pass_emitted", g.pass_emitted);
  w.describe("/pass_emitted", "photons", "photons emitted in each pass");
  for (size_t k = 0; k < g.grids.size(); ++k) {
    const PhotonGrid& grid = g.grids[k];
    std::string p = "/pass" + std::to_string(g.first_pass + int(k));
    w.write(p + "/mesh_grid", h5_type_mesh_grid(), grid.mesh_grid);
    w.describe(p + "/mesh_grid", "world units",
               "per-mesh grid: lo, bin_size d (eq. 7.1), nx ny nz, first_bin, first_photon, "
               "photon_count");
    w.write(p + "/cell_start", grid.cell_start);
    w.describe(p + "/cell_start", "", "first photon of each bin (offset x + y nx + z nx ny)");
    w.write(p + "/photons", h5_type_photon(), grid.photons);
    w.describe(p + "/photons", "as photons.h5", "the pass's photons sorted by (mesh, bin)");
    w.write(p + "/order", grid.order);
    w.attr(p, "max_bins", int64_t(grid.params.max_bins));
    w.attr(p, "default_radius", double(grid.params.default_radius));
  }
  write_provenance(w, prov);
  w.commit();
}

GridSet load_grids(const std::string& path) {
  h5::Reader r(path, kGridFormat, kGridVersion);
  const std::string hint = "the file is damaged; remake it with build-grid";
  GridSet g;
  g.scene_id = r.scene_id();
  g.pass_emitted = r.read<uint64_t>("/pass_emitted");
  g.first_pass = check_first_pass(r, path, g.pass_emitted.size(), hint);
  const Validator v(path, hint);
  check_pass_emitted(g.pass_emitted, v);
  // One /pass<k> group per pass_emitted entry: a group beyond them would be dropped silently.
  size_t groups = 0;
  for (const std::string& c : r.children("/"))
    if (c.size() > 4 && c.compare(0, 4, "pass") == 0 &&
        c.find_first_not_of("0123456789", 4) == std::string::npos)
      ++groups;
  if (groups != g.pass_emitted.size())
    v.fail("the file has " + std::to_string(groups) + " /pass<k> groups but pass_emitted has " +
           std::to_string(g.pass_emitted.size()) + " entries");
  for (size_t k = 0; k < g.pass_emitted.size(); ++k) {
    std::string p = "/pass" + std::to_string(g.first_pass + int(k));
    PhotonGrid grid;
    grid.mesh_grid = r.read<pf_mesh_grid>(p + "/mesh_grid", h5_type_mesh_grid());
    grid.cell_start = r.read<int32_t>(p + "/cell_start");
    grid.photons = r.read<pf_photon>(p + "/photons", h5_type_photon());
    grid.order = r.read<int32_t>(p + "/order");
    grid.params.max_bins = int(attr_in(r, path, p, "max_bins", 1, kMaxBinsPerAxis, hint));
    const double radius = r.attr_double(p, "default_radius");
    v.in_range("attribute " + p + "/default_radius", radius, kMinRadius, kMaxRadius);
    grid.params.default_radius = float(radius);
    g.grids.push_back(std::move(grid));
  }
  validate_grids(g, path);
  for (PhotonGrid& grid : g.grids) grid.index_positions();
  return g;
}

void validate_grids(const GridSet& g, const std::string& path) {
  const std::string hint = "the file is damaged; remake it with build-grid";
  const Validator v(path, hint);
  if (g.first_pass < 0 || !pass_indices_fit(g.first_pass, int64_t(g.pass_emitted.size())))
    v.fail("its passes run past 2^31-1");
  check_pass_emitted(g.pass_emitted, v);
  if (g.grids.size() != g.pass_emitted.size())
    v.fail("the file has " + std::to_string(g.grids.size()) + " /pass<k> groups but pass_emitted has " +
           std::to_string(g.pass_emitted.size()) + " entries");
  for (size_t k = 0; k < g.grids.size(); ++k) {
    const std::string p = "/pass" + std::to_string(g.first_pass + int(k));
    const PhotonGrid& grid = g.grids[k];
    v.int_in_range("attribute " + p + "/max_bins", grid.params.max_bins, 1, kMaxBinsPerAxis);
    v.in_range("attribute " + p + "/default_radius", grid.params.default_radius, kMinRadius,
               kMaxRadius);
    auto bad = [&](const std::string& what) {
      return input_error(path, p + ": " + what, hint);
    };
    // The layout build_photon_grid makes (photon_grid.h), which the gathers index without
    // checks: per mesh, a well-formed header (eq. 7.1) whose bins + 1 entries follow the previous
    // mesh's in cell_start and whose photons follow the previous mesh's in photons.
    const size_t n = grid.photons.size();
    int64_t entries = 0, first_photon = 0;
    for (size_t m = 0; m < grid.mesh_grid.size(); ++m) {
      const pf_mesh_grid& mg = grid.mesh_grid[m];
      const std::string mesh = "mesh " + std::to_string(m);
      const std::string problem = mesh_grid_problem(mg);
      if (!problem.empty()) throw bad(mesh + ": " + problem);
      if (mg.photon_count < 0 || (mg.photon_count == 0) != (mg.nx == 0))
        throw bad(mesh + ": photon_count " + std::to_string(mg.photon_count) +
                  " does not match its bins");
      if (mg.first_bin != entries || mg.first_photon != first_photon)
        throw bad(mesh + ": first_bin or first_photon does not follow the previous mesh");
      entries += mesh_grid_bins(mg) + 1;
      first_photon += mg.photon_count;
      if (entries > int64_t(grid.cell_start.size()) || first_photon > int64_t(n))
        throw bad(mesh + ": its bins or photons lie outside cell_start or photons");
      if (grid.cell_start[size_t(mg.first_bin)] != mg.first_photon ||
          grid.cell_start[size_t(entries - 1)] != first_photon)
        throw bad(mesh + ": cell_start does not span the mesh's photons");
      for (int64_t i = mg.first_photon; i < first_photon; ++i)
        if (grid.photons[size_t(i)].mesh != int32_t(m))
          throw bad("photon " + std::to_string(i) + " lies in the grid of another mesh");
    }
    if (entries != int64_t(grid.cell_start.size()) || first_photon != int64_t(n))
      throw bad("cell_start or photons are longer than the mesh grids");
    for (size_t e = 1; e < grid.cell_start.size(); ++e)
      if (grid.cell_start[e] < grid.cell_start[e - 1]) throw bad("cell_start decreases");
    // order: the photons' indices in the pass, each once.
    if (grid.order.size() != n) throw bad("order and photons differ in length");
    std::vector<uint8_t> seen(n, 0);
    for (int32_t i : grid.order)
      if (i < 0 || size_t(i) >= n || seen[size_t(i)]++)
        throw bad("order is not a permutation of the photons");
    for (size_t i = 0; i < n; ++i)
      if (!finite3(grid.photons[i].position))
        throw bad("photon " + std::to_string(i) + " has a non-finite position");
    check_photon_values(p.substr(1) + "/photons", grid.photons, 0, n, v);
    for (size_t i = 0; i < n; ++i)
      if (int64_t(grid.photons[i].pass) != int64_t(g.first_pass) + int64_t(k))
        throw bad("photon " + std::to_string(i) + " has pass " +
                  std::to_string(grid.photons[i].pass));
    // Each photon lies in the bin whose cell_start range holds it (eq. 7.1 with the header's lo
    // and bin size, grid_shared.h): the gathers look for a photon only in its own bin.
    for (size_t m = 0; m < grid.mesh_grid.size(); ++m) {
      const pf_mesh_grid& mg = grid.mesh_grid[m];
      if (mg.photon_count == 0) continue;
      v.position(Name(p.substr(1) + "/mesh_grid", m, "lo"), mg.lo);
      if (!(mg.bin_size >= grid.params.default_radius))
        throw bad("mesh " + std::to_string(m) + ": bin size " + value_text(mg.bin_size) +
                  " is below default_radius " + value_text(grid.params.default_radius));
      const int64_t bins = mesh_grid_bins(mg);
      for (int64_t b = 0; b < bins; ++b)
        for (int32_t i = grid.cell_start[size_t(mg.first_bin + b)];
             i < grid.cell_start[size_t(mg.first_bin + b + 1)]; ++i) {
          const pf_photon& ph = grid.photons[size_t(i)];
          if (pf_grid_bin(&mg, ph.position[0], ph.position[1], ph.position[2]) != b)
            throw bad("photon " + std::to_string(i) + " lies outside bin " + std::to_string(b) +
                      " of mesh " + std::to_string(m) + ", whose cell_start range holds it");
        }
    }
  }
}

}  // namespace pf
