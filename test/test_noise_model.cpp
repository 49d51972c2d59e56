// Tests of the IEEE 952 noise-model fit: exact recovery from model curves, unsupported terms, and recovery of declared
// coefficients from simulated gyros (tolerances from the acceptance criteria and the reported sigmas).
#include <gtest/gtest.h>

#include <bitset>
#include <cmath>
#include <cstdio>

#include "gyro_allan/allan.hpp"
#include "gyro_allan/analysis.hpp"
#include "gyro_allan/model_check.hpp"
#include "gyro_allan/noise_model.hpp"
#include "gyro_allan/quality.hpp"
#include "gyro_allan/simulate.hpp"

using namespace gyro_allan;

namespace {

DeviationCurve modelCurve(const std::array<double, kNumTerms>& coef, double tau0, int64_t n_phase, double edf) {
  DeviationCurve c;
  c.name = "oadev";
  c.tau0 = tau0;
  c.n_phase = n_phase;
  TauGrid g;
  for (int64_t m : tauGridFactors(g, (n_phase - 1) / 2)) {
    DeviationPoint p;
    p.m = m;
    p.tau = m * tau0;
    for (int t = 0; t < kNumTerms; ++t) p.var += coef[t] * coef[t] * noiseTermBasis(t, p.tau, tau0);
    p.dev = std::sqrt(p.var);
    p.edf = edf;
    c.points.push_back(p);
  }
  return c;
}

constexpr double kArcsec = M_PI / 180.0 / 3600.0;

}  // namespace

TEST(NoiseModel, RecoversExactModelCurve) {
  const std::array<double, kNumTerms> truth{{1e-6, 2e-4, 2e-5, 2e-6, 1e-8}};
  // Huge EDF: every term is significant, so the fit must return the truth to rounding.
  const DeviationCurve c = modelCurve(truth, 0.0025, 1440001, 1e9);
  const FitResult f = fitNoiseModel(c);
  ASSERT_TRUE(f.ok) << f.message;
  for (int t = 0; t < kNumTerms; ++t) {
    EXPECT_TRUE(f.terms[t].supported) << noiseTermKey(t);
    EXPECT_NEAR(f.terms[t].value / truth[t], 1.0, 1e-6) << noiseTermKey(t);
    EXPECT_GT(f.terms[t].sigma, 0.0);
  }
  EXPECT_LT(f.rms_log10, 1e-8);
  EXPECT_LT(f.chi2_dof, 1e-10);
}

// The sampled flicker's Allan variance over its floor, against an independent computation: the spectral integral
// AVAR(m) = 2 int_0^1/2 S(f) 2 sin^4(pi m f) / (m^2 sin^2(pi f)) df of Kasdin's 1/f noise, S(f) = 1 / (2 sin(pi f))
// (unit white input, f in cycles per sample), over (2 ln2 / pi); midpoint rule on 400000 cells. Beyond 512 samples
// the excess (2e-6 at 1024) is checked to 2e-6 (the midpoint rule's own error there is ~1e-6).
TEST(NoiseModel, FlickerShapeMatchesItsSpectralIntegral) {
  for (int m : {1, 2, 3, 4, 8, 16, 64, 512, 1024}) {  // 1024: beyond the table, its 1/m^2 tail
    const int cells = 400000;
    double s = 0;
    for (int i = 0; i < cells; ++i) {
      const double f = (i + 0.5) / cells * 0.5;
      const double sf = std::sin(M_PI * f);
      s += 2.0 * std::pow(std::sin(M_PI * m * f), 4) / (static_cast<double>(m) * m * sf * sf) / (2.0 * sf);
    }
    const double avar = 2.0 * s * 0.5 / cells;
    EXPECT_NEAR(flickerAvarShape(m), avar / (2.0 * std::log(2.0) / M_PI), m < 512 ? 2e-5 : 2e-6) << "m = " << m;
  }
  EXPECT_NEAR(flickerAvarShape(1), 1.0 / std::log(2.0), 1e-12);  // AVAR(1) = 2 / pi exactly
  EXPECT_NEAR(flickerAvarShape(1e6), 1.0, 1e-9);
  // The column: the shape at tau / tau0 samples; without a sampling interval (tau0 0) the long-tau floor.
  EXPECT_NEAR(noiseTermBasis(kBiasInstability, 0.02, 0.01) / noiseTermBasis(kBiasInstability, 0.02), flickerAvarShape(2), 1e-12);
  EXPECT_DOUBLE_EQ(noiseTermBasis(kBiasInstability, 0.02, 0.0), noiseTermBasis(kBiasInstability, 0.02));
  EXPECT_DOUBLE_EQ(noiseTermBasis(kAngleRandomWalk, 0.02, 0.01), noiseTermBasis(kAngleRandomWalk, 0.02));
}

