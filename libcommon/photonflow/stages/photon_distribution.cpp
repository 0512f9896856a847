// photon_distribution.cpp — the averaged photon-distribution map of thesis ch. 8.2 (eq. 8.3), see
// photon_distribution.h.
#include "photonflow/stages/photon_distribution.h"

#include <algorithm>
#include <climits>
#include <cmath>
#include <stdexcept>

#include "photonflow/stages/grid_shared.h"
#include "photonflow/io/h5io.h"
#include "photonflow/io/validate.h"

namespace pf {

namespace {
constexpr int kDistributionVersion = 1;

size_t bins_of(const pf_mesh_grid& g) { return size_t(g.nx) * size_t(g.ny) * size_t(g.nz); }
}  // namespace

PhotonDistribution empty_photon_distribution(const PhotonGridParams& params,
                                             const std::string& scene_id) {
  if (params.max_bins < 1 || !(params.default_radius > 0.f))
    throw std::invalid_argument("photon distribution: max_bins must be >= 1 and default_radius > 0");
  PhotonDistribution d;
  d.params = params;
  d.scene_id = scene_id;
  return d;
}

void PhotonDistribution::add_pass(const std::vector<pf_photon>& photons, uint64_t pass_emitted,
                                  int mesh_count) {
  if (passes == 0) {
    // The first pass's own grid (the one the gather builds for it), counts from its bin table.
    PhotonGrid g = build_photon_grid(photons, mesh_count, params);
    mesh_grid = g.mesh_grid;
    size_t total = 0;
    for (pf_mesh_grid& m : mesh_grid) {  // first_bin: from cell_start (bins + 1) to counts (bins)
      m.first_bin = int32_t(total);
      m.first_photon = 0;
      total += bins_of(m);
    }
    counts.assign(total, 0);
    for (size_t mi = 0; mi < mesh_grid.size(); ++mi) {
      const pf_mesh_grid& m = mesh_grid[mi];
      const size_t cs = size_t(g.mesh_grid[mi].first_bin);
      for (size_t b = 0; b < bins_of(m); ++b)
        counts[size_t(m.first_bin) + b] = uint64_t(g.cell_start[cs + b + 1] - g.cell_start[cs + b]);
    }
  } else {
    if (mesh_count != int(mesh_grid.size()))
      throw std::invalid_argument("photon distribution: passes with different mesh counts");
    for (size_t i = 0; i < photons.size(); ++i) {
      const pf_photon& p = photons[i];
      if (p.mesh < 0 || p.mesh >= mesh_count)
        throw std::invalid_argument("photon distribution: photon " + std::to_string(i) +
                                    " has mesh id " + std::to_string(p.mesh));
      pf_mesh_grid& m = mesh_grid[size_t(p.mesh)];
      if (m.nx == 0) continue;  // the mesh got no photons in the first pass: no bins
      const int b = pf_grid_bin(&m, p.position[0], p.position[1], p.position[2]);
      ++counts[size_t(m.first_bin) + size_t(b)];
      ++m.photon_count;
    }
  }
  ++passes;
  emitted += pass_emitted;
}

DistributionSums::DistributionSums(const PhotonDistribution& d) : d_(&d) {
  first_.resize(d.mesh_grid.size());
  size_t total = 0;
  for (size_t m = 0; m < d.mesh_grid.size(); ++m) {
    const pf_mesh_grid& g = d.mesh_grid[m];
    first_[m] = total;
    if (g.nx > 0) total += size_t(g.nx + 1) * size_t(g.ny + 1) * size_t(g.nz + 1);
  }
  sat_.assign(total, 0);
  for (size_t m = 0; m < d.mesh_grid.size(); ++m) {
    const pf_mesh_grid& g = d.mesh_grid[m];
    if (g.nx == 0) continue;
    const size_t sx = 1, sy = size_t(g.nx + 1), sz = sy * size_t(g.ny + 1);
    uint64_t* s = &sat_[first_[m]];
    // s[x+1, y+1, z+1] = Σ counts over [0..x] × [0..y] × [0..z] (inclusion–exclusion).
    for (int z = 0; z < g.nz; ++z)
      for (int y = 0; y < g.ny; ++y)
        for (int x = 0; x < g.nx; ++x) {
          const uint64_t c = d.counts[size_t(g.first_bin) + size_t(x + (y + z * g.ny) * g.nx)];
          const size_t i = size_t(x + 1) * sx + size_t(y + 1) * sy + size_t(z + 1) * sz;
          s[i] = c + s[i - sx] + s[i - sy] + s[i - sz] - s[i - sx - sy] - s[i - sx - sz] -
                 s[i - sy - sz] + s[i - sx - sy - sz];
        }
  }
}

bool DistributionSums::box(int mesh, const float centre[3], float radius, int lo[3],
                           int hi[3]) const {
  if (!d_ || mesh < 0 || mesh >= int(d_->mesh_grid.size())) return false;
  const pf_mesh_grid& g = d_->mesh_grid[size_t(mesh)];
  if (g.nx == 0) return false;
  // The same float expressions as gather_grid_clusters.
  const float pad = radius * kClusterBoxSlack * kClusterBoxSlack;
  const int n[3] = {g.nx, g.ny, g.nz};
  for (int a = 0; a < 3; ++a) {
    lo[a] = pf_grid_coord(centre[a] - pad, g.lo[a], g.bin_size, n[a]);
    hi[a] = pf_grid_coord(centre[a] + pad, g.lo[a], g.bin_size, n[a]);
  }
  return true;
}

uint64_t DistributionSums::photons(int mesh, const int lo[3], const int hi[3]) const {
  const pf_mesh_grid& g = d_->mesh_grid[size_t(mesh)];
  const size_t sy = size_t(g.nx + 1), sz = sy * size_t(g.ny + 1);
  const uint64_t* s = &sat_[first_[size_t(mesh)]];
  auto at = [&](int x, int y, int z) { return s[size_t(x) + size_t(y) * sy + size_t(z) * sz]; };
  const int x0 = lo[0], y0 = lo[1], z0 = lo[2], x1 = hi[0] + 1, y1 = hi[1] + 1, z1 = hi[2] + 1;
  return at(x1, y1, z1) - at(x0, y1, z1) - at(x1, y0, z1) - at(x1, y1, z0) + at(x0, y0, z1) +
         at(x0, y1, z0) + at(x1, y0, z0) - at(x0, y0, z0);
}

void save_photon_distribution(const PhotonDistribution& d, const std::string& path,
                              const Provenance& prov) {
  written_check([&] { validate_photon_distribution(d, path); });
  h5::Writer w(path, kPhotonDistributionFormat, kDistributionVersion);
  w.attr("/", "scene_id", d.scene_id);
  w.attr("/", "passes", int64_t(d.passes));
  w.attr("/", "first_pass", int64_t(d.first_pass));
  w.attr("/", "photons_emitted", int64_t(d.emitted));
  w.attr("/", "max_bins", int64_t(d.params.max_bins));
  w.attr("/", "default_radius", double(d.params.default_radius));
  w.write("/mesh_grid", h5_type_mesh_grid(), d.mesh_grid);
  w.describe("/mesh_grid", "world units",
             "per-mesh grid of eq. 7.1 (the first pass's photon grid): bin of p per axis "
             "clamp(floor((p - lo)/bin_size), 0, n - 1), offset x + y*nx + z*nx*ny; first_bin "
             "indexes /photon_count; photon_count = the mesh's photons over all passes");
  w.write("/photon_count", d.counts);
  w.describe("/photon_count", "photons",
             "photons per bin summed over all passes (eq. 8.3 photons_distribution x passes)");
  std::vector<float> mean(d.counts.size());
  for (size_t b = 0; b < mean.size(); ++b) mean[b] = float(d.mean(b));
  w.write("/mean_photons", mean);
  w.describe("/mean_photons", "photons per pass", "photon_count / passes");
  write_provenance(w, prov);
  w.commit();
}

PhotonDistribution load_photon_distribution(const std::string& path) {
  h5::Reader r(path, kPhotonDistributionFormat, kDistributionVersion);
  PhotonDistribution d;
  d.scene_id = r.scene_id();
  const int64_t passes = r.attr_int("/", "passes");
  if (passes < 1 || passes > INT32_MAX)
    throw input_error(path, "attribute passes = " + std::to_string(passes) + " is outside [1, 2^31-1]",
                      "remake it with photon-distribution");
  d.passes = int(passes);
  const Validator v(path, "remake it with photon-distribution");
  const int64_t first_pass = r.attr_int("/", "first_pass");
  v.int_in_range("attribute first_pass", first_pass, 0, INT32_MAX - (passes - 1));
  d.first_pass = int(first_pass);
  const int64_t emitted = r.attr_int("/", "photons_emitted");
  v.int_in_range("attribute photons_emitted", emitted, 0, INT64_MAX);
  d.emitted = uint64_t(emitted);
  const int64_t max_bins = r.attr_int("/", "max_bins");
  v.int_in_range("attribute max_bins", max_bins, 1, kMaxBinsPerAxis);
  d.params.max_bins = int(max_bins);
  const double radius = r.attr_double("/", "default_radius");
  v.in_range("attribute default_radius", radius, kMinRadius, kMaxRadius);
  d.params.default_radius = float(radius);
  d.mesh_grid = r.read<pf_mesh_grid>("/mesh_grid", h5_type_mesh_grid());
  d.counts = r.read<uint64_t>("/photon_count");
  validate_photon_distribution(d, path);
  return d;
}

void validate_photon_distribution(const PhotonDistribution& d, const std::string& path) {
  const Validator v(path, "remake it with photon-distribution");
  v.int_in_range("attribute passes", d.passes, 1, INT32_MAX);
  v.int_in_range("attribute first_pass", d.first_pass, 0, INT32_MAX - (int64_t(d.passes) - 1));
  v.photons_emitted("attribute photons_emitted", d.emitted, d.passes);
  v.int_in_range("attribute max_bins", d.params.max_bins, 1, kMaxBinsPerAxis);
  v.in_range("attribute default_radius", d.params.default_radius, kMinRadius, kMaxRadius);
  // Consistency: every mesh's bins lie inside /photon_count, contiguous, sizes sane.
  size_t next = 0;
  for (size_t m = 0; m < d.mesh_grid.size(); ++m) {
    const pf_mesh_grid& g = d.mesh_grid[m];
    // mesh_grid_problem bounds every n (so the product below cannot wrap) and the bins.
    const std::string problem = mesh_grid_problem(g);
    if (!problem.empty())
      throw input_error(path, "mesh " + std::to_string(m) + " has a malformed grid header: " + problem,
                        "remake it with photon-distribution");
    if (g.first_bin < 0 || size_t(g.first_bin) != next)
      throw input_error(path, "bins of mesh " + std::to_string(m) + " are not contiguous",
                        "remake it with photon-distribution");
    next += bins_of(g);
  }
  if (next != d.counts.size() || d.passes < 1)
    throw input_error(path, "bin table does not match the grid headers (or no passes)",
                      "remake it with photon-distribution");
  // Counts that add up: each mesh's photon_count is the sum of its bins' counts (the fitness sums
  // them in uint64: a sum that wraps is refused too), and a mesh's grid lies in world space.
  for (size_t m = 0; m < d.mesh_grid.size(); ++m) {
    const pf_mesh_grid& g = d.mesh_grid[m];
    uint64_t sum = 0;
    for (size_t b = size_t(g.first_bin); b < size_t(g.first_bin) + bins_of(g); ++b) {
      if (d.counts[b] > uint64_t(INT64_MAX) - sum)
        v.fail(Validator::element("photon_count", b) + ": the counts of mesh " +
               std::to_string(m) + " exceed 2^63-1");
      sum += d.counts[b];
    }
    if (g.photon_count < 0 || sum != uint64_t(g.photon_count))
      v.fail(Validator::element("mesh_grid", m, "photon_count") + " = " +
             std::to_string(g.photon_count) + " is not the sum of its bins' counts, " +
             std::to_string(sum));
    if (bins_of(g) > 0) v.position(Name("mesh_grid", m, "lo"), g.lo);
  }
}

void require_distribution_for(const PhotonDistribution& d, const std::string& path,
                              const HitpointSet& h) {
  if (d.scene_id != h.scene_id)
    throw input_error(path,
                      "was made for a different scene (scene_id " + d.scene_id.substr(0, 12) +
                          " vs the hitpoints' " + h.scene_id.substr(0, 12) + ")",
                      "rerun photon-distribution for this scene");
  const float r0 = h.radius0 > 0.f ? h.radius0 : 1e-3f;  // ppm_grid_params' lower bound
  if (d.params.default_radius != r0)
    throw input_error(path,
                      "has bins of at least " + std::to_string(d.params.default_radius) +
                          " but these hitpoints' R0 is " + std::to_string(r0) +
                          ", so the gather's grids differ",
                      "rerun photon-distribution with these hitpoints");
  int meshes = 0;
  for (const pf_hitpoint& p : h.hitpoints) meshes = std::max(meshes, p.mesh + 1);
  if (d.mesh_count() < meshes)
    throw input_error(path, "has " + std::to_string(d.mesh_count()) + " meshes, the hitpoints use " +
                                std::to_string(meshes), "rerun photon-distribution for this scene");
}

}  // namespace pf
