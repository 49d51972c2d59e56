// Spike removal (spikes.hpp): injected spikes found and removed with N back to the truth, clean records of several
// gyro classes untouched, the streaming filter equal to the batch function, the AxisAnalysis path, bad input.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "gyro_allan/analysis.hpp"
#include "gyro_allan/model_check.hpp"
#include "gyro_allan/simulate.hpp"
#include "gyro_allan/spikes.hpp"

using namespace gyro_allan;

namespace {

// A static MEMS gyro: N = 0.34 deg/sqrt(h), B = 3.7 deg/h, K = 2.5 deg/h/sqrt(h) (SI below).
AxisNoise mems() {
  AxisNoise a;
  a.angle_random_walk = 1e-4;
  a.bias_instability = 1.8e-5;
  a.rate_random_walk = 2e-7;
  a.bias = 3e-3;
  return a;
}

// Adds `count` spikes at distinct random samples, amplitude a * sigma with a log-uniform in [a_lo, a_hi] and a random
// sign (sigma: the per-sample white noise). Returns the spiked indices, ascending.
std::vector<int64_t> injectSpikes(std::vector<double>* x, int64_t count, double sigma, double a_lo, double a_hi,
                                  uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_int_distribution<int64_t> pos(0, static_cast<int64_t>(x->size()) - 1);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::set<int64_t> at;
  while (static_cast<int64_t>(at.size()) < count) at.insert(pos(rng));
  for (int64_t i : at) {
    const double a = a_lo * std::pow(a_hi / a_lo, u(rng));
    (*x)[static_cast<size_t>(i)] += (u(rng) < 0.5 ? -1 : 1) * a * sigma;
  }
  return std::vector<int64_t>(at.begin(), at.end());
}

FitResult jointFit(const std::vector<double>& x, double tau0) {
  DeviationOptions o;
  DeviationCurve c = oadev(x, tau0, o);
  enforceRedderWithTau(&c, o.confidence);
  return fitWithModelEdf(&c, FitOptions{}, o.confidence);
}

double excessKurtosis(const std::vector<double>& x) {
  double m = 0;
  for (double v : x) m += v;
  m /= x.size();
  double s2 = 0, s4 = 0;
  for (double v : x) {
    const double d = (v - m) * (v - m);
    s2 += d;
    s4 += d * d;
  }
  s2 /= x.size();
  s4 /= x.size();
  return s4 / (s2 * s2) - 3;
}

}  // namespace

TEST(Spikes, InjectedSpikesAreFoundAndNComesBack) {
  // Two spike populations on a 1 h, 200 Hz static MEMS record (720000 samples):
  //  A: the Xsens-like case, 0.5 % of samples at 25-40 sigma: excess kurtosis ~100, ARW x2.5;
  //  B: rare big ones, 1e-4 of samples at 30-1000 sigma (log-uniform): kurtosis in the thousands, ARW x1.5.
  // Every spike is >= 25 sigma (threshold 10): all must be found except where two fall within 3 samples of each
  // other in a run the rule rejects (none on these seeds): count == injected +- 0.5 %.
  const double fs = 200, tau0 = 1 / fs;
  const int64_t n = 720000;
  const AxisNoise truth = mems();
  const double sigma = truth.angle_random_walk * std::sqrt(fs);
  struct Case {
    const char* name;
    int64_t count;
    double lo, hi;
    double min_kurtosis, min_inflation;
  };
  for (const Case& c : {Case{"A", 3600, 25, 40, 60, 2.0}, Case{"B", 72, 30, 1000, 1000, 1.3}}) {
    SCOPED_TRACE(c.name);
    const std::vector<double> clean = simulateAxis(truth, fs, n, 11);
    std::vector<double> x = clean;
    const std::vector<int64_t> at = injectSpikes(&x, c.count, sigma, c.lo, c.hi, 12);
    const FitResult with = jointFit(x, tau0);
    const double k_before = excessKurtosis(x);
    const SpikeReport r = removeSpikes(&x, SpikeOptions{});
    EXPECT_NEAR(static_cast<double>(r.count), static_cast<double>(c.count), 0.005 * c.count);
    EXPECT_TRUE(r.removed);
    EXPECT_NEAR(r.robust_sigma / sigma, 1.0, 0.1);  // d = x - local median: sigma * sqrt(1 + pi/32) ~ 1.05 sigma
    EXPECT_NEAR(r.threshold, 10 * r.robust_sigma, 1e-15);
    EXPECT_NEAR(r.excess_kurtosis_before, k_before, 1e-6 * std::fabs(k_before));
    EXPECT_GT(r.excess_kurtosis_before, c.min_kurtosis);
    EXPECT_LT(std::fabs(r.excess_kurtosis_after), 0.1);
    ASSERT_FALSE(r.first_indices.empty());
    EXPECT_EQ(r.first_indices.front(), at.front());
    EXPECT_GE(std::fabs(r.largest_excursion), c.lo * sigma);
    // N after removal: the clean record's own estimate to 0.5 % (the replaced samples are 0.5 % at most), and the
    // truth within 3 sigma of N's statistical spread (the fit's 1-sigma, which tracks the seed-to-seed spread of N
    // on such records: docs/spikes.md).
    const FitResult after = jointFit(x, tau0), ref = jointFit(clean, tau0);
    const Coefficient& N = after.terms[kAngleRandomWalk];
    ASSERT_TRUE(N.supported);
    EXPECT_NEAR(N.value / ref.terms[kAngleRandomWalk].value, 1.0, 0.005);
    EXPECT_LE(std::fabs(N.value - truth.angle_random_walk), 3 * N.sigma) << N.value << " +- " << N.sigma;
    // With the spikes, N is clearly inflated.
    EXPECT_GT(with.terms[kAngleRandomWalk].value / N.value, c.min_inflation);
  }
}
