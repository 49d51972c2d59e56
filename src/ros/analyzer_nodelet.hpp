// Online gyro noise analyzer nodelet: sliding-window overlapping Allan variance, per-hop IEEE 952 fit, diagnostics.
#pragma once

#include <array>
#include <atomic>
#include <condition_variable>
#include <deque>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <diagnostic_updater/diagnostic_updater.h>
#include <diagnostic_updater/update_functions.h>
#include <geometry_msgs/Vector3Stamped.h>
#include <nodelet/nodelet.h>
#include <ros/ros.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/Temperature.h>

#include "gyro_allan/allan.hpp"
#include "gyro_allan/noise_model.hpp"
#include "gyro_allan/quality.hpp"
#include "gyro_allan/rest.hpp"
#include "gyro_allan/sliding_allan.hpp"
#include "gyro_allan/spikes.hpp"
#include "gyro_allan/timing.hpp"

namespace gyro_allan {

/// Private parameters after validation (defaults here are the documented defaults).
struct AnalyzerParams {
  double window_s = 3600;          ///< window length [s]
  double hop_s = 10;               ///< publish period, in input-stamp time [s]
  std::string tau_grid = "log:10";
  TauGrid grid;
  std::string method = "joint_fit";
  std::string input = "auto";      ///< imu | angle | auto (first topic that delivers)
  std::string angle_mode = "accumulated";  ///< accumulated | increment
  double expected_rate_hz = 0;     ///< 0: learn from the first learn_samples stamps (estimatePeriod)
  int learn_samples = 200;
  double gap_factor = 1.5;         ///< StampGrid: samples missing (late by > gap_factor - 1 periods) start a segment
  double lookahead_s = 2.0;        ///< StampGrid lookahead: samples are analysed this much later than they arrive
  double rate_tolerance = 0.1;     ///< relative deviation of the stamp-vs-grid slope that counts as a rate change
  double saturation_limit = 0;     ///< |value| >= limit is saturated (0: only the repeated-extreme rule)
  int saturation_run = 5;          ///< identical extreme values in a row that count as saturated (0: off)
  int64_t min_fit_samples = 1000;  ///< samples in the window before the first fit
  double confidence = 0.683;
  int recompute_steps = 2;
  bool publish_curves = true;
  bool publish_plot = true;        ///< ~plot: sensor_msgs/Image of the live log-log plot (only while subscribed)
  int plot_width = 800, plot_height = 600;
  bool model_check = false;        ///< run checkModel on the raw samples every hop (fills AxisNoiseFit.effects)
  double raw_max_s = 600;          ///< raw-sample analyses (wavelet split, model check) use at most this much [s]
  double recent_s = 10;            ///< diagnostics: a problem is "recent" for this long (ROS time) [s]
  double error_fraction = 0.01;    ///< diagnostics: recent bad samples / expected samples above which ERROR
  double rms_log10_warn = 0.1, rms_log10_error = 0.3;
  std::array<double, kNumTerms> spec_warn{{0, 0, 0, 0, 0}}, spec_error{{0, 0, 0, 0, 0}};
  double diagnostic_period = 1.0;
  bool rest_check = true;          ///< ~rest_check: the at-rest detector (rest.hpp) on imu input
  RestOptions rest;
  SpikeOptions spikes;             ///< ~spike_z: spike threshold in robust sigmas (imu rates; same rule as analyze_bag)
};

class AnalyzerNodelet : public nodelet::Nodelet {
 public:
  AnalyzerNodelet();
  ~AnalyzerNodelet() override;

