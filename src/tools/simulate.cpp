// simulate: writes a simulated static gyro (declared IEEE 952 noise, optional undeclared effects) as a ROS 1 bag or a
// ROS 2 .mcap / .db3 of sensor_msgs/Imu (+ sensor_msgs/Temperature), or as CSV, deterministic by seed.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <fstream>
#include <iostream>
#include <string>

#include <rosbag/bag.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/Temperature.h>

#include "gyro_allan/rosbag2/cdr.hpp"
#include "gyro_allan/rosbag2/writer.hpp"
#include "gyro_allan/simulate.hpp"

using namespace gyro_allan;

namespace {

const char* kUsage = R"(usage: simulate --output FILE.bag|FILE.mcap|FILE.db3|FILE.csv [options]

Simulated static gyro, all three axes with the same declared noise (independent per axis), SI units:
  --rate HZ                 sample rate (default 400)
  --duration S              length in seconds (default 3600)
  --seed N                  random seed (default 1); same seed, same output
  --quantization Q          angle quantization Q [rad] (RLG pulse counter, pulse = Q*sqrt(12))
  --no-dither               plain pulse counting (default: subtractive dither, white quantization error)
  --arw N                   angle random walk [rad/sqrt(s)]
  --bias-instability B      flicker bias instability [rad/s]
  --rrw K                   rate random walk [rad/s/sqrt(s)]
  --rate-ramp R             rate ramp [rad/s^2]
  --bias B0                 constant bias [rad/s]
  --input-rate W            constant true rate, e.g. Earth rate [rad/s]
  --rate-lsb L              round output rate samples to L [rad/s] (MEMS-style)
Undeclared effects (for testing the model check):
  --sine-amplitude A --sine-frequency F     sinusoid [rad/s], [Hz]
  --gm-sigma S --gm-tau T                   first-order Gauss-Markov [rad/s], [s]
  --step-size D --step-time T               bias step [rad/s] at T [s]
  --thermal-amplitude A --thermal-tau T     warm-up drift A*(1-exp(-t/T)) [rad/s], [s]
  --temperature                             also write a temperature series (/temperature, degC)
Output:
  --output FILE             .bag (ROS 1), .mcap or .db3 (ROS 2: MCAP with zstd chunks, or rosbag2 sqlite3) of
                            sensor_msgs/Imu on --topic, or .csv (t,wx,wy,wz in s and rad/s)
  --csv-format F            plain (default) or euroc: EuRoC/TUM-VI data.csv (#timestamp [ns], w_RS_S_x..z
                            [rad s^-1], a_RS_S_x..z [m s^-2])
  --accel-rate HZ           the accelerometer on a topic of its own (--accel-topic, default /imu/accel) at this
                            rate, as split gyro/accel drivers publish it (RealSense); the gyro topic's
                            linear_acceleration is then 0
  --topic T                 IMU topic (default /imu); frame --frame (default imu_link)
  --accel-noise V           accelerometer white noise [m/s/sqrt(s)] (default 1e-3), gravity on +z
  --accel-lsb L             round accelerometer samples to L [m/s^2] (default 0: no rounding)
  --compression C           .bag: none | bz2 | lz4 (default lz4); .mcap: none | lz4 | zstd (default zstd)
  --start-time T            stamp of the first sample, s since epoch (default 1700000000)
  --stamp-jitter F          stamp on arrival: delay each stamp by a uniform 0..F periods (default 0)
  --late-fraction P         ... and hold back a fraction P of samples 2..10 periods (a burst follows; default 0)
  --batched-stamps          ... the burst is one buffered read: its samples share one stamp
Not at rest (for testing the at-rest check):
  --bump-time T --bump-duration D --bump-rate W
                            the sensor is picked up at T s for D s: half-sine rotation about x, peak W rad/s,
                            and put back tilted (gravity in the accelerometer follows the angle)
)";

double num(const std::string& flag, const char* v) {
  char* end = nullptr;
  const double x = std::strtod(v, &end);
  if (*v == '\0' || *end != '\0' || !std::isfinite(x)) {
    std::cerr << "simulate: error: " << flag << " needs a number, got '" << v << "'\n";
    std::exit(1);
  }
  return x;
}

}  // namespace

