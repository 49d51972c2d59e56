// Tests of the wavelet split pipeline: exact split factors and level responses against hand derivations and
// simulation, and recovery of declared Q and N from simulated ring-laser-gyro data (dithered and sawtooth).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <stdexcept>
#include <vector>

#include "gyro_allan/model_check.hpp"
#include "gyro_allan/simulate.hpp"
#include "gyro_allan/wavelet_split.hpp"

using namespace gyro_allan;

namespace {
constexpr double kQ = 0.35 * M_PI / 180.0 / 3600.0;      // 0.35 arcsec
constexpr double kN = 0.001 * M_PI / 180.0 / 60.0;       // 0.001 deg/sqrt(h)
constexpr double kDegPerHour = M_PI / 180.0 / 3600.0;

// Mean square of the level's detail coefficients away from the ends (symmetric mode, F dropped at each end:
// a random walk is not periodic, so periodization would add a jump).
double levelMeanSquare(const std::vector<double>& x, const Wavelet& w, int level) {
  const auto c = wavedec(x, w, ExtensionMode::Symmetric, level);
  const auto& d = c[1];  // cD_level
  const size_t F = static_cast<size_t>(w.dec_len());
  double s = 0;
  for (size_t i = F; i + F < d.size(); ++i) s += d[i] * d[i];
  return s / static_cast<double>(d.size() - 2 * F);
}
// An undithered pulse counter (sawtooth quantization error) at a constant input rate.
AxisNoise undithered(double n, double rate_deg_h) {
  AxisNoise ax;
  ax.quantization = kQ;
  ax.angle_random_walk = n;
  ax.dither = false;
  ax.input_rate = rate_deg_h * kDegPerHour;
  return ax;
}
}  // namespace

TEST(WaveletSplitFactors, HaarLevel1ByHand) {
  // Haar level 1: removed pair (r0, r1) = ((y0 - y1)/2, (y1 - y0)/2); its running sum is r0 then 0.
  // White rate (var 1): E a^2 = (1/2)(1/2) = 1/4. White angle e (var 1), y = diff(e): E a^2 = (1/2)(6/4) = 3/4.
  const auto f = splitAngleFactors(Wavelet("haar"), 1);
  EXPECT_NEAR(f.v_n, 0.25, 1e-12);
  EXPECT_NEAR(f.v_q, 0.75, 1e-12);
}

TEST(WaveletSplitFactors, Sym8MatchesMonteCarlo) {
  const Wavelet w("sym8");
  const int L = 5;
  const auto f = splitAngleFactors(w, L);
  EXPECT_NEAR(f.v_q, 1.0 - std::ldexp(1.0, -L), 0.002);  // sym8 is close to the ideal half-band split
  const int n = 1 << 18;
  std::mt19937_64 rng(3);
  std::normal_distribution<double> g(0.0, 1.0);
  std::vector<double> e(n + 1), y(n), yq(n);
  for (auto& v : e) v = g(rng);
  for (int i = 0; i < n; ++i) {
    y[i] = g(rng);
    yq[i] = e[i + 1] - e[i];
  }
  auto angleVar = [&](const std::vector<double>& rate) {
    const auto c = wavedec(rate, w, ExtensionMode::Periodization, L);
    std::vector<std::vector<double>> rem = c;
    std::fill(rem[0].begin(), rem[0].end(), 0.0);  // remove every detail: the linear split
    const auto a = removedAngle(waverec(rem, w, ExtensionMode::Periodization), 1.0);
    double m = 0, s = 0;
    for (double v : a) m += v;
    m /= a.size();
    for (double v : a) s += (v - m) * (v - m);
    return s / a.size();
  };
  EXPECT_NEAR(angleVar(y), f.v_n, 0.03 * f.v_n);
  EXPECT_NEAR(angleVar(yq), f.v_q, 0.02 * f.v_q);
}

