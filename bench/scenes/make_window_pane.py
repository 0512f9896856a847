#!/usr/bin/env python3
"""make_window_pane.py: writes bench/scenes/window-pane.gltf, window-pane.bin and
window-pane.bake-options, the bench scene of light that only photons carry (Python 3 standard
library only; the room, the sky and the glTF helpers are data/make_outside.py's).

    /usr/bin/python3 bench/scenes/make_window_pane.py [--out DIR]   (default: this script's folder)

The scene is data/window-room (the closed room lit only by data/sky.hdr and its sun through a
window in its +x wall; docs/SCENES.md "Scenes lit from outside") with the window glazed: a
smooth glass pane (KHR_materials_transmission 1, ior 1.5, roughness 0: photonflow's smooth
dielectric) of PANE_THICKNESS filling the opening, a closed slab. Next-event estimation cannot
see the sky or the sun through glass (a shadow ray blocked by anything adds nothing), so every
bit of light in the room arrives by photons (L S S D …), except the sky seen through the pane
from the camera. Photons from the environment leave a disc covering the scene's bounding sphere,
and only those that cross the pane light the room: the case photon guidance is for (issue 50,
"Photons where the camera looks"; docs/RESULTS.md has the measurement).

Bake and render:

    build/bin/scene-bake bench/scenes/window-pane.gltf -o window-pane.h5 --width 512 --height 512
    build/bin/render --scene window-pane.h5 -o window-pane.exr --time 30
"""
import json
import os
import sys

sys.dont_write_bytecode = True
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "data"))
import make_outside as mo  # noqa: E402

PANE_THICKNESS = 0.006  # metres, centred on the wall's plane x = ROOM_X


def pane_meshes():
    """The pane: a closed box of six quads with outward normals spanning the window."""
    x0, x1 = mo.ROOM_X - PANE_THICKNESS / 2, mo.ROOM_X + PANE_THICKNESS / 2
    y0, y1, z0, z1 = mo.WIN_Y0, mo.WIN_Y1, mo.WIN_Z0, mo.WIN_Z1
    uv = [[0, 1], [1, 1], [1, 0], [0, 0]]
    q = mo.quad
    return [
        q([[x0, y0, z0], [x0, y0, z1], [x0, y1, z1], [x0, y1, z0]], [-1, 0, 0], uv),  # inside
        q([[x1, y0, z1], [x1, y0, z0], [x1, y1, z0], [x1, y1, z1]], [1, 0, 0], uv),   # outside
        q([[x0, y0, z0], [x1, y0, z0], [x1, y0, z1], [x0, y0, z1]], [0, -1, 0], uv),  # bottom
        q([[x0, y1, z1], [x1, y1, z1], [x1, y1, z0], [x0, y1, z0]], [0, 1, 0], uv),   # top
        q([[x1, y0, z0], [x0, y0, z0], [x0, y1, z0], [x1, y1, z0]], [0, 0, -1], uv),  # back
        q([[x0, y0, z1], [x1, y0, z1], [x1, y1, z1], [x0, y1, z1]], [0, 0, 1], uv),   # front
    ]


def build():
    """(window-pane JSON, its binary buffer): window-room's parts and the pane."""
    w = mo.ms.GltfWriter()
    pbr = mo.ms.pbr
    ext = {"KHR_materials_transmission": {"transmissionFactor": 1.0},
           "KHR_materials_ior": {"ior": 1.5}}
    glass = pbr("rough glass", [1, 1, 1], 0.0, 0.15, extensions=ext)
    pane_glass = pbr("window glass", [1, 1, 1], 0.0, 0.0, extensions=ext)
    steel = pbr("glossy metal", [0.95, 0.93, 0.88], 1.0, 0.3)
    mats = [pbr("wall", mo.WALL, 0.0, 1.0), pbr("floor", mo.FLOOR, 0.0, 1.0),
            pbr("accent wall", mo.ACCENT, 0.0, 1.0), pbr("box", [0.75, 0.32, 0.18], 0.0, 1.0),
            steel, glass, pane_glass]
    sphere = mo.ms.uv_sphere()
    parts = []
    for name, mesh in mo.window_room_walls():
        parts.append((name, mesh, {"floor": "floor", "left": "accent wall"}.get(name, "wall"), {}))
    parts.append(("box", mo.ms.rounded_box(mo.BOX_HALF, 0.04), "box",
                  mo.placed(mo.BOX_C, None, mo.BOX_YAW)))
    parts.append(("metal ball", sphere, "glossy metal", mo.placed(mo.BALL_C, mo.BALL_R)))
    parts.append(("glass sphere", "metal ball", "rough glass", mo.placed(mo.GLASS_C, mo.GLASS_R)))
    pane = mo.ms.Mesh()
    for m in pane_meshes():  # one mesh of the six faces (each face its own four vertices)
        base = len(pane.pos)
        pane.pos += m.pos
        pane.nrm += m.nrm
        pane.uv += m.uv
        pane.tri += [(a + base, b + base, c + base) for a, b, c in m.tri]
    parts.append(("window pane", pane, "window glass", {}))
    doc = mo.write_scene(w, "window-pane", mats, parts, mo.ROOM_EYE, mo.ROOM_TARGET, mo.ROOM_YFOV)
    doc["asset"]["generator"] = "photonflow bench/scenes/make_window_pane.py"
    doc["buffers"] = [{"uri": "window-pane.bin", "byteLength": len(w.bin)}]
    doc["bufferViews"] = w.views
    doc["accessors"] = w.accessors
    return doc, bytes(w.bin)


def main():
    out = mo.ms.output_folder(__doc__, __file__)
    doc, binary = build()
    options = ("# scene-bake options of bench/scenes/window-pane.gltf (written by\n"
               "# bench/scenes/make_window_pane.py): data/window-room's sky, through glass.\n"
               "# A relative map path is resolved against this file's folder.\n"
               "--environment ../../data/sky.hdr --environment-strength %s\n"
               % mo.num(mo.ROOM_STRENGTH))
    files = {"window-pane.gltf": (json.dumps(doc, indent=1) + "\n").encode(),
             "window-pane.bin": binary, "window-pane.bake-options": options.encode()}
    mo.ms.write_files(out, files)


if __name__ == "__main__":
    main()
