// The most one record can tell about its noise model: the exact Gaussian likelihood of its block-mean rate changes
// and the Cramér–Rao bound that likelihood puts on the model's Allan deviation (docs/fit.md, "What the record allows").
//
// Method: the angle x of a gyro with quantization Q, angle random walk N, flicker B and rate random walk K has the
// generalized covariance Q^2 [t = 0] - N^2 |t| / 2 + B^2 t^2 ln|t| / (2 pi) + K^2 |t|^3 / 12 (avar_covariance.hpp).
// The record's block means of the rate over blocks of D seconds, differenced once,
//   z_i = (x[(i+2)D] - 2 x[(i+1)D] + x[iD]) / D,
// are free of the unknown bias, stationary for all four terms, and Gaussian, so their covariance is a symmetric
// Toeplitz matrix linear in the squared coefficients; a rate ramp R only adds the mean R D. The Fisher information of
// the squared coefficients is I_pq = tr(S^-1 S_p S^-1 S_q) / 2 (and D^2 1'S^-1 1 for a signed R); the model's Allan
// variance at tau is linear in them, so its Cramér–Rao variance is g' I^-1 g with g the terms' Allan-variance basis.
// Blocks of D >= 1 s keep the information about every term that shapes tau >= a few D (they lose only what lies
// in the rate's fluctuations within a block, where N and Q dominate).
#pragma once

#include <array>
#include <vector>

#include <Eigen/Dense>

namespace gyro_allan {

/// Autocovariance at lags 0..n-1 of the differenced block means z_i (blocks of block_s seconds) for squared
/// coefficients s = (Q^2, N^2, B^2, K^2; R^2 ignored: the ramp shifts only the mean). SI units (rad^2/s^2).
/// At lag 0 it is twice the IEEE Allan variance at tau = block_s (continuous flicker).
std::vector<double> blockDifferenceAutocovariance(const std::array<double, 5>& s, double block_s, int n);

/// The n x n symmetric Toeplitz matrix of an autocovariance (at least n lags): the covariance of n differences.
Eigen::MatrixXd toeplitzMatrix(const std::vector<double>& acov, int n);

/// Log-likelihood of z under a zero-mean Gaussian with symmetric Toeplitz covariance (autocovariance acov, at least
/// z.size() lags), by the Durbin–Levinson recursion in O(n^2). Returns -infinity when acov is not positive definite.
double toeplitzGaussianLogLikelihood(const std::vector<double>& acov, const Eigen::VectorXd& z);

/// Maximum-likelihood squared coefficients (Q^2, N^2, B^2, K^2; R^2 stays 0) for differenced block means z: each term
/// flagged in `free` is searched as scale_t * exp(u) with u in [-14, 6] (u below -13.9: the term is 0), by coordinate-
/// wise golden sections (to 2e-4 in u) until no term moves by more than 1e-3; the others are held at `fixed`. A free
/// term starts at scale_t when fixed_t > 0, else at 0. Non-negative by construction; for studies, O(n^2) per
/// likelihood, so a few thousand differences.
std::array<double, 5> blockLikelihoodFit(const Eigen::VectorXd& z, double block_s, const std::array<double, 5>& fixed,
                                         const std::array<bool, 5>& free, const std::array<double, 5>& scale);

/// The Cramér–Rao bound on the model's Allan deviation for one record of duration_s seconds.
struct AdevBound {
  std::vector<double> tau;     ///< as asked
  std::vector<double> rel_sd;  ///< bound's standard deviation of the model ADEV at tau / the true ADEV (delta method)
  Eigen::MatrixXd inverse_fisher;  ///< over the free terms in term order (squared coefficients; R signed)
};

/// The bound when the terms flagged in `free` are unknown and the others known. coef: the true Q, N, B, K, R (SI).
/// Uses blocks of block_s seconds (duration_s / block_s - 2 differences; a few thousand keep it to seconds).
/// Throws std::invalid_argument on fewer than 16 differences, no free term, or a free R of 0 (its bound on the
/// Allan variance, which holds R^2, is degenerate there).
AdevBound adevInformationBound(const std::array<double, 5>& coef, double duration_s, double block_s,
                               const std::array<bool, 5>& free, const std::vector<double>& tau);

}  // namespace gyro_allan
