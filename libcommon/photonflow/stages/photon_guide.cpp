// Photons where the camera looks: see photon_guide.h.
#include "photonflow/stages/photon_guide.h"

#include <algorithm>
#include <cmath>

#include "photonflow/estimators/ppm.h"
#include "photonflow/foundations/error.h"
#include "photonflow/foundations/options.h"
#include "photonflow/io/hitpoints_file.h"
#include "photonflow/stages/illuminate.h"

namespace pf {

PhotonGuide parse_photon_guide(const std::string& name) {
  require_choice("photon-guide", name, {"uniform", "visibility"});
  return name == "uniform" ? PhotonGuide::Uniform : PhotonGuide::Visibility;
}

const char* photon_guide_name(PhotonGuide g) {
  return g == PhotonGuide::Uniform ? "uniform" : "visibility";
}

namespace {
// Cell coordinates are clamped to ±2^40 (positions far outside the points' box share the edge
// cells' hash; the distance test decides).
constexpr double kCoordLimit = 1099511627776.0;
inline int64_t coord(double v) {
  return int64_t(std::floor(std::max(-kCoordLimit, std::min(kCoordLimit, v))));
}
}  // namespace

size_t VisibleSet::slot_of(int64_t x, int64_t y, int64_t z) const {
  uint64_t h = uint64_t(x) * 0x9e3779b97f4a7c15ull;
  h ^= uint64_t(y) * 0xc2b2ae3d27d4eb4full + (h >> 29);
  h ^= uint64_t(z) * 0x165667b19e3779f9ull + (h >> 32);
  h ^= h >> 31;
  return size_t(h & mask_);
}

bool VisibleSet::cell_of(const float p[3], float off, int64_t c[3]) const {
  for (int a = 0; a < 3; ++a) {
    if (!std::isfinite(p[a])) return false;
    c[a] = coord((double(p[a]) + double(off) - double(lo_[a])) / double(cell_));
  }
  return true;
}

void VisibleSet::build(const std::vector<pf_hitpoint>& points, const std::vector<float>& radius,
                       const std::vector<pf_pbr_point>& bsdf, bool skip_direct) {
  pts_.clear();
  skip_direct_ = skip_direct;
  rmax_ = 0.f;
  for (int a = 0; a < 3; ++a) lo_[a] = INFINITY;
  for (size_t k = 0; k < points.size(); ++k) {
    const pf_hitpoint& h = points[k];
    const float r = radius.size() == 1 ? radius[0] : k < radius.size() ? radius[k] : NAN;
    if (h.mesh < 0 || !(r >= 0.f) || !std::isfinite(r) || !std::isfinite(h.position[0]) ||
        !std::isfinite(h.position[1]) || !std::isfinite(h.position[2]))
      continue;
    Point q;
    for (int a = 0; a < 3; ++a) {
      q.x[a] = h.position[a];
      q.n[a] = h.normal[a];
    }
    q.r = r;
    q.mesh = h.mesh;
    // A PBR point that is not on a PBR material has an all-zero entry: one-sided.
    q.both_sides = k < bsdf.size() && pbr_two_sided_gather(&bsdf[k]);
    pts_.push_back(q);
    rmax_ = std::max(rmax_, r);
    for (int a = 0; a < 3; ++a) lo_[a] = std::min(lo_[a], h.position[a]);
  }
  const size_t n = pts_.size();
  if (n == 0) {
    start_.assign(2, 0);
    mask_ = 0;
    return;
  }
  // Cells of side 2·R_max (at least a relative 1e-6 of the box's corner, so that a zero radius
  // still has cells): a sphere of radius R_max spans at most 2 cells per axis.
  const float scale = std::max({std::fabs(lo_[0]), std::fabs(lo_[1]), std::fabs(lo_[2]), 1.f});
  cell_ = std::max(2.f * rmax_ * 1.0001f, scale * 1e-6f);
  size_t slots = 1024;
  while (slots < 2 * n && slots < (size_t(1) << 30)) slots <<= 1;
  mask_ = slots - 1;
  std::vector<uint32_t> slot(n);
  start_.assign(slots + 1, 0);
  for (size_t k = 0; k < n; ++k) {
    int64_t c[3] = {0, 0, 0};  // the position is finite (checked above)
    cell_of(pts_[k].x, 0.f, c);
    slot[k] = uint32_t(slot_of(c[0], c[1], c[2]));
    start_[slot[k] + 1] += 1;
  }
  for (size_t s = 0; s < slots; ++s) start_[s + 1] += start_[s];
  std::vector<int32_t> cursor(start_.begin(), start_.end() - 1);
  std::vector<Point> sorted(n);
  for (size_t k = 0; k < n; ++k) sorted[size_t(cursor[slot[k]]++)] = pts_[k];  // stable, by slot
  pts_.swap(sorted);
}

bool VisibleSet::near(const pf_photon& ph) const {
  if (pts_.empty()) return false;
  if (skip_direct_ && (ph.flags & PF_PHOTON_DIRECT)) return false;
  const float* p = ph.position;
  // The cells of the box p ± R_max (widened by a relative 1e-4, as PhotonGrid::for_each_in_radius:
  // a point outside it is farther than R_max in float).
  const float pad = rmax_ * 1.0001f;
  int64_t lo[3], hi[3];
  if (!cell_of(p, -pad, lo) || !cell_of(p, pad, hi)) return false;
  for (int64_t cz = lo[2]; cz <= hi[2]; ++cz)
    for (int64_t cy = lo[1]; cy <= hi[1]; ++cy)
      for (int64_t cx = lo[0]; cx <= hi[0]; ++cx) {
        const size_t s = slot_of(cx, cy, cz);
        for (int32_t k = start_[s]; k < start_[s + 1]; ++k) {
          const Point& q = pts_[size_t(k)];
          // The gathers' rule without the slab (illuminate.h photon_accepted; its direct-photon
          // test is made once above).
          if (photon_faces(ph, q.mesh, q.n, q.both_sides) &&
              pf_ppm_in_radius(pf_ppm_dist2(q.x[0], q.x[1], q.x[2], p[0], p[1], p[2]), q.r))
            return true;
        }
      }
  return false;
}

void visible_at_own_radius(const HitpointSet& h, VisibleSet& out) {
  std::vector<float> r(h.hitpoints.size());
  for (size_t i = 0; i < r.size(); ++i) r[i] = h.hitpoints[i].radius;
  out.build(h.hitpoints, r, h.bsdf, h.direct_mode == DirectMode::ShadowRays);
}

void guide_points_from_file(const HitpointSet& h, const std::string& path, int first_pass,
                            int passes, VisibleSet& out) {
  if (h.eye_pass > 0 && (first_pass != h.eye_pass || passes != 1))
    throw input_error(path, "is eye pass " + std::to_string(h.eye_pass) +
                                ", it guides photon pass " + std::to_string(h.eye_pass) + " alone",
                      "trace with --first-pass " + std::to_string(h.eye_pass) + " --passes 1");
  visible_at_own_radius(h, out);
}

}  // namespace pf
