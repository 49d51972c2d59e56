// gyro_allan/AnalyzerNodelet: IMU (or angle) and temperature messages into OnlineAnalyzer; every hop the window is
// analysed on a worker thread by the pipeline analyze_bag uses; ~noise (latched), ~noise_model (latched, with ~gmwm),
// ~allan/*, ~plot, services, dynamic_reconfigure and diagnostics out. No analysis here: see online.hpp and pipeline.hpp.
#include "analyzer_nodelet.hpp"

#include <sys/stat.h>

#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <thread>

#include <pluginlib/class_list_macros.hpp>

#include "gyro_allan/io/imu_message.hpp"
#include "gyro_allan/io/noise_model_yaml.hpp"
#include "gyro_allan/io/plot.hpp"  // rasterAvailable
#include "gyro_allan/io/report.hpp"

namespace gyro_allan {
namespace {
// The sample thread's pause between batches: ~20 messages at 1 kHz, far inside the subscriber queue (~queue_size).
constexpr std::chrono::milliseconds kSampleBatch{20};
}  // namespace

AnalyzerNodelet::~AnalyzerNodelet() {
  sample_stop_ = true;
  if (sample_thread_.joinable()) sample_thread_.join();
  imu_sub_.shutdown();
  angle_sub_.shutdown();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  cv_.notify_all();
  if (worker_.joinable()) worker_.join();
}

void AnalyzerNodelet::onInit() {
  ros::NodeHandle& nh = getNodeHandle();
  ros::NodeHandle& pnh = getPrivateNodeHandle();
  p_ = loadAnalyzerParams(pnh, &param_problems_);
  for (const std::string& w : param_problems_) NODELET_WARN("gyro_allan analyzer: %s", w.c_str());
  oa_ = std::make_unique<OnlineAnalyzer>(p_.online);

  noise_pub_ = pnh.advertise<NoiseReport>("noise", 10, true);  // latched: a late subscriber gets the last result
  // latched; published while ~gmwm is on, and once with status "off" when it is turned off
  noise_model_pub_ = pnh.advertise<NoiseModel>("noise_model", 10, true);
  quick_pub_ = pnh.advertise<QuickNoise>("quick", 10, true);  // latched, as ~noise
  if (p_.publish_plot && rasterAvailable()) plot_pub_ = pnh.advertise<sensor_msgs::Image>("plot", 1);
  const char* axes[3] = {"x", "y", "z"};
  if (p_.publish_curves)
    for (int a = 0; a < 3; ++a) curve_pub_[a] = pnh.advertise<AllanCurve>(std::string("allan/") + axes[a], 10, true);
  reset_srv_ = pnh.advertiseService("reset", &AnalyzerNodelet::resetService, this);
  save_srv_ = pnh.advertiseService("save", &AnalyzerNodelet::saveService, this);
  analyze_srv_ = pnh.advertiseService("analyze", &AnalyzerNodelet::analyzeService, this);

  updater_ = std::make_unique<diagnostic_updater::Updater>(nh, pnh, "/gyro_allan" + getName());
  updater_->setHardwareID(p_.hardware_id.empty() ? "unknown (no IMU message yet)" : p_.hardware_id);
  using Wrapper = diagnostic_updater::DiagnosticStatusWrapper;
  updater_->add("stamps", [this](Wrapper& s) { diagStamps(diagState(), params(), &recent_, s); });
  updater_->add("input values", [this](Wrapper& s) { diagValues(diagState(), params(), &recent_, s); });
  updater_->add("window", [this](Wrapper& s) { diagWindow(diagState(), params(), &recent_, s); });
  updater_->add("motion", [this](Wrapper& s) { diagMotion(diagState(), s); });
  updater_->add("parameters", [this](Wrapper& s) { diagParams(diagState(), s); });
  updater_->add("fit quality", [this](Wrapper& s) { diagFit(diagState(), params(), s); });
  updater_->add("noise model", [this](Wrapper& s) { diagNoiseModel(diagState(), params(), s); });
  updater_->add("quality verdict", [this](Wrapper& s) { diagQuality(diagState(), s); });
  updater_->add("answers", [this](Wrapper& s) { diagAnswers(diagState(), params(), s); });
  for (int t = 0; t < kNumTerms; ++t)
    updater_->add(kTermLabel[t], [this, t](Wrapper& s) { diagTerm(t, diagState(), params(), s); });
  diag_timer_ = nh.createTimer(ros::Duration(p_.diagnostic_period), [this](const ros::TimerEvent&) { updater_->force_update(); });

  worker_ = std::thread(&AnalyzerNodelet::workerLoop, this);
  dyn_ = std::make_unique<dynamic_reconfigure::Server<AnalyzerConfig>>(dyn_mutex_, pnh);
  dyn_->updateConfig(toConfig(p_));
  dyn_->setCallback([this](AnalyzerConfig& c, uint32_t level) { reconfigure(c, level); });

  // No TCP_NODELAY: the publisher's TCP may then send several samples per packet (the answers come every few seconds,
  // a few ms of latency do not matter), and the samples have their own callback queue and thread, which takes every
  // message queued and then sleeps kSampleBatch: one wake-up per batch instead of one per message. Receiving 1 kHz
  // from another process is most of this process's CPU (docs/performance.md, the nodelet).
  const auto hints = ros::TransportHints();
  const uint32_t q = static_cast<uint32_t>(p_.queue_size);
  ros::NodeHandle sample_nh(nh);
  sample_nh.setCallbackQueue(&sample_queue_);
  if (p_.input != "angle") imu_sub_ = sample_nh.subscribe("imu", q, &AnalyzerNodelet::imuCallback, this, hints);
  if (p_.input != "imu") angle_sub_ = sample_nh.subscribe("angle", q, &AnalyzerNodelet::angleCallback, this, hints);
  // A separate accelerometer stream (split gyro/accel topics, RealSense's accel/sample): its linear_acceleration at its
  // own stamps, on the samples' queue so that it interleaves with the gyro as it arrives.
  if (p_.input != "angle") accel_sub_ = sample_nh.subscribe("accel", q, &AnalyzerNodelet::accelCallback, this, hints);
  sample_thread_ = std::thread([this] {
    while (!sample_stop_) {
      sample_queue_.callAvailable(ros::WallDuration(0.1));
      if (!sample_stop_) std::this_thread::sleep_for(kSampleBatch);
    }
  });
  // The same queue as the rate: a fixed 1000 can drop readings when a bag's worth (nodelet_closed_loop: 1200) arrives
  // at once while the callback thread lags. Suspected, not reproduced, cause of that test's rare failure under load.
  temp_sub_ = nh.subscribe("temperature", q, &AnalyzerNodelet::temperatureCallback, this);
  NODELET_INFO("gyro_allan analyzer: input %s, window %g s, hop %g s, quick answers every %g s, method %s%s%s%s",
               p_.input.c_str(), p_.online.window_s, p_.online.hop_s, p_.online.update_s, methodName(p_.method),
               p_.online.pipeline.analysis.model_check ? " + model check" : "",
               p_.online.pipeline.rest_check ? " + at-rest check" : "",
               p_.online.pipeline.analysis.gmwm ? " + GMWM noise model" : "");
}

void AnalyzerNodelet::imuCallback(const sensor_msgs::Imu::ConstPtr& m) {
  const ImuHalves h = imuHalves(*m);  // a half flagged absent is NaN: dropped and counted, as offline
  addSample("imu", m->header, h.gyro, h.accel);
}

void AnalyzerNodelet::accelCallback(const sensor_msgs::Imu::ConstPtr& m) {
  const ImuHalves h = imuHalves(*m);
  std::lock_guard<std::mutex> lock(mutex_);
  ++accel_messages_;
  if (source_ == "angle") return;
  oa_->addAccel(static_cast<int64_t>(m->header.stamp.toNSec()), h.accel);
}

void AnalyzerNodelet::angleCallback(const geometry_msgs::Vector3Stamped::ConstPtr& m) {
  addSample("angle", m->header, {{m->vector.x, m->vector.y, m->vector.z}}, {{0, 0, 0}});
}

void AnalyzerNodelet::temperatureCallback(const sensor_msgs::Temperature::ConstPtr& m) {
  std::lock_guard<std::mutex> lock(mutex_);
  oa_->addTemperature(static_cast<int64_t>(m->header.stamp.toNSec()), m->temperature);
}

void AnalyzerNodelet::addSample(const std::string& source, const std_msgs::Header& h, const std::array<double, 3>& g,
                                const std::array<double, 3>& a) {
  std::unique_ptr<QuickAnswer> quick;  // a due quick answer, fitted and published after the lock
  AnalyzerParams p;
  std::string frame;
  double full_age = -1;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (source_.empty()) {  // the first topic that delivers is the input (input: auto)
      source_ = source;
      topic_ = source == "imu" ? imu_sub_.getTopic() : angle_sub_.getTopic();
      if (source == "angle") {
        OnlineOptions o = p_.online;
        o.pipeline.analysis.input = InputKind::Angle;
        o.pipeline.analysis.angle_increments = p_.angle_mode == "increment";
        o.pipeline.accel = false;
        p_.online = o;
        oa_->setOptions(o);
      }
      NODELET_INFO("gyro_allan analyzer: input from %s (%s)", topic_.c_str(), source.c_str());
    } else if (source != source_) {
      ++other_source_;
      return;
    }
    if (!hwid_set_ && p_.hardware_id.empty() && !h.frame_id.empty()) {
      updater_->setHardwareID(h.frame_id);
      hwid_set_ = true;
    }
    frame_id_ = h.frame_id;
    oa_->addSample(static_cast<int64_t>(h.stamp.toNSec()), g, a);
    if (oa_->hopDue() && !startAnalysis()) oa_->skipHop();
    if (oa_->quickDue()) {
      quick = std::make_unique<QuickAnswer>(oa_->takeQuick());
      p = p_;
      frame = frame_id_;
      if (have_good_) full_age = 1e-9 * static_cast<double>(quick->newest_ns - last_good_.last_ns);
    }
  }
  if (quick) publishQuick(std::move(*quick), p, frame, full_age);
}

