// OnlineAnalyzer: sliding window of raw samples, hop clock in input-stamp time, and each window analysed by
// runPipeline exactly as analyze_bag analyses a record (see online.hpp).
#include "gyro_allan/online.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace gyro_allan {

namespace {

constexpr int64_t kNsPerS = 1000000000;

/// ns -> s as ros::Duration::toSec() and CompactStamps::toSeconds() give it (whole seconds + 1e-9 * nanoseconds).
double nsToSeconds(int64_t v) {
  int64_t sec = v / kNsPerS, nsec = v % kNsPerS;
  if (nsec < 0) {
    nsec += kNsPerS;
    --sec;
  }
  return static_cast<double>(sec) + 1e-9 * static_cast<double>(nsec);
}

int64_t secondsToNs(double s) { return static_cast<int64_t>(std::llround(s * 1e9)); }

}  // namespace

void OnlineOptions::validate() const {
  if (!(window_s > 0) || !std::isfinite(window_s) || window_s > 1e7)
    throw std::invalid_argument("window_s must be in (0, 1e7] s");
  if (!(hop_s > 0) || hop_s > window_s) throw std::invalid_argument("hop_s must be in (0, window_s]");
  if (min_samples < 3) throw std::invalid_argument("min_samples must be >= 3");
  if (!(pipeline.sanitize.gap_factor > 1)) throw std::invalid_argument("gap_factor must be > 1");
  if (pipeline.jobs < 0) throw std::invalid_argument("jobs must be >= 0");
  if (!(update_s >= 0) || !std::isfinite(update_s)) throw std::invalid_argument("update_s must be >= 0");
}

OnlineAnalyzer::OnlineAnalyzer(const OnlineOptions& options) : options_(options), quick_(QuickViewOptions{}) {
  options_.validate();
  quick_ = QuickView(quickOptions());
}

QuickViewOptions OnlineAnalyzer::quickOptions() const {
  QuickViewOptions q;
  q.window_s = options_.window_s;
  q.input = options_.pipeline.analysis.input;
  q.angle_increments = options_.pipeline.analysis.angle_increments;
  q.deviation.confidence = options_.pipeline.analysis.deviation.confidence;  // the grid stays the quick view's
  q.min_samples = options_.min_samples;
  return q;
}

void OnlineAnalyzer::rebuildQuick(double tau0) {
  quick_ = QuickView(quickOptions());
  if (options_.update_s <= 0) return;
  if (tau0 > 0) quick_.resetWithPeriod(tau0);
  for (const Raw& r : window_) quick_.add(r.ns, r.g);
}

bool OnlineAnalyzer::quickDue() const {
  return options_.update_s > 0 && quick_.ready() && (next_quick_ns_ == 0 || now_ns() >= next_quick_ns_);
}

QuickAnswer OnlineAnalyzer::takeQuick() {
  QuickAnswer q = quick_.curves();
  for (const Raw& r : window_)
    if (r.ns != 0) {
      q.window_first_ns = r.ns;
      break;
    }
  next_quick_ns_ = now_ns() + secondsToNs(options_.update_s);
  return q;
}

void OnlineAnalyzer::fitQuick(QuickAnswer* q, const PipelineOptions& options) {
  QuickView::fit(q, options.analysis.fit, options.analysis.deviation.confidence);
}

int64_t OnlineAnalyzer::now_ns() const {
  // The median of the last three non-zero stamps: one stamp glitch (far ahead or behind) moves neither the window
  // nor the hop clock.
  if (recent_n_ == 0) return 0;
  if (recent_n_ == 1) return recent_[0];
  if (recent_n_ == 2) return std::min(recent_[0], recent_[1]);
  std::array<int64_t, 3> r = recent_;
  std::sort(r.begin(), r.end());
  return r[1];
}

double OnlineAnalyzer::windowSpan() const {
  for (const Raw& r : window_)
    if (r.ns != 0) return std::max(0.0, nsToSeconds(now_ns() - r.ns));
  return 0;
}

