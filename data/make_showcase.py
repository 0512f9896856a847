#!/usr/bin/env python3
"""make_showcase.py: writes data/showcase*.gltf, showcase.bin, the showcase PNG textures and the
scenes' bake options (issue 32 item 8). Python 3 standard library only (PNGs by zlib + struct).

    /usr/bin/python3 data/make_showcase.py [--out DIR]      (default: the folder of this script)

The generated files are committed; tests/test_showcase_scene.cpp runs this script into a temporary
folder and checks that they are what it writes (docs/SCENES.md, "showcase.gltf").

The scene, written to the glTF 2.0 specification (units: metres, y up, +z towards the camera):

  * a closed room x in [-1, 1], y in [0, 1.6], z in [-1.2, 2.4] (Cornell colours: red wall at
    x = -1, green wall at x = +1, the others white), so that no light leaves it;
  * a tiled floor: baseColorTexture showcase_tiles.png, REPEAT sampler, one texture per 0.5 m;
  * a glossy metal sphere (metallic 1, roughness 0.3, gold base colour), r = 0.3;
  * a rough-glass sphere (KHR_materials_transmission 1, KHR_materials_ior 1.5, roughness 0.2),
    r = 0.28;
  * a rounded box with a metallicRoughnessTexture (showcase_mr.png: metallic stripes in u, four
    roughness bands in v);
  * a lattice fence panel in front of the back wall (showcase_fence.png, alphaMode MASK,
    alphaCutoff 0.5, doubleSided) that casts a patterned shadow;
  * a ceiling area light (emissive material, KHR_materials_emissive_strength 15) and a small spot
    light (KHR_lights_punctual) aimed at the two spheres: glossy caustics on the floor;
  * a perspective camera (aspectRatio 1: scene-bake's 512 x 512).

showcase-caustics.gltf is the same room, meshes and camera (the same showcase.bin) with the ceiling
light dimmed to emissive strength 1 and the spot light 3x stronger: the glossy caustics of the
spheres carry much of the light (bench/showcase.sh). scene-bake needs a light it imports today,
hence the dim ceiling light rather than none.

Depth of field is not in glTF (cameras have no aperture): showcase.bake-options holds the
scene-bake options (--aperture, --focus-distance on the metal sphere) that pipelines/scene.mk
passes to scene-bake for `make render SCENE=showcase`.

Determinism: every vertex value is rounded to a multiple of 2^-20 (exact in float32 for |x| < 8)
and every JSON number to 9 digits, so the output does not depend on the last bit of the
platform's sin/cos; PNG pixel values use integer arithmetic only. The PNGs' compressed bytes
depend on the zlib build (zlib-ng differs), so the test compares their decoded pixels.
"""
import argparse
import json
import math
import os
import struct
import zlib

# ---------------------------------------------------------------------------------------------
# Small vector helpers.


def sub(a, b):
    return [a[0] - b[0], a[1] - b[1], a[2] - b[2]]


def add(a, b):
    return [a[0] + b[0], a[1] + b[1], a[2] + b[2]]


def mul(a, s):
    return [a[0] * s, a[1] * s, a[2] * s]


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def normalize(a):
    n = math.sqrt(dot(a, a))
    return [a[0] / n, a[1] / n, a[2] / n]


Q = float(1 << 20)


def quant(x):
    """Round to a multiple of 2^-20: exactly representable in float32 for |x| < 8."""
    return round(x * Q) / Q


def num(x):
    """A JSON number with 9 significant decimals (deterministic text)."""
    return float("%.9g" % x)


# ---------------------------------------------------------------------------------------------
# Meshes: lists of (position, normal, uv) vertices and index triples, front faces
# counter-clockwise (glTF 2.0 section 3.7.2.1).


