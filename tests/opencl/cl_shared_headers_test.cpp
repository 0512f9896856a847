// rng.h and ppm.h compile as OpenCL C 1.2 and give the host's results on an OpenCL device
// (PoCL on the CPU in CI): random bits and floats bit-identical, the gather distance and rule
// bit-identical, the PPM update and radiance bit-identical too where the device rounds division
// and sqrt correctly (PoCL does; the kernels are built with -cl-fp32-correctly-rounded-divide-sqrt
// then), within a few ulp elsewhere. Without any OpenCL platform the test only warns.
#include <CL/cl.h>
#include <catch2/catch.hpp>

#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "photonflow/opencl/cl_runtime.h"
#include "photonflow/estimators/ppm.h"
#include "photonflow/foundations/rng.h"
#include "cl_raw.h"
#include "support.h"

namespace {

// FP_CONTRACT OFF at file level, as every kernel file has it (ppm.h also sets it in its own bodies).
const char* kKernels = R"CLC(
#pragma OPENCL FP_CONTRACT OFF
#include "photonflow/foundations/rng.h"
#include "photonflow/estimators/ppm.h"

__kernel void rng_bits(__global uint* out, uint seed, uint pass, uint dims) {
  uint i = get_global_id(0);
  pf_uint key = pf_rng_key(seed, pass);
  for (uint k = 0; k < dims; ++k) out[i * dims + k] = pf_rng_bits(key, i, k);
}

__kernel void rng_stream(__global float* out, uint seed, uint pass, uint dims) {
  uint i = get_global_id(0);
  pf_rng r = pf_rng_start(seed, pass, i);
  for (uint k = 0; k < dims; ++k) out[i * dims + k] = pf_rng_next(&r);
}

__kernel void gather_rule(__global const float* a, __global const float* b,
                          __global const float* radius, __global float* d2, __global int* inside) {
  uint i = get_global_id(0);
  d2[i] = pf_ppm_dist2(a[3 * i], a[3 * i + 1], a[3 * i + 2], b[3 * i], b[3 * i + 1], b[3 * i + 2]);
  inside[i] = pf_ppm_in_radius(d2[i], radius[i]);
}

__kernel void ppm_update(__global pf_hitpoint* hps, __global const int* m,
                         __global const float* tau, float alpha, float n_emitted,
                         __global float* radiance) {
  uint i = get_global_id(0);
  float t[3] = {tau[3 * i], tau[3 * i + 1], tau[3 * i + 2]};
  pf_ppm_update(&hps[i], m[i], t, alpha);
  radiance[i] = pf_ppm_radiance(hps[i].flux[0], hps[i].radius, n_emitted);
}
)CLC";

// Minimal OpenCL session on the first device of the first platform.
struct Cl {
  cl_context ctx = nullptr;
  cl_command_queue queue = nullptr;
  cl_program program = nullptr;
  cl_device_id device = nullptr;
  ~Cl() {
    if (program) clReleaseProgram(program);
    if (queue) clReleaseCommandQueue(queue);
    if (ctx) clReleaseContext(ctx);
  }
};

bool open_cl(Cl& cl, std::string& why) {
  cl_platform_id platform;
  cl_uint n = 0;
  if (clGetPlatformIDs(1, &platform, &n) != CL_SUCCESS || n == 0) {
    why = "no OpenCL platform";
    return false;
  }
  if (clGetDeviceIDs(platform, CL_DEVICE_TYPE_ALL, 1, &cl.device, &n) != CL_SUCCESS || n == 0) {
    why = "no OpenCL device";
    return false;
  }
  cl_int err;
  cl.ctx = clCreateContext(nullptr, 1, &cl.device, nullptr, nullptr, &err);
  REQUIRE(err == CL_SUCCESS);
  cl.queue = clCreateCommandQueue(cl.ctx, cl.device, 0, &err);
  REQUIRE(err == CL_SUCCESS);
  cl.program = clCreateProgramWithSource(cl.ctx, 1, &kKernels, nullptr, &err);
  REQUIRE(err == CL_SUCCESS);
  std::string options = "-cl-std=CL1.2 -I " + pf::test::source_dir() + "/libcommon" +
                        pf::cl_float_options(cl.device);
  std::string log;
  if (!pf::test::build_program(cl.program, cl.device, options, log))
    FAIL("OpenCL build of rng.h/ppm.h failed:\n" << log);
  return true;
}

