// Streaming rosbag reader for sensor_msgs/Imu (or geometry_msgs/Vector3Stamped angles) and sensor_msgs/Temperature.
#include "gyro_allan/io/bag_input.hpp"

#include "bag_direct.hpp"

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

void chooseTopics(const std::map<std::string, std::string>& topics, const BagReadOptions& options, std::string* topic_out,
                  std::string* temp_topic_out) {
  std::string topic = options.topic;
  if (!options.angle_topic.empty()) {
    if (!topic.empty()) throw InputError("give an IMU topic or an angle topic, not both");
    topic = options.angle_topic;
    auto it = topics.find(topic);
    if (it == topics.end())
      throw InputError("angle topic '" + topic + "' is not in the bag (topics: " + joinTopics(topics) + ")");
    if (it->second != kAngleType)
      throw InputError("angle topic '" + topic + "' has type " + it->second + ", not " + kAngleType);
  } else if (!topic.empty()) {
    auto it = topics.find(topic);
    if (it == topics.end()) throw InputError("topic '" + topic + "' is not in the bag (topics: " + joinTopics(topics) + ")");
    if (it->second != kImuType)
      throw InputError("topic '" + topic + "' has type " + it->second + ", not " + kImuType);
  } else {
    std::vector<std::string> imu;
    for (const auto& kv : topics)
      if (kv.second == kImuType) imu.push_back(kv.first);
    if (imu.empty()) throw InputError(std::string("no ") + kImuType + " topic in the bag (topics: " + joinTopics(topics) + ")");
    if (imu.size() > 1) {
      std::string list;
      for (const auto& t : imu) list += (list.empty() ? "" : ", ") + t;
      throw InputError("several " + std::string(kImuType) + " topics (" + list + "): choose one with --topic");
    }
    topic = imu.front();
  }
  std::string temp_topic = options.temperature_topic;
  if (temp_topic == "-") {
    temp_topic.clear();
  } else if (!temp_topic.empty()) {
    auto it = topics.find(temp_topic);
    if (it == topics.end()) throw InputError("temperature topic '" + temp_topic + "' is not in the bag");
    if (it->second != kTempType)
      throw InputError("topic '" + temp_topic + "' has type " + it->second + ", not " + kTempType);
  } else {
    std::vector<std::string> tt;
    for (const auto& kv : topics)
      if (kv.second == kTempType) tt.push_back(kv.first);
    if (tt.size() == 1) temp_topic = tt.front();
  }

  *topic_out = topic;
  *temp_topic_out = temp_topic;
}

}  // namespace bag_detail

ImuSeries readImuBags(const std::vector<std::string>& paths, const BagReadOptions& options) {
  if (paths.empty()) throw InputError("no bag given");
  if (options.start_s < 0 || options.duration_s < 0) throw InputError("--start and --duration must be >= 0");
  if (options.reader != "auto" && options.reader != "rosbag") throw InputError("reader must be auto or rosbag");
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
  std::string topic, temp_topic;
  bag_detail::chooseTopics(topics, options, &topic, &temp_topic);

  ImuSeries s;
  s.topic = topic;
  s.temperature_topic = temp_topic;
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
  bag_detail::ImuAppender app(&s, options);
  std::vector<ros::Time> temp_abs;
  for (auto& b : bags) {
    s.bags.push_back(b.path);
    std::vector<std::string> wanted{topic};
    if (!temp_topic.empty()) wanted.push_back(temp_topic);
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
  bag_detail::finishTemperature(temp_abs, app.origin(), &s.temperature_t);
  if (s.t.empty())
    throw InputError("topic '" + topic + "' has no messages" +
                     std::string(options.start_s > 0 || options.duration_s > 0 ? " in the requested time range" : ""));
  return s;
}

}  // namespace gyro_allan
