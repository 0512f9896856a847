#!/usr/bin/env python3
"""Render a Mitsuba 3 scene (from scene_to_mitsuba.py) in passes of K spp with different seeds,
averaged, until a wall-clock budget is reached (Mitsuba's own timeout does not bound llvm renders).
Benchmark-only; never used by photonflow or its tests.

  mi_render.py scene.xml out.exr --time S [--spp-per-pass K] [--seed-base B] [--streams N]
      [--sampler independent|multijitter|ldsampler|stratified] [--variant llvm_ad_rgb] [--threads 2]

Pass i renders K spp with seed B + i (an independent estimate: Mitsuba's samplers are randomised
per seed) and goes to stream i mod N; a stream's image is its passes' mean weighted by their spp
(the spp the sampler actually took: multijitter rounds K up to a product of its grid, 128 to 132).
With one stream the passes after the first are sized to the time left (at most K spp), so that the
run ends at most about one spp after the budget. The run stops after the first complete round of N passes
that ends at or after S seconds of rendering (scene loading not counted; the first pass includes
Dr.Jit's kernel compilation unless DRJIT_CACHE_DIR holds it already, so equal-time runs warm the
cache first, bench/mitsuba/equal_time.sh).

--streams N: N independent averages from disjoint seeds, each written to out-s<j>.exr after every
round (checkpoints: a partial or killed run stays usable, and --resume continues it), with the run
record out.json (passes, spp, seconds, load average) rewritten after them; with N = 1 the image is
out.exr. With
N >= 2 the record also holds the reference's own error: RMSE(a-b)/sqrt(2) per stream, /2 for the
mean of two, which is written to out.exr.
DRJIT_LIBLLVM_PATH must name libLLVM 19 for llvm_ad_rgb (../shared/toolchain.md).
"""
import argparse
import json
import math
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
ap.add_argument("--sampler", default="independent")
ap.add_argument("--variant", default="llvm_ad_rgb")
ap.add_argument("--threads", type=int, default=2)
ap.add_argument("--resume", action="store_true",
                help="continue the streams of out.json (same scene, sampler, spp per pass, seed base, "
                     "streams): their images are read back and the seeds go on where they stopped")
a = ap.parse_args()

import drjit as dr
import mitsuba as mi

mi.set_variant(a.variant)
dr.set_thread_count(a.threads)
t0 = time.time()
scene = mi.load_file(a.scene, spp=a.spp_per_pass, sampler=a.sampler)
t_load = time.time() - t0
sampler = scene.sensors()[0].sampler()
sums = [None] * a.streams  # per stream: sum of pass image x pass spp
npass = [0] * a.streams
nspp = [0] * a.streams
base = os.path.splitext(a.output)[0]
load_start = os.getloadavg()[0]
done_seconds = 0.0
if a.resume and os.path.exists(base + ".json"):
    old = json.load(open(base + ".json"))
    for k in ("sampler", "spp_per_pass", "seed_base", "variant"):
        if old[k] != getattr(a, k):
            raise SystemExit("mi_render.py: --resume: %s.json has %s %r, this run %r" % (base, k, old[k], getattr(a, k)))
    if len(old["passes"]) != a.streams or len(set(old["passes"])) != 1:
        raise SystemExit("mi_render.py: --resume: %s.json has passes %r for %d streams" % (base, old["passes"], a.streams))
    for j in range(a.streams):
        b = mi.Bitmap(a.output if a.streams == 1 else "%s-s%d.exr" % (base, j))
        npass[j], nspp[j] = old["passes"][j], old["spp"][j]
        sums[j] = np.array(b, dtype=np.float64)[:, :, :3] * nspp[j]
    done_seconds = old["render_seconds"]


def path(j):
    return a.output if a.streams == 1 else "%s-s%d.exr" % (base, j)


def write(img, p):
    mi.Bitmap(img.astype(np.float32), pixel_format=mi.Bitmap.PixelFormat.RGB).write(p + ".tmp.exr")
    os.replace(p + ".tmp.exr", p)


def record(el, final):
    rec = {"scene": os.path.abspath(a.scene), "variant": a.variant, "sampler": a.sampler, "threads": a.threads,
           "spp_per_pass": a.spp_per_pass, "passes": npass, "spp": nspp,
           "render_seconds": el + done_seconds, "load_seconds": t_load, "seed_base": a.seed_base, "final": final,
           "loadavg_1min_start": load_start, "loadavg_1min_now": os.getloadavg()[0],
           "mitsuba": mi.__version__, "drjit": dr.__version__}
    if a.streams >= 2:
        m = [s / n for s, n in zip(sums, nspp)]
        d = np.sqrt(np.mean((m[0] - m[1]) ** 2))
        rec["own_rmse_each"] = d / np.sqrt(2)
        rec["own_rmse_mean_of_two"] = d / 2
        write((m[0] + m[1]) / 2, a.output)
    with open(base + ".json.tmp", "w") as o:
        json.dump(rec, o, indent=1)
    os.replace(base + ".json.tmp", base + ".json")
    return rec


t1 = time.time()
i = sum(npass)
k = a.spp_per_pass
while True:
    j = i % a.streams
    tp = time.time()
    img = np.array(mi.render(scene, seed=a.seed_base + i, spp=k), dtype=np.float64)[:, :, :3]
    k_done = sampler.sample_count()  # multijitter rounds k up to a product of its grid (128 -> 132)
    img *= k_done
    sums[j] = img if sums[j] is None else sums[j] + img
    npass[j] += 1
    nspp[j] += k_done
    i += 1
    el = time.time() - t1
    if a.streams == 1 and a.time > el:
        # Equal-time runs: size the next pass to the time left (at the last pass's seconds per
        # spp), so that the run ends at most about one spp after the budget, as photonflow's runs
        # end after the pass that reaches it.
        per_spp = (time.time() - tp) / k_done
        k = int(min(a.spp_per_pass, max(1, math.ceil((a.time - el) / per_spp))))
    if (i % a.streams) == 0:  # a round: every stream has the same passes; checkpoint them
        for q in range(a.streams):
            write(sums[q] / nspp[q], path(q))
        if el >= a.time:
            break
        record(el, False)
print(json.dumps(record(el, True)))
