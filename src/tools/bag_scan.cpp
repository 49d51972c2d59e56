// bag_scan: prints the topics, types and message counts of a bag: a ROS 1 bag iterated with rosbag::View,
// deserializing every sensor_msgs/Imu message (the baseline analyze_bag's read time is compared with in benchmarks),
// or a ROS 2 recording (rosbag2 folder, .mcap, .db3) with its storage layout.
#include <cstdio>
#include <map>
#include <string>

#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/Imu.h>

#include "gyro_allan/rosbag2/storage.hpp"

int main(int argc, char** argv) {
  if (argc < 2 || std::string(argv[1]) == "-h" || std::string(argv[1]) == "--help") {
    std::printf("usage: bag_scan BAG [BAG...]\nprints topics, types and message counts (deserializing sensor_msgs/Imu);\n"
                "a BAG may be a ROS 2 recording: a rosbag2 folder, an .mcap or a .db3 file\n");
    return argc < 2 ? 1 : 0;
  }
  for (int i = 1; i < argc; ++i) {
    try {
      if (gyro_allan::rosbag2::isRos2Input(argv[i])) {
        gyro_allan::rosbag2::Bag bag({argv[i]});
        std::printf("%s: ROS 2\n", argv[i]);
        for (const auto& d : bag.describe()) std::printf("  %s\n", d.c_str());
        auto counts = bag.messageCounts();
        for (const auto& kv : bag.topicTypes())
          std::printf("  %-30s %-28s %lld\n", kv.first.c_str(), kv.second.c_str(), static_cast<long long>(counts[kv.first]));
        continue;
      }
      rosbag::Bag bag(argv[i], rosbag::bagmode::Read);
      rosbag::View view(bag);
      std::map<std::string, std::pair<std::string, long>> counts;
      double checksum = 0;
      for (const rosbag::MessageInstance& m : view) {
        auto& c = counts[m.getTopic()];
        c.first = m.getDataType();
        ++c.second;
        if (auto imu = m.instantiate<sensor_msgs::Imu>()) checksum += imu->angular_velocity.x;
      }
      std::printf("%s: %.3f s\n", argv[i], (view.getEndTime() - view.getBeginTime()).toSec());
      for (const auto& kv : counts) std::printf("  %-30s %-28s %ld\n", kv.first.c_str(), kv.second.first.c_str(), kv.second.second);
      std::printf("  (sum of angular_velocity.x: %.6g)\n", checksum);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "bag_scan: error: %s: %s\n", argv[i], e.what());
      return 2;
    }
  }
  return 0;
}
