// cl_runtime.h — the OpenCL side of photonflow's device backend (thesis ch. 7.2): device
// listing and choice (--device cpu|opencl|auto, --cl-platform, --cl-device), one context and
// in-order queue, programs built from the embedded kernels (or from source under
// PHOTONFLOW_KERNEL_DIR), buffers checked against the largest allocation the device allows, and
// kernel launches with a fixed work-group size.
//
// Failures are one line: no OpenCL platform, a device index out of range, or a kernel that does not
// build (its build log is saved to photonflow-cl-build.log in the current folder, or in $TMPDIR
// when that is not writable) all throw pf::InputError; nothing crashes.
//
// Profiling: with the environment variable PF_CL_PROFILE set (non-empty), the context sums each
// kernel's launch-to-finish time by kernel name and prints the table to stderr when it closes.
//
// Allocation limit: CL_DEVICE_MAX_MEM_ALLOC_SIZE (2 GiB on PoCL), lowered by the environment
// variable PF_CL_MAX_ALLOC=<bytes> or set_max_alloc() (tests force small limits to exercise the
// batched paths).
#pragma once
#include <CL/cl.h>

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace pf {

struct ClDeviceInfo {
  int platform = 0;  // index in clGetPlatformIDs order
  int device = 0;    // index within the platform
  std::string platform_name, device_name, device_version, driver_version;
  bool gpu = false;
  std::string type;  // "GPU", "CPU", "accelerator", "other"
  uint64_t max_alloc = 0, global_mem = 0;
  unsigned compute_units = 0;
  size_t max_work_group = 0;
  bool fp64 = false;
  uint64_t local_mem = 0;  // CL_DEVICE_LOCAL_MEM_SIZE, bytes
  cl_platform_id platform_id = nullptr;
  cl_device_id device_id = nullptr;
};

// Every device of every OpenCL platform; empty when there is no platform (no ICD). Never throws.
// The first call sets POCL_WORK_GROUP_METHOD=loops unless the environment has it (PoCL's
// vectorising default is slower for these divergent kernels).
std::vector<ClDeviceInfo> cl_list_devices();
// Human-readable table of cl_list_devices() for --list-devices (says so when there is none).
std::string cl_describe_devices();

// The backend choice of a tool.
struct DeviceOptions {
  std::string device = "cpu";  // cpu | opencl | auto
  int platform = -1;           // --cl-platform; -1 = choose
  int device_index = -1;       // --cl-device (within the platform); -1 = choose
  int work_group = 0;          // --work-group; 0 = each kernel's default (64)
};

// " -cl-fp32-correctly-rounded-divide-sqrt" when the device offers it (CL_DEVICE_SINGLE_FP_CONFIG),
// else "": single-precision division and sqrt then round as the host's do (OpenCL C otherwise
// allows 2.5 and 3 ulp, NVIDIA's driver uses that freedom). Every program photonflow builds, and
// the tests that build the shared headers themselves, take it.
std::string cl_float_options(cl_device_id device);

// Default work-group size of every kernel (fixed, so PoCL's per-size kernel cache is reused).
constexpr int kDefaultWorkGroup = 64;

// RAII cl_mem.
class ClBuffer {
 public:
  ClBuffer() = default;
  explicit ClBuffer(cl_mem m, size_t bytes) : m_(m), bytes_(bytes) {}
  ClBuffer(ClBuffer&& o) noexcept : m_(o.m_), bytes_(o.bytes_) { o.m_ = nullptr; o.bytes_ = 0; }
  ClBuffer& operator=(ClBuffer&& o) noexcept;
  ClBuffer(const ClBuffer&) = delete;
  ClBuffer& operator=(const ClBuffer&) = delete;
  ~ClBuffer();
  cl_mem get() const { return m_; }
  const cl_mem* ptr() const { return &m_; }
  size_t bytes() const { return bytes_; }

 private:
  cl_mem m_ = nullptr;
  size_t bytes_ = 0;
};

// A __local kernel argument of `bytes` bytes (dynamic local memory).
struct ClLocal {
  size_t bytes;
};

struct ClSceneBuffers;  // cl_backend.cpp: the baked scene uploaded once per context

class ClContext {
 public:
  // Opens a context and queue on `dev`. work_group 0 = kDefaultWorkGroup.
  ClContext(const ClDeviceInfo& dev, int work_group);
  ~ClContext();
  ClContext(const ClContext&) = delete;
  ClContext& operator=(const ClContext&) = delete;

  const ClDeviceInfo& info() const { return info_; }
  // "<device name> (<platform name>, GPU|CPU)"
  std::string name() const;
  cl_context context() const { return ctx_; }
  cl_command_queue queue() const { return queue_; }

  // Kernel `kernel` of kernels/<program>.cl; the program is built on first use (InputError with a
  // saved build log on failure) and cached. `variant`: extra build options (" -DNAME=value ..."),
  // each variant a program of its own — the scene variants of the tracing and gather kernels
  // (scene_kernel_variant, cl_backend.h; kernels/scene_features.h) compile away the branches of
  // materials a scene does not have.
  cl_kernel kernel(const std::string& program, const std::string& kernel,
                   const std::string& variant = "");
  // Whether the stages build scene variants of their kernels (scene_kernel_variant, cl_backend.h):
  // on by default; off (PF_CL_SCENE_VARIANTS=0, or set_scene_variants(false) before the first
  // kernel) every scene runs the kernels with every feature compiled in — the same results,
  // which tests check, at the cost the variants save.
  bool scene_variants() const { return scene_variants_; }
  void set_scene_variants(bool on) { scene_variants_ = on; }
  // Builds every embedded program now (benchmarks time this apart from the work).
  void build_all();
  double build_seconds() const { return build_seconds_; }
  // Adds -D<macro>=<value> to the options of every program this context builds, after the
  // defaults (-DPF_FP64, -DPF_DEVICE_CPU: 1 on a CPU device); only before the first build
  // (std::logic_error after: programs are cached). Tests compare a kernel's compile-time
  // variants with it (PF_GATHER_LIST, kernels/illuminate_methods.cl).
  void define(const std::string& macro, long value);

  // Largest single buffer this context will create.
  uint64_t max_alloc() const { return max_alloc_; }
  void set_max_alloc(uint64_t bytes);
  int work_group() const { return work_group_; }

  // Items of `item_bytes` each that fit one buffer (at least 1), capped at `total`.
  size_t batch_items(size_t item_bytes, size_t total) const;

  // A buffer of `bytes` (at least 1 byte is allocated), optionally initialised from `host`.
  // Throws InputError when bytes exceed max_alloc() (callers batch before that).
  ClBuffer buffer(size_t bytes, const void* host = nullptr, cl_mem_flags flags = CL_MEM_READ_WRITE);
  // A work buffer kept by the context under `key` and reused by later calls (reallocated only
  // when it must grow): per-call allocation would fault in and zero fresh pages every pass.
  const ClBuffer& scratch(const std::string& key, size_t bytes);
  void write(const ClBuffer& b, size_t bytes, const void* host, size_t offset = 0);
  void read(const ClBuffer& b, size_t bytes, void* host, size_t offset = 0);
  // Zeroes bytes offset .. offset + bytes − 1 of b (rounded up to whole ints); enqueued only,
  // no host wait.
  void fill_zero(const ClBuffer& b, size_t bytes, size_t offset = 0);
  // (Mapping a buffer to the host: ClMapping below.)

  // Sets the arguments in order (cl_mem via ClBuffer, scalars by value).
  template <class... A> void args(cl_kernel k, const A&... a) {
    cl_uint i = 0;
    (set_arg(k, i++, a), ...);
  }
  // Enqueues k over n work-items (global size rounded up to the work-group size; kernels check
  // their bound) and waits; adds the time to kernel_seconds().
  void run(cl_kernel k, size_t n);
  // The same with an explicit work-group size `local` (kernels whose work-groups are laid out by
  // the host, e.g. clusters of a given size); InputError when the kernel cannot run groups that
  // large on this device.
  void run(cl_kernel k, size_t n, size_t local);
  double kernel_seconds() const { return kernel_seconds_; }
  void reset_kernel_seconds() { kernel_seconds_ = 0; }
  // Whether run() waits for each kernel (the default: kernel_seconds() and PF_CL_PROFILE then
  // time every kernel from enqueue to clFinish). Off, run() only enqueues: the in-order queue
  // still runs the kernels in order, and the next blocking read, write or map waits for them, so
  // a chain of launches pays no host round trip per kernel (a GPU's launch latency);
  // kernel_seconds() then counts enqueue time only. PF_CL_PROFILE keeps the waits.
  // Returns the previous setting.
  bool set_wait_each(bool on) {
    const bool was = wait_each_;
    wait_each_ = on;
    return was;
  }
  bool wait_each() const { return wait_each_ || profile_; }
  // Waits for everything enqueued.
  void finish();
  // Host waits so far: calls that block the host until the queue has reached them (blocking
  // reads and writes, maps and unmaps, finish(), run() while wait_each()). On a GPU each is a
  // round trip; tests count a pass's waits with it.
  uint64_t host_waits() const { return host_waits_; }

  // Scene upload cache (cl_backend.cpp).
  std::shared_ptr<ClSceneBuffers> scene_cache;
  const void* scene_cache_key = nullptr;

 private:
  friend class ClMapping;
  // Maps `bytes` of b for reading (blocking).
  const void* map_read(const ClBuffer& b, size_t bytes);
  // Maps `bytes` of b for writing (blocking; the old contents are discarded, so nothing is
  // copied to the host: on a CPU device the pointer is the buffer itself).
  void* map_write(const ClBuffer& b, size_t bytes);
  // Unmaps and waits; unmap_quietly drops errors (for destructors).
  void unmap(const ClBuffer& b, const void* p);
  void unmap_quietly(const ClBuffer& b, const void* p) noexcept;
  void set_arg(cl_kernel k, cl_uint i, const ClBuffer& b);
  void set_arg(cl_kernel k, cl_uint i, const ClLocal& l) { set_raw(k, i, l.bytes, nullptr); }
  template <class T> void set_arg(cl_kernel k, cl_uint i, const T& v) { set_raw(k, i, sizeof(T), &v); }
  void set_raw(cl_kernel k, cl_uint i, size_t size, const void* v);
  cl_program build(const std::string& program, const std::string& variant = "");
  size_t local_size(cl_kernel k);
  void check_local(cl_kernel k, size_t wg);

  ClDeviceInfo info_;
  cl_context ctx_ = nullptr;
  cl_command_queue queue_ = nullptr;
  std::map<std::string, cl_program> programs_;  // by program name + variant
  std::string defines_;  // define(): " -DNAME=value" each
  bool wait_each_ = true;
  uint64_t host_waits_ = 0;
  std::map<std::string, cl_kernel> kernels_;
  std::map<cl_kernel, size_t> local_;
  std::map<std::string, ClBuffer> scratch_;
  uint64_t max_alloc_ = 0;
  int work_group_ = kDefaultWorkGroup;
  double build_seconds_ = 0, kernel_seconds_ = 0;
  bool profile_ = false;                                     // PF_CL_PROFILE
  bool scene_variants_ = true;                               // PF_CL_SCENE_VARIANTS
  std::map<std::string, std::pair<uint64_t, double>> profile_times_;  // name → calls, seconds
};

// ClContext::set_wait_each(on) for a scope; the previous setting comes back at its end.
class ClWaitScope {
 public:
  ClWaitScope(ClContext& dev, bool on) : dev_(dev), was_(dev.set_wait_each(on)) {}
  ~ClWaitScope() { dev_.set_wait_each(was_); }
  ClWaitScope(const ClWaitScope&) = delete;
  ClWaitScope& operator=(const ClWaitScope&) = delete;

 private:
  ClContext& dev_;
  bool was_;
};

// `bytes` of a buffer mapped to the host for reading or writing (a blocking map; for writing the
// old contents are discarded, so nothing is copied to the host, and on a CPU device the pointer
// is the buffer itself). Unmapped when the mapping goes out of scope, also when an exception
// leaves it (that unmap's own errors are dropped: the exception in flight is the one to report);
// unmap() ends it early and reports errors. The buffer must outlive the mapping.
class ClMapping {
 public:
  enum class Mode { Read, Write };
  ClMapping(ClContext& dev, const ClBuffer& b, size_t bytes, Mode mode);
  ~ClMapping();
  ClMapping(const ClMapping&) = delete;
  ClMapping& operator=(const ClMapping&) = delete;
  // The mapped bytes as T (const T for a Read mapping); nullptr after unmap().
  template <class T> T* as() const { return static_cast<T*>(p_); }
  void unmap();

 private:
  ClContext& dev_;
  const ClBuffer& b_;
  void* p_ = nullptr;
};

// Opens the backend `opt` asks for and says which on stdout (one line "<tool>: device: ..."):
//   cpu    → nullptr (the CPU backend), nothing printed;
//   opencl → the chosen device (--cl-platform/--cl-device, else the first GPU, else the first CPU
//            device, else the first), InputError when there is none;
//   auto   → a GPU if one exists, else an OpenCL CPU device (PoCL), else nullptr.
std::unique_ptr<ClContext> open_device(const DeviceOptions& opt, const std::string& tool);

// "cpu" or "opencl: <device name> (<platform>)" for provenance.
std::string backend_name(const ClContext* dev);

// Throws InputError unless `code` is CL_SUCCESS; `what` names the call.
void cl_check(cl_int code, const char* what);

}  // namespace pf
