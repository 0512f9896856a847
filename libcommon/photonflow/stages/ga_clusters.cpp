// ga_clusters.cpp — GaState (ga_clusters.h), the chromosome as the evolution loop, the
// checkpoints and the tests see it, over ga::Chromosome (ga_chromosome.h); and the clusters a
// chromosome gives, from its incremental state or from scratch.
#include "photonflow/stages/ga_clusters.h"

#include "photonflow/stages/ga_chromosome.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace pf {

struct GaState::Impl : ga::Chromosome {};

namespace ga {
namespace {

// The clusters of hitpoint groups (method "ga"): per mesh ascending, ordered by their lowest
// hitpoint; empty groups are left out.
ClusterSet to_set(const Chromosome& st, const std::vector<std::vector<int32_t>>& groups,
                  const std::vector<int32_t>& group_mesh) {
  ClusterSet c;  // empty_cluster_set's bindings, with the hash computed once
  c.wg_size = st.wg;
  c.method = "ga";
  c.scene_id = st.sh->h->scene_id;
  c.hitpoint_count = st.sh->h->hitpoints.size();
  c.hitpoints_sha256 = st.sh->hitpoints_sha256;
  std::vector<size_t> idx;
  for (size_t g = 0; g < groups.size(); ++g)
    if (!groups[g].empty()) idx.push_back(g);
  std::sort(idx.begin(), idx.end(), [&](size_t a, size_t b) {
    if (group_mesh[a] != group_mesh[b]) return group_mesh[a] < group_mesh[b];
    return groups[a].front() < groups[b].front();
  });
  c.order.reserve(st.assign.size() + st.assign.size() / 4);
  for (size_t g : idx)
    append_cluster(c, group_mesh[g], groups[g].data(), groups[g].size(), *st.sh->h);
  return c;
}

// The clusters of the incremental state.
ClusterSet clusters(const Chromosome& st) {
  std::vector<std::vector<int32_t>> groups;
  std::vector<int32_t> mesh;
  for (const CentroidMesh& m : st.meshes)
    for (int32_t k : m.alive) {
      groups.push_back(st.slots[size_t(k)].members);
      mesh.push_back(st.slots[size_t(k)].mesh);
    }
  return to_set(st, groups, mesh);
}

// The clusters of the same centroids from scratch: every hitpoint to its nearest centroid by brute
// force.
ClusterSet full_clusters(const Chromosome& st) {
  std::vector<std::vector<int32_t>> groups(st.slots.size());
  std::vector<int32_t> mesh(st.slots.size(), 0);
  for (size_t k = 0; k < st.slots.size(); ++k) mesh[k] = st.slots[k].mesh;
  for (size_t i = 0; i < st.assign.size(); ++i) {  // brute force over the mesh's centroids
    const CentroidMesh& m = st.meshes[size_t(st.sh->mesh[i])];
    double best = INFINITY;
    uint32_t best_id = UINT32_MAX;
    int32_t best_slot = -1;
    for (int32_t k : m.alive) {
      const double d = dist2(st.hp(int32_t(i)), st.slots[size_t(k)].c);
      if (best_slot < 0 || d < best || (d == best && st.slots[size_t(k)].id < best_id)) {
        best = d;
        best_id = st.slots[size_t(k)].id;
        best_slot = k;
      }
    }
    groups[size_t(best_slot)].push_back(int32_t(i));
  }
  return to_set(st, groups, mesh);
}

}  // namespace
}  // namespace ga

GaState::GaState(const GaFitnessInputs& in, GaFitness f, const ClusterSet& start)
    : p_(std::make_unique<Impl>()) {
  p_->setup(in, f);
  if (start.wg_size != in.wg_size)
    throw std::invalid_argument("ga: the start clusters have another work-group size");
  std::vector<GaCentroid> cs;
  for (const pf_cluster& c : start.clusters) {
    GaCentroid g{};
    for (int a = 0; a < 3; ++a) g.position[a] = c.centre[a];
    g.mesh = c.mesh;
    g.id = uint32_t(cs.size());
    cs.push_back(g);
  }
  p_->build(cs, uint32_t(cs.size()));
}

GaState::GaState(const GaFitnessInputs& in, GaFitness f, const std::vector<GaCentroid>& centroids,
                 uint32_t next_id)
    : p_(std::make_unique<Impl>()) {
  p_->setup(in, f);
  p_->build(centroids, next_id);
}

GaState::GaState(const GaState& o) : p_(std::make_unique<Impl>(*o.p_)) {}
GaState& GaState::operator=(const GaState& o) {
  if (this != &o) *p_ = *o.p_;
  return *this;
}
GaState::~GaState() = default;

bool GaState::mutate(Mutation m, pf_rng& rng) { return ga::mutate(*p_, m, rng); }
bool GaState::mutate_child(pf_rng& rng) { return ga::mutate_child(*p_, rng); }
int64_t GaState::evaluate() { return p_->evaluate(); }
void GaState::commit() { p_->commit(); }
void GaState::undo() { p_->undo(); }
int64_t GaState::score() const { return p_->score; }
double GaState::fitness() const { return double(p_->score) * p_->calc.scale(); }
double GaState::scale() const { return p_->calc.scale(); }
size_t GaState::cluster_count() const { return p_->live_count(); }
ClusterSet GaState::clusters() const { return ga::clusters(*p_); }
ClusterSet GaState::full_clusters() const { return ga::full_clusters(*p_); }
int64_t GaState::full_score() const {
  const ClusterSet c = ga::full_clusters(*p_);
  int64_t s = 0;
  for (const pf_cluster& cl : c.clusters) s += p_->calc.term(cl.mesh, cl.centre, cl.radius, cl.count);
  return s;
}
std::vector<GaCentroid> GaState::centroids() const {
  std::vector<GaCentroid> out;
  for (const ga::CentroidMesh& m : p_->meshes)
    for (int32_t k : m.alive) {
      const ga::Slot& s = p_->slots[size_t(k)];
      GaCentroid g{};
      for (int a = 0; a < 3; ++a) g.position[a] = s.c[a];
      g.mesh = s.mesh;
      g.id = s.id;
      out.push_back(g);
    }
  return out;
}
uint32_t GaState::next_id() const { return p_->next_id; }

}  // namespace pf
