#!/usr/bin/env python3
"""Report of pipelines/estimators.mk: error at equal time of path tracing, PPM (one fixed eye pass)
and the estimators with a new eye pass every pass (SPPM, probabilistic PPM), over all pixels and
over the pixels that see no emitter, against long references; and SPPM's error against passes with
a fitted floor.

Every number comes from build/bin/imgcompare (RMSE over RGB values) on the images the pipeline
wrote; run times come from the runs' JSON records (render --stats, pathtrace --stats).
"""
import argparse
import itertools
import json
import math
import os
import re
import subprocess
import sys


def compare_json(imgcompare, test, refs, mask=None):
    """imgcompare's JSON for `test` against the reference whose parts are `refs` (their mean)."""
    cmd = [imgcompare, test] + list(refs) + ["--json", "-"]
    if mask:
        cmd += ["--mask", mask]
    out = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout
    return json.loads(out)


def compare(imgcompare, test, refs, mask=None):
    return compare_json(imgcompare, test, refs, mask)["rmse"]


def reference_parts(d, n):
    """The reference's n parts in a scene's folder: ref.exr, ref2.exr, ..., ref<n>.exr."""
    return [os.path.join(d, "ref.exr" if i == 1 else "ref%d.exr" % i) for i in range(1, n + 1)]


def record_seconds(path):
    """Rendering seconds and passes (or samples) of the last image a run record lists."""
    try:
        with open(path) as f:
            rec = json.load(f)
    except (OSError, ValueError):
        return None, None
    im = rec.get("images", [])
    if not im:
        return None, None
    last = im[-1]
    return last.get("seconds"), last.get("passes", last.get("spp", last.get("samples")))


def fit_floor(points):
    """Least-squares fit of e(k)^2 = c k^(-p) + f^2 (c, f^2 >= 0) over (k, e) points; returns
    (f, p, c). p is searched on a grid, c and f^2 are linear for a given p."""
    best = None
    for i in range(1, 301):
        p = i / 100.0
        xs = [k ** (-p) for k, _ in points]
        ys = [e * e for _, e in points]
        n = len(points)
        sx, sy = sum(xs), sum(ys)
        sxx = sum(x * x for x in xs)
        sxy = sum(x * y for x, y in zip(xs, ys))
        det = n * sxx - sx * sx
        if det == 0:
            continue
        c = (n * sxy - sx * sy) / det
        f2 = (sy - c * sx) / n
        if f2 < 0:  # constrain the floor at 0: c alone
            f2 = 0.0
            c = sxy / sxx
        if c < 0:
            c, f2 = 0.0, sy / n
        res = sum((c * x + f2 - y) ** 2 for x, y in zip(xs, ys))
        if best is None or res < best[0]:
            best = (res, math.sqrt(f2), p, c)
    return best[1], best[2], best[3]


def solve(a, b):
    """Solution of the small linear system a x = b (Gaussian elimination, partial pivoting), or
    None when singular."""
    n = len(b)
    m = [list(a[i]) + [b[i]] for i in range(n)]
    for c in range(n):
        piv = max(range(c, n), key=lambda r: abs(m[r][c]))
        if abs(m[piv][c]) < 1e-300:
            return None
        m[c], m[piv] = m[piv], m[c]
        for r in range(n):
            if r != c:
                f = m[r][c] / m[c][c]
                m[r] = [m[r][k] - f * m[c][k] for k in range(n + 1)]
    return [m[i][n] / m[i][i] for i in range(n)]


def nnls(cols, ys):
    """Non-negative least squares min |X c − y|, c >= 0, for a few columns: the best feasible
    unconstrained fit over every subset of the columns (exact for so few)."""
    n = len(cols)
    best = None
    for r in range(1, n + 1):
        for subset in itertools.combinations(range(n), r):
            a = [[sum(cols[i][t] * cols[j][t] for t in range(len(ys))) for j in subset] for i in subset]
            b = [sum(cols[i][t] * ys[t] for t in range(len(ys))) for i in subset]
            x = solve(a, b)
            if x is None or min(x) < 0:
                continue
            coef = [0.0] * n
            for i, v in zip(subset, x):
                coef[i] = v
            res = sum((sum(coef[i] * cols[i][t] for i in range(n)) - ys[t]) ** 2 for t in range(len(ys)))
            if best is None or res < best[0]:
                best = (res, coef)
    return best[1] if best else [0.0] * n


def fit_kz(points, alpha):
    """The error model of progressive photon mapping (Knaus & Zwicker 2011, section 4: variance
    ∝ k^−α, bias ∝ r_k² ∝ k^−(1−α)) plus a floor: e² = b·k^(−2(1−α)) + v·k^(−α) + f², with b, v,
    f² >= 0 (NNLS). Returns (f, b, v). A floor here is error the estimator's own bias and
    variance do not explain: a fixed eye pass's outline pixels, or a systematic difference from
    the reference."""
    ks = [k for k, _ in points]
    ys = [e * e for _, e in points]
    cols = [[k ** (-2 * (1 - alpha)) for k in ks], [k ** (-alpha) for k in ks], [1.0] * len(ks)]
    b, v, f2 = nnls(cols, ys)
    return math.sqrt(f2), b, v


def curve(imgcompare, snapdir, refs):
    """(passes, RMSE net of the reference's noise, RMSE) of every snapshot in snapdir."""
    pts = []
    if os.path.isdir(snapdir):
        for name in os.listdir(snapdir):
            m = re.fullmatch(r"0*(\d+)\.exr", name)
            if m:
                j = compare_json(imgcompare, os.path.join(snapdir, name), refs)
                pts.append((int(m.group(1)), j["rmse_net"], j["rmse"]))
    return sorted(pts)


