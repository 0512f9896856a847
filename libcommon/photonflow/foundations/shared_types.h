/*
 * shared_types.h — the structs that the C++ host and the OpenCL C kernels share.
 *
 * This one header is included by both sides (LuxCore's habit), so a buffer written by the host is
 * read by a kernel with the same layout. Rules that keep the layout identical in C++ and OpenCL C:
 *   - only 4-byte scalars and arrays of them (no float3/float4: their alignment differs),
 *   - no pointers, no bool, no enums as members (enums become pf_int),
 *   - every struct's size is asserted on the host side (bottom of this file).
 * The same structs are the HDF5 compound types of the intermediates (docs/FORMATS.md), so a
 * dataset read from a file can be uploaded to a device unchanged.
 */
#ifndef PHOTONFLOW_SHARED_TYPES_H
#define PHOTONFLOW_SHARED_TYPES_H

#ifdef __OPENCL_VERSION__
typedef int pf_int;
typedef uint pf_uint;
typedef float pf_float;
#else
#include <cstdint>
typedef int32_t pf_int;
typedef uint32_t pf_uint;
typedef float pf_float;
#endif

/* Material types. Materials are kept to what the scenes need (design card). */
#define PF_MAT_DIFFUSE 0 /* Lambertian, color = albedo */
#define PF_MAT_MIRROR 1  /* perfect specular reflection, color = reflectance */
#define PF_MAT_GLASS 2   /* smooth dielectric with Fresnel, color = transmittance tint, ior */
#define PF_MAT_EMITTER 3 /* one-sided area emitter along the geometric normal, emission = radiance;
                            color = albedo of the (diffuse) surface under the emitter */
