// One-axis analysis pipeline: validate, compute deviations over gap-free segments, fit the IEEE 952 model.
#include "gyro_allan/analysis.hpp"

#include <cmath>
#include <exception>
#include <stdexcept>
#include <thread>

namespace gyro_allan {

double conventionalFactor(int term) {
  const double deg = 180.0 / M_PI;
  switch (term) {
    case kQuantization: return deg * 3600.0;              // rad -> arcsec
    case kAngleRandomWalk: return deg * 60.0;             // rad/sqrt(s) -> deg/sqrt(h)
    case kBiasInstability: return deg * 3600.0;           // rad/s -> deg/h
    case kRateRandomWalk: return deg * 3600.0 * 60.0;     // rad/s/sqrt(s) -> deg/h/sqrt(h)
    case kRateRamp: return deg * 3600.0 * 3600.0;         // rad/s^2 -> deg/h^2
    default: return 1.0;
  }
}

const char* conventionalUnit(int term) {
  static const char* units[] = {"arcsec", "deg/sqrt(h)", "deg/h", "deg/h/sqrt(h)", "deg/h^2"};
  return (term >= 0 && term < kNumTerms) ? units[term] : "";
}

void enforceRedderWithTau(DeviationCurve* curve, double confidence) {
  bool changed = false;
  for (size_t i = 1; i < curve->points.size(); ++i) {
    if (curve->points[i].alpha > curve->points[i - 1].alpha) {
      curve->points[i].alpha = curve->points[i - 1].alpha;
      changed = true;
    }
  }
  if (changed) fillConfidence(curve, confidence);
}

AxisAnalysis analyzeAxis(const std::string& axis, const std::vector<std::vector<double>>& segments, double tau0,
                         const AnalysisOptions& options, const std::vector<std::vector<double>>* temperature) {
  if (options.method != "auto" && options.method != "joint_fit" && options.method != "wavelet_split")
    throw std::invalid_argument("unknown method '" + options.method + "' (auto, joint_fit, wavelet_split)");
  if (options.method == "wavelet_split" && !options.wavelet_split)
    throw std::invalid_argument("method wavelet_split needs the wavelet split enabled");
  if (!(tau0 > 0) || !std::isfinite(tau0)) throw std::invalid_argument("sample interval must be positive and finite");
  if (!(options.deviation.confidence > 0 && options.deviation.confidence < 1))
    throw std::invalid_argument("confidence must be in (0, 1)");
  for (const auto& d : options.deviations)
    if (!isDeviationName(d)) throw std::invalid_argument("unknown deviation '" + d + "'");
  AxisAnalysis a;
  a.axis = axis;
  a.rate_hz = 1.0 / tau0;
  long double sum = 0;
  for (const auto& s : segments) {
    if (s.empty()) continue;
    ++a.segments;
    a.samples += static_cast<int64_t>(s.size());
    for (double v : s) {
      if (!std::isfinite(v)) throw std::invalid_argument("axis " + axis + ": non-finite sample");
      sum += v;
    }
  }
  if (a.samples < 3) throw std::invalid_argument("axis " + axis + ": too few samples (" + std::to_string(a.samples) + ")");
  a.mean = static_cast<double>(sum / a.samples);
  a.duration_s = static_cast<double>(a.samples) * tau0;
  a.oadev = computeDeviation("oadev", segments, options.input, tau0, options.deviation);
  const DeviationCurve raw_oadev = a.oadev;  // as computed, for the wavelet split's own fit error
  enforceRedderWithTau(&a.oadev, options.deviation.confidence);
  if (a.oadev.points.empty())
    throw std::invalid_argument("axis " + axis + ": record too short for any Allan-variance point");
  for (const auto& d : options.deviations)
    if (d == "oadev") {
      a.curves.push_back(a.oadev);
    } else {
      a.curves.push_back(computeDeviation(d, segments, options.input, tau0, options.deviation));
      enforceRedderWithTau(&a.curves.back(), options.deviation.confidence);
    }
  {
    // Fit weights: two passes, the second with each point's EDF from the noise type of the dominating model term
    // (as the nodelet does); the curve written out keeps its own (identified) EDFs and bounds.
    DeviationCurve weighted = a.oadev;
    a.fit = fitWithModelEdf(&weighted, options.fit, options.deviation.confidence);
  }

  // Stages that need contiguous raw samples run on the longest gap-free segment.
  size_t longest = 0;
  for (size_t i = 1; i < segments.size(); ++i)
    if (segments[i].size() > segments[longest].size()) longest = i;
  const std::vector<double>& rate_seg = segments[longest];
  if (a.segments > 1)
    a.notes.push_back("wavelet split and model check use the longest gap-free segment (" +
                      std::to_string(rate_seg.size()) + " of " + std::to_string(a.samples) + " samples)");
  const bool rate_input = options.input == InputKind::Rate;
  if (!rate_input && (options.wavelet_split || options.model_check))
    a.notes.push_back("wavelet split and model check need rate samples: skipped for angle input");
  std::exception_ptr split_error;
  auto runSplit = [&]() {
    WaveletSplitOptions so = options.split;
    so.deviation = options.deviation;
    try {
      // One gap-free segment: the split's curve of the raw samples is the one just computed (saves an oadev pass).
      a.split = waveletSplit(rate_seg, tau0, so, a.segments == 1 ? &raw_oadev : nullptr);
      a.has_split = true;
    } catch (const std::invalid_argument& e) {
      a.split.message = e.what();
    } catch (...) {
      split_error = std::current_exception();  // rethrown after the join
    }
  };
  std::thread split_thread;
  const bool run_split = rate_input && options.wavelet_split;
  if (run_split && options.concurrent_stages && options.model_check) split_thread = std::thread(runSplit);
  else if (run_split) runSplit();
  // The model check writes only a.check / a.has_check; the split thread only a.split / a.has_split; notes are
  // added after the join, in a fixed order.
  std::string check_note;
  if (rate_input && options.model_check && a.fit.ok) {
    ModelCheckOptions co = options.check;
    co.fit = options.fit;
    const std::vector<double>* temp = nullptr;
    if (temperature && longest < temperature->size() && (*temperature)[longest].size() == rate_seg.size())
      temp = &(*temperature)[longest];
    try {
      a.check = checkModel(rate_seg, tau0, a.oadev, a.fit, co, temp);
      a.has_check = a.check.ok;
      if (!a.check.ok) check_note = "model check: " + a.check.message;
    } catch (const std::invalid_argument& e) {
      check_note = std::string("model check skipped: ") + e.what();
    } catch (...) {
      if (split_thread.joinable()) split_thread.join();
      throw;
    }
  }
  if (split_thread.joinable()) split_thread.join();
  if (split_error) std::rethrow_exception(split_error);
  if (run_split) {
    if (!a.has_split) a.notes.push_back("wavelet split skipped: " + a.split.message);
    else if (!a.split.ok) a.notes.push_back("wavelet split: " + a.split.message);
  }
  if (!check_note.empty()) a.notes.push_back(check_note);

  // The answer.
  const bool split_ok = a.has_split && a.split.ok;
  std::string method = options.method;
  if (method == "auto") {
    // Quantization-limited gyros (RLG/FOG pulse outputs): where 3Q^2/tau^2 is most of the AVAR at the shortest tau the
    // Allan fit trades Q against N, and the wavelet split separates them by scale (docs/wavelet_split.md).
    const auto& q = a.fit.terms[kQuantization];
    const double q_share = a.oadev.points.empty() || !q.supported
                               ? 0.0
                               : termVariance(a.fit, kQuantization, a.oadev.points.front().tau) / a.oadev.points.front().var;
    if (split_ok && q_share >= 0.5) {
      method = "wavelet_split";
      a.method_reason = "quantization is " + std::to_string(static_cast<int>(100 * q_share)) +
                        " % of the Allan variance at the shortest tau";
    } else {
      method = "joint_fit";
      a.method_reason = split_ok ? "quantization does not dominate the shortest tau" : "wavelet split not available";
    }
  } else {
    a.method_reason = "requested";
  }
  if (method == "wavelet_split" && !split_ok)
    throw std::invalid_argument("axis " + axis + ": wavelet split failed: " + (a.has_split ? a.split.message : "not run"));
  a.method = method;
  a.final_model_var.resize(a.oadev.points.size());
  if (method == "wavelet_split") {
    a.coefficients = a.split.terms;
    FitResult tmp;
    tmp.terms = a.split.terms;
    for (size_t i = 0; i < a.oadev.points.size(); ++i) a.final_model_var[i] = modelVariance(tmp, a.oadev.points[i].tau);
    int n_params = 0;
    for (const auto& c : a.split.terms) n_params += c.supported ? 1 : 0;
    a.final_error = fitError(a.oadev, a.final_model_var, a.fit.used, n_params, options.fit.rms_min_edf);
  } else if (a.has_check && !a.check.effects.empty()) {
    a.coefficients = a.check.fit_after.terms;
    a.final_model_var = a.check.fit_after.model_var;
    a.final_error = {a.check.after.rms_log10, a.check.after.chi2_dof, a.check.fit_after.n_rms};
  } else {
    a.coefficients = a.fit.terms;
    a.final_model_var = a.fit.model_var;
    a.final_error = {a.fit.rms_log10, a.fit.chi2_dof, a.fit.n_rms};
  }
  return a;
}

}  // namespace gyro_allan
