// Tests of SlidingAllan: sliding overlapping AVAR equals batch computeDeviation("oadev") of the window's segments.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <random>
#include <stdexcept>
#include <vector>

#include "gyro_allan/allan.hpp"
#include "gyro_allan/sliding_allan.hpp"

using namespace gyro_allan;

namespace {

constexpr double kRelTol = 1e-9;

/// Mirrors the window of a SlidingAllan fed with rate samples: one entry per phase point, tagged with its segment
/// and the rate that produced it (the first point of a segment has no rate).
struct PhaseTag {
  int segment;
  bool has_rate;
  double rate;
};

class RateMirror {
 public:
  explicit RateMirror(int64_t window_samples) : cap_(window_samples + 1) {}
  void newSegment() { fresh_ = true; }
  void add(double y) {
    if (fresh_) {
      ++segment_;
      push({segment_, false, 0.0});
      fresh_ = false;
    }
    push({segment_, true, y});
  }
  /// Rate segments of the window: the rates of every retained point except each segment's first retained point.
  std::vector<std::vector<double>> segments() const {
    std::vector<std::vector<double>> out;
    int current = -1;
    for (const auto& p : points_) {
      if (p.segment != current) {
        current = p.segment;
        out.emplace_back();
        continue;  // first retained point of the segment: its rate reaches back before the window
      }
      out.back().push_back(p.rate);
    }
    return out;
  }

 private:
  void push(const PhaseTag& t) {
    points_.push_back(t);
    if (static_cast<int64_t>(points_.size()) > cap_) points_.erase(points_.begin());
  }
  int64_t cap_;
  int segment_ = 0;
  bool fresh_ = true;
  std::vector<PhaseTag> points_;
};

/// Compares the sliding curve with the batch curve point by point (matched by m). Returns matched points.
int expectSameCurve(const DeviationCurve& sliding, const DeviationCurve& batch, const char* where) {
  std::map<int64_t, const DeviationPoint*> by_m;
  for (const auto& p : sliding.points) by_m[p.m] = &p;
  int matched = 0;
  for (const auto& b : batch.points) {
    auto it = by_m.find(b.m);
    if (it == by_m.end()) continue;
    const DeviationPoint& s = *it->second;
    EXPECT_EQ(s.n_terms, b.n_terms) << where << " m=" << b.m;
    EXPECT_NEAR(s.tau, b.tau, 1e-12 * b.tau) << where << " m=" << b.m;
    EXPECT_NEAR(s.var, b.var, kRelTol * b.var) << where << " m=" << b.m;
    ++matched;
  }
  // Every sliding point with terms must be in the batch curve when the batch curve is on the same grid.
  return matched;
}

std::vector<double> whiteWithDrift(int64_t n, double sigma, double rrw, double bias, uint64_t seed) {
  std::mt19937_64 gen(seed);
  std::normal_distribution<double> g(0.0, 1.0);
  std::vector<double> y(n);
  double walk = bias;
  for (int64_t i = 0; i < n; ++i) {
    walk += rrw * g(gen);
    y[i] = walk + sigma * g(gen);
  }
  return y;
}

DeviationOptions batchOptions(const TauGrid& grid) {
  DeviationOptions o;
  o.grid = grid;
  o.compute_edf = false;
  return o;
}

}  // namespace

TEST(SlidingAllan, RejectsBadOptions) {
  SlidingAllanOptions o;
  o.tau0 = 0;
  o.window_samples = 100;
  EXPECT_THROW(SlidingAllan{o}, std::invalid_argument);
  o.tau0 = 0.01;
  o.window_samples = 1;
  EXPECT_THROW(SlidingAllan{o}, std::invalid_argument);
  o.window_samples = 100;
  o.recompute_steps = 1;
  EXPECT_THROW(SlidingAllan{o}, std::invalid_argument);
  o.recompute_steps = 2;
  SlidingAllan s(o);
  EXPECT_THROW(s.addRate(std::nan("")), std::invalid_argument);
  EXPECT_THROW(s.addAngle(INFINITY), std::invalid_argument);
  EXPECT_EQ(s.totalSamples(), 0);
}

TEST(SlidingAllan, MatchesBatchAfterManySlides) {
  const double tau0 = 0.01;
  const int64_t W = 600;
  for (const char* grid_name : {"all", "octave"}) {
    SlidingAllanOptions o;
    o.tau0 = tau0;
    o.window_samples = W;
    std::string err;
    ASSERT_TRUE(parseTauGrid(grid_name, &o.grid, &err)) << err;
    SlidingAllan s(o);
    RateMirror mirror(W);
    // Large bias (keeps the phase far from zero) + white + random-walk rate noise.
    const auto y = whiteWithDrift(12 * W + 37, 0.05, 0.002, 3.0, 7);
    int checks = 0;
    for (size_t i = 0; i < y.size(); ++i) {
      s.addRate(y[i]);
      mirror.add(y[i]);
      if ((i + 1) % 997 == 0 || i + 1 == y.size()) {
        const auto segs = mirror.segments();
        ASSERT_EQ(segs.size(), 1u);
        const DeviationCurve batch = computeDeviation("oadev", segs[0], InputKind::Rate, tau0, batchOptions(o.grid));
        const DeviationCurve slide = s.curve();
        EXPECT_EQ(slide.n_phase, static_cast<int64_t>(segs[0].size() + 1));
        const int matched = expectSameCurve(slide, batch, grid_name);
        EXPECT_GE(matched, static_cast<int>(batch.points.size()) - 1) << grid_name;  // batch may stop one m later
        EXPECT_GT(matched, 5);
        ++checks;
      }
    }
    EXPECT_GE(checks, 7);
    EXPECT_EQ(s.samples(), W);
    EXPECT_DOUBLE_EQ(s.fill(), 1.0);
    EXPECT_GT(s.recomputes(), 3);  // the incremental exact rebuild completed several times
  }
}

