// output_file.h — the output files of a stage: written under a temporary name and renamed into
// place (a killed stage never leaves a file that looks whole), and checked before any work, so a
// run that would fail to write its last output fails before it writes its first.
//
// Used by every writer (h5io.h, image.h, text_file.h, procedural.h) and by every tool's main.
#pragma once
#include <cstddef>
#include <string>
#include <vector>

namespace pf {

// "<path>.tmp.<pid>": the temporary name beside `path` (same directory), unique per process.
// A file name too long for that (the suffix would pass the file system's 255-byte name limit, from
// 241 bytes on) gives "<first 223 bytes of the name>~<16 hex digits>.tmp.<pid>", the digits a
// checksum of the whole name.
std::string temp_path(const std::string& path);
// The same for process `pid`.
std::string temp_path(const std::string& path, long pid);

// Removes the temporary files of output `path` that a killed run left: the regular files named
// exactly temp_path(path, pid) whose process is gone (kill(pid, 0) fails with ESRCH). Never the
// file of a live process or this one's. Returns how many it removed. Every TempOutput calls it.
size_t remove_stale_temps(const std::string& path);

// Refuses an input that exists and is not a regular file (a FIFO, a directory, a device): a
// FIFO's reader would block for ever. InputError "<path>: is not a regular file". A missing file
// passes (its reader names it). check_outputs runs it on every input of a run, and the readers
// (h5::Reader, read_exr, read_mask, scene import) run it too.
void require_regular_input(const std::string& path);

// Renames the finished `tmp` onto `path`. Refuses (InputError naming `path`, `tmp` removed) when
// `path` exists and is not a regular file — a rename would replace a device node such as /dev/null
// or fail on a directory — or when the rename fails.
void commit_temp(const std::string& tmp, const std::string& path);

// A temporary output file being written: temp_path(final_path), tracked while it exists so that an
// interrupt (interrupt.h) removes it, and removed on destruction unless commit() renamed it into
// place. Every writer (h5io.h, image.h, text_file.h, procedural.h) writes through one. Creating
// one removes the stale temporaries of final_path (remove_stale_temps).
class TempOutput {
 public:
  explicit TempOutput(const std::string& final_path);
  ~TempOutput();  // removes the file unless committed
  TempOutput(const TempOutput&) = delete;
  TempOutput& operator=(const TempOutput&) = delete;
  const std::string& path() const { return tmp_; }
  const std::string& final_path() const { return final_; }
  // Renames the file into place (commit_temp); on failure the file is removed and InputError
  // thrown.
  void commit();

 private:
  std::string final_, tmp_;
  int slot_ = -1;  // its entry in the table the interrupt handler reads; -1: not tracked
  bool done_ = false;
};

// Removes every TempOutput's file that exists now. Async-signal-safe (unlink only): the
// interrupt handler calls it.
void remove_tracked_temps() noexcept;

// Writes n bytes to `path` atomically: into temp_path(path), flushed, then commit_temp. InputError
// naming `path` when the file cannot be created or written (the temporary file removed).
void write_file_atomic(const std::string& path, const char* data, size_t n);

// Checks a run's inputs and outputs before any work (empty paths are skipped). InputError naming
// an input that is not a regular file (require_regular_input), or naming the path when an output
//   - is one of the inputs (the same file, also through another name or a link) or is named twice,
//   - exists and is not a regular file,
//   - cannot be created: its directory is missing, or a probe file "<path>.tmp.<pid>" cannot be
//     created there (read-only, /proc, no permission).
void check_outputs(const std::vector<std::string>& inputs, const std::vector<std::string>& outputs);

// The PNG preview beside an image: "dir/img.exr" → "dir/img.png", "a.d/img" → "a.d/img.png" (only
// the file name's extension is replaced).
std::string preview_path(const std::string& image);

}  // namespace pf
