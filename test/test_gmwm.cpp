// Tests of the GMWM estimator (gmwm.hpp): closed-form wavelet variances against exact sums, the WV covariance against
// Monte Carlo, and parameter recovery / model selection on simulated records with declared Gauss-Markov terms.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "gyro_allan/effects.hpp"
#include "gyro_allan/gmwm.hpp"
#include "gyro_allan/simulate.hpp"

using namespace gyro_allan;

namespace {

// The paper's closed form for an AR(1) with innovation variance s2 (Guerrier et al. 2013), as printed.
double paperAr1(double phi, double s2, double tau) {
  return ((phi * phi - 1) * tau + 2 * phi * (std::pow(phi, tau) - 4 * std::pow(phi, tau / 2) + 3)) * s2 /
         (std::pow(phi - 1, 3) * (phi + 1) * tau * tau);
}

// Haar MODWT filter at scale tau (even).
std::vector<double> haar(int64_t tau) {
  std::vector<double> h(static_cast<size_t>(tau));
  for (int64_t l = 0; l < tau; ++l) h[l] = (l < tau / 2 ? 1.0 : -1.0) / static_cast<double>(tau);
  return h;
}

}  // namespace

TEST(GmwmClosedForms, MatchExactSums) {
  for (int64_t tau = 2; tau <= 128; tau *= 2) {
    // White: acf = {s2}.
    EXPECT_NEAR(wvWhite(2.0, tau), wvFromAutocovariance({2.0}, tau), 1e-12 * wvWhite(2.0, tau));
    // Quantization: first difference of white q2: acf {2 q2, -q2}.
    EXPECT_NEAR(wvQuantization(0.5, tau), wvFromAutocovariance({1.0, -0.5}, tau), 1e-12);
    // AR(1): acf_k = s2 phi^k / (1 - phi^2); the paper's form and ours.
    for (double phi : {0.3, 0.9, 0.99, 0.999}) {
      const double s2 = 0.7;
      std::vector<double> acf(static_cast<size_t>(tau));
      for (size_t k = 0; k < acf.size(); ++k) acf[k] = s2 * std::pow(phi, static_cast<double>(k)) / (1 - phi * phi);
      const double exact = wvFromAutocovariance(acf, tau);
      EXPECT_NEAR(wvAr1(phi, s2, static_cast<double>(tau)), exact, 1e-9 * exact) << phi << " " << tau;
      EXPECT_NEAR(paperAr1(phi, s2, static_cast<double>(tau)), exact, 1e-6 * exact) << phi << " " << tau;
    }
    // Random walk x_t = sum e: W = sum_k g_k e_{t-k} with g_k = sum_{l <= k} h_l (earlier innovations cancel).
    const std::vector<double> h = haar(tau);
    double g = 0, sg2 = 0, slope = 0;
    for (int64_t l = 0; l < tau; ++l) {
      g += h[l];
      sg2 += g * g;
      slope += h[l] * static_cast<double>(l);
    }
    EXPECT_NEAR(wvRandomWalk(1.3, tau), 1.3 * sg2, 1e-12 * 1.3 * sg2);
    // Drift w t: W = -w sum l h_l.
    EXPECT_NEAR(wvDrift(0.04, tau), 0.04 * slope * slope, 1e-12 * wvDrift(0.04, tau));
  }
  // Near phi = 1 (tc of 10^4..10^8 samples) the AR(1) tends to a random walk of innovation variance 1 - phi^2 (unit
  // stationary variance); the closed form must keep its digits there (relative difference of order m a; 1e-3 covers the rounding left at tc = 1e8
  // samples).
  for (double a : {1e-4, 1e-6, 1e-8})
    for (double tau : {2.0, 8.0, 1024.0}) {
      const double rw = wvRandomWalk(-std::expm1(-2 * a), tau);
      EXPECT_NEAR(wvAr1(std::exp(-a), -std::expm1(-2 * a), tau) / rw, 1.0, 1e-3 + tau * a) << a << " " << tau;
    }
}