TEST(WaveletSplitResponses, MatchHandValuesAndSimulation) {
  const double tau0 = 0.01;
  // Haar level 1 of diff(e)/tau0: (2 e0 - e_-1 - e1) / (sqrt2 tau0) -> variance 3 / tau0^2 per unit Q^2.
  const auto rh = waveletLevelResponses(Wavelet("haar"), 1, tau0);
  EXPECT_NEAR(rh[0][kQuantization] * tau0 * tau0, 3.0, 1e-12);
  const Wavelet w("sym8");
  const auto r = waveletLevelResponses(w, 8, tau0);
  for (const auto& rj : r) EXPECT_DOUBLE_EQ(rj[kAngleRandomWalk], 1.0 / tau0);
  // Flicker rate noise (PSD B^2/(pi f)) and random-walk rate (K) against simulated level variances.
  const int n = 1 << 19;
  const double B = 1.0, K = 1.0;
  double flick = 0, rrw = 0;
  const int reps = 4;
  for (int rep = 0; rep < reps; ++rep) {
    const auto fl = flickerNoise(n, B, 100 + rep);
    flick += levelMeanSquare(fl, w, 6) / reps;
    std::mt19937_64 rng(200 + rep);
    std::normal_distribution<double> g(0.0, K * std::sqrt(tau0));
    std::vector<double> rw(n);
    double acc = 0;
    for (auto& v : rw) v = (acc += g(rng));
    rrw += levelMeanSquare(rw, w, 6) / reps;
  }
  EXPECT_NEAR(flick, r[5][kBiasInstability], 0.1 * r[5][kBiasInstability]);
  EXPECT_NEAR(rrw, r[5][kRateRandomWalk], 0.15 * r[5][kRateRandomWalk]);
}

// Declared Q and N from 20-minute 400 Hz records (the study uses 1-2 h): the measured spreads at 20 min are
// about 0.05 % (Q) and 3 % (N); tolerances are 1 % and 10 %.
TEST(WaveletSplit, RecoversDeclaredQAndNDithered) {
  for (uint64_t seed : {1u, 2u, 3u}) {
    AxisNoise ax;
    ax.quantization = kQ;
    ax.angle_random_walk = kN;
    ax.dither = true;
    const double fs = 400;
    const auto rate = simulateAxis(ax, fs, static_cast<int64_t>(fs * 1200), seed, 0);
    WaveletSplitOptions o;
    o.keep_signals = true;
    const auto r = waveletSplit(rate, 1.0 / fs, o);
    ASSERT_TRUE(r.ok) << r.message;
    EXPECT_NEAR(r.terms[kQuantization].value, kQ, 0.01 * kQ) << seed;
    EXPECT_NEAR(r.terms[kAngleRandomWalk].value, kN, 0.10 * kN) << seed;
    EXPECT_GT(r.terms[kQuantization].sigma, 0);
    EXPECT_LT(r.terms[kQuantization].sigma, 0.01 * kQ);
    EXPECT_GT(r.terms[kAngleRandomWalk].sigma, 0);
    EXPECT_LT(r.terms[kAngleRandomWalk].sigma, 0.1 * kN);
    EXPECT_TRUE(r.quantization_white);
    EXPECT_LT(r.kept_fraction, 0.01);  // sqtwolog/sln_rms removes the quantization band whole
    EXPECT_GE(r.level, 7);
    EXPECT_LE(r.level, 10);
    // Curves exist; the split is exact; the removed angle is bounded (pulse weight q = Q sqrt12).
    EXPECT_FALSE(r.denoised_curve.points.empty());
    EXPECT_FALSE(r.removed_curve.points.empty());
    ASSERT_EQ(r.denoised.size(), rate.size());
    double worst = 0;
    for (size_t i = 0; i < rate.size(); ++i) worst = std::max(worst, std::fabs(r.denoised[i] + r.removed[i] - rate[i]));
    EXPECT_LE(worst, 1e-10 * 1e3);  // rates ~ q/tau0 ~ 2e-3 rad/s: relative 1e-10
    EXPECT_LT(r.removed_angle.max_abs, 1.2 * kQ * std::sqrt(12.0));
    EXPECT_LT(r.removed_angle.half_mean_ratio, 0.1);
    EXPECT_GT(r.removed_arw_share, 0.0);
    EXPECT_LT(r.removed_arw_share, 0.02);
    // The reported model follows the input curve where its interval is tight (EDF from the model, >= 20).
    EXPECT_LE(r.fit_error.worst_adev_ratio, 1.25);
  }
}

