#!/usr/bin/env python3
"""Render a Mitsuba 3 scene (from scene_to_mitsuba.py) in ONE mi.render call of N spp, N calibrated
so that the call takes about a wall-clock budget: Mitsuba's best at equal time
(../shared/toolchain.md "Mitsuba 3 as a comparator": passes of 16 spp with new seeds lose most of
a stratified sampler's stratification and pay a call overhead each). Benchmark-only; never used by
photonflow or its tests.

  mi_render1.py scene.xml out.exr --time S [--sampler multijitter] [--seed 1] [--threads 2]
      [--variant llvm_ad_rgb] [--calib-spp 4]

Calibration (not counted in the budget, as the kernel compilation the warm-up renders of
equal_time.sh keep out): a call of C spp (--calib-spp; its seconds include loading Dr.Jit's cached
kernel), the same again (t1 at n1 = the spp the sampler took), then one sized at that rate to a
tenth of the budget (t2 at n2); the line t = a + b·n through the two gives
N = ⌊(S − a)/b⌋ (at least 1; lowered until the count the sampler rounds it to is at most
that). The calibration calls use seeds other than the final one. Then one
call of N spp with --seed is rendered and timed: its own seconds (the film developed, the image
copied out) are the run's `render_seconds`, reported as they came, above or below S (a sampler that
rounds N, multijitter to a product of its grid, takes the spp it rounds to: `spp` is that count).
The record out.json holds N, the spp taken, render_seconds, the calibration points, the load
average before and after, and the versions.
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
ap.add_argument("--sampler", default="multijitter")
ap.add_argument("--seed", type=int, default=1)
ap.add_argument("--variant", default="llvm_ad_rgb")
ap.add_argument("--threads", type=int, default=2)
ap.add_argument("--calib-spp", type=int, default=4)
a = ap.parse_args()

import drjit as dr  # noqa: E402
import mitsuba as mi  # noqa: E402

mi.set_variant(a.variant)
dr.set_thread_count(a.threads)
load_start = os.getloadavg()[0]
t0 = time.time()
scene = mi.load_file(a.scene, spp=a.calib_spp, sampler=a.sampler)
t_load = time.time() - t0
sampler = scene.sensors()[0].sampler()


def timed(spp, seed):
    t = time.time()
    img = mi.render(scene, seed=seed, spp=spp)
    out = np.array(img, dtype=np.float32)[:, :, :3]  # forces the evaluation
    return time.time() - t, sampler.sample_count(), out


calib_seed = a.seed + 0x40000000  # never one of the final calls' seeds (small run numbers)
t_first, _, _ = timed(a.calib_spp, calib_seed)
t1, n1, _ = timed(a.calib_spp, calib_seed + 1)
n2_want = max(n1 + 1, int(round(0.1 * a.time * n1 / max(t1, 1e-6))))
t2, n2, _ = timed(n2_want, calib_seed + 2)
b = max((t2 - t1) / max(n2 - n1, 1), 1e-9)
a0 = max(t1 - b * n1, 0.0)
N = max(1, int(math.floor((a.time - a0) / b)))
# A sampler that rounds the count up (multijitter: to a product of its grid, 292 -> 306) would
# overshoot the budget: take the largest request whose rounded count is at most N.
target = N
sampler.set_sample_count(N)
while N > 1 and sampler.sample_count() > target:
    N -= 1
    sampler.set_sample_count(N)
load_before = os.getloadavg()[0]
seconds, taken, img = timed(N, a.seed)
mi.Bitmap(img, pixel_format=mi.Bitmap.PixelFormat.RGB).write(a.output)
rec = {"scene": os.path.abspath(a.scene), "variant": a.variant, "sampler": a.sampler, "threads": a.threads,
       "method": "one mi.render call", "seed": a.seed, "budget_seconds": a.time,
       "spp_target": target, "spp_requested": N, "spp": [taken], "passes": [1], "render_seconds": seconds, "load_seconds": t_load,
       "calibration": {"first_call": [a.calib_spp, t_first], "points": [[n1, t1], [n2, t2]],
                       "overhead_seconds": a0, "seconds_per_spp": b},
       "loadavg_1min_start": load_start, "loadavg_1min_before_call": load_before,
       "loadavg_1min_now": os.getloadavg()[0], "mitsuba": mi.__version__, "drjit": dr.__version__}
with open(os.path.splitext(a.output)[0] + ".json", "w") as o:
    json.dump(rec, o, indent=1)
print(json.dumps(rec))