 private:
  enum class Source { None, Imu, Angle };
  /// One event counter with the ROS times of recent events.
  struct EventLog {
    uint64_t total = 0;
    std::deque<ros::Time> times;
    void add(const ros::Time& now);
    size_t recent(const ros::Time& now, double recent_s);
  };
  /// What a hop hands to the worker thread.
  struct Snapshot {
    std::array<DeviationCurve, 3> curves;
    ros::Time window_start, window_end;
    std::string frame_id;
    int64_t samples = 0;
    int segments = 0;
    double rate_hz = 0, fill = 0, temperature = 0;
    std::array<std::vector<double>, 3> raw;  ///< newest segment's rates, for wavelet_split / model_check
  };
  struct FitSummary {
    bool have = false;
    std::array<FitResult, 3> fits;
    std::array<QualityVerdict, 3> quality;  ///< assessQuality of each axis's answer (quality.hpp)
    ros::Time stamp;
  };

  void onInit() override;
  void loadParams();
  void initAccumulators(double tau0);
  void imuCallback(const sensor_msgs::Imu::ConstPtr& msg);
  void angleCallback(const geometry_msgs::Vector3Stamped::ConstPtr& msg);
  void temperatureCallback(const sensor_msgs::Temperature::ConstPtr& msg);
  void processSample(Source source, const ros::Time& stamp, const std::array<double, 3>& v,
                     const std::string& frame_id, const std::array<double, 3>* accel = nullptr);
  bool isSaturated(const std::array<double, 3>& v);
  /// One sample waiting in the StampGrid's lookahead.
  struct PendingSample {
    ros::Time stamp;
    std::array<double, 3> v;
    std::array<double, 3> a;       ///< linear acceleration (zeros for angle input)
    bool dropped_before = false;  ///< a sample was dropped (NaN, saturated) just before this one
  };
  void drainGrid();
  void onDecision(const StampDecision& d);
  /// One sample waiting for its rest-detector block to be decided.
  struct RestQueued {
    int64_t m;          ///< index among the samples given to the detector
    ros::Time stamp;
    std::array<double, 3> v;
    bool gap;
  };
  /// Feeds the rest detector and passes decided static samples on (forward); moving ones are dropped.
  void restStage(const PendingSample& smp, bool gap);
  void takeRestDecisions();
  void releaseRest(bool all);
  /// Spike filter (imu rates) and window for one kept sample; gap: it starts a segment.
  void forward(const ros::Time& stamp, const std::array<double, 3>& v, bool gap);
  void flushSpikes();
  void emitSpikeOutput();
  /// Adds one sample to the window (after the grid and the spike filter).
  void analyse(const ros::Time& stamp, const std::array<double, 3>& v);
  bool checkRate(const ros::Time& stamp, int64_t index);
  void maybeHop(const ros::Time& stamp);
  void workerLoop();
  void publishResults(const Snapshot& snap);
  void publishPlot(const std::array<DeviationCurve, 3>& curves, const std::array<FitResult, 3>& fits,
                   const std_msgs::Header& header, const Snapshot& snap);
  FitResult fitWithNoiseId(DeviationCurve* curve) const;
  void diagTimer(const ros::TimerEvent&);
  void diagStamps(diagnostic_updater::DiagnosticStatusWrapper& stat);
  void diagValues(diagnostic_updater::DiagnosticStatusWrapper& stat);
  void diagMotion(diagnostic_updater::DiagnosticStatusWrapper& stat);
  void diagWindow(diagnostic_updater::DiagnosticStatusWrapper& stat);
  void diagFit(diagnostic_updater::DiagnosticStatusWrapper& stat);
  void diagQuality(diagnostic_updater::DiagnosticStatusWrapper& stat);
  void diagTerm(int term, diagnostic_updater::DiagnosticStatusWrapper& stat);

  AnalyzerParams p_;
  ros::Subscriber imu_sub_, angle_sub_, temp_sub_;
  ros::Publisher noise_pub_, plot_pub_;
  std::array<ros::Publisher, 3> curve_pub_;
  ros::Timer diag_timer_;
  std::unique_ptr<diagnostic_updater::Updater> updater_;
  std::unique_ptr<diagnostic_updater::FrequencyStatus> freq_status_;
  double freq_min_ = 0, freq_max_ = 1e9;

