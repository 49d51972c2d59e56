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

// The tactical gyro of the rival tests (N 0.1 deg/sqrt(h), B 0.8 deg/h, K 0.5 deg/h/sqrt(h), R as given in deg/h^2),
// one hour at 20 Hz, fitted as analyze_bag fits it.
FitResult fitTacticalHour(double ramp_deg_h2, uint64_t seed, const FitOptions& options = {}) {
  const double deg = M_PI / 180.0;
  AxisNoise a;
  a.angle_random_walk = 0.1 * deg / 60.0;
  a.bias_instability = 0.8 * deg / 3600.0;
  a.rate_random_walk = 0.5 * deg / 3600.0 / 60.0;
  a.rate_ramp = ramp_deg_h2 * deg / 3600.0 / 3600.0;
  const std::vector<double> y = simulateAxis(a, 20.0, 72000, seed, 0);
  DeviationCurve c = computeDeviation("oadev", y, InputKind::Rate, 1.0 / 20.0, DeviationOptions{});
  return fitWithModelEdf(&c, options, 0.683);
}

// What the subset search selected (FitResult::terms: the least-squares values, before any correction), as a bit set.
int selectedTerms(const FitResult& f) {
  int sel = 0;
  for (int t = 0; t < kNumTerms; ++t)
    if (f.terms[static_cast<size_t>(t)].supported) sel |= 1 << t;
  return sel;
}

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

// Acceptance (issue "vertical slice"): 1 h, 400 Hz MEMS-like gyro, N = 2e-4 rad/sqrt(s), B = 2e-5 rad/s,
// K = 2e-6 rad/s/sqrt(s): N within 3 %, B and K inside their 95 % intervals. Two seeds x 3 axes = 6 cases
// per coefficient; at nominal 95 % coverage, 2 or more misses of 6 happen 3 % of the time, so at most 1 miss is allowed.
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
      const auto& b = f.terms_corrected[kBiasInstability];
      const auto& k = f.terms_corrected[kRateRandomWalk];
      std::printf("seed %d axis %d: B %.3g [%.3g, %.3g]%s, K %.3g [%.3g, %.3g]%s\n", static_cast<int>(seed), axis,
                  b.value, b.lo95, b.hi95, b.supported ? "" : " (not supported)", k.value, k.lo95, k.hi95,
                  k.supported ? "" : " (not supported)");
      if (!(b.lo95 <= 2e-5 && 2e-5 <= b.hi95)) ++miss_b;
      if (!(k.lo95 <= 2e-6 && 2e-6 <= k.hi95)) ++miss_k;
    }
  }
  EXPECT_LE(miss_b, 1);
  EXPECT_LE(miss_k, 1);
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

