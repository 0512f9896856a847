// Seeded semantic fuzzing of the intermediates (issue 26): valid files of a small room scene —
// scene.h5, a fresh hitpoints.h5, photons.h5, grid.h5, clusters.h5 and a PPM checkpoint — get
// VALUES changed through HDF5 (h5edit.h; byte flips are damaged_inputs_test.cpp's): a field of a
// random element set to NaN, ±inf, ±1e38, −1, 0, a denormal, INT_MAX, INT_MIN, 2^64 − 1, ...;
// two elements swapped; a dataset truncated, emptied or extended by rewriting it; an attribute set
// to such a value or to another string. The edited dataset's checksum64 is refreshed and, for a
// scene, the scene id recomputed (as a user's script would, docs/FORMATS.md), so the edits reach
// the loaders' value checks (validate.h). Each file is then read by the stage that consumes it,
// run in-process in a forked child (a crash shows as a signal, a hang as the alarm's):
//   scene       load_scene, eye pass, one photon pass, one PPM pass, synthesis (trace-hitpoints,
//               trace-photons, render)
//   hitpoints   accepted for the scene, a PPM pass with the fixture's photons, the grid
//               build-grid makes for it, synthesis (illuminate, build-grid)
//   photons     accepted for the scene, a PPM pass per pass, a classic estimate, a grid per pass
//               (illuminate, build-grid)
//   grid        accepted for the scene, a PPM pass per pass grid (illuminate --grid)
//   clusters    loaded for the fixture's hitpoints, radii refreshed: every member's gather sphere
//               inside its cluster's sphere (what the clustered gathers rely on)
//   checkpoint  accepted for the scene, synthesis, one more PPM pass, synthesis (render --resume,
//               synthesize)
//   sppm        an SPPM checkpoint (estimator "sppm", sppm.h, written by render_progressive):
//               accepted, synthesis, then render --resume through the render driver for one more
//               pass with a checkpoint, which must load again (synthesize, render --resume)
//   sums        a PPPM checkpoint (pass sums of render_pppm): synthesis, render --resume for one
//               more pass with a checkpoint, which must load again (synthesize --sums, render)
//   merge2/3    a pass-sums part merged with one (2 parts) or two (3 parts) valid neighbours; the
//               merged sums are saved, loaded again and synthesized (merge)
// Besides values, a dataset may be rewritten with another element type (float32, float64, int64)
// or another shape of the same element count (its dimensions reversed, or flattened), which the
// readers must refuse (h5io.h: exact shape and type), never reinterpret.
// Every run must end in exit 0 with every output value finite, or in a refusal: one line naming
// the file (InputError, exit code 2). Every PF_FUZZ_TOOL_EVERY-th mutation (default 40) also runs
// the real tool on the file (no clusters tool reads them without a device): exit 0 with finite
// outputs, or 2 with one line on stderr and no output file.
// PF_FUZZ_RUNS (default 250 per intermediate) and PF_FUZZ_SEED (default 26) change the run.
#include <catch2/catch.hpp>
#include <hdf5.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <functional>
#include <iostream>
#include <random>
#include <string>
#include <vector>

#include "h5edit.h"
#include "photonflow/stages/clusters.h"
#include "photonflow/stages/eye_pass.h"
#include "photonflow/stages/illuminate.h"
#include "photonflow/image/image.h"
#include "photonflow/estimators/pass_sums.h"
#include "photonflow/stages/photon_pass.h"
#include "photonflow/estimators/render_driver.h"
#include "photonflow/estimators/sppm.h"
#include "photonflow/io/stage_files.h"
#include "photonflow/stages/synthesize.h"
#include "photonflow/io/validate.h"
#include "photonflow/geometry/scene_file.h"
#include "photonflow/io/h5_types.h"
#include "support.h"

using namespace pf;
using test::TempDir;

