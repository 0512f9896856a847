// h5edit.h — edits of written intermediates the way a user's h5py script makes them (tests of the
// loaders' value checks, validate_test.cpp and semantic_fuzz_test.cpp). Include
// catch.hpp first. An edit of a dataset's values refreshes its checksum64 (support.h); a dataset
// rewritten with another length gets no checksum64 (as an editor that deletes the attribute,
// docs/FORMATS.md); refresh_scene_id recomputes a scene file's id from its content, as an editor
// that follows docs/FORMATS.md does, so the edited values reach the checks behind the id.
#pragma once
#include <hdf5.h>

#include <cstring>
#include <string>
#include <vector>

#include "photonflow/io/h5io.h"
#include "photonflow/geometry/scene.h"
#include "photonflow/io/h5_types.h"
#include "support.h"

namespace pf::test {

// Every element of dataset `dset` of `file`, read as memory type `type`.
template <class T>
std::vector<T> read_dataset(const std::string& file, const std::string& dset, hid_t type) {
  h5::Handle f(H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT));
  REQUIRE(f.valid());
  h5::Handle d(H5Dopen2(f.get(), dset.c_str(), H5P_DEFAULT));
  REQUIRE(d.valid());
  h5::Handle space(H5Dget_space(d.get()));
  std::vector<T> v(size_t(H5Sget_simple_extent_npoints(space.get())));
  if (!v.empty()) REQUIRE(H5Dread(d.get(), type, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()) >= 0);
  return v;
}

// Replaces dataset `dset` of open file `f` by n elements of memory type `mem_type` at `data`
// (1-D), stored with the old dataset's file type; no checksum64.
inline void rewrite_dataset_raw(hid_t f, const std::string& dset, hid_t mem_type, const void* data,
                                size_t n) {
  hid_t file_type = -1;
  {
    h5::Handle d(H5Dopen2(f, dset.c_str(), H5P_DEFAULT));
    REQUIRE(d.valid());
    file_type = H5Dget_type(d.get());
  }
  h5::Handle ft(file_type);
  REQUIRE(H5Ldelete(f, dset.c_str(), H5P_DEFAULT) >= 0);
  const hsize_t dims[1] = {hsize_t(n)};
  h5::Handle space(H5Screate_simple(1, dims, nullptr));
  h5::Handle d(H5Dcreate2(f, dset.c_str(), ft.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT,
                          H5P_DEFAULT));
  REQUIRE(d.valid());
  if (n) REQUIRE(H5Dwrite(d.get(), mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) >= 0);
}

// Replaces dataset `dset` of open file `f` by the n elements at `data` (memory type `mem_type`),
// stored as file type `stored` with shape `dims`, and gives it the checksum64 of its new bytes:
// what a script that retypes or reshapes a dataset consistently leaves.
inline void rewrite_dataset_as(hid_t f, const std::string& dset, hid_t stored, hid_t mem_type,
                               const void* data, size_t n, const std::vector<hsize_t>& dims) {
  REQUIRE(H5Ldelete(f, dset.c_str(), H5P_DEFAULT) >= 0);
  h5::Handle space(H5Screate_simple(int(dims.size()), dims.data(), nullptr));
  h5::Handle d(H5Dcreate2(f, dset.c_str(), stored, space.get(), H5P_DEFAULT, H5P_DEFAULT,
                          H5P_DEFAULT));
  REQUIRE(d.valid());
  if (n) REQUIRE(H5Dwrite(d.get(), mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) >= 0);
  std::vector<unsigned char> raw;
  REQUIRE(h5::read_stored_bytes(d.get(), raw));
  const int64_t sum = int64_t(checksum64(raw.data(), raw.size()));
  h5::Handle s1(H5Screate(H5S_SCALAR));
  h5::Handle a(H5Acreate2(d.get(), "checksum64", H5T_NATIVE_INT64, s1.get(), H5P_DEFAULT,
                          H5P_DEFAULT));
  REQUIRE(H5Awrite(a.get(), H5T_NATIVE_INT64, &sum) >= 0);
}

template <class T>
void rewrite_dataset(const std::string& file, const std::string& dset, hid_t mem_type,
                     const std::vector<T>& v) {
  h5::Handle f(H5Fopen(file.c_str(), H5F_ACC_RDWR, H5P_DEFAULT));
  REQUIRE(f.valid());
  rewrite_dataset_raw(f.get(), dset, mem_type, v.data(), v.size());
}

