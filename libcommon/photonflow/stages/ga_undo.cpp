// ga_undo.cpp — the chromosome's undo log (ga_chromosome.h, UndoLog): the primitive edits of a
// Chromosome, each of which logs what reverts it, and commit and undo. A child is mutated and
// evaluated in place and undone exactly, so that the parent need not be copied for every child.
#include "photonflow/stages/ga_chromosome.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace pf::ga {

namespace {

void insert_sorted(std::vector<int32_t>& v, int32_t i) {
  v.insert(std::lower_bound(v.begin(), v.end(), i), i);
}
void erase_sorted(std::vector<int32_t>& v, int32_t i) {
  auto it = std::lower_bound(v.begin(), v.end(), i);
  if (it == v.end() || *it != i) throw std::logic_error("ga: member not found");
  v.erase(it);
}

}  // namespace

void Chromosome::touch(int32_t k) {
  Slot& s = slots[size_t(k)];
  if (s.epoch == epoch) return;
  s.epoch = epoch;
  caches.push_back({k, s.term, s.maxd, {s.centre[0], s.centre[1], s.centre[2]}, s.radius});
  touched.push_back(k);
}
void Chromosome::grid_insert(int32_t k) {
  Slot& s = slots[size_t(k)];
  Mesh& m = meshes[size_t(s.mesh)];
  s.cell = cell_of(m, s.c);
  m.cells[size_t(s.cell)].push_back(k);
  log.push_back({kGridInsert, k, 0});
}
void Chromosome::grid_remove(int32_t k) {
  Slot& s = slots[size_t(k)];
  auto& cell = meshes[size_t(s.mesh)].cells[size_t(s.cell)];
  auto it = std::find(cell.begin(), cell.end(), k);
  *it = cell.back();
  cell.pop_back();
}
void Chromosome::grid_erase(int32_t k) {
  grid_remove(k);
  log.push_back({kGridErase, k, 0});
}
void Chromosome::alive_add(int32_t k) {
  Slot& s = slots[size_t(k)];
  auto& list = meshes[size_t(s.mesh)].alive;
  s.pos = int32_t(list.size());
  s.alive = true;
  list.push_back(k);
  log.push_back({kAliveAdd, k, 0});
}
void Chromosome::alive_remove(int32_t k) {
  Slot& s = slots[size_t(k)];
  auto& list = meshes[size_t(s.mesh)].alive;
  const int32_t pos = s.pos, last = list.back();
  list[size_t(pos)] = last;
  slots[size_t(last)].pos = pos;
  list.pop_back();
  s.alive = false;
  s.pos = -1;
  log.push_back({kAliveRemove, k, pos});
}
int32_t Chromosome::alloc() {
  slots.emplace_back();
  log.push_back({kAllocFresh, int32_t(slots.size() - 1), 0});
  return int32_t(slots.size() - 1);
}
void Chromosome::move_hitpoint(int32_t i, int32_t to) {
  const int32_t from = assign[size_t(i)];
  touch(from);
  touch(to);
  erase_sorted(slots[size_t(from)].members, i);
  log.push_back({kMemberErase, from, i});
  insert_sorted(slots[size_t(to)].members, i);
  log.push_back({kMemberInsert, to, i});
  assign[size_t(i)] = to;
  log.push_back({kAssign, i, from});
  Slot& t = slots[size_t(to)];
  t.maxd = std::max(t.maxd, std::sqrt(dist2(hp(i), t.c)));
  Mesh& m = meshes[size_t(t.mesh)];
  m.maxd_bound = std::max(m.maxd_bound, t.maxd);
}

int32_t Chromosome::create(int mesh, const float pos[3]) {
  const int32_t k = alloc();
  touch(k);
  Slot& s = slots[size_t(k)];
  for (int a = 0; a < 3; ++a) s.c[a] = pos[a];
  clamp_to_mesh(mesh, s.c);
  s.mesh = mesh;
  s.id = next_id++;
  s.members.clear();
  s.maxd = 0;
  s.term = 0;
  s.radius = 0;
  alive_add(k);
  grid_insert(k);
  return k;
}
void Chromosome::destroy(int32_t k, bool in_grid) {
  touch(k);
  Slot& s = slots[size_t(k)];
  score -= s.term;
  s.term = 0;
  if (in_grid) grid_erase(k);
  alive_remove(k);
}

void Chromosome::commit() {
  for (Mesh& m : meshes) {  // tighten the bound to the exact maximum
    m.maxd_bound = 0;
    for (int32_t k : m.alive) m.maxd_bound = std::max(m.maxd_bound, slots[size_t(k)].maxd);
  }
  log.clear();
  caches.clear();
  touched.clear();
  ++epoch;
  saved_score = score;
  saved_next_id = next_id;
}

void Chromosome::undo() {
  for (auto it = caches.rbegin(); it != caches.rend(); ++it) {
    Slot& s = slots[size_t(it->slot)];
    s.term = it->term;
    s.maxd = it->maxd;
    for (int a = 0; a < 3; ++a) s.centre[a] = it->centre[a];
    s.radius = it->radius;
  }
  for (auto it = log.rbegin(); it != log.rend(); ++it) {
    const int32_t k = it->a;
    switch (it->op) {
      case kAssign: assign[size_t(k)] = it->b; break;
      case kMemberInsert: erase_sorted(slots[size_t(k)].members, it->b); break;
      case kMemberErase: insert_sorted(slots[size_t(k)].members, it->b); break;
      case kGridInsert: grid_remove(k); break;
      case kGridErase: {
        Slot& s = slots[size_t(k)];
        meshes[size_t(s.mesh)].cells[size_t(s.cell)].push_back(k);
        break;
      }
      case kAliveAdd: {
        Slot& s = slots[size_t(k)];
        meshes[size_t(s.mesh)].alive.pop_back();
        s.alive = false;
        s.pos = -1;
        break;
      }
      case kAliveRemove: {
        Slot& s = slots[size_t(k)];
        auto& list = meshes[size_t(s.mesh)].alive;
        const int32_t pos = it->b;
        if (size_t(pos) == list.size()) {
          list.push_back(k);
        } else {
          const int32_t moved = list[size_t(pos)];
          list.push_back(moved);
          slots[size_t(moved)].pos = int32_t(list.size() - 1);
          list[size_t(pos)] = k;
        }
        s.pos = pos;
        s.alive = true;
        break;
      }
      case kAllocFresh: slots.pop_back(); break;
    }
  }
  log.clear();
  caches.clear();
  touched.clear();
  ++epoch;
  score = saved_score;
  next_id = saved_next_id;
}

}  // namespace pf::ga
