#!/usr/bin/env bash
# photon_guide.sh — issue 50 item 4: --photon-guide uniform against visibility (photons where the
# camera looks, Hachisuka & Jensen 2011; libcommon/photonflow/stages/photon_guide.h) on a closed
# room lit only through a window: walls of thick slabs (no light leaks through a wall's two faces),
# a square hole in the left wall, a bright constant environment outside, the camera inside
# looking at the back wall. Most environment photons land on the outside of the room or miss it.
# Renders with pppm: a reference (uniform, REF_PASSES passes), then uniform and visibility at
# PASSES passes each (equal passes), then uniform with --time set to visibility's rendering
# seconds (equal time); prints RMSE against the reference, seconds, the visible fraction Vc of
# the uniform photons and the chains' acceptance rate (render --stats).
#
#   bench/photon_guide.sh [BUILD]   (PASSES=16 REF_PASSES=2048 PHOTONS=100000 SIZE=64 THREADS=0 WINDOW=0.3 RADIUS=0.02)
set -euo pipefail
BUILD=${1:-build}
B=$BUILD/bin
PASSES=${PASSES:-16}
REF_PASSES=${REF_PASSES:-2048}
PHOTONS=${PHOTONS:-100000}
SIZE=${SIZE:-64}
THREADS=${THREADS:-0}
WINDOW=${WINDOW:-0.3}
RADIUS=${RADIUS:-0.02}
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
/usr/bin/python3 - "$T/room.obj" "$WINDOW" <<'PY'
import sys
path, w = sys.argv[1], float(sys.argv[2])
t = 0.25  # wall thickness: far more than the radius, no photon outside is near one inside
lo, hi = 0.5 - w / 2, 0.5 + w / 2
slabs = [  # (x0, y0, z0, x1, y1, z1)
    (-t, -t, -t, 1 + t, 0, 1 + t),        # floor
    (-t, 1, -t, 1 + t, 1 + t, 1 + t),     # ceiling
    (-t, 0, -t, 1 + t, 1, 0),             # back
    (-t, 0, 1, 1 + t, 1, 1 + t),          # front
    (1, 0, 0, 1 + t, 1, 1),               # right
    (-t, 0, 0, 0, lo, 1),                 # left wall around the window: below,
    (-t, hi, 0, 0, 1, 1),                 # above,
    (-t, lo, 0, 0, hi, lo),               # behind,
    (-t, lo, hi, 0, hi, 1),               # in front
]
v, f = [], []
for (x0, y0, z0, x1, y1, z1) in slabs:
    b = len(v)
    for x in (x0, x1):
        for y in (y0, y1):
            for z in (z0, z1):
                v.append((x, y, z))
    # corners: index = 4*ix + 2*iy + iz; outward quads
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    for q in quads:
        f.append(tuple(b + i + 1 for i in q))
with open(path, "w") as o:
    o.write("# room with a window\n")
    for p in v:
        o.write("v %g %g %g\n" % p)
    for q in f:
        o.write("f %d %d %d\nf %d %d %d\n" % (q[0], q[1], q[2], q[0], q[2], q[3]))
PY
$B/scene-bake "$T/room.obj" -o "$T/room.h5" --environment 1,1,1 --environment-strength 50 \
  --eye 0.5,0.5,0.95 --look-at 0.5,0.45,0 --fov 70 --width "$SIZE" --height "$SIZE" > /dev/null
run() {  # name, extra options
  local name=$1
  shift
  $B/render --scene "$T/room.h5" --estimator pppm --photons "$PHOTONS" --radius "$RADIUS" --threads "$THREADS" \
    -o "$T/$name.exr" --stats "$T/$name.json" "$@" > "$T/$name.log"
}
run ref --passes "$REF_PASSES" --photon-guide uniform --seed 99
run uniform --passes "$PASSES" --photon-guide uniform
run visibility --passes "$PASSES" --photon-guide visibility
secs=$(/usr/bin/python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['images'][-1]['seconds'])" "$T/visibility.json")
run uniform-time --passes 100000 --time "$secs" --photon-guide uniform
/usr/bin/python3 - "$T" "$B" <<'PY'
import json, subprocess, sys
d, b = sys.argv[1], sys.argv[2]
print("%-14s %7s %8s %10s %8s %8s" % ("run", "passes", "seconds", "RMSE", "Vc", "accept"))
for name in ["uniform", "visibility", "uniform-time", "ref"]:
    im = json.load(open("%s/%s.json" % (d, name)))["images"][-1]
    m = json.loads(subprocess.run([b + "/imgcompare", "--json", "-", "%s/%s.exr" % (d, name),
                                   "%s/ref.exr" % d], capture_output=True, text=True,
                                  check=True).stdout)
    print("%-14s %7d %8.2f %10.5f %8s %8s" % (name, im["passes"], im["seconds"], m["rmse"],
          "%.4f" % im["visible_fraction"] if "visible_fraction" in im else "-",
          "%.3f" % im["acceptance"] if "acceptance" in im else "-"))
PY
