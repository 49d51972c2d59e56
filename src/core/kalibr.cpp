// Kalibr imu.yaml from the IEEE 952 fit: N and K are Kalibr's continuous-time densities sigma_g and sigma_bg as is.
#include "gyro_allan/kalibr.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <stdexcept>

namespace gyro_allan {

const char* accelTermUnit(int term) {
  static const char* units[] = {"m/s", "m/s/sqrt(s)", "m/s^2", "m/s^2/sqrt(s)", "m/s^3"};
  return (term >= 0 && term < kNumTerms) ? units[term] : "";
}

const char* accelConventionalUnit(int term) {
  static const char* units[] = {"mm/s", "m/s/sqrt(h)", "ug", "m/s/h/sqrt(h)", "m/s/h^2"};
  return (term >= 0 && term < kNumTerms) ? units[term] : "";
}

double accelConventionalFactor(int term) {
  switch (term) {
    case kQuantization: return 1e3;                      // m/s -> mm/s
    case kAngleRandomWalk: return 60.0;                  // m/s/sqrt(s) -> m/s/sqrt(h)
    case kBiasInstability: return 1e6 / 9.80665;         // m/s^2 -> ug
    case kRateRandomWalk: return 3600.0 * 60.0;          // m/s^2/sqrt(s) -> m/s/h/sqrt(h)
    case kRateRamp: return 3600.0 * 3600.0;              // m/s^3 -> m/s/h^2
    default: return 1.0;
  }
}

KalibrAxisRule parseKalibrAxisRule(const std::string& s) {
  if (s == "worst") return KalibrAxisRule::Worst;
  if (s == "mean") return KalibrAxisRule::Mean;
  throw std::invalid_argument("kalibr axis rule must be worst or mean, got '" + s + "'");
}

KalibrValue combineAxes(const std::vector<std::string>& axes, const std::vector<Coefficient>& coefficients,
                        KalibrAxisRule rule) {
  if (axes.size() != coefficients.size())
    throw std::invalid_argument("combineAxes: " + std::to_string(axes.size()) + " axis names for " +
                                std::to_string(coefficients.size()) + " coefficients");
  KalibrValue v;
  if (coefficients.empty()) return v;
  v.present = true;
  double sum_sq = 0, sum_sq95 = 0, max95 = 0;
  for (size_t i = 0; i < coefficients.size(); ++i) {
    const Coefficient& c = coefficients[i];
    const double x = c.supported ? c.value : c.sigma;  // unsupported: the bound is what it could be
    if (!std::isfinite(x) || x < 0) throw std::invalid_argument("combineAxes: axis " + axes[i] + " has no valid value");
    sum_sq += x * x;
    const double x95 = c.supported ? c.value : std::max(c.hi95, x);  // at least the 68 % end (an unset hi95 is 0)
    sum_sq95 += x95 * x95;
    max95 = std::max(max95, x95);
    if (rule == KalibrAxisRule::Worst && (i == 0 || x > v.value)) {
      v.value = x;
      v.bound = !c.supported;
      v.axis = axes[i];
    }
    if (rule == KalibrAxisRule::Mean && !c.supported) v.bound = true;
  }
  v.value95 = max95;
  if (rule == KalibrAxisRule::Mean) {
    v.value = std::sqrt(sum_sq / static_cast<double>(coefficients.size()));
    v.value95 = std::sqrt(sum_sq95 / static_cast<double>(coefficients.size()));
    v.axis = "rms";
  }
  return v;
}

KalibrParams kalibrParams(const std::vector<std::string>& gyro_axes,
                          const std::vector<std::array<Coefficient, kNumTerms>>& gyro,
                          const std::vector<std::string>& accel_axes,
                          const std::vector<std::array<Coefficient, kNumTerms>>& accel, double update_rate_hz,
                          const std::string& rostopic, KalibrAxisRule rule) {
  if (gyro.empty()) throw std::invalid_argument("kalibrParams: no gyro axis");
  if (!(update_rate_hz > 0)) throw std::invalid_argument("kalibrParams: update rate must be > 0");
  auto term = [](const std::vector<std::array<Coefficient, kNumTerms>>& axes, int t) {
    std::vector<Coefficient> out;
    for (const auto& a : axes) out.push_back(a[static_cast<size_t>(t)]);
    return out;
  };
  KalibrParams p;
  p.rule = rule;
  p.update_rate_hz = update_rate_hz;
  p.rostopic = rostopic;
  p.gyroscope_noise_density = combineAxes(gyro_axes, term(gyro, kAngleRandomWalk), rule);
  p.gyroscope_random_walk = combineAxes(gyro_axes, term(gyro, kRateRandomWalk), rule);
  p.accelerometer_noise_density = combineAxes(accel_axes, term(accel, kAngleRandomWalk), rule);
  p.accelerometer_random_walk = combineAxes(accel_axes, term(accel, kRateRandomWalk), rule);
  return p;
}

namespace {

/// The bad axes of one sensor that decided (worst rule: the deciding axis) or entered (mean rule) a value.
std::string badAxes(const KalibrParams& p, const std::string& sensor, const KalibrValue& v) {
  std::string out;
  for (const auto& q : p.quality)
    if (q.sensor == sensor && q.verdict.quality == Quality::Bad && (v.axis == "rms" || v.axis == q.axis))
      out += (out.empty() ? "" : ", ") + q.axis;
  return out;
}

void line(std::ostringstream& o, const char* key, const KalibrValue& v, const char* unit, const char* source,
          const char* missing, const std::string& bad = "") {
  char buf[64];
  if (!v.present) {
    o << "# " << key << ": not measured (" << missing << ")\n";
    return;
  }
  std::snprintf(buf, sizeof buf, "%.6e", v.value);
  o << key << ": " << buf << "  # " << unit << ", " << source;
  if (v.axis == "rms") o << ", quadratic mean over axes";
  else o << ", axis " << v.axis << " (largest)";
  if (v.bound) {
    o << "; NOT SUPPORTED by the data: this is the upper end of its 68 % interval, the true value may be smaller";
    if (std::isfinite(v.value95)) {
      std::snprintf(buf, sizeof buf, "%.6e", v.value95);
      o << "; the 95 % upper end is " << buf;
    }
  }
  if (!bad.empty()) o << "; BAD FIT on axis " << bad << ": not a measurement, see the quality lines above";
  o << "\n";
}

}  // namespace

std::string kalibrYaml(const KalibrParams& p) {
  std::ostringstream o;
  o << "# Kalibr IMU noise model (continuous-time densities) from gyro_allan analyze_bag.\n"
       "# Allan N (ARW) and K (rate random walk) ARE Kalibr's sigma_g and sigma_bg: no sqrt(2), no sqrt(rate).\n"
       "# Static-bench values: inflate deliberately (and say by how much) for a vibrating or heated platform.\n";
  if (!p.data_note.empty()) o << "# Data: " << p.data_note << "\n";
  for (const auto& q : p.quality)
    o << "# Quality " << q.sensor << " " << q.axis << ": "
      << (q.verdict.quality == Quality::Bad ? "BAD" : qualityName(q.verdict.quality)) << " (" << q.verdict.reason
      << ")\n";
  o << "rostopic: " << (p.rostopic.empty() ? "/imu" : p.rostopic)
    << (p.rostopic.empty() ? "  # input was not a bag: set your IMU topic" : "") << "\n";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.6g", p.update_rate_hz);
  o << "update_rate: " << buf << "  # Hz, nominal sample rate of the data\n";
  line(o, "gyroscope_noise_density", p.gyroscope_noise_density, "rad/s/sqrt(Hz)", "Allan N (angle random walk)",
       "no gyro data", badAxes(p, "gyro", p.gyroscope_noise_density));
  line(o, "gyroscope_random_walk", p.gyroscope_random_walk, "rad/s^2/sqrt(Hz)", "Allan K (rate random walk)",
       "no gyro data", badAxes(p, "gyro", p.gyroscope_random_walk));
  line(o, "accelerometer_noise_density", p.accelerometer_noise_density, "m/s^2/sqrt(Hz)",
       "Allan N of the accelerometer (velocity random walk)", "no accelerometer data: CSV input or --no-accel",
       badAxes(p, "accelerometer", p.accelerometer_noise_density));
  line(o, "accelerometer_random_walk", p.accelerometer_random_walk, "m/s^3/sqrt(Hz)",
       "Allan K of the accelerometer (acceleration random walk)", "no accelerometer data: CSV input or --no-accel",
       badAxes(p, "accelerometer", p.accelerometer_random_walk));
  return o.str();
}

}  // namespace gyro_allan
