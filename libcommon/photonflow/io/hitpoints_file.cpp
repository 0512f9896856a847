// hitpoints_file.cpp — hitpoints.h5 (hitpoints_file.h): the hitpoint state's writing, reading and
// checks, on its own and against its scene.
#include "photonflow/io/hitpoints_file.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <limits>
#include <sstream>

#include "photonflow/geometry/camera.h"
#include "photonflow/io/h5io.h"
#include "photonflow/estimators/ppm.h"
#include "photonflow/geometry/scene.h"
#include "photonflow/io/h5_types.h"
#include "photonflow/io/stage_file_checks.h"
#include "photonflow/io/validate.h"

namespace pf {

namespace {
// Version 2: the optional dataset /hitpoint_bsdf (PF_MAT_PBR visible points). Version
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
// ior in [1, kMaxPbrIor], outside's bits PF_PBR_POINT_OUTSIDE and PF_PBR_POINT_MERGE_WEIGHTED only). Which entries must be zero is the scene's
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
    if (b.outside & ~(PF_PBR_POINT_OUTSIDE | PF_PBR_POINT_MERGE_WEIGHTED))
      v.fail(Validator::element(B, i, "outside") + " = " + std::to_string(b.outside) +
             " has bits other than 1 (outside) and 2 (merge-weighted)");
  }
}

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
// sampled continuation through a glossy point (EyePassOptions::glossy) weighs
// f·|cos|/pdf, which may exceed 1 where radiance leaves a denser medium, and the merge
// probability divides a shared point's weight), R, N and τ of eq. 3.14–3.18, and its radiance of eq. 3.19
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

}  // namespace pf
