// Tests of selective.hpp: the truncated-normal pivot, and the coverage and median-unbiasedness of the conditional
// estimates on draws with declared truth (tolerances: 3 binomial standard errors).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "gyro_allan/selective.hpp"

using namespace gyro_allan;

namespace {

double binomialTolerance(double p, int n) { return 3.0 * std::sqrt(p * (1 - p) / n); }

struct Tally {
  int n = 0, in68 = 0, in95 = 0, below_median = 0;
};

// X ~ N(mu, v(mu)); the "fit" keeps it when X >= threshold. Tally the selected and the dropped draws apart.
void simulate(double mu, const VarianceModel& v, double threshold, int draws, uint32_t seed, Tally* sel, Tally* drop) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> z;
  const double s = std::sqrt(v.at(mu));
  for (int i = 0; i < draws; ++i) {
    const double x = mu + s * z(rng);
    SelectionEvent e;
    e.selected = x >= threshold;
    e.threshold = threshold;
    const SelectiveEstimate est = selectiveEstimate(x, v, e);
    Tally* t = e.selected ? sel : drop;
    ++t->n;
    t->in68 += est.lo68 <= mu && mu <= est.hi68;
    t->in95 += est.lo95 <= mu && mu <= est.hi95;
    t->below_median += est.median < mu;
  }
}

}  // namespace

TEST(Selective, PivotIsAProbabilityAndDecreasesInMu) {
  VarianceModel v;
  v.v0 = 1.0;
  const SelectionEvent sel{true, 2.0}, drop{false, 2.0};
  double last_sel = 2, last_drop = 2;
  for (double mu = 0; mu <= 8; mu += 0.5) {
    const double ps = selectivePivot(3.0, mu, v, sel), pd = selectivePivot(0.5, mu, v, drop);
    EXPECT_GE(ps, 0.0);
    EXPECT_LE(ps, 1.0);
    EXPECT_GE(pd, 0.0);
    EXPECT_LE(pd, 1.0);
    EXPECT_LE(ps, last_sel + 1e-12);
    EXPECT_LE(pd, last_drop + 1e-12);
    last_sel = ps;
    last_drop = pd;
  }
  // No truncation: the plain normal cdf.
  const SelectionEvent none{true, -std::numeric_limits<double>::infinity()};
  EXPECT_NEAR(selectivePivot(1.0, 0.0, v, none), 0.8413447460685429, 1e-12);
  // Deep in the tail (the asymptotic branch) it stays finite and in [0, 1].
  const double deep = selectivePivot(41.0, 0.0, v, SelectionEvent{true, 40.0});
  EXPECT_GT(deep, 0.9);
  EXPECT_LE(deep, 1.0);
}

TEST(Selective, UntruncatedEstimateIsTheCentralInterval) {
  VarianceModel v;
  v.v0 = 4.0;  // sd 2
  const SelectionEvent none{true, -std::numeric_limits<double>::infinity()};
  const SelectiveEstimate e = selectiveEstimate(20.0, v, none);
  EXPECT_NEAR(e.median, 20.0, 1e-6);
  EXPECT_NEAR(e.lo68, 18.0, 1e-6);
  EXPECT_NEAR(e.hi68, 22.0, 1e-6);
  EXPECT_NEAR(e.lo95, 20.0 - 2 * 1.959963984540054, 1e-6);
  EXPECT_NEAR(e.hi95, 20.0 + 2 * 1.959963984540054, 1e-6);
}

TEST(Selective, VarianceModelThroughThreePoints) {
  const double mu[3] = {0.0, 1.0, 3.0};
  const double var[3] = {1.0, 1.0 + 0.5 + 0.25, 1.0 + 1.5 + 2.25};  // 1 + 0.5 mu + 0.25 mu^2
  const VarianceModel m = VarianceModel::through(mu, var);
  EXPECT_NEAR(m.v0, 1.0, 1e-12);
  EXPECT_NEAR(m.v1, 0.5, 1e-12);
  EXPECT_NEAR(m.v2, 0.25, 1e-12);
  const double bad[3] = {1.0, 3.0, 2.0};  // negative curvature: falls back to a line through the outer points
  const VarianceModel f = VarianceModel::through(mu, bad);
  EXPECT_GE(f.v2, 0.0);
  EXPECT_GT(f.at(0.0), 0.0);
  EXPECT_GT(f.at(10.0), 0.0);
}

