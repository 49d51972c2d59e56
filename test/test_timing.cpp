// Tests of stamp sanitation: every bad sample is dropped and counted, gaps split segments, nothing is bridged.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "gyro_allan/simulate.hpp"
#include "gyro_allan/timing.hpp"
#include "adis_data.hpp"

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
  t[30] = t[29];         // duplicate: a repeated sample (same stamp, same value)
  v[30] = v[29];
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

// ---- StampGrid: the regular sampler behind arrival-time stamps.
namespace {
// 100 Hz stamps delayed by a random 0..jitter periods, with `late` of them delayed by 2..10 periods more (bursts:
// the samples behind a late one are delayed at least as much, as a driver's queue does).
std::vector<double> jittered(int n, double jitter, double late, uint64_t seed, double period = 0.01) {
  std::vector<double> t(static_cast<size_t>(n));
  uint64_t s = seed * 2654435761ULL + 1;
  auto uni = [&]() {
    s = s * 6364136223846793005ULL + 1442695040888963407ULL;
    return static_cast<double>(s >> 11) / 9007199254740992.0;
  };
  double queue_until = 0;
  for (int i = 0; i < n; ++i) {
    const double true_t = 100.0 + i * period;
    double a = true_t + uni() * jitter * period;
    if (uni() < late) queue_until = std::max(queue_until, true_t + (2 + 8 * uni()) * period);
    a = std::max(a, queue_until + 1e-6 * uni());
    t[static_cast<size_t>(i)] = a;
  }
  for (size_t i = 1; i < t.size(); ++i) t[i] = std::max(t[i], t[i - 1] + 1e-7);  // a queue keeps the order
  return t;
}
}  // namespace

TEST(StampGrid, JitterAndBurstsAreNotGaps) {
  for (uint64_t seed = 1; seed <= 5; ++seed) {
    std::vector<double> t = jittered(20000, 0.5, 0.01, seed), v(t.size(), 0.0);
    const auto s = sanitize(t, {&v});
    EXPECT_EQ(s.report.kept, 20000) << seed;
    EXPECT_EQ(s.segments.size(), 1u) << seed;
    EXPECT_EQ(s.report.gaps, 0) << seed;
    EXPECT_EQ(s.report.too_close + s.report.duplicate + s.report.out_of_order, 0) << seed;
    EXPECT_NEAR(s.report.rate_hz, 100.0, 0.05) << seed;
    EXPECT_FALSE(s.report.rate_changed) << seed;
    EXPECT_TRUE(s.report.receipt_stamps) << seed;
    EXPECT_GT(s.report.jitter_max_s, 0.02) << seed;  // the bursts
  }
}

TEST(StampGrid, MissingSamplesAreGapsCountedExactly) {
  // Jittered stamps with 1, 3 and 50 samples really missing.
  std::vector<double> all = jittered(6000, 0.45, 0.0, 7), t;
  for (size_t i = 0; i < all.size(); ++i)
    if (i != 1000 && !(i >= 2000 && i < 2003) && !(i >= 4000 && i < 4050)) t.push_back(all[i]);
  std::vector<double> v(t.size(), 0.0);
  const auto s = sanitize(t, {&v});
  EXPECT_EQ(s.report.gaps, 3);
  EXPECT_EQ(s.report.missing_samples, 1 + 3 + 50);
  EXPECT_NEAR(s.report.nominal_period_s, 0.01, 1e-5);
  EXPECT_NEAR(s.report.gap_time_s, 54 * s.report.nominal_period_s, 1e-12);
  EXPECT_EQ(s.segments.size(), 4u);
  EXPECT_EQ(s.report.kept, static_cast<int64_t>(t.size()));
  // gap_factor 2.5: a single missing sample is absorbed (not a gap), 3 and 50 still are.
  SanitizeOptions o;
  o.gap_factor = 2.5;
  const auto s2 = sanitize(t, {&v}, o);
  EXPECT_EQ(s2.report.gaps, 2);
  EXPECT_EQ(s2.report.missing_samples, 53);
}