class Mesh:
    def __init__(self):
        self.pos, self.nrm, self.uv, self.tri = [], [], [], []

    def vertex(self, p, n, uv):
        self.pos.append([quant(c) for c in p])
        self.nrm.append([quant(c) for c in normalize(n)])
        self.uv.append([quant(c) for c in uv])
        return len(self.pos) - 1

    def triangle(self, a, b, c):
        # Front side counter-clockwise: the geometric normal agrees with the vertex normals.
        g = cross(sub(self.pos[b], self.pos[a]), sub(self.pos[c], self.pos[a]))
        n = add(add(self.nrm[a], self.nrm[b]), self.nrm[c])
        assert dot(g, n) > 0, "triangle wound against its normals"
        self.tri.append((a, b, c))


def quad(corners, normal, uvs):
    """Two triangles of the quad c0 c1 c2 c3 (counter-clockwise seen from `normal`'s side)."""
    m = Mesh()
    ids = [m.vertex(c, normal, uv) for c, uv in zip(corners, uvs)]
    m.triangle(ids[0], ids[1], ids[2])
    m.triangle(ids[0], ids[2], ids[3])
    return m


def uv_sphere(segments=48, rings=24):
    """Unit sphere: `segments` around y, `rings` from the north pole (+y) to the south pole,
    smooth normals, u = longitude / 2pi, v = colatitude / pi (seam vertices duplicated)."""
    m = Mesh()
    grid = []
    for i in range(rings + 1):
        theta = math.pi * i / rings
        row = []
        for j in range(segments + 1):
            phi = 2 * math.pi * j / segments
            p = [math.sin(theta) * math.sin(phi), math.cos(theta), math.sin(theta) * math.cos(phi)]
            if i == 0:
                p = [0.0, 1.0, 0.0]
            if i == rings:
                p = [0.0, -1.0, 0.0]
            row.append(m.vertex(p, p, [j / segments, i / rings]))
        grid.append(row)
    for i in range(rings):
        for j in range(segments):
            a, b = grid[i][j], grid[i][j + 1]
            c, d = grid[i + 1][j], grid[i + 1][j + 1]
            if i > 0:
                m.triangle(a, c, b)
            if i < rings - 1:
                m.triangle(b, c, d)
    return m


def rounded_box(half, radius, steps=4):
    """A box of half side `half` whose edges and corners are rounded with `radius`, centred at the
    origin: each face is a grid whose points p are pushed out from the inner box [-(half -
    radius), half - radius]^3 by `radius` along p - clamp(p); the rounded strips take `steps`
    grid lines each, at equal angles up to the 45 degrees where the neighbouring face takes over.
    Normals are that offset direction (continuous across faces); UVs run 0..1 on every face."""
    inner = half - radius
    coords = [-inner - radius * math.tan(math.pi / 4 * k / steps) for k in range(steps, 0, -1)]
    coords += [-inner] + [inner + radius * math.tan(math.pi / 4 * k / steps)
                          for k in range(0, steps + 1)]
    m = Mesh()
    # (normal axis, sign, u axis, v axis): u x v points out of the box.
    faces = [(0, 1, 2, 1), (0, -1, 1, 2), (1, 1, 0, 2), (1, -1, 2, 0), (2, 1, 1, 0), (2, -1, 0, 1)]
    for axis, sign, ua, va in faces:
        # Make u x v = sign * e_axis by flipping v when needed.
        e = [0, 0, 0]
        e[axis] = sign
        eu, ev = [0, 0, 0], [0, 0, 0]
        eu[ua], ev[va] = 1, 1
        vflip = 1 if dot(cross(eu, ev), e) > 0 else -1
        ids = []
        for s in coords:
            row = []
            for t in coords:
                p = [0.0, 0.0, 0.0]
                p[axis] = sign * half
                p[ua] = s
                p[va] = vflip * t
                q = [max(-inner, min(inner, c)) for c in p]
                d = normalize(sub(p, q))
                pos = add(q, mul(d, radius))
                row.append(m.vertex(pos, d, [(s + half) / (2 * half), (t + half) / (2 * half)]))
            ids.append(row)
        n = len(coords)
        for i in range(n - 1):
            for j in range(n - 1):
                a, b, c, d = ids[i][j], ids[i + 1][j], ids[i + 1][j + 1], ids[i][j + 1]
                m.triangle(a, b, c)
                m.triangle(a, c, d)
    return m


