// Shared helper of the core test suites: the accumulated angle of rate samples (phase data from frequency data).
#pragma once

#include <vector>

namespace gyro_allan_test {

/// theta[0] = 0, theta[k+1] = theta[k] + rate[k] tau0 (n + 1 points), summed in long double.
inline std::vector<double> accumulatedAngle(const std::vector<double>& rate, double tau0) {
  std::vector<double> theta(rate.size() + 1, 0.0);
  long double acc = 0;
  for (size_t k = 0; k < rate.size(); ++k) {
    acc += static_cast<long double>(rate[k]) * tau0;
    theta[k + 1] = static_cast<double>(acc);
  }
  return theta;
}

}  // namespace gyro_allan_test
