// The Scene's derived data: Havel–Herout planes, face normals, bounds, the lights and their CDF
// (derive_lights), light sampling and the scene id. Reading and writing scene.h5 is in
// scene_file.cpp, the checks of a scene's tables and values in scene_validate.cpp.
#include "photonflow/geometry/scene.h"

#include <algorithm>
#include <cmath>
#include <cstddef>

#include "photonflow/foundations/hash.h"
#include "photonflow/geometry/environment_shared.h"
#include "photonflow/geometry/light_shared.h"

namespace pf {

namespace {
float luminance(const float* c) { return 0.2126f * c[0] + 0.7152f * c[1] + 0.0722f * c[2]; }
constexpr float kPi = 3.14159265358979323846f;
}  // namespace

static_assert(PF_ENV_HEADER == 16, "Scene::kNoEnvironment is one header");
const float Scene::kNoEnvironment[16] = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0, -1, 0, 0, 0, 0, 0};

void Scene::compute_hh() {
  hh.resize(triangles.size());
  for (size_t i = 0; i < triangles.size(); ++i) hh[i] = make_hh_triangle(triangles[i]);
  compute_normals();
}

void Scene::compute_normals() {
  normals.resize(triangles.size());
  for (size_t i = 0; i < triangles.size(); ++i) normals[i] = face_normal(triangles[i]);
}

void Scene::compute_bounds() {
  bounds = Bounds();
  for (auto& t : triangles) {
    bounds.extend(Vec3(t.v0));
    bounds.extend(Vec3(t.v1));
    bounds.extend(Vec3(t.v2));
  }
}

void derive_lights(const std::vector<pf_triangle>& triangles,
                   const std::vector<pf_material>& materials, const std::vector<pf_light>& given,
                   std::vector<pf_light>& lights, std::vector<float>& cdf,
                   const Environment* env) {
  // Keep point, spot and directional lights, rebuild area lights from emitter triangles.
  std::vector<pf_light> kept;
  for (auto& l : given)
    if (l.type == PF_LIGHT_POINT || l.type == PF_LIGHT_SPOT || l.type == PF_LIGHT_DIRECTIONAL)
      kept.push_back(l);
  lights.clear();
  for (size_t i = 0; i < triangles.size(); ++i) {
    const pf_triangle& t = triangles[i];
    if (t.material < 0 || size_t(t.material) >= materials.size()) continue;
    const pf_material& m = materials[size_t(t.material)];
    if (m.type != PF_MAT_EMITTER || luminance(m.emission) <= 0.f) continue;
    pf_light l{};
    l.type = PF_LIGHT_AREA;
    l.triangle = int32_t(i);
    l.area = 0.5f * length(cross(Vec3(t.v1) - Vec3(t.v0), Vec3(t.v2) - Vec3(t.v0)));
    // One-sided Lambertian emitter: Φ = π·A·L.
    l.power = kPi * l.area * luminance(m.emission);
    Vec3 c = (Vec3(t.v0) + Vec3(t.v1) + Vec3(t.v2)) / 3.f;
    c.store(l.position);
    for (int k = 0; k < 3; ++k) l.radiance[k] = m.emission[k];
    lights.push_back(l);
  }
  // A directional light's disc (format version 5): the scene's bounding sphere (centre c, radius
  // R) seen along the light, the disc's centre R·kDirectionalDiscMargin before c against the light
  // (outside the bounds), area π·R².
  Bounds b;
  for (const pf_triangle& t : triangles) {
    b.extend(Vec3(t.v0));
    b.extend(Vec3(t.v1));
    b.extend(Vec3(t.v2));
  }
  const Vec3 centre = b.empty() ? Vec3() : (b.lo + b.hi) * 0.5f;
  const float radius = b.empty() ? 0.f : 0.5f * length(b.hi - b.lo);
  for (auto& l : kept) {
    if (l.type == PF_LIGHT_POINT) {
      l.power = 4.f * kPi * luminance(l.radiance);  // isotropic point light: Φ = 4π·I
    } else if (l.type == PF_LIGHT_SPOT) {
      // Φ = ∫ I·falloff dω = 2π·I·∫ falloff d(cos θ) (light_shared.h)
      l.power = float(2.0 * double(kPi) * double(luminance(l.radiance)) *
                      pf_spot_cone_integral(l.cos_inner, l.cos_outer));
    } else {
      (centre - Vec3(l.direction) * (radius * kDirectionalDiscMargin)).store(l.position);
      l.area = kPi * radius * radius;
      l.power = luminance(l.radiance) * l.area;  // Φ = E·π·R²
    }
    lights.push_back(l);
  }
  if (env && env->present()) {
    // The environment (format version 6): photons leave the disc of the bounding sphere, so its
    // flux is π·R²·∫ L dω (pbrt-v3 InfiniteAreaLight::Power).
    pf_light l{};
    l.type = PF_LIGHT_ENVIRONMENT;
    l.triangle = -1;
    centre.store(l.position);
    l.area = kPi * radius * radius;
    l.power = float(double(l.area) * environment_luminance_integral(*env));
    lights.push_back(l);
  }
  cdf.assign(lights.size(), 0.f);
  double total = 0;
  for (auto& l : lights) total += l.power;
  double acc = 0;
  for (size_t i = 0; i < lights.size(); ++i) {
    acc += lights[i].power;
    cdf[i] = total > 0 ? float(acc / total) : float(i + 1) / float(lights.size());
  }
  if (!cdf.empty()) cdf.back() = 1.f;
}

