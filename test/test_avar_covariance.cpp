// Tests of the analytic covariance of overlapping AVAR estimates: against a brute-force lag sum (integration
// accuracy), against the known variance of white-noise AVAR, and against Monte-Carlo covariances of simulated gyros.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <memory>
#include <string>
#include <thread>

#include "gyro_allan/allan.hpp"
#include "gyro_allan/avar_covariance.hpp"
#include "gyro_allan/noise_model.hpp"
#include "gyro_allan/simulate.hpp"

using namespace gyro_allan;

namespace {

// Brute force: sum over every integer lag of count(h) * (2 c(h)^2 + 4 mu mu' c(h)), c from the generalized covariance.
double bruteCov(int64_t m, int64_t mp, int64_t M, int64_t Mp, double tau0, const std::array<double, 5>& s) {
  const double w[3] = {1, -2, 1};
  auto gen = [&](double t) {  // generalized covariance of the angle at lag t samples
    const double at = std::fabs(t) * tau0;
    double v = 0;
    if (t == 0) v += s[0];
    v += -0.5 * s[1] * at;
    if (at > 0) v += s[2] * at * at * std::log(at) / (2 * M_PI);
    v += s[3] * at * at * at / 12.0;
    return v;
  };
  const double tau = m * tau0, taup = mp * tau0;
  const double mumu = s[4] * tau * tau * taup * taup;
  long double sum = 0;
  for (int64_t h = -(M - 1); h <= Mp - 1; ++h) {
    double c = 0;
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) c += w[a] * w[b] * gen(static_cast<double>(a * m - b * mp - h));
    const double cnt = std::max<double>(0, std::min<double>(M, Mp - h) - std::max<double>(0, -h));
    sum += cnt * (2 * c * c + 4 * mumu * c);
  }
  return static_cast<double>(sum / (4 * tau * tau * taup * taup * M * Mp));
}

}  // namespace

TEST(AvarCovariance, MatchesBruteForceLagSum) {
  // Lags up to ~6000: the integration between knots must agree with the exact sum to 1e-3 for every term mix.
  const double tau0 = 0.01;
  const int64_t n = 6000;
  const std::vector<int64_t> m{1, 3, 16, 100, 700};
  std::vector<int64_t> M;
  for (int64_t k : m) M.push_back(n - 2 * k);
  const AvarCovarianceBasis basis = avarCovarianceBasis(m, M, tau0);
  const std::vector<std::array<double, 5>> mixes{
      {{1e-10, 0, 0, 0, 0}}, {{0, 4e-8, 0, 0, 0}}, {{0, 0, 1e-10, 0, 0}}, {{0, 0, 0, 1e-12, 0}},
      {{1e-10, 4e-8, 1e-10, 1e-12, 1e-14}}};
  for (const auto& s : mixes) {
    const Eigen::MatrixXd cov = avarCovariance(basis, s, 0.0);  // the brute force is Gaussian
    for (size_t i = 0; i < m.size(); ++i)
      for (size_t j = i; j < m.size(); ++j) {
        const double b = bruteCov(m[i], m[j], M[i], M[j], tau0, s);
        const double scale = std::sqrt(bruteCov(m[i], m[i], M[i], M[i], tau0, s) * bruteCov(m[j], m[j], M[j], M[j], tau0, s));
        EXPECT_NEAR(cov(static_cast<int>(i), static_cast<int>(j)), b, 1e-3 * scale)
            << "m=" << m[i] << "," << m[j] << " mix Q2=" << s[0] << " N2=" << s[1] << " B2=" << s[2] << " K2=" << s[3];
      }
  }
}

TEST(AvarCovariance, WhiteNoiseVarianceAtTauZero) {
  // White rate noise at m = 1: d_k = (y[k+1] - y[k]) tau0, avar = mean(d^2) / (2 tau0^2). With sigma_y^2 = N^2 / tau0,
  // Var(d_k^2) sums 2 Cov(d_k, d_l)^2 over l: lags 0 (4 s^2)^2... = 2 (4 + 1 + 1) sigma^4 tau0^4 per term (lags 0, +-1),
  // so Var(avar) = 12 sigma_y^4 / (4 M) for large M.
  const double tau0 = 0.005, n2 = 1e-6;
  const int64_t M = 100000;
  const AvarCovarianceBasis basis = avarCovarianceBasis({1}, {M}, tau0);
  const double sy2 = n2 / tau0;
  const double expect = 12.0 * sy2 * sy2 / (4.0 * M);
  EXPECT_NEAR(avarCovariance(basis, {{0, n2, 0, 0, 0}}, 0.0)(0, 0) / expect, 1.0, 2e-4);
}