int main(int argc, char** argv) {
  SimulationSpec spec;
  AxisNoise a;
  std::string output, topic = "/imu", frame = "imu_link", compression = "lz4", csv_format = "plain";
  std::string accel_topic = "/imu/accel";
  double accel_rate = 0;
  bool compression_given = false;
  double accel_noise = 1e-3, accel_lsb = 0, start_time = 1700000000.0, stamp_jitter = 0, late_fraction = 0;
  bool batched_stamps = false;
  double bump_time = 0, bump_duration = 0, bump_rate = 0;
  for (int i = 1; i < argc; ++i) {
    const std::string s = argv[i];
    auto v = [&]() -> const char* {
      if (i + 1 >= argc) {
        std::cerr << "simulate: error: " << s << " needs a value\n";
        std::exit(1);
      }
      return argv[++i];
    };
    if (s == "-h" || s == "--help") {
      std::cout << kUsage;
      return 0;
    } else if (s == "--output" || s == "-o") output = v();
    else if (s == "--rate") spec.rate_hz = num(s, v());
    else if (s == "--duration") spec.duration_s = num(s, v());
    else if (s == "--seed") spec.seed = static_cast<uint64_t>(num(s, v()));
    else if (s == "--quantization") a.quantization = num(s, v());
    else if (s == "--no-dither") a.dither = false;
    else if (s == "--arw") a.angle_random_walk = num(s, v());
    else if (s == "--bias-instability") a.bias_instability = num(s, v());
    else if (s == "--rrw") a.rate_random_walk = num(s, v());
    else if (s == "--rate-ramp") a.rate_ramp = num(s, v());
    else if (s == "--bias") a.bias = num(s, v());
    else if (s == "--input-rate") a.input_rate = num(s, v());
    else if (s == "--rate-lsb") a.rate_lsb = num(s, v());
    else if (s == "--sine-amplitude") a.sine_amplitude = num(s, v());
    else if (s == "--sine-frequency") a.sine_frequency = num(s, v());
    else if (s == "--gm-sigma") a.gm_sigma = num(s, v());
    else if (s == "--gm-tau") a.gm_tau = num(s, v());
    else if (s == "--step-size") a.step_size = num(s, v());
    else if (s == "--step-time") a.step_time = num(s, v());
    else if (s == "--thermal-amplitude") a.thermal_amplitude = num(s, v());
    else if (s == "--thermal-tau") a.thermal_tau = num(s, v());
    else if (s == "--temperature") spec.temperature = true;
    else if (s == "--topic") topic = v();
    else if (s == "--accel-topic") accel_topic = v();
    else if (s == "--accel-rate") accel_rate = num(s, v());
    else if (s == "--csv-format") csv_format = v();
    else if (s == "--frame") frame = v();
    else if (s == "--accel-noise") accel_noise = num(s, v());
    else if (s == "--accel-lsb") accel_lsb = num(s, v());
    else if (s == "--compression") compression = v(), compression_given = true;
    else if (s == "--start-time") start_time = num(s, v());
    else if (s == "--stamp-jitter") stamp_jitter = num(s, v());
    else if (s == "--bump-time") bump_time = num(s, v());
    else if (s == "--bump-duration") bump_duration = num(s, v());
    else if (s == "--bump-rate") bump_rate = num(s, v());
    else if (s == "--late-fraction") late_fraction = num(s, v());
    else if (s == "--batched-stamps") batched_stamps = true;
    else {
      std::cerr << "simulate: error: unknown option " << s << " (see --help)\n";
      return 1;
    }
  }
  if (output.empty()) {
    std::cerr << "simulate: error: --output FILE.bag|FILE.mcap|FILE.db3|FILE.csv is required\n";
    return 1;
  }
  if (csv_format != "plain" && csv_format != "euroc") {
    std::cerr << "simulate: error: --csv-format must be plain or euroc\n";
    return 1;
  }
  if (accel_rate < 0 || (accel_rate > 0 && accel_topic == topic)) {
    std::cerr << "simulate: error: --accel-rate must be > 0, on a topic other than the gyro's\n";
    return 1;
  }
  if (!(start_time > 0)) {
    std::cerr << "simulate: error: --start-time must be > 0 (a zero stamp is invalid)\n";
    return 1;
  }
  for (auto& ax : spec.axes) ax = a;
  SimulatedData d;
  try {
    d = simulate(spec);
    // The stamps a receipt-stamping driver would give (the samples stay evenly spaced; only their stamps move).
    if (stamp_jitter > 0 || late_fraction > 0)
      d.t = receiptStamps(d.t, 1.0 / spec.rate_hz, stamp_jitter, late_fraction, spec.seed, batched_stamps);
  } catch (const std::exception& e) {
    std::cerr << "simulate: error: " << e.what() << "\n";
    return 1;
  }
  // Accelerometer: gravity on +z with white noise (its own seed stream, independent of the gyro).
  std::vector<double> acc[3];
  for (int k = 0; k < 3; ++k) {
    AxisNoise an;
    an.angle_random_walk = accel_noise;
    an.bias = k == 2 ? 9.80665 : 0.0;
    an.rate_lsb = accel_lsb;
    const double fa = accel_rate > 0 ? accel_rate : spec.rate_hz;
    const int64_t na = accel_rate > 0 ? static_cast<int64_t>(std::floor(spec.duration_s * accel_rate)) : static_cast<int64_t>(d.t.size());
    acc[k] = simulateAxis(an, fa, na, spec.seed ^ 0xACCE1ULL, k);
  }
  if (bump_rate != 0) {
    try {
      addTiltBump(d.t, bump_time, bump_duration, bump_rate, 9.80665, &d.rate[0], &acc[1], &acc[2]);
    } catch (const std::exception& e) {
      std::cerr << "simulate: error: " << e.what() << "\n";
      return 1;
    }
  }
  auto endsWith = [&](const char* e) {
    const size_t n = std::strlen(e);
    return output.size() > n && output.compare(output.size() - n, n, e) == 0;
  };
  const bool csv = endsWith(".csv"), mcap = endsWith(".mcap"), db3 = endsWith(".db3");
  const double tau0 = 1.0 / spec.rate_hz;
  // The split accelerometer's stamps: its own grid from the gyro's first stamp.
  std::vector<double> ta;
  if (accel_rate > 0)
    for (size_t i = 0; i < acc[0].size(); ++i) ta.push_back(d.t.front() + static_cast<double>(i) / accel_rate);
  if (bump_rate != 0 && accel_rate > 0) {
    std::cerr << "simulate: error: --bump-rate needs the accelerometer at the gyro's rate\n";
    return 1;
  }
  try {
    if (csv) {
      if (accel_rate > 0) throw std::runtime_error("--accel-rate is for bags: a CSV row holds one stamp");
      std::ofstream f(output + ".tmp");
      if (!f) throw std::runtime_error("cannot write '" + output + "'");
      char buf[300];
      if (csv_format == "euroc") {
        f << "#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],a_RS_S_x [m s^-2],"
             "a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]\n";
        const ros::Time t0(start_time);
        for (size_t i = 0; i < d.t.size(); ++i) {
          const ros::Time stamp = t0 + ros::Duration(d.t[i]);
          std::snprintf(buf, sizeof buf, "%llu,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g\n",
                        static_cast<unsigned long long>(stamp.toNSec()), d.rate[0][i], d.rate[1][i], d.rate[2][i],
                        acc[0][i], acc[1][i], acc[2][i]);
          f << buf;
        }
      } else {
        f << "t,wx,wy,wz\n";
        for (size_t i = 0; i < d.t.size(); ++i) {
          std::snprintf(buf, sizeof buf, "%.6f,%.17g,%.17g,%.17g\n", d.t[i], d.rate[0][i], d.rate[1][i], d.rate[2][i]);
          f << buf;
        }
      }
      f.close();
      if (!f || std::rename((output + ".tmp").c_str(), output.c_str()) != 0) throw std::runtime_error("cannot write '" + output + "'");
    } else {
      // Every message in stamp order (gyro, its split accelerometer, temperature at 1 Hz) to one writer.
      std::unique_ptr<rosbag::Bag> bag;
      std::unique_ptr<rosbag2::McapWriter> mw;
      std::unique_ptr<rosbag2::SqliteWriter> sw;
      int id_imu = 0, id_accel = 0, id_temp = 0;
      const std::string tmp = output + ".tmp";
      if (mcap || db3) {
        rosbag2::WriterTopic ti{topic, "sensor_msgs/msg/Imu", cdr::definition("sensor_msgs/msg/Imu")};
        rosbag2::WriterTopic ta_{accel_topic, "sensor_msgs/msg/Imu", cdr::definition("sensor_msgs/msg/Imu")};
        rosbag2::WriterTopic tt{"/temperature", "sensor_msgs/msg/Temperature", cdr::definition("sensor_msgs/msg/Temperature")};
        if (mcap) {
          if (compression != "lz4" && compression != "none" && compression != "zstd")
            throw std::runtime_error("--compression for .mcap must be zstd, lz4 or none");
          rosbag2::McapWriteOptions mo;
          mo.compression = !compression_given ? "zstd" : compression == "none" ? "" : compression;
          mw = std::make_unique<rosbag2::McapWriter>(tmp, mo);
          id_imu = mw->addTopic(ti);
          if (accel_rate > 0) id_accel = mw->addTopic(ta_);
          if (!d.temperature.empty()) id_temp = mw->addTopic(tt);
        } else {
          sw = std::make_unique<rosbag2::SqliteWriter>(tmp);
          id_imu = sw->addTopic(ti);
          if (accel_rate > 0) id_accel = sw->addTopic(ta_);
          if (!d.temperature.empty()) id_temp = sw->addTopic(tt);
        }
      } else {
        bag = std::make_unique<rosbag::Bag>();
        bag->open(tmp, rosbag::bagmode::Write);
        if (compression == "bz2") bag->setCompression(rosbag::compression::BZ2);
        else if (compression == "lz4") bag->setCompression(rosbag::compression::LZ4);
        else if (compression != "none") throw std::runtime_error("--compression must be none, bz2 or lz4");
      }
      auto writeImu = [&](const std::string& t, int id, const sensor_msgs::Imu& m, const ros::Time& stamp) {
        if (bag) {
          bag->write(t, stamp, m);
          return;
        }
        cdr::Imu c;
        c.header.sec = static_cast<int32_t>(m.header.stamp.sec);
        c.header.nanosec = m.header.stamp.nsec;
        c.header.frame_id = m.header.frame_id;
        c.orientation = {{m.orientation.x, m.orientation.y, m.orientation.z, m.orientation.w}};
        c.angular_velocity = {{m.angular_velocity.x, m.angular_velocity.y, m.angular_velocity.z}};
        c.linear_acceleration = {{m.linear_acceleration.x, m.linear_acceleration.y, m.linear_acceleration.z}};
        for (size_t k = 0; k < 9; ++k) {
          c.orientation_covariance[k] = m.orientation_covariance[k];
          c.angular_velocity_covariance[k] = m.angular_velocity_covariance[k];
          c.linear_acceleration_covariance[k] = m.linear_acceleration_covariance[k];
        }
        const std::string bytes = cdr::encode(c);
        if (mw) mw->write(id, static_cast<int64_t>(stamp.toNSec()), bytes);
        else sw->write(id, static_cast<int64_t>(stamp.toNSec()), bytes);
      };
      auto writeTemp = [&](const sensor_msgs::Temperature& m, const ros::Time& stamp) {
        if (bag) {
          bag->write("/temperature", stamp, m);
          return;
        }
        cdr::Temperature c;
        c.header.sec = static_cast<int32_t>(m.header.stamp.sec);
        c.header.nanosec = m.header.stamp.nsec;
        c.header.frame_id = m.header.frame_id;
        c.temperature = m.temperature;
        const std::string bytes = cdr::encode(c);
        if (mw) mw->write(id_temp, static_cast<int64_t>(stamp.toNSec()), bytes);
        else sw->write(id_temp, static_cast<int64_t>(stamp.toNSec()), bytes);
      };
      sensor_msgs::Imu imu;
      imu.header.frame_id = frame;
      imu.orientation.w = 1.0;
      imu.orientation_covariance[0] = -1.0;  // no orientation estimate (REP 145)
      sensor_msgs::Imu accel_msg = imu;
      size_t j = 0;  // next split accelerometer sample
      auto accelUpTo = [&](double t_limit) {
        for (; j < ta.size() && ta[j] <= t_limit; ++j) {
          const ros::Time stamp = ros::Time(start_time) + ros::Duration(ta[j]);
          accel_msg.header.seq = static_cast<uint32_t>(j);
          accel_msg.header.stamp = stamp;
          accel_msg.linear_acceleration.x = acc[0][j];
          accel_msg.linear_acceleration.y = acc[1][j];
          accel_msg.linear_acceleration.z = acc[2][j];
          writeImu(accel_topic, id_accel, accel_msg, stamp);
        }
      };
      for (size_t i = 0; i < d.t.size(); ++i) {
        if (accel_rate > 0) accelUpTo(d.t[i] - 1e-12);
        const ros::Time stamp = ros::Time(start_time) + ros::Duration(d.t[i]);
        imu.header.seq = static_cast<uint32_t>(i);
        imu.header.stamp = stamp;
        imu.angular_velocity.x = d.rate[0][i];
        imu.angular_velocity.y = d.rate[1][i];
        imu.angular_velocity.z = d.rate[2][i];
        if (accel_rate <= 0) {
          imu.linear_acceleration.x = acc[0][i];
          imu.linear_acceleration.y = acc[1][i];
          imu.linear_acceleration.z = acc[2][i];
        }
        writeImu(topic, id_imu, imu, stamp);
        // Temperature at 1 Hz.
        if (!d.temperature.empty() && std::fmod(d.t[i] + 0.5 * tau0, 1.0) < tau0) {
          sensor_msgs::Temperature tm;
          tm.header.stamp = stamp;
          tm.header.frame_id = frame;
          tm.temperature = d.temperature[i];
          writeTemp(tm, stamp);
        }
      }
      if (accel_rate > 0) accelUpTo(1e300);
      if (bag) bag->close();
      if (mw) mw->close();
      if (sw) sw->close();
      if (std::rename(tmp.c_str(), output.c_str()) != 0) throw std::runtime_error("cannot write '" + output + "'");
    }
  } catch (const std::exception& e) {
    std::cerr << "simulate: error: " << e.what() << "\n";
    return 2;
  }
  std::printf("wrote %s: %zu samples, %.6g Hz, %.6g s\n", output.c_str(), d.t.size(), spec.rate_hz, spec.duration_s);
  return 0;
}