def curve_lines(label, pts, e30, alpha):
    """The report's lines for one error-against-passes curve: the values, the local slopes, and
    the two floor fits over k >= 32 on the net error."""
    if len(pts) < 4:
        return []
    out = ["%s against passes (all pixels; RMSE, and net of the reference's noise): " % label +
           ", ".join("%d: %.4f (%.4f)" % (k, e, n) for k, n, e in pts), ""]
    tail = [(k, n) for k, n, _ in pts if k >= 32]
    if len(tail) < 3:
        return out
    # Over about a doubling (snapshots are about √2 apart): every point with the one two later.
    slopes = ["%d→%d: %.2f" % (k1, k2, math.log(max(e2, 1e-12) / max(e1, 1e-12)) / math.log(k2 / k1))
              for (k1, e1), (k2, e2) in zip(tail, tail[2:])]
    ratio = lambda x: "" if not e30 else " (%.2f × the SPPM error at equal time)" % (x / e30)
    f, p, _ = fit_floor(tail)
    fk, b, v = fit_kz(tail, alpha)
    out += ["Local slopes d log e / d log k of the net error: " + ", ".join(slopes) +
            " (SPPM's bias alone would tend to −(1−α) = %.2f, its variance alone to −α/2 = %.2f)."
            % (-(1 - alpha), -alpha / 2), "",
            "Floor fits over k ≥ 32 on the net error: KZ11 model e² = b·k^(−2(1−α)) + v·k^(−α) + f² "
            "(α = %.2g): f = %.4f%s; one free power e² = c·k^(−p) + f²: p = %.2f, f = %.4f%s."
            % (alpha, fk, ratio(fk), p, f, ratio(f)), ""]
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--dir", required=True)
    ap.add_argument("--imgcompare", required=True)
    ap.add_argument("--scenes", required=True)
    ap.add_argument("--methods", required=True)
    ap.add_argument("--ref-parts", default="",
                    help="reference parts per scene: 'scene=N scene=N ...' (default 2 each)")
    ap.add_argument("--alpha", type=float, default=0.7, help="the runs' α (render --alpha)")
    ap.add_argument("--settings", default="")
    ap.add_argument("-o", "--output", required=True)
    a = ap.parse_args()
    scenes, methods = a.scenes.split(), a.methods.split()
    nparts = {k: int(v) for k, v in (kv.split("=") for kv in a.ref_parts.split())}
    lines = ["# Estimators at equal time: all pixels and emitter-masked (pipelines/estimators.mk)", "",
             "Generated by `bench/estimators.py`; settings: `%s`." % " ".join(a.settings.split()), "",
             "RMSE over all pixels (lights included) / over the pixels that see no emitter, against "
             "the reference, the mean of its parts (ref.exr, ref2.exr, ...); `ref. error` is that "
             "mean's own noise estimated from the parts' spread (imgcompare; a bias common to all "
             "parts is not seen), and `ref. error / SPPM` its ratio to the SPPM figure (the "
             "pipeline's aim: below 0.25). Seconds: rendering time of the run (its record); passes "
             "or samples per pixel done.", ""]
    summary = {}
    for s in scenes:
        d = os.path.join(a.dir, s)
        ref = reference_parts(d, nparts.get(s, 2))
        mask = os.path.join(d, "mask.exr")
        if len(ref) < 2:
            sys.exit("estimators.py: %s has one reference part; its noise needs two or more" % d)
        lines += ["## %s" % s, "",
                  "| method | RMSE all pixels | RMSE masked | seconds | passes / spp |",
                  "|---|---:|---:|---:|---:|"]
        ref_all = ref_masked = None
        for m in methods:
            img = os.path.join(d, m + ".exr")
            j_all = compare_json(a.imgcompare, img, ref)
            j_mask = compare_json(a.imgcompare, img, ref, mask)
            e_all, e_mask = j_all["rmse"], j_mask["rmse"]
            ref_all, ref_masked = j_all["reference_rmse"], j_mask["reference_rmse"]
            sec, n = record_seconds(os.path.join(d, m + ".json"))
            summary[(s, m)] = e_all
            lines.append("| %s | %.4f | %.4f | %s | %s |" % (
                m, e_all, e_mask, "%.1f" % sec if sec is not None else "–", n if n is not None else "–"))
        lines.append("| ref. error (%d parts) | %.4f | %.4f | | |" % (len(ref), ref_all, ref_masked))
        if (s, "sppm") in summary:
            lines.append("| ref. error / SPPM | %.2f | | | |" % (ref_all / summary[(s, "sppm")]))
        lines.append("")
        # SPPM, and PPM's fixed eye pass, against passes.
        e30 = summary.get((s, "sppm"))
        for est, label in (("sppm", "SPPM"), ("ppm", "PPM (fixed eye pass)")):
            lines += curve_lines(label, curve(a.imgcompare, os.path.join(d, est + "-passes"), ref),
                                 e30, a.alpha)
        if (s, "pt") in summary:
            base = summary[(s, "pt")]
            lines += ["Ratios to path tracing at equal time (all pixels): " + ", ".join(
                "%s %.2f" % (m, summary[(s, m)] / base) for m in methods if m != "pt"), ""]
    with open(a.output, "w") as f:
        f.write("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    sys.exit(main())
