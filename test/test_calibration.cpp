// Calibration of the IEEE fit's intervals and term selection on simulated gyros with declared noise (fixed seeds):
// coverage of the 68 % / 95 % intervals and the phantom-term rate, with tolerances from the binomial spread.
#include <gtest/gtest.h>

#include <boost/math/distributions/chi_squared.hpp>

#include <cmath>
#include <cstdio>
#include <initializer_list>
#include <thread>

#include "gyro_allan/allan.hpp"
#include "gyro_allan/analysis.hpp"
#include "gyro_allan/model_check.hpp"
#include "gyro_allan/noise_model.hpp"
#include "gyro_allan/simulate.hpp"

using namespace gyro_allan;

namespace {

constexpr double kDeg = M_PI / 180.0;

// Intervals holding the truth among a set of cases.
struct Counts {
  int cases = 0, in68 = 0, in95 = 0;
  void add(int i68, int i95) {
    ++cases;
    in68 += i68;
    in95 += i95;
  }
};

struct Tally {
  Counts all;                   // terms with truth > 0
  Counts sel_term[kNumTerms];   // ... supported, per term: [lo, hi]
  Counts drop_term[kNumTerms];  // ... not supported, per term: [lo (usually 0), hi]
  int zeros = 0, phantom = 0;   // terms with truth 0
  double n_z2 = 0;              // sum of ((N - truth) / sigma)^2
  double n_z = 0;               // sum of (N - truth) / sigma
  int n_cases = 0;
  int ramp_bounded = 0;         // fits whose ramp's 95 % interval allows a dropped K (ramp_bounded_by_random_walk)
  // The unsupported terms of `terms` pooled (all five by default).
  Counts dropped(std::initializer_list<int> terms = kAllTerms) const { return pooled(drop_term, terms); }
  // The supported terms, pooled.
  Counts selected() const { return pooled(sel_term, kAllTerms); }