TEST(NoiseModel, WeakTermIsDroppedWithBoundCoveringIt) {
  // Same model with EDF 1000: Q is ~3 % of the AVAR at the shortest tau, below the 1-sigma significance; it must be
  // reported as unsupported with a bound that covers its true value within 2 bounds, and N must stay accurate.
  const std::array<double, kNumTerms> truth{{1e-6, 2e-4, 2e-5, 2e-6, 1e-8}};
  const FitResult f = fitNoiseModel(modelCurve(truth, 0.0025, 1440001, 1000.0));
  ASSERT_TRUE(f.ok);
  for (int t = 0; t < kNumTerms; ++t)
    if (!f.terms[t].supported) {
      EXPECT_LE(truth[t], 2 * f.terms[t].sigma) << noiseTermKey(t);
    }
  EXPECT_NEAR(f.terms[kAngleRandomWalk].value / 2e-4, 1.0, 0.01);
}

TEST(NoiseModel, AbsentTermIsZeroWithBound) {
  // White noise + rate random walk only: Q, B and R must come out as zero (unsupported) with a positive bound.
  const std::array<double, kNumTerms> truth{{0, 2e-4, 0, 2e-6, 0}};
  const FitResult f = fitNoiseModel(modelCurve(truth, 0.0025, 1440001, 200.0));
  ASSERT_TRUE(f.ok);
  for (int t : {kQuantization, kBiasInstability, kRateRamp}) {
    EXPECT_FALSE(f.terms[t].supported) << noiseTermKey(t);
    EXPECT_EQ(f.terms[t].value, 0.0) << noiseTermKey(t);
    EXPECT_GT(f.terms[t].sigma, 0.0) << noiseTermKey(t);
  }
  EXPECT_NEAR(f.terms[kAngleRandomWalk].value / 2e-4, 1.0, 1e-6);
  EXPECT_NEAR(f.terms[kRateRandomWalk].value / 2e-6, 1.0, 1e-6);
}

TEST(NoiseModel, DisabledTermsStayZero) {
  const std::array<double, kNumTerms> truth{{0, 2e-4, 2e-5, 0, 0}};
  FitOptions o;
  o.enabled = {{false, true, false, false, false}};
  const FitResult f = fitNoiseModel(modelCurve(truth, 0.01, 100001, 100.0), o);
  ASSERT_TRUE(f.ok);
  EXPECT_EQ(f.terms[kBiasInstability].value, 0.0);
  EXPECT_GT(f.rms_log10, 0.01);  // the model cannot describe the flicker floor: the error says so
}

TEST(NoiseModel, ExtraTermJoinsTheFit) {
  const std::array<double, kNumTerms> truth{{0, 1e-3, 0, 0, 0}};
  DeviationCurve c = modelCurve(truth, 0.01, 1000001, 500.0);
  const double f0 = 0.5, amp = 3e-3;
  auto sine = [f0](double tau) {
    const double x = M_PI * f0 * tau;
    return std::pow(std::sin(x) * std::sin(x) / x, 2);
  };
  for (auto& p : c.points) {
    p.var += amp * amp * sine(p.tau);
    p.dev = std::sqrt(p.var);
  }
  const FitResult plain = fitNoiseModel(c);
  const FitResult with = fitNoiseModel(c, FitOptions{}, {{"sinusoid", sine}});
  ASSERT_TRUE(with.ok);
  ASSERT_EQ(with.extra.size(), 1u);
  EXPECT_NEAR(with.extra[0].value / amp, 1.0, 1e-6);
  EXPECT_NEAR(with.terms[kAngleRandomWalk].value / 1e-3, 1.0, 1e-6);
  EXPECT_LT(with.rms_log10, plain.rms_log10 / 100);
}

