// The shell every stage shares (tool_main.h, output_file.h, threads.h) and the render driver's
// option checks, through the executables:
//   - an output that is an input (also under another name), is named twice, is not a regular file
//     (a FIFO here: as root a rename would have replaced /dev/null), or cannot be created is
//     refused before any work, with one line, exit 2, the input untouched and no output at all —
//     also no first output of a run whose later output would have failed;
//   - the PNG preview goes beside the image even when a directory name has a dot;
//   - a missing required option is named (only the missing ones), and one given an empty value
//     is refused before any work;
//   - stray arguments and --threads / OMP_NUM_THREADS beyond kMaxThreads are refused (libgomp
//     crashed on 100 000 threads);
//   - render checks its options as trace-hitpoints and trace-photons do, and --resume continues
//     only a checkpoint made with the same state options (state_parameters);
//   - a run that runs out of memory says so in one line and exits 1, also when the allocation
//     failed in an OpenMP worker thread (before: std::terminate, SIGABRT);
//   - a full disk (a file-size limit here) is one line and exit 2 with no output and no temporary
//     file, from HDF5, OpenEXR, OBJ and the import's child alike (before: HDF5 crashed at exit);
//   - synthesize --png none writes no preview;
//   - an input that is not a regular file (a FIFO, a directory, a device) is refused at once;
//   - outputs with names of up to 255 bytes are written (their temporary names fit), and a run
//     removes the temporaries of its output that a killed run left.
// Plus the library pieces themselves: preview_path, check_outputs, commit_temp, temp_path,
// remove_stale_temps.
#include <catch2/catch.hpp>
#include <signal.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "photonflow/foundations/error.h"
#include "photonflow/foundations/hash.h"
#include "photonflow/image/image.h"
#include "photonflow/foundations/memory_cap.h"
#include "photonflow/io/output_file.h"
#include "photonflow/estimators/render_driver.h"
#include "photonflow/foundations/threads.h"
#include "photonflow/foundations/tool_main.h"
#include "support.h"

using namespace pf;
using test::run_tool;
using test::TempDir;
namespace fs = std::filesystem;

namespace {

// Checks a refused run: exit 2, one line on stderr containing `needle`, none of `absent` exists,
// and no temporary file is left in the folder.
void check_refused(const test::ToolRun& r, const TempDir& tmp, const std::string& needle,
                   const std::vector<std::string>& absent = {}) {
  INFO("stderr: " << r.err);
  CHECK(r.exit_code == 2);
  CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
  CHECK(r.err.find(needle) != std::string::npos);
  for (const std::string& p : absent) {
    INFO("must not exist: " << p);
    CHECK_FALSE(fs::exists(p));
  }
  CHECK(test::temporary_files(tmp.dir).empty());
}

// A small chain: scene, hitpoints, photons, gathered state.
struct Chain {
  std::string scene, hp, ph, st;
};

Chain make_chain(const TempDir& tmp) {
  Chain c{tmp / "scene.h5", tmp / "hp.h5", tmp / "ph.h5", tmp / "st.h5"};
  REQUIRE(run_tool("scene-bake", std::string(PF_SOURCE_DIR) + "/data/cornell-box.dae -o " +
                                     c.scene + " --width 16 --height 12",
                   tmp)
              .exit_code == 0);
  REQUIRE(run_tool("trace-hitpoints", "--estimator ppm --direct photons --scene " + c.scene + " -o " + c.hp, tmp).exit_code == 0);
  REQUIRE(run_tool("trace-photons", "--scene " + c.scene + " -o " + c.ph + " --photons 2000", tmp)
              .exit_code == 0);
  REQUIRE(run_tool("illuminate",
                   "--estimator ppm --scene " + c.scene + " --hitpoints " + c.hp + " --photons " + c.ph + " -o " +
                       c.st,
                   tmp)
              .exit_code == 0);
  return c;
}

}  // namespace

TEST_CASE("outputs: preview_path replaces only the file name's extension", "[tools][outputs]") {
  CHECK(preview_path("img.exr") == "img.png");
  CHECK(preview_path("dir/img.exr") == "dir/img.png");
  CHECK(preview_path("sub.d/img") == "sub.d/img.png");
  CHECK(preview_path("a.b/c.d.exr") == "a.b/c.d.png");
}

