// Tests of the gyro simulator: determinism, and each declared term's Allan variance against its IEEE 952 formula.
#include <gtest/gtest.h>

#include <cmath>

#include "gyro_allan/allan.hpp"
#include "gyro_allan/noise_model.hpp"
#include "gyro_allan/simulate.hpp"

using namespace gyro_allan;

namespace {
double avarAt(const std::vector<double>& y, double tau0, int64_t m) {
  DeviationOptions o;
  o.grid.kind = TauGridKind::Octave;
  for (const auto& p : oadev(y, tau0, o).points)
    if (p.m == m) return p.var;
  return NAN;
}
}  // namespace

TEST(Simulate, DeterministicBySeed) {
  AxisNoise a;
  a.angle_random_walk = 1e-3;
  a.bias_instability = 1e-4;
  a.rate_random_walk = 1e-5;
  const auto y1 = simulateAxis(a, 100, 5000, 42, 0);
  const auto y2 = simulateAxis(a, 100, 5000, 42, 0);
  const auto y3 = simulateAxis(a, 100, 5000, 43, 0);
  const auto y4 = simulateAxis(a, 100, 5000, 42, 1);
  EXPECT_EQ(y1, y2);
  EXPECT_NE(y1, y3);
  EXPECT_NE(y1, y4);
}

TEST(Simulate, WhiteNoiseGivesArw) {
  AxisNoise a;
  a.angle_random_walk = 1e-3;
  const double tau0 = 0.01;
  const auto y = simulateAxis(a, 100, 400000, 1, 0);
  // AVAR(tau) = N^2/tau; at m = 16 the EDF is ~ 4e5*... >> 1e3, so 5 % is > 5 sigma.
  EXPECT_NEAR(avarAt(y, tau0, 16) / (1e-6 / (16 * tau0)), 1.0, 0.05);
}

TEST(Simulate, DitheredQuantizationIsWhitePhaseNoise) {
  AxisNoise a;
  a.quantization = 1e-5;  // rad
  a.input_rate = 0.01;    // a constant input must not matter with dither
  const double tau0 = 0.01;
  const auto y = simulateAxis(a, 100, 200000, 3, 0);
  for (int64_t m : {1, 4, 64}) EXPECT_NEAR(avarAt(y, tau0, m) / (3e-10 / std::pow(m * tau0, 2)), 1.0, 0.03) << m;
  // Output angle increments are multiples of the pulse weight only without dither.
  a.dither = false;
  const auto z = simulateAxis(a, 100, 1000, 3, 0);
  const double q = 1e-5 * std::sqrt(12.0);
  for (double v : z) EXPECT_NEAR(std::remainder(v * tau0, q), 0.0, 1e-12);
}

TEST(Simulate, FlickerHasIeeePlateau) {
  // Plateau (2 ln2/pi) B^2 at mid taus; a single realisation scatters, so average 4 seeds and allow 15 %.
  const double b = 1e-4, tau0 = 0.01;
  double sum = 0;
  for (uint64_t s = 1; s <= 4; ++s) sum += avarAt(flickerNoise(200000, b, s), tau0, 64);
  EXPECT_NEAR((sum / 4) / (2 * std::log(2.0) / M_PI * b * b), 1.0, 0.15);
}

TEST(Simulate, RateRandomWalkSlope) {
  AxisNoise a;
  a.rate_random_walk = 1e-4;
  const double tau0 = 0.01;
  double sum = 0;
  for (uint64_t s = 1; s <= 4; ++s) sum += avarAt(simulateAxis(a, 100, 200000, s, 0), tau0, 256);
  EXPECT_NEAR((sum / 4) / (1e-8 * 256 * tau0 / 3), 1.0, 0.25);
}

TEST(Simulate, EffectsAndLsb) {
  AxisNoise a;
  a.step_size = 0.5;
  a.step_time = 1.0;
  a.rate_lsb = 0.25;
  const auto y = simulateAxis(a, 10, 20, 1, 0);
  EXPECT_EQ(y[0], 0.0);
  EXPECT_EQ(y[19], 0.5);
  SimulationSpec spec;
  spec.rate_hz = 10;
  spec.duration_s = 100;
  spec.temperature = true;
  spec.axes[0].thermal_amplitude = 1e-3;
  spec.axes[0].thermal_tau = 20;
  const auto d = simulate(spec);
  ASSERT_EQ(d.temperature.size(), 1000u);
  EXPECT_NEAR(d.temperature.front(), 25.0, 0.1);
  EXPECT_NEAR(d.temperature.back(), 25.0 + 10.0 * (1 - std::exp(-99.95 / 20)), 0.1);
}

TEST(Simulate, RejectsAbsurdSpecs) {
  AxisNoise a;
  EXPECT_THROW(simulateAxis(a, 0, 10, 1), std::invalid_argument);
  EXPECT_THROW(simulateAxis(a, -5, 10, 1), std::invalid_argument);
  a.angle_random_walk = -1;
  EXPECT_THROW(simulateAxis(a, 100, 10, 1), std::invalid_argument);
  a.angle_random_walk = NAN;
  EXPECT_THROW(simulateAxis(a, 100, 10, 1), std::invalid_argument);
  SimulationSpec s;
  s.duration_s = 0;
  EXPECT_THROW(simulate(s), std::invalid_argument);
}
