// knn_indices.h — the k-nearest-neighbour indices of the thesis's Tables 6.2–6.5 behind one
// interface, for bench_ch6_photonmap.cpp. Benchmarks only (not part of libcommon).
//
// Every index is built from photons (pf_photon, positions copied into the library's own layout:
// part of the build time, as a renderer pays it) and answers k-nearest queries with an optional
// approximation ε. Each library runs with its defaults unless noted:
//   ANN 1.1.2 kd-tree      — ANNkd_tree, bucket size 1, ANN_KD_SUGGEST (sliding midpoint),
//                            double coordinates, annkSearch(q, k, …, eps);
//   ANN 1.1.2 bd-tree      — ANNbd_tree, bucket size 1, ANN_KD_SUGGEST + ANN_BD_SUGGEST shrinking;
//   FLANN randomized kd    — flann::KDTreeIndex, the thesis's "FLANN" row, twice:
//                            1 tree searched with checks = FLANN_CHECKS_UNLIMITED (FLANN's "exact"
//                            mode, which only ever reads the first tree), and FLANN's default
//                            4 trees with checks = 32 (best-bin-first over all trees, approximate
//                            even at ε = 0). Neither is exact here: FLANN 1.9's exact mode
//                            (KDTreeIndex::searchLevelExact) bounds a subtree by adding the
//                            squared distance to every split plane on the way down, "we don't
//                            attempt to correct for any use of this feature in a parent node,
//                            which is unlikely to happen" — in 3-D every axis is split again and
//                            again, the bound overestimates and prunes subtrees that hold true
//                            neighbours. Their recall is reported, not asserted;
//   FLANN single kd        — pf::PhotonMap, photonflow's own map: flann::KDTreeSingleIndex, leaf
//                            size 10, heap result set (flann::KNNResultSet2);
//   nanoflann 1.4.3        — KDTreeSingleIndexAdaptor, leaf size 10, KNNResultSet (sorted array).
// ANN and nanoflann are optional (PF_HAVE_ANN, PF_HAVE_NANOFLANN from bench/CMakeLists.txt).
#pragma once
#include <flann/flann.hpp>

#include <algorithm>
#include <memory>
#include <string>
#include <vector>

#include "photonflow/stages/photon_map.h"
#include "photonflow/foundations/shared_types.h"

#ifdef PF_HAVE_ANN
#include <ANN/ANN.h>
#endif
#ifdef PF_HAVE_NANOFLANN
#include <nanoflann.hpp>
#endif

namespace pf::bench {

class KnnIndex {
 public:
  virtual ~KnnIndex() = default;
  // The k nearest photons of q (all of them if the index holds fewer), as photon indices in any
  // order. eps >= 0 allows (1 + eps)-approximate search as the library defines it.
  virtual void knn(const float q[3], int k, float eps, std::vector<uint32_t>& out) = 0;
};

struct KnnLibrary {
  std::string name;
  bool exact;  // eps = 0 must return the exact k nearest (asserted against brute force)
  std::unique_ptr<KnnIndex> (*build)(const std::vector<pf_photon>& photons);
};

namespace detail {

inline std::vector<float> positions(const std::vector<pf_photon>& photons) {
  std::vector<float> xyz(3 * photons.size());
  for (size_t i = 0; i < photons.size(); ++i)
    std::copy(photons[i].position, photons[i].position + 3, &xyz[3 * i]);
  return xyz;
}

#ifdef PF_HAVE_ANN
class AnnIndex : public KnnIndex {
 public:
  AnnIndex(const std::vector<pf_photon>& photons, bool bd)
      : n_(int(photons.size())), pts_(annAllocPts(n_, 3)) {
    for (int i = 0; i < n_; ++i)
      for (int c = 0; c < 3; ++c) pts_[i][c] = photons[size_t(i)].position[c];
    tree_.reset(bd ? new ANNbd_tree(pts_, n_, 3) : new ANNkd_tree(pts_, n_, 3));
  }
  ~AnnIndex() override {
    tree_.reset();
    annDeallocPts(pts_);
  }
  AnnIndex(const AnnIndex&) = delete;
  AnnIndex& operator=(const AnnIndex&) = delete;
  void knn(const float q[3], int k, float eps, std::vector<uint32_t>& out) override {
    k = std::min(k, n_);
    idx_.resize(size_t(k));
    dist_.resize(size_t(k));
    ANNcoord p[3] = {q[0], q[1], q[2]};
    tree_->annkSearch(p, k, idx_.data(), dist_.data(), eps);
    out.assign(idx_.begin(), idx_.end());
  }

 private:
  int n_;
  ANNpointArray pts_;
  std::unique_ptr<ANNkd_tree> tree_;  // ANNbd_tree derives from ANNkd_tree
  std::vector<ANNidx> idx_;
  std::vector<ANNdist> dist_;
};
#endif

// flann::KDTreeIndex searched with `checks` leaves (FLANN_CHECKS_UNLIMITED = exact).
class FlannRandomizedIndex : public KnnIndex {
 public:
  FlannRandomizedIndex(const std::vector<pf_photon>& photons, int trees, int checks)
      : xyz_(positions(photons)), checks_(checks) {
    index_ = std::make_unique<Index>(flann::Matrix<float>(xyz_.data(), photons.size(), 3),
                                     flann::KDTreeIndexParams(trees));
    index_->buildIndex();
  }
  void knn(const float q[3], int k, float eps, std::vector<uint32_t>& out) override {
    flann::KNNResultSet2<float> result(std::min(size_t(k), xyz_.size() / 3));
    index_->findNeighbors(result, q, flann::SearchParams(checks_, eps));
    idx_.resize(result.size());
    dist_.resize(result.size());
    result.copy(idx_.data(), dist_.data(), idx_.size(), false);
    out.assign(idx_.begin(), idx_.end());
  }

