// ROS 2 bags (rosbag2 folders, .mcap and .db3 files, read by src/rosbag2 without ROS 2) into the same ImuSeries, by
// the same topic choice and appender as ROS 1 bags: CDR messages decoded into the ROS 1 message structs.
#include <unistd.h>

#include <cstdio>

#include "bag_direct.hpp"
#include "gyro_allan/rosbag2/cdr.hpp"
#include "gyro_allan/rosbag2/storage.hpp"

namespace gyro_allan {
namespace bag_detail {
namespace {

/// builtin_interfaces/Time as ros::Time; a time ROS 1 cannot hold (negative seconds) is a zero (invalid) stamp.
ros::Time rosTime(const cdr::Header& h) {
  ros::Time t;
  if (h.sec < 0) return t;
  if (h.nanosec < 1000000000u) {  // the normal case, without ros::Time's normalization
    t.sec = static_cast<uint32_t>(h.sec);
    t.nsec = h.nanosec;
    return t;
  }
  return ros::Time(static_cast<uint32_t>(h.sec), 0) + ros::Duration(0, static_cast<int32_t>(h.nanosec % 1000000000u)) +
         ros::Duration(static_cast<int32_t>(h.nanosec / 1000000000u), 0);
}

ros::Time recvTime(int64_t ns) {
  ros::Time t;
  if (ns > 0 && ns < int64_t(4294967295) * 1000000000) t.fromNSec(static_cast<uint64_t>(ns));
  return t;
}

void toRos1(const cdr::Imu& c, sensor_msgs::Imu* m) {
  m->header.stamp = rosTime(c.header);
  if (m->header.frame_id != c.header.frame_id) m->header.frame_id = c.header.frame_id;
  m->orientation.x = c.orientation[0];
  m->orientation.y = c.orientation[1];
  m->orientation.z = c.orientation[2];
  m->orientation.w = c.orientation[3];
  m->angular_velocity.x = c.angular_velocity[0];
  m->angular_velocity.y = c.angular_velocity[1];
  m->angular_velocity.z = c.angular_velocity[2];
  m->linear_acceleration.x = c.linear_acceleration[0];
  m->linear_acceleration.y = c.linear_acceleration[1];
  m->linear_acceleration.z = c.linear_acceleration[2];
  for (size_t i = 0; i < 9; ++i) {
    m->orientation_covariance[i] = c.orientation_covariance[i];
    m->angular_velocity_covariance[i] = c.angular_velocity_covariance[i];
    m->linear_acceleration_covariance[i] = c.linear_acceleration_covariance[i];
  }
}

}  // namespace

ImuSeries readRos2Bags(const std::vector<std::string>& paths, const BagReadOptions& options) {
  try {
    rosbag2::Bag bag(paths);
    const TopicChoice choice = chooseTopics(bag.topicTypes(), options);
    const bool angle = !options.angle_topic.empty();
    BagReadOptions opt = options;
    opt.accel_topic = choice.accel_topic;
    ImuSeries s;
    s.topic = choice.topic;
    s.temperature_topic = choice.temperature;
    s.accel_topic = choice.accel_topic;
    s.bags = bag.files();
    ImuAppender app(&s, opt);
    std::vector<ros::Time> temp_abs;
    cdr::Imu ci;
    cdr::Vector3Stamped cv;
    cdr::Temperature ct;
    sensor_msgs::Imu imu;
    geometry_msgs::Vector3Stamped vec;
    for (const std::string* t : {&choice.topic, &choice.accel_topic}) {
      if (t->empty()) continue;
      const std::string& format = bag.serializationFormats().at(*t);
      if (format != "cdr")
        throw InputError("topic '" + *t + "' is stored as '" + format + "', not as ROS 2's cdr: not readable here");
    }
    std::set<std::string> wanted{choice.topic};
    if (!choice.temperature.empty()) wanted.insert(choice.temperature);
    if (!choice.accel_topic.empty()) wanted.insert(choice.accel_topic);
    const bool show = options.progress && isatty(fileno(stderr));
    int64_t seen = 0;
    const bool has_temp = !choice.temperature.empty(), has_accel = !choice.accel_topic.empty();
    bag.read(wanted, [&](const std::string& topic, int64_t recv_ns, const uint8_t* data, size_t size) {
      const ros::Time rec = recvTime(recv_ns);
      try {
        if (has_temp && topic == choice.temperature) {
          cdr::decode(data, size, &ct);  // a temperature that does not decode is skipped, as in ROS 1 bags
          temp_abs.push_back(options.use_bag_time ? rec : rosTime(ct.header));
          s.temperature.push_back(ct.temperature);
          return;
        }
        if (has_accel && topic == choice.accel_topic) {
          cdr::decode(data, size, &ci);
          toRos1(ci, &imu);
          app.addAccel(rec, imu);
          return;
        }
        if (angle) {
          cdr::decode(data, size, &cv);
          vec.header.stamp = rosTime(cv.header);
          vec.header.frame_id = cv.header.frame_id;
          vec.vector.x = cv.vector[0];
          vec.vector.y = cv.vector[1];
          vec.vector.z = cv.vector[2];
          app.add(rec, vec);
        } else {
          cdr::decode(data, size, &ci);
          toRos1(ci, &imu);
          app.add(rec, imu);
        }
      } catch (const cdr::Error& e) {
        if (topic == choice.temperature) return;
        throw InputError("topic '" + topic + "' holds a message that is not a " + bag.topicTypes().at(topic) +
                         " (message " + std::to_string(app.offered() + 1) + ": " + e.what() + ")");
      }
      if (show && ++seen % 20000 == 0) std::fprintf(stderr, "\rreading %s: %lld messages", choice.topic.c_str(),
                                                    static_cast<long long>(seen));
    });
    if (show) std::fprintf(stderr, "\rreading %s: done                    \n", choice.topic.c_str());
    s.messages = static_cast<int64_t>(app.offered());
    s.reader = "rosbag2";
    app.finish();
    finishTemperature(temp_abs, app.origin(), &s.temperature_t);
    if (s.t.empty())
      throw InputError("topic '" + choice.topic + "' has no messages" +
                       std::string(options.start_s > 0 || options.duration_s > 0 ? " in the requested time range" : ""));
    return s;
  } catch (const rosbag2::FormatError& e) {
    throw InputError(e.what());
  }
}

}  // namespace bag_detail
}  // namespace gyro_allan
