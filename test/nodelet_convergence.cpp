// rostest node for AnalyzerNodelet: ARW converges to the simulated truth; diagnostics react to bad input and recover.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include <diagnostic_msgs/DiagnosticStatus.h>
#include <geometry_msgs/Vector3Stamped.h>
#include <gyro_allan/NoiseReport.h>
#include <ros/ros.h>
#include <sensor_msgs/Imu.h>
#include <std_msgs/Header.h>

#include "gyro_allan/simulate.hpp"
#include "nodelet_util.hpp"

// A message that claims to be sensor_msgs/Imu but carries only its header and a few bytes: the subscriber's
// deserializer must reject it without harming the nodelet. (The header must be complete: the publishing side
// rewrites header.seq in place.)
struct TruncatedImu {
  std_msgs::Header header;
  std::vector<uint8_t> bytes;
};
namespace ros {
namespace message_traits {
template <>
struct MD5Sum<TruncatedImu> {
  static const char* value() { return MD5Sum<sensor_msgs::Imu>::value(); }
  static const char* value(const TruncatedImu&) { return value(); }
};
template <>
struct DataType<TruncatedImu> {
  static const char* value() { return DataType<sensor_msgs::Imu>::value(); }
  static const char* value(const TruncatedImu&) { return value(); }
};
template <>
struct Definition<TruncatedImu> {
  static const char* value() { return Definition<sensor_msgs::Imu>::value(); }
  static const char* value(const TruncatedImu&) { return value(); }
};
}  // namespace message_traits
namespace serialization {
template <>
struct Serializer<TruncatedImu> {
  template <typename Stream>
  inline static void write(Stream& stream, const TruncatedImu& m) {
    stream.next(m.header);
    for (uint8_t b : m.bytes) stream.next(b);
  }
  template <typename Stream>
  inline static void read(Stream&, TruncatedImu&) {}
  inline static uint32_t serializedLength(const TruncatedImu& m) {
    return serializationLength(m.header) + static_cast<uint32_t>(m.bytes.size());
  }
};
}  // namespace serialization
}  // namespace ros

namespace {

using namespace nodelet_test;

constexpr double kRate = 1000.0;
const double kTrueN[3] = {1e-3, 2e-3, 5e-4};  // rad/sqrt(s): ARW declared to the simulator per axis
constexpr double kNTolerance = 0.10;          // relative: 20 s window at 1 kHz pins N to ~1-2 %

class Harness {
 public:
  Harness() : reports_(nh_, "analyzer/noise", 100), diag_(nh_, "analyzer", 100) {
    imu_pub_ = nh_.advertise<sensor_msgs::Imu>("imu", 20000);
    bad_pub_ = nh_.advertise<TruncatedImu>("imu", 100);
    angle_pub_ = nh_.advertise<geometry_msgs::Vector3Stamped>("angle", 100);
    const int64_t n = 120000;
    for (int a = 0; a < 3; ++a) {
      gyro_allan::AxisNoise noise;
      noise.angle_random_walk = kTrueN[a];
      noise.bias = 0.01 * (a + 1);
      data_[a] = gyro_allan::simulateAxis(noise, kRate, n, 42, a);
    }
    // Arrival-time stamps of a driver that stamps on receipt: up to half a period late, 1 % held back 2-10
    // periods with a burst behind them read at once (the burst shares one stamp), as offsets from the sample times,
    // for jittered(true).
    std::vector<double> t(static_cast<size_t>(n));
    for (int64_t k = 0; k < n; ++k) t[static_cast<size_t>(k)] = k / kRate;
    const std::vector<double> r = gyro_allan::receiptStamps(t, 1.0 / kRate, 0.5, 0.01, 7, true);
    delay_.resize(t.size());
    for (size_t k = 0; k < t.size(); ++k) delay_[k] = r[k] - t[k];
  }
  void jittered(bool on) { jittered_ = on; }
  void moving(bool on) { moving_ = on; }

