#!/usr/bin/env python3
"""make_pbr_gltf.py — writes tests/data/pbr.gltf, a small glTF 2.0 scene of metallic-roughness
materials (issue 32 item 2): a diffuse floor under an emitting ceiling quad, a rough gold quad, a
rough-glass quad (KHR_materials_transmission + KHR_materials_ior) and a quad with a base-colour
and a metallic-roughness texture (the same 4x4 PNG, made here with zlib: B = metallic,
G = roughness), seen by a camera. Buffers and the image are data URIs (no binary files).
Run from the repository root: python3 tests/data/make_pbr_gltf.py
"""
import base64
import json
import os
import struct
import zlib


def png_rgb(w, h, pixel):
    """8-bit RGB PNG of w x h pixels; pixel(x, y) -> (r, g, b), row 0 on top."""
    raw = b"".join(b"\x00" + bytes(c for x in range(w) for c in pixel(x, y)) for y in range(h))

    def chunk(tag, data):
        return (struct.pack(">I", len(data)) + tag + data +
                struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF))

    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)) +
            chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))


# Quads as two triangles (corners a, b, c, d counter-clockwise seen from the front).
QUADS = [  # name, material, corners
    ("floor", 0, [(-2, 0, 2), (2, 0, 2), (2, 0, -2), (-2, 0, -2)]),
    ("light", 1, [(-0.5, 3, -0.5), (0.5, 3, -0.5), (0.5, 3, 0.5), (-0.5, 3, 0.5)]),
    ("gold", 2, [(-1.8, 0.2, -1), (-0.7, 0.2, -1), (-0.7, 1.3, -1), (-1.8, 1.3, -1)]),
    ("rough_glass", 3, [(-0.55, 0.2, -0.5), (0.55, 0.2, -0.5), (0.55, 1.3, -0.5), (-0.55, 1.3, -0.5)]),
    ("textured", 4, [(0.7, 0.2, -1), (1.8, 0.2, -1), (1.8, 1.3, -1), (0.7, 1.3, -1)]),
]
UV = [(0, 1), (1, 1), (1, 0), (0, 0)]  # glTF: (0, 0) the image's top-left

MATERIALS = [
    {"name": "floor", "pbrMetallicRoughness": {"baseColorFactor": [0.6, 0.6, 0.6, 1],
                                               "metallicFactor": 0}},
    {"name": "light", "emissiveFactor": [1, 1, 1],
     "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1], "metallicFactor": 0}},
    {"name": "gold", "pbrMetallicRoughness": {"baseColorFactor": [1.0, 0.78, 0.34, 1],
                                              "metallicFactor": 1, "roughnessFactor": 0.3}},
    {"name": "rough_glass",
     "pbrMetallicRoughness": {"baseColorFactor": [0.95, 1, 0.95, 1], "metallicFactor": 0,
                              "roughnessFactor": 0.2},
     "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1},
                    "KHR_materials_ior": {"ior": 1.5}}},
    {"name": "textured",
     "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "metallicFactor": 1,
                              "roughnessFactor": 1, "metallicRoughnessTexture": {"index": 0}}},
]


def main():
    out = os.path.join(os.path.dirname(os.path.abspath(__file__)), "pbr.gltf")
    # A 4x4 checker: bright squares are rough dielectric (B 0, G 230), dark ones smooth-ish metal
    # (B 255, G 60); the same bytes are the base colour.
    image = png_rgb(4, 4, lambda x, y: (200, 230, 0) if (x + y) % 2 == 0 else (90, 60, 255))
    pos, uv, idx = b"", b"", b""
    for k, (_, _, corners) in enumerate(QUADS):
        for c in corners:
            pos += struct.pack("<3f", *c)
        for t in UV:
            uv += struct.pack("<2f", *t)
    for i in (0, 1, 2, 0, 2, 3):
        idx += struct.pack("<H", i)
    buf = pos + uv + idx
    n = len(QUADS)
    views = [{"buffer": 0, "byteOffset": 48 * k, "byteLength": 48} for k in range(n)]
    views += [{"buffer": 0, "byteOffset": len(pos) + 32 * k, "byteLength": 32} for k in range(n)]
    views.append({"buffer": 0, "byteOffset": len(pos) + len(uv), "byteLength": len(idx)})
    accessors = []
    for k, (_, _, corners) in enumerate(QUADS):
        accessors.append({"bufferView": k, "componentType": 5126, "count": 4, "type": "VEC3",
                          "min": [min(c[a] for c in corners) for a in range(3)],
                          "max": [max(c[a] for c in corners) for a in range(3)]})
    for k in range(n):
        accessors.append({"bufferView": n + k, "componentType": 5126, "count": 4, "type": "VEC2"})
    accessors.append({"bufferView": 2 * n, "componentType": 5123, "count": 6, "type": "SCALAR"})
    meshes = [{"name": name, "primitives": [{"attributes": {"POSITION": k, "TEXCOORD_0": n + k},
                                             "indices": 2 * n, "material": mat}]}
              for k, (name, mat, _) in enumerate(QUADS)]
    nodes = [{"name": name, "mesh": k} for k, (name, _, _) in enumerate(QUADS)]
    nodes.append({"name": "camera", "camera": 0, "translation": [0, 1.5, 4.5]})
    g = {
        "asset": {"version": "2.0", "generator": "tests/data/make_pbr_gltf.py"},
        "extensionsUsed": ["KHR_materials_transmission", "KHR_materials_ior"],
        "scene": 0,
        "scenes": [{"nodes": list(range(len(nodes)))}],
        "nodes": nodes,
        "cameras": [{"type": "perspective",
                     "perspective": {"yfov": 0.7, "aspectRatio": 1.0, "znear": 0.01, "zfar": 100}}],
        "meshes": meshes,
        "materials": MATERIALS,
        "textures": [{"source": 0}],
        "images": [{"uri": "data:image/png;base64," + base64.b64encode(image).decode()}],
        "buffers": [{"byteLength": len(buf),
                     "uri": "data:application/octet-stream;base64," + base64.b64encode(buf).decode()}],
        "bufferViews": views,
        "accessors": accessors,
    }
    with open(out, "w") as f:
        json.dump(g, f, indent=1)
        f.write("\n")


if __name__ == "__main__":
    main()
