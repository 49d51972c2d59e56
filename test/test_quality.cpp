// assessQuality: a clean simulated record is good; hand-made analyses with gross errors are bad, with moderate ones or
// warning signs doubtful, each with a reason that names the numbers; the FitResult overload applies the same rule.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "gyro_allan/analysis.hpp"
#include "gyro_allan/quality.hpp"
#include "gyro_allan/simulate.hpp"

using namespace gyro_allan;

namespace {

bool has(const std::string& s, const std::string& what) { return s.find(what) != std::string::npos; }

/// A hand-made analysis whose joint fit answered: N supported, the given fit error.
/// An axis answered by a fit whose model misses the tightest points by up to `worst_ratio` in ADEV, with the given
/// chi2/dof and, for a GLS fit, its p-value (NaN: an EDF-weighted fit without one).
AxisAnalysis handMade(double worst_ratio, double chi2_dof, double chi2_p = std::nan("")) {
  AxisAnalysis a;
  a.axis = "x";
  a.samples = 100000;
  a.method = Method::JointFit;
  a.fit.ok = true;
  a.fit.terms[kAngleRandomWalk] = {2e-4, 1e-6, true};
  a.fit.rms_log10 = 0.5 * std::log10(worst_ratio);
  a.fit.worst_adev_ratio = worst_ratio;
  a.fit.chi2_dof = chi2_dof;
  a.fit.gls = std::isfinite(chi2_p);
  a.fit.chi2_p = chi2_p;
  a.fit.n_rms = 12;
  a.coefficients = a.fit.terms;
  a.final_error = fitErrorOf(a.fit);
  return a;
}

/// rlg_saw classes' noise (coverage_study): an undithered pulse counter, Q = 0.35 arcsec, N = 0.002 deg/sqrt(h),
/// B = 0.005 deg/h, at a constant input rate [deg/h].
AxisNoise undithered(double rate_deg_h) {
  AxisNoise n;
  n.quantization = 1.69684788e-06;
  n.dither = false;
  n.angle_random_walk = 5.81776417e-07;
  n.bias_instability = 2.42406841e-08;
  n.input_rate = rate_deg_h * M_PI / 180 / 3600;
  return n;
}

}  // namespace

TEST(Quality, CleanSimulatedRecordIsGood) {
  // The bundled bag's MEMS gyro (N 2e-4, B 2e-5, K 2e-6; 100 Hz, 30 min), whole pipeline.
  AxisNoise n;
  n.angle_random_walk = 2e-4;
  n.bias_instability = 2e-5;
  n.rate_random_walk = 2e-6;
  const std::vector<std::vector<double>> seg{simulateAxis(n, 100, 180000, 2026)};
  const AxisAnalysis a = analyzeAxis("x", seg, 0.01, AnalysisOptions());
  EXPECT_EQ(a.quality.quality, Quality::Good) << a.quality.reason;
  EXPECT_TRUE(has(a.quality.reason, "the data accept the model")) << a.quality.reason;
  EXPECT_STREQ(qualityName(a.quality.quality), "good");
}

TEST(Quality, GrossErrorsAreBadWithTheNumbers) {
  const QualityVerdict v = assessQuality(handMade(2.5, 2.0, 0.2));
  EXPECT_EQ(v.quality, Quality::Bad);  // off by more than x2 at a tight point, whatever the chi-squared says
  EXPECT_TRUE(has(v.reason, "x2.50")) << v.reason;
  EXPECT_STREQ(qualityName(v.quality), "bad");

  const QualityVerdict c = assessQuality(handMade(1.05, 400.0));
  EXPECT_EQ(c.quality, Quality::Bad);
  EXPECT_TRUE(has(c.reason, "chi2/dof 400")) << c.reason;

  AxisAnalysis failed = handMade(1.05, 1.0);
  failed.fit.ok = false;
  failed.fit.message = "too few points";
  const QualityVerdict f = assessQuality(failed);
  EXPECT_EQ(f.quality, Quality::Bad);
  EXPECT_TRUE(has(f.reason, "too few points")) << f.reason;

  AxisAnalysis none = handMade(1.05, 1.0);
  for (auto& t : none.coefficients) t = {0, 1e-5, false};
  const QualityVerdict u = assessQuality(none);
  EXPECT_EQ(u.quality, Quality::Bad);
  EXPECT_TRUE(has(u.reason, "no noise term is supported")) << u.reason;

  AxisAnalysis nan = handMade(std::nan(""), 1.0);
  EXPECT_EQ(assessQuality(nan).quality, Quality::Bad);

  // wavelet_split answered but failed: bad, whatever the joint fit says.
  AxisAnalysis split = handMade(1.05, 1.0);
  split.method = Method::WaveletSplit;
  split.has_split = true;
  split.split.ok = false;
  split.split.message = "record too short for the wavelet";
  EXPECT_EQ(assessQuality(split).quality, Quality::Bad);
}