namespace {

long env_long(const char* name, long fallback) {
  const char* s = std::getenv(name);
  return s && *s ? std::strtol(s, nullptr, 10) : fallback;
}

Provenance prov() {
  Provenance p;
  p.tool = "test";
  return p;
}

// The outcome of one isolated run.
struct Outcome {
  enum Kind { Ok, Refused, Internal, NonFinite, Signal, Hang } kind = Ok;
  std::string text;  // the refusal's line, the error, the non-finite value
  int signal = 0;
};

// Runs `body` in a forked child with a time limit. body returns "" when every output value is
// finite, else a description of the first that is not; an InputError is a refusal. The parent of
// these children never runs OpenMP itself (the fixture is made in a child too): libgomp's thread
// pool does not survive fork.
Outcome isolated(const std::function<std::string()>& body, unsigned seconds) {
  int fd[2];
  REQUIRE(pipe(fd) == 0);
  std::cout.flush();
  const pid_t pid = fork();
  REQUIRE(pid >= 0);
  if (pid == 0) {
    close(fd[0]);
    alarm(seconds);
    int code = 0;
    std::string msg;
    try {
      msg = body();
      code = msg.empty() ? 0 : 3;
    } catch (const InputError& e) {
      code = 2;
      msg = e.what();
    } catch (const std::exception& e) {
      code = 1;
      msg = e.what();
    } catch (...) {
      code = 1;
      msg = "exception of unknown type";
    }
    for (size_t done = 0; done < msg.size();) {
      const ssize_t n = write(fd[1], msg.data() + done, msg.size() - done);
      if (n <= 0) break;
      done += size_t(n);
    }
    close(fd[1]);
    _exit(code);
  }
  close(fd[1]);
  Outcome o;
  char buf[4096];
  for (ssize_t n; (n = read(fd[0], buf, sizeof buf)) > 0;) o.text.append(buf, size_t(n));
  close(fd[0]);
  int status = 0;
  REQUIRE(waitpid(pid, &status, 0) == pid);
  if (WIFSIGNALED(status)) {
    o.signal = WTERMSIG(status);
    o.kind = o.signal == SIGALRM ? Outcome::Hang : Outcome::Signal;
  } else {
    const int code = WEXITSTATUS(status);
    o.kind = code == 0   ? Outcome::Ok
             : code == 2 ? Outcome::Refused
             : code == 3 ? Outcome::NonFinite
                         : Outcome::Internal;
  }
  return o;
}

// ---- the fixture ------------------------------------------------------------------------------



// The render runs of the SPPM and pass-sums fixtures (2 passes) and of their continuations: the
// options `render --estimator sppm|pppm --photons 1500 --threads 1` uses (render_cli below).
RenderOptions render_options(Estimator e) {
  RenderOptions o;
  o.estimator = e;
  o.passes = 2;
  o.photons.photons = 1500;
  o.photons.threads = o.eye.threads = o.ppm.threads = 1;
  o.eye.sampler = PixelSampler::Sobol;
  o.ppm.slab = kDefaultSlab;
  return o;
}
RenderOptions pppm_options() { return render_options(Estimator::Pppm); }

struct Fixture {
  TempDir tmp{"semfuzz"};
  std::string scene = tmp / "scene.h5", hp = tmp / "hp.h5", ph = tmp / "ph.h5",
              grid = tmp / "grid.h5", clusters = tmp / "clusters.h5", ckpt = tmp / "ckpt.h5",
              sppm = tmp / "sppm.h5", sums = tmp / "sums.h5", part2 = tmp / "part2.h5",
              part3 = tmp / "part3.h5";
  Fixture() {
    const Outcome o = isolated(
        [this] {
          Scene s = test::room_scene(PF_MAT_GLASS, 16, 12);  // a glass sphere: caustic photons
          save_scene(s, scene, prov());
          EyePassOptions eo;
          eo.threads = 1;
          HitpointSet h = make_hitpoint_set(trace_hitpoints(s, eo), eo.direct, s.scene_id);
          save_hitpoints(h, hp, prov());
          PhotonSet p;
          p.scene_id = s.scene_id;
          PhotonPassOptions po;
          po.photons = 1500;
          po.threads = 1;
          for (uint32_t pass = 0; pass < 2; ++pass) {
            PhotonPassResult r = trace_photons(s, pass, po);
            p.append_pass(r.photons, r.emitted);
          }
          save_photons(p, ph, prov());
          PpmOptions ppm;
          ppm.threads = 1;
          GridSet g;
          g.scene_id = s.scene_id;
          g.pass_emitted = p.pass_emitted;
          for (int k = 0; k < 2; ++k)
            g.grids.push_back(build_photon_grid(p.pass(k), int(s.mesh_names.size()),
                                                ppm_grid_params(h, ppm)));
          save_grids(g, grid, prov());
          save_clusters(cluster_kmeans(h, 8, 3, 1), clusters, prov());
          for (int k = 0; k < 2; ++k) ppm_pass(s, h, p.pass(k), p.pass_emitted[size_t(k)], ppm);
          save_hitpoints(h, ckpt, prov());
          RenderOptions so = render_options(Estimator::Sppm);
          so.checkpoint = sppm;  // the checkpoint render writes, with its state options
          render_progressive(s, so, false, prov());
          save_pass_sums(render_pppm(s, pppm_options(), false, prov()), sums, prov());
          // The neighbours of a merge: passes [2, 3) and [3, 4) of the same run.
          for (int k = 0; k < 2; ++k) {
            RenderOptions po = pppm_options();
            po.first_pass = 2 + k;
            po.passes = 1;
            save_pass_sums(render_pppm(s, po, false, prov()), k == 0 ? part2 : part3, prov());
          }
          return std::string();
        },
        120);
    INFO(o.text);
    REQUIRE(o.kind == Outcome::Ok);
  }
};

Fixture& fixture() {
  static Fixture f;
  return f;
}

// ---- finite outputs ---------------------------------------------------------------------------

std::string first_non_finite(const float* v, size_t n, const std::string& what) {
  for (size_t i = 0; i < n; ++i)
    if (!std::isfinite(v[i])) return what + "[" + std::to_string(i) + "] = " + std::to_string(v[i]);
  return "";
}

std::string non_finite(const Image& img) {
  std::string bad = first_non_finite(img.rgb.data(), img.rgb.size(), "image rgb");
  for (const auto& [name, layer] : img.layers)
    if (bad.empty()) bad = first_non_finite(layer.data(), layer.size(), "image layer " + name);
  return bad;
}

std::string non_finite(const HitpointSet& h) {
  static_assert(sizeof(pf_hitpoint) % 4 == 0, "4-byte fields");
  for (size_t i = 0; i < h.hitpoints.size(); ++i) {
    const pf_hitpoint& hp = h.hitpoints[i];
    const float* f = hp.position;  // the 16 floats before pixel_x
    const std::string bad = first_non_finite(f, size_t(&hp.flux[2] - f) + 1,
                                             "hitpoint " + std::to_string(i) + " field");
    if (!bad.empty()) return bad;
  }
  std::string bad = first_non_finite(h.emitted.data(), h.emitted.size(), "emitted");
  if (bad.empty()) bad = first_non_finite(h.direct.data(), h.direct.size(), "direct");
  return bad;
}

std::string non_finite(const std::vector<pf_photon>& photons) {
  for (size_t i = 0; i < photons.size(); ++i) {
    const std::string bad = first_non_finite(photons[i].position, 9, "photon " + std::to_string(i));
    if (!bad.empty()) return bad;
  }
  return "";
}

// The state and its image: every value finite.
std::string check_state(const HitpointSet& h) {
  std::string bad = non_finite(h);
  return bad.empty() ? non_finite(synthesize(h)) : bad;
}

// ---- the stages -------------------------------------------------------------------------------

enum class Kind { Scene, Hitpoints, Photons, Grid, Clusters, Checkpoint, Sppm, PassSums, Merge2,
                  Merge3 };

// A file a run wrote is one the next run reads (validate.h written_check): "" or what refused it.
template <class Load>
std::string reloads(const std::string& path, Load&& load) {
  try {
    load(path);
    return "";
  } catch (const InputError& e) {
    return std::string("the file the run wrote is refused: ") + e.what();
  }
}

PpmOptions ppm_options() {
  PpmOptions o;
  o.threads = 1;
  return o;
}

std::string run_stage(Kind kind, const std::string& file) {
  const Fixture& fx = fixture();
  const PpmOptions ppm = ppm_options();
  Provenance p;
  if (kind == Kind::Scene) {
    const Scene s = load_scene(file);
    EyePassOptions eo;
    eo.threads = 1;
    HitpointSet h = make_hitpoint_set(trace_hitpoints(s, eo), eo.direct, s.scene_id);
    std::string bad = non_finite(h);
    if (!bad.empty()) return "eye pass: " + bad;
    PhotonPassOptions po;
    po.photons = 400;
    po.threads = 1;
    const PhotonPassResult r = trace_photons(s, 0, po);
    bad = non_finite(r.photons);
    if (!bad.empty()) return "photon pass: " + bad;
    ppm_pass(s, h, r.photons, r.emitted, ppm);
    return check_state(h);
  }
  const Scene s = load_scene(fx.scene);
  if (kind == Kind::Clusters) {
    const HitpointSet h = load_hitpoints(fx.hp);
    ClusterSet c = load_clusters(file, h);
    update_cluster_radii(c, h);
    for (size_t k = 0; k < c.clusters.size(); ++k) {
      const pf_cluster& cl = c.clusters[k];
      if (!std::isfinite(cl.radius)) return "cluster " + std::to_string(k) + " radius not finite";
      for (int32_t t = cl.first; t < cl.first + cl.count; ++t) {
        const pf_hitpoint& hp = h.hitpoints[size_t(c.order[size_t(t)])];
        const double d = length(Vec3(hp.position) - Vec3(cl.centre)) + hp.radius;
        if (!(d <= double(cl.radius) * (1 + 1e-6)))
          return "cluster " + std::to_string(k) + " misses a member's gather sphere";
      }
    }
    return "";
  }
  if (kind == Kind::Grid) {
    const GridSet g = load_grids(file);
    accept_input(p, "grid", file, g, s, fx.scene);
    HitpointSet h = load_hitpoints(fx.hp);
    for (size_t k = 0; k < g.grids.size(); ++k) ppm_pass_grid(s, h, g.grids[k], g.pass_emitted[k], ppm);
    return check_state(h);
  }
  if (kind == Kind::Photons) {
    const PhotonSet ph = load_photons(file);
    accept_input(p, "photons", file, ph, s, fx.scene);
    const HitpointSet fresh = load_hitpoints(fx.hp);
    HitpointSet h = fresh;
    for (int k = 0; k < ph.pass_count(); ++k) {
      ppm_pass(s, h, ph.pass(k), ph.pass_emitted[size_t(k)], ppm);
      const PhotonGrid grid =
          build_photon_grid(ph.pass(k), int(s.mesh_names.size()), ppm_grid_params(fresh, ppm));
      const std::string bad = non_finite(grid.photons);
      if (!bad.empty()) return "grid: " + bad;
    }
    std::string bad = check_state(h);
    if (!bad.empty()) return "ppm: " + bad;
    HitpointSet c = fresh;
    uint64_t emitted = 0;
    for (uint64_t e : ph.pass_emitted) emitted += e;
    ClassicOptions co;
    co.k = 20;
    co.threads = 1;
    classic_estimate(s, c, ph.photons, emitted, co);
    bad = check_state(c);
    return bad.empty() ? "" : "classic: " + bad;
  }
  if (kind == Kind::Merge2 || kind == Kind::Merge3) {  // merge: the part between valid ones
    const std::vector<std::string> parts =
        kind == Kind::Merge2 ? std::vector<std::string>{file, fx.part2}
                             : std::vector<std::string>{fx.sums, file, fx.part3};
    const PassSums merged = merge_pass_sum_files(parts);
    std::string bad = non_finite(synthesize(merged));
    if (!bad.empty()) return "merged: " + bad;
    const std::string out = fx.tmp / "merged.h5";
    std::filesystem::remove(out);
    save_pass_sums(merged, out, prov());
    return reloads(out, [](const std::string& f) { load_pass_sums(f); });
  }
  if (kind == Kind::PassSums) {  // synthesize --sums, and render --resume: one more pass
    PassSums sums = load_pass_sums(file);
    require_scene(file, sums.scene_id, s.scene_id, fx.scene);
    std::string bad = non_finite(synthesize(sums));
    if (!bad.empty()) return "synthesize: " + bad;
    RenderOptions o = pppm_options();
    o.first_pass = sums.first_pass;
    o.passes = int(std::min<int64_t>(int64_t(sums.passes) + 1, kMaxPassEnd - sums.first_pass));
    o.checkpoint = file;  // the run continues the file itself and writes its checkpoint there
    const PassSums next = render_pppm(s, o, true, p);
    bad = non_finite(synthesize(next));
    if (!bad.empty()) return "one more pass: " + bad;
    return reloads(o.checkpoint, [](const std::string& f) { load_pass_sums(f); });
  }
  if (kind == Kind::Sppm) {  // render --resume of an SPPM checkpoint: one more pass
    HitpointSet h = load_hitpoints(file);
    accept_input(p, "hitpoints", file, h, s, fx.scene);
    std::string bad = check_state(h);
    if (!bad.empty()) return "loaded state: " + bad;
    RenderOptions o = render_options(Estimator::Sppm);
    o.passes = int(std::min<int64_t>(int64_t(h.passes) + 1, INT32_MAX));
    o.checkpoint = file;
    bad = check_state(render_progressive(s, o, true, p));
    if (!bad.empty()) return "one more pass: " + bad;
    return reloads(o.checkpoint, [](const std::string& f) { load_hitpoints(f); });
  }
  // Hitpoints and checkpoints: a PPM pass with the fixture's photons (one more pass of a
  // checkpoint: what render --resume does) and the image.
  HitpointSet h = load_hitpoints(file);
  accept_input(p, "hitpoints", file, h, s, fx.scene);
  std::string bad = check_state(h);
  if (!bad.empty()) return "loaded state: " + bad;
  const PhotonSet ph = load_photons(fx.ph);
  if (kind == Kind::Hitpoints) {
    const PhotonGrid grid =
        build_photon_grid(ph.pass(0), int(s.mesh_names.size()), ppm_grid_params(h, ppm));
    bad = non_finite(grid.photons);
    if (!bad.empty()) return "grid: " + bad;
  }
  ppm_pass(s, h, ph.pass(1), ph.pass_emitted[1], ppm);
  return check_state(h);
}

// ---- mutations --------------------------------------------------------------------------------

using Rng = std::mt19937_64;

size_t pick(Rng& rng, size_t n) { return n ? size_t(rng() % n) : 0; }

// Datasets and objects (for attributes) of a file, outside /provenance.
struct Objects {
  std::vector<std::string> datasets, all;
};

herr_t visit_link(hid_t group, const char* name, const H5L_info_t*, void* data) {
  auto* out = static_cast<Objects*>(data);
  const std::string n = name;
  if (n.rfind("provenance", 0) == 0) return 0;
  h5::Handle o(H5Oopen(group, name, H5P_DEFAULT));
  if (!o.valid()) return 0;
  const H5I_type_t t = H5Iget_type(o.get());
  if (t == H5I_DATASET) out->datasets.push_back("/" + n);
  if (t == H5I_DATASET || t == H5I_GROUP) out->all.push_back("/" + n);
  return 0;
}

Objects objects(hid_t f) {
  Objects o;
  o.all.push_back("/");
  H5Lvisit(f, H5_INDEX_NAME, H5_ITER_NATIVE, visit_link, &o);
  return o;
}

// A numeric leaf of a (compound, array) memory type: its byte offset in the element and class.
struct Leaf {
  size_t offset;
  H5T_class_t cls;
  size_t size;
  bool is_signed;
};

void leaves(hid_t type, size_t offset, std::vector<Leaf>& out) {
  const H5T_class_t c = H5Tget_class(type);
  if (c == H5T_COMPOUND) {
    const int n = H5Tget_nmembers(type);
    for (int i = 0; i < n; ++i) {
      h5::Handle m(H5Tget_member_type(type, unsigned(i)));
      leaves(m.get(), offset + H5Tget_member_offset(type, unsigned(i)), out);
    }
  } else if (c == H5T_ARRAY) {
    h5::Handle base(H5Tget_super(type));
    const size_t step = H5Tget_size(base.get());
    const size_t count = step ? H5Tget_size(type) / step : 0;
    for (size_t k = 0; k < count; ++k) leaves(base.get(), offset + k * step, out);
  } else if (c == H5T_FLOAT || c == H5T_INTEGER) {
    out.push_back({offset, c, H5Tget_size(type), c == H5T_INTEGER && H5Tget_sign(type) == H5T_SGN_2});
  }
}

// A new value for a float of value v.
double float_value(Rng& rng, double v) {
  const double values[] = {NAN, INFINITY, -INFINITY, 1e38, -1e38, -1.0, 0.0, -0.0, 1e-30,
                           1e-45, 2 * v, -v, v + 1, v * 1e6, 1e12, 0.5};
  return values[pick(rng, sizeof values / sizeof values[0])];
}

// A new value for an integer of value v (as int64; written truncated to the field's size).
int64_t int_value(Rng& rng, int64_t v, size_t size) {
  const int64_t values[] = {-1, 0, 1, INT_MAX, INT_MIN, v + 1, v - 1, v * 2, int64_t(1) << 20,
                            -v, size == 8 ? int64_t(-1) /* 2^64 − 1 unsigned */ : INT_MAX - 1,
                            size == 8 ? (int64_t(1) << 62) : 65536,
                            size == 8 ? INT64_MAX : 7, int64_t(rng() % 1000)};
  return values[pick(rng, sizeof values / sizeof values[0])];
}

void set_leaf(unsigned char* p, const Leaf& l, Rng& rng, std::string& what) {
  if (l.cls == H5T_FLOAT) {
    double v = 0;
    if (l.size == 4) {
      float f;
      std::memcpy(&f, p, 4);
      v = f;
    } else {
      std::memcpy(&v, p, 8);
    }
    const double nv = float_value(rng, v);
    what += " := " + std::to_string(nv);
    if (l.size == 4) {
      const float f = float(nv);
      std::memcpy(p, &f, 4);
    } else {
      std::memcpy(p, &nv, 8);
    }
    return;
  }
  int64_t v = 0;
  if (l.size == 4) {
    int32_t i;
    std::memcpy(&i, p, 4);
    v = i;
  } else if (l.size == 8) {
    std::memcpy(&v, p, 8);
  } else {
    return;
  }
  const int64_t nv = int_value(rng, v, l.size);
  what += " := " + std::to_string(nv);
  if (l.size == 4) {
    const int32_t i = int32_t(nv);
    std::memcpy(p, &i, 4);
  } else {
    std::memcpy(p, &nv, 8);
  }
}

// Changes dataset `name` of open file f: a value, a swap, a truncation or an extension. Returns
// what it did ("" when the dataset has no numeric values).
std::string mutate_dataset(hid_t f, const std::string& name, Rng& rng) {
  h5::Handle d(H5Dopen2(f, name.c_str(), H5P_DEFAULT));
  if (!d.valid()) return "";
  h5::Handle ftype(H5Dget_type(d.get()));
  h5::Handle ntype(H5Tget_native_type(ftype.get(), H5T_DIR_ASCEND));
  std::vector<Leaf> ls;
  leaves(ntype.get(), 0, ls);
  if (ls.empty()) return "";  // strings
  const size_t size = H5Tget_size(ntype.get());
  h5::Handle space(H5Dget_space(d.get()));
  const size_t n = size_t(H5Sget_simple_extent_npoints(space.get()));
  std::vector<unsigned char> bytes(n * size);
  if (n) REQUIRE(H5Dread(d.get(), ntype.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, bytes.data()) >= 0);
  const size_t op = pick(rng, 12);
  if (op >= 10) {  // the same values under another element type or another shape
    h5::Handle fspace(H5Dget_space(d.get()));
    std::vector<hsize_t> dims(size_t(std::max(0, H5Sget_simple_extent_ndims(fspace.get()))));
    if (!dims.empty()) H5Sget_simple_extent_dims(fspace.get(), dims.data(), nullptr);
    const bool numeric = ls.size() == 1 && H5Tget_class(ntype.get()) != H5T_COMPOUND;
    hid_t stored = ftype.get();
    std::string what;
    std::vector<unsigned char> values = bytes;
    hid_t mem = ntype.get();
    std::vector<double> as_double;
    if (op == 10 && numeric) {  // retyped: float64 ↔ float32, or int64
      as_double.resize(n);
      if (n) REQUIRE(H5Dread(d.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, as_double.data()) >= 0);
      const hid_t types[] = {H5T_IEEE_F32LE, H5T_IEEE_F64LE, H5T_STD_I64LE};
      stored = types[pick(rng, 3)];
      if (H5Tequal(stored, ftype.get()) > 0) stored = H5T_STD_I64LE;
      mem = H5T_NATIVE_DOUBLE;
      what = name + " retyped";
    } else {  // reshaped: dimensions reversed (1-D: split in two), or flattened
      const hsize_t total = hsize_t(n);
      if (dims.size() > 1 && pick(rng, 2) == 0) {
        dims = {total};
      } else if (dims.size() > 1) {
        std::reverse(dims.begin(), dims.end());
        if (std::adjacent_find(dims.begin(), dims.end(), std::not_equal_to<>()) == dims.end())
          dims.push_back(1);  // all equal: reversing changes nothing; add a dimension
      } else {
        dims = total % 2 == 0 && total > 0 ? std::vector<hsize_t>{2, total / 2}
                                           : std::vector<hsize_t>{total, 1};
      }
      what = name + " reshaped";
    }
    d = h5::Handle();
    const void* src = mem == H5T_NATIVE_DOUBLE ? static_cast<const void*>(as_double.data())
                                               : static_cast<const void*>(values.data());
    test::rewrite_dataset_as(f, name, stored, mem, src, n, dims);  // with a consistent checksum
    return what;
  }
  if (op < 7 && n > 0) {
    const size_t e = pick(rng, n);
    const Leaf& l = ls[pick(rng, ls.size())];
    std::string what = name + "[" + std::to_string(e) + "]@" + std::to_string(l.offset);
    set_leaf(bytes.data() + e * size + l.offset, l, rng, what);
    REQUIRE(H5Dwrite(d.get(), ntype.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, bytes.data()) >= 0);
    test::refresh_checksum(d.get());
    return what;
  }
  if (op == 7 && n >= 2) {
    const size_t a = pick(rng, n), b = pick(rng, n);
    std::vector<unsigned char> t(bytes.begin() + long(a * size), bytes.begin() + long((a + 1) * size));
    std::memmove(bytes.data() + a * size, bytes.data() + b * size, size);
    std::memcpy(bytes.data() + b * size, t.data(), size);
    REQUIRE(H5Dwrite(d.get(), ntype.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, bytes.data()) >= 0);
    test::refresh_checksum(d.get());
    return name + " swap " + std::to_string(a) + " " + std::to_string(b);
  }
  // Rewrite with another length: truncated (possibly to nothing) or one element repeated.
  size_t m = n;
  if (op == 9 && n > 0) {
    const size_t e = pick(rng, n);
    bytes.insert(bytes.end(), bytes.begin() + long(e * size), bytes.begin() + long((e + 1) * size));
    m = n + 1;
  } else {
    m = pick(rng, n);  // 0 … n − 1 (n = 0: stays empty)
    bytes.resize(m * size);
  }
  d = h5::Handle();
  test::rewrite_dataset_raw(f, name, ntype.get(), bytes.data(), m);
  return name + " rewritten with " + std::to_string(m) + " of " + std::to_string(n) + " elements";
}

herr_t collect_attr(hid_t, const char* name, const H5A_info_t*, void* data) {
  static_cast<std::vector<std::string>*>(data)->push_back(name);
  return 0;
}

// A string attribute to set once the file is closed (set_string_attr opens it itself).
struct StringEdit {
  std::string obj, name, value;
};

// Changes one attribute of object `obj`: an integer or float to a new value; for a string, fills
// `later` with another value (an estimator, a method, a direct mode, garbage). Returns what it
// did ("" when the object has no attribute to change).
std::string mutate_attribute(hid_t f, const std::string& obj, Rng& rng, StringEdit& later) {
  std::vector<std::string> names;
  h5::Handle o(H5Oopen(f, obj.c_str(), H5P_DEFAULT));
  if (!o.valid()) return "";
  hsize_t idx = 0;
  H5Aiterate2(o.get(), H5_INDEX_NAME, H5_ITER_NATIVE, &idx, collect_attr, &names);
  names.erase(std::remove_if(names.begin(), names.end(),
                             [](const std::string& n) {
                               return n == "checksum64" || n == "unit" || n == "description" ||
                                      n == "format";
                             }),
              names.end());
  if (names.empty()) return "";
  const std::string name = names[pick(rng, names.size())];
  h5::Handle a(H5Aopen(o.get(), name.c_str(), H5P_DEFAULT));
  h5::Handle t(H5Aget_type(a.get()));
  h5::Handle space(H5Aget_space(a.get()));
  if (H5Sget_simple_extent_npoints(space.get()) != 1) return "";
  const H5T_class_t cls = H5Tget_class(t.get());
  if (cls == H5T_INTEGER) {
    int64_t v = 0;
    H5Aread(a.get(), H5T_NATIVE_INT64, &v);
    const int64_t nv = int_value(rng, v, 8);
    REQUIRE(H5Awrite(a.get(), H5T_NATIVE_INT64, &nv) >= 0);
    return obj + "@" + name + " := " + std::to_string(nv);
  }
  if (cls == H5T_FLOAT) {
    double v = 0;
    H5Aread(a.get(), H5T_NATIVE_DOUBLE, &v);
    const double nv = float_value(rng, v);
    REQUIRE(H5Awrite(a.get(), H5T_NATIVE_DOUBLE, &nv) >= 0);
    return obj + "@" + name + " := " + std::to_string(nv);
  }
  if (cls != H5T_STRING) return "";
  static const char* strings[] = {"none", "ppm", "classic", "sppm", "bogus", "", "photons",
                                  "shadow-rays", "kmeans", "grid", "ga", "PPM"};
  later = {obj, name, strings[pick(rng, sizeof strings / sizeof strings[0])]};
  return obj + "@" + name + " := '" + later.value + "'";
}

// One mutation of `file` (a copy of a valid intermediate); returns its description.
std::string mutate(const std::string& file, Rng& rng, bool scene) {
  std::string what;
  StringEdit later;
  {
    h5::Handle f(H5Fopen(file.c_str(), H5F_ACC_RDWR, H5P_DEFAULT));
    REQUIRE(f.valid());
    const Objects obs = objects(f.get());
    for (int tries = 0; tries < 20 && what.empty(); ++tries) {
      if (pick(rng, 4) != 0)
        what = mutate_dataset(f.get(), obs.datasets[pick(rng, obs.datasets.size())], rng);
      else
        what = mutate_attribute(f.get(), obs.all[pick(rng, obs.all.size())], rng, later);
    }
  }
  if (!later.name.empty()) test::set_string_attr(file, later.obj, later.name, later.value);
  // A script that edits a scene recomputes its id (nine times in ten: the id check is tested too).
  const bool touched_id = later.name == "scene_id";
  if (scene && !touched_id && pick(rng, 10) != 0) test::refresh_scene_id(file);
  return what;
}

// ---- the tools (a sample) ---------------------------------------------------------------------

// The stage's tool on `file`: exit 0 with finite outputs, or 2 with one line and no output.
void run_tool_on(Kind kind, const std::string& file, const std::string& what, bool resume_tool) {
  const Fixture& fx = fixture();
  const bool image = kind == Kind::Checkpoint || kind == Kind::Sppm || kind == Kind::PassSums ||
                     kind == Kind::Merge2 || kind == Kind::Merge3;
  const std::string out = fx.tmp / (image ? "tool-out.exr" : "tool-out.h5");
  std::filesystem::remove(out);
  std::string tool, args;
  switch (kind) {
    case Kind::Scene: tool = "trace-hitpoints"; args = "--estimator ppm --direct photons --scene " + file; break;
    case Kind::Hitpoints:
      tool = "illuminate";
      args = "--estimator ppm --scene " + fx.scene + " --hitpoints " + file + " --photons " + fx.ph;
      break;
    case Kind::Photons:
      tool = "illuminate";
      args = "--estimator ppm --scene " + fx.scene + " --hitpoints " + fx.hp + " --photons " + file;
      break;
    case Kind::Grid:
      tool = "illuminate";
      args = "--estimator ppm --scene " + fx.scene + " --hitpoints " + fx.hp + " --grid " + file + " --method grid";
      break;
    case Kind::Checkpoint:
    case Kind::Sppm: tool = "synthesize"; args = "--hitpoints " + file + " --png none"; break;
    case Kind::PassSums: tool = "synthesize"; args = "--sums " + file + " --png none"; break;
    case Kind::Merge2: tool = "merge"; args = file + " " + fx.part2; break;
    case Kind::Merge3: tool = "merge"; args = fx.sums + " " + file + " " + fx.part3; break;
    case Kind::Clusters: return;
  }
  if ((kind == Kind::Sppm || kind == Kind::PassSums) && resume_tool) {
    const std::string ck = fx.tmp / "tool-resume.h5";
    std::filesystem::remove(ck);
    std::filesystem::copy_file(file, ck);
    tool = "render";
    args = "--scene " + fx.scene + " --estimator " + (kind == Kind::Sppm ? "sppm" : "pppm") +
           " --photons 1500 --threads 1 --passes 3 --checkpoint " + ck + " --resume";
  }
  args += " -o " + out + (image ? "" : " --threads 1");
  const std::string so = fx.tmp / ".tool-stdout", se = fx.tmp / ".tool-stderr";
  const std::string cmd = "timeout -s KILL 60 " + test::bin_dir() + "/" + tool + " " + args + " >" +
                          so + " 2>" + se;
  const int status = std::system(cmd.c_str());
  const int code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  const std::string err = test::file_bytes(se);
  INFO(tool << " " << args << "\nafter " << what << "\nexit " << code << ", stderr: " << err);
  CHECK((code == 0 || code == kExitBadInput));
  CHECK(test::temporary_files(fx.tmp.dir).empty());
  if (code == kExitBadInput) {
    CHECK(std::count(err.begin(), err.end(), '\n') == 1);
    CHECK_FALSE(std::filesystem::exists(out));
  } else if (code == 0) {
    REQUIRE(std::filesystem::exists(out));
    std::string bad;
    if (image) {
      bad = non_finite(read_exr(out));
    } else {
      std::vector<pf_hitpoint> hps = test::read_dataset<pf_hitpoint>(out, "/hitpoints", h5_type_hitpoint().id());
      HitpointSet h;
      h.hitpoints = hps;
      h.emitted = test::read_dataset<float>(out, "/image/emitted", H5T_NATIVE_FLOAT);
      h.direct = test::read_dataset<float>(out, "/image/direct", H5T_NATIVE_FLOAT);
      bad = non_finite(h);
    }
    INFO(bad);
    CHECK(bad.empty());
  }
  std::filesystem::remove(out);
  std::filesystem::remove(so);
  std::filesystem::remove(se);
}

// ---- the driver -------------------------------------------------------------------------------

void fuzz(Kind kind, const std::string& src, const char* label, uint64_t salt) {
  Fixture& fx = fixture();
  const long runs = env_long("PF_FUZZ_RUNS", 250);
  const long tool_every = env_long("PF_FUZZ_TOOL_EVERY", 40);
  const uint64_t seed = uint64_t(env_long("PF_FUZZ_SEED", 26));
  const std::string file = fx.tmp / (std::string("m-") + label + ".h5");
  long accepted = 0, refused = 0;
  // The valid file passes (a copy: the resumes write their checkpoint over the file they read).
  {
    std::filesystem::remove(file);
    std::filesystem::copy_file(src, file);
    const Outcome o = isolated([&] { return run_stage(kind, file); }, 60);
    INFO(label << ": " << o.text);
    REQUIRE(o.kind == Outcome::Ok);
  }
  for (long run = 0; run < runs; ++run) {
    Rng rng(seed * 1000003u + salt * 7919u + uint64_t(run));
    std::filesystem::remove(file);
    std::filesystem::copy_file(src, file);
    std::string what = mutate(file, rng, kind == Kind::Scene);
    if (pick(rng, 5) == 0) what += "; " + mutate(file, rng, kind == Kind::Scene);
    const Outcome o = isolated([&] { return run_stage(kind, file); }, 30);
    INFO(label << " run " << run << " (PF_FUZZ_SEED " << seed << "): " << what << "\n-> "
               << o.text << " (signal " << o.signal << ")");
    CHECK(o.kind != Outcome::Signal);
    CHECK(o.kind != Outcome::Hang);
    CHECK(o.kind != Outcome::Internal);
    CHECK(o.kind != Outcome::NonFinite);
    // A dataset of another element type or shape is refused, never read as if it were the one
    // written (in the files whose every dataset their readers read).
    const bool all_read = kind == Kind::Hitpoints || kind == Kind::Checkpoint ||
                          kind == Kind::Sppm || kind == Kind::PassSums || kind == Kind::Merge2 ||
                          kind == Kind::Merge3;
    // (Only as the one edit of a copy: a second can undo it, a reshape reversed or rewritten
    // one-dimensional, a retype back.)
    const auto count = [&](const char* w) {
      size_t n = 0;
      for (size_t at = what.find(w); at != std::string::npos; at = what.find(w, at + 1)) ++n;
      return n;
    };
    if (all_read && count(" retyped") + count(" reshaped") == 1 && what.find("; ") == std::string::npos)
      CHECK(o.kind == Outcome::Refused);
    if (o.kind == Outcome::Refused) {
      ++refused;
      CHECK(o.text.find('\n') == std::string::npos);
      // A merge's refusal may name the part beside the edited one (a gap, an overlap is a
      // relation between parts): any part of the merge, but a file of the merge.
      const bool merge = kind == Kind::Merge2 || kind == Kind::Merge3;
      CHECK((o.text.find(file) != std::string::npos ||
             (merge && (o.text.find(fx.part2) != std::string::npos ||
                        o.text.find(fx.part3) != std::string::npos ||
                        o.text.find(fx.sums) != std::string::npos))));
    } else if (o.kind == Outcome::Ok) {
      ++accepted;
    }
    if (tool_every > 0 && run % tool_every == 0)
      run_tool_on(kind, file, what, (run / tool_every) % 2 == 1);
  }
  std::cout << "semantic fuzz " << label << ": " << runs << " mutations (seed " << seed << "), "
            << accepted << " accepted with finite outputs, " << refused << " refused\n";
}

}  // namespace

