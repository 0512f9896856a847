// The environment light on the host: see environment.h; the sampling itself is
// environment_shared.h.
#include "photonflow/geometry/environment.h"

#include <cmath>
#include <cstdlib>

#include "photonflow/foundations/error.h"
#include "photonflow/geometry/environment_shared.h"
#include "photonflow/image/environment_image.h"

namespace pf {

namespace {

constexpr double kPiD = 3.14159265358979323846;

double lum(const float* c) { return 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]; }

}  // namespace

bool parse_environment_colour(const std::string& text, float rgb[3]) {
  size_t start = 0;
  for (int k = 0; k < 3; ++k) {
    const size_t end = k < 2 ? text.find(',', start) : text.size();
    if (end == std::string::npos) return false;
    const std::string part = text.substr(start, end - start);
    if (part.empty() || part.find(',') != std::string::npos) return false;
    char* stop = nullptr;
    rgb[k] = std::strtof(part.c_str(), &stop);
    if (stop != part.c_str() + part.size()) return false;
    start = end + 1;
  }
  return true;
}

void check_environment(const Environment& env, const std::string& file, const std::string& what) {
  const long long w = env.width, h = env.height;
  if (w <= 0 || h <= 0 || w != 2 * h || w > kMaxEnvironmentWidth)
    throw input_error(file, what + " is " + std::to_string(w) + " x " + std::to_string(h) +
                                " texels; an environment map is 2:1, at most " +
                                std::to_string(kMaxEnvironmentWidth) + " x " +
                                std::to_string(kMaxEnvironmentWidth / 2),
                      "give a latitude-longitude map of that size");
  if (env.texels.size() != size_t(w) * size_t(h) * 3)
    throw input_error(file, what + " holds " + std::to_string(env.texels.size()) +
                                " values, not 3 x " + std::to_string(w) + " x " + std::to_string(h),
                      "the file is damaged; rebake it with scene-bake");
  bool light = false;
  for (size_t i = 0; i < env.texels.size(); ++i) {
    const float t = env.texels[i];
    if (!(std::isfinite(t) && t >= 0.f)) {
      const size_t texel = i / 3;
      throw input_error(file, what + ": texel (" + std::to_string(texel % size_t(w)) + ", " +
                                  std::to_string(texel / size_t(w)) + ") has " +
                                  (std::isnan(t) ? "NaN" : std::isinf(t) ? "an infinite" : "a negative") +
                                  " channel (" + std::to_string(t) + "); radiance must be finite and >= 0",
                        "repair or clamp the map");
    }
  }
  for (size_t i = 0; i < env.texels.size() && !light; i += 3) light = lum(&env.texels[i]) > 0.0;
  if (!(std::isfinite(env.strength) && env.strength > 0.f))
    throw input_error(file, "the environment's strength (--environment-strength) must be finite "
                            "and > 0, got " + std::to_string(env.strength));
  if (!std::isfinite(env.rotation_deg))
    throw input_error(file, "the environment's rotation (--environment-rotate) must be a finite "
                            "angle in degrees");
  if (!light)
    throw input_error(file, what + " is black: the environment would send no light",
                      "give a map or colour with some light");
}

Environment load_environment(const std::string& text, float strength, float rotation_deg) {
  Environment env;
  env.strength = strength;
  env.rotation_deg = rotation_deg;
  float rgb[3];
  if (parse_environment_colour(text, rgb)) {
    env.width = kConstantEnvironmentWidth;
    env.height = kConstantEnvironmentWidth / 2;
    env.texels.resize(size_t(env.width) * size_t(env.height) * 3);
    for (size_t i = 0; i < env.texels.size(); ++i) env.texels[i] = rgb[i % 3];
    env.source = "constant " + text;
    check_environment(env, "", "--environment " + text);
    return env;
  }
  RadianceImage img = read_radiance_image(text, kMaxEnvironmentWidth);
  env.width = img.width;
  env.height = img.height;
  env.texels = std::move(img.rgb);
  env.source = text;
  check_environment(env, text, "the environment map");
  return env;
}

