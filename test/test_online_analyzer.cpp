// OnlineAnalyzer (online.hpp): the window = whole record gives exactly the offline pipeline's answer; a sliding window
// counts each raw sample's problem once; hops follow the input stamps; reset, skipped hops, bad options.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

#include "gyro_allan/online.hpp"
#include "gyro_allan/pipeline.hpp"
#include "gyro_allan/simulate.hpp"

using namespace gyro_allan;

namespace {

constexpr int64_t kStart = 1700000000LL * 1000000000LL;  // first stamp [ns since the epoch]

/// One input event as a driver delivers it: an IMU sample or a temperature reading.
struct Event {
  bool temperature = false;
  int64_t ns = 0;
  std::array<double, 3> g{{0, 0, 0}}, a{{0, 0, 0}};
  double celsius = 0;
};

/// The problems injected into a record: the declared truth of the sanitation counts. A dropped sample (NaN value,
/// zero stamp) leaves its grid slot empty: it is also a gap of one missing sample (timing.hpp).
struct Injected {
  int64_t non_finite = 0, zero_stamp = 0, duplicate = 0, gaps = 0, missing = 0;
};

/// 100 Hz record of `duration_s` with a warm-up drift of 2 mrad/s (theta 200 s) on x and its 1 Hz temperature series,
/// an accelerometer (gravity on z plus white noise), and problems at fixed times: NaN samples at `nan_s`, zero stamps
/// at `zero_s`, a repeated message (duplicate stamp) at `dup_s`, and `gap_len` samples missing from `gap_s`.
std::vector<Event> record(double duration_s, const std::vector<double>& nan_s, const std::vector<double>& zero_s,
                          const std::vector<double>& dup_s, double gap_s, int gap_len, Injected* truth) {
  SimulationSpec spec;
  spec.rate_hz = 100;
  spec.duration_s = duration_s;
  spec.seed = 7;
  for (auto& ax : spec.axes) {
    ax.quantization = 2e-6;
    ax.angle_random_walk = 1e-4;
    ax.bias_instability = 5e-6;
    ax.rate_random_walk = 2e-7;
  }
  spec.axes[0].thermal_amplitude = 2e-3;
  spec.axes[0].thermal_tau = 200;
  spec.temperature = true;
  const SimulatedData d = simulate(spec);
  const std::vector<double> accel_noise = simulateAxis(AxisNoise{0, true, 1e-3}, 100, static_cast<int64_t>(d.t.size()), 9);
  auto at = [](double s) { return static_cast<size_t>(std::llround(s * 100)); };
  std::vector<Event> ev;
  *truth = Injected();
  for (size_t i = 0; i < d.t.size(); ++i) {
    if (gap_len > 0 && i >= at(gap_s) && i < at(gap_s) + static_cast<size_t>(gap_len)) continue;
    Event e;
    e.ns = kStart + static_cast<int64_t>(i) * 10000000LL;  // 10 ms
    e.g = {{d.rate[0][i], d.rate[1][i], d.rate[2][i]}};
    e.a = {{0.01 * accel_noise[i], -0.02 * accel_noise[i], 9.81 + accel_noise[i]}};
    for (double s : nan_s)
      if (i == at(s)) e.g[1] = std::numeric_limits<double>::quiet_NaN(), ++truth->non_finite;
    for (double s : zero_s)
      if (i == at(s)) e.ns = 0, ++truth->zero_stamp;
    if (i % 100 == 0) {  // 1 Hz temperature, stamped with the sample
      Event t;
      t.temperature = true;
      t.ns = kStart + static_cast<int64_t>(i) * 10000000LL;
      t.celsius = d.temperature[i];
      ev.push_back(t);
    }
    ev.push_back(e);
    for (double s : dup_s)
      if (i == at(s)) ev.push_back(e), ++truth->duplicate;
  }
  truth->gaps = (gap_len > 0 ? 1 : 0) + truth->non_finite + truth->zero_stamp;
  truth->missing = gap_len + truth->non_finite + truth->zero_stamp;
  return ev;
}

/// The sample events [begin, end) as the bag reader hands them to the pipeline: stamps relative to (first non-zero
/// stamp - 1 s); the temperature readings before `end` from the last one at or before the first sample on (what the
/// online window keeps: interpolation holds that reading at the window's start).
PipelineInput offlineInput(const std::vector<Event>& ev, size_t begin, size_t end) {
  PipelineInput in;
  int64_t origin = 0, first = 0;
  for (size_t k = begin; k < end && origin == 0; ++k)
    if (!ev[k].temperature && ev[k].ns != 0) origin = ev[k].ns - 1000000000LL, first = ev[k].ns;
  size_t t_begin = 0;
  for (size_t k = 0; k < end; ++k)
    if (ev[k].temperature && ev[k].ns <= first) t_begin = k;
  for (size_t k = t_begin; k < end; ++k)
    if (ev[k].temperature) {
      {
      const int64_t d = ev[k].ns - origin;  // as ros::Duration::toSec(): whole seconds + 1e-9 ns (d >= 0 here)
      in.temperature_t.push_back(static_cast<double>(d / 1000000000LL) + 1e-9 * static_cast<double>(d % 1000000000LL));
    }
      in.temperature.push_back(ev[k].celsius);
    }
  for (size_t k = begin; k < end; ++k) {
    const Event& e = ev[k];
    if (e.temperature) continue;
    in.t_c.push_back(e.ns == 0 ? 0 : e.ns - origin);
    for (size_t a = 0; a < 3; ++a) in.gyro_c[a].push_back(e.g[a]), in.accel_c[a].push_back(e.a[a]);
  }
  return in;
}

void feed(OnlineAnalyzer* oa, const Event& e) {
  if (e.temperature) oa->addTemperature(e.ns, e.celsius);
  else oa->addSample(e.ns, e.g, e.a);
}

void expectSameCoefficients(const std::array<Coefficient, kNumTerms>& a, const std::array<Coefficient, kNumTerms>& b) {
  for (int t = 0; t < kNumTerms; ++t) {
    EXPECT_EQ(a[t].value, b[t].value) << noiseTermKey(t);
    EXPECT_EQ(a[t].sigma, b[t].sigma) << noiseTermKey(t);
    EXPECT_EQ(a[t].supported, b[t].supported) << noiseTermKey(t);
  }
}

void expectSameAxis(const AxisAnalysis& a, const AxisAnalysis& b) {
  SCOPED_TRACE("axis " + a.axis);
  EXPECT_EQ(a.axis, b.axis);
  EXPECT_EQ(a.samples, b.samples);
  EXPECT_EQ(a.segments, b.segments);
  EXPECT_EQ(a.method, b.method);
  expectSameCoefficients(a.coefficients, b.coefficients);
  expectSameCoefficients(a.fit.terms, b.fit.terms);
  EXPECT_EQ(a.final_error.rms_log10, b.final_error.rms_log10);
  EXPECT_EQ(a.has_check, b.has_check);
  EXPECT_EQ(a.check.before.rms_log10, b.check.before.rms_log10);
  EXPECT_EQ(a.check.after.rms_log10, b.check.after.rms_log10);
  ASSERT_EQ(a.check.effects.size(), b.check.effects.size());
  for (size_t k = 0; k < a.check.effects.size(); ++k) {
    EXPECT_EQ(a.check.effects[k].type, b.check.effects[k].type);
    EXPECT_EQ(a.check.effects[k].evidence, b.check.effects[k].evidence);
    ASSERT_EQ(a.check.effects[k].parameters.size(), b.check.effects[k].parameters.size());
    for (const auto& p : a.check.effects[k].parameters) {
      EXPECT_EQ(p.second.value, b.check.effects[k].parameters.at(p.first).value) << p.first;
      EXPECT_EQ(p.second.sigma, b.check.effects[k].parameters.at(p.first).sigma) << p.first;
    }
  }
  EXPECT_EQ(a.quality.quality, b.quality.quality);
  EXPECT_EQ(a.notes, b.notes);
}

void expectSameResult(const PipelineResult& a, const PipelineResult& b) {
  EXPECT_EQ(a.stamps.input, b.stamps.input);
  EXPECT_EQ(a.stamps.kept, b.stamps.kept);
  EXPECT_EQ(a.stamps.non_finite, b.stamps.non_finite);
  EXPECT_EQ(a.stamps.zero_stamp, b.stamps.zero_stamp);
  EXPECT_EQ(a.stamps.duplicate, b.stamps.duplicate);
  EXPECT_EQ(a.stamps.out_of_order, b.stamps.out_of_order);
  EXPECT_EQ(a.stamps.too_close, b.stamps.too_close);
  EXPECT_EQ(a.stamps.gaps, b.stamps.gaps);
  EXPECT_EQ(a.stamps.missing_samples, b.stamps.missing_samples);
  EXPECT_EQ(a.tau0, b.tau0);
  EXPECT_EQ(a.rest_checked, b.rest_checked);
  EXPECT_EQ(a.rest.at_rest, b.rest.at_rest);
  EXPECT_EQ(a.warnings, b.warnings);
  ASSERT_EQ(a.gyro.size(), b.gyro.size());
  for (size_t k = 0; k < a.gyro.size(); ++k) expectSameAxis(a.gyro[k], b.gyro[k]);
  ASSERT_EQ(a.accel.size(), b.accel.size());
  for (size_t k = 0; k < a.accel.size(); ++k) expectSameAxis(a.accel[k], b.accel[k]);
  EXPECT_EQ(a.accel_means, b.accel_means);
}

// Window and hop [s] of a test that needs no wavelet split, model check or at-rest check (fast analyses).
OnlineOptions plainOptions(double window_s, double hop_s) {
  OnlineOptions oo;
  oo.pipeline.analysis.wavelet_split = false;
  oo.pipeline.analysis.model_check = false;
  oo.pipeline.rest_check = false;
  oo.window_s = window_s;
  oo.hop_s = hop_s;
  return oo;
}

}  // namespace

