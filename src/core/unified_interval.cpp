// Unified (Feldman-Cousins) intervals for a non-negative mean with a value-dependent variance and skew.
#include "gyro_allan/unified_interval.hpp"

#include <boost/math/special_functions/gamma.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace gyro_allan {

double VarianceModel::at(double mu) const { return std::max(0.0, v0 + v1 * mu + v2 * mu * mu); }

double VarianceModel::skewAt(double mu) const {
  const double v = at(mu);
  if (!(v > 0) || !(v2 > 0) || !(mu > 0)) return 0.0;
  const double g = 2.0 * v2 * v2 * mu * mu * mu / (v * std::sqrt(v));
  return std::isfinite(g) ? std::min(g, 2.0) : 0.0;
}

double VarianceModel::logDensity(double x, double mu) const {
  const double sd = std::sqrt(std::max(at(mu), 1e-300));
  const double z = (x - mu) / sd;
  const double g = skewAt(mu);
  if (g < 0.02) return -0.5 * z * z - std::log(sd);
  const double k = 4.0 / (g * g), rk = std::sqrt(k);
  const double q = k + rk * z;  // the gamma variable
  if (!(q > 0)) return -std::numeric_limits<double>::infinity();
  return (k - 1.0) * std::log(q) - q - std::lgamma(k) + std::log(rk / sd);
}

double VarianceModel::cdf(double x, double mu) const {
  const double sd = std::sqrt(std::max(at(mu), 1e-300));
  const double z = (x - mu) / sd;
  const double g = skewAt(mu);
  if (g < 0.02) return 0.5 * std::erfc(-z / std::sqrt(2.0));
  const double k = 4.0 / (g * g), q = k + std::sqrt(k) * z;
  return q > 0 ? boost::math::gamma_p(k, q) : 0.0;
}

VarianceModel VarianceModel::through(const double mu[3], const double var[3]) {
  VarianceModel m;
  // Newton's divided differences.
  const double d01 = (var[1] - var[0]) / (mu[1] - mu[0]);
  const double d12 = (var[2] - var[1]) / (mu[2] - mu[1]);
  const double a2 = (d12 - d01) / (mu[2] - mu[0]);
  m.v2 = a2;
  m.v1 = d01 - a2 * (mu[0] + mu[1]);
  m.v0 = var[0] - m.v1 * mu[0] - m.v2 * mu[0] * mu[0];
  bool ok = std::isfinite(m.v0) && std::isfinite(m.v1) && std::isfinite(m.v2) && m.v2 >= 0 && m.v0 > 0;
  if (ok && m.v1 < 0) ok = m.v0 - m.v1 * m.v1 / (4 * m.v2) > 0;  // minimum on mu > 0 stays positive
  if (ok) return m;
  m = VarianceModel();
  const double slope = (var[2] - var[0]) / (mu[2] - mu[0]);
  if (std::isfinite(slope) && slope >= 0 && var[0] > 0) {
    m.v0 = var[0] - slope * mu[0];
    m.v1 = slope;
    if (m.v0 > 0) return m;
  }
  m = VarianceModel();
  m.v0 = std::max({var[0], var[1], var[2]});
  return m;
}

