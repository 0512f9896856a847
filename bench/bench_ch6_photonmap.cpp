// bench_ch6_photonmap — the thesis's photon-map experiments (ch. 6.5, Tables 6.2–6.5, Fig. 6.8)
// on this machine, with the libraries of bench/knn_indices.h (ANN kd and bd, FLANN randomized kd,
// FLANN KDTreeSingleIndex, nanoflann). Prints markdown tables (docs/results/ch6-photonmap.md,
// pipelines/ch6.mk).
//
//   bench_ch6_photonmap [--dae data/cornell-box.dae] [--sizes 50000,…,500000]
//                       [--ks 50,100,500,1000,2000,3000,4000,5000] [--nearest 5000]
//                       [--eps 0,1,2,5,10] [--queries 200] [--runs 3] [--image 160x160]
//                       [--dat DIR] [--image-dir DIR]
//
// Photons (the thesis: "real photon mapping data"): one photon pass (photon_pass.h) on the
// diffuse Cornell box, with as many photons emitted as it takes to store the largest map size in
// the global map of classic photon mapping with direct light from shadow rays, i.e. the photons
// that arrived after at least one diffuse bounce (no PF_PHOTON_DIRECT; the scene has no caustic
// paths). A map of size N is the first N of them in emission order.
//
// Queries: positions of eye-pass hitpoints (the points where eq. 3.10 is evaluated), every
// (hitpoints / queries)-th one; the agreement checks use another --check-queries of them. A query
// time is the mean over the queries of one single-threaded call (the thesis measured one query
// at a time too; ANN's search is not thread-safe), a build time that of one build; each is the
// median of --runs runs, taken round robin over the libraries (see round_robin). The ratio
// tables give, per library, the median over runs of its time ÷ pf::PhotonMap's in the same run.
//
//   Table 6.2  build time vs map size.
//   Table 6.3  kNN query time vs k, map of the largest size.
//   Table 6.4  kNN query time vs map size at k = --nearest (5,000: the thesis's photon-mapping
//              setting).
//   Agreement  on --check-queries queries at the smallest k and at --nearest, every library's
//              neighbour set against brute force (distances in double): identical sets, photons
//              swapped at the k-th distance (equal within 1e-5, float rounding), and photons
//              outside the exact set (an error for the libraries asserted exact: exit code 1;
//              reported for FLANN's randomized kd-trees, see knn_indices.h).
//   Table 6.5  kNN query time vs ε at k = --nearest, and the recall (share of the exact k
//              nearest returned) on the check queries.
//   Fig. 6.8   the classic estimate (illuminate.h classic_estimate, eq. 3.10, k = --nearest, FLANN
//              single kd via pf::PhotonMap with its eps) rendered at --image for each ε, indirect
//              light only (the eye pass's emitted and direct layers left out, as in the thesis's
//              experiment), and its RMSE against ε = 0 over all pixels and channels; wall time of
//              classic_estimate (one run each) on --threads threads, by default one like every
//              other time here: with two threads on a shared machine the render times varied by
//              a factor of two from one ε to the next, hiding the effect of ε.
//
// --dat DIR writes the tables as tab-separated files for bench/ch6.gp; --image-dir DIR writes the
// ε images as PNG (one exposure for all, set from the ε = 0 image).

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cxxopts.hpp>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "photonflow/stages/eye_pass.h"
#include "photonflow/stages/illuminate.h"
#include "photonflow/image/image.h"
#include "photonflow/stages/photon_pass.h"
#include "photonflow/stages/synthesize.h"
#include "bench_common.h"
#include "ch6_common.h"
#include "knn_indices.h"