// Term selection's non-nested rivals (FitResult::rival_terms, close_rival_terms): for every close rival (isCloseRival:
// within kRivalGap on the score or on AIC, a swap within a swapped-out term's entry penalty in chi-squared), the
// answer claims no term the rival does without; a term is ambiguous exactly when some
// close rival disagrees with the selection on it; and the closest rival's terms the answer lacks have intervals
// reaching its values. A tactical gyro with a weak ramp (N 0.1 deg/sqrt(h), B 0.8 deg/h, K 0.5 deg/h/sqrt(h),
// R 6 deg/h^2; 1 h at 20 Hz), where N+B and N+K tell many records about equally well: seeds 7801-7830 hold both kinds
// (session 12: 9 of the 30 within the gap; 9 selected terms flagged, 10 rival terms checked; session 13, with AIC's
// side and every close rival: the figures the test prints). In these records the rival's terms already had intervals
// past its values, so nothing was widened: that branch is a guard.
TEST(NoiseModel, CloseRivalMakesTheTermsItDisagreesOnAmbiguous) {
  int close = 0, far = 0, removed = 0, rival_checked = 0, aic_only = 0, by_other_rival = 0;
  for (uint64_t seed = 7801; seed <= 7830; ++seed) {
    const FitResult f = fitTacticalHour(6.0, seed);
    ASSERT_TRUE(f.ok) << f.message;
    ASSERT_NE(f.rival_terms, 0) << "seed " << seed;
    const int sel = selectedTerms(f);
    EXPECT_NE(f.rival_terms & sel, f.rival_terms) << "seed " << seed << ": the rival is a subset of the selection";
    EXPECT_NE(f.rival_terms & sel, sel) << "seed " << seed << ": the rival is a superset of the selection";
    EXPECT_DOUBLE_EQ(f.rival_gap, std::min(f.rival_score_gap, f.rival_aic_gap)) << "seed " << seed;
    // the closest rival, close by its own measure (any close rival is within the largest penalty)
    const bool closest_close =
        isCloseRival(sel, f.rival_terms, f.rival_score_gap, f.rival_aic_gap, FitOptions{});
    if (closest_close) {
      ASSERT_FALSE(f.close_rival_terms.empty()) << "seed " << seed;
      EXPECT_EQ(f.close_rival_terms.front(), f.rival_terms) << "seed " << seed;
    }
    if (f.rival_gap < kRivalGap) {
      EXPECT_TRUE(closest_close) << "seed " << seed;
    }
    if (!f.close_rival_terms.empty()) {
      EXPECT_LT(f.rival_gap, FitOptions{}.ramp_penalty) << "seed " << seed;
    }
    if (f.rival_score_gap >= kRivalGap && f.rival_aic_gap < kRivalGap) ++aic_only;
    for (int rt : f.close_rival_terms) {  // each listed rival: non-nested, and keeps N
      EXPECT_NE(rt & sel, rt) << "seed " << seed;
      EXPECT_NE(rt & sel, sel) << "seed " << seed;
      EXPECT_TRUE((rt >> kAngleRandomWalk) & 1) << "seed " << seed;
    }
    for (int t = 0; t < kNumTerms; ++t) {
      const size_t i = static_cast<size_t>(t);
      const bool in_rival = (f.rival_terms >> t) & 1, selected = (sel >> t) & 1;
      const Coefficient& cc = f.terms_corrected[i];
      bool disputed = false;  // by some rival within the gap
      for (int rt : f.close_rival_terms) disputed = disputed || (((rt >> t) & 1) != selected);
      EXPECT_EQ(f.ambiguous[i], disputed) << "seed " << seed << " " << noiseTermKey(t);
      if (disputed && (!closest_close || in_rival == selected)) ++by_other_rival;
      if (!disputed) continue;
      if (selected) {
        ++removed;
        EXPECT_FALSE(cc.supported) << "seed " << seed << ": " << noiseTermKey(t)
                                   << " claimed though a close rival does without it";
        EXPECT_EQ(cc.value, 0.0);
        EXPECT_EQ(cc.lo68, 0.0);
        EXPECT_EQ(cc.lo95, 0.0);
      } else {
        EXPECT_FALSE(cc.supported);
        if (!closest_close || !in_rival) continue;
        ++rival_checked;
        EXPECT_GE(cc.hi68, f.rival_values[i] * (1 - 1e-9)) << "seed " << seed << " " << noiseTermKey(t);
        EXPECT_GE(cc.hi95, cc.hi68) << "seed " << seed << " " << noiseTermKey(t);
      }
    }
    (closest_close ? close : far) += 1;
  }
  std::printf("closest rival close: %d of 30 records (%d on AIC's side only); %d selected terms removed, %d rival "
              "terms checked; %d terms made ambiguous by a rival other than the closest\n",
              close, aic_only, removed, rival_checked, by_other_rival);
  EXPECT_GT(close, 0);
  EXPECT_GT(far, 0);
  EXPECT_GT(removed, 0);
  EXPECT_GT(rival_checked, 0);
  EXPECT_GT(aic_only, 0);        // the AIC side admits rivals the score alone would not
  EXPECT_GT(by_other_rival, 0);  // and rivals other than the closest count
}

