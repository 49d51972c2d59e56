// OnlineAnalyzer: the ROS-free online analysis — a sliding window of raw samples (and temperature) analysed every hop
// (in input-stamp time) by the same pipeline as analyze_bag (pipeline.hpp), with cumulative problem counters.
#pragma once

#include <array>
#include <cstdint>
#include <deque>
#include <string>
#include <utility>
#include <vector>

#include "gyro_allan/pipeline.hpp"
#include "gyro_allan/quick_view.hpp"

namespace gyro_allan {

struct OnlineOptions {
  /// The analysis of each window: analyze_bag's pipeline and its options (input kind, method, stages, sanitation,
  /// at-rest check, threads). pipeline.accel: the accelerometer samples given to addSample are analysed (and used by
  /// the at-rest check) as analyze_bag does; false: they are not stored.
  PipelineOptions pipeline;
  double window_s = 3600;     ///< window length in input-stamp time [s] (> 0)
  double hop_s = 300;         ///< analysis period in input-stamp time [s] (0 < hop_s <= window_s)
  int64_t min_samples = 1000; ///< samples in the window before the first analysis (>= 3)
  /// Quick answer period in input-stamp time [s] (0: no quick answers): between full analyses the window's oadev is
  /// kept up to date per sample (QuickView) and fitted every update_s, the first once the window holds min_samples.
  double update_s = 5;
  /// Throws std::invalid_argument naming the first bad value.
  void validate() const;
};

/// Problems of the raw samples, each sample counted once however many windows it belongs to (the window's own
/// sanitation counts only the samples new since the previous job: SanitizeOptions::count_from), and what the
/// analyzer did. Updated by account(), i.e. once per analysed window: they lag the input by up to a hop plus the
/// stamp grid's lookahead (max(lookahead_s, 64 periods)).
struct OnlineCounters {
  int64_t samples = 0;          ///< samples given to addSample
  int64_t temperatures = 0;     ///< temperature readings given to addTemperature
  int64_t non_finite = 0, zero_stamp = 0, out_of_order = 0, duplicate = 0, too_close = 0, short_segment = 0;
  int64_t gaps = 0, missing_samples = 0;
  int64_t analyses = 0;         ///< analyses run
  int64_t failed = 0;           ///< of which not analysable (OnlineResult::error says why)
  int64_t skipped_hops = 0;     ///< hops skipped because the previous analysis was still running (skipHop)
  int64_t aged_out = 0;         ///< samples that left the window before any analysis counted their problems
};

/// One window ready for analysis: a copy of the window in the pipeline's input form. Independent of the analyzer
/// (run() may run on another thread while samples keep arriving).
struct OnlineJob {
  int64_t sequence = 0;                  ///< 1, 2, ... per analyzer (reset restarts)
  int64_t first_ns = 0, last_ns = 0;     ///< stamps of the window's first and last samples [ns, as given]
  int64_t origin_ns = 0;                 ///< stamps in `input` are relative to this (first non-zero stamp - 1 s)
  PipelineInput input;
  /// options.sanitize.count_from/count_to: the samples whose problems this job counts (new since the previous job,
  /// but not the newest max(lookahead_s, 64 periods), which the stamp grid decides with less information)
  PipelineOptions options;
};

struct OnlineResult {
  int64_t sequence = 0;
  int64_t first_ns = 0, last_ns = 0;     ///< the window analysed [ns]
  bool ok = false;                       ///< false: not analysable, `error` says why
  std::string error;
  bool not_at_rest = false;              ///< not analysable because the sensor moved (NotAtRest)
  PipelineResult result;                 ///< when ok
  StampReport new_samples;               ///< sanitation counts of the samples new since the previous job
};

class OnlineAnalyzer {
 public:
  explicit OnlineAnalyzer(const OnlineOptions& options = {});
  /// One sample: stamp [ns since the epoch; 0 = zero stamp, dropped by the sanitation as offline], gyro (rate rad/s or
  /// angle rad, as options.pipeline.analysis.input says) and linear acceleration [m/s^2] (zeros: not published).
  /// Samples older than window_s behind the newest stamps leave the window.
  void addSample(int64_t stamp_ns, const std::array<double, 3>& gyro, const std::array<double, 3>& accel = {{0, 0, 0}});
  /// One sample of a separate accelerometer stream (a split gyro/accel pair, e.g. RealSense's accel/sample topic) at
  /// its own stamps [ns] and rate [m/s^2]. Once one has arrived, the accelerometer is taken from this stream only
  /// (addSample's accel is ignored) and the at-rest check reads the gyro alone.
  void addAccel(int64_t stamp_ns, const std::array<double, 3>& accel);
  /// One temperature reading [degC] at stamp_ns; interpolated onto the samples' stamps for the model check.
  void addTemperature(int64_t stamp_ns, double celsius);
  /// A hop is due: the newest stamps are hop_s past the previous hop and the window holds min_samples.
  bool hopDue() const;
  /// The due hop is not analysed (e.g. the previous analysis still runs): counted, and the next hop is hop_s later.
  /// The samples stay in the window and are counted by the next job.
  void skipHop();
  /// The current window as a job (also when no hop is due); the next hop is hop_s after the newest stamps.
  /// Throws std::logic_error when the window is empty.
  OnlineJob takeJob();
  /// Analyses a job (thread-safe: touches no analyzer state).
  static OnlineResult run(OnlineJob&& job);
  /// Adds a result's counts to counters() (call once per result, in any order).
  void account(const OnlineResult& result);
  /// A quick answer is due: update_s past the previous one (the first: as soon as the quick view is ready).
  bool quickDue() const;
  /// The quick view's curves now (no fits yet: fitQuick does them, off any lock); the next is due update_s later.
  /// window_first_ns is the window's oldest stamp. Throws std::logic_error when the quick view is not ready.
  QuickAnswer takeQuick();
  /// Fits each axis of a quick answer as the full analysis fits its joint fit (thread-safe).
  static void fitQuick(QuickAnswer* q, const PipelineOptions& options);
  /// takeJob + run + account.
  OnlineResult analyzeNow();
  /// Empties the window and temperature, restarts the hop clock and the job sequence; counters are kept unless
  /// `counters` is true.
  void reset(bool counters = false);
  /// New options (window, hop, analysis); the window keeps its samples (trimmed to the new length). Validated.
  void setOptions(const OnlineOptions& options);
  const OnlineOptions& options() const { return options_; }
  const OnlineCounters& counters() const { return counters_; }
  size_t windowSize() const { return window_.size(); }
  /// The input's newest stamp as the window and clocks see it (median of the last three non-zero stamps) [ns], 0 before.
  int64_t newestStamp() const { return now_ns(); }
  /// Span of the window's stamps [s] (newest reference minus oldest), 0 when empty.
  double windowSpan() const;

 private:
  struct Raw {
    int64_t ns;
    std::array<double, 3> g, a;
  };
  void trim();
  int64_t now_ns() const;
  QuickViewOptions quickOptions() const;
  /// The quick view started again (period tau0, or estimated when 0) and fed the window's samples.
  void rebuildQuick(double tau0);
  OnlineOptions options_;
  OnlineCounters counters_;
  std::deque<Raw> window_;
  std::deque<std::pair<int64_t, double>> temperature_;
  std::deque<std::pair<int64_t, std::array<double, 3>>> accel_;  ///< the separate accelerometer stream
  std::array<int64_t, 3> recent_{{0, 0, 0}};  ///< last three non-zero stamps (their median is "now")
  int recent_n_ = 0, recent_pos_ = 0;
  size_t uncounted_ = 0;                       ///< samples at the end of the window not yet in a job
  bool have_hop_ = false;
  int64_t next_hop_ns_ = 0;
  int64_t sequence_ = 0;
  double last_tau0_ = 0;                       ///< period of the last analysed window (0 before)
  QuickView quick_;
  int64_t next_quick_ns_ = 0;                  ///< input time of the next quick answer (0: as soon as ready)
};

}  // namespace gyro_allan
