// bench_ga — the thesis's Tables 8.1–8.4 (ch. 8.2, 8.3) on this machine: evolutionary clustering
// (ga_clusters.h) with each fitness, --runs runs per fitness (seeds 1, 2, …): fitness value,
// clusters, gather time, creation time, with average and best rows; the gather time of k-means
// clusters on the same device; the rank correlation (Spearman) between fitness and measured gather
// time, within each fitness's runs (the thesis's observation "a low fitness does not always mean
// faster") and pooled over every clustering made, each scored by every CPU fitness.
//
//   bench_ga [--dae data/cornell-box.dae | --scene scene.h5] [--size 320x280] [--mesh floor]
//            [--photons 100000] [--dist-passes 1000] [--fitness filler,grid-bins,memory-access,work]
//            [--runs 10] [--iterations 3000] [--population 50] [--threads 0]
//            [--device-fitness-runs 10] [--device-iterations 300] [--device-population 50]
//            [--device-runs 5] [--time-rounds 25] [--wg-size 64] [--cl-platform -1 --cl-device -1]
//
// Setting (thesis ch. 8.2 "Speed evaluation"): 320×280, hitpoints of one mesh (--mesh, the floor:
// "this surface has most photons saved"; --mesh all keeps every mesh), the photon-distribution
// map averaged over --dist-passes passes (photon_distribution.h), gathers of pass 0's photons from
// the fresh eye-pass state (R = R0). Gather time = GatherTimes::gather of ppm_pass with
// GatherMethod::GridKmeans and the clusters (kernel time, enqueue to clFinish), the median of
// --time-rounds rounds (the best round is printed beside it); in each round every clustering (k-means,
// grid clusters, one hitpoint per cluster — the far end the `work` fitness drifts towards — and
// all GA results) is timed once, round-robin, so that other load on the machine hits all alike.
// Creation time = evolve_clusters' seconds (k-means start included), --threads OpenMP threads.
// device-time (Table 8.4) evaluates every child with --device-runs gathers on the device
// (GridGatherTimer: the photons' grid is built once per run, each evaluation uploads one cluster
// set and runs the gather kernel); its runs, generations and population have their own flags, by
// default the thesis's 10 runs of 300 generations × 50 (about 4–5 minutes per run on 2 CPU cores
// with PoCL at 320×280, floor hitpoints).
#include <omp.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cxxopts.hpp>
#include <iostream>
#include <map>
#include <numeric>
#include <sstream>
#include <string>
#include <vector>

#include "photonflow/opencl/cl_backend.h"
#include "photonflow/stages/clusters.h"
#include "photonflow/stages/eye_pass.h"
#include "photonflow/stages/ga_clusters.h"
#include "photonflow/stages/illuminate.h"
#include "photonflow/stages/photon_distribution.h"
#include "photonflow/stages/photon_pass.h"
#include "bench_common.h"

namespace {

using pf::bench::make_scene;
using pf::bench::median;
using pf::bench::now;
using pf::bench::parse_size;

// Ranks (1-based) with ties given their mean rank.
std::vector<double> ranks(const std::vector<double>& v) {
  std::vector<size_t> idx(v.size());
  std::iota(idx.begin(), idx.end(), 0);
  std::sort(idx.begin(), idx.end(), [&](size_t a, size_t b) { return v[a] < v[b]; });
  std::vector<double> r(v.size());
  for (size_t i = 0; i < idx.size();) {
    size_t j = i;
    while (j + 1 < idx.size() && v[idx[j + 1]] == v[idx[i]]) ++j;
    const double mean = 0.5 * double(i + j) + 1.0;
    for (size_t k = i; k <= j; ++k) r[idx[k]] = mean;
    i = j + 1;
  }
  return r;
}

// Spearman's rank correlation: Pearson's correlation of the ranks (NaN for < 3 values or no
// spread).
double spearman(const std::vector<double>& x, const std::vector<double>& y) {
  if (x.size() < 3) return NAN;
  const std::vector<double> a = ranks(x), b = ranks(y);
  const double n = double(a.size());
  const double ma = std::accumulate(a.begin(), a.end(), 0.0) / n,
               mb = std::accumulate(b.begin(), b.end(), 0.0) / n;
  double sab = 0, saa = 0, sbb = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    sab += (a[i] - ma) * (b[i] - mb);
    saa += (a[i] - ma) * (a[i] - ma);
    sbb += (b[i] - mb) * (b[i] - mb);
  }
  return saa > 0 && sbb > 0 ? sab / std::sqrt(saa * sbb) : NAN;
}

