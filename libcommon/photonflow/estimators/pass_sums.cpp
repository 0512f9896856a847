// Pass sums of probabilistic PPM: see pass_sums.h.
#include "photonflow/estimators/pass_sums.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "photonflow/geometry/camera.h"
#include "photonflow/foundations/error.h"
#include "photonflow/io/h5io.h"
#include "photonflow/stages/photon_pass.h"
#include "photonflow/io/validate.h"

namespace pf {

namespace {
constexpr int kPassSumsVersion = 1;
constexpr const char* kStatePrefix = "state.";
const char* const kHint = "the file is damaged; remake it with render --estimator pppm --sums";

std::string range_text(int64_t first, int64_t end) {
  return "[" + std::to_string(first) + ", " + std::to_string(end) + ")";
}
}  // namespace

PassSums make_pass_sums(int width, int height, int first_pass, float radius1, float alpha,
                        DirectMode mode, const std::string& scene_id,
                        const std::map<std::string, std::string>& parameters) {
  PassSums s;
  s.width = width;
  s.height = height;
  s.first_pass = first_pass;
  s.sum.assign(size_t(width) * size_t(height) * 3, 0.0);
  s.radius1 = radius1;
  s.alpha = alpha;
  s.direct_mode = mode;
  s.scene_id = scene_id;
  s.parameters = parameters;
  return s;
}

Image synthesize(const PassSums& s) {
  Image img(s.width, s.height);
  if (s.passes > 0) {
    const double inv = 1.0 / double(s.passes);  // KZ11 eq. 8: the mean of the pass estimates
    for (size_t j = 0; j < img.rgb.size(); ++j) img.rgb[j] = float(s.sum[j] * inv);
  }
  std::vector<float>& passes = img.layer("passes");
  std::fill(passes.begin(), passes.end(), float(s.passes));
  return img;
}

void validate_pass_sums(const PassSums& s, const std::string& path) {
  const Validator v(path, kHint);
  v.int_in_range("attribute width", s.width, 1, kMaxImageSide);
  v.int_in_range("attribute height", s.height, 1, kMaxImageSide);
  v.int_in_range("attribute first_pass", s.first_pass, 0, kMaxPassEnd);
  v.int_in_range("attribute passes", s.passes, 0, kMaxPassEnd);
  if (int64_t(s.first_pass) + int64_t(s.passes) > kMaxPassEnd)
    v.fail("its passes " + range_text(s.first_pass, int64_t(s.first_pass) + s.passes) +
           " end past 2^31-1");
  v.photons_emitted("attribute photons_emitted", s.photons_emitted, s.passes);
  v.in_range("attribute radius1", s.radius1, double(kMinRadius), double(kMaxRadius));
  // α of KZ11 eq. 19 in (0, 1]: the smallest float above 0 is the lower bound.
  v.in_range("attribute alpha", s.alpha, double(std::numeric_limits<float>::denorm_min()), 1.0);
  if (s.direct_mode != DirectMode::Photons && s.direct_mode != DirectMode::ShadowRays)
    v.fail("attribute direct_mode is no direct mode");
  if (s.sum.size() != size_t(s.width) * size_t(s.height) * 3)
    v.fail("dataset /sum does not hold width × height × 3 values");
  // Radiance is never negative, and each pass's estimate stays within the loaders' value bound
  // (validate.h kMaxValue), so a sum lies in [0, kMaxValue · passes].
  const double max_sum = double(kMaxValue) * double(std::max(s.passes, 1));
  for (size_t j = 0; j < s.sum.size(); ++j)
    if (!(s.sum[j] >= 0.0 && s.sum[j] <= max_sum))
      v.fail("dataset /sum[" + std::to_string(j / 3) + "] (pixel " +
             std::to_string(j / 3 % size_t(s.width)) + ", " +
             std::to_string(j / 3 / size_t(s.width)) + ") = " + value_text(s.sum[j]) +
             " is not a sum of radiances");
  if (s.passes == 0 && std::any_of(s.sum.begin(), s.sum.end(), [](double x) { return x != 0; }))
    v.fail("holds sums but no pass");
  if (s.parameters.empty()) v.fail("records none of the options its passes were made with");
}

void save_pass_sums(const PassSums& s, const std::string& path, const Provenance& prov) {
  written_check([&] { validate_pass_sums(s, path); });
  h5::Writer w(path, kPassSumsFormat, kPassSumsVersion);
  w.attr("/", "scene_id", s.scene_id);
  w.write("/sum", s.sum, {size_t(s.height), size_t(s.width), 3});
  w.describe("/sum", "W/(sr m^2) times passes",
             "per-pixel sum over the passes of the probabilistic PPM estimates L_i (Knaus & "
             "Zwicker 2011); the image is sum / passes");
  w.attr("/", "width", int64_t(s.width));
  w.attr("/", "height", int64_t(s.height));
  w.attr("/", "first_pass", int64_t(s.first_pass));
  w.attr("/", "passes", int64_t(s.passes));
  w.attr("/", "photons_emitted", int64_t(s.photons_emitted));
  w.attr("/", "radius1", double(s.radius1));
  w.attr("/", "alpha", double(s.alpha));
  w.attr("/", "direct_mode", direct_mode_name(s.direct_mode));
  Provenance p = prov;
  for (const auto& [name, value] : s.parameters) p.parameters[kStatePrefix + name] = value;
  write_provenance(w, p);
  w.commit();
}

Provenance load_pass_sums_provenance(const std::string& path) {
  return read_provenance(h5::Reader(path, kPassSumsFormat, kPassSumsVersion));
}

PassSums load_pass_sums(const std::string& path) {
  h5::Reader r(path, kPassSumsFormat, kPassSumsVersion);
  const Validator v(path, kHint);
  PassSums s;
  s.scene_id = r.scene_id();
  // Integers are range-checked as int64 before they become ints; then validate_pass_sums.
  auto int_in = [&](const char* name, int64_t lo, int64_t hi) {
    const int64_t x = r.attr_int("/", name);
    v.int_in_range(std::string("attribute ") + name, x, lo, hi);
    return x;
  };
  s.width = int(int_in("width", 1, kMaxImageSide));
  s.height = int(int_in("height", 1, kMaxImageSide));
  s.first_pass = int(int_in("first_pass", 0, kMaxPassEnd));
  s.passes = int(int_in("passes", 0, kMaxPassEnd));
  s.photons_emitted = uint64_t(int_in("photons_emitted", 0, std::numeric_limits<int64_t>::max()));
  // Kept as floats: refused when narrowing takes them out of range (1e-300 → 0).
  s.radius1 = v.to_float("attribute radius1", r.attr_double("/", "radius1"), double(kMinRadius),
                         double(kMaxRadius));
  s.alpha = v.to_float("attribute alpha", r.attr_double("/", "alpha"),
                       double(std::numeric_limits<float>::denorm_min()), 1.0);
  const std::string direct = r.attr_string("/", "direct_mode");
  if (direct != "photons" && direct != "shadow-rays")
    v.fail("unknown direct mode '" + direct + "'");
  s.direct_mode = direct == "photons" ? DirectMode::Photons : DirectMode::ShadowRays;
  s.sum = r.read<double>("/sum", {size_t(s.height), size_t(s.width), 3});
  const Provenance prov = read_provenance(r);
  for (const auto& [name, value] : prov.parameters)
    if (name.rfind(kStatePrefix, 0) == 0) s.parameters[name.substr(6)] = value;
  validate_pass_sums(s, path);
  return s;
}

namespace {

// "" when `p` may join a merge whose first part is `ref`, else what differs.
std::string incompatible(const PassSums& p, const PassSums& ref, const std::string& ref_path) {
  if (p.scene_id != ref.scene_id) return "was rendered from another scene than " + ref_path;
  if (p.width != ref.width || p.height != ref.height)
    return "is " + std::to_string(p.width) + "x" + std::to_string(p.height) + ", " + ref_path +
           " " + std::to_string(ref.width) + "x" + std::to_string(ref.height);
  if (p.radius1 != ref.radius1 || p.alpha != ref.alpha || p.direct_mode != ref.direct_mode)
    return "has another radius sequence or direct mode than " + ref_path;
  for (const auto& [key, value] : ref.parameters) {
    const auto it = p.parameters.find(key);
    const std::string theirs = it == p.parameters.end() ? "(none)" : it->second;
    if (theirs != value)
      return "was made with " + key + " " + theirs + ", " + ref_path + " with " + value;
  }
  if (p.parameters.size() != ref.parameters.size())
    return "records other options than " + ref_path;
  return "";
}

}  // namespace

void PassSumsMerger::add(const PassSums& part, const std::string& path) {
  if (part.passes == 0) throw input_error(path, "holds no pass", "leave it out of the merge");
  if (parts_ == 0) {
    out_ = part;
    first_path_ = last_path_ = path;
    parts_ = 1;
    return;
  }
  const std::string why = incompatible(part, out_, first_path_);
  if (!why.empty()) throw input_error(path, why, "merge parts of one run (same seed and options)");
  if (part.first_pass < out_.end_pass())
    throw input_error(path, "passes " + range_text(part.first_pass, part.end_pass()) +
                                " overlap those of " + last_path_ + " (the merge so far covers " +
                                range_text(out_.first_pass, out_.end_pass()) + ")",
                      "merge each pass once");
  if (part.first_pass > out_.end_pass())
    throw input_error(path, "starts at pass " + std::to_string(part.first_pass) + ", but passes " +
                                range_text(out_.end_pass(), part.first_pass) + " are in no part",
                      "render the missing passes first");
  // Both parts passed validate_pass_sums: their ranges end at most at 2^31 − 1 and each holds at
  // most passes × kMaxPhotonsPerPass photons, so neither sum below can wrap.
  for (size_t j = 0; j < out_.sum.size(); ++j) out_.sum[j] += part.sum[j];
  out_.passes += part.passes;
  out_.photons_emitted += part.photons_emitted;
  last_path_ = path;
  ++parts_;
}

PassSums PassSumsMerger::finish(int want_first, int want_end) const {
  if (parts_ == 0) throw input_error("", "no parts to merge");
  if (want_first >= 0 && (out_.first_pass != want_first || out_.end_pass() != want_end))
    throw input_error("", "the parts cover passes " + range_text(out_.first_pass, out_.end_pass()) +
                              ", not " + range_text(want_first, want_end),
                      out_.first_pass > want_first || out_.end_pass() < want_end
                          ? "render the missing passes first"
                          : "leave out the parts beyond the range");
  return out_;
}

PassSums merge_pass_sums(const std::vector<PassSums>& parts, const std::vector<std::string>& paths,
                         int want_first, int want_end) {
  std::vector<size_t> order(parts.size());
  std::iota(order.begin(), order.end(), size_t(0));
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    return parts[a].first_pass < parts[b].first_pass;
  });
  PassSumsMerger m;
  for (size_t k : order) m.add(parts[k], paths[k]);
  return m.finish(want_first, want_end);
}

