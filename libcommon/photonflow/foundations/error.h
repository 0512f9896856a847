// error.h — the one error type a stage throws for bad input; tools turn it into one line + exit 2.
#pragma once
#include <stdexcept>
#include <string>

namespace pf {

// Exit code of every tool for bad input (missing file, wrong format, foreign scene, bad option).
constexpr int kExitBadInput = 2;

// Bad input. what() is the whole user-facing line: "<file>: <what is wrong> (<what to do>)".
struct InputError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// Build the one-line message: file, problem, hint.
inline InputError input_error(const std::string& file, const std::string& problem,
                              const std::string& hint = {}) {
  std::string msg = file.empty() ? problem : file + ": " + problem;
  if (!hint.empty()) msg += " (" + hint + ")";
  return InputError(msg);
}

}  // namespace pf
