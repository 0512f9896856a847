#!/usr/bin/env python3
"""make_outside.py: writes the two data/ scenes lit from outside (issue 50 item 5) and their sky:
data/sky.hdr, window-room.gltf, hdri-object.gltf, outside.bin and the scenes' bake options.
Python 3 standard library only; the meshes and the glTF writer are data/make_showcase.py's.

    /usr/bin/python3 data/make_outside.py [--out DIR]      (default: the folder of this script)

The generated files are committed; tests/tools/outside_scenes_test.cpp runs this script into a
temporary folder and checks that they are what it writes (docs/SCENES.md, "Scenes lit from
outside").

  * sky.hdr: a 512 x 256 equirectangular Radiance RGBE map (flat, uncompressed scanlines) in the
    orientation of Mitsuba 3's envmap (docs/SCENES.md, "Environment"): a blue sky brightening
    towards the horizon, a glow around the sun, a darker brown ground below the horizon, and a
    sun disc of 9 texels (3 x 3 around one texel centre, about 1.1e-3 sr) whose radiance is
    SUN_RATIO times the sky's at the zenith, at elevation 34.8 degrees on the +x side, turned
    19.3 degrees towards -z.
  * window-room.gltf: a closed room (x in [-2, 2], y in [0, 2.6], z in [-2.5, 2.5]) of diffuse
    walls whose only opening is a window in the +x wall: lit only by the sky and the sun through
    it (no emitter, no punctual light). The sun throws the window's patch onto the floor in front
    of a camera in the opposite corner; inside stand a diffuse box, a glossy metal ball (metallic
    1, roughness 0.3) in the sun, and a rough-glass sphere that focuses the sun on the floor.
  * hdri-object.gltf: outdoors under the same sky, a glossy metal sphere and a red plastic rounded
    box on a finite 12 m x 12 m diffuse floor.
  * window-room.bake-options, hdri-object.bake-options: --environment sky.hdr (resolved against the options file's folder) with a strength
    (scene-bake resolves a relative map path against its working folder, so these name it from
    the repository root, where make render and the commands of docs/SCENES.md run).

Determinism: as make_showcase.py (vertex values rounded to 2^-20, JSON numbers to 9 digits); the
sky's radiance is rounded to 2^-20 before its 8-bit RGBE encoding.
"""
import json
import math
import os
import sys

sys.dont_write_bytecode = True  # no __pycache__ in data/ when the test runs this script
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
# The meshes, the glTF writer, look_rotation, num, quant, and the --out folder and file writing.
import make_showcase as ms  # noqa: E402

num, quant, quad, sub = ms.num, ms.quant, ms.quad, ms.sub

# ---------------------------------------------------------------------------------------------
# The sky.

SKY_W, SKY_H = 512, 256
SUN_ROW, SUN_COL = 78, 100            # the sun disc's centre texel (row 0 = +y, the zenith)
SUN_RATIO = 5000.0                    # sun radiance / the sky's at the zenith (luminance)
ZENITH = [0.10, 0.20, 0.50]           # sky radiance at the zenith, W/(sr m^2)
HORIZON = [0.55, 0.62, 0.75]          # ... at the horizon
GROUND = [0.060, 0.050, 0.040]        # below the horizon (the nadir; a little brighter near it)
SUN_COLOUR = [1.0, 0.92, 0.80]        # relative; scaled so its luminance is SUN_RATIO x zenith's
GLOW = [0.60, 0.50, 0.35]             # the glow around the sun, added to the sky at the sun


def luminance(c):
    return 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]


def texel_direction(row, col):
    """The unit direction towards the sky of a texel's centre (docs/SCENES.md, "Environment":
    u = atan2(d.x, -d.z) / 2pi, v = acos(d.y) / pi, row 0 at the top)."""
    theta = math.pi * (row + 0.5) / SKY_H
    phi = 2 * math.pi * (col + 0.5) / SKY_W
    return [math.sin(theta) * math.sin(phi), math.cos(theta), -math.sin(theta) * math.cos(phi)]


