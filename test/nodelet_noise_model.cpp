// rostest node for AnalyzerNodelet's ~noise_model (issue 16): with ~gmwm and ~filter_rate the nodelet publishes,
// latched, the GMWM bias model analyze_bag --method gmwm --filter-rate writes to noise_model.yaml for the same
// samples, field by field; ~save writes that noise_model.yaml too; the "noise model" diagnostic names the models.
#include <gtest/gtest.h>

#include <cmath>
#include <mutex>
#include <string>
#include <vector>

#include <gyro_allan/NoiseModel.h>
#include <ros/ros.h>
#include <sensor_msgs/Imu.h>
#include <yaml-cpp/yaml.h>

#include "nodelet_util.hpp"

namespace {

using namespace nodelet_test;

const std::string kNode = "nm_analyzer";
const std::string kOut = std::string(GYRO_ALLAN_TEST_OUT) + "/nodelet_noise_model";
const std::string kTools = GYRO_ALLAN_TOOL_DIR;
const double kFilterRate = 20.0;  // the launch file's ~filter_rate [Hz]

/// The test's view of the nodelet: its IMU input, ~noise_model and diagnostics.
struct Probe {
  ros::NodeHandle nh;
  ros::Publisher imu = nh.advertise<sensor_msgs::Imu>("imu", 100000);
  Latest<gyro_allan::NoiseModel> models{nh, kNode + "/noise_model"};
  Diagnostics diag{nh, kNode};
};

/// noise_model.yaml prints 10 significant digits: relative tolerance 1e-8 (equal NaN, equal zero).
const double kTol = 1e-8;
void expectNear(double msg, const YAML::Node& y, const std::string& what) {
  ASSERT_TRUE(y.IsDefined()) << what << " missing in noise_model.yaml";
  const double v = y.as<double>();
  if (std::isnan(v)) {
    EXPECT_TRUE(std::isnan(msg)) << what;
    return;
  }
  EXPECT_LE(std::fabs(msg - v), kTol * std::fabs(v)) << what << ": message " << msg << ", noise_model.yaml " << v;
}
void expectValueSigma(const gyro_allan::ValueSigma& m, const YAML::Node& y, const std::string& what) {
  expectNear(m.value, y["value"], what + ".value");
  expectNear(m.sigma, y["sigma"], what + ".sigma");
}
void expectAgreement(const gyro_allan::ModelAgreement& m, const YAML::Node& y, const std::string& what) {
  EXPECT_EQ(m.points, y["points"].as<int>()) << what;
  EXPECT_EQ(m.within_ci, y["within_ci"].as<int>()) << what;
  expectNear(m.worst_adev_ratio, y["worst_adev_ratio"], what + ".worst_adev_ratio");
  expectNear(m.worst_at_tau_s, y["worst_at_tau_s"], what + ".worst_at_tau_s");
  expectNear(m.rms_log10, y["rms_log10"], what + ".rms_log10");
}
std::vector<std::string> strings(const YAML::Node& y) {
  std::vector<std::string> v;
  for (const auto& s : y) v.push_back(s.as<std::string>());
  return v;
}

/// The message against noise_model.yaml's "axes", every field. Returns the number of Gauss-Markov terms published.
int expectSameAsYaml(const gyro_allan::NoiseModel& m, const YAML::Node& yaml) {
  const YAML::Node axes = yaml["axes"];
  EXPECT_EQ(m.axes.size(), axes.size());
  EXPECT_EQ(m.filter_rate_hz, kFilterRate);
  int gm_terms = 0;
  for (const gyro_allan::AxisNoiseModel& a : m.axes) {
    SCOPED_TRACE("axis " + a.axis);
    const YAML::Node y = axes[a.axis];
    EXPECT_TRUE(y.IsDefined());
    if (!y.IsDefined()) continue;
    EXPECT_EQ(a.ok, !y["error"].IsDefined());
    if (!a.ok) {
      EXPECT_EQ(a.error, y["error"].as<std::string>());
      continue;
    }
    EXPECT_EQ(a.model, y["model"].as<std::string>());
    EXPECT_EQ(a.selection, y["selection"].as<std::string>());
    const YAML::Node cands = y["candidates"];
    EXPECT_EQ(a.candidates.size(), cands.size());
    for (size_t k = 0; k < a.candidates.size() && k < cands.size(); ++k) {
      const gyro_allan::NoiseModelCandidate& c = a.candidates[k];
      EXPECT_EQ(c.model, cands[k]["model"].as<std::string>());
      EXPECT_EQ(c.ok, cands[k]["ok"].as<bool>()) << c.model;
      expectNear(c.criterion, cands[k]["criterion"], c.model + " criterion");
      expectNear(c.chi2, cands[k]["chi2"], c.model + " chi2");
      EXPECT_EQ(c.dof, cands[k]["dof"].as<int>()) << c.model;
      EXPECT_EQ(c.identified, cands[k]["identified"].as<bool>()) << c.model;
      EXPECT_EQ(c.unidentified, cands[k]["unidentified"].IsDefined() ? cands[k]["unidentified"].as<std::string>() : "");
    }
    expectNear(a.chi2, y["chi2"], "chi2");
    EXPECT_EQ(a.dof, y["dof"].as<int>());
    expectNear(a.chi2_p, y["chi2_p"], "chi2_p");
    expectNear(a.segment_s, y["segment_s"], "segment_s");
    expectNear(a.data_rate_hz, y["data_rate_hz"], "data_rate_hz");
    const YAML::Node c = y["continuous"];
    expectValueSigma(a.continuous.angle_random_walk, c["angle_random_walk"], "angle_random_walk");
    const std::pair<const gyro_allan::ValueSigma*, const char*> optional[] = {
        {&a.continuous.quantization, "quantization"},
        {&a.continuous.rate_random_walk, "rate_random_walk"},
        {&a.continuous.rate_ramp, "rate_ramp"}};
    for (const auto& o : optional) {
      if (c[o.second].IsDefined()) {
        expectValueSigma(*o.first, c[o.second], o.second);
      } else {  // not a term of the model: 0 in the message
        EXPECT_EQ(o.first->value, 0.0) << o.second;
        EXPECT_EQ(o.first->sigma, 0.0) << o.second;
      }
    }
    const YAML::Node ma = c["moving_average"];  // MA(q) short-memory noise: only in MA models
    if (ma.IsDefined()) {
      EXPECT_EQ(a.continuous.moving_average.order, ma["order"].as<unsigned>());
      EXPECT_EQ(a.continuous.moving_average.theta.size(), ma["theta"].size());
      for (size_t k = 0; k < a.continuous.moving_average.theta.size() && k < ma["theta"].size(); ++k) {
        expectNear(a.continuous.moving_average.theta[k], ma["theta"][k], "ma theta");
        expectNear(a.continuous.moving_average.theta_sigma[k], ma["theta_sigma"][k], "ma theta_sigma");
      }
      expectValueSigma(a.continuous.moving_average.innovation, ma["innovation"], "ma innovation");
    } else {
      EXPECT_EQ(a.continuous.moving_average.order, 0u);
    }
    const YAML::Node gm = c["gauss_markov"];
    EXPECT_EQ(a.continuous.gauss_markov.size(), gm.size());
    for (size_t k = 0; k < a.continuous.gauss_markov.size() && k < gm.size(); ++k) {
      expectValueSigma(a.continuous.gauss_markov[k].sigma, gm[k]["sigma"], "gm sigma");
      expectValueSigma(a.continuous.gauss_markov[k].correlation_time, gm[k]["correlation_time"], "gm tc");
    }
    gm_terms += static_cast<int>(a.continuous.gauss_markov.size());
    const YAML::Node kn = y["known_terms"];  // the model check's effects: only when it found some
    EXPECT_EQ(a.known_terms.size(), kn ? kn.size() : 0u);
    for (size_t k = 0; kn && k < a.known_terms.size() && k < kn.size(); ++k) {
      EXPECT_EQ(a.known_terms[k].type, kn[k]["type"].as<std::string>());
      EXPECT_EQ(a.known_terms[k].in_gmwm_fit, kn[k]["in_gmwm_fit"].as<bool>());
      EXPECT_EQ(a.known_terms[k].note, kn[k]["note"].as<std::string>());
      if (kn[k]["rms"]) expectValueSigma(a.known_terms[k].rms, kn[k]["rms"], "known term rms");
      if (kn[k]["frequency_hz"]) expectNear(a.known_terms[k].frequency_hz, kn[k]["frequency_hz"], "known term frequency");
    }
    const YAML::Node disc = y["discrete"];
    EXPECT_EQ(a.discrete.size(), 2u);  // data rate and filter rate
    EXPECT_EQ(a.discrete.size(), disc.size());
    for (size_t k = 0; k < a.discrete.size() && k < disc.size(); ++k) {
      const gyro_allan::DiscreteBiasModel& d = a.discrete[k];
      const YAML::Node yd = disc[k];
      const std::string w = "discrete[" + std::to_string(k) + "]";
      expectNear(d.dt, yd["dt"], w + ".dt");
      expectNear(d.rate_hz, yd["rate_hz"], w + ".rate_hz");
      EXPECT_EQ(d.states, strings(yd["states"])) << w;
      EXPECT_EQ(d.folded_into_white, strings(yd["folded_into_white"])) << w;
      EXPECT_EQ(d.dimension, d.states.size()) << w;
      const size_t n = d.dimension;
      if (d.Phi.size() != n * n || d.Qd.size() != n * n || yd["Phi"].size() != n || yd["Qd"].size() != n) {
        ADD_FAILURE() << w << ": Phi/Qd sizes " << d.Phi.size() << ", " << d.Qd.size() << " (message), "
                      << yd["Phi"].size() << ", " << yd["Qd"].size() << " rows (noise_model.yaml), dimension " << n;
        continue;
      }
      for (size_t i = 0; i < n; ++i)
        for (size_t j = 0; j < n; ++j) {
          expectNear(d.Phi[i * n + j], yd["Phi"][i][j], w + ".Phi");
          expectNear(d.Qd[i * n + j], yd["Qd"][i][j], w + ".Qd");
        }
      expectNear(d.measurement_variance, yd["measurement_variance"], w + ".measurement_variance");
      expectNear(d.white_variance, yd["white_variance"], w + ".white_variance");
      expectNear(d.quantization_variance, yd["quantization_variance"], w + ".quantization_variance");
      EXPECT_EQ(d.approximation, yd["approximation"].IsDefined() ? yd["approximation"].as<std::string>() : "") << w;
    }
    if (a.discrete.size() == 2) {
      EXPECT_NEAR(a.discrete[1].dt, 1.0 / kFilterRate, 1e-15);
    }
    const YAML::Node fl = y["flicker_approximation"];
    EXPECT_EQ(a.flicker_approximation.gauss_markov_terms, fl["gauss_markov_terms"].as<int>());
    expectNear(a.flicker_approximation.tau_range_s[0], fl["tau_range_s"][0], "tau_range_s[0]");
    expectNear(a.flicker_approximation.tau_range_s[1], fl["tau_range_s"][1], "tau_range_s[1]");
    expectValueSigma(a.flicker_approximation.ieee_bias_instability, fl["ieee_bias_instability"], "ieee_bias_instability");
    expectNear(a.flicker_approximation.worst_avar_ratio_vs_ieee_model, fl["worst_avar_ratio_vs_ieee_model"],
               "worst_avar_ratio_vs_ieee_model");
    expectNear(a.flicker_approximation.worst_avar_ratio_vs_data, fl["worst_avar_ratio_vs_data"], "worst_avar_ratio_vs_data");
    const YAML::Node cl = y["closed_loop"];
    expectAgreement(a.closed_loop.gmwm_model, cl["gmwm_model"], "gmwm_model");
    expectAgreement(a.closed_loop.ieee_model, cl["ieee_model"], "ieee_model");
    expectAgreement(a.closed_loop.final_model, cl["final_model"], "final_model");
    EXPECT_EQ(a.closed_loop.wavelet_variance_points, cl["wavelet_variance_points"].as<int>());
    EXPECT_EQ(a.closed_loop.wavelet_variance_within_ci, cl["wavelet_variance_within_ci"].as<int>());
    expectNear(a.closed_loop.wavelet_variance_confidence, cl["wavelet_variance_confidence"], "wavelet_variance_confidence");
  }
  return gm_terms;
}

}  // namespace

