#!/usr/bin/python3
"""accuracy.py — metrics, tables and charts of the speed–accuracy pipeline (pipelines/accuracy.mk).

  accuracy.py collect --imgcompare BIN/imgcompare (--record RUN.json | --classic DIR)
                      --reference REF.exr --mask MASK.exr --scene NAME --method M --label L
                      [--alpha A] [--load RUN.load] -o RUN.tsv
      One row per image of a run: the run record of `pathtrace --stats` or `render --stats`
      gives each image's samples or passes and its rendering seconds; `imgcompare --json -`
      gives its error against the reference over the mask. --classic reads a folder of classic
      photon-mapping images classic-<photons>-<k>.exr and the wall times of their processes
      (*.time files of /usr/bin/time -f %e).

  accuracy.py report --dir OUT/accuracy --res docs/results --scenes "a b c" --alphas "0.5 ..."
                     --settings "W=128 ..."
      Reads every <scene>/*.tsv, fits the log–log slopes of RMSE against passes, interpolates
      errors at equal time, and writes docs/results/accuracy.md (generated tables) and the charts
      accuracy-time.png, accuracy-passes.png, accuracy-alpha.png, accuracy-images.png.

Slope theory (Knaus & Zwicker 2011, "Progressive photon mapping: a probabilistic approach",
also the radius schedule of thesis eq. 3.16): with R_i² ∝ i^(α−1) the bias of the estimate falls
as R² ∝ i^(α−1) and its variance as i^(−α), so RMSE ∝ i^(−min(α/2, 1−α)): −1/3 at α = 2/3, the
fastest rate; −α/2 (variance-bound) below 2/3, −(1−α) (bias-bound) above.
"""
import argparse
import csv
import glob
import json
import math
import os
import subprocess
import sys

COLUMNS = ["scene", "method", "label", "alpha", "eye_spp", "x", "photons", "k", "seconds", "rmse",
           "relmse", "mae", "ssim", "mean_radius", "load_before", "load_after", "image"]


def imgcompare(tool, image, reference, mask):
    cmd = [tool, image, reference, "--json", "-"]
    if mask:
        cmd += ["--mask", mask]
    out = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout
    return json.loads(out)


def read_load(path):
    """1-minute load averages recorded before and after a run (/proc/loadavg lines)."""
    if not path or not os.path.exists(path):
        return "", ""
    lines = [l.split() for l in open(path) if l.strip()]
    if not lines:
        return "", ""
    return lines[0][0], lines[-1][0]


def collect(a):
    rows = []
    load0, load1 = read_load(a.load)
    base = dict(scene=a.scene, method=a.method, label=a.label, alpha=a.alpha, k="", eye_spp="",
                load_before=load0, load_after=load1, mean_radius="")
    if a.record:
        rec = json.load(open(a.record))
        pathtrace = rec["tool"] == "pathtrace"
        base["eye_spp"] = "" if pathtrace else rec["parameters"].get("spp", "")
        seen = set()
        for im in rec["images"]:
            x = im["samples"] if pathtrace else im["passes"]
            if x in seen:  # the final image repeats the last snapshot
                continue
            seen.add(x)
            m = imgcompare(a.imgcompare, im["path"], a.reference, a.mask)
            r = dict(base)
            r.update(x=x, seconds=im["seconds"], image=im["path"],
                     photons=0 if pathtrace else im["photons_emitted"],
                     mean_radius="" if pathtrace else im["mean_radius"],
                     rmse=m["rmse"], relmse=m["relmse"], mae=m["mae"], ssim=m["ssim"])
            rows.append(r)
    else:
        d = a.classic
        t = lambda name: float(open(os.path.join(d, name)).read().split()[-1])
        for path in sorted(glob.glob(os.path.join(d, "classic-*-*.exr"))):
            n, k = os.path.basename(path)[len("classic-"):-len(".exr")].split("-")
            seconds = t("hp.time") + t(f"ph-{n}.time") + t(f"ill-{n}-{k}.time") + t(f"syn-{n}-{k}.time")
            m = imgcompare(a.imgcompare, path, a.reference, a.mask)
            r = dict(base)
            r.update(x=1, photons=int(n), k=int(k), seconds=seconds, image=path, eye_spp=a.eye_spp,
                     label=f"classic-{n}-{k}", rmse=m["rmse"], relmse=m["relmse"], mae=m["mae"],
                     ssim=m["ssim"])
            rows.append(r)
        rows.sort(key=lambda r: (r["photons"], r["k"]))
    tmp = a.output + ".tmp"
    with open(tmp, "w", newline="") as f:
        w = csv.DictWriter(f, COLUMNS, delimiter="\t")
        w.writeheader()
        for r in rows:
            w.writerow(r)
    os.replace(tmp, a.output)
    print(f"accuracy.py: {a.output}: {len(rows)} images")


