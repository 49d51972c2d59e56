// Isolated spikes in gyro rate records (single samples or runs of a few far from their neighbours): detection,
// counting and replacement by the local median, in a batch form (one gap-free segment) and a streaming form (the
// nodelet) that share one decision rule, so offline and online results agree. Rule and validation: docs/spikes.md.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace gyro_allan {

/// The rule (docs/spikes.md). d_i = x_i - median of the +-half_window neighbours of sample i (itself excluded, the
/// window cut at the segment ends) — the local-median rule of detectOutliers (spectral.hpp). Robust sigma s =
/// max(MAD of d / 0.6745, 95th percentile of |d| / 1.960) over 2^15-2^16 evenly spaced samples (all when fewer), or the
/// smallest nonzero |d| of those when both are 0 (a quantized output). A candidate is a sample with |d_i| > z s.
/// A maximal run of consecutive candidates is a spike run when
///   - it is at most max_run samples long (longer runs are steps, saturation or motion, not spikes),
///   - none of its samples is in a run of >= saturation_run identical values (saturation: detectValueAnomalies warns),
///   - every sample of it is more than z s away both from the median of the half_window samples before the run and
///     from the median of the half_window samples after it (a bias step's edge samples are close to one side).
/// Every sample k of a spike run is replaced by the median of those 2 half_window neighbours (the run excluded: the
/// local level) plus, with restore_noise, a deterministic pseudo-random Gaussian draw (seeded by k's index in the
/// segment) of the local noise sigma (MAD of those neighbours about their median / 0.6745): the median alone has
/// almost no noise and would bias the Allan variance at short tau low by ~0.9 x the spike fraction (docs/spikes.md).
/// The grid stays regular; the angle keeps the local level. Both level and noise are local, so batch and streaming
/// replace a spike they both find with the same value.
struct SpikeOptions {
  double z = 10.0;           ///< threshold, robust sigmas (> 0)
  int half_window = 8;       ///< neighbours on each side (1..1000)
  int max_run = 3;           ///< longest run of consecutive samples that is still a spike (1..half_window)
  int saturation_run = 5;    ///< runs of >= this many identical values are saturation, never spikes (>= 2)
  double sigma = 0;          ///< > 0: use this robust sigma (input units) instead of estimating it
  int64_t warmup = 4096;     ///< SpikeFilter without `sigma`: samples buffered to estimate sigma before any output
  int max_listed = 10;       ///< indices of the first spike samples kept in SpikeReport::first_indices (0..10000)
  bool restore_noise = true; ///< add the noise draw to the local median (false: the median alone)
};

/// Throws std::invalid_argument naming the field when an option is out of range.
void validateSpikeOptions(const SpikeOptions& o);

/// What was found on one segment, or summed over several (merge()).
struct SpikeReport {
  int64_t samples = 0;              ///< samples examined
  int segments = 0;                 ///< gap-free segments examined
  int64_t count = 0;                ///< spike samples (replaced when removed)
  int64_t runs = 0;                 ///< spike runs (an isolated spike is a run of 1)
  int64_t rejected = 0;             ///< samples beyond the threshold that are not spikes (long runs, saturation, steps)
  double z = 0;                     ///< threshold in robust sigmas
  double robust_sigma = 0;          ///< input units (rad/s); of the longest segment when merged
  int64_t longest_segment = 0;      ///< samples of that segment
  double threshold = 0;             ///< z * robust_sigma
  double largest_excursion = 0;     ///< signed spike value minus its local level (run median), largest magnitude
  double excess_kurtosis_before = 0;  ///< of the samples about their segment's mean, spikes included
  double excess_kurtosis_after = 0;   ///< the same after replacement (== before when nothing was replaced)
  double std_before = 0, std_after = 0;  ///< standard deviation about the segment means, before / after
  bool removed = false;             ///< the spikes were replaced in the samples
  std::vector<int64_t> first_indices;  ///< first spike samples (index into the concatenated segments), ascending
  /// Adds another segment's report; its indices are shifted by index_offset (the samples before that segment).
  void merge(const SpikeReport& other, int64_t index_offset, int max_listed = 10);
};

/// One spike run: samples [begin, begin + length) of the segment; sample k is replaced by spikeReplacement(run, k).
struct SpikeRun {
  int64_t begin = 0;
  int length = 0;
  double level = 0;        ///< median of the run's neighbours
  double noise_sigma = 0;  ///< sigma of the noise draw added to it (0: none)
};
/// level + noise_sigma * g(k), g a Gaussian draw fixed by the index k (the same in batch and streaming).
double spikeReplacement(const SpikeRun& run, int64_t k);