TEST(OnlineAnalyzer, WholeRecordWindowEqualsOfflinePipeline) {
  // 20 min with a warm-up drift and its temperature, 3 NaN samples, 2 zero stamps, 4 repeated messages and a gap of
  // 50 samples: the online analysis of the whole record (one window) must be the offline pipeline's, to the bit.
  // The dropped samples and the gap come after 950 s, so the longest gap-free segment (where the wavelet split and
  // the model check run, analysis.hpp) holds the warm-up.
  Injected truth;
  const std::vector<Event> ev = record(1200, {950, 1000.25, 1100}, {960.5, 1150.1}, {50, 250, 600.5, 1000}, 1050, 50,
                                       &truth);
  PipelineOptions po;
  po.jobs = 2;
  const PipelineResult offline = runPipeline(offlineInput(ev, 0, ev.size()), po);

  OnlineOptions oo;
  oo.pipeline = po;
  oo.window_s = 1e6;
  oo.hop_s = 1e6;
  OnlineAnalyzer oa(oo);
  for (const Event& e : ev) feed(&oa, e);
  EXPECT_FALSE(oa.hopDue());
  const OnlineResult on = oa.analyzeNow();
  ASSERT_TRUE(on.ok) << on.error;
  expectSameResult(offline, on.result);
  // Declared truth of the counts, offline and online (cumulative counters) alike.
  EXPECT_EQ(offline.stamps.non_finite, truth.non_finite);
  EXPECT_EQ(offline.stamps.zero_stamp, truth.zero_stamp);
  EXPECT_EQ(offline.stamps.duplicate, truth.duplicate);
  EXPECT_EQ(offline.stamps.gaps, truth.gaps);
  EXPECT_EQ(offline.stamps.missing_samples, truth.missing);
  const OnlineCounters& c = oa.counters();
  EXPECT_EQ(c.non_finite, truth.non_finite);
  EXPECT_EQ(c.zero_stamp, truth.zero_stamp);
  EXPECT_EQ(c.duplicate, truth.duplicate);
  EXPECT_EQ(c.gaps, truth.gaps);
  EXPECT_EQ(c.missing_samples, truth.missing);
  EXPECT_EQ(c.analyses, 1);
  // Not a vacuous comparison: the injected warm-up is found (with temperature: thermal_drift) on x, and the
  // accelerometer was analysed.
  ASSERT_EQ(on.result.gyro.size(), 3u);
  ASSERT_FALSE(on.result.gyro[0].check.effects.empty());
  EXPECT_EQ(on.result.gyro[0].check.effects.front().type, "thermal_drift");
  EXPECT_EQ(on.result.accel.size(), 3u);
}

