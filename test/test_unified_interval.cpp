// Tests of the unified (Feldman-Cousins) interval: coverage of the truth at its stated rate for true values at, near
// and far above 0, with constant and growing (skewed) scatter; never empty; always holding the constrained estimate.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include "gyro_allan/unified_interval.hpp"

using namespace gyro_allan;

namespace {

// One draw of X at mu: a shifted gamma with the model's mean, variance and skew (normal where the skew is ~0), drawn
// independently of the code under test: a gamma of shape 4/skew^2 scaled to the variance, shifted to the mean.
double draw(const VarianceModel& v, double mu, std::mt19937_64* rng) {
  const double var = v.at(mu), skew = v.skewAt(mu);
  if (skew < 0.02) return mu + std::sqrt(var) * std::normal_distribution<double>()(*rng);
  const double shape = 4.0 / (skew * skew), scale = std::sqrt(var / shape);
  return mu - shape * scale + std::gamma_distribution<double>(shape, scale)(*rng);
}

struct Coverage {
  int n = 0, in68 = 0, in95 = 0;
};

Coverage measure(const VarianceModel& v, double mu, int n, uint64_t seed) {
  std::mt19937_64 rng(seed);
  Coverage c;
  for (int i = 0; i < n; ++i) {
    const double x = draw(v, mu, &rng);
    double lo68, hi68, lo95, hi95;
    unifiedInterval(x, v, 0.6826894921370859, &lo68, &hi68);
    unifiedInterval(x, v, 0.95, &lo95, &hi95);
    EXPECT_LE(lo68, hi68);
    EXPECT_LE(lo95, lo68 * (1 + 1e-9) + 1e-300);  // nested
    EXPECT_GE(hi95, hi68 * (1 - 1e-9));
    const double est = std::max(x, 0.0);  // the constrained estimate lies inside
    EXPECT_LE(lo68, est * (1 + 1e-9) + 1e-300) << x;
    EXPECT_GE(hi68, est * (1 - 1e-9)) << x;
    ++c.n;
    c.in68 += lo68 <= mu && mu <= hi68;
    c.in95 += lo95 <= mu && mu <= hi95;
  }
  return c;
}

}  // namespace

// 600 draws per case: the binomial sd of a 68 % coverage is 1.9 %, of a 95 % one 0.9 %; the bands below are 3 sd plus
// the construction's grid discreteness (~1 %), so a correct construction fails them about once in 300 cases.
TEST(UnifiedInterval, CoversAtItsStatedRate) {
  struct Case {
    const char* name;
    VarianceModel v;
  };
  // Constant scatter (normal); scatter growing with mu (the AVAR's chi-squared-like spread, skewed up to 2).
  // "precise": a term far above its noise (relative sd 1e-3 at mu 10), which the grid must resolve.
  const Case cases[] = {{"constant", {1.0, 0.0, 0.0}},
                        {"growing", {1.0, 0.0, 0.5}},
                        {"linear", {1.0, 0.5, 0.0}},
                        {"precise", {1e-6, 0.0, 1e-6}}};
  uint64_t seed = 1;
  for (const auto& k : cases)
    for (double mu : {0.0, 1.0, 3.0, 10.0}) {
      const Coverage c = measure(k.v, mu, 600, seed++);
      const double p68 = static_cast<double>(c.in68) / c.n, p95 = static_cast<double>(c.in95) / c.n;
      std::printf("%-8s mu %5.1f: 68 %% %.3f, 95 %% %.3f\n", k.name, mu, p68, p95);
      EXPECT_NEAR(p68, 0.683, 0.07) << k.name << " mu " << mu;
      EXPECT_NEAR(p95, 0.95, 0.035) << k.name << " mu " << mu;
    }
}

// Below its noise an estimate gives an upper bound [0, hi]; far above it a two-sided interval around the estimate
// whose half-widths approach the normal's 1 sd (constant scatter).
TEST(UnifiedInterval, UpperBoundBelowTheNoiseTwoSidedAbove) {
  const VarianceModel v{1.0, 0.0, 0.0};
  double lo, hi;
  unifiedInterval(-0.5, v, 0.6826894921370859, &lo, &hi);
  EXPECT_EQ(lo, 0.0);
  EXPECT_GT(hi, 0.0);
  unifiedInterval(8.0, v, 0.6826894921370859, &lo, &hi);
  EXPECT_NEAR(lo, 7.0, 0.1);
  EXPECT_NEAR(hi, 9.0, 0.1);
  // Growing scatter: the upper side is longer than the lower.
  const VarianceModel g{1.0, 0.0, 0.05};
  unifiedInterval(20.0, g, 0.6826894921370859, &lo, &hi);
  EXPECT_GT(hi - 20.0, 20.0 - lo);
}

// VarianceModel::through reproduces three points of a quadratic exactly and keeps the variance positive on [0, inf).
TEST(UnifiedInterval, VarianceModelThroughThreePoints) {
  const double mu[3] = {0.0, 1.0, 5.0};
  const double var[3] = {2.0, 2.0 + 0.5 + 0.25, 2.0 + 2.5 + 6.25};
  const VarianceModel v = VarianceModel::through(mu, var);
  EXPECT_NEAR(v.v0, 2.0, 1e-12);
  EXPECT_NEAR(v.v1, 0.5, 1e-12);
  EXPECT_NEAR(v.v2, 0.25, 1e-12);
  const double bent[3] = {2.0, 1.0, 3.0};  // dips between the outer points: whatever the fallback, positive
  const VarianceModel b = VarianceModel::through(mu, bent);
  for (double m : {0.0, 0.5, 1.0, 2.0, 5.0, 50.0}) EXPECT_GT(b.at(m), 0.0) << m;
}