void OnlineAnalyzer::addSample(int64_t stamp_ns, const std::array<double, 3>& gyro, const std::array<double, 3>& accel) {
  ++counters_.samples;
  Raw r{stamp_ns, gyro, options_.pipeline.accel ? accel : std::array<double, 3>{{0, 0, 0}}};
  window_.push_back(r);
  ++uncounted_;
  if (stamp_ns != 0) {
    recent_[static_cast<size_t>(recent_pos_)] = stamp_ns;
    recent_pos_ = (recent_pos_ + 1) % 3;
    recent_n_ = std::min(3, recent_n_ + 1);
  }
  if (!have_hop_ && recent_n_ > 0) {
    next_hop_ns_ = now_ns() + secondsToNs(options_.hop_s);
    have_hop_ = true;
  }
  if (options_.update_s > 0) quick_.add(stamp_ns, gyro);
  trim();
}

void OnlineAnalyzer::addAccel(int64_t stamp_ns, const std::array<double, 3>& accel) {
  if (!options_.pipeline.accel) return;
  accel_.emplace_back(stamp_ns, accel);
  trim();
}

void OnlineAnalyzer::addTemperature(int64_t stamp_ns, double celsius) {
  ++counters_.temperatures;
  temperature_.emplace_back(stamp_ns, celsius);
  trim();
}

void OnlineAnalyzer::trim() {
  if (recent_n_ == 0) return;
  const int64_t now = now_ns(), cutoff = now - secondsToNs(options_.window_s);
  // Old: before the window. A stamp later than "now" at the front (the oldest arrival) is a forward glitch that has
  // been in the window for window_s: it leaves too (else it would hold the window open behind it).
  auto old = [&](size_t i) { return window_[i].ns != 0 && (window_[i].ns < cutoff || (i == 0 && window_[i].ns > now)); };
  while (!window_.empty() &&
         (old(0) || (window_.front().ns == 0 && window_.size() > 1 && old(1)))) {
    if (window_.size() <= uncounted_) {  // never part of a job: its problems are not counted
      ++counters_.aged_out;
      --uncounted_;
    }
    window_.pop_front();
  }
  // Temperature: keep the last reading at or before the window's first stamp (interpolation holds it there).
  int64_t first = 0;
  for (const Raw& r : window_)
    if (r.ns != 0) {
      first = r.ns;
      break;
    }
  if (first != 0)
    while (temperature_.size() >= 2 && temperature_[1].first <= first) temperature_.pop_front();
  // The separate accelerometer: the samples before the window's first stamp leave (zero stamps with their neighbours).
  if (first != 0)
    while (!accel_.empty() && (accel_.front().first == 0 || accel_.front().first < first)) accel_.pop_front();
}

bool OnlineAnalyzer::hopDue() const {
  return have_hop_ && now_ns() >= next_hop_ns_ && static_cast<int64_t>(window_.size()) >= options_.min_samples;
}

void OnlineAnalyzer::skipHop() {
  ++counters_.skipped_hops;
  next_hop_ns_ = now_ns() + secondsToNs(options_.hop_s);
}

OnlineJob OnlineAnalyzer::takeJob() {
  if (window_.empty()) throw std::logic_error("OnlineAnalyzer::takeJob: the window is empty");
  OnlineJob job;
  job.sequence = ++sequence_;
  job.options = options_.pipeline;
  job.first_ns = window_.front().ns;
  job.last_ns = window_.back().ns;
  // Stamps relative to (first non-zero stamp - 1 s), as the bag reader makes them (bag_input.hpp).
  int64_t first_nonzero = 0;
  for (const Raw& r : window_)
    if (r.ns != 0) {
      first_nonzero = r.ns;
      break;
    }
  job.origin_ns = first_nonzero != 0 ? first_nonzero - kNsPerS : 0;
  PipelineInput& in = job.input;
  in.compact = true;
  in.t_c.reserve(window_.size());
  for (auto& g : in.gyro_c) g.reserve(window_.size());
  const bool split = !accel_.empty();  // the accelerometer from its own stream, at its own stamps
  const bool accel = options_.pipeline.accel && !split;
  if (accel)
    for (auto& a : in.accel_c) a.reserve(window_.size());
  for (const Raw& r : window_) {
    in.t_c.push_back(r.ns == 0 ? 0 : r.ns - job.origin_ns);
    for (size_t k = 0; k < 3; ++k) {
      in.gyro_c[k].push_back(r.g[k]);
      if (accel) in.accel_c[k].push_back(r.a[k]);
    }
  }
  if (split && options_.pipeline.accel)
    for (const auto& a : accel_) {
      in.accel_t_c.push_back(a.first == 0 ? 0 : a.first - job.origin_ns);
      for (size_t k = 0; k < 3; ++k) in.accel_c[k].push_back(a.second[k]);
    }
  for (const auto& tv : temperature_) {
    in.temperature_t.push_back(nsToSeconds(tv.first - job.origin_ns));
    in.temperature.push_back(tv.second);
  }
  // Problems are counted for the samples new since the previous job, except the newest ones: the stamp grid decides
  // a sample with the lookahead after it (max(lookahead_s, 64 periods)), which the end of the window lacks, so those
  // are counted by the next job.
  const size_t begin = window_.size() - std::min(uncounted_, window_.size());
  const double hold_s = std::max(options_.pipeline.sanitize.lookahead_s, 64 * last_tau0_);
  const int64_t hold_from = now_ns() - secondsToNs(hold_s);
  size_t end = window_.size();
  while (end > begin && (window_[end - 1].ns == 0 || window_[end - 1].ns > hold_from)) --end;
  job.options.sanitize.count_from = begin;
  job.options.sanitize.count_to = end;
  uncounted_ = window_.size() - end;
  next_hop_ns_ = now_ns() + secondsToNs(options_.hop_s);
  have_hop_ = true;
  return job;
}