SUN_DIR = texel_direction(SUN_ROW, SUN_COL)
SUN_ELEVATION_DEG = math.degrees(math.asin(SUN_DIR[1]))
SUN_SCALE = SUN_RATIO * luminance(ZENITH) / luminance(SUN_COLOUR)
SUN = [c * SUN_SCALE for c in SUN_COLOUR]


def sky_radiance(row, col):
    """RGB radiance of one texel."""
    if abs(row - SUN_ROW) <= 1 and abs(col - SUN_COL) <= 1:
        return SUN
    d = texel_direction(row, col)
    if d[1] < 0:  # the ground: dark, a little lighter towards the horizon
        t = 1.0 + d[1]                                # 1 at the horizon, 0 at the nadir
        return [g * (1.0 + 0.6 * t * t) for g in GROUND]
    t = 1.0 - d[1]                                    # 0 at the zenith, 1 at the horizon
    w = t ** 3
    c = [z + (h - z) * w for z, h in zip(ZENITH, HORIZON)]
    cos_sun = max(-1.0, min(1.0, ms.dot(d, SUN_DIR)))
    glow = math.exp(-math.acos(cos_sun) / 0.12)       # about 7 degrees wide
    return [a + g * glow for a, g in zip(c, GLOW)]


def rgbe(c):
    """Ward's RGBE encoding of one pixel (Graphics Gems II, "Real pixels")."""
    v = max(c)
    if v < 1e-32:
        return bytes((0, 0, 0, 0))
    m, e = math.frexp(v)
    scale = m * 256.0 / v
    return bytes([int(x * scale) for x in c] + [e + 128])


def sky_hdr():
    """The Radiance file: header, blank line, resolution "-Y H +X W" (top row first), then flat
    RGBE scanlines (valid without run-length encoding)."""
    head = ("#?RADIANCE\n# photonflow data/make_outside.py: procedural sky with a sun\n"
            "FORMAT=32-bit_rle_rgbe\n\n-Y %d +X %d\n" % (SKY_H, SKY_W)).encode()
    rows = bytearray()
    for row in range(SKY_H):
        for col in range(SKY_W):
            rows += rgbe([quant(x) for x in sky_radiance(row, col)])
    return head + bytes(rows)


# ---------------------------------------------------------------------------------------------
# The window room.

ROOM_X, ROOM_Y, ROOM_Z = 2.0, 2.6, 2.5            # x in [-2, 2], y in [0, 2.6], z in [-2.5, 2.5]
WIN_Z0, WIN_Z1, WIN_Y0, WIN_Y1 = -1.9, -0.5, 0.8, 2.0   # the window in the x = +2 wall
WALL = [0.75, 0.73, 0.70]
FLOOR = [0.55, 0.40, 0.28]
ACCENT = [0.45, 0.60, 0.62]                        # the -x wall, across from the window
BOX_C, BOX_HALF, BOX_YAW = [-1.1, 0.35, -1.6], 0.35, 20.0
BALL_C, BALL_R = [0.55, 0.4, -0.25], 0.4           # in the sun patch
GLASS_C, GLASS_R = [-0.15, 0.3, -0.95], 0.3        # in the sun patch too
ROOM_EYE, ROOM_TARGET, ROOM_YFOV = [-1.7, 1.55, 2.3], [0.55, 0.35, -0.55], 60.0
ROOM_STRENGTH = 4.0


