/*
 * scene_features.h — what the scene has, as compile-time constants of the tracing and gather
 * kernels (trace_common.h, illuminate_methods.cl).
 *
 *   macro              1 (default)                          0 (scene_kernel_variant, cl_backend.h)
 *   PF_SCENE_PBR       PF_MAT_PBR materials are handled     no material is PF_MAT_PBR
 *   PF_SCENE_TEXTURES  texture lookups are made             the scene has no textures
 *   PF_SCENE_ALPHA     cut-away points are skipped (leaf    no material is alpha-masked
 *                      test) and emit nothing (light samples)
 *
 * The host builds a kernel with a macro at 0 only for a scene that lacks the feature (the
 * program variant's options, ClContext::kernel), so every variant takes the same paths and
 * returns the same bits for that scene; a 0 merely lets the compiler drop branches the scene
 * never takes. That matters on PoCL, which vectorises a work-group's work-items together: a
 * branch one work-item could take costs every work-item its registers (docs/BENCHMARKS.md "Materials, alpha cut-outs and
 * lights: a diffuse scene's pass rate").
 * Without options (PHOTONFLOW_KERNEL_DIR builds by hand, tests that build a program directly)
 * every feature is on, which is correct for every scene.
 */
#ifndef PF_KERNEL_SCENE_FEATURES_H
#define PF_KERNEL_SCENE_FEATURES_H

#ifndef PF_SCENE_PBR
#define PF_SCENE_PBR 1
#endif
#ifndef PF_SCENE_TEXTURES
#define PF_SCENE_TEXTURES 1
#endif
#ifndef PF_SCENE_ALPHA
#define PF_SCENE_ALPHA 1
#endif

#endif
