// Online gyro noise analyzer nodelet (gyro_allan/AnalyzerNodelet): input checks, sliding AVAR, worker-thread fit.
#include "analyzer_nodelet.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <gyro_allan/AllanCurve.h>
#include <gyro_allan/NoiseReport.h>
#include <pluginlib/class_list_macros.hpp>

#include "gyro_allan/io/plot_image.hpp"
#include "gyro_allan/model_check.hpp"
#include "gyro_allan/wavelet_split.hpp"

namespace gyro_allan {
namespace {

const char* const kAxisName[3] = {"x", "y", "z"};
const char* const kTermLabel[kNumTerms] = {"quantization", "angle random walk", "bias instability",
                                           "rate random walk", "rate ramp"};

NoiseCoefficient toMsg(const Coefficient& c) {
  NoiseCoefficient m;
  m.value = c.value;
  m.sigma = c.sigma;
  m.supported = c.supported;
  return m;
}

}  // namespace

void AnalyzerNodelet::EventLog::add(const ros::Time& now) {
  ++total;
  times.push_back(now);
  if (times.size() > 100000) times.pop_front();  // bounded: only the recent ones matter
}

size_t AnalyzerNodelet::EventLog::recent(const ros::Time& now, double recent_s) {
  while (!times.empty() && (now - times.front()).toSec() > recent_s) times.pop_front();
  return times.size();
}

AnalyzerNodelet::AnalyzerNodelet() = default;

AnalyzerNodelet::~AnalyzerNodelet() {
  // Stop the inputs first: shutdown() waits for a callback that is running, so none touches a dying member.
  diag_timer_.stop();
  imu_sub_.shutdown();
  angle_sub_.shutdown();
  temp_sub_.shutdown();
  {
    std::lock_guard<std::mutex> lock(work_mutex_);
    stop_ = true;
  }
  work_cv_.notify_all();
  if (worker_.joinable()) worker_.join();
}

// ------------------------------------------------------------------------------------------------ parameters
void AnalyzerNodelet::loadParams() {
  ros::NodeHandle& pnh = getPrivateNodeHandle();
  const AnalyzerParams def;
  auto getD = [&](const std::string& name, double* value, double fallback) {
    pnh.param(name, *value, fallback);
    if (!std::isfinite(*value)) {
      NODELET_ERROR("parameter ~%s is not finite; using the default %g", name.c_str(), fallback);
      *value = fallback;
    }
  };
  getD("window_s", &p_.window_s, def.window_s);
  if (!(p_.window_s > 0)) {
    NODELET_ERROR("parameter ~window_s = %g must be > 0 s; using the default %g s", p_.window_s, def.window_s);
    p_.window_s = def.window_s;
  }
  getD("hop_s", &p_.hop_s, def.hop_s);
  if (!(p_.hop_s > 0) || p_.hop_s > p_.window_s) {
    const double fb = std::min(def.hop_s, p_.window_s);
    NODELET_ERROR("parameter ~hop_s = %g must be in (0, ~window_s = %g] s; using %g s", p_.hop_s, p_.window_s, fb);
    p_.hop_s = fb;
  }
  pnh.param<std::string>("tau_grid", p_.tau_grid, def.tau_grid);
  std::string err;
  if (!parseTauGrid(p_.tau_grid, &p_.grid, &err) || p_.grid.kind == TauGridKind::All) {
    NODELET_ERROR("parameter ~tau_grid = '%s' is invalid (%s; use octave, decade, log or log:K); using '%s'",
                  p_.tau_grid.c_str(), err.empty() ? "'all' is too costly online" : err.c_str(),
                  def.tau_grid.c_str());
    p_.tau_grid = def.tau_grid;
    parseTauGrid(p_.tau_grid, &p_.grid, &err);
  }
  pnh.param<std::string>("method", p_.method, def.method);
  if (p_.method != "joint_fit" && p_.method != "wavelet_split") {
    NODELET_ERROR("parameter ~method = '%s' is unknown (joint_fit, wavelet_split); using 'joint_fit'",
                  p_.method.c_str());
    p_.method = "joint_fit";
  }
  pnh.param("model_check", p_.model_check, def.model_check);
  pnh.param("rest_check", p_.rest_check, def.rest_check);
  getD("spike_z", &p_.spikes.z, def.spikes.z);
  if (!(p_.spikes.z >= 0)) {
    NODELET_ERROR("parameter ~spike_z = %g must be >= 0 (0: keep spikes); using %g", p_.spikes.z, def.spikes.z);
    p_.spikes.z = def.spikes.z;
  }
  getD("raw_max_s", &p_.raw_max_s, def.raw_max_s);
  if (!(p_.raw_max_s > 0)) {
    NODELET_ERROR("parameter ~raw_max_s = %g must be > 0 s; using %g s", p_.raw_max_s, def.raw_max_s);
    p_.raw_max_s = def.raw_max_s;
  }
  pnh.param<std::string>("input", p_.input, def.input);
  if (p_.input != "imu" && p_.input != "angle" && p_.input != "auto") {
    NODELET_ERROR("parameter ~input = '%s' is unknown (imu, angle, auto); using 'auto'", p_.input.c_str());
    p_.input = "auto";
  }
  pnh.param<std::string>("angle_mode", p_.angle_mode, def.angle_mode);
  if (p_.angle_mode != "accumulated" && p_.angle_mode != "increment") {
    NODELET_ERROR("parameter ~angle_mode = '%s' is unknown (accumulated, increment); using 'accumulated'",
                  p_.angle_mode.c_str());
    p_.angle_mode = "accumulated";
  }
  getD("expected_rate_hz", &p_.expected_rate_hz, def.expected_rate_hz);
  if (p_.expected_rate_hz < 0) {
    NODELET_ERROR("parameter ~expected_rate_hz = %g must be >= 0 Hz (0 = learn); learning the rate",
                  p_.expected_rate_hz);
    p_.expected_rate_hz = 0;
  }
  pnh.param("learn_samples", p_.learn_samples, def.learn_samples);
  if (p_.learn_samples < 10) {
    NODELET_ERROR("parameter ~learn_samples = %d must be >= 10; using %d", p_.learn_samples, def.learn_samples);
    p_.learn_samples = def.learn_samples;
  }
  getD("lookahead_s", &p_.lookahead_s, def.lookahead_s);
  if (!(p_.lookahead_s >= 0 && p_.lookahead_s <= 60)) {
    NODELET_ERROR("parameter ~lookahead_s = %g must be in [0, 60]; using %g", p_.lookahead_s, def.lookahead_s);
    p_.lookahead_s = def.lookahead_s;
  }
  getD("gap_factor", &p_.gap_factor, def.gap_factor);
  if (!(p_.gap_factor > 1.0)) {
    NODELET_ERROR("parameter ~gap_factor = %g must be > 1; using %g", p_.gap_factor, def.gap_factor);
    p_.gap_factor = def.gap_factor;
  }
  getD("rate_tolerance", &p_.rate_tolerance, def.rate_tolerance);
  if (!(p_.rate_tolerance > 0 && p_.rate_tolerance < 1)) {
    NODELET_ERROR("parameter ~rate_tolerance = %g must be in (0, 1); using %g", p_.rate_tolerance,
                  def.rate_tolerance);
    p_.rate_tolerance = def.rate_tolerance;
  }
  getD("saturation_limit", &p_.saturation_limit, def.saturation_limit);
  if (p_.saturation_limit < 0) {
    NODELET_ERROR("parameter ~saturation_limit = %g must be >= 0 (0 = off); using 0", p_.saturation_limit);
    p_.saturation_limit = 0;
  }
  pnh.param("saturation_run", p_.saturation_run, def.saturation_run);
  if (p_.saturation_run < 0 || p_.saturation_run == 1) {
    NODELET_ERROR("parameter ~saturation_run = %d must be 0 (off) or >= 2; using %d", p_.saturation_run,
                  def.saturation_run);
    p_.saturation_run = def.saturation_run;
  }
  int min_fit = static_cast<int>(def.min_fit_samples);
  pnh.param("min_fit_samples", min_fit, min_fit);
  if (min_fit < 10) {
    NODELET_ERROR("parameter ~min_fit_samples = %d must be >= 10; using %d", min_fit,
                  static_cast<int>(def.min_fit_samples));
    min_fit = static_cast<int>(def.min_fit_samples);
  }
  p_.min_fit_samples = min_fit;
  getD("confidence", &p_.confidence, def.confidence);
  if (!(p_.confidence > 0 && p_.confidence < 1)) {
    NODELET_ERROR("parameter ~confidence = %g must be in (0, 1); using %g", p_.confidence, def.confidence);
    p_.confidence = def.confidence;
  }
  pnh.param("recompute_steps", p_.recompute_steps, def.recompute_steps);
  if (p_.recompute_steps < 2 || p_.recompute_steps > 64) {
    NODELET_ERROR("parameter ~recompute_steps = %d must be in [2, 64]; using %d", p_.recompute_steps,
                  def.recompute_steps);
    p_.recompute_steps = def.recompute_steps;
  }
  pnh.param("publish_curves", p_.publish_curves, def.publish_curves);
  pnh.param("publish_plot", p_.publish_plot, def.publish_plot);
  pnh.param("plot_width", p_.plot_width, def.plot_width);
  pnh.param("plot_height", p_.plot_height, def.plot_height);
  if (p_.plot_width < 200 || p_.plot_height < 150 || p_.plot_width > 4096 || p_.plot_height > 4096) {
    NODELET_ERROR("parameters ~plot_width x ~plot_height = %d x %d outside 200x150 .. 4096x4096; using %d x %d",
                  p_.plot_width, p_.plot_height, def.plot_width, def.plot_height);
    p_.plot_width = def.plot_width;
    p_.plot_height = def.plot_height;
  }
  if (p_.publish_plot && !plotImageAvailable()) {
    NODELET_WARN("~publish_plot: this build has no OpenCV (libopencv-imgproc-dev): no ~plot image");
    p_.publish_plot = false;
  }
  getD("diag/recent_s", &p_.recent_s, def.recent_s);
  if (!(p_.recent_s > 0)) {
    NODELET_ERROR("parameter ~diag/recent_s = %g must be > 0 s; using %g", p_.recent_s, def.recent_s);
    p_.recent_s = def.recent_s;
  }
  getD("diag/error_fraction", &p_.error_fraction, def.error_fraction);
  if (!(p_.error_fraction > 0 && p_.error_fraction <= 1)) {
    NODELET_ERROR("parameter ~diag/error_fraction = %g must be in (0, 1]; using %g", p_.error_fraction,
                  def.error_fraction);
    p_.error_fraction = def.error_fraction;
  }
  getD("diag/rms_log10_warn", &p_.rms_log10_warn, def.rms_log10_warn);
  getD("diag/rms_log10_error", &p_.rms_log10_error, def.rms_log10_error);
  if (!(p_.rms_log10_warn > 0) || p_.rms_log10_error < p_.rms_log10_warn) {
    NODELET_ERROR("parameters ~diag/rms_log10_warn = %g, ~diag/rms_log10_error = %g must satisfy 0 < warn <= error; "
                  "using %g, %g", p_.rms_log10_warn, p_.rms_log10_error, def.rms_log10_warn, def.rms_log10_error);
    p_.rms_log10_warn = def.rms_log10_warn;
    p_.rms_log10_error = def.rms_log10_error;
  }
  for (int t = 0; t < kNumTerms; ++t) {
    const std::string key = std::string("spec/") + noiseTermKey(t);
    getD(key + "_warn", &p_.spec_warn[t], 0.0);
    getD(key + "_error", &p_.spec_error[t], 0.0);
    if (p_.spec_warn[t] < 0) {
      NODELET_ERROR("parameter ~%s_warn = %g must be >= 0 (0 = off); disabled", key.c_str(), p_.spec_warn[t]);
      p_.spec_warn[t] = 0;
    }
    if (p_.spec_error[t] < 0) {
      NODELET_ERROR("parameter ~%s_error = %g must be >= 0 (0 = off); disabled", key.c_str(), p_.spec_error[t]);
      p_.spec_error[t] = 0;
    }
    if (p_.spec_warn[t] > 0 && p_.spec_error[t] > 0 && p_.spec_error[t] < p_.spec_warn[t]) {
      NODELET_ERROR("parameter ~%s_error = %g is below ~%s_warn = %g; the warn level is ignored", key.c_str(),
                    p_.spec_error[t], key.c_str(), p_.spec_warn[t]);
      p_.spec_warn[t] = 0;
    }
  }
  getD("diagnostic_period", &p_.diagnostic_period, def.diagnostic_period);
  if (!(p_.diagnostic_period > 0)) p_.diagnostic_period = def.diagnostic_period;
  if (p_.expected_rate_hz > 0 && p_.window_s * p_.expected_rate_hz > 1e9) {
    NODELET_ERROR("parameters ~window_s = %g s at ~expected_rate_hz = %g Hz exceed 1e9 samples; using %g s",
                  p_.window_s, p_.expected_rate_hz, 1e9 / p_.expected_rate_hz);
    p_.window_s = 1e9 / p_.expected_rate_hz;
    p_.hop_s = std::min(p_.hop_s, p_.window_s);
  }
}

// ------------------------------------------------------------------------------------------------ setup
void AnalyzerNodelet::onInit() {
  ros::NodeHandle& nh = getNodeHandle();
  ros::NodeHandle& pnh = getPrivateNodeHandle();
  loadParams();

  noise_pub_ = pnh.advertise<NoiseReport>("noise", 10);
  if (p_.publish_plot) plot_pub_ = pnh.advertise<sensor_msgs::Image>("plot", 1);
  if (p_.publish_curves)
    for (int a = 0; a < 3; ++a) curve_pub_[a] = pnh.advertise<AllanCurve>(std::string("allan/") + kAxisName[a], 10);

  updater_.reset(new diagnostic_updater::Updater(nh, pnh, "/gyro_allan" + getName()));
  std::string hwid;
  pnh.param<std::string>("hardware_id", hwid, "gyro_allan");
  updater_->setHardwareID(hwid);
  freq_status_.reset(new diagnostic_updater::FrequencyStatus(
      diagnostic_updater::FrequencyStatusParam(&freq_min_, &freq_max_, p_.rate_tolerance, 5), "input rate"));
  updater_->add(*freq_status_);
  updater_->add("stamps", this, &AnalyzerNodelet::diagStamps);
  updater_->add("input values", this, &AnalyzerNodelet::diagValues);
  updater_->add("window", this, &AnalyzerNodelet::diagWindow);
  updater_->add("motion", this, &AnalyzerNodelet::diagMotion);
  updater_->add("fit quality", this, &AnalyzerNodelet::diagFit);
  updater_->add("quality verdict", this, &AnalyzerNodelet::diagQuality);
  for (int t = 0; t < kNumTerms; ++t) {
    updater_->add(kTermLabel[t], [this, t](diagnostic_updater::DiagnosticStatusWrapper& s) { diagTerm(t, s); });
  }

  if (p_.expected_rate_hz > 0) initAccumulators(1.0 / p_.expected_rate_hz);

  worker_ = std::thread(&AnalyzerNodelet::workerLoop, this);
  diag_timer_ = nh.createTimer(ros::Duration(0.1), &AnalyzerNodelet::diagTimer, this);

  const uint32_t queue = 10000;  // 10 s at 1 kHz: a busy manager must not drop samples (a drop is a gap)
  if (p_.input != "angle")
    imu_sub_ = nh.subscribe("imu", queue, &AnalyzerNodelet::imuCallback, this, ros::TransportHints().tcpNoDelay());
  if (p_.input != "imu")
    angle_sub_ =
        nh.subscribe("angle", queue, &AnalyzerNodelet::angleCallback, this, ros::TransportHints().tcpNoDelay());
  temp_sub_ = nh.subscribe("temperature", 100, &AnalyzerNodelet::temperatureCallback, this);
  NODELET_INFO("gyro_allan analyzer: input %s, window %g s, hop %g s, tau grid %s, method %s%s, rate %s",
               p_.input.c_str(), p_.window_s, p_.hop_s, p_.tau_grid.c_str(), p_.method.c_str(),
               p_.model_check ? " + model check" : "",
               p_.expected_rate_hz > 0 ? std::to_string(p_.expected_rate_hz).c_str() : "learned");
}

void AnalyzerNodelet::initAccumulators(double tau0) {
  SlidingAllanOptions o;
  o.tau0 = tau0;
  o.window_samples = std::max<int64_t>(4, std::llround(p_.window_s / tau0));
  o.grid = p_.grid;
  o.confidence = p_.confidence;
  o.compute_edf = false;  // EDF and confidence bounds are filled by the worker thread
  o.alpha_from_slope = false;  // pass 1 of fitWithNoiseId uses white rate noise (alpha 0) everywhere
  o.recompute_steps = p_.recompute_steps;
  for (auto& a : allan_) a.reset(new SlidingAllan(o));
  tau0_ = tau0;
  measured_rate_hz_ = 1.0 / tau0;
  freq_min_ = freq_max_ = 1.0 / tau0;
  recent_kept_.clear();
  dt_since_check_ = 0;
  seg_stamps_.clear();
  have_hop_ = false;
  // The sampler's grid at this period; samples still in the old grid's lookahead go through the new one.
  grid_.reset(new StampGrid(tau0, p_.gap_factor, p_.lookahead_s));
  // Spike filters start afresh with the window (what they held back belonged to the old rate).
  for (int a = 0; a < 3; ++a) {
    spike_[a].reset(p_.spikes.z > 0 ? new SpikeFilter(p_.spikes) : nullptr);  // ~spike_z 0: no filter
    spike_out_[a].clear();
  }
  spike_stamps_.clear();
  spikes_seen_ = 0;
  segment_pending_ = true;
  rest_.reset();  // created with the first sample at this rate
  rest_queue_.clear();  // decided at the old rate: they leave with the old window
  rest_blocks_.clear();
  rest_gap_pending_ = false;
  for (const auto& s : grid_values_) grid_->push(s.stamp.toSec());
  new_timeline_ = true;
  reinit_period_ = 0;
  NODELET_INFO("gyro_allan analyzer: nominal rate %.6g Hz, window %lld samples (%.1f MB for 3 axes)", 1.0 / tau0,
               static_cast<long long>(o.window_samples), 3.0 * allan_[0]->memoryBytes() / 1e6);
}

// ------------------------------------------------------------------------------------------------ input
void AnalyzerNodelet::imuCallback(const sensor_msgs::Imu::ConstPtr& msg) {
  const std::array<double, 3> v{{msg->angular_velocity.x, msg->angular_velocity.y, msg->angular_velocity.z}};
  const std::array<double, 3> acc{{msg->linear_acceleration.x, msg->linear_acceleration.y, msg->linear_acceleration.z}};
  processSample(Source::Imu, msg->header.stamp, v, msg->header.frame_id, &acc);
}

void AnalyzerNodelet::angleCallback(const geometry_msgs::Vector3Stamped::ConstPtr& msg) {
  const std::array<double, 3> v{{msg->vector.x, msg->vector.y, msg->vector.z}};
  processSample(Source::Angle, msg->header.stamp, v, msg->header.frame_id);
}

void AnalyzerNodelet::temperatureCallback(const sensor_msgs::Temperature::ConstPtr& msg) {
  if (!std::isfinite(msg->temperature)) return;
  std::lock_guard<std::mutex> lock(mutex_);
  temp_sum_ += msg->temperature;
  ++temp_count_;
}

bool AnalyzerNodelet::isSaturated(const std::array<double, 3>& v) {
  bool sat = false;
  for (int a = 0; a < 3; ++a) {
    const double x = std::fabs(v[a]);
    if (p_.saturation_limit > 0 && x >= p_.saturation_limit) sat = true;
    run_[a] = (v[a] == last_value_[a]) ? run_[a] + 1 : 1;
    last_value_[a] = v[a];
    if (p_.saturation_run > 0 && run_[a] >= p_.saturation_run && x > 0 && x >= 0.99 * max_abs_[a]) sat = true;
    max_abs_[a] = std::max(max_abs_[a], x);
  }
  return sat;
}

bool AnalyzerNodelet::checkRate(const ros::Time& stamp, int64_t index) {
  // Slope of stamp against grid index over the last 128 kept samples, checked every 64: neither arrival jitter nor
  // missing samples move it, a real rate change does. Returns true when the accumulators must restart.
  recent_kept_.emplace_back(stamp.toSec(), index);
  if (recent_kept_.size() > 129) recent_kept_.pop_front();
  if (++dt_since_check_ < 64 || recent_kept_.size() < 129) return false;
  dt_since_check_ = 0;
  const int64_t dk = recent_kept_.back().second - recent_kept_.front().second;
  if (dk <= 0) return false;
  const double slope = (recent_kept_.back().first - recent_kept_.front().first) / static_cast<double>(dk);
  if (!(slope > 0)) return false;
  measured_rate_hz_ = 1.0 / slope;
  const bool off = std::fabs(slope - tau0_) > p_.rate_tolerance * tau0_;
  if (!off) {
    rate_mismatch_ = false;
    return false;
  }
  if (p_.expected_rate_hz > 0) {
    if (!rate_mismatch_) {
      rate_change_.add(ros::Time::now());
      NODELET_ERROR("input rate %.6g Hz differs from ~expected_rate_hz = %.6g Hz", 1.0 / slope, p_.expected_rate_hz);
    }
    rate_mismatch_ = true;
    return false;
  }
  rate_change_.add(ros::Time::now());
  NODELET_WARN("input rate changed from %.6g Hz to %.6g Hz: restarting the window", 1.0 / tau0_, 1.0 / slope);
  reinit_period_ = slope;
  return true;
}

void AnalyzerNodelet::processSample(Source source, const ros::Time& stamp, const std::array<double, 3>& v,
                                    const std::string& frame_id, const std::array<double, 3>* accel) {
  try {
    std::lock_guard<std::mutex> lock(mutex_);
    const ros::Time now = ros::Time::now();
    if (source_ == Source::None) {
      source_ = source;
      NODELET_INFO("gyro_allan analyzer: using the %s topic", source == Source::Imu ? "imu" : "angle");
    } else if (source != source_) {
      other_source_.add(now);
      return;
    }
    if (freq_status_) freq_status_->tick();
    if (stamp.isZero()) {
      zero_stamp_.add(now);
      dropped_since_last_ = true;
      return;
    }
    bool restart = false;
    if (have_last_ && stamp < last_stamp_) {
      out_of_order_.add(now);
      // A single stamp far in the future must not stop the input until real time catches up with it: once
      // kGlitchRun consecutive samples, increasing among themselves, lie before the last accepted stamp, that stamp
      // was the glitch (or the clock jumped back). The timeline restarts at them as a new segment; the run is lost
      // and counted as out of order.
      ooo_run_ = (ooo_run_ > 0 && stamp > ooo_last_) ? ooo_run_ + 1 : 1;
      ooo_last_ = stamp;
      if (ooo_run_ < kGlitchRun) return;
      restart = true;
      ++timeline_restarts_;
      last_hop_ = stamp;
    }
    ooo_run_ = 0;
    if (!restart && have_last_ && stamp == last_stamp_) {
      duplicate_.add(now);
      return;
    }
    const bool increments = source == Source::Angle && p_.angle_mode == "increment";
    const bool rate_like = source == Source::Imu || increments;
    if (!std::isfinite(v[0]) || !std::isfinite(v[1]) || !std::isfinite(v[2])) {
      nonfinite_.add(now);
      dropped_since_last_ = true;
      return;
    }
    if (rate_like && isSaturated(v)) {
      saturated_.add(now);
      dropped_since_last_ = true;
      return;
    }

    const bool first = !have_last_;
    have_last_ = true;
    last_stamp_ = stamp;
    frame_id_ = frame_id;
    ++accepted_;
    last_accept_wall_ = now;

    if (tau0_ <= 0) {  // learning the rate from the stamps: these samples are not analysed
      if (first || restart) learn_t_.clear();
      learn_t_.push_back(stamp.toSec());
      dropped_since_last_ = false;
      if (static_cast<int>(learn_t_.size()) > p_.learn_samples) {
        const double period = estimatePeriod(learn_t_);
        learn_t_.clear();
        if (period > 0 && std::isfinite(period)) initAccumulators(period);
      }
      return;
    }
    if (restart) {
      // The timeline restarts: everything in the lookahead is decided on the old one first.
      grid_->finish();
      drainGrid();
      new_timeline_ = true;
    }
    grid_values_.push_back({stamp, v, accel ? *accel : std::array<double, 3>{{0, 0, 0}}, dropped_since_last_});
    dropped_since_last_ = false;
    grid_->push(stamp.toSec());
    drainGrid();
  } catch (const std::exception& e) {
    NODELET_ERROR_THROTTLE(5.0, "gyro_allan analyzer: sample dropped: %s", e.what());
  }
}

void AnalyzerNodelet::drainGrid() {
  StampDecision d;
  while (grid_->pop(&d)) {
    onDecision(d);
    if (reinit_period_ > 0) initAccumulators(reinit_period_);  // re-pushes what is still pending
  }
}

void AnalyzerNodelet::onDecision(const StampDecision& d) {
  const PendingSample smp = grid_values_.front();
  grid_values_.pop_front();
  const ros::Time now = ros::Time::now();
  switch (d.verdict) {
    case StampVerdict::Duplicate: duplicate_.add(now); return;
    case StampVerdict::OutOfOrder: out_of_order_.add(now); return;
    case StampVerdict::TooClose: too_close_.add(now); return;
    case StampVerdict::Keep: break;
  }
  if (d.missing > 0) {
    missing_total_ += d.missing;
    if (!smp.dropped_before) gap_.add(now);  // a gap we caused by dropping samples is not a stamp problem
  }
  lag_max_total_ = std::max(lag_max_total_, d.lag);
  lag_max_recent_ = std::max(lag_max_recent_, d.lag);
  const bool gap = d.missing > 0 || new_timeline_;
  new_timeline_ = false;
  if (checkRate(smp.stamp, d.index)) return;  // the caller restarts the accumulators at the new rate
  if (source_ == Source::Imu && p_.rest_check) {
    restStage(smp, gap);  // forwards the samples once their block is decided, moving ones dropped
    return;
  }
  forward(smp.stamp, smp.v, gap);
}

void AnalyzerNodelet::forward(const ros::Time& stamp, const std::array<double, 3>& v, bool gap) {
  if (source_ != Source::Imu || !spike_[0]) {  // angles, or ~spike_z 0: no spike filter
    if (gap) segment_pending_ = true;
    analyse(stamp, v);
    return;
  }
  // Rates pass the spike filters (the same rule as analyze_bag), which hold back delay() samples; at a gap the
  // segment's remaining samples go out first.
  if (gap) {
    flushSpikes();
    segment_pending_ = true;
  }
  spike_stamps_.push_back(stamp);
  for (int a = 0; a < 3; ++a) spike_[a]->push(v[a], &spike_out_[a]);
  emitSpikeOutput();
}

void AnalyzerNodelet::restStage(const PendingSample& smp, bool gap) {
  // The same rest detector as analyze_bag (rest.hpp), on the gyro and, when it publishes, the accelerometer. It
  // decides each 1 s block two blocks later, so samples wait in rest_queue_ until their block is decided: static
  // ones go on to the window, moving ones are dropped (the window keeps its static data on both sides of a motion,
  // split into segments there).
  if (!rest_) {
    const bool has_accel = std::isfinite(smp.a[0]) && std::isfinite(smp.a[1]) && std::isfinite(smp.a[2]) &&
                           (smp.a[0] != 0 || smp.a[1] != 0 || smp.a[2] != 0);
    rest_.reset(new RestMonitor(tau0_, 3, has_accel, p_.rest));
    rest_has_accel_ = has_accel;
    last_accel_ = {{0, 0, 0}};
    rest_count_ = 0;
    rest_blocks_.clear();
    rest_queue_.clear();
    decided_end_ = 0;
  }
  if (gap) {
    if (rest_->newSegment()) takeRestDecisions();
    releaseRest(true);  // the segment is over: every queued sample is decided (or in no block)
  }
  std::array<double, 3> a = smp.a;
  for (int k = 0; k < 3; ++k) {
    if (std::isfinite(a[k])) last_accel_[k] = a[k];
    else a[k] = last_accel_[k];  // a NaN accelerometer sample: hold the last one
  }
  rest_queue_.push_back({rest_count_++, smp.stamp, smp.v, gap});
  if (rest_->add(smp.v.data(), rest_has_accel_ ? a.data() : nullptr)) takeRestDecisions();
  releaseRest(false);
}

void AnalyzerNodelet::takeRestDecisions() {
  for (const auto& b : rest_->decided()) {
    rest_blocks_.push_back(b);
    decided_end_ = std::max(decided_end_, b.samples.end);
    if (b.moving) {
      rest_reason_ = b.reason;
      static_blocks_ = 0;
      if (!moving_) {
        moving_ = true;
        ++motion_episodes_;
        NODELET_WARN("gyro_allan analyzer: not at rest (%s): its samples are left out of the window and the last "
                     "static answer is held", rest_reason_.c_str());
      }
    } else if (moving_ && ++static_blocks_ >= 2) {
      moving_ = false;
      NODELET_INFO("gyro_allan analyzer: at rest again");
    }
  }
}

void AnalyzerNodelet::releaseRest(bool all) {
  while (!rest_queue_.empty() && (all || rest_queue_.front().m < decided_end_)) {
    const RestQueued q = rest_queue_.front();
    rest_queue_.pop_front();
    while (!rest_blocks_.empty() && rest_blocks_.front().samples.end <= q.m) rest_blocks_.pop_front();
    const bool in_block = !rest_blocks_.empty() && rest_blocks_.front().samples.begin <= q.m;
    if (!in_block || rest_blocks_.front().moving) {  // moving, or a segment too short to judge
      ++moving_samples_;
      rest_gap_pending_ = true;
      continue;
    }
    forward(q.stamp, q.v, q.gap || rest_gap_pending_);
    rest_gap_pending_ = false;
  }
}

void AnalyzerNodelet::flushSpikes() {
  if (!spike_[0]) return;
  for (int a = 0; a < 3; ++a) spike_[a]->flush(&spike_out_[a]);
  emitSpikeOutput();
}

void AnalyzerNodelet::emitSpikeOutput() {
  const size_t n = std::min({spike_out_[0].size(), spike_out_[1].size(), spike_out_[2].size()});
  for (size_t i = 0; i < n && !spike_stamps_.empty(); ++i) {
    const ros::Time stamp = spike_stamps_.front();
    spike_stamps_.pop_front();
    analyse(stamp, {{spike_out_[0][i], spike_out_[1][i], spike_out_[2][i]}});
  }
  for (auto& o : spike_out_) o.erase(o.begin(), o.begin() + static_cast<long>(n));
  int64_t count = 0;
  for (const auto& f : spike_) count += f->count();  // per sample: no report built
  const ros::Time now = ros::Time::now();
  for (; spikes_seen_ < count; ++spikes_seen_) spikes_.add(now);
}

void AnalyzerNodelet::analyse(const ros::Time& stamp, const std::array<double, 3>& v) {
  const Source source = source_;
  const bool increments = source == Source::Angle && p_.angle_mode == "increment";
  const bool rate_like = source == Source::Imu || increments;
  const bool new_seg = segment_pending_ || seg_stamps_.empty() || allan_[0]->phasePoints() == 0;
  if (segment_pending_)
    for (auto& a : allan_) a->newSegment();
  segment_pending_ = false;
  for (int a = 0; a < 3; ++a) {
    if (source == Source::Imu) allan_[a]->addRate(v[a]);
    else if (increments) allan_[a]->addIncrement(v[a]);
    else allan_[a]->addAngle(v[a]);
  }
  // Segment bookkeeping for the window's start stamp.
  if (new_seg) seg_stamps_.emplace_back(stamp, 0);
  seg_stamps_.back().second += (new_seg && rate_like) ? 2 : 1;
  maybeHop(stamp);
}

void AnalyzerNodelet::maybeHop(const ros::Time& stamp) {
  if (!have_hop_ || stamp < last_hop_) {  // first sample, or the hop clock was set by a stamp glitch in the future
    have_hop_ = true;
    last_hop_ = stamp;
    return;
  }
  if ((stamp - last_hop_).toSec() < p_.hop_s) return;
  last_hop_ = stamp;
  if (allan_[0]->samples() < p_.min_fit_samples) return;

  std::unique_ptr<Snapshot> snap(new Snapshot);
  for (int a = 0; a < 3; ++a) snap->curves[a] = allan_[a]->curve();  // O(#tau): sums only, no EDF here
  // Window start: drop the segments that have left the window, then offset into the oldest one.
  int64_t total = 0;
  for (const auto& s : seg_stamps_) total += s.second;
  int64_t excess = total - allan_[0]->phasePoints();
  while (seg_stamps_.size() > 1 && excess >= seg_stamps_.front().second) {
    excess -= seg_stamps_.front().second;
    seg_stamps_.pop_front();
  }
  snap->window_start = seg_stamps_.front().first + ros::Duration(std::max<int64_t>(0, excess) * tau0_);
  snap->window_end = stamp;
  snap->frame_id = frame_id_;
  snap->samples = allan_[0]->samples();
  snap->segments = allan_[0]->segments();
  snap->rate_hz = 1.0 / tau0_;
  snap->fill = allan_[0]->fill();
  snap->temperature = temp_count_ > 0 ? temp_sum_ / temp_count_ : std::numeric_limits<double>::quiet_NaN();
  if (p_.method == "wavelet_split" || p_.model_check) {
    // O(raw_max_s x rate) copy in the callback, once per hop (600 s at 1 kHz: 3 x 4.8 MB).
    const int64_t max_raw = std::max<int64_t>(16, std::llround(p_.raw_max_s / tau0_));
    for (int a = 0; a < 3; ++a) snap->raw[a] = allan_[a]->newestSegmentRates(max_raw);
  }
  temp_sum_ = 0;
  temp_count_ = 0;
  bool replaced = false;
  {
    std::lock_guard<std::mutex> lock(work_mutex_);
    replaced = static_cast<bool>(pending_);
    pending_ = std::move(snap);
  }
  if (replaced) skipped_fits_.add(ros::Time::now());
  work_cv_.notify_one();
}

// ------------------------------------------------------------------------------------------------ worker
void AnalyzerNodelet::workerLoop() {
  for (;;) {
    std::unique_ptr<Snapshot> snap;
    {
      std::unique_lock<std::mutex> lock(work_mutex_);
      work_cv_.wait(lock, [this] { return stop_ || pending_; });
      if (stop_) return;
      snap = std::move(pending_);
    }
    try {
      publishResults(*snap);
    } catch (const std::exception& e) {
      NODELET_ERROR_THROTTLE(5.0, "gyro_allan analyzer: fit failed: %s", e.what());
    }
  }
}

FitResult AnalyzerNodelet::fitWithNoiseId(DeviationCurve* c) const {
  // Pass 1: EDF for white rate noise (alpha 0) at every point. Pass 2: each point's power-law exponent is that
  // of the model term dominating there (Q: white PM 2, N: white FM 0, B: flicker FM -1, K and R: RW FM -2), which
  // is far less noisy than the measured slope at long tau, then EDF and the fit again.
  if (c->points.empty()) {
    FitResult f;
    f.message = "empty Allan curve";
    return f;
  }
  fillConfidence(c, p_.confidence);
  return fitWithModelEdf(c, FitOptions{}, p_.confidence);
}

void AnalyzerNodelet::publishResults(const Snapshot& snap) {
  std::array<FitResult, 3> fits;
  std::array<QualityVerdict, 3> verdicts;
  NoiseReport report;
  report.header.stamp = snap.window_end;
  report.header.frame_id = snap.frame_id;
  report.method = p_.method;
  report.deviation = "oadev";
  report.window_start = snap.window_start;
  report.window_end = snap.window_end;
  report.samples = snap.samples;
  report.segments = snap.segments;
  report.rate_hz = snap.rate_hz;
  report.window_s = p_.window_s;
  report.fill = snap.fill;
  report.temperature = snap.temperature;
  std::array<DeviationCurve, 3> curves = snap.curves;
  for (int a = 0; a < 3; ++a) {
    DeviationCurve& c = curves[a];
    AxisNoiseFit axis;
    axis.axis = kAxisName[a];
    try {
      fits[a] = fitWithNoiseId(&c);
    } catch (const std::exception& e) {
      fits[a] = FitResult();
      fits[a].ok = false;
      fits[a].message = e.what();
    }
    std::vector<double> denoised_adev, removed_adev;
    QualityContext quality_context;  // what the verdict cannot see in the answer's FitResult
    if (p_.method == "wavelet_split") {
      const FitResult joint = fits[a];
      std::string why;
      if (snap.raw[a].size() < 1024) {
        why = "too few gap-free samples for the wavelet split";
      } else {
        try {
          WaveletSplitOptions wo;
          wo.deviation.grid = p_.grid;
          const WaveletSplitResult ws = waveletSplit(snap.raw[a], c.tau0, wo);
          if (ws.ok) {
            FitResult& f = fits[a];
            f.ok = true;
            f.message.clear();
            f.terms = ws.terms;
            f.rms_log10 = ws.fit_error.rms_log10;
            f.chi2_dof = ws.fit_error.chi2_dof;
            f.n_rms = ws.fit_error.n_rms;
            if (joint.ok) {  // the two methods' N side by side, as analyze_bag compares them
              quality_context.compare_methods = true;
              quality_context.joint_fit_n = joint.terms[kAngleRandomWalk];
              quality_context.wavelet_split_n = ws.terms[kAngleRandomWalk];
            }
            f.model_var.assign(c.points.size(), 0.0);
            for (size_t i = 0; i < c.points.size(); ++i)
              for (int t = 0; t < kNumTerms; ++t)
                f.model_var[i] += f.terms[t].value * f.terms[t].value * noiseTermBasis(t, c.points[i].tau);
            auto byM = [&c](const DeviationCurve& part, std::vector<double>* out) {
              for (const auto& pt : c.points) {
                double v = std::numeric_limits<double>::quiet_NaN();
                for (const auto& q : part.points)
                  if (q.m == pt.m) v = q.dev;
                out->push_back(v);
              }
            };
            byM(ws.denoised_curve, &denoised_adev);
            byM(ws.removed_curve, &removed_adev);
          } else {
            why = ws.message;
          }
        } catch (const std::exception& e) {
          why = e.what();
        }
      }
      if (!why.empty()) {
        fits[a].ok = false;
        fits[a].message = "wavelet_split: " + why;
      }
    }
    if (p_.model_check && fits[a].ok && snap.raw[a].size() >= 1024) {
      try {
        // The check needs the curve and fit of exactly the raw samples (the newest gap-free part of the window).
        DeviationCurve raw_curve;
        if (static_cast<int64_t>(snap.raw[a].size()) == snap.samples) {
          raw_curve = c;
        } else {
          DeviationOptions dopt;
          dopt.grid = p_.grid;
          dopt.confidence = p_.confidence;
          raw_curve = computeDeviation("oadev", snap.raw[a], InputKind::Rate, c.tau0, dopt);
        }
        const FitResult raw_fit = fitWithNoiseId(&raw_curve);
        if (raw_fit.ok) {
          const ModelCheck mc = checkModel(snap.raw[a], c.tau0, raw_curve, raw_fit, ModelCheckOptions());
          for (const auto& eff : mc.effects) {
            AddedEffect em;
            em.type = eff.type;
            for (const auto& kv : eff.parameters) {
              em.param_names.push_back(kv.first);
              em.param_values.push_back(kv.second.value);
              em.param_sigmas.push_back(kv.second.sigma);
            }
            axis.effects.push_back(em);
          }
        }
      } catch (const std::exception& e) {
        NODELET_WARN_THROTTLE(30.0, "gyro_allan analyzer: model check failed on axis %s: %s", kAxisName[a], e.what());
      }
    }
    const FitResult& f = fits[a];
    verdicts[a] = assessQuality(f, quality_context);
    axis.fit_ok = f.ok;
    axis.message = f.ok ? "" : (f.message.empty() ? "fit failed" : f.message);
    axis.quantization = toMsg(f.terms_corrected[kQuantization]);
    axis.angle_random_walk = toMsg(f.terms_corrected[kAngleRandomWalk]);
    axis.bias_instability = toMsg(f.terms_corrected[kBiasInstability]);
    axis.rate_random_walk = toMsg(f.terms_corrected[kRateRandomWalk]);
    axis.rate_ramp = toMsg(f.terms_corrected[kRateRamp]);
    axis.rms_log10 = f.rms_log10;
    axis.chi2_dof = f.chi2_dof;
    axis.dof = f.dof;
    axis.n_points = 0;
    for (bool u : f.used) axis.n_points += u ? 1 : 0;
    report.axes.push_back(axis);

    if (p_.publish_curves) {
      AllanCurve cm;
      cm.header = report.header;
      cm.axis = kAxisName[a];
      cm.deviation = "oadev";
      cm.tau0 = c.tau0;
      for (const auto& pt : c.points) {
        cm.tau.push_back(pt.tau);
        cm.n_terms.push_back(pt.n_terms);
        cm.edf.push_back(pt.edf);
        cm.adev.push_back(pt.dev);
        cm.adev_lo.push_back(pt.dev_lo);
        cm.adev_hi.push_back(pt.dev_hi);
      }
      if (f.ok && f.model_var.size() == c.points.size())
        for (double mv : f.model_var) cm.model_adev.push_back(std::sqrt(std::max(0.0, mv)));
      cm.denoised_adev = denoised_adev;
      cm.removed_adev = removed_adev;
      curve_pub_[a].publish(cm);
    }
  }
  noise_pub_.publish(report);
  if (p_.publish_plot && plot_pub_.getNumSubscribers() > 0) publishPlot(curves, fits, report.header, snap);
  std::lock_guard<std::mutex> lock(work_mutex_);
  last_fit_.have = true;
  last_fit_.fits = fits;
  last_fit_.quality = verdicts;
  last_fit_.stamp = snap.window_end;
  ++fits_done_;
}

// ------------------------------------------------------------------------------------------------ diagnostics
void AnalyzerNodelet::publishPlot(const std::array<DeviationCurve, 3>& curves, const std::array<FitResult, 3>& fits,
                                  const std_msgs::Header& header, const Snapshot& snap) {
  std::vector<PlotSeries> series(3);
  for (int a = 0; a < 3; ++a) {
    series[a].name = kAxisName[a];
    series[a].curve = &curves[a];
    const FitResult& f = fits[a];
    if (f.ok && f.model_var.size() == curves[a].points.size())
      for (double mv : f.model_var) series[a].model_adev.push_back(std::sqrt(std::max(0.0, mv)));
  }
  char title[160];
  std::snprintf(title, sizeof title, "gyro_allan oadev  %lld samples  %.0f s window  %.4g Hz",
                static_cast<long long>(snap.samples), (snap.window_end - snap.window_start).toSec(), snap.rate_hz);
  try {
    RgbImage im = renderAllanPlot(series, p_.plot_width, p_.plot_height, title);
    sensor_msgs::Image msg;
    msg.header = header;
    msg.width = static_cast<uint32_t>(im.width);
    msg.height = static_cast<uint32_t>(im.height);
    msg.encoding = "rgb8";
    msg.is_bigendian = 0;
    msg.step = static_cast<uint32_t>(3 * im.width);
    msg.data = std::move(im.data);
    plot_pub_.publish(msg);
  } catch (const std::exception& e) {
    NODELET_WARN_THROTTLE(30.0, "gyro_allan analyzer: plot not rendered: %s", e.what());
  }
}

void AnalyzerNodelet::diagTimer(const ros::TimerEvent&) {
  if (updater_) updater_->update();
}

void AnalyzerNodelet::diagStamps(diagnostic_updater::DiagnosticStatusWrapper& stat) {
  std::lock_guard<std::mutex> lock(mutex_);
  const ros::Time now = ros::Time::now();
  const size_t ooo = out_of_order_.recent(now, p_.recent_s), dup = duplicate_.recent(now, p_.recent_s),
               close = too_close_.recent(now, p_.recent_s), zero = zero_stamp_.recent(now, p_.recent_s),
               gaps = gap_.recent(now, p_.recent_s), rate = rate_change_.recent(now, p_.recent_s);
  const size_t bad = ooo + dup + close + zero;
  const double expected = tau0_ > 0 ? p_.recent_s / tau0_ : 0;
  if (rate_mismatch_) {
    stat.summary(diagnostic_msgs::DiagnosticStatus::ERROR, "input rate differs from ~expected_rate_hz");
  } else if (bad + gaps > 0 && expected > 0 && (bad + gaps) >= p_.error_fraction * expected) {
    stat.summaryf(diagnostic_msgs::DiagnosticStatus::ERROR, "many stamp problems in the last %g s", p_.recent_s);
  } else if (bad + gaps + rate > 0) {
    stat.summaryf(diagnostic_msgs::DiagnosticStatus::WARN, "stamp problems in the last %g s", p_.recent_s);
  } else {
    stat.summary(diagnostic_msgs::DiagnosticStatus::OK, "stamps clean");
  }
  stat.add("recent window (s)", p_.recent_s);
  stat.add("out of order (recent)", ooo);
  stat.add("duplicates (recent)", dup);
  stat.add("too close (recent)", close);
  stat.add("zero stamps (recent)", zero);
  stat.add("gaps (recent)", gaps);
  stat.add("rate changes (recent)", rate);
  stat.add("out of order (total)", out_of_order_.total);
  stat.add("timeline restarts after a stamp glitch (total)", timeline_restarts_);
  stat.add("duplicates (total)", duplicate_.total);
  stat.add("too close (total)", too_close_.total);
  stat.add("zero stamps (total)", zero_stamp_.total);
  stat.add("gaps (total)", gap_.total);
  stat.add("missing samples (total)", missing_total_);
  // Arrival-time stamps (drivers that stamp on receipt) jitter; the grid absorbs it. Shown, not a problem.
  stat.add("stamp lag behind the grid, max since last report (s)", lag_max_recent_);
  stat.add("stamp lag behind the grid, max (s)", lag_max_total_);
  stat.add("arrival-time stamps", tau0_ > 0 && lag_max_total_ > 0.1 * tau0_ ? "yes (placed on the grid)" : "no");
  stat.add("grid lookahead (samples)", grid_ ? grid_->lookahead() : 0);
  lag_max_recent_ = 0;
  stat.add("rate changes (total)", rate_change_.total);
  stat.add("nominal rate (Hz)", tau0_ > 0 ? 1.0 / tau0_ : 0.0);
  stat.add("measured rate (Hz)", measured_rate_hz_);
  stat.add("gap threshold: missing samples late by (s)", tau0_ * (p_.gap_factor - 1.0));
}

void AnalyzerNodelet::diagMotion(diagnostic_updater::DiagnosticStatusWrapper& stat) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!p_.rest_check || source_ == Source::Angle) {
    stat.summary(diagnostic_msgs::DiagnosticStatus::OK, p_.rest_check ? "not checked (angle input)" : "not checked (~rest_check false)");
  } else if (moving_) {
    stat.summaryf(diagnostic_msgs::DiagnosticStatus::WARN, "not at rest: %s; holding the last static answer",
                  rest_reason_.c_str());
  } else if (!rest_ || rest_->blocks() < 3) {
    stat.summary(diagnostic_msgs::DiagnosticStatus::OK, "at rest as far as can be told (fewer than 3 blocks yet)");
  } else {
    stat.summary(diagnostic_msgs::DiagnosticStatus::OK, "at rest");
  }
  stat.add("moving", moving_ ? "yes" : "no");
  stat.add("reason (last motion)", rest_reason_);
  stat.add("motion episodes (total)", motion_episodes_);
  stat.add("samples left out: moving, or a segment too short to judge (total)", moving_samples_);
  stat.add("blocks decided", rest_ ? rest_->blocks() : 0);
  stat.add("moving blocks", rest_ ? rest_->moving_blocks() : 0);
  stat.add("accelerometer used", rest_has_accel_ ? "yes" : "no");
  stat.add("block (s)", p_.rest.block_s);
}

