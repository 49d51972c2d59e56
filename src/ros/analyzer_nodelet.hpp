// Online gyro noise analyzer nodelet: a thin ROS shell around OnlineAnalyzer (online.hpp) — messages in, the same
// analysis as analyze_bag on a sliding window (worker thread), messages, services and diagnostics out.
#pragma once

#include <atomic>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include <diagnostic_updater/diagnostic_updater.h>
#include <dynamic_reconfigure/server.h>
#include <geometry_msgs/Vector3Stamped.h>
#include <nodelet/nodelet.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/Temperature.h>
#include <std_srvs/Trigger.h>

#include "analyzer_ros.hpp"
#include "gyro_allan/online.hpp"

namespace gyro_allan {

class AnalyzerNodelet : public nodelet::Nodelet {
 public:
  AnalyzerNodelet() = default;
  ~AnalyzerNodelet() override;

 private:
  void onInit() override;
  void imuCallback(const sensor_msgs::Imu::ConstPtr& msg);
  void angleCallback(const geometry_msgs::Vector3Stamped::ConstPtr& msg);
  void accelCallback(const sensor_msgs::Imu::ConstPtr& msg);
  void temperatureCallback(const sensor_msgs::Temperature::ConstPtr& msg);
  /// One sample of the chosen source (the other topic's messages are counted and ignored); starts a due hop.
  void addSample(const std::string& source, const std_msgs::Header& h, const std::array<double, 3>& g,
                 const std::array<double, 3>& a);
  /// Hands the window to the worker unless it is busy (then the hop is skipped and counted). Needs mutex_.
  bool startAnalysis();
  void workerLoop();
  void publish(const OnlineResult& r, double temperature);
  /// Fits a quick answer and publishes ~quick, ~allan/* (quick) and ~plot; called off the lock.
  void publishQuick(QuickAnswer&& q, const AnalyzerParams& p, const std::string& frame, double full_age_s);
  bool resetService(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res);
  bool saveService(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res);
  bool analyzeService(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res);
  void reconfigure(AnalyzerConfig& config, uint32_t level);
  DiagState diagState();
  AnalyzerParams params();  ///< a copy of p_ (reconfigure changes it on another thread)

  AnalyzerParams p_;
  std::unique_ptr<OnlineAnalyzer> oa_;
  ros::Subscriber imu_sub_, angle_sub_, accel_sub_, temp_sub_;
  ros::CallbackQueue sample_queue_;  ///< imu / angle messages, served by sample_thread_
  std::thread sample_thread_;
  std::atomic<bool> sample_stop_{false};
  ros::Publisher noise_pub_, noise_model_pub_, plot_pub_, quick_pub_;
  std::array<ros::Publisher, 3> curve_pub_;
  ros::ServiceServer reset_srv_, save_srv_, analyze_srv_;
  std::unique_ptr<dynamic_reconfigure::Server<AnalyzerConfig>> dyn_;
  boost::recursive_mutex dyn_mutex_;
  ros::Timer diag_timer_;
  std::unique_ptr<diagnostic_updater::Updater> updater_;
  RecentProblems recent_;

  std::mutex mutex_;  ///< guards everything below and oa_
  std::string source_, frame_id_, topic_;
  uint64_t other_source_ = 0;
  uint64_t accel_messages_ = 0;  ///< messages of the separate accelerometer topic
  std::vector<std::string> param_problems_;
  bool hwid_set_ = false;
  // worker
  std::condition_variable cv_;
  std::unique_ptr<OnlineJob> job_;
  bool busy_ = false, stop_ = false;
  std::thread worker_;
  bool have_result_ = false, have_good_ = false;
  OnlineResult last_;          ///< the last analysis
  OnlineResult last_good_;     ///< the last analysable one (~save writes it)
  AnalyzerParams last_good_params_;  ///< the params last_good_ was published with (~save's report method, filter rate)
  NoiseReport last_report_;    ///< the last published ~noise
  bool have_noise_model_ = false;
  NoiseModel last_noise_model_;  ///< the last published ~noise_model
  bool have_quick_ = false;
  QuickNoise last_quick_;      ///< the last published ~quick
};

}  // namespace gyro_allan
