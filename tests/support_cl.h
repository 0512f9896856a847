// support_cl.h — the OpenCL device of the tests (PoCL in CI).
#pragma once
#include <catch2/catch.hpp>

#include <memory>

#include "photonflow/cl_runtime.h"

namespace pf::test {

// The device --device opencl would pick; nullptr (and a WARN) when there is none, so that a
// machine without OpenCL skips the device tests visibly instead of failing them.
inline std::unique_ptr<ClContext> test_device() {
  if (cl_list_devices().empty()) {
    WARN("SKIPPED: no OpenCL platform with a device (install pocl-opencl-icd to run this test)");
    return nullptr;
  }
  DeviceOptions o;
  o.device = "opencl";
  return open_device(o, "test");
}

}  // namespace pf::test