TEST_CASE("outputs: check_outputs and commit_temp refuse what a rename would destroy",
          "[tools][outputs]") {
  TempDir tmp("outputs-lib");
  const std::string in = tmp / "in.h5";
  { std::ofstream(in) << "x"; }
  fs::create_directories(tmp / "sub");
  CHECK_NOTHROW(check_outputs({in}, {tmp / "out.h5", "", tmp / "out.png"}));
  CHECK_THROWS_AS(check_outputs({in}, {in}), InputError);
  CHECK_THROWS_AS(check_outputs({in}, {tmp / "sub/../in.h5"}), InputError);  // another name
  fs::create_symlink(in, tmp / "link.h5");
  CHECK_THROWS_AS(check_outputs({tmp / "link.h5"}, {in}), InputError);  // through a link
  CHECK_THROWS_AS(check_outputs({}, {tmp / "a.h5", tmp / "./a.h5"}), InputError);
  CHECK_THROWS_AS(check_outputs({}, {tmp / "missing/a.h5"}), InputError);
  CHECK_THROWS_AS(check_outputs({}, {tmp / "sub"}), InputError);  // a directory
  REQUIRE(mkfifo((tmp / "fifo").c_str(), 0600) == 0);
  CHECK_THROWS_AS(check_outputs({}, {tmp / "fifo"}), InputError);
  // commit_temp over the FIFO: refused, the FIFO kept, the temporary file removed.
  const std::string t = temp_path(tmp / "fifo");
  { std::ofstream(t) << "data"; }
  CHECK_THROWS_AS(commit_temp(t, tmp / "fifo"), InputError);
  CHECK(fs::is_fifo(tmp / "fifo"));
  CHECK_FALSE(fs::exists(t));
  // The probe leaves nothing behind.
  CHECK(test::temporary_files(tmp.dir).empty());
}

TEST_CASE("outputs: stages never overwrite an input and fail before their first output",
          "[tools][outputs]") {
  TempDir tmp("outputs");
  const Chain c = make_chain(tmp);
  const std::string scene_hash = sha256_file(c.scene), st_hash = sha256_file(c.st);

  SECTION("an output that is an input") {
    check_refused(run_tool("trace-hitpoints", "--estimator ppm --direct photons --scene " + c.scene + " -o " + c.scene, tmp), tmp,
                  "is also an input");
    check_refused(run_tool("trace-hitpoints",
                           "--estimator ppm --direct photons --scene " + c.scene + " -o " + (tmp / "x/../scene.h5"), tmp),
                  tmp, "is also an input");
    check_refused(run_tool("synthesize", "--hitpoints " + c.st + " -o " + c.st, tmp), tmp,
                  "is also an input");
    check_refused(run_tool("render", "--scene " + c.scene + " -o " + (tmp / "r.exr") +
                                         " --passes 1 --photons 500 --checkpoint " + c.scene,
                           tmp),
                  tmp, "is also an input", {tmp / "r.exr"});
    CHECK(sha256_file(c.scene) == scene_hash);
    CHECK(sha256_file(c.st) == st_hash);
  }
  SECTION("the preview and the image under one name") {
    check_refused(run_tool("synthesize", "--hitpoints " + c.st + " -o " + (tmp / "o.png"), tmp),
                  tmp, "two outputs", {tmp / "o.png"});
    check_refused(run_tool("synthesize", "--hitpoints " + c.st + " -o " + (tmp / "o.exr") +
                                             " --png " + (tmp / "o.exr"), tmp),
                  tmp, "two outputs", {tmp / "o.exr"});
  }
  SECTION("an output that is not a regular file") {
    REQUIRE(mkfifo((tmp / "fifo").c_str(), 0600) == 0);
    check_refused(run_tool("trace-photons", "--scene " + c.scene + " -o " + (tmp / "fifo"), tmp),
                  tmp, "not a regular file");
    CHECK(fs::is_fifo(tmp / "fifo"));
  }
  SECTION("a later output that cannot be written: no earlier output either") {
    check_refused(run_tool("synthesize", "--hitpoints " + c.st + " -o " + (tmp / "o.exr") +
                                             " --png " + (tmp / "missing/x.png"), tmp),
                  tmp, "directory does not exist", {tmp / "o.exr"});
    check_refused(run_tool("render", "--scene " + c.scene + " -o " + (tmp / "r.exr") +
                                         " --passes 1 --photons 500 --stats /proc/pf-st.json",
                           tmp),
                  tmp, "cannot be created", {tmp / "r.exr", tmp / "r.png"});
  }
  SECTION("the PNG goes beside the image when a directory name has a dot") {
    fs::create_directories(tmp / "sub.d");
    REQUIRE(run_tool("synthesize", "--hitpoints " + c.st + " -o " + (tmp / "sub.d/img"), tmp)
                .exit_code == 0);
    CHECK(fs::exists(tmp / "sub.d/img"));
    CHECK(fs::exists(tmp / "sub.d/img.png"));
    CHECK_FALSE(fs::exists(tmp / "sub.png"));
  }
}