void AnalyzerNodelet::diagValues(diagnostic_updater::DiagnosticStatusWrapper& stat) {
  std::lock_guard<std::mutex> lock(mutex_);
  const ros::Time now = ros::Time::now();
  const size_t nf = nonfinite_.recent(now, p_.recent_s), sat = saturated_.recent(now, p_.recent_s),
               other = other_source_.recent(now, p_.recent_s), spk = spikes_.recent(now, p_.recent_s);
  const double expected = tau0_ > 0 ? p_.recent_s / tau0_ : 0;
  if (nf + sat > 0 && expected > 0 && (nf + sat) >= p_.error_fraction * expected) {
    stat.summaryf(diagnostic_msgs::DiagnosticStatus::ERROR, "many NaN/Inf or saturated samples in the last %g s",
                  p_.recent_s);
  } else if (nf + sat + other > 0) {
    stat.summaryf(diagnostic_msgs::DiagnosticStatus::WARN, "dropped samples in the last %g s", p_.recent_s);
  } else if (spk > 0) {
    stat.summaryf(diagnostic_msgs::DiagnosticStatus::WARN, "%zu spikes removed in the last %g s", spk, p_.recent_s);
  } else {
    stat.summary(diagnostic_msgs::DiagnosticStatus::OK, "values clean");
  }
  stat.add("NaN/Inf dropped (recent)", nf);
  stat.add("saturated dropped (recent)", sat);
  stat.add("other source ignored (recent)", other);
  stat.add("spikes removed (recent)", spk);
  stat.add("spikes removed (total)", spikes_.total);
  stat.add("spike threshold (rad/s)", spike_[0] ? p_.spikes.z * spike_[0]->sigma() : 0.0);
  stat.add("NaN/Inf dropped (total)", nonfinite_.total);
  stat.add("saturated dropped (total)", saturated_.total);
  stat.add("other source ignored (total)", other_source_.total);
  stat.add("accepted (total)", accepted_);
  stat.add("source", source_ == Source::Imu ? "imu" : source_ == Source::Angle ? "angle" : "none yet");
}

