// Tests of the raw-sample diagnostics (spectral.hpp) on simulated data with declared content.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <stdexcept>
#include <utility>
#include <vector>

#include "gyro_allan/simulate.hpp"
#include "gyro_allan/spectral.hpp"

using namespace gyro_allan;

TEST(Spectral, WhiteNoiseLevel) {
  // One-sided PSD of white noise with variance s^2 at fs is 2 s^2 / fs; the mean over bins within 2 %.
  std::mt19937_64 rng(1);
  std::normal_distribution<double> nd(0.0, 2.0);
  std::vector<double> x(200000);
  for (auto& v : x) v = nd(rng);
  const Psd p = welchPsd(x, 50.0, 1024);
  double mean = 0;
  for (size_t k = 1; k + 1 < p.p.size(); ++k) mean += p.p[k];
  mean /= (p.p.size() - 2);
  EXPECT_NEAR(mean, 2.0 * 4.0 / 50.0, 0.02 * 2.0 * 4.0 / 50.0);
  EXPECT_GT(p.segments, 300);
  EXPECT_TRUE(findPsdPeaks(p, 6.0, 5).empty()) << "no 6 dB peak in white noise";
}

TEST(Spectral, SinusoidPeak) {
  // 3.3 Hz, amplitude 0.2 in white noise of std 1 at 100 Hz: centroid within 1 % of f0, amplitude within 10 %.
  AxisNoise a;
  a.angle_random_walk = 0.1;  // 1/sqrt(0.01) * 0.1 = 1 rad/s std
  a.sine_amplitude = 0.2;
  a.sine_frequency = 3.3;
  const std::vector<double> x = simulateAxis(a, 100.0, 300000, 2);
  const Psd p = welchPsd(x, 100.0, 8192);
  const auto peaks = findPsdPeaks(p, 6.0, 3);
  ASSERT_FALSE(peaks.empty());
  EXPECT_NEAR(peaks[0].frequency_hz, 3.3, 0.033);
  EXPECT_NEAR(peaks[0].amplitude, 0.2, 0.02);
  EXPECT_GT(peaks[0].prominence_db, 10.0);
}

TEST(Spectral, AutocovarianceOfAr1) {
  // Gauss-Markov with Tc = 0.5 s at 20 Hz: rho(k) = exp(-k/10); fitted Tc within 10 %.
  AxisNoise a;
  a.gm_sigma = 1.0;
  a.gm_tau = 0.5;
  const std::vector<double> x = simulateAxis(a, 20.0, 400000, 3);
  const std::vector<double> ac = autocovariance(x, 40);
  ASSERT_EQ(ac.size(), 41u);
  EXPECT_NEAR(ac[0], 1.0, 0.05);
  std::vector<double> rho(ac.size());
  for (size_t k = 0; k < ac.size(); ++k) rho[k] = ac[k] / ac[0];
  EXPECT_NEAR(rho[10], std::exp(-1.0), 0.03);
  const ExponentialAcfFit f = fitExponentialAcf(rho, 0.05, 0.1);
  ASSERT_TRUE(f.ok);
  EXPECT_NEAR(f.tc, 0.5, 0.05);
  EXPECT_GT(f.r2, 0.95);
}

TEST(Spectral, AutocovarianceEqualsDirectSum) {
  // The blocked FFT correlation against the textbook sum (1/n) sum_i (x_i - mean)(x_{i+k} - mean), on lengths below,
  // at and across block boundaries, to 1e-12 of ac[0].
  std::mt19937_64 rng(7);
  std::normal_distribution<double> g(0.0, 1.0);
  for (int64_t n : {2, 3, 17, 255, 256, 257, 1000, 4097, 20001}) {
    std::vector<double> x(static_cast<size_t>(n));
    double prev = 0;
    for (auto& v : x) v = prev = 0.7 * prev + g(rng) + 3.0;  // correlated, with a mean to remove
    for (int64_t max_lag : {int64_t(0), int64_t(1), int64_t(40), int64_t(400), int64_t(700)}) {
      const std::vector<double> ac = autocovariance(x, max_lag);
      const int64_t L = std::min(max_lag, n - 1);
      ASSERT_EQ(static_cast<int64_t>(ac.size()), L + 1);
      double mean = 0;
      for (double v : x) mean += v;
      mean /= n;
      for (int64_t k = 0; k <= L; ++k) {
        double s = 0;
        for (int64_t i = 0; i + k < n; ++i) s += (x[i] - mean) * (x[i + k] - mean);
        EXPECT_NEAR(ac[static_cast<size_t>(k)], s / n, 1e-12 * ac[0]) << "n " << n << " lag " << k;
      }
    }
  }
}