void Scene::compute_light_cdf() {
  std::vector<pf_light> given;
  given.swap(lights);
  derive_lights(triangles, materials, given, lights, light_cdf, &environment);
  pack_environment_buffer();
  derive_light_choice();
}

void Scene::derive_light_choice() {
  light_choice.clear();
  const size_t n = lights.size();
  if (n < 2 || n > PF_LIGHT_CHOICE_MAX || light_cdf.size() != n) return;
  // Emitters: an area light's key is its triangle's material, every other light its own key.
  std::vector<int64_t> group(n);
  for (size_t li = 0; li < n; ++li) {
    const pf_light& l = lights[li];
    group[li] = l.type == PF_LIGHT_AREA ? int64_t(triangles[size_t(l.triangle)].material)
                                        : -1 - int64_t(li);
  }
  std::vector<int64_t> keys = group;
  std::sort(keys.begin(), keys.end());
  keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
  if (keys.size() < 2) return;
  auto slot = [&](int64_t g) {
    return size_t(std::lower_bound(keys.begin(), keys.end(), g) - keys.begin());
  };
  light_choice.assign(n, pf_light_choice{});
  std::vector<double> share(keys.size(), 0.0);  // each emitter's power share
  for (size_t li = 0; li < n; ++li) {
    light_choice[li].power_p = light_cdf[li] - (li ? light_cdf[li - 1] : 0.f);
    share[slot(group[li])] += double(light_choice[li].power_p);
  }
  for (size_t li = 0; li < n; ++li) {
    pf_light_choice& c = light_choice[li];
    const double g = share[slot(group[li])];
    if (g > 0.0) c.uniform_p = float(double(c.power_p) / g / double(keys.size()));
    const pf_light& l = lights[li];
    if (l.type == PF_LIGHT_AREA) {
      const pf_triangle& t = triangles[size_t(l.triangle)];
      ((Vec3(t.v0) + Vec3(t.v1) + Vec3(t.v2)) * (1.f / 3.f)).store(c.centre);
      face_normal(t).store(c.normal);
    } else {
      for (int k = 0; k < 3; ++k) c.centre[k] = l.position[k];
    }
  }
}

void Scene::light_choice_at(const Vec3& x, float* pr) const {
  const float fx[3] = {x.x, x.y, x.z};
  pf_light_choice_probabilities(lights.data(), light_choice.data(), int(lights.size()), fx, pr);
}

float Scene::light_pick_probability(size_t li, const Vec3& x) const {
  if (light_choice.empty()) return light_cdf[li] - (li ? light_cdf[li - 1] : 0.f);
  float pr[PF_LIGHT_CHOICE_MAX] = {};
  light_choice_at(x, pr);
  return pr[li];
}

