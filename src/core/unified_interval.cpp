// Unified (Feldman-Cousins) intervals for a non-negative mean with a value-dependent variance and skew.
#include "gyro_allan/unified_interval.hpp"

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
  // The range of mu searched reaches well past the constrained estimate: up to where x lies 5 sd below mu (the
  // skewed form's lower tail is shorter than that) or, where the relative scatter never falls below 1/5, 1e4 times
  // its start (an interval reaching it is unbounded in effect).
  const double xp = std::max(x, 0.0);
  const double s0 = std::sqrt(std::max(v.at(0.0), 1e-300));
  double mu_max = xp + 5.0 * s0;
  const double cap = 1e4 * mu_max;
  while (mu_max < cap && (mu_max - xp) < 5.0 * std::sqrt(v.at(mu_max))) mu_max = xp + 1.5 * (mu_max - xp);
  mu_max = std::max(std::min(mu_max, cap), 1e-300);
  constexpr int kMu = 141, kX = 400;
  std::vector<double> mus(kMu), sd(kMu);
  double s_max = 0;
  for (int k = 0; k < kMu; ++k) {
    const double u = static_cast<double>(k) / (kMu - 1);
    mus[k] = mu_max * u * u;  // dense near 0, where a truth far below detection sits
    sd[k] = std::sqrt(std::max(v.at(mus[k]), 1e-300));
    s_max = std::max(s_max, sd[k]);
  }
  auto logf = [&](double xv, int k) { return v.logDensity(xv, mus[k]); };
  const double x_lo = std::min(x, -7.0 * s_max);
  const double x_hi = std::max(x, mu_max + 12.0 * s_max);  // the skewed form's right tail reaches further
  const double dx = (x_hi - x_lo) / kX;
  // log f at every (x, mu) and the best mu >= 0 of every x (on the grid)
  std::vector<double> lf(static_cast<size_t>(kMu) * kX), best(kX, -std::numeric_limits<double>::infinity());
  for (int j = 0; j < kX; ++j) {
    const double xj = x_lo + (j + 0.5) * dx;
    for (int k = 0; k < kMu; ++k) {
      const double l = logf(xj, k);
      lf[static_cast<size_t>(k) * kX + j] = l;
      best[j] = std::max(best[j], l);
    }
  }
  double best_obs = -std::numeric_limits<double>::infinity();
  for (int k = 0; k < kMu; ++k) best_obs = std::max(best_obs, logf(x, k));
  // x lies in mu's acceptance region when the values ranked above it (higher likelihood ratio) hold less than the
  // confidence: no sort needed.
  int first = -1, last = -1;
  for (int k = 0; k < kMu; ++k) {
    const double* row = &lf[static_cast<size_t>(k) * kX];
    double peak = -std::numeric_limits<double>::infinity();
    for (int j = 0; j < kX; ++j) peak = std::max(peak, row[j]);
    const double r_obs = logf(x, k) - best_obs;
    double total = 0, above = 0;
    for (int j = 0; j < kX; ++j) {
      if (!(row[j] - peak >= -40.0)) continue;  // mass below 4e-18 of the peak's (or none)
      const double m = std::exp(row[j] - peak);
      total += m;
      if (row[j] - best[j] > r_obs) above += m;
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
  // each accepted grid point stands for the half-way marks to its neighbours
  *lo = first == 0 ? 0.0 : 0.5 * (mus[first - 1] + mus[first]);
  *hi = last == kMu - 1 ? mu_max : 0.5 * (mus[last] + mus[last + 1]);
  // the grid's half-cells: the constrained estimate itself always lies inside
  *lo = std::min(*lo, xp);
  *hi = std::max(*hi, xp);
}

}  // namespace gyro_allan