TEST_CASE("semantic fuzz: scene.h5", "[fuzz][semantic]") {
  fuzz(Kind::Scene, fixture().scene, "scene", 1);
}
TEST_CASE("semantic fuzz: hitpoints.h5", "[fuzz][semantic]") {
  fuzz(Kind::Hitpoints, fixture().hp, "hitpoints", 2);
}
TEST_CASE("semantic fuzz: photons.h5", "[fuzz][semantic]") {
  fuzz(Kind::Photons, fixture().ph, "photons", 3);
}
TEST_CASE("semantic fuzz: grid.h5", "[fuzz][semantic]") {
  fuzz(Kind::Grid, fixture().grid, "grid", 4);
}
TEST_CASE("semantic fuzz: clusters.h5", "[fuzz][semantic]") {
  fuzz(Kind::Clusters, fixture().clusters, "clusters", 5);
}
TEST_CASE("semantic fuzz: checkpoint (a PPM state)", "[fuzz][semantic]") {
  fuzz(Kind::Checkpoint, fixture().ckpt, "checkpoint", 6);
}
TEST_CASE("semantic fuzz: SPPM checkpoint (one hitpoint per pixel)", "[fuzz][semantic]") {
  fuzz(Kind::Sppm, fixture().sppm, "sppm", 7);
}
TEST_CASE("semantic fuzz: pass sums (probabilistic PPM)", "[fuzz][semantic]") {
  fuzz(Kind::PassSums, fixture().sums, "sums", 8);
}
TEST_CASE("semantic fuzz: merge of 2 pass-sums parts", "[fuzz][semantic][merge]") {
  fuzz(Kind::Merge2, fixture().sums, "merge2", 9);
}
TEST_CASE("semantic fuzz: merge of 3 pass-sums parts", "[fuzz][semantic][merge]") {
  fuzz(Kind::Merge3, fixture().part2, "merge3", 10);
}
