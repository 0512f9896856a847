// procedural.cpp — procedural meshes for tests and benchmarks (procedural.h).
#include "photonflow/geometry/procedural.h"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <unordered_map>

#include "photonflow/foundations/error.h"
#include "photonflow/foundations/hash.h"
#include "photonflow/io/output_file.h"

namespace pf {

namespace {

constexpr float kPi = 3.14159265358979323846f;

// SplitMix64: a tiny PRNG whose stream is the same on every platform.
class Rng {
 public:
  explicit Rng(uint64_t seed) : s_(seed) {}
  uint64_t next() { return splitmix64_mix(s_ += 0x9E3779B97F4A7C15ull); }
  float uniform() { return float(next() >> 40) * (1.f / 16777216.f); }  // [0, 1)
  float uniform(float a, float b) { return a + (b - a) * uniform(); }
  Vec3 unit_vector() {  // uniform on the sphere (Archimedes)
    const float z = uniform(-1.f, 1.f), phi = uniform(0.f, 2.f * kPi);
    const float r = std::sqrt(std::fmax(0.f, 1.f - z * z));
    return {r * std::cos(phi), r * std::sin(phi), z};
  }

 private:
  uint64_t s_;
};

// Smooth noise in [−1, 1]: the mean of 8 plane waves sin(f·k·p + φ) of random direction k,
// frequency f in [2, 5] and phase φ.
class WaveNoise {
 public:
  explicit WaveNoise(uint64_t seed) {
    Rng rng(seed);
    for (Wave& w : waves_) {
      // One draw per statement: the order of a call's arguments or of an operator's operands
      // is unspecified and differs between compilers (GCC and Clang gave different meshes).
      const float f = rng.uniform(2.f, 5.f);
      w.k = rng.unit_vector() * f;
      w.phase = rng.uniform(0.f, 2.f * kPi);
    }
  }
  float operator()(const Vec3& p) const {
    float sum = 0.f;
    for (const Wave& w : waves_) sum += std::sin(dot(w.k, p) + w.phase);
    return sum / float(kWaves);
  }

