// Timestamp and sample sanitation: drop bad samples, split at gaps, count everything.
#include "gyro_allan/timing.hpp"
#include "gyro_allan/stats.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

namespace gyro_allan {

std::vector<std::string> StampReport::warnings() const {
  std::vector<std::string> w;
  auto add = [&](int64_t n, const char* what) {
    if (n > 0) w.push_back(std::to_string(n) + " " + what);
  };
  add(non_finite, "samples with NaN/Inf dropped");
  add(zero_stamp, "samples with zero stamp dropped");
  add(out_of_order, "out-of-order stamps dropped");
  add(duplicate, "duplicate stamps dropped");
  add(too_close, "samples arrived over half a period before their grid slot (more samples than the rate allows): "
                 "dropped as too close");
  add(short_segment, "samples isolated between gaps dropped");
  char buf[256];
  if (gaps > 0) {
    std::snprintf(buf, sizeof buf, "%lld gaps (%lld samples missing, %.6g s): deviations computed over gap-free segments",
                  static_cast<long long>(gaps), static_cast<long long>(missing_samples), gap_time_s);
    w.push_back(buf);
  }
  if (receipt_stamps) {
    std::snprintf(buf, sizeof buf,
                  "stamps jitter by up to %.3g ms (99 %% within %.3g ms, %.0f %% of a period): arrival-time stamps? "
                  "samples placed on a regular %.6g Hz grid",
                  1e3 * jitter_max_s, 1e3 * jitter_p99_s, 100 * jitter_p99_s * rate_hz, rate_hz);
    w.push_back(buf);
  }
  if (rate_changed)
    w.push_back("sample rate changes within the record (max " + std::to_string(100 * max_rate_deviation) +
                " % from nominal)");
  return w;
}

std::vector<std::vector<double>> SanitizedSeries::segmentValues(int axis) const {
  std::vector<std::vector<double>> out;
  const auto& src = v[static_cast<size_t>(axis)];
  for (const auto& s : segments) out.emplace_back(src.begin() + static_cast<long>(s.begin), src.begin() + static_cast<long>(s.end));
  return out;
}

std::vector<std::vector<double>> SanitizedSeries::takeSegmentValues(int axis) {
  auto& src = v[static_cast<size_t>(axis)];
  std::vector<std::vector<double>> out;
  if (segments.size() == 1 && segments[0].begin == 0 && segments[0].end == src.size()) {
    out.push_back(std::move(src));
  } else {
    out = segmentValues(axis);
  }
  std::vector<double>().swap(src);
  return out;
}

int64_t SanitizedSeries::restrictTo(size_t begin, size_t end) {
  int64_t removed = 0;
  std::vector<Segment> kept_segments;
  for (const auto& seg : segments) {
    const size_t b = std::max(seg.begin, begin), e = std::min(seg.end, end);
    const size_t inside = e > b ? e - b : 0;
    removed += static_cast<int64_t>(seg.size() - inside);
    if (inside >= 2) kept_segments.push_back({b, e});
    else removed += static_cast<int64_t>(inside);
  }
  segments = std::move(kept_segments);
  return removed;
}

int64_t SanitizedSeries::restrictToTime(double first, double last) {
  const size_t b = static_cast<size_t>(std::lower_bound(t.begin(), t.end(), first) - t.begin());
  const size_t e = static_cast<size_t>(std::upper_bound(t.begin(), t.end(), last) - t.begin());
  return restrictTo(b, e);
}

std::vector<std::vector<double>> SanitizedSeries::interpolateSegments(const std::vector<double>& ts,
                                                                      const std::vector<double>& vs) const {
  std::vector<std::pair<double, double>> pts;
  for (size_t i = 0; i < ts.size() && i < vs.size(); ++i)
    if (std::isfinite(ts[i]) && std::isfinite(vs[i]) && ts[i] != 0) pts.emplace_back(ts[i], vs[i]);
  std::vector<std::vector<double>> out;
  if (pts.empty()) return out;
  std::stable_sort(pts.begin(), pts.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  for (const auto& seg : segments) {
    std::vector<double> v;
    v.reserve(seg.size());
    size_t j = 0;
    for (size_t i = seg.begin; i < seg.end; ++i) {
      const double x = t[i];
      while (j + 1 < pts.size() && pts[j + 1].first <= x) ++j;
      if (x <= pts.front().first) v.push_back(pts.front().second);
      else if (j + 1 >= pts.size()) v.push_back(pts.back().second);
      else {
        const double w = (x - pts[j].first) / (pts[j + 1].first - pts[j].first);
        v.push_back(pts[j].second + w * (pts[j + 1].second - pts[j].second));
      }
    }
    out.push_back(std::move(v));
  }
  return out;
}

ValueAnomalies detectValueAnomalies(const std::vector<double>& v, double min_rate) {
  ValueAnomalies a;
  if (v.size() < 16) return a;
  const size_t step = std::max<size_t>(1, v.size() >> 18);  // 2^18 samples: MAD within ~0.3 %
  std::vector<double> s;
  for (size_t i = 0; i < v.size(); i += step)
    if (std::isfinite(v[i])) s.push_back(v[i]);
  if (s.empty()) return a;
  const double m = upperMedian(s);
  for (auto& x : s) x = std::fabs(x - m);
  a.threshold = std::max(10 * 1.4826 * upperMedianInPlace(s), min_rate);
  for (size_t i = 0; i < v.size();) {
    size_t j = i + 1;
    while (j < v.size() && v[j] == v[i]) ++j;
    if (std::fabs(v[i] - m) > a.threshold) {
      if (j - i >= 5) {
        ++a.saturation_runs;
        a.saturated += static_cast<int64_t>(j - i);
      } else {
        a.spikes += static_cast<int64_t>(j - i);
      }
    }
    i = j;
  }
  return a;
}

std::vector<Warning> ValueAnomalies::warnings(const std::string& what) const {
  std::vector<Warning> w;
  char buf[200];
  if (spikes > 0) {
    std::snprintf(buf, sizeof buf, "%s: %lld impulsive samples (shocks) more than %.3g rad/s from the median",
                  what.c_str(), static_cast<long long>(spikes), threshold);
    w.push_back({WarningKind::Shocks, buf});
  }
  if (saturation_runs > 0) {
    std::snprintf(buf, sizeof buf, "%s: %lld runs of identical extreme values (%lld samples): saturation?", what.c_str(),
                  static_cast<long long>(saturation_runs), static_cast<long long>(saturated));
    w.push_back({WarningKind::Saturation, buf});
  }
  return w;
}


namespace {
/// estimatePeriod over n stamps given by at(i): at most ~2048 blocks, evenly spread over the record.
template <class At>
double estimatePeriodImpl(size_t n, At at, size_t block) {
  if (n < 2) return 0;
  // Blocks of `block` stamps, shorter for short series (at least ~16 blocks, so a few defective ones are a minority).
  const size_t b = std::max<size_t>(2, std::min(std::max<size_t>(2, block), std::max<size_t>(8, n / 16)));
  const size_t n_blocks = n / b;
  const size_t stride = std::max<size_t>(1, n_blocks / 2048);
  // Least-squares slope of stamp against index per block: unbiased for packet-wise delivery of any packet size
  // (equal stamps of one buffered read included). A block with a stamp earlier than its predecessor is skipped.
  const double kbar = 0.5 * static_cast<double>(b - 1);
  double sxx = 0;
  for (size_t k = 0; k < b; ++k) sxx += (static_cast<double>(k) - kbar) * (static_cast<double>(k) - kbar);
  std::vector<double> slopes;
  for (size_t j = 0; j < n_blocks; j += stride) {
    const size_t i = j * b;
    const double t0 = at(i);
    double sxy = 0, prev = -std::numeric_limits<double>::infinity();
    bool ok = std::isfinite(t0);
    for (size_t k = 0; k < b && ok; ++k) {
      const double x = at(i + k);
      ok = std::isfinite(x) && x >= prev;
      prev = x;
      sxy += (static_cast<double>(k) - kbar) * (x - t0);
    }
    if (ok) slopes.push_back(sxy / sxx);
  }
  if (slopes.empty()) {
    const double span = at(n - 1) - at(0);
    return std::isfinite(span) && span > 0 ? span / static_cast<double>(n - 1) : 0.0;
  }
  return upperMedianInPlace(slopes);
}
}  // namespace

double estimatePeriod(const std::vector<double>& t, size_t block) {
  return estimatePeriodImpl(t.size(), [&](size_t i) { return t[i]; }, block);
}

StampGrid::StampGrid(double period, double gap_factor, double lookahead_s)
    : period_(period), gap_factor_(gap_factor) {
  if (!(period > 0) || !std::isfinite(period)) throw std::invalid_argument("StampGrid: period must be > 0");
  if (!(gap_factor > 1) || !std::isfinite(gap_factor)) throw std::invalid_argument("StampGrid: gap_factor must be > 1");
  if (!(lookahead_s >= 0) || !std::isfinite(lookahead_s))
    throw std::invalid_argument("StampGrid: lookahead must be >= 0 s");
  lookahead_ = std::max<size_t>(32, static_cast<size_t>(std::min(1e7, std::ceil(lookahead_s / period))));
}

void StampGrid::reset() {
  q_.clear();
  vmin_.clear();
  next_pos_ = 0;
  have_newest_ = tail_open_ = finished_ = have_origin_ = have_kept_ = false;
  psi_ = 0;
  shift_ = 0;
}

void StampGrid::push(double stamp, uint64_t tag, bool batched) {
  if (finished_) reset();
  if (!have_origin_) {
    origin_ = stamp;
    have_origin_ = true;
  }
  Entry e;
  e.t = stamp - origin_;
  e.tag = tag;
  e.seq = next_seq_++;
  if (have_newest_ && !(e.t > newest_) && !(batched && e.t == newest_)) {
    e.pos = -1;  // not later than an earlier stamp: decided as duplicate / out of order, takes no position
    e.u = 0;
  } else {
    e.pos = next_pos_++;
    e.u = e.t - static_cast<double>(e.pos) * period_;
    newest_ = e.t;
    have_newest_ = true;
    if (tail_open_) {  // the previous candidate's pair value is now known
      const double v = std::max(tail_u_, e.u);
      while (!vmin_.empty() && vmin_.back().second >= v) vmin_.pop_back();
      vmin_.emplace_back(tail_seq_, v);
    }
    tail_open_ = true;
    tail_seq_ = e.seq;
    tail_u_ = e.u;
  }
  q_.push_back(e);
}

void StampGrid::finish() {
  finished_ = true;
  if (tail_open_) {
    while (!vmin_.empty() && vmin_.back().second >= tail_u_) vmin_.pop_back();
    vmin_.emplace_back(tail_seq_, tail_u_);
    tail_open_ = false;
  }
}

double StampGrid::windowMin() const {
  if (!vmin_.empty()) return vmin_.front().second;
  return tail_open_ ? tail_u_ : std::numeric_limits<double>::infinity();
}

bool StampGrid::pop(StampDecision* d) {
  if (q_.empty() || (!finished_ && q_.size() <= lookahead_)) return false;
  const Entry e = q_.front();
  q_.pop_front();
  while (!vmin_.empty() && vmin_.front().first <= e.seq) vmin_.pop_front();
  if (tail_open_ && tail_seq_ == e.seq && q_.empty()) tail_open_ = false;
  d->stamp = e.t + origin_;
  d->tag = e.tag;
  d->index = 0;
  d->missing = 0;
  d->lag = 0;
  if (e.pos < 0 || (have_kept_ && e.t < last_kept_)) {
    d->verdict = (have_kept_ && e.t == last_kept_) ? StampVerdict::Duplicate : StampVerdict::OutOfOrder;
    return true;
  }
  // The window's earliest arrival relative to the slots, in consecutive pairs (this entry's pair included).
  const double w = std::min(windowMin(), e.u);  // e's own pair left vmin_ with it: e counts alone
  if (!have_kept_) {
    // First sample: the slots start at the earliest arrival among it and the lookahead.
    double m = e.u;
    for (const auto& x : q_)
      if (x.pos >= 0) m = std::min(m, x.u);
    psi_ = m;
    shift_ = -e.pos;
  } else {
    const double lag = e.u - psi_;
    if (lag < -0.5 * period_) {
      d->verdict = StampVerdict::TooClose;
      // Later candidates were numbered counting this one: their slots move one period earlier.
      psi_ -= period_;
      --shift_;
      return true;
    }
    const double min_lag = w - psi_;
    if (min_lag > (gap_factor_ - 1.0) * period_) {
      const int64_t m = std::max<int64_t>(1, std::llround(min_lag / period_));
      d->missing = m;
      shift_ += m;
      psi_ += static_cast<double>(m) * period_;
    }
  }
  d->verdict = StampVerdict::Keep;
  d->index = e.pos + shift_;
  d->lag = e.u - psi_;
  // The envelope: lowered by an early arrival now, raised to the earliest arrival ahead.
  if (d->lag < 0) {
    psi_ += d->lag;
    d->lag = 0;
  } else {
    const double ahead = windowMin() - psi_;
    if (std::isfinite(ahead) && ahead > 0) psi_ += std::min(ahead, d->lag);
  }
  have_kept_ = true;
  last_kept_ = e.t;
  return true;
}

namespace {

// ---- sanitize, stage by stage -------------------------------------------------------------------------------------

// Rejects inputs sanitize cannot work on (std::invalid_argument).
template <class Axis>
void validateSanitizeInputs(const std::vector<double>& t, const std::vector<const Axis*>& axes,
                            const SanitizeOptions& options) {
  if (axes.empty() || axes.size() > 3) throw std::invalid_argument("sanitize: 1 to 3 axes expected");
  for (const auto* a : axes)
    if (!a || a->size() != t.size()) throw std::invalid_argument("sanitize: axis length differs from stamp count");
  if (!(options.gap_factor > 1.0)) throw std::invalid_argument("sanitize: gap_factor must be > 1");
}

// The problems of the input samples with index in [count_from, count_to), counted again in SanitizedSeries::counted
// (OnlineAnalyzer: only the samples new since its previous window).
struct CountedRange {
  size_t from, to;
  StampReport* counted;
  bool counts(size_t input_index) const { return input_index >= from && input_index < to; }
};

// Pass 1: indices of the samples with finite values and a finite, non-zero stamp (the others counted in rep).
template <class Axis>
std::vector<uint32_t> usableSamples(const std::vector<double>& t, const std::vector<const Axis*>& axes,
                                    StampReport* rep, const CountedRange& cr) {
  if (t.size() >= (size_t(1) << 32)) throw std::invalid_argument("sanitize: more than 2^32 samples");
  std::vector<uint32_t> idx;  // 4-byte indices: this runs on whole long records
  idx.reserve(t.size());
  for (size_t i = 0; i < t.size(); ++i) {
    bool finite = std::isfinite(t[i]);
    for (const auto* a : axes) finite = finite && std::isfinite((*a)[i]);
    if (!finite) {
      ++rep->non_finite;
      if (cr.counts(i)) ++cr.counted->non_finite;
      continue;
    }
    if (t[i] == 0) {
      ++rep->zero_stamp;
      if (cr.counts(i)) ++cr.counted->zero_stamp;
      continue;
    }
    idx.push_back(static_cast<uint32_t>(i));
  }
  return idx;
}

// A single stamp ahead of both neighbours (t[k] > t[k+1] while the previous kept stamp < t[k+1]) would otherwise be
// kept and make every later sample "out of order" until time catches up with it: drop the glitch itself instead.
void dropStampGlitches(const std::vector<double>& t, std::vector<uint32_t>* index, StampReport* rep,
                       const CountedRange& cr) {
  std::vector<uint32_t>& idx = *index;
  size_t kept = 0;  // compacted in place: idx[0, kept) are the kept ones (kept <= k, so idx[k + 1] is untouched)
  for (size_t k = 0; k < idx.size(); ++k) {
    if (k + 1 < idx.size() && t[idx[k]] > t[idx[k + 1]] && (kept == 0 || t[idx[kept - 1]] < t[idx[k + 1]])) {
      ++rep->out_of_order;
      if (cr.counts(idx[k])) ++cr.counted->out_of_order;
      continue;
    }
    idx[kept++] = idx[k];
  }
  idx.resize(kept);
  idx.shrink_to_fit();
}

// Pass 2: places the stamps on the sampler's grid (StampGrid), keeps their samples, splits where grid slots have no
// sample, and gathers the rate-check and jitter figures on the way.
template <class Axis>
struct GridPass {
  const std::vector<double>& t;
  const std::vector<const Axis*>& axes;
  const SanitizeOptions& options;
  bool keep_values;
  double period;
  SanitizedSeries* out;
  StampReport& rep;
  CountedRange cr;
  std::vector<uint32_t> kept_input;  // input index of each kept sample, when out->kept is not kept and counting from > 0
  size_t seg_start = 0;
  // Rate check: the slope of stamp against grid index over chunks of kept samples (about 20 per record), so that
  // neither jitter nor gaps look like a rate change.
  size_t chunk;
  size_t chunk_n = 0;
  double chunk_t0 = 0;
  int64_t chunk_k0 = 0;
  // Jitter: lags of a subsample of kept stamps (at most ~65536), for percentiles.
  size_t lag_step;
  std::vector<float> lags;
  size_t n_keep = 0;
  bool have_prev = false;
  double first_keep_t = 0, last_keep_t = 0;  // grid span of the record, for the final period
  int64_t first_keep_k = 0, last_keep_k = 0;

  GridPass(const std::vector<double>& t_, const std::vector<const Axis*>& axes_, const SanitizeOptions& options_,
           bool keep_values_, double period_, size_t n_usable, SanitizedSeries* out_, const CountedRange& cr_)
      : t(t_), axes(axes_), options(options_), keep_values(keep_values_), period(period_), out(out_),
        rep(out_->report), cr(cr_), chunk(std::max<size_t>(64, n_usable / 20)), lag_step(std::max<size_t>(1, n_usable >> 16)) {
    out->t.reserve(n_usable);
    if (keep_values) {
      for (size_t a = 0; a < axes.size(); ++a) out->v[a].reserve(n_usable);
    } else {
      out->kept.reserve(n_usable);
    }
  }

  // Ends the current segment at `end`: kept if long enough, otherwise its samples are dropped.
  void closeSegment(size_t end) {
    if (end > seg_start) {
      if (end - seg_start >= options.min_segment) out->segments.push_back({seg_start, end});
      else {
        // Too short to carry a difference: its samples are dropped and counted as missing time.
        for (size_t j = seg_start; j < end; ++j) {
          ++rep.short_segment;
          // the sample popped now (the last kept one), by its input index
          const size_t in_index = !out->kept.empty() ? out->kept.back() : !kept_input.empty() ? kept_input.back() : cr.from;
          if (cr.counts(in_index)) ++cr.counted->short_segment;
          if (!kept_input.empty()) kept_input.pop_back();
          out->t.pop_back();
          for (auto& a : out->v)
            if (!a.empty()) a.pop_back();
          if (!out->kept.empty()) out->kept.pop_back();
        }
        end = seg_start;
      }
    }
    seg_start = out->t.size();
  }

  // One decision of the grid: counted when dropped; kept (after closing the segment at a gap) otherwise.
  void handle(const StampDecision& d) {
    switch (d.verdict) {
      case StampVerdict::Duplicate: ++rep.duplicate, cr.counted->duplicate += cr.counts(d.tag); return;
      case StampVerdict::OutOfOrder: ++rep.out_of_order, cr.counted->out_of_order += cr.counts(d.tag); return;
      case StampVerdict::TooClose: ++rep.too_close, cr.counted->too_close += cr.counts(d.tag); return;
      case StampVerdict::Keep: break;
    }
    if (have_prev && d.missing > 0) {
      ++rep.gaps;
      rep.missing_samples += d.missing;
      if (cr.counts(d.tag)) ++cr.counted->gaps, cr.counted->missing_samples += d.missing;  // the gap before a counted sample
      closeSegment(out->t.size());
    }
    if (n_keep++ % lag_step == 0) lags.push_back(static_cast<float>(d.lag));
    rep.jitter_max_s = std::max(rep.jitter_max_s, d.lag);
    if (chunk_n == 0) {
      chunk_t0 = d.stamp;
      chunk_k0 = d.index;
    }
    if (++chunk_n == chunk) {
      if (d.index > chunk_k0)
        rep.max_rate_deviation = std::max(
            rep.max_rate_deviation, std::fabs((d.stamp - chunk_t0) / static_cast<double>(d.index - chunk_k0) / period - 1.0));
      chunk_n = 0;
    }
    if (n_keep == 1) {
      first_keep_t = d.stamp;
      first_keep_k = d.index;
    }
    last_keep_t = d.stamp;
    last_keep_k = d.index;
    const size_t i = static_cast<size_t>(d.tag);
    out->t.push_back(t[i]);
    if (keep_values) {
      for (size_t a = 0; a < axes.size(); ++a) out->v[a].push_back((*axes[a])[i]);
      if (cr.from > 0 || cr.to < t.size()) kept_input.push_back(static_cast<uint32_t>(i));
    } else {
      out->kept.push_back(static_cast<uint32_t>(i));
    }
    have_prev = true;
  }

  // All usable samples through the grid, then the last segment closed.
  void run(const std::vector<uint32_t>& idx) {
    if (period > 0) {
      StampGrid grid(period, options.gap_factor, options.lookahead_s);
      StampDecision d;
      for (size_t k = 0; k < idx.size(); ++k) {
        // A stamp equal to the previous one on a sample with other values is a buffered read, not a repeat.
        bool batched = false;
        if (k > 0 && t[idx[k]] == t[idx[k - 1]])
          for (const auto* a : axes) batched = batched || (*a)[idx[k]] != (*a)[idx[k - 1]];
        grid.push(t[idx[k]], idx[k], batched);
        while (grid.pop(&d)) handle(d);
      }
      grid.finish();
      while (grid.pop(&d)) handle(d);
    } else if (!idx.empty()) {
      // One usable stamp (or all equal): keep the first, the rest are duplicates.
      StampDecision d;
      d.stamp = t[idx[0]];
      d.tag = idx[0];
      handle(d);
      for (size_t k = 1; k < idx.size(); ++k) {
        const bool dup = t[idx[k]] == t[idx[0]];
        ++(dup ? rep.duplicate : rep.out_of_order);
        if (cr.counts(idx[k])) ++(dup ? cr.counted->duplicate : cr.counted->out_of_order);
      }
    }
    closeSegment(out->t.size());
  }
};

// The report's period, rate, jitter and span from the grid pass. The period over the whole grid (first to last kept
// stamp over their index difference): the block estimate started the grid, this one carries the jitter once over the
// whole record. Kept only when it agrees (a rate change makes the two differ; rate_changed says so).
template <class Axis>
void summarizeStamps(GridPass<Axis>* g, SanitizedSeries* out) {
  StampReport& rep = out->report;
  double period = g->period;
  if (g->options.nominal_rate_hz <= 0 && g->last_keep_k - g->first_keep_k >= 64) {
    const double whole = (g->last_keep_t - g->first_keep_t) / static_cast<double>(g->last_keep_k - g->first_keep_k);
    if (std::fabs(whole / period - 1.0) < 0.01) period = whole;
  }
  rep.nominal_period_s = period;
  rep.gap_time_s = static_cast<double>(rep.missing_samples) * period;
  rep.rate_hz = period > 0 ? 1.0 / period : 0.0;
  std::vector<float>& lags = g->lags;
  if (!lags.empty()) {
    std::sort(lags.begin(), lags.end());
    rep.jitter_p50_s = lags[lags.size() / 2];
    rep.jitter_p99_s = lags[std::min(lags.size() - 1, static_cast<size_t>(0.99 * static_cast<double>(lags.size())))];
  }
  rep.receipt_stamps = period > 0 && rep.jitter_p99_s > 0.1 * period;
  rep.rate_changed = rep.max_rate_deviation > 0.05;
  if (!out->t.empty()) {
    rep.first_stamp = out->t.front();
    rep.last_stamp = out->t.back();
  }
}

/// sanitize() for any axis container with size() and operator[] (std::vector<double>, CompactSeries).
template <class Axis>
SanitizedSeries sanitizeImpl(const std::vector<double>& t, const std::vector<const Axis*>& axes,
                             const SanitizeOptions& options, bool keep_values = true) {
  validateSanitizeInputs(t, axes, options);
  SanitizedSeries out;
  StampReport& rep = out.report;
  rep.input = static_cast<int64_t>(t.size());
  const CountedRange cr{options.count_from, std::min(options.count_to, t.size()), &out.counted};
  out.counted.input = static_cast<int64_t>(cr.to > cr.from ? cr.to - cr.from : 0);
  std::vector<uint32_t> idx = usableSamples(t, axes, &rep, cr);
  dropStampGlitches(t, &idx, &rep, cr);
  // Nominal period: given, or the median block slope of the stamps (robust to jitter and bursts).
  double period = options.nominal_rate_hz > 0 ? 1.0 / options.nominal_rate_hz : 0.0;
  if (period <= 0) {
    period = estimatePeriodImpl(idx.size(), [&](size_t k) { return t[idx[k]]; }, 64);
  }
  GridPass<Axis> pass(t, axes, options, keep_values, period, idx.size(), &out, cr);
  pass.run(idx);
  std::vector<uint32_t>().swap(idx);
  // Nothing dropped (the usual case): the kept index is the identity and is not stored.
  if (!keep_values && out.kept.size() == t.size()) std::vector<uint32_t>().swap(out.kept);
  rep.kept = static_cast<int64_t>(out.t.size());
  summarizeStamps(&pass, &out);
  return out;
}

}  // namespace

SanitizedSeries sanitize(const std::vector<double>& t, const std::vector<const std::vector<double>*>& axes,
                         const SanitizeOptions& options) {
  return sanitizeImpl(t, axes, options);
}

SanitizedSeries sanitizeCompact(const std::vector<double>& t, const std::vector<const CompactSeries*>& axes,
                                const SanitizeOptions& options) {
  return sanitizeImpl(t, axes, options, false);
}

std::vector<std::vector<double>> SanitizedSeries::segmentValuesOf(const CompactSeries& axis) const {
  std::vector<std::vector<double>> out;
  for (const auto& s : segments) {
    std::vector<double> v(s.size());
    if (kept.empty()) {  // identity: nothing was dropped
      for (size_t i = s.begin; i < s.end; ++i) v[i - s.begin] = axis[i];
    } else {
      for (size_t i = s.begin; i < s.end; ++i) v[i - s.begin] = axis[kept[i]];
    }
    out.push_back(std::move(v));
  }
  return out;
}

}  // namespace gyro_allan