 private:
  using Index = flann::KDTreeIndex<flann::L2_Simple<float>>;
  std::vector<float> xyz_;  // the index points into it
  int checks_;
  std::unique_ptr<Index> index_;
  std::vector<size_t> idx_;
  std::vector<float> dist_;
};

class PhotonMapIndex : public KnnIndex {
 public:
  explicit PhotonMapIndex(const std::vector<pf_photon>& photons) : map_(photons) {}
  void knn(const float q[3], int k, float eps, std::vector<uint32_t>& out) override {
    map_.knn(q, k, idx_, dist_, eps);
    out.assign(idx_.begin(), idx_.end());
  }

 private:
  PhotonMap map_;
  std::vector<int32_t> idx_;
  std::vector<float> dist_;
};

#ifdef PF_HAVE_NANOFLANN
class NanoflannIndex : public KnnIndex {
 public:
  explicit NanoflannIndex(const std::vector<pf_photon>& photons)
      : cloud_{positions(photons)},
        tree_(3, cloud_, nanoflann::KDTreeSingleIndexAdaptorParams(10)) {}
  void knn(const float q[3], int k, float eps, std::vector<uint32_t>& out) override {
    const size_t n = std::min(size_t(k), cloud_.kdtree_get_point_count());
    out.resize(n);
    dist_.resize(n);
    nanoflann::KNNResultSet<float, uint32_t> result(n);
    result.init(out.data(), dist_.data());
    tree_.findNeighbors(result, q, nanoflann::SearchParams(0, eps));
    out.resize(result.size());
  }

 private:
  // nanoflann's dataset adaptor over x, y, z per photon.
  struct Cloud {
    std::vector<float> xyz;
    size_t kdtree_get_point_count() const { return xyz.size() / 3; }
    float kdtree_get_pt(size_t i, size_t dim) const { return xyz[3 * i + dim]; }
    template <class Box>
    bool kdtree_get_bbox(Box&) const {
      return false;  // let nanoflann compute the bounding box
    }
  };
  using Tree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, Cloud>,
                                                   Cloud, 3, uint32_t>;
  Cloud cloud_;
  Tree tree_;
  std::vector<float> dist_;
};
#endif

}  // namespace detail

// The libraries compared, in the thesis's order, then nanoflann.
inline std::vector<KnnLibrary> knn_libraries() {
  using namespace detail;
  std::vector<KnnLibrary> libs;
#ifdef PF_HAVE_ANN
  libs.push_back({"ANN kd-tree", true, [](const std::vector<pf_photon>& p) {
                    return std::unique_ptr<KnnIndex>(new AnnIndex(p, false));
                  }});
  libs.push_back({"ANN bd-tree", true, [](const std::vector<pf_photon>& p) {
                    return std::unique_ptr<KnnIndex>(new AnnIndex(p, true));
                  }});
#endif
  libs.push_back({"FLANN randomized kd, 1 tree, unlimited checks", false,
                  [](const std::vector<pf_photon>& p) {
                    return std::unique_ptr<KnnIndex>(
                        new FlannRandomizedIndex(p, 1, flann::FLANN_CHECKS_UNLIMITED));
                  }});
  libs.push_back({"FLANN randomized kd, 4 trees, checks 32", false,
                  [](const std::vector<pf_photon>& p) {
                    return std::unique_ptr<KnnIndex>(new FlannRandomizedIndex(p, 4, 32));
                  }});
  libs.push_back({"FLANN KDTreeSingleIndex (pf::PhotonMap)", true,
                  [](const std::vector<pf_photon>& p) {
                    return std::unique_ptr<KnnIndex>(new PhotonMapIndex(p));
                  }});
#ifdef PF_HAVE_NANOFLANN
  libs.push_back({"nanoflann KDTreeSingleIndexAdaptor", true,
                  [](const std::vector<pf_photon>& p) {
                    return std::unique_ptr<KnnIndex>(new NanoflannIndex(p));
                  }});
#endif
  return libs;
}

// Index of photonflow's own map (pf::PhotonMap) in `libs`, the reference of the ratio tables.
inline int photon_map_library(const std::vector<KnnLibrary>& libs) {
  for (size_t l = 0; l < libs.size(); ++l)
    if (libs[l].name.find("pf::PhotonMap") != std::string::npos) return int(l);
  return 0;
}

// Libraries not built in (for the tables' notes).
inline std::string missing_knn_libraries() {
  std::string m;
#ifndef PF_HAVE_ANN
  m += "ANN (libann-dev) ";
#endif
#ifndef PF_HAVE_NANOFLANN
  m += "nanoflann (libnanoflann-dev) ";
#endif
  return m;
}

}  // namespace pf::bench