OnlineResult OnlineAnalyzer::run(OnlineJob&& job) {
  OnlineResult out;
  out.sequence = job.sequence;
  out.first_ns = job.first_ns;
  out.last_ns = job.last_ns;
  try {
    out.result = runPipeline(std::move(job.input), job.options, &out.new_samples);
    out.ok = true;
  } catch (const NotAtRest& e) {
    out.error = e.what();
    out.not_at_rest = true;
  } catch (const std::exception& e) {
    out.error = e.what();
  }
  return out;
}

void OnlineAnalyzer::account(const OnlineResult& r) {
  ++counters_.analyses;
  if (r.ok && r.result.tau0 > 0) last_tau0_ = r.result.tau0;
  // The quick view's period from its first stamps; the full analysis's grid is better (e.g. batched stamps early on).
  if (r.ok && r.result.tau0 > 0 && quick_.tau0() > 0 && std::abs(quick_.tau0() / r.result.tau0 - 1) > 0.005)
    rebuildQuick(r.result.tau0);
  if (!r.ok) ++counters_.failed;
  const StampReport& s = r.new_samples;
  counters_.non_finite += s.non_finite;
  counters_.zero_stamp += s.zero_stamp;
  counters_.out_of_order += s.out_of_order;
  counters_.duplicate += s.duplicate;
  counters_.too_close += s.too_close;
  counters_.short_segment += s.short_segment;
  counters_.gaps += s.gaps;
  counters_.missing_samples += s.missing_samples;
}

OnlineResult OnlineAnalyzer::analyzeNow() {
  OnlineResult r = run(takeJob());
  account(r);
  return r;
}

void OnlineAnalyzer::reset(bool counters) {
  window_.clear();
  temperature_.clear();
  accel_.clear();
  recent_n_ = 0;
  recent_pos_ = 0;
  uncounted_ = 0;
  have_hop_ = false;
  sequence_ = 0;
  next_quick_ns_ = 0;
  quick_.reset();
  if (counters) counters_ = OnlineCounters();
}

void OnlineAnalyzer::setOptions(const OnlineOptions& options) {
  options.validate();
  const QuickViewOptions before = quickOptions();
  const bool was_on = options_.update_s > 0;
  options_ = options;
  if (have_hop_) next_hop_ns_ = std::min(next_hop_ns_, now_ns() + secondsToNs(options_.hop_s));
  if (next_quick_ns_ != 0) next_quick_ns_ = std::min(next_quick_ns_, now_ns() + secondsToNs(options_.update_s));
  trim();
  const QuickViewOptions after = quickOptions();
  // The engines depend on the window and the input kind (the fit's options are the pipeline's at each fitQuick).
  if ((options_.update_s > 0) != was_on || after.window_s != before.window_s || after.input != before.input ||
      after.angle_increments != before.angle_increments || after.min_samples != before.min_samples)
    rebuildQuick(quick_.tau0());
}

}  // namespace gyro_allan
