// The ~noise_model per-axis message from the core's reported noise model (see noise_model_msg.hpp).
#include "noise_model_msg.hpp"

namespace gyro_allan {

namespace {

ValueSigma valueSigma(double value, double sigma) {
  ValueSigma v;
  v.value = value;
  v.sigma = sigma;
  return v;
}

std::vector<double> rowMajor(const Eigen::MatrixXd& x) {
  std::vector<double> v;
  v.reserve(static_cast<size_t>(x.size()));
  for (int i = 0; i < x.rows(); ++i)
    for (int j = 0; j < x.cols(); ++j) v.push_back(x(i, j));
  return v;
}

ModelAgreement toMsg(const CurveAgreement& c) {
  ModelAgreement m;
  m.points = c.points;
  m.within_ci = c.within_ci;
  m.worst_adev_ratio = c.worst_ratio;
  m.worst_at_tau_s = c.worst_tau;
  m.rms_log10 = c.rms_log10;
  return m;
}

}  // namespace

AxisNoiseModel toAxisNoiseModel(const std::string& axis, const ReportedNoiseModel& r) {
  AxisNoiseModel m;
  m.axis = axis;
  m.ok = r.ok;
  m.error = r.error;
  if (!r.ok) return m;
  const GmwmFit& f = r.fit;
  m.model = r.model;
  m.selection = r.selection;
  for (const ReportedCandidate& c : r.candidates) {
    NoiseModelCandidate cm;
    cm.model = c.model;
    cm.ok = c.ok;
    cm.criterion = c.criterion;
    cm.chi2 = c.chi2;
    cm.dof = c.dof;
    cm.identified = c.identified;
    cm.unidentified = c.unidentified;
    m.candidates.push_back(cm);
  }
  for (const ReportedKnownTerm& k : r.known_terms) {
    KnownTerm km;
    km.type = k.type;
    km.in_gmwm_fit = k.in_gmwm_fit;
    km.in_state_space_model = k.in_state_space_model;
    if (k.in_gmwm_fit) {  // as noise_model.yaml: the rest only for a term in the fit
      km.kind = k.kind;
      km.frequency_hz = k.frequency_hz;
      km.bandwidth_hz = k.bandwidth_hz;
      km.amplitude = valueSigma(k.amplitude, k.amplitude_sigma);
      km.rms = valueSigma(k.rms, k.rms_sigma);
    }
    km.note = k.note;
    m.known_terms.push_back(km);
  }
  m.chi2 = f.chi2;
  m.dof = f.dof;
  m.chi2_p = f.chi2_p;
  m.segment_s = r.segment_s;
  m.data_rate_hz = r.data_rate_hz;
  m.continuous.angle_random_walk = valueSigma(f.N, f.N_sd);
  if (f.model.quantization) m.continuous.quantization = valueSigma(f.Q, f.Q_sd);
  if (f.model.random_walk) m.continuous.rate_random_walk = valueSigma(f.K, f.K_sd);
  if (f.model.drift) m.continuous.rate_ramp = valueSigma(f.R, f.R_sd);
  if (f.model.moving_average > 0) {
    MovingAverageNoise& ma = m.continuous.moving_average;
    ma.order = static_cast<uint32_t>(f.model.moving_average);
    ma.theta = f.ma;
    ma.theta_sigma = f.ma_sd;
    ma.innovation = valueSigma(f.ma_innovation, f.ma_innovation_sd);
  }
  for (const GaussMarkovTerm& t : f.gm) {
    GaussMarkovProcess g;
    g.sigma = valueSigma(t.sigma, t.sigma_sd);
    g.correlation_time = valueSigma(t.tc, t.tc_sd);
    m.continuous.gauss_markov.push_back(g);
  }
  for (const ReportedDiscreteModel& d : r.discrete) {
    DiscreteBiasModel dm;
    dm.dt = d.dt;
    dm.rate_hz = d.rate_hz;
    dm.states = d.model.states;
    dm.folded_into_white = d.model.folded;
    dm.dimension = static_cast<uint32_t>(d.model.Phi.rows());
    dm.Phi = rowMajor(d.model.Phi);
    dm.Qd = rowMajor(d.model.Qd);
    dm.measurement_variance = d.measurement_variance;
    dm.white_variance = d.model.white_variance;
    dm.quantization_variance = d.model.quantization_variance;
    dm.approximation = d.model.approximation;
    m.discrete.push_back(dm);
  }
  FlickerApproximation& fl = m.flicker_approximation;
  fl.gauss_markov_terms = r.gauss_markov_terms;
  fl.tau_range_s[0] = r.tau_min_s;
  fl.tau_range_s[1] = r.tau_max_s;
  fl.ieee_bias_instability = valueSigma(r.ieee_bias_instability, r.ieee_bias_instability_sigma);
  fl.worst_avar_ratio_vs_ieee_model = r.worst_avar_ratio_vs_ieee_model;
  fl.worst_avar_ratio_vs_data = r.worst_avar_ratio_vs_data;
  ClosedLoopCheck& cl = m.closed_loop;
  cl.gmwm_model = toMsg(r.gmwm_model);
  cl.ieee_model = toMsg(r.ieee_model);
  cl.final_model = toMsg(r.final_model);
  cl.wavelet_variance_points = r.wavelet_variance_points;
  cl.wavelet_variance_within_ci = r.wavelet_variance_within_ci;
  cl.wavelet_variance_confidence = r.wavelet_variance_confidence;
  return m;
}

}  // namespace gyro_allan
