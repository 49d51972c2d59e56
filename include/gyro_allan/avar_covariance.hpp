// Covariance of overlapping Allan-variance (oadev^2) estimates across tau for the IEEE 952 noise model: the weight
// matrix of the generalized-least-squares fit (noise_model.cpp) and of the calibrated residual test.
//
// Method (docs/fit.md): the angle x of a gyro whose rate holds quantization Q, angle random walk N, flicker
// bias instability B and rate random walk K is a Gaussian intrinsic random function of order 1 with generalized
// covariance  Q^2 [t = 0]  -  N^2 |t| / 2  +  B^2 t^2 ln|t| / (2 pi)  +  K^2 |t|^3 / 12  (each reproduces its term of
// sigma^2(tau) exactly). The second difference d_k(m) = x[k+2m] - 2 x[k+m] + x[k] behind each AVAR term is a linear
// combination with zero-sum, zero-first-moment weights, so Cov(d_k(m), d_l(m')) follows from that function alone,
// and for Gaussian d, Cov(d^2, d'^2) = 2 Cov(d, d')^2 (+ 4 mu mu' Cov(d, d') with the rate ramp's mean
// mu = R tau^2; uniform quantization error adds its fourth cumulant). Summing over the pairs of overlapping terms gives Cov(avar(m), avar(m')) exactly for one gap-free
// record (pooled segments are treated as one record with the pooled term counts). The sum over lags is exact near
// the breakpoints and a midpoint/Gauss-Legendre integral between them (relative error < 1e-3).
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include <Eigen/Dense>

namespace gyro_allan {

/// The covariance as a quadratic form in the squared coefficients s = (Q^2, N^2, B^2, K^2, R^2):
///   Cov = sum_{p<=q<4} s_p s_q G[p][q] + sum_{p<4} s_p s_R H[p]
/// where the matrices depend only on the averaging factors, term counts and tau0 (computed once per curve).
struct AvarCovarianceBasis {
  std::vector<int64_t> m;        ///< averaging factors of the points
  std::vector<int64_t> n_terms;  ///< terms summed at each point
  double tau0 = 0;
  std::array<std::array<Eigen::MatrixXd, 4>, 4> G;  ///< G[p][q] for p <= q (stochastic terms Q, N, B, K)
  std::array<Eigen::MatrixXd, 4> H;                 ///< rate-ramp cross terms
  /// Quantization's fourth-cumulant term per unit Q^4 and unit excess kurtosis: quantization error is not Gaussian
  /// (uniform: excess kurtosis -6/5), and Cov(d^2, d'^2) gains kappa4 * sum of w^2 w'^2 over shared samples.
  Eigen::MatrixXd K4;
};

/// Excess kurtosis of uniform quantization error (pulse-counter rounding, subtractive dither).
constexpr double kUniformExcessKurtosis = -1.2;

/// Builds the basis for points at averaging factors m[i] (tau = m tau0) with n_terms[i] overlapping terms each.
/// Throws std::invalid_argument on empty or inconsistent input.
AvarCovarianceBasis avarCovarianceBasis(const std::vector<int64_t>& m, const std::vector<int64_t>& n_terms,
                                        double tau0);

/// avarCovarianceBasis, shared: the bases of the last 8 sets of points are kept (process-wide, thread-safe) and
/// returned again for the same set. Every entry depends only on its two points (m, term count) and tau0, so a new
/// set copies each entry whose two points a kept basis with the same tau0 also has (in the same order) and sums only
/// the others: the result equals avarCovarianceBasis's bit for bit. Threads asking for a basis that is still being
/// built sum its remaining entries alongside and all return the same object. Throws as avarCovarianceBasis.
std::shared_ptr<const AvarCovarianceBasis> sharedAvarCovarianceBasis(const std::vector<int64_t>& m,
                                                                     const std::vector<int64_t>& n_terms, double tau0);

/// Covariance matrix of the AVAR estimates at the basis points for squared coefficients s (SI: rad^2, rad^2/s,
/// rad^2/s^2, rad^2/s^3, rad^2/s^4). Entries for a term with s_p <= 0 vanish. The quantization error's excess
/// kurtosis defaults to the uniform distribution's; 0 treats it as Gaussian.
Eigen::MatrixXd avarCovariance(const AvarCovarianceBasis& basis, const std::array<double, 5>& s,
                               double quantization_excess_kurtosis = kUniformExcessKurtosis);

}  // namespace gyro_allan
