// One axis, end to end: deviations of gap-free segments, the IEEE 952 fit (and later stages) — the core entry point
// shared by analyze_bag and tests.
#pragma once

#include <string>
#include <vector>

#include "gyro_allan/allan.hpp"
#include "gyro_allan/noise_model.hpp"

namespace gyro_allan {

struct AnalysisOptions {
  DeviationOptions deviation;                       ///< tau grid and confidence of every curve
  FitOptions fit;                                   ///< IEEE 952 fit settings
  std::vector<std::string> deviations{"oadev"};     ///< curves written out; the fit always uses oadev
  InputKind input = InputKind::Rate;                ///< rate samples (rad/s) or angle samples (rad)
};

struct AxisAnalysis {
  std::string axis;                 ///< "x", "y", "z" (or a CSV column name)
  int64_t samples = 0;              ///< samples used (sum over segments)
  int segments = 0;                 ///< gap-free segments
  double rate_hz = 0;
  double duration_s = 0;            ///< samples / rate (time actually covered, gaps excluded)
  double mean = 0;                  ///< mean of the samples (bias for rate input), SI
  DeviationCurve oadev;             ///< the curve the model is fitted to
  std::vector<DeviationCurve> curves;  ///< requested deviations, in the order asked
  FitResult fit;
};

/// Validates options (throws std::invalid_argument naming the problem) and analyses one axis.
/// Throws std::invalid_argument when the data is too short for any Allan point.
AxisAnalysis analyzeAxis(const std::string& axis, const std::vector<std::vector<double>>& segments, double tau0,
                         const AnalysisOptions& options);

/// Gyro noise gets redder with tau (quantization, then ARW, flicker, rate random walk): a noise type identified as
/// bluer than at a shorter tau is a misidentification of the lag-1 ACF method on few points (it can turn a random-walk
/// point into white PM, whose EDF is a thousand times larger). Replaces each alpha by the running minimum over shorter
/// taus and recomputes EDF and intervals. allan.hpp itself keeps Stable32's per-point identification.
void enforceRedderWithTau(DeviationCurve* curve, double confidence);

/// Conventional units for humans: factor from SI and label of each IEEE term
/// (arcsec, deg/sqrt(h), deg/h, deg/h/sqrt(h), deg/h^2).
double conventionalFactor(int term);
const char* conventionalUnit(int term);

}  // namespace gyro_allan
