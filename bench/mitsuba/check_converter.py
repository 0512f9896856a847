#!/usr/bin/env python3
"""Check that scene_to_mitsuba.py gives Mitsuba 3 the scene photonflow renders (issue 34 item 2).

Benchmark-only: run with the Mitsuba venv's python (bench/mitsuba/README.md); no photonflow test
depends on it. For one scene source it bakes scene.h5, converts it, renders

  mi    Mitsuba llvm_ad_rgb, path, max_depth -1, independent sampler: 2 seeds x SPP spp
  pt    photonflow `pathtrace`: 2 seeds x SPP spp (unbiased, the same radiometry as render)
  sppm  photonflow `render` with its defaults: PASSES passes (consistent, biased at finite R)

(images already in OUT are reused) and prints, each with PASS or FAIL:

  camera  the pixels that see an emitter directly: `emitter-mask --max-depth 0` against Mitsuba's pixels
          brighter than half the emitter radiance (orientation, fov, aspect, the emitter's side);
          the two sets must agree but for a ring of outline pixels (Jaccard index >= 0.9);
  mean    the image mean, mi against pt: |difference| <= 4 standard errors (from the seeds'
          spread) + 0.2 %;
  regions the mean over the pixels that see one material first (classified by primary rays at
          the pixel's centre and four corners through Mitsuba's ray caster, so only interior
          pixels count), mi against pt with the same tolerance, and mi against sppm within 3 %
          (SPPM's bias at 64 passes and its correlated noise: reported, the limit generous);
  rmse    RMSE(mi - pt) against the one the seeds' own noise predicts (at most 10 % above it; a
          model difference only adds to it, a ratio below 1 is the noise of the estimate): a
          difference confined to a few pixels (the camera, a flipped normal) shows here.

  check_converter.py --scene data/cornell-box.dae [--build build] [--out DIR] [--size 512]
      [--spp 64] [--passes 64] [--threads 2] [--spot exact|mitsuba] [--bake-arg=--no-options-file]

--passes 0 leaves SPPM out (its checks are not made). check.json holds the verdict, the RMSE
figures and every region's pixel count, means (mi, pt) and standard error of mi − pt per channel
(bench/mitsuba/model_diff.py reads them).

Exit 0 when every check passes, 1 otherwise.
"""
import argparse
import json
import os
import subprocess
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import scene_to_mitsuba  # noqa: E402
import h5py  # noqa: E402

ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
ap.add_argument("--scene", required=True, help="scene source (data/*.dae) or a baked scene.h5")
ap.add_argument("--build", default="build")
ap.add_argument("--out", default=None, help="work folder (default out/mitsuba-check/<scene name>)")
ap.add_argument("--size", type=int, default=512)
ap.add_argument("--spp", type=int, default=64)
ap.add_argument("--passes", type=int, default=64)
ap.add_argument("--threads", type=int, default=2)
ap.add_argument("--spot", choices=["exact", "mitsuba"], default="exact", help="scene_to_mitsuba.py --spot")
ap.add_argument("--photonflow-only", action="store_true",
                help="make photonflow's images and exit (no Mitsuba render, no checks)")
ap.add_argument("--bake-arg", action="append", default=[], help="one more scene-bake argument (repeatable)")
ap.add_argument("--mutate", choices=["fov", "emitter-side", "swap-walls"], default=None,
                help="break the conversion on purpose (fov 2 %% wider; the emitter's triangles flipped; "
                     "materials 1 and 2 exchanged) to show that the checks fail")
a = ap.parse_args()

name = os.path.splitext(os.path.basename(a.scene))[0]
if name == "scene":  # a baked REFS/<name>/scene.h5
    name = os.path.basename(os.path.dirname(os.path.abspath(a.scene)))
out = a.out or os.path.join("out", "mitsuba-check", name)
os.makedirs(out, exist_ok=True)
B = os.path.join(a.build, "bin")


def run(cmd):
    print("+", " ".join(cmd), flush=True)
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)