TEST(Quality, ModerateErrorsAndWarningSignsAreDoubtful) {
  const QualityVerdict r = assessQuality(handMade(1.7, 1.0, 0.5));
  EXPECT_EQ(r.quality, Quality::Doubtful);  // off by more than x1.5 at a tight point
  EXPECT_TRUE(has(r.reason, "x1.70")) << r.reason;
  const QualityVerdict p = assessQuality(handMade(1.05, 2.0, 0.001));
  EXPECT_EQ(p.quality, Quality::Doubtful);  // the chi-squared test rejects the model
  EXPECT_TRUE(has(p.reason, "p = 0.001")) << p.reason;
  EXPECT_EQ(assessQuality(handMade(1.05, 2.0, 0.3)).quality, Quality::Good);
  EXPECT_EQ(assessQuality(handMade(1.05, 8.0)).quality, Quality::Doubtful);  // EDF fit: chi2/dof > 5

  AxisAnalysis cut = handMade(1.05, 1.0);
  cut.static_stretch = true;
  const QualityVerdict c = assessQuality(cut);
  EXPECT_EQ(c.quality, Quality::Doubtful);
  EXPECT_TRUE(has(c.reason, "static stretch")) << c.reason;

  AxisAnalysis spikes = handMade(1.05, 1.0);
  spikes.spikes_checked = true;
  spikes.spikes.count = 500;  // 0.5 % of 100000
  const QualityVerdict s = assessQuality(spikes);
  EXPECT_EQ(s.quality, Quality::Doubtful);
  EXPECT_TRUE(has(s.reason, "500 spikes")) << s.reason;
  spikes.spikes.count = 20;  // 0.02 %: fine
  EXPECT_EQ(assessQuality(spikes).quality, Quality::Good);

  AxisAnalysis methods = handMade(1.05, 1.0);
  methods.has_split = true;
  methods.split.ok = true;
  methods.split.terms[kAngleRandomWalk] = {9e-4, 1e-5, true};  // x4.5 the joint fit's 2e-4
  const QualityVerdict m = assessQuality(methods);
  EXPECT_EQ(m.quality, Quality::Doubtful);
  EXPECT_TRUE(has(m.reason, "x4.50")) << m.reason;
  methods.split.terms[kAngleRandomWalk] = {2.5e-4, 1e-5, true};  // x1.25: agree
  EXPECT_EQ(assessQuality(methods).quality, Quality::Good);
  methods.split.terms[kAngleRandomWalk] = {0, 5e-5, false};  // bound 5e-5, joint fit 2e-4 above twice it
  EXPECT_EQ(assessQuality(methods).quality, Quality::Doubtful);
  methods.split.terms[kAngleRandomWalk] = {0, 5e-4, false};  // a bound above the joint fit: no contradiction
  EXPECT_EQ(assessQuality(methods).quality, Quality::Good);

  // The split answered because the joint fit misfits grossly (a sawtooth): the joint fit's N is no evidence against
  // it. With the joint fit's own error good again, the same disagreement counts.
  methods.method = Method::WaveletSplit;
  methods.split.terms[kAngleRandomWalk] = {9e-4, 1e-5, true};
  methods.coefficients = methods.split.terms;
  methods.fit.rms_log10 = 0.5;
  methods.fit.chi2_dof = 67;
  const QualityVerdict w = assessQuality(methods);
  EXPECT_EQ(w.quality, Quality::Good) << w.reason;
  EXPECT_TRUE(has(w.reason, "not cross-checked")) << w.reason;
  methods.has_check = true;  // the model check's fit with effects fits, and its N is x4.5 below the split's
  methods.check.effects.resize(1);
  methods.check.fit_after.ok = true;
  methods.check.fit_after.terms[kAngleRandomWalk] = {2e-4, 1e-6, true};
  methods.check.after.rms_log10 = 0.03;
  methods.check.after.chi2_dof = 2.0;
  const QualityVerdict wc = assessQuality(methods);
  EXPECT_EQ(wc.quality, Quality::Doubtful);
  EXPECT_TRUE(has(wc.reason, "disagree")) << wc.reason;
  methods.check.fit_after.terms[kAngleRandomWalk] = {8e-4, 1e-6, true};  // ... and agrees with it
  EXPECT_EQ(assessQuality(methods).quality, Quality::Good);
  methods.has_check = false;
  methods.fit.rms_log10 = 0.01;  // the plain fit fits: its N counts
  methods.fit.chi2_dof = 1.0;
  const QualityVerdict wp = assessQuality(methods);
  EXPECT_EQ(wp.quality, Quality::Doubtful);
  EXPECT_TRUE(has(wp.reason, "disagree")) << wp.reason;
}

