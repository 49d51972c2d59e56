// rostest node: AnalyzerNodelet started with absurd parameters (negative window, hop > window, negative rate,
// gap factor < 1, ...), retired, misspelt and mistyped ones stays up, names every problem in its 'parameters'
// status, uses the documented replacements and analyses every valid sample.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>

#include <ros/ros.h>
#include <sensor_msgs/Imu.h>

#include "nodelet_util.hpp"

namespace {

using namespace nodelet_test;

/// The test's view of the nodelet: its IMU input and diagnostics.
struct Probe {
  ros::NodeHandle nh;
  ros::Publisher pub_ = nh.advertise<sensor_msgs::Imu>("imu", 10000);
  Diagnostics diag{nh, "badparam_analyzer", 100};
  double value(const std::string& key) { return diag.value(key); }
  /// A status's message and values as one text.
  std::string text(const std::string& status) { return diag.text(status); }
};

}  // namespace

TEST(NodeletBadParams, ComesUpWithDocumentedReplacements) {
  Probe p;
  const ros::WallTime until = ros::WallTime::now() + ros::WallDuration(30.0);
  while (p.pub_.getNumSubscribers() == 0 && ros::WallTime::now() < until) ros::WallDuration(0.05).sleep();
  ASSERT_GT(p.pub_.getNumSubscribers(), 0u) << "analyzer nodelet did not come up";
  ros::WallDuration(0.3).sleep();
  std::mt19937 rng(1);
  std::normal_distribution<double> g(0, 0.01);
  const int n = 1200;  // 6 s at 200 Hz
  ros::WallRate r(100);
  for (int i = 0; i < n; i += 2) {
    for (int j = i; j < i + 2; ++j) {
      const double x = g(rng), y = g(rng), z = g(rng);
      p.pub_.publish(imuMessage(ros::Time(500.0) + ros::Duration(j / 200.0), x, y, z, ""));
    }
    r.sleep();
  }
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(10.0);
  while (ros::WallTime::now() < end && !(p.value("samples received (total)") >= n)) ros::WallDuration(0.1).sleep();
  EXPECT_EQ(p.value("samples received (total)"), n);
  EXPECT_EQ(p.value("window (s)"), 3600.0);     // window_s -5 -> default
  EXPECT_EQ(p.value("hop (s)"), 300.0);         // hop_s > window -> min(300, window)
  EXPECT_EQ(p.value("expected rate (Hz, 0 = from the stamps)"), 0.0);  // expected_rate_hz < 0 -> from the stamps
  EXPECT_EQ(p.value("gap factor"), 1.5);        // gap_factor 0.5 -> 1.5
  EXPECT_EQ(p.value("quick answer: period update_s [s]"), 5.0);  // update_s -2 -> 5
  // Every problem named: invalid values, retired names, a misspelt name, a mistyped value.
  const std::string all = p.text("parameters");
  for (const char* name : {"~window_s", "~hop_s", "~update_s", "~expected_rate_hz", "~gap_factor", "~tau_grid", "~input",
                           "~confidence", "~learn_samples", "~saturation_limit", "~windw_s", "~model_check", "~gmwm",
                           "~filter_rate"})
    EXPECT_NE(all.find(name), std::string::npos) << name << " not reported in: " << all;
  EXPECT_NE(all.find("~learn_samples is no longer used"), std::string::npos) << all;
  EXPECT_NE(all.find("~windw_s is unknown"), std::string::npos) << all;
  EXPECT_NE(all.find("~model_check must be true or false"), std::string::npos) << all;
  EXPECT_NE(all.find("~gmwm must be true or false"), std::string::npos) << all;
  EXPECT_NE(all.find("~filter_rate must be in [0, 1e6] Hz"), std::string::npos) << all;
  EXPECT_NE(all.find("~update_s must be in [0, 1e6] s"), std::string::npos) << all;
  EXPECT_EQ(p.value("filter rate (Hz, 0 = data rate only)"), 0.0);  // filter_rate -20 -> 0 (data rate only)
  EXPECT_NE(p.text("noise model").find("GMWM off (~gmwm)"), std::string::npos);  // gmwm "on" -> default false
  // ... and it analyses normally: the 6 s window on request (~analyze), at the rate from the stamps.
  std_srvs::Trigger::Response t;
  ASSERT_TRUE(callTrigger("badparam_analyzer", "analyze", &t));
  EXPECT_TRUE(t.success) << t.message;
  const ros::WallTime end2 = ros::WallTime::now() + ros::WallDuration(20.0);
  while (ros::WallTime::now() < end2 && std::isnan(p.value("nominal rate (Hz)"))) ros::WallDuration(0.1).sleep();
  EXPECT_NEAR(p.value("nominal rate (Hz)"), 200.0, 1.0);
  EXPECT_EQ(p.value("out of order (total)"), 0.0);
  EXPECT_EQ(p.value("gaps (total)"), 0.0);
}

int main(int argc, char** argv) { return nodelet_test::runRostest(argc, argv, "nodelet_bad_params", 1); }