namespace {

using pf::bench::KnnIndex;
using pf::bench::KnnLibrary;
using pf::bench::median;
using pf::bench::now;
using pf::bench::parse_list;
using Point = std::array<float, 3>;

std::string fmt(double v, const char* f = "%.3g") {
  char buf[32];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

// The photons of the global map (after at least one diffuse bounce) of one pass that stores at
// least `want` of them: the pass is traced again with more photons until it does.
pf::PhotonPassResult trace_global(const pf::Scene& scene, size_t want, uint32_t seed,
                                  int threads, std::vector<pf_photon>& global) {
  pf::PhotonPassOptions po;
  po.photons = uint32_t(want);
  po.seed = seed;
  po.threads = threads;
  for (;;) {
    pf::PhotonPassResult pass = pf::trace_photons(scene, 0, po);
    global.clear();
    for (const pf_photon& p : pass.photons)
      if (!(p.flags & (PF_PHOTON_DIRECT | PF_PHOTON_CAUSTIC))) global.push_back(p);
    if (global.size() >= want) return pass;
    if (global.empty()) throw std::runtime_error("the scene stores no indirect photons");
    po.photons = uint32_t(std::ceil(1.02 * double(po.photons) * double(want) / global.size()));
  }
}

// Mean time of one query in ms over the query points, after one untimed warm-up query.
double query_ms(KnnIndex& index, const std::vector<Point>& qs, int k, float eps) {
  std::vector<uint32_t> out;
  index.knn(qs[0].data(), k, eps, out);
  const double t0 = now();
  for (const Point& q : qs) index.knn(q.data(), k, eps, out);
  return (now() - t0) * 1e3 / double(qs.size());
}

// Times of every library in every run: [library][run].
using RunTimes = std::vector<std::vector<double>>;

// Measures time_one(library) for every library, `runs` times, round robin (run 1 of every
// library, then run 2 of every library, ...): a change of load on the shared machine then falls
// on all libraries of a run alike, and the ratios between libraries within a run stay meaningful.
RunTimes round_robin(size_t libraries, int runs, const std::function<double(size_t)>& time_one) {
  RunTimes t(libraries);
  for (int r = 0; r < runs; ++r)
    for (size_t l = 0; l < libraries; ++l) t[l].push_back(time_one(l));
  return t;
}

double dist2(const pf_photon& p, const Point& q) {
  double s = 0;
  for (int c = 0; c < 3; ++c) s += (double(p.position[c]) - q[c]) * (double(p.position[c]) - q[c]);
  return s;
}

// The exact k nearest photons of q, sorted by index, by brute force in double (ties by index);
// dk = squared distance of the k-th.
std::vector<uint32_t> brute_knn(const std::vector<pf_photon>& photons, const Point& q, int k,
                                double& dk) {
  std::vector<std::pair<double, uint32_t>> d(photons.size());
  for (size_t i = 0; i < photons.size(); ++i) d[i] = {dist2(photons[i], q), uint32_t(i)};
  const size_t n = std::min(size_t(k), d.size());
  std::nth_element(d.begin(), d.begin() + long(n) - 1, d.end());
  dk = d[n - 1].first;
  std::vector<uint32_t> out(n);
  for (size_t i = 0; i < n; ++i) out[i] = d[i].second;
  std::sort(out.begin(), out.end());
  return out;
}

// One library's result sets against the exact ones.
struct Agreement {
  size_t queries = 0;
  size_t identical = 0;  // the same set
  size_t swapped = 0;    // photons not in the exact set but at its k-th distance (within 1e-5)
  size_t outside = 0;    // photons not in the exact set and farther (or a short result)
  double recall = 0;     // sum over queries of |returned ∩ exact| / |exact|
};

void compare(const std::vector<pf_photon>& photons, const Point& q,
             const std::vector<uint32_t>& exact, double dk, std::vector<uint32_t> got,
             Agreement& a) {
  std::sort(got.begin(), got.end());
  std::vector<uint32_t> extra;
  std::set_difference(got.begin(), got.end(), exact.begin(), exact.end(),
                      std::back_inserter(extra));
  a.queries += 1;
  a.recall += double(got.size() - extra.size()) / double(exact.size());
  if (extra.empty() && got.size() == exact.size()) {
    a.identical += 1;
    return;
  }
  for (uint32_t i : extra) (dist2(photons[i], q) <= dk * (1 + 1e-5) ? a.swapped : a.outside) += 1;
  a.outside += got.size() < exact.size() ? exact.size() - got.size() : 0;
}

// The indirect-light image of a hitpoint state (eq. 3.19 without the eye pass's layers).
pf::Image indirect_image(pf::HitpointSet h) {
  std::fill(h.emitted.begin(), h.emitted.end(), 0.f);
  std::fill(h.direct.begin(), h.direct.end(), 0.f);
  return pf::synthesize(h);
}

double rmse(const pf::Image& a, const pf::Image& b) {
  double s = 0;
  for (size_t i = 0; i < a.rgb.size(); ++i) s += (double(a.rgb[i]) - b.rgb[i]) * (a.rgb[i] - b.rgb[i]);
  return std::sqrt(s / double(a.rgb.size()));
}

double mean(const std::vector<float>& v) {
  double s = 0;
  for (float x : v) s += x;
  return v.empty() ? 0 : s / double(v.size());
}

// A markdown table with one row per library and one column per parameter value, and the same
// numbers tab-separated (first column the parameter, one column per library) for gnuplot.
struct Table {
  std::string title, param;
  std::vector<double> values;    // the parameter of each column
  std::vector<RunTimes> columns;  // the run times of each column
  // Medians of the run times; with ref >= 0 instead the median over runs of each library's time
  // divided by library ref's time in the same run.
  double cell(size_t lib, size_t col, int ref = -1) const {
    const std::vector<double>& t = columns[col][lib];
    if (ref < 0) return median(t);
    std::vector<double> ratio;
    for (size_t r = 0; r < t.size(); ++r) ratio.push_back(t[r] / columns[col][size_t(ref)][r]);
    return median(ratio);
  }
  void print(const std::vector<KnnLibrary>& libs, std::ostream& md, int ref = -1) const {
    md << "\n## " << title;
    if (ref >= 0) md << " — ratio to " << libs[size_t(ref)].name << " (same run, median)";
    md << "\n\n| library |";
    for (double v : values) md << " " << param << " = " << fmt(v, "%.10g") << " |";
    md << "\n|---|";
    for (size_t i = 0; i < values.size(); ++i) md << "---:|";
    md << "\n";
    for (size_t l = 0; l < libs.size(); ++l) {
      md << "| " << libs[l].name << " |";
      for (size_t i = 0; i < values.size(); ++i)
        md << " " << fmt(cell(l, i, ref), ref >= 0 ? "%.2f" : "%.3g") << " |";
      md << "\n";
    }
  }
  void write_dat(const std::vector<KnnLibrary>& libs, const std::string& path) const {
    std::ofstream f(path);
    f << '"' << param << '"';
    for (const KnnLibrary& l : libs) f << "\t\"" << l.name << '"';
    f << "\n";
    for (size_t i = 0; i < values.size(); ++i) {
      f << values[i];
      for (size_t l = 0; l < libs.size(); ++l) f << "\t" << cell(l, i);
      f << "\n";
    }
  }
};

}  // namespace

int main(int argc, char** argv) {
  cxxopts::Options opts("bench_ch6_photonmap",
                        "Thesis Tables 6.2-6.5: photon-map build and kNN query times of ANN, "
                        "FLANN and nanoflann, and image error of approximate search.");
  // clang-format off
  opts.add_options()
    ("dae", "scene file", cxxopts::value<std::string>()->default_value("data/cornell-box.dae"))
    ("sizes", "map sizes of Tables 6.2 and 6.4 (photons)",
     cxxopts::value<std::string>()->default_value("50000,100000,200000,300000,400000,500000"))
    ("ks", "k of Table 6.3", cxxopts::value<std::string>()->default_value(
     "50,100,500,1000,2000,3000,4000,5000"))
    ("nearest", "k of Tables 6.4, 6.5 and of the rendered estimate",
     cxxopts::value<int>()->default_value("5000"))
    ("eps", "approximation epsilons of Table 6.5 (0, the reference, is always included)",
     cxxopts::value<std::string>()->default_value("0,1,2,5,10"))
    ("queries", "query points per timing", cxxopts::value<size_t>()->default_value("200"))
    ("check-queries", "query points of the agreement checks and recall",
     cxxopts::value<size_t>()->default_value("20"))
    ("runs", "runs per measurement (median)", cxxopts::value<int>()->default_value("3"))
    ("image", "size of the rendered estimate (WxH; the queries are its hitpoints)",
     cxxopts::value<std::string>()->default_value("160x160"))
    ("threads", "threads of the photon pass, the eye pass and the rendered estimate (0 = all)",
     cxxopts::value<int>()->default_value("1"))
    ("seed", "photon seed", cxxopts::value<uint32_t>()->default_value("1"))
    ("dat", "directory for the tab-separated tables (gnuplot)",
     cxxopts::value<std::string>()->default_value(""))
    ("image-dir", "directory for the PNG images of the estimate per epsilon",
     cxxopts::value<std::string>()->default_value(""))
    ("h,help", "print this help");
  // clang-format on
  const auto args = opts.parse(argc, argv);
  if (args.count("help")) {
    std::cout << opts.help() << "\n";
    return 0;
  }
  std::vector<size_t> sizes = parse_list<size_t>(args["sizes"].as<std::string>());
  std::sort(sizes.begin(), sizes.end());
  const std::vector<int> ks = parse_list<int>(args["ks"].as<std::string>());
  const int k_main = args["nearest"].as<int>();
  // ε = 0 is the reference of the image error; the ε tables and images share this sorted list.
  std::vector<float> eps = parse_list<float>(args["eps"].as<std::string>());
  if (std::find(eps.begin(), eps.end(), 0.f) == eps.end()) eps.push_back(0.f);
  std::sort(eps.begin(), eps.end());
  const int runs = std::max(1, args["runs"].as<int>());
  const int threads = args["threads"].as<int>();
  const std::string dat = args["dat"].as<std::string>();
  const std::string image_dir = args["image-dir"].as<std::string>();
  if (sizes.empty() || ks.empty() || k_main <= 0) {
    std::cerr << "bench_ch6_photonmap: --sizes and --ks must not be empty, --nearest positive\n";
    return 2;
  }
  const std::vector<KnnLibrary> libs = pf::bench::knn_libraries();
  const double load_start = pf::bench::load_average();

  // Scene, eye pass (hitpoints: the query points and the rendered estimate), photons.
  const pf::Scene scene =
      pf::bench::make_scene("", args["dae"].as<std::string>(),
                            pf::bench::parse_size(args["image"].as<std::string>()));
  pf::EyePassOptions eye;
  eye.direct = pf::DirectMode::ShadowRays;  // the global map then holds indirect photons only
  eye.shadow_samples = 1;                   // the direct layer is not used here
  eye.threads = threads;
  const pf::HitpointSet fresh =
      pf::make_hitpoint_set(pf::trace_hitpoints(scene, eye), eye.direct, scene.scene_id);
  std::vector<pf_photon> global;
  const pf::PhotonPassResult pass =
      trace_global(scene, sizes.back(), args["seed"].as<uint32_t>(), threads, global);
  const size_t global_all = global.size();
  global.resize(sizes.back());

  auto pick = [&](size_t n, size_t offset) {
    std::vector<Point> qs;
    const size_t stride = std::max<size_t>(1, fresh.hitpoints.size() / std::max<size_t>(1, n));
    for (size_t i = offset % stride; i < fresh.hitpoints.size() && qs.size() < n; i += stride) {
      const float* p = fresh.hitpoints[i].position;
      qs.push_back({p[0], p[1], p[2]});
    }
    return qs;
  };
  const std::vector<Point> queries = pick(args["queries"].as<size_t>(), 0);
  const std::vector<Point> checks = pick(args["check-queries"].as<size_t>(), 7);

  std::ostringstream md;
  md << "# Thesis ch. 6.5, photon-map experiments (bench_ch6_photonmap)\n\n"
     << "Scene " << scene.source << "; " << pass.emitted << " photons emitted, "
     << pass.photons.size() << " stored, " << global_all
     << " in the global map (indirect only); maps are its first N photons. Query points: "
     << queries.size() << " eye-pass hitpoints (" << fresh.width << "×" << fresh.height
     << " image), one query at a time on one thread. Times are medians of " << runs
     << " runs; kNN times are ms per query, build times s.\n";
  if (!pf::bench::missing_knn_libraries().empty())
    md << "\nNot built (library not found): " << pf::bench::missing_knn_libraries() << "\n";

  // Tables 6.2 and 6.4: every size, every library: build, then k = k_main queries. The indices
  // of the largest size are kept for Tables 6.3 and 6.5.
  Table build{"Table 6.2: photon-map build time (s) vs map size", "photons", {}, {}};
  Table by_size{"Table 6.4: kNN query time (ms) vs map size, k = " + std::to_string(k_main),
                "photons", {}, {}};
  std::vector<std::unique_ptr<KnnIndex>> full(libs.size());
  for (size_t n : sizes) {
    std::cerr << "map size " << n << "\n";
    const std::vector<pf_photon> map(global.begin(), global.begin() + long(n));
    build.values.push_back(double(n));
    by_size.values.push_back(double(n));
    build.columns.push_back(round_robin(libs.size(), runs, [&](size_t l) {
      full[l].reset();
      const double t0 = now();
      full[l] = libs[l].build(map);
      return now() - t0;
    }));
    by_size.columns.push_back(round_robin(libs.size(), runs, [&](size_t l) {
      return query_ms(*full[l], queries, k_main, 0.f);
    }));
  }

  // Agreement with brute force at the smallest k and at k_main.
  std::ostringstream agree;
  bool all_exact = true;
  agree << "\n## Agreement with brute force (" << checks.size() << " queries, map of "
        << global.size() << ", ε = 0)\n\n"
        << "| library | asserted exact | k | identical sets | photons swapped at the k-th "
           "distance | photons outside the exact set | recall |\n|---|---|---:|---:|---:|---:|---:|\n";
  for (int k : {*std::min_element(ks.begin(), ks.end()), k_main}) {
    std::vector<std::vector<uint32_t>> exact(checks.size());
    std::vector<double> dk(checks.size());
    for (size_t i = 0; i < checks.size(); ++i) exact[i] = brute_knn(global, checks[i], k, dk[i]);
    for (size_t l = 0; l < libs.size(); ++l) {
      Agreement a;
      std::vector<uint32_t> got;
      for (size_t i = 0; i < checks.size(); ++i) {
        full[l]->knn(checks[i].data(), k, 0.f, got);
        compare(global, checks[i], exact[i], dk[i], got, a);
      }
      if (libs[l].exact && a.outside > 0) all_exact = false;
      agree << "| " << libs[l].name << " | " << (libs[l].exact ? "yes" : "no") << " | " << k
            << " | " << a.identical << " of " << a.queries << " | " << a.swapped << " | "
            << a.outside << " | " << fmt(a.recall / double(a.queries)) << " |\n";
    }
  }

  // Table 6.3: k.
  Table by_k{"Table 6.3: kNN query time (ms) vs k, map of " + std::to_string(global.size()),
             "k", {}, {}};
  for (int k : ks) {
    std::cerr << "k " << k << "\n";
    by_k.values.push_back(k);
    by_k.columns.push_back(round_robin(
        libs.size(), runs, [&](size_t l) { return query_ms(*full[l], queries, k, 0.f); }));
  }

  // Table 6.5: ε, times and recall against the exact k_main nearest.
  Table by_eps{"Table 6.5: kNN query time (ms) vs ε, k = " + std::to_string(k_main) + ", map of " +
                   std::to_string(global.size()),
               "ε", {}, {}};
  Table recall{"Table 6.5 (recall): share of the exact " + std::to_string(k_main) +
                   " nearest returned, mean over " + std::to_string(checks.size()) + " queries",
               "ε", {}, {}};
  {
    std::vector<std::vector<uint32_t>> exact(checks.size());
    std::vector<double> dk(checks.size());
    for (size_t i = 0; i < checks.size(); ++i)
      exact[i] = brute_knn(global, checks[i], k_main, dk[i]);
    for (float e : eps) {
      std::cerr << "eps " << e << "\n";
      by_eps.values.push_back(e);
      recall.values.push_back(e);
      by_eps.columns.push_back(round_robin(
          libs.size(), runs, [&](size_t l) { return query_ms(*full[l], queries, k_main, e); }));
      // Recall as a one-run "time" column, so that the table prints it like the others.
      RunTimes share(libs.size());
      for (size_t l = 0; l < libs.size(); ++l) {
        Agreement a;
        std::vector<uint32_t> got;
        for (size_t i = 0; i < checks.size(); ++i) {
          full[l]->knn(checks[i].data(), k_main, e, got);
          compare(global, checks[i], exact[i], dk[i], got, a);
        }
        share[l].push_back(a.recall / double(a.queries));
      }
      recall.columns.push_back(share);
    }
  }
  full.clear();

  // Fig. 6.8: the classic estimate per ε, against ε = 0.
  std::ostringstream fig;
  fig << "\n## Fig. 6.8: classic photon mapping (eq. 3.10), indirect light, k = " << k_main
      << ", " << fresh.width << "×" << fresh.height << ", global map of " << global_all
      << " photons, pf::PhotonMap (FLANN single kd) with ε\n\n"
      << "| ε | classic_estimate (s) | RMSE vs ε = 0 | relative RMSE | mean radius / radius at ε = "
         "0 |\n|---:|---:|---:|---:|---:|\n";
  std::ofstream eps_dat;
  if (!dat.empty()) {
    std::filesystem::create_directories(dat);
    eps_dat.open(dat + "/ch6-eps-image.dat");
    eps_dat << "\"ε\"\t\"estimate (s)\"\t\"RMSE\"\t\"relative RMSE\"\n";
  }
  if (!image_dir.empty()) std::filesystem::create_directories(image_dir);
  pf::Image ref;
  std::vector<float> ref_radius;
  float exposure = 0.f;
  for (float e : eps) {
    std::cerr << "image eps " << e << "\n";
    pf::HitpointSet h = fresh;
    pf::ClassicOptions co;
    co.k = k_main;
    co.eps = e;
    co.threads = threads;
    const double t0 = now();
    pf::classic_estimate(scene, h, pass.photons, pass.emitted, co);
    const double secs = now() - t0;
    const pf::Image img = indirect_image(h);
    if (e == 0.f) {
      ref = img;
      for (const pf_hitpoint& hp : h.hitpoints) ref_radius.push_back(hp.radius);
      exposure = float(std::log2(0.18 / std::max(1e-12, mean(ref.rgb))));
    }
    double ratio = 0;
    size_t counted = 0;
    for (size_t i = 0; i < h.hitpoints.size(); ++i)
      if (ref_radius[i] > 0.f) ratio += h.hitpoints[i].radius / ref_radius[i], ++counted;
    const double err = rmse(img, ref), rel = err / mean(ref.rgb);
    fig << "| " << fmt(e) << " | " << fmt(secs) << " | " << fmt(err) << " | " << fmt(100 * rel)
        << " % | " << fmt(ratio / double(std::max<size_t>(1, counted))) << " |\n";
    if (eps_dat.is_open()) eps_dat << e << "\t" << secs << "\t" << err << "\t" << rel << "\n";
    if (!image_dir.empty()) {
      char name[64];
      std::snprintf(name, sizeof name, "/ch6-eps-%g.png", double(e));
      pf::write_png(img, image_dir + name, exposure);
    }
  }

  std::cout << md.str() << "\nLoad average (1 min) at start / end: " << load_start << " / "
            << pf::bench::load_average() << ".\n";
  const int ref_lib = pf::bench::photon_map_library(libs);
  for (const Table* t : {&build, &by_k, &by_size}) {
    t->print(libs, std::cout);
    t->print(libs, std::cout, ref_lib);
  }
  std::cout << agree.str();
  by_eps.print(libs, std::cout);
  by_eps.print(libs, std::cout, ref_lib);
  recall.print(libs, std::cout);
  std::cout << fig.str();
  if (!dat.empty()) {
    build.write_dat(libs, dat + "/ch6-build.dat");
    by_k.write_dat(libs, dat + "/ch6-knn-k.dat");
    by_size.write_dat(libs, dat + "/ch6-knn-size.dat");
    by_eps.write_dat(libs, dat + "/ch6-knn-eps.dat");
  }
#ifdef PF_HAVE_ANN
  annClose();
#endif
  if (!all_exact) {
    std::cerr << "bench_ch6_photonmap: an exact library returned photons outside the exact "
                 "neighbour set (see the agreement table)\n";
    return 1;
  }
  return 0;
}
