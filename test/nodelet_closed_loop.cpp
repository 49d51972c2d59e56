// rostest node for AnalyzerNodelet's closed loop (issue 15): the nodelet, fed a bag's messages, publishes the effect,
// the before/after fit error and the coefficients analyze_bag reports for the same samples; dynparam changes the
// window live; ~save writes report.yaml, allan.csv and imu.yaml; a late ~noise subscriber gets the last result.
#include <gtest/gtest.h>

#include <sys/stat.h>

#include <algorithm>
#include <cmath>
#include <string>

#include <gyro_allan/NoiseReport.h>
#include <ros/ros.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/Temperature.h>
#include <yaml-cpp/yaml.h>

#include "nodelet_util.hpp"

namespace {

using namespace nodelet_test;

const std::string kNode = "loop_analyzer";
const std::string kOut = std::string(GYRO_ALLAN_TEST_OUT) + "/nodelet_closed_loop";
const std::string kTools = GYRO_ALLAN_TOOL_DIR;

/// The test's view of the nodelet: its IMU and temperature input, ~noise and diagnostics.
struct Loop {
  ros::NodeHandle nh;
  ros::Publisher imu = nh.advertise<sensor_msgs::Imu>("imu", 300000);
  ros::Publisher temp = nh.advertise<sensor_msgs::Temperature>("temperature", 10000);
  Latest<gyro_allan::NoiseReport> reports{nh, kNode + "/noise"};
  Diagnostics diag{nh, kNode};

  /// Publishes every IMU and temperature message of a bag and waits until the nodelet has them all; the IMU count.
  int64_t play(const std::string& bag) { return playBag(bag, imu, &temp, diag, 120.0); }
  /// ~analyze and the report it publishes.
  gyro_allan::NoiseReport analyze() {
    const int before = reports.count();
    const std_srvs::Trigger::Response r = trigger(kNode, "analyze");
    EXPECT_TRUE(r.success) << r.message;
    EXPECT_TRUE(waitFor(60.0, [&] { return reports.count() > before; })) << "no ~noise after ~analyze";
    return reports.last();
  }
};

double rel(double a, double b) { return std::fabs(a - b) / std::max(std::fabs(b), 1e-300); }

/// The nodelet's report against analyze_bag's report.yaml of the same bag: the same effects (type, every parameter
/// and its sigma), fit error before and after the model check, corrected coefficients, the answer's coefficients,
/// method and verdict. report.yaml prints 10 significant digits: relative tolerance 1e-8.
void expectSameAsAnalyzeBag(const gyro_allan::NoiseReport& r, const YAML::Node& report, const std::string& effect) {
  const double tol = 1e-8;
  ASSERT_EQ(r.axes.size(), 3u);
  EXPECT_EQ(r.samples, report["axes"]["x"]["samples"].as<int64_t>());
  const char* terms[5] = {"quantization", "angle_random_walk", "bias_instability", "rate_random_walk", "rate_ramp"};
  bool found = false;
  for (const gyro_allan::AxisNoiseFit& a : r.axes) {
    SCOPED_TRACE("axis " + a.axis);
    const YAML::Node y = report["axes"][a.axis];
    EXPECT_EQ(a.method, y["method"].as<std::string>());
    EXPECT_EQ(a.quality, y["quality"].as<std::string>());
    const gyro_allan::NoiseCoefficient* c[5] = {&a.quantization, &a.angle_random_walk, &a.bias_instability,
                                                &a.rate_random_walk, &a.rate_ramp};
    for (int t = 0; t < 5; ++t) {
      EXPECT_LE(rel(c[t]->value, y["coefficients"][terms[t]]["value"].as<double>()), tol) << terms[t];
      EXPECT_LE(rel(c[t]->sigma, y["coefficients"][terms[t]]["sigma"].as<double>()), tol) << terms[t];
      EXPECT_EQ(c[t]->supported, y["coefficients"][terms[t]]["supported"].as<bool>()) << terms[t];
    }
    const YAML::Node mc = y["model_check"];
    ASSERT_TRUE(a.model_checked) << a.model_check_note;
    ASSERT_TRUE(mc.IsDefined());
    EXPECT_LE(rel(a.rms_log10_before, mc["before"]["rms_log10"].as<double>()), tol);
    EXPECT_LE(rel(a.rms_log10_after, mc["after"]["rms_log10"].as<double>()), tol);
    EXPECT_LE(rel(a.chi2_dof_before, mc["before"]["chi2_dof"].as<double>()), tol);
    EXPECT_LE(rel(a.chi2_dof_after, mc["after"]["chi2_dof"].as<double>()), tol);
    const YAML::Node fx = mc["effects"];
    ASSERT_EQ(a.effects.size(), fx.IsSequence() ? fx.size() : 0u);
    for (size_t k = 0; k < a.effects.size(); ++k) {
      EXPECT_EQ(a.effects[k].type, fx[k]["type"].as<std::string>());
      EXPECT_EQ(a.effects[k].evidence, fx[k]["evidence"].as<std::string>());
      for (size_t j = 0; j < a.effects[k].param_names.size(); ++j) {
        const YAML::Node pj = fx[k]["parameters"][a.effects[k].param_names[j]];
        EXPECT_LE(rel(a.effects[k].param_values[j], pj["value"].as<double>()), tol) << a.effects[k].param_names[j];
        EXPECT_LE(rel(a.effects[k].param_sigmas[j], pj["sigma"].as<double>()), tol) << a.effects[k].param_names[j];
      }
      if (a.effects[k].type == effect) found = true;
    }
    ASSERT_EQ(a.corrected.size(), 5u);
    for (int t = 0; t < 5; ++t)
      EXPECT_LE(rel(a.corrected[t].value, mc["coefficients"][terms[t]]["value"].as<double>()), tol) << terms[t];
  }
  // Not vacuous: the injected effect (declared truth of the simulation) is found on some axis.
  EXPECT_TRUE(found) << "no " << effect << " effect";
}

YAML::Node analyzeBagReport(const std::string& bag, const std::string& out) {
  EXPECT_EQ(analyzeBag(bag, out), 0);
  return YAML::LoadFile(out + "/report.yaml");
}

}  // namespace

