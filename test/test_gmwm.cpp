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

// Sample mean and (unbiased) covariance across records of per-level wavelet variances.
void sampleMeanCov(const std::vector<std::vector<double>>& est, size_t J, std::vector<double>* mean, Eigen::MatrixXd* S) {
  const double reps = static_cast<double>(est.size());
  mean->assign(J, 0.0);
  for (const auto& e : est)
    for (size_t j = 0; j < J; ++j) (*mean)[j] += e[j] / reps;
  *S = Eigen::MatrixXd::Zero(J, J);
  for (const auto& e : est)
    for (size_t a = 0; a < J; ++a)
      for (size_t b = 0; b < J; ++b) (*S)(a, b) += (e[a] - (*mean)[a]) * (e[b] - (*mean)[b]) / (reps - 1);
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

// MA(q) measurement noise: the finite-lag form against the brute-force double sum, at every scale including those
// shorter than the memory (tau = 2m < 2q), and the model WV of an "MA3" model (internal layout: log s2, theta_1..3).
TEST(GmwmClosedForms, MovingAverageMatchesExactSum) {
  const std::vector<double> theta = {0.6, -0.35, 0.2};
  const double s2 = 1.7;
  const std::vector<double> acf = maAutocovariance(theta, s2);
  ASSERT_EQ(acf.size(), 4u);
  EXPECT_NEAR(acf[0], s2 * (1 + 0.36 + 0.35 * 0.35 + 0.04), 1e-12);
  EXPECT_NEAR(acf[3], s2 * 0.2, 1e-12);
  GmwmModel model = parseGmwmModel("MA3");
  Eigen::VectorXd th(4);
  th << std::log(s2), theta[0], theta[1], theta[2];
  for (int64_t tau = 2; tau <= 256; tau *= 2) {
    const double exact = wvFromAutocovariance(acf, tau);
    EXPECT_NEAR(wvShortMemory(acf, static_cast<double>(tau)), exact, 1e-12 * std::fabs(exact)) << tau;
  }
  for (int64_t tau : {2, 4, 6, 10}) {  // also scales that are not powers of two (gmwmModelAvar at any m)
    const double exact = wvFromAutocovariance(acf, tau);
    EXPECT_NEAR(wvShortMemory(acf, static_cast<double>(tau)), exact, 1e-12 * std::fabs(exact)) << tau;
  }
  WaveletVariance wv;
  wv.level = {1, 2, 3, 4, 5};
  const std::vector<double> mw = gmwmModelWv(wv, model, th);
  for (size_t j = 0; j < mw.size(); ++j)
    EXPECT_NEAR(mw[j], wvFromAutocovariance(acf, int64_t{1} << wv.level[j]), 1e-12) << j;
  // The long-run white equivalent: AVAR(m) m -> S(0) = s2 (1 + sum theta)^2 (relative error O(1/m)).
  GmwmFit f;
  f.model = model;
  f.theta = th;
  const int64_t m = 1000000;
  EXPECT_NEAR(gmwmModelAvar(f, 1.0, m) * m / (s2 * 1.45 * 1.45), 1.0, 1e-5);
  EXPECT_EQ(parseGmwmModel("ma2+gm+rw").name(), "MA2+GM+RW");
  EXPECT_EQ(parseGmwmModel("MA2+GM").parameters(), 5);
  EXPECT_THROW(parseGmwmModel("WN+MA2"), std::invalid_argument);
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
  std::vector<double> mean;
  Eigen::MatrixXd S;
  sampleMeanCov(est, J, &mean, &S);
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

namespace {

// A 1-h, 100-Hz record of white noise N plus Gauss-Markov terms (sigma, tc) plus rate random walk K: the first GM with
// the white noise and K from one simulateAxis call, each further GM from an independent stream (as gmwm_study).
std::vector<double> simulateGm(double N, const std::vector<std::pair<double, double>>& gm, double K, uint64_t seed) {
  const double rate = 100, duration = 3600;
  const int64_t n = static_cast<int64_t>(rate * duration);
  AxisNoise a;
  a.angle_random_walk = N;
  a.rate_random_walk = K;
  a.gm_sigma = gm[0].first;
  a.gm_tau = gm[0].second;
  std::vector<double> x = simulateAxis(a, rate, n, seed, 0);
  for (size_t i = 1; i < gm.size(); ++i) {
    AxisNoise b;
    b.gm_sigma = gm[i].first;
    b.gm_tau = gm[i].second;
    const std::vector<double> y = simulateAxis(b, rate, n, seed, static_cast<int>(i));
    for (int64_t k = 0; k < n; ++k) x[k] += y[k];
  }
  return x;
}

}  // namespace

// Recovery of declared GM parameters (gmwm_study settings S2 and S3, seeds 2001..2008, disjoint from the study's tuning
// 1..50 and validation 1001..1050 seeds). Claim: each parameter within 10 % of the truth and within 2 reported sigma in
// >= 90 % of records. Tolerance: at least 6 of 8 seeds; if the true rate were exactly 0.9 this fails with probability
// P(Binomial(8, 0.9) <= 5) = 0.038 (the 2-sigma coverage's nominal 0.954 gives 0.006).
TEST(GmwmRecovery, DeclaredGaussMarkovTermsOnOneHourRecords) {
  struct Case {
    const char* model;
    std::vector<std::pair<double, double>> gm;
    double K;
  };
  const std::vector<Case> cases = {{"WN+2GM", {{1e-3, 0.1}, {1e-3, 2.0}}, 0.0}, {"WN+GM+RW", {{1e-3, 2.0}}, 1.5e-4}};
  const double N = 3e-4;
  for (const Case& c : cases) {
    const GmwmModel model = parseGmwmModel(c.model);
    std::vector<int> s10(c.gm.size()), t10(c.gm.size()), s2sd(c.gm.size()), t2sd(c.gm.size());
    int n_ok = 0, k10 = 0;
    for (uint64_t seed = 2001; seed <= 2008; ++seed) {
      const WaveletVariance wv = haarWaveletVariance(simulateGm(N, c.gm, c.K, seed), 0.01);
      const GmwmFit f = fitGmwm(wv, model);
      ASSERT_TRUE(f.ok) << f.message;
      ASSERT_EQ(f.gm.size(), c.gm.size());
      ++n_ok;
      for (size_t i = 0; i < c.gm.size(); ++i) {
        const double ts = c.gm[i].first, tt = c.gm[i].second;
        s10[i] += std::fabs(f.gm[i].sigma / ts - 1) <= 0.1;
        t10[i] += std::fabs(f.gm[i].tc / tt - 1) <= 0.1;
        s2sd[i] += std::fabs(f.gm[i].sigma - ts) <= 2 * f.gm[i].sigma_sd;
        t2sd[i] += std::fabs(f.gm[i].tc - tt) <= 2 * f.gm[i].tc_sd;
      }
      if (c.K > 0) k10 += std::fabs(f.K / c.K - 1) <= 0.25;
    }
    for (size_t i = 0; i < c.gm.size(); ++i) {
      EXPECT_GE(s10[i], 6) << c.model << " GM" << i + 1 << " sigma within 10 %";
      EXPECT_GE(t10[i], 6) << c.model << " GM" << i + 1 << " tc within 10 %";
      EXPECT_GE(s2sd[i], 6) << c.model << " GM" << i + 1 << " sigma within 2 sd";
      EXPECT_GE(t2sd[i], 6) << c.model << " GM" << i + 1 << " tc within 2 sd";
    }
    // K is weakly determined on 1 h (its relative sd is ~0.18 here): within 25 % in >= 6 of 8.
    if (c.K > 0) {
      EXPECT_GE(k10, 6) << c.model << " K within 25 %";
    }
    EXPECT_EQ(n_ok, 8);
  }
}

// Selection of the number of GM terms (and RW) among WN+RW, WN+kGM(+RW), k <= 3: claim >= 90 % correct; 5 seeds
// (3001..3005) per setting, at least 4 correct (P(Binomial(5, 0.9) <= 3) = 0.081 if the rate were exactly 0.9).
TEST(GmwmSelection, PicksTheTrueNumberOfGaussMarkovTerms) {
  struct Case {
    std::vector<std::pair<double, double>> gm;
    double K;
    int n_gm;
    bool rw;
  };
  const std::vector<Case> cases = {{{{1e-3, 2.0}}, 0.0, 1, false}, {{{1e-3, 0.1}, {1e-3, 2.0}}, 0.0, 2, false},
                                   {{{1e-3, 2.0}}, 1.5e-4, 1, true}};
  for (const Case& c : cases) {
    int right = 0;
    for (uint64_t seed = 3001; seed <= 3005; ++seed) {
      const WaveletVariance wv = haarWaveletVariance(simulateGm(3e-4, c.gm, c.K, seed), 0.01);
      const GmwmSelection sel = selectGmwm(wv);
      ASSERT_GE(sel.best, 0);
      right += sel.chosen().model.gauss_markov == c.n_gm && sel.chosen().model.random_walk == c.rw;
    }
    EXPECT_GE(right, 4) << c.n_gm << " GM" << (c.rw ? " + RW" : "");
  }
}

// The model covariance of the WV estimates with an MA(2) measurement noise (its spectrum s2 |1 + sum theta e^-i2pifk|^2)
// and a GM, against Monte Carlo (tolerances as above).
TEST(GmwmCovariance, MovingAverageMatchesMonteCarlo) {
  const int reps = 400, n = 4096;
  const GmwmModel model = parseGmwmModel("MA2+GM");
  const double s2 = 1.0, t1 = 0.7, t2 = -0.4, v = 2.0, tc = 30.0;
  Eigen::VectorXd th(5);  // log s2, theta_1, theta_2, GM log variance, log tc
  th << std::log(s2), t1, t2, std::log(v), std::log(tc);
  std::mt19937_64 rng(12);
  std::normal_distribution<double> nd;
  const double phi = std::exp(-1.0 / tc);
  std::vector<std::vector<double>> est;
  WaveletVariance wv0;
  for (int r = 0; r < reps; ++r) {
    std::vector<double> x(n);
    double ar = std::sqrt(v) * nd(rng), e1 = nd(rng), e2 = nd(rng);
    for (auto& y : x) {
      ar = phi * ar + std::sqrt(v * (1 - phi * phi)) * nd(rng);
      const double e = nd(rng);
      y = std::sqrt(s2) * (e + t1 * e1 + t2 * e2) + ar;
      e2 = e1;
      e1 = e;
    }
    wv0 = haarWaveletVariance(x, 1.0);
    est.push_back(wv0.nu2);
  }
  const size_t J = wv0.level.size();
  const Eigen::MatrixXd C = gmwmCovariance(wv0, model, th);
  std::vector<double> mean;
  Eigen::MatrixXd S;
  sampleMeanCov(est, J, &mean, &S);
  const std::vector<double> model_wv = gmwmModelWv(wv0, model, th);
  for (size_t j = 0; j < J; ++j) {
    EXPECT_NEAR(mean[j] / model_wv[j], 1.0, 3 * std::sqrt(S(j, j) / reps) / model_wv[j] + 0.01) << "level " << j + 1;
    if (wv0.n_coeffs[j] < 8 * (int64_t{1} << wv0.level[j])) continue;
    EXPECT_NEAR(C(j, j) / S(j, j), 1.0, 0.25) << "level " << j + 1;
    if (j + 1 < J && wv0.n_coeffs[j + 1] >= 8 * (int64_t{1} << wv0.level[j + 1])) {
      const double rho_model = C(j, j + 1) / std::sqrt(C(j, j) * C(j + 1, j + 1));
      const double rho_mc = S(j, j + 1) / std::sqrt(S(j, j) * S(j + 1, j + 1));
      EXPECT_NEAR(rho_model, rho_mc, 0.15) << "levels " << j + 1 << "," << j + 2;
    }
  }
}

// A white noise through a declared 3-tap FIR (MA(2), theta = 0.5, 0.25) plus a GM (1e-3 rad/s, 2 s), 1 h at 100 Hz:
// the selection (forward in the MA order) picks MA2+GM, and the fit of that model recovers theta within 3 reported
// sigma and the long-run white equivalent N within 10 % (seeds 4001..4003, disjoint from the others; each claim
// must hold in >= 2 of 3: a 0.9 success rate fails this with probability 0.028).
TEST(GmwmSelection, FindsAShortMemoryMeasurementNoise) {
  const double N = 3e-4, t1 = 0.5, t2 = 0.25, rate = 100;
  const int64_t n = 360000;
  int picked = 0, theta_ok = 0, n_ok = 0;
  for (uint64_t seed = 4001; seed <= 4003; ++seed) {
    AxisNoise a;
    a.gm_sigma = 1e-3;
    a.gm_tau = 2.0;
    std::vector<double> x = simulateAxis(a, rate, n, seed, 0);
    std::mt19937_64 rng(seed);
    std::normal_distribution<double> nd;
    const double s = N * std::sqrt(rate);  // innovation sd per sample
    double e1 = s * nd(rng), e2 = s * nd(rng);
    for (auto& y : x) {
      const double e = s * nd(rng);
      y += e + t1 * e1 + t2 * e2;
      e2 = e1;
      e1 = e;
    }
    const WaveletVariance wv = haarWaveletVariance(x, 1.0 / rate);
    const GmwmSelection sel = selectGmwm(wv);
    ASSERT_GE(sel.best, 0);
    picked += sel.chosen().model.name() == "MA2+GM";
    const GmwmFit f = fitGmwm(wv, parseGmwmModel("MA2+GM"));
    ASSERT_TRUE(f.ok) << f.message;
    ASSERT_EQ(f.ma.size(), 2u);
    theta_ok += std::fabs(f.ma[0] - t1) <= 3 * f.ma_sd[0] && std::fabs(f.ma[1] - t2) <= 3 * f.ma_sd[1];
    n_ok += std::fabs(f.N / (N * (1 + t1 + t2)) - 1) <= 0.1;
  }
  EXPECT_GE(picked, 2);
  EXPECT_GE(theta_ok, 2);
  EXPECT_GE(n_ok, 2);
}

// Discretization: Phi and Qd of each GM and the random walk, and a GM faster than half a step folded into the white
// variance (its dt-average's variance).
TEST(GmwmDiscrete, PhiQdAndFolding) {
  GmwmFit f;
  f.N = 2e-3;
  f.K = 1e-4;
  f.gm = {{1e-3, 0, 0.002, 0}, {5e-4, 0, 30.0, 0}};
  const DiscreteNoiseModel d = discretize(f, 0.01);
  ASSERT_EQ(d.states.size(), 2u);  // gm2, rw; gm1 (tc 2 ms < 5 ms) folded
  EXPECT_EQ(d.states[0], "gm2");
  EXPECT_EQ(d.states[1], "rw");
  ASSERT_EQ(d.folded.size(), 1u);
  EXPECT_NEAR(d.Phi(0, 0), std::exp(-0.01 / 30.0), 1e-15);
  EXPECT_NEAR(d.Qd(0, 0), 25e-8 * (1 - std::exp(-0.02 / 30.0)), 1e-20);
  EXPECT_DOUBLE_EQ(d.Phi(1, 1), 1.0);
  EXPECT_NEAR(d.Qd(1, 1), 1e-8 * 0.01, 1e-22);
  // Folded GM: the white noise with its long-run angle random walk, N_eq^2 = sigma^2 tau0 (1 + phi0) / (1 - phi0)
  // (data interval tau0 = 1 ms here, phi0 = exp(-0.5)), i.e. the GM's AVAR at tau >> tc is N_eq^2 / tau.
  f.tau0 = 0.001;
  const DiscreteNoiseModel d2 = discretize(f, 0.01);
  const double phi0 = std::exp(-0.5), neq2 = 1e-6 * 0.001 * (1 + phi0) / (1 - phi0);
  EXPECT_NEAR(d2.white_variance, 4e-6 / 0.01 + neq2 / 0.01, 1e-12);
  // ... which is what the fitted model's Allan variance says far beyond tc (m = 1e5 samples, 100 s).
  GmwmFit only_gm;
  only_gm.model = parseGmwmModel("GM");
  only_gm.theta = Eigen::Vector2d(std::log(1e-6), std::log(2.0));  // variance 1e-6, tc 2 samples
  EXPECT_NEAR(gmwmModelAvar(only_gm, 0.001, 100000) * 100.0 / neq2, 1.0, 1e-3);
  // The stationary variance is kept by the GM recursion: Qd / (1 - Phi^2) = sigma^2.
  EXPECT_NEAR(d.Qd(0, 0) / (1 - d.Phi(0, 0) * d.Phi(0, 0)), 25e-8, 1e-15);
  EXPECT_THROW(discretize(f, 0), std::invalid_argument);
}

// An MA(q) measurement noise is folded into the white variance with its long-run equivalent N = sqrt(S(0) tau0):
// no approximation note at dt >= q tau0, a note below.
TEST(GmwmDiscrete, MovingAverageFoldedIntoWhite) {
  GmwmFit f;
  f.model = parseGmwmModel("MA2+GM");
  f.theta = Eigen::VectorXd(5);
  f.theta << std::log(4.0), 0.5, 0.25, std::log(1e-6), std::log(200.0);  // per sample; tau0 = 0.01 s
  f.tau0 = 0.01;
  f.N = std::sqrt(4.0 * 0.01) * 1.75;  // as fillSiValues: innovation density times |1 + sum theta|
  f.ma = {0.5, 0.25};
  f.gm = {{1e-3, 0, 2.0, 0}};
  // At k = 100 samples per step the step-variance error 2 sum h gamma_h / (k S(0)) = 2 (0.625 + 0.5) / (100 * 3.0625)
  // = 0.7 % is below the 1 % that is stated; at k = 5 (14.7 %) and within the memory (k = 1) it is stated.
  const DiscreteNoiseModel d = discretize(f, 1.0);
  ASSERT_EQ(d.folded.size(), 1u);
  EXPECT_EQ(d.folded[0], "ma2");
  EXPECT_TRUE(d.approximation.empty()) << d.approximation;
  EXPECT_NE(discretize(f, 0.05).approximation.find("14.7 %"), std::string::npos) << discretize(f, 0.05).approximation;
  EXPECT_NEAR(d.white_variance, f.N * f.N / 1.0, 1e-15);
  // N^2 / dt is the model's AVAR far beyond the memory minus the GM: AVAR(m) m tau0 -> N^2 for the MA part.
  GmwmFit ma_only;
  ma_only.model = parseGmwmModel("MA2");
  ma_only.theta = f.theta.head(3);
  const int64_t m = 1000000;
  EXPECT_NEAR(gmwmModelAvar(ma_only, 0.01, m) * m * 0.01 / (f.N * f.N), 1.0, 1e-5);
  EXPECT_FALSE(discretize(f, 0.01).approximation.empty());  // dt = 1 sample < 2
}

// ---- Known terms (the model check's sinusoid / narrowband effects, docs/gmwm.md "Known terms") --------------------

namespace {

/// A sinusoid known term A sin(2 pi f t) at sample interval tau0 (c = A^2, basis sinusoidAvar).
GmwmKnownTerm sinusoidTerm(double A, double f, double tau0) {
  GmwmKnownTerm k;
  k.type = "sinusoid";
  k.basis = [f, tau0](double tau) { return sinusoidAvar(tau, f, tau0); };
  k.c = A * A;
  k.spectrum_hz = {f};
  k.spectrum_weight = {1.0};
  k.parameters["frequency_hz"] = f;
  return k;
}

}  // namespace

// The known term's WV c basis(2^(j-1) tau0) / 2 against the Haar MODWT of a sampled sinusoid (brute force through
// haarWaveletVariance). The sample WV of a deterministic line averages W_t^2 = B^2 (1 - cos(2 w t + psi)) / 2 over
// M_j coefficients, so it differs from B^2 / 2 by at most B^2 / (2 M_j |sin w|), w = 2 pi f tau0: that bound is the
// tolerance (plus 1e-12).
TEST(GmwmKnownTerms, SinusoidWaveletVarianceMatchesHaarMODWT) {
  const double tau0 = 0.01, A = 0.7;
  for (double f : {0.37, 3.1, 19.7, 41.3}) {
    std::vector<double> x(1 << 16);
    for (size_t t = 0; t < x.size(); ++t) x[t] = A * std::sin(2 * M_PI * f * tau0 * static_cast<double>(t) + 0.3);
    const WaveletVariance wv = haarWaveletVariance(x, tau0);
    const std::vector<double> k = knownTermsWv(wv, {sinusoidTerm(A, f, tau0)});
    const double w = 2 * M_PI * f * tau0;
    for (size_t j = 0; j < wv.nu2.size(); ++j) {
      // B^2 / 2 = k[j]: the bound is k[j] / (M_j |sin w|).
      const double tol = k[j] / (static_cast<double>(wv.n_coeffs[j]) * std::fabs(std::sin(w))) + 1e-12;
      EXPECT_NEAR(wv.nu2[j], k[j], tol) << "f " << f << " level " << wv.level[j];
    }
  }
}

// The known terms' part of the WV covariance (cross term with the noise) against Monte Carlo: white noise plus a line
// of random phase, 400 records of 4096 samples; the same tolerances as GmwmCovariance.MatchesMonteCarlo (which the
// noise-only covariance meets there).
TEST(GmwmKnownTerms, CovarianceWithALineMatchesMonteCarlo) {
  const int reps = 400, n = 4096;
  const double s2 = 1.0, A = 2.0, f = 0.0173;  // cycles per sample (tau0 = 1): the line's WV peaks near level 5
  const GmwmModel model = parseGmwmModel("WN");
  Eigen::VectorXd th(1);
  th << std::log(s2);
  const std::vector<GmwmKnownTerm> known = {sinusoidTerm(A, f, 1.0)};
  std::mt19937_64 rng(12);
  std::normal_distribution<double> nd;
  std::uniform_real_distribution<double> ud(0, 2 * M_PI);
  std::vector<std::vector<double>> est;
  WaveletVariance wv0;
  for (int r = 0; r < reps; ++r) {
    std::vector<double> x(n);
    const double ph = ud(rng);
    for (int t = 0; t < n; ++t) x[t] = std::sqrt(s2) * nd(rng) + A * std::sin(2 * M_PI * f * t + ph);
    wv0 = haarWaveletVariance(x, 1.0);
    est.push_back(wv0.nu2);
  }
  const size_t J = wv0.level.size();
  const Eigen::MatrixXd C_noise = gmwmCovariance(wv0, model, th);
  std::vector<double> mean;
  Eigen::MatrixXd S;
  sampleMeanCov(est, J, &mean, &S);
  const std::vector<double> kw = knownTermsWv(wv0, known);
  const std::vector<double> nw = gmwmModelWv(wv0, model, th);
  const Eigen::MatrixXd Ck = gmwmKnownCovariance(wv0, model, th, known);
  int line_dominated = 0;
  for (size_t j = 0; j < J; ++j) {
    EXPECT_NEAR(mean[j] / (nw[j] + kw[j]), 1.0, 3 * std::sqrt(S(j, j) / reps) / (nw[j] + kw[j]) + 0.01)
        << "level " << j + 1;
    if (wv0.n_coeffs[j] < 8 * (int64_t{1} << wv0.level[j])) continue;
    const double c = C_noise(j, j) + Ck(j, j);
    EXPECT_NEAR(c / S(j, j), 1.0, 0.25) << "level " << j + 1;
    line_dominated += Ck(j, j) > C_noise(j, j);
  }
  EXPECT_GE(line_dominated, 2);  // the check is not vacuous: at some levels the line's part is the larger
}

// WN + GM + a sinusoid of declared amplitude and frequency (1-h, 100-Hz records, seeds 2101..2108, disjoint from the
// others): the GM's sigma and tc against the truth, fitting the true stochastic model WN+GM
//  - on the same noise without the sinusoid (reference),
//  - with the sinusoid, the declared line passed as a known term (c re-estimated, the default),
//  - with the sinusoid and no known term.
// Claim (the recovery test's): with the known term, each of sigma and tc within 10 % of the truth and within 2
// reported sigma in >= 90 % of records; tolerance: >= 6 of 8 (P(Binomial(8, 0.9) <= 5) = 0.038). "About as well as
// without the sinusoid": the reference must meet the same claim on the same seeds, and the known-term fit's reported
// sigmas may exceed the reference's by at most 25 % (the line only adds the cross term of its covariance). Without the
// known term the fit must fail: it rejects itself (chi2_p < 1e-6) and misses the claim in every record. The line (A = 1.5e-3 rad/s at
// 0.2 Hz, RMS 1.06e-3 against the GM's 1e-3) sits at the GM's scales (tc = 2 s, period 5 s).
TEST(GmwmKnownTerms, GaussMarkovRecoveredWithASinusoidAsKnownTerm) {
  const double N = 3e-4, sigma = 1e-3, tc = 2.0, A = 1.5e-3, f = 0.2, tau0 = 0.01;
  const GmwmModel model = parseGmwmModel("WN+GM");
  GmwmOptions with;
  with.known = {sinusoidTerm(A, f, tau0)};
  int ref_ok = 0, known_ok = 0, unknown_ok = 0, unknown_rejected = 0, sd_close = 0;
  for (uint64_t seed = 2101; seed <= 2108; ++seed) {
    std::vector<double> x = simulateGm(N, {{sigma, tc}}, 0.0, seed);
    const GmwmFit f0 = fitGmwm(haarWaveletVariance(x, tau0), model);
    std::mt19937_64 rng(seed);
    const double ph = std::uniform_real_distribution<double>(0, 2 * M_PI)(rng);
    for (size_t t = 0; t < x.size(); ++t) x[t] += A * std::sin(2 * M_PI * f * tau0 * static_cast<double>(t) + ph);
    const WaveletVariance wv = haarWaveletVariance(x, tau0);
    const GmwmFit fk = fitGmwm(wv, model, with);
    const GmwmFit fu = fitGmwm(wv, model);
    ASSERT_TRUE(f0.ok && fk.ok && fu.ok);
    auto good = [&](const GmwmFit& g) {
      const GaussMarkovTerm& m = g.gm[0];
      return std::fabs(m.sigma / sigma - 1) <= 0.1 && std::fabs(m.tc / tc - 1) <= 0.1 &&
             std::fabs(m.sigma - sigma) <= 2 * m.sigma_sd && std::fabs(m.tc - tc) <= 2 * m.tc_sd;
    };
    ref_ok += good(f0);
    known_ok += good(fk);
    unknown_ok += good(fu);
    unknown_rejected += fu.chi2_p < 1e-6;
    sd_close += fk.gm[0].sigma_sd <= 1.25 * f0.gm[0].sigma_sd && fk.gm[0].tc_sd <= 1.25 * f0.gm[0].tc_sd;
    std::printf("seed %llu: sigma/tc ref %.4g/%.4g (sd %.3g/%.3g, chi2 %.1f/%d), known %.4g/%.4g (sd %.3g/%.3g, chi2 "
                "%.1f/%d, A %.4g), unknown %.4g/%.4g (chi2 %.3g/%d)\n",
                static_cast<unsigned long long>(seed), f0.gm[0].sigma, f0.gm[0].tc, f0.gm[0].sigma_sd, f0.gm[0].tc_sd,
                f0.chi2, f0.dof, fk.gm[0].sigma, fk.gm[0].tc, fk.gm[0].sigma_sd, fk.gm[0].tc_sd, fk.chi2, fk.dof,
                std::sqrt(fk.known[0].c), fu.gm[0].sigma, fu.gm[0].tc, fu.chi2, fu.dof);
  }
  EXPECT_GE(ref_ok, 6);
  EXPECT_GE(known_ok, 6);
  EXPECT_EQ(sd_close, 8);
  EXPECT_EQ(unknown_rejected, 8);
  EXPECT_EQ(unknown_ok, 0);  // measured: sigma +43..49 %, tc -12..-19 % without the known term
}

// The simulated narrowband known term (a Gaussian process by inverse FFT, simulateGmwmFit) has the WV the fit uses
// (c sum_i w_i sinusoidAvar(2^(j-1) tau0, f_i, tau0) / 2) and the variance c / 2: 40 records of 2^15 samples of white
// noise plus a 1.5-Hz-wide band at 20 Hz (weights a triangle over 24 bins); the mean WV of each level within 3
// standard errors of the records' scatter (+ 1 %), and the mean variance within 3 standard errors.
TEST(GmwmKnownTerms, SimulatedNarrowbandHasTheModelWaveletVariance) {
  const double tau0 = 0.01, s2 = 1e-6, c = 2 * 4e-6;  // white variance per sample; band variance 4e-6
  GmwmKnownTerm k;
  k.type = "narrowband";
  k.spectrum_bin_hz = 1.5 / 24;
  double wsum = 0;
  for (int i = 0; i < 24; ++i) {
    k.spectrum_hz.push_back(20.0 - 0.75 + (i + 0.5) * k.spectrum_bin_hz);
    k.spectrum_weight.push_back(12.0 - std::fabs(i - 11.5));
    wsum += k.spectrum_weight.back();
  }
  for (auto& w : k.spectrum_weight) w /= wsum;
  const std::vector<double> fh = k.spectrum_hz, wt = k.spectrum_weight;
  k.basis = [fh, wt, tau0](double tau) {
    double s = 0;
    for (size_t i = 0; i < fh.size(); ++i) s += wt[i] * sinusoidAvar(tau, fh[i], tau0);
    return s;
  };
  k.c = c;
  GmwmFit fit;
  fit.model = parseGmwmModel("WN");
  fit.theta = Eigen::VectorXd::Constant(1, std::log(s2));
  fit.tau0 = tau0;
  fit.known = {k};
  const int R = 40, n = 1 << 15;
  std::vector<std::vector<double>> est;
  WaveletVariance wv;
  double vm = 0, vq = 0;
  for (int r = 0; r < R; ++r) {
    const std::vector<double> x = simulateGmwmFit(fit, tau0, n, 500 + r);
    double m = 0, q = 0;
    for (double v : x) m += v / n;
    for (double v : x) q += (v - m) * (v - m) / (n - 1);
    vm += q / R;
    vq += q * q;
    wv = haarWaveletVariance(x, tau0);
    est.push_back(wv.nu2);
  }
  const double vsd = std::sqrt((vq - R * vm * vm) / (R - 1) / R);
  EXPECT_NEAR(vm, s2 + c / 2, 3 * vsd);
  for (size_t j = 0; j < wv.nu2.size(); ++j) {
    double m = 0, q = 0;
    for (const auto& e : est) m += e[j] / R;
    for (const auto& e : est) q += (e[j] - m) * (e[j] - m) / (R - 1);
    const double model = gmwmModelWvAt(fit, tau0, wv.level[j]);
    EXPECT_NEAR(m / model, 1.0, 3 * std::sqrt(q / R) / model + 0.01) << "level " << wv.level[j];
  }
}
