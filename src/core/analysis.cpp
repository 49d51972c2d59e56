// One-axis analysis pipeline: validate, compute deviations over gap-free segments, fit the IEEE 952 model.
#include "gyro_allan/analysis.hpp"

#include <cmath>
#include <stdexcept>

namespace gyro_allan {

double conventionalFactor(int term) {
  const double deg = 180.0 / M_PI;
  switch (term) {
    case kQuantization: return deg * 3600.0;              // rad -> arcsec
    case kAngleRandomWalk: return deg * 60.0;             // rad/sqrt(s) -> deg/sqrt(h)
    case kBiasInstability: return deg * 3600.0;           // rad/s -> deg/h
    case kRateRandomWalk: return deg * 3600.0 * 60.0;     // rad/s/sqrt(s) -> deg/h/sqrt(h)
    case kRateRamp: return deg * 3600.0 * 3600.0;         // rad/s^2 -> deg/h^2
    default: return 1.0;
  }
}

const char* conventionalUnit(int term) {
  static const char* units[] = {"arcsec", "deg/sqrt(h)", "deg/h", "deg/h/sqrt(h)", "deg/h^2"};
  return (term >= 0 && term < kNumTerms) ? units[term] : "";
}

void enforceRedderWithTau(DeviationCurve* curve, double confidence) {
  bool changed = false;
  for (size_t i = 1; i < curve->points.size(); ++i) {
    if (curve->points[i].alpha > curve->points[i - 1].alpha) {
      curve->points[i].alpha = curve->points[i - 1].alpha;
      changed = true;
    }
  }
  if (changed) fillConfidence(curve, confidence);
}

AxisAnalysis analyzeAxis(const std::string& axis, const std::vector<std::vector<double>>& segments, double tau0,
                         const AnalysisOptions& options) {
  if (!(tau0 > 0) || !std::isfinite(tau0)) throw std::invalid_argument("sample interval must be positive and finite");
  if (!(options.deviation.confidence > 0 && options.deviation.confidence < 1))
    throw std::invalid_argument("confidence must be in (0, 1)");
  for (const auto& d : options.deviations)
    if (!isDeviationName(d)) throw std::invalid_argument("unknown deviation '" + d + "'");
  AxisAnalysis a;
  a.axis = axis;
  a.rate_hz = 1.0 / tau0;
  long double sum = 0;
  for (const auto& s : segments) {
    if (s.empty()) continue;
    ++a.segments;
    a.samples += static_cast<int64_t>(s.size());
    for (double v : s) {
      if (!std::isfinite(v)) throw std::invalid_argument("axis " + axis + ": non-finite sample");
      sum += v;
    }
  }
  if (a.samples < 3) throw std::invalid_argument("axis " + axis + ": too few samples (" + std::to_string(a.samples) + ")");
  a.mean = static_cast<double>(sum / a.samples);
  a.duration_s = static_cast<double>(a.samples) * tau0;
  a.oadev = computeDeviation("oadev", segments, options.input, tau0, options.deviation);
  enforceRedderWithTau(&a.oadev, options.deviation.confidence);
  if (a.oadev.points.empty())
    throw std::invalid_argument("axis " + axis + ": record too short for any Allan-variance point");
  for (const auto& d : options.deviations)
    if (d == "oadev") {
      a.curves.push_back(a.oadev);
    } else {
      a.curves.push_back(computeDeviation(d, segments, options.input, tau0, options.deviation));
      enforceRedderWithTau(&a.curves.back(), options.deviation.confidence);
    }
  a.fit = fitNoiseModel(a.oadev, options.fit);
  return a;
}

}  // namespace gyro_allan