def need(path, cmd):
    if not os.path.exists(path):
        run(cmd)


h5 = os.path.join(out, "scene.h5")
if a.scene.endswith(".h5"):
    h5 = a.scene
else:
    need(h5, [B + "/scene-bake", a.scene, "-o", h5, "--width", str(a.size), "--height", str(a.size)] + a.bake_arg)
xml = scene_to_mitsuba.convert(h5, os.path.join(out, "mi"), spot=a.spot)
if a.mutate:
    import re
    src = open(xml).read()
    if a.mutate == "fov":
        src = re.sub(r'(name="fov" value=")([0-9.]+)', lambda m: m.group(1) + "%.9g" % (float(m.group(2)) * 1.02), src)
    elif a.mutate == "swap-walls":
        src = src.replace('"mat1.obj"', '"tmp.obj"').replace('"mat2.obj"', '"mat1.obj"').replace('"tmp.obj"', '"mat2.obj"')
    else:
        with h5py.File(h5, "r") as f:
            em_mats = [k for k, m in enumerate(f["materials/materials"][:]) if m["type"] == 3]
        for k in em_mats:
            p = os.path.join(out, "mi", "mat%d.obj" % k)
            lines = open(p).read().splitlines()
            open(p, "w").write("\n".join(re.sub(r"^f (\S+) (\S+) (\S+)$", r"f \1 \3 \2", x) for x in lines) + "\n")
    open(xml, "w").write(src)
T = ["--threads", str(a.threads)]
need(os.path.join(out, "mi-s1.exr") if not a.photonflow_only else h5,
     [sys.executable, os.path.join(HERE, "mi_render.py"), xml, os.path.join(out, "mi.exr"), "--time", "0",
      "--spp-per-pass", str(a.spp), "--streams", "2", "--seed-base", "7001"] + T)
for s in (1, 2):
    need(os.path.join(out, "pt%d.exr" % s),
         [B + "/pathtrace", "--scene", h5, "-o", os.path.join(out, "pt%d.exr" % s), "--spp", str(a.spp),
          "--seed", str(s), "--png", "none"] + T)
if a.passes > 0:
    need(os.path.join(out, "sppm.exr"),
         [B + "/render", "--scene", h5, "-o", os.path.join(out, "sppm.exr"), "--passes", str(a.passes)] + T)
need(os.path.join(out, "mask.exr"),
     [B + "/emitter-mask", "--scene", h5, "-o", os.path.join(out, "mask.exr"), "--spp", "64", "--dilate", "0"] + T)
need(os.path.join(out, "mask-direct.exr"),  # the emitters seen directly (no mirror or glass between)
     [B + "/emitter-mask", "--scene", h5, "-o", os.path.join(out, "mask-direct.exr"), "--spp", "64", "--dilate", "0",
      "--max-depth", "0"] + T)
if a.photonflow_only:
    sys.exit(0)

import drjit as dr  # noqa: E402
import mitsuba as mi  # noqa: E402

mi.set_variant("llvm_ad_rgb")
dr.set_thread_count(a.threads)


def load(p):
    b = mi.Bitmap(p)
    names = [f.name for f in b.struct_()]
    img = np.array(b, dtype=np.float64)
    return img[:, :, [names.index(c) for c in "RGB"]]


mi0, mi1 = load(os.path.join(out, "mi-s0.exr")), load(os.path.join(out, "mi-s1.exr"))
pt1, pt2 = load(os.path.join(out, "pt1.exr")), load(os.path.join(out, "pt2.exr"))
sppm = load(os.path.join(out, "sppm.exr")) if a.passes > 0 else None
mask = load(os.path.join(out, "mask.exr")).mean(axis=2)  # 1 = sees no emitter
mask_direct = load(os.path.join(out, "mask-direct.exr")).mean(axis=2)  # 1 = sees no emitter directly
MI, PT = (mi0 + mi1) / 2, (pt1 + pt2) / 2
# Per-pixel variance of each mean image, from its two seeds: E[(a-b)^2]/4 = var(mean of two).
V = ((mi0 - mi1) ** 2 + (pt1 - pt2) ** 2) / 4
H, W, _ = MI.shape