 private:
  static constexpr int kWaves = 8;
  struct Wave {
    Vec3 k;
    float phase;
  };
  Wave waves_[kWaves];
};

Vec3 geometric_normal(const Vec3& a, const Vec3& b, const Vec3& c) {
  return normalize(cross(b - a, c - a));
}

pf_triangle make_triangle(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& na,
                          const Vec3& nb, const Vec3& nc, MeshIds ids) {
  pf_triangle t{};
  a.store(t.v0);
  b.store(t.v1);
  c.store(t.v2);
  na.store(t.n0);
  nb.store(t.n1);
  nc.store(t.n2);
  t.mesh = ids.mesh;
  t.material = ids.material;
  return t;
}

// Flat-shaded triangle (shading normals = geometric normal).
pf_triangle make_flat(const Vec3& a, const Vec3& b, const Vec3& c, MeshIds ids) {
  const Vec3 n = geometric_normal(a, b, c);
  return make_triangle(a, b, c, n, n, n, ids);
}

// Vertex grid of a UV sphere: `stacks` + 1 rings from the north pole (+z) to the south pole,
// `slices` vertices per ring; radius(dir) gives the distance from the centre per direction.
template <class RadiusFn>
std::vector<pf_triangle> uv_sphere(const Vec3& center, size_t min_triangles, bool smooth,
                                   MeshIds ids, RadiusFn radius) {
  int stacks = 3;
  while (4 * size_t(stacks) * size_t(stacks) - 4 * size_t(stacks) < min_triangles) ++stacks;
  const int slices = 2 * stacks;
  // dirs[i][j]: unit direction of ring i, slice j (rings 0 and `stacks` are the poles).
  std::vector<Vec3> dir(size_t(stacks + 1) * size_t(slices)), pos(dir.size());
  for (int i = 0; i <= stacks; ++i) {
    const float theta = kPi * float(i) / float(stacks);
    for (int j = 0; j < slices; ++j) {
      const float phi = 2.f * kPi * float(j) / float(slices);
      Vec3 d(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
      if (i == 0 || i == stacks) d = Vec3(0.f, 0.f, i == 0 ? 1.f : -1.f);  // one pole vertex
      const size_t k = size_t(i) * size_t(slices) + size_t(j);
      dir[k] = d;
      pos[k] = center + d * radius(d);
    }
  }
  auto at = [&](int i, int j) { return size_t(i) * size_t(slices) + size_t(j % slices); };
  std::vector<pf_triangle> tris;
  tris.reserve(4 * size_t(stacks) * size_t(slices));
  auto emit = [&](size_t a, size_t b, size_t c) {
    tris.push_back(smooth ? make_triangle(pos[a], pos[b], pos[c], dir[a], dir[b], dir[c], ids)
                          : make_flat(pos[a], pos[b], pos[c], ids));
  };
  for (int i = 0; i < stacks; ++i) {
    for (int j = 0; j < slices; ++j) {
      // Quad (i, j)-(i+1, j)-(i+1, j+1)-(i, j+1), CCW seen from outside.
      if (i != stacks - 1) emit(at(i, j), at(i + 1, j), at(i + 1, j + 1));
      if (i != 0) emit(at(i, j), at(i + 1, j + 1), at(i, j + 1));
    }
  }
  return tris;
}

}  // namespace

std::vector<pf_triangle> make_sphere(const Vec3& center, float radius, size_t min_triangles,
                                     MeshIds ids) {
  return uv_sphere(center, min_triangles, true, ids, [radius](const Vec3&) { return radius; });
}

std::vector<pf_triangle> make_blob(const Vec3& center, float radius, size_t min_triangles,
                                   float amplitude, uint64_t seed, MeshIds ids) {
  const WaveNoise noise(seed);
  return uv_sphere(center, min_triangles, false, ids, [&](const Vec3& d) {
    return radius * (1.f + amplitude * noise(d));
  });
}

std::vector<pf_triangle> make_heightfield(float x0, float x1, float z0, float z1, float base,
                                          float height, int cells, uint64_t seed, MeshIds ids) {
  const WaveNoise noise(seed);
  const int n = cells + 1;
  std::vector<Vec3> p(size_t(n) * size_t(n));
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      const float x = x0 + (x1 - x0) * float(i) / float(cells);
      const float z = z0 + (z1 - z0) * float(j) / float(cells);
      // Noise over the unit square, so the relief does not depend on the rectangle's size.
      const Vec3 q(float(i) / float(cells), 0.f, float(j) / float(cells));
      p[size_t(i) * size_t(n) + size_t(j)] = Vec3(x, base + height * noise(q), z);
    }
  }
  std::vector<pf_triangle> tris;
  tris.reserve(2 * size_t(cells) * size_t(cells));
  for (int i = 0; i < cells; ++i) {
    for (int j = 0; j < cells; ++j) {
      const Vec3& a = p[size_t(i) * size_t(n) + size_t(j)];
      const Vec3& b = p[size_t(i + 1) * size_t(n) + size_t(j)];
      const Vec3& c = p[size_t(i + 1) * size_t(n) + size_t(j + 1)];
      const Vec3& d = p[size_t(i) * size_t(n) + size_t(j + 1)];
      // Seen from +y, (x, z) → (x+1, z) → (x+1, z+1) turns clockwise; reverse it.
      tris.push_back(make_flat(a, c, b, ids));
      tris.push_back(make_flat(a, d, c, ids));
    }
  }
  return tris;
}

std::vector<pf_triangle> make_triangle_soup(const Bounds& box, size_t count, float size,
                                            uint64_t seed, MeshIds ids) {
  Rng rng(seed);
  std::vector<pf_triangle> tris;
  tris.reserve(count);
  auto clamp_to_box = [&](Vec3 p) { return vmin(vmax(p, box.lo), box.hi); };
  while (tris.size() < count) {
    // One draw per statement, as in WaveNoise (z, y, x: the order these meshes were made in).
    const float cz = rng.uniform(box.lo.z, box.hi.z);
    const float cy = rng.uniform(box.lo.y, box.hi.y);
    const float cx = rng.uniform(box.lo.x, box.hi.x);
    const Vec3 c(cx, cy, cz);
    Vec3 v[3];
    for (Vec3& x : v) {
      const float reach = size * rng.uniform();
      x = clamp_to_box(c + rng.unit_vector() * reach);
    }
    const float area2 = length(cross(v[1] - v[0], v[2] - v[0]));
    if (!(area2 > 1e-4f * size * size)) continue;  // redraw slivers and degenerates
    tris.push_back(make_flat(v[0], v[1], v[2], ids));
  }
  return tris;
}

