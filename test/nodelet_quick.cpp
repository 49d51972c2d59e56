// rostest node for the nodelet's quick answers: with the default parameters a 400 Hz IMU gets its first curve and N
// on ~quick and ~allan/* (quick: true) within 30 s of the first sample, then one every update_s (5 s) of input time,
// with N at the declared truth, while the full analysis (hop 300 s) has not run; diagnostics say which is which.
#include <gtest/gtest.h>

#include <cmath>
#include <mutex>
#include <vector>

#include <gyro_allan/AllanCurve.h>
#include <gyro_allan/NoiseReport.h>
#include <gyro_allan/QuickNoise.h>
#include <ros/ros.h>
#include <sensor_msgs/Imu.h>

#include "gyro_allan/simulate.hpp"
#include "nodelet_util.hpp"

namespace {

using namespace nodelet_test;

constexpr double kRate = 400.0;
const double kTrueN[3] = {2e-4, 4e-4, 1e-4};  // rad/sqrt(s) per axis

/// Every message of a topic, with the wall time it arrived.
template <class M>
class Collect {
 public:
  Collect(ros::NodeHandle& nh, const std::string& topic) { sub_ = nh.subscribe(topic, 100, &Collect::on, this); }
  std::vector<std::pair<ros::WallTime, M>> all() {
    std::lock_guard<std::mutex> l(mutex_);
    return all_;
  }
  size_t size() {
    std::lock_guard<std::mutex> l(mutex_);
    return all_.size();
  }

 private:
  void on(const typename M::ConstPtr& m) {
    std::lock_guard<std::mutex> l(mutex_);
    all_.emplace_back(ros::WallTime::now(), *m);
  }
  ros::Subscriber sub_;
  std::mutex mutex_;
  std::vector<std::pair<ros::WallTime, M>> all_;
};

}  // namespace

TEST(NodeletQuick, FirstAnswerWithinSecondsThenEveryUpdate) {
  ros::NodeHandle nh;
  Collect<gyro_allan::QuickNoise> quick(nh, "analyzer/quick");
  Collect<gyro_allan::AllanCurve> curve_x(nh, "analyzer/allan/x");
  Latest<gyro_allan::NoiseReport> full(nh, "analyzer/noise");
  Diagnostics diag(nh, "analyzer");
  ros::Publisher imu = nh.advertise<sensor_msgs::Imu>("imu", 20000);
  ASSERT_TRUE(waitFor(20.0, [&] { return imu.getNumSubscribers() > 0; })) << "analyzer nodelet did not come up";
  ros::WallDuration(0.5).sleep();

  const int64_t n = static_cast<int64_t>(28 * kRate);
  std::vector<double> data[3];
  for (int a = 0; a < 3; ++a) {
    gyro_allan::AxisNoise noise;
    noise.angle_random_walk = kTrueN[a];
    noise.bias = 0.002 * (a + 1);
    data[a] = gyro_allan::simulateAxis(noise, kRate, n, 11, a);
  }
  // Real time: 4 samples every 10 ms, stamped with their sample times.
  const ros::Time t0(2000.0);
  const ros::WallTime start = ros::WallTime::now();
  ros::WallRate rate(100);
  for (int64_t k = 0; k < n && ros::ok(); k += 4) {
    for (int64_t j = k; j < std::min(n, k + 4); ++j)
      imu.publish(imuMessage(t0 + ros::Duration(static_cast<double>(j) / kRate), data[0][j], data[1][j], data[2][j]));
    rate.sleep();
  }
  ASSERT_TRUE(waitFor(10.0, [&] { return quick.size() >= 5; })) << quick.size() << " quick answers";
  const auto q = quick.all();
  // First within 30 s of the first sample (wall time; it is due after min_fit_samples = 1000 samples, 2.5 s).
  EXPECT_LT((q.front().first - start).toSec(), 30.0);
  // Then every 5 s of input time.
  for (size_t i = 1; i < q.size(); ++i)
    EXPECT_NEAR((q[i].second.header.stamp - q[i - 1].second.header.stamp).toSec(), 5.0, 0.05) << i;
  const gyro_allan::QuickNoise& last = q.back().second;
  EXPECT_NEAR(last.rate_hz, kRate, 0.01 * kRate);
  EXPECT_EQ(last.segments, 1);
  EXPECT_DOUBLE_EQ(last.full_age_s, -1.0);  // no full answer yet (hop 300 s)
  EXPECT_EQ(full.count(), 0);
  ASSERT_EQ(last.axes.size(), 3u);
  for (int a = 0; a < 3; ++a) {
    const auto& ax = last.axes[static_cast<size_t>(a)];
    EXPECT_EQ(ax.method, "quick_fit");
    ASSERT_TRUE(ax.fit_ok) << ax.message;
    EXPECT_NEAR(ax.angle_random_walk.value / kTrueN[a], 1.0, 0.05) << "axis " << ax.axis;  // ~25 s at 400 Hz: ~1 %
  }
  // The curves on ~allan/x are marked quick and carry the quick fit's model.
  const auto c = curve_x.all();
  ASSERT_FALSE(c.empty());
  EXPECT_TRUE(c.back().second.quick);
  EXPECT_EQ(c.back().second.model_adev.size(), c.back().second.adev.size());
  // Diagnostics: which answer is which.
  EXPECT_TRUE(waitFor(3.0, [&] { return diag.message("answers").find("quick answer") != std::string::npos; }))
      << diag.message("answers");
  EXPECT_NE(diag.message("answers").find("no full answer yet"), std::string::npos) << diag.message("answers");
}

int main(int argc, char** argv) { return nodelet_test::runRostest(argc, argv, "nodelet_quick", 2); }
