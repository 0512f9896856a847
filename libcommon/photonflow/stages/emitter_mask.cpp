// Emitter mask: see emitter_mask.h.
#include "photonflow/stages/emitter_mask.h"

#include <algorithm>
#include <vector>

#include "photonflow/foundations/error.h"
#include "photonflow/stages/eye_pass.h"

namespace pf {

EmitterMask emitter_mask(const Scene& scene, const EmitterMaskOptions& opt) {
  if (opt.spp < 1) throw input_error("", "spp must be >= 1, got " + std::to_string(opt.spp));
  if (opt.dilate < 0)
    throw input_error("", "dilate must be >= 0, got " + std::to_string(opt.dilate));
  // One eye sample per pixel and pass, `spp` passes: pass p's sample of a pixel is point p of
  // the pixel's scrambled (0,2)-sequence (pixel_sampler.h), so the first spp of them are
  // stratified as spp samples of one pass would be, while memory holds one pass's visible points
  // (W·H, not W·H·spp: 512² × 1024 samples no longer need tens of GB).
  EyePassOptions eye;
  eye.spp = 1;
  eye.sampler = PixelSampler::Sobol;
  eye.max_depth = opt.max_depth;
  eye.seed = opt.seed;
  eye.threads = opt.threads;
  const int W = scene.camera.width, H = scene.camera.height;
  std::vector<uint8_t> sees(size_t(W) * size_t(H), 0);
  EyePassResult r;
  EyePassWork work;
  for (int pass = 0; pass < opt.spp; ++pass) {
    eye.pass = uint32_t(pass);
    trace_hitpoints_into(scene, eye, r, work);
    for (size_t p = 0; p < sees.size(); ++p) {
      const float* e = &r.emitted[3 * p];
      if (e[0] > 0.f || e[1] > 0.f || e[2] > 0.f) sees[p] = 1;
    }
  }
  EmitterMask out;
  for (uint8_t v : sees) out.seeing += v;
  out.mask = Image(W, H);
  const int d = opt.dilate;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      bool near = false;
      for (int yy = std::max(0, y - d); yy <= std::min(H - 1, y + d) && !near; ++yy)
        for (int xx = std::max(0, x - d); xx <= std::min(W - 1, x + d) && !near; ++xx)
          near = sees[size_t(yy) * size_t(W) + size_t(xx)] != 0;
      out.mask.set(x, y, near ? Vec3(0.f, 0.f, 0.f) : Vec3(1.f, 1.f, 1.f));
      out.excluded += near;
    }
  return out;
}

}  // namespace pf
