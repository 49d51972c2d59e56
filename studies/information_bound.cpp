// The exact Gaussian likelihood of a record's differenced block means and its Cramér–Rao bound on the model ADEV.
#include "information_bound.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>

#include "gyro_allan/noise_model.hpp"
#include "gyro_allan/stats.hpp"

namespace gyro_allan {
namespace {

/// The angle's generalized covariance at lag t seconds for squared coefficients s (Q^2, N^2, B^2, K^2).
double angleGeneralizedCovariance(const std::array<double, 5>& s, double t) {
  const double a = std::abs(t);
  if (a == 0) return s[kQuantization];
  return -s[kAngleRandomWalk] * a / 2 + s[kBiasInstability] * a * a * std::log(a) / (2 * M_PI) +
         s[kRateRandomWalk] * a * a * a / 12;
}

}  // namespace

Eigen::MatrixXd toeplitzMatrix(const std::vector<double>& acov, int n) {
  if (static_cast<int>(acov.size()) < n) throw std::invalid_argument("toeplitzMatrix: too few lags");
  Eigen::MatrixXd m(n, n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) m(i, j) = acov[static_cast<size_t>(std::abs(i - j))];
  return m;
}

std::vector<double> blockDifferenceAutocovariance(const std::array<double, 5>& s, double block_s, int n) {
  static const double kLambda[3] = {1, -2, 1};  // second difference of the angle at block edges
  std::vector<double> c(static_cast<size_t>(std::max(n, 0)));
  for (int k = 0; k < n; ++k) {
    double sum = 0;
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) sum += kLambda[a] * kLambda[b] * angleGeneralizedCovariance(s, (k + a - b) * block_s);
    c[static_cast<size_t>(k)] = sum / (block_s * block_s);
  }
  return c;
}

double toeplitzGaussianLogLikelihood(const std::vector<double>& acov, const Eigen::VectorXd& z) {
  const int n = static_cast<int>(z.size());
  if (n == 0) return 0;
  if (static_cast<int>(acov.size()) < n) throw std::invalid_argument("toeplitzGaussianLogLikelihood: too few lags");
  // Durbin–Levinson: phi holds the coefficients of the best linear predictor of z_t from the t values before it.
  std::vector<double> phi, next;
  double v = acov[0];
  double ll = 0;
  for (int t = 0; t < n; ++t) {
    if (!(v > 0)) return -std::numeric_limits<double>::infinity();
    double pred = 0;
    for (int j = 0; j < t; ++j) pred += phi[static_cast<size_t>(j)] * z(t - 1 - j);
    const double e = z(t) - pred;
    ll -= 0.5 * (std::log(2 * M_PI * v) + e * e / v);
    if (t + 1 == n) break;
    // Extend the predictor by one lag (reflection coefficient kappa).
    double num = acov[static_cast<size_t>(t + 1)];
    for (int j = 0; j < t; ++j) num -= phi[static_cast<size_t>(j)] * acov[static_cast<size_t>(t - j)];
    const double kappa = num / v;
    next.assign(static_cast<size_t>(t + 1), 0);
    for (int j = 0; j < t; ++j)
      next[static_cast<size_t>(j)] = phi[static_cast<size_t>(j)] - kappa * phi[static_cast<size_t>(t - 1 - j)];
    next[static_cast<size_t>(t)] = kappa;
    phi.swap(next);
    v *= 1 - kappa * kappa;
  }
  return ll;
}

std::array<double, 5> blockLikelihoodFit(const Eigen::VectorXd& z, double block_s, const std::array<double, 5>& fixed,
                                         const std::array<bool, 5>& free, const std::array<double, 5>& scale) {
  constexpr double kOff = -13.9, kLo = -14, kHi = 6;
  const int n = static_cast<int>(z.size());
  std::array<double, 5> u{};
  for (int t = 0; t < 4; ++t) u[static_cast<size_t>(t)] = fixed[static_cast<size_t>(t)] > 0 ? 0.0 : kLo;
  auto squares = [&](const std::array<double, 5>& uu) {
    std::array<double, 5> s = fixed;
    s[kRateRamp] = 0;
    for (int t = 0; t < 4; ++t)
      if (free[static_cast<size_t>(t)])
        s[static_cast<size_t>(t)] = uu[static_cast<size_t>(t)] < kOff ? 0 : scale[static_cast<size_t>(t)] * std::exp(uu[static_cast<size_t>(t)]);
    return s;
  };
  for (int sweep = 0; sweep < 30; ++sweep) {
    double moved = 0;
    for (int t = 0; t < 4; ++t) {
      if (!free[static_cast<size_t>(t)]) continue;
      std::array<double, 5> x = u;
      const double best = goldenSectionMax(
          [&](double v) {
            x[static_cast<size_t>(t)] = v;
            return toeplitzGaussianLogLikelihood(blockDifferenceAutocovariance(squares(x), block_s, n), z);
          },
          kLo, kHi, 24);  // bracket 20 * 0.618^24 = 2e-4
      moved = std::max(moved, std::abs(best - u[static_cast<size_t>(t)]));
      u[static_cast<size_t>(t)] = best;
    }
    if (moved < 1e-3) break;
  }
  return squares(u);
}

