// Benchmarks of the analysis pipeline's kernels on long records: OADEV on octave and dense grids (1e6-1e8 samples),
// the stationary wavelet transform, the IEEE fit, the model check and its raw-sample diagnostics, the wavelet split,
// sanitation, and the stages of one 1 h / 400 Hz axis as analyze_bag runs them.
#include <benchmark/benchmark.h>

#include <map>
#include <vector>

#include "gyro_allan/allan.hpp"
#include "gyro_allan/analysis.hpp"
#include "gyro_allan/model_check.hpp"
#include "gyro_allan/rest.hpp"
#include "gyro_allan/simulate.hpp"
#include "gyro_allan/stats.hpp"
#include "gyro_allan/spectral.hpp"
#include "gyro_allan/timing.hpp"
#include "gyro_allan/wavelet.hpp"
#include "gyro_allan/wavelet_split.hpp"

using namespace gyro_allan;

namespace {

constexpr double kRate = 400.0;
constexpr double kTau0 = 1.0 / kRate;

/// A MEMS-like axis (N, B, K and a little quantization), generated once per length.
const std::vector<double>& axis(int64_t n) {
  static std::map<int64_t, std::vector<double>> cache;
  auto it = cache.find(n);
  if (it != cache.end()) return it->second;
  AxisNoise a;
  a.angle_random_walk = 2e-4;
  a.bias_instability = 2e-5;
  a.rate_random_walk = 1e-6;
  a.quantization = 1e-6;
  return cache[n] = simulateAxis(a, kRate, n, 11);
}

constexpr int64_t kHour = 1440000;  // 1 h at 400 Hz

DeviationOptions grid(const char* name, bool edf) {
  DeviationOptions o;
  std::string err;
  parseTauGrid(name, &o.grid, &err);
  o.compute_edf = edf;
  return o;
}

void BM_Oadev(benchmark::State& st, const char* g) {
  const auto& x = axis(st.range(0));
  const DeviationOptions o = grid(g, true);
  size_t points = 0;
  for (auto _ : st) {
    const DeviationCurve c = computeDeviation("oadev", x, InputKind::Rate, kTau0, o);
    points = c.points.size();
    benchmark::DoNotOptimize(c.points.data());
  }
  st.counters["tau_points"] = static_cast<double>(points);
  st.SetItemsProcessed(st.iterations() * st.range(0));
}
BENCHMARK_CAPTURE(BM_Oadev, octave, "octave")->Arg(1000000)->Arg(10000000)->Arg(100000000)->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK_CAPTURE(BM_Oadev, log10, "log:10")->Arg(1000000)->Arg(10000000)->Arg(100000000)->Unit(benchmark::kMillisecond)->Iterations(1);

void BM_Swt(benchmark::State& st) {
  const auto& x = axis(1 << 20);
  const Wavelet w("sym8");
  for (auto _ : st) {
    auto c = swt(x, w, 4);
    benchmark::DoNotOptimize(c.data());
  }
  st.SetItemsProcessed(st.iterations() * (1 << 20));
}
BENCHMARK(BM_Swt)->Unit(benchmark::kMillisecond);

void BM_FitWithModelEdf(benchmark::State& st) {
  const DeviationCurve c0 = computeDeviation("oadev", axis(kHour), InputKind::Rate, kTau0, grid("log:10", true));
  for (auto _ : st) {
    DeviationCurve c = c0;
    const FitResult f = fitWithModelEdf(&c, FitOptions{}, 0.683);
    benchmark::DoNotOptimize(f.terms.data());
  }
}
BENCHMARK(BM_FitWithModelEdf)->Unit(benchmark::kMillisecond);

void BM_CheckModel(benchmark::State& st) {
  const auto& x = axis(kHour);
  DeviationCurve c = computeDeviation("oadev", x, InputKind::Rate, kTau0, grid("log:10", true));
  enforceRedderWithTau(&c, 0.683);
  DeviationCurve w = c;
  const FitResult f = fitWithModelEdf(&w, FitOptions{}, 0.683);
  for (auto _ : st) {
    const ModelCheck m = checkModel(x, kTau0, c, f, ModelCheckOptions{});
    benchmark::DoNotOptimize(m.ok);
  }
}
BENCHMARK(BM_CheckModel)->Unit(benchmark::kMillisecond);

void BM_WaveletSplit(benchmark::State& st) {
  const auto& x = axis(kHour);
  for (auto _ : st) {
    const WaveletSplitResult r = waveletSplit(x, kTau0);
    benchmark::DoNotOptimize(r.ok);
  }
}
BENCHMARK(BM_WaveletSplit)->Unit(benchmark::kMillisecond);

void BM_WelchPsd(benchmark::State& st) {
  const auto& x = axis(kHour);
  for (auto _ : st) benchmark::DoNotOptimize(welchPsd(x, kRate, st.range(0), 0.5).p.data());
}
BENCHMARK(BM_WelchPsd)->Arg(1024)->Arg(65536)->Unit(benchmark::kMillisecond);

void BM_Autocovariance400(benchmark::State& st) {
  const auto& x = axis(kHour);
  for (auto _ : st) benchmark::DoNotOptimize(autocovariance(x, 400).data());
}
BENCHMARK(BM_Autocovariance400)->Unit(benchmark::kMillisecond);

void BM_DetectOutliers(benchmark::State& st) {
  const auto& x = axis(kHour);
  for (auto _ : st) benchmark::DoNotOptimize(detectOutliers(x, kTau0, 10.0).robust_sigma);
}
BENCHMARK(BM_DetectOutliers)->Unit(benchmark::kMillisecond);

void BM_SanitizeCompact3Axis(benchmark::State& st) {
  const auto& x = axis(kHour);
  std::vector<double> t(x.size());
  for (size_t i = 0; i < t.size(); ++i) t[i] = 1.0 + static_cast<double>(i) * kTau0;
  CompactSeries c[3];
  for (auto& s : c) {
    s.reserve(x.size());
    for (double v : x) s.push_back(v);
  }
  for (auto _ : st) {
    const SanitizedSeries ss = sanitizeCompact(t, {&c[0], &c[1], &c[2]});
    benchmark::DoNotOptimize(ss.report.kept);
  }
}
BENCHMARK(BM_SanitizeCompact3Axis)->Unit(benchmark::kMillisecond);

/// Exact medians by selection (stats.hpp) of a noise sample of range(0) values: the rest detector takes three per
/// 1 s block and channel (400 values), spike removal, the sampling check and the wavelet threshold whole records.
void BM_Median(benchmark::State& st) {
  const auto& x = axis(kHour);
  const size_t n = static_cast<size_t>(st.range(0));
  const size_t blocks = x.size() / n;  // every block of the record once per iteration (copy included)
  std::vector<double> w;
  for (auto _ : st)
    for (size_t b = 0; b < blocks; ++b) {
      w.assign(x.begin() + static_cast<std::ptrdiff_t>(b * n), x.begin() + static_cast<std::ptrdiff_t>((b + 1) * n));
      benchmark::DoNotOptimize(medianInPlace(w));
    }
  st.SetItemsProcessed(st.iterations() * static_cast<int64_t>(blocks));
}
BENCHMARK(BM_Median)->Arg(400)->Arg(kHour)->Unit(benchmark::kMillisecond);

/// The rest detector on three gyro and three accelerometer axes, 1 h at 400 Hz (what analyze_bag runs between
/// sanitation and the axes).
void BM_DetectRest(benchmark::State& st) {
  const auto& g = axis(kHour);
  std::vector<std::vector<double>> acc(3);
  for (int c = 0; c < 3; ++c) {
    AxisNoise a;
    a.angle_random_walk = 1e-3;
    a.bias_instability = 1e-4;
    a.quantization = 1e-3;
    acc[static_cast<size_t>(c)] = simulateAxis(a, kRate, kHour, 21 + static_cast<uint64_t>(c));
    if (c == 2)
      for (double& v : acc[2]) v += 9.81;
  }
  for (auto _ : st) {
    const RestResult r = detectRestSingle({&g, &g, &g}, {&acc[0], &acc[1], &acc[2]}, kTau0);
    benchmark::DoNotOptimize(r.blocks);
  }
}
BENCHMARK(BM_DetectRest)->Unit(benchmark::kMillisecond);

/// One axis of analyze_bag's default pipeline, stage by stage (1 h at 400 Hz).
void BM_AxisStages(benchmark::State& st) {
  const auto& x = axis(kHour);
  const int stage = static_cast<int>(st.range(0));  // 0 prepare, 1 split, 2 check, 3 all
  AnalysisOptions o;
  for (auto _ : st) {
    st.PauseTiming();
    AxisStages s("x", {x}, kTau0, o);
    if (stage != 0 && stage != 3) s.prepare();
    st.ResumeTiming();
    if (stage == 0 || stage == 3) s.prepare();
    if (stage == 1 || stage == 3) s.split();
    if (stage == 2 || stage == 3) s.check();
    if (stage == 3) benchmark::DoNotOptimize(s.finish().coefficients.data());
  }
}
BENCHMARK(BM_AxisStages)->Arg(0)->Arg(1)->Arg(2)->Arg(3)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
