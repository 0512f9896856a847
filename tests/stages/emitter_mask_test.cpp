// Emitter mask (emitter_mask.h): which pixels see a lamp does not depend on the lamp's colour —
// a lamp that emits in one channel only (pure red, green or blue) is left out like a white one.
#include <catch2/catch.hpp>

#include "photonflow/stages/emitter_mask.h"
#include "support.h"

using namespace pf;

TEST_CASE("emitter mask: a lamp of one colour channel is left out like a white lamp",
          "[emitter-mask]") {
  const int lamp = 3;  // material id of the lamp in test::room_scene
  EmitterMaskOptions o;
  o.spp = 4;
  o.dilate = 0;
  auto mask_for = [&](float r, float g, float b) {
    Scene s = test::room_scene(PF_MAT_DIFFUSE, 24, 24);
    // Looking up at the ceiling lamp from the centre of the room.
    s.camera = pf_camera{{0.5f, 0.3f, 0.5f}, {0.5f, 1.f, 0.5f}, {0, 0, 1}, 60.f, 24, 24};
    pf_material& m = s.materials[size_t(lamp)];
    m.emission[0] = r;
    m.emission[1] = g;
    m.emission[2] = b;
    finish_scene(s);
    return emitter_mask(s, o);
  };
  const EmitterMask white = mask_for(20.f, 20.f, 20.f);
  REQUIRE(white.seeing > 10);
  REQUIRE(white.seeing < size_t(24 * 24));
  for (int c = 0; c < 3; ++c) {
    INFO("channel " << c);
    const EmitterMask one = mask_for(c == 0 ? 20.f : 0.f, c == 1 ? 20.f : 0.f, c == 2 ? 20.f : 0.f);
    CHECK(one.seeing == white.seeing);
    CHECK(one.excluded == white.excluded);
    CHECK(one.mask.rgb == white.mask.rgb);
  }
}

TEST_CASE("emitter mask: more samples leave out a superset of pixels, one pass of samples at a "
          "time",
          "[emitter-mask]") {
  // spp samples of a pixel are the first spp points of its (0,2)-sequence, traced one eye pass
  // at a time (memory for one pass): the samples of spp 4 are among those of spp 32, so every
  // pixel left out at 4 is left out at 32, and 32 finds outline pixels that 4 misses. One
  // sample is the pixel's first point alone.
  Scene s = test::room_scene(PF_MAT_DIFFUSE, 40, 40);
  s.camera = pf_camera{{0.5f, 0.3f, 0.5f}, {0.5f, 1.f, 0.5f}, {0, 0, 1}, 60.f, 40, 40};
  finish_scene(s);
  EmitterMaskOptions o;
  o.dilate = 0;
  o.spp = 1;
  const EmitterMask one = emitter_mask(s, o);
  o.spp = 4;
  const EmitterMask few = emitter_mask(s, o);
  o.spp = 32;
  const EmitterMask many = emitter_mask(s, o);
  REQUIRE(one.seeing > 10);
  size_t not_kept = 0;
  for (size_t i = 0; i < few.mask.rgb.size(); ++i) {
    not_kept += few.mask.rgb[i] == 0.f && many.mask.rgb[i] != 0.f;
    not_kept += one.mask.rgb[i] == 0.f && few.mask.rgb[i] != 0.f;
  }
  CHECK(not_kept == 0);
  INFO("pixels seeing the lamp: 1 spp " << one.seeing << ", 4 spp " << few.seeing << ", 32 spp "
                                        << many.seeing);
  CHECK(few.seeing >= one.seeing);
  CHECK(many.seeing > few.seeing);
  CHECK(many.excluded == many.seeing);  // dilate 0
}