void AnalyzerNodelet::publishQuick(QuickAnswer&& q, const AnalyzerParams& p, const std::string& frame,
                                   double full_age_s) {
  OnlineAnalyzer::fitQuick(&q, p.online.pipeline);
  const QuickNoise m = toQuickNoise(q, frame, full_age_s);
  quick_pub_.publish(m);
  if (p.publish_curves)
    for (size_t i = 0; i < q.axes.size() && i < 3; ++i) curve_pub_[i].publish(toCurve(q.axes[i], m.header, true));
  if (plot_pub_ && plot_pub_.getNumSubscribers() > 0) {
    char title[160], note[160];
    std::snprintf(title, sizeof title, "gyro_allan oadev  %lld samples  %.0f s  %.4g Hz", static_cast<long long>(q.samples),
                  static_cast<double>(q.samples) * q.tau0, m.rate_hz);
    if (full_age_s >= 0)
      std::snprintf(note, sizeof note, "quick answer (per-sample oadev + IEEE fit); full analysis %.0f s old on ~noise", full_age_s);
    else
      std::snprintf(note, sizeof note, "quick answer (per-sample oadev + IEEE fit); no full analysis yet");
    try {
      plot_pub_.publish(plotMessage(q.axes, m.header, title, note, p));
    } catch (const std::exception& e) {
      NODELET_WARN_THROTTLE(30.0, "gyro_allan analyzer: plot not rendered: %s", e.what());
    }
  }
  std::lock_guard<std::mutex> lock(mutex_);
  last_quick_ = m;
  have_quick_ = true;
}