TEST(Selective, EntryThresholdIsTheFixedPoint) {
  // Constant variance: sqrt(penalty) sd. Growing variance: x^2 = penalty var(x), the larger root; the cap on mu does
  // not enter. Relative sd at large mu >= 1 / sqrt(penalty): the term never enters.
  VarianceModel flat;
  flat.v0 = 4.0;
  EXPECT_NEAR(flat.entryThreshold(4.0), 4.0, 1e-12);
  VarianceModel grow;
  grow.v0 = 1.0;
  grow.v1 = 0.5;
  grow.v2 = 0.05;
  grow.cap_mu = 0.1;
  const double t = grow.entryThreshold(4.0);
  EXPECT_NEAR(t * t, 4.0 * (1.0 + 0.5 * t + 0.05 * t * t), 1e-9 * t * t);
  EXPECT_GT(t, 2.0);  // above sqrt(penalty) sd(0)
  VarianceModel down;  // a variance dipping at small mu still gives the positive root
  down.v0 = 1.0;
  down.v1 = -0.5;
  down.v2 = 0.1;
  const double u = down.entryThreshold(4.0);
  EXPECT_GT(u, 0.0);
  EXPECT_NEAR(u * u, 4.0 * (1.0 - 0.5 * u + 0.1 * u * u), 1e-9 * u * u);
  VarianceModel steep;
  steep.v0 = 1.0;
  steep.v2 = 0.25;
  EXPECT_TRUE(std::isinf(steep.entryThreshold(4.0)));
}

// Conditional coverage among selected draws and median-unbiasedness, for a term near the detection limit (truth 1.5
// sd: selected ~31 % of the time, and its plain value then biased up by ~+70 %) and a strong one (truth 5 sd).
TEST(Selective, SelectedDrawsAreCoveredAndMedianUnbiased) {
  for (double mu : {1.5, 5.0}) {
    VarianceModel v;
    v.v0 = 1.0;
    v.v1 = 0.05;  // the scatter grows with the term
    Tally sel, drop;
    simulate(mu, v, 2.0, 4000, 11u + static_cast<uint32_t>(mu * 10), &sel, &drop);
    ASSERT_GT(sel.n, 500);
    const double c68 = static_cast<double>(sel.in68) / sel.n, c95 = static_cast<double>(sel.in95) / sel.n;
    const double below = static_cast<double>(sel.below_median) / sel.n;
    EXPECT_NEAR(c68, 0.6827, binomialTolerance(0.6827, sel.n)) << "mu " << mu;
    EXPECT_NEAR(c95, 0.95, binomialTolerance(0.95, sel.n)) << "mu " << mu;
    EXPECT_NEAR(below, 0.5, binomialTolerance(0.5, sel.n)) << "mu " << mu;
  }
}

// A skewed estimate selected above a threshold: right-skewed like the long-tau Allan points behind a rate random walk
// (shifted gamma, skew 1), and its mirror (skew -1, the gamma_p branch). With its third cumulant in the model the
// selected draws are covered and the corrected value is median-unbiased; the normal model, on the same draws, keeps
// the right-skewed selected values too high (the winner's curse is larger than a normal tail allows) and corrects
// the left-skewed ones too far.
TEST(Selective, SkewedSelectedDrawsAreCoveredWithTheirThirdCumulant) {
  for (double g : {1.0, -1.0}) {
    const double mu = 1.5, var = 1.0, k = 4.0 / (g * g);
    VarianceModel skewed;
    skewed.v0 = var;
    skewed.kappa3.k0 = var;  // kappa3 = k0^2 i3 / i2^2 = var^2 g / sqrt(var): skew g at every mu
    skewed.kappa3.i2[0] = 1.0;
    skewed.kappa3.i3[0] = g / std::sqrt(var);
    ASSERT_NEAR(skewed.skewAt(mu), g, 1e-12);
    VarianceModel normal;
    normal.v0 = var;
    std::mt19937_64 rng(20261127u);
    std::gamma_distribution<double> gam(k, 1.0);
    Tally with, without;
    for (int i = 0; i < 20000; ++i) {
      const double x = mu + (g > 0 ? 1.0 : -1.0) * std::sqrt(var) * (gam(rng) - k) / std::sqrt(k);
      const SelectionEvent e{true, 2.0};
      if (x < e.threshold) continue;
      for (Tally* t : {&with, &without}) {
        const SelectiveEstimate est = selectiveEstimate(x, t == &with ? skewed : normal, e);
        ++t->n;
        t->in68 += est.lo68 <= mu && mu <= est.hi68;
        t->in95 += est.lo95 <= mu && mu <= est.hi95;
        t->below_median += est.median < mu;
      }
    }
    ASSERT_GT(with.n, 2000) << "skew " << g;
    const double below = static_cast<double>(with.below_median) / with.n;
    EXPECT_NEAR(below, 0.5, binomialTolerance(0.5, with.n)) << "skew " << g;
    EXPECT_NEAR(static_cast<double>(with.in68) / with.n, 0.6827, binomialTolerance(0.6827, with.n)) << "skew " << g;
    EXPECT_NEAR(static_cast<double>(with.in95) / with.n, 0.95, binomialTolerance(0.95, with.n)) << "skew " << g;
    const double below_normal = static_cast<double>(without.below_median) / without.n;
    if (g > 0) EXPECT_LT(below_normal, 0.5 - binomialTolerance(0.5, without.n));
    else EXPECT_GT(below_normal, 0.5 + binomialTolerance(0.5, without.n));
  }
}

