// Allan-family deviations (allantools names: adev, oadev, mdev, hdev, ohdev, tdev, totdev, mtotdev, ttotdev) on tau grids, with EDF and CIs.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace gyro_allan {

/// What the samples are. In time-and-frequency terms a gyro rate is "frequency" y and an angle is "phase" x.
enum class InputKind { Rate, Angle };

/// Tau grids as allantools names them: octave (m = 2^k), decade (1,2,4 x 10^k), log (per_decade log-spaced m), all.
enum class TauGridKind { Octave, Decade, Log, All };
struct TauGrid {
  TauGridKind kind = TauGridKind::Log;
  int per_decade = 10;  ///< points per decade for Log
};
/// Parses "octave", "decade", "all", "log" or "log:K" (K points per decade). Returns false and sets *error otherwise.
bool parseTauGrid(const std::string& text, TauGrid* grid, std::string* error);
std::string tauGridName(const TauGrid& grid);

/// Averaging factors m (tau = m * tau0) of the grid: unique, ascending, 1 <= m <= max_m.
std::vector<int64_t> tauGridFactors(const TauGrid& grid, int64_t max_m);

/// Angle (phase) from rate (frequency): x[0] = 0, x[i+1] = x[i] + (y[i] - mean(y)) * tau0, accumulated in long double.
/// Removing the mean changes no deviation (it is a linear phase trend) and keeps 1e8-sample phases exact in double.
std::vector<double> rateToAngle(const std::vector<double>& rate, double tau0);

/// One point of a deviation curve.
struct DeviationPoint {
  double tau = 0;       ///< averaging time, s
  int64_t m = 0;        ///< averaging factor
  double var = 0;       ///< variance (deviation squared)
  double dev = 0;       ///< deviation, units of the rate (rad/s for a gyro)
  int64_t n_terms = 0;  ///< number of terms summed (Stable32 "#terms")
  double edf = 0;       ///< equivalent degrees of freedom (0 if not computed)
  int alpha = 0;        ///< power-law noise exponent used for the EDF (2 white PM ... -2 RW FM)
  double dev_lo = 0;    ///< lower confidence bound of dev (chi-squared, DeviationOptions::confidence)
  double dev_hi = 0;    ///< upper confidence bound of dev
};

struct DeviationCurve {
  std::string name;   ///< "oadev", "mdev", ...
  double tau0 = 0;    ///< sample interval, s
  int64_t n_phase = 0;  ///< phase points used (sum over segments)
  std::vector<DeviationPoint> points;
};

/// How chi-squared quantiles are taken for the confidence interval.
///  Exact:    quantiles of chi2(edf) at (1 -+ confidence)/2 (default).
///  Stable32: as Stable32 1.5x/1.60 prints them: exact for edf <= 100; for edf > 100 Wilson-Hilferty quantiles at a
///            confidence truncated to two decimals (0.683 -> 0.68, i.e. p = 0.16 / 0.84), which reproduces its
///            68.3 % bounds to printing precision (see docs/deviations.md).
enum class ChiSquareConvention { Exact, Stable32 };

struct DeviationOptions {
  TauGrid grid;
  double confidence = 0.683;  ///< two-sided confidence of dev_lo/dev_hi
  bool compute_edf = true;
  ChiSquareConvention chi2 = ChiSquareConvention::Exact;
};

/// Names accepted by computeDeviation. mtotdev/ttotdev are exact and O(N) per tau but cost ~0.1-0.2 us per window
/// and tau (~70-100 times an OADEV point; docs/deviations.md).
const std::vector<std::string>& deviationNames();
bool isDeviationName(const std::string& name);

/// Computes deviation `name` of one contiguous record. Throws std::invalid_argument on unknown name, tau0 <= 0,
/// or non-finite samples. Points with no terms are omitted.
DeviationCurve computeDeviation(const std::string& name, const std::vector<double>& samples, InputKind kind,
                                double tau0, const DeviationOptions& options);

/// Same, for a record split into gap-free segments (each contiguous, same tau0): the sums of squared differences
/// and term counts of every segment are pooled per m, so no difference ever spans a gap.
DeviationCurve computeDeviation(const std::string& name, const std::vector<std::vector<double>>& segments,
                                InputKind kind, double tau0, const DeviationOptions& options);

/// Same as computeDeviation, at the given averaging factors m instead of a grid (factors with no terms are omitted).
DeviationCurve computeDeviationAt(const std::string& name, const std::vector<double>& samples, InputKind kind,
                                  double tau0, const std::vector<int64_t>& factors, const DeviationOptions& options);
DeviationCurve computeDeviationAt(const std::string& name, const std::vector<std::vector<double>>& segments,
                                  InputKind kind, double tau0, const std::vector<int64_t>& factors,
                                  const DeviationOptions& options);

/// Largest averaging factor with at least one term for deviation `name` on n_phase phase points
/// (adev/oadev (n-1)/2, hdev/ohdev (n-1)/3, mdev/tdev/mtotdev/ttotdev n/3, totdev n-1).
int64_t deviationMaxFactor(const std::string& name, int64_t n_phase);

/// Shorthand for the overlapping Allan deviation of rate samples.
DeviationCurve oadev(const std::vector<double>& rate, double tau0, const DeviationOptions& options = {});

/// Equivalent degrees of freedom of deviation `name` at averaging factor m for power-law noise alpha
/// (2 white PM, 1 flicker PM, 0 white FM, -1 flicker FM, -2 random-walk FM) with n_phase phase points
/// (Greenhall-Riley where available, documented approximations otherwise).
double deviationEdf(const std::string& name, int alpha, int64_t m, int64_t n_phase);

/// Fills edf (given alpha per point) and dev_lo/dev_hi of every point at the given two-sided confidence.
void fillConfidence(DeviationCurve* curve, double confidence,
                    ChiSquareConvention convention = ChiSquareConvention::Exact);

/// Two-sided interval multipliers (lo, hi) of a deviation with `edf` degrees of freedom: dev_lo = lo * dev,
/// dev_hi = hi * dev. Returns false (and 0, 0) if edf is not positive and finite.
bool deviationIntervalFactors(double edf, double confidence, ChiSquareConvention convention, double* lo, double* hi);

/// Chi-squared quantile (inverse CDF, Boost.Math) for dof > 0 (non-integer allowed), p in (0,1).
double chi2Quantile(double p, double dof);

}  // namespace gyro_allan
