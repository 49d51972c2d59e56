// The nodelet's ROS side that is not the node itself: parameters (typed, validated, unknown names warned), the
// conversion of OnlineAnalyzer results to messages, and the diagnostic statuses.
#pragma once

#include <array>
#include <map>
#include <string>
#include <vector>

#include <diagnostic_updater/DiagnosticStatusWrapper.h>
#include <gyro_allan/AllanCurve.h>
#include <gyro_allan/AnalyzerConfig.h>
#include <gyro_allan/NoiseModel.h>
#include <gyro_allan/NoiseReport.h>
#include <gyro_allan/QuickNoise.h>
#include <ros/ros.h>
#include <sensor_msgs/Image.h>

#include "gyro_allan/io/report.hpp"
#include "gyro_allan/online.hpp"

namespace gyro_allan {

/// Private parameters after validation (defaults = config/analyzer.yaml).
struct AnalyzerParams {
  OnlineOptions online;            ///< window_s, hop_s, min_fit_samples and the pipeline's options
  std::string input = "auto";      ///< imu | angle | auto (the first topic that delivers)
  std::string angle_mode = "accumulated";
  std::string tau_grid = "log:10";
  Method method = Method::Auto;
  double filter_rate = 0;          ///< ~noise_model / noise_model.yaml: Phi/Qd also at this rate [Hz]; 0 = data rate only
                                   ///< (> 0 turns the GMWM stage on: online.pipeline.analysis.gmwm)
  double spike_z = 10;             ///< 0 = keep spikes
  bool publish_curves = true, publish_plot = true;
  int plot_width = 800, plot_height = 600;
  std::string hardware_id;         ///< empty: the IMU messages' frame_id
  double diagnostic_period = 1.0;
  double recent_s = 10;            ///< diag/recent_s: a problem keeps WARN this long [s, ROS time]
  double rms_log10_warn = 0.1, rms_log10_error = 0.3;
  std::array<double, kNumTerms> spec_warn{{0, 0, 0, 0, 0}}, spec_error{{0, 0, 0, 0, 0}};
  std::string save_dir;            ///< ~save writes here (empty: $ROS_HOME/gyro_allan/<node name>)
  std::string kalibr_axis = "worst";
  int queue_size = 10000;
};

/// Reads and validates the private parameters. Each problem (unknown name, wrong type, invalid value: the default is
/// used) is one line in *problems, naming the parameter.
AnalyzerParams loadAnalyzerParams(const ros::NodeHandle& pnh, std::vector<std::string>* problems);

/// Applies a dynamic_reconfigure request to params (window, hop, method, stages, fit thresholds); a hop longer than the
/// window is set to the window (in c too). Returns the problem (empty when applied; else params are unchanged).
std::string applyConfig(AnalyzerConfig& c, AnalyzerParams* p);
/// The current params as a dynamic_reconfigure config.
AnalyzerConfig toConfig(const AnalyzerParams& p);

/// ~noise message of one analysed window.
NoiseReport toNoiseReport(const OnlineResult& r, const AnalyzerParams& p, const std::string& frame_id,
                          double mean_temperature);
/// ~noise_model message of one analysed window: the GMWM model of the gyro axes analysed with it (AnalysisOptions::gmwm),
/// copied from axisNoiseModel (io/noise_model_yaml.hpp), the source of noise_model.yaml too; sources as there.
NoiseModel toNoiseModel(const OnlineResult& r, const AnalyzerParams& p, const std::string& frame_id,
                        const std::vector<std::string>& sources);
/// The ~noise_model message that replaces the latched model when ~gmwm is turned off: status "off", no axes.
NoiseModel noiseModelOff(const ros::Time& stamp, const std::string& frame_id);
/// True when some gyro axis of the result carries a GMWM stage (then ~noise_model and ~save's noise_model.yaml).
bool hasNoiseModel(const PipelineResult& r);
/// ~allan/<axis> message of one axis (quick: from a quick answer).
AllanCurve toCurve(const AxisAnalysis& a, const std_msgs::Header& header, bool quick = false);
/// ~quick message of a fitted quick answer; full_age_s: input time since the last full answer's window ended (-1: none).
QuickNoise toQuickNoise(const QuickAnswer& q, const std::string& frame_id, double full_age_s);
/// ~plot image of the axes' curves and models, title and a note line under it (throws when rendering is unavailable).
sensor_msgs::Image plotMessage(const std::vector<AxisAnalysis>& axes, const std_msgs::Header& header,
                               const std::string& title, const std::string& note, const AnalyzerParams& p);
/// Mean of a job's temperature readings (NaN when none).
double meanTemperature(const OnlineJob& job);
/// report.yaml's "method" for these params, as analyze_bag names its --method: "gmwm" for auto with the GMWM stage on
/// (~gmwm or ~filter_rate > 0; analyze_bag --method gmwm), else ~method (the GMWM stage does not change the answer).
std::string reportMethod(const AnalyzerParams& p);
/// The report's description of the live input (sources, topic, units, method: reportMethod) for ~save.
ReportMeta liveReportMeta(const AnalyzerParams& p, const std::string& topic);

/// State the diagnostics read (a copy taken under the nodelet's lock).
struct DiagState {
  OnlineCounters counters;
  size_t window_samples = 0;
  double window_span_s = 0;
  bool have_result = false;
  OnlineResult last;               ///< the last analysis (ok or not)
  bool have_good = false;
  NoiseReport last_report;         ///< the last published ~noise
  bool have_noise_model = false;
  NoiseModel last_noise_model;     ///< the last published ~noise_model
  std::string source;              ///< "imu", "angle" or "" while waiting
  uint64_t other_source = 0;       ///< messages of the other input topic ignored
  uint64_t accel_messages = 0;     ///< messages of the separate accelerometer topic ("accel")
  std::vector<std::string> param_problems;  ///< from loading and refused reconfigures
  int64_t newest_ns = 0;           ///< the input's newest stamp (OnlineAnalyzer::newestStamp)
  bool have_quick = false;
  QuickNoise last_quick;           ///< the last published ~quick
};

/// Per-class "recently" tracking of cumulative counters for WARN levels (ROS time).
class RecentProblems {
 public:
  /// Remembers when a counter last grew; returns true when it grew within recent_s of now.
  bool recent(const std::string& key, int64_t total, const ros::Time& now, double recent_s);

