// h5_types.h — the HDF5 compound types of the structs the files store (shared_types.h and
// texture_shared.h), by field name for h5dump and h5py, with the layouts of the older scene format
// versions. Every reader and writer of a file that holds such a struct uses them.
#pragma once

namespace pf {

// HDF5 compound types of the shared structs (named fields for h5dump/h5py).
namespace h5 { class Compound; }
const h5::Compound& h5_type_triangle();
const h5::Compound& h5_type_hh_triangle();
const h5::Compound& h5_type_material();
const h5::Compound& h5_type_material_v4();  // format versions 1-4: no metallic-roughness fields
const h5::Compound& h5_type_light();
const h5::Compound& h5_type_light_v4();  // format versions 1-4: no direction or cone
const h5::Compound& h5_type_camera();
const h5::Compound& h5_type_camera_pinhole();  // format versions 1-3: no lens fields
const h5::Compound& h5_type_kd_node();
const h5::Compound& h5_type_hitpoint();
const h5::Compound& h5_type_photon();
const h5::Compound& h5_type_texture();

}  // namespace pf
