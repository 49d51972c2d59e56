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

namespace {

std::string sci(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.6e", v);
  return buf;
}

/// The rate as ORB-SLAM3's legacy parser wants it (an integer when it is one) and as every other reads it.
std::string rateText(double hz) {
  char buf[40];
  if (hz == std::floor(hz) && hz < 1e9) std::snprintf(buf, sizeof buf, "%.0f", hz);
  else std::snprintf(buf, sizeof buf, "%.6g", hz);
  return buf;
}

/// "# NOT SUPPORTED..." / "BAD FIT" notes of a value, for the frameworks' comments.
std::string caveat(const KalibrParams& p, const std::string& sensor, const KalibrValue& v) {
  std::string c;
  if (v.bound) c += "; not supported by the data: upper end of its 68 % interval";
  const std::string bad = badAxes(p, sensor, v);
  if (!bad.empty()) c += "; BAD FIT on axis " + bad + ": not a measurement";
  return c;
}

/// One "key: value  # comment" line, or the key commented out when the sensor has no data.
void field(std::ostringstream& o, const std::string& indent, const std::string& key, const KalibrValue& v,
           double factor, const std::string& comment, const std::string& caveat_text) {
  if (!v.present) {
    o << indent << "# " << key << ": not measured (no accelerometer in the data): fill in before use\n";
    return;
  }
  o << indent << key << ": " << sci(v.value * factor) << "  # " << comment << caveat_text << "\n";
}

std::string header(const KalibrParams& p, const std::string& what) {
  std::string h = "# " + what + " from gyro_allan analyze_bag (the same measurement as imu.yaml).\n";
  if (!p.data_note.empty()) h += "# Data: " + p.data_note + "\n";
  for (const auto& q : p.quality)
    if (q.verdict.quality != Quality::Good)
      h += "# Quality " + q.sensor + " " + q.axis + ": " +
           (q.verdict.quality == Quality::Bad ? std::string("BAD") : qualityName(q.verdict.quality)) + " (" +
           q.verdict.reason + ")\n";
  h += "# Static-bench values: inflate deliberately (and say by how much) for a vibrating or heated platform.\n";
  return h;
}

}  // namespace

