// Direct reader of ROS bag format 2.0 files for the IMU series: chunk by chunk, without rosbag's per-message index.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <algorithm>
#include <array>
#include <climits>
#include <limits>
#include <map>

#include <ros/time.h>
#include <geometry_msgs/Vector3Stamped.h>
#include <sensor_msgs/Imu.h>

#include "gyro_allan/io/bag_input.hpp"
#include "gyro_allan/io/imu_message.hpp"

namespace gyro_allan {
namespace bag_detail {

/// Stamps as ns since (first non-zero IMU stamp - 1 s), in integers: epoch seconds in a double carry only ~0.2 us
/// of precision, which would blur the sample period. A zero stamp stays exactly 0 (invalid).
inline int64_t relativeStampNs(const ros::Time& stamp, ros::Time* origin) {
  if (stamp.isZero()) return 0;
  if (origin->isZero()) *origin = stamp - ros::Duration(1.0);
  return (stamp - *origin).toNSec();
}

/// The same in seconds, as CompactStamps::toSeconds gives it back (ros::Duration::toSec).
inline double relativeStamp(const ros::Time& stamp, ros::Time* origin) {
  if (stamp.isZero()) return 0.0;
  if (origin->isZero()) *origin = stamp - ros::Duration(1.0);
  return (stamp - *origin).toSec();
}

/// Temperature stamps are kept absolute while reading and made relative at the end, so the origin is the IMU's
/// whatever order the two topics are read in.
inline void finishTemperature(const std::vector<ros::Time>& abs, ros::Time* origin, std::vector<double>* rel) {
  rel->clear();
  rel->reserve(abs.size());
  for (const auto& t : abs) rel->push_back(relativeStamp(t, origin));
}

/// The topics readImuBags reads, chosen from `topics` (topic -> type over all bags, ROS 1 or ROS 2 type names).
struct TopicChoice {
  std::string topic;        ///< the IMU (or angle) topic
  std::string accel_topic;  ///< a separate accelerometer topic, or empty
  std::string temperature;  ///< the temperature topic, or empty
  std::string note;         ///< how a choice was made that the user did not ask for (the gyro/accel pair), or empty
};
/// The only sensor_msgs/Imu topic unless given (or the only two, when named as a gyro/accel pair), or the given
/// angle topic; the given accelerometer topic; the only Temperature topic, if any, unless given or "-". Throws
/// InputError naming the problem.
TopicChoice chooseTopics(const std::map<std::string, std::string>& topics, const BagReadOptions& options);

/// Appends IMU messages to a series as every reader does: stamps relative to the first non-zero one, the --start /
/// --duration window, the frame id; counts every message offered. A half of an Imu flagged as absent
/// (covariance[0] = -1, sensor_msgs/Imu's convention) is stored as NaN and counted. Messages of a separate
/// accelerometer topic (BagReadOptions::accel_topic) get their own stamps, relative to the same origin.
class ImuAppender {
 public:
  ImuAppender(ImuSeries* s, const BagReadOptions& o) : s_(s), o_(o) {}
  void add(const ros::Time& record_time, const sensor_msgs::Imu& imu) {
    if (!keep(record_time, imu.header)) return;
    const ImuHalves h = imuHalves(imu);
    s_->gyro_flagged += h.gyro_flagged;
    for (size_t k = 0; k < 3; ++k) s_->gyro[k].push_back(h.gyro[k]);
    if (!o_.accel_topic.empty()) return;  // the accelerometer comes from its own topic
    s_->accel_flagged += h.accel_flagged;
    for (size_t k = 0; k < 3; ++k) s_->accel[k].push_back(h.accel[k]);
  }
  /// An angle message (BagReadOptions::angle_topic): the same, with the vector as the three gyro values and no
  /// accelerometer.
  void add(const ros::Time& record_time, const geometry_msgs::Vector3Stamped& m) {
    if (!keep(record_time, m.header)) return;
    s_->gyro[0].push_back(m.vector.x);
    s_->gyro[1].push_back(m.vector.y);
    s_->gyro[2].push_back(m.vector.z);
  }
  /// A message of the separate accelerometer topic: its stamp and linear_acceleration (kept whatever the time
  /// window: finish() cuts it to the gyro's span).
  void addAccel(const ros::Time& record_time, const sensor_msgs::Imu& imu) {
    ++s_->accel_messages;
    const ros::Time stamp = o_.use_bag_time ? record_time : imu.header.stamp;
    accel_t_.push_back(relativeStampNs(stamp, &origin_));
    const ImuHalves h = imuHalves(imu);
    s_->accel_flagged += h.accel_flagged;
    for (size_t k = 0; k < 3; ++k) accel_[k].push_back(h.accel[k]);
  }
  /// After the last message: the separate accelerometer's samples within the gyro's kept span (zero stamps kept:
  /// its sanitation counts them) moved into the series.
  void finish() {
    if (o_.accel_topic.empty()) return;
    int64_t lo = INT64_MAX, hi = INT64_MIN;
    for (int64_t ns : s_->t.toNanoseconds())
      if (ns != 0) lo = std::min(lo, ns), hi = std::max(hi, ns);
    for (size_t i = 0; i < accel_t_.size(); ++i) {
      const int64_t ns = accel_t_[i];
      if (ns != 0 && (ns < lo || ns > hi)) continue;
      s_->accel_t.push_back(ns);
      for (int k = 0; k < 3; ++k) s_->accel[k].push_back(accel_[k][i]);
    }
    accel_t_.clear();
    for (auto& a : accel_) a.clear();
  }
  /// Messages offered so far (kept or not).
  size_t offered() const { return offered_; }
  /// Zero until the first non-zero stamp; temperature stamps are made relative to it at the end.
  ros::Time* origin() { return &origin_; }