// Sets attribute `name` of object `obj` to a fixed-length string (replacing the old attribute).
inline void set_string_attr(const std::string& file, const std::string& obj,
                            const std::string& name, const std::string& value) {
  h5::Handle f(H5Fopen(file.c_str(), H5F_ACC_RDWR, H5P_DEFAULT));
  REQUIRE(f.valid());
  h5::Handle o(H5Oopen(f.get(), obj.c_str(), H5P_DEFAULT));
  REQUIRE(o.valid());
  if (H5Aexists(o.get(), name.c_str()) > 0) REQUIRE(H5Adelete(o.get(), name.c_str()) >= 0);
  h5::Handle t(H5Tcopy(H5T_C_S1));
  REQUIRE(H5Tset_size(t.get(), value.empty() ? 1 : value.size()) >= 0);
  REQUIRE(H5Tset_strpad(t.get(), H5T_STR_NULLPAD) >= 0);
  h5::Handle space(H5Screate(H5S_SCALAR));
  h5::Handle a(H5Acreate2(o.get(), name.c_str(), t.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT));
  REQUIRE(a.valid());
  std::string buf = value.empty() ? std::string(1, '\0') : value;
  REQUIRE(H5Awrite(a.get(), t.get(), buf.data()) >= 0);
}

// Sets the float64 attribute `name` of object `obj`.
inline void set_double_attr(const std::string& file, const std::string& obj,
                            const std::string& name, double value) {
  write_attr(file, obj, name, H5T_NATIVE_DOUBLE, &value);
}

// Recomputes the scene_id of a scene.h5 from its triangles, materials, lights and camera (and its
// textures, texels, materials' textures and UVs where it has textures; the metallic-roughness
// textures where some material is PF_MAT_PBR)
// (docs/FORMATS.md; Scene::compute_scene_id). Where a field cannot be read (an edit removed it),
// the id is left as it is.
inline void refresh_scene_id(const std::string& file) {
  Scene s;
  {
    h5::quiet_hdf5();
    h5::Handle f(H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT));
    if (!f.valid()) return;
    auto read = [&](const char* dset, hid_t type, auto& v) {
      h5::Handle d(H5Dopen2(f.get(), dset, H5P_DEFAULT));
      if (!d.valid()) return false;
      h5::Handle space(H5Dget_space(d.get()));
      const hssize_t n = H5Sget_simple_extent_npoints(space.get());
      if (n < 0) return false;
      v.resize(size_t(n));
      return n == 0 || H5Dread(d.get(), type, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()) >= 0;
    };
    std::vector<pf_camera> cam;
    if (!read("/geometry/triangles", h5_type_triangle().id(), s.triangles) ||
        !read("/materials/materials", h5_type_material().id(), s.materials) ||
        !read("/lights/lights", h5_type_light().id(), s.lights) ||
        !read("/camera", h5_type_camera().id(), cam) || cam.size() != 1)
      return;
    s.camera = cam[0];
    // Format version 3: the textures, where the file has them (compute_scene_id covers them then).
    std::vector<float> uv;
    if (H5Lexists(f.get(), "/textures", H5P_DEFAULT) > 0 &&
        read("/textures/textures", h5_type_texture().id(), s.textures)) {
      read("/textures/texels", H5T_NATIVE_FLOAT, s.texels);
      read("/materials/texture", H5T_NATIVE_INT32, s.material_texture);
      if (H5Lexists(f.get(), "/geometry/uvs", H5P_DEFAULT) > 0 &&
          read("/geometry/uvs", H5T_NATIVE_FLOAT, uv)) {
        s.uvs.resize(uv.size() / 6);
        if (!s.uvs.empty()) std::memcpy(s.uvs.data(), uv.data(), s.uvs.size() * sizeof(TriangleUV));
      }
    }
    // Format version 5: the metallic-roughness textures (compute_scene_id covers them where some
    // material is PF_MAT_PBR).
    if (H5Lexists(f.get(), "/materials/metallic_roughness_texture", H5P_DEFAULT) > 0)
      read("/materials/metallic_roughness_texture", H5T_NATIVE_INT32, s.material_mr_texture);
    // Format version 5: the alpha cut-outs, where the file has them.
    std::vector<float> cutoff, factor;
    std::vector<int32_t> texture;
    if (H5Lexists(f.get(), "/materials/alpha_cutoff", H5P_DEFAULT) > 0 &&
        read("/materials/alpha_cutoff", H5T_NATIVE_FLOAT, cutoff) &&
        read("/materials/alpha_factor", H5T_NATIVE_FLOAT, factor) &&
        read("/materials/alpha_texture", H5T_NATIVE_INT32, texture) &&
        factor.size() == cutoff.size() && texture.size() == cutoff.size())
      for (size_t i = 0; i < cutoff.size(); ++i)
        s.material_alpha.push_back(pf_alpha_material{cutoff[i], factor[i], texture[i], 0});
  }
  s.compute_scene_id();
  set_string_attr(file, "/", "scene_id", s.scene_id);
}

}  // namespace pf::test
