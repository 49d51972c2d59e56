// One-axis analysis pipeline: validate, compute deviations over gap-free segments, fit the IEEE 952 model.
#include "gyro_allan/analysis.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
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

void angleToRate(std::vector<double>* segment, double tau0, bool increments) {
  std::vector<double>& v = *segment;
  if (increments) {
    for (double& x : v) x /= tau0;
    return;
  }
  if (v.size() < 2) {
    v.clear();
    return;
  }
  for (size_t k = 0; k + 1 < v.size(); ++k) v[k] = (v[k + 1] - v[k]) / tau0;
  v.pop_back();
}

AxisStages::AxisStages(std::string axis, std::vector<std::vector<double>> segments, double tau0,
                       const AnalysisOptions& options, const std::vector<std::vector<double>>* temperature)
    : axis_(std::move(axis)), segments_(std::move(segments)), tau0_(tau0), options_(options), temperature_(temperature) {}

void AxisStages::prepare() {
  const std::string& axis = axis_;
  const std::vector<std::vector<double>>& segments = segments_;
  const double tau0 = tau0_;
  const AnalysisOptions& options = options_;
  AxisAnalysis& a = a_;
  if (options.method == Method::PulseTimes || options.method == Method::QuickFit)
    throw std::invalid_argument(std::string("method ") + methodName(options.method) +
                                " cannot be requested (auto, joint_fit, wavelet_split)");
  if (options.method == Method::WaveletSplit && !options.wavelet_split)
    throw std::invalid_argument("method wavelet_split needs the wavelet split enabled");
  if (!(tau0 > 0) || !std::isfinite(tau0)) throw std::invalid_argument("sample interval must be positive and finite");
  if (!(options.deviation.confidence > 0 && options.deviation.confidence < 1))
    throw std::invalid_argument("confidence must be in (0, 1)");
  for (const auto& d : options.deviations)
    if (!isDeviationName(d)) throw std::invalid_argument("unknown deviation '" + d + "'");
  const bool spikes_on = options.remove_spikes && options.input == InputKind::Rate;
  if (spikes_on) validateSpikeOptions(options.spikes);
  double lattice_tol = 0;  // quantized-output detection: what storing an accumulated angle may have rounded
  if (options.input == InputKind::Angle) {
    // From here on the samples are rates (in place, no copy): every stage runs as for rate input.
    for (auto& s : segments_) angleToRate(&s, tau0, options.angle_increments);
    angle_points_ = !options.angle_increments;
    if (angle_points_) {
      // An accumulated angle read through the 4-byte sample storage (compact_series.hpp) is rounded by up to 2^-24 of
      // its change since its block's first sample (4096 samples), so a difference of two of them by up to 2^-23 of
      // 4096 tau0 max|rate|, over tau0: 2^-11 max|rate|. Off the pulse lattice by that much, an RLG's accumulated
      // pulse count was not recognised as one (it is ~5e-4 of the quantum for a counter of one pulse per sample).
      double max_abs = 0;
      for (const auto& s : segments_)
        for (double v : s)
          if (std::isfinite(v)) max_abs = std::max(max_abs, std::fabs(v));
      lattice_tol = std::ldexp(max_abs, -11);
    }
  }
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
  a.quantized = detectQuantizedOutput(segments, tau0, lattice_tol);  // before spike removal
  if (spikes_on && isPulseCount(a.quantized)) {
    // A pulse counter whose noise is below one count (>= 90 % of samples on the two counts around the mean): each
    // pulse is an isolated jump of one count and the spike rule would take every one of them (2 % of an undithered
    // RLG's samples, leaving N 1e-12 of the truth).
    a.notes.push_back("spike removal skipped: the output is a pulse count (" + a.quantized.summary + ")");
  } else if (spikes_on) {
    removeSegmentSpikes();
  }
  a.oadev = computeDeviation("oadev", segments, InputKind::Rate, tau0, options.deviation);
  raw_oadev_ = a.oadev;  // as computed, for the wavelet split's own fit error
  enforceRedderWithTau(&a.oadev, options.deviation.confidence);
  if (a.oadev.points.empty())
    throw std::invalid_argument("axis " + axis + ": record too short for any Allan-variance point");
  for (const auto& d : options.deviations)
    if (d == "oadev") {
      a.curves.push_back(a.oadev);
    } else {
      a.curves.push_back(computeDeviation(d, segments, InputKind::Rate, tau0, options.deviation));
      enforceRedderWithTau(&a.curves.back(), options.deviation.confidence);
    }
  {
    // Fit weights: two passes, the second with each point's EDF from the noise type of the dominating model term
    // (as the nodelet does); the curve written out keeps its own (identified) EDFs and bounds.
    DeviationCurve weighted = a.oadev;
    a.fit = fitWithModelEdf(&weighted, options.fit, options.deviation.confidence);
  }
  if (a.has_with_spikes && a.fit.ok) {
    const Coefficient &with = a.coefficients_with_spikes[kAngleRandomWalk], &without = a.fit.terms[kAngleRandomWalk];
    char buf[200];
    if (with.supported && without.supported && without.value > 0)
      std::snprintf(buf, sizeof buf, "with the spikes, the joint fit's N would be %.4g (x%.3g of %.4g without them)",
                    with.value, with.value / without.value, without.value);
    else
      std::snprintf(buf, sizeof buf, "with the spikes, the joint fit's N would be %s",
                    with.supported ? std::to_string(with.value).c_str() : "unsupported");
    a.notes.push_back(buf);
  }


  // Stages that need contiguous raw samples run on the longest gap-free segment.
  for (size_t i = 1; i < segments.size(); ++i)
    if (segments[i].size() > segments[longest_].size()) longest_ = i;
  if (a.segments > 1) {
    a.notes.push_back("wavelet split and model check use the longest gap-free segment (" +
                      std::to_string(segments[longest_].size()) + " of " + std::to_string(a.samples) + " samples)");
    a.check_notes.push_back(a.notes.back());
  }
  prepared_ = true;
}

