#!/usr/bin/env python3
"""Check scene_to_mitsuba.py's environment against photonflow's lookup (docs/FORMATS.md
`/environment/texels`): Mitsuba's envmap emitter evaluated at random directions d against
strength × texel(R_y(−rotation_deg)·d), photonflow's texel-constant map. Benchmark-only (the
Mitsuba venv's python).

  check_env.py scene.h5 [--sub 8] [--out DIR]

Evaluates both on a grid of SUB × SUB directions per texel (cell centres in u, v; the grid is
that of photonflow's texels, so the map and the sun are resolved) and prints: the fraction of
directions where the two agree within 10⁻⁴ and within 10 % relative (a direction disagrees only in
Mitsuba's bilinear ramp across a texel edge: 1/ENV_UPSAMPLE_COLS of a texel wide across
columns, 2/ENV_UPSAMPLE_ROWS across rows), and ∫ L dω of both over the sphere (sin θ weights, per channel; the
sky's irradiance scale), then the same with the rotation's sign flipped (which must disagree
where the map is not symmetric about the y axis). Exit 0 when ≥ 50 % agree within 10⁻⁴, ≥ 90 %
within 10 %, and the integrals within 0.5 %.
"""
import argparse
import os
import sys
import tempfile

import h5py
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import scene_to_mitsuba  # noqa: E402

ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
ap.add_argument("scene")
ap.add_argument("--sub", type=int, default=8, help="grid directions per texel side")
ap.add_argument("--out", default=None)
a = ap.parse_args()

import drjit as dr  # noqa: E402
import mitsuba as mi  # noqa: E402

mi.set_variant("llvm_ad_rgb")
with h5py.File(a.scene, "r") as f:
    tex = f["environment/texels"][:].astype(np.float64)
    strength = float(f["environment"].attrs["strength"])
    rot = float(f["environment"].attrs["rotation_deg"])
out = a.out or tempfile.mkdtemp(prefix="check_env.")
xml = scene_to_mitsuba.convert(a.scene, out)
scene = mi.load_file(xml, spp=1)
env = scene.environment()
assert env is not None, "no envmap in the converted scene"

H0, W0 = tex.shape[:2]
S = a.sub  # directions per texel side: a grid of (u, v) cell centres over the whole sphere
gu = (np.arange(S * W0) + 0.5) / (S * W0)
gv = (np.arange(S * H0) + 0.5) / (S * H0)
U, V = np.meshgrid(gu, gv)
phi, th = 2 * np.pi * U.ravel(), np.pi * V.ravel()
d = np.stack([np.sin(th) * np.sin(phi), np.cos(th), -np.sin(th) * np.cos(phi)], axis=1)  # u = atan2(x, −z)/2π
w = np.sin(th) * (2 * np.pi / len(gu)) * (np.pi / len(gv))  # dω of each cell: Σ w = 4π
a.n = len(d)


def photonflow(d, rho_deg):
    r = np.radians(rho_deg)
    c, s = np.cos(-r), np.sin(-r)  # R_y(−ρ), right-handed: x' = c x + s z, z' = −s x + c z
    x, y, z = c * d[:, 0] + s * d[:, 2], d[:, 1], -s * d[:, 0] + c * d[:, 2]
    H, W = tex.shape[:2]
    u = np.mod(np.arctan2(x, -z) / (2 * np.pi), 1.0)
    v = np.arccos(np.clip(y, -1, 1)) / np.pi
    col = np.minimum((u * W).astype(int), W - 1)
    row = np.minimum((v * H).astype(int), H - 1)
    return strength * tex[row, col]


si = dr.zeros(mi.SurfaceInteraction3f, a.n)
si.wi = mi.Vector3f(*[mi.Float(-d[:, i].astype(np.float32)) for i in range(3)])
m = np.array(env.eval(si), dtype=np.float64).reshape(3, -1).T if np.array(env.eval(si)).shape[0] == 3 \
    else np.array(env.eval(si), dtype=np.float64)
ok = True
for label, sign in (("rotation as converted", 1), ("rotation sign flipped", -1)):
    p = photonflow(d, sign * rot)
    rel = np.abs(m - p).max(axis=1) / np.maximum(np.abs(p).max(axis=1), 1e-12)
    agree, near = np.mean(rel < 1e-4), np.mean(rel < 0.1)
    mm, pm = (m * w[:, None]).sum(axis=0), (p * w[:, None]).sum(axis=0)
    print("%s (rotation_deg %g): of %d directions %.2f %% agree within 1e-4, %.2f %% within 10 %%; "
          "integral Mitsuba %s photonflow %s (%+.3f %%)"
          % (label, sign * rot, a.n, 100 * agree, 100 * near, np.array2string(mm, precision=5),
             np.array2string(pm, precision=5), 100 * (mm.sum() / pm.sum() - 1)))
    if sign == 1:
        ok = agree >= 0.5 and near >= 0.9 and abs(mm.sum() / pm.sum() - 1) <= 0.005
print("check_env: %s" % ("PASS" if ok else "FAIL"))
sys.exit(0 if ok else 1)
