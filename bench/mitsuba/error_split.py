#!/usr/bin/env python3
"""error_split.py — where the error of a rendering method comes from, from R >= 2 runs of it that
differ only in --seed, against the two-stream references of make_refs.sh.

    error_split.py REF_S0 REF_S1 RUN.exr RUN.exr [RUN.exr ...] [--mask mask.exr] [--blocks 8]
                   [--label NAME] [--region NAME:Y0:Y1:X0:X1] [--outside NAME:Y0:Y1:X0:X1]

Per pixel p (the mean over R, G, B of squared differences), with runs x_1..x_R, their mean m and
the reference mean ref = (s0 + s1) / 2:
    variance    v(p)   = sum_r (x_r - m)^2 / (R - 1)           (one run's noise)
    ref noise   n(p)   = (s0 - s1)^2 / 4                       (the reference mean's own noise)
    bias^2      b(p)   = (m - ref)^2 - v(p) / R - n(p)         (what more runs would not remove)
and a run's expected squared error against the exact image is b + v (its MSE against ref, minus
n). Printed over all pixels and over the mask's pixels (mask > 0.5: the pixels away from the
lights, as equal_time.sh writes it): the means of v, b and n, the RMSE net of the reference's
noise sqrt(b + v), and the share of the variance held by the noisiest 0.1 %, 1 % and 10 % of the
pixels; then, with --blocks B, each block's share of the net squared error and of the variance
(B x B blocks, top row first). bias^2 from few runs is an estimate whose own noise is of the
order of v / R per pixel; its mean over many pixels is what to read. --region adds the pixels of
rows Y0..Y1-1 and columns X0..X1-1 (top row 0) as a region of its own, --outside all pixels but
those (repeatable; the blocks are of the last region, the mask's if none is given).

Reads EXR through Mitsuba's Bitmap (the venv of bench/mitsuba/README.md).
"""
import argparse
import sys

import numpy as np


def load(path):
    import mitsuba as mi
    if not mi.variant():
        mi.set_variant("scalar_rgb")
    return np.array(mi.Bitmap(path), dtype=np.float64)[..., :3]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("ref_s0")
    ap.add_argument("ref_s1")
    ap.add_argument("runs", nargs="+")
    ap.add_argument("--mask", help="mask.exr: pixels > 0.5 are 'away from the lights'")
    ap.add_argument("--blocks", type=int, default=0, help="print B x B block shares")
    ap.add_argument("--label", default="")
    ap.add_argument("--region", action="append", default=[], help="NAME:Y0:Y1:X0:X1, a rectangle")
    ap.add_argument("--outside", action="append", default=[],
                    help="NAME:Y0:Y1:X0:X1, every pixel but the rectangle's")
    a = ap.parse_args()
    if len(a.runs) < 2:
        sys.exit("error_split.py: needs at least two runs (seeds) of the method")
    s0, s1 = load(a.ref_s0), load(a.ref_s1)
    runs = [load(p) for p in a.runs]
    for i, x in enumerate(runs):
        if x.shape != s0.shape:
            sys.exit(f"error_split.py: {a.runs[i]} is {x.shape[1]}x{x.shape[0]}, the reference "
                     f"{s0.shape[1]}x{s0.shape[0]}")
    r = len(runs)
    ref = 0.5 * (s0 + s1)
    m = sum(runs) / r
    v = sum(((x - m) ** 2).mean(axis=2) for x in runs) / (r - 1)
    n = (((s0 - s1) / 2) ** 2).mean(axis=2)
    b = ((m - ref) ** 2).mean(axis=2) - v / r - n
    regions = [("all", np.ones(v.shape, bool))]
    if a.mask:
        regions.append(("away", load(a.mask)[..., 0] > 0.5))
    for spec, inside in [(t, True) for t in a.region] + [(t, False) for t in a.outside]:
        parts = spec.split(":")
        try:
            name, (y0, y1, x0, x1) = parts[0], [int(t) for t in parts[1:]]
        except ValueError:
            sys.exit(f"error_split.py: region '{spec}' is not NAME:Y0:Y1:X0:X1 (integers)")
        rect = np.zeros(v.shape, bool)
        rect[y0:y1, x0:x1] = True
        if not rect.any():
            sys.exit(f"error_split.py: region '{spec}' holds no pixel of the "
                     f"{v.shape[1]}x{v.shape[0]} image")
        regions.append((name, rect if inside else ~rect))
    label = (a.label + " ") if a.label else ""
    for name, sel in regions:
        vs = np.sort(v[sel])[::-1]
        cum = np.cumsum(vs) / max(vs.sum(), 1e-300)
        share = [cum[max(int(q * vs.size) - 1, 0)] for q in (0.001, 0.01, 0.1)]
        vm, bm, nm = v[sel].mean(), b[sel].mean(), n[sel].mean()
        print(f"{label}{name}: runs {r}, pixels {int(sel.sum())}: variance {vm:.3g}, bias^2 "
              f"{bm:.3g} ({bm / (vm + bm):.0%} of the error), reference noise {nm:.3g}; "
              f"net RMSE {np.sqrt(max(vm + bm, 0.0)):.5f}; variance in the noisiest 0.1 % / 1 % / "
              f"10 % of the pixels: {share[0]:.2f} / {share[1]:.2f} / {share[2]:.2f}")
    if a.blocks:
        h, w = v.shape
        k = a.blocks
        sel = regions[-1][1]
        e = np.where(sel, b + v, 0.0)
        vv = np.where(sel, v, 0.0)
        hb, wb = h // k, w // k
        e = e[: hb * k, : wb * k].reshape(k, hb, k, wb).sum(axis=(1, 3))
        vv = vv[: hb * k, : wb * k].reshape(k, hb, k, wb).sum(axis=(1, 3))
        np.set_printoptions(precision=3, suppress=True, linewidth=160)
        print(f"{label}share of the net squared error per block ({regions[-1][0]}, top row first):")
        print(e / e.sum())
        print(f"{label}share of the variance per block:")
        print(vv / vv.sum())


if __name__ == "__main__":
    main()