double environment_luminance_integral(const Environment& env) {
  if (!env.present()) return 0.0;
  const int w = env.width, h = env.height;
  double sum = 0.0;
  for (int j = 0; j < h; ++j) {
    // Solid angle of a texel of row j: Δφ · (cos θ_j − cos θ_{j+1}), θ = π·row/H.
    const double omega = (2.0 * kPiD / w) * (std::cos(kPiD * j / h) - std::cos(kPiD * (j + 1) / h));
    double row = 0.0;
    for (int i = 0; i < w; ++i) row += lum(&env.texels[3 * (size_t(j) * size_t(w) + size_t(i))]);
    sum += row * omega;
  }
  return sum * double(env.strength);
}

std::vector<float> pack_environment(const Environment& env, const Vec3& centre, float radius,
                                    int light, float p_pick) {
  const int w = env.present() ? env.width : 0, h = env.present() ? env.height : 0;
  std::vector<float> p(size_t(pf_env_packed_size(w, h)), 0.f);
  p[PF_ENV_WIDTH] = float(w);
  p[PF_ENV_HEIGHT] = float(h);
  p[PF_ENV_LIGHT] = float(light);
  p[PF_ENV_P_PICK] = p_pick;
  if (!w) return p;
  const double rot = double(env.rotation_deg) * kPiD / 180.0;
  p[PF_ENV_STRENGTH] = env.strength;
  p[PF_ENV_COS_ROT] = float(std::cos(rot));
  p[PF_ENV_SIN_ROT] = float(std::sin(rot));
  p[PF_ENV_CENTRE] = centre.x;
  p[PF_ENV_CENTRE + 1] = centre.y;
  p[PF_ENV_CENTRE + 2] = centre.z;
  p[PF_ENV_RADIUS] = radius;
  std::copy(env.texels.begin(), env.texels.end(), p.begin() + PF_ENV_HEADER);
  // f(i, j) = luminance · sin θ_j at the row's centre (pbrt-v3 InfiniteAreaLight's
  // construction); the conditional CDF of each row and the marginal CDF over the rows' sums
  // (pbrt-v3 Distribution1D: cdf[k] = Σ_{<k} f / Σ f; uniform over a row of zeros).
  float* func = &p[size_t(pf_env_func_at(w, h))];
  float* cond = &p[size_t(pf_env_cond_at(w, h))];
  float* marg = &p[size_t(pf_env_marg_at(w, h))];
  std::vector<double> row_sum(size_t(h), 0.0);
  double total = 0.0;
  for (int j = 0; j < h; ++j) {
    const double st = std::sin(kPiD * (j + 0.5) / h);
    double acc = 0.0;
    for (int i = 0; i < w; ++i) {
      func[size_t(j) * size_t(w) + size_t(i)] =
          float(lum(&env.texels[3 * (size_t(j) * size_t(w) + size_t(i))]) * st);
      acc += double(func[size_t(j) * size_t(w) + size_t(i)]);  // the stored values are the pdf
    }
    float* c = cond + size_t(j) * size_t(w + 1);
    double run = 0.0;
    c[0] = 0.f;
    for (int i = 0; i < w; ++i) {
      run += double(func[size_t(j) * size_t(w) + size_t(i)]);
      c[i + 1] = acc > 0.0 ? float(run / acc) : float(double(i + 1) / w);
    }
    c[w] = 1.f;
    row_sum[size_t(j)] = acc;
    total += acc;
  }
  double run = 0.0;
  marg[0] = 0.f;
  for (int j = 0; j < h; ++j) {
    run += row_sum[size_t(j)];
    marg[j + 1] = float(run / total);  // total > 0: check_environment requires some light
  }
  marg[h] = 1.f;
  p[PF_ENV_INV_FUNC] = float(double(w) * double(h) / total);
  return p;
}

}  // namespace pf