void Scene::pack_environment_buffer() {
  int li = -1;
  for (size_t i = 0; i < lights.size(); ++i)
    if (lights[i].type == PF_LIGHT_ENVIRONMENT) li = int(i);
  float p_pick = 0.f;
  if (li >= 0 && size_t(li) < light_cdf.size())
    p_pick = light_cdf[size_t(li)] - (li ? light_cdf[size_t(li) - 1] : 0.f);
  const Vec3 centre = li >= 0 ? Vec3(lights[size_t(li)].position) : Vec3();
  const float radius = li >= 0 ? std::sqrt(lights[size_t(li)].area / kPi) : 0.f;
  env_packed = pack_environment(environment, centre, radius, li, p_pick);
}

Vec3 Scene::environment_radiance(const Vec3& d) const {
  const float fd[3] = {d.x, d.y, d.z};
  float le[3];
  pf_env_radiance(env_data(), fd, le);
  return Vec3(le);
}

float Scene::environment_light_pdf(const Vec3& d) const {
  const float fd[3] = {d.x, d.y, d.z};
  return pf_env_light_pdf(env_data(), fd);
}

float Scene::environment_light_pdf(const Vec3& d, const Vec3& x) const {
  const float pdf = environment_light_pdf(d);  // p_pick by power × pdf_ω
  if (light_choice.empty() || !(pdf > 0.f)) return pdf;
  const size_t li = lights.size() - 1;  // the environment is the last light
  return pdf * (light_pick_probability(li, x) / light_choice[li].power_p);
}

float Scene::light_incident(size_t li, const Vec3& p, float u1, float u2, Vec3& w,
                           Vec3& q, Vec3* le) const {
  const pf_light& l = lights[li];
  const float fp[3] = {p.x, p.y, p.z};
  float fw[3], fq[3], nl[3] = {0.f, 0.f, 0.f};
  if (l.type == PF_LIGHT_ENVIRONMENT) {
    float fl[3];
    const float g = pf_env_incident(env_data(), fp, u1, u2, fw, fq, fl);
    w = Vec3(fw);
    q = Vec3(fq);
    if (le) *le = Vec3(fl);
    return g;
  }
  if (le) *le = Vec3(l.radiance);
  const float none[3] = {0.f, 0.f, 0.f};
  const float *v0 = none, *v1 = none, *v2 = none;
  if (l.type == PF_LIGHT_AREA) {
    const pf_triangle& t = triangles[size_t(l.triangle)];
    v0 = t.v0;
    v1 = t.v1;
    v2 = t.v2;
    normal_of(size_t(l.triangle)).store(nl);
  }
  const float g = pf_light_incident(l.type, l.position, l.direction, l.cos_inner, l.cos_outer,
                                    l.area, v0, v1, v2, nl, fp, u1, u2, fw, fq);
  w = Vec3(fw);
  q = Vec3(fq);
  return g > 0.f && light_point_cut_away(li, u1, u2) ? 0.f : g;
}

bool Scene::light_point_cut_away(size_t li, float u1, float u2) const {
  const pf_light& l = lights[li];
  if (!has_alpha_masks() || l.type != PF_LIGHT_AREA) return false;
  return pf_alpha_light_point_cut_away(material_alpha.data(), triangles.data(), textures.data(),
                                       texels.data(), uvs.empty() ? nullptr : uvs[0].uv,
                                       l.triangle, u1, u2) != 0;
}

bool Scene::sample_light(float ul, float u1, float u2, const Vec3& p, LightSample& s) const {
  if (lights.empty()) return false;
  if (light_choice.empty()) {
    s.light = pick_light(ul, s.p_light);
  } else {
    float pr[PF_LIGHT_CHOICE_MAX] = {};
    light_choice_at(p, pr);
    s.light = size_t(pf_light_choice_pick(pr, int(lights.size()), ul));
    s.p_light = pr[s.light];
  }
  if (!(s.p_light > 0.f)) return false;
  s.g = light_incident(s.light, p, u1, u2, s.w, s.q, &s.le);
  return s.g > 0.f;
}

