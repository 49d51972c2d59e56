// Internals shared by the two weightings of the IEEE 952 fit (noise_model.cpp: EDF, noise_model_gls.cpp: GLS).
#pragma once

#include <vector>

#include <Eigen/Dense>

#include "gyro_allan/noise_model.hpp"

namespace gyro_allan {
namespace detail {

/// Lawson-Hanson active-set NNLS: min ||A x - b|| subject to x >= 0.
Eigen::VectorXd nnls(const Eigen::MatrixXd& A, const Eigen::VectorXd& b);

/// The covariance weighting needs an overlapping Allan variance with averaging factors and term counts.
bool glsApplies(const DeviationCurve& curve);

/// fitNoiseModel with FitWeighting::Covariance (noise_model_gls.cpp).
FitResult fitNoiseModelGls(const DeviationCurve& curve, const FitOptions& options, const std::vector<ExtraTerm>& extra);

}  // namespace detail
}  // namespace gyro_allan