TEST(NoiseModel, TooFewPointsIsNotOk) {
  DeviationCurve c;
  c.n_phase = 5;
  DeviationPoint p;
  p.tau = 1;
  p.m = 1;
  p.var = 1;
  p.edf = 10;
  c.points.push_back(p);
  const FitResult f = fitNoiseModel(c);
  EXPECT_FALSE(f.ok);
  EXPECT_FALSE(f.message.empty());
}

// Worst relative error of a fit's model ADEV against the truth's over tau in [10/fs, T/10] (60 log-spaced taus).
double worstAdevError(const FitResult& f, const AxisNoise& truth, double fs, double duration_s) {
  FitResult t = f;
  const double v[kNumTerms] = {truth.quantization, truth.angle_random_walk, truth.bias_instability,
                               truth.rate_random_walk, truth.rate_ramp};
  for (int k = 0; k < kNumTerms; ++k) t.terms[static_cast<size_t>(k)].value = v[k];
  double worst = 0;
  for (int i = 0; i < 60; ++i) {
    const double tau = (10.0 / fs) * std::pow(duration_s / 100.0 * fs, i / 59.0);
    worst = std::max(worst, std::fabs(std::sqrt(modelVariance(f, tau) / modelVariance(t, tau)) - 1.0));
  }
  return worst;
}

// 1 h, 400 Hz MEMS-like gyro, N = 2e-4 rad/sqrt(s), B = 2e-5 rad/s, K = 2e-6 rad/s/sqrt(s), two seeds x 3 axes:
// N within 3 %, the model's ADEV within 50 % of the truth's over tau in [10/fs, T/10] on every axis (the line past
// which a model counts as badly off; the 25 % target is a study figure, docs/validation.md), B inside its
// 95 % interval on at least 5 of 6 (at nominal 95 %, 2 or more misses of 6 happen 3 % of the time). K beside B is
// near its detection limit here and its 95 % interval under-covers there (0.90 on the study, docs/fit.md "Limits"):
// its misses are printed, not asserted.
TEST(NoiseModel, RecoversMemsCoefficientsFromSimulation) {
  AxisNoise a;
  a.angle_random_walk = 2e-4;
  a.bias_instability = 2e-5;
  a.rate_random_walk = 2e-6;
  int miss_b = 0, miss_k = 0;
  for (uint64_t seed : {11u, 12u}) {
    for (int axis = 0; axis < 3; ++axis) {
      const std::vector<double> y = simulateAxis(a, 400.0, 1440000, seed, axis);
      const FitResult f = analyzeAxis("x", {y}, 1.0 / 400.0, AnalysisOptions{}).fit;
      ASSERT_TRUE(f.ok);
      EXPECT_NEAR(f.terms[kAngleRandomWalk].value / 2e-4, 1.0, 0.03) << "seed " << seed << " axis " << axis;
      const double worst = worstAdevError(f, a, 400.0, 3600.0);
      EXPECT_LE(worst, 0.5) << "seed " << seed << " axis " << axis;
      const auto& b = f.terms[kBiasInstability];
      const auto& k = f.terms[kRateRandomWalk];
      std::printf("seed %d axis %d: B %.3g [%.3g, %.3g]%s, K %.3g [%.3g, %.3g]%s, model ADEV worst error %.3f\n",
                  static_cast<int>(seed), axis, b.value, b.lo95, b.hi95, b.supported ? "" : " (not supported)", k.value,
                  k.lo95, k.hi95, k.supported ? "" : " (not supported)", worst);
      if (!(b.lo95 <= 2e-5 && 2e-5 <= b.hi95)) ++miss_b;
      if (!(k.lo95 <= 2e-6 && 2e-6 <= k.hi95)) ++miss_k;
    }
  }
  EXPECT_LE(miss_b, 1);
  std::printf("K's 95 %% interval misses the truth on %d of 6 axes\n", miss_k);
}

// Acceptance: RLG-like, Q = 0.35 arcsec with dither, N = 0.001 deg/sqrt(h), 400 Hz, 2 h: Q within 3 %, N within 10 %.
TEST(NoiseModel, RecoversRlgCoefficientsFromSimulation) {
  AxisNoise a;
  a.quantization = 0.35 * kArcsec;
  a.dither = true;
  a.angle_random_walk = 0.001 * M_PI / 180.0 / 60.0;
  for (uint64_t seed : {5u, 6u}) {
    const std::vector<double> y = simulateAxis(a, 400.0, 2 * 3600 * 400, seed, 0);
    const FitResult f = analyzeAxis("x", {y}, 1.0 / 400.0, AnalysisOptions{}).fit;
    ASSERT_TRUE(f.ok);
    EXPECT_NEAR(f.terms[kQuantization].value / a.quantization, 1.0, 0.03) << "seed " << seed;
    EXPECT_NEAR(f.terms[kAngleRandomWalk].value / a.angle_random_walk, 1.0, 0.10) << "seed " << seed;
  }
}