TEST(OnlineAnalyzer, SlidingWindowCountsEachProblemOnce) {
  // 20 min, window 300 s, hop 100 s: every sample is in three windows, yet each injected problem is counted once.
  // Each window's answer is the offline pipeline's on the same samples (checked on the last one).
  Injected truth;
  const std::vector<Event> ev = record(1200, {150, 450.5, 899.99}, {310, 620}, {200, 1000.005}, 700, 30, &truth);
  OnlineOptions oo;
  oo.pipeline.jobs = 2;
  oo.pipeline.analysis.wavelet_split = false;  // keep the 11 analyses short; equality is the whole-record test's
  oo.window_s = 300;
  oo.hop_s = 100;
  OnlineAnalyzer oa(oo);
  std::vector<OnlineResult> results;
  std::vector<std::pair<size_t, size_t>> spans;  // event range of each window
  size_t first_in_window = 0;
  for (size_t k = 0; k < ev.size(); ++k) {
    feed(&oa, ev[k]);
    if (oa.hopDue()) {
      results.push_back(oa.analyzeNow());
      // The window's first event: the earliest still inside (the analyzer keeps the newest window_s).
      while (first_in_window < k && (ev[first_in_window].temperature || ev[first_in_window].ns != results.back().first_ns))
        ++first_in_window;
      spans.emplace_back(first_in_window, k + 1);
    }
  }
  // Hops at 100, 200, ..., 1100 s of input-stamp time.
  ASSERT_EQ(results.size(), 11u);
  for (const auto& r : results) {
    ASSERT_TRUE(r.ok) << r.sequence << ": " << r.error;
    // "now" is the median of the last three stamps, one period behind the newest: the window spans up to 300.01 s.
    EXPECT_LE(static_cast<double>(r.last_ns - r.first_ns) * 1e-9, 300.0 + 0.01 + 1e-9);
    EXPECT_GE(r.result.analysed(), 100 * 95);  // at least the first hop's 100 s (minus the gap)
  }
  EXPECT_NEAR(static_cast<double>(results.back().result.analysed()), 300 * 100, 2);
  const OnlineCounters& c = oa.counters();
  EXPECT_EQ(c.analyses, 11);
  EXPECT_EQ(c.failed, 0);
  // Problems up to the last hop (1100 s): the NaN at 899.99, zero stamps at 310 and 620, the duplicate at 200,
  // the gap at 700 are before it; the duplicate at 1000.005 too. All of them, once.
  EXPECT_EQ(c.non_finite, truth.non_finite);
  EXPECT_EQ(c.zero_stamp, truth.zero_stamp);
  EXPECT_EQ(c.duplicate, truth.duplicate);
  EXPECT_EQ(c.gaps, truth.gaps);
  EXPECT_EQ(c.missing_samples, truth.missing);
  EXPECT_EQ(c.out_of_order, 0);
  EXPECT_EQ(c.aged_out, 0);
  // The last window, analysed offline from the same events (temperature readings of its span included).
  const PipelineResult offline = runPipeline(offlineInput(ev, spans.back().first, spans.back().second), oo.pipeline);
  expectSameResult(offline, results.back().result);
}

