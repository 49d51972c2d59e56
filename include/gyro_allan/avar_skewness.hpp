// Third cumulant of a linear combination of overlapping Allan-variance estimates (the skew of a fitted coefficient),
// by the spectral (circulant) approximation of the estimates as quadratic forms in the rate samples.
//
// Method (docs/calibration.md, "Session 26"): the overlapping AVAR at m samples with n terms is, up to end effects, a
// quadratic form in the rate samples with the spectral window h_m(nu) = 2 sin^4(pi m nu) / (m^2 sin^2(pi nu)) (nu in
// cycles per sample): its mean is the integral of h_m S over nu in [-1/2, 1/2] for the rate's two-sided PSD S, and
// over n Fourier pairs its r-th cumulant is about (r - 1)! 2^r n^(1 - r) int_0^(1/2) (h_m S)^r dnu. For a combination
// x = sum_i a_i avar(m_i) the windows add with each point's own length in the mean of order r (geometric):
// phi_r = sum_i a_i n_i^((1 - r) / r) h_{m_i}, I_r = int_0^(1/2) (phi_r S)^r dnu. One common factor on those lengths
// (the overlap's correlation, end effects) is taken from the exact variance kappa2 (avar_covariance.hpp):
// kappa3 = kappa2^2 I3 / I2^2. On simulated gyros this is within 6-7 % of the simulated skew of a fitted rate random
// walk (the same form with one common length, 5-33 % low; test_avar_covariance).
#pragma once

#include <array>
#include <cstdint>
#include <vector>

namespace gyro_allan {

/// Two-sided PSD of the rate samples (rad^2/s^2 per cycle/sample) of one IEEE term at unit squared coefficient:
/// quantization Q^2 4 sin^2(pi nu) / tau0^2, angle random walk N^2 / tau0, flicker B^2 / (2 sin(pi nu)) (the
/// sampled 1/f noise of simulate.cpp), rate random walk K^2 tau0 / (4 sin^2(pi nu)). term: 0..3 (Q, N, B, K).
double termRatePsd(int term, double nu, double tau0);

/// The overlapping AVAR's spectral window h_m(nu).
double avarWindow(int64_t m, double nu);

/// Spectral moments of x = sum_i a_i avar(m_i) (n_terms[i] overlapping terms at point i) whose noise is a fixed part
/// (squared coefficients s_fixed of Q, N, B) plus a rate random walk of squared coefficient mu:
/// I2(mu) = int (phi_2 (S_fixed + mu S_K))^2 and I3(mu) = int (phi_3 (S_fixed + mu S_K))^3 over nu in (0, 1/2].
struct AvarCombinationSpectrum {
  std::array<double, 3> i2{};  ///< I2(mu) = i2[0] + i2[1] mu + i2[2] mu^2
  std::array<double, 4> i3{};  ///< I3(mu) = i3[0] + ... + i3[3] mu^3
  double I2(double mu) const { return i2[0] + mu * (i2[1] + mu * i2[2]); }
  double I3(double mu) const { return i3[0] + mu * (i3[1] + mu * (i3[2] + mu * i3[3])); }
};

/// The moments above on a log-spaced grid (64 points per octave; each window's sin^4 held at its mean 3/8 where
/// m nu > 4, beyond its main lobes: exact for the mean, an approximation for I2 and I3, whose powers of a side lobe
/// average to more, e.g. sin^8 to 35/128 = 1.94 (3/8)^2; the long-tau windows a rate random walk is read from carry
/// little weight there, and the form's skew of a fitted K is within 7 % of simulation). Throws
/// std::invalid_argument when m, n_terms and a differ in size, a point has no terms or tau0 <= 0.
AvarCombinationSpectrum avarCombinationSpectrum(const std::vector<int64_t>& m, const std::vector<int64_t>& n_terms,
                                                const std::vector<double>& a, double tau0,
                                                const std::array<double, 3>& s_fixed);

/// Mean of the overlapping AVAR at m samples for squared coefficients s (Q, N, B, K) from the same grid: the check
/// that the PSDs above reproduce the IEEE terms.
double spectralMeanAvar(int64_t m, double tau0, const std::array<double, 4>& s);

}  // namespace gyro_allan
