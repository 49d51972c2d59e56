// Closed-form Allan-variance terms of non-IEEE effects (sinusoid, Gauss-Markov, bias step, warm-up, impulses).
#include "gyro_allan/effects.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace gyro_allan {
namespace {

void requirePositive(double v, const char* what) {
  if (!(v > 0) || !std::isfinite(v)) throw std::invalid_argument(std::string(what) + " must be positive and finite");
}

}  // namespace

double sinusoidAvar(double tau, double f0, double tau0) {
  requirePositive(tau, "sinusoidAvar: tau");
  requirePositive(f0, "sinusoidAvar: frequency");
  const double s = std::sin(M_PI * f0 * tau);
  if (tau0 > 0) {
    const double m = tau / tau0;
    const double d = m * std::sin(M_PI * f0 * tau0);
    if (std::fabs(d) < 1e-300) return 0.0;  // f0 a multiple of the sample rate: aliased to DC
    return s * s * s * s / (d * d);
  }
  const double x = M_PI * f0 * tau;
  return s * s * s * s / (x * x);
}

double spectrumAvar(double tau, double f_start, double df, const std::vector<double>& power, double tau0) {
  requirePositive(tau, "spectrumAvar: tau");
  requirePositive(tau0, "spectrumAvar: tau0");
  requirePositive(df, "spectrumAvar: bin spacing");
  if (!(f_start > 0) || !std::isfinite(f_start)) throw std::invalid_argument("spectrumAvar: f_start must be positive");
  const double m = tau / tau0;
  // sin(pi f_i tau) and sin(pi f_i tau0) by rotation: angle a + i d; renormalized every 64 steps.
  const double d = M_PI * df * tau, d0 = M_PI * df * tau0;
  const double cd = std::cos(d), sd = std::sin(d), cd0 = std::cos(d0), sd0 = std::sin(d0);
  double s = std::sin(M_PI * f_start * tau), c = std::cos(M_PI * f_start * tau);
  double s0 = std::sin(M_PI * f_start * tau0), c0 = std::cos(M_PI * f_start * tau0);
  double acc = 0;
  for (size_t i = 0; i < power.size(); ++i) {
    if (i > 0 && i % 64 == 0) {
      const double a = M_PI * (f_start + static_cast<double>(i) * df);
      s = std::sin(a * tau);
      c = std::cos(a * tau);
      s0 = std::sin(a * tau0);
      c0 = std::cos(a * tau0);
    }
    const double den = s0 * s0;
    if (den > 1e-300) {
      const double s2 = s * s;
      acc += power[i] * s2 * s2 / den;
    }
    const double sn = s * cd + c * sd, cn = c * cd - s * sd;
    const double sn0 = s0 * cd0 + c0 * sd0, cn0 = c0 * cd0 - s0 * sd0;
    s = sn;
    c = cn;
    s0 = sn0;
    c0 = cn0;
  }
  return 2.0 * acc / (m * m);
}

double gaussMarkovAvar(double tau, double tc, double tau0) {
  requirePositive(tau, "gaussMarkovAvar: tau");
  requirePositive(tc, "gaussMarkovAvar: correlation time");
  if (tau0 > 0) {
    const double m = tau / tau0;
    const double a = tau0 / tc;
    const double omp = -std::expm1(-a);                 // 1 - phi
    const double phi = std::exp(-a);
    const double ompm = -std::expm1(-a * m);            // 1 - phi^m
    const double var_s = m + 2.0 * phi * (m * omp - ompm) / (omp * omp);
    const double cov_s = phi * ompm * ompm / (omp * omp);
    return std::max(0.0, (var_s - cov_s) / (m * m));
  }
  const double x = tau / tc;
  if (x < 1e-3) return (2.0 / 3.0) * x - 0.5 * x * x;  // series: avoids cancellation
  const double e = std::exp(-x);
  return (2.0 * x - 3.0 + 4.0 * e - e * e) / (x * x);
}

double biasStepAvar(double tau, double t_step, double record_s) {
  requirePositive(tau, "biasStepAvar: tau");
  requirePositive(record_s, "biasStepAvar: record length");
  const double span = record_s - 2.0 * tau;  // start times available to the estimator: [0, span]
  if (span <= 0) return 0.0;
  // Difference of means vs start time t: rises linearly 0 -> 1 on [ts - 2 tau, ts - tau], falls 1 -> 0 on
  // [ts - tau, ts]. Integrate its square over [0, span].
  const double s0 = t_step - 2.0 * tau, s1 = t_step - tau, s2 = t_step;
  double integral = 0;
  {
    const double lo = std::max(0.0, s0), hi = std::min(span, s1);
    if (hi > lo) integral += (std::pow(hi - s0, 3) - std::pow(lo - s0, 3)) / (3.0 * tau * tau);
  }
  {
    const double lo = std::max(0.0, s1), hi = std::min(span, s2);
    if (hi > lo) integral += (std::pow(s2 - lo, 3) - std::pow(s2 - hi, 3)) / (3.0 * tau * tau);
  }
  return integral / (2.0 * span);
}

double warmupAvar(double tau, double theta, double record_s) {
  requirePositive(tau, "warmupAvar: tau");
  requirePositive(theta, "warmupAvar: time constant");
  requirePositive(record_s, "warmupAvar: record length");
  const double span = record_s - 2.0 * tau;
  if (span <= 0) return 0.0;
  const double g = -std::expm1(-tau / theta);
  return theta * theta * theta * g * g * g * g * (-std::expm1(-2.0 * span / theta)) / (4.0 * tau * tau * span);
}

double shortCorrelationAvar(double tau, double tau0) {
  requirePositive(tau, "shortCorrelationAvar: tau");
  requirePositive(tau0, "shortCorrelationAvar: tau0");
  return -3.0 * (tau0 / tau) * (tau0 / tau);
}

double impulseAvar(double tau, double record_s) {
  requirePositive(tau, "impulseAvar: tau");
  requirePositive(record_s, "impulseAvar: record length");
  const double span = record_s - 2.0 * tau;
  if (span <= 0) return 0.0;
  return 1.0 / (tau * span);
}

double overlappingAvarAt(const std::vector<double>& y, int64_t m) {
  if (m < 1) throw std::invalid_argument("overlappingAvarAt: m must be >= 1");
  const int64_t n = static_cast<int64_t>(y.size());
  if (n < 2 * m + 1) return 0.0;
  std::vector<long double> cum(n + 1, 0.0L);
  for (int64_t i = 0; i < n; ++i) cum[i + 1] = cum[i] + y[i];
  long double sum = 0;
  const int64_t terms = n - 2 * m + 1;
  for (int64_t k = 0; k < terms; ++k) {
    const long double d = (cum[k + 2 * m] - 2.0L * cum[k + m] + cum[k]) / m;
    sum += d * d;
  }
  return static_cast<double>(sum / (2.0L * terms));
}

}  // namespace gyro_allan