// FitOptions::intervals off (the model check's trial fits) changes nothing but the intervals: the same values,
// statistics and model curve, and NaN (not a plausible number) where the intervals were left out.
TEST(NoiseModel, ValuesOnlyFitHasTheSameValuesAndNoIntervals) {
  AxisNoise a;
  a.angle_random_walk = 2e-4;
  a.bias_instability = 2e-5;
  a.rate_random_walk = 3e-7;
  for (uint64_t seed : {3u, 4u, 5u}) {
    const std::vector<double> y = simulateAxis(a, 200.0, 360000, seed);
    const DeviationCurve c = computeDeviation("oadev", y, InputKind::Rate, 1.0 / 200.0, DeviationOptions{});
    FitOptions with, without;
    without.intervals = false;
    const FitResult f = fitNoiseModel(c, with), g = fitNoiseModel(c, without);
    ASSERT_TRUE(f.ok && g.ok) << f.message << g.message;
    ASSERT_TRUE(f.gls);  // the option belongs to the covariance-weighted fit
    EXPECT_TRUE(f.intervals);
    EXPECT_FALSE(g.intervals);
    EXPECT_EQ(f.model_var, g.model_var);
    EXPECT_EQ(f.chi2, g.chi2);
    EXPECT_EQ(f.rms_log10, g.rms_log10);
    EXPECT_EQ(f.evidence, g.evidence);
    for (int t = 0; t < kNumTerms; ++t) {
      SCOPED_TRACE(std::string(noiseTermKey(t)) + " seed " + std::to_string(seed));
      EXPECT_EQ(f.terms[t].value, g.terms[t].value);
      EXPECT_TRUE(std::isnan(g.terms[t].hi68));
      EXPECT_TRUE(std::isfinite(f.terms[t].hi68));
    }
  }
}

namespace {
// MEMS-like axes with the coefficients (N 2e-4 rad/sqrt(s), B 2e-5 rad/s, K 2e-6 rad/s/sqrt(s)), 30 min at
// 100 Hz (the bundled demo's gyro), several seeds: the records on which selecting terms at the full model's
// covariance reported N alone while the data rose 4-11x above that model at the longest taus.
std::vector<DeviationCurve> demoLikeCurves(int n) {
  AxisNoise a;
  a.angle_random_walk = 2e-4;
  a.bias_instability = 2e-5;
  a.rate_random_walk = 2e-6;
  std::vector<DeviationCurve> out;
  for (int s = 0; s < n; ++s) {
    const std::vector<double> y = simulateAxis(a, 100.0, 180000, 900 + static_cast<uint64_t>(s), 0);
    out.push_back(computeDeviation("oadev", y, InputKind::Rate, 0.01, DeviationOptions{}));
  }
  return out;
}
}  // namespace

// The reported coefficients are the model: model_var is the IEEE curve of the reported values at every point; each
// value lies inside its own 68 % and 95 % intervals; "supported" is exactly "the 95 % interval excludes 0".
TEST(NoiseModel, ReportedValuesAreTheModelAndLieInsideTheirIntervals) {
  for (const DeviationCurve& c : demoLikeCurves(6)) {
    const FitResult f = fitNoiseModel(c);
    ASSERT_TRUE(f.ok && f.gls) << f.message;
    for (size_t i = 0; i < c.points.size(); ++i) {
      double v = 0;
      for (int t = 0; t < kNumTerms; ++t) v += termVariance(f, t, c.points[i].tau);
      EXPECT_NEAR(f.model_var[i] / v, 1.0, 1e-9) << "tau " << c.points[i].tau;
    }
    for (int t = 0; t < kNumTerms; ++t) {
      const Coefficient& k = f.terms[static_cast<size_t>(t)];
      SCOPED_TRACE(noiseTermKey(t));
      EXPECT_LE(k.lo68, k.value * (1 + 1e-9));
      EXPECT_GE(k.hi68, k.value * (1 - 1e-9));
      EXPECT_LE(k.lo95, k.lo68 * (1 + 1e-9));
      EXPECT_GE(k.hi95, k.hi68 * (1 - 1e-9));
      EXPECT_EQ(k.supported, k.lo95 > 0);
    }
  }
}

