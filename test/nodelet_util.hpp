// Shared harness of the nodelet rostests (test/nodelet_*.cpp): waiting, /diagnostics and latched-topic capture, services, dynamic_reconfigure, bag playback, analyze_bag runs, main().
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <map>
#include <mutex>
#include <string>

#include <diagnostic_msgs/DiagnosticArray.h>
#include <dynamic_reconfigure/Reconfigure.h>
#include <ros/ros.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/Temperature.h>
#include <std_srvs/Trigger.h>

namespace nodelet_test {

inline int sh(const std::string& cmd) { return std::system(cmd.c_str()); }

/// Polls done() every 20 ms (wall time) until it is true or timeout_s has passed; returns its last value.
template <class F>
bool waitFor(double timeout_s, F done) {
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(timeout_s);
  while (ros::WallTime::now() < end) {
    if (done()) return true;
    ros::WallDuration(0.02).sleep();
  }
  return done();
}

/// The statuses one analyzer nodelet publishes on /diagnostics ("gyro_allan/<node>: <status>"): every key/value (one
/// map over all statuses), and per status its summary message, message + values as one text, level and highest level.
class Diagnostics {
 public:
  Diagnostics(ros::NodeHandle& nh, const std::string& node, uint32_t queue = 1000)
      : prefix_("gyro_allan/" + node + ": ") {
    sub_ = nh.subscribe("/diagnostics", queue, &Diagnostics::onDiag, this);
  }
  Diagnostics(const Diagnostics&) = delete;
  Diagnostics& operator=(const Diagnostics&) = delete;

  /// A key's value as a number (`missing` until seen).
  double value(const std::string& key, double missing = std::nan("")) {
    std::lock_guard<std::mutex> l(mutex_);
    auto it = values_.find(key);
    return it == values_.end() ? missing : std::atof(it->second.c_str());
  }
  /// A status's summary message ("" until seen).
  std::string message(const std::string& status) {
    std::lock_guard<std::mutex> l(mutex_);
    return message_[status];
  }
  /// A status's message and values as one text, one per line.
  std::string text(const std::string& status) {
    std::lock_guard<std::mutex> l(mutex_);
    return text_[status];
  }
  /// A status's last level (-1 until seen).
  int level(const std::string& status) {
    std::lock_guard<std::mutex> l(mutex_);
    return level_.count(status) ? level_[status] : -1;
  }
  /// A status's highest level since the start or clearMax() (-1 until seen).
  int maxLevel(const std::string& status) {
    std::lock_guard<std::mutex> l(mutex_);
    return max_level_.count(status) ? max_level_[status] : -1;
  }
  void clearMax() {
    std::lock_guard<std::mutex> l(mutex_);
    max_level_.clear();
  }
  std::string hardwareId() {
    std::lock_guard<std::mutex> l(mutex_);
    return hardware_id_;
  }

 private:
  void onDiag(const diagnostic_msgs::DiagnosticArray::ConstPtr& msg) {
    std::lock_guard<std::mutex> l(mutex_);
    for (const auto& s : msg->status) {
      if (s.name.rfind(prefix_, 0) != 0) continue;
      const std::string key = s.name.substr(prefix_.size());
      std::string all = s.message;
      for (const auto& kv : s.values) values_[kv.key] = kv.value, all += "\n" + kv.value;
      message_[key] = s.message;
      text_[key] = all;
      level_[key] = s.level;
      max_level_[key] = std::max<int>(max_level_.count(key) ? max_level_[key] : 0, s.level);
      hardware_id_ = s.hardware_id;
    }
  }

  const std::string prefix_;
  ros::Subscriber sub_;
  std::mutex mutex_;
  std::map<std::string, std::string> values_, message_, text_;
  std::map<std::string, int> level_, max_level_;
  std::string hardware_id_;
};

/// The last message on a topic and how many have arrived.
template <class M>
class Latest {
 public:
  Latest(ros::NodeHandle& nh, const std::string& topic, uint32_t queue = 10) {
    sub_ = nh.subscribe(topic, queue, &Latest::onMessage, this);
  }
  Latest(const Latest&) = delete;
  Latest& operator=(const Latest&) = delete;
  int count() {
    std::lock_guard<std::mutex> l(mutex_);
    return count_;
  }
  M last() {
    std::lock_guard<std::mutex> l(mutex_);
    return last_;
  }
  uint32_t publishers() const { return sub_.getNumPublishers(); }