bool AnalyzerNodelet::startAnalysis() {
  if (busy_ || oa_->windowSize() == 0) return false;
  job_ = std::make_unique<OnlineJob>(oa_->takeJob());
  busy_ = true;
  cv_.notify_all();
  return true;
}

void AnalyzerNodelet::workerLoop() {
  for (;;) {
    std::unique_ptr<OnlineJob> job;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      cv_.wait(lock, [this] { return stop_ || job_; });
      if (stop_) return;
      job = std::move(job_);
    }
    const double temperature = meanTemperature(*job);
    const OnlineResult r = OnlineAnalyzer::run(std::move(*job));
    if (!r.ok) NODELET_WARN_THROTTLE(30.0, "gyro_allan analyzer: window not analysable: %s", r.error.c_str());
    publish(r, temperature);
    std::lock_guard<std::mutex> lock(mutex_);
    busy_ = false;
  }
}

void AnalyzerNodelet::publish(const OnlineResult& r, double temperature) {
  std::string frame, topic;
  AnalyzerParams p;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    p = p_;
    oa_->account(r);
    last_ = r;
    have_result_ = true;
    frame = frame_id_;
    topic = topic_;
  }
  if (!r.ok) return;  // the window diagnostic says why
  const NoiseReport report = toNoiseReport(r, p, frame, temperature);
  noise_pub_.publish(report);
  bool with_model = hasNoiseModel(r.result);  // the window was analysed with ~gmwm on
  NoiseModel model;
  if (with_model) {
    model = toNoiseModel(r, p, frame, liveReportMeta(p, topic).sources);
    // Only while ~gmwm is still on: a window started before it was turned off must not replace the "off" message
    // on the latched topic (reconfigure publishes that under the same lock).
    std::lock_guard<std::mutex> lock(mutex_);
    with_model = p_.online.pipeline.analysis.gmwm;
    if (with_model) noise_model_pub_.publish(model);
  }
  if (p.publish_curves)
    for (size_t a = 0; a < r.result.gyro.size() && a < 3; ++a) curve_pub_[a].publish(toCurve(r.result.gyro[a], report.header));
  if (plot_pub_ && plot_pub_.getNumSubscribers() > 0) {
    char title[160];
    std::snprintf(title, sizeof title, "gyro_allan oadev  %lld samples  %.0f s window  %.4g Hz",
                  static_cast<long long>(report.samples), (report.window_end - report.window_start).toSec(), report.rate_hz);
    try {
      plot_pub_.publish(plotMessage(r.result.gyro, report.header, title, "full analysis (~noise)", p));
    } catch (const std::exception& e) {
      NODELET_WARN_THROTTLE(30.0, "gyro_allan analyzer: plot not rendered: %s", e.what());
    }
  }
  std::lock_guard<std::mutex> lock(mutex_);
  last_good_ = r;
  last_good_params_ = p;
  last_report_ = report;
  have_good_ = true;
  if (with_model) {
    last_noise_model_ = std::move(model);
    have_noise_model_ = true;
  }
}

