#!/usr/bin/env python3
"""A method's noise alone, without a reference: the RMSE between runs of different seeds over √2.

  pairnoise.py LABEL run1.exr run2.exr [run3.exr ...]

For independent runs a and b of one method, E[(a − b)²] = 2·Var per pixel, so rms(a − b)/√2 is one
run's noise (its error net of any bias, and of no reference's noise). Prints it for every pair of
the runs given and the root of the pairs' mean square. Benchmark-only (docs/RESULTS.md,
"Photons where the camera looks").
"""
import itertools
import sys

import Imath
import numpy as np
import OpenEXR


def load(path):
    f = OpenEXR.InputFile(path)
    dw = f.header()["dataWindow"]
    w, h = dw.max.x - dw.min.x + 1, dw.max.y - dw.min.y + 1
    pt = Imath.PixelType(Imath.PixelType.FLOAT)
    return np.stack([np.frombuffer(f.channel(c, pt), dtype=np.float32).reshape(h, w)
                     for c in "RGB"], 2).astype(np.float64)


if len(sys.argv) < 4:
    sys.exit("usage: pairnoise.py LABEL run1.exr run2.exr [run3.exr ...]")
label, images = sys.argv[1], [load(p) for p in sys.argv[2:]]
var = [((a - b) ** 2).mean() / 2 for a, b in itertools.combinations(images, 2)]
print("%-24s noise %.5f (pairs: %s)" % (label, np.sqrt(np.mean(var)),
                                         " ".join("%.5f" % np.sqrt(v) for v in var)))
