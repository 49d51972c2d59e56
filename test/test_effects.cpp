// Verifies the closed-form Allan-variance terms of effects.hpp against the overlapping AVAR of simulated data that
// contains only that effect (simulate.hpp), and against the brute-force estimator overlappingAvarAt.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <stdexcept>
#include <vector>

#include "gyro_allan/allan.hpp"
#include "gyro_allan/effects.hpp"
#include "gyro_allan/simulate.hpp"

using namespace gyro_allan;

namespace {

// Overlapping AVAR at factor m (brute force; equal to oadev^2, checked in BruteForceMatchesOadev).
double measuredAvar(const std::vector<double>& y, double /*tau0*/, int64_t m) { return overlappingAvarAt(y, m); }

}  // namespace

TEST(Effects, BruteForceMatchesOadev) {
  // The brute-force estimator used below equals the library's oadev^2 (octave grid) on the same samples.
  AxisNoise a;
  a.angle_random_walk = 1e-3;
  a.rate_random_walk = 1e-5;
  const std::vector<double> y = simulateAxis(a, 50.0, 20000, 3);
  DeviationOptions opt;
  opt.grid.kind = TauGridKind::Octave;
  opt.compute_edf = false;
  const DeviationCurve c = oadev(y, 0.02, opt);
  ASSERT_GT(c.points.size(), 5u);
  for (const auto& p : c.points) {
    const double bf = overlappingAvarAt(y, p.m);
    EXPECT_NEAR(p.var, bf, 1e-9 * bf) << "m=" << p.m;
  }
}

TEST(Effects, SinusoidMatchesSimulation) {
  // 2 Hz, 1 mrad/s amplitude sampled at 100 Hz for 600 s; the sampled-average form must match to 2 % (+1e-4 A^2
  // absolute near the zeros at integer f0 tau), the continuous form to 2 % where f0 tau0 << 1 matters little.
  AxisNoise a;
  a.sine_amplitude = 1e-3;
  a.sine_frequency = 2.0;
  const double tau0 = 0.01;
  const std::vector<double> y = simulateAxis(a, 100.0, 60000, 1);
  const double a2 = a.sine_amplitude * a.sine_amplitude;
  for (int64_t m : {1, 2, 3, 5, 7, 10, 13, 17, 25, 37, 50, 75, 100, 300, 1000}) {
    const double tau = m * tau0;
    const double meas = measuredAvar(y, tau0, m);
    const double th = a2 * sinusoidAvar(tau, a.sine_frequency, tau0);
    EXPECT_NEAR(meas, th, 0.02 * th + 1e-4 * a2) << "m=" << m;
    if (m >= 10) {
      const double cont = a2 * sinusoidAvar(tau, a.sine_frequency);
      EXPECT_NEAR(cont, th, 0.02 * th + 1e-4 * a2) << "m=" << m;
    }
  }
  // Peak of the continuous form: 0.5246 A^2 near f0 tau = 0.371.
  EXPECT_NEAR(sinusoidAvar(0.371, 1.0), 0.5246, 0.002);
}

TEST(Effects, GaussMarkovMatchesSimulation) {
  // Tc = 20 s, sigma = 1 mrad/s at 10 Hz over 40000 s (2000 correlation times): the estimator scatter is a few %
  // at tau <= 2 Tc, tolerance 12 %.
  AxisNoise a;
  a.gm_sigma = 1e-3;
  a.gm_tau = 20.0;
  const double tau0 = 0.1;
  const std::vector<double> y = simulateAxis(a, 10.0, 400000, 5);
  const double s2 = a.gm_sigma * a.gm_sigma;
  for (int64_t m : {10, 50, 100, 200, 400}) {
    const double tau = m * tau0;
    const double meas = measuredAvar(y, tau0, m);
    const double th = s2 * gaussMarkovAvar(tau, a.gm_tau);
    EXPECT_NEAR(meas, th, 0.12 * th) << "tau=" << tau;
    EXPECT_NEAR(s2 * gaussMarkovAvar(tau, a.gm_tau, tau0), th, 0.01 * th) << "discrete vs continuous, tau=" << tau;
  }
  // Limits: (2/3) tau/tc for tau << tc, 2 tc / tau for tau >> tc.
  EXPECT_NEAR(gaussMarkovAvar(1e-4, 1.0), (2.0 / 3.0) * 1e-4, 1e-7);
  EXPECT_NEAR(gaussMarkovAvar(1e4, 1.0), 2e-4, 1e-6);
}