bool AnalyzerNodelet::resetService(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
  std::lock_guard<std::mutex> lock(mutex_);
  const size_t n = oa_->windowSize();
  oa_->reset();
  res.success = true;
  res.message = "window emptied (" + std::to_string(n) + " samples); counters kept";
  return true;
}

bool AnalyzerNodelet::analyzeService(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
  std::lock_guard<std::mutex> lock(mutex_);
  const size_t n = oa_->windowSize();
  res.success = startAnalysis();
  res.message = res.success ? "analysing the window now (" + std::to_string(n) + " samples); the result follows on ~noise"
                : n == 0 ? "the window is empty" : "an analysis is running; call again when ~noise is published";
  return true;
}

bool AnalyzerNodelet::saveService(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
  OnlineResult r;
  std::string topic;
  AnalyzerParams p;  // those the window was analysed and published with: the report's method, the filter rate
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!have_good_) {
      res.success = false;
      res.message = "nothing to save: no window analysed yet";
      return true;
    }
    r = last_good_;
    p = last_good_params_;
    topic = topic_;
  }
  std::string dir = p.save_dir;
  if (dir.empty()) {
    const char* home = std::getenv("ROS_HOME");
    const char* user = std::getenv("HOME");
    dir = (home ? std::string(home) : std::string(user ? user : "/tmp") + "/.ros") + "/gyro_allan" + getName();
  }
  try {
    std::string path;
    for (size_t i = 0; i <= dir.size(); ++i)
      if (i == dir.size() || (dir[i] == '/' && i > 0)) {
        path = dir.substr(0, i);
        if (mkdir(path.c_str(), 0775) != 0 && errno != EEXIST) throw std::runtime_error("cannot create folder " + path);
      }
    ReportMeta meta = liveReportMeta(p, topic);
    setPipelineMeta(r.result, &meta);
    writeAnalysisFiles(dir, meta, r.result, "yaml", parseKalibrAxisRule(p.kalibr_axis),
                       p.online.pipeline.analysis.input == InputKind::Rate,
                       "the window; at-rest check off (~rest_check): valid only if the sensor was static");
    res.success = true;
    res.message = "wrote " + dir + "/report.yaml, " + dir + "/allan.csv and " + dir + "/imu.yaml";
    if (hasNoiseModel(r.result)) {  // the window was analysed with ~gmwm on: analyze_bag --method gmwm's file too
      writeFileAtomic(dir + "/noise_model.yaml", noiseModelYaml(r.result.gyro, p.filter_rate, meta.sources));
      res.message += " and " + dir + "/noise_model.yaml";
    }
  } catch (const std::exception& e) {
    res.success = false;
    res.message = e.what();
  }
  return true;
}