void AxisStages::removeSegmentSpikes() {
  AxisAnalysis& a = a_;
  const AnalysisOptions& options = options_;
  // Detection first (samples untouched: the with-spikes fit needs them, and no second copy is made), then the fit of
  // the untouched samples when there is anything to remove, then the replacement in place.
  std::vector<std::vector<SpikeRun>> runs(segments_.size());
  std::vector<SpikeReport> reports(segments_.size());
  int64_t found = 0;
  for (size_t i = 0; i < segments_.size(); ++i) {
    if (segments_[i].empty()) continue;
    reports[i] = detectSpikes(segments_[i], options.spikes, &runs[i]);
    found += reports[i].count;
  }
  if (found > 0) {
    DeviationCurve c = computeDeviation("oadev", segments_, InputKind::Rate, tau0_, options.deviation);
    enforceRedderWithTau(&c, options.deviation.confidence);
    if (!c.points.empty()) {
      const FitResult f = fitWithModelEdf(&c, options.fit, options.deviation.confidence);
      if (f.ok) {
        a.has_with_spikes = true;
        a.coefficients_with_spikes = f.terms;
        a.error_with_spikes = {f.rms_log10, f.chi2_dof, f.n_rms};
      }
    }
    long double sum = 0;
    for (size_t i = 0; i < segments_.size(); ++i) {
      if (!runs[i].empty()) applySpikeRuns(runs[i], &segments_[i], &reports[i]);
      for (double v : segments_[i]) sum += v;
    }
    a.mean = static_cast<double>(sum / a.samples);
  }
  int64_t offset = 0;
  for (size_t i = 0; i < segments_.size(); ++i) {
    if (!segments_[i].empty()) a.spikes.merge(reports[i], offset, options.spikes.max_listed);
    offset += static_cast<int64_t>(segments_[i].size());
  }
  a.spikes_checked = true;
  if (found == 0) return;
  const SpikeReport& r = a.spikes;
  char buf[400];
  std::snprintf(buf, sizeof buf,
                "%lld spikes in %lld runs (samples more than %.3g robust sigmas = %.4g from their local median, runs of "
                "<= %d) replaced by the local median%s before any deviation; excess kurtosis %.3g -> %.3g",
                static_cast<long long>(r.count), static_cast<long long>(r.runs), options.spikes.z, r.threshold,
                options.spikes.max_run, options.spikes.restore_noise ? " plus a noise draw" : "",
                r.excess_kurtosis_before, r.excess_kurtosis_after);
  a.notes.push_back(buf);  // the with-spikes comparison follows once `fit` exists (prepare)
}