with h5py.File(h5, "r") as f:
    cam = f["camera"][0]
    mats = f["materials/materials"][:]
    mat_names = [x.decode() if isinstance(x, bytes) else str(x) for x in f["materials/names"][:]]
    tris = f["geometry/triangles"][:]
    if cam["aperture"] > 0:
        raise SystemExit("check_converter: the region check needs a pinhole camera")

# Primary rays through the pixel's centre and four corners (pinhole, x right, y down), classified
# by the material of the first surface; a pixel is in a region when all five agree.
eye = cam["eye"].astype(np.float64)
fw = cam["look_at"] - eye
fw /= np.linalg.norm(fw)
right = np.cross(fw, cam["up"])
right /= np.linalg.norm(right)
up = np.cross(right, fw)
th = np.tan(np.radians(cam["fov_y_deg"]) / 2)
scene = mi.load_file(xml, spp=1)
shape_mat = [int(shp.id()[3:]) if shp.id().startswith("mat") else -1 for shp in scene.shapes()]  # id="mat<K>"
labels = []
yy, xx = np.mgrid[0:H, 0:W].astype(np.float64)
for ox, oy in ((0.5, 0.5), (0.05, 0.05), (0.95, 0.05), (0.05, 0.95), (0.95, 0.95)):
    sx = (2 * (xx + ox) / W - 1) * th * W / H
    sy = (1 - 2 * (yy + oy) / H) * th
    d = fw[None, None] + sx[..., None] * right[None, None] + sy[..., None] * up[None, None]
    d /= np.linalg.norm(d, axis=2, keepdims=True)
    d = d.reshape(-1, 3)
    o = np.broadcast_to(eye, d.shape)
    ray = mi.Ray3f(mi.Point3f(*[mi.Float(o[:, i].astype(np.float32)) for i in range(3)]),
                   mi.Vector3f(*[mi.Float(d[:, i].astype(np.float32)) for i in range(3)]))
    si = scene.ray_intersect(ray)
    lab = np.full(d.shape[0], -1)
    for k, shp in enumerate(scene.shapes()):
        hit = np.array(si.shape == mi.ShapePtr(shp), dtype=bool)
        lab[hit] = shape_mat[k]
    labels.append(lab.reshape(H, W))
labels = np.array(labels)
region = np.where(np.all(labels == labels[0], axis=0), labels[0], -2)  # -2: mixed (an edge)

ok = True


def verdict(good):
    global ok
    ok &= bool(good)
    return "PASS" if good else "FAIL"


print("\n%s: %dx%d, %d spp x 2 seeds (mi, pt), sppm %d passes" % (name, W, H, a.spp, a.passes))
# Camera: emitter pixels.
em = np.asarray(mats["emission"]).max()
# Mitsuba's image has no "seen directly" flag: leave out the pixels whose primary rays (centre or a
# corner) hit a mirror, glass or a glossy (PBR) surface, where the lamp's reflection is as bright.
spec_mats = [k for k in range(len(mats)) if int(mats["type"][k]) in (1, 2, 4)]
spec_px = np.isin(labels, spec_mats).any(axis=0)
mi_light = (MI.max(axis=2) > 0.5 * em) & ~spec_px
pf_light = (mask_direct < 0.5) & ~spec_px
jac = np.sum(mi_light & pf_light) / max(np.sum(mi_light | pf_light), 1)
print("camera  emitter pixels: photonflow %d, Mitsuba %d, both %d, Jaccard %.3f  %s"
      % (pf_light.sum(), mi_light.sum(), np.sum(mi_light & pf_light), jac, verdict(jac >= 0.9)))
