// OpenCL runtime: see cl_runtime.h.
#include "photonflow/opencl/cl_runtime.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <sstream>
#include <stdexcept>

#include "photonflow/foundations/error.h"
#include "photonflow/opencl/kernels_embedded.h"

namespace pf {

namespace {

const char* cl_error_name(cl_int e) {
  switch (e) {
    case CL_DEVICE_NOT_FOUND: return "CL_DEVICE_NOT_FOUND";
    case CL_DEVICE_NOT_AVAILABLE: return "CL_DEVICE_NOT_AVAILABLE";
    case CL_COMPILER_NOT_AVAILABLE: return "CL_COMPILER_NOT_AVAILABLE";
    case CL_MEM_OBJECT_ALLOCATION_FAILURE: return "CL_MEM_OBJECT_ALLOCATION_FAILURE";
    case CL_OUT_OF_RESOURCES: return "CL_OUT_OF_RESOURCES";
    case CL_OUT_OF_HOST_MEMORY: return "CL_OUT_OF_HOST_MEMORY";
    case CL_BUILD_PROGRAM_FAILURE: return "CL_BUILD_PROGRAM_FAILURE";
    case CL_INVALID_VALUE: return "CL_INVALID_VALUE";
    case CL_INVALID_BUFFER_SIZE: return "CL_INVALID_BUFFER_SIZE";
    case CL_INVALID_KERNEL_NAME: return "CL_INVALID_KERNEL_NAME";
    case CL_INVALID_KERNEL_ARGS: return "CL_INVALID_KERNEL_ARGS";
    case CL_INVALID_ARG_SIZE: return "CL_INVALID_ARG_SIZE";
    case CL_INVALID_WORK_GROUP_SIZE: return "CL_INVALID_WORK_GROUP_SIZE";
    case CL_INVALID_BUILD_OPTIONS: return "CL_INVALID_BUILD_OPTIONS";
    case -1001: return "CL_PLATFORM_NOT_FOUND_KHR";
    default: return "OpenCL error";
  }
}

std::string str_info(cl_platform_id p, cl_platform_info what) {
  size_t n = 0;
  if (clGetPlatformInfo(p, what, 0, nullptr, &n) != CL_SUCCESS || n == 0) return "";
  std::string s(n, '\0');
  clGetPlatformInfo(p, what, n, &s[0], nullptr);
  while (!s.empty() && (s.back() == '\0' || s.back() == ' ')) s.pop_back();
  return s;
}

std::string str_info(cl_device_id d, cl_device_info what) {
  size_t n = 0;
  if (clGetDeviceInfo(d, what, 0, nullptr, &n) != CL_SUCCESS || n == 0) return "";
  std::string s(n, '\0');
  clGetDeviceInfo(d, what, n, &s[0], nullptr);
  while (!s.empty() && (s.back() == '\0' || s.back() == ' ')) s.pop_back();
  return s;
}

template <class T> T num_info(cl_device_id d, cl_device_info what) {
  T v{};
  clGetDeviceInfo(d, what, sizeof(T), &v, nullptr);
  return v;
}

std::string mib(uint64_t bytes) {
  std::ostringstream s;
  s << (bytes >> 20) << " MiB";
  return s.str();
}

std::string read_text(const std::string& path) {
  std::ifstream f(path);
  if (!f) return {};
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

// Where the build log goes: ./photonflow-cl-build.log, or $TMPDIR (/tmp) when . is not writable.
std::string write_build_log(const std::string& text) {
  std::vector<std::string> dirs = {"."};
  const char* tmp = std::getenv("TMPDIR");
  dirs.push_back(tmp && *tmp ? tmp : "/tmp");
  for (const std::string& d : dirs) {
    std::string path = d + "/photonflow-cl-build.log";
    std::ofstream f(path);
    if (!f) continue;
    f << text;
    if (f) return path;
  }
  return "(could not be saved)";
}

// Captures what the OpenCL compiler writes to stderr itself (PoCL's clang prints "N errors
// generated." there) so that a failed build stays one line on the terminal; the text goes into the
// build log instead.
class StderrCapture {
 public:
  StderrCapture() {
    std::fflush(stderr);
    file_ = std::tmpfile();
    if (!file_) return;
    saved_ = dup(2);
    if (saved_ < 0 || dup2(fileno(file_), 2) < 0) {
      if (saved_ >= 0) close(saved_);
      saved_ = -1;
    }
  }
  // Restores stderr and returns what was written meanwhile.
  std::string finish() {
    std::string text;
    if (saved_ >= 0) {
      std::fflush(stderr);
      dup2(saved_, 2);
      close(saved_);
      saved_ = -1;
    }
    if (file_) {
      std::rewind(file_);
      char buf[4096];
      size_t n;
      while ((n = std::fread(buf, 1, sizeof buf, file_)) > 0) text.append(buf, n);
      std::fclose(file_);
      file_ = nullptr;
    }
    return text;
  }
  ~StderrCapture() { finish(); }

 private:
  FILE* file_ = nullptr;
  int saved_ = -1;
};

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

void cl_check(cl_int code, const char* what) {
  if (code == CL_SUCCESS) return;
  throw input_error("", std::string("OpenCL call ") + what + " failed: " + cl_error_name(code) +
                            " (" + std::to_string(code) + ")");
}

// ---- devices -----------------------------------------------------------------------------------

// PoCL's default work-group method ("loopvec") vectorises the loop over a work-group's items; our
// kernels diverge (rope traversal, bounce loops), and the masked vector code runs slower than
// plain work-item loops ("loops") on the benchmark (docs/BENCHMARKS.md "OpenCL backend"). Set
// before the platform is first queried; a POCL_WORK_GROUP_METHOD from the user's environment
// wins, and other drivers ignore the variable.
void pocl_defaults() {
  static bool done = false;
  if (done) return;
  done = true;
  setenv("POCL_WORK_GROUP_METHOD", "loops", 0);
}

std::vector<ClDeviceInfo> cl_list_devices() {
  pocl_defaults();
  std::vector<ClDeviceInfo> out;
  cl_uint np = 0;
  if (clGetPlatformIDs(0, nullptr, &np) != CL_SUCCESS || np == 0) return out;
  std::vector<cl_platform_id> platforms(np);
  if (clGetPlatformIDs(np, platforms.data(), nullptr) != CL_SUCCESS) return out;
  for (cl_uint p = 0; p < np; ++p) {
    cl_uint nd = 0;
    if (clGetDeviceIDs(platforms[p], CL_DEVICE_TYPE_ALL, 0, nullptr, &nd) != CL_SUCCESS || nd == 0)
      continue;
    std::vector<cl_device_id> devs(nd);
    if (clGetDeviceIDs(platforms[p], CL_DEVICE_TYPE_ALL, nd, devs.data(), nullptr) != CL_SUCCESS)
      continue;
    for (cl_uint d = 0; d < nd; ++d) {
      ClDeviceInfo i;
      i.platform = int(p);
      i.device = int(d);
      i.platform_id = platforms[p];
      i.device_id = devs[d];
      i.platform_name = str_info(platforms[p], CL_PLATFORM_NAME);
      i.device_name = str_info(devs[d], CL_DEVICE_NAME);
      i.device_version = str_info(devs[d], CL_DEVICE_VERSION);
      i.driver_version = str_info(devs[d], CL_DRIVER_VERSION);
      cl_device_type t = num_info<cl_device_type>(devs[d], CL_DEVICE_TYPE);
      i.gpu = (t & CL_DEVICE_TYPE_GPU) != 0;
      i.type = i.gpu ? "GPU"
                     : (t & CL_DEVICE_TYPE_CPU) ? "CPU"
                     : (t & CL_DEVICE_TYPE_ACCELERATOR) ? "accelerator" : "other";
      i.max_alloc = num_info<cl_ulong>(devs[d], CL_DEVICE_MAX_MEM_ALLOC_SIZE);
      i.global_mem = num_info<cl_ulong>(devs[d], CL_DEVICE_GLOBAL_MEM_SIZE);
      i.compute_units = num_info<cl_uint>(devs[d], CL_DEVICE_MAX_COMPUTE_UNITS);
      i.max_work_group = num_info<size_t>(devs[d], CL_DEVICE_MAX_WORK_GROUP_SIZE);
      i.fp64 = num_info<cl_device_fp_config>(devs[d], CL_DEVICE_DOUBLE_FP_CONFIG) != 0;
      i.local_mem = num_info<cl_ulong>(devs[d], CL_DEVICE_LOCAL_MEM_SIZE);
      out.push_back(i);
    }
  }
  return out;
}

std::string cl_float_options(cl_device_id device) {
  const auto sp = num_info<cl_device_fp_config>(device, CL_DEVICE_SINGLE_FP_CONFIG);
  return (sp & CL_FP_CORRECTLY_ROUNDED_DIVIDE_SQRT) ? " -cl-fp32-correctly-rounded-divide-sqrt" : "";
}

std::string cl_describe_devices() {
  std::vector<ClDeviceInfo> devs = cl_list_devices();
  std::ostringstream s;
  if (devs.empty()) {
    s << "no OpenCL platform or device found (install an OpenCL driver, e.g. pocl-opencl-icd; "
         "--device cpu always works)\n";
    return s.str();
  }
  for (const ClDeviceInfo& d : devs) {
    s << "platform " << d.platform << " device " << d.device << ": " << d.device_name << " ["
      << d.type << "] on \"" << d.platform_name << "\", " << d.device_version << ", "
      << d.compute_units << " compute units, max alloc " << mib(d.max_alloc) << ", global "
      << mib(d.global_mem) << (d.fp64 ? ", fp64" : "") << "\n";
  }
  return s.str();
}

// ---- buffers -----------------------------------------------------------------------------------

ClBuffer& ClBuffer::operator=(ClBuffer&& o) noexcept {
  if (this != &o) {
    if (m_) clReleaseMemObject(m_);
    m_ = o.m_;
    bytes_ = o.bytes_;
    o.m_ = nullptr;
    o.bytes_ = 0;
  }
  return *this;
}

ClBuffer::~ClBuffer() {
  if (m_) clReleaseMemObject(m_);
}

// ---- context -----------------------------------------------------------------------------------

ClContext::ClContext(const ClDeviceInfo& dev, int work_group) : info_(dev) {
  cl_int err = CL_SUCCESS;
  cl_context_properties props[] = {CL_CONTEXT_PLATFORM, cl_context_properties(dev.platform_id), 0};
  ctx_ = clCreateContext(props, 1, &dev.device_id, nullptr, nullptr, &err);
  cl_check(err, "clCreateContext");
  queue_ = clCreateCommandQueue(ctx_, dev.device_id, 0, &err);
  if (err != CL_SUCCESS) {
    clReleaseContext(ctx_);
    ctx_ = nullptr;
    cl_check(err, "clCreateCommandQueue");
  }
  work_group_ = work_group > 0 ? work_group : kDefaultWorkGroup;
  if (dev.max_work_group > 0 && size_t(work_group_) > dev.max_work_group)
    throw input_error("", "--work-group " + std::to_string(work_group_) + " exceeds the device's "
                              "maximum " + std::to_string(dev.max_work_group));
  max_alloc_ = dev.max_alloc;
  if (const char* env = std::getenv("PF_CL_MAX_ALLOC")) {
    char* end = nullptr;
    unsigned long long v = std::strtoull(env, &end, 10);
    if (end == env || *end != '\0' || v == 0)
      throw input_error("", std::string("PF_CL_MAX_ALLOC must be a positive byte count, got '") +
                                env + "'");
    set_max_alloc(v);
  }
  const char* prof = std::getenv("PF_CL_PROFILE");
  profile_ = prof && *prof;
  const char* variants = std::getenv("PF_CL_SCENE_VARIANTS");
  scene_variants_ = !(variants && std::string(variants) == "0");
}

ClContext::~ClContext() {
  if (profile_ && !profile_times_.empty()) {
    std::fprintf(stderr, "PF_CL_PROFILE %-32s %8s %12s %10s\n", "kernel", "calls", "total ms", "ms/call");
    for (const auto& [name, t] : profile_times_)
      std::fprintf(stderr, "PF_CL_PROFILE %-32s %8llu %12.3f %10.4f\n", name.c_str(),
                   static_cast<unsigned long long>(t.first), t.second * 1e3,
                   t.second * 1e3 / double(t.first));
  }
  scene_cache.reset();
  scratch_.clear();
  for (auto& k : kernels_) clReleaseKernel(k.second);
  for (auto& p : programs_) clReleaseProgram(p.second);
  if (queue_) clReleaseCommandQueue(queue_);
  if (ctx_) clReleaseContext(ctx_);
}

std::string ClContext::name() const {
  return info_.device_name + " (" + info_.platform_name + ", " + info_.type + ")";
}

void ClContext::set_max_alloc(uint64_t bytes) {
  max_alloc_ = std::min<uint64_t>(bytes, info_.max_alloc ? info_.max_alloc : bytes);
}

size_t ClContext::batch_items(size_t item_bytes, size_t total) const {
  size_t n = item_bytes ? size_t(max_alloc_ / item_bytes) : total;
  n = std::max<size_t>(1, n);
  return std::min(n, std::max<size_t>(1, total));
}

void ClContext::define(const std::string& macro, long value) {
  if (!programs_.empty())
    throw std::logic_error("ClContext::define(" + macro + ") after a program was built");
  defines_ += " -D" + macro + "=" + std::to_string(value);
}

cl_program ClContext::build(const std::string& name, const std::string& variant) {
  const std::string key = name + variant;
  auto it = programs_.find(key);
  if (it != programs_.end()) return it->second;
  std::string source, includes;
  if (const char* dir = std::getenv("PHOTONFLOW_KERNEL_DIR"); dir && *dir) {
    std::string path = std::string(dir) + "/kernels/" + name + ".cl";
    source = read_text(path);
    if (source.empty())
      throw input_error(path, "cannot read the OpenCL kernel source",
                        "PHOTONFLOW_KERNEL_DIR must point at the photonflow source folder");
    includes = std::string(" -I ") + dir + "/libcommon -I " + dir + "/kernels";
  } else {
    const char* s = embedded_kernel(name);
    if (!s) throw input_error("", "no embedded OpenCL kernel named '" + name + "'");
    source = s;
  }
  cl_int err = CL_SUCCESS;
  const char* src = source.c_str();
  cl_program prog = clCreateProgramWithSource(ctx_, 1, &src, nullptr, &err);
  cl_check(err, "clCreateProgramWithSource");
  std::string options = "-cl-std=CL1.2 -DPF_FP64=" + std::string(info_.fp64 ? "1" : "0");
  options += " -DPF_DEVICE_CPU=" + std::string(info_.type == "CPU" ? "1" : "0") + defines_ + variant;
  options += cl_float_options(info_.device_id);
  options += includes;
  if (const char* extra = std::getenv("PF_CL_BUILD_OPTIONS")) options += std::string(" ") + extra;
  auto t0 = std::chrono::steady_clock::now();
  StderrCapture capture;
  err = clBuildProgram(prog, 1, &info_.device_id, options.c_str(), nullptr, nullptr);
  const std::string compiler_output = capture.finish();
  build_seconds_ += seconds_since(t0);
  if (err != CL_SUCCESS) {
    size_t len = 0;
    clGetProgramBuildInfo(prog, info_.device_id, CL_PROGRAM_BUILD_LOG, 0, nullptr, &len);
    std::string log(len, '\0');
    if (len) clGetProgramBuildInfo(prog, info_.device_id, CL_PROGRAM_BUILD_LOG, len, &log[0], nullptr);
    while (!log.empty() && log.back() == '\0') log.pop_back();
    clReleaseProgram(prog);
    std::string path = write_build_log("photonflow: OpenCL build of kernels/" + name + ".cl on " +
                                       this->name() + "\noptions: " + options + "\n\n" + log +
                                       (compiler_output.empty() ? "" : "\n" + compiler_output));
    throw input_error("", "OpenCL kernel build of " + name + ".cl failed on " + info_.device_name +
                              " (" + cl_error_name(err) + "; build log: " + path + ")");
  }
  programs_[key] = prog;
  return prog;
}

void ClContext::build_all() {
  for (const std::string& n : embedded_kernel_names()) build(n);
}

cl_kernel ClContext::kernel(const std::string& program, const std::string& kernel,
                            const std::string& variant) {
  std::string key = program + variant + "/" + kernel;
  auto it = kernels_.find(key);
  if (it != kernels_.end()) return it->second;
  cl_program p = build(program, variant);
  cl_int err = CL_SUCCESS;
  cl_kernel k = clCreateKernel(p, kernel.c_str(), &err);
  cl_check(err, ("clCreateKernel " + kernel).c_str());
  kernels_[key] = k;
  return k;
}

void ClContext::check_local(cl_kernel k, size_t wg) {
  size_t max_k = 0;
  clGetKernelWorkGroupInfo(k, info_.device_id, CL_KERNEL_WORK_GROUP_SIZE, sizeof max_k, &max_k,
                           nullptr);
  if (max_k > 0 && wg > max_k) {
    char name[128] = {};
    clGetKernelInfo(k, CL_KERNEL_FUNCTION_NAME, sizeof name - 1, name, nullptr);
    throw input_error("", "work-group size " + std::to_string(wg) + " exceeds the maximum " +
                              std::to_string(max_k) + " of kernel " + name + " on this device",
                      "pass a smaller --work-group");
  }
}

size_t ClContext::local_size(cl_kernel k) {
  auto it = local_.find(k);
  if (it != local_.end()) return it->second;
  const size_t wg = size_t(work_group_);
  check_local(k, wg);
  local_[k] = wg;
  return wg;
}

ClBuffer ClContext::buffer(size_t bytes, const void* host, cl_mem_flags flags) {
  if (bytes > max_alloc_)
    throw input_error("", "a device buffer of " + mib(bytes) + " exceeds the device's largest "
                              "allocation (" + mib(max_alloc_) + ")");
  size_t n = std::max<size_t>(bytes, 4);
  cl_int err = CL_SUCCESS;
  cl_mem m = clCreateBuffer(ctx_, flags, n, nullptr, &err);
  cl_check(err, "clCreateBuffer");
  ClBuffer b(m, n);
  if (host && bytes) write(b, bytes, host);
  return b;
}

const ClBuffer& ClContext::scratch(const std::string& key, size_t bytes) {
  ClBuffer& b = scratch_[key];
  if (!b.get() || b.bytes() < bytes || b.bytes() > max_alloc_) {
    b = ClBuffer();  // release first: the old and new buffer need not fit together
    b = buffer(bytes);
  }
  return b;
}

void ClContext::write(const ClBuffer& b, size_t bytes, const void* host, size_t offset) {
  if (!bytes) return;
  ++host_waits_;
  cl_check(clEnqueueWriteBuffer(queue_, b.get(), CL_TRUE, offset, bytes, host, 0, nullptr, nullptr),
           "clEnqueueWriteBuffer");
}

void ClContext::read(const ClBuffer& b, size_t bytes, void* host, size_t offset) {
  if (!bytes) return;
  ++host_waits_;
  cl_check(clEnqueueReadBuffer(queue_, b.get(), CL_TRUE, offset, bytes, host, 0, nullptr, nullptr),
           "clEnqueueReadBuffer");
}

void ClContext::fill_zero(const ClBuffer& b, size_t bytes, size_t offset) {
  if (!bytes) return;
  const cl_uint zero = 0;
  cl_check(clEnqueueFillBuffer(queue_, b.get(), &zero, sizeof zero, offset, (bytes + 3) / 4 * 4,
                               0, nullptr, nullptr),
           "clEnqueueFillBuffer");
}

const void* ClContext::map_read(const ClBuffer& b, size_t bytes) {
  ++host_waits_;
  cl_int err = CL_SUCCESS;
  void* p = clEnqueueMapBuffer(queue_, b.get(), CL_TRUE, CL_MAP_READ, 0, std::max<size_t>(bytes, 4),
                               0, nullptr, nullptr, &err);
  cl_check(err, "clEnqueueMapBuffer");
  return p;
}

void* ClContext::map_write(const ClBuffer& b, size_t bytes) {
  ++host_waits_;
  cl_int err = CL_SUCCESS;
  void* p = clEnqueueMapBuffer(queue_, b.get(), CL_TRUE, CL_MAP_WRITE_INVALIDATE_REGION, 0,
                               std::max<size_t>(bytes, 4), 0, nullptr, nullptr, &err);
  cl_check(err, "clEnqueueMapBuffer");
  return p;
}

void ClContext::unmap(const ClBuffer& b, const void* p) {
  ++host_waits_;
  cl_check(clEnqueueUnmapMemObject(queue_, b.get(), const_cast<void*>(p), 0, nullptr, nullptr),
           "clEnqueueUnmapMemObject");
  cl_check(clFinish(queue_), "clFinish");
}

void ClContext::unmap_quietly(const ClBuffer& b, const void* p) noexcept {
  ++host_waits_;
  if (clEnqueueUnmapMemObject(queue_, b.get(), const_cast<void*>(p), 0, nullptr, nullptr) ==
      CL_SUCCESS)
    clFinish(queue_);
}

ClMapping::ClMapping(ClContext& dev, const ClBuffer& b, size_t bytes, Mode mode)
    : dev_(dev),
      b_(b),
      p_(mode == Mode::Read ? const_cast<void*>(dev.map_read(b, bytes)) : dev.map_write(b, bytes)) {}

ClMapping::~ClMapping() {
  if (p_) dev_.unmap_quietly(b_, p_);
}

void ClMapping::unmap() {
  if (!p_) return;
  void* p = p_;
  p_ = nullptr;  // unmapped even when the call reports an error: never twice
  dev_.unmap(b_, p);
}

void ClContext::set_arg(cl_kernel k, cl_uint i, const ClBuffer& b) {
  cl_check(clSetKernelArg(k, i, sizeof(cl_mem), b.ptr()), "clSetKernelArg");
}

void ClContext::set_raw(cl_kernel k, cl_uint i, size_t size, const void* v) {
  cl_check(clSetKernelArg(k, i, size, v), "clSetKernelArg");
}

void ClContext::run(cl_kernel k, size_t n) { run(k, n, local_size(k)); }

void ClContext::finish() {
  ++host_waits_;
  cl_check(clFinish(queue_), "clFinish");
}

void ClContext::run(cl_kernel k, size_t n, size_t local) {
  if (n == 0) return;
  if (local != size_t(work_group_)) check_local(k, local);
  const size_t global = (n + local - 1) / local * local;
  auto t0 = std::chrono::steady_clock::now();
  cl_check(clEnqueueNDRangeKernel(queue_, k, 1, nullptr, &global, &local, 0, nullptr, nullptr),
           "clEnqueueNDRangeKernel");
  if (wait_each()) {
    ++host_waits_;
    cl_check(clFinish(queue_), "clFinish");
  }
  const double dt = seconds_since(t0);
  kernel_seconds_ += dt;
  if (profile_) {
    char name[128] = {0};
    clGetKernelInfo(k, CL_KERNEL_FUNCTION_NAME, sizeof name - 1, name, nullptr);
    auto& t = profile_times_[name];
    t.first += 1;
    t.second += dt;
  }
}

// ---- choice ------------------------------------------------------------------------------------

std::unique_ptr<ClContext> open_device(const DeviceOptions& opt, const std::string& tool) {
  if (opt.device != "cpu" && opt.device != "opencl" && opt.device != "auto")
    throw input_error("", "--device must be one of cpu, opencl, auto, got '" + opt.device + "'");
  if (opt.work_group < 0) throw input_error("", "--work-group must be positive");
  if (opt.device == "cpu") return nullptr;
  // On stdout with the tool's other report lines: stderr holds only the one line of a failure.
  auto say = [&](const std::string& line) { std::cout << tool << ": device: " << line << "\n"; };
  std::vector<ClDeviceInfo> devs = cl_list_devices();
  const bool pinned = opt.platform >= 0 || opt.device_index >= 0;
  const ClDeviceInfo* pick = nullptr;
  if (pinned) {
    int p = std::max(opt.platform, 0), d = std::max(opt.device_index, 0);
    for (const ClDeviceInfo& i : devs)
      if (i.platform == p && i.device == d) pick = &i;
    if (!pick)
      throw input_error("", "no OpenCL device " + std::to_string(d) + " on platform " +
                                std::to_string(p) + (devs.empty() ? " (no OpenCL platform found)" : ""),
                        "see --list-devices");
  } else {
    for (const ClDeviceInfo& i : devs)
      if (!pick && i.gpu) pick = &i;
    for (const ClDeviceInfo& i : devs)
      if (!pick && i.type == "CPU") pick = &i;
    if (!pick && opt.device == "opencl" && !devs.empty()) pick = &devs[0];
  }
  if (!pick) {
    if (opt.device == "opencl")
      throw input_error("", "--device opencl: no OpenCL platform or device found",
                        "install an OpenCL driver such as pocl-opencl-icd, or use --device cpu");
    say("cpu backend (auto: no OpenCL GPU or CPU device found)");
    return nullptr;
  }
  std::unique_ptr<ClContext> ctx;
  try {
    ctx = std::make_unique<ClContext>(*pick, opt.work_group);
  } catch (const InputError& e) {
    if (opt.device == "opencl" || pinned) throw;
    say(std::string("cpu backend (auto: OpenCL device unusable: ") + e.what() + ")");
    return nullptr;
  }
  say("opencl on " + ctx->name() + (opt.device == "auto" ? " (auto)" : "") + ", work-group " +
      std::to_string(ctx->work_group()) + ", max allocation " + mib(ctx->max_alloc()));
  return ctx;
}

std::string backend_name(const ClContext* dev) {
  return dev ? "opencl: " + dev->name() : "cpu";
}

}  // namespace pf