namespace {

// Share of the Allan variance at the shortest tau that the joint fit gives quantization (0 when Q is not supported).
double quantizationShare(const AxisAnalysis& a) {
  const auto& q = a.fit.terms[kQuantization];
  if (a.oadev.points.empty() || !q.supported) return 0.0;
  return termVariance(a.fit, kQuantization, a.oadev.points.front().tau) / a.oadev.points.front().var;
}

// The split can be the answer (finish): requested, quantization dominating the shortest tau, a sawtooth pulse count,
// or a joint fit the data reject grossly. Elsewhere it would only cost time and memory (a quarter of a 1 h MEMS
// record's analysis) for an answer nobody reads.
bool splitCanAnswer(const AxisAnalysis& a, const AnalysisOptions& options) {
  if (options.method == Method::WaveletSplit) return true;
  if (options.method != Method::Auto) return false;
  return quantizationShare(a) >= kSplitQuantizationShare || a.quantized.sawtooth || grossMisfit(a.fit);
}

}  // namespace

void AxisStages::split() {
  if (!prepared_) throw std::logic_error("AxisStages::split before prepare");
  if (!options_.wavelet_split || !splitCanAnswer(a_, options_)) return;
  WaveletSplitOptions so = options_.split;
  so.deviation = options_.deviation;
  // The sawtooth bootstrap simulates an undithered pulse counter: only where the output was seen to be a pulse count
  // (a lattice with >= 90 % of the counts on the two levels around the mean, quantized_output.hpp; the split then
  // also has to find its quantization not white), never on a record whose quantization the split merely finds not
  // white (e.g. a MEMS sensor's internal filter). Not the sawtooth line test too: it missed 24 of 60 records at 2 deg/h
  // and ~15 of 60 at 5 deg/h (coverage_study seeds 1-60), which then kept the biased answer.
  if (!isPulseCount(a_.quantized)) so.sawtooth_replicas = 0;
  try {
    // One gap-free segment: the split's curve of the raw samples is the one just computed (saves an oadev pass).
    a_.split = waveletSplit(segments_[longest_], tau0_, so, a_.segments == 1 ? &raw_oadev_ : nullptr,
                            a_.segments == 1 && a_.fit.ok ? &a_.fit : nullptr);
    a_.has_split = true;
    if (!a_.split.ok) split_note_ = "wavelet split: " + a_.split.message;
  } catch (const std::invalid_argument& e) {
    split_note_ = std::string("wavelet split skipped: ") + e.what();
  }
}

void AxisStages::check() {
  if (!prepared_) throw std::logic_error("AxisStages::check before prepare");
  if (!options_.model_check || !a_.fit.ok) return;
  ModelCheckOptions co = options_.check;
  co.fit = options_.fit;
  const std::vector<double>& rate_seg = segments_[longest_];
  const std::vector<double>* temp = nullptr;
  std::vector<double> temp_rates;  // accumulated angle: one temperature per angle point, the rate k takes point k's
  if (temperature_ && longest_ < temperature_->size()) {
    const std::vector<double>& ts = (*temperature_)[longest_];
    if (ts.size() == rate_seg.size()) {
      temp = &ts;
    } else if (angle_points_ && ts.size() == rate_seg.size() + 1) {
      temp_rates.assign(ts.begin(), ts.end() - 1);
      temp = &temp_rates;
    }
  }
  try {
    a_.check = checkModel(rate_seg, tau0_, a_.oadev, a_.fit, co, temp);
    a_.has_check = a_.check.ok;
    if (!a_.check.ok) check_note_ = "model check: " + a_.check.message;
  } catch (const std::invalid_argument& e) {
    check_note_ = std::string("model check skipped: ") + e.what();
  }
}

