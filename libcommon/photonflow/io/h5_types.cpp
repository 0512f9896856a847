// The HDF5 compound types of the structs the files store (triangles, planes, materials, lights,
// camera, kd-tree nodes, hitpoints, photons, textures), with the older format versions' layouts
// that the readers still accept. They describe files, so they sit in the io layer beside h5io.
#include "photonflow/io/h5_types.h"

#include <cstddef>

#include "photonflow/foundations/shared_types.h"
#include "photonflow/io/h5io.h"
#include "photonflow/material/texture_shared.h"

namespace pf {

#define PF_F32(T, f, n) f32(#f, offsetof(T, f), n)
#define PF_I32(T, f) i32(#f, offsetof(T, f))

const h5::Compound& h5_type_triangle() {
  static const h5::Compound t = [] {
    h5::Compound c(sizeof(pf_triangle));
    c.PF_F32(pf_triangle, v0, 3).PF_F32(pf_triangle, v1, 3).PF_F32(pf_triangle, v2, 3);
    c.PF_F32(pf_triangle, n0, 3).PF_F32(pf_triangle, n1, 3).PF_F32(pf_triangle, n2, 3);
    c.PF_I32(pf_triangle, mesh).PF_I32(pf_triangle, material);
    return c;
  }();
  return t;
}

const h5::Compound& h5_type_hh_triangle() {
  static const h5::Compound t = [] {
    h5::Compound c(sizeof(pf_hh_triangle));
    c.PF_F32(pf_hh_triangle, n, 4).PF_F32(pf_hh_triangle, n1, 4).PF_F32(pf_hh_triangle, n2, 4);
    return c;
  }();
  return t;
}

namespace {
// The material's fields, with the metallic-roughness ones (format version 5) or without
// (versions 1-4: they read as the 0 the vector was made with).
h5::Compound material_compound(bool pbr) {
  h5::Compound c(sizeof(pf_material));
  c.PF_I32(pf_material, type).PF_F32(pf_material, ior, 1);
  c.PF_F32(pf_material, color, 3).PF_F32(pf_material, emission, 3);
  if (pbr) {
    c.PF_F32(pf_material, metallic, 1).PF_F32(pf_material, roughness, 1);
    c.PF_F32(pf_material, transmission, 1);
  }
  return c;
}
}  // namespace

const h5::Compound& h5_type_material() {
  static const h5::Compound t = material_compound(true);
  return t;
}

const h5::Compound& h5_type_material_v4() {
  static const h5::Compound t = material_compound(false);
  return t;
}

namespace {
// The light's fields, with the spot/directional fields of format version 5 or without (1-4).
h5::Compound light_compound(bool punctual) {
  h5::Compound c(sizeof(pf_light));
  c.PF_I32(pf_light, type).PF_I32(pf_light, triangle);
  c.PF_F32(pf_light, area, 1).PF_F32(pf_light, power, 1);
  c.PF_F32(pf_light, position, 3).PF_F32(pf_light, radiance, 3);
  if (punctual)
    c.PF_F32(pf_light, direction, 3).PF_F32(pf_light, cos_inner, 1).PF_F32(pf_light, cos_outer, 1);
  return c;
}
}  // namespace

const h5::Compound& h5_type_light() {
  static const h5::Compound t = light_compound(true);
  return t;
}

const h5::Compound& h5_type_light_v4() {
  static const h5::Compound t = light_compound(false);
  return t;
}

namespace {
// The camera's fields, with the thin lens (format version 4) or without (versions 1-3).
h5::Compound camera_compound(bool lens) {
  h5::Compound c(sizeof(pf_camera));
  c.PF_F32(pf_camera, eye, 3).PF_F32(pf_camera, look_at, 3).PF_F32(pf_camera, up, 3);
  c.PF_F32(pf_camera, fov_y_deg, 1).PF_I32(pf_camera, width).PF_I32(pf_camera, height);
  if (lens) c.PF_F32(pf_camera, aperture, 1).PF_F32(pf_camera, focus_distance, 1);
  return c;
}
}  // namespace

const h5::Compound& h5_type_camera() {
  static const h5::Compound t = camera_compound(true);
  return t;
}

const h5::Compound& h5_type_camera_pinhole() {
  static const h5::Compound t = camera_compound(false);
  return t;
}

const h5::Compound& h5_type_kd_node() {
  static const h5::Compound t = [] {
    h5::Compound c(sizeof(pf_kd_node));
    c.PF_F32(pf_kd_node, lo, 3).PF_F32(pf_kd_node, hi, 3);
    c.PF_I32(pf_kd_node, axis).PF_F32(pf_kd_node, split, 1);
    c.PF_I32(pf_kd_node, left).PF_I32(pf_kd_node, right);
    c.PF_I32(pf_kd_node, first).PF_I32(pf_kd_node, count);
    c.i32("ropes", offsetof(pf_kd_node, ropes), 6);
    return c;
  }();
  return t;
}

const h5::Compound& h5_type_hitpoint() {
  static const h5::Compound t = [] {
    h5::Compound c(sizeof(pf_hitpoint));
    c.PF_F32(pf_hitpoint, position, 3).PF_F32(pf_hitpoint, normal, 3);
    c.PF_F32(pf_hitpoint, dir, 3).PF_F32(pf_hitpoint, weight, 3);
    c.PF_F32(pf_hitpoint, radius, 1).PF_F32(pf_hitpoint, n_photons, 1);
    c.PF_F32(pf_hitpoint, flux, 3);
    c.PF_I32(pf_hitpoint, pixel_x).PF_I32(pf_hitpoint, pixel_y);
    c.PF_I32(pf_hitpoint, mesh).PF_I32(pf_hitpoint, material);
    return c;
  }();
  return t;
}

const h5::Compound& h5_type_photon() {
  static const h5::Compound t = [] {
    h5::Compound c(sizeof(pf_photon));
    c.PF_F32(pf_photon, position, 3).PF_F32(pf_photon, dir, 3).PF_F32(pf_photon, flux, 3);
    c.PF_I32(pf_photon, mesh).PF_I32(pf_photon, pass).PF_I32(pf_photon, flags);
    return c;
  }();
  return t;
}

const h5::Compound& h5_type_texture() {
  static const h5::Compound t = [] {
    h5::Compound c(sizeof(pf_texture));
    c.PF_I32(pf_texture, width).PF_I32(pf_texture, height).PF_I32(pf_texture, offset);
    c.PF_I32(pf_texture, wrap_s).PF_I32(pf_texture, wrap_t).PF_I32(pf_texture, filter);
    return c;
  }();
  return t;
}

#undef PF_F32
#undef PF_I32

}  // namespace pf
