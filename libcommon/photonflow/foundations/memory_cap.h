// memory_cap.h — a cap on how far a stretch of work may grow the process's address space, for
// third-party parsers that can run away on damaged input.
//
// assimp 5.2.5's COLLADA reader loops on an index list with a stray letter in it (`<p>… 1x 13 …`)
// and grows one vector until the allocator fails: 21 GB of zero-filled pages and 46 s on a 24 GiB
// machine before its std::bad_alloc, an out-of-memory kill where there is less. A cap turns that
// into a prompt std::bad_alloc inside the parser (which assimp reports as its error string), while
// well-formed files never meet it: scene-bake sets budget = 256 MiB + 64 × the bytes of the files
// assimp opens (measured: a 3.7 MB OBJ imports within 64 MiB, a 2.4 MB one within 32 MiB).
//
// The cap is RLIMIT_AS (setrlimit), lowered to the current address-space size (/proc/self/statm)
// plus the budget for the cap's lifetime and restored after it. It is process-wide, so it belongs
// around single-threaded work: another thread's allocations count against it too. scene-bake's
// imports run in a child process of their own (isolate.h), where nothing else runs. A soft limit
// the user set lower is kept. Inactive (active() false, no limit set) in AddressSanitizer builds,
// whose operator new aborts instead of throwing when the allocator fails, and where setrlimit or
// /proc fail.
#pragma once
#include <sys/resource.h>

#include <cstdint>

namespace pf {

// Bytes of address space the process has mapped now (VmSize); 0 if /proc cannot be read.
uint64_t address_space_bytes();
// Bytes of physical memory of this machine (sysconf); 0 if unknown.
uint64_t physical_memory_bytes();

class AddressSpaceCap {
 public:
  explicit AddressSpaceCap(uint64_t budget_bytes);  // growth allowed from now on
  ~AddressSpaceCap();                               // restores the previous limit
  AddressSpaceCap(const AddressSpaceCap&) = delete;
  AddressSpaceCap& operator=(const AddressSpaceCap&) = delete;

  void grow(uint64_t bytes);  // raises the budget (e.g. per input file opened)
  uint64_t budget() const { return budget_; }
  bool active() const { return active_; }
  static bool supported();  // false in sanitizer builds

 private:
  void apply();
  rlimit saved_{};
  uint64_t base_ = 0, budget_ = 0;
  bool active_ = false;
};

}  // namespace pf