// The long-tau rise is never dropped: on the demo-like records the reported model's ADEV follows the true one within
// 25 % over tau in [10/fs, T/10] (the done-when figure) on at least 5 of 6 records, and within 50 % on all,
// where an N-only answer is off by a factor 2.3 at T/10.
TEST(NoiseModel, ModelFollowsTheLongTauRise) {
  const double n = 2e-4, b = 2e-5, k = 2e-6;
  int within25 = 0, records = 0;
  for (const DeviationCurve& c : demoLikeCurves(6)) {
    const FitResult f = fitNoiseModel(c);
    ASSERT_TRUE(f.ok) << f.message;
    double worst = 0;
    for (double tau = 0.1; tau <= 180.0; tau *= 1.1) {
      const double truth = n * n / tau + 2 * std::log(2.0) / M_PI * b * b + k * k * tau / 3;
      double model = 0;
      for (int t = 0; t < kNumTerms; ++t) model += termVariance(f, t, tau);
      worst = std::max(worst, std::fabs(std::sqrt(model / truth) - 1.0));
    }
    std::printf("record %d: worst ADEV error %.1f %%\n", records, 100 * worst);
    EXPECT_LT(worst, 0.5);
    within25 += worst <= 0.25;
    ++records;
  }
  EXPECT_GE(within25, 5);
}

// The correlation of the free estimates is published for every pair of enabled terms: symmetric, unit diagonal, and
// B/K strongly negative on these records (the two trade over the longest taus).
TEST(NoiseModel, PublishesTheCorrelationOfTheTerms) {
  const FitResult f = fitNoiseModel(demoLikeCurves(1)[0]);
  ASSERT_TRUE(f.ok);
  for (int i = 0; i < kNumTerms; ++i) {
    EXPECT_NEAR(f.correlation[i][i], 1.0, 1e-9);
    for (int j = 0; j < kNumTerms; ++j) EXPECT_NEAR(f.correlation[i][j], f.correlation[j][i], 1e-9);
  }
  EXPECT_LT(f.correlation[kBiasInstability][kRateRandomWalk], -0.5);
}

// FitOptions::working_independence (the population study's comparison estimator): diagonal weights at the model,
// sandwich intervals. On a white-noise-plus-random-walk record (N 2e-4 rad/sqrt(s), K 1e-6 rad/s/sqrt(s), 1 h at
// 100 Hz, seed 5101) it must recover N within 3 %, give every term an interval that holds its value, and estimate
// differently from the GLS (the same fit would mean the option is not applied).
TEST(NoiseModel, WorkingIndependenceFitsAndHoldsItsValues) {
  AxisNoise a;
  a.angle_random_walk = 2e-4;
  a.rate_random_walk = 1e-6;
  const std::vector<std::vector<double>> y{simulateAxis(a, 100.0, 360000, 5101)};
  const DeviationCurve c = computeDeviation("oadev", y, InputKind::Rate, 0.01, DeviationOptions{});
  FitOptions wi;
  wi.working_independence = true;
  const FitResult f = fitNoiseModel(c, wi), g = fitNoiseModel(c);
  ASSERT_TRUE(f.ok) << f.message;
  ASSERT_TRUE(g.ok) << g.message;
  EXPECT_NEAR(f.terms[kAngleRandomWalk].value / 2e-4, 1.0, 0.03);
  for (int t = 0; t < kNumTerms; ++t) {
    const Coefficient& co = f.terms[static_cast<size_t>(t)];
    EXPECT_LE(co.lo68, co.value * (1 + 1e-9)) << noiseTermKey(t);
    EXPECT_GE(co.hi68, co.value * (1 - 1e-9)) << noiseTermKey(t);
  }
  double diff = 0;
  for (int t = 0; t < kNumTerms; ++t)
    diff = std::max(diff, std::fabs(f.terms[static_cast<size_t>(t)].value - g.terms[static_cast<size_t>(t)].value));
  EXPECT_GT(diff, 0.0);
}