void unifiedInterval(double x, const VarianceModel& v, double confidence, double* lo, double* hi) {
  // The range of mu searched: up to where x lies so far in mu's lower tail (probability 1e-4) that no interval of
  // the confidences used reaches it, or 1e4 times its start.
  const double xp = std::max(x, 0.0);
  const double s0 = std::sqrt(std::max(v.at(0.0), 1e-300));
  double mu_max = xp + 3.0 * std::sqrt(std::max(v.at(xp), 1e-300));
  const double cap = 1e4 * (xp + 5.0 * s0);
  const double tail = std::min(1e-4, 0.1 * (1.0 - confidence));
  while (mu_max < cap && v.cdf(x, mu_max) > tail) mu_max = xp + 1.5 * (mu_max - xp);
  mu_max = std::max(std::min(mu_max, cap), 1e-300);
  // The mu grid: dense near 0 (quadratic spacing from 0) where the interval may reach 0; where it cannot (x more
  // than 10 sd above 0), 0 and an even grid over [x - 10 sd, mu_max], which resolves the interval of a term far
  // above its noise (its relative sd can be 1e-3).
  constexpr int kMu = 141, kX = 200;
  const double window = std::max(0.0, xp - 10.0 * std::sqrt(std::max(v.at(xp), 1e-300)));
  std::vector<double> mus(kMu);
  mus[0] = 0.0;
  for (int k = 1; k < kMu; ++k) {
    const double u = static_cast<double>(k - (window > 0 ? 1 : 0)) / (kMu - 1 - (window > 0 ? 1 : 0));
    mus[k] = window > 0 ? window + (mu_max - window) * u : mu_max * u * u;
  }
  auto logf = [&](double xv, int k) { return v.logDensity(xv, mus[k]); };
  // The best mu >= 0 for a value xv: 0 for xv <= 0; above, a golden-section search on [0, 2 xv + s0] (the density's
  // mean is mu, so its maximum lies below ~xv where the scatter grows with mu), tabulated on 200 values evenly spaced
  // in asinh(xv / s0) (fine near 0, coarse far above) and interpolated.
  auto bestAt = [&](double xv) {
    if (xv <= 0) return v.logDensity(xv, 0.0);
    double a = 0, b = 2.0 * xv + s0;
    const double g = 0.5 * (std::sqrt(5.0) - 1.0);
    double c = b - g * (b - a), d = a + g * (b - a), fc = v.logDensity(xv, c), fd = v.logDensity(xv, d);
    for (int it = 0; it < 40; ++it) {
      if (fc > fd) b = d, d = c, fd = fc, c = b - g * (b - a), fc = v.logDensity(xv, c);
      else a = c, c = d, fc = fd, d = a + g * (b - a), fd = v.logDensity(xv, d);
    }
    return std::max({fc, fd, v.logDensity(xv, 0.0)});
  };
  const double sd_top = std::sqrt(std::max(v.at(mu_max), 1e-300));
  const double t_hi = std::asinh(std::max(x, mu_max + 14.0 * sd_top) / s0);
  constexpr int kTable = 200;
  std::vector<double> table(kTable + 1);
  for (int i = 0; i <= kTable; ++i) table[i] = bestAt(s0 * std::sinh(t_hi * i / kTable));
  auto best = [&](double xv) {
    if (xv <= 0) return v.logDensity(xv, 0.0);
    const double u = std::asinh(xv / s0) / t_hi * kTable;
    if (u >= kTable) return bestAt(xv);
    const int i = static_cast<int>(u);
    const double w = u - i;
    return (1 - w) * table[i] + w * table[i + 1];
  };
  const double best_x = bestAt(x);
  // x lies in mu's acceptance region when the values ranked above it (higher likelihood ratio) hold less than the
  // confidence: each mu's own grid of X values over its bulk (8 sd below the mean, 14 above: the skewed form's right
  // tail reaches further), no sort needed.
  int first = -1, last = -1;
  std::vector<double> row(kX), ratio(kX);
  for (int k = 0; k < kMu; ++k) {
    const double sd = std::sqrt(std::max(v.at(mus[k]), 1e-300));
    const double x0 = mus[k] - 8.0 * sd, dx = 22.0 * sd / kX;
    double peak = -std::numeric_limits<double>::infinity();
    for (int j = 0; j < kX; ++j) {
      const double xj = x0 + (j + 0.5) * dx;
      row[j] = logf(xj, k);
      ratio[j] = row[j] - best(xj);
      peak = std::max(peak, row[j]);
    }
    const double r_obs = logf(x, k) - best_x;
    double total = 0, above = 0;
    for (int j = 0; j < kX; ++j) {
      if (!(row[j] - peak >= -40.0)) continue;  // mass below 4e-18 of the peak's (or none)
      const double m = std::exp(row[j] - peak);
      total += m;
      if (ratio[j] > r_obs) above += m;
    }
    if (!(total > 0)) continue;
    if (above / total < confidence) {
      if (first < 0) first = k;
      last = k;
    }
  }
  if (last < 0) {  // no grid point accepts x (cannot happen for a proper ordering): the best mu's neighbourhood
    *lo = 0.0;
    *hi = xp + mus[1];
    return;
  }
  // each accepted grid point stands for the half-way marks to its neighbours (not across the gap from 0 to the
  // window)
  *lo = first == 0 ? 0.0 : (first == 1 && window > 0 ? mus[1] : 0.5 * (mus[first - 1] + mus[first]));
  *hi = last == kMu - 1 ? mu_max : 0.5 * (mus[last] + mus[last + 1]);
  // the grid's half-cells: the constrained estimate itself always lies inside
  *lo = std::min(*lo, xp);
  *hi = std::max(*hi, xp);
}

}  // namespace gyro_allan
