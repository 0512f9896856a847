// Image synthesis: see synthesize.h.
#include "photonflow/stages/synthesize.h"

#include "photonflow/estimators/ppm.h"

namespace pf {

Image synthesize(const HitpointSet& h) {
  Image img(h.width, h.height);
  for (size_t i = 0; i < img.rgb.size(); ++i) img.rgb[i] = h.emitted[i] + h.direct[i];
  std::vector<float>& radius = img.layer("radius");
  std::vector<float>& photons = img.layer("photons");
  std::vector<float>& count = img.layer("hitpoints");
  for (const pf_hitpoint& hp : h.hitpoints) {
    size_t o = img.offset(hp.pixel_x, hp.pixel_y);
    if (h.photons_emitted > 0) {
      for (int c = 0; c < 3; ++c)  // eq. 3.19
        img.rgb[3 * o + size_t(c)] +=
            hp.weight[c] * pf_ppm_radiance(hp.flux[c], hp.radius, float(h.photons_emitted));
    }
    radius[o] += hp.radius;
    photons[o] += hp.n_photons;
    count[o] += 1.f;
  }
  for (size_t o = 0; o < img.pixel_count(); ++o) {
    if (count[o] > 0.f) {
      radius[o] /= count[o];
      photons[o] /= count[o];
    }
  }
  return img;
}

}  // namespace pf