// Flicker rate noise (B) has power in the removed band too, and the removed angle holds it: the split subtracts that
// share (removedAngleOfLongerTerms, from the denoised fit's B and K) and carries B's uncertainty into Q and N.
// B 100 deg/h beside Q 2 arcsec and N 0.25 deg/sqrt(h), 1 h at 100 Hz, simulateAxis seeds 1-4: without it Q came out
// +2.4 to +13.6 % (z +12 to +80) and N -4.7 % (z -8.4) in one record; with it Q is within -0.11 to +0.76 % (its
// scatter ~0.35 %) and N's z within +-2.4. Tolerances: Q 1.5 % (the mean +0.39 % plus 3 scatters), |z_N| < 3.5.
TEST(WaveletSplit, FlickerInTheRemovedBandIsNotReadAsQuantization) {
  for (uint64_t seed : {1u, 2u, 3u, 4u}) {
    AxisNoise ax;
    ax.quantization = 2.0 * M_PI / 180.0 / 3600.0;
    ax.angle_random_walk = 0.25 * M_PI / 180.0 / 60.0;
    ax.bias_instability = 100 * kDegPerHour;
    ax.dither = true;
    const auto r = waveletSplit(simulateAxis(ax, 100, 360000, seed, 0), 0.01);
    ASSERT_TRUE(r.ok) << r.message;
    const Coefficient &q = r.terms[kQuantization], &n = r.terms[kAngleRandomWalk];
    EXPECT_NEAR(q.value, ax.quantization, 0.015 * ax.quantization) << seed;
    ASSERT_GT(n.sigma, 0) << seed;
    EXPECT_LT(std::fabs(n.value - ax.angle_random_walk) / n.sigma, 3.5) << seed;
  }
}

// B, K and R of the split are the input fit's, values and intervals, so the curve drawn for the split is the model
// that fit reported: the fit of the input's own oadev when the caller has none, the caller's when given. Where the
// model cannot describe the input (sawtooth quantization: a gross misfit) they are the denoised fit's. Dithered RLG
// noise with a B at 0.02 deg/h, 1 h at 100 Hz, simulateAxis seeds 1-2; a pulse counter at 10 deg/h, seed 4.
static void expectLongerTauTerms(const WaveletSplitResult& r, const FitResult& want, uint64_t seed) {
  for (int t = kBiasInstability; t < kNumTerms; ++t) {
    const size_t i = static_cast<size_t>(t);
    const Coefficient& got = r.terms[i];
    EXPECT_EQ(got.value, want.terms[i].value) << seed << " " << noiseTermKey(t);
    EXPECT_EQ(got.supported, want.terms[i].supported) << seed << " " << noiseTermKey(t);
    EXPECT_EQ(got.lo68, want.terms[i].lo68) << seed << " " << noiseTermKey(t);
    EXPECT_EQ(got.hi95, want.terms[i].hi95) << seed << " " << noiseTermKey(t);
  }
}

