// Reads sensor_msgs/Imu or geometry_msgs/Vector3Stamped angles (and optional sensor_msgs/Temperature) from ROS 1 bags
// or ROS 2 bags (rosbag2 folders, .mcap, .db3) in one streaming pass into per-axis sample arrays, with one-line
// errors for every way a bag can be unusable.
#pragma once

#include <array>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "gyro_allan/compact_series.hpp"

namespace gyro_allan {

/// An input problem the user must fix (missing file, wrong topic type, empty bag...): what() is one line.
struct InputError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct BagReadOptions {
  std::string topic;              ///< sensor_msgs/Imu topic; empty = the only one in the bags
  /// geometry_msgs/Vector3Stamped topic of angles per axis [rad] to read instead of an IMU topic (`topic` must then
  /// be empty): its x, y, z go to ImuSeries::gyro, the accelerometer stays empty.
  std::string angle_topic;
  /// sensor_msgs/Imu topic of a separate accelerometer stream at its own rate (RealSense's /camera/accel/sample):
  /// its linear_acceleration is the accelerometer (`topic`'s is ignored). Empty: none, unless the bag's only two
  /// Imu topics are such a pair (names with "gyro" and "accel") and `topic` is empty.
  std::string accel_topic;
  std::string temperature_topic;  ///< sensor_msgs/Temperature topic; empty = the only one, if any; "-" = none
  bool use_bag_time = false;      ///< use the bag's receive time instead of header.stamp
  double start_s = 0;             ///< skip this many seconds from the first message
  double duration_s = 0;          ///< keep at most this many seconds (0 = all)
  bool progress = false;          ///< print progress on stderr
  /// "auto": the direct chunk reader when the bags allow it, else rosbag::View; "rosbag": always rosbag::View.
  std::string reader = "auto";
};

/// The samples are held compactly (4 bytes each, see compact_series.hpp) while the bags' indexes are in memory.
struct ImuSeries {
  std::string topic;
  std::string frame_id;
  std::vector<std::string> bags;           ///< in time order
  CompactStamps t;                         ///< stamps, ns since (first non-zero stamp - 1 s); 0 = zero stamp
  std::array<CompactSeries, 3> gyro;       ///< angular_velocity x, y, z, rad/s (angle topic: vector x, y, z, rad)
  std::array<CompactSeries, 3> accel;      ///< linear_acceleration x, y, z, m/s^2 (angle topic: empty)
  std::string accel_topic;                 ///< the separate accelerometer topic, or empty (accel then shares t)
  CompactStamps accel_t;                   ///< its stamps (same origin as t), within the gyro's span
  int64_t accel_messages = 0;              ///< messages read from it
  /// Messages whose angular_velocity / linear_acceleration was flagged as absent (covariance[0] = -1): those
  /// values are NaN.
  int64_t gyro_flagged = 0, accel_flagged = 0;
  std::string temperature_topic;           ///< empty when none was read
  std::vector<double> temperature_t, temperature;  ///< stamps [s, same origin as t] and degC
  int64_t messages = 0;
  std::string reader;                      ///< "direct" (bag_direct.hpp), "rosbag" (rosbag::View) or "rosbag2"
};

/// Reads every bag (ordered by their first stamp) for the chosen topic. ROS 1 bags, or one ROS 2 recording (a
/// rosbag2 folder, or its .mcap / .db3 files), not both. Throws InputError.
ImuSeries readImuBags(const std::vector<std::string>& bags, const BagReadOptions& options);

}  // namespace gyro_allan
