// pass_sums.h — the partial result of probabilistic PPM (sppm.h, estimator pppm): per-pixel sums
// of the independent pass estimates L_i over a contiguous range of passes, the file that
// `render --estimator pppm --sums` writes, `merge` combines and `synthesize` turns into an image
// (docs/FORMATS.md, photonflow.pass-sums).
//
// The image of passes [a, b) is  L̄ = Σ_{i∈[a,b)} L_i / (b − a)  (Knaus & Zwicker 2011, eq. 8).
// Sums of disjoint ranges add: parts [0, 50) and [50, 100) merged give the sums of one run of
// 100 passes up to the order of the double additions (merge_pass_sums adds parts in pass order).
// Parts merge only when they come from the same scene and the same state options
// (`parameters`: seed, photons per pass, alpha, radius, depth limits, direct mode, sampler).
#pragma once
#include <cstdint>
#include <map>
#include <utility>
#include <string>
#include <vector>

#include "photonflow/stages/eye_pass.h"
#include "photonflow/image/image.h"
#include "photonflow/io/provenance.h"

namespace pf {

constexpr const char* kPassSumsFormat = "photonflow.pass-sums";

struct PassSums {
  int width = 0, height = 0;
  int first_pass = 0;            // index of the first pass summed (0-based)
  int passes = 0;                // passes summed: [first_pass, first_pass + passes)
  std::vector<double> sum;       // width × height × 3: Σ L_i, W/(sr m^2)
  uint64_t photons_emitted = 0;  // photons emitted by the passes summed
  float radius1 = 0.f;           // r_1, the radius of pass 0 (world units)
  float alpha = 0.f;             // α of the radius sequence
  DirectMode direct_mode = DirectMode::Photons;  // ShadowRays: L_d has direct light, photons not
  std::string scene_id;
  // The options every pass's estimate depends on, as render records them (state_parameters,
  // render_driver.h): parts merge only when these are equal.
  std::map<std::string, std::string> parameters;

  int end_pass() const { return first_pass + passes; }
};

// An empty range starting at `first_pass` for a width × height image.
PassSums make_pass_sums(int width, int height, int first_pass, float radius1, float alpha,
                        DirectMode mode, const std::string& scene_id,
                        const std::map<std::string, std::string>& parameters);

// The image L̄ = sum / passes (black before any pass); AOV "passes" holds the pass count.
Image synthesize(const PassSums& s);

// Atomic write with provenance (tool, parameters, inputs); `parameters` go into the provenance's
// parameters as "state.<name>", where load_pass_sums reads them back.
void save_pass_sums(const PassSums& s, const std::string& path, const Provenance& prov);
// Reads and checks a sums file: its datasets' shapes and types (h5io.h), then validate_pass_sums.
// InputError naming the file and what is wrong.
PassSums load_pass_sums(const std::string& path);
// The checks of a sums file's values, which save_pass_sums also applies to what it writes
// (merge writes through it; validate.h written_check): image size, pass range (first_pass >= 0,
// passes >= 0, first_pass + passes <= 2^31 − 1), photons_emitted a count of `passes` passes
// (validate.h kMaxPhotonsPerPass), one sum in [0, kMaxValue · passes] per pixel channel, radius1
// in [kMinRadius, kMaxRadius], alpha in (0, 1], the "state.*" parameters recorded. InputError
// naming `path`.
void validate_pass_sums(const PassSums& s, const std::string& path);
// The provenance group of a sums file (the render driver checks a checkpoint's with it).
Provenance load_pass_sums_provenance(const std::string& path);

// Merges parts in pass order, one at a time: add() refuses (InputError naming the part) a part
// without passes, one that differs from the first in scene, image size, radius sequence or state
// options, and one whose range overlaps the merge so far or leaves a gap after it.
class PassSumsMerger {
 public:
  void add(const PassSums& part, const std::string& path);
  // The merged range; with want_first >= 0 it must be exactly [want_first, want_end) (InputError).
  PassSums finish(int want_first = -1, int want_end = -1) const;

 private:
  PassSums out_;
  std::string first_path_, last_path_;
  size_t parts_ = 0;
};

// Merges parts (paths[i] is the file of parts[i], for messages) in pass order (PassSumsMerger).
PassSums merge_pass_sums(const std::vector<PassSums>& parts, const std::vector<std::string>& paths,
                         int want_first = -1, int want_end = -1);
// The same over files, holding one part in memory at a time (the merge of many parts).
PassSums merge_pass_sum_files(const std::vector<std::string>& paths, int want_first = -1,
                              int want_end = -1);

// "A:B" → {A, B}, the passes A … B−1 (0 <= A < B <= 2^31−1); InputError naming --range otherwise.
std::pair<int, int> parse_pass_range(const std::string& text);

}  // namespace pf