def window_room_walls():
    """(name, mesh) of the walls, facing into the room; the +x wall is four quads around the
    window."""
    x, y, z = ROOM_X, ROOM_Y, ROOM_Z
    uv = [[0, 1], [1, 1], [1, 0], [0, 0]]
    walls = [
        ("floor", quad([[-x, 0, z], [x, 0, z], [x, 0, -z], [-x, 0, -z]], [0, 1, 0], uv)),
        ("ceiling", quad([[-x, y, -z], [x, y, -z], [x, y, z], [-x, y, z]], [0, -1, 0], uv)),
        ("back", quad([[-x, 0, -z], [x, 0, -z], [x, y, -z], [-x, y, -z]], [0, 0, 1], uv)),
        ("front", quad([[x, 0, z], [-x, 0, z], [-x, y, z], [x, y, z]], [0, 0, -1], uv)),
        ("left", quad([[-x, 0, z], [-x, 0, -z], [-x, y, -z], [-x, y, z]], [1, 0, 0], uv)),
    ]

    def right(name, z0, z1, y0, y1):  # a rectangle of the x = +x wall, facing -x
        return (name, quad([[x, y0, z0], [x, y0, z1], [x, y1, z1], [x, y1, z0]], [-1, 0, 0], uv))
    walls += [right("window wall below", -z, z, 0, WIN_Y0),
              right("window wall above", -z, z, WIN_Y1, y),
              right("window wall back", -z, WIN_Z0, WIN_Y0, WIN_Y1),
              right("window wall front", WIN_Z1, z, WIN_Y0, WIN_Y1)]
    return walls


def sun_patch_centre():
    """Where sunlight through the window's centre meets the floor."""
    c = [ROOM_X, 0.5 * (WIN_Y0 + WIN_Y1), 0.5 * (WIN_Z0 + WIN_Z1)]
    s = c[1] / SUN_DIR[1]
    return [c[0] - s * SUN_DIR[0], 0.0, c[2] - s * SUN_DIR[2]]


# ---------------------------------------------------------------------------------------------
# The object outdoors.

GROUND_HALF = 6.0                                   # the floor: x, z in [-6, 6], y = 0
GROUND_ALBEDO = [0.5, 0.5, 0.5]
SPHERE_C, SPHERE_R = [-0.55, 0.5, 0.0], 0.5
PLASTIC_C, PLASTIC_HALF, PLASTIC_YAW = [0.75, 0.35, 0.35], 0.35, 30.0
OBJ_EYE, OBJ_TARGET, OBJ_YFOV = [0.3, 1.2, 4.0], [0.1, 0.45, 0.0], 38.0
OBJ_STRENGTH = 1.0


def write_scene(w, name, materials, parts, eye, target, yfov):
    """The glTF document of `parts` ((node name, mesh or accessors, material name, node extra)),
    with one camera. A part's mesh may be the (attributes, indices) of an earlier one."""
    MAT = {m["name"]: i for i, m in enumerate(materials)}
    meshes, nodes, shared = [], [], {}
    for node_name, mesh, material, extra in parts:
        if isinstance(mesh, str):
            attrs, idx = shared[mesh]
        else:
            attrs, idx = w.primitive_attributes(mesh)
            shared[node_name] = (attrs, idx)
        meshes.append({"name": node_name, "primitives": [
            {"attributes": attrs, "indices": idx, "material": MAT[material]}]})
        n = {"name": node_name, "mesh": len(meshes) - 1}
        n.update(extra)
        nodes.append(n)
    nodes.append({"name": "camera", "camera": 0, "translation": eye,
                  "rotation": ms.look_rotation(sub(target, eye), [0, 1, 0])})
    return {
        "asset": {"version": "2.0", "generator": "photonflow data/make_outside.py"},
        "extensionsUsed": ["KHR_materials_ior", "KHR_materials_transmission"],
        "scene": 0,
        "scenes": [{"name": name, "nodes": list(range(len(nodes)))}],
        "nodes": nodes,
        "cameras": [{"name": "camera", "type": "perspective", "perspective": {
            "aspectRatio": 1.0, "yfov": num(math.radians(yfov)), "znear": 0.05, "zfar": 50.0}}],
        "meshes": meshes,
        "materials": materials,
    }


def placed(center, scale, yaw_deg=None):
    n = {"translation": [num(c) for c in center]}
    if yaw_deg is not None:
        yaw = math.radians(yaw_deg)
        n["rotation"] = [0.0, num(math.sin(yaw / 2)), 0.0, num(math.cos(yaw / 2))]
    if scale is not None:
        n["scale"] = [scale] * 3
    return n