cl_mem buffer(Cl& cl, size_t bytes, const void* init = nullptr) {
  cl_int err;
  cl_mem m = clCreateBuffer(cl.ctx, CL_MEM_READ_WRITE | (init ? CL_MEM_COPY_HOST_PTR : 0), bytes,
                            const_cast<void*>(init), &err);
  REQUIRE(err == CL_SUCCESS);
  return m;
}

void run(Cl& cl, cl_kernel k, size_t n) {
  REQUIRE(clEnqueueNDRangeKernel(cl.queue, k, 1, nullptr, &n, nullptr, 0, nullptr, nullptr) ==
          CL_SUCCESS);
  REQUIRE(clFinish(cl.queue) == CL_SUCCESS);
}

template <class T> std::vector<T> read(Cl& cl, cl_mem m, size_t n) {
  std::vector<T> v(n);
  REQUIRE(clEnqueueReadBuffer(cl.queue, m, CL_TRUE, 0, n * sizeof(T), v.data(), 0, nullptr,
                              nullptr) == CL_SUCCESS);
  return v;
}

cl_kernel kernel(Cl& cl, const char* name) {
  cl_int err;
  cl_kernel k = clCreateKernel(cl.program, name, &err);
  REQUIRE(err == CL_SUCCESS);
  return k;
}

}  // namespace

