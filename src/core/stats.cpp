// Order statistics (include/gyro_allan/stats.hpp): the median and the upper median by selection.
#include "gyro_allan/stats.hpp"

#include <algorithm>
#include <cmath>

namespace gyro_allan {

double upperMedianInPlace(std::vector<double>& v) {
  if (v.empty()) return std::nan("");
  const auto k = static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[static_cast<size_t>(k)];
}

double medianInPlace(std::vector<double>& v) {
  const double hi = upperMedianInPlace(v);
  if (v.size() % 2 == 1 || v.empty()) return hi;
  // After nth_element every value before rank n/2 is <= it: the lower middle value is the largest of them.
  const double lo = *std::max_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2));
  return 0.5 * (hi + lo);
}

}  // namespace gyro_allan
