// device_options.h — the backend options every render-stage tool shares:
//   --device cpu|opencl|auto, --cl-platform, --cl-device, --work-group, --list-devices;
// and --method, the gather method of the tools that illuminate hitpoints.
// Header-only so that only the tools (which link cxxopts) see cxxopts.
#pragma once
#include <cxxopts.hpp>
#include <iostream>
#include <memory>
#include <string>

#include "photonflow/opencl/cl_runtime.h"
#include "photonflow/foundations/error.h"
#include "photonflow/stages/gather_method.h"
#include "photonflow/io/provenance.h"

namespace pf {

inline void add_device_options(cxxopts::Options& o) {
  o.add_options("Device")
    ("device", "backend: cpu | opencl | auto (auto: a GPU if there is one, else an OpenCL CPU "
     "device such as PoCL, else cpu; the choice is printed)",
     cxxopts::value<std::string>()->default_value("cpu"))
    ("cl-platform", "OpenCL platform index (see --list-devices); -1 = choose",
     cxxopts::value<int>()->default_value("-1"))
    ("cl-device", "OpenCL device index within the platform; -1 = choose",
     cxxopts::value<int>()->default_value("-1"))
    ("work-group", "OpenCL work-group size of every kernel; 0 = the default (64)",
     cxxopts::value<int>()->default_value("0"))
    ("list-devices", "list the OpenCL platforms and devices and exit");
}

inline DeviceOptions device_options(const cxxopts::ParseResult& a) {
  DeviceOptions d;
  d.device = a["device"].as<std::string>();
  d.platform = a["cl-platform"].as<int>();
  d.device_index = a["cl-device"].as<int>();
  d.work_group = a["work-group"].as<int>();
  return d;
}

// Prints the device list for --list-devices; returns true when the tool should exit.
inline bool list_devices_requested(const cxxopts::ParseResult& a) {
  if (!a.count("list-devices")) return false;
  std::cout << cl_describe_devices();
  return true;
}

inline void add_method_option(cxxopts::Options& o) {
  o.add_options()
    ("method", "PPM hitpoint illumination (gather_method.h; every method gathers the same "
     "photons): auto (grid on the cpu backend, hash-grid on opencl) | " + gather_method_choices(),
     cxxopts::value<std::string>()->default_value("auto"));
}

// The --method for the backend that was opened (dev == nullptr: CPU); InputError when the method
// belongs to the other backend.
inline GatherMethod method_option(const cxxopts::ParseResult& a, const ClContext* dev) {
  const std::string s = a["method"].as<std::string>();
  const GatherMethod m = s == "auto" ? default_gather_method(dev != nullptr) : parse_gather_method(s);
  if (gather_method_info(m).device && !dev)
    throw input_error("", "--method " + s + " runs on the OpenCL backend", "add --device opencl");
  if (!gather_method_info(m).device && dev)
    throw input_error("", "--method " + s + " runs on the CPU backend", "use --device cpu");
  return m;
}

// Records the backend actually used (the option says only what was asked for).
inline void record_backend(Provenance& prov, const ClContext* dev) {
  prov.parameters["backend"] = backend_name(dev);
}

}  // namespace pf
