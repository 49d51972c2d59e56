// report.yaml / report.json, allan.csv and the printed summary, written atomically.
#include "gyro_allan/io/report.hpp"

#include "gyro_allan/kalibr.hpp"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <stdexcept>

namespace gyro_allan {
namespace {

YAML::Node num(double v) { return yamlNumber(v); }

/// A string scalar: tagged "!" (YAML's non-specific tag of a quoted scalar, never printed by the emitter) so that
/// toJson writes it as a JSON string whatever it looks like. Every text value of the report goes through str();
/// numbers come from num() or integers, flags from bool.
YAML::Node str(const std::string& s) {
  YAML::Node n(s);
  n.SetTag("!");
  return n;
}

YAML::Node coefficientNode(const Coefficient& c, const char* unit) {
  YAML::Node n;
  n["value"] = num(c.value);
  n["sigma"] = num(c.sigma);
  n["supported"] = c.supported;
  // Unified intervals (unified_interval.hpp): two-sided when supported, [0, hi] for a bound; they hold the value.
  n["interval_68"] = YAML::Node(YAML::NodeType::Sequence);
  n["interval_68"].push_back(num(c.lo68));
  n["interval_68"].push_back(num(c.hi68));
  n["interval_95"] = YAML::Node(YAML::NodeType::Sequence);
  n["interval_95"].push_back(num(c.lo95));
  n["interval_95"].push_back(num(c.hi95));
  n["unit"] = str(unit);
  return n;
}

YAML::Node coefficientsNode(const std::array<Coefficient, kNumTerms>& terms) {
  YAML::Node n;
  for (int t = 0; t < kNumTerms; ++t) n[noiseTermKey(t)] = coefficientNode(terms[static_cast<size_t>(t)], noiseTermUnit(t));
  return n;
}
YAML::Node coefficientsNode(const FitResult& fit) { return coefficientsNode(fit.terms); }

YAML::Node errorNode(double rms_log10, double chi2_dof) {
  YAML::Node n;
  n["rms_log10"] = num(rms_log10);
  n["chi2_dof"] = num(chi2_dof);
  return n;
}

YAML::Node splitNode(const WaveletSplitResult& w) {
  YAML::Node n;
  n["ok"] = w.ok;
  if (!w.ok) n["message"] = str(w.message);
  n["coefficients"] = coefficientsNode(w.terms);
  n["fit"] = errorNode(w.fit_error.rms_log10, w.fit_error.chi2_dof);
  n["wavelet"] = str(w.wavelet);
  n["level"] = w.level;
  n["split_frequency_hz"] = num(w.split_frequency_hz);
  n["kept_fraction"] = num(w.kept_fraction);
  n["quantization_white"] = w.quantization_white;
  if (w.sawtooth_bootstrap.replicas > 0 || !w.sawtooth_bootstrap.note.empty()) {
    // Quantization not white: Q^2, N^2 corrected by, and Q's sigma from, records simulated from the fitted model.
    const SawtoothBootstrap& b = w.sawtooth_bootstrap;
    YAML::Node bn;
    bn["replicas"] = b.replicas;
    bn["applied"] = b.applied;
    if (b.applied) {
      bn["note"] = str("quantization is not white (a sawtooth): Q and N corrected by the split's bias on " +
                       std::to_string(b.replicas) + " records simulated from the fitted model (pulse counter and N); "
                       "Q's interval from their scatter (Student t, " + std::to_string(b.replicas - 1) + " dof)");
    } else {
      bn["note"] = str(b.note + "; Q and N keep the analytic allowance for a sawtooth");
    }
    bn["replicas_white"] = b.replicas_white;
    bn["q_before_correction_rad"] = num(std::sqrt(std::max(0.0, b.q2_raw)));
    bn["q2_bias_rad2"] = num(b.q2_bias);
    bn["q2_sd_rad2"] = num(b.q2_sd);
    bn["n_before_correction_rad_per_sqrt_s"] = num(std::sqrt(std::max(0.0, b.n2_raw)));
    bn["n2_bias_rad2_per_s"] = num(b.n2_bias);
    bn["n2_sd_rad2_per_s"] = num(b.n2_sd);
    n["sawtooth_bootstrap"] = bn;
  }
  n["removed_arw_share"] = num(w.removed_arw_share);
  n["removed_angle_std_rad"] = num(w.removed_angle.std);
  n["removed_angle_max_abs_rad"] = num(w.removed_angle.max_abs);
  YAML::Node est;
  est["q_angle"] = num(w.q_angle);
  est["q_allan"] = num(w.q_allan);
  est["n_wavelet"] = num(w.n_wavelet);
  est["n_allan"] = num(w.n_allan);
  est["n_removed"] = num(w.n_removed);
  n["estimates"] = est;
  n["longer_tau_terms"] = w.longer_tau_from_input ? "input_fit" : "denoised_fit";  // where B, K and R come from
  n["denoised_fit"] = errorNode(w.denoised_fit_error.rms_log10, w.denoised_fit_error.chi2_dof);
  n["removed_fit"] = errorNode(w.removed_fit_error.rms_log10, w.removed_fit_error.chi2_dof);
  return n;
}

YAML::Node checkNode(const ModelCheck& c) {
  YAML::Node n;
  n["before"] = errorNode(c.before.rms_log10, c.before.chi2_dof);
  n["residual"] = str(c.residual_before.summary);
  n["effects"] = YAML::Node(YAML::NodeType::Sequence);
  for (const auto& e : c.effects) {
    YAML::Node en;
    en["type"] = str(e.type);
    for (const auto& kv : e.parameters) {
      en["parameters"][kv.first]["value"] = num(kv.second.value);
      en["parameters"][kv.first]["sigma"] = num(kv.second.sigma);
    }
    en["evidence"] = str(e.evidence);
    en["delta_bic"] = num(e.delta_bic);
    n["effects"].push_back(en);
  }
  n["after"] = errorNode(c.after.rms_log10, c.after.chi2_dof);
  n["coefficients"] = coefficientsNode(c.fit_after);
  n["rejected"] = YAML::Node(YAML::NodeType::Sequence);
  for (const auto& r : c.rejected) n["rejected"].push_back(str(r));
  if (c.line_search.slow_frequencies > 0) {
    YAML::Node ls;
    ls["periodogram_band_hz"].push_back(num(c.line_search.slow_lo_hz));
    ls["periodogram_band_hz"].push_back(num(c.line_search.slow_hi_hz));
    ls["periodogram_frequencies"] = c.line_search.slow_frequencies;
    ls["welch_band_hz"].push_back(num(c.line_search.slow_hi_hz));
    ls["welch_band_hz"].push_back(num(c.line_search.nyquist_hz));
    ls["welch_frequencies"] = c.line_search.welch_frequencies;
    ls["false_alarm_per_band"] = num(c.line_search.false_alarm_each);
    n["line_search"] = ls;
  }
  return n;
}

/// report.yaml `spikes:` of one axis; the with-spikes coefficients in SI and in conventional units (factor/unit of
/// each term from the callbacks: gyro or accelerometer).
YAML::Node spikesNode(const AxisAnalysis& a, double (*factor)(int), const char* (*conv_unit)(int),
                      const char* (*si_unit)(int), const std::string& suffix) {
  const SpikeReport& r = a.spikes;
  YAML::Node n;
  n["count"] = r.count;
  n["runs"] = r.runs;
  n["rejected"] = r.rejected;
  n["removed"] = r.removed;
  n["z"] = num(r.z);
  n["threshold_" + suffix] = num(r.threshold);
  n["robust_sigma_" + suffix] = num(r.robust_sigma);
  n["largest_excursion_" + suffix] = num(r.largest_excursion);
  n["excess_kurtosis_before"] = num(r.excess_kurtosis_before);
  n["excess_kurtosis_after"] = num(r.excess_kurtosis_after);
  n["first_indices"] = YAML::Node(YAML::NodeType::Sequence);
  for (int64_t i : r.first_indices) n["first_indices"].push_back(i);
  if (a.has_with_spikes) {
    YAML::Node c;
    for (int t = 0; t < kNumTerms; ++t) {
      const Coefficient& k = a.coefficients_with_spikes[static_cast<size_t>(t)];
      YAML::Node tn = coefficientNode(k, si_unit(t));
      tn["conventional"]["value"] = num(k.value * factor(t));
      tn["conventional"]["sigma"] = num(k.sigma * factor(t));
      tn["conventional"]["unit"] = str(conv_unit(t));
      c[noiseTermKey(t)] = tn;
    }
    n["coefficients_with_spikes"] = c;
    n["fit_with_spikes"] = errorNode(a.error_with_spikes.rms_log10, a.error_with_spikes.chi2_dof);
    const Coefficient &w = a.coefficients_with_spikes[kAngleRandomWalk], &o = a.fit.terms[kAngleRandomWalk];
    if (w.supported && o.supported && o.value > 0) n["angle_random_walk_ratio"] = num(w.value / o.value);
  }
  return n;
}

/// The summary line of one axis with spikes, or "".
std::string spikesLine(const AxisAnalysis& a, const char* label, double factor, const char* unit, const char* rate_unit) {
  if (!a.spikes_checked || a.spikes.count == 0) return "";
  const SpikeReport& r = a.spikes;
  char buf[320];
  int len = std::snprintf(buf, sizeof buf, "axis %s: %lld spikes removed (> %.3g sigma = %.3g %s from the local median)",
                          a.axis.c_str(), static_cast<long long>(r.count), r.z, r.threshold, rate_unit);
  if (a.has_with_spikes) {
    const Coefficient &w = a.coefficients_with_spikes[kAngleRandomWalk], &o = a.fit.terms[kAngleRandomWalk];
    if (w.supported && o.supported && o.value > 0)
      std::snprintf(buf + len, sizeof buf - static_cast<size_t>(len), "; with them %s would be %.3g %s (x%.2g)", label,
                    w.value * factor, unit, w.value / o.value);
  }
  return std::string(buf) + "\n";
}

/// The correlation of B, K and R's free estimates in a fit (FitResult::correlation): how they trade.
YAML::Node correlationNode(const FitResult& fit) {
  YAML::Node n;
  const int t[3] = {kBiasInstability, kRateRandomWalk, kRateRamp};
  for (int i = 0; i < 3; ++i)
    for (int j = i + 1; j < 3; ++j)
      n[std::string(noiseTermKey(t[i])) + "/" + noiseTermKey(t[j])] =
          num(fit.correlation[static_cast<size_t>(t[i])][static_cast<size_t>(t[j])]);
  return n;
}

YAML::Node fitNode(const FitResult& fit) {
  YAML::Node n;
  n["ok"] = fit.ok;
  if (!fit.ok) n["message"] = str(fit.message);
  n["rms_log10"] = num(fit.rms_log10);
  n["chi2_dof"] = num(fit.chi2_dof);
  n["dof"] = fit.dof;
  n["rms_points"] = fit.n_rms;
  n["worst_adev_ratio"] = num(fit.worst_adev_ratio);
  if (fit.gls) {
    n["weighting"] = str("gls");
    n["chi2_p"] = num(fit.chi2_p);
    n["uncertainty"] = str(fit.uncertainty);
    n["uncertainty_inflation"] = num(fit.uncertainty_inflation);
    // How much the generalized chi-squared rises when each term is held at 0.
    for (int t = 0; t < kNumTerms; ++t) n["evidence_chi2"][noiseTermKey(t)] = num(fit.evidence[static_cast<size_t>(t)]);
    n["correlation"] = correlationNode(fit);
  } else {
    n["weighting"] = str("edf");
  }
  return n;
}

/// report.yaml `quantized_output:` of an axis whose output is on a lattice (quantized_output.hpp).
YAML::Node quantizedNode(const QuantizedOutput& q) {
  YAML::Node n;
  n["quantum"] = num(q.quantum_rate);
  n["quantum_unit"] = str("rad/s");
  n["pulse_weight"] = num(q.pulse_weight);
  n["pulse_weight_unit"] = str("rad");
  n["offset"] = num(q.offset);
  n["fraction_on_lattice"] = num(q.fraction_on_lattice);
  n["levels"] = q.levels;
  n["sawtooth"] = q.sawtooth;
  n["sawtooth_hz"] = num(q.sawtooth_hz);
  n["two_level_fraction"] = num(q.two_level_fraction);
  n["alias_hz"] = num(q.alias_hz);
  n["line_to_floor"] = num(q.line_to_floor);
  n["summary"] = str(q.summary);
  return n;
}

/// Quality fields of an axis node.
void addQuality(YAML::Node* n, const AxisAnalysis& a) {
  (*n)["quality"] = str(qualityName(a.quality.quality));
  (*n)["quality_reason"] = str(a.quality.reason);
}

/// Printed lines after a table: the verdict of each axis that is not good, and (gyro) the quantized-output line.
std::string qualityLines(const std::vector<AxisAnalysis>& axes, bool quantized) {
  std::string o;
  for (const auto& a : axes) {
    if (a.quality.quality == Quality::Doubtful) o += "quality: axis " + a.axis + " doubtful: " + a.quality.reason + "\n";
    if (quantized && a.quantized.quantized) o += "axis " + a.axis + ": " + a.quantized.summary + "\n";
  }
  return o;
}

/// The line printed before the row of a bad axis, so that its coefficients never read as a plain answer.
std::string badFitLine(const AxisAnalysis& a) {
  return "BAD FIT: axis " + a.axis + ": " + a.quality.reason + " -- the coefficients below are not a measurement:\n";
}

void jsonString(std::ostringstream& o, const std::string& s) {
  o << '"';
  for (char ch : s) {
    switch (ch) {
      case '"': o << "\\\""; break;
      case '\\': o << "\\\\"; break;
      case '\n': o << "\\n"; break;
      case '\t': o << "\\t"; break;
      default:
        if (static_cast<unsigned char>(ch) < 0x20) o << "\\u" << std::hex << std::setw(4) << std::setfill('0') << int(ch) << std::dec;
        else o << ch;
    }
  }
  o << '"';
}

/// True when s is a number in JSON's grammar: -?(0|[1-9][0-9]*)(.[0-9]+)?([eE][+-]?[0-9]+)? (what %.10g and
/// integers print; strtod would also take "inf", "0x1p3", "1." or " 1", none of them JSON).
bool isJsonNumber(const std::string& s) {
  size_t i = 0;
  const size_t n = s.size();
  auto digits = [&]() {
    const size_t b = i;
    while (i < n && s[i] >= '0' && s[i] <= '9') ++i;
    return i - b;
  };
  if (i < n && s[i] == '-') ++i;
  if (i < n && s[i] == '0') ++i;
  else if (digits() == 0) return false;
  if (i < n && s[i] == '.') {
    ++i;
    if (digits() == 0) return false;
  }
  if (i < n && (s[i] == 'e' || s[i] == 'E')) {
    ++i;
    if (i < n && (s[i] == '+' || s[i] == '-')) ++i;
    if (digits() == 0) return false;
  }
  return i == n;
}

/// JSON of a report tree: the types are those the tree was built with (str() text, num() and integer numbers,
/// bools), none guessed from a string's content; map keys are strings.
void jsonValue(std::ostringstream& o, const YAML::Node& n, int indent) {
  const std::string pad(static_cast<size_t>(indent) * 2, ' ');
  const std::string pad2(static_cast<size_t>(indent + 1) * 2, ' ');
  if (n.IsMap()) {
    o << "{";
    bool first = true;
    for (auto it = n.begin(); it != n.end(); ++it) {
      o << (first ? "\n" : ",\n") << pad2;
      first = false;
      jsonString(o, it->first.as<std::string>());
      o << ": ";
      jsonValue(o, it->second, indent + 1);
    }
    o << (first ? "}" : "\n" + pad + "}");
  } else if (n.IsSequence()) {
    o << "[";
    for (size_t i = 0; i < n.size(); ++i) {
      o << (i ? ", " : "");
      jsonValue(o, n[i], indent + 1);
    }
    o << "]";
  } else if (n.IsScalar()) {
    const std::string& s = n.Scalar();
    if (n.Tag() == "!") jsonString(o, s);                           // text (str())
    else if (s == "true" || s == "false") o << s;                   // bool
    else if (s == ".nan" || s == ".inf" || s == "-.inf") o << "null";  // num() of a non-finite value: JSON has none
    else if (isJsonNumber(s)) o << s;                               // num() or an integer
    else jsonString(o, s);                                          // not a number: only a string can hold it
  } else {
    o << "null";
  }
}

std::string fmtCoef(const Coefficient& c, double factor) {
  char buf[64];
  if (!c.supported) std::snprintf(buf, sizeof buf, "%.2g (<%.3g)", c.value * factor, c.hi95 * factor);
  else std::snprintf(buf, sizeof buf, "%.4g +- %.2g", c.value * factor, c.sigma * factor);
  return buf;
}

}  // namespace

YAML::Node buildReport(const ReportMeta& meta, const std::vector<AxisAnalysis>& axes) {
  YAML::Node r;
  r["tool"] = str("gyro_allan analyze_bag");
  r["version"] = str("0.1.0");
  YAML::Node in;
  for (const auto& s : meta.sources) in["sources"].push_back(str(s));
  if (!meta.topic.empty()) in["topic"] = str(meta.topic);
  if (!meta.accel_topic.empty()) in["accel_topic"] = str(meta.accel_topic);
  if (!meta.input_note.empty()) in["note"] = str(meta.input_note);
  in["kind"] = str(meta.input);
  in["units"] = str(meta.input_units);
  r["input"] = in;
  r["method"] = str(meta.method);
  r["tau_grid"] = str(meta.tau_grid);
  r["confidence"] = num(meta.confidence);
  YAML::Node st;
  st["input"] = meta.stamps.input;
  st["kept"] = meta.stamps.kept;
  st["non_finite"] = meta.stamps.non_finite;
  st["zero_stamp"] = meta.stamps.zero_stamp;
  st["out_of_order"] = meta.stamps.out_of_order;
  st["duplicate"] = meta.stamps.duplicate;
  st["too_close"] = meta.stamps.too_close;
  st["short_segment"] = meta.stamps.short_segment;
  st["gaps"] = meta.stamps.gaps;
  st["missing_samples"] = meta.stamps.missing_samples;
  st["gap_time_s"] = num(meta.stamps.gap_time_s);
  st["rate_changed"] = meta.stamps.rate_changed;
  st["receipt_stamps"] = meta.stamps.receipt_stamps;
  YAML::Node jit;
  jit["p50_s"] = num(meta.stamps.jitter_p50_s);
  jit["p99_s"] = num(meta.stamps.jitter_p99_s);
  jit["max_s"] = num(meta.stamps.jitter_max_s);
  st["jitter"] = jit;
  r["stamps"] = st;
  if (meta.rest_checked) {
    YAML::Node m;
    m["at_rest"] = meta.rest.at_rest;
    m["analysed"] = str(meta.rest.at_rest ? "whole record"
                                          : (meta.rest_restricted ? "longest static stretch" : "whole record (not checked)"));
    m["reason"] = str(meta.rest.reason);
    if (!meta.rest.channel.empty()) m["channel"] = str(meta.rest.channel);
    m["moving_fraction"] = num(meta.rest.moving_fraction);
    m["score"] = num(meta.rest.score);
    m["spread"] = num(meta.rest.spread);
    m["blocks"] = meta.rest.blocks;
    m["moving_blocks"] = meta.rest.moving_blocks;
    if (meta.rest_restricted) {
      m["from_s"] = num(meta.rest_from_s);
      m["to_s"] = num(meta.rest_to_s);
      m["excluded_samples"] = meta.rest_excluded;
    }
    r["motion"] = m;
  }
  r["warnings"] = YAML::Node(YAML::NodeType::Sequence);
  for (const auto& w : meta.warnings) r["warnings"].push_back(str(w));
  YAML::Node ax;
  for (const auto& a : axes) {
    YAML::Node n;
    n["samples"] = a.samples;
    n["segments"] = a.segments;
    n["rate_hz"] = num(a.rate_hz);
    n["duration_s"] = num(a.duration_s);
    n["mean"] = num(a.mean);
    n["method"] = str(methodName(a.method));
    n["method_reason"] = str(a.method_reason);
    n["coefficients"] = coefficientsNode(a.coefficients);
    n["fit"] = errorNode(a.final_error.rms_log10, a.final_error.chi2_dof);
    // The verdict's figures: the largest model/measured ADEV factor at tight points, the adequacy p-value (GLS).
    n["fit"]["worst_adev_ratio"] = num(a.final_error.worst_adev_ratio);
    if (std::isfinite(a.final_error.chi2_p)) n["fit"]["chi2_p"] = num(a.final_error.chi2_p);
    addQuality(&n, a);
    if (answerFit(a).ok && answerFit(a).gls) n["correlation"] = correlationNode(answerFit(a));  // how B, K, R trade
    if (a.quantized.quantized) n["quantized_output"] = quantizedNode(a.quantized);
    YAML::Node jf;
    jf["coefficients"] = coefficientsNode(a.fit);
    jf["fit"] = fitNode(a.fit);
    n["methods"]["joint_fit"] = jf;
    if (a.has_split) n["methods"]["wavelet_split"] = splitNode(a.split);
    if (a.has_pulse_times) {  // slow undithered counter (pulse_times.hpp)
      YAML::Node pt;
      pt["ok"] = a.pulse_times.ok;
      pt["message"] = str(a.pulse_times.message);
      pt["crossings"] = a.pulse_times.crossings;
      pt["backward_crossings"] = a.pulse_times.back;
      pt["mean_interval_s"] = num(a.pulse_times.mean_interval_s);
      pt["tau_min_s"] = num(a.pulse_times.tau_min_s);
      if (a.pulse_times.ok && a.pulse_fit.ok) {
        pt["coefficients"] = coefficientsNode(a.pulse_fit);
        pt["fit"] = fitNode(a.pulse_fit);
      }
      n["methods"]["pulse_times"] = pt;
    }
    if (a.has_check) n["model_check"] = checkNode(a.check);
    if (a.spikes_checked)
      n["spikes"] = spikesNode(a, conventionalFactor, conventionalUnit, noiseTermUnit, "rad_s");
    if (!a.notes.empty())
      for (const auto& note : a.notes) n["notes"].push_back(str(note));
    ax[a.axis] = n;
  }
  r["axes"] = ax;
  return r;
}

YAML::Node yamlNumber(double v) {
  if (std::isnan(v)) return YAML::Node(".nan");
  if (std::isinf(v)) return YAML::Node(v > 0 ? ".inf" : "-.inf");
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.10g", v);
  return YAML::Node(std::string(buf));
}

std::string toYaml(const YAML::Node& node) {
  YAML::Emitter e;
  e.SetDoublePrecision(10);
  e << node;
  return std::string(e.c_str()) + "\n";
}

std::string toJson(const YAML::Node& node) {
  std::ostringstream o;
  jsonValue(o, node, 0);
  o << "\n";
  return o.str();
}

std::string allanCsv(const std::vector<AxisAnalysis>& axes) {
  std::ostringstream o;
  o << std::setprecision(10);
  o << "axis,deviation,tau_s,m,dev,dev_lo,dev_hi,edf,alpha,n_terms,model_dev,model_joint_dev,model_check_dev\n";
  auto dev = [](double var) { return std::sqrt(std::max(0.0, var)); };
  for (const auto& a : axes) {
    // Model columns (oadev rows only): the answer's model, the plain IEEE joint fit ("before") and the model check's
    // refit with its effects ("after"; empty when the check did not run).
    auto rows = [&](const DeviationCurve& c, bool with_model) {
      for (size_t i = 0; i < c.points.size(); ++i) {
        const auto& p = c.points[i];
        o << a.axis << ',' << c.name << ',' << p.tau << ',' << p.m << ',' << p.dev << ',' << p.dev_lo << ','
          << p.dev_hi << ',' << p.edf << ',' << p.alpha << ',' << p.n_terms << ',';
        if (with_model && i < a.final_model_var.size()) {
          o << dev(a.final_model_var[i]) << ',' << dev(i < a.fit.model_var.size() ? a.fit.model_var[i] : 0) << ',';
          if (a.has_check && i < a.check.model_var_after.size()) o << dev(a.check.model_var_after[i]);
        } else {
          o << ",,";
        }
        o << '\n';
      }
    };
    bool wrote_oadev = false;
    for (const auto& c : a.curves) {
      rows(c, c.name == "oadev");
      wrote_oadev = wrote_oadev || c.name == "oadev";
    }
    if (!wrote_oadev) rows(a.oadev, true);
    if (a.has_split && a.split.ok) {
      DeviationCurve d = a.split.denoised_curve, r = a.split.removed_curve;
      d.name = "oadev_denoised";
      r.name = "oadev_removed";
      rows(d, false);
      rows(r, false);
    }
  }
  return o.str();
}

std::string summaryTable(const std::vector<AxisAnalysis>& axes) {
  std::ostringstream o;
  o << std::left << std::setw(6) << "axis";
  const char* short_names[] = {"Q", "N", "B", "K", "R"};
  for (int t = 0; t < kNumTerms; ++t)
    o << std::setw(24) << (std::string(short_names[t]) + " [" + conventionalUnit(t) + "]");
  o << std::setw(11) << "rms_log10" << std::setw(10) << "chi2/dof" << std::setw(15) << "method" << "quality\n";
  for (const auto& a : axes) {
    if (a.quality.quality == Quality::Bad) o << badFitLine(a);
    o << std::setw(6) << a.axis;
    for (int t = 0; t < kNumTerms; ++t) o << std::setw(24) << fmtCoef(a.coefficients[static_cast<size_t>(t)], conventionalFactor(t));
    char buf[96];
    std::snprintf(buf, sizeof buf, "%-11.4f%-10.3g%-15s%s", a.final_error.rms_log10, a.final_error.chi2_dof,
                  methodName(a.method), a.quality.quality == Quality::Bad ? "BAD" : qualityName(a.quality.quality));
    o << buf << "\n";
  }
  o << "(value +- 1 sigma from the GLS covariance of the Allan-variance estimates; v (<b): not supported by the data "
       "(its 95 % interval reaches 0), fitted value v and b = upper end of its 95 % interval; the model curve uses v; "
       "68 %/95 % intervals in report.yaml)\n";
  o << qualityLines(axes, true);
  // Spikes: how many were removed and what N the plain joint fit gives with them left in (x: ratio to the joint fit
  // without them).
  for (const auto& a : axes) o << spikesLine(a, "N", conventionalFactor(kAngleRandomWalk), conventionalUnit(kAngleRandomWalk), "rad/s");
  // Model check: what the residual showed and what was added.
  bool any = false;
  for (const auto& a : axes) any = any || a.has_check;
  if (any) {
    o << "model check (residual -> effect -> refit):\n";
    for (const auto& a : axes) {
      if (!a.has_check) continue;
      const auto& c = a.check;
      char buf[160];
      std::snprintf(buf, sizeof buf, "  %-4s before rms_log10 %.4f chi2/dof %.3g -> after %.4f %.3g; ", a.axis.c_str(),
                    c.before.rms_log10, c.before.chi2_dof, c.after.rms_log10, c.after.chi2_dof);
      o << buf;
      if (c.effects.empty()) o << "no effect added (" << c.residual_before.summary << ")\n";
      else {
        o << "added:";
        for (const auto& e : c.effects) {
          o << " " << e.type;
          bool first = true;
          for (const auto& kv : e.parameters) {
            std::snprintf(buf, sizeof buf, "%s%s=%.4g", first ? " (" : ", ", kv.first.c_str(), kv.second.value);
            o << buf;
            first = false;
          }
          if (!first) o << ")";
        }
        o << "\n";
        for (const auto& e : c.effects) o << "       " << e.type << ": " << e.evidence << "\n";
      }
    }
  }
  return o.str();
}

YAML::Node accelerometerNode(const std::vector<AxisAnalysis>& axes, const std::vector<double>& means) {
  YAML::Node r;
  r["note"] = str("same IEEE 952 model on linear_acceleration (mean, i.e. gravity, removed); joint fit only: no "
                  "wavelet split or model check");
  for (size_t i = 0; i < axes.size(); ++i) {
    const AxisAnalysis& a = axes[i];
    std::string key = a.axis;
    if (key.rfind("accel_", 0) == 0) key = key.substr(6);
    YAML::Node n;
    n["samples"] = a.samples;
    n["rate_hz"] = num(a.rate_hz);
    n["mean"] = num(i < means.size() ? means[i] : a.mean);
    n["mean_unit"] = str("m/s^2");
    n["method"] = str(methodName(a.method));
    YAML::Node c;
    for (int t = 0; t < kNumTerms; ++t) {
      static const char* keys[] = {"velocity_quantization", "velocity_random_walk", "bias_instability",
                                   "acceleration_random_walk", "acceleration_ramp"};
      c[keys[t]] = coefficientNode(a.coefficients[static_cast<size_t>(t)], accelTermUnit(t));
    }
    n["coefficients"] = c;
    n["fit"] = errorNode(a.final_error.rms_log10, a.final_error.chi2_dof);
    // The verdict's figures: the largest model/measured ADEV factor at tight points, the adequacy p-value (GLS).
    n["fit"]["worst_adev_ratio"] = num(a.final_error.worst_adev_ratio);
    if (std::isfinite(a.final_error.chi2_p)) n["fit"]["chi2_p"] = num(a.final_error.chi2_p);
    addQuality(&n, a);
    if (a.spikes_checked) n["spikes"] = spikesNode(a, accelConventionalFactor, accelConventionalUnit, accelTermUnit, "m_s2");
    r["axes"][key] = n;
  }
  return r;
}

std::string accelSummaryTable(const std::vector<AxisAnalysis>& axes) {
  std::ostringstream o;
  o << std::left << std::setw(8) << "accel";
  const char* short_names[] = {"Q", "VRW", "B", "AccRW", "R"};
  for (int t = 0; t < kNumTerms; ++t)
    o << std::setw(24) << (std::string(short_names[t]) + " [" + accelConventionalUnit(t) + "]");
  o << std::setw(11) << "rms_log10" << "quality\n";
  for (const auto& a : axes) {
    if (a.quality.quality == Quality::Bad) o << badFitLine(a);
    o << std::setw(8) << a.axis;
    for (int t = 0; t < kNumTerms; ++t)
      o << std::setw(24) << fmtCoef(a.coefficients[static_cast<size_t>(t)], accelConventionalFactor(t));
    char buf[64];
    std::snprintf(buf, sizeof buf, "%-11.4f%s", a.final_error.rms_log10,
                  a.quality.quality == Quality::Bad ? "BAD" : qualityName(a.quality.quality));
    o << buf << "\n";
  }
  o << qualityLines(axes, false);  // quantized output: a gyro question (pulse counters), not shown here
  for (const auto& a : axes)
    o << spikesLine(a, "VRW", accelConventionalFactor(kAngleRandomWalk), accelConventionalUnit(kAngleRandomWalk),
                    "m/s^2");
  return o.str();
}

namespace {

/// A method's name in words for the first screen.
std::string methodWords(Method m) {
  switch (m) {
    case Method::JointFit: return "joint fit of the five terms";
    case Method::WaveletSplit: return "wavelet split: quantization from the sym8 residue";
    case Method::PulseTimes: return "fit of the pulse times";
    case Method::Auto:
    case Method::QuickFit: break;
  }
  return methodName(m);
}

/// One effect the model check added, in a few words.
std::string effectWords(const DetectedEffect& e) {
  auto par = [&](const char* k) { const auto it = e.parameters.find(k); return it == e.parameters.end() ? NAN : it->second.value; };
  char buf[120];
  if (e.type == "sinusoid") std::snprintf(buf, sizeof buf, "a sinusoid at %.4g Hz", par("frequency_hz"));
  else if (e.type == "narrowband") std::snprintf(buf, sizeof buf, "a narrowband oscillation near %.4g Hz", par("frequency_hz"));
  else if (e.type == "gauss_markov") std::snprintf(buf, sizeof buf, "a Gauss-Markov term (tau_c %.3g s)", par("tau_c_s"));
  else if (e.type == "bias_step") std::snprintf(buf, sizeof buf, "a bias step at %.4g s", par("time_s"));
  else if (e.type == "thermal_drift") std::snprintf(buf, sizeof buf, "a thermal drift");
  else if (e.type == "warmup") std::snprintf(buf, sizeof buf, "a warm-up drift");
  else if (e.type == "short_correlation") std::snprintf(buf, sizeof buf, "noise correlated over a few samples (a filter)");
  else if (e.type == "outliers") std::snprintf(buf, sizeof buf, "outliers");
  else std::snprintf(buf, sizeof buf, "%s", e.type.c_str());
  return buf;
}

/// The coefficient table of one sensor in conventional units, every line under 120 characters.
std::string briefTable(const std::vector<AxisAnalysis>& axes, bool accel) {
  std::ostringstream o;
  static const char* gyro_names[] = {"Q", "N", "B", "K", "R"};
  static const char* accel_names[] = {"Q", "VRW", "B", "AccRW", "R"};
  o << std::left << std::setw(6) << (accel ? "accel" : "gyro");
  for (int t = 0; t < kNumTerms; ++t)
    o << std::setw(23) << (std::string(accel ? accel_names[t] : gyro_names[t]) + " [" +
                           (accel ? accelConventionalUnit(t) : conventionalUnit(t)) + "]");
  o << "quality\n";
  for (const auto& a : axes) {
    std::string axis = a.axis;
    if (axis.rfind("accel_", 0) == 0) axis = axis.substr(6);
    o << std::setw(6) << axis;
    for (int t = 0; t < kNumTerms; ++t)
      o << std::setw(23) << fmtCoef(a.coefficients[static_cast<size_t>(t)],
                                    accel ? accelConventionalFactor(t) : conventionalFactor(t));
    o << (a.quality.quality == Quality::Bad ? "BAD: not a measurement" : qualityName(a.quality.quality)) << "\n";
  }
  return o.str();
}

}  // namespace

std::string axisWords(const AxisAnalysis& a) {
  std::string w = a.axis + ": ";
  w += a.quality.quality == Quality::Bad ? "BAD FIT, " : std::string(qualityName(a.quality.quality)) + ", ";
  w += methodWords(a.method);
  if (a.quality.quality != Quality::Good && !a.quality.reason.empty()) w += " (" + a.quality.reason + ")";
  if (a.has_check) {
    if (a.check.effects.empty()) {
      w += "; nothing outside the IEEE model found";
    } else {
      w += "; added to the model: ";
      for (size_t i = 0; i < a.check.effects.size(); ++i) w += (i ? ", " : "") + effectWords(a.check.effects[i]);
      char buf[120];
      std::snprintf(buf, sizeof buf, " (fit error %.3g -> %.3g)", a.check.before.rms_log10, a.check.after.rms_log10);
      w += buf;
    }
  }
  const bool accel = a.axis.rfind("accel_", 0) == 0;
  if (a.quantized.quantized) {
    char buf[120];
    std::snprintf(buf, sizeof buf, "; quantized output (steps of %.3g %s%s)", a.quantized.quantum_rate,
                  accel ? "m/s^2" : "rad/s", a.quantized.sawtooth ? ", undithered" : "");
    w += buf;
  }
  if (a.spikes_checked && a.spikes.count > 0)
    w += "; " + std::to_string(a.spikes.count) + (a.spikes.count == 1 ? " spike" : " spikes") + " removed";
  return w;  // the static stretch analysed, if any, is on the input's line
}

std::string wrapLine(const std::string& line, size_t width) {
  std::string out, rest = line;
  size_t w = width;
  while (rest.size() > w) {
    size_t cut = rest.rfind(' ', w);
    if (cut == std::string::npos || cut < w / 2) cut = w;
    out += rest.substr(0, cut) + "\n    ";
    rest = rest.substr(cut + (cut < rest.size() && rest[cut] == ' ' ? 1 : 0));
    w = width - 4;  // after the indent
  }
  return out + rest;
}

std::string briefSummary(const std::vector<AxisAnalysis>& gyro, const std::vector<AxisAnalysis>& accel) {
  std::string o = briefTable(gyro, false);
  if (!accel.empty()) o += briefTable(accel, true);
  o += "(value +- 1 sigma; v (<b): not supported by the data: fitted v, b = upper end of its 95 % interval)\n";
  auto fit = [](const std::string& s) { return wrapLine(s, 200) + "\n"; };
  for (const auto& a : gyro) o += fit(axisWords(a));
  if (!accel.empty()) {
    bool same = true;
    for (const auto& a : accel) same = same && a.quality.quality == accel.front().quality.quality && a.notes.empty();
    if (same) {
      o += fit("accelerometer: " + std::string(accel.front().quality.quality == Quality::Bad ? "BAD FIT"
                                                                                           : qualityName(accel.front().quality.quality)) +
               " on every axis, " + methodWords(accel.front().method) + " (no model check on the accelerometer)");
    } else {
      for (const auto& a : accel) o += fit(axisWords(a));
    }
  }
  return o;
}

void writeFileAtomic(const std::string& path, const std::string& content) {
  const std::string tmp = path + ".tmp";
  {
    std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
    if (!f) throw std::runtime_error("cannot write '" + tmp + "'");
    f << content;
    f.flush();
    if (!f) {
      std::remove(tmp.c_str());  // never leave a half-written .tmp behind
      throw std::runtime_error("cannot write '" + tmp + "' (disk full?)");
    }
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    std::remove(tmp.c_str());
    throw std::runtime_error("cannot rename '" + tmp + "' to '" + path + "'");
  }
}

void setPipelineMeta(const PipelineResult& r, ReportMeta* meta) {
  meta->stamps = r.stamps;
  meta->warnings = warningTexts(r.warnings);
  meta->rest_checked = r.rest_checked;
  meta->rest = r.rest;
  meta->rest_restricted = r.rest_restricted;
  meta->rest_from_s = r.rest_from_s;
  meta->rest_to_s = r.rest_to_s;
  meta->rest_excluded = r.rest_excluded;
}

void writeAnalysisFiles(const std::string& dir, const ReportMeta& meta, const PipelineResult& r,
                        const std::string& format, KalibrAxisRule rule, bool rate_input,
                        const std::string& rest_off_note) {
  const std::vector<AxisAnalysis>& results = r.gyro;
  const std::vector<AxisAnalysis>& accel_results = r.accel;
  YAML::Node report = buildReport(meta, results);
  if (!accel_results.empty()) report["accelerometer"] = accelerometerNode(accel_results, r.accel_means);
  std::string csv = allanCsv(results);
  if (!accel_results.empty()) {
    const std::string acsv = allanCsv(accel_results);
    csv += acsv.substr(acsv.find('\n') + 1);  // same columns: drop the second header
  }
  writeFileAtomic(dir + "/allan.csv", csv);
  std::vector<std::string> gyro_axes, accel_axes;
  std::vector<std::array<Coefficient, kNumTerms>> gyro_c, accel_c;
  for (const auto& a : results) gyro_axes.push_back(a.axis), gyro_c.push_back(a.coefficients);
  for (const auto& a : accel_results) accel_axes.push_back(a.axis), accel_c.push_back(a.coefficients);
  KalibrParams kp = kalibrParams(gyro_axes, gyro_c, accel_axes, accel_c, 1.0 / r.tau0, meta.topic, rule);
  for (const auto& a : results) kp.quality.push_back({"gyro", a.axis, a.quality});
  for (const auto& a : accel_results) kp.quality.push_back({"accelerometer", a.axis, a.quality});
  if (meta.rest_restricted) {
    char note[200];
    std::snprintf(note, sizeof note, "the longest static stretch, %.1f-%.1f s of the record (the sensor moved outside it)",
                  meta.rest_from_s, meta.rest_to_s);
    kp.data_note = note;
  } else if (meta.rest_checked) {
    kp.data_note = "the whole record, at rest (at-rest check passed)";
  } else if (rate_input) {
    kp.data_note = rest_off_note;
  }
  writeFileAtomic(dir + "/imu.yaml", kalibrYaml(kp));
  for (const FrameworkConfig& f : frameworkConfigs(kp)) writeFileAtomic(dir + "/" + f.file, f.text);
  if (format == "json") writeFileAtomic(dir + "/report.json", toJson(report));
  else writeFileAtomic(dir + "/report.yaml", toYaml(report));
}

}  // namespace gyro_allan