TEST_CASE("outputs: stray arguments and thread counts beyond the limit are refused",
          "[tools][outputs]") {
  TempDir tmp("args");
  const Chain c = make_chain(tmp);
  const std::string out = tmp / "o.h5";
  check_refused(run_tool("trace-hitpoints", "--estimator ppm --direct photons --scene " + c.scene + " -o " + out + " stray", tmp),
                tmp, "unexpected argument 'stray'", {out});
  // "-o --spp 2": --spp becomes the output's name, "2" is left over.
  check_refused(run_tool("trace-hitpoints", "--estimator ppm --direct photons --scene " + c.scene + " -o --spp 2", tmp), tmp,
                "unexpected argument '2'", {tmp / "--spp"});
  const std::string big = std::to_string(kMaxThreads + 1);
  check_refused(run_tool("trace-photons", "--scene " + c.scene + " -o " + out + " --threads " + big,
                         tmp),
                tmp, "--threads must be 0 (all cores) to", {out});
  check_refused(run_tool("scene-bake", std::string(PF_SOURCE_DIR) + "/data/cornell-box.dae -o " +
                                           out + " --threads -1", tmp),
                tmp, "--threads", {out});
  check_refused(run_tool("trace-photons", "--scene " + c.scene + " -o " + out, tmp,
                         "OMP_NUM_THREADS=100000"),
                tmp, "OMP_NUM_THREADS=100000", {out});
  CHECK(worker_threads(kMaxThreads * 4) == kMaxThreads);
  CHECK(worker_threads(3) == 3);
  CHECK(worker_threads(0) >= 1);
}

TEST_CASE("outputs: a missing required option is named, the given ones are not",
          "[tools][outputs]") {
  TempDir tmp("required");
  const Chain c = make_chain(tmp);
  const std::string out = tmp / "o.h5";
  check_refused(run_tool("trace-hitpoints", "--estimator ppm --direct photons --scene " + c.scene, tmp), tmp,
                "--output is required (see trace-hitpoints --help)");
  test::ToolRun r = run_tool("illuminate", "--estimator ppm --scene " + c.scene + " --photons " + c.ph, tmp);
  check_refused(r, tmp, "--hitpoints and --output are required");
  CHECK(r.err.find("--scene") == std::string::npos);
  check_refused(run_tool("illuminate", "--estimator ppm --scene " + c.scene + " --hitpoints " + c.hp + " -o " + out,
                         tmp),
                tmp, "--photons or --grid is required", {out});
  check_refused(run_tool("cluster", "", tmp), tmp,
                "--scene, --hitpoints and --output are required");
  check_refused(run_tool("synthesize", "-o " + out, tmp), tmp, "--hitpoints is required", {out});
  // An empty value ("-o \"$OUT\"" with OUT unset) is refused before any work, not at the end.
  check_refused(run_tool("trace-hitpoints", "--estimator ppm --direct photons --scene " + c.scene + " -o ''", tmp), tmp,
                "trace-hitpoints: --output is empty (give it a file name)");
  check_refused(run_tool("trace-photons", "--scene '' -o " + out, tmp), tmp,
                "--scene is empty", {out});
  check_refused(run_tool("scene-bake", std::string(PF_SOURCE_DIR) + "/data/cornell-box.dae -o ''",
                         tmp),
                tmp, "scene-bake: --output is empty");

  // The library function alone.
  auto parse = [](cxxopts::Options& options, std::vector<std::string> words) {
    std::vector<char*> argv;
    for (auto& w : words) argv.push_back(w.data());
    return options.parse(int(argv.size()), argv.data());
  };
  cxxopts::Options o("tool", "");
  o.add_options()("alpha", "", cxxopts::value<int>())("beta", "", cxxopts::value<int>());
  const cxxopts::ParseResult parsed = parse(o, {"tool", "--beta", "1"});
  CHECK_NOTHROW(require_options(o, parsed, {"beta"}));
  CHECK_THROWS_WITH(require_options(o, parsed, {"alpha", "beta"}),
                    "--alpha is required (see tool --help)");
  cxxopts::Options p("tool", "");
  p.add_options()("out", "", cxxopts::value<std::string>())("in", "", cxxopts::value<std::string>());
  const cxxopts::ParseResult with_empty = parse(p, {"tool", "--in", "a.h5", "--out", ""});
  CHECK_NOTHROW(require_options(p, with_empty, {"in"}));
  CHECK_THROWS_WITH(require_options(p, with_empty, {"in", "out"}),
                    "--out is empty (give it a file name)");
}