TEST(SlidingAllan, GapsSegmentTheWindowAndResetStartsOver) {
  const double tau0 = 0.001;
  const int64_t W = 1000;
  SlidingAllanOptions o;
  o.tau0 = tau0;
  o.window_samples = W;
  std::string err;
  ASSERT_TRUE(parseTauGrid("all", &o.grid, &err)) << err;
  SlidingAllan s(o);
  RateMirror mirror(W);
  const auto y = whiteWithDrift(6000, 0.2, 0.01, -1.0, 11);
  // Segment lengths between gaps; checks at many points, including while segments leave the window.
  const std::vector<int> seg_len = {700, 300, 1, 5, 1500, 40, 2000};
  size_t pos = 0;
  int checks = 0;
  for (size_t k = 0; k < seg_len.size(); ++k) {
    if (k > 0) {
      s.newSegment();
      mirror.newSegment();
    }
    for (int j = 0; j < seg_len[k]; ++j, ++pos) {
      s.addRate(y[pos]);
      mirror.add(y[pos]);
      if (pos % 89 == 0 || j + 1 == seg_len[k]) {
        auto segs = mirror.segments();
        int64_t total = 0;
        for (const auto& sg : segs) total += sg.size();
        EXPECT_EQ(s.samples(), total);
        EXPECT_EQ(s.segments(), static_cast<int>(segs.size()));
        bool any_terms = false;
        for (const auto& sg : segs) any_terms = any_terms || sg.size() >= 2;
        if (!any_terms) continue;
        std::vector<std::vector<double>> usable;  // segments shorter than 2 samples hold no term
        for (const auto& sg : segs)
          if (sg.size() >= 2) usable.push_back(sg);
        const DeviationCurve batch = computeDeviation("oadev", usable, InputKind::Rate, tau0, batchOptions(o.grid));
        const DeviationCurve slide = s.curve();
        expectSameCurve(slide, batch, "gap");
        // No sliding point may exist that the pooled batch has no terms for.
        for (const auto& p : slide.points) {
          bool found = false;
          for (const auto& b : batch.points) found = found || b.m == p.m;
          EXPECT_TRUE(found) << "sliding point m=" << p.m << " spans a gap";
        }
        ++checks;
      }
    }
  }
  EXPECT_GT(checks, 40);
  EXPECT_EQ(s.segments(), 1);  // the last segment (2000 samples) fills the whole 1000-sample window
  // Reset: the next samples stand alone.
  s.reset();
  EXPECT_EQ(s.phasePoints(), 0);
  EXPECT_TRUE(s.curve().points.empty());
  std::vector<double> tail(y.begin(), y.begin() + 800);
  for (double v : tail) s.addRate(v);
  const DeviationCurve batch = computeDeviation("oadev", tail, InputKind::Rate, tau0, batchOptions(o.grid));
  EXPECT_GT(expectSameCurve(s.curve(), batch, "reset"), 100);
}

TEST(SlidingAllan, AngleAndIncrementInputsMatchBatch) {
  const double tau0 = 0.002;
  const int64_t W = 500;
  SlidingAllanOptions o;
  o.tau0 = tau0;
  o.window_samples = W;
  std::string err;
  ASSERT_TRUE(parseTauGrid("octave", &o.grid, &err)) << err;
  SlidingAllan by_angle(o), by_increment(o);
  const auto y = whiteWithDrift(3 * W + 11, 0.1, 0.0, 0.5, 3);
  std::vector<double> angle;  // accumulated angle, starting at a large counter offset
  long double a = 12345.0L;
  angle.push_back(static_cast<double>(a));
  for (double v : y) {
    a += static_cast<long double>(v) * tau0;
    angle.push_back(static_cast<double>(a));
  }
  for (double v : angle) by_angle.addAngle(v);
  for (double v : y) by_increment.addIncrement(v * tau0);
  // Angle window: the last W + 1 angle samples; increment window: the last W increments.
  std::vector<double> last_angle(angle.end() - (W + 1), angle.end());
  std::vector<double> last_rate(y.end() - W, y.end());
  const DeviationCurve ba = computeDeviation("oadev", last_angle, InputKind::Angle, tau0, batchOptions(o.grid));
  const DeviationCurve br = computeDeviation("oadev", last_rate, InputKind::Rate, tau0, batchOptions(o.grid));
  // The angle path rounds the large counter offset (1e4 rad) to double: allow 1e-6 there.
  const DeviationCurve sa = by_angle.curve();
  int matched = 0;
  for (const auto& b : ba.points)
    for (const auto& p : sa.points)
      if (p.m == b.m) {
        EXPECT_NEAR(p.var, b.var, 1e-6 * b.var) << "angle m=" << b.m;
        ++matched;
      }
  EXPECT_GT(matched, 5);
  EXPECT_GT(expectSameCurve(by_increment.curve(), br, "increment"), 5);
}