/// Detection only: `x` is one gap-free segment of rate samples and is not changed; `runs` (optional) receives the
/// spike runs in order. Throws std::invalid_argument on non-finite samples or bad options. A segment shorter than
/// 2 half_window + 2 samples, or with robust sigma 0, is examined for nothing (count 0).
SpikeReport detectSpikes(const std::vector<double>& x, const SpikeOptions& o, std::vector<SpikeRun>* runs = nullptr);

/// Replaces the samples of `runs` (from detectSpikes on the same x) and fills the report's `removed`,
/// `std_after` and `excess_kurtosis_after`.
void applySpikeRuns(const std::vector<SpikeRun>& runs, std::vector<double>* x, SpikeReport* report);

/// detectSpikes + applySpikeRuns: the spikes of one gap-free segment replaced in place.
SpikeReport removeSpikes(std::vector<double>* x, const SpikeOptions& o);

/// The same rule sample by sample. Output is delayed by delay() = max_run + max(half_window, saturation_run)
/// samples (plus the warm-up of `warmup` samples when sigma is estimated). With a fixed SpikeOptions::sigma the
/// output equals removeSpikes on the same segment exactly. Estimating sigma, the filter first buffers `warmup`
/// samples (the estimate from them), then refreshes it from 2^15-2^16 evenly spaced samples of everything seen
/// (the batch estimator on the record so far); a segment no longer than `warmup` gives exactly the batch output.
/// Not thread-safe; one filter per axis.
class SpikeFilter {
 public:
  explicit SpikeFilter(const SpikeOptions& o = {});  ///< throws std::invalid_argument on bad options
  /// Adds one sample (must be finite: throws std::invalid_argument otherwise) and appends to *out every sample that
  /// is now decided, oldest first, spikes replaced: one per push in steady state, none during the warm-up, the
  /// warm-up's backlog at its end. Returns the number appended.
  size_t push(double x, std::vector<double>* out);
  /// End of the gap-free segment (a gap, or the end of the record): decides the remaining samples as the batch does
  /// at a segment end and appends them to *out; the next push starts a new segment (sigma is kept when fixed, else
  /// estimated afresh).
  void flush(std::vector<double>* out);
  int delay() const;
  /// Totals over all segments so far (kurtosis from running moments of input and output; indices count every
  /// sample pushed).
  SpikeReport report() const;
  /// Spike samples found so far (report().count without building the report: cheap per sample).
  int64_t count() const { return total_.count + seg_.count; }
  double sigma() const { return scale_; }  ///< current robust sigma (0 before the first estimate)

 private:
  void estimateScale(bool ended);
  void computeCandidates(bool ended);
  bool emitOne(bool ended, double* out);
  void compact();
  /// The current segment's report, closed (sizes, threshold, moments) as at its end.
  SpikeReport closedSegment() const;
  SpikeOptions o_;
  std::vector<double> buf_;      // samples of the current segment from absolute index base_
  std::vector<char> cand_;       // candidate flags, same indexing (computed up to cand_hi_)
  int64_t base_ = 0;             // absolute index (within the segment) of buf_[0]
  int64_t n_ = 0;                // samples of the current segment pushed
  int64_t cand_hi_ = 0;          // candidates known for [.., cand_hi_)
  int64_t next_out_ = 0;         // next sample to emit
  int64_t run_begin_ = -1, run_end_ = -1;  // cached decision of the run containing next_out_
  bool run_spike_ = false;
  double run_value_ = 0, run_noise_ = 0;
  double scale_ = 0;
  bool scale_known_ = false;
  std::vector<double> reservoir_;  // |d| of samples 0, step_, 2 step_, ...
  int64_t step_ = 1, reservoir_next_ = 0, added_since_ = 0;
  int64_t offset_ = 0;           // samples of earlier segments
  SpikeReport total_, seg_;
  long double in_s1_ = 0, in_s2_ = 0, in_s3_ = 0, in_s4_ = 0, out_s1_ = 0, out_s2_ = 0, out_s3_ = 0, out_s4_ = 0;
  double shift_ = 0;             // first sample of the segment (moments about it)
  int64_t out_n_ = 0;
  std::vector<double> scratch_;
};

}  // namespace gyro_allan