size_t Scene::pick_light_search(float u) const {
  return size_t(std::upper_bound(light_cdf.begin(), light_cdf.end(), u) - light_cdf.begin());
}

void Scene::compute_scene_id() {
  Sha256 h;
  auto feed = [&h](const auto& v) {
    uint64_t n = v.size();
    h.update(&n, sizeof n);
    if (n) h.update(v.data(), n * sizeof(v[0]));
  };
  feed(triangles);
  // Materials: the fields of format versions 1-4 (the first 32 bytes of each pf_material, the
  // bytes this hashed before version 5 grew the struct), so that a scene without a PBR material
  // keeps its id; the metallic-roughness fields (validate_scene: 0 on every other type) and
  // materials/metallic_roughness_texture only when some material is PF_MAT_PBR.
  constexpr size_t kLegacyMaterialBytes = offsetof(pf_material, metallic);
  static_assert(kLegacyMaterialBytes == 32, "pf_material: the version 1-4 fields come first");
  {
    const uint64_t n = materials.size();
    h.update(&n, sizeof n);
    for (const pf_material& m : materials) h.update(&m, kLegacyMaterialBytes);
  }
  // Lights: the fields of format versions 1-4 always (the same bytes as hashing the old 40-byte
  // lights), the spot/directional fields of version 5 only where a scene has such a light, so
  // that a scene of area and point lights keeps its id (validate_scene requires those fields 0).
  const uint64_t n_lights = lights.size();
  h.update(&n_lights, sizeof n_lights);
  bool punctual = false;
  for (const pf_light& l : lights) {
    h.update(&l, offsetof(pf_light, direction));
    punctual = punctual || l.type == PF_LIGHT_SPOT || l.type == PF_LIGHT_DIRECTIONAL;
  }
  if (punctual)
    for (const pf_light& l : lights)
      h.update(&l.direction, sizeof(pf_light) - offsetof(pf_light, direction));
  // The pinhole fields always; the lens only when there is one, so that a pinhole scene keeps
  // the id it had before format version 4 added the lens.
  h.update(&camera, offsetof(pf_camera, aperture));
  if (camera.aperture > 0.f) {
    h.update(&camera.aperture, sizeof camera.aperture);
    h.update(&camera.focus_distance, sizeof camera.focus_distance);
  }
  // Textures (format version 3): only where there are some, so that a scene without textures
  // keeps its version-2 id (its materials/texture is all −1 and it has no UVs: nothing to cover).
  if (!textures.empty()) {
    feed(textures);
    feed(texels);
    feed(material_texture);
    feed(uvs);
  }
  if (has_pbr()) {
    for (const pf_material& m : materials) {
      const float mr[3] = {m.metallic, m.roughness, m.transmission};
      h.update(mr, sizeof mr);
    }
    std::vector<int32_t> mr_texture = material_mr_texture;
    mr_texture.resize(materials.size(), -1);
    feed(mr_texture);
  }
  // Alpha cut-outs (format version 5): only when some material is masked, so that every scene
  // without masks keeps its version-4 id.
  bool masked = false;
  for (const pf_alpha_material& a : material_alpha) masked = masked || pf_alpha_masked(a.cutoff);
  if (masked) feed(material_alpha);
  // The environment (format version 6): only where there is one, so that every scene without it
  // keeps its version-5 id.
  if (environment.present()) {
    const int32_t size[2] = {environment.width, environment.height};
    h.update(size, sizeof size);
    feed(environment.texels);
    const float sr[2] = {environment.strength, environment.rotation_deg};
    h.update(sr, sizeof sr);
  }
  scene_id = h.hex();
}

Vec3 Scene::texture_value(int texture, size_t tri, float u, float v) const {
  float rgba[4];
  pf_tex_sample_triangle(&textures[size_t(texture)], texels.data(), uvs[tri].uv, u, v, rgba);
  return {rgba[0], rgba[1], rgba[2]};
}

void finish_scene(Scene& s, const KdBuildParams& kd) {
  s.compute_hh();
  s.compute_bounds();
  s.compute_light_cdf();
  s.kd = build_kdtree(s.triangles, kd);
  s.compute_scene_id();
}

}  // namespace pf