 private:
  static constexpr std::initializer_list<int> kAllTerms = {kQuantization, kAngleRandomWalk, kBiasInstability,
                                                           kRateRandomWalk, kRateRamp};
  static Counts pooled(const Counts (&per_term)[kNumTerms], std::initializer_list<int> terms) {
    Counts c;
    for (int k : terms) {
      c.cases += per_term[k].cases;
      c.in68 += per_term[k].in68;
      c.in95 += per_term[k].in95;
    }
    return c;
  }
};

// Runs the plain joint fit (oadev, GLS) on `seeds` records of one class and tallies every term.
void runClass(const AxisNoise& noise, double rate_hz, double duration_s, uint64_t first_seed, int seeds, Tally* t) {
  const double truth[kNumTerms] = {noise.quantization, noise.angle_random_walk, noise.bias_instability,
                                   noise.rate_random_walk, noise.rate_ramp};
  std::vector<FitResult> fits(static_cast<size_t>(seeds));
  auto work = [&](int part) {
    for (int s = part; s < seeds; s += 2) {
      const std::vector<double> y =
          simulateAxis(noise, rate_hz, static_cast<int64_t>(rate_hz * duration_s), first_seed + static_cast<uint64_t>(s));
      DeviationCurve c = computeDeviation("oadev", y, InputKind::Rate, 1.0 / rate_hz, DeviationOptions{});
      enforceRedderWithTau(&c, 0.683);
      fits[static_cast<size_t>(s)] = fitWithModelEdf(&c, FitOptions{}, 0.683);
    }
  };
  std::thread th(work, 1);
  work(0);
  th.join();
  for (const FitResult& f : fits) {
    ASSERT_TRUE(f.ok) << f.message;
    t->ramp_bounded += f.ramp_bounded_by_random_walk ? 1 : 0;
    for (int k = 0; k < kNumTerms; ++k) {
      const Coefficient& co = f.terms_corrected[static_cast<size_t>(k)];
      if (k == kAngleRandomWalk && co.supported && co.sigma > 0) {
        t->n_z2 += std::pow((co.value - truth[k]) / co.sigma, 2);
        t->n_z += (co.value - truth[k]) / co.sigma;
        ++t->n_cases;
      }
      if (truth[k] > 0) {
        const int in68 = (truth[k] >= co.lo68 && truth[k] <= co.hi68) ? 1 : 0;
        const int in95 = (truth[k] >= co.lo95 && truth[k] <= co.hi95) ? 1 : 0;
        t->all.add(in68, in95);
        (co.supported ? t->sel_term[k] : t->drop_term[k]).add(in68, in95);
      } else {
        ++t->zeros;
        t->phantom += co.supported ? 1 : 0;
      }
    }
  }
}

// |observed - p| within 3 binomial standard deviations (a false failure ~ 0.3 % per check).
void expectBinomial(int hits, int n, double p, const char* what) {
  const double sd = std::sqrt(p * (1 - p) / n);
  EXPECT_NEAR(static_cast<double>(hits) / n, p, 3 * sd) << what << ": " << hits << "/" << n;
}

// A 95 % interval holding the truth at least that often, less 3 binomial standard deviations.
void expectAtLeast95(int hits, int n, const char* what) {
  EXPECT_GE(static_cast<double>(hits) / n, 0.95 - 3 * std::sqrt(0.95 * 0.05 / n)) << what << ": " << hits << "/" << n;
}

// The dropped K's and R's coverage of a run, printed.
void printDroppedLongTau(const Tally& t) {
  const Counts& k = t.drop_term[kRateRandomWalk];
  const Counts& r = t.drop_term[kRateRamp];
  std::printf("dropped K: 68 %% %d/%d, 95 %% %d/%d; dropped R: 68 %% %d/%d, 95 %% %d/%d\n", k.in68, k.cases, k.in95,
              k.cases, r.in68, r.cases, r.in95, r.cases);
}

// The issue's MEMS example: N, B, K declared; Q and R absent.
AxisNoise issueMems() {
  AxisNoise mems;
  mems.angle_random_walk = 2e-4;
  mems.bias_instability = 1e-5;
  mems.rate_random_walk = 1e-6;
  return mems;
}

// The coverage study's tactical_ramp class: N 0.1 deg/sqrt(h), B 0.8 deg/h, K 0.5 deg/h/sqrt(h), R 2 deg/h^2.
AxisNoise tacticalWithRamp() {
  AxisNoise a;
  a.angle_random_walk = 0.1 / 60 * kDeg;
  a.bias_instability = 0.8 / 3600 * kDeg;
  a.rate_random_walk = 0.5 / 3600 / 60 * kDeg;
  a.rate_ramp = 2.0 / 3600 / 3600 * kDeg;
  return a;
}

}  // namespace

TEST(Calibration, IntervalsCoverAndNoPhantomTerms) {
  // Two classes (validation-style seeds 7001..): the issue's MEMS example (N, B, K; Q and R absent) and a dithered
  // ring-laser gyro (Q, N, B; K and R absent). 30 records each, 30 min at 100 Hz.
  Tally t;
  runClass(issueMems(), 100, 1800, 7001, 30, &t);
  AxisNoise rlg;
  rlg.quantization = 0.35 / 3600 * kDeg;
  rlg.angle_random_walk = 0.002 / 60 * kDeg;
  rlg.bias_instability = 0.003 / 3600 * kDeg;
  runClass(rlg, 100, 1800, 7101, 30, &t);
  const Counts& a = t.all;
  const Counts sel = t.selected();
  const Counts d = t.dropped();
  ASSERT_EQ(a.cases, 180);
  std::printf("coverage 68 %%: %d/%d, 95 %%: %d/%d (supported terms %d/%d, %d/%d; not supported %d/%d, %d/%d); "
              "phantom terms %d/%d\n",
              a.in68, a.cases, a.in95, a.cases, sel.in68, sel.cases, sel.in95, sel.cases, d.in68, d.cases, d.in95,
              d.cases, t.phantom, t.zeros);
  // Supported terms: intervals conditional on the selection (selective.hpp) hold the truth at their nominal rate.
  // Pooled over terms (cases within a record are not independent; the 3-sigma band still allows for it).
  expectBinomial(sel.in68, sel.cases, 0.683, "68 % intervals of supported terms holding the truth");
  expectAtLeast95(sel.in95, sel.cases, "95 % intervals of supported terms holding the truth");
  // Terms not supported: the 68 % interval is the unified (Feldman-Cousins) one of the dropped estimate's truncated
  // distribution, at its nominal rate also where the truth is far below detection (the 30-min records' B and K);
  // the 95 % one is the one-sided power-constrained bound: no under-coverage. Overall, 68 % at nominal too.
  expectBinomial(d.in68, d.cases, 0.683, "68 % intervals of unsupported terms holding the truth");
  expectBinomial(a.in68, a.cases, 0.683, "68 % intervals holding the truth");
  expectAtLeast95(d.in95, d.cases, "95 % bounds of unsupported terms holding the truth");
  expectAtLeast95(a.in95, a.cases, "95 % intervals holding the truth");
  // Phantom terms: the selection penalty 4 (6 for the ramp) aims at <= 5 % per absent term.
  EXPECT_LE(static_cast<double>(t.phantom) / t.zeros, 0.05 + 3 * std::sqrt(0.05 * 0.95 / t.zeros))
      << "absent terms reported supported: " << t.phantom << "/" << t.zeros;
}

