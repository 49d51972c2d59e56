// Angle input in the core (issue 15): the rates from the angle's differences give the angle's Allan variance, and
// the wavelet split and the model check run on them as for rate input.
#include <gtest/gtest.h>

#include "series_util.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "gyro_allan/allan.hpp"
#include "gyro_allan/analysis.hpp"
#include "gyro_allan/simulate.hpp"

namespace {

using namespace gyro_allan;
using gyro_allan_test::accumulatedAngle;


void expectSameCurve(const DeviationCurve& a, const DeviationCurve& b, double rel) {
  ASSERT_EQ(a.points.size(), b.points.size());
  ASSERT_FALSE(a.points.empty());
  for (size_t i = 0; i < a.points.size(); ++i) {
    EXPECT_EQ(a.points[i].m, b.points[i].m) << i;
    EXPECT_NEAR(a.points[i].var / b.points[i].var, 1.0, rel) << "m = " << a.points[i].m;
  }
}

TEST(AngleToRate, AccumulatedGivesDifferencesIncrementsAreScaled) {
  std::vector<double> theta{1.0, 1.5, 1.25, 2.0};
  angleToRate(&theta, 0.5, false);
  EXPECT_EQ(theta, (std::vector<double>{1.0, -0.5, 1.5}));
  std::vector<double> inc{0.5, -0.25, 0.75};
  angleToRate(&inc, 0.5, true);
  EXPECT_EQ(inc, (std::vector<double>{1.0, -0.5, 1.5}));
  std::vector<double> one{3.0};
  angleToRate(&one, 0.5, false);
  EXPECT_TRUE(one.empty());
}

// MEMS-like noise (ARW + RRW + bias), 100 Hz, 30 min: the oadev of accumulated-angle and increment input is that of
// the rate they came from, and that of the angle as phase data (the old angle path), to 1e-12 relative.
TEST(AngleInput, SameAllanVarianceAsTheRate) {
  AxisNoise noise;
  noise.angle_random_walk = 1e-3;
  noise.rate_random_walk = 2e-5;
  noise.bias = 3e-3;
  const double hz = 100, tau0 = 1 / hz;
  const std::vector<double> rate = simulateAxis(noise, hz, 180000, 7);
  const std::vector<double> theta = accumulatedAngle(rate, tau0);
  std::vector<double> inc(rate.size());
  for (size_t k = 0; k < rate.size(); ++k) inc[k] = rate[k] * tau0;

  AnalysisOptions ro;
  ro.remove_spikes = false;  // only rate input has spike removal: compare like with like
  ro.deviations = {"oadev", "mdev", "ohdev"};
  const AxisAnalysis r = analyzeAxis("x", {rate}, tau0, ro);
  AnalysisOptions ao = ro;
  ao.input = InputKind::Angle;
  const AxisAnalysis a = analyzeAxis("x", {theta}, tau0, ao);
  ao.angle_increments = true;
  const AxisAnalysis i = analyzeAxis("x", {inc}, tau0, ao);

  EXPECT_EQ(a.samples, r.samples);
  EXPECT_EQ(i.samples, r.samples);
  expectSameCurve(a.oadev, r.oadev, 1e-12);
  expectSameCurve(i.oadev, r.oadev, 1e-12);
  for (size_t c = 0; c < r.curves.size(); ++c) {
    expectSameCurve(a.curves[c], r.curves[c], 1e-12);
    expectSameCurve(i.curves[c], r.curves[c], 1e-12);
  }
  // The angle as phase data, as the angle path computed it before the conversion.
  expectSameCurve(a.oadev, computeDeviation("oadev", theta, InputKind::Angle, tau0, ro.deviation), 1e-12);
  EXPECT_NEAR(a.mean / r.mean, 1.0, 1e-9);  // the mean rate, not the mean angle

  // The model check ran on the angle input too (no "skipped" note), with the rate input's answers; the split is not
  // run for any of them (no quantization here, so it cannot answer).
  EXPECT_FALSE(r.has_split) << r.method_reason;
  EXPECT_NE(r.method_reason.find("% of the Allan variance at the shortest tau"), std::string::npos) << r.method_reason;
  for (const AxisAnalysis* x : {&a, &i}) {
    EXPECT_EQ(x->has_split, r.has_split);
    EXPECT_EQ(x->method_reason, r.method_reason);
    EXPECT_TRUE(x->has_check) << x->check.message;
    EXPECT_EQ(x->method, r.method);
    for (const auto& n : x->notes) EXPECT_EQ(n.find("skipped"), std::string::npos) << n;
    for (int t = 0; t < kNumTerms; ++t) {
      EXPECT_EQ(x->coefficients[t].supported, r.coefficients[t].supported) << t;
      if (r.coefficients[t].supported) {
        EXPECT_NEAR(x->coefficients[t].value / r.coefficients[t].value, 1.0, 1e-8) << t;
      }
    }
  }
}

// The undithered ring-laser gyro of test_cli_outputs (Q = 1.6968e-6 rad, N = 2.909e-7 rad/sqrt(s), 400 Hz, 10 min,
// 4.848e-5 rad/s input, no dither) given as its accumulated angle: the split answers Q within 5 % and N within
// 10 %, as from the rate, and the quantized-output detector sees the sawtooth in the rates from the angle.
TEST(AngleInput, UnditheredRlgSplitFromAngle) {
  AxisNoise noise;
  noise.quantization = 1.6968e-6;
  noise.dither = false;
  noise.angle_random_walk = 2.909e-7;
  noise.input_rate = 4.848e-5;
  const double hz = 400, tau0 = 1 / hz;
  const std::vector<double> rate = simulateAxis(noise, hz, 240000, 3);
  const std::vector<double> theta = accumulatedAngle(rate, tau0);
  AnalysisOptions ro;
  ro.remove_spikes = false;
  const AxisAnalysis r = analyzeAxis("x", {rate}, tau0, ro);
  AnalysisOptions ao = ro;
  ao.input = InputKind::Angle;
  const AxisAnalysis a = analyzeAxis("x", {theta}, tau0, ao);
  ASSERT_TRUE(a.has_split);
  ASSERT_TRUE(a.split.ok) << a.split.message;
  EXPECT_NEAR(a.split.terms[kQuantization].value / 1.6968e-6, 1.0, 0.05);
  EXPECT_NEAR(a.split.terms[kAngleRandomWalk].value / 2.909e-7, 1.0, 0.10);
  EXPECT_TRUE(a.has_check) << a.check.message;
  EXPECT_TRUE(a.quantized.quantized);
  EXPECT_TRUE(a.quantized.sawtooth);
  // A detected sawtooth pulse count: the split's Q and N come from the sawtooth bootstrap, seeded the same for the
  // rate and the angle input (their rates differ in the last bits only).
  EXPECT_TRUE(a.split.sawtooth_bootstrap.applied) << a.split.sawtooth_bootstrap.note;
  EXPECT_TRUE(r.split.sawtooth_bootstrap.applied) << r.split.sawtooth_bootstrap.note;
  // ... and the axis's notes say so.
  EXPECT_TRUE(std::any_of(a.notes.begin(), a.notes.end(),
                          [](const std::string& n) { return n.find("parametric bootstrap") != std::string::npos; }));
  EXPECT_EQ(a.method, Method::WaveletSplit) << a.method_reason;
  EXPECT_EQ(a.method, r.method);
  for (int t : {kQuantization, kAngleRandomWalk})
    EXPECT_NEAR(a.coefficients[t].value / r.coefficients[t].value, 1.0, 1e-6) << t;
  expectSameCurve(a.oadev, r.oadev, 1e-12);
}

// Several gap-free segments: each accumulated segment loses one point to the differences, and a segment of one
// point is dropped, not an error.
TEST(AngleInput, SegmentsEachLoseOnePoint) {
  AxisNoise noise;
  noise.angle_random_walk = 1e-3;
  const double tau0 = 0.01;
  const std::vector<double> r1 = simulateAxis(noise, 100, 20000, 1), r2 = simulateAxis(noise, 100, 30000, 2);
  AnalysisOptions ao;
  ao.input = InputKind::Angle;
  ao.wavelet_split = false;
  ao.model_check = false;
  const AxisAnalysis a = analyzeAxis("x", {accumulatedAngle(r1, tau0), {5.0}, accumulatedAngle(r2, tau0)}, tau0, ao);
  EXPECT_EQ(a.samples, 50000);
  EXPECT_EQ(a.segments, 2);
  AnalysisOptions ro;
  ro.remove_spikes = false;
  ro.wavelet_split = false;
  ro.model_check = false;
  const AxisAnalysis r = analyzeAxis("x", {r1, r2}, tau0, ro);
  expectSameCurve(a.oadev, r.oadev, 1e-12);
}

}  // namespace
