// Tests of AddressSpaceCap (memory_cap.h): allocations past the budget fail with std::bad_alloc,
// grow() raises the budget, the previous limit comes back when the cap goes, and a soft limit set
// lower beforehand is kept. Inactive in AddressSanitizer builds (its operator new aborts instead
// of throwing), where these tests skip with a warning.
#include <catch2/catch.hpp>

#include <new>

#include "photonflow/foundations/memory_cap.h"

using namespace pf;

namespace {

constexpr uint64_t kMiB = uint64_t(1) << 20;

// Whether `bytes` can be allocated now. The explicit operator new call is not elided (a
// new-expression paired with its delete may be) and touches no page.
bool can_allocate(uint64_t bytes) {
  try {
    void* p = ::operator new(size_t(bytes));
    ::operator delete(p);
    return true;
  } catch (const std::bad_alloc&) {
    return false;
  }
}

bool same_limit(const rlimit& a, const rlimit& b) {
  return a.rlim_cur == b.rlim_cur && a.rlim_max == b.rlim_max;
}

}  // namespace

TEST_CASE("address_space_bytes reads the process's mapped size", "[memory_cap]") {
  const uint64_t before = address_space_bytes();
  CHECK(before > 0);
  void* p = ::operator new(size_t(256 * kMiB));  // mapped, not touched
  CHECK(address_space_bytes() >= before + 256 * kMiB);
  ::operator delete(p);
}

TEST_CASE("AddressSpaceCap: past the budget allocations fail, grow() raises it, the limit comes "
          "back",
          "[memory_cap]") {
  if (!AddressSpaceCap::supported()) {
    WARN("SKIPPED: address-space caps are off in sanitizer builds");
    return;
  }
  rlimit before{};
  REQUIRE(getrlimit(RLIMIT_AS, &before) == 0);
  REQUIRE(can_allocate(512 * kMiB));
  {
    AddressSpaceCap cap(64 * kMiB);
    REQUIRE(cap.active());
    CHECK(cap.budget() == 64 * kMiB);
    CHECK(can_allocate(16 * kMiB));
    CHECK_FALSE(can_allocate(512 * kMiB));
    cap.grow(512 * kMiB);
    CHECK(cap.budget() == 576 * kMiB);
    CHECK(can_allocate(512 * kMiB));
    CHECK_FALSE(can_allocate(1024 * kMiB));
  }
  rlimit after{};
  REQUIRE(getrlimit(RLIMIT_AS, &after) == 0);
  CHECK(same_limit(before, after));
  CHECK(can_allocate(1024 * kMiB));
}

TEST_CASE("AddressSpaceCap keeps a lower soft limit the process already had", "[memory_cap]") {
  if (!AddressSpaceCap::supported()) {
    WARN("SKIPPED: address-space caps are off in sanitizer builds");
    return;
  }
  rlimit original{};
  REQUIRE(getrlimit(RLIMIT_AS, &original) == 0);
  rlimit lowered = original;
  lowered.rlim_cur = rlim_t(address_space_bytes() + 128 * kMiB);
  REQUIRE(setrlimit(RLIMIT_AS, &lowered) == 0);
  {
    AddressSpaceCap cap(4096 * kMiB);  // looser than the process's own limit
    CHECK(cap.active());
    CHECK_FALSE(can_allocate(512 * kMiB));
  }
  rlimit after{};
  REQUIRE(getrlimit(RLIMIT_AS, &after) == 0);
  CHECK(same_limit(after, lowered));
  CHECK_FALSE(can_allocate(512 * kMiB));
  REQUIRE(setrlimit(RLIMIT_AS, &original) == 0);
  CHECK(can_allocate(512 * kMiB));
}