TEST(OnlineAnalyzer, SkippedHopsResetAndBadOptions) {
  Injected truth;
  const std::vector<Event> ev = record(130, {}, {}, {}, 0, 0, &truth);
  OnlineOptions oo = plainOptions(100, 20);
  OnlineAnalyzer oa(oo);
  int due = 0;
  for (const Event& e : ev) {
    feed(&oa, e);
    if (oa.hopDue()) {
      ++due;
      oa.skipHop();  // e.g. the previous analysis still running
    }
  }
  EXPECT_EQ(due, 6);  // 20, 40, ..., 120 s
  EXPECT_EQ(oa.counters().skipped_hops, 6);
  EXPECT_EQ(oa.counters().analyses, 0);
  EXPECT_NEAR(oa.windowSpan(), 100.0, 0.011);
  // Samples that left the window before any analysis are said to have gone uncounted.
  EXPECT_EQ(oa.counters().aged_out, static_cast<int64_t>(oa.counters().samples) - static_cast<int64_t>(oa.windowSize()));
  oa.reset();
  EXPECT_EQ(oa.windowSize(), 0u);
  EXPECT_FALSE(oa.hopDue());
  EXPECT_THROW(oa.takeJob(), std::logic_error);
  EXPECT_EQ(oa.counters().skipped_hops, 6);  // counters survive a reset unless asked
  oa.reset(true);
  EXPECT_EQ(oa.counters().skipped_hops, 0);
  // Too few samples: not analysable, with the reason, and counted as failed.
  for (size_t k = 0; k < 3; ++k) feed(&oa, ev[k]);  // a temperature reading and two samples
  const OnlineResult r = oa.analyzeNow();
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.error.find("too"), std::string::npos) << r.error;
  EXPECT_EQ(oa.counters().failed, 1);

  OnlineOptions bad = oo;
  bad.hop_s = 200;  // longer than the window
  EXPECT_THROW(OnlineAnalyzer{bad}, std::invalid_argument);
  bad = oo;
  bad.window_s = -1;
  EXPECT_THROW(oa.setOptions(bad), std::invalid_argument);
  bad = oo;
  bad.min_samples = 2;
  EXPECT_THROW(OnlineAnalyzer{bad}, std::invalid_argument);
}

