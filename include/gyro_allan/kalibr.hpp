// Kalibr IMU noise parameters (imu.yaml) from per-axis IEEE 952 coefficients: continuous-time noise densities.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "gyro_allan/noise_model.hpp"
#include "gyro_allan/quality.hpp"

namespace gyro_allan {

/// Accelerometer units of the five IEEE terms (same model, m/s^2 instead of rad/s): SI unit (m/s, m/s/sqrt(s),
/// m/s^2, m/s^2/sqrt(s), m/s^3) and conventional unit with its factor from SI (mm/s, m/s/sqrt(h), ug,
/// m/s/h/sqrt(h), m/s/h^2). ug uses standard gravity 9.80665 m/s^2.
const char* accelTermUnit(int term);
const char* accelConventionalUnit(int term);
double accelConventionalFactor(int term);

/// How the per-axis coefficients become Kalibr's one isotropic value: the largest axis ("worst") or the quadratic
/// mean over axes ("mean": sqrt of the mean of the squares, i.e. the mean noise power).
enum class KalibrAxisRule { Worst, Mean };
/// "worst" or "mean"; throws std::invalid_argument otherwise.
KalibrAxisRule parseKalibrAxisRule(const std::string& s);

/// One Kalibr number: the value (SI), whether it is only an upper bound (the term is not supported by the data on
/// the axis that decided it, so the 1-sigma bound is written) and which axis decided it ("rms" for the mean rule).
struct KalibrValue {
  double value = 0;
  bool bound = false;
  std::string axis;
  bool present = false;  ///< false: no data for this sensor (e.g. CSV input has no accelerometer)
  /// The same rule with each unsupported axis's 95 % upper end (Coefficient::hi95) in place of its 68 % one; written
  /// beside a bound: a 68 % upper end lies below the truth in about a sixth of records by construction, a 95 % one
  /// in about 2.5 %.
  /// Not finite when an axis has no finite 95 % upper end (+inf on a bad fit, NaN without intervals); the comment
  /// then omits it.
  double value95 = 0;
};

/// The quality verdict of one axis behind the numbers (quality.hpp), written as a comment line.
struct KalibrAxisQuality {
  std::string sensor;  ///< "gyro" or "accelerometer"
  std::string axis;    ///< the axis name as in kalibrParams (e.g. "x", "accel_x")
  QualityVerdict verdict;
};

struct KalibrParams {
  KalibrValue gyroscope_noise_density;      ///< = N, angle random walk [rad/s/sqrt(Hz)] = [rad/sqrt(s)]
  KalibrValue gyroscope_random_walk;        ///< = K, rate random walk [rad/s^2/sqrt(Hz)] = [rad/s/sqrt(s)]
  KalibrValue accelerometer_noise_density;  ///< = VRW [m/s^2/sqrt(Hz)] = [m/s/sqrt(s)]
  KalibrValue accelerometer_random_walk;    ///< = acceleration random walk [m/s^3/sqrt(Hz)] = [m/s^2/sqrt(s)]
  double update_rate_hz = 0;
  std::string rostopic;
  KalibrAxisRule rule = KalibrAxisRule::Worst;
  std::string data_note;   ///< one comment line on what the values come from (e.g. the static stretch used); may be empty
  /// Verdict per axis (may be empty): one comment line each, and a value decided by (worst rule) or including (mean
  /// rule) a bad axis says so in its comment.
  std::vector<KalibrAxisQuality> quality;
};

/// Combines one term over axes: each axis contributes its value when supported, else its 1-sigma bound.
/// Empty input gives present == false. Throws std::invalid_argument if names and coefficients differ in size.
KalibrValue combineAxes(const std::vector<std::string>& axes, const std::vector<Coefficient>& coefficients,
                        KalibrAxisRule rule);

/// Kalibr parameters from gyro (and optionally accelerometer) coefficients per axis (IEEE term order).
/// Throws std::invalid_argument when the gyro has no axis or the rate is not > 0.
KalibrParams kalibrParams(const std::vector<std::string>& gyro_axes,
                          const std::vector<std::array<Coefficient, kNumTerms>>& gyro,
                          const std::vector<std::string>& accel_axes,
                          const std::vector<std::array<Coefficient, kNumTerms>>& accel, double update_rate_hz,
                          const std::string& rostopic, KalibrAxisRule rule);

/// imu.yaml text in Kalibr's format, with comments naming the source of each number and any bound.
std::string kalibrYaml(const KalibrParams& p);

/// A noise-parameter file for a VIO framework, written next to imu.yaml from the same KalibrParams.
struct FrameworkConfig {
  std::string file;       ///< e.g. "kalibr_imu_chain.yaml"
  std::string framework;  ///< e.g. "OpenVINS"
  std::string text;
};
/// The IMU noise blocks of OpenVINS (kalibr_imu_chain.yaml), VINS-Fusion, ORB-SLAM3 and Basalt, each with its units
/// and how the framework reads each field in comments (docs/outputs.md cites the sources). OpenVINS, ORB-SLAM3 and
/// Basalt take the continuous-time densities of imu.yaml as they are; VINS-Fusion's pre-integration takes noise
/// per sample, i.e. imu.yaml's values times sqrt(update_rate). A sensor without data (no accelerometer) has its
/// fields commented out, so that a framework that needs them stops instead of running on a guess.
std::vector<FrameworkConfig> frameworkConfigs(const KalibrParams& p);

}  // namespace gyro_allan
