#!/usr/bin/env python3
"""Convert a baked photonflow scene.h5 into a Mitsuba 3 scene (XML + one OBJ per material).

Benchmark-only (issue 34 item 2): Mitsuba is a comparator, never a dependency of photonflow.
Converting from the baked file keeps the geometry identical to what photonflow renders.

  scene_to_mitsuba.py scene.h5 OUTDIR      -> OUTDIR/scene.xml, OUTDIR/mat<K>.obj

Mapping (docs/FORMATS.md):
  type 0 diffuse  -> twosided(diffuse reflectance=color)
  type 1 mirror   -> conductor material="none" specular_reflectance=color
  type 2 glass    -> dielectric int_ior=ior ext_ior=1 specular_transmittance=color
  type 3 emitter  -> area emitter radiance=emission on a diffuse(color) surface. photonflow emits
                     one-sided along the geometric normal cross(v1-v0, v2-v0); Mitsuba's area emitter
                     emits on the side of the face normal, which is the same cross product of the
                     vertex order, so triangles keep their winding (no flip).
  flat meshes (n0=n1=n2=geometric normal) -> face_normals=true; otherwise the file's vertex normals.
  camera -> perspective, fov_axis="y", lookat eye/look_at/up, box rfilter, hdrfilm rgb.
  integrator -> path, max_depth -1 (unlimited, like photonflow's eye and photon paths).
"""
import os
import sys

import h5py
import numpy as np


def fmt3(v):
    return ", ".join("%.9g" % x for x in v)


def convert(h5path, outdir, spp=16, max_depth=-1, sampler="independent"):
    os.makedirs(outdir, exist_ok=True)
    with h5py.File(h5path, "r") as f:
        tris = f["geometry/triangles"][:]
        mats = f["materials/materials"][:]
        cam = f["camera"][0]
    shapes = []
    for k, m in enumerate(mats):
        sel = tris[tris["material"] == k]
        if len(sel) == 0:
            continue
        v = np.stack([sel["v0"], sel["v1"], sel["v2"]], axis=1).astype(np.float64)  # T,3,3
        n = np.stack([sel["n0"], sel["n1"], sel["n2"]], axis=1).astype(np.float64)
        g = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
        g /= np.maximum(np.linalg.norm(g, axis=1, keepdims=True), 1e-30)
        flat = bool(np.all(np.abs(n - g[:, None, :]) < 1e-4))
        name = "mat%d.obj" % k
        with open(os.path.join(outdir, name), "w") as o:
            o.write("# photonflow material %d (type %d), %d triangles\n" % (k, m["type"], len(sel)))
            o.write("".join("v %.9g %.9g %.9g\n" % tuple(p) for p in v.reshape(-1, 3)))
            if flat:
                o.write("".join("f %d %d %d\n" % (3 * i + 1, 3 * i + 2, 3 * i + 3) for i in range(len(sel))))
            else:
                o.write("".join("vn %.9g %.9g %.9g\n" % tuple(p) for p in n.reshape(-1, 3)))
                o.write("".join("f %d//%d %d//%d %d//%d\n" % ((3 * i + 1,) * 2 + (3 * i + 2,) * 2 + (3 * i + 3,) * 2)
                                for i in range(len(sel))))
        t, c = int(m["type"]), m["color"]
        if t == 0:
            bsdf = '<bsdf type="twosided"><bsdf type="diffuse"><rgb name="reflectance" value="%s"/></bsdf></bsdf>' % fmt3(c)
        elif t == 1:
            bsdf = ('<bsdf type="conductor"><string name="material" value="none"/>'
                    '<rgb name="specular_reflectance" value="%s"/></bsdf>' % fmt3(c))
        elif t == 2:
            bsdf = ('<bsdf type="dielectric"><float name="int_ior" value="%.9g"/><float name="ext_ior" value="1"/>'
                    '<rgb name="specular_transmittance" value="%s"/></bsdf>' % (m["ior"], fmt3(c)))
        elif t == 3:
            bsdf = ('<bsdf type="diffuse"><rgb name="reflectance" value="%s"/></bsdf>'
                    '<emitter type="area"><rgb name="radiance" value="%s"/></emitter>' % (fmt3(c), fmt3(m["emission"])))
        else:
            raise SystemExit("material %d: unknown type %d" % (k, t))
        shapes.append('  <shape type="obj"><string name="filename" value="%s"/>'
                      '<boolean name="face_normals" value="%s"/>%s</shape>' % (name, "true" if flat else "false", bsdf))
    xml = """<scene version="3.0.0">
  <default name="spp" value="%d"/>
  <default name="seed" value="0"/>
  <integrator type="path"><integer name="max_depth" value="%d"/></integrator>
  <sensor type="perspective">
    <string name="fov_axis" value="y"/>
    <float name="fov" value="%.9g"/>
    <transform name="to_world"><lookat origin="%s" target="%s" up="%s"/></transform>
    <sampler type="%s"><integer name="sample_count" value="$spp"/><integer name="seed" value="$seed"/></sampler>
    <film type="hdrfilm"><integer name="width" value="%d"/><integer name="height" value="%d"/>
      <string name="pixel_format" value="rgb"/><rfilter type="box"/></film>
  </sensor>
%s
</scene>
""" % (spp, max_depth, cam["fov_y_deg"], fmt3(cam["eye"]), fmt3(cam["look_at"]), fmt3(cam["up"]), sampler,
       cam["width"], cam["height"], "\n".join(shapes))
    with open(os.path.join(outdir, "scene.xml"), "w") as o:
        o.write(xml)
    return os.path.join(outdir, "scene.xml")


if __name__ == "__main__":
    if len(sys.argv) < 3:
        raise SystemExit(__doc__)
    print(convert(sys.argv[1], sys.argv[2], sampler=(sys.argv[3] if len(sys.argv) > 3 else "independent")))
