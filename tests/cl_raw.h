// cl_raw.h — the few raw OpenCL objects the shared-header tests make themselves (a kernel that
// #includes a header shared with the host, built outside the library's ClContext): RAII handles,
// the first device of any platform, and a read-only buffer holding a vector.
#pragma once
#include <CL/cl.h>

#include <string>
#include <vector>

namespace pf::test {

template <class T, cl_int (*Release)(T)>
struct ClHandle {
  T h = nullptr;
  ClHandle() = default;
  explicit ClHandle(T x) : h(x) {}
  ClHandle(const ClHandle&) = delete;
  ClHandle& operator=(const ClHandle&) = delete;
  ~ClHandle() {
    if (h) Release(h);
  }
};
using ClContextHandle = ClHandle<cl_context, clReleaseContext>;
using ClQueueHandle = ClHandle<cl_command_queue, clReleaseCommandQueue>;
using ClProgramHandle = ClHandle<cl_program, clReleaseProgram>;
using ClKernelHandle = ClHandle<cl_kernel, clReleaseKernel>;
using ClBufferHandle = ClHandle<cl_mem, clReleaseMemObject>;

// A read-only device buffer initialised with `v`.
template <class T>
cl_mem upload(cl_context ctx, const std::vector<T>& v, cl_int* err) {
  return clCreateBuffer(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, sizeof(T) * v.size(),
                        const_cast<T*>(v.data()), err);
}

// First device of the first platform that has one, and that platform's name; false if none.
inline bool find_device(cl_device_id& device, std::string& platform_name) {
  cl_uint n = 0;
  if (clGetPlatformIDs(0, nullptr, &n) != CL_SUCCESS || n == 0) return false;
  std::vector<cl_platform_id> platforms(n);
  clGetPlatformIDs(n, platforms.data(), nullptr);
  for (cl_platform_id p : platforms) {
    if (clGetDeviceIDs(p, CL_DEVICE_TYPE_ALL, 1, &device, nullptr) != CL_SUCCESS) continue;
    char buf[256] = {};
    clGetPlatformInfo(p, CL_PLATFORM_NAME, sizeof buf - 1, buf, nullptr);
    platform_name = buf;
    return true;
  }
  return false;
}

// Builds `program` for `device` with `options`; false on failure, with the compiler's build log
// in `log`.
inline bool build_program(cl_program program, cl_device_id device,
                          const std::string& options, std::string& log) {
  if (clBuildProgram(program, 1, &device, options.c_str(), nullptr, nullptr) == CL_SUCCESS)
    return true;
  size_t len = 0;
  clGetProgramBuildInfo(program, device, CL_PROGRAM_BUILD_LOG, 0, nullptr, &len);
  log.assign(len, '\0');
  if (len) clGetProgramBuildInfo(program, device, CL_PROGRAM_BUILD_LOG, len, &log[0], nullptr);
  return false;
}

// The short names the tests use: `using namespace pf::test::cl_raw;`.
namespace cl_raw {
using Context = ClContextHandle;
using Queue = ClQueueHandle;
using Program = ClProgramHandle;
using Kernel = ClKernelHandle;
using Buffer = ClBufferHandle;
using pf::test::build_program;
using pf::test::find_device;
using pf::test::upload;
}  // namespace cl_raw

}  // namespace pf::test