  bool waitForSubscriber(double timeout_s) {
    return waitFor(timeout_s, [&] { return imu_pub_.getNumSubscribers() > 0 && reports_.publishers() > 0; });
  }

  /// Publishes clean samples in real time (10 per 10 ms) for `seconds`, or until pred() is true. Returns pred's
  /// last value (true when there is no predicate).
  template <class Pred>
  bool publishUntil(double seconds, Pred pred) {
    ros::WallRate rate(100);
    const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(seconds);
    while (ros::WallTime::now() < end && ros::ok()) {
      for (int j = 0; j < 10; ++j) publishNext();
      if (pred()) return true;
      rate.sleep();
    }
    return pred();
  }
  void publishFor(double seconds) {
    publishUntil(seconds, [] { return false; });
  }

  void publishNext(double override_x = NAN, bool use_override = false) {
    const size_t k = next_ % data_[0].size();
    // Hand-waving when moving(true): 0.5 rad/s at 0.5 Hz about x.
    const double wave = moving_ ? 0.5 * std::sin(M_PI * static_cast<double>(next_) / kRate) : 0.0;
    publish(stamp(next_), use_override ? override_x : data_[0][k] + wave, data_[1][k], data_[2][k]);
    ++next_;
  }
  void publish(const ros::Time& stamp, double x, double y, double z) { imu_pub_.publish(imuMessage(stamp, x, y, z)); }
  ros::Time stamp(int64_t k) const {
    return t0_ + ros::Duration(k / kRate + (jittered_ ? delay_[static_cast<size_t>(k) % delay_.size()] : 0.0));
  }
  void skip(int64_t samples) { next_ += samples; }
  int64_t next() const { return next_; }

  void publishTruncated() {
    TruncatedImu bad;
    bad.header.stamp = stamp(next_);
    bad.header.frame_id = "imu_link";
    bad.bytes = {1, 2, 3, 4, 5, 6, 7};
    bad_pub_.publish(bad);
  }
  void publishAngle() {
    geometry_msgs::Vector3Stamped m;
    m.header.stamp = stamp(next_);
    angle_pub_.publish(m);
  }

  // ---- observations
  int level(const std::string& status) { return diag_.level(status); }
  int maxLevel(const std::string& status) { return diag_.maxLevel(status); }
  std::string message(const std::string& status) { return diag_.message(status); }
  void clearMax() { diag_.clearMax(); }
  int reports() { return reports_.count(); }
  gyro_allan::NoiseReport lastReport() { return reports_.last(); }

 private:
  ros::NodeHandle nh_;
  Latest<gyro_allan::NoiseReport> reports_;
  Diagnostics diag_;
  ros::Publisher imu_pub_, bad_pub_, angle_pub_;
  std::vector<double> data_[3];
  std::vector<double> delay_;
  bool jittered_ = false, moving_ = false;
  ros::Time t0_{1000.0};
  int64_t next_ = 0;
};

const int OK = diagnostic_msgs::DiagnosticStatus::OK;
const int WARN = diagnostic_msgs::DiagnosticStatus::WARN;

void expectConverged(const gyro_allan::NoiseReport& r, const char* when) {
  ASSERT_EQ(r.axes.size(), 3u) << when;
  EXPECT_NEAR(r.rate_hz, kRate, 0.01 * kRate) << when;
  for (int a = 0; a < 3; ++a) {
    const auto& ax = r.axes[a];
    EXPECT_TRUE(ax.fit_ok) << when << " axis " << ax.axis << ": " << ax.message;
    EXPECT_TRUE(ax.angle_random_walk.supported) << when << " axis " << ax.axis;
    EXPECT_NEAR(ax.angle_random_walk.value, kTrueN[a], kNTolerance * kTrueN[a])
        << when << " axis " << ax.axis << " (sigma " << ax.angle_random_walk.sigma << ")";
  }
}

}  // namespace

