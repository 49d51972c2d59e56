// Benchmark of the nodelet's quick answers: sliding AVAR update per 3-axis sample (1 kHz, 1 h window) and the fit of
// the three curves per answer, on the log:10 and octave grids.
#include <benchmark/benchmark.h>

#include <array>
#include <cmath>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "gyro_allan/noise_model.hpp"
#include "gyro_allan/model_check.hpp"
#include "gyro_allan/sliding_allan.hpp"

using namespace gyro_allan;

namespace {

constexpr double kRate = 1000.0;

std::vector<double> noise(size_t n, uint64_t seed) {
  std::mt19937_64 gen(seed);
  std::normal_distribution<double> g(0.0, 0.03);
  std::vector<double> v(n);
  for (auto& x : v) x = 0.01 + g(gen);
  return v;
}

/// Three axes with a full window (built once per configuration: filling 1 h at 1 kHz takes a few seconds).
struct Filled {
  std::array<std::unique_ptr<SlidingAllan>, 3> axes;
  std::vector<double> data;
  size_t pos = 0;
};

Filled& filled(double window_s, const std::string& grid, int steps) {
  static std::map<std::string, std::unique_ptr<Filled>> cache;
  const std::string key = std::to_string(window_s) + grid + std::to_string(steps);
  auto& slot = cache[key];
  if (!slot) {
    slot.reset(new Filled);
    SlidingAllanOptions o;
    o.tau0 = 1.0 / kRate;
    o.window_samples = static_cast<int64_t>(window_s * kRate);
    std::string err;
    parseTauGrid(grid, &o.grid, &err);
    o.compute_edf = false;
    o.recompute_steps = steps;
    for (auto& a : slot->axes) a.reset(new SlidingAllan(o));
    slot->data = noise(1 << 20, 3);
    const int64_t n = o.window_samples + 1000;
    for (int64_t i = 0; i < n; ++i) {
      const double v = slot->data[i & ((1 << 20) - 1)];
      for (auto& a : slot->axes) a->addRate(v);
    }
  }
  return *slot;
}

// Per 3-axis sample: the only work the subscriber callback does on the data (args: window s, steps; grid by name).
void runUpdate(benchmark::State& state, const std::string& grid) {
  const double window_s = static_cast<double>(state.range(0));
  Filled& f = filled(window_s, grid, static_cast<int>(state.range(1)));
  const size_t mask = f.data.size() - 1;
  for (auto _ : state) {
    const size_t i = f.pos++ & mask;
    f.axes[0]->addRate(f.data[i]);
    f.axes[1]->addRate(f.data[(i + 7) & mask]);
    f.axes[2]->addRate(f.data[(i + 13) & mask]);
  }
  state.counters["tau_points"] = static_cast<double>(f.axes[0]->factors().size());
  state.counters["MB_3axes"] = 3.0 * f.axes[0]->memoryBytes() / 1e6;
  state.counters["core_pct_at_1kHz"] =
      // time per 3-axis sample [s] x 1000 samples/s x 100 %
      benchmark::Counter(1e-5, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}
void BM_Update3Axis_log10(benchmark::State& s) { runUpdate(s, "log:10"); }
void BM_Update3Axis_octave(benchmark::State& s) { runUpdate(s, "octave"); }
BENCHMARK(BM_Update3Axis_log10)->Args({3600, 2})->Args({60, 2})->Args({3600, 4})->Unit(benchmark::kNanosecond);
BENCHMARK(BM_Update3Axis_octave)->Args({3600, 2})->Unit(benchmark::kNanosecond);

// Per quick answer: snapshot the three curves and fit them as QuickView::fit does (fitWithModelEdf, two passes,
// values and delta-method sigmas without the unified intervals); arg 1: with the intervals, as the full analysis.
void runQuickFit(benchmark::State& state, const std::string& grid) {
  Filled& f = filled(3600, grid, 2);
  FitOptions fo;
  fo.intervals = state.range(0) != 0;
  for (auto _ : state) {
    for (auto& a : f.axes) {
      DeviationCurve c = a->curve();
      fillConfidence(&c, 0.683);
      FitResult fit = fitWithModelEdf(&c, fo, 0.683);
      benchmark::DoNotOptimize(fit);
    }
  }
  state.counters["core_pct_at_5s_update"] =
      // time per answer [s] / 5 s x 100 % = iterations^-1 x seconds x 20
      benchmark::Counter(1.0 / 20.0, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}
void BM_QuickFit3Axis_log10(benchmark::State& s) { runQuickFit(s, "log:10"); }
void BM_QuickFit3Axis_octave(benchmark::State& s) { runQuickFit(s, "octave"); }
BENCHMARK(BM_QuickFit3Axis_log10)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_QuickFit3Axis_octave)->Arg(0)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