// A rival of the same size (a swap: N + B for N + K) counts within the entry penalty of the term it swaps out, not
// only within kRivalGap (isCloseRival): between sets of equal size only chi-squared decides, and a term claimed over
// a swap must have won it by what it must save to enter a nested set. The tactical gyro without the ramp (N 0.1
// deg/sqrt(h), B 0.8 deg/h, K 0.5 deg/h/sqrt(h); 1 h at 20 Hz, seeds 7901-7960): in every record whose closest rival
// is a swap trailing by 2 to 4, the term it swaps out is reported as a bound (value 0, interval from 0) and the
// swapped-in term's interval reaches the rival's value. Before session 17 those terms were claimed (B at its value,
// or a K far below detection: +330 % to +690 % in 4 of 400 tactical and tactical-ramp records at 200 Hz).
TEST(NoiseModel, SwapMustBeWonByAnEntrysWorth) {
  const FitOptions opt;
  int swaps = 0, checked_out = 0, checked_in = 0;
  for (uint64_t seed = 7901; seed <= 7960; ++seed) {
    const FitResult f = fitTacticalHour(0.0, seed, opt);
    ASSERT_TRUE(f.ok) << f.message;
    const int sel = selectedTerms(f);
    const int rival = f.rival_terms;
    const std::bitset<kNumTerms> sel_set(static_cast<unsigned>(sel)), rival_set(static_cast<unsigned>(rival));
    if (rival == 0 || rival_set.count() != sel_set.count()) continue;
    if (!(f.rival_gap >= kRivalGap && f.rival_aic_gap < opt.term_penalty)) continue;
    ++swaps;
    EXPECT_TRUE(isCloseRival(sel, rival, f.rival_score_gap, f.rival_aic_gap, opt)) << "seed " << seed;
    ASSERT_FALSE(f.close_rival_terms.empty()) << "seed " << seed;
    EXPECT_EQ(f.close_rival_terms.front(), rival) << "seed " << seed;
    for (int t = 0; t < kNumTerms; ++t) {
      const size_t i = static_cast<size_t>(t);
      const bool in_rival = rival_set[i], selected = sel_set[i];
      if (in_rival == selected) continue;
      const Coefficient& cc = f.terms_corrected[i];
      EXPECT_TRUE(f.ambiguous[i]) << "seed " << seed << " " << noiseTermKey(t);
      EXPECT_FALSE(cc.supported) << "seed " << seed << " " << noiseTermKey(t) << " (gap " << f.rival_gap << ")";
      if (selected) {
        ++checked_out;
        EXPECT_EQ(cc.value, 0.0) << "seed " << seed;
        EXPECT_EQ(cc.lo68, 0.0) << "seed " << seed;
      } else {
        ++checked_in;
        EXPECT_GE(cc.hi68, f.rival_values[i] * (1 - 1e-9)) << "seed " << seed << " " << noiseTermKey(t);
      }
    }
  }
  std::printf("swaps trailing by %g to %g: %d of 60 records; %d swapped-out terms reported as bounds, %d swapped-in "
              "terms checked\n", kRivalGap, opt.term_penalty, swaps, checked_out, checked_in);
  EXPECT_GE(swaps, 2);  // the rule must have been exercised
}

