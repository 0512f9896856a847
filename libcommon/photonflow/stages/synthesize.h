// synthesize.h — image synthesis (thesis ch. 7.2, last block): every hitpoint adds
// weight · L to its pixel, with L = τ / (π R² N_emitted) (thesis eq. 3.19), on top of the emitted
// and direct layers of the eye pass.
//
// AOV layers: "radius" (mean R of the pixel's hitpoints, world units), "photons" (mean N),
// "hitpoints" (hitpoints per pixel).
#pragma once
#include "photonflow/image/image.h"
#include "photonflow/io/stage_files.h"

namespace pf {

Image synthesize(const HitpointSet& h);

}  // namespace pf
