// Address-space cap around runaway-prone parsers (see memory_cap.h).
#include "photonflow/foundations/memory_cap.h"

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <limits>

// Sanitizers reserve terabytes of shadow address space, which any cap would refuse.
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define PF_SANITIZER_BUILD 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
#define PF_SANITIZER_BUILD 1
#endif
#endif

namespace pf {

uint64_t physical_memory_bytes() {
  const long pages = sysconf(_SC_PHYS_PAGES), size = sysconf(_SC_PAGE_SIZE);
  return pages > 0 && size > 0 ? uint64_t(pages) * uint64_t(size) : 0;
}

uint64_t address_space_bytes() {
  std::FILE* f = std::fopen("/proc/self/statm", "r");
  if (!f) return 0;
  unsigned long long pages = 0;
  const int got = std::fscanf(f, "%llu", &pages);
  std::fclose(f);
  const long page = sysconf(_SC_PAGESIZE);
  return got == 1 && page > 0 ? uint64_t(pages) * uint64_t(page) : 0;
}

bool AddressSpaceCap::supported() {
#ifdef PF_SANITIZER_BUILD
  return false;
#else
  return true;
#endif
}

AddressSpaceCap::AddressSpaceCap(uint64_t budget_bytes) : budget_(budget_bytes) {
  if (!supported() || getrlimit(RLIMIT_AS, &saved_) != 0) return;
  base_ = address_space_bytes();
  if (base_ == 0) return;
  active_ = true;
  apply();
}

AddressSpaceCap::~AddressSpaceCap() {
  if (active_) setrlimit(RLIMIT_AS, &saved_);
}

void AddressSpaceCap::grow(uint64_t bytes) {
  const uint64_t most = std::numeric_limits<uint64_t>::max();
  budget_ = budget_ > most - bytes ? most : budget_ + bytes;
  if (active_) apply();
}

void AddressSpaceCap::apply() {
  const uint64_t most = std::numeric_limits<uint64_t>::max();
  uint64_t limit = base_ > most - budget_ ? most : base_ + budget_;
  if (saved_.rlim_cur != RLIM_INFINITY) limit = std::min<uint64_t>(limit, saved_.rlim_cur);
  rlimit r = saved_;
  r.rlim_cur = rlim_t(limit);
  if (saved_.rlim_max != RLIM_INFINITY) r.rlim_cur = std::min(r.rlim_cur, saved_.rlim_max);
  if (setrlimit(RLIMIT_AS, &r) != 0) {
    setrlimit(RLIMIT_AS, &saved_);
    active_ = false;
  }
}

}  // namespace pf