TEST(Effects, ShortGaussMarkovNeedsSampledForm) {
  // Tc = 15 ms at 100 Hz (a sensor's internal low-pass): the sampled AR(1) form must match to 3 %; the continuous one
  // is visibly off at m = 1.
  AxisNoise a;
  a.gm_sigma = 1e-3;
  a.gm_tau = 0.015;
  const double tau0 = 0.01;
  const std::vector<double> y = simulateAxis(a, 100.0, 200000, 7);
  const double s2 = a.gm_sigma * a.gm_sigma;
  for (int64_t m : {1, 2, 3, 5, 10, 30, 100}) {
    const double meas = measuredAvar(y, tau0, m);
    const double th = s2 * gaussMarkovAvar(m * tau0, a.gm_tau, tau0);
    EXPECT_NEAR(meas, th, 0.03 * th) << "m=" << m;
  }
  EXPECT_GT(std::fabs(gaussMarkovAvar(tau0, a.gm_tau) / gaussMarkovAvar(tau0, a.gm_tau, tau0) - 1.0), 0.1);
}

TEST(Effects, BiasStepMatchesSimulation) {
  // Deterministic: 1 mrad/s step at 300 s of a 1000 s record at 10 Hz. Tolerance 1 % (sampling of the triangle),
  // including taus where 2 tau > t_step (clipped triangle) and a step near the end.
  const double tau0 = 0.1;
  for (double ts : {300.0, 900.0}) {
    AxisNoise a;
    a.step_size = 1e-3;
    a.step_time = ts;
    const std::vector<double> y = simulateAxis(a, 10.0, 10000, 1);
    for (int64_t m : {10, 100, 1000, 2000, 4000}) {
      const double tau = m * tau0;
      const double meas = measuredAvar(y, tau0, m);
      const double th = 1e-6 * biasStepAvar(tau, ts, 1000.0);
      EXPECT_NEAR(meas, th, 0.01 * th + 1e-15) << "ts=" << ts << " tau=" << tau;
    }
  }
  EXPECT_NEAR(biasStepAvar(10.0, 500.0, 1000.0), 10.0 / (3.0 * 980.0), 1e-12);
  EXPECT_EQ(biasStepAvar(600.0, 500.0, 1000.0), 0.0);
}

TEST(Effects, WarmupMatchesSimulation) {
  // 1 mrad/s warm-up with theta = 300 s over 3000 s at 10 Hz: deterministic, tolerance 2 %.
  AxisNoise a;
  a.thermal_amplitude = 1e-3;
  a.thermal_tau = 300.0;
  const double tau0 = 0.1;
  const std::vector<double> y = simulateAxis(a, 10.0, 30000, 1);
  for (int64_t m : {10, 100, 1000, 5000, 10000}) {
    const double tau = m * tau0;
    const double meas = measuredAvar(y, tau0, m);
    const double th = 1e-6 * warmupAvar(tau, a.thermal_tau, 3000.0);
    EXPECT_NEAR(meas, th, 0.02 * th) << "tau=" << tau;
  }
}

TEST(Effects, ImpulseMatchesBruteForce) {
  // One spike of 0.5 rad/s for one 10 ms sample in 1000 s: AVAR = (0.5 * 0.01)^2 / (tau (T - 2 tau)), 2 %.
  std::vector<double> y(100000, 0.0);
  y[40000] = 0.5;
  const double area2 = (0.5 * 0.01) * (0.5 * 0.01);
  for (int64_t m : {10, 100, 1000, 10000}) {
    const double tau = m * 0.01;
    EXPECT_NEAR(overlappingAvarAt(y, m), area2 * impulseAvar(tau, 1000.0), 0.02 * area2 * impulseAvar(tau, 1000.0));
  }
}

TEST(Effects, ShortCorrelationMatchesMa1) {
  // MA(1) noise y_k = e_k + 0.5 e_{k-1} (unit e): gamma_0 = 1.25, gamma_1 = 0.5, S = 2.25, M1 = 0.5;
  // AVAR(m) = S/m + M1 * shortCorrelationAvar within 1 % (2e6 samples).
  std::mt19937_64 rng(11);
  std::normal_distribution<double> nd(0.0, 1.0);
  std::vector<double> y(2000000);
  double prev = nd(rng);
  for (auto& v : y) {
    const double e = nd(rng);
    v = e + 0.5 * prev;
    prev = e;
  }
  for (int64_t m : {1, 2, 3, 5, 10, 30}) {
    const double th = 2.25 / m + 0.5 * shortCorrelationAvar(m * 0.01, 0.01);
    EXPECT_NEAR(overlappingAvarAt(y, m), th, 0.01 * th) << "m=" << m;
  }
  EXPECT_NEAR(shortCorrelationAvar(0.02, 0.01), -0.75, 1e-12);
}