def build():
    """(window-room JSON, hdri-object JSON, the shared binary buffer)."""
    w = ms.GltfWriter()
    pbr = ms.pbr
    glass = pbr("rough glass", [1, 1, 1], 0.0, 0.15,
                extensions={"KHR_materials_transmission": {"transmissionFactor": 1.0},
                            "KHR_materials_ior": {"ior": 1.5}})
    steel = pbr("glossy metal", [0.95, 0.93, 0.88], 1.0, 0.3)
    room_mats = [pbr("wall", WALL, 0.0, 1.0), pbr("floor", FLOOR, 0.0, 1.0),
                 pbr("accent wall", ACCENT, 0.0, 1.0), pbr("box", [0.75, 0.32, 0.18], 0.0, 1.0),
                 steel, glass]
    sphere = ms.uv_sphere()
    parts = []
    for name, mesh in window_room_walls():
        parts.append((name, mesh, {"floor": "floor", "left": "accent wall"}.get(name, "wall"), {}))
    parts.append(("box", ms.rounded_box(BOX_HALF, 0.04), "box", placed(BOX_C, None, BOX_YAW)))
    parts.append(("metal ball", sphere, "glossy metal", placed(BALL_C, BALL_R)))
    parts.append(("glass sphere", "metal ball", "rough glass", placed(GLASS_C, GLASS_R)))
    room = write_scene(w, "window-room", room_mats, parts, ROOM_EYE, ROOM_TARGET, ROOM_YFOV)

    obj_mats = [pbr("ground", GROUND_ALBEDO, 0.0, 1.0), steel,
                pbr("red plastic", [0.7, 0.08, 0.05], 0.0, 0.35)]
    g = GROUND_HALF
    parts = [("ground", quad([[-g, 0, g], [g, 0, g], [g, 0, -g], [-g, 0, -g]], [0, 1, 0],
                             [[0, 1], [1, 1], [1, 0], [0, 0]]), "ground", {}),
             ("metal sphere", sphere, "glossy metal", placed(SPHERE_C, SPHERE_R)),
             ("plastic box", ms.rounded_box(PLASTIC_HALF, 0.06), "red plastic",
              placed(PLASTIC_C, None, PLASTIC_YAW))]
    obj = write_scene(w, "hdri-object", obj_mats, parts, OBJ_EYE, OBJ_TARGET, OBJ_YFOV)
    del obj["extensionsUsed"]  # no glass outdoors
    for doc in (room, obj):
        doc["buffers"] = [{"uri": "outside.bin", "byteLength": len(w.bin)}]
        doc["bufferViews"] = w.views
        doc["accessors"] = w.accessors
    return room, obj, bytes(w.bin)


def bake_options(scene, strength, what):
    return ("# scene-bake options of data/%s.gltf (written by data/make_outside.py; read by\n"
            "# scene-bake and render --scene beside the scene file, also for make render).\n"
            "# %s\n"
            "# A relative map path is resolved against this file's folder.\n"
            "--environment sky.hdr --environment-strength %s\n" % (scene, what, num(strength)))


def main():
    out = ms.output_folder(__doc__, __file__)
    room, obj, binary = build()
    files = {
        "sky.hdr": sky_hdr(),
        "window-room.gltf": (json.dumps(room, indent=1) + "\n").encode(),
        "hdri-object.gltf": (json.dumps(obj, indent=1) + "\n").encode(),
        "outside.bin": binary,
        "window-room.bake-options": bake_options(
            "window-room", ROOM_STRENGTH,
            "The only light: the sky and its sun through the window.").encode(),
        "hdri-object.bake-options": bake_options(
            "hdri-object", OBJ_STRENGTH, "The only light: the sky and its sun.").encode(),
    }
    ms.write_files(out, files)
    p = sun_patch_centre()
    print("sun: elevation %.2f deg, direction (%.4f, %.4f, %.4f), radiance %.1f (luminance), "
          "%.0f x the zenith's; sun patch centre in the room (%.2f, 0, %.2f)"
          % (SUN_ELEVATION_DEG, SUN_DIR[0], SUN_DIR[1], SUN_DIR[2], luminance(SUN),
             luminance(SUN) / luminance(ZENITH), p[0], p[2]))


if __name__ == "__main__":
    main()