 private:
  /// Counts the message and, when it is in the time window, appends its stamp (and the frame id): true.
  bool keep(const ros::Time& record_time, const std_msgs::Header& header) {
    ++offered_;
    const ros::Time stamp = o_.use_bag_time ? record_time : header.stamp;
    const int64_t t_ns = relativeStampNs(stamp, &origin_);
    const double t = t_ns == 0 ? 0.0 : (stamp - origin_).toSec();  // as CompactStamps::toSeconds gives it
    if (t_first_ < 0 && t != 0) t_first_ = t;
    if (o_.start_s > 0 || o_.duration_s > 0) {
      if (t_first_ >= 0 && t < t_first_ + o_.start_s) return false;
      if (o_.duration_s > 0 && t_first_ >= 0 && t >= t_first_ + o_.start_s + o_.duration_s) return false;
    }
    if (s_->frame_id.empty()) s_->frame_id = header.frame_id;
    s_->t.push_back(t_ns);
    return true;
  }
  ImuSeries* s_;
  const BagReadOptions& o_;
  ros::Time origin_;
  double t_first_ = -1;
  size_t offered_ = 0;
  std::vector<int64_t> accel_t_;              // the separate accelerometer until finish()
  std::array<std::vector<double>, 3> accel_;
};

/// Reads ROS 2 bags (rosbag2 folders, .mcap / .db3 files; rosbag2/storage.hpp) as readImuBags reads ROS 1 bags:
/// the same topic choice, appender and errors. Throws InputError.
ImuSeries readRos2Bags(const std::vector<std::string>& paths, const BagReadOptions& options);

/// Whether a stored type is the ROS 1 type `ros1` ("sensor_msgs/Imu") in its ROS 1 or ROS 2 spelling
/// ("sensor_msgs/msg/Imu").
bool isType(const std::string& stored, const char* ros1);

}  // namespace bag_detail

/// Reads the bags like readImuBags does with rosbag::View, but straight from the file: the bag header, the
/// connection and chunk-info records at the end of the file, then each chunk that holds a wanted topic, decompressed
/// (none, bz2, lz4) and scanned record by record; messages are deserialized with roscpp's serializers into one reused
/// message. Memory is one chunk instead of an index entry per message, and chunks without a wanted message are not
/// even decompressed.
/// Returns false, leaving *out untouched, whenever the bags are not plain indexed v2.0 bags this reader is sure to
/// read exactly as rosbag::View would (unindexed or truncated bags, unknown compression, a message-definition
/// mismatch, records whose times are not in order, a topic choice that would be an error, any parse failure):
/// the caller then uses rosbag, which also gives the user-facing error messages.
bool readImuBagsDirect(const std::vector<std::string>& paths, const BagReadOptions& options, ImuSeries* out);

}  // namespace gyro_allan
