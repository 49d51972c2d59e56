// Truncated-normal pivot, conditional intervals and median-unbiased estimates for selected/dropped terms.
#include "gyro_allan/selective.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace gyro_allan {
namespace {

// log of the standard normal upper tail Q(z) = P(Z > z); the asymptotic series where erfc underflows.
double logUpperTail(double z) {
  if (z < 30.0) return std::log(0.5 * std::erfc(z / std::sqrt(2.0)));
  const double z2 = z * z;
  return -0.5 * z2 - std::log(z) - 0.5 * std::log(2.0 * M_PI) + std::log1p(-1.0 / z2 + 3.0 / (z2 * z2));
}

constexpr double kP68 = 0.15865525393145707;  // each tail of a two-sided 68.27 % interval
constexpr double kP95 = 0.025;

}  // namespace

double VarianceModel::at(double mu) const {
  mu = std::min(mu, cap_mu);
  return std::max(0.0, v0 + v1 * mu + v2 * mu * mu);
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

double selectivePivot(double x, double mu, const VarianceModel& v, const SelectionEvent& e) {
  const double s = std::sqrt(v.at(mu));
  if (!(s > 0)) return x >= mu ? 1.0 : 0.0;
  const double zx = (x - mu) / s, zt = (e.threshold - mu) / s;
  if (e.selected) {  // X >= T: 1 - Q(zx)/Q(zT)
    if (x <= e.threshold) return 0.0;
    return std::clamp(1.0 - std::exp(logUpperTail(zx) - logUpperTail(zt)), 0.0, 1.0);
  }
  if (x >= e.threshold) return 1.0;  // X < T: Phi(zx)/Phi(zT)
  return std::clamp(std::exp(logUpperTail(-zx) - logUpperTail(-zt)), 0.0, 1.0);
}

double selectiveSolve(double x, double p, const VarianceModel& v, const SelectionEvent& e) {
  if (selectivePivot(x, 0.0, v, e) <= p) return 0.0;
  // Bracket: scan upward geometrically for the first mu where the pivot is <= p. For a dropped term whose scatter
  // grows like mu itself the pivot turns back towards 1 far out (conditioning on an event that has become
  // astronomically unlikely); the scan stops where that event's own probability is below 1e-6.
  const double s0 = std::sqrt(std::max(v.at(0.0), 0.0));
  double scale = std::max(std::fabs(x), s0);
  if (std::isfinite(e.threshold)) scale = std::max(scale, std::fabs(e.threshold));
  if (!(scale > 0)) return 0.0;
  double lo = 0.0, hi = scale * 1e-3;
  bool found = false;
  for (int k = 0; k < 200; ++k) {
    if (selectivePivot(x, hi, v, e) <= p) {
      found = true;
      break;
    }
    if (!e.selected) {
      const double s = std::sqrt(v.at(hi));
      if (s > 0 && (e.threshold - hi) / s < -4.753424308822899) return hi;  // P(X < T; hi) < 1e-6
    }
    lo = hi;
    hi *= 1.5;
    if (hi > scale * 1e4) return hi;
  }
  if (!found) return hi;
  for (int it = 0; it < 100 && hi - lo > 1e-12 * hi; ++it) {
    const double mid = 0.5 * (lo + hi);
    if (selectivePivot(x, mid, v, e) <= p) hi = mid;
    else lo = mid;
  }
  return 0.5 * (lo + hi);
}

SelectiveEstimate selectiveEstimate(double x, const VarianceModel& v, const SelectionEvent& e) {
  SelectiveEstimate r;
  const double xx = e.selected ? x : std::max(x, 0.0);
  SelectionEvent ev = e;
  if (!ev.selected) ev.threshold = std::max(ev.threshold, std::nextafter(xx, std::numeric_limits<double>::infinity()));
  else ev.threshold = std::min(ev.threshold, xx);
  r.median = selectiveSolve(xx, 0.5, v, ev);
  r.lo68 = selectiveSolve(xx, 1.0 - kP68, v, ev);
  r.lo95 = selectiveSolve(xx, 1.0 - kP95, v, ev);
  if (e.selected) {
    r.hi68 = selectiveSolve(xx, kP68, v, ev);
    r.hi95 = selectiveSolve(xx, kP95, v, ev);
  } else {  // reported as [0, upper bound]: one-sided
    r.lo68 = r.lo95 = 0.0;
    r.hi68 = selectiveSolve(xx, 2.0 * kP68, v, ev);
    r.hi95 = selectiveSolve(xx, 2.0 * kP95, v, ev);
  }
  return r;
}

}  // namespace gyro_allan