TEST(Spectral, MeanShiftFoundAndLocalized) {
  // A 0.5-sigma step at sample 123457 of 400000 white samples: found, index within 0.2 % of the record, size 10 %.
  std::mt19937_64 rng(4);
  std::normal_distribution<double> nd(0.0, 1.0);
  std::vector<double> x(400000);
  for (size_t i = 0; i < x.size(); ++i) x[i] = nd(rng) + (i >= 123457 ? 0.5 : 0.0);
  const MeanShift s = detectMeanShift(x, 4000, 6.0);
  ASSERT_TRUE(s.found);
  EXPECT_NEAR(static_cast<double>(s.index), 123457.0, 800.0);
  EXPECT_NEAR(s.size, 0.5, 0.05);
  // Without the step nothing reaches z = 6.
  for (size_t i = 123457; i < x.size(); ++i) x[i] -= 0.5;
  EXPECT_FALSE(detectMeanShift(x, 4000, 6.0).found);
}

TEST(Spectral, RegressionWarmupOutliers) {
  std::vector<double> t(100), y(100);
  for (int i = 0; i < 100; ++i) {
    t[i] = 20.0 + 0.1 * i;
    y[i] = 3.0 - 0.25 * t[i] + 0.01 * std::sin(7.0 * i);
  }
  const LinearRegression lr = linearRegression(t, y);
  EXPECT_NEAR(lr.slope, -0.25, 0.005);
  EXPECT_LT(lr.r, -0.99);

  std::vector<double> bm(200);
  for (int i = 0; i < 200; ++i) bm[i] = 1.0 + 0.3 * (1.0 - std::exp(-(i + 0.5) * 10.0 / 400.0));
  const WarmupFit w = fitWarmup(bm, 10.0, 20.0, 4000.0);
  ASSERT_TRUE(w.ok);
  EXPECT_NEAR(w.theta, 400.0, 40.0);
  EXPECT_NEAR(w.a, 0.3, 0.03);

  std::mt19937_64 rng(5);
  std::normal_distribution<double> nd(0.0, 1.0);
  std::vector<double> x(50000);
  for (auto& v : x) v = nd(rng);
  x[1000] += 30.0;
  x[30000] -= 25.0;
  const Outliers o = detectOutliers(x, 0.01, 10.0);
  ASSERT_EQ(o.index.size(), 2u);
  EXPECT_EQ(o.index[0], 1000);
  EXPECT_EQ(o.index[1], 30000);
  EXPECT_NEAR(o.robust_sigma, 1.0, 0.1);
}

namespace {

// White rate noise of std sigma plus a random walk of step k_step per sample (the rising low-frequency floor a slow
// line has to stand out of) plus lines (frequency, amplitude) with random phases.
std::vector<double> noisyRecord(int64_t n, double fs, double sigma, double k_step,
                                const std::vector<std::pair<double, double>>& lines, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> nd(0.0, 1.0);
  std::uniform_real_distribution<double> ph(0.0, 2 * M_PI);
  std::vector<double> phases;
  for (size_t l = 0; l < lines.size(); ++l) phases.push_back(ph(rng));
  std::vector<double> x(static_cast<size_t>(n));
  double walk = 0;
  for (int64_t i = 0; i < n; ++i) {
    walk += k_step * nd(rng);
    x[i] = sigma * nd(rng) + walk;
    for (size_t l = 0; l < lines.size(); ++l)
      x[i] += lines[l].second * std::sin(2 * M_PI * lines[l].first * i / fs + phases[l]);
  }
  return x;
}

}  // namespace

TEST(Spectral, SlowLinesFalseAlarmRate) {
  // Records without a line (white noise + a random walk that dominates below ~30 periods per record, 2000 s at
  // 10 Hz; seeds 1001-1300): the share with a line found at a family-wise false-alarm level of 0.05 is at most 0.08
  // (binomial: 0.05 + 2.4 sigma over 300 records).
  int alarms = 0;
  const int runs = 300;
  for (int s = 1; s <= runs; ++s) {
    const std::vector<double> x = noisyRecord(20000, 10.0, 1.0, 0.01, {}, static_cast<uint64_t>(1000 + s));
    alarms += !findSlowLines(x, 10.0, 4.0 / 2000.0, 0.5, 0.05, 3).empty();
  }
  std::printf("records with a line: %d of %d at a false-alarm level of 0.05\n", alarms, runs);
  EXPECT_LE(alarms, 0.08 * runs);
}