TEST(Effects, SpectrumAvarEqualsSinusoidSum) {
  // spectrumAvar is sum_i 2 P_i sinusoidAvar(tau, f_i, tau0); the rotation recurrence must not drift over 3000 bins.
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double tau0 = 0.01, f_start = 3.7, df = 0.0122;
  std::vector<double> power(3000);
  for (auto& v : power) v = u(rng) - 0.1;  // some negative bins too (estimated excess)
  for (int64_t m : {1, 2, 3, 5, 7, 10, 33, 100, 1000, 100000}) {
    const double tau = m * tau0;
    double ref = 0;
    for (size_t i = 0; i < power.size(); ++i) ref += 2 * power[i] * sinusoidAvar(tau, f_start + i * df, tau0);
    EXPECT_NEAR(spectrumAvar(tau, f_start, df, power, tau0), ref, 1e-9 * std::fabs(ref) + 1e-15) << "m=" << m;
  }
  EXPECT_THROW(spectrumAvar(0.1, 0.0, df, power, tau0), std::invalid_argument);
  EXPECT_THROW(spectrumAvar(0.1, f_start, -df, power, tau0), std::invalid_argument);
}

TEST(Effects, SpectrumAvarMatchesResonanceProcess) {
  // A narrowband Gaussian process: AR(2) resonance y_k = a1 y_{k-1} + a2 y_{k-2} + e_k at 20 Hz, pole radius
  // exp(-pi 1.5 Hz tau0) (about 1.5 Hz wide), 100 Hz, 2e6 samples. Its one-sided PSD is
  // 2 tau0 / |1 - a1 z^-1 - a2 z^-2|^2 (unit e); spectrumAvar over that PSD on 0.001 Hz bins must match the
  // overlapping AVAR of the simulation within 5 sigma of the estimate, sigma^2 = 2 / EDF with the spectral EDF
  // 2 T (int S H)^2 / int (S H)^2 (H the AVAR transfer function), i.e. 1-2 % here.
  const double tau0 = 0.01, f0 = 20.0;
  const double r = std::exp(-M_PI * 1.5 * tau0);
  const double a1 = 2 * r * std::cos(2 * M_PI * f0 * tau0), a2 = -r * r;
  std::mt19937_64 rng(17);
  std::normal_distribution<double> nd(0.0, 1.0);
  std::vector<double> y(2000000);
  double y1 = 0, y2 = 0;
  for (int k = -2000; k < static_cast<int>(y.size()); ++k) {  // burn-in
    const double v = a1 * y1 + a2 * y2 + nd(rng);
    y2 = y1;
    y1 = v;
    if (k >= 0) y[static_cast<size_t>(k)] = v;
  }
  const double df = 0.001;
  std::vector<double> power;
  for (double f = df; f <= 50.0 + 1e-9; f += df) {
    const double w = 2 * M_PI * f * tau0;
    const double re = 1 - a1 * std::cos(w) - a2 * std::cos(2 * w), im = a1 * std::sin(w) + a2 * std::sin(2 * w);
    power.push_back(2 * tau0 / (re * re + im * im) * df);
  }
  const double T = y.size() * tau0;
  for (int64_t m : {1, 2, 3, 4, 5, 6, 8, 10, 20, 50, 100, 1000}) {
    const double tau = m * tau0;
    const double th = spectrumAvar(tau, df, df, power, tau0);
    // Spectral EDF of the estimate.
    double s1 = 0, s2 = 0;
    for (size_t i = 0; i < power.size(); ++i) {
      const double f = (i + 1) * df;
      const double h = 2 * std::pow(std::sin(M_PI * f * tau), 4) / std::pow(m * std::sin(M_PI * f * tau0), 2);
      s1 += power[i] * h;
      s2 += power[i] * h * power[i] * h / df;
    }
    const double edf = 2 * T * s1 * s1 / s2;
    EXPECT_NEAR(overlappingAvarAt(y, m), th, 5 * std::sqrt(2 / edf) * th) << "m=" << m << " edf=" << edf;
  }
}

TEST(Effects, BadInputThrows) {
  EXPECT_THROW(sinusoidAvar(0.0, 1.0), std::invalid_argument);
  EXPECT_THROW(sinusoidAvar(1.0, -1.0), std::invalid_argument);
  EXPECT_THROW(gaussMarkovAvar(1.0, 0.0), std::invalid_argument);
  EXPECT_THROW(biasStepAvar(1.0, 1.0, 0.0), std::invalid_argument);
  EXPECT_THROW(warmupAvar(1.0, std::nan(""), 10.0), std::invalid_argument);
  EXPECT_THROW(overlappingAvarAt({1.0, 2.0, 3.0}, 0), std::invalid_argument);
}
