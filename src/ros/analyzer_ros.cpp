// The nodelet's parameters (typed reads, validation, unknown names), message conversion and diagnostic statuses.
#include "analyzer_ros.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <map>
#include <set>

#include "gyro_allan/io/noise_model_yaml.hpp"
#include "gyro_allan/io/plot.hpp"
#include "gyro_allan/quality.hpp"
#include "noise_model_msg.hpp"

namespace gyro_allan {

const char* const kTermLabel[kNumTerms] = {"quantization", "angle random walk", "bias instability",
                                           "rate random walk", "rate ramp"};

namespace {

const double kNaN = std::numeric_limits<double>::quiet_NaN();

/// Parameters of earlier versions: named when still set, so a stale config file does not pass silently.
const std::map<std::string, std::string> kRetired = {
    {"learn_samples", "the rate is estimated from each window's stamps"},
    {"lookahead_s", "the stamp grid runs on the whole window"},
    {"rate_tolerance", "rate changes are reported by the window's sanitation"},
    {"saturation_limit", "saturation is detected per window as analyze_bag does"},
    {"saturation_run", "saturation is detected per window as analyze_bag does"},
    {"recompute_steps", "each window is analysed from its raw samples"},
    {"raw_max_s", "the wavelet split and model check use the window as analyze_bag uses a record"},
    {"diag/error_fraction", "diagnostics warn on any recent problem"},
    {"diag/rms_log10_warn", "renamed rms_log10_warn (dynamic_reconfigure)"},
    {"diag/rms_log10_error", "renamed rms_log10_error (dynamic_reconfigure)"},
};

/// Typed reads: a missing parameter keeps the default, a mistyped one keeps it and is reported; every name read is
/// known, the rest of the private namespace is reported as unknown.
class ParamReader {
 public:
  ParamReader(const ros::NodeHandle& pnh, std::vector<std::string>* problems) : pnh_(pnh), problems_(problems) {}
  void get(const std::string& name, double* v) {
    XmlRpc::XmlRpcValue x;
    if (!fetch(name, &x)) return;
    if (x.getType() == XmlRpc::XmlRpcValue::TypeDouble) *v = static_cast<double>(x);
    else if (x.getType() == XmlRpc::XmlRpcValue::TypeInt) *v = static_cast<int>(x);
    else wrongType(name, "a number", std::to_string(*v));
  }
  void get(const std::string& name, int* v) {
    XmlRpc::XmlRpcValue x;
    if (!fetch(name, &x)) return;
    if (x.getType() == XmlRpc::XmlRpcValue::TypeInt) *v = static_cast<int>(x);
    else wrongType(name, "an integer", std::to_string(*v));
  }
  void get(const std::string& name, bool* v) {
    XmlRpc::XmlRpcValue x;
    if (!fetch(name, &x)) return;
    if (x.getType() == XmlRpc::XmlRpcValue::TypeBoolean) *v = static_cast<bool>(x);
    else wrongType(name, "true or false", *v ? "true" : "false");
  }
  void get(const std::string& name, std::string* v) {
    XmlRpc::XmlRpcValue x;
    if (!fetch(name, &x)) return;
    if (x.getType() == XmlRpc::XmlRpcValue::TypeString) *v = static_cast<std::string>(x);
    else wrongType(name, "a string", "'" + *v + "'");
  }
  void checkUnknown() {
    std::vector<std::string> names;
    if (!ros::param::getParamNames(names)) return;
    const std::string ns = pnh_.getNamespace() + "/";
    for (const std::string& full : names) {
      if (full.compare(0, ns.size(), ns) != 0) continue;
      const std::string rel = full.substr(ns.size());
      if (known_.count(rel)) continue;
      auto r = kRetired.find(rel);
      problems_->push_back("parameter ~" + rel + (r != kRetired.end() ? " is no longer used (" + r->second + ")"
                                                                       : " is unknown (misspelt?): ignored"));
    }
  }

