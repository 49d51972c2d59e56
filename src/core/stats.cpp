// Order statistics and the normal quantile (include/gyro_allan/stats.hpp): the median and the upper median by
// selection.
#include "gyro_allan/stats.hpp"

#include <boost/math/distributions/normal.hpp>

#include <algorithm>
#include <cmath>

namespace gyro_allan {

double normalQuantile(double p) { return boost::math::quantile(boost::math::normal_distribution<double>(), p); }

namespace {

double median3(double a, double b, double c) { return std::max(std::min(a, b), std::min(std::max(a, b), c)); }

/// The value of rank k of a[0, n), leaving a as std::nth_element would (nothing after position k smaller, nothing
/// before it larger). Written out rather than std::nth_element because libstdc++'s introselect branches on every
/// comparison, which random noise mispredicts about half the time: this quickselect partitions without branches
/// (each element is written to both sides and the boundary advances by the comparison), three ways so that runs of
/// equal values (quantized samples, their differences) end the search instead of slowing it, and hands the range to
/// std::nth_element when it gets small or after 2 log2(n) + 8 rounds (a bad run of pivots). The result is the same
/// value std::nth_element gives (the k-th smallest is unique as a value); with NaNs in a it is unspecified, as
/// there.
double selectRank(double* a, size_t n, size_t k) {
  size_t lo = 0, hi = n;
  int rounds = 8;
  for (size_t m = n; m > 1; m >>= 1) rounds += 2;
  while (hi - lo > 32 && rounds-- > 0) {
    const double p = median3(a[lo], a[lo + (hi - lo) / 2], a[hi - 1]);
    size_t lt = lo;  // [lo, lt) < p
    for (size_t j = lo; j < hi; ++j) {
      const double t = a[j];
      a[j] = a[lt];
      a[lt] = t;
      lt += t < p;
    }
    if (k < lt) {
      hi = lt;
      continue;
    }
    size_t eq = lt;  // [lt, eq) == p: p is one of the values, so eq > lt and the range shrinks
    for (size_t j = lt; j < hi; ++j) {
      const double t = a[j];
      a[j] = a[eq];
      a[eq] = t;
      eq += !(p < t);
    }
    if (k < eq) return a[k];
    lo = eq;
  }
  std::nth_element(a + lo, a + k, a + hi);
  return a[k];
}

}  // namespace

double upperMedianInPlace(std::vector<double>& v) {
  if (v.empty()) return std::nan("");
  return selectRank(v.data(), v.size(), v.size() / 2);
}

double medianInPlace(std::vector<double>& v) {
  const double hi = upperMedianInPlace(v);
  if (v.size() % 2 == 1 || v.empty()) return hi;
  // After the selection every value before rank n/2 is <= it: the lower middle value is the largest of them.
  const double lo = *std::max_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2));
  return 0.5 * (hi + lo);
}

}  // namespace gyro_allan