TEST(OnlineAnalyzer, StampGlitchMovesNeitherWindowNorClock) {
  // One stamp far ahead (a driver glitch) must not empty the window or fire a hop: "now" is the median of the last
  // three stamps. The glitch itself is dropped by the sanitation as out of order.
  Injected truth;
  std::vector<Event> ev = record(60, {}, {}, {}, 0, 0, &truth);
  OnlineOptions oo = plainOptions(100, 100);
  OnlineAnalyzer oa(oo);
  size_t n = 0;
  for (Event e : ev) {
    if (!e.temperature && ++n == 3000) e.ns += 1000LL * 1000000000LL;  // 1000 s ahead
    feed(&oa, e);
    EXPECT_FALSE(oa.hopDue());
  }
  EXPECT_EQ(oa.windowSize(), n);
  const OnlineResult r = oa.analyzeNow();
  ASSERT_TRUE(r.ok) << r.error;
  EXPECT_EQ(r.result.stamps.out_of_order, 1);
  EXPECT_EQ(oa.counters().out_of_order, 1);
}

TEST(OnlineAnalyzer, StampGlitchLeavesTheWindowLikeAnySample) {
  // A stamp 1000 s ahead at 10 s of a 60 s record, window 30 s: once the glitch is the window's oldest sample it
  // leaves like any other, so the window stays 30 s long (it must not hold the window open behind it).
  Injected truth;
  std::vector<Event> ev = record(60, {}, {}, {}, 0, 0, &truth);
  OnlineOptions oo = plainOptions(30, 30);
  OnlineAnalyzer oa(oo);
  size_t n = 0;
  int due = 0;
  for (Event e : ev) {
    if (!e.temperature && ++n == 1001) e.ns += 1000LL * 1000000000LL;
    feed(&oa, e);
    if (oa.hopDue()) ++due, oa.skipHop();
  }
  EXPECT_EQ(due, 1);  // at 30 s only
  EXPECT_NEAR(static_cast<double>(oa.windowSize()), 3001.0, 1.0);
  const OnlineResult r = oa.analyzeNow();
  ASSERT_TRUE(r.ok) << r.error;
  EXPECT_EQ(r.result.stamps.out_of_order, 0);
  EXPECT_NEAR(static_cast<double>(r.result.analysed()), 3001.0, 1.0);
}

