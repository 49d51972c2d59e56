// Sliding-window overlapping Allan variance: O(#tau) per sample incremental sums over a phase ring buffer, with gaps.
#pragma once

#include <cstdint>
#include <deque>
#include <vector>

#include "gyro_allan/allan.hpp"

namespace gyro_allan {

struct SlidingAllanOptions {
  double tau0 = 0;               ///< nominal sample interval [s], > 0
  int64_t window_samples = 0;    ///< window length in rate samples (the window holds window_samples + 1 phase points)
  TauGrid grid;                  ///< averaging factors: tauGridFactors(grid, window_samples / 2)
  double confidence = 0.683;     ///< two-sided confidence of dev_lo/dev_hi
  bool compute_edf = true;       ///< fill edf/dev_lo/dev_hi (deviationEdf via fillConfidence)
  int alpha = 0;                 ///< power-law exponent for the EDF when alpha_from_slope is false (0: white rate noise)
  bool alpha_from_slope = false;  ///< pick alpha per point from the least-squares log-log AVAR slope over +-1/2
                                  ///< decade (noisy at long tau: a spurious white-PM pick inflates the EDF)
  int recompute_steps = 2;       ///< exact-recompute cursor steps per sample (>= 2); one full recompute every
                                 ///< ~window/(steps-1) samples
};

/// Overlapping Allan variance ("oadev") of the last window_samples samples, updated per sample.
///
/// Phase (angle) points live in a ring buffer. For every averaging factor m of the grid the sum of squared second
/// differences x[i+2m] - 2x[i+m] + x[i] and their count are kept: the term completed by the newest point is added and
/// the term starting at the point leaving the window is subtracted, so a sample costs O(#m) whatever the window.
/// A second set of sums is rebuilt from the buffer by a cursor that advances recompute_steps points per sample; when it
/// reaches the newest point its exact sums replace the running ones, so rounding never accumulates over days.
/// Gaps: newSegment() starts a new gap-free segment; no difference spans two segments (pooled as in
/// computeDeviation(segments)). Results equal the batch oadev of the window's segments.
class SlidingAllan {
 public:
  /// Throws std::invalid_argument on tau0 <= 0 (or non-finite), window_samples < 2, recompute_steps < 2.
  explicit SlidingAllan(const SlidingAllanOptions& options);

  /// A rate sample [rad/s]; the phase advances by rate * tau0. Non-finite values throw std::invalid_argument.
  void addRate(double rate);
  /// An accumulated angle sample [rad] (phase point); a segment starts with its first angle.
  void addAngle(double angle);
  /// An angle increment [rad] over one sample interval (RLG/FOG pulse output): same as addRate(increment / tau0).
  void addIncrement(double increment);

  /// The next sample starts a new gap-free segment (call on a gap, rate glitch or dropped sample).
  void newSegment();
  /// Forgets everything (window empty).
  void reset();
  /// Rebuilds the sums from the buffer now, O(window * #m) (normally done incrementally; for tests).
  void recomputeNow();

  /// The deviation curve of the current window: one point per grid m with at least one term (tau = m * tau0).
  DeviationCurve curve() const;
  /// Rate samples [rad/s] of the newest gap-free segment inside the window, rebuilt from phase differences (for
  /// addAngle: angle differences / tau0). O(segment length); for analyses that need raw samples (wavelet split,
  /// model check). Exact to ~1e-16 x |phase| / tau0. max_samples > 0 keeps only the newest max_samples.
  std::vector<double> newestSegmentRates(int64_t max_samples = 0) const;

  const SlidingAllanOptions& options() const { return opt_; }
  const std::vector<int64_t>& factors() const { return m_; }
  /// Rate samples (or increments) in the window, summed over segments: phase points minus segments.
  int64_t samples() const;
  /// Phase points in the window.
  int64_t phasePoints() const { return head_ - start_; }
  /// Gap-free segments overlapping the window.
  int segments() const { return static_cast<int>(seg_.size()); }
  /// samples() / window_samples.
  double fill() const;
  /// Total samples added since construction/reset (including those that left the window).
  int64_t totalSamples() const { return total_; }
  /// Completed incremental exact recomputes.
  int64_t recomputes() const { return recomputes_; }
  /// Heap memory held (ring buffer and sums), bytes.
  size_t memoryBytes() const;

 private:
  void pushPhase(double x);
  void removeOldest();
  void advanceCursor();
  double term(int64_t i, int64_t m) const {
    const double a = buf_[i & mask_], b = buf_[(i + m) & mask_], c = buf_[(i + 2 * m) & mask_];
    const double d = c - 2.0 * b + a;
    return d * d;
  }
  int64_t segmentEnd(int64_t i) const;  ///< first index after the segment holding i (INT64_MAX for the last one)

  SlidingAllanOptions opt_;
  std::vector<int64_t> m_;
  std::vector<double> buf_;
  int64_t mask_ = 0;
  int64_t cap_ = 0;        ///< window in phase points (window_samples + 1)
  int64_t head_ = 0;       ///< absolute index of the next phase point
  int64_t start_ = 0;      ///< absolute index of the oldest phase point in the window
  std::deque<int64_t> seg_;  ///< absolute start index of each segment overlapping the window (front may be < start_)
  bool new_segment_ = true;
  bool angle_input_ = false;  ///< the newest segment came from addAngle
  // Running phase of the current segment, relative to its first sample's rate (keeps |x| small).
  long double phase_ = 0;
  double rate_ref_ = 0;
  double angle_ref_ = 0;
  // Running sums (S, count) and the exact rebuild (F, count) per m.
  std::vector<long double> sum_, fresh_;
  std::vector<int64_t> count_, fresh_count_;
  int64_t cursor_ = 0;
  int64_t total_ = 0;
  int64_t recomputes_ = 0;
};

}  // namespace gyro_allan
