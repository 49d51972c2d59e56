// Tests of stamp sanitation: every bad sample is dropped and counted, gaps split segments, nothing is bridged.
#include <gtest/gtest.h>

#include <cmath>

#include "gyro_allan/timing.hpp"

using namespace gyro_allan;

TEST(Timing, CleanSeriesIsOneSegment) {
  std::vector<double> t, v;
  for (int i = 0; i < 100; ++i) {
    t.push_back(1.0 + i * 0.01);
    v.push_back(i);
  }
  const auto s = sanitize(t, {&v});
  EXPECT_EQ(s.segments.size(), 1u);
  EXPECT_EQ(s.report.kept, 100);
  EXPECT_NEAR(s.report.rate_hz, 100.0, 1e-9);
  EXPECT_TRUE(s.report.warnings().empty());
}

TEST(Timing, CountsAndDropsBadSamples) {
  std::vector<double> t, v;
  for (int i = 0; i < 200; ++i) {
    t.push_back(1.0 + i * 0.01);
    v.push_back(i);
  }
  v[10] = NAN;
  v[11] = INFINITY;
  t[20] = 0.0;           // zero stamp
  t[30] = t[29];         // duplicate
  t[40] = t[35];         // out of order
  for (int i = 100; i < 200; ++i) t[i] += 0.5;  // a 0.5 s gap
  const auto s = sanitize(t, {&v});
  EXPECT_EQ(s.report.non_finite, 2);
  EXPECT_EQ(s.report.zero_stamp, 1);
  EXPECT_EQ(s.report.duplicate, 1);
  EXPECT_EQ(s.report.out_of_order, 1);
  // The two non-finite samples, the zero stamp and the gap each break contiguity.
  EXPECT_GE(s.report.gaps, 3);
  EXPECT_NEAR(s.report.gap_time_s, 0.5 + 0.02 + 0.01 + 0.01 + 0.01, 1e-6);
  EXPECT_EQ(s.report.kept + s.report.non_finite + s.report.zero_stamp + s.report.duplicate + s.report.out_of_order,
            200);
  // No segment spans a gap.
  for (const auto& seg : s.segments)
    for (size_t i = seg.begin + 1; i < seg.end; ++i) EXPECT_LT(s.t[i] - s.t[i - 1], 0.015);
  EXPECT_FALSE(s.report.warnings().empty());
}

TEST(Timing, DetectsRateChange) {
  std::vector<double> t, v;
  double now = 1.0;
  for (int i = 0; i < 300; ++i) {
    now += i < 150 ? 0.01 : 0.008;
    t.push_back(now);
    v.push_back(0);
  }
  const auto s = sanitize(t, {&v});
  EXPECT_TRUE(s.report.rate_changed);
}

TEST(Timing, RejectsMismatchedAxes) {
  std::vector<double> t{1, 2, 3}, v{1, 2};
  EXPECT_THROW(sanitize(t, {&v}), std::invalid_argument);
  EXPECT_THROW(sanitize(t, {}), std::invalid_argument);
}

TEST(Timing, ValueAnomaliesFindShocksAndSaturation) {
  std::vector<double> v(10000);
  for (size_t i = 0; i < v.size(); ++i) v[i] = 1e-3 * std::sin(0.37 * static_cast<double>(i));  // bounded "noise"
  EXPECT_EQ(detectValueAnomalies(v).spikes, 0);
  v[100] = 0.5;  // shock
  v[2000] = -0.7;
  for (int i = 5000; i < 5010; ++i) v[static_cast<size_t>(i)] = 5.2;  // clipped at full scale
  const auto a = detectValueAnomalies(v);
  EXPECT_EQ(a.spikes, 2);
  EXPECT_EQ(a.saturation_runs, 1);
  EXPECT_EQ(a.saturated, 10);
  EXPECT_EQ(a.warnings("axis x").size(), 2u);
}
