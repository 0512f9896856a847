#!/usr/bin/env python3
"""mutate_material.py — check that the material tests can fail (issue 32 item 7).

Applies one small mutation at a time to libcommon/photonflow/material/*.h (a wrong pdf factor, a
wrong Jacobian, a missing half-texel offset, ...), rebuilds the test that covers the header, runs
it, and reports which test cases fail; the header is restored afterwards, whatever happens. Every
mutation must make at least one test case fail: the script exits 1 if one survives.

Run from the repository root with a configured build folder (default build/):
    python3 tests/mutate_material.py [build-dir]
It builds only bsdf_shared_test, texture_shared_test, lens_shared_test and material_shared_cl_test (-j2);
about 2 minutes. MUTATE_ONLY=<text> runs only the mutations whose name contains <text>.
"""
import os
import sys

BUILD = sys.argv[1] if len(sys.argv) > 1 else "build"
M = "libcommon/photonflow/material/"
MUTATIONS = [
    # (header, test, name, original, mutated)
    ("bsdf_shared.h", "bsdf_shared_test", "VNDF reflection pdf: 4(o.h) -> 3.6(o.h)",
     "return pf_ggx_vndf_pdf(o, h, alpha) / (4.0f * oh);",
     "return pf_ggx_vndf_pdf(o, h, alpha) / (3.6f * oh);"),
    ("bsdf_shared.h", "bsdf_shared_test", "transmission Jacobian: eta_i^2 -> eta_o^2",
     "(eta_i * eta_i * PF_S_FABS(ih)) / (den * den);",
     "(eta_o * eta_o * PF_S_FABS(ih)) / (den * den);"),
    ("bsdf_shared.h", "bsdf_shared_test", "mixture pdf: diffuse weight x0.9",
     "return c->p_diffuse * pf_bsdf_pdf_cosine(i) +",
     "return 0.9f * c->p_diffuse * pf_bsdf_pdf_cosine(i) +"),
    ("bsdf_shared.h", "bsdf_shared_test", "cosine pdf: cos/pi -> 3cos^2/(2pi) (normalized, wrong shape)",
     "return i[2] > 0.0f ? i[2] * PF_S_INV_PI : 0.0f;",
     "return i[2] > 0.0f ? 1.5f * i[2] * i[2] * PF_S_INV_PI : 0.0f;"),
    ("bsdf_shared.h", "bsdf_shared_test", "visibility: 0.5 -> 0.55",
     "return den > 0.0f ? 0.5f / den : 0.0f;", "return den > 0.0f ? 0.55f / den : 0.0f;"),
    ("bsdf_shared.h", "bsdf_shared_test", "transport modes: radiance/importance eta swapped",
     "const float eta_num = mode == PF_TRANSPORT_IMPORTANCE ? c.eta_i : c.eta_o;",
     "const float eta_num = mode == PF_TRANSPORT_IMPORTANCE ? c.eta_o : c.eta_i;"),
    ("bsdf_shared.h", "bsdf_shared_test", "visibility: the two roots swapped",
     "const float den = ci * pf_ggx_root(co, alpha) + co * pf_ggx_root(ci, alpha);",
     "const float den = ci * pf_ggx_root(ci, alpha) + co * pf_ggx_root(co, alpha);"),
    ("bsdf_shared.h", "bsdf_shared_test", "D x1.05",
     "return a2 / (PF_S_PI * t * t);", "return 1.05f * a2 / (PF_S_PI * t * t);"),
    ("bsdf_shared.h", "bsdf_shared_test", "Veach factor: ns and ng swapped",
     "return PF_S_FABS(pf_dot3(wo, ns)) * PF_S_FABS(pf_dot3(wi, ng)) / den;",
     "return PF_S_FABS(pf_dot3(wo, ng)) * PF_S_FABS(pf_dot3(wi, ns)) / den;"),
    ("bsdf_shared.h", "bsdf_shared_test", "G1: 2|c| -> 1.9|c|",
     "return den > 0.0f ? (2.0f * ac) / den : 0.0f;", "return den > 0.0f ? (1.9f * ac) / den : 0.0f;"),
    ("bsdf_shared.h", "bsdf_shared_test", "VNDF warp: s = (1 + vh.z)/2 -> (1 + 0.9 vh.z)/2",
     "const float s = 0.5f * (1.0f + vh[2]);", "const float s = 0.5f * (1.0f + 0.9f * vh[2]);"),
    ("bsdf_shared.h", "bsdf_shared_test", "refraction: cos_t x0.97",
     "const float s = e * c - cos_t;", "const float s = e * c - 0.97f * cos_t;"),
    ("texture_shared.h", "texture_shared_test", "bilinear: no half-texel offset",
     "const float xs = x - 0.5f, ys = y - 0.5f;", "const float xs = x, ys = y - 0.5f;"),
    ("texture_shared.h", "texture_shared_test", "bilinear: weights fx and 1 - fx swapped",
     "const float top = a[k] * (1.0f - fx) + b[k] * fx;", "const float top = a[k] * fx + b[k] * (1.0f - fx);"),
    ("texture_shared.h", "texture_shared_test", "mirrored repeat: off by one",
     "return m < n ? m : p - 1 - m;", "return m < n ? m : (p - m) % n;"),
    ("texture_shared.h", "texture_shared_test", "UV convention: v flipped",
     "v = pf_tex_reduce(v, tex->wrap_t);", "v = pf_tex_reduce(1.0f - v, tex->wrap_t);"),
    ("texture_shared.h", "texture_shared_test", "sRGB: exponent 2.4 -> 2.2",
     "return PF_T_POW((c + 0.055f) / 1.055f, 2.4f);", "return PF_T_POW((c + 0.055f) / 1.055f, 2.2f);"),
    ("texture_shared.h", "texture_shared_test", "sRGB: linear slope 12.92 -> 12",
     "if (c <= 0.04045f) return c / 12.92f;", "if (c <= 0.04045f) return c / 12.0f;"),
    ("lens_shared.h", "lens_shared_test", "focus point: no division by dir.forward",
     "const float t = focus_distance / df;", "const float t = focus_distance;"),
    ("lens_shared.h", "lens_shared_test", "lens point: half the aperture",
     "const float l = o[k] + (right[k] * x + up[k] * y) * aperture;",
     "const float l = o[k] + (right[k] * x + up[k] * y) * (0.5f * aperture);"),
    ("lens_shared.h", "lens_shared_test", "circle of confusion: / d instead of / z",
     "return 2.0f * aperture * PF_S_FABS(z - focus_distance) / z;",
     "return 2.0f * aperture * PF_S_FABS(z - focus_distance) / focus_distance;"),
    ("lens_shared.h", "lens_shared_test", "lens sample: square instead of disc",
     "pf_sample_concentric_disc(u1, u2, &x, &y);\n  const float t",
     "x = 2.0f * u1 - 1.0f;\n  y = 2.0f * u2 - 1.0f;\n  const float t"),
    ("texture_shared.h", "material_shared_cl_test", "device only: floor -> ceil",
     "#define PF_T_FLOOR(x) floor(x)", "#define PF_T_FLOOR(x) ceil(x)"),
    ("bsdf_shared.h", "material_shared_cl_test", "a C++ reference in the shared code",
     "PF_INLINE float pf_pow5(float x) {\n  const float x2 = x * x;",
     "PF_INLINE float pf_pow5(float x) {\n  const float& xr = x;\n  const float x2 = xr * x;"),
]
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from mutation_runner import run_mutations  # noqa: E402

sys.exit(run_mutations([(M + h, test, name, a, b) for h, test, name, a, b in MUTATIONS], BUILD,
                       lambda test: test,
                       "bsdf_shared_test texture_shared_test lens_shared_test material_shared_cl_test"))