TEST(StampGrid, ExtraSampleIsTooCloseNotDuplicate) {
  std::vector<double> t;
  for (int i = 0; i < 3000; ++i) t.push_back(5.0 + i * 0.01);
  t.insert(t.begin() + 1500, t[1499] + 0.0005);  // a second sample 0.5 ms after its predecessor: no slot for it
  std::vector<double> v(t.size(), 0.0);
  const auto s = sanitize(t, {&v});
  EXPECT_EQ(s.report.too_close, 1);
  EXPECT_EQ(s.report.duplicate, 0);
  EXPECT_EQ(s.report.gaps, 0);
  EXPECT_EQ(s.report.kept, 3000);
}

TEST(StampGrid, SlowClockDriftIsFollowed) {
  // The sensor runs 0.3 % slow against the host clock and stamps jitter: no gap, no drop, rate measured.
  std::vector<double> base = jittered(50000, 0.3, 0.0, 11, 0.01003), v(base.size(), 0.0);
  const auto s = sanitize(base, {&v});
  EXPECT_EQ(s.report.gaps, 0);
  EXPECT_EQ(s.report.kept, 50000);
  EXPECT_NEAR(1.0 / s.report.rate_hz, 0.01003, 2e-6);
}

TEST(StampGrid, StreamingDecisionsEqualBatch) {
  // The grid decides each stamp after its lookahead, and identically however the stream is fed.
  std::vector<double> t = jittered(3000, 0.5, 0.02, 3);
  t.erase(t.begin() + 1200, t.begin() + 1210);  // 10 missing
  StampGrid a(0.01, 1.5, 0.5), b(0.01, 1.5, 0.5);
  std::vector<StampDecision> da, db;
  StampDecision d;
  for (size_t i = 0; i < t.size(); ++i) {
    a.push(t[i], i);
    EXPECT_LE(a.pending(), a.lookahead() + 1);
    while (a.pop(&d)) da.push_back(d);
  }
  a.finish();
  while (a.pop(&d)) da.push_back(d);
  for (size_t i = 0; i < t.size(); ++i) b.push(t[i], i);
  b.finish();
  while (b.pop(&d)) db.push_back(d);
  ASSERT_EQ(da.size(), t.size());
  ASSERT_EQ(db.size(), t.size());
  int64_t missing = 0;
  for (size_t i = 0; i < da.size(); ++i) {
    EXPECT_EQ(da[i].verdict, db[i].verdict);
    EXPECT_EQ(da[i].index, db[i].index);
    EXPECT_EQ(da[i].tag, i);
    missing += da[i].missing;
  }
  EXPECT_EQ(missing, 10);
  EXPECT_EQ(da.back().index, static_cast<int64_t>(t.size()) - 1 + 10);
  EXPECT_THROW(StampGrid(0.0), std::invalid_argument);
  EXPECT_THROW(StampGrid(0.01, 1.0), std::invalid_argument);
}

TEST(StampGrid, EstimatePeriodIgnoresJitterBurstsAndGaps) {
  std::vector<double> t = jittered(10000, 0.5, 0.02, 5, 0.0025);
  t.erase(t.begin() + 5000, t.begin() + 5400);
  EXPECT_NEAR(estimatePeriod(t), 0.0025, 0.0025 * 2e-3);
  // Two-per-packet delivery: intervals alternate ~0 and ~2 periods, the median interval says nothing.
  std::vector<double> p;
  for (int i = 0; i < 4000; ++i) p.push_back(1.0 + (i / 2) * 0.02 + (i % 2) * 1e-5);
  EXPECT_NEAR(estimatePeriod(p), 0.01, 1e-5);
  EXPECT_EQ(estimatePeriod({}), 0.0);
}

