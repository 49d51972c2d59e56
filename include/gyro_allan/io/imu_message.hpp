// The rate and acceleration halves of a sensor_msgs/Imu as the analysis takes them: a half flagged absent by
// covariance[0] = -1 (sensor_msgs/Imu's convention for "no estimate") is NaN, which the sanitation drops and counts.
#pragma once

#include <array>
#include <limits>

#include <sensor_msgs/Imu.h>

namespace gyro_allan {

struct ImuHalves {
  std::array<double, 3> gyro, accel;  ///< rad/s, m/s^2; NaN where flagged
  bool gyro_flagged = false, accel_flagged = false;
};

inline ImuHalves imuHalves(const sensor_msgs::Imu& m) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  ImuHalves h;
  h.gyro_flagged = m.angular_velocity_covariance[0] == -1.0;
  h.accel_flagged = m.linear_acceleration_covariance[0] == -1.0;
  h.gyro = h.gyro_flagged ? std::array<double, 3>{{nan, nan, nan}}
                          : std::array<double, 3>{{m.angular_velocity.x, m.angular_velocity.y, m.angular_velocity.z}};
  h.accel = h.accel_flagged
                ? std::array<double, 3>{{nan, nan, nan}}
                : std::array<double, 3>{{m.linear_acceleration.x, m.linear_acceleration.y, m.linear_acceleration.z}};
  return h;
}

}  // namespace gyro_allan
