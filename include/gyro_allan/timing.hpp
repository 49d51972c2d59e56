// Timestamp and sample sanitation: finds the regular sampler behind jittered stamps (StampGrid), drops NaN/Inf,
// out-of-order, duplicate, too-close and zero stamps, splits at real gaps (missing samples) into gap-free segments,
// and counts every problem so nothing is lost silently.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <string>
#include <vector>

#include "gyro_allan/compact_series.hpp"
#include "gyro_allan/warning.hpp"

namespace gyro_allan {

struct StampReport {
  int64_t input = 0;           ///< samples offered
  int64_t kept = 0;            ///< samples in segments
  int64_t non_finite = 0;      ///< dropped: a NaN/Inf value on any axis
  int64_t zero_stamp = 0;      ///< dropped: stamp == 0
  int64_t out_of_order = 0;    ///< dropped: stamp earlier than the previous kept one
  int64_t duplicate = 0;       ///< dropped: stamp equal to the previous kept one
  int64_t too_close = 0;       ///< dropped: arrived over half a period before its grid slot (more samples than slots)
  int64_t short_segment = 0;   ///< dropped: samples of gap-free runs shorter than min_segment (isolated by gaps)
  int64_t gaps = 0;            ///< splits: places where grid slots have no sample (missing samples)
  int64_t missing_samples = 0; ///< grid slots without a sample, summed over gaps
  double gap_time_s = 0;       ///< time missing in gaps, s (missing_samples x nominal period)
  double nominal_period_s = 0; ///< sampler period: median over blocks of (last - first stamp) / (count - 1)
  /// Stamp jitter: how late kept stamps are after their grid slot (the earliest arrivals define the slots), s.
  double jitter_p50_s = 0, jitter_p99_s = 0, jitter_max_s = 0;
  /// Stamps jitter by more than 10 % of a period at the 99th percentile: receipt-time stamps (driver stamps on
  /// arrival). The samples are placed on the regular grid, not at their stamps.
  bool receipt_stamps = false;
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
  std::vector<double> t;                    ///< kept stamps, s (non-decreasing: a buffered read repeats one)
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
  /// Keeps only the kept samples [begin, end) (indices into the kept arrays, i.e. the segments one after the other)
  /// in `segments`; the arrays themselves are unchanged. Returns the number of samples taken out of segments.
  int64_t restrictTo(size_t begin, size_t end);
  /// The same by stamp: the kept samples with first <= t <= last (needs `t`).
  int64_t restrictToTime(double first, double last);
  /// The problem counts (input, non_finite ... short_segment, gaps, missing_samples) of the input samples with index
  /// in [SanitizeOptions::count_from, count_to) only (a gap counts with the sample after it); equal to `report`'s
  /// by default.
  StampReport counted;
};

struct SanitizeOptions {
  /// A sample later than its grid slot by more than (gap_factor - 1) periods, with every sample of the following
  /// lookahead as late, follows missing samples: a gap (1.5: one missing sample is a gap).
  double gap_factor = 1.5;
  double nominal_rate_hz = 0;   ///< 0 = estimate from the stamps (estimatePeriod)
  size_t min_segment = 2;       ///< shorter segments are dropped (and counted in gaps)
  double lookahead_s = 2.0;     ///< StampGrid lookahead (at least 32 samples)
  /// SanitizedSeries::counted counts the problems of input samples from this index on (OnlineAnalyzer: the samples
  /// new since its previous window, so that each sample's problem is counted once over overlapping windows).
  size_t count_from = 0;
  size_t count_to = SIZE_MAX;   ///< ... up to this index, exclusive
};

/// Sampler period from stamps alone: the median over blocks of consecutive stamps of (last - first) / (count - 1).
/// Robust to arrival-time jitter and bursts (a block's end points carry the jitter once, divided by the block
/// length) and to a minority of blocks holding gaps. Blocks of 64 stamps (fewer for short series); only
/// non-decreasing stamps count (equal ones: a buffered read stamped once). 0 when fewer than 2 usable stamps.
double estimatePeriod(const std::vector<double>& t, size_t block = 64);

/// What StampGrid decided about one stamp.
enum class StampVerdict { Keep, Duplicate, TooClose, OutOfOrder };

struct StampDecision {
  StampVerdict verdict = StampVerdict::Keep;
  double stamp = 0;      ///< the stamp decided about, s
  uint64_t tag = 0;      ///< what the caller pushed with it (e.g. an input index)
  int64_t index = 0;     ///< grid index (Keep): consecutive kept samples differ by 1 + missing
  int64_t missing = 0;   ///< grid slots without a sample just before this one (Keep); > 0 is a gap
  double lag = 0;        ///< stamp - slot time, s (Keep; >= 0 up to the envelope's tolerance)
};

/// The regular sampler behind jittered stamps. Drivers that stamp on arrival (USB, serial, WiFi) give stamps that
/// lag the true sample times by a varying delay, with bursts; the samples themselves are evenly spaced. The grid
/// puts kept sample k at slot time psi + k * period, where the slots follow the earliest arrivals (the lower
/// envelope of the stamps: lowered by any kept stamp that arrives before its slot, raised to the earliest arrival
/// of the lookahead, so slow clock drift is followed). Rules, applied to the oldest pending stamp once the
/// lookahead's newer stamps are known — the same in analyze_bag and the nodelet:
/// - equal to the previous stamp and pushed as a new sample (`batched`: a driver that stamps every sample of one
///   buffered read with the read's time): placed on the grid like any late arrival;
/// - otherwise equal to the last kept stamp: Duplicate; earlier: OutOfOrder;
/// - more than half a period before its slot (more samples than slots): TooClose;
/// - otherwise Keep; if every stamp of the lookahead (taken in consecutive pairs, so one early stamp cannot hide
///   it) is later than its slot by more than (gap_factor - 1) periods, round(lag / period) slots were skipped:
///   `missing` samples, a gap.
/// Streaming with a delay of the lookahead; O(1) amortized per stamp.
class StampGrid {
 public:
  /// period > 0 s; gap_factor > 1; lookahead_s >= 0 (at least 32 stamps are always looked ahead).
  StampGrid(double period, double gap_factor = 1.5, double lookahead_s = 2.0);
  /// batched: the sample differs from the previous one although its stamp may equal the previous stamp (a
  /// buffered read); an equal stamp then takes a slot instead of being a duplicate.
  void push(double stamp, uint64_t tag = 0, bool batched = false);
  /// The oldest pending stamp's decision, once it can be made (enough newer stamps, or finish()); false if none.
  bool pop(StampDecision* d);
  /// No more input: every pending stamp can be decided. A push() after finish() starts a new timeline.
  void finish();
  size_t pending() const { return q_.size(); }
  double period() const { return period_; }
  size_t lookahead() const { return lookahead_; }

