// raycast_packets.cpp — the switch between the SSE and AVX leaf tests of raycast_packets.h: AVX
// where the CPU has it, unless set_kd_leaf_avx (raycast.h) turned it off.
#include "photonflow/geometry/raycast_packets.h"

#include "photonflow/geometry/raycast.h"

namespace pf {

std::atomic<bool>& kd_leaf_avx() {
#ifdef PF_HAVE_AVX_LEAF
  static std::atomic<bool> on{__builtin_cpu_supports("avx") != 0};
#else
  static std::atomic<bool> on{false};
#endif
  return on;
}

bool set_kd_leaf_avx(bool on) {
  if (on && !kd_leaf_avx_supported()) return false;
  kd_leaf_avx().store(on);
  return true;
}

bool kd_leaf_avx_supported() {
#ifdef PF_HAVE_AVX_LEAF
  return __builtin_cpu_supports("avx") != 0;
#else
  return false;
#endif
}

}  // namespace pf