TEST(Calibration, AngleRandomWalkSigmaMatchesItsScatter) {
  // N is always selected; its sigma comes from the selected columns. With the full model's columns (the quantization
  // column, nearly collinear with N's, in as well) the interval was wider than the scatter where Q is 0: rms of
  // (N - truth) / sigma 0.67-0.93 in the joint-fit classes of coverage_study. 200 records of the issue's MEMS
  // example (Q = 0), 1 h at 20 Hz, seeds 7201..: sum z^2 is chi-squared with 200 dof if sigma is right; the test
  // takes its central 99.7 % range. Measured: 210 (rms z 1.03); with the full model's columns 144 (0.85), a failure.
  Tally t;
  runClass(issueMems(), 20, 3600, 7201, 200, &t);
  ASSERT_EQ(t.n_cases, 200);
  const boost::math::chi_squared chi2(t.n_cases);
  const double lo = boost::math::quantile(chi2, 0.0015), hi = boost::math::quantile(chi2, 0.9985);
  std::printf("N: sum z^2 = %.1f on %d records (rms z %.2f); accepted [%.1f, %.1f]\n", t.n_z2, t.n_cases,
              std::sqrt(t.n_z2 / t.n_cases), lo, hi);
  EXPECT_GE(t.n_z2, lo) << "N's sigma is wider than its scatter";
  EXPECT_LE(t.n_z2, hi) << "N's sigma is narrower than its scatter";
}

// A rate random walk below its entry threshold (K = 10 deg/h/sqrt(h) beside B = 3 deg/h, 2 h at 100 Hz: K is
// selected in ~5-10 % of the records) pushes the bias instability up when it is left out. A larger set of terms
// within kSupersetGap on AIC widens B's interval towards that set's value (FitResult::widened): B's 68 % interval must
// hold the truth at its nominal rate within the binomial band, and more often than the unwidened one (`terms`, the
// same fit's intervals before the widening and the rival rule, which does not act on B in these records; the
// study's seeds 1-40: 0.58 -> 0.70, 21001-21060: 0.58 -> 0.68).
TEST(Calibration, BiasInstabilityCoversWhereRateRandomWalkIsBelowEntry) {
  AxisNoise a;
  a.angle_random_walk = 0.25 / 60 * kDeg;
  a.bias_instability = 3.0 / 3600 * kDeg;
  a.rate_random_walk = 10.0 / 3600 / 60 * kDeg;
  const int n = 30;
  std::vector<FitResult> fits(static_cast<size_t>(n));
  auto work = [&](int part) {
    for (int s = part; s < n; s += 2) {
      const std::vector<double> y = simulateAxis(a, 100.0, 720000, 7201 + static_cast<uint64_t>(s));
      DeviationCurve c = computeDeviation("oadev", y, InputKind::Rate, 0.01, DeviationOptions{});
      enforceRedderWithTau(&c, 0.683);
      fits[static_cast<size_t>(s)] = fitWithModelEdf(&c, FitOptions{}, 0.683);
    }
  };
  std::thread th(work, 1);
  work(0);
  th.join();
  const double b = a.bias_instability;
  int in68 = 0, in95 = 0, plain68 = 0, widened = 0, supported = 0, ambiguous = 0;
  for (const FitResult& f : fits) {
    ASSERT_TRUE(f.ok) << f.message;
    const Coefficient& co = f.terms_corrected[kBiasInstability];
    const Coefficient& plain = f.terms[kBiasInstability];
    in68 += co.lo68 <= b && b <= co.hi68;
    in95 += co.lo95 <= b && b <= co.hi95;
    plain68 += plain.lo68 <= b && b <= plain.hi68;
    widened += f.widened[kBiasInstability];
    supported += co.supported;
    ambiguous += f.ambiguous[kBiasInstability];
    if (f.widened[kBiasInstability]) {  // widened, never narrowed, and only by a larger set within the gap
      EXPECT_TRUE(co.lo68 <= plain.lo68 && co.hi68 >= plain.hi68 && co.lo95 <= plain.lo95 && co.hi95 >= plain.hi95);
      EXPECT_TRUE(co.lo68 < plain.lo68 || co.hi68 > plain.hi68 || co.lo95 < plain.lo95 || co.hi95 > plain.hi95);
      EXPECT_FALSE(f.close_superset_terms.empty());
    }
  }
  std::printf("B: 68 %% %d/%d (without the widening %d), 95 %% %d/%d; widened in %d, supported in %d\n", in68, n,
              plain68, in95, n, widened, supported);
  EXPECT_GE(supported, n * 3 / 4);  // the class is one where B is detected
  EXPECT_GE(widened, 3);            // the rule acts in this class
  EXPECT_EQ(ambiguous, 0);          // so that `terms` against terms_corrected is the widening alone
  expectBinomial(in68, n, 0.683, "B's 68 % intervals holding the truth");
  expectAtLeast95(in95, n, "B's 95 %");
  EXPECT_GT(in68, plain68);
}

