// The receiving floor for bench/nodelet_cpu.sh --bare: a roscpp node that subscribes to `imu` as the analyzer does
// (no TCP_NODELAY, its own callback queue taken in batches with a pause of ~batch_ms, 20 as the analyzer; 0: ros::spin,
// one wake-up per message) and only counts the messages. What it costs is what any process pays to receive the topic.
// _udp:=true asks for UDPROS first (TCP if the publisher has no UDP).
#include <atomic>
#include <chrono>
#include <cstdio>
#include <thread>

#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <sensor_msgs/Imu.h>

int main(int argc, char** argv) {
  ros::init(argc, argv, "bare_imu_subscriber");
  ros::NodeHandle nh, pnh("~");
  const int batch_ms = pnh.param("batch_ms", 20);
  const int queue_size = pnh.param("queue_size", 1000);
  const ros::TransportHints hints = pnh.param("udp", false) ? ros::TransportHints().udp().tcp() : ros::TransportHints();
  std::atomic<uint64_t> received{0};
  auto count = [&received](const sensor_msgs::Imu::ConstPtr&) { ++received; };
  auto report = [&received] {  // the count, for lost messages (stderr: unbuffered, the benchmark kills the node)
    std::fprintf(stderr, "bare_imu_subscriber: %llu messages\n", static_cast<unsigned long long>(received.load()));
  };
  if (batch_ms <= 0) {
    ros::Subscriber sub = nh.subscribe<sensor_msgs::Imu>("imu", queue_size, count, ros::VoidConstPtr(), hints);
    ros::spin();
  } else {
    ros::CallbackQueue queue;
    ros::NodeHandle sample_nh(nh);
    sample_nh.setCallbackQueue(&queue);
    ros::Subscriber sub =
        sample_nh.subscribe<sensor_msgs::Imu>("imu", queue_size, count, ros::VoidConstPtr(), hints);
    ros::AsyncSpinner spinner(1);  // the global queue (parameters, shutdown) as a nodelet manager serves it
    spinner.start();
    auto last = std::chrono::steady_clock::now();
    while (ros::ok()) {
      queue.callAvailable(ros::WallDuration(0.1));
      std::this_thread::sleep_for(std::chrono::milliseconds(batch_ms));
      if (std::chrono::steady_clock::now() - last > std::chrono::seconds(60)) {
        last = std::chrono::steady_clock::now();
        report();
      }
    }
  }
  report();
  return 0;
}
