// Selective inference for a term that a threshold kept or dropped: truncated-normal (or shifted-gamma) pivot,
// conditional intervals and the conditional median-unbiased estimate (Fithian, Sun & Taylor 2014; the "winner's curse" correction).
#pragma once

#include <array>
#include <limits>

namespace gyro_allan {

/// Third cumulant of an estimate X as a function of the true value mu, in the spectral form of avar_skewness.hpp:
/// kappa3(mu) = kappa2(mu)^2 I3(mu) / I2(mu)^2 (kappa2 its variance without the rate ramp's share, I2 and I3
/// polynomials in mu). Empty (all zero): X is normal.
struct ThirdCumulantModel {
  double k0 = 0, k1 = 0, k2 = 0;   ///< kappa2(mu) = k0 + k1 mu + k2 mu^2
  std::array<double, 3> i2{};      ///< I2(mu) = i2[0] + i2[1] mu + i2[2] mu^2
  std::array<double, 4> i3{};      ///< I3(mu) = i3[0] + ... + i3[3] mu^3
  double at(double mu) const;
};

/// Variance of an estimate X as a function of the true value mu: var(X | mu) = v0 + v1 mu + v2 mu^2 (the Allan-variance
/// scatter grows with the term itself, so a fixed sigma makes the upper side of an interval too short).
struct VarianceModel {
  double v0 = 0, v1 = 0, v2 = 0;
  double cap_mu = std::numeric_limits<double>::infinity();  ///< beyond this mu the variance is held at its value there
  /// The estimate's third cumulant; where it is set, a selected term's pivot takes X as a shifted gamma (Pearson
  /// type III) with this variance and skew instead of a normal (the dropped branch and droppedIntervalFC stay normal).
  ThirdCumulantModel kappa3;
  /// Skewness of X at mu (0 without a third cumulant), held within [-2, 2] (the gamma's shape 4 / skew^2 at least 1,
  /// where its density is finite at the lower end).
  double skewAt(double mu) const;
  double at(double mu) const;
  /// Where a term with this scatter enters a selection that keeps it when x^2 > penalty * var(x): the fixed point
  /// x = sqrt(penalty * (v0 + v1 x + v2 x^2)) (cap_mu ignored), +inf when penalty * v2 >= 1 (the relative sd never
  /// falls below 1 / sqrt(penalty), so the term never enters).
  double entryThreshold(double penalty) const;
  /// Through three (mu, variance) points (distinct mu); negative curvature or a non-positive minimum on [0, inf)
  /// falls back to the straight line through the outer points, then to the largest variance.
  static VarianceModel through(const double mu[3], const double var[3]);
};

/// How X came to be reported: selected when X >= threshold, dropped when X < threshold.
struct SelectionEvent {
  bool selected = true;
  double threshold = 0;
};

/// P(X <= x | event; mu) for X ~ N(mu, var(mu)) (a selected event with a third cumulant: the shifted gamma): the
/// pivot, decreasing in mu.
double selectivePivot(double x, double mu, const VarianceModel& v, const SelectionEvent& e);

/// The mu >= 0 at which the pivot equals p (0 when the pivot at mu = 0 is already <= p).
double selectiveSolve(double x, double p, const VarianceModel& v, const SelectionEvent& e);

/// Conditional intervals (each holds the truth with its stated probability among the records on which the same
/// selection happened) and the conditional median-unbiased estimate. A selected term gets the equal-tailed interval
/// of the pivot. A dropped term's 68 % interval is the unified (Feldman-Cousins) interval of its truncated
/// distribution (droppedIntervalFC): [0, hi] when the estimate is low, [lo > 0, hi] when it came out high but still
/// below the threshold; never empty, and at its stated coverage for every true value >= 0, also far below what the
/// record can detect (a plain one-sided bound then covers ~100 %). Its 95 % interval is the one-sided,
/// power-constrained [0, hi] (x counted as max(x, 0)): conservative where the estimate's tails are heavier than normal.
struct SelectiveEstimate {
  double median = 0;  // pivot = 1/2
  double lo68 = 0, hi68 = 0, lo95 = 0, hi95 = 0;
};
SelectiveEstimate selectiveEstimate(double x, const VarianceModel& v, const SelectionEvent& e);

/// Interval [lo, hi] for mu >= 0 from X ~ N(mu, v(mu)) truncated to X < threshold (+inf: no truncation) by a Neyman
/// construction with likelihood-ratio ordering (Feldman & Cousins 1998, "Unified approach to the classical
/// statistical analysis of small signals"): for each mu on a grid the acceptance region holds the values of X whose
/// likelihood ratio f(X | mu) / f(X | best mu >= 0) is highest, up to probability `confidence`; the interval is the
/// set of mu whose region holds x. The grid's resolution is ~1/140 of the range searched.
void droppedIntervalFC(double x, const VarianceModel& v, double threshold, double confidence, double* lo, double* hi);

}  // namespace gyro_allan
