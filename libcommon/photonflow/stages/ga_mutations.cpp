// ga_mutations.cpp — the mutations of a child (thesis ch. 8.1; ga_clusters.h lists them): merge,
// move, remove and add, with their random choices, built from the chromosome's two structural
// mutations (Chromosome::add_centroid and remove_centroid, ga_chromosome.cpp).
#include "photonflow/stages/ga_chromosome.h"

#include <algorithm>
#include <cstdint>
#include <vector>

namespace pf::ga {

using Mutation = GaState::Mutation;

int32_t random_slot(const Chromosome& st, pf_rng& rng) {
  const size_t total = st.live_count();
  size_t k = std::min(total - 1, size_t(double(pf_rng_next(&rng)) * double(total)));
  for (const CentroidMesh& m : st.meshes) {
    if (k < m.alive.size()) return m.alive[k];
    k -= m.alive.size();
  }
  return -1;
}

bool mutate(Chromosome& st, Mutation mu, pf_rng& rng) {
  switch (mu) {
    case Mutation::Merge: {
      const int32_t a = random_slot(st, rng);
      const float u = pf_rng_next(&rng);
      const Slot& A = st.slots[size_t(a)];
      const int32_t b = st.nearest(A.mesh, A.c, a);
      if (b < 0) return false;
      const Slot& B = st.slots[size_t(b)];
      const int64_t s = int64_t(A.members.size() + B.members.size());
      if (s > 2 * int64_t(st.wg)) return false;
      if (s >= st.wg && !(double(u) < double(2 * st.wg - s) / double(st.wg))) return false;
      double sum[3] = {0, 0, 0};
      for (const std::vector<int32_t>* ms : {&A.members, &B.members})
        for (int32_t i : *ms)
          for (int a3 = 0; a3 < 3; ++a3) sum[a3] += st.hp(i)[a3];
      float pos[3];
      for (int a3 = 0; a3 < 3; ++a3) pos[a3] = float(sum[a3] / double(s));
      const int mesh = A.mesh;
      const uint32_t ida = A.id, idb = B.id;
      st.add_centroid(mesh, pos);
      if (st.alive_with_id(a, ida)) st.remove_centroid(a);
      if (st.alive_with_id(b, idb)) st.remove_centroid(b);
      return true;
    }
    case Mutation::Move: {
      const int32_t k = random_slot(st, rng);
      float off[3];
      for (float& o : off) o = 2.f * pf_rng_next(&rng) - 1.f;
      const Slot& s = st.slots[size_t(k)];
      const float r = s.radius > 0.f ? s.radius : st.sh->r0;
      float pos[3];
      for (int a3 = 0; a3 < 3; ++a3) pos[a3] = s.c[a3] + off[a3] * r;
      const int mesh = s.mesh;
      const uint32_t id = s.id;
      const bool added = st.add_centroid(mesh, pos);
      bool removed = false;
      if (st.alive_with_id(k, id)) removed = st.remove_centroid(k);
      return added || removed;
    }
    case Mutation::Remove: {
      const int count = 1 + std::min(kGaMaxRemoveAdd - 1, int(pf_rng_next(&rng) * float(kGaMaxRemoveAdd)));
      bool changed = false;
      for (int t = 0; t < count; ++t) {
        const int32_t a = random_slot(st, rng), b = random_slot(st, rng);
        const int32_t k = st.slots[size_t(b)].members.size() < st.slots[size_t(a)].members.size() ? b : a;
        changed |= st.remove_centroid(k);
      }
      return changed;
    }
    case Mutation::Add: {
      const int count = 1 + std::min(kGaMaxRemoveAdd - 1, int(pf_rng_next(&rng) * float(kGaMaxRemoveAdd)));
      bool changed = false;
      const size_t n = st.assign.size();
      for (int t = 0; t < count; ++t) {
        const int32_t i = int32_t(std::min(n - 1, size_t(double(pf_rng_next(&rng)) * double(n))));
        float pos[3];
        for (int a3 = 0; a3 < 3; ++a3)
          pos[a3] = st.hp(i)[a3] + (2.f * pf_rng_next(&rng) - 1.f) * st.sh->r0;
        changed |= st.add_centroid(st.sh->mesh[size_t(i)], pos);
      }
      return changed;
    }
  }
  return false;
}

bool mutate_child(Chromosome& st, pf_rng& rng) {
  const float u_move = pf_rng_next(&rng), u_remove = pf_rng_next(&rng), u_add = pf_rng_next(&rng);
  bool changed = mutate(st, Mutation::Merge, rng);
  if (u_move < kGaMoveProbability) changed |= mutate(st, Mutation::Move, rng);
  if (u_remove < kGaRemoveProbability) changed |= mutate(st, Mutation::Remove, rng);
  if (u_add < kGaAddProbability) changed |= mutate(st, Mutation::Add, rng);
  return changed;
}

}  // namespace pf::ga