TEST(WaveletSplit, ReportsTheInputFitsLongerTauTerms) {
  for (uint64_t seed : {1u, 2u}) {
    AxisNoise ax;
    ax.quantization = kQ;
    ax.angle_random_walk = 0.002 * M_PI / 180.0 / 60.0;
    ax.bias_instability = 0.02 * kDegPerHour;
    ax.dither = true;
    const auto rate = simulateAxis(ax, 100, 360000, seed, 0);
    DeviationCurve c = computeDeviation("oadev", rate, InputKind::Rate, 0.01, DeviationOptions{});
    const FitResult input = fitWithModelEdf(&c);
    ASSERT_TRUE(input.ok);
    ASSERT_FALSE(grossMisfit(input));
    const auto own = waveletSplit(rate, 0.01);
    ASSERT_TRUE(own.ok) << own.message;
    EXPECT_TRUE(own.longer_tau_from_input);
    expectLongerTauTerms(own, input, seed);
    FitResult given = input;  // the caller's fit is used as given
    given.terms[kBiasInstability].value *= 1.5;
    const auto r = waveletSplit(rate, 0.01, WaveletSplitOptions{}, nullptr, &given);
    EXPECT_TRUE(r.longer_tau_from_input);
    expectLongerTauTerms(r, given, seed);
  }
  const auto rate = simulateAxis(undithered(kN, 10), 400, 400 * 1200, 4, 0);
  const auto r = waveletSplit(rate, 1.0 / 400);
  ASSERT_TRUE(r.ok) << r.message;
  EXPECT_FALSE(r.longer_tau_from_input);
  expectLongerTauTerms(r, r.denoised_fit, 4);
}

TEST(WaveletSplit, RecoversDeclaredQAndNSawtooth) {
  // Pulse counter without dither at a constant 10 deg/h: the quantization error is a sawtooth (not white).
  for (uint64_t seed : {4u, 5u}) {
    const double fs = 400;
    const auto rate = simulateAxis(undithered(kN, 10), fs, static_cast<int64_t>(fs * 1200), seed, 0);
    const auto r = waveletSplit(rate, 1.0 / fs);
    ASSERT_TRUE(r.ok) << r.message;
    EXPECT_NEAR(r.terms[kQuantization].value, kQ, 0.01 * kQ) << seed;
    EXPECT_NEAR(r.terms[kAngleRandomWalk].value, kN, 0.10 * kN) << seed;
    EXPECT_FALSE(r.quantization_white);
    EXPECT_LT(r.kept_fraction, 0.03);  // a few pulse coefficients pass the threshold (shrunk by the soft rule)
  }
}