TEST_CASE("render: options out of range are refused as the stages refuse them",
          "[tools][render][options]") {
  TempDir tmp("render-options");
  const Chain c = make_chain(tmp);
  const std::string base = "--scene " + c.scene + " -o " + (tmp / "r.exr") + " --photons 500 ";
  const std::vector<std::string> none = {tmp / "r.exr", tmp / "r.png"};
  check_refused(run_tool("render", base + "--max-depth 0", tmp), tmp, "--max-depth", none);
  check_refused(run_tool("render", base + "--max-bounces -5", tmp), tmp, "--max-bounces", none);
  check_refused(run_tool("render", base + "--shadow-samples 0 --direct shadow-rays", tmp), tmp,
                "--shadow-samples", none);
  check_refused(run_tool("render", base + "--glossy-merge rough", tmp), tmp, "--glossy-merge",
                none);
  check_refused(run_tool("render", base + "--glossy-merge mis --estimator ppm", tmp), tmp,
                "--glossy-merge", none);
  check_refused(run_tool("render", base + "--glossy-merge mis --direct photons", tmp), tmp,
                "--glossy-merge", none);
  check_refused(run_tool("render", base + "--glossy-spp 2 --estimator sppm", tmp), tmp,
                "--glossy-spp", none);
  check_refused(run_tool("render", base + "--glossy-spp 65", tmp), tmp, "--glossy-spp", none);
  check_refused(run_tool("render", base + "--checkpoint " + (tmp / "ck.h5") +
                                       " --checkpoint-every 0", tmp),
                tmp, "--checkpoint-every", none);
  check_refused(run_tool("render", base + "--passes 2 --snapshot-at 1,99", tmp), tmp,
                "--snapshot-at 99", none);
  // The library refuses the same (render_progressive calls check_options first).
  RenderOptions opt;
  opt.eye.max_depth = 0;
  CHECK_THROWS_AS(check_options(opt), InputError);
  opt = RenderOptions{};
  opt.snapshot_at = {opt.passes + 1};
  CHECK_THROWS_AS(check_options(opt), InputError);
  CHECK_NOTHROW(check_options(RenderOptions{}));
}