TEST(NodeletNoiseModel, SameAsAnalyzeBagLatchedSaved) {
  Probe h;
  ASSERT_TRUE(waitFor(30.0, [&] { return h.imu.getNumSubscribers() > 0 && serviceUp(kNode, "analyze"); }))
      << "analyzer nodelet did not come up";
  sh("mkdir -p " + kOut);
  // 10 min at 100 Hz (simulate tool, fixed seed): white noise, a first-order Gauss-Markov term (sigma 2e-4 rad/s,
  // tc 5 s) and a rate random walk, the declared truth of a WN+GM(+RW) bias model.
  const std::string bag = kOut + "/gm.bag", out = kOut + "/analyze_bag";
  ASSERT_EQ(sh(kTools + "/simulate --output " + bag + " --rate 100 --duration 600 --arw 1e-4 --gm-sigma 2e-4 " +
               "--gm-tau 5 --rrw 1e-6 --seed 7 > /dev/null"), 0);
  ASSERT_EQ(analyzeBag(bag, out, "--method gmwm --filter-rate 20"), 0);
  const YAML::Node yaml = YAML::LoadFile(out + "/noise_model.yaml");

  EXPECT_EQ(playBag(bag, h.imu, nullptr, h.diag, 60.0), 60000);
  const std_srvs::Trigger::Response r = trigger(kNode, "analyze");
  ASSERT_TRUE(r.success) << r.message;
  ASSERT_TRUE(waitFor(60.0, [&] { return h.models.count() > 0; })) << "no ~noise_model after ~analyze";
  const gyro_allan::NoiseModel m = h.models.last();
  EXPECT_EQ(m.status, gyro_allan::NoiseModel::STATUS_CURRENT);
  EXPECT_EQ(m.axes.size(), 3u);
  EXPECT_NEAR(m.rate_hz, 100.0, 1e-6);
  ASSERT_EQ(m.sources.size(), 1u);
  EXPECT_EQ(m.sources[0], "live topic /imu");
  EXPECT_NEAR((m.window_end - m.window_start).toSec(), 599.99, 1e-6);  // the whole record is the window
  // Not vacuous: the simulated Gauss-Markov term (declared truth) is found, with a correlation time within a
  // factor 2 of the declared 5 s, on at least one axis.
  const int gm_terms = expectSameAsYaml(m, yaml);
  EXPECT_GE(gm_terms, 1);
  bool tc_found = false;
  for (const auto& a : m.axes)
    for (const auto& g : a.continuous.gauss_markov)
      if (g.correlation_time.value > 2.5 && g.correlation_time.value < 10) tc_found = true;
  EXPECT_TRUE(tc_found) << "no Gauss-Markov term with tc near the simulated 5 s";

  // A subscriber that comes late gets the model at once (latched ~noise_model).
  {
    Latest<gyro_allan::NoiseModel> late(h.nh, kNode + "/noise_model", 1);
    EXPECT_TRUE(waitFor(10.0, [&] { return late.count() > 0; })) << "late subscriber got no ~noise_model";
    EXPECT_EQ(late.last().window_end, m.window_end);
  }

  // The "noise model" diagnostic names each axis's model.
  EXPECT_TRUE(waitFor(5.0, [&] { return h.diag.message("noise model").find("x " + m.axes[0].model) != std::string::npos; }))
      << h.diag.message("noise model");
  EXPECT_EQ(h.diag.value("filter rate (Hz, 0 = data rate only)"), kFilterRate);

  // ~save writes noise_model.yaml through analyze_bag's writer: the same axes as analyze_bag's file; its report.yaml
  // names the method as analyze_bag --method gmwm --filter-rate 20 does ("gmwm", not "auto").
  const std_srvs::Trigger::Response saved = trigger(kNode, "save");
  ASSERT_TRUE(saved.success) << saved.message;
  const std::string dir = savedDir(saved.message);
  ASSERT_FALSE(dir.empty()) << saved.message;
  EXPECT_NE(saved.message.find(dir + "/noise_model.yaml"), std::string::npos) << saved.message;
  const YAML::Node saved_yaml = YAML::LoadFile(dir + "/noise_model.yaml");
  YAML::Emitter a, b;
  a << saved_yaml["axes"];
  b << yaml["axes"];
  EXPECT_EQ(std::string(a.c_str()), std::string(b.c_str()));
  EXPECT_EQ(saved_yaml["sources"][0].as<std::string>(), "live topic /imu");
  const YAML::Node bag_report = YAML::LoadFile(out + "/report.yaml");
  EXPECT_EQ(bag_report["method"].as<std::string>(), "gmwm");
  EXPECT_EQ(YAML::LoadFile(dir + "/report.yaml")["method"].as<std::string>(), bag_report["method"].as<std::string>());

  // dynamic_reconfigure: a filter rate turns the GMWM stage on even when gmwm is asked off (as analyze_bag
  // --filter-rate implies --method gmwm); with both off the latched model is replaced by one saying "off" (no axes),
  // which a late subscriber gets, and the next window publishes no ~noise_model.
  auto gmwmAfter = [](bool gmwm, double filter_rate) {
    dynamic_reconfigure::Config applied;
    EXPECT_TRUE(reconfigure(kNode, {{"filter_rate", filter_rate}}, {{"gmwm", gmwm}}, &applied));
    bool found = false;
    const bool on = configBool(applied, "gmwm", &found);
    EXPECT_TRUE(found) << "no gmwm in the reconfigure response";
    return on;
  };
  EXPECT_TRUE(gmwmAfter(false, 50.0));
  EXPECT_TRUE(waitFor(5.0, [&] { return h.diag.value("filter rate (Hz, 0 = data rate only)") == 50.0; }));
  EXPECT_EQ(h.models.count(), 1) << "~noise_model published without an analysis";
  EXPECT_FALSE(gmwmAfter(false, 0.0));
  EXPECT_TRUE(waitFor(5.0, [&] { return h.diag.message("noise model") == "GMWM off (~gmwm)"; }))
      << h.diag.message("noise model");
  EXPECT_TRUE(waitFor(5.0, [&] { return h.models.count() == 2; })) << "no \"off\" ~noise_model after ~gmwm off";
  const gyro_allan::NoiseModel off = h.models.last();
  EXPECT_EQ(off.status, gyro_allan::NoiseModel::STATUS_OFF);
  EXPECT_TRUE(off.axes.empty());
  EXPECT_EQ(off.header.frame_id, m.header.frame_id);
  {
    Latest<gyro_allan::NoiseModel> late(h.nh, kNode + "/noise_model", 1);
    EXPECT_TRUE(waitFor(10.0, [&] { return late.count() > 0; })) << "late subscriber got no ~noise_model";
    EXPECT_EQ(late.last().status, gyro_allan::NoiseModel::STATUS_OFF) << "a late subscriber still gets the old model";
    EXPECT_TRUE(late.last().axes.empty());
  }
  const int models_before = h.models.count();
  const double analyses = h.diag.value("analyses (total)");
  ASSERT_TRUE(trigger(kNode, "analyze").success);
  EXPECT_TRUE(waitFor(60.0, [&] { return h.diag.value("analyses (total)") == analyses + 1; }));
  ros::WallDuration(0.5).sleep();
  EXPECT_EQ(h.models.count(), models_before) << "~noise_model published with gmwm off";
}

int main(int argc, char** argv) { return nodelet_test::runRostest(argc, argv, "nodelet_noise_model", 2); }
