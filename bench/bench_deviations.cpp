// Benchmark of the Allan-family deviations (incl. mtotdev) on 1e7 gyro-like rate samples (octave grid, with EDF/CI),
// plus 1e8-sample OADEV/MDEV numerical-soundness runs (large bias vs exactly removed bias) and the rate-to-angle
// integration every deviation of a rate record starts with (1.44e6 samples: one axis of 1 h at 400 Hz).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "gyro_allan/allan.hpp"

using namespace gyro_allan;

namespace {

/// White rate noise (ARW) plus a small rate random walk, 100 Hz: what a static gyro record looks like.
const std::vector<double>& gyroLike(size_t n) {
  static std::vector<double> data;
  if (data.size() != n) {
    std::mt19937_64 rng(7);
    std::normal_distribution<double> nd(0.0, 1.0);
    data.resize(n);
    double walk = 0;
    for (size_t i = 0; i < n; ++i) {
      walk += 1e-7 * nd(rng);
      data[i] = 1e-3 * nd(rng) + walk;
    }
  }
  return data;
}

void BM_Deviation(benchmark::State& state, const char* name, bool edf) {
  const auto& y = gyroLike(10000000);
  DeviationOptions opt;
  opt.grid.kind = TauGridKind::Octave;
  opt.compute_edf = edf;
  size_t points = 0;
  for (auto _ : state) {
    const auto c = computeDeviation(name, y, InputKind::Rate, 0.01, opt);
    points = c.points.size();
    benchmark::DoNotOptimize(c.points.data());
  }
  state.counters["points"] = static_cast<double>(points);
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(y.size()));
}

void BM_RateToAngle(benchmark::State& state) {
  const auto& y = gyroLike(static_cast<size_t>(state.range(0)));
  for (auto _ : state) {
    const auto x = rateToAngle(y, 0.0025);
    benchmark::DoNotOptimize(x.data());
  }
  state.SetItemsProcessed(state.iterations() * state.range(0));
}

void BM_Bias1e8(benchmark::State& state, const char* name) {
  const size_t n = 100000000;
  const double bias = 1e3;
  std::mt19937_64 rng(9);
  std::normal_distribution<double> nd(0.0, 1e-6);
  std::vector<double> biased(n);
  for (auto& v : biased) v = bias + nd(rng);
  DeviationOptions opt;
  opt.grid.kind = TauGridKind::Octave;
  opt.compute_edf = false;
  double worst = 0;
  for (auto _ : state) {
    const auto c1 = computeDeviation(name, biased, InputKind::Rate, 0.001, opt);
    state.PauseTiming();
    std::vector<double> noise(biased);
    for (auto& v : noise) v -= bias;  // exact (Sterbenz): same information without the bias
    const auto c0 = computeDeviation(name, noise, InputKind::Rate, 0.001, opt);
    for (size_t i = 0; i < c0.points.size(); ++i)
      worst = std::max(worst, std::fabs(c1.points[i].dev / c0.points[i].dev - 1));
    state.ResumeTiming();
  }
  state.counters["max_rel_diff_vs_unbiased"] = worst;
}

}  // namespace

#define DEV_BENCH(NAME)                                                                                         \
  BENCHMARK_CAPTURE(BM_Deviation, NAME, #NAME, true)->Unit(benchmark::kMillisecond)->Iterations(2);            \
  BENCHMARK_CAPTURE(BM_Deviation, NAME##_no_edf, #NAME, false)->Unit(benchmark::kMillisecond)->Iterations(2)

DEV_BENCH(oadev);
DEV_BENCH(adev);
DEV_BENCH(mdev);
DEV_BENCH(tdev);
DEV_BENCH(hdev);
DEV_BENCH(ohdev);
DEV_BENCH(totdev);
// mtotdev (exact, O(N) per tau from m = 8 on via fold sums; ttotdev costs the same).
DEV_BENCH(mtotdev);
BENCHMARK(BM_RateToAngle)->Arg(1440000)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Bias1e8, oadev, "oadev")->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK_CAPTURE(BM_Bias1e8, mdev, "mdev")->Unit(benchmark::kMillisecond)->Iterations(1);

BENCHMARK_MAIN();