// A pulse counter whose count pattern shows no sawtooth (a slow undithered counter, e.g. a ring-laser gyro at
// 0.5-2 deg/h): the angle is exact at each lattice crossing, so the IEEE fit runs on the angle interpolated between
// crossings, from a few crossing intervals up (its Q term absorbs the interpolation error; Q itself is the lattice's
// pulse weight / sqrt(12), the white-quantization equivalent the other methods report).
void AxisStages::pulseTimes() {
  AxisAnalysis& a = a_;
  const QuantizedOutput& q = a.quantized;
  if (options_.method != Method::Auto || !isPulseCount(q) || q.sawtooth) return;
  a.has_pulse_times = true;
  a.pulse_times = reconstructPulseTimes(segments_[longest_], tau0_, q);
  if (!a.pulse_times.ok) return;
  DeviationCurve c = computeDeviation("oadev", {a.pulse_times.rate}, InputKind::Rate, tau0_, options_.deviation);
  a.pulse_times.rate.clear();
  a.pulse_times.rate.shrink_to_fit();
  enforceRedderWithTau(&c, options_.deviation.confidence);
  std::vector<DeviationPoint> kept;
  for (const auto& pt : c.points)
    if (pt.tau >= a.pulse_times.tau_min_s) kept.push_back(pt);
  c.points = kept;
  if (c.points.size() < 6) {
    a.pulse_times.ok = false;
    a.pulse_times.message += "; too few Allan points above tau_min";
    return;
  }
  a.pulse_fit = fitWithModelEdf(&c, options_.fit, options_.deviation.confidence);
  a.pulse_oadev = c;
}

void AxisStages::runGmwm() {
  if (!options_.gmwm || longest_ >= segments_.size()) return;
  // The model check's stationary spectral effects (sinusoid, narrowband) enter as known terms (docs/gmwm.md).
  GmwmOptions go = options_.gmwm_options;
  std::vector<LeftOutEffect> left_out;
  if (a_.has_check && go.known.empty())
    go.known = knownTermsFromEffects(a_.check.effects, a_.check.fit_after.extra_c, &left_out);
  a_.gmwm = gmwmStage(segments_[longest_], tau0_, go);
  a_.gmwm.effects_not_in_model = left_out;
  a_.has_gmwm = true;
}

void AxisStages::noteStages() {
  AxisAnalysis& a = a_;
  if (!split_note_.empty()) a.notes.push_back(split_note_);
  if (!check_note_.empty()) {
    a.notes.push_back(check_note_);
    a.check_notes.push_back(check_note_);
  }
  if (!(a.has_split && a.split.ok)) return;
  // Where the split's Q and N came from on a pulse count whose quantization is not white (a sawtooth).
  const SawtoothBootstrap& b = a.split.sawtooth_bootstrap;
  if (b.applied) {
    char buf[320];
    std::snprintf(buf, sizeof buf,
                  "wavelet split: quantization not white (a sawtooth); Q and N corrected for the split's bias by a "
                  "parametric bootstrap (%d records simulated from the fitted pulse counter: Q %+.3g %%, N %+.3g %%), "
                  "Q's interval from their scatter",
                  b.replicas, 100.0 * (a.split.terms[kQuantization].value / std::sqrt(b.q2_raw) - 1.0),
                  100.0 * (a.split.terms[kAngleRandomWalk].value / std::sqrt(b.n2_raw) - 1.0));
    a.notes.push_back(buf);
  } else if (!b.note.empty()) {
    a.notes.push_back("wavelet split, sawtooth bootstrap " + b.note + "; Q and N keep the analytic allowance");
  }
}

MethodChoice AxisStages::chooseAllanMethod() const {
  const AxisAnalysis& a = a_;
  AnswerEvidence e;
  e.requested = options_.method;
  e.split_ok = a.has_split && a.split.ok;
  e.quantization_share = quantizationShare(a);
  e.sawtooth = a.quantized.sawtooth;
  e.sawtooth_hz = a.quantized.sawtooth_hz;
  e.joint = &a.fit;
  e.denoised = e.split_ok && a.split.denoised_fit.ok ? &a.split.denoised_fit : nullptr;
  const MethodChoice c = chooseMethod(e);
  if (c.method == Method::WaveletSplit && !e.split_ok)
    throw std::invalid_argument("axis " + axis_ + ": wavelet split failed: " + (a.has_split ? a.split.message : "not run"));
  return c;
}

