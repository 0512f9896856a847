#!/usr/bin/env bash
# photon_balance.sh — issue 34 item 1: the measured ratio of photon-tracing to eye-pass cost behind
# render's automatic photon count per pass (render_defaults.h, kEyeSampleCostInPhotons).
#
# For each scene of data/ at WIDTH×HEIGHT, render's default estimator (sppm, direct light by
# shadow rays) runs 1 + PASSES passes twice: with FEW photons per pass and with MANY. The pass
# time is the rendering seconds between the run record's two images (a snapshot after pass 1,
# then the final image), so program start, the bake and the first pass's allocations are left
# out. A pass costs  t(P) = E + c·P  (E: the eye pass with its shadow rays and gather, c: one
# photon emitted, traced and sorted into the grid, and its share of the gather), so
#   c = (t(MANY) − t(FEW)) / (MANY − FEW),  E = t(FEW) − c·FEW,
# and the eye pass of one pixel costs  E / (c · pixels)  photons: the figure printed last, the
# photons per pixel at which a pass spends as long tracing photons as tracing eye paths.
# RUNS runs of each (interleaved), the median pass time used.
#
#   bench/photon_balance.sh [BUILD]    (WIDTH=512 HEIGHT=512 PASSES=12 FEW=16384 MANY=524288 RUNS=3)
set -euo pipefail
BUILD=${1:-build}
B=$BUILD/bin
WIDTH=${WIDTH:-512}
HEIGHT=${HEIGHT:-512}
PASSES=${PASSES:-12}
FEW=${FEW:-16384}
MANY=${MANY:-524288}
RUNS=${RUNS:-3}
THREADS=${THREADS:-0}
SCENES=${SCENES:-cornell-box cornell-spheres sds-pool}
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
total=$((PASSES + 1))
for s in $SCENES; do
  $B/scene-bake "data/$s.dae" -o "$T/$s.h5" --width "$WIDTH" --height "$HEIGHT" > /dev/null
done
for r in $(seq 1 "$RUNS"); do
  for s in $SCENES; do
    for p in "$FEW" "$MANY"; do
      $B/render --scene "$T/$s.h5" --estimator sppm --direct shadow-rays --passes $total \
        --photons "$p" --snapshot-at 1 --snapshot "$T/snap-{pass}.exr" -o "$T/r.exr" \
        --stats "$T/$s-$p-$r.json" --threads "$THREADS" > /dev/null
    done
  done
done
/usr/bin/python3 - "$T" "$RUNS" "$PASSES" "$FEW" "$MANY" "$WIDTH" "$HEIGHT" $SCENES <<'PY'
import json, statistics, sys
d, runs, passes, few, many, w, h = sys.argv[1], *map(int, sys.argv[2:8])
scenes = sys.argv[8:]
def pass_time(s, p, r):
    im = json.load(open(f"{d}/{s}-{p}-{r}.json"))["images"]
    return (im[-1]["seconds"] - im[0]["seconds"]) / passes
ratios = []
print(f"{w}x{h}, {passes} passes after the first, median of {runs} runs; FEW={few} MANY={many}")
print("scene | pass s (FEW) | pass s (MANY) | eye pass E s | photon c us | E/(c*pixels)")
for s in scenes:
    tf = statistics.median(pass_time(s, few, r) for r in range(1, runs + 1))
    tm = statistics.median(pass_time(s, many, r) for r in range(1, runs + 1))
    c = (tm - tf) / (many - few)
    e = tf - c * few
    ratio = e / (c * w * h)
    ratios.append(ratio)
    print(f"{s} | {tf:.4f} | {tm:.4f} | {e:.4f} | {c * 1e6:.4f} | {ratio:.3f}")
print(f"median E/(c*pixels) over the scenes: {statistics.median(ratios):.3f}"
      f" (min {min(ratios):.3f}, max {max(ratios):.3f})")
PY
