// tool_main.h — the shared shell of every stage executable's main().
//
// A tool's main parses options (parse_options), checks its outputs before any work (check_outputs,
// output_file.h), reads inputs, calls one library function and writes outputs, all inside
// run_tool(), which turns failures into one line on stderr and an exit code:
//   pf::InputError / cxxopts option errors → "<tool>: <message>", exit 2 (bad input)
//   std::bad_alloc                         → "<tool>: out of memory: <what to lower>", exit 1
//   any other std::exception              → "<tool>: internal error: <message>", exit 1
// An exception thrown in an OpenMP worker thread cannot reach run_tool: the OpenMP runtime ends
// the program through std::terminate (before, "terminate called after throwing an instance of
// 'std::bad_alloc'" and SIGABRT: `trace-photons --photons 4000000000`). run_tool installs a
// terminate handler that prints the same one line and exits with 1 instead.
// Ctrl-C, SIGTERM and SIGHUP remove the temporary outputs being written, then end the tool by
// that signal (interrupt.h); render and cluster's GA stop cleanly on the first one.
#pragma once
#include <cstdio>
#include <cstdlib>
#include <cxxopts.hpp>
#include <exception>
#include <new>
#include <functional>
#include <initializer_list>
#include <iostream>
#include <string>
#include <vector>

#include "photonflow/foundations/error.h"
#include "photonflow/foundations/interrupt.h"
#include "photonflow/io/output_file.h"
#include "photonflow/foundations/threads.h"