void AxisStages::answerWithSplit() {
  AxisAnalysis& a = a_;
  a.coefficients = a.split.terms;
  FitResult tmp;
  tmp.terms = a.split.terms;  // the curve the split fitted
  tmp.tau0 = a.oadev.tau0;    // B's column as the fits have it (noiseTermBasis)
  for (size_t i = 0; i < a.oadev.points.size(); ++i) a.final_model_var[i] = modelVariance(tmp, a.oadev.points[i].tau);
  int n_params = 0;
  for (const auto& c : a.split.terms) n_params += c.value > 0 ? 1 : 0;
  a.final_error = fitError(a.oadev, a.final_model_var, a.fit.used, n_params, options_.fit.rms_min_edf);
  const FitResult& den = a.split.denoised_fit;
  const bool raw_bad = !quality_limits::notBad(a.final_error.rms_log10, a.final_error.chi2_dof);
  // A pulse count whose pattern repeats too slowly for the sawtooth test (a counter at ~0 rate: the angle wanders
  // across a few quanta in the record, and its rounding error is neither white nor a sawtooth): nothing explains the
  // raw misfit, which then stands.
  const QuantizedOutput& qo = a.quantized;
  const bool slow_counter = isPulseCount(qo) && !qo.sawtooth && !(qo.line_to_floor > 0);
  char note[300];
  if (raw_bad && den.ok && quality_limits::notBad(den.rms_log10, den.chi2_dof) && !slow_counter) {
    // The raw Allan curve is not the IEEE model's while the denoised signal is: the removed part is not white
    // quantization (an undithered pulse count at constant rate is a sawtooth). The split's answer is judged by its
    // fit of the denoised signal; the axis is bad only when both fit badly.
    std::snprintf(note, sizeof note,
                  "fit error is that of the denoised signal: the raw Allan curve misfits the split's model "
                  "(rms_log10 %.3g, chi2/dof %.3g), as for non-white (sawtooth) quantization",
                  a.final_error.rms_log10, a.final_error.chi2_dof);
    a.notes.push_back(note);
    a.final_error = fitErrorOf(den);
  } else if (raw_bad && slow_counter) {
    std::snprintf(note, sizeof note,
                  "the raw Allan curve misfits the split's model and the output is a pulse count that changes too "
                  "rarely for a sawtooth (mean count %.3g per sample): its rounding error is neither white nor a "
                  "sawtooth, so Q and N cannot be separated on this record",
                  qo.mean_count);
    a.notes.push_back(note);
  }
}

void AxisStages::answerWithFit(const FitResult& f) {
  a_.coefficients = f.terms;
  a_.final_model_var = f.model_var;
  a_.final_error = fitErrorOf(f);
}

// The pulse-time N (pulseTimesN); Q the lattice's pulse weight as white quantization, q / sqrt(12) (the lattice is
// refined by least squares over the whole record; its relative error is far below 1e-6, used as the interval).
void AxisStages::answerWithPulseTimes() {
  AxisAnalysis& a = a_;
  a.coefficients = a.pulse_fit.terms;
  a.coefficients[kAngleRandomWalk] = pulseTimesN(a.pulse_fit.terms[kAngleRandomWalk]);
  const double qv = a.quantized.pulse_weight / std::sqrt(12.0);
  Coefficient& cq = a.coefficients[kQuantization];
  cq.value = qv;
  cq.sigma = 1e-6 * qv;
  cq.supported = true;
  cq.lo68 = qv - cq.sigma, cq.hi68 = qv + cq.sigma, cq.lo95 = qv - 2 * cq.sigma, cq.hi95 = qv + 2 * cq.sigma;
  FitResult shown = a.pulse_fit;
  shown.terms[kQuantization] = cq;
  for (size_t i = 0; i < a.oadev.points.size(); ++i) a.final_model_var[i] = modelVariance(shown, a.oadev.points[i].tau);
  a.final_error = fitErrorOf(a.pulse_fit);
  a.notes.push_back("pulse_times: " + a.pulse_times.message +
                    "; fit error is that of the reconstructed angle's Allan curve; Q is the pulse weight / sqrt(12)");
}

void AxisStages::considerPulseTimes() {
  AxisAnalysis& a = a_;
  if (!a.has_pulse_times) return;
  if (!a.pulse_times.ok) {
    a.notes.push_back("pulse_times not used: " + a.pulse_times.message);
    return;
  }
  MethodChoice pulse;
  if (pulseTimesAnswers({a.method, a.method_reason}, a.final_error, a.pulse_fit, &pulse)) {
    a.method = pulse.method;
    a.method_reason = pulse.reason;
    answerWithPulseTimes();
    return;
  }
  const Coefficient n = pulseTimesN(a.pulse_fit.terms[kAngleRandomWalk]);
  if (a.pulse_fit.ok && n.supported && n.sigma > kPulseTimesMaxRelSigma * n.value) {
    char buf[200];
    std::snprintf(buf, sizeof buf, "pulse_times not used: its N %.4g has a relative sigma of %.0f %% (> %.0f %%)",
                  n.value, 100 * n.sigma / n.value, 100 * kPulseTimesMaxRelSigma);
    a.notes.push_back(buf);
  }
}

