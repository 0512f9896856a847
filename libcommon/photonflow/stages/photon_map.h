// photon_map.h — photon map: a FLANN single kd-tree over photon positions (thesis ch. 3.4, 6;
// Tables 6.2–6.5 chose FLANN KDTreeSingleIndex), for
//   - k-nearest queries (classic photon mapping, radiance estimate eq. 3.10),
//   - radius queries (caustic map, fixed radius),
//   - the PPM gather: photons of one mesh within R of a hitpoint (CPU version, ch. 7.1).
//
// Radius rule everywhere: a photon is inside when pf_ppm_in_radius(pf_ppm_dist2(q, p), R), i.e.
// distance² <= R² evaluated exactly as ppm.h does. FLANN is only used to find candidates (with a
// slightly larger radius, since FLANN keeps dist < radius² with its own arithmetic); every
// candidate is then tested with the ppm.h rule, so gather_radius selects exactly the photons that
// PhotonGrid::for_each_in_radius selects.
//
// Queries are const and allocate only locals: any number of threads may query one map at once.
#pragma once
#include <cstdint>
#include <memory>
#include <vector>

#include "photonflow/foundations/shared_types.h"

namespace pf {

struct PhotonMapParams {
  int leaf_max_size = 10;  // photons per kd-tree leaf (FLANN's default)
};

class PhotonMap {
 public:
  PhotonMap();
  // Builds the tree over the photons' positions (copied; the map does not keep `photons`).
  explicit PhotonMap(const std::vector<pf_photon>& photons, const PhotonMapParams& params = {});
  ~PhotonMap();
  PhotonMap(PhotonMap&&) noexcept;
  PhotonMap& operator=(PhotonMap&&) noexcept;
  PhotonMap(const PhotonMap&) = delete;
  PhotonMap& operator=(const PhotonMap&) = delete;

  size_t size() const;
  bool empty() const { return size() == 0; }
  double build_seconds() const;

  // The k nearest photons of q (fewer if the map is smaller), nearest first: photon indices and
  // squared distances. eps >= 0 allows approximate search (FLANN: a subtree is skipped when its
  // distance·(1+eps) exceeds the current k-th distance). Returns the squared distance of the
  // farthest one returned (r² of eq. 3.10), 0 if none.
  float knn(const float q[3], int k, std::vector<int32_t>& index, std::vector<float>& dist2,
            float eps = 0.f) const;

  // All photons with distance² <= radius² of q, in increasing photon index. With eps > 0 the
  // search is approximate (some photons inside may be missed; none outside is returned).
  void radius_search(const float q[3], float radius, std::vector<int32_t>& index,
                     float eps = 0.f) const;

  // The PPM gather: photons of mesh `mesh` with distance² <= radius² of q, exact, in increasing
  // photon index — the same set as PhotonGrid::gather (mapped through the grid's order).
  void gather_radius(const float q[3], float radius, int mesh, std::vector<int32_t>& index) const;

 private:
  // Photons passing the radius rule; mesh < 0 = every mesh.
  void collect(const float q[3], float radius, int mesh, float eps,
               std::vector<int32_t>& index) const;
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace pf
