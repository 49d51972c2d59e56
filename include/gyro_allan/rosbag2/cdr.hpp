// CDR (OMG DDS-XTypes 1.3, 7.4 "Data Representation") of the ROS 2 messages the analysis reads — sensor_msgs/msg/Imu,
// geometry_msgs/msg/Vector3Stamped, sensor_msgs/msg/Temperature — decoded and encoded without ROS 2.
//
// A ROS 2 message is a 4-byte encapsulation header (representation identifier, big-endian uint16, then 2 option
// bytes) and the members in declaration order:
//   0x0000 / 0x0001            XCDR1 (plain CDR) big / little endian: primitives aligned to their size (8 for double)
//   0x0006 / 0x0007, 0x0010 / 0x0011  PLAIN_CDR2 (XTypes / DDSI-RTPS 2.5 numbering): alignment at most 4
//   0x0008 / 0x0009, 0x0014 / 0x0015  DELIMITED_CDR2: as PLAIN_CDR2, each struct preceded by a uint32 DHEADER (its
//                                     size in bytes), which lets a reader skip members appended to a newer type
// Alignment counts from the first byte after the encapsulation header. A string is a uint32 length that includes
// the terminating NUL, then the bytes; fixed arrays (covariances) have no length. Parameter-list encodings (mutable
// types, 0x0002/3, 0x000a/b, 0x0012/3) are refused: no ROS 2 message type is mutable.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>

namespace gyro_allan {
namespace cdr {

/// A message that is not the CDR of the type it is decoded as (truncated, unknown encapsulation...): one line.
struct Error : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// Which CDR to write: XCDR1 (what rmw_fastrtps, rmw_cyclonedds and rosbag2 write), PLAIN_CDR2, DELIMITED_CDR2.
enum class Kind { Xcdr1, Xcdr2, Xcdr2Delimited };

/// std_msgs/msg/Header (builtin_interfaces/msg/Time stamp + frame_id).
struct Header {
  int32_t sec = 0;
  uint32_t nanosec = 0;
  std::string frame_id;
};

/// sensor_msgs/msg/Imu.
struct Imu {
  Header header;
  std::array<double, 4> orientation{{0, 0, 0, 1}};  ///< x, y, z, w
  std::array<double, 9> orientation_covariance{};
  std::array<double, 3> angular_velocity{};          ///< rad/s
  std::array<double, 9> angular_velocity_covariance{};
  std::array<double, 3> linear_acceleration{};       ///< m/s^2
  std::array<double, 9> linear_acceleration_covariance{};
};

/// geometry_msgs/msg/Vector3Stamped.
struct Vector3Stamped {
  Header header;
  std::array<double, 3> vector{};
};

/// sensor_msgs/msg/Temperature.
struct Temperature {
  Header header;
  double temperature = 0;  ///< degC
  double variance = 0;
};

/// Decode `size` bytes (with the encapsulation header). Throws Error naming what is wrong and where.
void decode(const uint8_t* data, size_t size, Imu* out);
void decode(const uint8_t* data, size_t size, Vector3Stamped* out);
void decode(const uint8_t* data, size_t size, Temperature* out);

/// The message's bytes in the given CDR and byte order, with the encapsulation header.
std::string encode(const Imu& m, Kind kind = Kind::Xcdr1, bool big_endian = false);
std::string encode(const Vector3Stamped& m, Kind kind = Kind::Xcdr1, bool big_endian = false);
std::string encode(const Temperature& m, Kind kind = Kind::Xcdr1, bool big_endian = false);

/// The ROS 2 message definitions (ros2msg text, as rosbag2 stores them) of the three types, for writers.
const char* definition(const std::string& type);

}  // namespace cdr
}  // namespace gyro_allan
