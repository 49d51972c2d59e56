// Tests of the record's information bound: the block differences' autocovariance against the IEEE Allan variance and
// white noise's known covariance, the Durbin–Levinson likelihood against a dense one, the bound against white noise's
// exact Fisher information and against the scatter of maximum-likelihood fits on drawn records.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "../studies/information_bound.hpp"
#include "gyro_allan/noise_model.hpp"

using namespace gyro_allan;

TEST(InformationBound, LagZeroIsTwiceTheAllanVarianceAtTheBlock) {
  const double block = 2.5;
  for (int t = 0; t < 4; ++t) {
    std::array<double, 5> s{};
    s[static_cast<size_t>(t)] = 1;
    const double c0 = blockDifferenceAutocovariance(s, block, 1)[0];
    EXPECT_NEAR(c0 / 2, noiseTermBasis(t, block), 1e-12 * std::abs(noiseTermBasis(t, block))) << noiseTermKey(t);
  }
}

TEST(InformationBound, WhiteRateGivesDifferencedIndependentMeans) {
  // Block means of white rate are independent with variance N^2 / D; their first differences have variance
  // 2 N^2 / D, lag-one covariance -N^2 / D and nothing beyond.
  const double n2 = 4e-8, block = 0.5;
  const std::vector<double> c = blockDifferenceAutocovariance({0, n2, 0, 0, 0}, block, 4);
  EXPECT_NEAR(c[0], 2 * n2 / block, 1e-20);
  EXPECT_NEAR(c[1], -n2 / block, 1e-20);
  EXPECT_NEAR(c[2], 0, 1e-20);
  EXPECT_NEAR(c[3], 0, 1e-20);
}

TEST(InformationBound, DurbinLevinsonMatchesTheDenseLikelihood) {
  const int n = 60;
  const std::vector<double> c = blockDifferenceAutocovariance({1e-9, 4e-8, 1e-10, 1e-12, 0}, 1.0, n);
  const Eigen::MatrixXd cov = toeplitzMatrix(c, n);
  std::mt19937_64 rng(7);
  std::normal_distribution<double> g;
  Eigen::VectorXd z(n);
  for (int i = 0; i < n; ++i) z(i) = 1e-4 * g(rng);
  const Eigen::LLT<Eigen::MatrixXd> chol(cov);
  const Eigen::VectorXd w = chol.matrixL().solve(z);
  double logdet = 0;
  for (int i = 0; i < n; ++i) logdet += 2 * std::log(chol.matrixL()(i, i));
  const double dense = -0.5 * (n * std::log(2 * M_PI) + logdet + w.squaredNorm());
  EXPECT_NEAR(toeplitzGaussianLogLikelihood(c, z), dense, 1e-8 * std::abs(dense));
  // Not positive definite: no likelihood.
  std::vector<double> bad = c;
  bad[1] = 2 * bad[0];
  EXPECT_EQ(toeplitzGaussianLogLikelihood(bad, z), -std::numeric_limits<double>::infinity());
}

TEST(InformationBound, WhiteNoiseAloneHasTheExactFisherInformation) {
  // Covariance N^2 S: the information on N^2 is n / (2 N^4) for n differences, so the Allan deviation's relative
  // standard deviation is sqrt(2 / n) / 2 at every tau.
  const double duration = 1000, block = 1;
  const int n = 998;
  const AdevBound b = adevInformationBound({0, 2e-4, 0, 0, 0}, duration, block, {false, true, false, false, false},
                                           {1.0, 10.0, 100.0});
  for (double r : b.rel_sd) EXPECT_NEAR(r, 0.5 * std::sqrt(2.0 / n), 1e-9);
  EXPECT_THROW(adevInformationBound({0, 2e-4, 0, 0, 0}, 10, 1, {false, true, false, false, false}, {1.0}),
               std::invalid_argument);
  EXPECT_THROW(adevInformationBound({0, 2e-4, 0, 0, 0}, 1000, 0, {false, true, false, false, false}, {1.0}),
               std::invalid_argument);
  EXPECT_THROW(adevInformationBound({0, 2e-4, 0, 0, 0}, 1000, 1, {false, false, false, false, false}, {1.0}),
               std::invalid_argument);
  EXPECT_THROW(adevInformationBound({0, 2e-4, 0, 0, 0}, 1000, 1, {false, true, false, false, true}, {1.0}),
               std::invalid_argument);
}

TEST(InformationBound, MaximumLikelihoodScatterMatchesTheBound) {
  // Rate random walk well above a weak white noise on 400 differences: K^2's information is large, so its maximum-
  // likelihood estimate is near normal with the bound's variance. 300 drawn records; the sample sd of the fitted
  // Allan deviation at tau = 10 s against the bound: the ratio's own sampling sd is ~4 %, tolerance 15 %.
  const double block = 1, duration = 402, n2 = 1e-14, k2 = 1e-12;
  const int n = 400;
  const std::array<double, 5> s{0, n2, 0, k2, 0};
  const AdevBound b =
      adevInformationBound({0, std::sqrt(n2), 0, std::sqrt(k2), 0}, duration, block, {false, false, false, true, false}, {10.0});
  const Eigen::LLT<Eigen::MatrixXd> chol(toeplitzMatrix(blockDifferenceAutocovariance(s, block, n), n));
  std::mt19937_64 rng(2024);
  std::normal_distribution<double> g;
  std::vector<double> rel;
  for (int draw = 0; draw < 300; ++draw) {
    Eigen::VectorXd e(n);
    for (int i = 0; i < n; ++i) e(i) = g(rng);
    const Eigen::VectorXd z = chol.matrixL() * e;
    const double k2_hat = blockLikelihoodFit(z, block, s, {false, false, false, true, false}, s)[kRateRandomWalk];
    rel.push_back(std::sqrt((n2 / 10.0 + k2_hat * 10.0 / 3) / (n2 / 10.0 + k2 * 10.0 / 3)) - 1);
  }
  double mean = 0, var = 0;
  for (double r : rel) mean += r / rel.size();
  for (double r : rel) var += (r - mean) * (r - mean) / (rel.size() - 1);
  EXPECT_NEAR(std::sqrt(var) / b.rel_sd[0], 1.0, 0.15) << "bound " << b.rel_sd[0] << ", scatter " << std::sqrt(var);
  EXPECT_LT(std::abs(mean), 3 * b.rel_sd[0] / std::sqrt(300.0) + 0.01);
}