TEST(WaveletSplit, SawtoothSigmasCoverTheSplitsBias) {
  // At 2 deg/h the sawtooth's line (1.65 Hz) sits near the split frequency, and the white-shaped level model misjudges
  // how much of it the split loses: Q came out 0.20 % low with a scatter of 0.03 % (coverage_study rlg_saw2, 2 h,
  // seeds 1-60), N ~1 % low. The parametric bootstrap (WaveletSplitOptions::sawtooth_replicas) corrects both by the
  // bias it finds on records simulated from the fitted model, and Q's sigma is the replicas' scatter.
  // Checks on 8 records of rlg_saw2's noise at 1 h (simulateAxis seeds 11..18):
  //  - the mean relative error of Q is within 0.06 %: the corrected estimate scatters 0.034 % per 2 h record, so
  //    ~0.048 % per 1 h record and 0.017 % for a mean of 8, and 0.06 % is 3.5 of those; without the correction the
  //    mean is -0.18 to -0.20 % and fails. (N's correction is not checked here: its scatter, ~1.8 % per 1 h record,
  //    leaves the mean of 8 too loose to tell a -1 % bias from none.)
  //  - sum of z^2 in [0.86, 23.6], chi-squared with 8 dof's central 99.7 %; with a sigma estimated from 9-dof replicas
  //    z is t-distributed and the upper end is passed by chance ~4 % of the time. Measured: Q 6.4, N 6.6.
  //  - Q's 68 % and 95 % intervals are Student t's (1.06 and 2.26 sigma), not the normal 1 and 1.96.
  constexpr double kN2 = 0.002 * M_PI / 180.0 / 60.0;
  double zq2 = 0, zn2 = 0, rel = 0;
  int boot = 0;
  for (uint64_t seed = 11; seed <= 18; ++seed) {
    AxisNoise ax = undithered(kN2, 2);
    ax.bias_instability = 0.005 * kDegPerHour;
    const double fs = 100;
    const auto rate = simulateAxis(ax, fs, static_cast<int64_t>(fs * 3600), seed, 0);
    const auto r = waveletSplit(rate, 1.0 / fs);
    ASSERT_TRUE(r.ok) << r.message;
    EXPECT_FALSE(r.quantization_white) << seed;
    boot += r.sawtooth_bootstrap.applied && r.sawtooth_bootstrap.replicas == WaveletSplitOptions{}.sawtooth_replicas;
    const Coefficient& q = r.terms[kQuantization];
    const Coefficient& n = r.terms[kAngleRandomWalk];
    EXPECT_NEAR(q.value, kQ, 0.005 * kQ) << seed;
    EXPECT_NEAR(n.value, kN2, 0.10 * kN2) << seed;
    ASSERT_GT(q.sigma, 0);
    ASSERT_GT(n.sigma, 0);
    EXPECT_LT(q.lo68, q.value - 1.04 * q.sigma) << seed;  // normal: value - 1.00 sigma (sigma / Q ~ 3e-4)
    EXPECT_GT(q.lo68, q.value - 1.08 * q.sigma) << seed;
    EXPECT_LT(q.lo95, q.value - 2.20 * q.sigma) << seed;  // normal: value - 1.96 sigma
    EXPECT_GT(q.lo95, q.value - 2.32 * q.sigma) << seed;
    rel += (q.value / kQ - 1) / 8;
    zq2 += std::pow((q.value - kQ) / q.sigma, 2);
    zn2 += std::pow((n.value - kN2) / n.sigma, 2);
  }
  std::printf("2 deg/h: mean relative error of Q %+.4f %%; sum z^2 of Q = %.1f, of N = %.1f on 8 records; accepted "
              "|mean| <= 0.06 %%, [0.86, 23.6]\n", 100 * rel, zq2, zn2);
  EXPECT_EQ(boot, 8) << "every record should have run the sawtooth bootstrap";
  EXPECT_LE(std::fabs(rel), 0.0006) << "Q's bias at 2 deg/h is not corrected";
  EXPECT_GE(zq2, 0.86) << "Q's sigma is far wider than its error";
  EXPECT_LE(zq2, 23.6) << "Q's sigma does not cover its error";
  EXPECT_GE(zn2, 0.86) << "N's sigma is far wider than its error";
  EXPECT_LE(zn2, 23.6) << "N's sigma does not cover its error";
}

TEST(WaveletSplit, ShortSawtoothRecordIsNotTakenForWhite) {
  // 10 min at 2 deg/h (rlg_saw2's noise): the free level fit has only the levels below the split (0.78 Hz) and its
  // share of the quantization is uncertain, so it can agree with white quantization by chance. The fixed (white)
  // fit then read the sawtooth's power on the finer levels it adds as ARW: N^2 x100, Q^2 driven to 0, the split
  // failed and the axis fell back to a joint fit flagged bad (coverage_study rlg_saw2 at 600 s: 10 of 40 axes,
  // seeds 1-40). The fits' disagreement on N^2 marks the quantization as not white. Records 21..32 of the
  // simulator (before the N^2 test, 7 of them failed and Q's 95 % interval held 4 of 12): each must be split, judged
  // not white and bootstrapped, with Q within 1 % and N within 15 % (3 of its ~5 % sigma per 10 min record); Q's
  // 95 % interval must hold the truth in at least 10 of 12 (at a true 95 %, fewer happens with probability 0.02).
  constexpr double kN2 = 0.002 * M_PI / 180.0 / 60.0;
  int q95 = 0;
  for (uint64_t seed = 21; seed <= 32; ++seed) {
    AxisNoise ax = undithered(kN2, 2);
    ax.bias_instability = 0.005 * kDegPerHour;
    const auto r = waveletSplit(simulateAxis(ax, 100, 100 * 600, seed, 0), 0.01);
    ASSERT_TRUE(r.ok) << seed << ": " << r.message;
    EXPECT_FALSE(r.quantization_white) << seed;
    EXPECT_TRUE(r.sawtooth_bootstrap.applied) << seed << ": " << r.sawtooth_bootstrap.note;
    const Coefficient& q = r.terms[kQuantization];
    EXPECT_NEAR(q.value, kQ, 0.01 * kQ) << seed;
    EXPECT_NEAR(r.terms[kAngleRandomWalk].value, kN2, 0.15 * kN2) << seed;
    q95 += q.lo95 <= kQ && kQ <= q.hi95;
  }
  EXPECT_GE(q95, 10) << "Q's 95 % interval held the truth in " << q95 << " of 12";
}