 private:
  bool fetch(const std::string& name, XmlRpc::XmlRpcValue* x) {
    known_.insert(name);
    return pnh_.getParam(name, *x);
  }
  void wrongType(const std::string& name, const char* want, const std::string& def) {
    problems_->push_back("parameter ~" + name + " must be " + want + ": default " + def + " used");
  }
  const ros::NodeHandle& pnh_;
  std::vector<std::string>* problems_;
  std::set<std::string> known_{"num_worker_threads"};  // nodelet's own (standalone manager)
};

NoiseCoefficient toMsg(const Coefficient& c) {
  NoiseCoefficient m;
  m.value = c.value;
  m.sigma = c.sigma;
  m.supported = c.supported;
  return m;
}

ros::Time fromNs(int64_t ns) {
  ros::Time t;
  if (ns > 0) t.fromNSec(static_cast<uint64_t>(ns));
  return t;
}

AxisNoiseFit toAxisMsg(const AxisAnalysis& a) {
  AxisNoiseFit m;
  m.axis = a.axis;
  m.fit_ok = a.fit.ok;
  m.message = a.fit.ok ? "" : a.fit.message;
  m.method = methodName(a.method);
  m.quantization = toMsg(a.coefficients[kQuantization]);
  m.angle_random_walk = toMsg(a.coefficients[kAngleRandomWalk]);
  m.bias_instability = toMsg(a.coefficients[kBiasInstability]);
  m.rate_random_walk = toMsg(a.coefficients[kRateRandomWalk]);
  m.rate_ramp = toMsg(a.coefficients[kRateRamp]);
  m.rms_log10 = a.final_error.rms_log10;
  m.chi2_dof = a.final_error.chi2_dof;
  m.dof = a.fit.dof;
  m.n_points = static_cast<int32_t>(std::count(a.fit.used.begin(), a.fit.used.end(), true));
  m.model_checked = a.has_check && a.check.ok;
  m.rms_log10_before = m.rms_log10_after = m.chi2_dof_before = m.chi2_dof_after = kNaN;
  if (m.model_checked) {
    m.rms_log10_before = a.check.before.rms_log10;
    m.rms_log10_after = a.check.after.rms_log10;
    m.chi2_dof_before = a.check.before.chi2_dof;
    m.chi2_dof_after = a.check.after.chi2_dof;
    for (const DetectedEffect& e : a.check.effects) {
      AddedEffect em;
      em.type = e.type;
      for (const auto& kv : e.parameters) {
        em.param_names.push_back(kv.first);
        em.param_values.push_back(kv.second.value);
        em.param_sigmas.push_back(kv.second.sigma);
      }
      em.evidence = e.evidence;
      em.delta_bic = e.delta_bic;
      m.effects.push_back(em);
    }
    for (int t = 0; t < kNumTerms; ++t) m.corrected.push_back(toMsg(a.check.fit_after.terms[t]));
    m.rejected = a.check.rejected;
  } else if (a.has_check) {
    m.model_check_note = "model check failed: " + a.check.message;
  }
  for (const std::string& n : a.check_notes) m.model_check_note += (m.model_check_note.empty() ? "" : "; ") + n;
  if (!a.has_check && m.model_check_note.empty()) m.model_check_note = "model check off (~model_check)";
  m.quality = qualityName(a.quality.quality);
  m.quality_reason = a.quality.reason;
  m.notes = a.notes;
  return m;
}

int level(bool warn, bool error) {
  return error ? diagnostic_msgs::DiagnosticStatus::ERROR
               : warn ? diagnostic_msgs::DiagnosticStatus::WARN : diagnostic_msgs::DiagnosticStatus::OK;
}

}  // namespace

AnalyzerParams loadAnalyzerParams(const ros::NodeHandle& pnh, std::vector<std::string>* problems) {
  AnalyzerParams p;
  const AnalyzerParams def;
  ParamReader r(pnh, problems);
  auto invalid = [&](const std::string& name, const std::string& rule, const std::string& used) {
    problems->push_back("parameter ~" + name + " " + rule + ": " + used + " used");
  };
  OnlineOptions& o = p.online;
  r.get("window_s", &o.window_s);
  if (!(o.window_s > 0) || o.window_s > 1e6) invalid("window_s", "must be in (0, 1e6] s", "3600"), o.window_s = 3600;
  r.get("hop_s", &o.hop_s);
  if (!(o.hop_s > 0) || o.hop_s > o.window_s) {
    invalid("hop_s", "must be in (0, window_s]", "min(300, window_s)");
    o.hop_s = std::min(300.0, o.window_s);
  }
  int min_fit = static_cast<int>(o.min_samples);
  r.get("min_fit_samples", &min_fit);
  if (min_fit < 10) invalid("min_fit_samples", "must be >= 10", "1000"), min_fit = 1000;
  o.min_samples = min_fit;
  r.get("update_s", &o.update_s);
  if (!(o.update_s >= 0) || o.update_s > 1e6) invalid("update_s", "must be in [0, 1e6] s", "5"), o.update_s = 5;
  r.get("input", &p.input);
  if (p.input != "imu" && p.input != "angle" && p.input != "auto")
    invalid("input", "must be imu, angle or auto", "auto"), p.input = "auto";
  r.get("angle_mode", &p.angle_mode);
  if (p.angle_mode != "accumulated" && p.angle_mode != "increment")
    invalid("angle_mode", "must be accumulated or increment", "accumulated"), p.angle_mode = "accumulated";
  AnalysisOptions& ao = o.pipeline.analysis;
  r.get("tau_grid", &p.tau_grid);
  std::string err;
  if (!parseTauGrid(p.tau_grid, &ao.deviation.grid, &err)) {
    invalid("tau_grid", "(" + err + ")", "log:10");
    p.tau_grid = "log:10";
    parseTauGrid(p.tau_grid, &ao.deviation.grid, &err);
  }
  r.get("confidence", &ao.deviation.confidence);
  if (!(ao.deviation.confidence > 0 && ao.deviation.confidence < 1))
    invalid("confidence", "must be in (0, 1)", "0.683"), ao.deviation.confidence = 0.683;
  std::string method = methodName(p.method);
  r.get("method", &method);
  if (!parseRequestedMethod(method, &p.method))
    invalid("method", "must be auto, joint_fit or wavelet_split", "auto"), p.method = Method::Auto;
  ao.method = p.method;
  r.get("wavelet_split", &ao.wavelet_split);
  if (p.method == Method::WaveletSplit && !ao.wavelet_split)
    invalid("wavelet_split", "false contradicts method wavelet_split", "true"), ao.wavelet_split = true;
  r.get("model_check", &ao.model_check);
  r.get("gmwm", &ao.gmwm);
  r.get("filter_rate", &p.filter_rate);
  if (!(p.filter_rate >= 0) || p.filter_rate > 1e6)
    invalid("filter_rate", "must be in [0, 1e6] Hz", "0 (data rate only)"), p.filter_rate = 0;
  if (p.filter_rate > 0) ao.gmwm = true;  // as analyze_bag --filter-rate implies --method gmwm
  r.get("rest_check", &o.pipeline.rest_check);
  r.get("spike_z", &p.spike_z);
  if (!(p.spike_z >= 0)) invalid("spike_z", "must be >= 0", "10"), p.spike_z = 10;
  ao.remove_spikes = p.spike_z > 0;
  if (p.spike_z > 0) ao.spikes.z = p.spike_z;
  r.get("gap_factor", &o.pipeline.sanitize.gap_factor);
  if (!(o.pipeline.sanitize.gap_factor > 1)) invalid("gap_factor", "must be > 1", "1.5"), o.pipeline.sanitize.gap_factor = 1.5;
  r.get("expected_rate_hz", &o.pipeline.sanitize.nominal_rate_hz);
  if (!(o.pipeline.sanitize.nominal_rate_hz >= 0))
    invalid("expected_rate_hz", "must be >= 0", "0 (estimated from the stamps)"), o.pipeline.sanitize.nominal_rate_hz = 0;
  r.get("accel", &o.pipeline.accel);
  int jobs = 2;
  r.get("jobs", &jobs);
  if (jobs < 0 || jobs > 64) invalid("jobs", "must be in 0..64", "2"), jobs = 2;
  o.pipeline.jobs = jobs;
  r.get("publish_curves", &p.publish_curves);
  r.get("publish_plot", &p.publish_plot);
  r.get("plot_width", &p.plot_width);
  r.get("plot_height", &p.plot_height);
  if (p.plot_width < 200 || p.plot_height < 150 || p.plot_width > 4096 || p.plot_height > 4096) {
    invalid("plot_width/plot_height", "must be 200..4096 x 150..4096", "800 x 600");
    p.plot_width = def.plot_width, p.plot_height = def.plot_height;
  }
  r.get("hardware_id", &p.hardware_id);
  r.get("diagnostic_period", &p.diagnostic_period);
  if (!(p.diagnostic_period > 0)) invalid("diagnostic_period", "must be > 0", "1"), p.diagnostic_period = 1;
  r.get("diag/recent_s", &p.recent_s);
  if (!(p.recent_s > 0)) invalid("diag/recent_s", "must be > 0", "10"), p.recent_s = 10;
  r.get("rms_log10_warn", &p.rms_log10_warn);
  r.get("rms_log10_error", &p.rms_log10_error);
  if (!(p.rms_log10_warn > 0) || p.rms_log10_error < p.rms_log10_warn) {
    invalid("rms_log10_warn/rms_log10_error", "must be 0 < warn <= error", "0.1 / 0.3");
    p.rms_log10_warn = def.rms_log10_warn, p.rms_log10_error = def.rms_log10_error;
  }
  for (int t = 0; t < kNumTerms; ++t) {
    const std::string key = std::string("spec/") + noiseTermKey(t);
    r.get(key + "_warn", &p.spec_warn[t]);
    r.get(key + "_error", &p.spec_error[t]);
    if (p.spec_warn[t] < 0 || p.spec_error[t] < 0) {
      invalid(key + "_warn/_error", "must be >= 0", "0 (no threshold)");
      p.spec_warn[t] = p.spec_error[t] = 0;
    }
  }
  r.get("save_dir", &p.save_dir);
  r.get("kalibr_axis", &p.kalibr_axis);
  if (p.kalibr_axis != "worst" && p.kalibr_axis != "mean") invalid("kalibr_axis", "must be worst or mean", "worst"), p.kalibr_axis = "worst";
  r.get("queue_size", &p.queue_size);
  if (p.queue_size < 1) invalid("queue_size", "must be >= 1", "10000"), p.queue_size = 10000;
  r.checkUnknown();
  o.validate();
  return p;
}

std::string applyConfig(AnalyzerConfig& c, AnalyzerParams* p) {
  if (c.hop_s > c.window_s) c.hop_s = c.window_s;  // a shorter window brings the hop down with it
  AnalyzerParams n = *p;
  n.online.window_s = c.window_s;
  n.online.hop_s = c.hop_s;
  n.online.update_s = c.update_s;
  if (!parseRequestedMethod(c.method, &n.method)) return "method must be auto, joint_fit or wavelet_split";
  n.online.pipeline.analysis.method = n.method;
  n.online.pipeline.analysis.wavelet_split = c.wavelet_split;
  n.online.pipeline.analysis.model_check = c.model_check;
  if (c.filter_rate > 0) c.gmwm = true;  // a filter rate implies the GMWM stage (as analyze_bag --filter-rate)
  n.online.pipeline.analysis.gmwm = c.gmwm;
  n.filter_rate = c.filter_rate;
  n.online.pipeline.rest_check = c.rest_check;
  n.rms_log10_warn = c.rms_log10_warn;
  n.rms_log10_error = c.rms_log10_error;
  if (n.method == Method::WaveletSplit && !c.wavelet_split) return "method wavelet_split needs wavelet_split";
  if (!(n.rms_log10_warn > 0) || n.rms_log10_error < n.rms_log10_warn) return "rms_log10_warn/error must be 0 < warn <= error";
  if (!(n.filter_rate >= 0) || n.filter_rate > 1e6) return "filter_rate must be in [0, 1e6] Hz";
  try {
    n.online.validate();
  } catch (const std::exception& e) {
    return e.what();
  }
  *p = n;
  return "";
}

AnalyzerConfig toConfig(const AnalyzerParams& p) {
  AnalyzerConfig c;
  c.window_s = p.online.window_s;
  c.hop_s = p.online.hop_s;
  c.update_s = p.online.update_s;
  c.method = methodName(p.method);
  c.wavelet_split = p.online.pipeline.analysis.wavelet_split;
  c.model_check = p.online.pipeline.analysis.model_check;
  c.gmwm = p.online.pipeline.analysis.gmwm;
  c.filter_rate = p.filter_rate;
  c.rest_check = p.online.pipeline.rest_check;
  c.rms_log10_warn = p.rms_log10_warn;
  c.rms_log10_error = p.rms_log10_error;
  return c;
}

double meanTemperature(const OnlineJob& job) {
  double sum = 0;
  int64_t n = 0;
  for (double c : job.input.temperature)
    if (std::isfinite(c)) sum += c, ++n;
  return n ? sum / static_cast<double>(n) : kNaN;
}

NoiseReport toNoiseReport(const OnlineResult& r, const AnalyzerParams& p, const std::string& frame_id,
                          double mean_temperature) {
  NoiseReport m;
  m.header.stamp = fromNs(r.last_ns);
  m.header.frame_id = frame_id;
  m.method = methodName(p.method);
  m.deviation = "oadev";
  m.window_start = fromNs(r.first_ns);
  m.window_end = fromNs(r.last_ns);
  m.window_s = p.online.window_s;
  m.temperature = mean_temperature;
  const PipelineResult& pr = r.result;
  m.samples = pr.analysed();
  m.segments = pr.gyro.empty() ? 0 : pr.gyro.front().segments;
  m.rate_hz = pr.tau0 > 0 ? 1.0 / pr.tau0 : 0;
  m.fill = m.rate_hz > 0 ? std::min(1.0, static_cast<double>(m.samples) / (p.online.window_s * m.rate_hz)) : 0;
  m.at_rest_checked = pr.rest_checked;
  m.at_rest = !pr.rest_checked || pr.rest.at_rest;
  m.warnings = warningTexts(pr.warnings);
  for (const AxisAnalysis& a : pr.gyro) m.axes.push_back(toAxisMsg(a));
  return m;
}

bool hasNoiseModel(const PipelineResult& r) {
  for (const AxisAnalysis& a : r.gyro)
    if (a.has_gmwm) return true;
  return false;
}

NoiseModel toNoiseModel(const OnlineResult& r, const AnalyzerParams& p, const std::string& frame_id,
                        const std::vector<std::string>& sources) {
  NoiseModel m;
  m.header.stamp = fromNs(r.last_ns);
  m.header.frame_id = frame_id;
  m.status = NoiseModel::STATUS_CURRENT;
  m.window_start = fromNs(r.first_ns);
  m.window_end = fromNs(r.last_ns);
  m.rate_hz = r.result.tau0 > 0 ? 1.0 / r.result.tau0 : 0;
  m.filter_rate_hz = p.filter_rate;
  m.sources = sources;
  for (const AxisAnalysis& a : r.result.gyro)
    if (a.has_gmwm) m.axes.push_back(toAxisNoiseModel(a.axis, axisNoiseModel(a, p.filter_rate)));
  return m;
}

NoiseModel noiseModelOff(const ros::Time& stamp, const std::string& frame_id) {
  NoiseModel m;
  m.header.stamp = stamp;
  m.header.frame_id = frame_id;
  m.status = NoiseModel::STATUS_OFF;
  return m;
}

AllanCurve toCurve(const AxisAnalysis& a, const std_msgs::Header& header, bool quick) {
  AllanCurve cm;
  cm.header = header;
  cm.axis = a.axis;
  cm.deviation = "oadev";
  cm.quick = quick;
  cm.tau0 = a.oadev.tau0;
  for (const auto& pt : a.oadev.points) {
    cm.tau.push_back(pt.tau);
    cm.n_terms.push_back(pt.n_terms);
    cm.edf.push_back(pt.edf);
    cm.adev.push_back(pt.dev);
    cm.adev_lo.push_back(pt.dev_lo);
    cm.adev_hi.push_back(pt.dev_hi);
  }
  if (a.final_model_var.size() == a.oadev.points.size())
    for (double v : a.final_model_var) cm.model_adev.push_back(std::sqrt(std::max(0.0, v)));
  if (a.has_split && a.split.ok) {
    auto byM = [&a](const DeviationCurve& part, std::vector<double>* out) {
      for (const auto& pt : a.oadev.points) {
        double v = kNaN;
        for (const auto& q : part.points)
          if (q.m == pt.m) v = q.dev;
        out->push_back(v);
      }
    };
    byM(a.split.denoised_curve, &cm.denoised_adev);
    byM(a.split.removed_curve, &cm.removed_adev);
  }
  return cm;
}

QuickNoise toQuickNoise(const QuickAnswer& q, const std::string& frame_id, double full_age_s) {
  QuickNoise m;
  m.header.stamp = fromNs(q.newest_ns);
  m.header.frame_id = frame_id;
  m.window_start = fromNs(q.window_first_ns);
  m.samples = q.samples;
  m.segments = q.segments;
  m.rate_hz = q.tau0 > 0 ? 1.0 / q.tau0 : 0;
  m.full_age_s = full_age_s;
  for (const AxisAnalysis& a : q.axes) {
    AxisNoiseFit f = toAxisMsg(a);
    f.model_check_note = "quick answer: no model check";
    f.quality = "";
    f.quality_reason = "quick answer: the verdict comes with the full analysis on ~noise";
    m.axes.push_back(f);
  }
  return m;
}

sensor_msgs::Image plotMessage(const std::vector<AxisAnalysis>& axes, const std_msgs::Header& header,
                               const std::string& title, const std::string& note, const AnalyzerParams& p) {
  RgbImage im = renderRaster(windowFigure(axes, title, note, p.plot_width, p.plot_height));
  sensor_msgs::Image msg;
  msg.header = header;
  msg.width = static_cast<uint32_t>(im.width);
  msg.height = static_cast<uint32_t>(im.height);
  msg.encoding = "rgb8";
  msg.step = static_cast<uint32_t>(3 * im.width);
  msg.data = std::move(im.data);
  return msg;
}

std::string reportMethod(const AnalyzerParams& p) {
  return p.online.pipeline.analysis.gmwm && p.method == Method::Auto ? "gmwm" : methodName(p.method);
}

ReportMeta liveReportMeta(const AnalyzerParams& p, const std::string& topic) {
  ReportMeta meta;
  meta.sources.push_back("live topic " + topic);
  meta.topic = topic;
  const AnalysisOptions& ao = p.online.pipeline.analysis;
  meta.input = ao.input == InputKind::Rate ? "rate" : ao.angle_increments ? "angle_increment" : "angle";
  meta.input_units = ao.input == InputKind::Rate ? "rad/s" : "rad";
  meta.tau_grid = tauGridName(ao.deviation.grid);
  meta.method = reportMethod(p);
  meta.confidence = ao.deviation.confidence;
  return meta;
}

bool RecentProblems::recent(const std::string& key, int64_t total, const ros::Time& now, double recent_s) {
  auto it = last_.find(key);
  if (it == last_.end()) {
    last_[key] = {total, total > 0 ? now : ros::Time()};
    return total > 0;
  }
  if (total > it->second.first) it->second = {total, now};
  return !it->second.second.isZero() && (now - it->second.second).toSec() <= recent_s;
}

void diagStamps(const DiagState& s, const AnalyzerParams& p, RecentProblems* rp,
                diagnostic_updater::DiagnosticStatusWrapper& stat) {
  const OnlineCounters& c = s.counters;
  const ros::Time now = ros::Time::now();
  std::string recent;
  auto check = [&](const char* what, int64_t total) {
    if (rp->recent(what, total, now, p.recent_s)) recent += std::string(recent.empty() ? "" : ", ") + what;
  };
  check("out of order", c.out_of_order);
  check("duplicates", c.duplicate);
  check("too close", c.too_close);
  check("zero stamps", c.zero_stamp);
  check("gaps", c.gaps);
  if (recent.empty()) stat.summary(diagnostic_msgs::DiagnosticStatus::OK, "stamps ok");
  else stat.summary(diagnostic_msgs::DiagnosticStatus::WARN, "recent stamp problems: " + recent);
  stat.add("samples received (total)", c.samples);
  stat.add("out of order (total)", c.out_of_order);
  stat.add("duplicates (total)", c.duplicate);
  stat.add("too close (total)", c.too_close);
  stat.add("zero stamps (total)", c.zero_stamp);
  stat.add("gaps (total)", c.gaps);
  stat.add("missing samples (total)", c.missing_samples);
  stat.add("short segments dropped (total)", c.short_segment);
  stat.add("other source ignored (total)", s.other_source);
  stat.add("expected rate (Hz, 0 = from the stamps)", p.online.pipeline.sanitize.nominal_rate_hz);
  stat.add("gap factor", p.online.pipeline.sanitize.gap_factor);
  if (s.have_result && s.last.ok) {
    const StampReport& st = s.last.result.stamps;
    stat.add("nominal rate (Hz)", st.rate_hz);
    stat.add("jitter p99 (s)", st.jitter_p99_s);
    stat.add("receipt stamps", st.receipt_stamps ? "yes" : "no");
  }
}

void diagValues(const DiagState& s, const AnalyzerParams& p, RecentProblems* rp,
                diagnostic_updater::DiagnosticStatusWrapper& stat) {
  const bool nan = rp->recent("NaN/Inf", s.counters.non_finite, ros::Time::now(), p.recent_s);
  stat.summary(nan ? diagnostic_msgs::DiagnosticStatus::WARN : diagnostic_msgs::DiagnosticStatus::OK,
               nan ? "recent samples with NaN/Inf dropped" : "values ok");
  stat.add("NaN/Inf dropped (total)", s.counters.non_finite);
  stat.add("temperature readings (total)", s.counters.temperatures);
  stat.add("separate accelerometer messages (total)", s.accel_messages);
  if (s.have_result && s.last.ok) {
    for (const AxisAnalysis& a : s.last.result.gyro)
      if (a.spikes_checked) stat.add("spikes removed in window, axis " + a.axis, a.spikes.count);
    for (const Warning& w : s.last.result.warnings)
      if (w.kind == WarningKind::Saturation || w.kind == WarningKind::Spikes)
        stat.mergeSummary(diagnostic_msgs::DiagnosticStatus::WARN, w.text);
  }
}

void diagWindow(const DiagState& s, const AnalyzerParams& p, RecentProblems* rp,
                diagnostic_updater::DiagnosticStatusWrapper& stat) {
  const OnlineCounters& c = s.counters;
  const bool skipped = rp->recent("skipped hops", c.skipped_hops, ros::Time::now(), p.recent_s);
  if (s.source.empty()) stat.summary(diagnostic_msgs::DiagnosticStatus::OK, "waiting for input");
  else if (s.have_result && !s.last.ok)
    stat.summary(diagnostic_msgs::DiagnosticStatus::WARN, "window not analysable: " + s.last.error);
  else if (skipped)
    stat.summary(diagnostic_msgs::DiagnosticStatus::WARN, "hops skipped: the previous analysis was still running");
  else if (!s.have_result)
    stat.summary(diagnostic_msgs::DiagnosticStatus::OK, "filling the window (first analysis after hop_s and min_fit_samples)");
  else stat.summary(diagnostic_msgs::DiagnosticStatus::OK, "analysing");
  stat.add("input", s.source.empty() ? "none yet" : s.source);
  stat.add("window (s)", p.online.window_s);
  stat.add("hop (s)", p.online.hop_s);
  stat.add("samples in window", s.window_samples);
  stat.add("window span (s)", s.window_span_s);
  stat.add("analyses (total)", c.analyses);
  stat.add("not analysable (total)", c.failed);
  stat.add("hops skipped, analysis busy (total)", c.skipped_hops);
  stat.add("samples aged out uncounted (total)", c.aged_out);
  if (s.have_good) stat.add("analysed samples (last)", s.last_report.samples);
}

void diagParams(const DiagState& s, diagnostic_updater::DiagnosticStatusWrapper& stat) {
  if (s.param_problems.empty()) return stat.summary(diagnostic_msgs::DiagnosticStatus::OK, "parameters ok");
  stat.summary(diagnostic_msgs::DiagnosticStatus::WARN,
               std::to_string(s.param_problems.size()) + " parameter problems (defaults used): " + s.param_problems.front());
  for (size_t i = 0; i < s.param_problems.size(); ++i) stat.add("problem " + std::to_string(i + 1), s.param_problems[i]);
}

void diagMotion(const DiagState& s, diagnostic_updater::DiagnosticStatusWrapper& stat) {
  if (!s.have_result || !s.last.ok) {
    if (s.have_result && s.last.not_at_rest)
      stat.summary(diagnostic_msgs::DiagnosticStatus::WARN, s.last.error);
    else stat.summary(diagnostic_msgs::DiagnosticStatus::OK, "no analysis yet");
    return;
  }
  const PipelineResult& r = s.last.result;
  if (!r.rest_checked) stat.summary(diagnostic_msgs::DiagnosticStatus::OK, "at-rest check off (~rest_check or angle input)");
  else if (r.rest.at_rest) stat.summary(diagnostic_msgs::DiagnosticStatus::OK, r.rest.reason);
  else {
    char buf[200];
    std::snprintf(buf, sizeof buf, "not at rest (%s): only %.1f-%.1f s of the window analysed", r.rest.reason.c_str(),
                  r.rest_from_s, r.rest_to_s);
    stat.summary(diagnostic_msgs::DiagnosticStatus::WARN, buf);
  }
  stat.add("moving fraction", r.rest.moving_fraction);
}

void diagFit(const DiagState& s, const AnalyzerParams& p, diagnostic_updater::DiagnosticStatusWrapper& stat) {
  if (!s.have_good) return stat.summary(diagnostic_msgs::DiagnosticStatus::OK, "no fit yet");
  int worst = 0;
  for (const AxisNoiseFit& a : s.last_report.axes) {
    const int l = !a.fit_ok ? diagnostic_msgs::DiagnosticStatus::ERROR
                            : level(a.rms_log10 > p.rms_log10_warn, a.rms_log10 > p.rms_log10_error);
    worst = std::max(worst, l);
    stat.add("rms_log10 " + a.axis, a.rms_log10);
    if (a.model_checked) {
      stat.add("rms_log10 before model check " + a.axis, a.rms_log10_before);
      stat.add("rms_log10 after model check " + a.axis, a.rms_log10_after);
      std::string effects;
      for (const AddedEffect& e : a.effects) effects += (effects.empty() ? "" : ", ") + e.type;
      stat.add("effects " + a.axis, effects.empty() ? "none" : effects);
    } else {
      stat.add("model check " + a.axis, a.model_check_note);
    }
  }
  stat.summary(static_cast<unsigned char>(worst), worst ? "fit error above ~rms_log10_warn" : "fit ok");
}

void diagNoiseModel(const DiagState& s, const AnalyzerParams& p, diagnostic_updater::DiagnosticStatusWrapper& stat) {
  stat.add("filter rate (Hz, 0 = data rate only)", p.filter_rate);
  if (!p.online.pipeline.analysis.gmwm)  // (~noise_model keeps its last message latched)
    return stat.summary(diagnostic_msgs::DiagnosticStatus::OK, "GMWM off (~gmwm)");
  if (!s.have_noise_model) return stat.summary(diagnostic_msgs::DiagnosticStatus::OK, "no noise model yet");
  std::string summary, failed;
  for (const AxisNoiseModel& a : s.last_noise_model.axes) {
    stat.add("model " + a.axis, a.ok ? a.model : "none: " + a.error);
    if (a.ok) {
      stat.add("angle random walk " + a.axis + " (rad/sqrt(s))", a.continuous.angle_random_walk.value);
      for (size_t k = 0; k < a.continuous.gauss_markov.size(); ++k) {
        const std::string gm = "gm" + std::to_string(k + 1) + " " + a.axis;
        stat.add(gm + " sigma (rad/s)", a.continuous.gauss_markov[k].sigma.value);
        stat.add(gm + " correlation time (s)", a.continuous.gauss_markov[k].correlation_time.value);
      }
      if (parseGmwmModel(a.model).random_walk)
        stat.add("rate random walk " + a.axis + " (rad/s/sqrt(s))", a.continuous.rate_random_walk.value);
    } else {
      failed += (failed.empty() ? "" : ", ") + a.axis;
    }
    summary += (summary.empty() ? "" : ", ") + a.axis + " " + (a.ok ? a.model : "none");
  }
  if (!failed.empty())
    stat.summary(diagnostic_msgs::DiagnosticStatus::WARN, "no GMWM model on axis " + failed + " (" + summary + ")");
  else stat.summary(diagnostic_msgs::DiagnosticStatus::OK, summary.empty() ? "no gyro axis" : summary);
}

void diagQuality(const DiagState& s, diagnostic_updater::DiagnosticStatusWrapper& stat) {
  if (!s.have_good) return stat.summary(diagnostic_msgs::DiagnosticStatus::OK, "no verdict yet");
  int worst = 0;
  std::string msg;
  for (const AxisNoiseFit& a : s.last_report.axes) {
    const int l = a.quality == "bad" ? diagnostic_msgs::DiagnosticStatus::ERROR
                  : a.quality == "good" ? diagnostic_msgs::DiagnosticStatus::OK : diagnostic_msgs::DiagnosticStatus::WARN;
    if (l > worst) worst = l, msg = "axis " + a.axis + ": " + a.quality + " (" + a.quality_reason + ")";
    stat.add("verdict " + a.axis, a.quality + ": " + a.quality_reason);
  }
  stat.summary(static_cast<unsigned char>(worst), worst ? msg : "all axes good");
}

void diagAnswers(const DiagState& s, const AnalyzerParams& p, diagnostic_updater::DiagnosticStatusWrapper& stat) {
  auto age = [&s](int64_t ns) { return 1e-9 * static_cast<double>(s.newest_ns - ns); };
  const double full_age = s.have_good ? age(s.last_report.window_end.toNSec()) : -1;
  const double quick_age = s.have_quick ? age(s.last_quick.header.stamp.toNSec()) : -1;
  char buf[200];
  std::string full = s.have_good ? (std::snprintf(buf, sizeof buf, "full answer %.0f s old", full_age), buf)
                                 : "no full answer yet (first after hop_s " + std::to_string(static_cast<int>(p.online.hop_s)) + " s)";
  std::string quick;
  if (p.online.update_s <= 0) quick = "quick answers off (update_s 0)";
  else if (s.have_quick) quick = (std::snprintf(buf, sizeof buf, "quick answer %.1f s old", quick_age), buf);
  else quick = "no quick answer yet (first after min_fit_samples " + std::to_string(p.online.min_samples) + " samples)";
  stat.summary(diagnostic_msgs::DiagnosticStatus::OK, full + ", " + quick);
  stat.add("full answer", "~noise and ~allan/* with quick: false; the whole pipeline every hop_s");
  stat.add("full answer: age [s, input time]", s.have_good ? std::to_string(full_age) : "none");
  stat.add("quick answer", "~quick and ~allan/* with quick: true; the window's oadev kept per sample, IEEE fit every update_s");
  stat.add("quick answer: age [s, input time]", s.have_quick ? std::to_string(quick_age) : "none");
  stat.add("quick answer: period update_s [s]", p.online.update_s);
  if (s.have_quick)
    for (const AxisNoiseFit& a : s.last_quick.axes)
      if (a.fit_ok)
        stat.add("quick N " + a.axis + " [deg/sqrt(h)]", a.angle_random_walk.value * conventionalFactor(kAngleRandomWalk));
}

void diagTerm(int term, const DiagState& s, const AnalyzerParams& p, diagnostic_updater::DiagnosticStatusWrapper& stat) {
  if (!s.have_good) return stat.summary(diagnostic_msgs::DiagnosticStatus::OK, "no fit yet");
  int worst = 0;
  for (const AxisNoiseFit& a : s.last_report.axes) {
    const NoiseCoefficient* c[kNumTerms] = {&a.quantization, &a.angle_random_walk, &a.bias_instability,
                                            &a.rate_random_walk, &a.rate_ramp};
    const double v = c[term]->value;
    worst = std::max(worst, level(p.spec_warn[term] > 0 && v > p.spec_warn[term],
                                  p.spec_error[term] > 0 && v > p.spec_error[term]));
    stat.add(a.axis + " (SI)", v);
    stat.add(a.axis + " sigma (SI)", c[term]->sigma);
    stat.add(a.axis + " (" + std::string(conventionalUnit(term)) + ")", v * conventionalFactor(term));
  }
  stat.summary(static_cast<unsigned char>(worst), worst ? "above the ~spec threshold" : "within spec");
}

}  // namespace gyro_allan
