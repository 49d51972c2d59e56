// Selective inference for a term that a threshold kept or dropped: truncated-normal pivot, conditional intervals
// and the conditional median-unbiased estimate (Fithian, Sun & Taylor 2014; the "winner's curse" correction).
#pragma once

#include <limits>

namespace gyro_allan {

/// Variance of an estimate X as a function of the true value mu: var(X | mu) = v0 + v1 mu + v2 mu^2 (the Allan-variance
/// scatter grows with the term itself, so a fixed sigma makes the upper side of an interval too short).
struct VarianceModel {
  double v0 = 0, v1 = 0, v2 = 0;
  double cap_mu = std::numeric_limits<double>::infinity();  ///< beyond this mu the variance is held at its value there
  double at(double mu) const;
  /// Through three (mu, variance) points (distinct mu); negative curvature or a non-positive minimum on [0, inf)
  /// falls back to the straight line through the outer points, then to the largest variance.
  static VarianceModel through(const double mu[3], const double var[3]);
};

/// How X came to be reported: selected when X >= threshold, dropped when X < threshold.
struct SelectionEvent {
  bool selected = true;
  double threshold = 0;
};

/// P(X <= x | event; mu) for X ~ N(mu, var(mu)): the pivot, decreasing in mu.
double selectivePivot(double x, double mu, const VarianceModel& v, const SelectionEvent& e);

/// The mu >= 0 at which the pivot equals p (0 when the pivot at mu = 0 is already <= p).
double selectiveSolve(double x, double p, const VarianceModel& v, const SelectionEvent& e);

/// Conditional intervals (each holds the truth with its stated probability among the records on which the same
/// selection happened) and the conditional median-unbiased estimate. For a dropped term x is taken as max(x, 0): the
/// bound never excludes values the record cannot tell from zero (power-constrained), at a slight over-coverage, and
/// the interval is one-sided, [0, hi], at the same confidence.
struct SelectiveEstimate {
  double median = 0;  // pivot = 1/2
  double lo68 = 0, hi68 = 0, lo95 = 0, hi95 = 0;
};
SelectiveEstimate selectiveEstimate(double x, const VarianceModel& v, const SelectionEvent& e);

}  // namespace gyro_allan
