// Render-stage intermediates: see stage_files.h and docs/FORMATS.md.
#include "photonflow/stage_files.h"

#include <cstddef>

#include "photonflow/h5io.h"
#include "photonflow/scene.h"

namespace pf {

namespace {
constexpr int kHitpointsVersion = 1;
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
}  // namespace

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

void accept_input(Provenance& prov, const std::string& role, const std::string& path,
                  const std::string& format, const std::string& scene_id,
                  const std::string& expected, const std::string& scene_path) {
  require_scene(path, scene_id, expected, scene_path);
  prov.add_input(role, path, format, scene_id);
}

// ---- hitpoints.h5 ---------------------------------------------------------------------------

HitpointSet make_hitpoint_set(EyePassResult&& eye, DirectMode mode, const std::string& scene_id) {
  HitpointSet h;
  h.hitpoints = std::move(eye.hitpoints);
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
  h5::Writer w(path, kHitpointsFormat, kHitpointsVersion);
  w.attr("/", "scene_id", h.scene_id);
  w.write("/hitpoints", h5_type_hitpoint(), h.hitpoints);
  w.describe("/hitpoints", "world units; flux W/sr",
             "PPM hitpoints: position, normal (facing the eye ray), dir, weight, radius R, "
             "n_photons N, flux tau, pixel, mesh, material (thesis ch. 3.5)");
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
  write_provenance(w, prov);
  w.commit();
}

Provenance load_hitpoints_provenance(const std::string& path) {
  return read_provenance(h5::Reader(path, kHitpointsFormat, kHitpointsVersion));
}

HitpointSet load_hitpoints(const std::string& path) {
  h5::Reader r(path, kHitpointsFormat, kHitpointsVersion);
  HitpointSet h;
  h.scene_id = r.scene_id();
  h.width = int(r.attr_int("/", "width"));
  h.height = int(r.attr_int("/", "height"));
  h.direct_mode = parse_direct(r.attr_string("/", "direct_mode"), path);
  h.radius0 = float(r.attr_double("/", "radius0"));
  h.estimator = r.attr_string("/", "estimator");
  h.photons_emitted = uint64_t(r.attr_int("/", "photons_emitted"));
  h.passes = int(r.attr_int("/", "passes"));
  h.hitpoints = r.read<pf_hitpoint>("/hitpoints", h5_type_hitpoint());
  h.emitted = r.read<float>("/image/emitted");
  h.direct = r.read<float>("/image/direct");
  check_image(path, h.emitted, h.width, h.height, "emitted");
  check_image(path, h.direct, h.width, h.height, "direct");
  for (auto& hp : h.hitpoints)
    if (hp.pixel_x < 0 || hp.pixel_x >= h.width || hp.pixel_y < 0 || hp.pixel_y >= h.height)
      throw input_error(path, "a hitpoint's pixel lies outside the image",
                        "the file is damaged; remake it with trace-hitpoints");
  return h;
}

// ---- photons.h5 -----------------------------------------------------------------------------

void save_photons(const PhotonSet& p, const std::string& path, const Provenance& prov) {
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

PhotonSet load_photons(const std::string& path) {
  h5::Reader r(path, kPhotonsFormat, kPhotonsVersion);
  PhotonSet p;
  p.scene_id = r.scene_id();
  p.first_pass = int(r.attr_int("/", "first_pass"));
  p.seed = uint32_t(r.attr_int("/", "seed"));
  p.photons = r.read<pf_photon>("/photons", h5_type_photon());
  p.pass_begin = r.read<uint64_t>("/pass_begin");
  p.pass_emitted = r.read<uint64_t>("/pass_emitted");
  bool ok = p.pass_begin.size() == p.pass_emitted.size() + 1 && !p.pass_begin.empty() &&
            p.pass_begin.front() == 0 && p.pass_begin.back() == p.photons.size();
  for (size_t i = 1; ok && i < p.pass_begin.size(); ++i) ok = p.pass_begin[i - 1] <= p.pass_begin[i];
  if (!ok)
    throw input_error(path, "pass table does not match the photons",
                      "the file is damaged; remake it with trace-photons");
  return p;
}

// ---- grid.h5 --------------------------------------------------------------------------------

void save_grids(const GridSet& g, const std::string& path, const Provenance& prov) {
  h5::Writer w(path, kGridFormat, kGridVersion);
  w.attr("/", "scene_id", g.scene_id);
  w.attr("/", "first_pass", int64_t(g.first_pass));
  w.write("/pass_emitted", g.pass_emitted);
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
  GridSet g;
  g.scene_id = r.scene_id();
  g.first_pass = int(r.attr_int("/", "first_pass"));
  g.pass_emitted = r.read<uint64_t>("/pass_emitted");
  for (size_t k = 0; k < g.pass_emitted.size(); ++k) {
    std::string p = "/pass" + std::to_string(g.first_pass + int(k));
    PhotonGrid grid;
    grid.mesh_grid = r.read<pf_mesh_grid>(p + "/mesh_grid", h5_type_mesh_grid());
    grid.cell_start = r.read<int32_t>(p + "/cell_start");
    grid.photons = r.read<pf_photon>(p + "/photons", h5_type_photon());
    grid.order = r.read<int32_t>(p + "/order");
    grid.params.max_bins = int(r.attr_int(p, "max_bins"));
    grid.params.default_radius = float(r.attr_double(p, "default_radius"));
    // Every bin range must lie inside the photon array.
    for (auto& m : grid.mesh_grid) {
      size_t bins = size_t(m.nx) * size_t(m.ny) * size_t(m.nz);
      if (m.first_bin < 0 || size_t(m.first_bin) + bins + 1 > grid.cell_start.size())
        throw input_error(path, "a mesh grid's bins lie outside cell_start", "remake it");
    }
    for (int32_t c : grid.cell_start)
      if (c < 0 || size_t(c) > grid.photons.size())
        throw input_error(path, "cell_start points outside the photons", "remake it");
    g.grids.push_back(std::move(grid));
  }
  return g;
}

}  // namespace pf