// isCloseRival itself, case by case (FitOptions' penalties: 4 per term, 6 for the ramp): within kRivalGap on either
// scale always; a swap within the swapped-out term's penalty in chi-squared (the AIC gap), strictly below; a ramp
// swapped out needs 6, not the score gap's 8; a larger rival within the penalty in chi-squared (since session 26).
TEST(NoiseModel, CloseRivalRuleCaseByCase) {
  const FitOptions o;
  const int N = 1 << kAngleRandomWalk, B = 1 << kBiasInstability, K = 1 << kRateRandomWalk, R = 1 << kRateRamp;
  const int Q = 1 << kQuantization;
  EXPECT_TRUE(isCloseRival(N | K, N | B, 1.9, 1.9, o));     // within 2
  EXPECT_TRUE(isCloseRival(N | K, N | B, 3.0, 3.0, o));     // a swap within K's 4
  EXPECT_FALSE(isCloseRival(N | K, N | B, 4.0, 4.0, o));    // not within: strictly below
  EXPECT_FALSE(isCloseRival(N | K, N | B, 5.0, 5.0, o));
  EXPECT_TRUE(isCloseRival(N | R, N | K, 3.5, 5.5, o));     // the ramp swapped out: 6 in chi-squared
  EXPECT_FALSE(isCloseRival(N | R, N | K, 4.5, 6.5, o));    // score gap 4.5 < 6, but chi-squared 6.5 is not
  EXPECT_FALSE(isCloseRival(N | K, N | R, 7.5, 5.5, o));    // K swapped out: 4, whatever the ramp costs
  EXPECT_TRUE(isCloseRival(N | K, N | R, 5.5, 3.5, o));
  EXPECT_TRUE(isCloseRival(N | K, N | B | R, 5.0, 1.5, o));   // on AIC's side
  // A larger rival (since session 26): the AIC gap less 2 per extra rival term is the chi-squared difference; the
  // score gap is that plus the rival's extra penalties (B 4 and R 6 for K's 4: + 6).
  EXPECT_TRUE(isCloseRival(N | K, N | B | R, 9.9, 5.9, o));   // one more term: chi-squared 3.9 < K's 4
  EXPECT_FALSE(isCloseRival(N | K, N | B | R, 10.0, 6.0, o));  // 4.0: not within
  EXPECT_FALSE(isCloseRival(N | B | K, Q | N | B, 5.06, 5.06, o));  // validation's consumer record (seed 24019)
  FitOptions heavy;
  heavy.term_penalty = 9.0;  // the limit follows the options' penalty
  EXPECT_TRUE(isCloseRival(N | K, N | B, 8.0, 8.0, heavy));
}

// The same rule through the wavelet split (its B, K, R come from the denoised part's fit): a dithered MEMS-like gyro
// with every term (Q 2 arcsec, N 0.15 deg/sqrt(h), B 2 deg/h, K 3 deg/h/sqrt(h), R 10 deg/h^2; 1 h at 200 Hz;
// coverage_study's held-out class all5, seed 5), where N+B scores within 2 of the selected N+K. K is reported as a
// bound, and the split's model curve keeps the fitted K: taking the reported K (0) into the curve made the raw fit
// miss (chi2/dof ~170) and switched the verdict to the sawtooth fallback for a dithered sensor.
TEST(NoiseModel, CloseRivalInTheWaveletSplitKeepsItsModelCurve) {
  const double deg = M_PI / 180.0;
  AxisNoise a;
  a.quantization = 2.0 * deg / 3600.0;
  a.dither = true;
  a.angle_random_walk = 0.15 * deg / 60.0;
  a.bias_instability = 2.0 * deg / 3600.0;
  a.rate_random_walk = 3.0 * deg / 3600.0 / 60.0;
  a.rate_ramp = 10.0 * deg / 3600.0 / 3600.0;
  const std::vector<double> y = simulateAxis(a, 200.0, 720000, 13766864119334436869ULL, 0);
  const AxisAnalysis r = analyzeAxis("x", {y}, 1.0 / 200.0, AnalysisOptions{});
  ASSERT_EQ(r.method, "wavelet_split");
  const FitResult& f = answerFit(r);
  ASSERT_LT(f.rival_gap, kRivalGap);
  const std::array<bool, kNumTerms> amb = answerAmbiguous(r);
  EXPECT_FALSE(amb[kQuantization]);
  EXPECT_FALSE(amb[kAngleRandomWalk]);
  int n_amb = 0;
  for (int t = kBiasInstability; t < kNumTerms; ++t) {
    const size_t i = static_cast<size_t>(t);
    n_amb += amb[i];
    if (r.coefficients[i].supported) {
      for (int rt : f.close_rival_terms)
        EXPECT_TRUE((rt >> t) & 1) << noiseTermKey(t) << " claimed though a close rival does without it";
    }
  }
  EXPECT_GT(n_amb, 0);
  for (const std::string& n : r.notes) EXPECT_EQ(n.find("non-white"), std::string::npos) << n;
  EXPECT_LT(r.final_error.chi2_dof, quality_limits::kDoubtfulChi2Dof);
  EXPECT_NE(r.quality.quality, Quality::Bad);
}