rows = np.nonzero(pf_light.any(axis=1))[0]
cols = np.nonzero(pf_light.any(axis=0))[0]
rows_m = np.nonzero(mi_light.any(axis=1))[0]
cols_m = np.nonzero(mi_light.any(axis=0))[0]
if len(rows) and len(rows_m):
    print("        emitter bbox rows %d-%d / %d-%d, columns %d-%d / %d-%d (photonflow / Mitsuba)"
          % (rows[0], rows[-1], rows_m[0], rows_m[-1], cols[0], cols[-1], cols_m[0], cols_m[-1]))


regions = {}


def compare(label, sel, mat_name=None):
    n = sel.sum()
    m_mi, m_pt = MI[sel].mean(axis=0), PT[sel].mean(axis=0)
    se = np.sqrt(V[sel].sum(axis=0)) / n
    tol = 4 * se + 0.002 * np.abs(m_pt)
    good_pt = np.all(np.abs(m_mi - m_pt) <= tol)
    regions[label] = {"name": mat_name, "pixels": int(n), "mi": m_mi.tolist(), "pt": m_pt.tolist(), "se": se.tolist()}
    if sppm is None:
        print("%-24s %7d px  mi %s  pt %s  (mi-pt)/se %s %s  (mi-pt)/pt %s"
              % (label, n, np.array2string(m_mi, precision=4), np.array2string(m_pt, precision=4),
                 np.array2string((m_mi - m_pt) / np.maximum(se, 1e-12), precision=1), verdict(good_pt),
                 np.array2string((m_mi - m_pt) / np.maximum(np.abs(m_pt), 1e-12), precision=4)))
        return
    m_sp = sppm[sel].mean(axis=0)
    rel_sp = np.abs(m_sp - m_mi) / np.maximum(np.abs(m_mi), 1e-6)
    good_sp = np.all(rel_sp <= 0.03)
    print("%-24s %7d px  mi %s  pt %s  (mi-pt)/se %s %s  sppm %s  (sppm-mi)/mi %s %s"
          % (label, n, np.array2string(m_mi, precision=4), np.array2string(m_pt, precision=4),
             np.array2string((m_mi - m_pt) / np.maximum(se, 1e-12), precision=1), verdict(good_pt),
             np.array2string(m_sp, precision=4), np.array2string((m_sp - m_mi) / np.maximum(np.abs(m_mi), 1e-6),
                                                                 precision=3), verdict(good_sp)))


compare("mean (all pixels)", np.ones((H, W), bool))
compare("mean (no emitter seen)", mask >= 0.5)
kinds = {0: "diffuse", 1: "mirror", 2: "glass", 3: "emitter", 4: "pbr"}
for k in range(len(mats)):
    sel = region == k
    if sel.sum() >= 50:
        compare("material %d %s" % (k, kinds.get(int(mats["type"][k]), "?")), sel, mat_names[k])
print("%-24s %7d px" % ("edge pixels (mixed)", np.sum(region == -2)))
d = np.sqrt(np.mean((MI - PT) ** 2))
pred = np.sqrt(np.mean(V))
print("rmse    RMSE(mi - pt) %.5f, predicted from the seeds' spread %.5f, ratio %.3f  %s"
      % (d, pred, d / pred, verdict(d / pred <= 1.1)))
if sppm is not None:
    print("rmse    RMSE(sppm - mi) %.5f (all), %.5f (no emitter seen)"
          % (np.sqrt(np.mean((sppm - MI) ** 2)), np.sqrt(np.mean(((sppm - MI) ** 2)[mask >= 0.5]))))
print("%s: %s" % (name, "all checks PASS" if ok else "some checks FAIL"))
with open(os.path.join(out, "check.json"), "w") as o:
    json.dump({"scene": a.scene, "ok": ok, "jaccard": float(jac), "rmse_mi_pt": float(d), "rmse_pred": float(pred),
               "spp": a.spp, "size": [W, H], "spot": a.spot, "regions": regions}, o, indent=1)
sys.exit(0 if ok else 1)
