// light_choice_shared.h (next-event estimation's light choice, Scene::sample_light) compiles as
// OpenCL C 1.2 and gives the host's probabilities and picks bit for bit on an OpenCL device
// (PoCL on the CPU in CI; the kernels' float options round division and sqrt correctly), for
// area, point, spot and directional lights at points all over a room. Without any OpenCL
// platform the test only warns.
#include <CL/cl.h>
#include <catch2/catch.hpp>

#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "photonflow/geometry/light_choice_shared.h"
#include "photonflow/geometry/scene.h"
#include "photonflow/opencl/cl_runtime.h"
#include "cl_raw.h"
#include "support.h"

namespace {

const char* kKernel = R"CLC(
#pragma OPENCL FP_CONTRACT OFF
#include "photonflow/geometry/light_choice_shared.h"

/* One work-item per point (3 floats) and number u: the n probabilities, then the pick. */
__kernel void choose(__global const pf_light* lights, __global const pf_light_choice* choice,
                     int n, __global const float* points, __global const float* us,
                     __global float* pr_out, __global int* pick_out) {
  const size_t i = get_global_id(0);
  const float x[3] = {points[3 * i], points[3 * i + 1], points[3 * i + 2]};
  float pr[PF_LIGHT_CHOICE_MAX];
  pf_light_choice_probabilities(lights, choice, n, x, pr);
  for (int k = 0; k < n; ++k) pr_out[i * (size_t)n + (size_t)k] = pr[k];
  pick_out[i] = pf_light_choice_pick(pr, n, us[i]);
}
)CLC";

using namespace pf::test::cl_raw;

pf_light punctual(int type, pf::Vec3 pos, pf::Vec3 dir, float intensity) {
  pf_light l{};
  l.type = type;
  pos.store(l.position);
  dir.store(l.direction);
  for (float& c : l.radiance) c = intensity;
  if (type == PF_LIGHT_SPOT) {
    l.cos_inner = 0.9f;
    l.cos_outer = 0.8f;
  }
  return l;
}

}  // namespace