// A rate random walk and a rate ramp far below what a 1 h record detects (the coverage study's tactical_ramp class:
// N 0.1 deg/sqrt(h), B 0.8 deg/h, K 0.5 deg/h/sqrt(h), R 2 deg/h^2, 200 Hz), both dropped: their unified 68 %
// intervals must hold the truth at the nominal rate within the binomial band, their 95 % bounds at least 95 %.
// 120 records, simulateAxis seeds 8301..; K and R pooled (the two terms of a record are not independent; the 3-sigma
// band still allows for it). Measured: K 89/120, R 83/120 (pooled 0.717; before session 20's joint estimate of the
// dropped K and R, 83/120 and 87/120). The study's analyzeAxis runs of the class measured K 0.72-0.85 and R
// 0.78-0.83 per seed set of 40-100 records before it (docs/calibration.md, "Session 18"). The band guards against
// drifts of 10 points or more; it could not tell session 18's rejected 0.60 level (77/120, 79/120).
TEST(Calibration, DroppedLongTauTermsCoverAtTheirStatedRate) {
  const AxisNoise a = tacticalWithRamp();
  Tally t;
  runClass(a, 200, 3600, 8301, 120, &t);
  const Counts d = t.dropped({kRateRandomWalk, kRateRamp});
  printDroppedLongTau(t);
  ASSERT_GE(d.cases, 200);  // K and R are dropped in nearly every record
  expectBinomial(d.in68, d.cases, 0.683, "68 % intervals of dropped K and R holding the truth");
  expectAtLeast95(d.in95, d.cases, "95 % bounds of dropped K and R");
}

// The tactical class with a ramp (as above) over 4 h at 50 Hz, where K and R are both dropped in most records and
// nearer detection. A dropped K fitted with the selected terms alone took up the dropped ramp's rise, and its 68 %
// interval started above the truth (coverage_study, 60 records: K 0.35, the lower end above the truth in 62 %).
// Since session 20 the dropped K and R are estimated together (noise_model_gls.cpp, jointEstimate). The dropped K's
// 68 % intervals must hold the truth at the nominal rate within the binomial band, its 95 % bounds at least 95 %.
// 60 records, simulateAxis seeds 8501..; measured 47/60 (95 %: 60/60), and 22/60 before the joint estimate.
TEST(Calibration, DroppedRandomWalkBesideADroppedRampCovers) {
  const AxisNoise a = tacticalWithRamp();
  Tally t;
  runClass(a, 50, 4 * 3600, 8501, 60, &t);
  const Counts& k = t.drop_term[kRateRandomWalk];
  printDroppedLongTau(t);
  ASSERT_GE(k.cases, 40);  // K is dropped in most records
  expectBinomial(k.in68, k.cases, 0.683, "68 % intervals of the dropped K holding the truth");
  expectAtLeast95(k.in95, k.cases, "95 % bounds of the dropped K");
}