TEST_CASE("render: --resume continues only a checkpoint made with the same state options",
          "[tools][render][resume]") {
  TempDir tmp("render-resume");
  const Chain c = make_chain(tmp);
  const std::string ck = tmp / "ck.h5";
  // The estimator and direct light named: the changes below are away from them.
  const std::string common = "--scene " + c.scene + " --estimator ppm --direct photons" +
                             " --photons 1000 --checkpoint " + ck + " --checkpoint-every 1 --resume ";
  REQUIRE(run_tool("render", common + "--passes 2 -o " + (tmp / "a.exr"), tmp).exit_code == 0);
  const std::string ck_hash = sha256_file(ck);
  for (const std::string& change :
       {"--alpha 0.3", "--seed 9", "--spp 2", "--direct shadow-rays", "--photons 999",
        "--radius 0.05", "--max-depth 3", "--max-bounces 4"}) {
    INFO(change);
    check_refused(run_tool("render", common + "--passes 3 -o " + (tmp / "b.exr") + " " + change,
                           tmp),
                  tmp, "differs from the checkpoint's", {tmp / "b.exr"});
    CHECK(sha256_file(ck) == ck_hash);
  }
  // Options the state does not depend on may change (more passes, threads), and a value may be
  // spelled another way (0.70).
  auto r = run_tool("render", common + "--passes 3 -o " + (tmp / "c.exr") +
                                  " --threads 1 --alpha 0.70",
                    tmp);
  INFO(r.err);
  REQUIRE(r.exit_code == 0);
  // A fresh 3-pass run gives the same image as the resumed one.
  REQUIRE(run_tool("render", "--scene " + c.scene + " --estimator ppm --direct photons" +
                                 " --photons 1000 --passes 3 -o " + (tmp / "d.exr"),
                   tmp)
              .exit_code == 0);
  CHECK(read_exr(tmp / "c.exr").rgb == read_exr(tmp / "d.exr").rgb);
}

TEST_CASE("outputs: out of memory is one line and exit code 1, also from a worker thread",
          "[tools][outputs]") {
  if (!AddressSpaceCap::supported()) {
    WARN("SKIPPED: address-space caps are off in sanitizer builds");
    return;
  }
  TempDir tmp("oom");
  const Chain c = make_chain(tmp);
  const std::string big = tmp / "big.h5", out = tmp / "o.h5";
  REQUIRE(run_tool("scene-bake", std::string(PF_SOURCE_DIR) + "/data/cornell-box.dae -o " + big +
                                     " --width 65536 --height 65536", tmp)
              .exit_code == 0);
  // The tools inherit the cap: this process's address space plus 1 GiB.
  AddressSpaceCap cap(uint64_t(1) << 30);
  REQUIRE(cap.active());
  // Photon counts whose photons fit this machine's memory (more is refused before any work,
  // photon_pass.cpp) but not the cap.
  const uint64_t fits = physical_memory_bytes() / 2 / sizeof(pf_photon);
  REQUIRE(fits * sizeof(pf_photon) > (uint64_t(4) << 30));
  const std::string many = std::to_string(std::min<uint64_t>(fits, 4000000000u));
  for (const auto& [tool, args] : std::vector<std::pair<std::string, std::string>>{
           // a chunk buffer's growth fails in an OpenMP worker thread
           {"trace-photons", "--scene " + c.scene + " -o " + out + " --photons " + many},
           {"render", "--scene " + c.scene + " -o " + (tmp / "o.exr") + " --photons " + many +
                          " --passes 1"},
           // 65536 x 65536 hitpoints
           {"trace-hitpoints", "--estimator ppm --direct photons --scene " + big + " -o " + out}}) {
    const test::ToolRun r = run_tool(tool, args, tmp);
    INFO(tool << " " << args << "\nexit " << r.exit_code << ", stderr: " << r.err);
    CHECK(r.exit_code == 1);
    CHECK(r.err == tool + ": " + out_of_memory_text() + "\n");
    CHECK_FALSE(fs::exists(out));
    CHECK_FALSE(fs::exists(tmp / "o.exr"));
    CHECK(test::temporary_files(tmp.dir).empty());
  }
}

namespace {

// A file-size limit (RLIMIT_FSIZE, as `ulimit -f`) for this process and the tools it starts, with
// SIGXFSZ ignored, so a write past it fails with EFBIG as a write to a full disk fails with
// ENOSPC. Restores both on destruction.
struct FileSizeCap {
  rlimit old{};
  struct sigaction old_action {};
  explicit FileSizeCap(rlim_t bytes) {
    getrlimit(RLIMIT_FSIZE, &old);
    const rlimit cap{bytes, old.rlim_max};
    REQUIRE(setrlimit(RLIMIT_FSIZE, &cap) == 0);
    struct sigaction ignore {};
    ignore.sa_handler = SIG_IGN;
    sigaction(SIGXFSZ, &ignore, &old_action);
  }
  ~FileSizeCap() {
    setrlimit(RLIMIT_FSIZE, &old);
    sigaction(SIGXFSZ, &old_action, nullptr);
  }
  FileSizeCap(const FileSizeCap&) = delete;
  FileSizeCap& operator=(const FileSizeCap&) = delete;
};

}  // namespace