# ---------------------------------------------------------------------------------------------
# PNG writer (PNG specification, ISO/IEC 15948: signature, IHDR, one IDAT, IEND; filter 0).


def png(width, height, rows, channels):
    """rows: `height` lists of width*channels ints in 0..255; 8-bit RGB or RGBA."""
    def chunk(kind, data):
        return (struct.pack(">I", len(data)) + kind + data +
                struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))
    raw = b"".join(b"\x00" + bytes(r) for r in rows)
    color_type = {3: 2, 4: 6}[channels]
    ihdr = struct.pack(">IIBBBBB", width, height, 8, color_type, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(raw, 9)) +
            chunk(b"IEND", b""))


def hash2(i, j):
    """A small integer hash of a tile (deterministic, integer arithmetic only)."""
    h = (i * 73856093) ^ (j * 19349663)
    h = (h ^ (h >> 13)) * 1274126177
    return (h ^ (h >> 16)) & 0xFFFF


def tiles_png():
    """128 x 128 sRGB: 2 x 2 tiles of 64 texels (terracotta and cream in a checker, each tile's
    shade varied a little), 3-texel grout lines; tiles seamlessly under REPEAT."""
    size, tile, grout = 128, 64, 3
    rows = []
    for y in range(size):
        row = []
        for x in range(size):
            tx, ty = x // tile, y // tile
            fx, fy = x % tile, y % tile
            if fx < grout or fy < grout:
                c = (96, 90, 84)
            else:
                base = (186, 104, 72) if (tx + ty) % 2 == 0 else (224, 210, 182)
                shade = hash2(tx, ty) % 17 - 8          # -8 .. 8
                grain = ((fx * 7 + fy * 13) % 5) - 2    # -2 .. 2, a faint texture
                c = tuple(max(0, min(255, v + shade + grain)) for v in base)
            row.extend(c)
        rows.append(row)
    return png(size, size, rows, 3)


FENCE_PERIOD, FENCE_SLAT, FENCE_FRAME = 32, 6, 6


def fence_opaque(x, y, size=128):
    """The fence's slats: a diagonal lattice of FENCE_SLAT-texel slats every FENCE_PERIOD
    texels both ways, inside a FENCE_FRAME-texel frame."""
    if x < FENCE_FRAME or y < FENCE_FRAME or x >= size - FENCE_FRAME or y >= size - FENCE_FRAME:
        return True
    return (x + y) % FENCE_PERIOD < FENCE_SLAT or (x - y) % FENCE_PERIOD < FENCE_SLAT


def fence_png():
    """128 x 128 sRGB + alpha: the lattice (alpha 255) and the diamond holes (alpha 0). The holes
    keep the wood's colour, so that bilinear filtering at an edge blends alpha, not colour."""
    size = 128
    rows = []
    for y in range(size):
        row = []
        for x in range(size):
            grain = ((x * 5 + y * 3) % 7) - 3
            row.extend((150 + grain, 108 + grain, 66 + grain, 255 if fence_opaque(x, y) else 0))
        rows.append(row)
    return png(size, size, rows, 4)


MR_ROUGHNESS = (26, 89, 153, 217)   # G channel: roughness 0.10, 0.35, 0.60, 0.85 (linear)


