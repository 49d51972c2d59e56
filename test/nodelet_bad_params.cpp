// rostest node: AnalyzerNodelet started with absurd parameters (negative window, hop > window, negative rate,
// gap factor < 1, ...), retired, misspelt and mistyped ones stays up, names every problem in its 'parameters'
// status, uses the documented replacements and analyses every valid sample.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <mutex>
#include <random>
#include <string>

#include <diagnostic_msgs/DiagnosticArray.h>
#include <ros/ros.h>
#include <sensor_msgs/Imu.h>
#include <std_srvs/Trigger.h>

namespace {

class Probe {
 public:
  Probe() {
    pub_ = nh_.advertise<sensor_msgs::Imu>("imu", 10000);
    sub_ = nh_.subscribe("/diagnostics", 100, &Probe::onDiag, this);
  }
  void onDiag(const diagnostic_msgs::DiagnosticArray::ConstPtr& msg) {
    std::lock_guard<std::mutex> l(mutex_);
    for (const auto& s : msg->status) {
      if (s.name.rfind("gyro_allan/badparam_analyzer: ", 0) != 0) continue;
      for (const auto& kv : s.values) values_[kv.key] = kv.value;
      std::string all = s.message;
      for (const auto& kv : s.values) all += "\n" + kv.value;
      texts_[s.name.substr(s.name.find(": ") + 2)] = all;
    }
  }
  double value(const std::string& key) {
    std::lock_guard<std::mutex> l(mutex_);
    auto it = values_.find(key);
    return it == values_.end() ? std::nan("") : std::atof(it->second.c_str());
  }
  /// A status's message and values as one text.
  std::string text(const std::string& status) {
    std::lock_guard<std::mutex> l(mutex_);
    return texts_[status];
  }
  ros::Publisher pub_;

 private:
  ros::NodeHandle nh_;
  ros::Subscriber sub_;
  std::mutex mutex_;
  std::map<std::string, std::string> values_, texts_;
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
      sensor_msgs::Imu m;
      m.header.stamp = ros::Time(500.0) + ros::Duration(j / 200.0);
      m.angular_velocity.x = g(rng);
      m.angular_velocity.y = g(rng);
      m.angular_velocity.z = g(rng);
      p.pub_.publish(m);
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
  // Every problem named: invalid values, retired names, a misspelt name, a mistyped value.
  const std::string all = p.text("parameters");
  for (const char* name : {"~window_s", "~hop_s", "~expected_rate_hz", "~gap_factor", "~tau_grid", "~input",
                           "~confidence", "~learn_samples", "~saturation_limit", "~windw_s", "~model_check", "~gmwm",
                           "~filter_rate"})
    EXPECT_NE(all.find(name), std::string::npos) << name << " not reported in: " << all;
  EXPECT_NE(all.find("~learn_samples is no longer used"), std::string::npos) << all;
  EXPECT_NE(all.find("~windw_s is unknown"), std::string::npos) << all;
  EXPECT_NE(all.find("~model_check must be true or false"), std::string::npos) << all;
  EXPECT_NE(all.find("~gmwm must be true or false"), std::string::npos) << all;
  EXPECT_NE(all.find("~filter_rate must be in [0, 1e6] Hz"), std::string::npos) << all;
  EXPECT_EQ(p.value("filter rate (Hz, 0 = data rate only)"), 0.0);  // filter_rate -20 -> 0 (data rate only)
  EXPECT_NE(p.text("noise model").find("GMWM off (~gmwm)"), std::string::npos);  // gmwm "on" -> default false
  // ... and it analyses normally: the 6 s window on request (~analyze), at the rate from the stamps.
  std_srvs::Trigger t;
  ASSERT_TRUE(ros::service::call("/badparam_analyzer/analyze", t));
  EXPECT_TRUE(t.response.success) << t.response.message;
  const ros::WallTime end2 = ros::WallTime::now() + ros::WallDuration(20.0);
  while (ros::WallTime::now() < end2 && std::isnan(p.value("nominal rate (Hz)"))) ros::WallDuration(0.1).sleep();
  EXPECT_NEAR(p.value("nominal rate (Hz)"), 200.0, 1.0);
  EXPECT_EQ(p.value("out of order (total)"), 0.0);
  EXPECT_EQ(p.value("gaps (total)"), 0.0);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "nodelet_bad_params");
  ros::AsyncSpinner spinner(1);
  spinner.start();
  const int rc = RUN_ALL_TESTS();
  spinner.stop();
  ros::shutdown();
  return rc;
}
