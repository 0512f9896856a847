// kernels_embedded.h — the OpenCL kernels of kernels/*.cl, embedded in the binaries at build time
// (cmake/embed_kernels.cmake inlines their quoted includes into one self-contained source each).
#pragma once
#include <string>
#include <vector>

namespace pf {

// Source of kernels/<name>.cl with its includes inlined; nullptr for an unknown name.
const char* embedded_kernel(const std::string& name);
// Names of all embedded kernel files (without .cl), sorted.
std::vector<std::string> embedded_kernel_names();

}  // namespace pf
