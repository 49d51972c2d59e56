// Benchmark: sym8 multilevel DWT + IDWT (wavedec/waverec) and wden of 1e7 samples vs one plain pass (a sum).
#include <benchmark/benchmark.h>

#include <random>
#include <vector>

#include "gyro_allan/wavelet.hpp"

namespace {

const std::vector<double>& data() {
  static const std::vector<double> x = [] {
    std::vector<double> v(10000000);
    std::mt19937_64 rng(1);
    std::normal_distribution<double> g(0.0, 1.0);
    for (auto& s : v) s = g(rng);
    return v;
  }();
  return x;
}

void BM_PlainSum(benchmark::State& state) {
  const auto& x = data();
  for (auto _ : state) {
    double s = 0;
    for (double v : x) s += v;
    benchmark::DoNotOptimize(s);
  }
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(x.size()));
}
BENCHMARK(BM_PlainSum)->Unit(benchmark::kMillisecond);

void BM_Sym8WavedecWaverec(benchmark::State& state) {
  const auto& x = data();
  const gyro_allan::Wavelet w("sym8");
  const auto mode = gyro_allan::ExtensionMode::Symmetric;
  const int level = static_cast<int>(state.range(0));
  for (auto _ : state) {
    auto c = gyro_allan::wavedec(x, w, mode, level);
    auto y = gyro_allan::waverec(c, w, mode);
    benchmark::DoNotOptimize(y.data());
  }
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(x.size()));
}
BENCHMARK(BM_Sym8WavedecWaverec)->Arg(8)->Arg(19)->Unit(benchmark::kMillisecond);

void BM_Sym8Wden(benchmark::State& state) {
  const auto& x = data();
  gyro_allan::WdenOptions o;
  o.level = 8;
  for (auto _ : state) {
    auto r = gyro_allan::wden(x, o);
    benchmark::DoNotOptimize(r.removed.data());
  }
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(x.size()));
}
BENCHMARK(BM_Sym8Wden)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
