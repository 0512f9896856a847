#!/usr/bin/env python3
"""Render a Mitsuba 3 scene (from scene_to_mitsuba.py) in passes of K spp with different seeds,
averaged, until a wall-clock budget is reached (Mitsuba's own timeout does not bound llvm renders).
Benchmark-only; never used by photonflow or its tests.

  mi_render.py scene.xml out.exr --time S [--spp-per-pass K] [--seed-base B] [--streams N]
      [--variant llvm_ad_rgb] [--threads 2]

--streams N: N independent averages from disjoint seeds (pass i goes to stream i mod N), each written
to out-s<j>.exr after every pass (checkpoints: a partial run stays usable); with N = 1 the image is
out.exr. With N >= 2 the reference's own error is printed: RMSE(a-b)/sqrt(2) per stream, /2 for the
mean of two (written to out.exr).
DRJIT_LIBLLVM_PATH must name libLLVM 19 for llvm_ad_rgb (../shared/toolchain.md).
"""
import argparse
import json
import os
import time

import numpy as np

ap = argparse.ArgumentParser()
ap.add_argument("scene")
ap.add_argument("output")
ap.add_argument("--time", type=float, required=True)
ap.add_argument("--spp-per-pass", type=int, default=16)
ap.add_argument("--seed-base", type=int, default=1000)
ap.add_argument("--streams", type=int, default=1)
ap.add_argument("--variant", default="llvm_ad_rgb")
ap.add_argument("--threads", type=int, default=2)
a = ap.parse_args()

import drjit as dr
import mitsuba as mi

mi.set_variant(a.variant)
dr.set_thread_count(a.threads)
t0 = time.time()
scene = mi.load_file(a.scene, spp=a.spp_per_pass)
t_load = time.time() - t0
sums = [None] * a.streams
npass = [0] * a.streams
base = os.path.splitext(a.output)[0]


def path(j):
    return a.output if a.streams == 1 else "%s-s%d.exr" % (base, j)


def write(img, p):
    mi.Bitmap(img.astype(np.float32), pixel_format=mi.Bitmap.PixelFormat.RGB).write(p + ".tmp.exr")
    os.replace(p + ".tmp.exr", p)


t1 = time.time()
i = 0
while True:
    j = i % a.streams
    img = np.array(mi.render(scene, seed=a.seed_base + i, spp=a.spp_per_pass), dtype=np.float64)[:, :, :3]
    sums[j] = img if sums[j] is None else sums[j] + img
    npass[j] += 1
    write(sums[j] / npass[j], path(j))
    i += 1
    el = time.time() - t1
    if el >= a.time and j == a.streams - 1:
        break
rec = {"variant": a.variant, "threads": a.threads, "spp_per_pass": a.spp_per_pass, "passes": npass,
       "spp": [p * a.spp_per_pass for p in npass], "render_seconds": el, "load_seconds": t_load,
       "seed_base": a.seed_base}
if a.streams >= 2:
    m = [s / n for s, n in zip(sums, npass)]
    d = np.sqrt(np.mean((m[0] - m[1]) ** 2))
    rec["own_rmse_each"] = d / np.sqrt(2)
    rec["own_rmse_mean_of_two"] = d / 2
    write((m[0] + m[1]) / 2, a.output)
print(json.dumps(rec))
with open(base + ".json", "w") as o:
    json.dump(rec, o, indent=1)