TEST_CASE("light_choice_shared.h runs as OpenCL C and picks the host's light",
          "[light-choice][opencl]") {
  cl_device_id device;
  std::string platform_name;
  if (!find_device(device, platform_name)) {
    WARN("SKIPPED: no OpenCL platform with a device (install pocl-opencl-icd to run this test)");
    return;
  }
  INFO("OpenCL platform: " << platform_name);
  // The room's lamp (an emitter of 12 triangles) and a spot, a point and a directional light.
  pf::Scene s = pf::test::room_scene(PF_MAT_DIFFUSE, 8, 8);
  s.lights.push_back(punctual(PF_LIGHT_SPOT, {0.7f, 0.9f, 0.6f}, {0.f, -1.f, 0.f}, 0.8f));
  s.lights.push_back(punctual(PF_LIGHT_POINT, {0.2f, 0.5f, 0.3f}, {}, 0.05f));
  s.lights.push_back(
      punctual(PF_LIGHT_DIRECTIONAL, {}, pf::normalize(pf::Vec3(0.3f, -1.f, 0.2f)), 0.5f));
  pf::finish_scene(s);
  REQUIRE(s.light_choice.size() == s.lights.size());
  const int n = int(s.lights.size());

  std::mt19937 rng(5);
  std::uniform_real_distribution<float> uni(0.f, 1.f);
  const size_t count = 2048;
  std::vector<float> points, us;
  for (size_t i = 0; i < count; ++i) {
    points.insert(points.end(), {uni(rng), uni(rng), uni(rng)});
    us.push_back(uni(rng));
  }
  std::vector<float> host_pr(count * size_t(n));
  std::vector<int> host_pick(count);
  for (size_t i = 0; i < count; ++i) {
    pf_light_choice_probabilities(s.lights.data(), s.light_choice.data(), n, &points[3 * i],
                                  &host_pr[i * size_t(n)]);
    host_pick[i] = pf_light_choice_pick(&host_pr[i * size_t(n)], n, us[i]);
  }

  cl_int err = CL_SUCCESS;
  Context ctx(clCreateContext(nullptr, 1, &device, nullptr, nullptr, &err));
  REQUIRE(err == CL_SUCCESS);
  Queue queue(clCreateCommandQueue(ctx.h, device, 0, &err));
  REQUIRE(err == CL_SUCCESS);
  Program program(clCreateProgramWithSource(ctx.h, 1, &kKernel, nullptr, &err));
  REQUIRE(err == CL_SUCCESS);
  const std::string options = "-cl-std=CL1.2 -I " + pf::test::source_dir() + "/libcommon" +
                              pf::cl_float_options(device);
  std::string log;
  if (!build_program(program.h, device, options, log)) FAIL("OpenCL build failed:\n" << log);
  Kernel kernel(clCreateKernel(program.h, "choose", &err));
  REQUIRE(err == CL_SUCCESS);
  Buffer lights(upload(ctx.h, s.lights, &err));
  REQUIRE(err == CL_SUCCESS);
  Buffer choice(upload(ctx.h, s.light_choice, &err));
  REQUIRE(err == CL_SUCCESS);
  Buffer pts(upload(ctx.h, points, &err));
  REQUIRE(err == CL_SUCCESS);
  Buffer ubuf(upload(ctx.h, us, &err));
  REQUIRE(err == CL_SUCCESS);
  Buffer pr_buf(
      clCreateBuffer(ctx.h, CL_MEM_WRITE_ONLY, sizeof(float) * host_pr.size(), nullptr, &err));
  REQUIRE(err == CL_SUCCESS);
  Buffer pick_buf(clCreateBuffer(ctx.h, CL_MEM_WRITE_ONLY, sizeof(int) * count, nullptr, &err));
  REQUIRE(err == CL_SUCCESS);
  const cl_int cn = n;
  REQUIRE(clSetKernelArg(kernel.h, 0, sizeof(cl_mem), &lights.h) == CL_SUCCESS);
  REQUIRE(clSetKernelArg(kernel.h, 1, sizeof(cl_mem), &choice.h) == CL_SUCCESS);
  REQUIRE(clSetKernelArg(kernel.h, 2, sizeof(cl_int), &cn) == CL_SUCCESS);
  REQUIRE(clSetKernelArg(kernel.h, 3, sizeof(cl_mem), &pts.h) == CL_SUCCESS);
  REQUIRE(clSetKernelArg(kernel.h, 4, sizeof(cl_mem), &ubuf.h) == CL_SUCCESS);
  REQUIRE(clSetKernelArg(kernel.h, 5, sizeof(cl_mem), &pr_buf.h) == CL_SUCCESS);
  REQUIRE(clSetKernelArg(kernel.h, 6, sizeof(cl_mem), &pick_buf.h) == CL_SUCCESS);
  const size_t global = count;
  REQUIRE(clEnqueueNDRangeKernel(queue.h, kernel.h, 1, nullptr, &global, nullptr, 0, nullptr,
                                 nullptr) == CL_SUCCESS);
  std::vector<float> dev_pr(host_pr.size());
  std::vector<int> dev_pick(count);
  REQUIRE(clEnqueueReadBuffer(queue.h, pr_buf.h, CL_TRUE, 0, sizeof(float) * dev_pr.size(),
                              dev_pr.data(), 0, nullptr, nullptr) == CL_SUCCESS);
  REQUIRE(clEnqueueReadBuffer(queue.h, pick_buf.h, CL_TRUE, 0, sizeof(int) * count,
                              dev_pick.data(), 0, nullptr, nullptr) == CL_SUCCESS);
  size_t same_pr = 0, same_pick = 0, spot_zero = 0;
  const size_t spot = size_t(n) - 3;
  for (size_t i = 0; i < count; ++i) {
    same_pick += dev_pick[i] == host_pick[i];
    same_pr += std::memcmp(&dev_pr[i * size_t(n)], &host_pr[i * size_t(n)],
                           sizeof(float) * size_t(n)) == 0;
    spot_zero += pf_light_choice_irradiance(&s.lights[spot], &s.light_choice[spot],
                                            &points[3 * i]) == 0.f;
  }
  INFO(count << " points: probabilities equal bit for bit at " << same_pr << ", picks at "
             << same_pick << "; outside the spot's cone " << spot_zero);
  CHECK(spot_zero > count / 4);       // the spot's cone cut-off is exercised
  CHECK(spot_zero < count * 9 / 10);  // and its inside
  CHECK(same_pr == count);
  CHECK(same_pick == count);
}