std::vector<pf_triangle> make_box(const Vec3& lo, const Vec3& hi, bool inward, MeshIds ids) {
  // Corner c has x from bit 0, y from bit 1, z from bit 2.
  auto corner = [&](int c) {
    return Vec3(c & 1 ? hi.x : lo.x, c & 2 ? hi.y : lo.y, c & 4 ? hi.z : lo.z);
  };
  // Faces as corner quads, CCW seen from outside: −x, +x, −y, +y, −z, +z.
  static const int kQuads[6][4] = {{0, 4, 6, 2}, {1, 3, 7, 5}, {0, 1, 5, 4},
                                   {2, 6, 7, 3}, {0, 2, 3, 1}, {4, 5, 7, 6}};
  std::vector<pf_triangle> tris;
  for (const auto& q : kQuads) {
    const Vec3 a = corner(q[0]), b = corner(q[1]), c = corner(q[2]), d = corner(q[3]);
    if (inward) {
      tris.push_back(make_flat(a, c, b, ids));
      tris.push_back(make_flat(a, d, c, ids));
    } else {
      tris.push_back(make_flat(a, b, c, ids));
      tris.push_back(make_flat(a, c, d, ids));
    }
  }
  return tris;
}

std::vector<pf_triangle> make_cornell_room(size_t sphere_triangles) {
  std::vector<pf_triangle> tris = make_box({0.f, 0.f, 0.f}, {1.f, 1.f, 1.f}, true, {0, 0});
  const auto box = make_box({0.55f, 0.f, 0.15f}, {0.85f, 0.6f, 0.45f}, false, {1, 1});
  const auto ball = make_sphere({0.3f, 0.2f, 0.6f}, 0.2f, sphere_triangles, {2, 2});
  tris.insert(tris.end(), box.begin(), box.end());
  tris.insert(tris.end(), ball.begin(), ball.end());
  return tris;
}

void write_obj(const std::string& path, const std::vector<pf_triangle>& tris) {
  TempOutput tmp(path);
  {
    std::ofstream out(tmp.path());
    if (!out) throw input_error(path, "cannot create the output file", "check the directory");
    // Identical vertices (and normals) are written once; keys are the exact float bits.
    auto key = [](const float* p) {
      std::string k(12, '\0');
      std::memcpy(&k[0], p, 12);
      return k;
    };
    std::unordered_map<std::string, size_t> vindex, nindex;
    std::vector<size_t> face(6 * tris.size());
    char line[128];
    for (size_t i = 0; i < tris.size(); ++i) {
      const pf_triangle& t = tris[i];
      const float* v[3] = {t.v0, t.v1, t.v2};
      const float* n[3] = {t.n0, t.n1, t.n2};
      for (int c = 0; c < 3; ++c) {
        auto vi = vindex.emplace(key(v[c]), vindex.size() + 1);
        if (vi.second) {
          std::snprintf(line, sizeof line, "v %.9g %.9g %.9g\n", v[c][0], v[c][1], v[c][2]);
          out << line;
        }
        auto ni = nindex.emplace(key(n[c]), nindex.size() + 1);
        if (ni.second) {
          std::snprintf(line, sizeof line, "vn %.9g %.9g %.9g\n", n[c][0], n[c][1], n[c][2]);
          out << line;
        }
        face[6 * i + 2 * size_t(c)] = vi.first->second;
        face[6 * i + 2 * size_t(c) + 1] = ni.first->second;
      }
    }
    for (size_t i = 0; i < tris.size(); ++i) {
      const size_t* f = &face[6 * i];
      std::snprintf(line, sizeof line, "f %zu//%zu %zu//%zu %zu//%zu\n", f[0], f[1], f[2], f[3],
                    f[4], f[5]);
      out << line;
    }
    out.flush();
    if (!out) throw input_error(path, "cannot write the output file", "is the disk full?");
  }
  tmp.commit();
}

}  // namespace pf
