// gyro_allan/BagPlayerNodelet: plays a bag's sensor_msgs/Imu messages in real time (or ~speed x) inside a nodelet
// manager, so a nodelet beside it (the analyzer) receives them as a driver's nodelet would deliver them: by pointer,
// without serialization. For benchmarks and demos (bench/nodelet_cpu.sh --in-process).
#include <pthread.h>

#include <atomic>
#include <thread>

#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>
#include <ros/ros.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/Imu.h>

namespace gyro_allan {

class BagPlayerNodelet : public nodelet::Nodelet {
 public:
  ~BagPlayerNodelet() override {
    stop_ = true;
    if (thread_.joinable()) thread_.join();
  }

 private:
  void onInit() override {
    ros::NodeHandle& pnh = getPrivateNodeHandle();
    std::string bag_path;
    double speed = 1.0;
    pnh.getParam("bag", bag_path);
    pnh.param("speed", speed, 1.0);
    if (bag_path.empty() || !(speed > 0)) {
      NODELET_ERROR("gyro_allan bag player: ~bag (a path) and ~speed > 0 are needed");
      return;
    }
    pub_ = getNodeHandle().advertise<sensor_msgs::Imu>("imu", 1000);
    thread_ = std::thread([this, bag_path, speed] { play(bag_path, speed); });
  }

  void play(const std::string& path, double speed) {
    pthread_setname_np(pthread_self(), "bag_player");  // bench/nodelet_cpu.sh leaves this thread's CPU out
    try {
      rosbag::Bag bag(path);
      rosbag::View view(bag, rosbag::TypeQuery(std::string("sensor_msgs/Imu")));
      ros::Time first;
      const ros::WallTime start = ros::WallTime::now();
      for (const rosbag::MessageInstance& m : view) {
        if (stop_ || !ros::ok()) return;
        if (first.isZero()) first = m.getTime();
        const ros::WallTime due = start + ros::WallDuration((m.getTime() - first).toSec() / speed);
        const ros::WallDuration wait = due - ros::WallTime::now();
        if (wait > ros::WallDuration(0.001)) wait.sleep();
        if (auto imu = m.instantiate<sensor_msgs::Imu>()) pub_.publish(imu);  // a shared pointer: no copy in-process
      }
      NODELET_INFO("gyro_allan bag player: %s played", path.c_str());
    } catch (const std::exception& e) {
      NODELET_ERROR("gyro_allan bag player: %s: %s", path.c_str(), e.what());
    }
    while (!stop_ && ros::ok()) ros::WallDuration(0.2).sleep();  // stays until unloaded (its CPU stays countable)
  }

  ros::Publisher pub_;
  std::thread thread_;
  std::atomic<bool> stop_{false};
};

}  // namespace gyro_allan

PLUGINLIB_EXPORT_CLASS(gyro_allan::BagPlayerNodelet, nodelet::Nodelet)
