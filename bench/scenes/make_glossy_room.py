#!/usr/bin/env python3
"""make_glossy_room.py: writes bench/scenes/glossy-room.gltf and glossy-room.bin, the bench scene
for glossy materials (Python 3 standard library only; the mesh and glTF helpers are those of
data/make_showcase.py).

    /usr/bin/python3 bench/scenes/make_glossy_room.py [--out DIR]   (default: this script's folder)

The scene (glTF 2.0, metres, y up, +z towards the camera), a Cornell-style room open at the front:

  * walls x in [-1, 1], y in [0, 2], z in [-1, 1]: red at x = -1, green at x = +1, white floor,
    ceiling and back wall (metallicFactor 0, roughness 1: photonflow's Lambertian, scene-bake's
    rule a), no front wall;
  * a white metal ball: metallic 1, base colour 1, roughness 0.3 (r = 0.38);
  * a rough-glass ball: KHR_materials_transmission 1, KHR_materials_ior 1.5, roughness 0.2, base
    colour 1 (r = 0.38);
  * one area lamp, a 0.5 m square just below the ceiling facing down (emissive, one-sided);
  * a perspective camera outside the open front (aspectRatio 1: bake at 512 x 512).

The balls are UV spheres of 64 x 32 segments with smooth vertex normals (the sphere's normal at
each vertex). Bake and render:

    build/bin/scene-bake bench/scenes/glossy-room.gltf -o glossy-room.h5 --width 512 --height 512
    build/bin/render --scene glossy-room.h5 -o glossy-room.exr
"""
import json
import math
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "data"))
from make_showcase import (GltfWriter, look_rotation, num, output_folder, pbr,  # noqa: E402
                           quad, sub, uv_sphere, write_files, WHITE, RED, GREEN)

X, Y, Z0, Z1 = 1.0, 2.0, -1.0, 1.0
METAL_CENTER, GLASS_CENTER, BALL_R = [-0.45, 0.38, -0.3], [0.45, 0.38, 0.25], 0.38
LAMP_HALF, LAMP_Y = 0.25, 1.99
LAMP_EMISSION, LAMP_STRENGTH = [1.0, 0.8, 0.55], 15.0
EYE, TARGET, YFOV_DEG = [0.0, 1.0, 3.9], [0.0, 1.0, 0.0], 38.0


def room():
    uv = [[0, 1], [1, 1], [1, 0], [0, 0]]
    floor = quad([[-X, 0, Z1], [X, 0, Z1], [X, 0, Z0], [-X, 0, Z0]], [0, 1, 0], uv)
    ceiling = quad([[-X, Y, Z0], [X, Y, Z0], [X, Y, Z1], [-X, Y, Z1]], [0, -1, 0], uv)
    back = quad([[-X, 0, Z0], [X, 0, Z0], [X, Y, Z0], [-X, Y, Z0]], [0, 0, 1], uv)
    left = quad([[-X, 0, Z1], [-X, 0, Z0], [-X, Y, Z0], [-X, Y, Z1]], [1, 0, 0], uv)
    right = quad([[X, 0, Z0], [X, 0, Z1], [X, Y, Z1], [X, Y, Z0]], [-1, 0, 0], uv)
    return [("floor", floor, "white"), ("ceiling", ceiling, "white"), ("back", back, "white"),
            ("left", left, "red"), ("right", right, "green")]


def lamp():
    h, y = LAMP_HALF, LAMP_Y
    return quad([[-h, y, -h], [h, y, -h], [h, y, h], [-h, y, h]], [0, -1, 0],
                [[0, 1], [1, 1], [1, 0], [0, 0]])


def build():
    w = GltfWriter()
    materials = [
        pbr("white", WHITE, 0.0, 1.0),
        pbr("red", RED, 0.0, 1.0),
        pbr("green", GREEN, 0.0, 1.0),
        pbr("white metal", [1, 1, 1], 1.0, 0.3),
        pbr("rough glass", [1, 1, 1], 0.0, 0.2,
            extensions={"KHR_materials_transmission": {"transmissionFactor": 1.0},
                        "KHR_materials_ior": {"ior": 1.5}}),
        pbr("lamp", [0.78, 0.78, 0.78], 0.0, 1.0, emissiveFactor=LAMP_EMISSION,
            extensions={"KHR_materials_emissive_strength": {"emissiveStrength": LAMP_STRENGTH}}),
    ]
    MAT = {m["name"]: i for i, m in enumerate(materials)}
    meshes, nodes = [], []
    prims = []
    for _, mesh, mat in room():
        attrs, idx = w.primitive_attributes(mesh)
        prims.append({"attributes": attrs, "indices": idx, "material": MAT[mat]})
    meshes.append({"name": "room", "primitives": prims})
    nodes.append({"name": "room", "mesh": 0})
    attrs, idx = w.primitive_attributes(lamp())
    meshes.append({"name": "lamp", "primitives": [{"attributes": attrs, "indices": idx, "material": MAT["lamp"]}]})
    nodes.append({"name": "lamp", "mesh": 1})
    attrs, idx = w.primitive_attributes(uv_sphere(64, 32))
    for name, mat, c in (("metal ball", "white metal", METAL_CENTER), ("glass ball", "rough glass", GLASS_CENTER)):
        meshes.append({"name": name, "primitives": [{"attributes": attrs, "indices": idx, "material": MAT[mat]}]})
        nodes.append({"name": name, "mesh": len(meshes) - 1, "translation": [num(v) for v in c],
                      "scale": [BALL_R] * 3})
    nodes.append({"name": "camera", "camera": 0, "translation": EYE,
                  "rotation": look_rotation(sub(TARGET, EYE), [0, 1, 0])})
    doc = {
        "asset": {"version": "2.0", "generator": "photonflow bench/scenes/make_glossy_room.py"},
        "extensionsUsed": ["KHR_materials_emissive_strength", "KHR_materials_ior", "KHR_materials_transmission"],
        "scene": 0,
        "scenes": [{"name": "glossy-room", "nodes": list(range(len(nodes)))}],
        "nodes": nodes,
        "cameras": [{"name": "camera", "type": "perspective", "perspective": {
            "aspectRatio": 1.0, "yfov": num(math.radians(YFOV_DEG)), "znear": 0.05, "zfar": 20.0}}],
        "meshes": meshes,
        "materials": materials,
        "buffers": [{"uri": "glossy-room.bin", "byteLength": len(w.bin)}],
        "bufferViews": w.views,
        "accessors": w.accessors,
    }
    return doc, bytes(w.bin)


def main():
    out = output_folder(__doc__, __file__)
    doc, binary = build()
    write_files(out, {"glossy-room.gltf": (json.dumps(doc, indent=1) + "\n").encode(),
                      "glossy-room.bin": binary})


if __name__ == "__main__":
    main()
