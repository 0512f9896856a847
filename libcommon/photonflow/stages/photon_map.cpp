// photon_map.cpp — FLANN KDTreeSingleIndex photon map with the ppm.h radius rule.
#include "photonflow/stages/photon_map.h"

#include <flann/flann.hpp>

#include <algorithm>
#include <cmath>
#include <limits>

#include "photonflow/estimators/ppm.h"
#include "photonflow/io/provenance.h"

namespace pf {

using FlannIndex = flann::KDTreeSingleIndex<flann::L2_Simple<float>>;

struct PhotonMap::Impl {
  std::vector<float> pos;      // x, y, z per photon; the FLANN index points into it
  std::vector<int32_t> mesh;   // mesh id per photon
  std::unique_ptr<FlannIndex> index;
  double build_seconds = 0;
};

namespace {

// FLANN result set that receives candidates within a slightly enlarged radius and keeps those
// that pass the ppm.h rule (and, optionally, belong to one mesh).
//
// Why the enlarged bound is safe: FLANN's L2_Simple distance is ((0 + dx²) + dy²) + dz², the same
// float value as pf_ppm_dist2, and a photon passing the rule has it <= R·R < bound, so FLANN's
// `dist < worstDist()` test offers it. FLANN prunes a subtree when its (float) lower-bound
// distance exceeds the bound; that lower bound carries rounding errors of a few ulps, far below
// the 2·10⁻⁴ relative margin, so no subtree holding an accepted photon is pruned (eps = 0).
class RuleResultSet : public flann::ResultSet<float> {
 public:
  RuleResultSet(const float* pos, const int32_t* mesh_of, const float q[3], float radius,
                bool filter_mesh, int mesh, std::vector<int32_t>& out)
      : pos_(pos),
        mesh_of_(mesh_of),
        q_(q),
        radius_(radius),
        filter_mesh_(filter_mesh),
        mesh_(mesh),
        out_(out) {
    float pad = radius * 1.0001f;
    bound_ = std::nextafter(pad * pad, std::numeric_limits<float>::infinity());
  }
  bool full() const override { return true; }
  float worstDist() const override { return bound_; }
  void addPoint(float, size_t i) override {
    if (filter_mesh_ && mesh_of_[i] != mesh_) return;
    const float* p = pos_ + 3 * i;
    if (pf_ppm_in_radius(pf_ppm_dist2(q_[0], q_[1], q_[2], p[0], p[1], p[2]), radius_))
      out_.push_back(static_cast<int32_t>(i));
  }

 private:
  const float* pos_;       // x, y, z per photon
  const int32_t* mesh_of_;  // mesh id per photon
  const float* q_;
  float radius_;
  bool filter_mesh_;
  int mesh_;
  std::vector<int32_t>& out_;
  float bound_;
};

}  // namespace

PhotonMap::PhotonMap() : impl_(std::make_unique<Impl>()) {}
PhotonMap::~PhotonMap() = default;
PhotonMap::PhotonMap(PhotonMap&&) noexcept = default;
PhotonMap& PhotonMap::operator=(PhotonMap&&) noexcept = default;

PhotonMap::PhotonMap(const std::vector<pf_photon>& photons, const PhotonMapParams& params)
    : impl_(std::make_unique<Impl>()) {
  Stopwatch sw;
  Impl& m = *impl_;
  m.pos.resize(3 * photons.size());
  m.mesh.resize(photons.size());
  for (size_t i = 0; i < photons.size(); ++i) {
    std::copy(photons[i].position, photons[i].position + 3, &m.pos[3 * i]);
    m.mesh[i] = photons[i].mesh;
  }
  if (!photons.empty()) {
    flann::Matrix<float> data(m.pos.data(), photons.size(), 3);
    m.index = std::make_unique<FlannIndex>(
        data, flann::KDTreeSingleIndexParams(std::max(1, params.leaf_max_size)));
    m.index->buildIndex();
  }
  m.build_seconds = sw.seconds();
}

size_t PhotonMap::size() const { return impl_ ? impl_->mesh.size() : 0; }

double PhotonMap::build_seconds() const { return impl_ ? impl_->build_seconds : 0.0; }

float PhotonMap::knn(const float q[3], int k, std::vector<int32_t>& index,
                     std::vector<float>& dist2, float eps) const {
  index.clear();
  dist2.clear();
  if (empty() || k <= 0) return 0.f;
  size_t n = std::min(static_cast<size_t>(k), size());
  flann::KNNResultSet2<float> result(n);
  flann::SearchParams sp;
  sp.eps = std::max(0.f, eps);
  impl_->index->findNeighbors(result, q, sp);
  std::vector<size_t> idx(result.size());
  dist2.resize(result.size());
  result.copy(idx.data(), dist2.data(), idx.size(), true);  // sorted by (distance, index)
  index.assign(idx.begin(), idx.end());
  return dist2.empty() ? 0.f : dist2.back();
}

void PhotonMap::collect(const float q[3], float radius, int mesh, float eps,
                        std::vector<int32_t>& index) const {
  index.clear();
  if (empty() || !(radius >= 0.f)) return;
  RuleResultSet result(impl_->pos.data(), impl_->mesh.data(), q, radius, mesh >= 0, mesh, index);
  flann::SearchParams sp;
  sp.eps = std::max(0.f, eps);
  impl_->index->findNeighbors(result, q, sp);
  std::sort(index.begin(), index.end());
}

void PhotonMap::radius_search(const float q[3], float radius, std::vector<int32_t>& index,
                              float eps) const {
  collect(q, radius, -1, eps, index);
}

void PhotonMap::gather_radius(const float q[3], float radius, int mesh,
                              std::vector<int32_t>& index) const {
  if (mesh < 0) {
    index.clear();
    return;
  }
  collect(q, radius, mesh, 0.f, index);
}

}  // namespace pf
