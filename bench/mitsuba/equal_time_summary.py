#!/usr/bin/env python3
"""Summary of bench/mitsuba/equal_time.sh's runs.tsv: per scene and method the median RMSE over the
runs (all pixels, away from the lights), the median seconds, the reference's own error beside, and
the ratios the targets of issue 34 item 2 are stated in. Plain Python (no third-party modules).

  equal_time_summary.py runs.tsv TIME THREADS > summary.md
"""
import csv
import statistics
import sys

tsv, budget, threads = sys.argv[1], sys.argv[2], sys.argv[3]


def ratio(a, b):
    return "%.2f" % (a / b) if b > 0 else "n/a (reference noise larger)"


rows = list(csv.DictReader(open(tsv), delimiter="\t"))
scenes = list(dict.fromkeys(r["scene"] for r in rows))
print("Equal time %s s, %s threads; median over runs (n = runs); RMSE against the mean of two Mitsuba "
      "references, whose own error is the `ref` column. Load: 1-minute load average before/after "
      "the runs (min–max). net = sqrt(MSE − the reference's MSE), the error against the exact image "
      "estimated without the references' own noise (0 where the run is within it).\n" % (budget, threads))
for s in scenes:
    R = [r for r in rows if r["scene"] == s]
    methods = list(dict.fromkeys(r["method"] for r in R))
    med = {}
    print("**%s**\n" % s)
    print("| method | n | seconds | work (last run) | RMSE all | net | ref all | RMSE away from lights | net | ref away | load |")
    print("|---|---:|---:|---|---:|---:|---:|---:|---:|---:|---|")
    for m in methods:
        M = [r for r in R if r["method"] == m]
        f = lambda k: statistics.median(float(r[k]) for r in M)  # noqa: E731
        med[m] = (f("rmse_all"), f("rmse_masked"), f("rmse_net_all"), f("rmse_net_masked"))
        loads = [float(r[k]) for r in M for k in ("load_before", "load_after")]
        print("| %s | %d | %.1f | %s | %.5f | %.5f | %.5f | %.5f | %.5f | %.5f | %.1f–%.1f |"
              % (m, len(M), f("seconds"), M[-1]["passes_or_spp"], med[m][0], med[m][2], f("ref_rmse_all"),
                 med[m][1], med[m][3], f("ref_rmse_masked"), min(loads), max(loads)))
    mis = [m for m in methods if m.startswith("mi-") or m.startswith("mi1-")]
    if mis:
        best = min(mis, key=lambda m: med[m][0])
        print("\nRatios to Mitsuba (%s, the lowest of its methods over all pixels; issue 34 item 2: all pixels "
              "≤ 0.5×, away from the lights ≤ 1× on the diffuse box; both ≤ 0.5× on the ≥ 200k-triangle scene; "
              "issue 50 item 6: ≤ 0.5× both on window-room, ≤ 1× on hdri-object):\n"
              % best)
        print("| method | all pixels / mitsuba | away from lights / mitsuba | the same, net of the references' noise |")
        print("|---|---:|---:|---|")
        for m in methods:
            print("| %s | %.2f | %.2f | %s, %s |" % (m, med[m][0] / med[best][0], med[m][1] / med[best][1],
                                                   ratio(med[m][2], med[best][2]), ratio(med[m][3], med[best][3])))
    for base, what in (("pppm", "pppm as it is now"),
                       ("pppm-issue", "today's pppm when issue 34 was filed, the target's baseline")):
        if base in med and "defaults" in med:
            print("\ndefaults / %s (%s; the mirror-and-glass box's target: ≤ 0.75 all pixels, ≤ 0.72 away "
                  "from the lights): %.2f, %.2f; net of the references' noise %s, %s"
                  % (base, what, med["defaults"][0] / med[base][0], med["defaults"][1] / med[base][1],
                     ratio(med["defaults"][2], med[base][2]), ratio(med["defaults"][3], med[base][3])))
    if "guided" in med and "defaults" in med:
        print("\nguided / defaults (issue 50 item 6 on window-room: --photon-guide visibility ≤ 0.33× uniform): "
              "%.2f, %.2f; net of the references' noise %s, %s"
              % (med["guided"][0] / med["defaults"][0], med["guided"][1] / med["defaults"][1],
                 ratio(med["guided"][2], med["defaults"][2]), ratio(med["guided"][3], med["defaults"][3])))
    print()
