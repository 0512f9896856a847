#!/usr/bin/env python3
"""mutate_textures.py — check that tests/image/texture_image_test.cpp can fail (issue 32 item 1).

Applies one small mutation at a time to the texture code of the bake, the scene file and the CPU
shading (a texture left out of the eye pass, the photon bounce or the path tracer, no sRGB
decode, no v flip, the texCoord or the wrap modes ignored, an image stored twice, the scene id
or the loader's checks weakened, the missing-texture warning dropped, damaged JPEGs or oversized
images accepted, the OpenCL tracers without the texture), rebuilds texture_image_test and the tools it runs, runs
it, and reports which test cases fail; the source is restored afterwards, whatever happens.
Every mutation must make at least one test case fail: the script exits 1 if one survives.

Run from the repository root with a configured build folder (default build/):
    python3 tests/mutate_textures.py [build-dir]
It builds texture_image_test, scene-bake, render and trace-hitpoints (-j2), about a minute per
mutation. MUTATE_ONLY=<text> runs only the mutations whose name contains <text>.
"""
import os
import sys

BUILD = sys.argv[1] if len(sys.argv) > 1 else "build"
TARGETS = "texture_image_test scene-bake render trace-hitpoints"
S = "libcommon/photonflow/"
MUTATIONS = [
    # (file, name, original, mutated)
    (S + "stages/eye_pass.cpp", "eye pass: texture not in the hitpoint weight",
     "if (texture >= 0) T = T * scene_.texture_value(", "if (false) T = T * scene_.texture_value("),
    (S + "stages/photon_pass.cpp", "photon bounce: colour factor alone",
     "const Vec3 color = diffuse_color(scene, m, sh);", "const Vec3 color(m.color);"),
    (S + "stages/pathtrace.cpp", "path tracer: colour factor alone",
     "const Vec3 albedo = diffuse_color(scene_, m, sh);", "const Vec3 albedo(m.color);"),
    (S + "geometry/scene_import.cpp", "bake: no sRGB decode",
     "t[size_t(i)] = pf_srgb8_to_linear(i);", "t[size_t(i)] = float(i) / 255.f;"),
    (S + "geometry/scene_import.cpp", "bake: no v flip",
     "v = 1.f - tex[idx[k]].y;", "v = tex[idx[k]].y;"),
    (S + "geometry/scene_import.cpp", "bake: texCoord ignored",
     "uv_channel_[i] = ref->uv_channel;", "uv_channel_[i] = 0;"),
    (S + "geometry/scene_import.cpp", "bake: wrap modes ignored",
     "r.wrap_s = wrap_mode(modes[0]);", "r.wrap_s = PF_TEX_WRAP_REPEAT;"),
    (S + "geometry/scene_import.cpp", "bake: magFilter ignored",
     "r.filter = PF_TEX_FILTER_NEAREST;  // GL NEAREST", "r.filter = PF_TEX_FILTER_BILINEAR;"),
    (S + "geometry/scene_import.cpp", "bake: an image decoded again for every material",
     "auto image = images_.find(key);", "auto image = images_.end();"),
    (S + "geometry/scene_import.cpp", "bake: missing texture without a warning",
     "report_.warnings.push_back(file + \": material '\" + material + \"': texture '\" + name +",
     "std::string(file + \": material '\" + material + \"': texture '\" + name +"),
    (S + "geometry/scene.cpp", "scene id: texels not covered",
     "    feed(texels);\n", "\n"),
    (S + "geometry/scene.cpp", "scene id: UVs not covered",
     "    feed(uvs);\n", "\n"),
    (S + "geometry/scene_validate.cpp", "load: texel values unchecked",
     "for (size_t i = 0; i < pool; ++i) v.in_range(Name(P, i), &s.texels[4 * i], 4, 0.0, 1.0);",
     "for (size_t i = 0; i < 0; ++i) v.in_range(Name(P, i), &s.texels[4 * i], 4, 0.0, 1.0);"),
    (S + "geometry/scene_validate.cpp", "load: texture past the pool accepted",
     "if (uint64_t(t.offset) + uint64_t(t.width) * uint64_t(t.height) > pool)",
     "if (uint64_t(t.offset) > pool)"),
    (S + "geometry/scene_validate.cpp", "load: missing UVs accepted",
     "if (textured && s.uvs.size() != s.triangles.size())",
     "if (textured && !s.uvs.empty() && s.uvs.size() != s.triangles.size())"),
    (S + "image/texture_image.cpp", "JPEG: corrupt-data warnings tolerated",
     "if (level < 0) jpeg_on_error(c);", "(void)level;"),
    (S + "image/texture_image.cpp", "size limit: one texel more a side",
     "w > uint64_t(max_side) || h > uint64_t(max_side)",
     "w > uint64_t(max_side) + 1 || h > uint64_t(max_side)"),
    (S + "image/texture_image.cpp", "size limit: texel budget unchecked",
     "|| w * h > max_texels)", ")"),
    ("kernels/trace_hitpoints.cl", "OpenCL eye pass: texture not in the weight",
     "for (int k = 0; k < 3; ++k) T[k] = T[k] * tf[k];", "for (int k = 0; k < 3; ++k) T[k] = T[k];"),
    ("kernels/trace_photons.cl", "OpenCL photon bounce: colour factor alone",
     "for (int k = 0; k < 3; ++k) c[k] = c[k] * tf[k];", "for (int k = 0; k < 3; ++k) c[k] = c[k];"),
    ("kernels/trace_common.h", "OpenCL: UV interpolated with u and v swapped",
     "const float s = w * uv[0] + h->u * uv[2] + h->v * uv[4];",
     "const float s = w * uv[0] + h->v * uv[2] + h->u * uv[4];"),
]
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from mutation_runner import run_mutations  # noqa: E402

sys.exit(run_mutations([(path, "texture_image_test", name, a, b) for path, name, a, b in MUTATIONS],
                       BUILD, lambda test: TARGETS, TARGETS, env=f"PF_BIN={BUILD}/bin"))