namespace {

// Sample covariance of the oadev at averaging factors m over `reps` simulated records (seeds seed0, seed0 + 1, ...),
// and the term counts of those points.
struct MonteCarloAvar {
  Eigen::MatrixXd cov;
  std::vector<int64_t> terms;
  std::vector<Eigen::VectorXd> draws;  // each record's AVARs
};
MonteCarloAvar monteCarloAvar(const AxisNoise& noise, double rate, int64_t n, int reps, uint64_t seed0,
                              const std::vector<int64_t>& m) {
  const int np = static_cast<int>(m.size());
  std::vector<Eigen::VectorXd> draws;
  MonteCarloAvar r;
  DeviationOptions opt;
  opt.compute_edf = false;
  for (int k = 0; k < reps; ++k) {
    const std::vector<double> y = simulateAxis(noise, rate, n, seed0 + static_cast<uint64_t>(k));
    const DeviationCurve c = computeDeviationAt("oadev", y, InputKind::Rate, 1.0 / rate, m, opt);
    EXPECT_EQ(static_cast<int>(c.points.size()), np);
    Eigen::VectorXd v(np);
    for (int i = 0; i < np; ++i) v[i] = c.points[static_cast<size_t>(i)].var;
    draws.push_back(v);
    if (r.terms.empty())
      for (const auto& p : c.points) r.terms.push_back(p.n_terms);
  }
  Eigen::VectorXd mean = Eigen::VectorXd::Zero(np);
  for (const auto& d : draws) mean += d / reps;
  r.cov = Eigen::MatrixXd::Zero(np, np);
  for (const auto& d : draws) r.cov += (d - mean) * (d - mean).transpose() / (reps - 1);
  r.draws = std::move(draws);
  return r;
}

}  // namespace

TEST(AvarCovariance, MatchesMonteCarloOfSimulatedGyros) {
  // 300 simulated records of 8192 samples with N, K, B and dithered Q; the sample covariance of their AVARs at octave
  // taus must match the analytic one: variances within 25 % (the Monte-Carlo standard error of a variance from 300
  // draws is sqrt(2/300) = 8 %, 3 sigma), correlations within 0.2 (their standard error is <= 0.058).
  const double rate = 100, tau0 = 1.0 / rate;
  const int64_t n = 8192;
  const int reps = 300;
  AxisNoise noise;
  noise.quantization = 2e-6;
  noise.angle_random_walk = 2e-4;
  noise.bias_instability = 2e-5;
  noise.rate_random_walk = 5e-5;
  std::vector<int64_t> m;
  for (int64_t k = 1; k <= n / 8; k *= 2) m.push_back(k);
  const int np = static_cast<int>(m.size());
  const MonteCarloAvar mca = monteCarloAvar(noise, rate, n, reps, 5000, m);
  const Eigen::MatrixXd& mc = mca.cov;
  const std::vector<int64_t>& terms = mca.terms;
  const AvarCovarianceBasis basis = avarCovarianceBasis(m, terms, tau0);
  const std::array<double, 5> s{{noise.quantization * noise.quantization, noise.angle_random_walk * noise.angle_random_walk,
                                 noise.bias_instability * noise.bias_instability,
                                 noise.rate_random_walk * noise.rate_random_walk, 0}};
  const Eigen::MatrixXd an = avarCovariance(basis, s);
  for (int i = 0; i < np; ++i) {
    EXPECT_NEAR(mc(i, i) / an(i, i), 1.0, 0.25) << "variance at m=" << m[static_cast<size_t>(i)];
    for (int j = i + 1; j < std::min(np, i + 3); ++j) {
      const double rmc = mc(i, j) / std::sqrt(mc(i, i) * mc(j, j));
      const double ran = an(i, j) / std::sqrt(an(i, i) * an(j, j));
      EXPECT_NEAR(rmc, ran, 0.2) << "correlation m=" << m[static_cast<size_t>(i)] << "," << m[static_cast<size_t>(j)];
    }
  }
}

TEST(AvarCovariance, UniformQuantizationKurtosis) {
  // Quantization-dominated records (dithered pulse counter: uniform error). The fourth cumulant of uniform noise
  // lowers the scatter of the short-tau AVAR; the Monte-Carlo variance at m = 1, 2 must match the corrected
  // covariance within 20 % (400 draws: standard error 7 %), and the Gaussian formula must be further off.
  const double rate = 100, tau0 = 1.0 / rate;
  const int64_t n = 4096;
  const int reps = 400;
  AxisNoise noise;
  noise.quantization = 1e-5;
  noise.angle_random_walk = 1e-5;
  const std::vector<int64_t> m{1, 2};
  const MonteCarloAvar mca = monteCarloAvar(noise, rate, n, reps, 9000, m);
  const std::vector<int64_t>& terms = mca.terms;
  const AvarCovarianceBasis basis = avarCovarianceBasis(m, terms, tau0);
  const std::array<double, 5> s{{1e-10, 1e-10, 0, 0, 0}};
  const Eigen::MatrixXd uni = avarCovariance(basis, s), gauss = avarCovariance(basis, s, 0.0);
  const double mc[2] = {mca.cov(0, 0), mca.cov(1, 1)};
  for (int i = 0; i < 2; ++i) {
    EXPECT_NEAR(mc[i] / uni(i, i), 1.0, 0.2) << "m=" << m[static_cast<size_t>(i)];
    EXPECT_LT(std::fabs(mc[i] / uni(i, i) - 1.0), std::fabs(mc[i] / gauss(i, i) - 1.0)) << "m=" << m[static_cast<size_t>(i)];
  }
}

