// Order statistics, the normal quantiles and a one-dimensional maximizer shared by the core and the tools: the median
// in O(n), in the two even-count conventions in use, the standard normal quantile and the golden-section search.
#pragma once

#include <cmath>
#include <vector>

namespace gyro_allan {

/// Standard normal quantile: the z with P(Z <= z) = p (Boost.Math), and the values the intervals and robust scales
/// use, named here once.
double normalQuantile(double p);
constexpr double kZ95 = 1.959963984540054;             ///< normalQuantile(0.975): two-sided 95 % half-width
constexpr double kZ95OneSided = 1.6448536269514722;    ///< normalQuantile(0.95): one-sided 95 % bound
constexpr double kP68Upper = 0.8413447460685429;       ///< P(Z <= 1): upper end of the 68.3 % interval
constexpr double kMadPerSigma = 0.6744897501960817;    ///< normalQuantile(0.75): a normal's median |x - median| / sigma

/// Median of v: the middle value for odd n, the mean of the two middle values for even n; NaN when v is empty.
/// Reorders v (a selection in O(n), leaving v as std::nth_element would): pass a scratch copy when the order matters.
double medianInPlace(std::vector<double>& v);

/// median of a copy of v (medianInPlace).
inline double median(std::vector<double> v) { return medianInPlace(v); }

/// Upper median: the value of rank n/2 (0-based) of the sorted v, i.e. the middle value for odd n and the larger of
/// the two middle values for even n; NaN when v is empty. Always one of the samples (a sample interval, a PSD bin).
/// It is what the stamp-period, value-anomaly, step-location and quantization-line estimates were tuned with; for
/// their large n it differs from median() by less than the spacing of neighbouring samples, but it is kept so that
/// their results do not move. Reorders v as medianInPlace does.
double upperMedianInPlace(std::vector<double>& v);

/// upperMedian of a copy of v (upperMedianInPlace).
inline double upperMedian(std::vector<double> v) { return upperMedianInPlace(v); }

/// Golden-section search for the maximum of a unimodal g over [lo, hi]: `iterations` steps, each shrinking the
/// bracket by 0.618; returns the better of the last two interior points.
template <class G>
double goldenSectionMax(G g, double lo, double hi, int iterations) {
  const double gr = 0.5 * (std::sqrt(5.0) - 1.0);
  double x1 = hi - gr * (hi - lo), x2 = lo + gr * (hi - lo);
  double g1 = g(x1), g2 = g(x2);
  for (int it = 0; it < iterations; ++it) {
    if (g1 > g2) {
      hi = x2;
      x2 = x1;
      g2 = g1;
      x1 = hi - gr * (hi - lo);
      g1 = g(x1);
    } else {
      lo = x1;
      x1 = x2;
      g1 = g2;
      x2 = lo + gr * (hi - lo);
      g2 = g(x2);
    }
  }
  return g1 > g2 ? x1 : x2;
}

}  // namespace gyro_allan
