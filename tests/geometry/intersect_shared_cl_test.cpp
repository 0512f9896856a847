// intersect_shared_cl_test.cpp — intersect_shared.h compiles as OpenCL C 1.2 and its rope
// traversal gives on the device what it gives on the host.
//
// A tiny kernel #includes the header through the OpenCL compiler (-I <source>/libcommon) and casts
// a few hundred rays through the Cornell room; hits are compared with the host's Traversal::Ropes.
// Without an OpenCL platform (e.g. no ICD installed) the test is skipped with a WARN, never passed
// silently. PoCL runs it on the CPU.
#include <CL/cl.h>

#include <catch2/catch.hpp>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "photonflow/opencl/cl_runtime.h"
#include "photonflow/geometry/intersect_shared.h"
#include "photonflow/geometry/procedural.h"
#include "photonflow/geometry/raycast.h"
#include "cl_raw.h"
#include "support.h"

namespace {

const char* kKernel = R"CLC(
#include "photonflow/geometry/intersect_shared.h"

/* One work-item per ray; rays are 8 floats: origin, direction, tmin, tmax. */
__kernel void cast_rays(__global const pf_kd_node* nodes, int node_count,
                        __global const int* leaf_tris, __global const pf_hh_triangle* hh,
                        __global const float* rays, __global pf_ray_hit* hits) {
  const size_t i = get_global_id(0);
  const float o[3] = {rays[8 * i + 0], rays[8 * i + 1], rays[8 * i + 2]};
  const float d[3] = {rays[8 * i + 3], rays[8 * i + 4], rays[8 * i + 5]};
  pf_ray_hit hit;
  hit.t = rays[8 * i + 7];
  hit.tri = -1;
  hit.u = 0.0f;
  hit.v = 0.0f;
  pf_kd_traverse_ropes(nodes, node_count, leaf_tris, hh, o, d, rays[8 * i + 6], 0, &hit);
  hits[i] = hit;
}
)CLC";

using namespace pf::test::cl_raw;



}  // namespace

TEST_CASE("intersect_shared.h runs as OpenCL C and matches the host", "[raycast][opencl]") {
  cl_device_id device;
  std::string platform_name;
  if (!find_device(device, platform_name)) {
    WARN("SKIPPED: no OpenCL platform with a device (install pocl-opencl-icd to run this test)");
    return;
  }
  INFO("OpenCL platform: " << platform_name);

  pf::Scene scene;
  scene.triangles = pf::make_cornell_room(400);
  scene.compute_hh();
  scene.kd = pf::build_kdtree(scene.triangles, {});

  std::mt19937 rng(3);
  std::uniform_real_distribution<float> uni(0.f, 1.f);
  const size_t n_rays = 512;
  std::vector<pf::Ray> rays(n_rays);
  std::vector<float> packed;
  for (pf::Ray& r : rays) {
    r.o = {0.05f + 0.9f * uni(rng), 0.05f + 0.9f * uni(rng), 0.05f + 0.9f * uni(rng)};
    r.d = {uni(rng) - 0.5f, uni(rng) - 0.5f, uni(rng) - 0.5f};
    r.tmax = uni(rng) < 0.25f ? 0.5f : INFINITY;
    packed.insert(packed.end(), {r.o.x, r.o.y, r.o.z, r.d.x, r.d.y, r.d.z, r.tmin, r.tmax});
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
  Kernel kernel(clCreateKernel(program.h, "cast_rays", &err));
  REQUIRE(err == CL_SUCCESS);

  Buffer nodes(upload(ctx.h, scene.kd.nodes, &err));
  REQUIRE(err == CL_SUCCESS);
  Buffer leaf_tris(upload(ctx.h, scene.kd.leaf_tris, &err));
  REQUIRE(err == CL_SUCCESS);
  Buffer hh(upload(ctx.h, scene.hh, &err));
  REQUIRE(err == CL_SUCCESS);
  Buffer ray_buf(upload(ctx.h, packed, &err));
  REQUIRE(err == CL_SUCCESS);
  Buffer hit_buf(clCreateBuffer(ctx.h, CL_MEM_WRITE_ONLY, sizeof(pf_ray_hit) * n_rays, nullptr,
                                &err));
  REQUIRE(err == CL_SUCCESS);

  const cl_int node_count = cl_int(scene.kd.nodes.size());
  REQUIRE(clSetKernelArg(kernel.h, 0, sizeof(cl_mem), &nodes.h) == CL_SUCCESS);
  REQUIRE(clSetKernelArg(kernel.h, 1, sizeof(cl_int), &node_count) == CL_SUCCESS);
  REQUIRE(clSetKernelArg(kernel.h, 2, sizeof(cl_mem), &leaf_tris.h) == CL_SUCCESS);
  REQUIRE(clSetKernelArg(kernel.h, 3, sizeof(cl_mem), &hh.h) == CL_SUCCESS);
  REQUIRE(clSetKernelArg(kernel.h, 4, sizeof(cl_mem), &ray_buf.h) == CL_SUCCESS);
  REQUIRE(clSetKernelArg(kernel.h, 5, sizeof(cl_mem), &hit_buf.h) == CL_SUCCESS);
  const size_t global = n_rays;
  REQUIRE(clEnqueueNDRangeKernel(queue.h, kernel.h, 1, nullptr, &global, nullptr, 0, nullptr,
                                 nullptr) == CL_SUCCESS);
  std::vector<pf_ray_hit> device_hits(n_rays);
  REQUIRE(clEnqueueReadBuffer(queue.h, hit_buf.h, CL_TRUE, 0, sizeof(pf_ray_hit) * n_rays,
                              device_hits.data(), 0, nullptr, nullptr) == CL_SUCCESS);

  // The device compiler may contract a·b + c into fma, so t may differ in the last bits, and a
  // different triangle is accepted as a tie: the host must hit it at the same t as well.
  auto host_t = [&](const pf::Ray& ray, int32_t tri) {
    float t = NAN, u, v;
    const float o[3] = {ray.o.x, ray.o.y, ray.o.z}, d[3] = {ray.d.x, ray.d.y, ray.d.z};
    pf_hh_intersect(&scene.hh[size_t(tri)], o, d, ray.tmin, INFINITY, &t, &u, &v);
    return t;
  };
  size_t hits = 0, bad = 0;
  for (size_t i = 0; i < n_rays; ++i) {
    pf::Hit host;
    const bool h = pf::intersect_closest(scene, rays[i], host, pf::Traversal::Ropes);
    const pf_ray_hit& dev = device_hits[i];
    hits += h ? 1 : 0;
    const float tol = 1e-5f * std::fmax(1.f, host.t);
    bool same = h == (dev.tri >= 0);
    if (same && h) {
      same = std::fabs(host.t - dev.t) <= tol &&
             (host.tri == dev.tri || std::fabs(host_t(rays[i], dev.tri) - host.t) <= tol);
    }
    if (!same && bad++ < 5)
      WARN("ray " << i << ": host tri " << host.tri << " t " << host.t << ", device tri "
                  << dev.tri << " t " << dev.t);
  }
  CHECK(hits > n_rays / 2);
  CHECK(bad == 0);
}
