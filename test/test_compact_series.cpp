// Tests of the compact sample and stamp storage used by the bag reader.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "gyro_allan/allan.hpp"
#include "gyro_allan/compact_series.hpp"

using namespace gyro_allan;

TEST(CompactSeries, RoundTripWithinFloatOfTheBlockSpread) {
  // A gyro-like series: large constant offset (bias + Earth rate), slow drift, white noise. Each value must come back
  // within 2^-24 of its distance from the block's first sample (the documented bound), and within 1e-7 of the noise.
  std::mt19937_64 rng(3);
  std::normal_distribution<double> g(0.0, 1e-3);
  CompactSeries c;
  std::vector<double> x(100000);
  c.reserve(x.size());  // as the bag reader does (it knows the message count)
  for (size_t i = 0; i < x.size(); ++i) {
    x[i] = 0.37 + 1e-6 * static_cast<double>(i) + g(rng);
    c.push_back(x[i]);
  }
  ASSERT_EQ(c.size(), x.size());
  const std::vector<double> back = c.toVector();
  for (size_t i = 0; i < x.size(); ++i) {
    const double ref = x[(i / CompactSeries::kBlock) * CompactSeries::kBlock];
    EXPECT_LE(std::fabs(back[i] - x[i]), std::ldexp(std::fabs(x[i] - ref), -24) + 1e-300) << i;
    EXPECT_EQ(back[i], c[i]);
  }
  EXPECT_LT(c.bytes(), x.size() * sizeof(double) * 6 / 10);  // about half of the doubles
}

TEST(CompactSeries, AllanDeviationUnchangedToOnePartIn1e7) {
  // The whole point: storing the record compactly must not move an Allan deviation measurably.
  std::mt19937_64 rng(5);
  std::normal_distribution<double> g(0.0, 2e-3);
  std::vector<double> x(200000);
  CompactSeries c;
  double walk = 0;
  for (auto& v : x) {
    walk += 1e-6 * g(rng);
    v = -0.012 + walk + g(rng);
    c.push_back(v);
  }
  DeviationOptions o;
  o.compute_edf = false;
  const DeviationCurve a = computeDeviation("oadev", x, InputKind::Rate, 0.0025, o);
  const DeviationCurve b = computeDeviation("oadev", c.toVector(), InputKind::Rate, 0.0025, o);
  ASSERT_EQ(a.points.size(), b.points.size());
  for (size_t i = 0; i < a.points.size(); ++i) EXPECT_NEAR(b.points[i].dev / a.points[i].dev, 1.0, 1e-7) << a.points[i].tau;
}

TEST(CompactSeries, NonFiniteAndHugeValuesKept) {
  CompactSeries c;
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  const std::vector<double> x{nan, inf, 1.0, -inf, 1e300, -1e300, 2.0, nan, 3.0};
  for (double v : x) c.push_back(v);
  EXPECT_TRUE(std::isnan(c[0]));
  EXPECT_EQ(c[1], inf);
  EXPECT_EQ(c[2], 1.0);  // first finite sample: the block reference, exact
  EXPECT_EQ(c[3], -inf);
  EXPECT_EQ(c[4], 1e300);   // beyond float range: kept exactly aside
  EXPECT_EQ(c[5], -1e300);
  EXPECT_EQ(c[6], 2.0);
  EXPECT_TRUE(std::isnan(c[7]));
  EXPECT_EQ(c[8], 3.0);
  c.clear();
  EXPECT_TRUE(c.empty());
}

TEST(CompactStamps, ExactNanosecondsAndSeconds) {
  CompactStamps s;
  // 400 Hz stamps, a zero stamp, a 10 s gap, a jump back by an hour, a huge value.
  std::vector<int64_t> ns;
  int64_t t = 1000000000;
  for (int i = 0; i < 1000; ++i) ns.push_back(t += 2500000);
  ns.push_back(0);
  ns.push_back(t += 10000000000LL);
  ns.push_back(t - 3600000000000LL);
  ns.push_back(int64_t(1) << 60);
  ns.push_back(-7);
  for (int64_t v : ns) s.push_back(v);
  ASSERT_EQ(s.size(), ns.size());
  EXPECT_EQ(s.toNanoseconds(), ns);
  const std::vector<double> sec = s.toSeconds();
  for (size_t i = 0; i < ns.size(); ++i) {
    // ros::Duration::toSec() of the same value: whole seconds + 1e-9 * the non-negative nanosecond part
    int64_t whole = ns[i] / 1000000000, frac = ns[i] % 1000000000;
    if (frac < 0) frac += 1000000000, --whole;
    const double expect = ns[i] == 0 ? 0.0 : static_cast<double>(whole) + 1e-9 * static_cast<double>(frac);
    EXPECT_EQ(sec[i], expect) << i;
  }
}