std::vector<FrameworkConfig> frameworkConfigs(const KalibrParams& p) {
  const std::string topic = p.rostopic.empty() ? "/imu" : p.rostopic;
  const std::string rate = rateText(p.update_rate_hz);
  const auto& gn = p.gyroscope_noise_density;
  const auto& gw = p.gyroscope_random_walk;
  const auto& an = p.accelerometer_noise_density;
  const auto& aw = p.accelerometer_random_walk;
  std::vector<FrameworkConfig> out;
  {
    // OpenVINS: OpenCV FileStorage (needs %YAML:1.0); Propagator uses sigma^2 / dt (continuous densities). Tw, Ta
    // and the two rotations identity, Tg zero: an IMU without intrinsic calibration.
    std::ostringstream o;
    o << "%YAML:1.0\n" << header(p, "OpenVINS IMU noise (config/<platform>/kalibr_imu_chain.yaml)")
      << "# OpenVINS reads these as continuous-time densities (ov_msckf Propagator: sigma^2 / dt): imu.yaml's values.\n"
      << "imu0:\n"
      << "  T_i_b:\n    - [1.0, 0.0, 0.0, 0.0]\n    - [0.0, 1.0, 0.0, 0.0]\n    - [0.0, 0.0, 1.0, 0.0]\n"
      << "    - [0.0, 0.0, 0.0, 1.0]\n";
    field(o, "  ", "accelerometer_noise_density", an, 1, "[ m / s^2 / sqrt(Hz) ]", caveat(p, "accelerometer", an));
    field(o, "  ", "accelerometer_random_walk", aw, 1, "[ m / s^3 / sqrt(Hz) ]", caveat(p, "accelerometer", aw));
    field(o, "  ", "gyroscope_noise_density", gn, 1, "[ rad / s / sqrt(Hz) ]", caveat(p, "gyro", gn));
    field(o, "  ", "gyroscope_random_walk", gw, 1, "[ rad / s^2 / sqrt(Hz) ]", caveat(p, "gyro", gw));
    o << "  rostopic: " << topic << (p.rostopic.empty() ? "  # input was not a bag: set your IMU topic" : "") << "\n"
      << "  time_offset: 0.0\n"
      << "  update_rate: " << rate << "  # Hz\n"
      << "  model: \"kalibr\"\n"
      << "  Tw:\n    - [1.0, 0.0, 0.0]\n    - [0.0, 1.0, 0.0]\n    - [0.0, 0.0, 1.0]\n"
      << "  R_IMUtoGYRO:\n    - [1.0, 0.0, 0.0]\n    - [0.0, 1.0, 0.0]\n    - [0.0, 0.0, 1.0]\n"
      << "  Ta:\n    - [1.0, 0.0, 0.0]\n    - [0.0, 1.0, 0.0]\n    - [0.0, 0.0, 1.0]\n"
      << "  R_IMUtoACC:\n    - [1.0, 0.0, 0.0]\n    - [0.0, 1.0, 0.0]\n    - [0.0, 0.0, 1.0]\n"
      << "  Tg:\n    - [0.0, 0.0, 0.0]\n    - [0.0, 0.0, 0.0]\n    - [0.0, 0.0, 0.0]\n";
    out.push_back({"kalibr_imu_chain.yaml", "OpenVINS", o.str()});
  }
  {
    // VINS-Fusion: integration_base.h adds V * diag(n^2) * V' per sample with V ~ dt, i.e. n is a per-sample std:
    // continuous density * sqrt(rate). The random walks the same way (V = dt * I).
    const double k = std::sqrt(p.update_rate_hz);
    char note[200];
    std::snprintf(note, sizeof note, "x sqrt(%s Hz) = x %.4g", rate.c_str(), k);
    std::ostringstream o;
    o << "%YAML:1.0\n" << header(p, "VINS-Fusion IMU noise (merge into your config yaml)")
      << "# VINS-Fusion's pre-integration (vins_estimator/src/factor/integration_base.h) takes acc_n, gyr_n as the\n"
         "# noise of one sample and acc_w, gyr_w as the bias change per sample period (each multiplied by dt there):\n"
         "# imu.yaml's continuous-time densities times sqrt(update_rate). Its sample config's values are hand-tuned.\n"
      << "imu: 1\n"
      << "imu_topic: \"" << topic << "\"" << (p.rostopic.empty() ? "  # input was not a bag: set your IMU topic" : "")
      << "\n";
    field(o, "", "acc_n", an, k, "m/s^2 per sample = accelerometer_noise_density [m/s^2/sqrt(Hz)] " + std::string(note),
          caveat(p, "accelerometer", an));
    field(o, "", "gyr_n", gn, k, "rad/s per sample = gyroscope_noise_density [rad/s/sqrt(Hz)] " + std::string(note),
          caveat(p, "gyro", gn));
    field(o, "", "acc_w", aw, k, "m/s^3 per sample = accelerometer_random_walk [m/s^3/sqrt(Hz)] " + std::string(note),
          caveat(p, "accelerometer", aw));
    field(o, "", "gyr_w", gw, k, "rad/s^2 per sample = gyroscope_random_walk [rad/s^2/sqrt(Hz)] " + std::string(note),
          caveat(p, "gyro", gw));
    o << "g_norm: 9.81  # m/s^2, local gravity: set yours\n";
    out.push_back({"vins_fusion_imu.yaml", "VINS-Fusion", o.str()});
  }
  {
    // ORB-SLAM3: Tracking builds IMU::Calib(Ng * sqrt(f), Na * sqrt(f), Ngw / sqrt(f), Naw / sqrt(f)) from these:
    // continuous-time densities and the rate.
    std::ostringstream o;
    o << "%YAML:1.0\n" << header(p, "ORB-SLAM3 IMU noise (merge into your settings yaml)")
      << "# ORB-SLAM3 takes continuous-time densities and discretizes them with IMU.Frequency (Tracking.cc:\n"
         "# sf = sqrt(freq)): imu.yaml's values. Your settings file also needs IMU.T_b_c1 (File.version \"1.0\") or Tbc.\n";
    field(o, "", "IMU.NoiseGyro", gn, 1, "rad/s/sqrt(Hz) (= rad/s^0.5)", caveat(p, "gyro", gn));
    field(o, "", "IMU.NoiseAcc", an, 1, "m/s^2/sqrt(Hz) (= m/s^1.5)", caveat(p, "accelerometer", an));
    field(o, "", "IMU.GyroWalk", gw, 1, "rad/s^2/sqrt(Hz) (= rad/s^1.5)", caveat(p, "gyro", gw));
    field(o, "", "IMU.AccWalk", aw, 1, "m/s^3/sqrt(Hz) (= m/s^2.5)", caveat(p, "accelerometer", aw));
    o << "IMU.Frequency: " << rate << "  # Hz\n";
    out.push_back({"orb_slam3_imu.yaml", "ORB-SLAM3", o.str()});
  }
  {
    // Basalt: calibration JSON (cereal), fields of "value0"; Calibration::dicrete_time_gyro_noise_std multiplies by
    // sqrt(imu_update_rate): continuous-time densities, one per axis.
    std::ostringstream o;
    auto vec = [&](const KalibrValue& v) {
      const std::string x = v.present ? sci(v.value) : "null";
      return "[" + x + ", " + x + ", " + x + "]";
    };
    o << "{\n"
      << "  \"gyro_allan\": \"Basalt IMU noise from gyro_allan analyze_bag (the same measurement as imu.yaml): merge "
         "the fields of value0 into your calibration json. Basalt takes continuous-time densities (calibration.hpp: "
         "dicrete_time_gyro_noise_std = gyro_noise_std * sqrt(imu_update_rate)). Units: gyro_noise_std rad/s/sqrt(Hz), "
         "gyro_bias_std rad/s^2/sqrt(Hz), accel_noise_std m/s^2/sqrt(Hz), accel_bias_std m/s^3/sqrt(Hz), "
         "imu_update_rate Hz."
      << (an.present ? "" : " No accelerometer in the data: its fields are null, fill them in.")
      << (gw.bound || aw.bound ? " A random walk not supported by the data is the upper end of its 68 % interval." : "")
      << "\",\n"
      << "  \"value0\": {\n"
      << "    \"imu_update_rate\": " << rate << ",\n"
      << "    \"accel_noise_std\": " << vec(an) << ",\n"
      << "    \"gyro_noise_std\": " << vec(gn) << ",\n"
      << "    \"accel_bias_std\": " << vec(aw) << ",\n"
      << "    \"gyro_bias_std\": " << vec(gw) << "\n"
      << "  }\n}\n";
    out.push_back({"basalt_imu.json", "Basalt", o.str()});
  }
  return out;
}

}  // namespace gyro_allan