void AnalyzerNodelet::diagWindow(diagnostic_updater::DiagnosticStatusWrapper& stat) {
  std::lock_guard<std::mutex> lock(mutex_);
  const ros::Time now = ros::Time::now();
  if (!allan_[0]) {
    stat.summary(diagnostic_msgs::DiagnosticStatus::OK, "learning the input rate");
    stat.add("stamps collected", learn_t_.size());
    return;
  }
  const bool stale = accepted_ == 0 || (now - last_accept_wall_).toSec() > p_.recent_s;
  if (stale)
    stat.summaryf(diagnostic_msgs::DiagnosticStatus::WARN, "no accepted sample in the last %g s", p_.recent_s);
  else
    stat.summaryf(diagnostic_msgs::DiagnosticStatus::OK, "window %.1f %% full", 100.0 * allan_[0]->fill());
  stat.add("fill", allan_[0]->fill());
  stat.add("samples", allan_[0]->samples());
  stat.add("segments", allan_[0]->segments());
  stat.add("window (s)", p_.window_s);
  stat.add("hop (s)", p_.hop_s);
  stat.add("tau points", allan_[0]->factors().size());
  stat.add("memory (MB)", 3.0 * allan_[0]->memoryBytes() / 1e6);
  stat.add("exact recomputes", allan_[0]->recomputes());
  stat.add("skipped fits (total)", skipped_fits_.total);
}

