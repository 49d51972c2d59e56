// Confidence intervals for a non-negative quantity (a noise term's AVAR weight c >= 0) whose estimate scatters more,
// and more skewed, as the true value grows: the unified (Feldman-Cousins) construction.
#pragma once

#include <limits>

namespace gyro_allan {

/// Variance of an estimate X as a function of the true value mu: var(X | mu) = v0 + v1 mu + v2 mu^2 (the Allan-variance
/// scatter grows with the term itself, so a fixed sigma makes the upper side of an interval too short).
/// The estimate's distribution at mu: its part that grows like mu^2 (the term's own Allan points, chi-squared-like) is
/// a gamma with relative variance v2, the rest normal, so its skew is 2 v2^2 mu^3 / var^1.5 (0 at mu = 0, the gamma's
/// 2 sqrt(v2) far above the noise; held at 2 at most); X is taken as a shifted gamma with that mean, variance and
/// skew (normal where the skew is below 0.02).
struct VarianceModel {
  double v0 = 0, v1 = 0, v2 = 0;
  double at(double mu) const;
  double skewAt(double mu) const;
  /// log of the density of X at x when the true value is mu.
  double logDensity(double x, double mu) const;
  /// P(X <= x) when the true value is mu.
  double cdf(double x, double mu) const;
  /// Through three (mu, variance) points (distinct mu); negative curvature or a non-positive minimum on [0, inf)
  /// falls back to the straight line through the outer points, then to the largest variance.
  static VarianceModel through(const double mu[3], const double var[3]);
};

/// The unified interval [lo, hi] for mu >= 0 from one observation x of X (VarianceModel) at the given confidence
/// (Feldman & Cousins 1998, "Unified approach to the classical statistical analysis of small signals"): a Neyman
/// construction whose acceptance region for each mu holds the values of X with the highest likelihood ratio
/// f(X | mu) / f(X | best mu >= 0). It holds the truth at its stated rate for every mu >= 0, also at and near 0,
/// is never empty, turns from an upper bound [0, hi] into a two-sided interval as x rises above its noise, and always
/// holds max(x, 0), the constrained estimate. The grid's resolution is ~1/140 of the range searched, which reaches
/// where x has probability 1e-4 below it.
void unifiedInterval(double x, const VarianceModel& v, double confidence, double* lo, double* hi);

}  // namespace gyro_allan