std::string fmt(double v, int digits = 3) {
  if (std::isnan(v)) return "—";
  char b[64];
  std::snprintf(b, sizeof b, "%.*f", digits, v);
  return b;
}
std::string fmtg(double v) {
  char b[64];
  std::snprintf(b, sizeof b, "%.6g", v);
  return b;
}

struct Candidate {
  std::string label;     // "k-means", "grid", "<fitness> #<seed>"
  std::string fitness;   // the fitness it was evolved with ("" for k-means / grid)
  pf::ClusterSet clusters;
  double value = 0;      // its own fitness value
  double creation = 0;   // seconds
  bool control = false;  // a timing control, not part of the correlation pool
  std::vector<double> times;  // gather ms, one per round
  // Median of the rounds. On a machine shared with other work one gather takes about twice as
  // long while another process holds one of the cores; the rounds interleave all clusterings, so
  // the median compares them under the same mix of load. The best round is printed beside it.
  double gather() const { return median(times); }
  double gather_best() const { return *std::min_element(times.begin(), times.end()); }
};

std::string loadavg() {
  FILE* f = std::fopen("/proc/loadavg", "r");
  if (!f) return "?";
  char b[128] = {0};
  if (!std::fgets(b, sizeof b, f)) b[0] = 0;
  std::fclose(f);
  std::string s(b);
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  // OpenMP workers must not spin while PoCL's threads run (see bench_opencl.cpp).
  pf::bench::reexec_with_passive_openmp(argv);
  cxxopts::Options o("bench_ga", "Evolutionary clustering (thesis Tables 8.1-8.4)");
  o.add_options()
    ("scene", "baked scene.h5 (camera resolution overridden); default: bake --dae",
     cxxopts::value<std::string>()->default_value(""))
    ("dae", "scene file baked in-process", cxxopts::value<std::string>()->default_value("data/cornell-box.dae"))
    ("size", "image size", cxxopts::value<std::string>()->default_value("320x280"))
    ("mesh", "keep the hitpoints of this mesh only (thesis: the floor), or all",
     cxxopts::value<std::string>()->default_value("floor"))
    ("photons", "photons emitted per pass", cxxopts::value<uint32_t>()->default_value("100000"))
    ("dist-passes", "passes averaged into the photon-distribution map",
     cxxopts::value<int>()->default_value("1000"))
    ("fitness", "CPU fitnesses to evolve with (comma-separated)",
     cxxopts::value<std::string>()->default_value("filler,grid-bins,memory-access,work"))
    ("runs", "runs (seeds 1..runs) per CPU fitness", cxxopts::value<int>()->default_value("10"))
    ("iterations", "generations per CPU-fitness run", cxxopts::value<int>()->default_value("3000"))
    ("population", "population per CPU-fitness run", cxxopts::value<int>()->default_value("50"))
    ("threads", "OpenMP threads of the evolution (0 = all cores)", cxxopts::value<int>()->default_value("0"))
    ("device-fitness-runs", "runs of the device-time fitness (Table 8.4; 0 = none)",
     cxxopts::value<int>()->default_value("10"))
    ("device-iterations", "generations per device-time run", cxxopts::value<int>()->default_value("300"))
    ("device-population", "population per device-time run", cxxopts::value<int>()->default_value("50"))
    ("device-runs", "gathers per device-time evaluation (the fastest counts)",
     cxxopts::value<int>()->default_value("5"))
    ("time-rounds", "rounds of gather timing (best and median)", cxxopts::value<int>()->default_value("25"))
    ("wg-size", "work-group size of the clusters", cxxopts::value<int>()->default_value("64"))
    ("h,help", "print this help");
  pf::bench::add_opencl_device_options(o);
  auto a = o.parse(argc, argv);
  if (a.count("help")) {
    std::cout << o.help() << "\n";
    return 0;
  }
  try {
    const int wg = a["wg-size"].as<int>(), runs = a["runs"].as<int>();
    const int rounds = std::max(1, a["time-rounds"].as<int>());
    std::unique_ptr<pf::ClContext> dev = pf::bench::open_opencl_device(a, wg, "bench_ga");
    dev->build_all();

    const pf::bench::Size sz = parse_size(a["size"].as<std::string>());
    const pf::Scene scene = make_scene(a["scene"].as<std::string>(), a["dae"].as<std::string>(), sz);
    pf::EyePassOptions eye;
    pf::HitpointSet h = pf::make_hitpoint_set(pf::trace_hitpoints(scene, eye),
                                              pf::DirectMode::Photons, scene.scene_id);
    const std::string mesh = a["mesh"].as<std::string>();
    if (mesh != "all") {
      auto it = std::find(scene.mesh_names.begin(), scene.mesh_names.end(), mesh);
      if (it == scene.mesh_names.end()) throw std::runtime_error("no mesh named " + mesh);
      const int m = int(it - scene.mesh_names.begin());
      std::vector<pf_hitpoint> keep;
      for (const pf_hitpoint& p : h.hitpoints)
        if (p.mesh == m) keep.push_back(p);
      h.hitpoints = std::move(keep);
    }
    pf::PhotonPassOptions ph;
    ph.photons = a["photons"].as<uint32_t>();
    const pf::PhotonPassResult pass0 = pf::trace_photons(scene, 0, ph);
    pf::PpmOptions ppm;
    const int dist_passes = a["dist-passes"].as<int>();
    double t0 = now();
    pf::PhotonDistribution dist = pf::empty_photon_distribution(pf::ppm_grid_params(h, ppm), scene.scene_id);
    for (int p = 0; p < dist_passes; ++p) {
      const pf::PhotonPassResult r = p == 0 ? pass0 : pf::trace_photons(scene, uint32_t(p), ph);
      dist.add_pass(r.photons, r.emitted, int(scene.mesh_names.size()));
    }
    const double dist_s = now() - t0;

    pf::GaFitnessInputs in;
    in.hitpoints = &h;
    in.wg_size = wg;
    in.distribution = &dist;
    in.scene = &scene;
    in.photons = &pass0.photons;
    in.emitted = pass0.emitted;
    in.max_bins = ppm.max_bins;
    in.device = dev.get();
    in.device_runs = a["device-runs"].as<int>();

    std::printf("# bench_ga: %s %dx%d, hitpoints of %s: %zu; %u photons/pass (%zu stored in pass 0); "
                "map of %d passes (%.1f s); work-group %d\n",
                a["scene"].as<std::string>().empty() ? a["dae"].as<std::string>().c_str()
                                                     : a["scene"].as<std::string>().c_str(),
                sz.w, sz.h, mesh.c_str(), h.hitpoints.size(), ph.photons, pass0.photons.size(),
                dist_passes, dist_s, wg);
    std::printf("# OpenCL: %s; evolution: %d OpenMP threads (nproc %ld); /proc/loadavg at start: %s\n\n",
                dev->name().c_str(),
                a["threads"].as<int>() > 0 ? a["threads"].as<int>() : omp_get_max_threads(),
                sysconf(_SC_NPROCESSORS_ONLN), loadavg().c_str());
    std::fflush(stdout);

    std::vector<Candidate> cands;
    {
      Candidate k;
      k.label = "k-means";
      t0 = now();
      k.clusters = pf::cluster_kmeans(h, wg, 10, 1);
      k.creation = now() - t0;
      cands.push_back(std::move(k));
      Candidate g;
      g.label = "grid clusters";
      t0 = now();
      g.clusters = pf::cluster_grid(h, wg, 0);
      g.creation = now() - t0;
      cands.push_back(std::move(g));
      // The far end of the `work` fitness: every hitpoint a cluster of its own (all fillers but one
      // per work-group), to see where the fitness stops predicting the device.
      Candidate one;
      one.label = "one hitpoint per cluster";
      one.clusters = pf::empty_cluster_set(h, wg, "singletons");
      for (int32_t i = 0; i < int32_t(h.hitpoints.size()); ++i)
        pf::append_cluster(one.clusters, h.hitpoints[size_t(i)].mesh, &i, 1, h);
      cands.push_back(std::move(one));
    }
    std::vector<std::string> fits = pf::bench::split_list(a["fitness"].as<std::string>());
    const int dev_runs = a["device-fitness-runs"].as<int>();
    std::map<std::string, pf::GaOptions> opts;
    for (const std::string& fname : fits) {
      pf::GaOptions go;
      go.fitness = pf::parse_ga_fitness(fname);
      if (go.fitness == pf::GaFitness::DeviceTime) throw std::runtime_error("device-time has its own runs");
      go.iterations = a["iterations"].as<int>();
      go.population = a["population"].as<int>();
      go.threads = a["threads"].as<int>();
      opts[fname] = go;
    }
    if (dev_runs > 0) {
      pf::GaOptions go;
      go.fitness = pf::GaFitness::DeviceTime;
      go.iterations = a["device-iterations"].as<int>();
      go.population = a["device-population"].as<int>();
      opts["device-time"] = go;
      fits.push_back("device-time");
    }
    for (const std::string& fname : fits) {
      pf::GaOptions go = opts[fname];
      const int n = go.fitness == pf::GaFitness::DeviceTime ? dev_runs : runs;
      for (int r = 1; r <= n; ++r) {
        go.seed = uint32_t(r);
        t0 = now();
        pf::GaResult res = pf::evolve_clusters(in, go);
        Candidate c;
        c.label = fname + " #" + std::to_string(r);
        c.fitness = fname;
        c.value = res.fitness;
        c.creation = res.seconds;
        c.clusters = std::move(res.clusters);
        std::fprintf(stderr, "bench_ga: %s: fitness %s (k-means clusters %s), %zu clusters, %.1f s\n",
                     c.label.c_str(), fmtg(c.value).c_str(), fmtg(res.kmeans_fitness).c_str(),
                     c.clusters.clusters.size(), now() - t0);
        cands.push_back(std::move(c));
      }
    }

    // A second copy of the k-means clusters, timed last in every round: a control for effects of
    // the position in the round (the k-means row uses the first copy).
    {
      Candidate k2;
      k2.label = "k-means (control, timed last in each round)";
      k2.clusters = cands[0].clusters;
      k2.control = true;
      cands.push_back(std::move(k2));
    }
    // Gather timing, round-robin over all clusterings (one untimed warm-up call each).
    auto time_once = [&](Candidate& c) {
      pf::PpmOptions po;
      po.method = pf::GatherMethod::GridKmeans;
      po.clusters = &c.clusters;
      pf::HitpointSet w = h;
      return pf::ppm_pass(scene, w, pass0.photons, pass0.emitted, po, *dev).gather * 1e3;
    };
    for (Candidate& c : cands) time_once(c);
    for (int r = 0; r < rounds; ++r)
      for (Candidate& c : cands) c.times.push_back(time_once(c));
    const double kmeans_ms = cands[0].gather();

    // Tables 8.1–8.4.
    const double kmeans_best = cands[0].gather_best();
    std::printf("/proc/loadavg after the timing: %s. Gather times: median of %d rounds (best round "
                "in brackets).\n\n", loadavg().c_str(), rounds);
    std::printf("k-means clusters: %zu clusters, gather %s ms (%s), creation %s s; grid clusters: "
                "%zu clusters, gather %s ms (%s); one hitpoint per cluster: %zu clusters, gather %s ms (%s)\n\n",
                cands[0].clusters.clusters.size(), fmt(kmeans_ms).c_str(), fmt(kmeans_best).c_str(),
                fmt(cands[0].creation).c_str(), cands[1].clusters.clusters.size(),
                fmt(cands[1].gather()).c_str(), fmt(cands[1].gather_best()).c_str(),
                cands[2].clusters.clusters.size(), fmt(cands[2].gather()).c_str(),
                fmt(cands[2].gather_best()).c_str());
    const char* table_no[] = {"8.1", "8.2", "8.3", "(new)", "8.4"};
    std::string summary =
        "| fitness | runs | generations × population | average gather (ms) | best gather (ms) | "
        "k-means / average | k-means / best | k-means / average (best rounds) | average creation (s) | "
        "Spearman(fitness, gather) |\n"
        "|---|---:|---|---:|---:|---:|---:|---:|---:|---:|\n";
    for (const std::string& fname : fits) {
      const pf::GaOptions& go = opts[fname];
      const int tn = fname == "filler" ? 0 : fname == "grid-bins" ? 1 : fname == "memory-access" ? 2
                   : fname == "work" ? 3 : 4;
      std::printf("### Table %s: fitness %s (%s), %d generations, population %d\n\n", table_no[tn],
                  fname.c_str(), pf::ga_fitness_unit(go.fitness), go.iterations, go.population);
      std::printf("| test | fitness value | clusters | gather (ms) | best round (ms) | creation (s) |\n"
                  "|---:|---:|---:|---:|---:|---:|\n");
      std::vector<double> val, ms, med, ncl, cre;
      for (const Candidate& c : cands) {
        if (c.fitness != fname) continue;
        val.push_back(c.value);
        ms.push_back(c.gather());
        med.push_back(c.gather_best());
        ncl.push_back(double(c.clusters.clusters.size()));
        cre.push_back(c.creation);
        std::printf("| %s | %s | %zu | %s | %s | %s |\n", c.label.substr(c.label.find('#') + 1).c_str(),
                    fmtg(c.value).c_str(), c.clusters.clusters.size(), fmt(c.gather()).c_str(),
                    fmt(c.gather_best()).c_str(), fmt(c.creation, 2).c_str());
      }
      if (val.empty()) continue;
      auto avg = [](const std::vector<double>& v) {
        return std::accumulate(v.begin(), v.end(), 0.0) / double(v.size());
      };
      auto mn = [](const std::vector<double>& v) { return *std::min_element(v.begin(), v.end()); };
      std::printf("| average | %s | %.1f | %s | %s | %s |\n", fmtg(avg(val)).c_str(), avg(ncl),
                  fmt(avg(ms)).c_str(), fmt(avg(med)).c_str(), fmt(avg(cre), 2).c_str());
      std::printf("| best | %s | %.0f | %s | %s | %s |\n\n", fmtg(mn(val)).c_str(), mn(ncl),
                  fmt(mn(ms)).c_str(), fmt(mn(med)).c_str(), fmt(mn(cre), 2).c_str());
      const double rho = spearman(val, ms);
      char line[512];
      std::snprintf(line, sizeof line, "| %s | %zu | %d × %d | %s | %s | %s× | %s× | %s× | %s | %s |\n",
                    fname.c_str(), val.size(), go.iterations, go.population, fmt(avg(ms)).c_str(),
                    fmt(mn(ms)).c_str(), fmt(kmeans_ms / avg(ms), 2).c_str(),
                    fmt(kmeans_ms / mn(ms), 2).c_str(), fmt(kmeans_best / avg(med), 2).c_str(),
                    fmt(avg(cre), 2).c_str(), fmt(rho, 2).c_str());
      summary += line;
      std::fflush(stdout);
    }
    std::printf("### Summary (k-means: %s ms)\n\n%s\n", fmt(kmeans_ms).c_str(), summary.c_str());

    // Pooled: every clustering scored by every CPU fitness, against its measured gather time.
    std::printf("### Rank correlation over all %zu clusterings (k-means, grid, one hitpoint per "
                "cluster, every GA result)\n\n",
                cands.size() - 1);
    std::printf("| fitness | Spearman(fitness, gather time) |\n|---|---:|\n");
    std::vector<double> ms;
    for (const Candidate& c : cands)
      if (!c.control) ms.push_back(c.gather());
    for (pf::GaFitness f : {pf::GaFitness::Filler, pf::GaFitness::GridBins,
                            pf::GaFitness::MemoryAccess, pf::GaFitness::Work}) {
      std::vector<double> v;
      for (const Candidate& c : cands)
        if (!c.control) v.push_back(pf::cluster_fitness(c.clusters, in, f));
      std::printf("| %s | %s |\n", pf::ga_fitness_name(f), fmt(spearman(v, ms), 2).c_str());
    }
    std::printf("\nGather times per clustering (ms over %d rounds: best, median, worst):\n\n", rounds);
    for (const Candidate& c : cands) {
      const auto mm = std::minmax_element(c.times.begin(), c.times.end());
      std::printf("- %s: %s, %s, %s\n", c.label.c_str(), fmt(*mm.first).c_str(),
                  fmt(c.gather()).c_str(), fmt(*mm.second).c_str());
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_ga: %s\n", e.what());
    return 1;
  }
  return 0;
}
