// grid_file.cpp — grid.h5 (grid_file.h): the per-pass photon grids' writing, reading and checks,
// on their own and against their scene.
#include "photonflow/io/grid_file.h"

#include <string>

#include "photonflow/io/h5io.h"
#include "photonflow/geometry/scene.h"
#include "photonflow/io/h5_types.h"
#include "photonflow/io/stage_file_checks.h"
#include "photonflow/io/validate.h"
#include "photonflow/stages/photon_pass.h"

namespace pf {

namespace {
constexpr int kGridVersion = 1;
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

}  // namespace pf