// A strong flicker bias instability beside a weak angle random walk (N 0.25 deg/sqrt(h), B 30 deg/h; 1 h at 100 Hz).
// A sampled flicker's Allan variance is not flat at the shortest taus where N is read: 1.44, 1.15, 1.05 times its
// floor at 1, 2 and 4 samples (flickerAvarShape). With a flat B column that excess was read as angle random walk, and
// N came out high by about two of its sigmas here (cons4h, N 0.25 and B 8 at 4 h: mean z +0.45, N's 95 % coverage 0.87
// of 200; docs/calibration.md, "Session 22"). The mean of (N - truth) / sigma over the records must lie within 3 of its
// standard errors (1 / sqrt(n)) of 0, and sum z^2 within chi-squared's central 99.7 %. 30 records, seeds 8701..
TEST(Calibration, AngleRandomWalkIsUnbiasedBesideAStrongFlicker) {
  AxisNoise a;
  a.angle_random_walk = 0.25 / 60 * kDeg;
  a.bias_instability = 30.0 / 3600 * kDeg;
  Tally t;
  runClass(a, 100, 3600, 8701, 30, &t);
  ASSERT_EQ(t.n_cases, 30);
  const double mean_z = t.n_z / t.n_cases;
  const boost::math::chi_squared chi2(t.n_cases);
  std::printf("N: mean z %+.2f, sum z^2 %.1f on %d records\n", mean_z, t.n_z2, t.n_cases);
  EXPECT_LE(std::fabs(mean_z), 3.0 / std::sqrt(t.n_cases)) << "N is biased beside a flicker";
  EXPECT_GE(t.n_z2, boost::math::quantile(chi2, 0.0015)) << "N's sigma is wider than its scatter";
  EXPECT_LE(t.n_z2, boost::math::quantile(chi2, 0.9985)) << "N's sigma is narrower than its scatter";
}

// A gyro whose rate ramp is plain but whose rate random walk is not (N 0.15 deg/sqrt(h), K 3 deg/h/sqrt(h), R 20
// deg/h^2; 2 h at 100 Hz): R is selected and K dropped in most records. The ramp's Allan estimates scatter through
// the rate random walk's wander (a cross term that grows with K), and the full model's K, which the ramp's interval
// was computed at, is 0 in most such records: R's 95 % interval held the truth in 69 of 100 records, 85 of them with R
// supported (coverage_study, seeds 28001-28100). Since session 21 a selected ramp's 95 % interval allows K up to the
// upper end of K's 68 % interval (noise_model_gls.cpp, boundRampByRandomWalk). The supported R's 95 % intervals must
// hold the truth at least 95 % of the time, less the binomial allowance, and the bound must act in most records. Its
// 68 % intervals still under-cover (docs/calibration.md, "Session 21"), so they are printed, not checked. 60 records,
// simulateAxis seeds 8601..
TEST(Calibration, SelectedRampBesideADroppedRandomWalkCoversAt95) {
  AxisNoise a;
  a.angle_random_walk = 0.15 / 60 * kDeg;
  a.rate_random_walk = 3.0 / 3600 / 60 * kDeg;
  a.rate_ramp = 20.0 / 3600 / 3600 * kDeg;
  Tally t;
  runClass(a, 100, 2 * 3600, 8601, 60, &t);
  const Counts& r = t.sel_term[kRateRamp];
  EXPECT_GT(t.ramp_bounded, r.cases / 2) << "the bound acts in most of these records";
  std::printf("selected R: 68 %% %d/%d, 95 %% %d/%d (widened in %d); dropped K: 68 %% %d/%d\n", r.in68, r.cases,
              r.in95, r.cases, t.ramp_bounded, t.drop_term[kRateRandomWalk].in68, t.drop_term[kRateRandomWalk].cases);
  ASSERT_GE(r.cases, 40);  // R is selected in most records
  expectAtLeast95(r.in95, r.cases, "95 % intervals of the selected R beside a dropped K");
}