// A rate random walk far below detection chosen over a flicker and a ramp (coverage_study's held-out class kr_big: N
// 0.15 deg/sqrt(h), B 1 deg/h, K 6 deg/h/sqrt(h), R 40 deg/h^2, 2 h at 100 Hz; seed 31466): the search selects N + K,
// and N + B + R trails by 5.0 on AIC, 3.0 in chi-squared, within K's entry penalty. K is a bound, not the +56 % value
// (68 % interval 1.18-2.03 times the truth) reported before session 26; its upper end still holds the truth.
TEST(NoiseModel, RandomWalkChosenOverALargerRivalWithinItsEntryIsABound) {
  const double deg = M_PI / 180.0;
  AxisNoise a;
  a.angle_random_walk = 0.15 * deg / 60.0;
  a.bias_instability = 1.0 * deg / 3600.0;
  a.rate_random_walk = 6.0 * deg / 3600.0 / 60.0;
  a.rate_ramp = 40.0 * deg / 3600.0 / 3600.0;
  const std::vector<double> y = simulateAxis(a, 100.0, 720000, 6140114452139244266ULL, 0);
  const AxisAnalysis r = analyzeAxis("x", {y}, 1.0 / 100.0, AnalysisOptions{});
  const FitResult& f = answerFit(r);
  ASSERT_EQ(f.rival_terms, (1 << kAngleRandomWalk) | (1 << kBiasInstability) | (1 << kRateRamp));
  ASSERT_GT(f.rival_aic_gap, kRivalGap);  // not close by kRivalGap alone
  ASSERT_LT(f.rival_aic_gap - 2.0, FitOptions{}.term_penalty);  // but within K's entry in chi-squared
  ASSERT_FALSE(f.close_rival_terms.empty());
  EXPECT_EQ(f.close_rival_terms.front(), f.rival_terms);
  const std::array<bool, kNumTerms> amb = answerAmbiguous(r);
  EXPECT_TRUE(amb[kRateRandomWalk]);
  const Coefficient& k = r.coefficients[kRateRandomWalk];
  EXPECT_FALSE(k.supported);
  EXPECT_GE(k.hi68, a.rate_random_walk);
  EXPECT_TRUE(r.coefficients[kAngleRandomWalk].supported);
}

// FitOptions::intervals off (the model check's trial fits, the first pass of a reweighted fit) must change nothing
// but the selective intervals: the same selection, values, statistics, rival and model curve, a selected term's
// sigma from the same covariance, and NaN (not a plausible number) where the intervals were left out.
TEST(NoiseModel, ValuesOnlyFitHasTheSameValuesAndNoIntervals) {
  AxisNoise a;
  a.angle_random_walk = 2e-4;
  a.bias_instability = 2e-5;
  a.rate_random_walk = 3e-7;  // near detection at 30 min: dropped on some seeds
  for (uint64_t seed : {3u, 4u, 5u}) {
    const std::vector<double> y = simulateAxis(a, 200.0, 360000, seed);
    DeviationOptions dopt;
    const DeviationCurve c = computeDeviation("oadev", y, InputKind::Rate, 1.0 / 200.0, dopt);
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
    EXPECT_EQ(f.rival_terms, g.rival_terms);
    int dropped = 0;
    for (int t = 0; t < kNumTerms; ++t) {
      SCOPED_TRACE(std::string(noiseTermKey(t)) + " seed " + std::to_string(seed));
      EXPECT_EQ(f.terms[t].supported, g.terms[t].supported);
      EXPECT_EQ(f.terms[t].value, g.terms[t].value);
      if (f.terms[t].supported) {
        EXPECT_EQ(f.terms[t].sigma, g.terms[t].sigma);
      } else {
        ++dropped;
        EXPECT_TRUE(std::isnan(g.terms[t].hi68));
        EXPECT_TRUE(std::isfinite(f.terms[t].hi68));
      }
    }
    EXPECT_GE(dropped, 1);  // Q (absent) at least: the skipped part is exercised
  }
}

