// Timestamp and sample sanitation: drop bad samples, split at gaps, count everything.
#include "gyro_allan/timing.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace gyro_allan {
namespace {
double median(std::vector<double> v) {
  if (v.empty()) return 0;
  const size_t mid = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + static_cast<long>(mid), v.end());
  return v[mid];
}
}  // namespace

std::vector<std::string> StampReport::warnings() const {
  std::vector<std::string> w;
  auto add = [&](int64_t n, const char* what) {
    if (n > 0) w.push_back(std::to_string(n) + " " + what);
  };
  add(non_finite, "samples with NaN/Inf dropped");
  add(zero_stamp, "samples with zero stamp dropped");
  add(out_of_order, "out-of-order stamps dropped");
  add(duplicate, "duplicate stamps dropped");
  add(short_segment, "samples isolated between gaps dropped");
  if (gaps > 0)
    w.push_back(std::to_string(gaps) + " gaps (" + std::to_string(gap_time_s) +
                " s missing): deviations computed over gap-free segments");
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
  const double m = median(s);
  for (auto& x : s) x = std::fabs(x - m);
  a.threshold = std::max(10 * 1.4826 * median(s), min_rate);
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

std::vector<std::string> ValueAnomalies::warnings(const std::string& what) const {
  std::vector<std::string> w;
  char buf[200];
  if (spikes > 0) {
    std::snprintf(buf, sizeof buf, "%s: %lld impulsive samples (shocks) more than %.3g rad/s from the median",
                  what.c_str(), static_cast<long long>(spikes), threshold);
    w.push_back(buf);
  }
  if (saturation_runs > 0) {
    std::snprintf(buf, sizeof buf, "%s: %lld runs of identical extreme values (%lld samples): saturation?", what.c_str(),
                  static_cast<long long>(saturation_runs), static_cast<long long>(saturated));
    w.push_back(buf);
  }
  return w;
}

namespace {

/// sanitize() for any axis container with size() and operator[] (std::vector<double>, CompactSeries).
template <class Axis>
SanitizedSeries sanitizeImpl(const std::vector<double>& t, const std::vector<const Axis*>& axes,
                             const SanitizeOptions& options, bool keep_values = true) {
  if (axes.empty() || axes.size() > 3) throw std::invalid_argument("sanitize: 1 to 3 axes expected");
  for (const auto* a : axes)
    if (!a || a->size() != t.size()) throw std::invalid_argument("sanitize: axis length differs from stamp count");
  if (!(options.gap_factor > 1.0)) throw std::invalid_argument("sanitize: gap_factor must be > 1");
  SanitizedSeries out;
  StampReport& rep = out.report;
  rep.input = static_cast<int64_t>(t.size());

  // Pass 1: drop non-finite values and zero or non-finite stamps.
  if (t.size() >= (size_t(1) << 32)) throw std::invalid_argument("sanitize: more than 2^32 samples");
  std::vector<uint32_t> idx;  // 4-byte indices: this runs on whole long records
  idx.reserve(t.size());
  for (size_t i = 0; i < t.size(); ++i) {
    bool finite = std::isfinite(t[i]);
    for (const auto* a : axes) finite = finite && std::isfinite((*a)[i]);
    if (!finite) {
      ++rep.non_finite;
      continue;
    }
    if (t[i] == 0) {
      ++rep.zero_stamp;
      continue;
    }
    idx.push_back(static_cast<uint32_t>(i));
  }
  // A single stamp ahead of both neighbours (t[k] > t[k+1] while the previous kept stamp < t[k+1]) would otherwise be
  // kept and make every later sample "out of order" until time catches up with it: drop the glitch itself instead.
  {
    size_t kept = 0;  // compacted in place: idx[0, kept) are the kept ones (kept <= k, so idx[k + 1] is untouched)
    for (size_t k = 0; k < idx.size(); ++k) {
      if (k + 1 < idx.size() && t[idx[k]] > t[idx[k + 1]] && (kept == 0 || t[idx[kept - 1]] < t[idx[k + 1]])) {
        ++rep.out_of_order;
        continue;
      }
      idx[kept++] = idx[k];
    }
    idx.resize(kept);
    idx.shrink_to_fit();
  }
  // Nominal period: the median of positive consecutive intervals (robust to a few bad stamps).
  double period = options.nominal_rate_hz > 0 ? 1.0 / options.nominal_rate_hz : 0.0;
  if (period <= 0) {
    std::vector<double> d;
    d.reserve(idx.size());
    for (size_t k = 1; k < idx.size(); ++k) {
      const double dt = t[idx[k]] - t[idx[k - 1]];
      if (dt > 0) d.push_back(dt);
    }
    period = median(std::move(d));  // selection in place: no second copy of a long record
  }
  // Pass 2: keep strictly increasing stamps at least half a period apart; split at gaps.
  out.t.reserve(idx.size());
  if (keep_values) {
    for (size_t a = 0; a < axes.size(); ++a) out.v[a].reserve(idx.size());
  } else {
    out.kept.reserve(idx.size());
  }
  bool have_prev = false;
  double prev = 0;
  size_t seg_start = 0;
  std::vector<double> seg_periods;
  auto closeSegment = [&](size_t end) {
    if (end > seg_start) {
      if (end - seg_start >= options.min_segment) out.segments.push_back({seg_start, end});
      else {
        // Too short to carry a difference: its samples are dropped and counted as missing time.
        for (size_t j = seg_start; j < end; ++j) {
          ++rep.short_segment;
          out.t.pop_back();
          for (auto& a : out.v)
            if (!a.empty()) a.pop_back();
          if (!out.kept.empty()) out.kept.pop_back();
        }
        end = seg_start;
      }
    }
    seg_start = out.t.size();
  };
  // Median interval of the run being closed (the intervals between its consecutive kept stamps), computed when it
  // ends from the kept stamps themselves.
  auto segmentPeriod = [&]() {
    const size_t n = out.t.size();
    if (n < seg_start + 2) return;
    std::vector<double> d(n - seg_start - 1);
    for (size_t j = seg_start + 1; j < n; ++j) d[j - seg_start - 1] = out.t[j] - out.t[j - 1];
    seg_periods.push_back(median(std::move(d)));
  };
  for (size_t k = 0; k < idx.size(); ++k) {
    const size_t i = idx[k];
    const double ti = t[i];
    if (have_prev) {
      const double dt = ti - prev;
      if (dt < 0) {
        ++rep.out_of_order;
        continue;
      }
      if (period > 0 ? dt < 0.5 * period : dt == 0) {
        ++rep.duplicate;
        continue;
      }
      if (period > 0 && dt > options.gap_factor * period) {
        ++rep.gaps;
        rep.gap_time_s += dt - period;
        segmentPeriod();
        closeSegment(out.t.size());
      }
    }
    out.t.push_back(ti);
    if (keep_values) {
      for (size_t a = 0; a < axes.size(); ++a) out.v[a].push_back((*axes[a])[i]);
    } else {
      out.kept.push_back(static_cast<uint32_t>(i));
    }
    prev = ti;
    have_prev = true;
  }
  segmentPeriod();
  closeSegment(out.t.size());
  std::vector<uint32_t>().swap(idx);
  // Nothing dropped (the usual case): the kept index is the identity and is not stored.
  if (!keep_values && out.kept.size() == t.size()) std::vector<uint32_t>().swap(out.kept);
  rep.kept = static_cast<int64_t>(out.t.size());
  rep.nominal_period_s = period;
  rep.rate_hz = period > 0 ? 1.0 / period : 0.0;
  for (double p : seg_periods) rep.max_rate_deviation = std::max(rep.max_rate_deviation, std::fabs(p / period - 1.0));
  // A rate change without a gap (e.g. 100 -> 125 Hz) stays inside one segment: compare the median interval of
  // consecutive blocks (20 per record, at least 16 intervals each) with the nominal period.
  {
    // The intervals of all segments in order, taken block by block (one block in memory at a time).
    size_t total = 0;
    for (const auto& seg : out.segments) total += seg.size() - 1;
    const size_t block = std::max<size_t>(16, total / 20);
    std::vector<double> chunk;
    chunk.reserve(block);
    for (const auto& seg : out.segments)
      for (size_t i = seg.begin + 1; i < seg.end; ++i) {
        chunk.push_back(out.t[i] - out.t[i - 1]);
        if (chunk.size() == block) {
          rep.max_rate_deviation = std::max(rep.max_rate_deviation, std::fabs(median(chunk) / period - 1.0));
          chunk.clear();
        }
      }
  }
  rep.rate_changed = rep.max_rate_deviation > 0.05;
  if (!out.t.empty()) {
    rep.first_stamp = out.t.front();
    rep.last_stamp = out.t.back();
  }
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
