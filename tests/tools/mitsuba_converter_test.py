#!/usr/bin/env python3
"""The Mitsuba converter's test (ctest tools.mitsuba_converter, run by mitsuba_converter_test.sh
with the Mitsuba venv's python): bench/mitsuba/scene_to_mitsuba.py's output renders in Mitsuba 3
to the photonflow image's mean within 1 % on an untextured and a textured scene.

  mitsuba_converter_test.py BIN_DIR SOURCE_DIR WORK_DIR

Scenes, baked at SIZE x SIZE:
  glossy-room  bench/scenes/glossy-room.gltf: diffuse walls, a white metal ball
               (roughconductor), a rough-glass ball (roughdielectric), an area lamp; no textures
  showcase     data/showcase.gltf with its bake options: base-colour textures, a
               metallic-roughness texture, an alpha-masked fence, a gold metal, rough glass, a spot
               light and the thin lens
For each: photonflow `pathtrace` (PT_SPP spp, seed 1) and Mitsuba llvm_ad_rgb (MI_SPP spp, fixed
seed), and per channel |mean(mi) − mean(pt)| ≤ 1 % of mean(pt). The seeds are fixed, so the
result does not change from run to run; the noise of the means is about 0.1 % here, the
converter's remaining model differences 0.1–0.4 % (bench/mitsuba/README.md), and a material
mapped wrongly moves them by far more (the roughplastic first tried for glTF's dielectric: −14 %
on showcase). Prints the means; exit 0 on pass, 1 on failure.
"""
import os
import subprocess
import sys

import numpy as np

SIZE, PT_SPP, MI_SPP, TOL = 64, 1024, 512, 0.01
bin_dir, src, work = sys.argv[1:4]
sys.path.insert(0, os.path.join(src, "bench", "mitsuba"))
import scene_to_mitsuba  # noqa: E402
import drjit as dr  # noqa: E402
import mitsuba as mi  # noqa: E402

mi.set_variant("llvm_ad_rgb")
dr.set_thread_count(2)

SCENES = [("glossy-room", os.path.join(src, "bench", "scenes", "glossy-room.gltf")),
          ("showcase", os.path.join(src, "data", "showcase.gltf"))]


def run(cmd):
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    if r.returncode != 0:
        sys.stdout.write(r.stdout)
        raise SystemExit("mitsuba_converter_test: %s failed (exit %d)" % (cmd[0], r.returncode))
    return r.stdout


def load_rgb(path):
    b = mi.Bitmap(path)
    names = [f.name for f in b.struct_()]
    img = np.array(b, dtype=np.float64)
    return img[:, :, [names.index(c) for c in "RGB"]]


ok = True
for name, source in SCENES:
    d = os.path.join(work, name)
    os.makedirs(d, exist_ok=True)
    h5 = os.path.join(d, "scene.h5")
    run([os.path.join(bin_dir, "scene-bake"), source, "-o", h5, "--width", str(SIZE), "--height", str(SIZE)])
    xml = scene_to_mitsuba.convert(h5, os.path.join(d, "mi"))
    run([os.path.join(bin_dir, "pathtrace"), "--scene", h5, "-o", os.path.join(d, "pt.exr"), "--spp", str(PT_SPP),
         "--seed", "1", "--threads", "2", "--png", "none"])
    pt = load_rgb(os.path.join(d, "pt.exr")).mean(axis=(0, 1))
    scene = mi.load_file(xml, spp=MI_SPP, seed=7)
    img = np.array(mi.render(scene, seed=7, spp=MI_SPP), dtype=np.float64)[:, :, :3]
    m = img.mean(axis=(0, 1))
    rel = (m - pt) / pt
    good = bool(np.all(np.abs(rel) <= TOL))
    ok &= good
    kinds = open(xml).readline().strip()
    print("%-12s %dx%d  mean mi %s (%d spp)  pt %s (%d spp)  (mi-pt)/pt %s  %s\n             %s"
          % (name, SIZE, SIZE, np.array2string(m, precision=4), MI_SPP, np.array2string(pt, precision=4), PT_SPP,
             np.array2string(rel, precision=4), "PASS" if good else "FAIL (limit 1 %)", kinds))
print("mitsuba_converter_test: %s" % ("PASS" if ok else "FAIL"))
sys.exit(0 if ok else 1)
