// emitter_mask.h — which pixels of an image see a light source, directly or through mirrors and
// glass: the mask that error metrics (image_metrics.h, imgcompare --mask) use to leave them out.
//
// Why: an emitter seen by the camera has a radiance one to two orders of magnitude above the lit
// surfaces (17 against about 0.1–1 in the Cornell box), and along its outline a pixel's value is
// the emitter's radiance times the covered fraction of the pixel. That fraction depends only on
// how the pixel is sampled (photon mapping's eye pass uses a few fixed sample positions per pixel,
// the path tracer a fresh jittered position per sample), not on how light is transported, yet a
// handful of outline pixels would dominate the RMSE of the whole image. The speed–accuracy
// pipeline (pipelines/accuracy.mk) therefore compares images on the pixels that see no emitter.
//
// A pixel sees an emitter when any of `spp` eye samples (the first spp points of the pixel's
// (0,2)-sequence, traced one per eye pass so that memory holds one pass) reaches the front of an
// emitting surface along the eye pass's specular chain (eye_pass.h: the `emitted` layer, which
// follows mirrors and picks reflection or refraction at glass by the Fresnel probability). The
// excluded set is then grown by `dilate` pixels (a (2·dilate+1)² square), so that the outline
// pixels a finer sampling would catch are excluded too.
#pragma once
#include <cstddef>
#include <cstdint>

#include "photonflow/image/image.h"
#include "photonflow/geometry/scene.h"

namespace pf {

struct EmitterMaskOptions {
  int spp = 16;        // eye samples per pixel (stratified: pixel_sampler.h's sobol, one per pass)
  int dilate = 1;      // pixels added around the excluded set, in each direction
  int max_depth = 16;  // specular bounces followed
  uint32_t seed = 1;
  int threads = 0;     // 0 = all cores
};

struct EmitterMask {
  Image mask;             // RGB = 1 where a pixel is compared, 0 where it is left out
  size_t excluded = 0;    // pixels left out (after dilation)
  size_t seeing = 0;      // pixels where a sample saw an emitter (before dilation)
};

// The mask of the scene's camera image. InputError for spp < 1 or dilate < 0.
EmitterMask emitter_mask(const Scene& scene, const EmitterMaskOptions& opt);

}  // namespace pf