  // ---- input state (guarded by mutex_) ----
  std::mutex mutex_;
  Source source_ = Source::None;
  double tau0_ = 0;                          ///< nominal interval, 0 while learning
  std::vector<double> learn_t_;              ///< stamps while learning the rate
  std::unique_ptr<StampGrid> grid_;          ///< the sampler's grid behind the stamps (same rule as analyze_bag)
  std::deque<PendingSample> grid_values_;    ///< samples in the grid's lookahead, in push order
  bool new_timeline_ = true;                 ///< the next kept sample starts a segment
  bool segment_pending_ = true;              ///< the next analysed sample starts a segment
  std::array<std::unique_ptr<SpikeFilter>, 3> spike_;  ///< per axis (imu rates), reset with the window
  std::array<std::vector<double>, 3> spike_out_;      ///< decided samples not yet analysed
  std::deque<ros::Time> spike_stamps_;       ///< stamps of the samples inside the spike filters
  int64_t spikes_seen_ = 0;
  std::unique_ptr<RestMonitor> rest_;        ///< at-rest detector, created with the first sample at a rate
  bool rest_has_accel_ = false;
  std::array<double, 3> last_accel_{{0, 0, 0}};
  std::deque<RestQueued> rest_queue_;        ///< samples waiting for their block's decision
  std::deque<RestBlock> rest_blocks_;        ///< decided blocks not yet passed by the queue
  int64_t rest_count_ = 0, decided_end_ = 0;
  bool rest_gap_pending_ = false;            ///< samples were dropped as moving: the next one starts a segment
  bool moving_ = false;                      ///< the latest decided block moves: nothing new is analysed
  int static_blocks_ = 0;                    ///< static blocks decided since the last moving one
  std::string rest_reason_;
  uint64_t motion_episodes_ = 0, moving_samples_ = 0;                  ///< spikes of the current filters already logged
  double reinit_period_ = 0;                 ///< > 0: a rate change was seen; restart at this period
  int64_t missing_total_ = 0;                ///< grid slots without a sample
  double lag_max_total_ = 0, lag_max_recent_ = 0;  ///< stamp lag behind the grid slot [s]
  std::array<std::unique_ptr<SlidingAllan>, 3> allan_;
  bool have_last_ = false;
  ros::Time last_stamp_;
  // Forward stamp glitch recovery: consecutive out-of-order samples, increasing among themselves.
  static constexpr int kGlitchRun = 16;
  int ooo_run_ = 0;
  ros::Time ooo_last_;
  size_t timeline_restarts_ = 0;
  bool dropped_since_last_ = false;          ///< a sample was dropped since the last accepted one
  std::deque<std::pair<double, int64_t>> recent_kept_;  ///< (stamp, grid index) of the last kept samples
  int64_t dt_since_check_ = 0;
  bool rate_mismatch_ = false;               ///< fixed expected rate but the median interval disagrees
  double measured_rate_hz_ = 0;
  std::array<double, 3> last_value_{{0, 0, 0}}, max_abs_{{0, 0, 0}};
  std::array<int, 3> run_{{0, 0, 0}};
  std::deque<std::pair<ros::Time, int64_t>> seg_stamps_;  ///< (first stamp, phase points) per segment
  ros::Time last_hop_;
  bool have_hop_ = false;
  std::string frame_id_;
  double temp_sum_ = 0;
  int64_t temp_count_ = 0;
  uint64_t accepted_ = 0;
  ros::Time last_accept_wall_;
  EventLog spikes_;
  EventLog out_of_order_, duplicate_, too_close_, zero_stamp_, gap_, rate_change_, nonfinite_, saturated_, other_source_,
      skipped_fits_;

  // ---- worker (guarded by work_mutex_) ----
  std::mutex work_mutex_;
  std::condition_variable work_cv_;
  std::unique_ptr<Snapshot> pending_;
  bool stop_ = false;
  std::thread worker_;
  FitSummary last_fit_;
  uint64_t fits_done_ = 0;
};

}  // namespace gyro_allan