# ---- report -------------------------------------------------------------------------------------

def load_rows(d, scenes):
    rows = []
    for s in scenes:
        for path in sorted(glob.glob(os.path.join(d, s, "*.tsv"))):
            with open(path) as f:
                for r in csv.DictReader(f, delimiter="\t"):
                    for c in ("x", "photons", "seconds", "rmse", "relmse", "mae", "ssim"):
                        r[c] = float(r[c])
                    r["k"] = int(r["k"]) if r["k"] else 0
                    r["mean_radius"] = float(r["mean_radius"]) if r["mean_radius"] else float("nan")
                    rows.append(r)
    return rows


def series(rows, scene, label):
    s = [r for r in rows if r["scene"] == scene and r["label"] == label]
    return sorted(s, key=lambda r: r["x"])


def fit_slope(points):
    """Least-squares slope and intercept of log(y) against log(x)."""
    if len(points) < 2:
        return float("nan"), float("nan")
    lx = [math.log(x) for x, _ in points]
    ly = [math.log(y) for _, y in points]
    mx, my = sum(lx) / len(lx), sum(ly) / len(ly)
    sxx = sum((u - mx) ** 2 for u in lx)
    if sxx == 0:
        return float("nan"), float("nan")
    b = sum((u - mx) * (v - my) for u, v in zip(lx, ly)) / sxx
    return b, my - b * mx


def fit_with_floor(points):
    """Fits RMSE(i)² = A²·i^(−2s) + F² (a power law that falls to a constant floor F: the part of
    the error that more photon passes cannot remove — the eye pass's fixed samples, the
    reference's own error) by least squares on log RMSE. Returns (s, F) or (nan, nan)."""
    import numpy as np
    from scipy.optimize import least_squares
    pts = [(x, y) for x, y in points if y > 0]
    if len(pts) < 4:
        return float("nan"), float("nan")
    x = np.array([p[0] for p in pts], float)
    y = np.log(np.array([p[1] for p in pts], float))

    def resid(q):
        la, sl, lf = q
        return 0.5 * np.logaddexp(2 * la - 2 * sl * np.log(x), 2 * lf) - y

    best = None
    for f0 in (0.1, 0.5, 0.9):  # a few starts: floors well below and near the last error
        q0 = [y[0], 0.3, y[-1] + math.log(f0)]
        r = least_squares(resid, q0, bounds=([-50, 0.0, -50], [50, 2.0, 50]))
        if best is None or r.cost < best.cost:
            best = r
    return float(best.x[1]), float(math.exp(best.x[2]))


def slope_in(s, lo, hi):
    return fit_slope([(r["x"], r["rmse"]) for r in s if lo <= r["x"] <= hi and r["rmse"] > 0])[0]


def at_time(s, t):
    """RMSE at wall time t by log–log interpolation between a run's snapshots; None outside."""
    pts = sorted((r["seconds"], r["rmse"]) for r in s)
    for (t0, e0), (t1, e1) in zip(pts, pts[1:]):
        if t0 <= t <= t1 and t0 > 0:
            if t1 == t0:
                return e0
            f = (math.log(t) - math.log(t0)) / (math.log(t1) - math.log(t0))
            return math.exp(math.log(e0) + f * (math.log(e1) - math.log(e0)))
    return None


def fmt(v, digits=4):
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return "–"
    if isinstance(v, float):
        if v != 0 and (abs(v) < 1e-3 or abs(v) >= 1e5):
            return f"{v:.{digits - 1}e}"
        return f"{v:.{digits}g}"
    return str(v)


def theory_slope(alpha):
    return -min(alpha / 2.0, 1.0 - alpha)