void AnalyzerNodelet::diagFit(diagnostic_updater::DiagnosticStatusWrapper& stat) {
  std::lock_guard<std::mutex> lock(work_mutex_);
  if (!last_fit_.have) {
    stat.summary(diagnostic_msgs::DiagnosticStatus::OK, "no fit yet (window filling)");
    return;
  }
  int level = diagnostic_msgs::DiagnosticStatus::OK;
  std::string msg = "fit good";
  for (int a = 0; a < 3; ++a) {
    const FitResult& f = last_fit_.fits[a];
    const std::string ax = kAxisName[a];
    stat.add(ax + " fit ok", f.ok ? "true" : "false");
    stat.add(ax + " rms_log10", f.rms_log10);
    stat.add(ax + " chi2_dof", f.chi2_dof);
    if (!f.ok) {
      level = std::max<int>(level, diagnostic_msgs::DiagnosticStatus::WARN);
      msg = "fit failed on " + ax + ": " + f.message;
    } else if (f.rms_log10 > p_.rms_log10_error) {
      level = diagnostic_msgs::DiagnosticStatus::ERROR;
      msg = "model misfit on " + ax + " (rms_log10 above ~diag/rms_log10_error)";
    } else if (f.rms_log10 > p_.rms_log10_warn && level < diagnostic_msgs::DiagnosticStatus::ERROR) {
      level = diagnostic_msgs::DiagnosticStatus::WARN;
      msg = "model misfit on " + ax + " (rms_log10 above ~diag/rms_log10_warn)";
    }
  }
  stat.summary(static_cast<unsigned char>(level), msg);
  stat.add("fits published", fits_done_);
}