 private:
  std::map<std::string, std::pair<int64_t, ros::Time>> last_;
};

void diagStamps(const DiagState& s, const AnalyzerParams& p, RecentProblems* rp,
                diagnostic_updater::DiagnosticStatusWrapper& stat);
void diagValues(const DiagState& s, const AnalyzerParams& p, RecentProblems* rp,
                diagnostic_updater::DiagnosticStatusWrapper& stat);
void diagWindow(const DiagState& s, const AnalyzerParams& p, RecentProblems* rp,
                diagnostic_updater::DiagnosticStatusWrapper& stat);
void diagMotion(const DiagState& s, diagnostic_updater::DiagnosticStatusWrapper& stat);
void diagParams(const DiagState& s, diagnostic_updater::DiagnosticStatusWrapper& stat);
void diagFit(const DiagState& s, const AnalyzerParams& p, diagnostic_updater::DiagnosticStatusWrapper& stat);
void diagNoiseModel(const DiagState& s, const AnalyzerParams& p, diagnostic_updater::DiagnosticStatusWrapper& stat);
void diagQuality(const DiagState& s, diagnostic_updater::DiagnosticStatusWrapper& stat);
/// Which answer is which and how old each is (input time): the full analysis (~noise) and the quick answer (~quick).
void diagAnswers(const DiagState& s, const AnalyzerParams& p, diagnostic_updater::DiagnosticStatusWrapper& stat);
void diagTerm(int term, const DiagState& s, const AnalyzerParams& p, diagnostic_updater::DiagnosticStatusWrapper& stat);
extern const char* const kTermLabel[kNumTerms];

}  // namespace gyro_allan