TEST(Spectral, SlowLineSigmasHoldTheTruth) {
  // One line between 6 and 200 periods per record at 40x the white-noise level, over white noise and a random walk
  // that doubles the level at 6 periods (2000 s at 10 Hz, seeds 1001-1200): found in >= 97 % of the records;
  // frequency and amplitude within 1 reported sigma in 58-78 % of them, the frequency within 3 sigma in >= 97 %.
  std::mt19937_64 rng(99);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  int found = 0, f1 = 0, f3 = 0, a1 = 0;
  const int runs = 200;
  const double fs = 10.0, T = 2000.0;
  for (int s = 1; s <= runs; ++s) {
    const double f = 6.0 / T * std::pow(200.0 / 6.0, u(rng));
    const double A = std::sqrt(40.0 * 2.0 * (2.0 / fs) / T);  // white level S = 2 sigma^2 / fs; A^2 T / (2 S) = 40
    const std::vector<double> x = noisyRecord(20000, fs, 1.0, 0.002, {{f, A}}, static_cast<uint64_t>(1000 + s));
    const auto lines = findSlowLines(x, fs, 4.0 / T, 0.5, 0.01, 1);
    if (lines.empty()) continue;
    ++found;
    const SpectralLine& l = lines[0];
    const double zf = std::fabs(l.frequency_hz - f) / l.frequency_sigma_hz;
    f1 += zf <= 1;
    f3 += zf <= 3;
    a1 += std::fabs(l.amplitude - A) <= l.amplitude_sigma;
  }
  std::printf("found %d of %d, frequency within 1 sigma %d, 3 sigma %d, amplitude within 1 sigma %d\n", found, runs, f1,
              f3, a1);
  EXPECT_GE(found, 0.97 * runs);
  EXPECT_GE(f1, 0.58 * found);
  EXPECT_LE(f1, 0.78 * found);
  EXPECT_GE(f3, 0.97 * found);
  EXPECT_GE(a1, 0.58 * found);
  EXPECT_LE(a1, 0.78 * found);
}

TEST(Spectral, SlowLinesSeveralAtOnce) {
  // Two lines (a fundamental and its third harmonic) and a third one 4 bins away from the first, each at 40x the
  // noise level: all three, frequencies within 3 sigma.
  const double fs = 10.0, T = 2000.0, S = 2.0 / fs;
  const double A = std::sqrt(40.0 * 2.0 * S / T);
  const std::vector<std::pair<double, double>> truth = {{0.0105, A}, {0.0315, A}, {0.0125, A}};
  const auto lines = findSlowLines(noisyRecord(20000, fs, 1.0, 0.0, truth, 5), fs, 4.0 / T, 0.5, 0.01, 3);
  ASSERT_EQ(lines.size(), 3u);
  for (const auto& t : truth) {
    bool ok = false;
    for (const auto& l : lines) ok = ok || std::fabs(l.frequency_hz - t.first) <= 3 * l.frequency_sigma_hz;
    EXPECT_TRUE(ok) << t.first;
  }
}

TEST(Spectral, RefineLineBeatsTheWelchBin) {
  // A 3.3 Hz line refined from a Welch centroid 0.005 Hz off: within 3 sigma, sigma far below the 0.0122 Hz bin.
  const double fs = 100.0;
  const std::vector<double> x = noisyRecord(300000, fs, 1.0, 0.0, {{3.3, 0.05}}, 3);
  const SpectralLine l = refineLine(x, fs, 3.305, 1.5 * 0.0122, 2.0 / fs);
  EXPECT_LE(std::fabs(l.frequency_hz - 3.3), 3 * l.frequency_sigma_hz);
  EXPECT_LT(l.frequency_sigma_hz, 0.0122 / 20);
  EXPECT_NEAR(l.amplitude, 0.05, 3 * l.amplitude_sigma);
}

TEST(Spectral, BadInputThrows) {
  std::vector<double> x(100, 1.0);
  EXPECT_THROW(welchPsd(x, 0.0, 32), std::invalid_argument);
  EXPECT_THROW(welchPsd(std::vector<double>(8, 1.0), 10.0, 32), std::invalid_argument);
  x[5] = std::nan("");
  EXPECT_THROW(welchPsd(x, 10.0, 32), std::invalid_argument);
  EXPECT_THROW(blockMeans(x, 0), std::invalid_argument);
  EXPECT_THROW(linearRegression({1, 2, 3}, {1, 2}), std::invalid_argument);
  EXPECT_THROW(findSlowLines(x, 10.0, 0.01, 1.0, 0.01, 3), std::invalid_argument);  // non-finite sample
  const std::vector<double> ok(1000, 0.5);
  EXPECT_THROW(findSlowLines(ok, 10.0, 0.1, 0.05, 0.01, 3), std::invalid_argument);  // f_hi <= f_lo
  EXPECT_THROW(findSlowLines(ok, 10.0, 0.01, 6.0, 0.01, 3), std::invalid_argument);  // above Nyquist
  EXPECT_THROW(refineLine(ok, 10.0, 0.0, 0.1, 1.0), std::invalid_argument);
  EXPECT_THROW(fitSinusoids(x, 10.0, {0.1}), std::invalid_argument);  // non-finite sample
  EXPECT_THROW(fitSinusoids(std::vector<double>(5, 1.0), 10.0, {0.1, 0.2}), std::invalid_argument);  // too short
  EXPECT_TRUE(findSlowLines(ok, 10.0, 0.05, 0.06, 0.01, 3).empty());  // fewer than 8 bins in the band
}
