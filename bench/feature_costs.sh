#!/usr/bin/env bash
# feature_costs.sh — issue 32 item 9: what each feature of the scenes users bring costs where a
# scene uses it. Variants of data/showcase.gltf, each baked at W×H and rendered with the same
# estimator and photon count; the pass rate of each against the variant with none of them:
#
#   none      every material diffuse (metallic 0, roughness 1, no transmission, no texture) with
#             its base-colour factor, times its base-colour texture's mean linear colour where it
#             has one (so that the room's albedo, and with it the photons' path lengths, stay
#             those of the textured scene), every alphaMode OPAQUE, a pinhole camera
#   textures  none + the base-colour textures (floor tiles, fence) instead of their means
#   pbr       none + the metallic, roughness, transmission and ior of the file, with its
#             metallic-roughness texture (gold, rough glass, the striped box, the floor's 0.8)
#   alpha     none + the fence's alphaMode MASK (its coverage comes from the base-colour texture,
#             which this variant therefore keeps on the fence alone)
#   dof       none + the thin lens of data/showcase.bake-options (--aperture, --focus-distance)
#   all       the file as it is (the showcase)
#
# The lights (ceiling emitter with emissive strength, the spot light) are the file's in every
# variant. A feature's cost includes what it changes in the light transport (glass and metal
# send photons on where diffuse surfaces end more of them; an opaque fence blocks light that
# the cut-outs let through): the cost a scene that uses it pays. Each run renders 1 + PASSES
# passes with a snapshot after the first; the rate is PASSES over the rendering seconds between
# the two images of the run record (as bench/sppm_speed.sh), RUNS runs per variant interleaved,
# medians and the median of the per-round ratios to `none` printed.
#
#   bench/feature_costs.sh [BUILD]   (ESTIMATOR=pppm PHOTONS=183296 W=512 H=512 PASSES=10 RUNS=3
#                                     THREADS=0 DEVICE=cpu VARIANTS="none textures pbr alpha dof all")
set -euo pipefail
BUILD=${1:-build}
B=$BUILD/bin
ESTIMATOR=${ESTIMATOR:-pppm}
PHOTONS=${PHOTONS:-183296}
W=${W:-512}
H=${H:-512}
PASSES=${PASSES:-10}
RUNS=${RUNS:-3}
THREADS=${THREADS:-0}
DEVICE=${DEVICE:-cpu}
VARIANTS=${VARIANTS:-none textures pbr alpha dof all}
for t in scene-bake render; do
  [ -x "$B/$t" ] || { echo "feature_costs.sh: $B/$t not built (cmake --build $BUILD --target tools)" >&2; exit 2; }
done
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
# The variants' glTF files beside links to the scene's buffer and images.
for f in data/showcase.bin data/showcase_*.png; do ln -s "$PWD/$f" "$T/"; done
/usr/bin/python3 - "$T" data/showcase.gltf $VARIANTS <<'PY'
import copy, json, sys
out, src, variants = sys.argv[1], sys.argv[2], sys.argv[3:]
import os, struct, zlib
g = json.load(open(src))
def png_mean(path):
    """Mean linear RGB of an 8-bit RGB(A) PNG with filter 0 rows (data/make_showcase.py's)."""
    data = open(path, "rb").read()
    pos, idat, w = 8, b"", None
    while pos < len(data):
        n, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        if kind == b"IHDR":
            w, h, depth, ctype = struct.unpack(">IIBB", body[:10])
            ch = {2: 3, 6: 4}[ctype]
        elif kind == b"IDAT":
            idat += body
        pos += 12 + n
    raw = zlib.decompress(idat)
    lin = lambda c: c / 12.92 if c <= 0.04045 else ((c + 0.055) / 1.055) ** 2.4  # noqa: E731
    table = [lin(v / 255.0) for v in range(256)]
    sums, stride = [0.0, 0.0, 0.0], 1 + w * ch
    for y in range(h):
        row = raw[y * stride:(y + 1) * stride]
        assert row[0] == 0, "filtered PNG row"
        for x in range(w):
            for c in range(3):
                sums[c] += table[row[1 + x * ch + c]]
    return [v / (w * h) for v in sums]
def texture_mean(index):
    uri = g["images"][g["textures"][index]["source"]]["uri"]
    return png_mean(os.path.join(os.path.dirname(src), uri))
def variant(name):
    v = copy.deepcopy(g)
    keep_pbr = name in ("pbr", "all")
    keep_tex = name in ("textures", "all")
    keep_alpha = name in ("alpha", "all")
    for m in v["materials"]:
        pm = m.setdefault("pbrMetallicRoughness", {})
        masked = m.get("alphaMode") == "MASK"
        if not keep_pbr:
            pm["metallicFactor"], pm["roughnessFactor"] = 0.0, 1.0
            pm.pop("metallicRoughnessTexture", None)
            ext = m.get("extensions", {})
            ext.pop("KHR_materials_transmission", None)
            ext.pop("KHR_materials_ior", None)
        if not keep_tex and not (keep_alpha and masked) and "baseColorTexture" in pm:
            mean = texture_mean(pm.pop("baseColorTexture")["index"])
            f = pm.get("baseColorFactor", [1.0, 1.0, 1.0, 1.0])
            pm["baseColorFactor"] = [f[c] * mean[c] for c in range(3)] + [f[3]]
        if not keep_alpha:
            m.pop("alphaMode", None)
            m.pop("alphaCutoff", None)
    json.dump(v, open(f"{out}/{name}.gltf", "w"), indent=1)
for name in variants:
    if name not in ("none", "textures", "pbr", "alpha", "dof", "all"):
        sys.exit(f"feature_costs.sh: unknown variant {name}")
    variant(name)
PY
lens=$(sed -e 's/#.*//' data/showcase.bake-options)
for v in $VARIANTS; do
  opts=""
  case $v in dof|all) opts=$lens ;; esac
  # shellcheck disable=SC2086  # the options are words
  $B/scene-bake "$T/$v.gltf" -o "$T/$v.h5" --width "$W" --height "$H" $opts > /dev/null
done
total=$((PASSES + 1))
for r in $(seq 1 "$RUNS"); do
  for v in $VARIANTS; do
    $B/render --scene "$T/$v.h5" --estimator "$ESTIMATOR" --passes $total --photons "$PHOTONS" \
      --device "$DEVICE" --snapshot-at 1 --snapshot "$T/$v-{pass}.exr" -o "$T/$v.exr" \
      --stats "$T/$v-$r.json" --threads "$THREADS" > /dev/null
  done
done
/usr/bin/python3 - "$T" "$RUNS" "$PASSES" $VARIANTS <<'PY'
import json, statistics, sys
d, runs, passes, variants = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4:]
rates = {}
for v in variants:
    r = []
    for k in range(1, runs + 1):
        im = json.load(open(f"{d}/{v}-{k}.json"))["images"]
        r.append(passes / (im[-1]["seconds"] - im[0]["seconds"]))
    rates[v] = r
print("| variant | passes/s (median) | runs | time per pass / none's (median of round ratios) |")
print("|---|---:|---|---:|")
for v in variants:
    rel = (statistics.median(x / y for x, y in zip(rates["none"], rates[v]))
           if "none" in rates else float("nan"))
    print(f"| {v} | {statistics.median(rates[v]):.3f} | " + " ".join(f"{x:.3f}" for x in rates[v])
          + f" | {rel:.2f} |")
PY
cat /proc/loadavg
