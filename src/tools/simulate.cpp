// simulate: writes a simulated static gyro (declared IEEE 952 noise, optional undeclared effects) as a rosbag of
// sensor_msgs/Imu (+ sensor_msgs/Temperature) or as CSV, deterministic by seed.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <string>

#include <rosbag/bag.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/Temperature.h>

#include "gyro_allan/simulate.hpp"

using namespace gyro_allan;

namespace {

const char* kUsage = R"(usage: simulate --output FILE.bag|FILE.csv [options]

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
  --output FILE             .bag (sensor_msgs/Imu on --topic) or .csv (t,wx,wy,wz in s and rad/s)
  --topic T                 IMU topic (default /imu); frame --frame (default imu_link)
  --accel-noise V           accelerometer white noise [m/s/sqrt(s)] (default 1e-3), gravity on +z
  --accel-lsb L             round accelerometer samples to L [m/s^2] (default 0: no rounding)
  --compression C           none | bz2 | lz4 (default lz4)
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
  std::string output, topic = "/imu", frame = "imu_link", compression = "lz4";
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
    else if (s == "--frame") frame = v();
    else if (s == "--accel-noise") accel_noise = num(s, v());
    else if (s == "--accel-lsb") accel_lsb = num(s, v());
    else if (s == "--compression") compression = v();
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
    std::cerr << "simulate: error: --output FILE.bag|FILE.csv is required\n";
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
    acc[k] = simulateAxis(an, spec.rate_hz, static_cast<int64_t>(d.t.size()), spec.seed ^ 0xACCE1ULL, k);
  }
  if (bump_rate != 0) {
    try {
      addTiltBump(d.t, bump_time, bump_duration, bump_rate, 9.80665, &d.rate[0], &acc[1], &acc[2]);
    } catch (const std::exception& e) {
      std::cerr << "simulate: error: " << e.what() << "\n";
      return 1;
    }
  }
  const bool csv = output.size() > 4 && output.compare(output.size() - 4, 4, ".csv") == 0;
  try {
    if (csv) {
      std::ofstream f(output + ".tmp");
      if (!f) throw std::runtime_error("cannot write '" + output + "'");
      f << "t,wx,wy,wz\n";
      char buf[160];
      for (size_t i = 0; i < d.t.size(); ++i) {
        std::snprintf(buf, sizeof buf, "%.6f,%.17g,%.17g,%.17g\n", d.t[i], d.rate[0][i], d.rate[1][i], d.rate[2][i]);
        f << buf;
      }
      f.close();
      if (!f || std::rename((output + ".tmp").c_str(), output.c_str()) != 0) throw std::runtime_error("cannot write '" + output + "'");
    } else {
      rosbag::Bag bag;
      bag.open(output + ".tmp", rosbag::bagmode::Write);
      if (compression == "bz2") bag.setCompression(rosbag::compression::BZ2);
      else if (compression == "lz4") bag.setCompression(rosbag::compression::LZ4);
      else if (compression != "none") throw std::runtime_error("--compression must be none, bz2 or lz4");
      sensor_msgs::Imu imu;
      imu.header.frame_id = frame;
      imu.orientation.w = 1.0;
      imu.orientation_covariance[0] = -1.0;  // no orientation estimate (REP 145)
      const double tau0 = 1.0 / spec.rate_hz;
      for (size_t i = 0; i < d.t.size(); ++i) {
        const ros::Time stamp = ros::Time(start_time) + ros::Duration(d.t[i]);
        imu.header.seq = static_cast<uint32_t>(i);
        imu.header.stamp = stamp;
        imu.angular_velocity.x = d.rate[0][i];
        imu.angular_velocity.y = d.rate[1][i];
        imu.angular_velocity.z = d.rate[2][i];
        imu.linear_acceleration.x = acc[0][i];
        imu.linear_acceleration.y = acc[1][i];
        imu.linear_acceleration.z = acc[2][i];
        bag.write(topic, stamp, imu);
        // Temperature at 1 Hz.
        if (!d.temperature.empty() && std::fmod(d.t[i] + 0.5 * tau0, 1.0) < tau0) {
          sensor_msgs::Temperature tm;
          tm.header.stamp = stamp;
          tm.header.frame_id = frame;
          tm.temperature = d.temperature[i];
          bag.write("/temperature", stamp, tm);
        }
      }
      bag.close();
      if (std::rename((output + ".tmp").c_str(), output.c_str()) != 0) throw std::runtime_error("cannot write '" + output + "'");
    }
  } catch (const std::exception& e) {
    std::cerr << "simulate: error: " << e.what() << "\n";
    return 2;
  }
  std::printf("wrote %s: %zu samples, %.6g Hz, %.6g s\n", output.c_str(), d.t.size(), spec.rate_hz, spec.duration_s);
  return 0;
}