def finish_axes(ax, heading, xlabel, **legend):
    """The look every RMSE chart shares: heading, axis labels, log grid, small legend (legend
    options such as its own title pass through)."""
    ax.set_title(heading)
    ax.set_xlabel(xlabel)
    ax.set_ylabel("RMSE (masked)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, **legend)


def save_figure(fig, res, name):
    import matplotlib.pyplot as plt  # imported where charts are drawn, as in report()
    fig.tight_layout()
    fig.savefig(os.path.join(res, name), dpi=110)
    plt.close(fig)


def report(a):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.image as mpimg

    scenes = a.scenes.split()
    alphas = a.alphas.split()
    rows = load_rows(a.dir, scenes)
    os.makedirs(a.res, exist_ok=True)
    labels_cl = sorted({r["label"] for r in rows if r["method"].startswith("cl-")})
    # The estimators with a new eye pass every pass (ESTIMATORS of accuracy.mk), when run.
    labels_new = [e for e in ("sppm", "pppm") if any(r["label"] == e for r in rows)]
    styles = {"pt": ("tab:red", "o"), "ppm": ("tab:blue", "s"),
              "cl-hash-grid": ("tab:green", "^"), "cl-grid-kmeans": ("tab:purple", "v"),
              "ppm-ref": ("tab:gray", "x"), "sppm": ("tab:brown", "P"), "pppm": ("tab:olive", "X")}
    names = {"pt": "path tracing", "ppm": "PPM CPU grid (α 0.7)",
             "cl-hash-grid": "PPM OpenCL hash-grid", "cl-grid-kmeans": "PPM OpenCL grid-kmeans",
             "ppm-ref": "PPM reference recipe", "sppm": "SPPM CPU (α 0.7)",
             "pppm": "probabilistic PPM CPU (α 0.7)"}
    out = []
    w = out.append
    w("# Speed against accuracy: generated tables\n")
    w("Written by `bench/accuracy.py report` (pipelines/accuracy.mk); do not edit by hand. "
      "[RESULTS.md](../RESULTS.md) discusses these numbers.\n")
    w(f"Settings: `{' '.join(a.settings.split())}`.\n")
    w("Error: imgcompare's RMSE (linear RGB, W/(sr·m²)) over the pixels that see no emitter "
      "(emitter-mask), against each scene's reference. Times: rendering wall seconds from the run "
      "records (render and pathtrace `--stats`; for classic PM the wall time of its four "
      "processes).\n")
    loads = [float(r["load_before"]) for r in rows if r["load_before"]] + \
            [float(r["load_after"]) for r in rows if r["load_after"]]
    if loads:
        w(f"Load: the 1-minute load average read before and after each run was "
          f"{min(loads):.2f}–{max(loads):.2f} on this machine's {os.cpu_count()} cores "
          f"(other work was running); absolute times are upper bounds, ratios within a scene "
          f"are the robust figures.\n")

    # -- final errors
    w("## Final error of each run\n")
    w("| scene | run | eye spp | passes or spp | photons emitted | seconds | RMSE | relMSE | SSIM |")
    w("|---|---|---:|---:|---:|---:|---:|---:|---:|")
    for s in scenes:
        for lab in ["pt", "ppm"] + labels_new + labels_cl + ["ppm-ref"]:
            ser = series(rows, s, lab)
            if not ser:
                continue
            r = ser[-1]
            w(f"| {s} | {names.get(lab, lab)} | {r['eye_spp'] or '–'} | {int(r['x'])} | "
              f"{int(r['photons']) or '–'} | "
              f"{r['seconds']:.2f} | {fmt(r['rmse'])} | {fmt(r['relmse'])} | {fmt(r['ssim'])} |")
    w("")

    # -- equal time
    w("## Error at equal time\n")
    w("RMSE interpolated (log–log) at the same rendering seconds; `–` where a run did not span "
      "that time. Ratio = PPM (CPU) ÷ path tracing.\n")
    w("| scene | seconds | path tracing | PPM CPU α 0.7 | " +
      " | ".join(names.get(l, l) for l in labels_new + labels_cl) + " | PPM ÷ PT |")
    w("|---|---:|---:|---:|" + "---:|" * len(labels_new + labels_cl) + "---:|")
    equal_time = {}
    for s in scenes:
        pt, ppm = series(rows, s, "pt"), series(rows, s, "ppm")
        for t in (0.5, 1.0, 2.0, 5.0, 10.0, 20.0):
            e_pt, e_ppm = (at_time(pt, t) if pt else None), (at_time(ppm, t) if ppm else None)
            cls = [at_time(series(rows, s, l), t) for l in labels_new + labels_cl]
            if e_pt is None and e_ppm is None:
                continue
            ratio = e_ppm / e_pt if e_pt and e_ppm else None
            equal_time[(s, t)] = ratio
            w(f"| {s} | {t:g} | {fmt(e_pt)} | {fmt(e_ppm)} | " + " | ".join(fmt(c) for c in cls) +
              f" | {fmt(ratio, 3)} |")
    w("")

    # -- slopes
    w("## Log–log slope of RMSE against passes\n")
    w("Least-squares slope of log RMSE against log passes over the snapshots in each window. "
      "Theory: −min(α/2, 1−α) (module docstring of bench/accuracy.py), the limit of many passes "
      "against an exact reference. The last two columns fit RMSE² = A²·i^(−2s) + F² over passes "
      "≥ 2: s is the slope once the error floor F (what more passes cannot remove: the fixed eye "
      "samples, the reference's own error) is taken out. `ppm` rows: the main runs (EYE_SPP of the "
      "scene); α rows: the sweep (SWEEP_EYE_SPP).\n")
    last = max((r["x"] for r in rows if r["method"].startswith("ppm")), default=0)
    wins = [(1, last), (1, 16), (16, last), (64, last)]
    w("| scene | run | theory | " + " | ".join(f"passes {lo}–{int(hi)}" for lo, hi in wins) +
      " | RMSE at 1 pass | RMSE at the end | fit: s | fit: floor F |")
    w("|---|---|---:|" + "---:|" * len(wins) + "---:|---:|---:|---:|")
    slopes = {}
    for s in scenes:
        for lab, al in [("ppm", "0.7")] + [(f"ppm-a{al}", al) for al in alphas]:
            ser = series(rows, s, lab)
            if not ser:
                continue
            sl = [slope_in(ser, lo, hi) for lo, hi in wins]
            fs, ff = fit_with_floor([(r["x"], r["rmse"]) for r in ser if r["x"] >= 2])
            slopes[(s, lab)] = sl + [fs, ff]
            name = f"ppm (α 0.7, eye spp {ser[0]['eye_spp']})" if lab == "ppm" else f"α {al}"
            w(f"| {s} | {name} | {theory_slope(float(al)):.3f} | " +
              " | ".join(fmt(v, 3) for v in sl) +
              f" | {fmt(ser[0]['rmse'])} | {fmt(ser[-1]['rmse'])} | {fmt(-fs, 3)} | {fmt(ff)} |")
    w("")
    w("Path tracing, slope of RMSE against samples per pixel (theory −1/2 while its noise is "
      "above the reference's error):\n")
    w("| scene | spp 8–128 | spp 128–1024 | spp 8–1024 |")
    w("|---|---:|---:|---:|")
    for s in scenes:
        ser = series(rows, s, "pt")
        if ser:
            w(f"| {s} | {fmt(slope_in(ser, 8, 128), 3)} | {fmt(slope_in(ser, 128, 1024), 3)} | "
              f"{fmt(slope_in(ser, 8, 1024), 3)} |")
    w("")

    # -- the references' own error, seen by path tracing
    w("## The references' own error, seen by path tracing\n")
    w("Path tracing is unbiased, so against a reference with error E (its distance from the true "
      "image) its expected squared error is a²/spp + E². A least-squares line of RMSE² against "
      "1/spp (snapshots with spp ≥ 64) gives E² as the intercept. For the path-traced reference of "
      "the box, E is that reference's noise (expected: the run's own noise at REF_SPP); for the "
      "PPM references it is their bias and noise together, and it bounds how far the PPM runs' "
      "floors (the fit above) can be their own.\n")
    w("| scene | reference | a (RMSE at 1 spp) | E: the reference's error | PT RMSE at the end | "
      "PT RMSE at the end with E taken out |")
    w("|---|---|---:|---:|---:|---:|")
    ref_err = {}
    for s in scenes:
        ser = [r for r in series(rows, s, "pt") if r["x"] >= 64]
        if len(ser) < 3:
            continue
        import numpy as np
        x = np.array([r["x"] for r in ser])
        y2 = np.array([r["rmse"] ** 2 for r in ser])
        A = np.vstack([1.0 / x, np.ones_like(x)]).T
        (a2, e2), *_ = np.linalg.lstsq(A, y2, rcond=None)
        e = math.sqrt(max(e2, 0.0))
        ref_err[s] = e
        last = ser[-1]["rmse"]
        rec = os.path.join(a.dir, s, "ref.json")
        tool = json.load(open(rec))["tool"] if os.path.exists(rec) else ""
        kind = {"pathtrace": "path tracing", "render": "long PPM run"}.get(tool, "?")
        w(f"| {s} | {kind} | {fmt(math.sqrt(max(a2, 0.0)))} | {fmt(e)} | {fmt(last)} | "
          f"{fmt(math.sqrt(max(last ** 2 - e * e, 0.0)))} |")
    w("")

    # -- classic
    w("## Classic photon mapping\n")
    w("One photon pass of N photons, k nearest global photons (eq. 3.10), caustic map with the "
      "fixed radius R0, direct light by shadow rays, the scene's eye samples per pixel. PPM "
      "column: the main CPU PPM run (α 0.7) at the same seconds.\n")
    w("| scene | photons N | k | seconds | RMSE | PPM at that time |")
    w("|---|---:|---:|---:|---:|---:|")
    for s in scenes:
        ppm = series(rows, s, "ppm")
        for r in sorted([r for r in rows if r["scene"] == s and r["method"] == "classic"],
                        key=lambda r: (r["photons"], r["k"])):
            w(f"| {s} | {int(r['photons'])} | {r['k']} | {r['seconds']:.2f} | {fmt(r['rmse'])} | "
              f"{fmt(at_time(ppm, r['seconds']) if ppm else None)} |")
    w("")

    # -- refcheck
    rc = series(rows, "cornell-box", "ppm-ref")
    if rc:
        w("## The PPM reference recipe on the diffuse box\n")
        w("The recipe of the caustic scenes' references (REF_PASSES × REF_PHOTONS, REF_EYE_SPP eye "
          "samples) rendered on the diffuse box and compared with its path-traced reference: the "
          "error such a reference itself carries.\n")
        w("| passes | photons emitted | seconds | mean radius | RMSE |")
        w("|---:|---:|---:|---:|---:|")
        for r in rc:
            w(f"| {int(r['x'])} | {int(r['photons'])} | {r['seconds']:.1f} | "
              f"{fmt(r['mean_radius'])} | {fmt(r['rmse'])} |")
        w("")

    # -- charts
    n = len(scenes)
    fig, axes = plt.subplots(1, n, figsize=(5.2 * n, 4.4), squeeze=False)
    for ax, s in zip(axes[0], scenes):
        for lab in ["pt", "ppm"] + labels_new + labels_cl:
            ser = series(rows, s, lab)
            if ser:
                c, m = styles.get(lab, ("black", "."))
                ax.loglog([r["seconds"] for r in ser], [r["rmse"] for r in ser], marker=m,
                          ms=3, color=c, label=names.get(lab, lab))
        cl = [r for r in rows if r["scene"] == s and r["method"] == "classic"]
        if cl:
            ax.scatter([r["seconds"] for r in cl], [r["rmse"] for r in cl], color="tab:orange",
                       marker="D", s=18, label="classic PM (N, k)", zorder=3)
            for r in cl:
                ax.annotate(f"{int(r['photons']) // 1000}k,{r['k']}", (r["seconds"], r["rmse"]),
                            fontsize=6, xytext=(3, 2), textcoords="offset points")
        finish_axes(ax, s, "rendering wall time (s)")
    save_figure(fig, a.res, "accuracy-time.png")

    fig, axes = plt.subplots(1, n, figsize=(5.2 * n, 4.4), squeeze=False)
    for ax, s in zip(axes[0], scenes):
        ppm = series(rows, s, "ppm")
        pt = series(rows, s, "pt")
        if ppm:
            xs = [r["x"] for r in ppm]
            ax.loglog(xs, [r["rmse"] for r in ppm], "s-", ms=3, color="tab:blue",
                      label="PPM α 0.7 (x = passes)")
            b, c0 = fit_slope([(r["x"], r["rmse"]) for r in ppm if r["x"] >= 16])
            if not math.isnan(b):
                ax.loglog([16, xs[-1]], [math.exp(c0) * 16 ** b, math.exp(c0) * xs[-1] ** b], "--",
                          color="tab:blue", lw=1, label=f"fit, passes ≥ 16: {b:.3f}")
            x0, y0 = xs[0], ppm[0]["rmse"]
            ax.loglog([x0, xs[-1]], [y0, y0 * (xs[-1] / x0) ** (-1 / 3)], ":", color="black",
                      lw=1, label="slope −1/3")
        for lab in labels_new + labels_cl:
            ser = series(rows, s, lab)
            if ser:
                c, m = styles.get(lab, ("black", "."))
                ax.loglog([r["x"] for r in ser], [r["rmse"] for r in ser], marker=m, ms=3,
                          color=c, lw=0.8, label=names.get(lab, lab) + " (passes)")
        if pt:
            ax.loglog([r["x"] for r in pt], [r["rmse"] for r in pt], "o-", ms=2, color="tab:red",
                      label="path tracing (x = spp)")
            x0, y0 = pt[0]["x"], pt[0]["rmse"]
            ax.loglog([x0, pt[-1]["x"]], [y0, y0 * (pt[-1]["x"] / x0) ** (-0.5)], "-.",
                      color="tab:red", lw=0.8, label="slope −1/2")
        finish_axes(ax, s, "photon passes (PPM) or samples per pixel (PT)")
    save_figure(fig, a.res, "accuracy-passes.png")

    fig, axes = plt.subplots(1, n, figsize=(5.2 * n, 4.4), squeeze=False)
    cmap = plt.get_cmap("viridis")
    for ax, s in zip(axes[0], scenes):
        for i, al in enumerate(alphas):
            ser = series(rows, s, f"ppm-a{al}")
            if ser:
                sl = slopes.get((s, f"ppm-a{al}"), [float("nan")] * 6)
                ax.loglog([r["x"] for r in ser], [r["rmse"] for r in ser], "o-", ms=3,
                          color=cmap(i / max(1, len(alphas) - 1)),
                          label=f"α {al}: {sl[2]:.2f}, fit {-sl[4]:.2f} (theory "
                                f"{theory_slope(float(al)):.2f})")
        finish_axes(ax, f"{s}: α sweep", "photon passes",
                    title=f"slope over passes 16–{int(last)}; with floor fitted", title_fontsize=7)
    save_figure(fig, a.res, "accuracy-alpha.png")

    # The PNG previews: reference, path tracing and PPM at their final passes.
    cols = [("ref.png", "reference"), ("pt/final.png", "path tracing, final"),
            ("ppm/final.png", "PPM α 0.7, final")]
    fig, axes = plt.subplots(n, len(cols), figsize=(3.0 * len(cols), 3.1 * n), squeeze=False)
    for i, s in enumerate(scenes):
        for j, (f, title) in enumerate(cols):
            ax = axes[i][j]
            ax.axis("off")
            p = os.path.join(a.dir, s, f)
            if os.path.exists(p):
                ax.imshow(mpimg.imread(p))
                ser = series(rows, s, "pt" if j == 1 else "ppm") if j else []
                extra = f"\n{ser[-1]['seconds']:.1f} s, RMSE {ser[-1]['rmse']:.4f}" if ser else ""
                ax.set_title(f"{s}: {title}{extra}", fontsize=7)
    save_figure(fig, a.res, "accuracy-images.png")

    w("Charts: [accuracy-time.png](accuracy-time.png) (error against wall time), "
      "[accuracy-passes.png](accuracy-passes.png) (against passes or samples), "
      "[accuracy-alpha.png](accuracy-alpha.png) (α sweep), "
      "[accuracy-images.png](accuracy-images.png) (final images).\n")
    path = os.path.join(a.res, "accuracy.md")
    with open(path + ".tmp", "w") as f:
        f.write("\n".join(out) + "\n")
    os.replace(path + ".tmp", path)
    print(f"accuracy.py: {path} and 4 charts in {a.res}")


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    sub = p.add_subparsers(dest="cmd", required=True)
    c = sub.add_parser("collect")
    c.add_argument("--imgcompare", required=True)
    g = c.add_mutually_exclusive_group(required=True)
    g.add_argument("--record")
    g.add_argument("--classic")
    c.add_argument("--reference", required=True)
    c.add_argument("--mask", default="")
    c.add_argument("--scene", required=True)
    c.add_argument("--method", required=True)
    c.add_argument("--label", required=True)
    c.add_argument("--alpha", default="")
    c.add_argument("--load", default="")
    c.add_argument("--eye-spp", default="", help="eye samples per pixel of --classic images")
    c.add_argument("-o", "--output", required=True)
    r = sub.add_parser("report")
    r.add_argument("--dir", required=True)
    r.add_argument("--res", required=True)
    r.add_argument("--scenes", required=True)
    r.add_argument("--alphas", required=True)
    r.add_argument("--settings", default="")
    a = p.parse_args()
    if a.cmd == "collect":
        collect(a)
    else:
        report(a)


if __name__ == "__main__":
    sys.exit(main())
