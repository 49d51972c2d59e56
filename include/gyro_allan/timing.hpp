// Timestamp and sample sanitation: drops NaN/Inf, out-of-order, duplicate and zero stamps, splits at gaps into
// gap-free segments, and counts every problem so nothing is lost silently.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "gyro_allan/compact_series.hpp"

namespace gyro_allan {

struct StampReport {
  int64_t input = 0;           ///< samples offered
  int64_t kept = 0;            ///< samples in segments
  int64_t non_finite = 0;      ///< dropped: a NaN/Inf value on any axis
  int64_t zero_stamp = 0;      ///< dropped: stamp == 0
  int64_t out_of_order = 0;    ///< dropped: stamp earlier than the previous kept one
  int64_t duplicate = 0;       ///< dropped: stamp equal to (or closer than half a period to) the previous kept one
  int64_t short_segment = 0;   ///< dropped: samples of gap-free runs shorter than min_segment (isolated by gaps)
  int64_t gaps = 0;            ///< splits: interval > gap_factor nominal periods
  double gap_time_s = 0;       ///< time missing in gaps, s
  double nominal_period_s = 0; ///< median interval between consecutive kept stamps
  double rate_hz = 0;          ///< 1 / nominal_period_s
  double max_rate_deviation = 0;  ///< largest relative difference of a segment's median interval from the nominal
  bool rate_changed = false;   ///< some segment's median interval differs from the nominal by more than 5 %
  double first_stamp = 0, last_stamp = 0;
  /// One line per problem class that occurred, for humans ("3 out-of-order stamps dropped", ...).
  std::vector<std::string> warnings() const;
};

/// A gap-free run: indices [begin, end) into the kept arrays.
struct Segment {
  size_t begin = 0, end = 0;
  size_t size() const { return end - begin; }
};

struct SanitizedSeries {
  std::vector<double> t;                    ///< kept stamps, s
  std::array<std::vector<double>, 3> v;     ///< kept values per axis (unused axes stay empty)
  std::vector<Segment> segments;            ///< gap-free runs over the kept arrays
  StampReport report;
  /// Values of one axis split into segments (for computeDeviation over segments).
  std::vector<std::vector<double>> segmentValues(int axis) const;
  /// The same, moving the values out (v[axis] is empty afterwards): no second copy of a long record.
  std::vector<std::vector<double>> takeSegmentValues(int axis);
  /// sanitizeCompact: input index of each kept sample (empty when every sample was kept: the identity), and the
  /// kept values of `axis` (an input axis) by segment.
  std::vector<uint32_t> kept;
  std::vector<std::vector<double>> segmentValuesOf(const CompactSeries& axis) const;
  /// A side series (e.g. temperature at 1 Hz: stamps ts, values vs, same time origin) linearly interpolated onto the
  /// kept stamps, split like the segments; held constant beyond its ends. Empty when it has no finite point.
  std::vector<std::vector<double>> interpolateSegments(const std::vector<double>& ts, const std::vector<double>& vs) const;
};

struct SanitizeOptions {
  double gap_factor = 1.5;      ///< an interval longer than this many nominal periods is a gap
  double nominal_rate_hz = 0;   ///< 0 = estimate from the median interval
  size_t min_segment = 2;       ///< shorter segments are dropped (and counted in gaps)
};

/// Impulsive shocks and saturation on one rate axis. Robust centre and spread (median and MAD of 2^18-2^19
/// evenly spaced samples); a sample farther than max(10 robust sigma, min_rate) from the median is extreme; a run of
/// >= 5 identical extreme values is saturation, other extreme samples are spikes (shocks). Samples are not removed:
/// these are warnings for the user.
struct ValueAnomalies {
  int64_t spikes = 0;             ///< extreme samples outside saturation runs
  int64_t saturation_runs = 0;    ///< runs of >= 5 identical extreme values
  int64_t saturated = 0;          ///< samples in those runs
  double threshold = 0;           ///< distance from the median that counts as extreme (input units)
  /// One line per anomaly class found, each prefixed with `what` (e.g. "axis x").
  std::vector<std::string> warnings(const std::string& what) const;
};
ValueAnomalies detectValueAnomalies(const std::vector<double>& v, double min_rate = 0.1);

/// Sanitizes a multi-axis series (axes = 1..3 vectors of the same length as t).
SanitizedSeries sanitize(const std::vector<double>& t, const std::vector<const std::vector<double>*>& axes,
                         const SanitizeOptions& options = {});
/// The same for compactly stored axes (the bag reader's), without copying values: `kept` holds the input index of
/// every kept sample and `v` stays empty; segmentValuesOf() gathers one axis as doubles when it is needed.
SanitizedSeries sanitizeCompact(const std::vector<double>& t, const std::vector<const CompactSeries*>& axes,
                                const SanitizeOptions& options = {});

}  // namespace gyro_allan