 private:
  void onMessage(const typename M::ConstPtr& m) {
    std::lock_guard<std::mutex> l(mutex_);
    ++count_;
    last_ = *m;
  }
  ros::Subscriber sub_;
  std::mutex mutex_;
  int count_ = 0;
  M last_;
};

/// Calls the std_srvs/Trigger service /<node>/<service>; false when the call itself failed.
inline bool callTrigger(const std::string& node, const std::string& service, std_srvs::Trigger::Response* res) {
  std_srvs::Trigger t;
  const bool called = ros::service::call("/" + node + "/" + service, t);
  *res = t.response;
  return called;
}
/// The same, the call expected to go through; its response.
inline std_srvs::Trigger::Response trigger(const std::string& node, const std::string& service) {
  std_srvs::Trigger::Response res;
  EXPECT_TRUE(callTrigger(node, service, &res)) << service;
  return res;
}
inline bool serviceUp(const std::string& node, const std::string& service) {
  return ros::service::exists("/" + node + "/" + service, false);
}

/// The folder of ~save's reply "wrote DIR/report.yaml, ..." ("" when the reply names no report.yaml).
inline std::string savedDir(const std::string& reply) {
  const size_t to = reply.find("/report.yaml"), from = reply.find("wrote ");
  if (to == std::string::npos || from == std::string::npos || from + 6 > to) return "";
  return reply.substr(from + 6, to - from - 6);
}

/// What `rosrun dynamic_reconfigure dynparam set /<node> ...` sends: these doubles and bools, in one request. False when
/// the call failed; *applied: the configuration the node answers with (after its own corrections).
inline bool reconfigure(const std::string& node, const std::map<std::string, double>& doubles,
                        const std::map<std::string, bool>& bools, dynamic_reconfigure::Config* applied = nullptr) {
  dynamic_reconfigure::Reconfigure rc;
  for (const auto& kv : doubles) {
    dynamic_reconfigure::DoubleParameter d;
    d.name = kv.first;
    d.value = kv.second;
    rc.request.config.doubles.push_back(d);
  }
  for (const auto& kv : bools) {
    dynamic_reconfigure::BoolParameter b;
    b.name = kv.first;
    b.value = kv.second;
    rc.request.config.bools.push_back(b);
  }
  const bool called = ros::service::call("/" + node + "/set_parameters", rc);
  if (applied) *applied = rc.response.config;
  return called;
}
/// A bool of a reconfigure answer; false when absent (*found says which).
inline bool configBool(const dynamic_reconfigure::Config& c, const std::string& name, bool* found) {
  for (const auto& x : c.bools)
    if (x.name == name) return *found = true, static_cast<bool>(x.value);
  *found = false;
  return false;
}

/// An IMU message with only a stamp, a frame and the angular rate [rad/s].
inline sensor_msgs::Imu imuMessage(const ros::Time& stamp, double x, double y, double z,
                                   const std::string& frame_id = "imu_link") {
  sensor_msgs::Imu m;
  m.header.stamp = stamp;
  m.header.frame_id = frame_id;
  m.angular_velocity.x = x;
  m.angular_velocity.y = y;
  m.angular_velocity.z = z;
  return m;
}

/// Publishes every IMU message of a bag, and its temperature messages when temp is given, in bag order, then waits up
/// to timeout_s until the nodelet's diagnostics count them all ("samples received (total)", "temperature readings
/// (total)" grown by the numbers published). Returns the number of IMU messages.
inline int64_t playBag(const std::string& bag_path, ros::Publisher& imu, ros::Publisher* temp, Diagnostics& diag,
                       double timeout_s) {
  auto count = [&](const char* key) {
    const double v = diag.value(key);
    return std::isnan(v) ? 0.0 : v;
  };
  const double before = count("samples received (total)"), temps_before = count("temperature readings (total)");
  rosbag::Bag bag(bag_path);
  rosbag::View view(bag);
  int64_t n = 0, nt = 0;
  for (const rosbag::MessageInstance& m : view) {
    if (auto i = m.instantiate<sensor_msgs::Imu>()) imu.publish(*i), ++n;
    else if (temp)
      if (auto t = m.instantiate<sensor_msgs::Temperature>()) temp->publish(*t), ++nt;
  }
  EXPECT_TRUE(waitFor(timeout_s, [&] {
    return diag.value("samples received (total)") == before + static_cast<double>(n) &&
           (!temp || diag.value("temperature readings (total)") == temps_before + static_cast<double>(nt));
  })) << "the nodelet did not receive every message of " << bag_path << " (" << n << " IMU, " << nt << " temperature)";
  return n;
}

/// Runs the tool analyze_bag on a bag into out (no plot, quiet) with extra options; its exit status.
inline int analyzeBag(const std::string& bag, const std::string& out, const std::string& options = "") {
  return sh("GYRO_ALLAN_NO_PLOT=1 " + std::string(GYRO_ALLAN_TOOL_DIR) + "/analyze_bag " + bag + " --output " + out +
            (options.empty() ? "" : " " + options) + " --quiet");
}

/// The rostest node's main(): gtest and ROS initialised, callbacks on an AsyncSpinner of `threads` threads.
inline int runRostest(int argc, char** argv, const std::string& name, uint32_t threads) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, name);
  ros::AsyncSpinner spinner(threads);
  spinner.start();
  const int rc = RUN_ALL_TESTS();
  spinner.stop();
  ros::shutdown();
  return rc;
}

}  // namespace nodelet_test