TEST(OnlineAnalyzer, SeparateAccelerometerStreamAtItsOwnRate) {
  // A split gyro/accel driver (RealSense): the gyro at 200 Hz through addSample (its accelerometer half zero), the
  // accelerometer at 125 Hz through addAccel. The window's answer is the offline pipeline's with the accelerometer at
  // its own stamps, to the bit, and the accelerometer's N is the declared one at its own rate.
  const double n_acc = 2e-3;
  SimulationSpec spec;
  spec.rate_hz = 200;
  spec.duration_s = 600;
  spec.seed = 4;
  for (auto& ax : spec.axes) ax.angle_random_walk = 1e-4;
  const SimulatedData d = simulate(spec);
  const int64_t na = 600 * 125;
  std::array<std::vector<double>, 3> acc;
  for (int k = 0; k < 3; ++k) {
    AxisNoise an;
    an.angle_random_walk = n_acc;
    an.bias = k == 2 ? 9.81 : 0.0;
    acc[static_cast<size_t>(k)] = simulateAxis(an, 125, na, 99, k);
  }
  PipelineOptions po;
  po.jobs = 2;
  po.analysis.model_check = false;
  po.analysis.wavelet_split = false;
  OnlineOptions oo;
  oo.pipeline = po;
  oo.window_s = 1e6;
  oo.hop_s = 1e6;
  OnlineAnalyzer oa(oo);
  PipelineInput in;
  const int64_t origin = kStart - 1000000000LL;
  size_t j = 0;
  for (size_t i = 0; i < d.t.size(); ++i) {
    const int64_t ns = kStart + static_cast<int64_t>(i) * 5000000LL;  // 5 ms
    for (; j < static_cast<size_t>(na) && kStart + static_cast<int64_t>(j) * 8000000LL <= ns; ++j) {  // 8 ms
      const int64_t ans = kStart + static_cast<int64_t>(j) * 8000000LL;
      oa.addAccel(ans, {{acc[0][j], acc[1][j], acc[2][j]}});
      in.accel_t_c.push_back(ans - origin);
      for (size_t k = 0; k < 3; ++k) in.accel_c[k].push_back(acc[k][j]);
    }
    oa.addSample(ns, {{d.rate[0][i], d.rate[1][i], d.rate[2][i]}});
    in.t_c.push_back(ns - origin);
    for (size_t k = 0; k < 3; ++k) in.gyro_c[k].push_back(d.rate[k][i]);
  }
  const PipelineResult offline = runPipeline(std::move(in), po);
  const OnlineResult on = oa.analyzeNow();
  ASSERT_TRUE(on.ok) << on.error;
  expectSameResult(offline, on.result);
  ASSERT_EQ(on.result.accel.size(), 3u);
  EXPECT_NEAR(on.result.accel_tau0, 1.0 / 125, 1e-9);
  EXPECT_NEAR(on.result.tau0, 1.0 / 200, 1e-9);
  for (const auto& a : on.result.accel) {
    EXPECT_NEAR(a.rate_hz, 125, 1e-6);
    EXPECT_NEAR(a.coefficients[kAngleRandomWalk].value / n_acc, 1.0, 0.05) << a.axis;
  }
}
