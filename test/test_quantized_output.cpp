// detectQuantizedOutput: lattice and undithered-sawtooth recognition on simulated RLG (dithered and not), MEMS LSB
// rounding, and plain float noise; also through the bag reader's float32 compact storage.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "gyro_allan/compact_series.hpp"
#include "gyro_allan/quantized_output.hpp"
#include "gyro_allan/simulate.hpp"

using namespace gyro_allan;

namespace {

const double kDegPerHour = M_PI / 180.0 / 3600.0;  // rad/s
const double kArcsec = M_PI / 180.0 / 3600.0;       // rad

/// The seed study's RLG: Q = 0.35 arcsec, N = 0.001 deg/sqrt(h), 400 Hz; 10 min.
AxisNoise rlg(bool dither, double input_deg_h, double bias_deg_h) {
  AxisNoise a;
  a.quantization = 0.35 * kArcsec;
  a.dither = dither;
  a.angle_random_walk = 0.001 * M_PI / 180.0 / 60.0;
  a.input_rate = input_deg_h * kDegPerHour;
  a.bias = bias_deg_h * kDegPerHour;
  return a;
}

/// The bundled bag's MEMS gyro: N = 2e-4 rad/sqrt(s), B = 2e-5 rad/s at 100 Hz, rates rounded to 1e-4 rad/s (the
/// white noise spans about 20 LSB per sigma).
AxisNoise mems() {
  AxisNoise a;
  a.angle_random_walk = 2e-4;
  a.bias_instability = 2e-5;
  a.bias = 3.3e-3;
  a.rate_lsb = 1e-4;
  return a;
}

/// Through analyze_bag's storage: float32 relative to a per-block double reference.
std::vector<double> compact(const std::vector<double>& x) {
  CompactSeries c;
  for (double v : x) c.push_back(v);
  return c.toVector();
}

}  // namespace

TEST(QuantizedOutput, DitheredRlgIsNotOnALatticeAndNoSawtooth) {
  const double tau0 = 1.0 / 400;
  const std::vector<double> r = simulateAxis(rlg(true, 10, 0.2), 400, 240000, 1);
  const QuantizedOutput q = detectQuantizedOutput(r, tau0);
  EXPECT_FALSE(q.quantized) << q.summary;
  EXPECT_FALSE(q.sawtooth) << q.summary;
  EXPECT_LT(q.fraction_on_lattice, 0.5) << q.summary;
}

TEST(QuantizedOutput, UnditheredRlgIsQuantizedWithSawtoothAtTheInputsPulseRate) {
  const double tau0 = 1.0 / 400;
  const AxisNoise base = rlg(false, 0, 0);
  const double pulse = base.quantization * std::sqrt(12.0);
  for (double input : {5.0, 10.0, 15.0}) {
    const AxisNoise a = rlg(false, input, 0.2);
    for (int stored = 0; stored < 2; ++stored) {
      std::vector<double> r = simulateAxis(a, 400, 240000, 2 + static_cast<int>(input));
      if (stored) r = compact(r);
      const QuantizedOutput q = detectQuantizedOutput(r, tau0);
      SCOPED_TRACE(std::to_string(input) + " deg/h" + (stored ? ", compact storage" : "") + ": " + q.summary);
      EXPECT_TRUE(q.quantized);
      EXPECT_GE(q.fraction_on_lattice, 0.999);
      EXPECT_NEAR(q.pulse_weight / pulse, 1.0, 1e-6);
      EXPECT_NEAR(q.quantum_rate, pulse / tau0, 1e-6 * pulse / tau0);
      EXPECT_EQ(q.offset, 0.0);
      EXPECT_TRUE(q.sawtooth);
      const double declared = std::fabs(a.input_rate + a.bias) / pulse;
      EXPECT_NEAR(q.sawtooth_hz / declared, 1.0, 0.02);
      EXPECT_GT(q.line_to_floor, 100.0);
      EXPECT_FALSE(q.summary.empty());
    }
  }
}

TEST(QuantizedOutput, UnditheredRlgAtZeroInputIsQuantizedButShowsNoPattern) {
  // No input and no bias: the angle is a slow random walk, a pulse now and then in either direction; the mean count
  // is ~0 and no periodic pattern can be seen in the record.
  const double tau0 = 1.0 / 400;
  const AxisNoise a = rlg(false, 0, 0);
  const std::vector<double> r = simulateAxis(a, 400, 240000, 5);
  const QuantizedOutput q = detectQuantizedOutput(r, tau0);
  EXPECT_TRUE(q.quantized) << q.summary;
  EXPECT_NEAR(q.pulse_weight / (a.quantization * std::sqrt(12.0)), 1.0, 1e-6) << q.summary;
  EXPECT_FALSE(q.sawtooth) << q.summary;
}

