// Streaming bag reader for sensor_msgs/Imu (or geometry_msgs/Vector3Stamped angles) and sensor_msgs/Temperature:
// ROS 1 bags here (the direct chunk reader, else rosbag::View), ROS 2 bags in ros2_input.cpp.
#include "gyro_allan/io/bag_input.hpp"

#include "bag_direct.hpp"
#include "gyro_allan/rosbag2/storage.hpp"

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <map>
#include <memory>
#include <set>

#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <geometry_msgs/Vector3Stamped.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/Temperature.h>

namespace gyro_allan {
namespace {


const char* kImuType = "sensor_msgs/Imu";
const char* kTempType = "sensor_msgs/Temperature";
const char* kAngleType = "geometry_msgs/Vector3Stamped";

std::string joinTopics(const std::map<std::string, std::string>& topics) {
  std::string s;
  for (const auto& kv : topics) s += (s.empty() ? "" : ", ") + kv.first + " [" + kv.second + "]";
  return s.empty() ? "none" : s;
}

struct OpenBag {
  std::string path;
  std::unique_ptr<rosbag::Bag> bag;
  std::map<std::string, std::string> topics;  // topic -> type
  ros::Time first;
};

}  // namespace

namespace bag_detail {

bool isType(const std::string& stored, const char* ros1) {
  if (stored == ros1) return true;
  const std::string r(ros1);
  const size_t slash = r.find('/');
  return slash != std::string::npos && stored == r.substr(0, slash) + "/msg" + r.substr(slash);
}

TopicChoice chooseTopics(const std::map<std::string, std::string>& topics, const BagReadOptions& options) {
  TopicChoice c;
  auto checkType = [&](const std::string& topic, const char* type, const char* what) {
    const auto it = topics.find(topic);
    if (it == topics.end())
      throw InputError(std::string(what) + "'" + topic + "' is not in the bag (topics: " + joinTopics(topics) + ")");
    if (!isType(it->second, type))
      throw InputError(std::string(what) + "'" + topic + "' has type " + it->second + ", not " + type);
  };
  if (!options.angle_topic.empty()) {
    if (!options.topic.empty()) throw InputError("give an IMU topic or an angle topic, not both");
    if (!options.accel_topic.empty()) throw InputError("an angle topic has no accelerometer: --accel-topic is for IMU topics");
    c.topic = options.angle_topic;
    checkType(c.topic, kAngleType, "angle topic ");
  } else if (!options.topic.empty()) {
    c.topic = options.topic;
    checkType(c.topic, kImuType, "topic ");
  } else {
    std::vector<std::string> imu;
    for (const auto& kv : topics)
      if (isType(kv.second, kImuType)) imu.push_back(kv.first);
    if (imu.empty()) throw InputError(std::string("no ") + kImuType + " topic in the bag (topics: " + joinTopics(topics) + ")");
    auto has = [](const std::string& s, const char* w) { return s.find(w) != std::string::npos; };
    if (imu.size() == 2 && options.accel_topic.empty()) {
      // A camera's split streams (RealSense: /camera/gyro/sample at 200/400 Hz, /camera/accel/sample at 63/250 Hz).
      for (int k = 0; k < 2 && c.topic.empty(); ++k)
        if (has(imu[k], "gyro") && !has(imu[k], "accel") && has(imu[1 - k], "accel") && !has(imu[1 - k], "gyro")) {
          c.topic = imu[k];
          c.accel_topic = imu[1 - k];
          c.note = "gyro from " + c.topic + ", accelerometer from " + c.accel_topic + " (a split gyro/accel pair)";
        }
    }
    if (c.topic.empty() && !options.accel_topic.empty()) {
      imu.erase(std::remove(imu.begin(), imu.end(), options.accel_topic), imu.end());
      if (imu.size() == 1) c.topic = imu.front();
    }
    if (c.topic.empty() && imu.size() == 1) c.topic = imu.front();
    if (c.topic.empty()) {
      std::string list;
      for (const auto& t : imu) list += (list.empty() ? "" : ", ") + t;
      throw InputError("several " + std::string(kImuType) + " topics (" + list + "): choose one with --topic" +
                       " (and a separate accelerometer stream with --accel-topic)");
    }
  }
  if (!options.accel_topic.empty()) {
    c.accel_topic = options.accel_topic;
    checkType(c.accel_topic, kImuType, "accelerometer topic ");
    if (c.accel_topic == c.topic) throw InputError("--accel-topic is the IMU topic itself");
  }
  std::string temp_topic = options.temperature_topic;
  if (temp_topic == "-") {
    temp_topic.clear();
  } else if (!temp_topic.empty()) {
    checkType(temp_topic, kTempType, "temperature topic ");
  } else {
    std::vector<std::string> tt;
    for (const auto& kv : topics)
      if (isType(kv.second, kTempType)) tt.push_back(kv.first);
    if (tt.size() == 1) temp_topic = tt.front();
  }
  c.temperature = temp_topic;
  return c;
}

}  // namespace bag_detail

ImuSeries readImuBags(const std::vector<std::string>& paths, const BagReadOptions& options) {
  if (paths.empty()) throw InputError("no bag given");
  if (options.start_s < 0 || options.duration_s < 0) throw InputError("--start and --duration must be >= 0");
  if (options.reader != "auto" && options.reader != "rosbag") throw InputError("reader must be auto or rosbag");
  size_t ros2 = 0;
  for (const auto& p : paths) ros2 += rosbag2::isRos2Input(p);
  if (ros2 == paths.size()) return bag_detail::readRos2Bags(paths, options);
  if (ros2 > 0) throw InputError("give ROS 1 bags or one ROS 2 recording, not both");
  {
    ImuSeries direct;
    if (options.reader == "auto" && readImuBagsDirect(paths, options, &direct)) return direct;
  }
  std::vector<OpenBag> bags;
  for (const auto& path : paths) {
    {
      std::ifstream probe(path);
      if (!probe) throw InputError("cannot open bag '" + path + "': no such file or not readable");
    }
    OpenBag ob;
    ob.path = path;
    ob.bag = std::make_unique<rosbag::Bag>();
    try {
      ob.bag->open(path, rosbag::bagmode::Read);
      rosbag::View all(*ob.bag);
      for (const rosbag::ConnectionInfo* c : all.getConnections()) ob.topics[c->topic] = c->datatype;
      if (all.size() == 0) throw InputError("bag '" + path + "' has no messages");
      ob.first = all.getBeginTime();
    } catch (const InputError&) {
      throw;
    } catch (const std::exception& e) {
      throw InputError("cannot read bag '" + path + "' (truncated or not a bag?): " + e.what());
    }
    bags.push_back(std::move(ob));
  }
  std::sort(bags.begin(), bags.end(), [](const OpenBag& a, const OpenBag& b) { return a.first < b.first; });

  // Topic choice: the same across bags.
  std::map<std::string, std::string> topics;
  for (const auto& b : bags) topics.insert(b.topics.begin(), b.topics.end());
  const bag_detail::TopicChoice choice = bag_detail::chooseTopics(topics, options);
  const std::string& topic = choice.topic;
  const std::string& temp_topic = choice.temperature;
  BagReadOptions opt = options;
  opt.accel_topic = choice.accel_topic;

  ImuSeries s;
  s.topic = topic;
  s.temperature_topic = temp_topic;
  s.accel_topic = choice.accel_topic;
  size_t total = 0;
  for (auto& b : bags) {
    rosbag::View v(*b.bag, rosbag::TopicQuery(topic));
    total += v.size();
  }
  const bool angle = !options.angle_topic.empty();
  for (auto& x : s.gyro) x.reserve(total);
  if (!angle)
    for (auto& x : s.accel) x.reserve(total);
  s.t.reserve(total);
  const bool show = options.progress && isatty(fileno(stderr));
  size_t next_report = total / 50 + 1;
  bag_detail::ImuAppender app(&s, opt);
  std::vector<ros::Time> temp_abs;
  for (auto& b : bags) {
    s.bags.push_back(b.path);
    std::vector<std::string> wanted{topic};
    if (!temp_topic.empty()) wanted.push_back(temp_topic);
    if (!opt.accel_topic.empty()) wanted.push_back(opt.accel_topic);
    try {
      rosbag::View view(*b.bag, rosbag::TopicQuery(wanted));
      for (const rosbag::MessageInstance& m : view) {
        if (m.getTopic() == temp_topic) {
          auto tm = m.instantiate<sensor_msgs::Temperature>();
          if (!tm) continue;
          temp_abs.push_back(options.use_bag_time ? m.getTime() : tm->header.stamp);
          s.temperature.push_back(tm->temperature);
          continue;
        }
        if (m.getTopic() == opt.accel_topic) {
          auto imu = m.instantiate<sensor_msgs::Imu>();
          if (!imu) throw InputError("accelerometer topic '" + opt.accel_topic + "' holds a message that is not " + kImuType);
          app.addAccel(m.getTime(), *imu);
          continue;
        }
        if (angle) {
          auto v = m.instantiate<geometry_msgs::Vector3Stamped>();
          if (!v) throw InputError("angle topic '" + topic + "' holds a message that is not " + kAngleType);
          app.add(m.getTime(), *v);
        } else {
          auto imu = m.instantiate<sensor_msgs::Imu>();
          if (!imu) throw InputError("topic '" + topic + "' holds a message that is not " + kImuType);
          app.add(m.getTime(), *imu);
        }
        const size_t done = app.offered();
        if (show && done >= next_report) {
          std::fprintf(stderr, "\rreading %s: %3.0f %%", topic.c_str(), 100.0 * done / std::max<size_t>(1, total));
          next_report += total / 50 + 1;
        }
      }
    } catch (const InputError&) {
      throw;
    } catch (const std::exception& e) {
      throw InputError("bag '" + b.path + "' is truncated or corrupt after " + std::to_string(app.offered()) +
                       " messages of '" + topic + "': " + e.what());
    }
  }
  if (show) std::fprintf(stderr, "\rreading %s: done     \n", topic.c_str());
  s.messages = static_cast<int64_t>(app.offered());
  s.reader = "rosbag";
  app.finish();
  bag_detail::finishTemperature(temp_abs, app.origin(), &s.temperature_t);
  if (s.t.empty())
    throw InputError("topic '" + topic + "' has no messages" +
                     std::string(options.start_s > 0 || options.duration_s > 0 ? " in the requested time range" : ""));
  return s;
}

}  // namespace gyro_allan
