#!/usr/bin/env python3
"""Measure where scene_to_mitsuba.py's mapping is approximate: render variants of data/showcase.gltf
(pinhole, SIZE x SIZE) in Mitsuba and in photonflow's `pathtrace` (check_converter.py, 2 seeds x
SPP spp each) and print a Markdown table of (mi − pt)/pt, image mean and the mean over the pixels
that see the changed material first, luminance, ± one standard error (from the seeds' spread).

  model_diff.py [--build build] [--out out/mitsuba-model-diff] [--size 128] [--spp 256]
                [--variants exact,gold,...]

Variants (each a glTF written under OUT/<variant>/ beside copies of showcase.bin and the PNGs):
  exact     every approximately mapped material swapped for one that maps exactly: the gold metal
            and the striped box (metallic-roughness texture) as white metals (roughconductor
            material="none"; the box at roughness 0.5 without the texture), the floor tiles and the
            fence at roughness 1 (scene-bake's Lambertian, textured); the spot's falloff as glTF's
  gold      exact + the gold metal (metallic 1, base colour 1, 0.766, 0.336: principled metal)
  plastic   exact + the floor tiles and fence at their roughness 0.8 / 0.9 (glTF's dielectric
            fresnel_mix: the diffuse + coat blend)
  striped   exact + the striped box's metallic-roughness texture and base colour (blend of the two)
  tint      exact + the rough glass tinted (base colour 0.7, 0.85, 1: roughdielectric
            specular_transmittance)
  spot      exact, the spot converted with Mitsuba's own falloff (--spot mitsuba)
  showcase  data/showcase.gltf as it is (pinhole)
Benchmark-only; run with the Mitsuba venv's python (bench/mitsuba/README.md).
"""
import argparse
import copy
import json
import os
import shutil
import subprocess
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)
import scene_to_mitsuba  # noqa: E402
ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
ap.add_argument("--build", default="build")
ap.add_argument("--out", default="out/mitsuba-model-diff")
ap.add_argument("--size", type=int, default=128)
ap.add_argument("--spp", type=int, default=256)
ap.add_argument("--threads", type=int, default=2)
ap.add_argument("--photonflow-only", action="store_true",
                help="write, bake and render the variants in photonflow only (no Mitsuba, no table)")
ap.add_argument("--table-only", action="store_true", help="print the table from the check.json files in OUT")
ap.add_argument("--variants", default="exact,gold,plastic,striped,tint,spot,showcase")
a = ap.parse_args()

SRC = json.load(open(os.path.join(ROOT, "data", "showcase.gltf")))
Y = np.array([0.2126, 0.7152, 0.0722])
# the material each variant changes (by name in the glTF and in scene.h5); for `exact`, its glossy ones
GLOSSY = ["floor tiles", "fence", "gold, glossy metal", "rough glass", "striped metal and plastic"]
CHANGED = {"exact": GLOSSY,
           "gold": ["gold, glossy metal"], "plastic": ["floor tiles", "fence"],
           "striped": ["striped metal and plastic"], "tint": ["rough glass"], "spot": [], "showcase": GLOSSY}
WHAT = {"exact": "all materials mapped exactly (reference row; the gold and striped materials are white "
                 "metals here, the glass untinted)",
        "gold": "coloured metal: principled metal (Schlick F0 = base colour, separable Smith G)",
        "plastic": "dielectric over diffuse (floor 0.8, fence 0.9): blend of diffuse (W = %.4f) and coat"
                   % scene_to_mitsuba.diffuse_weight(1.5),
        "striped": "metallic-roughness texture: blend(metallic; diffuse + coat, principled metal)",
        "tint": "tinted rough glass (0.7, 0.85, 1): roughdielectric specular_transmittance",
        "spot": "spot with Mitsuba's falloff (linear in angle, beam 0.3, cutoff 0.45 rad)",
        "showcase": "data/showcase.gltf as it is (pinhole)"}


def material(doc, name):
    return next(m for m in doc["materials"] if m["name"] == name)


def variant(v):
    doc = copy.deepcopy(SRC)
    if v == "showcase":
        return doc
    restore = CHANGED[v]

    def swap(name, fn):
        if name not in restore:
            fn(material(doc, name)["pbrMetallicRoughness"])
    swap("gold, glossy metal", lambda p: p.update(baseColorFactor=[1.0, 1.0, 1.0, 1.0]))
    swap("floor tiles", lambda p: p.update(roughnessFactor=1.0))
    swap("fence", lambda p: p.update(roughnessFactor=1.0))

    def plain_metal(p):
        p.pop("metallicRoughnessTexture")
        p.update(baseColorFactor=[1.0, 1.0, 1.0, 1.0], metallicFactor=1.0, roughnessFactor=0.5)
    swap("striped metal and plastic", plain_metal)
    if v == "tint":
        material(doc, "rough glass")["pbrMetallicRoughness"]["baseColorFactor"] = [0.7, 0.85, 1.0, 1.0]
    return doc


def lum(x):
    return float(np.dot(Y, x))


def rel(r):
    mi, pt = lum(r["mi"]), lum(r["pt"])
    return 100 * (mi - pt) / pt, 100 * np.sqrt(np.dot(Y ** 2, np.square(r["se"]))) / pt


results = {}
for v in a.variants.split(","):
    d = os.path.join(a.out, v)
    if not a.table_only:
        os.makedirs(d, exist_ok=True)
        for f in ("showcase.bin", "showcase_tiles.png", "showcase_fence.png", "showcase_mr.png"):
            shutil.copyfile(os.path.join(ROOT, "data", f), os.path.join(d, f))
        src = os.path.join(d, "scene.gltf")
        json.dump(variant(v), open(src, "w"), indent=1)
        h5 = os.path.join(d, "scene.h5")
        if not os.path.exists(h5):
            subprocess.run([os.path.join(a.build, "bin", "scene-bake"), src, "--no-options-file", "-o", h5,
                            "--width", str(a.size), "--height", str(a.size)], check=True, stdout=subprocess.DEVNULL)
        cmd = [sys.executable, os.path.join(HERE, "check_converter.py"), "--scene", h5, "--out", d, "--build", a.build,
               "--spp", str(a.spp), "--passes", "0", "--threads", str(a.threads),
               "--spot", "mitsuba" if v == "spot" else "exact"] + (["--photonflow-only"] if a.photonflow_only else [])
        subprocess.run(cmd, stdout=subprocess.DEVNULL)  # its verdict is not this script's: read check.json
        if a.photonflow_only:
            continue
    R = json.load(open(os.path.join(d, "check.json")))["regions"]
    results[v] = {"image": rel(R["mean (all pixels)"]),
                  "materials": {r["name"]: rel(r) for r in R.values() if r.get("name")}}
if a.photonflow_only:
    sys.exit(0)
print("| variant | what differs from `exact` | image mean (mi − pt)/pt, % | the changed materials' pixels: "
      "(mi − pt)/pt, %, and (its change from `exact`) |")
print("|---|---|---|---|")
E = results.get("exact")
for v, res in results.items():
    cells = []
    for name in CHANGED[v]:
        x, se = res["materials"][name]
        c = "%s %+.2f ± %.2f" % (name, x, se)
        if E and v != "exact":
            x0, se0 = E["materials"][name]
            c += " (%+.2f ± %.2f)" % (x - x0, np.hypot(se, se0))
        cells.append(c)
    print("| %s | %s | %+.2f ± %.2f | %s |" % ((v, WHAT[v]) + res["image"] + ("; ".join(cells) or "—",)))