TEST_CASE("OpenCL: rng.h and ppm.h agree between host and device", "[rng][ppm][opencl]") {
  Cl cl;
  std::string why;
  if (!open_cl(cl, why)) {
    WARN("skipped: " << why);
    return;
  }
  const pf_uint seed = 777, pass = 3, dims = 8;
  const size_t n = 4096;

  {
    INFO("random bits and stream floats are bit-identical");
    cl_mem bits = buffer(cl, n * dims * sizeof(cl_uint));
    cl_mem floats = buffer(cl, n * dims * sizeof(cl_float));
    cl_kernel kb = kernel(cl, "rng_bits"), ks = kernel(cl, "rng_stream");
    for (cl_kernel k : {kb, ks}) {
      clSetKernelArg(k, 0, sizeof(cl_mem), k == kb ? &bits : &floats);
      clSetKernelArg(k, 1, sizeof(pf_uint), &seed);
      clSetKernelArg(k, 2, sizeof(pf_uint), &pass);
      clSetKernelArg(k, 3, sizeof(pf_uint), &dims);
      run(cl, k, n);
    }
    std::vector<cl_uint> dev_bits = read<cl_uint>(cl, bits, n * dims);
    std::vector<float> dev_floats = read<float>(cl, floats, n * dims);
    int bits_differ = 0, floats_differ = 0;
    const pf_uint key = pf_rng_key(seed, pass);
    for (pf_uint i = 0; i < n; ++i)
      for (pf_uint k = 0; k < dims; ++k) {
        bits_differ += dev_bits[i * dims + k] != pf_rng_bits(key, i, k);
        floats_differ += dev_floats[i * dims + k] != pf_rng_float(seed, pass, i, k);
      }
    CHECK(bits_differ == 0);
    CHECK(floats_differ == 0);
    clReleaseKernel(kb);
    clReleaseKernel(ks);
    clReleaseMemObject(bits);
    clReleaseMemObject(floats);
  }

  {
    INFO("gather distance and rule are bit-identical");
    std::vector<float> a(3 * n), b(3 * n), radius(n);
    for (pf_uint i = 0; i < n; ++i) {
      for (int c = 0; c < 3; ++c) {
        a[3 * i + c] = 10.f * pf_rng_float(1, 0, i, c) - 5.f;
        b[3 * i + c] = a[3 * i + c] + 0.3f * (pf_rng_float(1, 0, i, 3 + c) - 0.5f);
      }
      float d = std::sqrt(pf_ppm_dist2(a[3 * i], a[3 * i + 1], a[3 * i + 2], b[3 * i],
                                       b[3 * i + 1], b[3 * i + 2]));
      radius[i] = (i % 2) ? d : 0.25f * pf_rng_float(1, 0, i, 6);  // half on the boundary
    }
    cl_mem ma = buffer(cl, a.size() * 4, a.data()), mb = buffer(cl, b.size() * 4, b.data());
    cl_mem mr = buffer(cl, n * 4, radius.data()), md = buffer(cl, n * 4), mi = buffer(cl, n * 4);
    cl_kernel k = kernel(cl, "gather_rule");
    cl_mem args[5] = {ma, mb, mr, md, mi};
    for (int j = 0; j < 5; ++j) clSetKernelArg(k, j, sizeof(cl_mem), &args[j]);
    run(cl, k, n);
    std::vector<float> d2 = read<float>(cl, md, n);
    std::vector<int> inside = read<int>(cl, mi, n);
    int d2_differ = 0, rule_differ = 0;
    for (pf_uint i = 0; i < n; ++i) {
      float h = pf_ppm_dist2(a[3 * i], a[3 * i + 1], a[3 * i + 2], b[3 * i], b[3 * i + 1],
                             b[3 * i + 2]);
      d2_differ += d2[i] != h;
      rule_differ += inside[i] != pf_ppm_in_radius(h, radius[i]);
    }
    CHECK(d2_differ == 0);
    CHECK(rule_differ == 0);
    clReleaseKernel(k);
    for (cl_mem m : args) clReleaseMemObject(m);
  }

  {
    INFO("PPM update and radiance match the host");
    std::vector<pf_hitpoint> hps(n);
    std::vector<int> m(n);
    std::vector<float> tau(3 * n);
    for (pf_uint i = 0; i < n; ++i) {
      std::memset(&hps[i], 0, sizeof(pf_hitpoint));
      hps[i].radius = 0.01f + pf_rng_float(2, 0, i, 0);
      hps[i].n_photons = (i % 3 == 0) ? 0.f : 1000.f * pf_rng_float(2, 0, i, 1);
      for (int c = 0; c < 3; ++c) {
        hps[i].flux[c] = 50.f * pf_rng_float(2, 0, i, 2 + c);
        tau[3 * i + c] = 5.f * pf_rng_float(2, 0, i, 5 + c);
      }
      m[i] = (i % 5 == 0) ? 0 : static_cast<int>(100 * pf_rng_float(2, 0, i, 8));
    }
    const float alpha = 0.7f, n_emitted = 1e6f;
    cl_mem mh = buffer(cl, n * sizeof(pf_hitpoint), hps.data());
    cl_mem mm = buffer(cl, n * 4, m.data()), mt = buffer(cl, tau.size() * 4, tau.data());
    cl_mem ml = buffer(cl, n * 4);
    cl_kernel k = kernel(cl, "ppm_update");
    clSetKernelArg(k, 0, sizeof(cl_mem), &mh);
    clSetKernelArg(k, 1, sizeof(cl_mem), &mm);
    clSetKernelArg(k, 2, sizeof(cl_mem), &mt);
    clSetKernelArg(k, 3, sizeof(float), &alpha);
    clSetKernelArg(k, 4, sizeof(float), &n_emitted);
    clSetKernelArg(k, 5, sizeof(cl_mem), &ml);
    run(cl, k, n);
    std::vector<pf_hitpoint> dev = read<pf_hitpoint>(cl, mh, n);
    std::vector<float> dev_l = read<float>(cl, ml, n);
    // Where the device rounds division and sqrt correctly (cl_float_options asks for it), the
    // update and the radiance are the host's to the bit; elsewhere within a few ulp (OpenCL C
    // allows 2.5 ulp for division and 3 for sqrt).
    const bool exact = !pf::cl_float_options(cl.device).empty();
    int differ = 0;
    auto close = [&](float x, float y) {
      return exact ? std::memcmp(&x, &y, sizeof(float)) == 0
                   : std::fabs(x - y) <= 1e-6f * std::fabs(y) + 1e-30f;
    };
    for (pf_uint i = 0; i < n; ++i) {
      pf_hitpoint h = hps[i];
      pf_ppm_update(&h, m[i], &tau[3 * i], alpha);
      float l = pf_ppm_radiance(h.flux[0], h.radius, n_emitted);
      bool ok = close(dev[i].radius, h.radius) && close(dev[i].n_photons, h.n_photons) &&
                close(dev_l[i], l);
      for (int c = 0; c < 3; ++c) ok = ok && close(dev[i].flux[c], h.flux[c]);
      if (m[i] == 0 || exact) ok = ok && std::memcmp(&dev[i], &h, sizeof(pf_hitpoint)) == 0;
      differ += !ok;
    }
    INFO((exact ? "bit-identical" : "within 1e-6") << " expected");
    CHECK(differ == 0);
    clReleaseKernel(k);
    for (cl_mem b : {mh, mm, mt, ml}) clReleaseMemObject(b);
  }
}