TEST(Sanitize, CountFromCountsOnlyTheLaterSamplesProblems) {
  // 1000 samples at 100 Hz with a NaN at 100 and 700, a zero stamp at 200 and 800, a duplicate after 300 and 900 and
  // 5 missing samples after 400 and 950: with count_from = 600 (index in the input) `counted` holds exactly the
  // problems from input sample 600 on; with 0 it equals the report.
  std::vector<double> t, x;
  for (int i = 0; i < 1000; ++i) {
    const int k = i + (i > 400 ? 5 : 0) + (i > 950 ? 5 : 0);
    t.push_back(1.0 + k * 0.01);
    x.push_back(i == 100 || i == 700 ? std::nan("") : 0.001 * (i % 7));
    if (i == 200 || i == 800) t.back() = 0;
    if (i == 300 || i == 900) t.push_back(t.back()), x.push_back(x.back());
  }
  SanitizeOptions o;
  const SanitizedSeries all = sanitize(t, {&x}, o);
  EXPECT_EQ(all.counted.non_finite, all.report.non_finite);
  EXPECT_EQ(all.counted.duplicate, all.report.duplicate);
  EXPECT_EQ(all.counted.gaps, all.report.gaps);
  EXPECT_EQ(all.counted.missing_samples, all.report.missing_samples);
  o.count_from = 600;  // input index of sample 599 (one duplicate inserted before it)
  const SanitizedSeries s = sanitize(t, {&x}, o);
  EXPECT_EQ(s.report.non_finite, 2);
  EXPECT_EQ(s.report.zero_stamp, 2);
  EXPECT_EQ(s.report.duplicate, 2);
  EXPECT_EQ(s.counted.non_finite, 1);
  EXPECT_EQ(s.counted.zero_stamp, 1);
  EXPECT_EQ(s.counted.duplicate, 1);
  // gaps: the two missing runs, plus the slots of the 4 dropped samples; later half: one run and 2 dropped samples
  EXPECT_EQ(s.report.gaps, 6);
  EXPECT_EQ(s.counted.gaps, 3);
  EXPECT_EQ(s.counted.missing_samples, 5 + 2);
  EXPECT_EQ(s.counted.input, static_cast<int64_t>(t.size()) - 600);
  o.count_to = 800;  // input index of sample 799: the NaN at 700 (index 701) only, with its empty slot
  const SanitizedSeries u = sanitize(t, {&x}, o);
  EXPECT_EQ(u.counted.non_finite, 1);
  EXPECT_EQ(u.counted.zero_stamp, 0);
  EXPECT_EQ(u.counted.duplicate, 0);
  EXPECT_EQ(u.counted.gaps, 1);
  EXPECT_EQ(u.counted.missing_samples, 1);
  EXPECT_EQ(u.counted.input, 200);
}

// A real static record (ADIS16405 run 1, 100 Hz, 10,000 s, 0.05 deg/s output resolution) re-stamped as a driver
// that reads a buffer would stamp it: jitter up to 0.45 period, 1 % of the samples late by 2-10 periods, and the
// samples queued behind a late one read with it (one stamp for the read). Every sample is kept, in order, in one
// segment: the deviations and coefficients are those of the clean-stamp record. A repeated sample would be a
// duplicate only if all three axes repeated, which a 0.05 deg/s resolution makes rare but not impossible: such
// samples are counted and their slot is a one-sample gap.
TEST(Timing, BufferedReadsOfARealRecordKeepEverySample) {
  const auto g = gyro_allan_test::readAdisRun(1);
  if (g[0].empty()) GTEST_SKIP() << "ADIS16405 shared data not found";
  std::vector<double> t(g[0].size());
  for (size_t i = 0; i < t.size(); ++i) t[i] = 100.0 + 0.01 * static_cast<double>(i);
  const std::vector<double> r = receiptStamps(t, 0.01, 0.45, 0.01, 5, true);
  int64_t equal = 0, repeated = 0;
  for (size_t i = 1; i < r.size(); ++i)
    if (r[i] == r[i - 1]) {
      ++equal;
      repeated += g[0][i] == g[0][i - 1] && g[1][i] == g[1][i - 1] && g[2][i] == g[2][i - 1];
    }
  ASSERT_GT(equal, 10000) << "the re-stamping must produce buffered reads";
  const auto s = sanitize(r, {&g[0], &g[1], &g[2]});
  std::printf("%lld equal stamps, %lld of them on repeated values; kept %lld of %zu, %zu segment(s), %lld gaps\n",
              static_cast<long long>(equal), static_cast<long long>(repeated), static_cast<long long>(s.report.kept),
              r.size(), s.segments.size(), static_cast<long long>(s.report.gaps));
  EXPECT_EQ(s.report.duplicate, repeated);
  EXPECT_EQ(s.report.out_of_order + s.report.too_close, 0);
  EXPECT_EQ(s.report.kept + repeated, static_cast<int64_t>(r.size()));
  EXPECT_NEAR(s.report.rate_hz, 100.0, 0.01);
  if (repeated == 0) {
    ASSERT_EQ(s.segments.size(), 1u);
    EXPECT_TRUE(s.v[0] == g[0] && s.v[1] == g[1] && s.v[2] == g[2]);
  }
}