// Before: HDF5 writers printed their line, then crashed at exit (SIGSEGV in HDF5's exit handler,
// which closed again the file whose close had failed; h5io.cpp); scene-bake blamed assimp for
// a child that could not pass the scene back.
TEST_CASE("outputs: a full disk is one line and exit code 2, and leaves no output",
          "[tools][outputs]") {
  if (test::thread_sanitizer_build()) {
    // TSan keeps shadow memory for read-only data in a file it writes (/tmp/tsan.rodata.<pid>)
    // and maps: under the cap that file stays short and TSan itself dies of SIGBUS at start.
    WARN("SKIPPED: ThreadSanitizer's own shadow file cannot be written under a file-size cap");
    return;
  }
  TempDir tmp("disk-full");
  const Chain c = make_chain(tmp);
  const std::string h5 = tmp / "o.h5", exr = tmp / "o.exr", png = tmp / "o.png";
  const std::string box = std::string(PF_SOURCE_DIR) + "/data/cornell-box.dae";
  struct Case {
    std::string tool, args, needle;
    std::vector<std::string> outputs;
  };
  const std::vector<Case> cases = {
      // the import's child cannot write the scene into its memory file
      {"scene-bake", box + " -o " + h5, "file-size limit", {h5}},
      {"trace-hitpoints", "--estimator ppm --direct photons --scene " + c.scene + " -o " + h5, "is the disk full?", {h5}},
      {"trace-photons", "--scene " + c.scene + " -o " + h5 + " --photons 20000",
       "is the disk full?", {h5}},
      {"illuminate",
       "--estimator ppm --scene " + c.scene + " --hitpoints " + c.hp + " --photons " + c.ph + " -o " + h5,
       "is the disk full?", {h5}},
      {"synthesize", "--hitpoints " + c.st + " -o " + exr, "is the disk full?", {exr, png}},
      {"render", "--scene " + c.scene + " -o " + exr + " --photons 2000 --passes 2",
       "is the disk full?", {exr, png}},
      {"render",
       "--scene " + c.scene + " -o " + exr + " --photons 2000 --passes 2 --checkpoint " + h5 +
           " --checkpoint-every 1",
       "is the disk full?", {exr, png, h5}},
      {"gen-mesh", "-o " + (tmp / "o.obj"), "is the disk full?", {tmp / "o.obj"}},
  };
  for (const Case& k : cases) {
    test::ToolRun r;
    {
      FileSizeCap cap(1024);  // the tools' stdout and stderr files stay below it
      r = run_tool(k.tool, k.args, tmp);
    }
    INFO(k.tool << " " << k.args << "\nexit " << r.exit_code << ", stderr: " << r.err);
    CHECK(r.exit_code == 2);
    CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
    CHECK(r.err.rfind(k.tool + ": ", 0) == 0);
    CHECK(r.err.find(k.needle) != std::string::npos);
    for (const std::string& o : k.outputs) {
      INFO("must not exist: " << o);
      CHECK_FALSE(fs::exists(o));
    }
    CHECK(test::temporary_files(tmp.dir).empty());
  }
  // The same commands without the limit write their outputs (the cap above caused the failures).
  for (const Case& k : cases) {
    const test::ToolRun r = run_tool(k.tool, k.args, tmp);
    INFO(k.tool << " " << k.args << "\nstderr: " << r.err);
    CHECK(r.exit_code == 0);
    for (const std::string& o : k.outputs) {
      CHECK(fs::exists(o));
      fs::remove(o);
    }
  }
}