void AnalyzerNodelet::diagQuality(diagnostic_updater::DiagnosticStatusWrapper& stat) {
  // The verdict rule analyze_bag writes into report.yaml (quality.hpp): doubtful -> WARN, bad -> ERROR, with the
  // worst axis's reason in the message.
  std::lock_guard<std::mutex> lock(work_mutex_);
  if (!last_fit_.have) {
    stat.summary(diagnostic_msgs::DiagnosticStatus::OK, "no fit yet (window filling)");
    return;
  }
  int worst = -1;
  std::string others;
  for (int a = 0; a < 3; ++a) {
    const QualityVerdict& v = last_fit_.quality[a];
    const std::string ax = kAxisName[a];
    stat.add(ax + " quality", qualityName(v.quality));
    stat.add(ax + " quality reason", v.reason);
    if (worst < 0 || v.quality > last_fit_.quality[worst].quality) worst = a;
  }
  for (int a = 0; a < 3; ++a)
    if (a != worst && last_fit_.quality[a].quality != Quality::Good)
      others += std::string(others.empty() ? "" : ", ") + kAxisName[a] + " " + qualityName(last_fit_.quality[a].quality);
  const QualityVerdict& w = last_fit_.quality[worst];
  if (w.quality == Quality::Good) {
    stat.summary(diagnostic_msgs::DiagnosticStatus::OK, "every axis good");
    return;
  }
  const unsigned char level =
      w.quality == Quality::Bad ? diagnostic_msgs::DiagnosticStatus::ERROR : diagnostic_msgs::DiagnosticStatus::WARN;
  stat.summary(level, std::string(w.quality == Quality::Bad ? "BAD FIT" : "doubtful") + " on axis " +
                          kAxisName[worst] + ": " + w.reason + (others.empty() ? "" : " (also " + others + ")"));
}