TEST(SlidingAllan, StableAfterHugeTransientLeavesTheWindow) {
  // A 1e6 rad/s burst inflates the sums by ~1e20 relative to the quiet data; once it has left the window the
  // running sums alone would keep its rounding residue, the exact rebuild removes it.
  const double tau0 = 0.001;
  const int64_t W = 2000;
  SlidingAllanOptions o;
  o.tau0 = tau0;
  o.window_samples = W;
  std::string err;
  ASSERT_TRUE(parseTauGrid("log:10", &o.grid, &err)) << err;
  SlidingAllan s(o);
  const int64_t n = 100 * W;  // 100 window lengths
  auto y = whiteWithDrift(n, 1e-4, 0.0, 0.0, 5);
  for (int i = 0; i < 50; ++i) y[W + i] = (i % 2 ? 1e6 : -1e6);
  for (double v : y) s.addRate(v);
  std::vector<double> last(y.end() - W, y.end());
  const DeviationCurve batch = computeDeviation("oadev", last, InputKind::Rate, tau0, batchOptions(o.grid));
  EXPECT_GT(expectSameCurve(s.curve(), batch, "transient"), 10);
  EXPECT_GT(s.recomputes(), 50);
}

TEST(SlidingAllan, NewestSegmentRatesRebuildTheSamples) {
  SlidingAllanOptions o;
  o.tau0 = 0.001;
  o.window_samples = 1000;
  std::string err;
  ASSERT_TRUE(parseTauGrid("octave", &o.grid, &err)) << err;
  SlidingAllan s(o);
  EXPECT_TRUE(s.newestSegmentRates().empty());
  const auto y = whiteWithDrift(3000, 0.05, 0.001, 2.0, 17);
  for (int i = 0; i < 1700; ++i) s.addRate(y[i]);
  auto r = s.newestSegmentRates();  // window: the last 1000 samples of the first segment
  ASSERT_EQ(r.size(), 1000u);
  for (size_t k = 0; k < r.size(); ++k) ASSERT_NEAR(r[k], y[700 + k], 1e-9) << k;
  s.newSegment();
  for (int i = 1700; i < 2000; ++i) s.addRate(y[i]);
  r = s.newestSegmentRates();
  ASSERT_EQ(r.size(), 300u);
  for (size_t k = 0; k < r.size(); ++k) ASSERT_NEAR(r[k], y[1700 + k], 1e-9) << k;
  r = s.newestSegmentRates(120);
  ASSERT_EQ(r.size(), 120u);
  for (size_t k = 0; k < r.size(); ++k) ASSERT_NEAR(r[k], y[1880 + k], 1e-9) << k;
  // Angle input: differences of the angles / tau0.
  SlidingAllan a(o);
  double angle = 5.0;
  a.addAngle(angle);
  for (int i = 0; i < 50; ++i) a.addAngle(angle += y[i] * o.tau0);
  r = a.newestSegmentRates();
  ASSERT_EQ(r.size(), 50u);
  for (size_t k = 0; k < r.size(); ++k) ASSERT_NEAR(r[k], y[k], 1e-9) << k;
}

TEST(SlidingAllan, CurveHasEdfAndConfidence) {
  SlidingAllanOptions o;
  o.tau0 = 0.01;
  o.window_samples = 4000;
  o.alpha_from_slope = true;
  std::string err;
  ASSERT_TRUE(parseTauGrid("octave", &o.grid, &err)) << err;
  SlidingAllan s(o);
  for (double v : whiteWithDrift(5000, 0.01, 0, 0, 9)) s.addRate(v);
  const DeviationCurve c = s.curve();
  ASSERT_GT(c.points.size(), 8u);
  for (const auto& p : c.points) {
    EXPECT_GT(p.edf, 0) << p.m;
    EXPECT_LT(p.dev_lo, p.dev) << p.m;
    EXPECT_GT(p.dev_hi, p.dev) << p.m;
    if (p.m <= 32) {
      EXPECT_EQ(p.alpha, 0) << "white rate noise has AVAR slope -1, m=" << p.m;
    }
  }
  // Memory is bounded by the window: ring buffer of the next power of two >= window + 2 doubles, plus O(#m).
  EXPECT_LE(s.memoryBytes(), 8192 * sizeof(double) + 4096);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
