#!/usr/bin/env bash
# sppm_speed.sh — issue 25 item 8: pass rate of SPPM (eye pass included) and PPPM against PPM's
# (eye pass once, not counted) on the diffuse Cornell box at 512×512 with 262,144 photon paths per
# pass. Each run renders 1 + PASSES passes with a snapshot after the first; the rate is PASSES over
# the rendering seconds between the two images of the run record (render --stats), so program
# start, the scene load, PPM's one-off eye pass and the first pass's allocations are left out.
# RUNS runs per estimator, interleaved (ppm, sppm, pppm, ppm, ...), medians printed.
#
#   bench/sppm_speed.sh [BUILD]        (PASSES=20 RUNS=5 THREADS=0 by default)
set -euo pipefail
BUILD=${1:-build}
B=$BUILD/bin
PASSES=${PASSES:-20}
RUNS=${RUNS:-5}
THREADS=${THREADS:-0}
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
$B/scene-bake data/cornell-box.dae -o "$T/box.h5" --width 512 --height 512 > /dev/null
total=$((PASSES + 1))
for r in $(seq 1 "$RUNS"); do
  for e in ppm sppm pppm; do
    $B/render --scene "$T/box.h5" --estimator "$e" --passes $total --photons 262144 \
      --snapshot-at 1 --snapshot "$T/$e-{pass}.exr" -o "$T/$e.exr" --stats "$T/$e-$r.json" \
      --threads "$THREADS" > /dev/null
  done
done
/usr/bin/python3 - "$T" "$RUNS" "$PASSES" <<'PY'
import json, statistics, sys
d, runs, passes = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
rate = {}
for e in ("ppm", "sppm", "pppm"):
    r = []
    for k in range(1, runs + 1):
        im = json.load(open(f"{d}/{e}-{k}.json"))["images"]
        r.append(passes / (im[-1]["seconds"] - im[0]["seconds"]))
    rate[e] = statistics.median(r)
    print(f"{e:5s} passes/s: median {rate[e]:.3f}  runs " + " ".join(f"{x:.3f}" for x in r))
for e in ("sppm", "pppm"):
    print(f"{e} / ppm pass rate: {rate[e] / rate['ppm']:.2f}")
PY
cat /proc/loadavg