def mr_png():
    """64 x 64 linear metallic-roughness map (glTF 2.0 section 3.9.2: B = metallic, G =
    roughness, R unused = 255): 4 stripes in u alternating dielectric and metal, 4 bands in v
    of rising roughness."""
    size = 64
    rows = []
    for y in range(size):
        row = []
        for x in range(size):
            metal = 255 if (x // 16) % 2 == 1 else 0
            row.extend((255, MR_ROUGHNESS[y // 16], metal))
        rows.append(row)
    return png(size, size, rows, 3)


# ---------------------------------------------------------------------------------------------
# The scene.

ROOM_X, ROOM_Y, ROOM_Z0, ROOM_Z1 = 1.0, 1.6, -1.2, 2.4
TILE_METRES = 0.5                     # one floor texture (2 x 2 tiles) per 0.5 m
METAL_CENTER, METAL_R = [-0.5, 0.3, -0.15], 0.3
GLASS_CENTER, GLASS_R = [0.55, 0.28, 0.25], 0.28
BOX_CENTER, BOX_HALF, BOX_RADIUS, BOX_YAW_DEG = [0.2, 0.22, -0.7], 0.22, 0.05, 35.0
FENCE_X0, FENCE_X1, FENCE_Y1, FENCE_Z = -0.97, -0.07, 0.9, -0.95
LIGHT_X0, LIGHT_X1, LIGHT_Z0, LIGHT_Z1, LIGHT_Y = -0.3, 0.3, -0.4, 0.2, 1.595
SPOT_POS, SPOT_AIM = [0.85, 1.5, 1.3], [0.0, 0.25, -0.05]
EYE, TARGET, YFOV_DEG = [0.0, 0.85, 2.25], [0.0, 0.6, -0.5], 52.0
APERTURE = 0.04                        # lens radius (m): depth of field in showcase.bake-options
# Light strengths per variant. The spot's intensity is in candela (KHR_lights_punctual); photonflow
# reads a point light's colour as W/sr (docs/SCENES.md, "Lights"), and these values assume the same
# 1 cd -> 1 W/sr for spots: about 1 W/m^2 on the spheres, half the ceiling light's irradiance on
# the floor. An importer that converts photometric units (/683 lm/W) needs them scaled.
EMISSIVE_STRENGTH = {"showcase": 15.0, "showcase-caustics": 1.0}
SPOT_INTENSITY = {"showcase": 4.0, "showcase-caustics": 12.0}

WHITE, RED, GREEN = [0.725, 0.71, 0.68], [0.63, 0.065, 0.05], [0.14, 0.45, 0.091]


def room_meshes():
    """The six walls, facing into the room, one primitive each: (name, mesh)."""
    x, y, z0, z1 = ROOM_X, ROOM_Y, ROOM_Z0, ROOM_Z1
    u = lambda v: v / TILE_METRES  # noqa: E731
    floor = quad([[-x, 0, z1], [x, 0, z1], [x, 0, z0], [-x, 0, z0]], [0, 1, 0],
                 [[u(0), u(z1 - z0)], [u(2 * x), u(z1 - z0)], [u(2 * x), 0], [0, 0]])
    uv = [[0, 1], [1, 1], [1, 0], [0, 0]]
    ceiling = quad([[-x, y, z0], [x, y, z0], [x, y, z1], [-x, y, z1]], [0, -1, 0], uv)
    back = quad([[-x, 0, z0], [x, 0, z0], [x, y, z0], [-x, y, z0]], [0, 0, 1], uv)
    front = quad([[x, 0, z1], [-x, 0, z1], [-x, y, z1], [x, y, z1]], [0, 0, -1], uv)
    left = quad([[-x, 0, z1], [-x, 0, z0], [-x, y, z0], [-x, y, z1]], [1, 0, 0], uv)
    right = quad([[x, 0, z0], [x, 0, z1], [x, y, z1], [x, y, z0]], [-1, 0, 0], uv)
    return [("floor", floor), ("ceiling", ceiling), ("back", back), ("front", front),
            ("left", left), ("right", right)]


def light_mesh():
    x0, x1, z0, z1, y = LIGHT_X0, LIGHT_X1, LIGHT_Z0, LIGHT_Z1, LIGHT_Y
    return quad([[x0, y, z0], [x1, y, z0], [x1, y, z1], [x0, y, z1]], [0, -1, 0],
                [[0, 1], [1, 1], [1, 0], [0, 0]])


def fence_mesh():
    """The square panel (0.9 m), facing the camera (+z); glTF UV (0, 0) at its top-left."""
    x0, x1, y1, z = FENCE_X0, FENCE_X1, FENCE_Y1, FENCE_Z
    return quad([[x0, 0, z], [x1, 0, z], [x1, y1, z], [x0, y1, z]], [0, 0, 1],
                [[0, 1], [1, 1], [1, 0], [0, 0]])


def look_rotation(forward, up):
    """Unit quaternion (x, y, z, w) turning -z to `forward` and +y towards `up` (glTF cameras
    and spot lights look along their node's -z, section 3.10 and KHR_lights_punctual)."""
    f = normalize(forward)
    r = normalize(cross(f, up))
    u = cross(r, f)
    # Columns of the rotation matrix: r, u, -f.
    m = [[r[0], u[0], -f[0]], [r[1], u[1], -f[1]], [r[2], u[2], -f[2]]]
    tr = m[0][0] + m[1][1] + m[2][2]
    if tr > 0:
        s = math.sqrt(tr + 1.0) * 2
        q = [(m[2][1] - m[1][2]) / s, (m[0][2] - m[2][0]) / s, (m[1][0] - m[0][1]) / s, 0.25 * s]
    elif m[0][0] > m[1][1] and m[0][0] > m[2][2]:
        s = math.sqrt(1.0 + m[0][0] - m[1][1] - m[2][2]) * 2
        q = [0.25 * s, (m[0][1] + m[1][0]) / s, (m[0][2] + m[2][0]) / s, (m[2][1] - m[1][2]) / s]
    elif m[1][1] > m[2][2]:
        s = math.sqrt(1.0 + m[1][1] - m[0][0] - m[2][2]) * 2
        q = [(m[0][1] + m[1][0]) / s, 0.25 * s, (m[1][2] + m[2][1]) / s, (m[0][2] - m[2][0]) / s]
    else:
        s = math.sqrt(1.0 + m[2][2] - m[0][0] - m[1][1]) * 2
        q = [(m[0][2] + m[2][0]) / s, (m[1][2] + m[2][1]) / s, 0.25 * s, (m[1][0] - m[0][1]) / s]
    return [num(c) for c in q]


class GltfWriter:
    """Collects buffer views, accessors, meshes into one binary buffer and the glTF JSON."""

    def __init__(self):
        self.bin = bytearray()
        self.views, self.accessors = [], []

    def _view(self, data, target):
        while len(self.bin) % 4:
            self.bin.append(0)
        self.views.append({"buffer": 0, "byteOffset": len(self.bin), "byteLength": len(data),
                           "target": target})
        self.bin.extend(data)
        return len(self.views) - 1

    def _floats(self, rows, kind, bounds):
        data = b"".join(struct.pack("<%df" % len(r), *r) for r in rows)
        acc = {"bufferView": self._view(data, 34962), "componentType": 5126,
               "count": len(rows), "type": kind}
        if bounds:  # POSITION needs min and max (glTF 2.0 section 3.7.2.1)
            acc["min"] = [min(r[k] for r in rows) for k in range(len(rows[0]))]
            acc["max"] = [max(r[k] for r in rows) for k in range(len(rows[0]))]
        self.accessors.append(acc)
        return len(self.accessors) - 1

    def primitive_attributes(self, mesh):
        """Accessors of a mesh's vertices and indices: (attributes, indices accessor)."""
        attrs = {"POSITION": self._floats(mesh.pos, "VEC3", True),
                 "NORMAL": self._floats(mesh.nrm, "VEC3", False),
                 "TEXCOORD_0": self._floats(mesh.uv, "VEC2", False)}
        flat = [i for t in mesh.tri for i in t]
        assert max(flat) < 65536
        data = struct.pack("<%dH" % len(flat), *flat)
        self.accessors.append({"bufferView": self._view(data, 34963), "componentType": 5123,
                               "count": len(flat), "type": "SCALAR"})
        return attrs, len(self.accessors) - 1


def pbr(name, color, metallic, roughness, **extra):
    m = {"name": name,
         "pbrMetallicRoughness": {"baseColorFactor": [num(c) for c in color] + [1.0],
                                  "metallicFactor": metallic, "roughnessFactor": roughness}}
    m.update(extra)
    return m


def build(variant):
    """The glTF JSON of `variant` ("showcase" or "showcase-caustics") and the binary buffer."""
    w = GltfWriter()
    materials = [
        pbr("white", WHITE, 0.0, 1.0),
        pbr("red", RED, 0.0, 1.0),
        pbr("green", GREEN, 0.0, 1.0),
        pbr("floor tiles", [1, 1, 1], 0.0, 0.8),
        pbr("gold, glossy metal", [1.0, 0.766, 0.336], 1.0, 0.3),
        pbr("rough glass", [1, 1, 1], 0.0, 0.2,
            extensions={"KHR_materials_transmission": {"transmissionFactor": 1.0},
                        "KHR_materials_ior": {"ior": 1.5}}),
        pbr("striped metal and plastic", [0.9, 0.55, 0.25], 1.0, 1.0),
        pbr("fence", [1, 1, 1], 0.0, 0.9, alphaMode="MASK", alphaCutoff=0.5, doubleSided=True),
        pbr("ceiling light", [0.8, 0.8, 0.8], 0.0, 1.0, emissiveFactor=[1.0, 0.85, 0.65],
            extensions={"KHR_materials_emissive_strength": {
                "emissiveStrength": EMISSIVE_STRENGTH[variant]}}),
    ]
    MAT = {m["name"]: i for i, m in enumerate(materials)}
    materials[MAT["floor tiles"]]["pbrMetallicRoughness"]["baseColorTexture"] = {"index": 0}
    materials[MAT["fence"]]["pbrMetallicRoughness"]["baseColorTexture"] = {"index": 1}
    materials[MAT["striped metal and plastic"]]["pbrMetallicRoughness"][
        "metallicRoughnessTexture"] = {"index": 2}

    meshes, nodes = [], []
    wall_material = {"floor": "floor tiles", "left": "red", "right": "green"}
    room = []
    for name, mesh in room_meshes():
        attrs, idx = w.primitive_attributes(mesh)
        room.append({"attributes": attrs, "indices": idx,
                     "material": MAT[wall_material.get(name, "white")]})
    meshes.append({"name": "room", "primitives": room})
    nodes.append({"name": "room", "mesh": 0})

    def single(name, mesh, material, **node):
        attrs, idx = w.primitive_attributes(mesh)
        meshes.append({"name": name, "primitives": [
            {"attributes": attrs, "indices": idx, "material": MAT[material]}]})
        n = {"name": name, "mesh": len(meshes) - 1}
        n.update(node)
        nodes.append(n)
        return attrs, idx

    single("ceiling light", light_mesh(), "ceiling light")
    single("fence", fence_mesh(), "fence")
    # One unit sphere for both spheres: two meshes share its accessors, each with its material.
    attrs, idx = single("metal sphere", uv_sphere(), "gold, glossy metal",
                        translation=[num(c) for c in METAL_CENTER], scale=[METAL_R] * 3)
    meshes.append({"name": "glass sphere", "primitives": [
        {"attributes": attrs, "indices": idx, "material": MAT["rough glass"]}]})
    nodes.append({"name": "glass sphere", "mesh": len(meshes) - 1,
                  "translation": [num(c) for c in GLASS_CENTER], "scale": [GLASS_R] * 3})
    yaw = math.radians(BOX_YAW_DEG)
    single("striped box", rounded_box(BOX_HALF, BOX_RADIUS), "striped metal and plastic",
           translation=[num(c) for c in BOX_CENTER],
           rotation=[0.0, num(math.sin(yaw / 2)), 0.0, num(math.cos(yaw / 2))])

    nodes.append({"name": "spot light", "translation": SPOT_POS,
                  "rotation": look_rotation(sub(SPOT_AIM, SPOT_POS), [0, 1, 0]),
                  "extensions": {"KHR_lights_punctual": {"light": 0}}})
    nodes.append({"name": "camera", "camera": 0, "translation": EYE,
                  "rotation": look_rotation(sub(TARGET, EYE), [0, 1, 0])})

    doc = {
        "asset": {"version": "2.0", "generator": "photonflow data/make_showcase.py"},
        "extensionsUsed": ["KHR_lights_punctual", "KHR_materials_emissive_strength",
                           "KHR_materials_ior", "KHR_materials_transmission"],
        "scene": 0,
        "scenes": [{"name": variant, "nodes": list(range(len(nodes)))}],
        "nodes": nodes,
        "cameras": [{"name": "camera", "type": "perspective", "perspective": {
            "aspectRatio": 1.0, "yfov": num(math.radians(YFOV_DEG)), "znear": 0.05,
            "zfar": 20.0}}],
        "extensions": {"KHR_lights_punctual": {"lights": [{
            "name": "spot light", "type": "spot", "color": [1.0, 0.95, 0.85],
            "intensity": SPOT_INTENSITY[variant],
            "spot": {"innerConeAngle": 0.3, "outerConeAngle": 0.45}}]}},
        "meshes": meshes,
        "materials": materials,
        "textures": [{"sampler": 0, "source": 0}, {"sampler": 1, "source": 1},
                     {"sampler": 2, "source": 2}],
        # 9729 LINEAR, 9728 NEAREST, 9987 LINEAR_MIPMAP_LINEAR, 10497 REPEAT, 33071 CLAMP_TO_EDGE
        "samplers": [{"magFilter": 9729, "minFilter": 9987, "wrapS": 10497, "wrapT": 10497},
                     {"magFilter": 9729, "minFilter": 9987, "wrapS": 33071, "wrapT": 33071},
                     {"magFilter": 9728, "minFilter": 9728, "wrapS": 33071, "wrapT": 33071}],
        "images": [{"uri": "showcase_tiles.png", "mimeType": "image/png"},
                   {"uri": "showcase_fence.png", "mimeType": "image/png"},
                   {"uri": "showcase_mr.png", "mimeType": "image/png"}],
        "buffers": [{"uri": "showcase.bin", "byteLength": len(w.bin)}],
        "bufferViews": w.views,
        "accessors": w.accessors,
    }
    return doc, bytes(w.bin)


def bake_options():
    """scene-bake options for depth of field: the lens radius, and the focus on the metal
    sphere's centre (its distance along the view axis)."""
    forward = normalize(sub(TARGET, EYE))
    focus = dot(sub(METAL_CENTER, EYE), forward)
    return ("# scene-bake options of data/showcase.gltf (written by data/make_showcase.py; read by\n"
            "# scene-bake and render --scene beside the scene file, also for make render\n"
            "# SCENE=showcase): depth of field, focused on the metal sphere. glTF cameras carry\n"
            "# no aperture.\n"
            "--aperture %s --focus-distance %s\n" % (num(APERTURE), "%.4f" % focus))


def output_folder(doc, script):
    """The scene scripts' one option, --out DIR (default: the folder of `script`), created; `doc`
    is the script's docstring, whose first line is its description."""
    ap = argparse.ArgumentParser(description=doc.split("\n")[0])
    ap.add_argument("--out", default=os.path.dirname(os.path.abspath(script)),
                    help="output folder (default: the script's folder)")
    out = ap.parse_args().out
    os.makedirs(out, exist_ok=True)
    return out


def write_files(out, files):
    """Writes each file of `files` (name: bytes) into `out`, and lists it with its size."""
    width = max(len(name) for name in files) + 2
    for name, data in files.items():
        with open(os.path.join(out, name), "wb") as f:
            f.write(data)
        print("%-*s %7d bytes" % (width, name, len(data)))


def main():
    out = output_folder(__doc__, __file__)
    files = {}
    bins = set()
    for variant in ("showcase", "showcase-caustics"):
        doc, binary = build(variant)
        bins.add(binary)
        files[variant + ".gltf"] = (json.dumps(doc, indent=1) + "\n").encode()
    assert len(bins) == 1  # both variants share showcase.bin
    files["showcase.bin"] = bins.pop()
    files["showcase_tiles.png"] = tiles_png()
    files["showcase_fence.png"] = fence_png()
    files["showcase_mr.png"] = mr_png()
    files["showcase.bake-options"] = bake_options().encode()
    write_files(out, files)


if __name__ == "__main__":
    main()