#define PF_MAT_PBR 4     /* glTF 2.0 metallic-roughness BSDF (material/bsdf_shared.h): color =
                            baseColorFactor (times the base-colour texture), metallic, roughness
                            (times the metallic-roughness texture's B and G), transmission and
                            ior (KHR_materials_transmission / _ior); non-delta, so photons are
                            stored on it and visible points sit on it (scene format version 5) */

/* A material. Units: color dimensionless in [0,1]; emission radiance W/(sr m^2) per channel.
 * metallic, roughness and transmission are read only for PF_MAT_PBR (0 for every other type);
 * scene format versions 1-4 have no such fields and read them as 0. */
typedef struct {
  pf_int type;            /* PF_MAT_* */
  pf_float ior;           /* index of refraction (glass and PBR; 1 otherwise) */
  pf_float color[3];      /* albedo / reflectance / transmittance / PBR base colour */
  pf_float emission[3];   /* radiance of an emitter, 0 otherwise */
  pf_float metallic;      /* PF_MAT_PBR: glTF metallicFactor, [0,1] */
  pf_float roughness;     /* PF_MAT_PBR: glTF roughnessFactor (perceptual; alpha = roughness^2) */
  pf_float transmission;  /* PF_MAT_PBR: KHR_materials_transmission factor, [0,1] */
} pf_material;

/* A scene triangle in world space. Winding v0→v1→v2 counter-clockwise seen from the front: the
 * geometric normal is normalize((v1-v0)×(v2-v0)). Shading normals n0..n2 are the file's vertex
 * normals, or the geometric normal when the file has none. */
typedef struct {
  pf_float v0[3];
  pf_float v1[3];
  pf_float v2[3];
  pf_float n0[3];
  pf_float n1[3];
  pf_float n2[3];
  pf_int mesh;     /* index into the scene's mesh table */
  pf_int material; /* index into the scene's material table */
} pf_triangle;

/* Precomputed planes of the Havel–Herout ray–triangle test (thesis eq. 4.3–4.7):
 *   n  = (N, d)   with N = (B−A)×(C−A), d = −N·A              (the triangle's plane)
 *   n1 = (N1, d1) with N1 = ((C−A)×N)/|N|², d1 = −N1·A         (u = 1 at B, 0 on edge AC)
 *   n2 = (N2, d2) with N2 = (N×(B−A))/|N|², d2 = −N2·A         (v = 1 at C, 0 on edge AB)
 * A hit point P has barycentrics u = N1·P + d1, v = N2·P + d2; P = (1−u−v)A + uB + vC. */
typedef struct {
  pf_float n[4];
  pf_float n1[4];
  pf_float n2[4];
} pf_hh_triangle;

/* Node of the SAH kd-tree with ropes (Popov et al. 2007), stored flat.
 * axis 0/1/2: inner node split at `split` on that axis, children left (< split) and right.
 * axis PF_KD_LEAF: leaf holding leaf_tris[first .. first+count).
 * ropes[f], f = 2·axis + (0 for the low face, 1 for the high face): the node on the other side of
 * that face of the node's box (the deepest node whose box covers the whole face), −1 if the face
 * lies on the scene bounds. Ropes are set on every node; stackless traversal only needs leaves'. */
#define PF_KD_LEAF 3
typedef struct {
  pf_float lo[3];
  pf_float hi[3];
  pf_int axis;
  pf_float split;
  pf_int left;
  pf_int right;
  pf_int first;
  pf_int count;
  pf_int ropes[6];
} pf_kd_node;

/* Light types. */
#define PF_LIGHT_AREA 0        /* one emissive triangle */
#define PF_LIGHT_POINT 1       /* isotropic point light */
#define PF_LIGHT_SPOT 2        /* KHR_lights_punctual spot (format version 5; light_shared.h) */
#define PF_LIGHT_DIRECTIONAL 3 /* KHR_lights_punctual directional (format version 5) */
#define PF_LIGHT_ENVIRONMENT 4 /* the environment map (format version 6; environment_shared.h) */

/* A light. Area light: triangle index, its area (m^2), radiance (W/(sr m^2)); power = π·area·L.
 * Point light: position and intensity (W/sr); power = 4π·I.
 * Spot light (version 5): position, intensity I (W/sr) on its axis `direction` (unit, the way the
 * light travels), the cosines of the inner and outer cone half-angles, 1 ≥ cos_inner > cos_outer
 * ≥ 0; intensity I·falloff(cos θ) (light_shared.h, the KHR_lights_punctual attenuation);
 * power = 2π·I·∫ falloff d(cos θ) (pf_spot_cone_integral).
 * Directional light (version 5): irradiance E (W/m^2, on a plane facing it) travelling along
 * `direction` (unit); photons leave a disc of area `area` = π·R² (R the radius of the scene's
 * bounding sphere) centred at `position`, outside the bounds against the light; power = E·π·R².
 * Environment (version 6, at most one, the last light): the map around the scene (scene.h5
 * /environment; its radiance is the map's, so `radiance` is 0 here), `position` the centre c and
 * `area` = π·R² the photons' disc of the scene's bounding sphere; power = π·R²·∫ L dω
 * (geometry/environment.h environment_luminance_integral).
 * Area, point and environment lights have direction, cos_inner and cos_outer 0.
 * `power` is the luminance-weighted scalar used for sampling lights in proportion to power (rgb
 * weights 0.2126, 0.7152, 0.0722). The first five fields are the whole light of format versions
 * 1-4 (io/h5_types.h's h5_type_light_v4). */
typedef struct {
  pf_int type;
  pf_int triangle;
  pf_float area;
  pf_float power;
  pf_float position[3];
  pf_float radiance[3]; /* area: radiance; point, spot: intensity; directional: irradiance */
  pf_float direction[3];
  pf_float cos_inner;
  pf_float cos_outer;
} pf_light;

/* Camera: a pinhole, or a thin lens when aperture > 0 (depth of field; material/lens_shared.h).
 * Right-handed world; the image's +x is to the right, +y is down (row 0 at top). */
typedef struct {
  pf_float eye[3];
  pf_float look_at[3];
  pf_float up[3];
  pf_float fov_y_deg;      /* vertical field of view, degrees */
  pf_int width;            /* pixels */
  pf_int height;           /* pixels */
  pf_float aperture;       /* lens radius, world units; 0 = pinhole (scene format version 4) */
  pf_float focus_distance; /* distance of the sharp plane along the view axis, world units (> 0
                              when aperture > 0; 0 with a pinhole) */
} pf_camera;


/* A hitpoint of progressive photon mapping (thesis ch. 3.5, 7.1; Hachisuka et al. 2008): the first
 * diffuse surface seen through a pixel (after specular bounces). Units: world units for position and
 * radius; weight is the RGB throughput of the specular chain times the pixel filter weight;
 * n_photons is the accumulated photon count N (fractional after eq. 3.14); flux is τ (eq. 3.18),
 * in units of the photons' flux (watts) times BRDF (1/sr). */
typedef struct {
  pf_float position[3];
  pf_float normal[3]; /* shading normal, facing the incoming ray */
  pf_float dir[3];    /* direction of the ray that arrived (pointing into the surface), unit */
  pf_float weight[3];
  pf_float radius;    /* R (eq. 3.16) */
  pf_float n_photons; /* N (eq. 3.14) */
  pf_float flux[3];   /* τ (eq. 3.18) */
  pf_int pixel_x;
  pf_int pixel_y;
  pf_int mesh;
  pf_int material;
} pf_hitpoint;

/* Photon flags. */
#define PF_PHOTON_CAUSTIC 1 /* the path was L S+ D: only specular bounces before this hit */
#define PF_PHOTON_DIRECT 2  /* the path was L D: first hit straight from the light */

/* A photon stored at a diffuse hit. dir points along travel (into the surface); flux in watts. */
typedef struct {
  pf_float position[3];
  pf_float dir[3];
  pf_float flux[3];
  pf_int mesh;
  pf_int pass;
  pf_int flags; /* PF_PHOTON_* */
} pf_photon;

/* The sorted photons as the hashed-grid gather reads them (hash_grid.h), in two arrays, so that
 * testing a candidate reads 16 bytes and only an accepted photon's payload is read:
 *   pf_photon_keys4   photons 4b .. 4b + 3 in one 64-byte block, each field as 4 lanes (the gather
 *                     tests four photons per float4 / int4 with aligned loads, and a photon's
 *                     key fields share one cache line); key = pf_photon_hash_key (grid_shared.h);
 *                     lanes past the last photon are never read as photons;
 *   pf_photon_payload direction and flux, one per photon. */
typedef struct {
  pf_float x[4], y[4], z[4];
  pf_int key[4];
} pf_photon_keys4;

typedef struct {
  pf_float dir[3];
  pf_float flux[3];
} pf_photon_payload;

/* A hitpoint as the hashed-grid gather keeps it on the device (cl_gather.h), split by access: the
 * fields a pass only reads, and the PPM state (R, N, τ: eq. 3.14–3.18) it reads and rewrites —
 * the same values as pf_hitpoint's. A pass moves 32 + 2·20 bytes per hitpoint instead of 2·84
 * (the gather's hitpoint stream is memory-bound on a CPU device: docs/BENCHMARKS.md "How
 * hash-grid's pass is built"). */
typedef struct {
  pf_float position[3];
  pf_float normal[3];
  pf_int mesh;
  pf_int material;
} pf_gather_site;

typedef struct {
  pf_float radius;    /* R (eq. 3.16) */
  pf_float n_photons; /* N (eq. 3.14) */
  pf_float flux[3];   /* τ (eq. 3.18) */
} pf_ppm_state;

/* Grid header of one mesh's photons (thesis ch. 7.3, eq. 7.1; photon_grid.h, grid_shared.h).
 * Bin of a point p: per axis c = clamp(floor((p − lo)/bin_size), 0, n−1) (eq. 7.1), linear
 * offset cx + cy·nx + cz·nx·ny. A mesh without photons has nx = ny = nz = 0 and one cell_start
 * entry. */
typedef struct {
  pf_float lo[3];      /* minimum corner of the mesh's photons */
  pf_float bin_size;   /* d = max(longest extent / max_bins, default_radius) */
  pf_int nx, ny, nz;   /* bins per axis */
  pf_int first_bin;    /* index of the mesh's first cell_start entry */
  pf_int first_photon; /* index of the mesh's first photon in the sorted photon array */
  pf_int photon_count; /* photons of this mesh */
} pf_mesh_grid;

/* One work-group cluster of hitpoints (clusters.h): every member lies on `mesh`, and every
 * member's gather sphere lies inside the sphere (centre, radius). */
typedef struct {
  pf_float centre[3];  /* world units */
  pf_float radius;     /* shared gather radius R (clusters.h), world units */
  pf_int mesh;         /* mesh id of every member */
  pf_int first;        /* index of the cluster's first entry in the order array */
  pf_int count;        /* member hitpoints (> 0) */
  pf_int padded_count; /* count rounded up to a multiple of the work-group size */
} pf_cluster;

#ifndef __OPENCL_VERSION__
static_assert(sizeof(pf_material) == 44, "pf_material layout");
static_assert(sizeof(pf_triangle) == 80, "pf_triangle layout");
static_assert(sizeof(pf_hh_triangle) == 48, "pf_hh_triangle layout");
static_assert(sizeof(pf_kd_node) == 72, "pf_kd_node layout");
static_assert(sizeof(pf_light) == 60, "pf_light layout");
static_assert(sizeof(pf_camera) == 56, "pf_camera layout");
static_assert(sizeof(pf_hitpoint) == 84, "pf_hitpoint layout");
static_assert(sizeof(pf_photon) == 48, "pf_photon layout");
static_assert(sizeof(pf_photon_keys4) == 64, "pf_photon_keys4 layout");
static_assert(sizeof(pf_photon_payload) == 24, "pf_photon_payload layout");
static_assert(sizeof(pf_gather_site) == 32, "pf_gather_site layout");
static_assert(sizeof(pf_ppm_state) == 20, "pf_ppm_state layout");
static_assert(sizeof(pf_mesh_grid) == 40, "pf_mesh_grid layout");
static_assert(sizeof(pf_cluster) == 32, "pf_cluster layout");
#endif

#endif /* PHOTONFLOW_SHARED_TYPES_H */