TEST(NodeletConvergence, ConvergesReactsAndRecovers) {
  Harness h;
  ASSERT_TRUE(h.waitForSubscriber(20.0)) << "analyzer nodelet did not come up";
  ros::WallDuration(0.5).sleep();

  // A. Clean data: reports arrive and N converges (window 20 s, hop 1 s, rate learned from 200 intervals).
  ASSERT_TRUE(h.publishUntil(25.0, [&] { return h.reports() >= 3 && h.next() >= 12000; }))
      << "no noise reports after " << h.next() << " samples";
  h.publishFor(1.5);  // let the diagnostics settle on clean data
  expectConverged(h.lastReport(), "clean");
  EXPECT_EQ(h.lastReport().segments, 1);
  EXPECT_EQ(h.level("stamps"), OK) << h.message("stamps");
  EXPECT_EQ(h.level("input values"), OK) << h.message("input values");
  EXPECT_EQ(h.level("window"), OK) << h.message("window");
  EXPECT_EQ(h.level("angle random walk"), OK) << h.message("angle random walk");
  EXPECT_GE(h.level("fit quality"), OK) << "fit quality status missing";
  // The verdict analyze_bag writes (quality.hpp): present, and clean data is not a bad fit.
  EXPECT_GE(h.level("quality verdict"), OK) << "quality verdict status missing";
  EXPECT_LE(h.level("quality verdict"), WARN) << h.message("quality verdict");

  // A2. Arrival-time stamps (jitter up to half a period, 1 % of samples late by 2-10 periods with a burst behind
  // them sharing one stamp): the grid places the samples, none is a duplicate; no gap, no stamp warning, one
  // segment, N still converged.
  h.clearMax();
  h.jittered(true);
  const int before_jitter = h.reports();
  h.publishUntil(25.0, [&] { return h.reports() >= before_jitter + 8; });
  EXPECT_EQ(h.maxLevel("stamps"), OK) << h.message("stamps");
  EXPECT_EQ(h.lastReport().segments, 1) << "arrival-time jitter must not split the window";
  expectConverged(h.lastReport(), "arrival-time stamps");
  h.jittered(false);

  // B. One NaN sample: "input values" goes to WARN/ERROR, then back to OK (diag/recent_s = 3 s). (Its empty grid
  // slot is a one-sample gap, as analyze_bag counts it, so "stamps" may warn too.)
  h.clearMax();
  h.publishNext(std::nan(""), true);
  EXPECT_TRUE(h.publishUntil(5.0, [&] { return h.maxLevel("input values") >= WARN; })) << "NaN not reported";
  EXPECT_TRUE(h.publishUntil(10.0, [&] { return h.level("input values") == OK; }))
      << "input values did not recover: " << h.message("input values");

  // B2. Isolated spikes (30 sigma) on x: removed by the same spike rule as analyze_bag, reported as a WARN of
  // "input values" while they are in the window (20 s), and N stays at the truth.
  h.clearMax();
  for (int k = 0; k < 5; ++k) {
    h.publishNext(1.0, true);
    h.publishUntil(0.1, [] { return false; });
  }
  EXPECT_TRUE(h.publishUntil(10.0, [&] { return h.maxLevel("input values") >= WARN; })) << "spikes not reported";
  EXPECT_NE(h.message("input values").find("spikes removed"), std::string::npos) << h.message("input values");
  EXPECT_TRUE(h.publishUntil(30.0, [&] { return h.level("input values") == OK; }))
      << "input values did not recover: " << h.message("input values");
  expectConverged(h.lastReport(), "after spikes");

  // C. A 100 ms gap in the stamps: "stamps" warns, the window is segmented, then recovery.
  h.clearMax();
  h.skip(100);
  EXPECT_TRUE(h.publishUntil(5.0, [&] { return h.maxLevel("stamps") >= WARN; })) << "gap not reported";
  EXPECT_TRUE(h.publishUntil(10.0, [&] { return h.level("stamps") == OK; }))
      << "stamps did not recover: " << h.message("stamps");
  EXPECT_GE(h.lastReport().segments, 2) << "a gap must split the window into segments";

  // D. An out-of-order and a duplicate stamp.
  h.clearMax();
  h.publish(h.stamp(h.next() - 5), 0.0, 0.0, 0.0);
  h.publish(h.stamp(h.next() - 1), 0.0, 0.0, 0.0);
  EXPECT_TRUE(h.publishUntil(5.0, [&] { return h.maxLevel("stamps") >= WARN; })) << "out of order not reported";
  EXPECT_TRUE(h.publishUntil(10.0, [&] { return h.level("stamps") == OK; }))
      << "stamps did not recover: " << h.message("stamps");

  // E. Malformed input: truncated Imu payloads, a zero stamp, a message on the other source topic. The nodelet
  // must survive (reports keep coming) and its statuses recover.
  h.clearMax();
  for (int i = 0; i < 5; ++i) h.publishTruncated();
  h.publish(ros::Time(0), 0.1, 0.1, 0.1);
  h.publishAngle();
  const int before = h.reports();
  EXPECT_TRUE(h.publishUntil(5.0, [&] { return h.maxLevel("stamps") >= WARN; })) << "zero stamp not reported";
  EXPECT_TRUE(h.publishUntil(12.0, [&] {
    return h.reports() >= before + 3 && h.level("stamps") == OK && h.level("input values") == OK;
  })) << "after malformed input: reports " << h.reports() - before << ", stamps '" << h.message("stamps")
      << "', values '" << h.message("input values") << "'";
  expectConverged(h.lastReport(), "after bad input");

  // F. One stamp 1000 s in the future (a clock glitch): the following samples are out of order with respect to it;
  // after a short run the nodelet restarts its timeline, keeps reporting and the stamps status recovers.
  h.clearMax();
  h.publish(h.stamp(h.next() + 1000000), 0.0, 0.0, 0.0);
  const int before_glitch = h.reports();
  EXPECT_TRUE(h.publishUntil(15.0, [&] { return h.reports() >= before_glitch + 3 && h.level("stamps") == OK; }))
      << "after a future stamp: reports " << h.reports() - before_glitch << ", stamps '" << h.message("stamps") << "'";
  expectConverged(h.lastReport(), "after a stamp glitch");

  // G. The IMU is picked up and waved (0.5 rad/s): "motion" goes to WARN "not at rest", no new answer is published
  // while the window holds the motion and no static stretch of 60 s (analyze_bag's rule: the 20 s window has none),
  // the last static answer is held; once the motion has left the window the answers resume, converged.
  h.clearMax();
  EXPECT_EQ(h.level("motion"), OK) << h.message("motion");
  h.moving(true);
  EXPECT_TRUE(h.publishUntil(10.0, [&] { return h.level("motion") == WARN; })) << "motion not reported: "
                                                                               << h.message("motion");
  EXPECT_NE(h.message("motion").find("not at rest"), std::string::npos) << h.message("motion");
  const int during = h.reports();
  h.publishFor(4.0);
  EXPECT_EQ(h.reports(), during) << "an answer was published while the sensor moved";
  EXPECT_EQ(h.level("motion"), WARN) << h.message("motion");
  h.moving(false);
  EXPECT_EQ(h.reports(), during) << "an answer was published while the window held the motion";
  // (the motion leaves the 20 s window after 20 s of stamps; on a loaded machine the publisher runs behind real time)
  EXPECT_TRUE(h.publishUntil(60.0, [&] { return h.reports() > during; })) << "no answer after the motion";
  EXPECT_GE(h.lastReport().samples, 19000) << "the window after the motion holds 20 s of static data";
  EXPECT_TRUE(h.publishUntil(15.0, [&] { return h.level("motion") == OK && h.reports() >= during + 3; }))
      << "after motion: motion '" << h.message("motion") << "', reports " << h.reports() - during;
  expectConverged(h.lastReport(), "after motion");
}

int main(int argc, char** argv) { return nodelet_test::runRostest(argc, argv, "nodelet_convergence", 1); }