TEST_CASE("outputs: synthesize --png none writes no preview", "[tools][outputs]") {
  TempDir tmp("png-none");
  const Chain c = make_chain(tmp);
  const test::ToolRun r =
      run_tool("synthesize", "--hitpoints " + c.st + " -o " + (tmp / "a.exr") + " --png none", tmp);
  INFO(r.err);
  CHECK(r.exit_code == 0);
  CHECK(fs::exists(tmp / "a.exr"));
  CHECK_FALSE(fs::exists(tmp / "a.png"));
  CHECK_FALSE(fs::exists(tmp / "none"));
  CHECK(run_tool("synthesize", "--hitpoints " + c.st + " -o " + (tmp / "b.exr"), tmp).exit_code ==
        0);
  CHECK(fs::exists(tmp / "b.png"));  // the default: beside the output
}

namespace {
// Runs f in a child process with a time limit: 2 when it threw InputError (its line in *what), 0
// when it returned, -1 when it crashed or was still running after `seconds` (SIGALRM).
int in_child(const std::function<void()>& f, int seconds, std::string* what = nullptr) {
  int fd[2];
  REQUIRE(pipe(fd) == 0);
  const pid_t pid = fork();
  REQUIRE(pid >= 0);
  if (pid == 0) {
    close(fd[0]);
    alarm(unsigned(seconds));
    int code = 0;
    try {
      f();
    } catch (const InputError& e) {
      const std::string line = e.what();
      code = write(fd[1], line.data(), line.size()) < 0 ? 3 : 2;
    } catch (...) {
      code = 1;
    }
    _exit(code);
  }
  close(fd[1]);
  std::string line;
  char buf[512];
  ssize_t n;
  while ((n = read(fd[0], buf, sizeof buf)) > 0) line.append(buf, size_t(n));
  close(fd[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  if (what) *what = line;
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}
}  // namespace

TEST_CASE("outputs: a FIFO or directory or device as an input is refused at once and not waited on",
          "[tools][outputs]") {
  // Before: every stage blocked for ever opening a FIFO input (H5Fis_hdf5, OpenEXR, assimp's
  // child until its time limit). Each run here is killed after 20 s (exit 137: the test fails
  // instead of hanging).
  TempDir tmp("fifo-in");
  const Chain c = make_chain(tmp);
  const std::string fifo = tmp / "fifo.h5", obj = tmp / "fifo.obj", exr = tmp / "img.exr";
  REQUIRE(mkfifo(fifo.c_str(), 0600) == 0);
  REQUIRE(mkfifo(obj.c_str(), 0600) == 0);
  REQUIRE(run_tool("synthesize", "--hitpoints " + c.st + " -o " + exr, tmp).exit_code == 0);
  const std::string out = tmp / "out.h5";
  struct Case {
    const char* tool;
    std::string args, bad;
  };
  const std::vector<Case> cases = {
      {"trace-hitpoints", "--estimator ppm --direct photons --scene " + fifo + " -o " + out, fifo},  // scene inputs
      {"render", "--scene " + fifo + " -o " + (tmp / "r.exr"), fifo},
      {"scene-bake", obj + " -o " + out, obj},
      {"illuminate", "--estimator ppm --scene " + c.scene + " --hitpoints " + c.hp + " --photons " + fifo +
                         " -o " + out, fifo},  // HDF5 inputs
      {"synthesize", "--hitpoints " + fifo + " -o " + (tmp / "s.exr"), fifo},
      {"imgcompare", exr + " " + exr + " --mask " + fifo, fifo},  // an image input
      {"synthesize", "--hitpoints " + tmp.dir.string() + " -o " + (tmp / "s.exr"),
       tmp.dir.string()},  // a directory
      {"trace-photons", "--scene /dev/zero -o " + out, "/dev/zero"},  // a device
  };
  for (const Case& k : cases) {
    INFO(k.tool << " " << k.args);
    const test::ToolRun r = run_tool(k.tool, k.args, tmp, "", 20);
    check_refused(r, tmp, k.bad + ": is not a regular file", {out, tmp / "r.exr", tmp / "s.exr"});
  }
  // The readers refuse it too (a library caller that skips check_outputs), in a child process
  // with a time limit.
  std::string line;
  CHECK(in_child([&] { h5::Reader r(fifo, "photonflow.hitpoints", 1); }, 20, &line) == 2);
  CHECK(line == fifo + ": is not a regular file (give a file, not a pipe, directory or device; "
                       "a pipe's reader would wait for ever)");
  CHECK(in_child([&] { read_exr(fifo); }, 20) == 2);
  CHECK(fs::is_fifo(fifo));  // left as it was
}

TEST_CASE("outputs: temporary names fit the file system's limit for outputs of up to 255 bytes",
          "[tools][outputs]") {
  TempDir tmp("long-names");
  const std::string name255 = std::string(252, 'n') + ".h5";
  const std::string t = temp_path(tmp / name255);
  const fs::path tp(t);
  CHECK(tp.parent_path() == tmp.dir);                            // beside the output
  CHECK(tp.filename().string().size() <= 255);                   // fits
  CHECK(tp.filename().string().rfind(std::string(200, 'n'), 0) == 0);  // recognisable
  CHECK(t.find(".tmp.") != std::string::npos);
  // Unique: two long names that differ only at the end get different temporary names.
  CHECK(temp_path(tmp / (std::string(252, 'n') + ".h6")) != t);
  CHECK(temp_path(tmp / "short.h5") == (tmp / "short.h5") + ".tmp." + std::to_string(getpid()));

  const Chain c = make_chain(tmp);
  // Before: "cannot be created" (the probe "<name>.tmp.<pid>" passed 255 bytes), exit 2.
  const std::string hp = tmp / name255;
  test::ToolRun r = run_tool("trace-hitpoints", "--estimator ppm --direct photons --scene " + c.scene + " -o " + hp, tmp);
  INFO(r.err);
  CHECK(r.exit_code == 0);
  CHECK(fs::is_regular_file(hp));
  const std::string exr = tmp / (std::string(251, 'e') + ".exr");
  r = run_tool("synthesize", "--hitpoints " + c.st + " -o " + exr, tmp);
  INFO(r.err);
  CHECK(r.exit_code == 0);
  CHECK(fs::is_regular_file(exr));
  CHECK(fs::is_regular_file(preview_path(exr)));
  CHECK(test::temporary_files(tmp.dir).empty());
}

TEST_CASE("outputs: a run removes the temporaries a killed run of the same output left",
          "[tools][outputs]") {
  // After kill -9 "<out>.tmp.<pid>" stayed for ever, also after a successful --resume. Now every
  // writer removes the temporaries of its output whose process is gone, and no other file.
  TempDir tmp("stale-temps");
  const Chain c = make_chain(tmp);
  const pid_t dead = fork();
  REQUIRE(dead >= 0);
  if (dead == 0) _exit(0);
  REQUIRE(waitpid(dead, nullptr, 0) == dead);  // reaped: the pid names no process now
  for (const std::string& name : std::vector<std::string>{"out.h5", std::string(252, 'n') + ".h5"}) {
    INFO(name.size() << "-byte name");
    const std::string out = tmp / name;
    const std::string stale = temp_path(out, long(dead)), live = temp_path(out, long(getpid()));
    const std::string other = temp_path(tmp / "other.h5", long(dead));  // another output's
    const std::string near = stale + "x";                                 // not the pattern
    for (const std::string& f : {stale, live, other, near}) std::ofstream(f) << "partial";
    test::ToolRun r = run_tool("trace-hitpoints", "--estimator ppm --direct photons --scene " + c.scene + " -o " + out, tmp);
    INFO(r.err);
    REQUIRE(r.exit_code == 0);
    CHECK_FALSE(fs::exists(stale));
    CHECK(fs::exists(live));  // this test process is alive
    CHECK(fs::exists(other));
    CHECK(fs::exists(near));
    for (const std::string& f : {live, other, near}) fs::remove(f);
  }
  // The library call alone: only the dead process's file of that output goes.
  const std::string out = tmp / "x.h5";
  std::ofstream(temp_path(out, long(dead))) << "partial";
  std::ofstream(temp_path(out, long(getpid()))) << "partial";
  CHECK(remove_stale_temps(out) == 1);
  CHECK(fs::exists(temp_path(out, long(getpid()))));
}