TEST(Quality, FitResultOverloadAppliesTheSameRule) {
  const AxisAnalysis a = handMade(2.5, 2.0);
  const QualityVerdict v = assessQuality(a.fit);
  EXPECT_EQ(v.quality, Quality::Bad);
  EXPECT_EQ(v.reason, assessQuality(a).reason);
  FitResult good = handMade(1.1, 1.5).fit;
  EXPECT_EQ(assessQuality(good).quality, Quality::Good);
  QualityContext ctx;
  ctx.static_stretch = true;
  EXPECT_EQ(assessQuality(good, ctx).quality, Quality::Doubtful);
  ctx = QualityContext();
  ctx.compare_methods = true;
  ctx.joint_fit_n = {1e-3, 1e-5, true};
  ctx.wavelet_split_n = {2e-4, 1e-6, true};
  EXPECT_EQ(assessQuality(good, ctx).quality, Quality::Doubtful);
  good.ok = false;
  EXPECT_EQ(assessQuality(good).quality, Quality::Bad);
}

// An undithered pulse counter at 10 deg/h (rlg_saw10's noise, 20 min, 100 Hz): auto answers by the split because the
// plain joint fit cannot describe the sawtooth (its N is ~18x the truth). Before the verdict compared the split's N
// with that fit's, every such axis was doubtful for "joint_fit and wavelet_split disagree on N"; the answer is right
// (Q within 1 %, N within 10 %). Now the split's N is held against the model check's fit when that added effects (the
// sawtooth's lines) and fits, else against nothing, and the reason says so. Seeds 1-4 (all four were doubtful
// before; at this length and rate the check's fit fits, chi2/dof ~30 against 50, and its least-squares N is within
// x2 of the split's).
TEST(Quality, SawtoothAnswerIsNotDoubtedByAMisfittingJointFit) {
  const AxisNoise n = undithered(10);
  const double hz = 100;
  int good = 0, checked = 0;
  for (uint64_t seed = 1; seed <= 4; ++seed) {
    const AxisAnalysis a = analyzeAxis("x", {simulateAxis(n, hz, 120000, seed)}, 1 / hz, AnalysisOptions{});
    EXPECT_EQ(a.method, Method::WaveletSplit) << seed << ": " << a.method_reason;
    EXPECT_GT(a.fit.rms_log10, quality_limits::kBadRmsLog10) << seed << ": the joint fit was expected to misfit";
    EXPECT_NEAR(a.coefficients[kQuantization].value / n.quantization, 1, 0.01) << seed;
    EXPECT_NEAR(a.coefficients[kAngleRandomWalk].value / n.angle_random_walk, 1, 0.10) << seed;
    EXPECT_FALSE(has(a.quality.reason, "disagree")) << seed << ": " << a.quality.reason;
    const bool check_fits = a.has_check && !a.check.effects.empty() &&
                            a.check.after.rms_log10 <= quality_limits::kBadRmsLog10 &&
                            a.check.after.chi2_dof <= quality_limits::kBadChi2Dof;
    checked += check_fits;
    // Either the check's fit was the comparison, or the reason says N was not cross-checked.
    EXPECT_NE(check_fits, has(a.quality.reason, "not cross-checked")) << seed << ": " << a.quality.reason;
    good += a.quality.quality == Quality::Good;
  }
  std::printf("sawtooth at 10 deg/h: %d of 4 axes good, %d checked against the model check's fit\n", good, checked);
  EXPECT_GE(checked, 1) << "the model check's branch was not exercised";
}

// An undithered pulse counter at 0 deg/h for 10 min (Q = 0.35 arcsec, N = 0.002 deg/sqrt(h), 100 Hz): the angle
// wanders across a few quanta, its rounding error is neither white nor a sawtooth, and no method can read Q and N.
// Never a confident wrong answer: each axis is either right (Q within 5 %, N within 10 %) or flagged bad. Before the
// slow-counter rule (analysis.cpp) the split's denoised fit excused the raw misfit: seed 3 here came out "good"
// with Q = 0 and N 4.3x its truth.
TEST(Quality, SlowUnditheredCounterIsRightOrBad) {
  const AxisNoise n = undithered(0);
  const double hz = 100, tau0 = 1 / hz;
  int bad = 0;
  for (uint64_t seed = 1; seed <= 8; ++seed) {
    const std::vector<double> rate = simulateAxis(n, hz, 60000, seed);
    const AxisAnalysis a = analyzeAxis("x", {rate}, tau0, AnalysisOptions{});
    const double q = a.coefficients[kQuantization].value / n.quantization;
    const double arw = a.coefficients[kAngleRandomWalk].value / n.angle_random_walk;
    const bool right = std::fabs(q - 1) <= 0.05 && std::fabs(arw - 1) <= 0.10;
    bad += a.quality.quality == Quality::Bad;
    EXPECT_TRUE(right || a.quality.quality == Quality::Bad)
        << "seed " << seed << ": " << methodName(a.method) << ", Q/truth " << q << ", N/truth " << arw << ", "
        << qualityName(a.quality.quality) << " (" << a.quality.reason << ")";
  }
  std::printf("slow counter: %d of 8 axes bad\n", bad);
}