// Dropped draws: the 68 % interval is the unified one of the truncated distribution, at its stated coverage for every
// truth, also one far below the threshold (a one-sided bound would cover those ~100 %); the 95 % one-sided bound
// covers at least its nominal rate (it is conservative: ~100 % near the threshold).
TEST(Selective, DroppedDrawsAreCoveredAtTheStatedRate) {
  for (double mu : {0.05, 1.0, 2.5}) {
    for (double v2 : {0.0, 0.25}) {
      if (mu == 1.0 && v2 > 0) continue;  // fixed scatter, and scatter growing like the term (held at the threshold)
      VarianceModel v;
      v.v0 = 1.0;
      v.v2 = v2;
      v.cap_mu = 2.0;
      Tally sel, drop;
      simulate(mu, v, 2.0, 2000, 101u + static_cast<uint32_t>(mu * 10 + v2 * 100), &sel, &drop);
      ASSERT_GT(drop.n, 300);
      const double c68 = static_cast<double>(drop.in68) / drop.n, c95 = static_cast<double>(drop.in95) / drop.n;
      EXPECT_NEAR(c68, 0.6827, binomialTolerance(0.6827, drop.n)) << "mu " << mu << " v2 " << v2;
      EXPECT_GE(c95, 0.95 - binomialTolerance(0.95, drop.n)) << "mu " << mu << " v2 " << v2;
    }
  }
}

// The unified interval of a dropped term starts above 0 when the estimate came out high (but below the threshold),
// and at 0 when it came out low; it always holds the one-sided 95 % bound's range below its upper end.
TEST(Selective, DroppedIntervalExcludesZeroOnlyForAHighEstimate) {
  VarianceModel v;
  v.v0 = 1.0;
  v.cap_mu = 2.0;
  const SelectionEvent drop{false, 2.0};
  const SelectiveEstimate low = selectiveEstimate(-0.5, v, drop), high = selectiveEstimate(1.8, v, drop);
  EXPECT_EQ(low.lo68, 0.0);
  EXPECT_GT(low.hi68, 0.0);
  EXPECT_GT(high.lo68, 0.0);
  EXPECT_GT(high.hi68, 1.8);
  for (const SelectiveEstimate& e : {low, high}) {
    EXPECT_EQ(e.lo95, 0.0);
    EXPECT_GE(e.hi95, e.hi68);
  }
}

// A selected estimate right at its threshold carries no evidence beyond the selection itself: its corrected value is
// 0 (the GLS fit then drops the term, FitResult::dropped_by_correction). Well above the threshold the correction
// vanishes.
TEST(Selective, AtTheThresholdTheCorrectedValueIsZero) {
  VarianceModel v;
  v.v0 = 1.0;
  EXPECT_EQ(selectiveEstimate(2.0, v, SelectionEvent{true, 2.0}).median, 0.0);
  EXPECT_EQ(selectiveEstimate(2.05, v, SelectionEvent{true, 2.0}).median, 0.0);
  const double far = selectiveEstimate(8.0, v, SelectionEvent{true, 2.0}).median;
  EXPECT_NEAR(far, 8.0, 1e-3);
  const double near = selectiveEstimate(3.0, v, SelectionEvent{true, 2.0}).median;
  EXPECT_GT(near, 0.0);
  EXPECT_LT(near, 3.0);  // shrunk: the winner's-curse correction
}

// A dropped term whose scatter grows like the term itself (relative sd 0.5): without a cap the conditional bound has
// no finite end (the pivot turns back towards 1); with the variance held beyond the threshold it is finite and above
// the threshold, and the 95 % bound is above the 68 % one.
TEST(Selective, DroppedBoundWithGrowingVarianceIsFiniteWhenCapped) {
  VarianceModel v;
  v.v0 = 1.0;
  v.v2 = 0.25;
  const SelectionEvent drop{false, 2.0};
  EXPECT_GT(selectivePivot(0.0, 1e6, v, drop), 0.5);  // uncapped: a huge value is not excluded
  v.cap_mu = 2.0;
  const SelectiveEstimate e = selectiveEstimate(0.0, v, drop);
  EXPECT_GT(e.hi68, 0.0);
  EXPECT_LT(e.hi68, 2.0 + 10.0 * std::sqrt(v.at(2.0)));
  EXPECT_GT(e.hi95, e.hi68);
  EXPECT_LT(e.hi95, 2.0 + 10.0 * std::sqrt(v.at(2.0)));
}
