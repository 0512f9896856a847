// chi2.h — chi-square goodness-of-fit of a direction sampler against its pdf on the sphere, in
// the manner of pbrt-v3's and Mitsuba's BSDF tests (src/tests/bsdfs.cpp, mitsuba chi2.py): bin
// sampled directions on a (θ, φ) grid, integrate the pdf over each bin numerically (adaptive
// Gauss-Legendre in θ and φ, with the sin θ Jacobian), pool bins whose expected count is below 5, and
// compute the p-value of Pearson's statistic. Samples that fail (a lobe's lost energy) are not
// binned; the pdf then integrates to less than 1 by the same amount, so expected and observed
// still agree bin by bin.
#pragma once
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <random>
#include <sstream>
#include <string>
#include <vector>

namespace pf::test {

// Regularized upper incomplete gamma Q(a, x) (Numerical Recipes gammq: series below a + 1,
// Lentz continued fraction above).
inline double gamma_q(double a, double x) {
  if (x <= 0.0) return 1.0;
  const double gln = std::lgamma(a);
  if (x < a + 1.0) {
    double ap = a, sum = 1.0 / a, del = sum;
    for (int n = 0; n < 100000; ++n) {
      ap += 1.0;
      del *= x / ap;
      sum += del;
      if (std::fabs(del) < std::fabs(sum) * 1e-15) break;
    }
    return 1.0 - sum * std::exp(-x + a * std::log(x) - gln);
  }
  double b = x + 1.0 - a, c = 1.0 / 1e-300, d = 1.0 / b, h = d;
  for (int i = 1; i < 100000; ++i) {
    const double an = -i * (i - a);
    b += 2.0;
    d = an * d + b;
    if (std::fabs(d) < 1e-300) d = 1e-300;
    c = b + an / c;
    if (std::fabs(c) < 1e-300) c = 1e-300;
    d = 1.0 / d;
    const double del = d * c;
    h *= del;
    if (std::fabs(del - 1.0) < 1e-15) break;
  }
  return std::exp(-x + a * std::log(x) - gln) * h;
}

struct SphereGrid {
  int nt = 24, np = 48;  // bins in θ ∈ [0, π] and φ ∈ [0, 2π)
  int bin(const float* w) const {
    const double z = std::max(-1.0, std::min(1.0, double(w[2])));
    double phi = std::atan2(double(w[1]), double(w[0]));
    if (phi < 0) phi += 2 * M_PI;
    int it = std::min(nt - 1, int(std::acos(z) / M_PI * nt));
    int ip = std::min(np - 1, int(phi / (2 * M_PI) * np));
    return it * np + ip;
  }
};

// 8-point Gauss-Legendre over the cell [t0, t1] × [p0, p1] of (θ, φ), with the sin θ Jacobian.
// Its nodes are interior, so a pdf that jumps on a cell edge (the horizon at θ = π/2) is never
// evaluated on the wrong side of the jump, as an endpoint rule (Simpson) would.
inline double gauss_cell(const std::function<double(const float*)>& pdf, double t0, double t1,
                         double p0, double p1) {
  static const double x[8] = {-0.9602898564975363, -0.7966664774136267, -0.5255324099163290,
                              -0.1834346424956498, 0.1834346424956498,  0.5255324099163290,
                              0.7966664774136267,  0.9602898564975363};
  static const double w[8] = {0.1012285362903763, 0.2223810344533745, 0.3137066458778873,
                              0.3626837833783620, 0.3626837833783620, 0.3137066458778873,
                              0.2223810344533745, 0.1012285362903763};
  const double ht = 0.5 * (t1 - t0), hp = 0.5 * (p1 - p0), ct0 = t0 + ht, cp0 = p0 + hp;
  double s = 0;
  for (int a = 0; a < 8; ++a) {
    const double th = ct0 + x[a] * ht;
    const double st = std::sin(th), ct = std::cos(th);
    for (int b = 0; b < 8; ++b) {
      const double ph = cp0 + x[b] * hp;
      const float d[3] = {float(st * std::cos(ph)), float(st * std::sin(ph)), float(ct)};
      s += w[a] * w[b] * pdf(d) * st;
    }
  }
  return s * ht * hp;
}

// Adaptive: a cell is split in four until the four quarters agree with the whole to 1e-9 in
// probability (or 8 levels deep). The pdfs have jumps inside cells (the support boundary of the
// transmission lobe where its generalized half vector reaches the horizon), which a fixed rule
// integrates with an error the chi-square test would see.
inline double adaptive_cell(const std::function<double(const float*)>& pdf, double t0, double t1,
                            double p0, double p1, double whole, int depth) {
  const double tm = 0.5 * (t0 + t1), pm = 0.5 * (p0 + p1);
  const double q[4] = {gauss_cell(pdf, t0, tm, p0, pm), gauss_cell(pdf, tm, t1, p0, pm),
                       gauss_cell(pdf, t0, tm, pm, p1), gauss_cell(pdf, tm, t1, pm, p1)};
  const double sum = q[0] + q[1] + q[2] + q[3];
  if (depth >= 8 || std::fabs(sum - whole) < 1e-9) return sum;
  return adaptive_cell(pdf, t0, tm, p0, pm, q[0], depth + 1) +
         adaptive_cell(pdf, tm, t1, p0, pm, q[1], depth + 1) +
         adaptive_cell(pdf, t0, tm, pm, p1, q[2], depth + 1) +
         adaptive_cell(pdf, tm, t1, pm, p1, q[3], depth + 1);
}

// ∫ pdf over every bin of the grid.
inline std::vector<double> integrate_bins(const SphereGrid& g,
                                          const std::function<double(const float*)>& pdf) {
  std::vector<double> out(size_t(g.nt) * g.np, 0.0);
  const double dt = M_PI / g.nt, dp = 2 * M_PI / g.np;
  for (int it = 0; it < g.nt; ++it)
    for (int ip = 0; ip < g.np; ++ip) {
      const double t0 = it * dt, t1 = t0 + dt, p0 = ip * dp, p1 = p0 + dp;
      out[size_t(it) * g.np + ip] =
          adaptive_cell(pdf, t0, t1, p0, p1, gauss_cell(pdf, t0, t1, p0, p1), 0);
    }
  return out;
}

struct Chi2Result {
  double p = 0, chi2 = 0, pdf_integral = 0, success = 0;
  int dof = 0;
  std::string detail;
};

// sample(u1, u2, u3, wi) → false when the sample is lost; pdf(wi) its density (solid angle).
inline Chi2Result chi2_test(const std::function<bool(float, float, float, float*)>& sample,
                            const std::function<double(const float*)>& pdf, int n,
                            uint32_t seed, SphereGrid g = {}) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> uni(0.f, 1.f);
  std::vector<double> obs(size_t(g.nt) * g.np, 0.0);
  int ok = 0;
  for (int s = 0; s < n; ++s) {
    float w[3];
    const float u1 = uni(rng), u2 = uni(rng), u3 = uni(rng);
    if (!sample(u1, u2, u3, w)) continue;
    ++ok;
    obs[g.bin(w)] += 1;
  }
  std::vector<double> exp = integrate_bins(g, pdf);
  Chi2Result r;
  for (double& e : exp) {
    r.pdf_integral += e;
    e *= n;
  }
  r.success = double(ok) / n;
  std::vector<size_t> idx(exp.size());
  for (size_t i = 0; i < idx.size(); ++i) idx[i] = i;
  std::sort(idx.begin(), idx.end(), [&](size_t a, size_t b) { return exp[a] < exp[b]; });
  double pool_e = 0, pool_o = 0;
  int bins = 0;
  struct Worst { double dev; size_t i; };
  std::vector<Worst> worst;
  for (size_t j : idx) {
    if (exp[j] < 5.0) {
      pool_e += exp[j];
      pool_o += obs[j];
      if (pool_e >= 5.0) {
        r.chi2 += (pool_o - pool_e) * (pool_o - pool_e) / pool_e;
        ++bins;
        pool_e = pool_o = 0;
      }
      continue;
    }
    const double d = (obs[j] - exp[j]) * (obs[j] - exp[j]) / exp[j];
    worst.push_back({d, j});
    r.chi2 += d;
    ++bins;
  }
  if (pool_e > 0) {
    r.chi2 += (pool_o - pool_e) * (pool_o - pool_e) / pool_e;
    ++bins;
  } else if (pool_o > 0) {
    r.chi2 = INFINITY;  // samples where the pdf integrates to nothing
  }
  r.dof = std::max(1, bins - 1);
  r.p = std::isfinite(r.chi2) ? gamma_q(0.5 * r.dof, 0.5 * r.chi2) : 0.0;
  std::sort(worst.begin(), worst.end(), [](const Worst& a, const Worst& b) { return a.dev > b.dev; });
  std::ostringstream s;
  s << "chi2 " << r.chi2 << " dof " << r.dof << " p " << r.p << "; ∫pdf " << r.pdf_integral
    << ", sampled fraction " << r.success << "; worst bins (θ-bin, φ-bin: observed / expected):";
  for (size_t k = 0; k < std::min<size_t>(4, worst.size()); ++k) {
    const size_t j = worst[k].i;
    s << " (" << j / g.np << "," << j % g.np << ": " << obs[j] << "/" << exp[j] << ")";
  }
  r.detail = s.str();
  return r;
}

}  // namespace pf::test
