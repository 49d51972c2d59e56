// Unit tests of the nodelet's message conversions (src/ros, no ROS master): ~noise_model's AxisNoiseModel from a hand-built core ReportedNoiseModel field by field, the "off" message, report.yaml's method.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "../src/ros/analyzer_ros.hpp"
#include "../src/ros/noise_model_msg.hpp"

namespace {

using gyro_allan::AxisNoiseModel;
using gyro_allan::ReportedNoiseModel;

/// A model with every part set to distinct values (declared truth of the conversion: each field is a copy).
ReportedNoiseModel handBuilt() {
  ReportedNoiseModel r;
  r.ok = true;
  r.model = "MA2+GM+RW";
  r.selection = "smallest chi2 + 2.5 p among identified fits";
  auto candidate = [](const char* model, bool ok, double criterion, double chi2, int dof, const char* unidentified) {
    gyro_allan::ReportedCandidate c;
    c.model = model, c.ok = ok, c.criterion = criterion, c.chi2 = chi2, c.dof = dof;
    c.identified = std::string(unidentified).empty();
    c.unidentified = unidentified;
    return c;
  };
  r.candidates = {candidate("WN+RW", true, 41.5, 36.5, 9, ""), candidate("WN+2GM+RW", false, 51.25, 33.75, 5, "gm2")};
  gyro_allan::GmwmFit& f = r.fit;
  f.model.white = false;
  f.model.moving_average = 2;
  f.model.gauss_markov = 1;
  f.model.random_walk = true;
  f.model.quantization = false;  // Q set below but not a term: the message must say 0
  f.model.drift = false;
  f.N = 1.25e-4, f.N_sd = 2.5e-6;
  f.Q = 7.0, f.Q_sd = 0.5;
  f.K = 3.5e-6, f.K_sd = 4.5e-7;
  f.R = 9.0, f.R_sd = 1.0;
  f.ma = {0.375, -0.125};
  f.ma_sd = {0.0625, 0.03125};
  f.ma_innovation = 1.5e-4, f.ma_innovation_sd = 3e-6;
  gyro_allan::GaussMarkovTerm gm;
  gm.sigma = 2e-4, gm.sigma_sd = 1.5e-5, gm.tc = 5.5, gm.tc_sd = 0.75;
  f.gm = {gm};
  f.chi2 = 12.5;
  f.dof = 7;
  f.chi2_p = 0.085;
  r.segment_s = 599.99;
  r.data_rate_hz = 100.0;
  for (double dt : {0.01, 0.05}) {
    gyro_allan::ReportedDiscreteModel d;
    d.dt = dt;
    d.rate_hz = 1.0 / dt;
    d.model.dt = dt;
    d.model.states = {"gm1", "rw"};
    d.model.folded = {"ma2"};
    d.model.Phi.resize(2, 2);
    d.model.Phi << 0.91, 0.02, 0.03, 1.0;  // not symmetric: row-major order is visible
    d.model.Qd.resize(2, 2);
    d.model.Qd << 1e-9, 2e-10, 3e-10, 4e-11;
    d.model.white_variance = 1.5625e-6 / dt;
    d.model.quantization_variance = 0.0;
    d.model.approximation = dt > 0.02 ? "MA2 folded into white at 5 samples per step" : "";
    d.measurement_variance = d.model.white_variance + d.model.quantization_variance;
    r.discrete.push_back(d);
  }
  r.gauss_markov_terms = 1;
  r.tau_min_s = 0.01, r.tau_max_s = 60.0;
  r.ieee_bias_instability = 3e-5, r.ieee_bias_instability_sigma = 4e-6;
  r.worst_avar_ratio_vs_ieee_model = 1.75;
  r.worst_avar_ratio_vs_data = 1.5;
  auto agreement = [](int points, int within, double worst, double at, double rms) {
    gyro_allan::CurveAgreement a;
    a.points = points, a.within_ci = within, a.worst_ratio = worst, a.worst_tau = at, a.rms_log10 = rms;
    return a;
  };
  r.gmwm_model = agreement(40, 38, 1.2, 30.0, 0.02);
  r.ieee_model = agreement(40, 31, 1.6, 4.0, 0.05);
  r.final_model = agreement(40, 35, 1.3, 8.0, 0.03);
  r.wavelet_variance_points = 14;
  r.wavelet_variance_within_ci = 13;
  r.wavelet_variance_confidence = 0.95;
  gyro_allan::ReportedKnownTerm line;  // a model-check line in the fit, and an effect that is not
  line.type = "narrowband";
  line.in_gmwm_fit = true;
  line.kind = "stationary narrowband oscillation";
  line.frequency_hz = 20.0;
  line.bandwidth_hz = 0.5;
  line.rms = 2e-3;
  line.rms_sigma = 1e-5;
  line.note = "notch it";
  gyro_allan::ReportedKnownTerm step;
  step.type = "bias_step";
  step.frequency_hz = 7.0;  // not copied: only a term in the fit carries the rest (as noise_model.yaml)
  step.note = "not stationary";
  r.known_terms = {line, step};
  return r;
}

TEST(RosConversion, AxisNoiseModelFieldByField) {
  const ReportedNoiseModel r = handBuilt();
  const AxisNoiseModel m = gyro_allan::toAxisNoiseModel("y", r);
  EXPECT_EQ(m.axis, "y");
  EXPECT_TRUE(m.ok);
  EXPECT_EQ(m.error, "");
  EXPECT_EQ(m.model, "MA2+GM+RW");
  EXPECT_EQ(m.selection, r.selection);
  ASSERT_EQ(m.candidates.size(), 2u);
  EXPECT_EQ(m.candidates[1].model, "WN+2GM+RW");
  EXPECT_FALSE(m.candidates[1].ok);
  EXPECT_EQ(m.candidates[1].criterion, 51.25);
  EXPECT_EQ(m.candidates[1].chi2, 33.75);
  EXPECT_EQ(m.candidates[1].dof, 5);
  EXPECT_FALSE(m.candidates[1].identified);
  EXPECT_EQ(m.candidates[1].unidentified, "gm2");
  EXPECT_TRUE(m.candidates[0].identified);
  EXPECT_EQ(m.chi2, 12.5);
  EXPECT_EQ(m.dof, 7);
  EXPECT_EQ(m.chi2_p, 0.085);
  EXPECT_EQ(m.segment_s, 599.99);
  EXPECT_EQ(m.data_rate_hz, 100.0);
  // Continuous terms: the model's terms copied with their sigma, the others 0 (Q and R are set in the fit but are
  // not terms of MA2+GM+RW).
  EXPECT_EQ(m.continuous.angle_random_walk.value, 1.25e-4);
  EXPECT_EQ(m.continuous.angle_random_walk.sigma, 2.5e-6);
  EXPECT_EQ(m.continuous.rate_random_walk.value, 3.5e-6);
  EXPECT_EQ(m.continuous.rate_random_walk.sigma, 4.5e-7);
  EXPECT_EQ(m.continuous.quantization.value, 0.0);
  EXPECT_EQ(m.continuous.quantization.sigma, 0.0);
  EXPECT_EQ(m.continuous.rate_ramp.value, 0.0);
  EXPECT_EQ(m.continuous.moving_average.order, 2u);
  EXPECT_EQ(m.continuous.moving_average.theta, (std::vector<double>{0.375, -0.125}));
  EXPECT_EQ(m.continuous.moving_average.theta_sigma, (std::vector<double>{0.0625, 0.03125}));
  EXPECT_EQ(m.continuous.moving_average.innovation.value, 1.5e-4);
  EXPECT_EQ(m.continuous.moving_average.innovation.sigma, 3e-6);
  ASSERT_EQ(m.continuous.gauss_markov.size(), 1u);
  EXPECT_EQ(m.continuous.gauss_markov[0].sigma.value, 2e-4);
  EXPECT_EQ(m.continuous.gauss_markov[0].sigma.sigma, 1.5e-5);
  EXPECT_EQ(m.continuous.gauss_markov[0].correlation_time.value, 5.5);
  EXPECT_EQ(m.continuous.gauss_markov[0].correlation_time.sigma, 0.75);
  // Discrete models: Phi and Qd flattened row-major, element (i, j) at i * dimension + j (msg/DiscreteBiasModel.msg).
  ASSERT_EQ(m.discrete.size(), 2u);
  for (size_t k = 0; k < 2; ++k) {
    SCOPED_TRACE("discrete[" + std::to_string(k) + "]");
    const gyro_allan::DiscreteBiasModel& d = m.discrete[k];
    const gyro_allan::ReportedDiscreteModel& e = r.discrete[k];
    EXPECT_EQ(d.dt, e.dt);
    EXPECT_EQ(d.rate_hz, e.rate_hz);
    EXPECT_EQ(d.states, (std::vector<std::string>{"gm1", "rw"}));
    EXPECT_EQ(d.folded_into_white, (std::vector<std::string>{"ma2"}));
    EXPECT_EQ(d.dimension, 2u);
    EXPECT_EQ(d.Phi, (std::vector<double>{0.91, 0.02, 0.03, 1.0}));
    EXPECT_EQ(d.Qd, (std::vector<double>{1e-9, 2e-10, 3e-10, 4e-11}));
    EXPECT_EQ(d.measurement_variance, e.measurement_variance);
    EXPECT_EQ(d.white_variance, e.model.white_variance);
    EXPECT_EQ(d.quantization_variance, 0.0);
    EXPECT_EQ(d.approximation, e.model.approximation);
  }
  EXPECT_EQ(m.discrete[1].approximation, "MA2 folded into white at 5 samples per step");
  // Flicker approximation and closed loop (CurveAgreement worst_ratio/worst_tau -> worst_adev_ratio/worst_at_tau_s).
  EXPECT_EQ(m.flicker_approximation.gauss_markov_terms, 1);
  EXPECT_EQ(m.flicker_approximation.tau_range_s[0], 0.01);
  EXPECT_EQ(m.flicker_approximation.tau_range_s[1], 60.0);
  EXPECT_EQ(m.flicker_approximation.ieee_bias_instability.value, 3e-5);
  EXPECT_EQ(m.flicker_approximation.ieee_bias_instability.sigma, 4e-6);
  EXPECT_EQ(m.flicker_approximation.worst_avar_ratio_vs_ieee_model, 1.75);
  EXPECT_EQ(m.flicker_approximation.worst_avar_ratio_vs_data, 1.5);
  EXPECT_EQ(m.closed_loop.gmwm_model.points, 40);
  EXPECT_EQ(m.closed_loop.gmwm_model.within_ci, 38);
  EXPECT_EQ(m.closed_loop.gmwm_model.worst_adev_ratio, 1.2);
  EXPECT_EQ(m.closed_loop.gmwm_model.worst_at_tau_s, 30.0);
  EXPECT_EQ(m.closed_loop.gmwm_model.rms_log10, 0.02);
  EXPECT_EQ(m.closed_loop.ieee_model.within_ci, 31);
  EXPECT_EQ(m.closed_loop.ieee_model.worst_at_tau_s, 4.0);
  EXPECT_EQ(m.closed_loop.final_model.worst_adev_ratio, 1.3);
  EXPECT_EQ(m.closed_loop.wavelet_variance_points, 14);
  EXPECT_EQ(m.closed_loop.wavelet_variance_within_ci, 13);
  EXPECT_EQ(m.closed_loop.wavelet_variance_confidence, 0.95);
  ASSERT_EQ(m.known_terms.size(), 2u);
  EXPECT_EQ(m.known_terms[0].type, "narrowband");
  EXPECT_TRUE(m.known_terms[0].in_gmwm_fit);
  EXPECT_FALSE(m.known_terms[0].in_state_space_model);
  EXPECT_EQ(m.known_terms[0].frequency_hz, 20.0);
  EXPECT_EQ(m.known_terms[0].bandwidth_hz, 0.5);
  EXPECT_EQ(m.known_terms[0].rms.value, 2e-3);
  EXPECT_EQ(m.known_terms[0].rms.sigma, 1e-5);
  EXPECT_EQ(m.known_terms[0].amplitude.value, 0.0);
  EXPECT_EQ(m.known_terms[0].note, "notch it");
  EXPECT_EQ(m.known_terms[1].type, "bias_step");
  EXPECT_FALSE(m.known_terms[1].in_gmwm_fit);
  EXPECT_EQ(m.known_terms[1].frequency_hz, 0.0);
  EXPECT_EQ(m.known_terms[1].note, "not stationary");
}

TEST(RosConversion, FailedAxisCarriesOnlyItsReason) {
  ReportedNoiseModel r = handBuilt();
  r.ok = false;
  r.error = "segment too short for the wavelet variance";
  const AxisNoiseModel m = gyro_allan::toAxisNoiseModel("z", r);
  EXPECT_EQ(m.axis, "z");
  EXPECT_FALSE(m.ok);
  EXPECT_EQ(m.error, r.error);
  EXPECT_EQ(m.model, "");
  EXPECT_TRUE(m.candidates.empty());
  EXPECT_TRUE(m.discrete.empty());
  EXPECT_EQ(m.continuous.angle_random_walk.value, 0.0);
}

TEST(RosConversion, NoiseModelOffSaysSo) {
  const gyro_allan::NoiseModel m = gyro_allan::noiseModelOff(ros::Time(12.5), "imu_link");
  EXPECT_EQ(m.status, gyro_allan::NoiseModel::STATUS_OFF);
  EXPECT_EQ(m.status, "off");
  EXPECT_EQ(m.header.stamp, ros::Time(12.5));
  EXPECT_EQ(m.header.frame_id, "imu_link");
  EXPECT_TRUE(m.axes.empty());
  EXPECT_TRUE(m.sources.empty());
  EXPECT_EQ(m.rate_hz, 0.0);
  EXPECT_EQ(gyro_allan::NoiseModel::STATUS_CURRENT, "current");
}

// report.yaml's method as analyze_bag writes it for the equivalent options: --method gmwm -> "gmwm" (with or without
// --filter-rate), --method joint_fit / wavelet_split -> that name, no option -> "auto".
TEST(RosConversion, ReportMethodAsAnalyzeBag) {
  gyro_allan::AnalyzerParams p;
  EXPECT_EQ(gyro_allan::reportMethod(p), "auto");
  p.online.pipeline.analysis.gmwm = true;
  EXPECT_EQ(gyro_allan::reportMethod(p), "gmwm");
  p.filter_rate = 20;
  EXPECT_EQ(gyro_allan::reportMethod(p), "gmwm");
  p.method = gyro_allan::Method::JointFit;
  EXPECT_EQ(gyro_allan::reportMethod(p), "joint_fit");
  p.method = gyro_allan::Method::WaveletSplit;
  p.online.pipeline.analysis.gmwm = false;
  p.filter_rate = 0;
  EXPECT_EQ(gyro_allan::reportMethod(p), "wavelet_split");
}

}  // namespace