AdevBound adevInformationBound(const std::array<double, 5>& coef, double duration_s, double block_s,
                               const std::array<bool, 5>& free, const std::vector<double>& tau) {
  if (!(block_s > 0) || !(duration_s / block_s >= 18))
    throw std::invalid_argument("adevInformationBound: fewer than 16 block differences");
  const int n = static_cast<int>(std::floor(duration_s / block_s)) - 2;
  if (free[kRateRamp] && coef[kRateRamp] == 0)
    throw std::invalid_argument("adevInformationBound: a free rate ramp needs a true R other than 0");
  std::array<double, 5> s{};
  for (int t = 0; t < kNumTerms; ++t) s[static_cast<size_t>(t)] = coef[static_cast<size_t>(t)] * coef[static_cast<size_t>(t)];
  std::vector<int> terms;
  for (int t = 0; t < kNumTerms; ++t)
    if (free[static_cast<size_t>(t)]) terms.push_back(t);
  if (terms.empty()) throw std::invalid_argument("adevInformationBound: no free term");

  const Eigen::LLT<Eigen::MatrixXd> chol(toeplitzMatrix(blockDifferenceAutocovariance(s, block_s, n), n));
  if (chol.info() != Eigen::Success) throw std::invalid_argument("adevInformationBound: covariance not positive definite");
  const int m = static_cast<int>(terms.size());
  std::vector<Eigen::MatrixXd> whitened(static_cast<size_t>(m));  // L^-1 S_p L^-T
  for (int i = 0; i < m; ++i) {
    const int t = terms[static_cast<size_t>(i)];
    if (t == kRateRamp) continue;
    std::array<double, 5> unit{};
    unit[static_cast<size_t>(t)] = 1;
    const Eigen::MatrixXd x = chol.matrixL().solve(toeplitzMatrix(blockDifferenceAutocovariance(unit, block_s, n), n));
    whitened[static_cast<size_t>(i)] = chol.matrixL().solve(x.transpose());
  }
  Eigen::MatrixXd fisher = Eigen::MatrixXd::Zero(m, m);
  for (int i = 0; i < m; ++i)
    for (int j = 0; j <= i; ++j) {
      const int ti = terms[static_cast<size_t>(i)], tj = terms[static_cast<size_t>(j)];
      if (ti == kRateRamp && tj == kRateRamp) {  // mean R * block_s on every difference
        const Eigen::VectorXd w = chol.matrixL().solve(Eigen::VectorXd::Constant(n, block_s));
        fisher(i, j) = w.squaredNorm();
      } else if (ti != kRateRamp && tj != kRateRamp) {
        fisher(i, j) = 0.5 * (whitened[static_cast<size_t>(i)].array() * whitened[static_cast<size_t>(j)].array()).sum();
      }
      fisher(j, i) = fisher(i, j);
    }
  AdevBound out;
  out.tau = tau;
  out.inverse_fisher = fisher.inverse();
  for (double tt : tau) {
    Eigen::VectorXd g(m);
    double avar = 0;
    for (int t = 0; t < kNumTerms; ++t) avar += s[static_cast<size_t>(t)] * noiseTermBasis(t, tt);
    for (int i = 0; i < m; ++i) {
      const int t = terms[static_cast<size_t>(i)];
      g(i) = t == kRateRamp ? coef[kRateRamp] * tt * tt : noiseTermBasis(t, tt);  // d avar / d (s_t or R)
    }
    out.rel_sd.push_back(0.5 * std::sqrt(std::max(0.0, g.dot(out.inverse_fisher * g))) / avar);
  }
  return out;
}

}  // namespace gyro_allan