PassSums merge_pass_sum_files(const std::vector<std::string>& paths, int want_first,
                              int want_end) {
  // Pass order from the files' first_pass attributes; then one part in memory at a time.
  std::vector<std::pair<int64_t, size_t>> order;
  for (size_t i = 0; i < paths.size(); ++i) {
    const h5::Reader r(paths[i], kPassSumsFormat, kPassSumsVersion);
    order.emplace_back(r.attr_int("/", "first_pass"), i);
  }
  std::stable_sort(order.begin(), order.end());
  PassSumsMerger m;
  for (const auto& [first, i] : order) m.add(load_pass_sums(paths[i]), paths[i]);
  return m.finish(want_first, want_end);
}

std::pair<int, int> parse_pass_range(const std::string& text) {
  const size_t colon = text.find(':');
  auto number = [&](const std::string& t) {
    size_t used = 0;
    long v = -1;
    try {
      v = std::stol(t, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    return used == t.size() && !t.empty() && v >= 0 && v <= std::numeric_limits<int32_t>::max()
               ? int(v)
               : -1;
  };
  const int a = colon == std::string::npos ? -1 : number(text.substr(0, colon));
  const int b = colon == std::string::npos ? -1 : number(text.substr(colon + 1));
  if (a < 0 || b <= a)
    throw input_error("", "--range takes A:B, passes A to B-1 (0 <= A < B), got '" + text + "'");
  return {a, b};
}

}  // namespace pf