TEST(NodeletClosedLoop, SameAsAnalyzeBagLiveControlSaveLatched) {
  Loop h;
  ASSERT_TRUE(waitFor(30.0, [&] {
    return h.imu.getNumSubscribers() > 0 && h.temp.getNumSubscribers() > 0 && serviceUp(kNode, "analyze");
  })) << "analyzer nodelet did not come up";
  sh("mkdir -p " + kOut);
  // 20 min at 100 Hz with declared noise and one undeclared effect each (simulate tool, fixed seeds):
  // a warm-up drift of 2 mrad/s (theta 200 s) with the temperature series, and a 0.5 mrad/s sinusoid at 2.5 Hz.
  const std::string warm = kOut + "/warm.bag", sine = kOut + "/sine.bag";
  ASSERT_EQ(sh(kTools + "/simulate --output " + warm + " --rate 100 --duration 1200 --arw 1e-4 --rrw 1e-6 " +
               "--thermal-amplitude 2e-3 --thermal-tau 200 --temperature --seed 3 > /dev/null"), 0);
  ASSERT_EQ(sh(kTools + "/simulate --output " + sine + " --rate 100 --duration 1200 --arw 1e-4 " +
               "--sine-amplitude 5e-4 --sine-frequency 2.5 --seed 4 > /dev/null"), 0);

  // Warm-up: whole record in one window, the same answer as analyze_bag.
  EXPECT_EQ(h.play(warm), 120000);
  const gyro_allan::NoiseReport rw = h.analyze();
  expectSameAsAnalyzeBag(rw, analyzeBagReport(warm, kOut + "/warm_out"), "thermal_drift");
  EXPECT_TRUE(std::isfinite(rw.temperature));
  EXPECT_EQ(h.diag.hardwareId(), "imu_link");  // the IMU's frame_id (simulate --frame default)

  // Sinusoid: the window is emptied first (~reset), then the same.
  EXPECT_TRUE(trigger(kNode, "reset").success);
  EXPECT_EQ(h.play(sine), 120000);
  const gyro_allan::NoiseReport rs = h.analyze();
  expectSameAsAnalyzeBag(rs, analyzeBagReport(sine, kOut + "/sine_out"), "sinusoid");

  // dynamic_reconfigure (what `rosrun dynamic_reconfigure dynparam set /loop_analyzer window_s 600` sends): the
  // window shrinks to the newest 600 s at once, and hop_s (3600) is brought down to the window with it.
  ASSERT_TRUE(reconfigure(kNode, {{"window_s", 600.0}}, {}));
  EXPECT_TRUE(waitFor(10.0, [&] { return h.diag.value("window (s)") == 600.0; }));
  EXPECT_EQ(h.diag.value("hop (s)"), 600.0);
  const gyro_allan::NoiseReport r600 = h.analyze();
  EXPECT_EQ(r600.window_s, 600.0);
  EXPECT_LE((r600.window_end - r600.window_start).toSec(), 600.0 + 0.011);
  EXPECT_NEAR(static_cast<double>(r600.samples), 60000.0, 2.0);

  // ~save writes the three files of the last analysis (the 600 s window).
  const std_srvs::Trigger::Response saved = trigger(kNode, "save");
  ASSERT_TRUE(saved.success) << saved.message;
  const std::string dir = savedDir(saved.message);
  ASSERT_FALSE(dir.empty()) << saved.message;
  struct stat st;
  for (const char* f : {"/report.yaml", "/allan.csv", "/imu.yaml"})
    EXPECT_EQ(stat((dir + f).c_str(), &st), 0) << dir << f;
  const YAML::Node saved_report = YAML::LoadFile(dir + "/report.yaml");
  EXPECT_EQ(saved_report["axes"]["x"]["samples"].as<int64_t>(), r600.samples);
  EXPECT_EQ(saved_report["method"].as<std::string>(), "auto");  // as analyze_bag's report without --method

  // A subscriber that comes late gets the last result at once (latched ~noise).
  Latest<gyro_allan::NoiseReport> late(h.nh, kNode + "/noise", 1);
  EXPECT_TRUE(waitFor(10.0, [&] { return late.count() > 0; }));
  EXPECT_EQ(late.last().window_end, r600.window_end);
}

int main(int argc, char** argv) { return nodelet_test::runRostest(argc, argv, "nodelet_closed_loop", 2); }
