// Decides from the data alone whether an IMU record was at rest (so no noise coefficients are printed for a moved sensor).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace gyro_allan {

/// Thresholds of the rest detector. The defaults were set on the tuning seeds of rest_study and validated on disjoint
/// seeds and on real data: see docs/rest_detection.md.
///
/// Statistic, per channel (each gyro axis, each accelerometer axis) and per block of `block_s`:
///   loc_j   = clipped mean of the block (samples clipped to median +- clip_k * sigma_j): spikes cannot move it;
///   sigma_j = white-noise level of the block from its first differences, robust and quantization-aware (RMS of the
///             differences within 5 robust units, where the robust unit is max(1.4826 MAD, smallest non-zero |diff|));
///   z_j     = (loc_{j+1} - loc_j) / sqrt(sigma_j^2/n_j + sigma_{j+1}^2/n_{j+1})   (block change in noise units);
///   S_j     = 1.4826 MAD of the z of the last `window_blocks` block changes (1 when fewer than min_window_blocks):
///             about 1 for white noise, 1-3 for bias instability / rate random walk, large when the sensor moves.
/// A block is moving when
///   (a) |z| > block_z * max(1, S) for a change it takes part in, and that change exceeds the channel's floor; or
///   (b) S > record_ratio and S times the noise prediction exceeds the channel's floor (motion all along the window); or
///   (c) the gyro block means have a magnitude above max_rest_rate (a constant turn changes no block mean).
/// Each moving block also marks one neighbour on either side (within its segment).
struct RestOptions {
  double block_s = 1.0;           ///< statistic block length [s]; at least min_block_samples samples
  int min_block_samples = 16;     ///< shorter blocks are not formed (a segment tail this short joins the last block)
  double block_z = 11.0;          ///< (a): a block-to-block change beyond this many noise units marks motion
  double record_ratio = 6.0;      ///< (b): spread of block changes / white-noise prediction above which the window moves
  int window_blocks = 60;         ///< trailing window of block changes for S (same in batch and streaming)
  int min_window_blocks = 8;      ///< S is used from this many block changes on
  double max_rest_rate = 0.35;    ///< (c) [rad/s]: 20 deg/s, the largest zero-rate offset of common consumer MEMS
  double gyro_floor = 0.01;       ///< [rad/s] changes below this are never motion (0.57 deg/s)
  double accel_floor = 0.05;      ///< [m/s^2] changes below this are never motion
  double clip_k = 3.0;            ///< clipping of the block mean in units of sigma_j
  double min_static_s = 60.0;     ///< shortest static stretch worth analysing [s] (RestResult::static_usable)
};

/// Sample indices [begin, end) into the concatenated input (all segments one after the other).
struct RestInterval {
  int64_t begin = 0, end = 0;
};

struct RestResult {
  bool at_rest = true;                 ///< no motion anywhere
  std::vector<RestInterval> moving;    ///< moving stretches, in order
  RestInterval longest_static;         ///< longest stretch with no moving or undecided sample (may be empty)
  bool static_usable = false;          ///< longest_static is at least min_static_s long
  double moving_fraction = 0;          ///< moving samples / all samples
  double score = 0;                    ///< largest block change |z| / max(1, S) seen, in noise units (changes above
                                       ///< the channel's floor only: a channel whose changes stay below it scores 0)
  double spread = 0;                   ///< largest window spread S seen (white noise: ~1; floor as for score)
  std::string channel;                 ///< which channel decided (e.g. "gyro z", "accel x", "gyro |w|"); "" at rest
  std::string reason;                  ///< one line for humans
  int64_t blocks = 0, moving_blocks = 0;
};

/// gyro: 1..3 rate axes [rad/s]; accel: 0 or 3 axes [m/s^2] (an accelerometer whose samples are all exactly zero is
/// "not published" and ignored). Each axis is a list of gap-free segments, all axes with the same segment lengths;
/// blocks never straddle a segment boundary. tau0 = sample interval [s].
/// Throws std::invalid_argument on inconsistent input (no axis, null axis, mismatched segments, tau0 <= 0, non-finite
/// sample, bad options).
RestResult detectRest(const std::vector<const std::vector<std::vector<double>>*>& gyro,
                      const std::vector<const std::vector<std::vector<double>>*>& accel, double tau0,
                      const RestOptions& opts = {});

/// The same with the samples fetched one at a time (e.g. from compactly stored bag samples, without a copy of every
/// axis): `segment_sizes` gap-free segments; sample(c, k, i) returns channel c (0..n_gyro-1 the gyro axes, then the
/// three accelerometer axes when has_accel) of sample i of segment k. It is called from several threads at once
/// (the block statistics of different channels are computed in parallel), so it must not modify shared state; a
/// non-finite value throws std::invalid_argument. Decisions are those of the streaming RestMonitor on the same data.
RestResult detectRest(int n_gyro, bool has_accel, double tau0, const std::vector<size_t>& segment_sizes,
                      const std::function<double(int, size_t, size_t)>& sample, const RestOptions& opts = {});

/// Convenience for one gap-free segment per axis.
RestResult detectRestSingle(const std::vector<const std::vector<double>*>& gyro,
                            const std::vector<const std::vector<double>*>& accel, double tau0,
                            const RestOptions& opts = {});

/// One block decision of the streaming form.
struct RestBlock {
  RestInterval samples;  ///< [begin, end) counted from the first add() (a short segment tail joins its last block)
  bool moving = false;
  double score = 0;      ///< largest |z| / max(1, S) of the changes it takes part in
  std::string channel, reason;  ///< of the strongest trigger among it and its neighbours, when moving
};

namespace detail {
class RestEngine;
}

/// Streaming form for the nodelet: the SAME statistic, thresholds and block decisions as detectRest (detectRest runs
/// this very engine). Block j is decided once block j+2 of its segment is complete (or at newSegment()).
class RestMonitor {
 public:
  /// Throws std::invalid_argument on tau0 <= 0, n_gyro outside 1..3 or bad options.
  RestMonitor(double tau0, int n_gyro, bool has_accel, const RestOptions& opts = {});
  ~RestMonitor();
  RestMonitor(RestMonitor&&) noexcept;
  RestMonitor& operator=(RestMonitor&&) noexcept;

  /// Adds one sample (gyro[n_gyro], accel[3] or nullptr). Returns true when at least one block decision was made.
  /// Throws std::invalid_argument on a non-finite value (or accel == nullptr when has_accel).
  bool add(const double* gyro, const double* accel);
  /// A gap: pending blocks are decided now, the next block starts fresh. Returns true when a decision was made.
  bool newSegment();
  bool moving() const;              ///< latest decision
  double score() const;             ///< |z| / max(1, S) of the latest decided block (largest over its channels)
  std::string reason() const;       ///< why the latest decided block is moving ("" when it is not)
  int64_t blocks() const;           ///< blocks decided so far
  int64_t moving_blocks() const;
  /// Samples [begin, end) (counted from the first add()) of the latest decided block.
  RestInterval lastBlock() const;
  /// Every block decided by the latest add() or newSegment() call, oldest first (add: at most one).
  const std::vector<RestBlock>& decided() const;

 private:
  std::unique_ptr<detail::RestEngine> engine_;
};

}  // namespace gyro_allan
