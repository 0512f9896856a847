// ga_chromosome.cpp — the GA's chromosome (ga_chromosome.h, Chromosome): its setup from the
// hitpoints and from centroids, the two structural mutations that keep every hitpoint at its
// nearest centroid while touching only the clusters near the change (add and remove a centroid),
// and the re-evaluation of the touched clusters' fitness terms.
#include "photonflow/stages/ga_chromosome.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>

namespace pf::ga {

void Chromosome::setup(const GaFitnessInputs& in, GaFitness fit) {
  check_inputs(in, fit);
  auto s = std::make_shared<Shared>();
  s->h = in.hitpoints;
  const HitpointSet& h = *in.hitpoints;
  s->pos.resize(3 * h.hitpoints.size());
  s->mesh.resize(h.hitpoints.size());
  int mesh_count = 0;
  for (size_t i = 0; i < h.hitpoints.size(); ++i) {
    const pf_hitpoint& p = h.hitpoints[i];
    if (p.mesh < 0) throw std::invalid_argument("ga: a hitpoint without mesh");
    for (int a = 0; a < 3; ++a) {
      if (!std::isfinite(p.position[a])) throw std::invalid_argument("ga: non-finite hitpoint");
      s->pos[3 * i + size_t(a)] = p.position[a];
    }
    s->mesh[i] = p.mesh;
    mesh_count = std::max(mesh_count, p.mesh + 1);
  }
  s->r0 = h.radius0 > 0.f ? h.radius0 : 1e-3f;
  s->hitpoints_sha256 = hitpoints_hash(h);
  if (ga_fitness_needs_distribution(fit)) s->sums = DistributionSums(*in.distribution);
  sh = s;
  f = fit;
  wg = in.wg_size;
  calc = TermCalc{fit, wg, &sh->sums};
  meshes.assign(size_t(mesh_count), Mesh{});
  for (Mesh& m : meshes)
    for (int a = 0; a < 3; ++a) {
      m.lo[a] = INFINITY;
      m.hi[a] = -INFINITY;
    }
  for (size_t i = 0; i < h.hitpoints.size(); ++i) {
    Mesh& m = meshes[size_t(sh->mesh[i])];
    ++m.hitpoints;
    for (int a = 0; a < 3; ++a) {
      m.lo[a] = std::min(m.lo[a], hp(int32_t(i))[a]);
      m.hi[a] = std::max(m.hi[a], hp(int32_t(i))[a]);
    }
  }
  assign.assign(h.hitpoints.size(), -1);
}

void Chromosome::build(const std::vector<GaCentroid>& cs, uint32_t nid) {
  std::vector<size_t> per_mesh(meshes.size(), 0);
  for (const GaCentroid& c : cs) {
    if (c.mesh < 0 || size_t(c.mesh) >= meshes.size() || meshes[size_t(c.mesh)].hitpoints == 0)
      throw std::invalid_argument("ga: a centroid on a mesh without hitpoints");
    ++per_mesh[size_t(c.mesh)];
  }
  for (size_t m = 0; m < meshes.size(); ++m) {
    if (meshes[m].hitpoints > 0 && per_mesh[m] == 0)
      throw std::invalid_argument("ga: mesh " + std::to_string(m) + " has hitpoints but no centroid");
    setup_grid(meshes[m], per_mesh[m]);
  }
  slots.clear();
  next_id = nid;
  for (const GaCentroid& c : cs) {
    Slot s;
    for (int a = 0; a < 3; ++a) s.c[a] = c.position[a];
    clamp_to_mesh(c.mesh, s.c);
    s.mesh = c.mesh;
    s.id = c.id;
    if (c.id >= next_id) next_id = c.id + 1;
    s.alive = true;
    Mesh& m = meshes[size_t(c.mesh)];
    s.cell = cell_of(m, s.c);
    m.cells[size_t(s.cell)].push_back(int32_t(slots.size()));
    slots.push_back(std::move(s));
  }
  for (size_t i = 0; i < assign.size(); ++i) {
    const int32_t k = nearest(sh->mesh[i], hp(int32_t(i)), -1);
    assign[i] = k;
    slots[size_t(k)].members.push_back(int32_t(i));  // ascending: i ascends
  }
  // Live list per mesh in the given order, without the empty centroids.
  for (Mesh& m : meshes)
    for (auto& cell : m.cells) cell.clear();
  for (size_t k = 0; k < slots.size(); ++k) {
    Slot& s = slots[k];
    Mesh& m = meshes[size_t(s.mesh)];
    if (s.members.empty()) {
      s.alive = false;
      continue;
    }
    s.pos = int32_t(m.alive.size());
    m.alive.push_back(int32_t(k));
    m.cells[size_t(s.cell)].push_back(int32_t(k));
  }
  score = 0;
  for (size_t k = 0; k < slots.size(); ++k)
    if (slots[k].alive) touch(int32_t(k));
  evaluate();
  commit();
}

bool Chromosome::add_centroid(int mesh, const float pos[3]) {
  const int32_t k = create(mesh, pos);
  const float* c = slots[size_t(k)].c;
  std::vector<int32_t>& sw = scratch;    // hitpoints that switch to k
  std::vector<int32_t>& losers = scratch2;  // clusters they leave
  sw.clear();
  losers.clear();
  // Only clusters whose centroid lies within 2·maxd of c can lose members (below); 2·maxd_bound
  // bounds every maxd of the mesh.
  within(mesh, c, 2.0 * meshes[size_t(mesh)].maxd_bound * (1 + 1e-9), cand);
  for (int32_t j : cand) {
    if (j == k) continue;
    const Slot& s = slots[size_t(j)];
    // A member x of j can be nearer to c only if |c − cj| ≤ |c − x| + |x − cj| < 2|x − cj|.
    const double lim = 2.0 * s.maxd * (1 + 1e-9) + 1e-30;
    if (dist2(c, s.c) > lim * lim) continue;
    bool any = false;
    for (int32_t i : s.members)
      if (dist2(hp(i), c) < dist2(hp(i), s.c)) {  // ties stay: the new id is the highest
        sw.push_back(i);
        any = true;
      }
    if (any) losers.push_back(j);
  }
  for (int32_t i : sw) move_hitpoint(i, k);
  // Destroy emptied clusters in id order: the order of the grid cells' lists differs between
  // copies (undo re-inserts at the end), the live lists' order must not.
  std::sort(losers.begin(), losers.end(),
            [&](int32_t x, int32_t y) { return slots[size_t(x)].id < slots[size_t(y)].id; });
  for (int32_t j : losers)
    if (slots[size_t(j)].members.empty()) destroy(j, true);
  if (slots[size_t(k)].members.empty()) {
    destroy(k, true);
    return false;
  }
  return true;
}

bool Chromosome::remove_centroid(int32_t k) {
  Slot& s0 = slots[size_t(k)];
  if (!s0.alive || meshes[size_t(s0.mesh)].alive.size() <= 1) return false;
  const int mesh = s0.mesh;
  touch(k);
  grid_erase(k);
  // Every member x has |x − ck| ≤ maxd. With j0 the centroid nearest to ck (at D0), x's new
  // nearest centroid j satisfies |x − cj| ≤ |x − cj0| ≤ maxd + D0, so |ck − cj| ≤ 2·maxd + D0:
  // one search for the candidates, then each member picks among them (ties: lower id).
  const float ck[3] = {s0.c[0], s0.c[1], s0.c[2]};
  const int32_t j0 = nearest(mesh, ck, -1);
  const double lim = (2.0 * s0.maxd + std::sqrt(dist2(ck, slots[size_t(j0)].c))) * (1 + 1e-9) + 1e-30;
  within(mesh, ck, lim, cand);
  size_t n = 0;
  for (int32_t j : cand)
    if (dist2(ck, slots[size_t(j)].c) <= lim * lim) cand[n++] = j;
  cand.resize(n);
  const std::vector<int32_t> members = slots[size_t(k)].members;
  for (auto it = members.rbegin(); it != members.rend(); ++it) {
    const float* x = hp(*it);
    double best = INFINITY;
    uint32_t best_id = UINT32_MAX;
    int32_t to = -1;
    for (int32_t j : cand) {
      const double d = dist2(x, slots[size_t(j)].c);
      if (to < 0 || d < best || (d == best && slots[size_t(j)].id < best_id)) {
        best = d;
        best_id = slots[size_t(j)].id;
        to = j;
      }
    }
    move_hitpoint(*it, to);
  }
  destroy(k, false);
  return true;
}

int64_t Chromosome::evaluate() {
  const HitpointSet& h = *sh->h;
  for (int32_t k : touched) {
    Slot& s = slots[size_t(k)];
    if (!s.alive) continue;
    cluster_centre_radius(h, s.members.data(), s.members.size(), s.centre, &s.radius);
    const int64_t t = calc.term(s.mesh, s.centre, s.radius, int64_t(s.members.size()));
    score += t - s.term;
    s.term = t;
    double md = 0;
    for (int32_t i : s.members) md = std::max(md, dist2(hp(i), s.c));
    s.maxd = std::sqrt(md);
  }
  return score;
}

}  // namespace pf::ga