TEST(WaveletSplit, SawtoothBootstrapOffKeepsTheAllowance) {
  // sawtooth_replicas 0: the analytic allowance and normal intervals, the bias left in; a dithered
  // (white) record never runs the bootstrap.
  constexpr double kN2 = 0.002 * M_PI / 180.0 / 60.0;
  AxisNoise ax = undithered(kN2, 2);
  const auto rate = simulateAxis(ax, 100, 100 * 3600, 11, 0);
  WaveletSplitOptions off;
  off.sawtooth_replicas = 0;
  const auto r = waveletSplit(rate, 0.01, off);
  ASSERT_TRUE(r.ok) << r.message;
  EXPECT_EQ(r.sawtooth_bootstrap.replicas, 0);
  EXPECT_FALSE(r.sawtooth_bootstrap.applied);
  const Coefficient& q = r.terms[kQuantization];
  EXPECT_NEAR(q.lo68, std::sqrt(q.value * q.value - 2 * q.value * q.sigma), 1e-6 * kQ);
  AxisNoise dith = ax;
  dith.dither = true;
  const auto rd = waveletSplit(simulateAxis(dith, 100, 100 * 1800, 12, 0), 0.01);
  ASSERT_TRUE(rd.ok) << rd.message;
  EXPECT_TRUE(rd.quantization_white);
  EXPECT_EQ(rd.sawtooth_bootstrap.replicas, 0);
}

TEST(WaveletSplit, MadScalingKeepsSawtoothPulses) {
  // Why the pipeline uses sln_rms: with the MAD the sparse quantization pulses look like signal and are kept.
  const auto rate = simulateAxis(undithered(kN, 10), 400, 400 * 300, 9, 0);
  WdenOptions o;
  o.level = 7;
  o.scaling = NoiseScaling::Sln;
  const auto mad = wden(rate, o);
  o.scaling = NoiseScaling::SlnRms;
  const auto rms = wden(rate, o);
  EXPECT_GT(mad.kept_fraction[0], 0.2);
  EXPECT_LT(rms.kept_fraction[0], 0.05);
}

TEST(WaveletSplit, BadInputThrows) {
  std::vector<double> x(100000, 0.0);
  EXPECT_THROW(waveletSplit(x, 0.0), std::invalid_argument);
  EXPECT_THROW(waveletSplit(std::vector<double>(100, 0.0), 0.01), std::invalid_argument);
  WaveletSplitOptions o;
  o.q_estimator = "median";
  EXPECT_THROW(waveletSplit(x, 0.01, o), std::invalid_argument);
  o = WaveletSplitOptions{};
  o.wavelet = "db99";
  EXPECT_THROW(waveletSplit(x, 0.01, o), std::invalid_argument);
  x[5] = std::nan("");
  EXPECT_THROW(waveletSplit(x, 0.01), std::invalid_argument);
  EXPECT_THROW(splitAngleFactors(Wavelet("sym8"), 0), std::invalid_argument);
}

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