 private:
  struct Entry {
    double t;         // stamp relative to origin_
    uint64_t tag;
    int64_t pos;      // provisional position among candidates (-1: not later than the newest earlier stamp)
    double u;         // t - pos * period
    uint64_t seq;
  };
  void reset();
  double windowMin() const;
  double period_, gap_factor_;
  size_t lookahead_;
  std::deque<Entry> q_;
  // Sliding minimum over pending candidates of v_j = max(u_j, u_of_next_candidate): (seq, v), increasing v.
  std::deque<std::pair<uint64_t, double>> vmin_;
  uint64_t next_seq_ = 0;
  int64_t next_pos_ = 0;
  bool have_newest_ = false;
  double newest_ = 0;            // newest candidate stamp (relative)
  bool tail_open_ = false;       // the newest candidate's v waits for its successor
  uint64_t tail_seq_ = 0;
  double tail_u_ = 0;
  bool finished_ = false;
  bool have_origin_ = false, have_kept_ = false;
  double origin_ = 0;            // first stamp: relative stamps keep double precision
  double psi_ = 0;               // slot time of grid index `shift_` (u-space: lag = u - psi)
  int64_t shift_ = 0;            // grid index = pos + shift
  double last_kept_ = 0;
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
  std::vector<Warning> warnings(const std::string& what) const;
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
