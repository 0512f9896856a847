// device_options.h — the backend options every render-stage tool shares (issue 4):
//   --device cpu|opencl|auto, --cl-platform, --cl-device, --work-group, --list-devices.
// Header-only so that only the tools (which link cxxopts) see cxxopts.
#pragma once
#include <cxxopts.hpp>
#include <iostream>
#include <memory>
#include <string>

#include "photonflow/cl_runtime.h"
#include "photonflow/provenance.h"

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

// Records the backend actually used (the option says only what was asked for).
inline void record_backend(Provenance& prov, const ClContext* dev) {
  prov.parameters["backend"] = backend_name(dev);
}

}  // namespace pf
