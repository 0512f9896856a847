// tool_main.h — the shared shell of every stage executable's main().
//
// A tool's main parses options, reads inputs, calls one library function and writes outputs, all
// inside run_tool(), which turns failures into one line on stderr and an exit code:
//   pf::InputError / cxxopts option errors → "<tool>: <message>", exit 2 (bad input)
//   any other std::exception              → "<tool>: internal error: <message>", exit 1
#pragma once
#include <cxxopts.hpp>
#include <exception>
#include <functional>
#include <iostream>

#include "photonflow/error.h"

namespace pf {

inline int run_tool(const char* tool, const std::function<int()>& body) {
  try {
    return body();
  } catch (const InputError& e) {
    std::cerr << tool << ": " << e.what() << "\n";
    return kExitBadInput;
  } catch (const cxxopts::exceptions::exception& e) {
    std::cerr << tool << ": " << e.what() << " (see " << tool << " --help)\n";
    return kExitBadInput;
  } catch (const std::exception& e) {
    std::cerr << tool << ": internal error: " << e.what() << "\n";
    return 1;
  }
}

// Records every option of a parsed command line, defaults included, as provenance parameters.
template <class Prov> void record_options(Prov& prov, const cxxopts::ParseResult& r) {
  for (const auto& kv : r.defaults()) prov.parameters[kv.key()] = kv.value();
  for (const auto& kv : r.arguments()) prov.parameters[kv.key()] = kv.value();
}

}  // namespace pf