TEST(GmwmWaveletVariance, EqualsHalfTheOverlappingAvar) {
  std::mt19937_64 rng(5);
  std::normal_distribution<double> nd;
  std::vector<double> x(5000);
  double ar = 0;
  for (auto& v : x) v = (ar = 0.95 * ar + nd(rng)) + nd(rng);
  const WaveletVariance wv = haarWaveletVariance(x, 0.01);
  ASSERT_GE(wv.level.size(), 8u);
  for (size_t j = 0; j < wv.level.size(); ++j) {
    const double oavar = overlappingAvarAt(x, int64_t{1} << (wv.level[j] - 1));
    EXPECT_NEAR(wv.nu2[j], oavar / 2, 1e-10 * oavar);
    EXPECT_LT(wv.lo[j], wv.nu2[j]);
    EXPECT_GT(wv.hi[j], wv.nu2[j]);
  }
  EXPECT_THROW(haarWaveletVariance({1, 2, 3}, 0.01), std::invalid_argument);
  std::vector<double> bad(100, 0.0);
  bad[5] = NAN;
  EXPECT_THROW(haarWaveletVariance(bad, 0.01), std::invalid_argument);
}

// The model covariance of the WV estimates against a Monte-Carlo covariance of WN + AR(1) + RW records.
// 400 records: the sample variance of a variance has relative standard error ~ sqrt(2/400) * kurtosis factor, so
// diagonal entries are compared within 25 % and correlations of neighbouring levels within 0.15.
TEST(GmwmCovariance, MatchesMonteCarlo) {
  const int reps = 400, n = 4096;
  GmwmModel model = parseGmwmModel("WN+GM+RW");
  const double s2 = 1.0, v = 4.0, tc = 20.0, g2 = 1e-4;
  Eigen::VectorXd th(4);  // internal layout: log WN variance, log RW variance, GM log variance, log tc (samples)
  th << std::log(s2), std::log(g2), std::log(v), std::log(tc);
  std::mt19937_64 rng(11);
  std::normal_distribution<double> nd;
  const double phi = std::exp(-1.0 / tc);
  std::vector<std::vector<double>> est;
  WaveletVariance wv0;
  for (int r = 0; r < reps; ++r) {
    std::vector<double> x(n);
    double ar = std::sqrt(v) * nd(rng), rw = 0;
    for (auto& y : x) {
      ar = phi * ar + std::sqrt(v * (1 - phi * phi)) * nd(rng);
      rw += std::sqrt(g2) * nd(rng);
      y = std::sqrt(s2) * nd(rng) + ar + rw;
    }
    wv0 = haarWaveletVariance(x, 1.0);
    est.push_back(wv0.nu2);
  }
  const size_t J = wv0.level.size();
  const Eigen::MatrixXd C = gmwmCovariance(wv0, model, th);
  std::vector<double> mean(J, 0.0);
  for (const auto& e : est)
    for (size_t j = 0; j < J; ++j) mean[j] += e[j] / reps;
  Eigen::MatrixXd S = Eigen::MatrixXd::Zero(J, J);
  for (const auto& e : est)
    for (size_t a = 0; a < J; ++a)
      for (size_t b = 0; b < J; ++b) S(a, b) += (e[a] - mean[a]) * (e[b] - mean[b]) / (reps - 1);
  const std::vector<double> model_wv = gmwmModelWv(wv0, model, th);
  for (size_t j = 0; j < J; ++j) {
    EXPECT_NEAR(mean[j] / model_wv[j], 1.0, 3 * std::sqrt(S(j, j) / reps) / model_wv[j] + 0.01) << "level " << j + 1;
    if (wv0.n_coeffs[j] < 8 * (int64_t{1} << wv0.level[j])) continue;  // the asymptotic form needs M_j >> L_j
    EXPECT_NEAR(C(j, j) / S(j, j), 1.0, 0.25) << "level " << j + 1;
    if (j + 1 < J && wv0.n_coeffs[j + 1] >= 8 * (int64_t{1} << wv0.level[j + 1])) {
      const double rho_model = C(j, j + 1) / std::sqrt(C(j, j) * C(j + 1, j + 1));
      const double rho_mc = S(j, j + 1) / std::sqrt(S(j, j) * S(j + 1, j + 1));
      EXPECT_NEAR(rho_model, rho_mc, 0.15) << "levels " << j + 1 << "," << j + 2;
    }
  }
}

TEST(GmwmModel, ParsesNames) {
  EXPECT_EQ(parseGmwmModel("wn+2gm+rw").name(), "WN+2GM+RW");
  EXPECT_EQ(parseGmwmModel("QN+WN+GM").parameters(), 4);
  EXPECT_THROW(parseGmwmModel("WN+XX"), std::invalid_argument);
  EXPECT_THROW(parseGmwmModel(""), std::invalid_argument);
}