void AnalyzerNodelet::reconfigure(AnalyzerConfig& c, uint32_t) {
  std::lock_guard<std::mutex> lock(mutex_);
  AnalyzerParams p = p_;
  const std::string problem = applyConfig(c, &p);
  if (!problem.empty()) {
    NODELET_ERROR("gyro_allan analyzer: reconfigure refused: %s", problem.c_str());
    param_problems_.push_back("reconfigure refused: " + problem);
    c = toConfig(p_);
    return;
  }
  // ~gmwm turned off: the latched ~noise_model is replaced by one that says so (status "off", no axes).
  const bool gmwm_off = p_.online.pipeline.analysis.gmwm && !p.online.pipeline.analysis.gmwm;
  p_ = p;
  oa_->setOptions(p_.online);
  if (gmwm_off) {
    have_noise_model_ = false;
    last_noise_model_ = NoiseModel();
    noise_model_pub_.publish(noiseModelOff(ros::Time::now(), frame_id_));
  }
  NODELET_INFO("gyro_allan analyzer: window %g s, hop %g s, method %s, wavelet split %s, model check %s, rest check %s, "
               "GMWM %s (filter rate %g Hz)",
               p_.online.window_s, p_.online.hop_s, methodName(p_.method), c.wavelet_split ? "on" : "off",
               c.model_check ? "on" : "off", c.rest_check ? "on" : "off", c.gmwm ? "on" : "off", c.filter_rate);
}

AnalyzerParams AnalyzerNodelet::params() {
  std::lock_guard<std::mutex> lock(mutex_);
  return p_;
}

DiagState AnalyzerNodelet::diagState() {
  std::lock_guard<std::mutex> lock(mutex_);
  DiagState s;
  s.counters = oa_->counters();
  s.window_samples = oa_->windowSize();
  s.window_span_s = oa_->windowSpan();
  s.have_result = have_result_;
  if (have_result_) {
    s.last.ok = last_.ok;
    s.last.error = last_.error;
    s.last.not_at_rest = last_.not_at_rest;
    s.last.result.stamps = last_.result.stamps;
    s.last.result.rest_checked = last_.result.rest_checked;
    s.last.result.rest = last_.result.rest;
    s.last.result.rest_from_s = last_.result.rest_from_s;
    s.last.result.rest_to_s = last_.result.rest_to_s;
    s.last.result.warnings = last_.result.warnings;
    for (const AxisAnalysis& a : last_.result.gyro) {
      AxisAnalysis b;  // only what the diagnostics read
      b.axis = a.axis;
      b.spikes_checked = a.spikes_checked;
      b.spikes = a.spikes;
      s.last.result.gyro.push_back(b);
    }
  }
  s.have_good = have_good_;
  s.last_report = last_report_;
  s.have_noise_model = have_noise_model_;
  s.last_noise_model = last_noise_model_;
  s.source = source_;
  s.other_source = other_source_;
  s.accel_messages = accel_messages_;
  s.param_problems = param_problems_;
  s.newest_ns = oa_->newestStamp();
  s.have_quick = have_quick_;
  s.last_quick = last_quick_;
  return s;
}

}  // namespace gyro_allan

PLUGINLIB_EXPORT_CLASS(gyro_allan::AnalyzerNodelet, nodelet::Nodelet)