void AnalyzerNodelet::diagTerm(int term, diagnostic_updater::DiagnosticStatusWrapper& stat) {
  std::lock_guard<std::mutex> lock(work_mutex_);
  const double warn = p_.spec_warn[term], error = p_.spec_error[term];
  stat.add("unit", noiseTermUnit(term));
  stat.add("warn threshold", warn);
  stat.add("error threshold", error);
  if (!last_fit_.have) {
    stat.summary(diagnostic_msgs::DiagnosticStatus::OK, "no fit yet");
    return;
  }
  int level = diagnostic_msgs::DiagnosticStatus::OK;
  std::string worst;
  for (int a = 0; a < 3; ++a) {
    const FitResult& f = last_fit_.fits[a];
    const Coefficient& c = f.terms_corrected[term];
    const std::string ax = kAxisName[a];
    stat.add(ax, f.ok ? c.value : std::numeric_limits<double>::quiet_NaN());
    stat.add(ax + " sigma", c.sigma);
    stat.add(ax + " supported", c.supported ? "true" : "false");
    if (!f.ok) continue;
    if (error > 0 && c.value > error) {
      level = diagnostic_msgs::DiagnosticStatus::ERROR;
      worst = ax;
    } else if (warn > 0 && c.value > warn && level < diagnostic_msgs::DiagnosticStatus::ERROR) {
      level = diagnostic_msgs::DiagnosticStatus::WARN;
      worst = ax;
    }
  }
  if (level == diagnostic_msgs::DiagnosticStatus::OK)
    stat.summary(level, (warn > 0 || error > 0) ? "within spec" : "no spec set");
  else
    stat.summaryf(static_cast<unsigned char>(level), "%s above its %s threshold on axis %s", kTermLabel[term],
                  level == diagnostic_msgs::DiagnosticStatus::ERROR ? "error" : "warn", worst.c_str());
}

}  // namespace gyro_allan

PLUGINLIB_EXPORT_CLASS(gyro_allan::AnalyzerNodelet, nodelet::Nodelet)