namespace {

// Every matrix of two bases equal bit for bit (memcmp: also the sign of zeros).
void expectSameBasis(const AvarCovarianceBasis& a, const AvarCovarianceBasis& b, const std::string& what) {
  ASSERT_EQ(a.m, b.m) << what;
  ASSERT_EQ(a.n_terms, b.n_terms) << what;
  auto same = [&](const Eigen::MatrixXd& x, const Eigen::MatrixXd& y, const std::string& name) {
    ASSERT_EQ(x.rows(), y.rows()) << what << " " << name;
    ASSERT_EQ(x.cols(), y.cols()) << what << " " << name;
    EXPECT_EQ(0, std::memcmp(x.data(), y.data(), sizeof(double) * static_cast<size_t>(x.size()))) << what << " " << name;
  };
  for (int p = 0; p < 4; ++p) {
    for (int q = 0; q < 4; ++q)
      same(a.G[static_cast<size_t>(p)][static_cast<size_t>(q)], b.G[static_cast<size_t>(p)][static_cast<size_t>(q)],
           "G" + std::to_string(p) + std::to_string(q));
    same(a.H[static_cast<size_t>(p)], b.H[static_cast<size_t>(p)], "H" + std::to_string(p));
  }
  same(a.K4, b.K4, "K4");
}

}  // namespace

TEST(AvarCovariance, SharedBasisEqualsDirectBuildForOverlappingPointSets) {
  // The shared basis copies the entries a kept basis has (same two points) and sums the rest: a superset, a subset,
  // a set with a changed term count and one with a different tau0 must all equal the direct build bit for bit.
  const double tau0 = 0.0025;
  const int64_t n = 200000;
  auto terms = [&](const std::vector<int64_t>& m) {
    std::vector<int64_t> t;
    for (int64_t k : m) t.push_back(n - 2 * k);
    return t;
  };
  const std::vector<int64_t> base{1, 2, 4, 8, 16, 32, 63, 126, 251, 501, 1000, 1995, 3981, 7943};
  std::vector<int64_t> super = base;
  super.push_back(15849);
  const std::vector<int64_t> sub(base.begin() + 3, base.end());
  const std::vector<int64_t> gapped{1, 4, 16, 63, 251, 1000, 3981, 15849, 31623};
  struct Case {
    std::vector<int64_t> m, n;
    double tau0;
    std::string what;
  };
  std::vector<int64_t> changed = terms(base);
  changed[5] -= 7;  // one point's term count differs (another record length): that point's entries are summed anew
  const std::vector<Case> cases{{base, terms(base), tau0, "base"},      {super, terms(super), tau0, "superset"},
                                {sub, terms(sub), tau0, "subset"},      {gapped, terms(gapped), tau0, "gapped"},
                                {base, changed, tau0, "changed count"}, {sub, terms(sub), 2 * tau0, "other tau0"},
                                {base, terms(base), tau0, "base again"}};
  for (const auto& c : cases) {
    const auto shared = sharedAvarCovarianceBasis(c.m, c.n, c.tau0);
    ASSERT_TRUE(shared);
    expectSameBasis(*shared, avarCovarianceBasis(c.m, c.n, c.tau0), c.what);
  }
  EXPECT_EQ(sharedAvarCovarianceBasis(base, terms(base), tau0), sharedAvarCovarianceBasis(base, terms(base), tau0));
  EXPECT_THROW(sharedAvarCovarianceBasis({}, {}, tau0), std::invalid_argument);
  EXPECT_THROW(sharedAvarCovarianceBasis({1, 2}, {10, 0}, tau0), std::invalid_argument);
}

TEST(AvarCovariance, SharedBasisConcurrentRequestsBuildOnce) {
  // Threads asking for the same new set at once sum its entries together and get the same object, equal to the
  // direct build.
  const double tau0 = 0.001;
  const std::vector<int64_t> m{1, 3, 9, 27, 81, 243, 729, 2187, 6561, 19683};
  std::vector<int64_t> nt;
  for (int64_t k : m) nt.push_back(500000 - 2 * k);
  std::vector<std::shared_ptr<const AvarCovarianceBasis>> got(4);
  std::vector<std::thread> pool;
  for (size_t t = 0; t < got.size(); ++t) pool.emplace_back([&, t] { got[t] = sharedAvarCovarianceBasis(m, nt, tau0); });
  for (auto& th : pool) th.join();
  for (const auto& g : got) EXPECT_EQ(g, got[0]);
  expectSameBasis(*got[0], avarCovarianceBasis(m, nt, tau0), "concurrent");
}