// The selected rate random walk cases below: N 0.15 deg/sqrt(h), K 20 deg/h/sqrt(h) and a flicker of b deg/h whose
// B column is added (b > 0) or taken away (b < 0); the expected Allan variance of 2 h at 100 Hz, no noise, with the
// term counts the GLS covariance is built from.
namespace {
constexpr double kCaseK = 20.0 * M_PI / 180.0 / 3600 / 60;
FitResult fitRandomWalkCase(double b_deg_h) {
  const double deg = M_PI / 180.0, b = b_deg_h * deg / 3600;
  const std::array<double, kNumTerms> truth{{0.0, 0.15 * deg / 60, 0.0, kCaseK, 0.0}};
  DeviationCurve c = modelCurve(truth, 0.01, 720001, 10.0);
  for (auto& p : c.points) {
    p.var += (b_deg_h < 0 ? -1.0 : 1.0) * b * b * noiseTermBasis(kBiasInstability, p.tau, c.tau0);
    EXPECT_GT(p.var, 0.0);
    p.dev = std::sqrt(p.var);
    p.n_terms = c.n_phase - 2 * p.m;
  }
  return fitNoiseModel(c);
}

// The cases' preconditions: a GLS fit with B dropped and K selected.
void assertKSelectedBDropped(const FitResult& f) {
  ASSERT_TRUE(f.ok) << f.message;
  ASSERT_TRUE(f.gls);
  ASSERT_FALSE(f.terms[kBiasInstability].supported) << "the case needs B dropped";
  ASSERT_TRUE(f.terms[kRateRandomWalk].supported);
}

// The answer's K: supported, within 1 % of the truth, inside its 68 % interval.
void expectAnsweredKAtTruth(const FitResult& f) {
  const Coefficient& k = f.terms_corrected[kRateRandomWalk];
  ASSERT_TRUE(k.supported);
  EXPECT_NEAR(k.value / kCaseK, 1.0, 0.01);
  EXPECT_LE(k.lo68, kCaseK);
  EXPECT_GE(k.hi68, kCaseK);
}
}  // namespace

// A selected rate random walk beside a flicker too weak to be selected (B 1 deg/h): the selected set {N, K} has no
// column for B's floor, so its least-squares K takes up B's share at long tau (+9.7 %). The reported K is estimated
// with the columns its sd comes from (the selected terms and those the full model holds, B among them), so it is the
// truth up to the small selection correction (-0.3 %). Before session 23 the reported K was the selected set's
// (+9.7 %); on records this was part of the supported K's bias (docs/calibration.md, "Session 23").
TEST(NoiseModel, SelectedRandomWalkIsNotRaisedByADroppedFlicker) {
  const FitResult f = fitRandomWalkCase(1.0);
  ASSERT_NO_FATAL_FAILURE(assertKSelectedBDropped(f));
  EXPECT_GT(f.terms[kRateRandomWalk].value / kCaseK, 1.05) << "the selected set's K takes up B";
  expectAnsweredKAtTruth(f);
}

// The same where the full model clipped B to 0 (since session 25): less 1 deg/h's worth of B's column (a record
// whose flicker floor came out low). With B at 0 the full model's K takes up the deficit, and B is then not among the
// columns the selected K's estimate came from; with B's column free the estimate is the truth.
TEST(NoiseModel, SelectedRandomWalkIgnoresAFlickerDeficitTheFullModelClipped) {
  const FitResult f = fitRandomWalkCase(-1.0);
  ASSERT_NO_FATAL_FAILURE(assertKSelectedBDropped(f));
  EXPECT_LT(f.terms[kRateRandomWalk].value / kCaseK, 0.98) << "the selected set's K takes up the deficit";
  expectAnsweredKAtTruth(f);
}

// And where the record has no flicker at all (the full model's B is 0 there too): B's column, free beside the
// selected K, must not widen K's sd until its selection correction pulls K down (what the ramp's column did in
// session 23's every-column variant).
TEST(NoiseModel, SelectedRandomWalkWithoutAFlickerKeepsItsValue) {
  const FitResult f = fitRandomWalkCase(0.0);
  ASSERT_NO_FATAL_FAILURE(assertKSelectedBDropped(f));
  expectAnsweredKAtTruth(f);
}
