#!/usr/bin/env python3
"""Convert a baked photonflow scene.h5 into a Mitsuba 3 scene (XML + one OBJ per material).

Benchmark-only (issue 34 item 2): Mitsuba is a comparator, never a dependency of photonflow.
Converting from the baked file keeps the geometry identical to what photonflow renders.

  scene_to_mitsuba.py scene.h5 OUTDIR      -> OUTDIR/scene.xml, OUTDIR/mat<K>.obj

The XML takes three parameters (mitsuba.load_file(path, spp=..., seed=..., sampler=...)):
spp (default 16), seed (0) and sampler (independent, Mitsuba's default; multijitter or ldsampler
converge faster at light outlines and are what the references use, bench/mitsuba/README.md).

Mapping (docs/FORMATS.md, docs/SCENES.md; validated against photonflow's own path tracer by
bench/mitsuba/check_converter.py):
  type 0 diffuse  -> twosided(diffuse reflectance=color): photonflow's Lambertian reflects on the
                     side the ray arrives from.
  type 1 mirror   -> twosided(conductor material="none" specular_reflectance=color): reflectance
                     `color` at every angle, on both sides (specular_bounce, surface.h).
  type 2 glass    -> dielectric int_ior=ior ext_ior=1 specular_transmittance=color (exact Fresnel
                     both; the tint on transmission only, as specular_bounce).
  type 3 emitter  -> area emitter radiance=emission on a twosided(diffuse(color)) surface.
                     photonflow emits one-sided along the geometric normal cross(v1-v0, v2-v0);
                     Mitsuba's area emitter emits on the side of the face normal, which is the same
                     cross product of the vertex order, so triangles keep their winding (no flip).
  point lights (/lights/lights type 1) -> point emitter, intensity = the stored intensity (W/sr).
  flat meshes (n0=n1=n2=geometric normal) -> face_normals=true; otherwise the file's vertex normals.
  camera -> perspective (thinlens with aperture_radius/focus_distance when aperture > 0),
            fov_axis="y", lookat eye/look_at/up, box rfilter (a pixel = the mean radiance over it,
            as photonflow's pixel), hdrfilm rgb.
  integrator -> path, max_depth -1 (unlimited; photonflow's paths are cut at 16 bounces (render)
                or 64 (pathtrace), which loses < 0.1 % here).
Refused (exit 2, one line): textured materials (not converted: the image would silently differ).
"""
import argparse
import os
import sys

import h5py
import numpy as np


def fmt3(v):
    return ", ".join("%.9g" % x for x in v)


def refuse(path, what):
    sys.stderr.write("scene_to_mitsuba: %s: %s\n" % (path, what))
    raise SystemExit(2)


def convert(h5path, outdir, max_depth=-1):
    with h5py.File(h5path, "r") as f:
        if f.attrs.get("format", b"") not in (b"photonflow.scene", "photonflow.scene"):
            refuse(h5path, "not a photonflow scene (format attribute); bake it with scene-bake first")
        tris = f["geometry/triangles"][:]
        mats = f["materials/materials"][:]
        cam = f["camera"][0]
        lights = f["lights/lights"][:]
        tex = f["materials/texture"][:] if "materials/texture" in f else np.full(len(mats), -1)
    if np.any(tex >= 0):
        refuse(h5path, "materials %s have textures, which this converter does not carry over; "
               "use an untextured scene" % list(np.nonzero(tex >= 0)[0]))
    os.makedirs(outdir, exist_ok=True)
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
        diffuse = '<bsdf type="twosided"><bsdf type="diffuse"><rgb name="reflectance" value="%s"/></bsdf></bsdf>'
        if t == 0:
            bsdf = diffuse % fmt3(c)
        elif t == 1:
            bsdf = ('<bsdf type="twosided"><bsdf type="conductor"><string name="material" value="none"/>'
                    '<rgb name="specular_reflectance" value="%s"/></bsdf></bsdf>' % fmt3(c))
        elif t == 2:
            bsdf = ('<bsdf type="dielectric"><float name="int_ior" value="%.9g"/><float name="ext_ior" value="1"/>'
                    '<rgb name="specular_transmittance" value="%s"/></bsdf>' % (m["ior"], fmt3(c)))
        elif t == 3:
            bsdf = (diffuse % fmt3(c)) + ('<emitter type="area"><rgb name="radiance" value="%s"/></emitter>'
                                          % fmt3(m["emission"]))
        else:
            refuse(h5path, "material %d has unknown type %d" % (k, t))
        shapes.append('  <shape type="obj" id="mat%d"><string name="filename" value="%s"/>'
                      '<boolean name="face_normals" value="%s"/>%s</shape>' % (k, name, "true" if flat else "false", bsdf))
    for L in lights[lights["type"] == 1]:
        shapes.append('  <emitter type="point"><point name="position" value="%s"/>'
                      '<rgb name="intensity" value="%s"/></emitter>' % (fmt3(L["position"]), fmt3(L["radiance"])))
    lens = ""
    sensor = "perspective"
    if cam["aperture"] > 0:
        sensor = "thinlens"
        lens = ('<float name="aperture_radius" value="%.9g"/><float name="focus_distance" value="%.9g"/>'
                % (cam["aperture"], cam["focus_distance"]))
    xml = """<scene version="3.0.0">
  <default name="spp" value="16"/>
  <default name="seed" value="0"/>
  <default name="sampler" value="independent"/>
  <integrator type="path"><integer name="max_depth" value="%d"/></integrator>
  <sensor type="%s">
    <string name="fov_axis" value="y"/>
    <float name="fov" value="%.9g"/>%s
    <transform name="to_world"><lookat origin="%s" target="%s" up="%s"/></transform>
    <sampler type="$sampler"><integer name="sample_count" value="$spp"/><integer name="seed" value="$seed"/></sampler>
    <film type="hdrfilm"><integer name="width" value="%d"/><integer name="height" value="%d"/>
      <string name="pixel_format" value="rgb"/><rfilter type="box"/></film>
  </sensor>
%s
</scene>
""" % (max_depth, sensor, cam["fov_y_deg"], lens, fmt3(cam["eye"]), fmt3(cam["look_at"]), fmt3(cam["up"]),
       cam["width"], cam["height"], "\n".join(shapes))
    with open(os.path.join(outdir, "scene.xml"), "w") as o:
        o.write(xml)
    return os.path.join(outdir, "scene.xml")


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene", help="baked scene.h5")
    ap.add_argument("outdir")
    ap.add_argument("--max-depth", type=int, default=-1, help="Mitsuba path max_depth (-1 = unlimited)")
    a = ap.parse_args()
    print(convert(a.scene, a.outdir, a.max_depth))