namespace pf {

// What a tool says when an allocation fails.
inline const char* out_of_memory_text() {
  return "out of memory: the run needs more than this machine has (lower --photons, --spp or "
         "the image size baked into the scene)";
}

// The tool's name for the terminate handler (set by run_tool).
inline const char*& terminating_tool() {
  static const char* name = "photonflow";
  return name;
}

// std::terminate's handler in the tools: one line for the exception nobody caught (one thrown in
// an OpenMP worker thread), then exit code 1; no abort, no core file.
[[noreturn]] inline void terminate_with_one_line() {
  std::string line = "internal error: std::terminate without an exception";
  if (const std::exception_ptr e = std::current_exception()) {
    try {
      std::rethrow_exception(e);
    } catch (const std::bad_alloc&) {
      line = out_of_memory_text();
    } catch (const std::exception& x) {
      line = std::string("internal error in a worker thread: ") + x.what();
    } catch (...) {
      line = "internal error in a worker thread: an exception of unknown type";
    }
  }
  remove_tracked_temps();  // a file being written when the thread failed
  std::fprintf(stderr, "%s: %s\n", terminating_tool(), line.c_str());
  std::fflush(stderr);
  std::_Exit(1);
}

inline int run_tool(const char* tool, const std::function<int()>& body) {
  terminating_tool() = tool;
  std::set_terminate(terminate_with_one_line);
  install_interrupt_handlers();  // Ctrl-C and SIGTERM remove the outputs being written
  try {
    check_thread_environment();
    return body();
  } catch (const InputError& e) {
    std::cerr << tool << ": " << e.what() << "\n";
    return kExitBadInput;
  } catch (const cxxopts::exceptions::exception& e) {
    std::cerr << tool << ": " << e.what() << " (see " << tool << " --help)\n";
    return kExitBadInput;
  } catch (const std::bad_alloc&) {
    std::cerr << tool << ": " << out_of_memory_text() << "\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << tool << ": internal error: " << e.what() << "\n";
    return 1;
  }
}

// An option's old spelling, still accepted for one release (one vocabulary across the tools): parse_options reads `--old_name V` (or `--old_name=V`) as `--new_name V`, says so in one
// line on stderr ("pathtrace: --time-limit is deprecated, use --time (accepted until the next
// release)"), and lists the old spelling in --help under "Deprecated". Provenance and run records
// carry the new name only; the command line as typed is kept in command_line.
struct DeprecatedOption {
  const char* old_name;
  const char* new_name;
};

// The deprecation notice for `d` given to `program` (one line, no newline).
inline std::string deprecation_notice(const std::string& program, const DeprecatedOption& d) {
  return program + ": --" + d.old_name + " is deprecated, use --" + d.new_name +
         " (accepted until the next release)";
}

// argv with every deprecated spelling replaced by its new one; a notice on stderr for each old
// spelling used. Both spellings of one option on one command line are refused (the run would
// read only one of them).
inline std::vector<std::string> rewrite_deprecated(const std::string& program, int argc,
                                                   char** argv,
                                                   std::initializer_list<DeprecatedOption> deprecated) {
  std::vector<std::string> args(argv, argv + argc);
  for (const DeprecatedOption& d : deprecated) {
    const std::string old_flag = std::string("--") + d.old_name;
    const std::string new_flag = std::string("--") + d.new_name;
    bool used_old = false, used_new = false;
    for (int i = 1; i < argc; ++i) {
      std::string& a = args[size_t(i)];
      if (a == "--") break;  // the rest are positional
      auto spelled = [&](const std::string& flag) {
        return a == flag || a.compare(0, flag.size() + 1, flag + "=") == 0;
      };
      if (spelled(new_flag)) used_new = true;
      if (spelled(old_flag)) {
        used_old = true;
        a = new_flag + a.substr(old_flag.size());
      }
    }
    if (used_old && used_new)
      throw input_error("", old_flag + " is the deprecated spelling of " + new_flag +
                                " and both were given", "give " + new_flag + " only");
    if (used_old) std::cerr << deprecation_notice(program, d) << "\n";
  }
  return args;
}

// A floating-point option's value must be a number to its last character: cxxopts reads the
// number at the front of "0.1;" or "0.1x" and drops the rest without a word (an options file's
// "--aperture 0.1; touch x" would bake with 0.1). Whole-number options are already read whole.
// True when the option holds a T (cxxopts' as<T> refuses another type with std::bad_cast).
template <typename T>
bool option_holds(const cxxopts::OptionValue& o) {
  try {
    (void)o.as<T>();
    return true;
  } catch (const std::exception&) {
    return false;
  }
}

inline void require_whole_number(const cxxopts::ParseResult& r, const std::string& key,
                                 const std::string& value) {
  if (!option_holds<float>(r[key]) && !option_holds<double>(r[key])) return;
  char* end = nullptr;
  std::strtod(value.c_str(), &end);
  if (value.empty() || end != value.c_str() + value.size())
    throw input_error("", "--" + key + " must be a number, got '" + value + "'",
                      "give the number alone");
}

// Parses the command line and refuses what it does not take: a stray argument (also the value
// "2" left over by "-o --spp 2", where --spp became the output's name) and a --threads option out
// of 0..kMaxThreads. `deprecated`: the tool's old option spellings (DeprecatedOption).
inline cxxopts::ParseResult parse_options(cxxopts::Options& options, int argc, char** argv,
                                          std::initializer_list<DeprecatedOption> deprecated = {}) {
  if (deprecated.size() > 0) {
    auto add = options.add_options("Deprecated (accepted until the next release)");
    for (const DeprecatedOption& d : deprecated)
      add(d.old_name, std::string("old spelling of --") + d.new_name,
          cxxopts::value<std::string>());
  }
  const std::vector<std::string> args = rewrite_deprecated(options.program(), argc, argv, deprecated);
  std::vector<const char*> ptrs;
  for (const std::string& a : args) ptrs.push_back(a.c_str());
  ptrs.push_back(nullptr);
  cxxopts::ParseResult r = options.parse(argc, ptrs.data());
  if (!r.unmatched().empty())
    throw input_error("", "unexpected argument '" + r.unmatched().front() + "'",
                      "see " + options.program() + " --help");
  for (const auto& kv : r.arguments()) {
    if (kv.key() == "threads") require_threads(kv.as<int>());
    require_whole_number(r, kv.key(), kv.value());
  }
  return r;
}

// Refuses a command line that lacks required options, naming the missing ones only:
// "--output is required", "--hitpoints and --output are required" (hint: see <program> --help).
// A required option given an empty value ("-o \"$OUT\"" with OUT unset) is refused too, before
// any work: "--output is empty (give it a file name)"; an empty output path would otherwise fail
// only at the end, after the whole run, and without a name to report.
inline void require_options(const cxxopts::Options& options, const cxxopts::ParseResult& r,
                            std::initializer_list<const char*> required) {
  std::vector<std::string> missing;
  for (const char* name : required)
    if (!r.count(name)) missing.push_back(std::string("--") + name);
  if (missing.empty()) {
    for (const char* name : required)
      for (const auto& kv : r.arguments())
        if (kv.key() == name && kv.value().empty())
          throw input_error("", std::string("--") + name + " is empty", "give it a file name");
    return;
  }
  std::string list = missing.front();
  for (size_t i = 1; i < missing.size(); ++i)
    list += (i + 1 == missing.size() ? " and " : ", ") + missing[i];
  throw input_error("", list + (missing.size() == 1 ? " is required" : " are required"),
                    "see " + options.program() + " --help");
}

// Refuses options `a` and `b` given together when a run reads only one of them (the other would be
// ignored without a word, its file not even in the provenance): "--a and --b exclude each other:
// <why>" (hint: give one of them).
inline void require_not_both(const cxxopts::ParseResult& r, const char* a, const char* b,
                             const std::string& why) {
  if (r.count(a) && r.count(b))
    throw input_error("", std::string("--") + a + " and --" + b + " exclude each other: " + why,
                      "give one of them");
}

// A path option's value: given, else its default, else "" (for check_outputs' lists).
inline std::string path_option(const cxxopts::ParseResult& r, const std::string& name) {
  if (r.count(name)) return r[name].as<std::string>();
  for (const auto& kv : r.defaults())
    if (kv.key() == name) return kv.value();
  return "";
}

// check_outputs (output_file.h) on the files named by options: `inputs` and `outputs` are option
// names ("scene", "output"); options not given are skipped.
inline void check_output_options(const cxxopts::ParseResult& r,
                                 std::initializer_list<const char*> inputs,
                                 std::initializer_list<const char*> outputs) {
  std::vector<std::string> in, out;
  for (const char* name : inputs) in.push_back(path_option(r, name));
  for (const char* name : outputs) out.push_back(path_option(r, name));
  check_outputs(in, out);
}

// Records every option of a parsed command line, defaults included, as provenance parameters.
template <class Prov> void record_options(Prov& prov, const cxxopts::ParseResult& r) {
  for (const auto& kv : r.defaults()) prov.parameters[kv.key()] = kv.value();
  for (const auto& kv : r.arguments()) prov.parameters[kv.key()] = kv.value();
}

}  // namespace pf