TEST(QuantizedOutput, MemsLsbRoundingIsALatticeButNotASawtooth) {
  const double tau0 = 1.0 / 100;
  for (int stored = 0; stored < 2; ++stored) {
    std::vector<double> r = simulateAxis(mems(), 100, 60000, 7);
    if (stored) r = compact(r);
    const QuantizedOutput q = detectQuantizedOutput(r, tau0);
    SCOPED_TRACE(q.summary);
    EXPECT_TRUE(q.quantized);
    EXPECT_NEAR(q.quantum_rate / 1e-4, 1.0, 1e-6);
    EXPECT_GE(q.fraction_on_lattice, 0.999);
    EXPECT_GT(q.levels, 50);
    EXPECT_FALSE(q.sawtooth);
    EXPECT_LT(q.two_level_fraction, 0.2);
  }
}

TEST(QuantizedOutput, CoarseMemsRoundingWithFewLevelsIsWhiteNotSawtooth) {
  // Noise of 0.3 LSB about a mean 0.3 LSB above a level: two levels nearly always, as an undithered counter, but
  // the rounding of independent samples makes no periodic pattern (the sawtooth test runs and finds no line).
  const double tau0 = 1.0 / 200, lsb = 1e-3;
  std::mt19937_64 rng(3);
  std::normal_distribution<double> n(0.0, 0.3 * lsb);
  std::vector<double> r(200000);
  for (double& x : r) x = std::round((0.3 * lsb + n(rng)) / lsb) * lsb;
  const QuantizedOutput q = detectQuantizedOutput(r, tau0);
  EXPECT_TRUE(q.quantized) << q.summary;
  EXPECT_GE(q.two_level_fraction, 0.9) << q.summary;
  EXPECT_GT(q.line_to_floor, 0.0) << q.summary;  // tested
  EXPECT_LT(q.line_to_floor, 5.0) << q.summary;
  EXPECT_FALSE(q.sawtooth) << q.summary;
}

TEST(QuantizedOutput, LatticeWithAnOffset) {
  // A driver that subtracts a calibrated bias from counts * LSB: still a lattice, offset by that bias.
  std::vector<double> r = simulateAxis(mems(), 100, 60000, 8);
  for (double& x : r) x -= 0.37e-4;
  const QuantizedOutput q = detectQuantizedOutput(r, 0.01);
  EXPECT_TRUE(q.quantized) << q.summary;
  EXPECT_NEAR(q.quantum_rate / 1e-4, 1.0, 1e-6) << q.summary;
  EXPECT_NEAR(std::fabs(q.offset), 0.37e-4, 1e-9) << q.summary;
}

TEST(QuantizedOutput, PlainFloatNoiseIsNotQuantized) {
  std::mt19937_64 rng(4);
  std::normal_distribution<double> n(1e-3, 2e-3);
  std::vector<double> r(200000);
  for (double& x : r) x = n(rng);
  const QuantizedOutput q = detectQuantizedOutput(r, 0.01);
  EXPECT_FALSE(q.quantized) << q.summary;
  EXPECT_FALSE(q.sawtooth);
  // The same noise through float32 (a float driver, or the bag reader's storage) is not a lattice either.
  std::vector<double> f(r.size());
  for (size_t i = 0; i < r.size(); ++i) f[i] = static_cast<float>(r[i]);
  EXPECT_FALSE(detectQuantizedOutput(f, 0.01).quantized) << detectQuantizedOutput(f, 0.01).summary;
  EXPECT_FALSE(detectQuantizedOutput(compact(r), 0.01).quantized);
  // Simulated without any rounding (dithered RLG aside): an ARW + flicker gyro.
  AxisNoise a = mems();
  a.rate_lsb = 0;
  EXPECT_FALSE(detectQuantizedOutput(simulateAxis(a, 100, 60000, 9), 0.01).quantized);
}

TEST(QuantizedOutput, DegenerateInputs) {
  EXPECT_FALSE(detectQuantizedOutput(std::vector<double>(10, 1.0), 0.01).quantized);
  const QuantizedOutput c = detectQuantizedOutput(std::vector<double>(1000, 2e-3), 0.01);
  EXPECT_FALSE(c.quantized);
  EXPECT_FALSE(c.summary.empty());
  EXPECT_FALSE(detectQuantizedOutput(std::vector<double>(1000, 2e-3), 0.0).quantized);
  // The longest segment is the one judged.
  std::vector<std::vector<double>> segs = {std::vector<double>(100, 0.0), simulateAxis(mems(), 100, 20000, 10)};
  EXPECT_TRUE(detectQuantizedOutput(segs, 0.01).quantized);
}
