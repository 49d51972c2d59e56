// Writes noise_model.yaml (the GMWM state-space bias model) and the GMWM summary lines; see docs/outputs.md "noise_model.yaml".
#include "gyro_allan/io/noise_model_yaml.hpp"
#include "gyro_allan/io/report.hpp"

#include <cmath>
#include <cstdio>

namespace gyro_allan {
namespace {

YAML::Node num(double v) { return yamlNumber(v); }

YAML::Node valueSd(double value, double sd, const char* unit) {
  YAML::Node n;
  n["value"] = num(value);
  n["sigma"] = num(sd);
  n["unit"] = unit;
  return n;
}

YAML::Node matrix(const Eigen::MatrixXd& m) {
  YAML::Node rows(YAML::NodeType::Sequence);
  for (int i = 0; i < m.rows(); ++i) {
    YAML::Node r(YAML::NodeType::Sequence);
    r.SetStyle(YAML::EmitterStyle::Flow);
    for (int j = 0; j < m.cols(); ++j) r.push_back(num(m(i, j)));
    rows.push_back(r);
  }
  return rows;
}

YAML::Node discreteNode(const ReportedDiscreteModel& r) {
  const DiscreteNoiseModel& d = r.model;
  YAML::Node n;
  n["dt"] = num(r.dt);
  n["rate_hz"] = num(r.rate_hz);
  YAML::Node states(YAML::NodeType::Sequence);
  states.SetStyle(YAML::EmitterStyle::Flow);
  for (const auto& s : d.states) states.push_back(s);
  n["states"] = states;
  YAML::Node folded(YAML::NodeType::Sequence);
  folded.SetStyle(YAML::EmitterStyle::Flow);
  for (const auto& s : d.folded) folded.push_back(s);
  n["folded_into_white"] = folded;
  n["Phi"] = matrix(d.Phi);
  n["Qd"] = matrix(d.Qd);
  n["measurement_variance"] = num(r.measurement_variance);
  n["white_variance"] = num(d.white_variance);
  n["quantization_variance"] = num(d.quantization_variance);
  if (!d.approximation.empty()) n["approximation"] = d.approximation;
  return n;
}

YAML::Node agreementNode(const CurveAgreement& c) {
  YAML::Node n;
  n["points"] = c.points;
  n["within_ci"] = c.within_ci;
  n["worst_adev_ratio"] = num(c.worst_ratio);
  n["worst_at_tau_s"] = num(c.worst_tau);
  n["rms_log10"] = num(c.rms_log10);
  return n;
}

}  // namespace

ReportedNoiseModel axisNoiseModel(const AxisAnalysis& a, double filter_rate_hz) {
  const Coefficient& bi = a.fit.terms[kBiasInstability];
  return reportedNoiseModel(a.gmwm, filter_rate_hz, bi.value, bi.sigma);
}

YAML::Node noiseModelNode(const std::vector<AxisAnalysis>& axes, double filter_rate_hz,
                          const std::vector<std::string>& sources) {
  YAML::Node root;
  root["format"] = "gyro_allan noise_model 1";
  root["units"] = "SI: rad, rad/s, s";
  YAML::Node src(YAML::NodeType::Sequence);
  for (const auto& s : sources) src.push_back(s);
  root["sources"] = src;
  root["bias_model"] =
      "b = sum of the states; x[k+1] = Phi x[k] + w[k], Cov(w) = Qd; measured rate = true rate + b + white noise of "
      "variance measurement_variance";
  YAML::Node ax;
  for (const auto& a : axes) {
    if (!a.has_gmwm) continue;
    const ReportedNoiseModel r = axisNoiseModel(a, filter_rate_hz);
    YAML::Node n;
    if (!r.ok) {
      n["error"] = r.error;
      ax[a.axis] = n;
      continue;
    }
    const GmwmFit& f = r.fit;
    n["model"] = r.model;
    n["selection"] = r.selection;
    YAML::Node cands(YAML::NodeType::Sequence);
    for (const auto& c : r.candidates) {
      YAML::Node cn;
      cn["model"] = c.model;
      cn["ok"] = c.ok;
      cn["criterion"] = num(c.criterion);
      cn["chi2"] = num(c.chi2);
      cn["dof"] = c.dof;
      cn["identified"] = c.identified;
      if (!c.unidentified.empty()) cn["unidentified"] = c.unidentified;
      cands.push_back(cn);
    }
    n["candidates"] = cands;
    n["chi2"] = num(f.chi2);
    n["dof"] = f.dof;
    n["chi2_p"] = num(f.chi2_p);
    n["segment_s"] = num(r.segment_s);
    n["data_rate_hz"] = num(r.data_rate_hz);
    YAML::Node c;
    c["angle_random_walk"] = valueSd(f.N, f.N_sd, "rad/sqrt(s)");
    if (f.model.moving_average > 0) {
      // Short-memory measurement noise e_t + sum theta_k e_{t-k} at the data rate; angle_random_walk above is its
      // long-run equivalent.
      YAML::Node ma;
      ma["order"] = f.model.moving_average;
      YAML::Node th(YAML::NodeType::Sequence), sd(YAML::NodeType::Sequence);
      th.SetStyle(YAML::EmitterStyle::Flow);
      sd.SetStyle(YAML::EmitterStyle::Flow);
      for (size_t k = 0; k < f.ma.size(); ++k) {
        th.push_back(num(f.ma[k]));
        sd.push_back(num(f.ma_sd[k]));
      }
      ma["theta"] = th;
      ma["theta_sigma"] = sd;
      ma["innovation"] = valueSd(f.ma_innovation, f.ma_innovation_sd, "rad/sqrt(s)");
      c["moving_average"] = ma;
    }
    if (f.model.quantization) c["quantization"] = valueSd(f.Q, f.Q_sd, "rad");
    if (f.model.random_walk) c["rate_random_walk"] = valueSd(f.K, f.K_sd, "rad/s/sqrt(s)");
    if (f.model.drift) c["rate_ramp"] = valueSd(f.R, f.R_sd, "rad/s^2");
    YAML::Node gms(YAML::NodeType::Sequence);
    for (const auto& t : f.gm) {
      YAML::Node gn;
      gn["sigma"] = valueSd(t.sigma, t.sigma_sd, "rad/s");
      gn["correlation_time"] = valueSd(t.tc, t.tc_sd, "s");
      gms.push_back(gn);
    }
    c["gauss_markov"] = gms;
    n["continuous"] = c;
    if (!r.known_terms.empty()) {
      // The model check's effects: sinusoid / narrowband are known terms of the GMWM fit and its closed loop, but
      // not part of the bias model (Phi, Qd, measurement_variance) below; the others are in no part of it.
      YAML::Node kn(YAML::NodeType::Sequence);
      for (const auto& k : r.known_terms) {
        YAML::Node e;
        e["type"] = k.type;
        e["in_gmwm_fit"] = k.in_gmwm_fit;
        e["in_state_space_model"] = k.in_state_space_model;
        if (k.in_gmwm_fit) {
          e["kind"] = k.kind;
          if (k.frequency_hz > 0) e["frequency_hz"] = num(k.frequency_hz);
          if (k.bandwidth_hz > 0) e["bandwidth_hz"] = num(k.bandwidth_hz);
          if (k.amplitude > 0) e["amplitude"] = valueSd(k.amplitude, k.amplitude_sigma, "rad/s");
          e["rms"] = valueSd(k.rms, k.rms_sigma, "rad/s");
        }
        e["note"] = k.note;
        kn.push_back(e);
      }
      n["known_terms"] = kn;
    }
    YAML::Node disc(YAML::NodeType::Sequence);
    for (const auto& d : r.discrete) disc.push_back(discreteNode(d));
    n["discrete"] = disc;
    YAML::Node fl;
    fl["gauss_markov_terms"] = r.gauss_markov_terms;
    YAML::Node range(YAML::NodeType::Sequence);
    range.SetStyle(YAML::EmitterStyle::Flow);
    range.push_back(num(r.tau_min_s));
    range.push_back(num(r.tau_max_s));
    fl["tau_range_s"] = range;
    fl["ieee_bias_instability"] = valueSd(r.ieee_bias_instability, r.ieee_bias_instability_sigma, "rad/s");
    fl["worst_avar_ratio_vs_ieee_model"] = num(r.worst_avar_ratio_vs_ieee_model);
    fl["worst_avar_ratio_vs_data"] = num(r.worst_avar_ratio_vs_data);
    n["flicker_approximation"] = fl;
    YAML::Node cl;
    cl["gmwm_model"] = agreementNode(r.gmwm_model);
    cl["ieee_model"] = agreementNode(r.ieee_model);
    cl["final_model"] = agreementNode(r.final_model);
    cl["wavelet_variance_points"] = r.wavelet_variance_points;
    cl["wavelet_variance_within_ci"] = r.wavelet_variance_within_ci;
    cl["wavelet_variance_confidence"] = num(r.wavelet_variance_confidence);
    n["closed_loop"] = cl;
    ax[a.axis] = n;
  }
  root["axes"] = ax;
  return root;
}

std::string noiseModelYaml(const std::vector<AxisAnalysis>& axes, double filter_rate_hz,
                           const std::vector<std::string>& sources) {
  YAML::Emitter e;
  e.SetDoublePrecision(10);
  e << YAML::Comment("gyro_allan GMWM bias model per axis; fields in docs/outputs.md");
  e << YAML::Newline;
  e << noiseModelNode(axes, filter_rate_hz, sources);
  return std::string(e.c_str()) + "\n";
}

std::string gmwmSummary(const std::vector<AxisAnalysis>& axes) {
  std::string out;
  char buf[600];
  for (const auto& a : axes) {
    if (!a.has_gmwm) continue;
    const GmwmAxis& g = a.gmwm;
    if (!g.ok) {
      out += "GMWM " + a.axis + ": " + g.message + "\n";
      continue;
    }
    const GmwmFit& f = g.selection.chosen();
    std::snprintf(buf, sizeof buf, "GMWM %s: %s, N %.4g deg/sqrt(h)", a.axis.c_str(), f.model.name().c_str(),
                  f.N * 180 / M_PI * 60);
    out += buf;
    for (const auto& t : f.gm) {
      std::snprintf(buf, sizeof buf, ", GM %.4g deg/h tc %.4g s", t.sigma * 180 / M_PI * 3600, t.tc);
      out += buf;
    }
    if (f.model.random_walk) {
      std::snprintf(buf, sizeof buf, ", K %.4g deg/h/sqrt(h)", f.K * 180 / M_PI * 3600 * 60);
      out += buf;
    }
    out += "\n";
    for (const auto& k : f.known) {  // the model check's spectral effects: in the fit, not in Phi/Qd
      std::snprintf(buf, sizeof buf,
                    "  known term %s at %.4g Hz, RMS %.4g deg/h: in the GMWM fit, not in the filter model (Phi/Qd)\n",
                    k.type.c_str(), k.parameters.count("frequency_hz") ? k.parameters.at("frequency_hz") : 0.0,
                    std::sqrt(k.c / 2) * 180 / M_PI * 3600);
      out += buf;
    }
    if (g.compared) {
      std::snprintf(buf, sizeof buf,
                    "  closed loop (tau %.3g..%.3g s): ADEV inside the data's CI at %d/%d points, worst ratio %.3f, "
                    "rms_log10 %.4f (IEEE slopes: %d/%d, worst %.3f, rms_log10 %.4f; report's final model: %d/%d, worst %.3f, "
                    "rms_log10 %.4f)\n",
                    g.gmwm_vs_data.tau_min, g.gmwm_vs_data.tau_max, g.gmwm_vs_data.within_ci, g.gmwm_vs_data.points,
                    g.gmwm_vs_data.worst_ratio, g.gmwm_vs_data.rms_log10, g.ieee_vs_data.within_ci,
                    g.ieee_vs_data.points, g.ieee_vs_data.worst_ratio, g.ieee_vs_data.rms_log10, g.final_vs_data.within_ci,
                    g.final_vs_data.points, g.final_vs_data.worst_ratio, g.final_vs_data.rms_log10);
      out += buf;
    }
  }
  return out;
}

}  // namespace gyro_allan
