#!/usr/bin/env bash
# sppm_speed.sh — issue 25 item 8: pass rate of SPPM (eye pass included) and PPPM against PPM's
# (eye pass once, not counted) on the diffuse Cornell box at 512×512 with 262,144 photon paths per
# pass. Each run renders 1 + PASSES passes with a snapshot after the first; the rate is PASSES over
# the rendering seconds between the two images of the run record (render --stats), so program
# start, the scene load, PPM's one-off eye pass and the first pass's allocations are left out.
# RUNS runs per estimator, interleaved (ppm, sppm, pppm, ppm, ...), medians printed.
# BASE=DIR adds the PPM of another build (its bin/render; e.g. the commit before SPPM, b1c0a38,
# whose PPM the issue's "today's PPM pass rate" measured) as a fourth, interleaved, estimator
# "ppm@base", and prints each rate against it too. BASE_ESTIMATORS="ppm sppm pppm" runs those
# estimators of the base build instead (a base that has --estimator: issue 32 item 9 compares
# today's SPPM with the SPPM of the commit before a feature), each printed as "<e>@base" and
# compared with the same estimator of BUILD.
#
# DEVICE=opencl runs every render (this build's and the base's) with --device opencl: the device
# route's eye and photon passes and gathers (PoCL on a CPU machine; its kernel compilation falls in
# the first pass, which the rate leaves out).
#
#   bench/sppm_speed.sh [BUILD]        (PASSES=20 RUNS=5 THREADS=0 DEVICE=cpu by default)
set -euo pipefail
BUILD=${1:-build}
B=$BUILD/bin
PASSES=${PASSES:-20}
RUNS=${RUNS:-5}
THREADS=${THREADS:-0}
BASE=${BASE:-}
BASE_ESTIMATORS=${BASE_ESTIMATORS:-}
DEVICE=${DEVICE:-cpu}
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
$B/scene-bake data/cornell-box.dae -o "$T/box.h5" --width 512 --height 512 > /dev/null
# The base build bakes its own copy (an older build may not read this build's scene format).
BASE_SCENE="$T/box.h5"
if [ -n "$BASE" ]; then
  BASE_SCENE="$T/box-base.h5"
  "$BASE/bin/scene-bake" data/cornell-box.dae -o "$BASE_SCENE" --width 512 --height 512 > /dev/null
fi
total=$((PASSES + 1))
for r in $(seq 1 "$RUNS"); do
  for e in ppm sppm pppm; do
    $B/render --scene "$T/box.h5" --estimator "$e" --direct photons --passes $total --photons 262144 \
      --snapshot-at 1 --snapshot "$T/$e-{pass}.exr" -o "$T/$e.exr" --stats "$T/$e-$r.json" \
      --threads "$THREADS" --device "$DEVICE" > /dev/null
  done
  if [ -n "$BASE" ] && [ -z "$BASE_ESTIMATORS" ]; then  # a base before --estimator: PPM only
    "$BASE/bin/render" --scene "$BASE_SCENE" --passes $total --photons 262144 \
      --snapshot-at 1 --snapshot "$T/base-{pass}.exr" -o "$T/base.exr" --stats "$T/ppm@base-$r.json" \
      --threads "$THREADS" > /dev/null
  fi
  for e in $BASE_ESTIMATORS; do
    "$BASE/bin/render" --scene "$BASE_SCENE" --estimator "$e" --direct photons --passes $total \
      --photons 262144 --snapshot-at 1 --snapshot "$T/base-{pass}.exr" -o "$T/base.exr" \
      --stats "$T/$e@base-$r.json" --threads "$THREADS" --device "$DEVICE" > /dev/null
  done
done
/usr/bin/python3 - "$T" "$RUNS" "$PASSES" "$BASE" "$BASE_ESTIMATORS" <<'PY'
import json, statistics, sys
d, runs, passes, base = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
base_est = sys.argv[5].split() if base else []
rate, runs_of = {}, {}
based = [f"{e}@base" for e in base_est] if base_est else (["ppm@base"] if base else [])
for e in ["ppm", "sppm", "pppm"] + based:
    r = []
    for k in range(1, runs + 1):
        im = json.load(open(f"{d}/{e}-{k}.json"))["images"]
        r.append(passes / (im[-1]["seconds"] - im[0]["seconds"]))
    rate[e], runs_of[e] = statistics.median(r), r
    print(f"{e:8s} passes/s: median {rate[e]:.3f}  runs " + " ".join(f"{x:.3f}" for x in r))
# Ratios of medians, and the median of the ratios within each round (a round's runs follow one
# another within seconds, so a slow spell of the machine tends to slow both).
def ratio(a, b):
    paired = statistics.median(x / y for x, y in zip(runs_of[a], runs_of[b]))
    print(f"{a} / {b} pass rate: {rate[a] / rate[b]:.2f} (median of round ratios {paired:.2f})")
for e in ("sppm", "pppm"):
    ratio(e, "ppm")
if base_est:
    for e in base_est:
        ratio(e, f"{e}@base")
elif base:
    for e in ("ppm", "sppm", "pppm"):
        ratio(e, "ppm@base")
PY
cat /proc/loadavg