void AxisStages::judge() {
  AxisAnalysis& a = a_;
  // Terms that trade (FitResult::correlation): say which, and how strongly, where one of them is only a bound.
  const std::string trade = tradeNote(answerFit(a), a.coefficients);
  if (!trade.empty()) a.notes.push_back(trade);
  if (a.has_gmwm) gmwmCompare(&a.gmwm, a.oadev, a.fit.model_var, a.final_model_var);  // closed loop vs IEEE fits
  a.quality = assessQuality(a);
  if (unboundIntervalsIfBad(a.quality, &a.coefficients))
    a.notes.push_back("intervals unbounded: the fit is bad, no interval computed under its model can be trusted");
}

AxisAnalysis AxisStages::finish() {
  if (!prepared_) throw std::logic_error("AxisStages::finish before prepare");
  runGmwm();  // before the samples are freed
  if (longest_ < segments_.size()) pulseTimes();
  std::vector<std::vector<double>>().swap(segments_);  // the samples are not needed any more
  noteStages();
  const MethodChoice choice = chooseAllanMethod();
  a_.method = choice.method;
  a_.method_reason = choice.reason;
  a_.final_model_var.resize(a_.oadev.points.size());
  if (choice.method == Method::WaveletSplit) answerWithSplit();
  else if (a_.has_check && !a_.check.effects.empty()) answerWithFit(a_.check.fit_after);
  else answerWithFit(a_.fit);
  considerPulseTimes();
  judge();
  return std::move(a_);
}

const FitResult& answerFit(const AxisAnalysis& a) {
  if (a.method == Method::WaveletSplit) return a.split.longer_tau_from_input ? a.fit : a.split.denoised_fit;
  if (a.method == Method::PulseTimes) return a.pulse_fit;
  if (a.has_check && !a.check.effects.empty()) return a.check.fit_after;
  return a.fit;
}

std::string tradeNote(const FitResult& f, const std::array<Coefficient, kNumTerms>& c) {
  std::string pairs;
  const int long_tau[3] = {kBiasInstability, kRateRandomWalk, kRateRamp};
  for (int i = 0; i < 3; ++i)
    for (int j = i + 1; j < 3; ++j) {
      const int a = long_tau[i], b = long_tau[j];
      const double r = f.correlation[static_cast<size_t>(a)][static_cast<size_t>(b)];
      const bool weak = !c[static_cast<size_t>(a)].supported || !c[static_cast<size_t>(b)].supported;
      const bool present = c[static_cast<size_t>(a)].value > 0 || c[static_cast<size_t>(b)].value > 0;
      if (!(std::fabs(r) >= kTradeCorrelation) || !weak || !present) continue;
      char buf[160];
      std::snprintf(buf, sizeof buf, "%s%s and %s (correlation %+.2f)", pairs.empty() ? "" : ", ", noiseTermKey(a),
                    noiseTermKey(b), r);
      pairs += buf;
    }
  if (pairs.empty()) return "";
  return "terms that trade over the longest taus: " + pairs +
         "; the record tells their combination (the model curve) better than each, so a term reported as a bound "
         "may hold what its partner lacks";
}

AxisAnalysis analyzeAxis(const std::string& axis, const std::vector<std::vector<double>>& segments, double tau0,
                         const AnalysisOptions& options, const std::vector<std::vector<double>>* temperature) {
  AxisStages st(axis, segments, tau0, options, temperature);
  st.prepare();
  if (options.concurrent_stages && options.wavelet_split && options.model_check) {
    // The split and the model check only read the samples and write their own members.
    std::exception_ptr split_error;
    std::thread t([&] {
      try {
        st.split();
      } catch (...) {
        split_error = std::current_exception();
      }
    });
    try {
      st.check();
    } catch (...) {
      t.join();
      throw;
    }
    t.join();
    if (split_error) std::rethrow_exception(split_error);
  } else {
    st.split();
    st.check();
  }
  return st.finish();
}

}  // namespace gyro_allan
