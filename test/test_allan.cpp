// Unit tests of the Allan-family deviations: tau grids, rate/angle equivalence, gap-free segments, numerical
// soundness on 1e7 samples, noise identification, EDF coverage, chi-squared quantiles and input validation.
#include <gtest/gtest.h>

#include "series_util.hpp"

#include <cmath>
#include <random>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "gyro_allan/allan.hpp"

using namespace gyro_allan;

namespace {

std::vector<double> whiteNoise(size_t n, double sigma, uint64_t seed, double mean = 0) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> nd(0.0, sigma);
  std::vector<double> v(n);
  for (auto& x : v) x = mean + nd(rng);
  return v;
}

/// Exact modified Allan variance of unit white rate noise (tau0 = 1): the mvar term is a weighted sum of the
/// rates; sum its squared weights.
double whiteFmMvar(int64_t m) {
  std::vector<double> w(3 * m, 0.0);
  for (int64_t i = 0; i < m; ++i)
    for (int64_t k = 0; k < m; ++k) {
      w[i + 2 * m - m + k] += 1;  // + y over [i+m, i+2m)
      w[i + k] -= 1;              // - y over [i, i+m)
    }
  double s = 0;
  for (double v : w) s += v * v;
  return s / (2.0 * m * m * m * m);
}

// ------------------------------------------------------------------------------------------------ grids
TEST(AllanGrid, OctaveDecadeAllLog) {
  TauGrid g;
  g.kind = TauGridKind::Octave;
  EXPECT_EQ(tauGridFactors(g, 100), (std::vector<int64_t>{1, 2, 4, 8, 16, 32, 64}));
  EXPECT_EQ(tauGridFactors(g, 64).back(), 64);
  g.kind = TauGridKind::Decade;
  EXPECT_EQ(tauGridFactors(g, 500), (std::vector<int64_t>{1, 2, 4, 10, 20, 40, 100, 200, 400}));
  g.kind = TauGridKind::All;
  EXPECT_EQ(tauGridFactors(g, 5), (std::vector<int64_t>{1, 2, 3, 4, 5}));
  EXPECT_TRUE(tauGridFactors(g, 0).empty());
  g.kind = TauGridKind::Log;
  g.per_decade = 10;
  const auto ms = tauGridFactors(g, 1000);
  EXPECT_EQ(ms.front(), 1);
  EXPECT_EQ(ms.back(), 1000);
  for (size_t i = 1; i < ms.size(); ++i) EXPECT_GT(ms[i], ms[i - 1]);
  // 10 per decade: 1,2,3,4,5,6,8 in the first decade (1.26,1.58,... rounded and made unique), 10 per later
  // decade, then 1000
  EXPECT_EQ(ms.size(), 7u + 10u + 10u + 1u);
  g.per_decade = 3;
  EXPECT_EQ(tauGridFactors(g, 100), (std::vector<int64_t>{1, 2, 5, 10, 22, 46, 100}));
}

TEST(AllanGrid, ParseAndName) {
  TauGrid g;
  std::string err;
  for (const std::string s : {"octave", "decade", "all", "log:7"}) {
    ASSERT_TRUE(parseTauGrid(s, &g, &err)) << s;
    EXPECT_EQ(tauGridName(g), s);
  }
  ASSERT_TRUE(parseTauGrid("log", &g, &err));
  EXPECT_EQ(g.kind, TauGridKind::Log);
  EXPECT_EQ(g.per_decade, 10);
  for (const std::string s : {"", "foo", "log:", "log:0", "log:x", "log:-3", "Octave"}) {
    err.clear();
    EXPECT_FALSE(parseTauGrid(s, &g, &err)) << s;
    EXPECT_FALSE(err.empty()) << s;
  }
}

TEST(AllanGrid, MaxFactorPerDeviation) {
  EXPECT_EQ(deviationMaxFactor("oadev", 1001), 500);
  EXPECT_EQ(deviationMaxFactor("adev", 1001), 500);
  EXPECT_EQ(deviationMaxFactor("hdev", 1001), 333);
  EXPECT_EQ(deviationMaxFactor("ohdev", 1001), 333);
  EXPECT_EQ(deviationMaxFactor("mdev", 1001), 333);
  EXPECT_EQ(deviationMaxFactor("tdev", 1001), 333);
  EXPECT_EQ(deviationMaxFactor("totdev", 1001), 1000);
  EXPECT_EQ(deviationMaxFactor("mtotdev", 1001), 333);
  EXPECT_EQ(deviationMaxFactor("ttotdev", 1001), 333);
  // the largest factor of each grid has at least one term
  const auto y = whiteNoise(1000, 1.0, 3);
  DeviationOptions opt;
  opt.grid.kind = TauGridKind::All;
  opt.compute_edf = false;
  for (const auto& name : deviationNames()) {
    const auto c = computeDeviation(name, y, InputKind::Rate, 1.0, opt);
    ASSERT_FALSE(c.points.empty()) << name;
    EXPECT_EQ(c.points.back().m, deviationMaxFactor(name, 1001)) << name;
    EXPECT_GE(c.points.back().n_terms, 1) << name;
  }
}

// ------------------------------------------------------------------------------------------------ phase
TEST(AllanPhase, RateToAngleRemovesMean) {
  const std::vector<double> y = {1.0, 2.0, 3.0, 6.0};
  const auto x = rateToAngle(y, 0.5);
  ASSERT_EQ(x.size(), 5u);
  EXPECT_EQ(x[0], 0.0);
  // mean 3: increments (-2,-1,0,3)*0.5
  EXPECT_DOUBLE_EQ(x[1], -1.0);
  EXPECT_DOUBLE_EQ(x[2], -1.5);
  EXPECT_DOUBLE_EQ(x[3], -1.5);
  EXPECT_NEAR(x[4], 0.0, 1e-15);
}

TEST(AllanPhase, RateAndAngleInputsAgree) {
  const double tau0 = 0.01;
  const auto y = whiteNoise(5000, 0.3, 11, 0.7);
  const auto x = gyro_allan_test::accumulatedAngle(y, tau0);  // no mean removal: a linear phase trend must not matter
  DeviationOptions opt;
  opt.grid.kind = TauGridKind::Octave;
  for (const auto& name : deviationNames()) {
    const auto a = computeDeviation(name, y, InputKind::Rate, tau0, opt);
    const auto b = computeDeviation(name, x, InputKind::Angle, tau0, opt);
    ASSERT_EQ(a.points.size(), b.points.size()) << name;
    ASSERT_GT(a.points.size(), 5u);
    EXPECT_EQ(a.n_phase, 5001);
    for (size_t i = 0; i < a.points.size(); ++i) {
      EXPECT_EQ(a.points[i].m, b.points[i].m);
      EXPECT_NEAR(a.points[i].dev / b.points[i].dev, 1.0, 1e-9) << name << " m=" << a.points[i].m;
      EXPECT_NEAR(a.points[i].tau, a.points[i].m * tau0, 1e-15);
      EXPECT_EQ(a.points[i].alpha, b.points[i].alpha) << name << " m=" << a.points[i].m;
    }
  }
}

// ------------------------------------------------------------------------------------------------ segments
TEST(AllanSegments, PoolsSumsAndNeverSpansAGap) {
  const auto a = whiteNoise(3000, 1.0, 21);
  auto b = whiteNoise(2000, 1.0, 22);
  for (auto& v : b) v += 50.0;  // a bias step across the gap: any difference spanning it would explode
  DeviationOptions opt;
  opt.grid.kind = TauGridKind::Octave;
  opt.compute_edf = false;
  for (const auto& name : deviationNames()) {
    const auto pooled = computeDeviation(name, std::vector<std::vector<double>>{a, b}, InputKind::Rate, 1.0, opt);
    const auto ca = computeDeviation(name, a, InputKind::Rate, 1.0, opt);
    const auto cb = computeDeviation(name, b, InputKind::Rate, 1.0, opt);
    EXPECT_EQ(pooled.n_phase, 3001 + 2001);
    ASSERT_EQ(pooled.points.size(), ca.points.size()) << name;  // grid follows the longest segment
    for (size_t i = 0; i < pooled.points.size(); ++i) {
      const auto& p = pooled.points[i];
      double sum = ca.points[i].var * ca.points[i].n_terms;
      int64_t n = ca.points[i].n_terms;
      for (const auto& q : cb.points)
        if (q.m == p.m) {
          sum += q.var * q.n_terms;
          n += q.n_terms;
        }
      EXPECT_EQ(p.n_terms, n) << name << " m=" << p.m;
      EXPECT_NEAR(p.var / (sum / n), 1.0, 1e-12) << name << " m=" << p.m;
      if (name != "tdev" && name != "ttotdev") {  // (time deviations are in phase units)
        EXPECT_LT(p.dev, 3.0) << name << " m=" << p.m;  // unit white noise: far below the step
      }
    }
    // The same data concatenated (gap ignored) is dominated by the step
    std::vector<double> joined = a;
    joined.insert(joined.end(), b.begin(), b.end());
    const auto cj = computeDeviationAt(name, joined, InputKind::Rate, 1.0, {1024}, opt);
    const auto cp = computeDeviationAt(name, std::vector<std::vector<double>>{a, b}, InputKind::Rate, 1.0, {1024}, opt);
    if (!cj.points.empty() && !cp.points.empty()) {
      EXPECT_GT(cj.points[0].dev, 5 * cp.points[0].dev) << name;
    }
  }
  // empty and too-short segments are ignored
  const auto c = computeDeviation("oadev", std::vector<std::vector<double>>{{}, {1.0}, a}, InputKind::Rate, 1.0, opt);
  const auto ca = computeDeviation("oadev", a, InputKind::Rate, 1.0, opt);
  ASSERT_EQ(c.points.size(), ca.points.size());
  for (size_t i = 0; i < c.points.size(); ++i) EXPECT_NEAR(c.points[i].dev, ca.points[i].dev, 1e-14);
}

// ------------------------------------------------------------------------------------------------ numerics
TEST(AllanNumerics, LargeBiasTenMillionSamples) {
  // 1e7 rate samples: bias 1e3 rad/s with 1e-6 rad/s noise (9 orders below). The reference is the same samples
  // with the bias subtracted exactly (Sterbenz), so only the algorithm can make them differ: long-double mean
  // removal and phase accumulation must keep every deviation to 1e-9.
  const size_t n = 10000000;
  const double bias = 1e3;
  auto biased = whiteNoise(n, 1e-6, 5, bias);
  std::vector<double> noise(biased);
  for (auto& v : noise) v -= bias;
  DeviationOptions opt;
  opt.grid.kind = TauGridKind::Octave;
  opt.compute_edf = false;
  const auto c0 = oadev(noise, 0.001, opt);
  const auto c1 = oadev(biased, 0.001, opt);
  ASSERT_EQ(c0.points.size(), c1.points.size());
  ASSERT_GE(c0.points.size(), 22u);
  double worst = 0;
  for (size_t i = 0; i < c0.points.size(); ++i) worst = std::max(worst, std::fabs(c1.points[i].dev / c0.points[i].dev - 1));
  EXPECT_LT(worst, 1e-9);
  // white rate noise: AVAR(m) = sigma^2 / (m tau0) * tau0 => adev = sigma / sqrt(m) within the sampling error
  for (const auto& p : c0.points)
    if (p.m <= 4096) {
      EXPECT_NEAR(p.dev * std::sqrt(static_cast<double>(p.m)) / 1e-6, 1.0, 0.05) << "m=" << p.m;
    }
  // mdev, ohdev, totdev, mtotdev on 1e6 of them (same check, cheaper)
  const std::vector<double> n6(noise.begin(), noise.begin() + 1000000), b6(biased.begin(), biased.begin() + 1000000);
  for (const std::string name : {"mdev", "ohdev", "totdev", "mtotdev"}) {
    const auto a = computeDeviationAt(name, n6, InputKind::Rate, 0.001, {1, 16, 1024}, opt);
    const auto b = computeDeviationAt(name, b6, InputKind::Rate, 0.001, {1, 16, 1024}, opt);
    for (size_t i = 0; i < a.points.size(); ++i)
      EXPECT_NEAR(b.points[i].dev / a.points[i].dev, 1.0, 1e-9) << name << " m=" << a.points[i].m;
  }
}

// ------------------------------------------------------------------------------------------------ mtotdev
/// The 6m terms of one window of the modified total variance, written out as NIST SP1065 eq. (27) and its text
/// describe it, independently of the library's prefix-sum form: the 3m-point subsequence sub = x(n..n+3m-1) has
/// its linear frequency drift removed (difference of the averages of its first and last halves, floor(3m/2)
/// points each, divided by the spacing of their centres, ceil(3m/2)) and is extended by uninverted even
/// reflection to 9m points; the terms are its 6m second differences of m-point averages. Linear in x.
std::vector<long double> mtotWindowTerms(const double* sub_x, int64_t m) {
  const int64_t L = 3 * m, half = L / 2;
  long double a1 = 0, a2 = 0;
  for (int64_t k = 0; k < half; ++k) {
    a1 += sub_x[k];
    a2 += sub_x[L - half + k];
  }
  const long double drift = (a2 / half - a1 / half) / ((L + 1) / 2);
  std::vector<long double> sub(L), ext(9 * m), terms(6 * m);
  for (int64_t k = 0; k < L; ++k) sub[k] = sub_x[k] - drift * k;
  for (int64_t k = 0; k < L; ++k) {
    ext[L + k] = sub[k];              // the subsequence in the middle
    ext[L - 1 - k] = sub[k];          // mirrored to the left (uninverted: x#(-1) = x(0))
    ext[2 * L + k] = sub[L - 1 - k];  // mirrored to the right
  }
  for (int64_t i = 0; i < 6 * m; ++i) {
    long double avg[3] = {0, 0, 0};
    for (int b = 0; b < 3; ++b)
      for (int64_t k = 0; k < m; ++k) avg[b] += ext[i + b * m + k] / m;
    terms[i] = avg[2] - 2 * avg[1] + avg[0];
  }
  return terms;
}

/// MTOTVAR = 1 / (2 tau^2 (N - 3m + 1)) sum over windows of 1/(6m) sum of the squared terms (long double).
long double mtotvarDirect(const std::vector<double>& x, int64_t m, double tau0) {
  const int64_t N = static_cast<int64_t>(x.size()), L = 3 * m;
  long double outer = 0;
  int64_t count = 0;
  for (int64_t n = 0; n + L <= N; ++n) {
    long double inner = 0;
    for (long double t : mtotWindowTerms(x.data() + n, m)) inner += t * t;
    outer += inner / (6 * m);
    ++count;
  }
  const long double tau = m * tau0;
  return outer / (2 * tau * tau * count);
}

/// Exact expectation of MTOTVAR for unit white rate noise (tau0 = 1): each term is a linear form sum_k a_k x_k
/// with sum a_k = 0, i.e. sum_k b_k y_k in the rates y_k = x_{k+1} - x_k with b_k = -(a_0 + ... + a_k), so its
/// mean square is sum b_k^2. The weights a come from the transcription applied to unit vectors.
double whiteFmMtotvar(int64_t m) {
  const int64_t L = 3 * m;
  std::vector<std::vector<long double>> a(L);  // a[t][j]: weight of x_t in term j
  std::vector<double> e(L, 0.0);
  for (int64_t t = 0; t < L; ++t) {
    e[t] = 1;
    a[t] = mtotWindowTerms(e.data(), m);
    e[t] = 0;
  }
  long double sum = 0;
  for (int64_t j = 0; j < 6 * m; ++j) {
    long double b = 0;
    for (int64_t k = 0; k + 1 < L; ++k) {
      b -= a[k][j];
      sum += b * b;
    }
  }
  return static_cast<double>(sum / (6 * m) / (2.0L * m * m));
}

TEST(AllanMtotdev, MatchesDirectTranscriptionOfSp1065) {
  // Random phase with a drift and a random walk (so detrending and the reflections matter), odd and even m up
  // to the largest factor N/3; rate input of the same data must agree too.
  std::mt19937_64 rng(77);
  std::normal_distribution<double> nd(0.0, 1.0);
  std::vector<double> x(301), y(300);
  double walk = 0;
  for (size_t i = 0; i < x.size(); ++i) {
    walk += 0.3 * nd(rng);
    x[i] = 5.0 + 0.02 * i + 1e-4 * i * i + walk + nd(rng);
  }
  const double tau0 = 0.5;
  for (size_t i = 0; i < y.size(); ++i) y[i] = (x[i + 1] - x[i]) / tau0;
  const std::vector<int64_t> ms = {1, 2, 3, 4, 5, 7, 8, 13, 16, 21, 32, 50, 64, 99, 100};
  DeviationOptions opt;
  opt.compute_edf = false;
  const auto a = computeDeviationAt("mtotdev", x, InputKind::Angle, tau0, ms, opt);
  const auto r = computeDeviationAt("mtotdev", y, InputKind::Rate, tau0, ms, opt);
  const auto t = computeDeviationAt("ttotdev", x, InputKind::Angle, tau0, ms, opt);
  ASSERT_EQ(a.points.size(), ms.size());
  ASSERT_EQ(r.points.size(), ms.size());
  ASSERT_EQ(t.points.size(), ms.size());
  for (size_t i = 0; i < ms.size(); ++i) {
    const int64_t m = ms[i];
    const double want = static_cast<double>(mtotvarDirect(x, m, tau0));
    EXPECT_NEAR(a.points[i].var / want, 1.0, 1e-12) << "m=" << m;
    EXPECT_NEAR(r.points[i].var / want, 1.0, 1e-12) << "rate input, m=" << m;
    EXPECT_EQ(a.points[i].n_terms, 301 - 3 * m + 1) << "m=" << m;
    // TTOTVAR = tau^2 / 3 MTOTVAR
    const double tau = m * tau0;
    EXPECT_NEAR(t.points[i].var / (tau * tau / 3 * want), 1.0, 1e-12) << "m=" << m;
  }
}

/// Same definition, quicker for long records (for the checks on 2e4 points): per window the 9m-point extension is
/// built explicitly and its m-point sums taken from its own prefix sums, in long double.
long double mtotvarExtensionSums(const std::vector<double>& x, int64_t m, double tau0) {
  const int64_t N = static_cast<int64_t>(x.size()), L = 3 * m, half = L / 2;
  long double outer = 0;
  std::vector<long double> ext(9 * m), pre(9 * m + 1);
  for (int64_t n = 0; n + L <= N; ++n) {
    long double a1 = 0, a2 = 0;
    for (int64_t k = 0; k < half; ++k) {
      a1 += x[n + k] - x[n];
      a2 += x[n + L - half + k] - x[n];
    }
    const long double drift = (a2 / half - a1 / half) / ((L + 1) / 2);
    for (int64_t k = 0; k < L; ++k) {
      const long double v = (x[n + k] - x[n]) - drift * k;
      ext[L + k] = v;
      ext[L - 1 - k] = v;
      ext[3 * L - 1 - k] = v;
    }
    pre[0] = 0;
    for (int64_t k = 0; k < 9 * m; ++k) pre[k + 1] = pre[k] + ext[k];
    long double inner = 0;
    for (int64_t i = 0; i < 6 * m; ++i) {
      const long double d2 = (pre[i + 3 * m] - pre[i + 2 * m]) - 2 * (pre[i + 2 * m] - pre[i + m]) + (pre[i + m] - pre[i]);
      inner += d2 * d2 / (static_cast<long double>(m) * m);
    }
    outer += inner / (6 * m);
  }
  const long double tau = m * tau0;
  return outer / (2 * tau * tau * (N - L + 1));
}

TEST(AllanMtotdev, LongRecordsAgainstExtensionSums) {
  // 2e4 points of random-walk FM with white FM and a frequency drift (the hardest case for the block prefix
  // sums: large phase excursions), m up to N/3; 1e-10 relative. And a bias step between two segments never
  // leaks in (pooled = combined per-segment sums).
  std::mt19937_64 rng(99);
  std::normal_distribution<double> nd(0.0, 1.0);
  std::vector<double> y(20000);
  double walk = 0;
  for (size_t i = 0; i < y.size(); ++i) {
    walk += 0.05 * nd(rng);
    y[i] = 3.0 + 1e-4 * i + walk + nd(rng);
  }
  const auto x = rateToAngle(y, 1.0);
  DeviationOptions opt;
  opt.compute_edf = false;
  const std::vector<int64_t> ms = {7, 23, 24, 100, 777, 6000, 6667};  // direct below m = 24, fold sums from 24
  const auto c = computeDeviationAt("mtotdev", x, InputKind::Angle, 1.0, ms, opt);
  ASSERT_EQ(c.points.size(), ms.size());
  for (size_t i = 0; i < ms.size(); ++i) {
    const double want = static_cast<double>(mtotvarExtensionSums(x, ms[i], 1.0));
    EXPECT_NEAR(c.points[i].var / want, 1.0, 1e-10) << "m=" << ms[i];
  }
}

TEST(AllanMtotdev, WhiteFmExpectation) {
  // White FM: MTOTVAR is not MVAR (at m = 1 it is exactly MVAR / 2: the detrended 3-point window reflects into
  // terms of half the energy; Stable32's PHASE.DAT table shows the same), so the truth is the exact expectation
  // of the estimator (whiteFmMtotvar). 2e5 samples: 1/sqrt(2 edf) <= 1.7 % up to m = 64, so 5 % is ~3 sd.
  const auto y = whiteNoise(200000, 1.0, 4242);
  DeviationOptions opt;
  opt.compute_edf = false;
  const std::vector<int64_t> ms = {1, 4, 16, 64};
  const auto c = computeDeviationAt("mtotdev", y, InputKind::Rate, 1.0, ms, opt);
  ASSERT_EQ(c.points.size(), ms.size());
  EXPECT_NEAR(whiteFmMtotvar(1) / whiteFmMvar(1), 0.5, 1e-12);
  for (size_t i = 0; i < ms.size(); ++i)
    EXPECT_NEAR(c.points[i].dev / std::sqrt(whiteFmMtotvar(ms[i])), 1.0, 0.05) << "m=" << ms[i];
}

// ------------------------------------------------------------------------------------------------ noise ID, EDF
TEST(AllanNoiseId, IdentifiesPowerLawNoises) {
  const size_t n = 200000;
  DeviationOptions opt;
  opt.grid.kind = TauGridKind::Octave;
  auto check = [&](const std::vector<double>& data, InputKind kind, int want, const char* what) {
    const auto c = computeDeviationAt("oadev", data, kind, 1.0, {1, 4, 16, 64, 256}, opt);
    for (const auto& p : c.points) EXPECT_EQ(p.alpha, want) << what << " m=" << p.m;
  };
  check(whiteNoise(n, 1.0, 31), InputKind::Rate, 0, "white FM (ARW)");
  check(whiteNoise(n, 1.0, 32), InputKind::Angle, 2, "white PM (quantization)");
  const auto steps = whiteNoise(n, 1.0, 33);
  std::vector<double> rw(n);
  double acc = 0;
  for (size_t i = 0; i < n; ++i) rw[i] = (acc += steps[i]);
  check(rw, InputKind::Rate, -2, "random-walk FM (RRW)");
}

TEST(AllanNoiseId, LongSpansUseSpreadBlocks) {
  // Above 2^17 decimated points the lag-1 ACF comes from 16 spread blocks: on 2^20 samples white FM (rate white),
  // white PM (angle white) and random-walk FM (rate a random walk) must still be told apart at the short factors
  // (m = 1..6, all on the block path), as on the full sequence.
  std::mt19937_64 rng(21);
  std::normal_distribution<double> g(0.0, 1.0);
  const size_t n = size_t(1) << 20;
  std::vector<double> white(n), pm(n), rw(n);
  double prev = g(rng), walk = 0;
  for (size_t i = 0; i < n; ++i) {
    white[i] = g(rng);
    const double e = g(rng);
    pm[i] = e - prev;  // rate = difference of a white angle error
    prev = e;
    walk += g(rng);
    rw[i] = walk;
  }
  DeviationOptions o;
  std::string err;
  ASSERT_TRUE(parseTauGrid("all", &o.grid, &err));
  const std::vector<int64_t> ms{1, 2, 3, 4, 5, 6};
  const std::pair<const std::vector<double>*, int> cases[] = {{&white, 0}, {&pm, 2}, {&rw, -2}};
  for (const auto& c : cases) {
    const DeviationCurve curve = computeDeviationAt("oadev", *c.first, InputKind::Rate, 1.0, ms, o);
    ASSERT_EQ(curve.points.size(), ms.size());
    for (const auto& p : curve.points) EXPECT_EQ(p.alpha, c.second) << "m=" << p.m;
  }
}

TEST(AllanEdf, ChiSquaredQuantiles) {
  EXPECT_NEAR(chi2Quantile(0.95, 1), 3.841458820694124, 1e-10);
  EXPECT_NEAR(chi2Quantile(0.5, 2), 2 * std::log(2.0), 1e-12);
  EXPECT_NEAR(chi2Quantile(0.025, 10), 3.246972780236841, 1e-10);
  EXPECT_NEAR(chi2Quantile(0.975, 10), 20.48317735080739, 1e-9);
  EXPECT_NEAR(chi2Quantile(0.8413447460685429, 1000) / 1044.9, 1.0, 1e-3);
  EXPECT_THROW(chi2Quantile(0.0, 3), std::invalid_argument);
  EXPECT_THROW(chi2Quantile(0.5, 0), std::invalid_argument);
}

// Published table values (NIST/SEMATECH e-Handbook 1.3.6.7.4, 3-5 significant digits): within half the last digit.
TEST(AllanEdf, ChiSquaredQuantilesMatchTables) {
  struct Row { double p, dof, x, half_ulp; };
  const Row rows[] = {
      {0.975, 1, 5.0239, 5e-5},  {0.975, 10, 20.483, 5e-4}, {0.025, 1, 0.000982, 5e-7},  {0.025, 10, 3.247, 5e-4},
      {0.95, 5, 11.070, 5e-4},   {0.05, 5, 1.145, 5e-4},    {0.99, 20, 37.566, 5e-4}, {0.01, 20, 8.260, 5e-4},
      {0.975, 100, 129.561, 5e-4}, {0.025, 100, 74.222, 5e-4}, {0.9, 2, 4.605, 5e-4},   {0.1, 2, 0.211, 5e-4},
  };
  for (const Row& r : rows) EXPECT_NEAR(chi2Quantile(r.p, r.dof), r.x, r.half_ulp) << "p " << r.p << " dof " << r.dof;
  // Closed forms: dof 2 is exponential with mean 2; dof 1 is a squared standard normal (z_0.975 = 1.959963984540054).
  EXPECT_NEAR(chi2Quantile(0.9, 2) / (-2 * std::log(0.1)), 1.0, 1e-12);
  EXPECT_NEAR(chi2Quantile(0.95, 1) / (1.959963984540054 * 1.959963984540054), 1.0, 1e-12);
  // The hand-written quantile this replaced (Newton on a series/continued fraction, Wilson-Hilferty above 2e6
  // degrees of freedom) agreed to 1e-12 relative for p in [1e-3, 0.999] and dof in [0.3, 1e5]; Wilson-Hilferty
  // at 2.5e6: within 1e-9.
  EXPECT_NEAR(chi2Quantile(0.025, 2.5e6) / 2495619.2818831271, 1.0, 1e-9);
  EXPECT_NEAR(chi2Quantile(0.975, 1234.5) / 1333.7689616466023, 1.0, 1e-12);
}

TEST(AllanEdf, GreenhallKnownValuesAndTrends) {
  // white PM, unmodified, overlapping, r = M/S > d: 1/edf = (a0 - a1/r)/M with a0 = 35/18, a1 = 1 (d = 2)
  const int64_t N = 10001, m = 10;
  const double M = N - 2 * m, r = M / m;
  EXPECT_NEAR(deviationEdf("oadev", 2, m, N), M / (35.0 / 18 - 1.0 / r), 1e-9 * M);
  // white FM, non-overlapping, m = 1 is the plain first-difference estimator of 999 terms (782.03, as allantools)
  EXPECT_NEAR(deviationEdf("adev", 0, 1, 1001), 782.03, 0.01);
  // totdev: equals oadev at m = 1 (same estimator), never above SP1065's 1.5 T/tau for white FM, and reaches it
  // at long tau
  EXPECT_NEAR(deviationEdf("totdev", 0, 1, 1001), deviationEdf("oadev", 0, 1, 1001), 1e-9);
  for (int64_t mm = 1; mm <= 1000; mm *= 3) EXPECT_LE(deviationEdf("totdev", 0, mm, 1001), 1.5 * 1000 / mm + 1e-9);
  EXPECT_NEAR(deviationEdf("totdev", 0, 400, 1001), 1.5 * 1000 / 400, 1e-9);
  // fewer dof at longer tau (white PM excepted: its overlapping EDF is nearly flat in m)
  for (const auto& name : deviationNames())
    for (int alpha = -2; alpha <= 1; ++alpha) {
      double prev = 1e300;
      for (int64_t mm = 1; mm <= 256; mm *= 2) {
        const double e = deviationEdf(name, alpha, mm, 100000);
        EXPECT_GT(e, 0) << name << " alpha " << alpha << " m " << mm;
        EXPECT_LE(e, prev * 1.0001) << name << " alpha " << alpha << " m " << mm;
        prev = e;
      }
    }
  // overlapping estimators never have fewer dof than the non-overlapping ones
  for (int alpha = -2; alpha <= 2; ++alpha)
    for (int64_t mm : {2, 8, 64}) {
      EXPECT_GE(deviationEdf("oadev", alpha, mm, 20000), deviationEdf("adev", alpha, mm, 20000) * 0.999);
      EXPECT_GE(deviationEdf("ohdev", alpha, mm, 20000), deviationEdf("hdev", alpha, mm, 20000) * 0.999);
    }
}

TEST(AllanEdf, ConfidenceIntervalCoverage) {
  // 400 records of white rate noise (known sigma): the 68.3 % interval must cover the true deviation ~68 % of
  // the time. m = 1, 8, 16 keep >= 125 decimated points so the noise ID is reliable; at m = 64 (31 points) the
  // lag-1 ACF misidentifies ~20 % of the records (coverage then drops to ~62 %), so there alpha is fixed to 0
  // to test the EDF itself.
  const int runs = 400;
  const std::vector<int64_t> ms = {1, 8, 16, 64};
  std::vector<double> mtot_truth;
  for (int64_t m : ms) mtot_truth.push_back(std::sqrt(whiteFmMtotvar(m)));
  for (const std::string name : {"oadev", "mdev", "ohdev", "totdev", "mtotdev"}) {
    std::vector<int> covered(ms.size(), 0);
    for (int r = 0; r < runs; ++r) {
      const auto y = whiteNoise(2000, 1.0, 1000 + r);
      DeviationOptions opt;
      auto c = computeDeviationAt(name, y, InputKind::Rate, 1.0, ms, opt);
      ASSERT_EQ(c.points.size(), ms.size());
      c.points.back().alpha = 0;
      fillConfidence(&c, opt.confidence);
      for (size_t i = 0; i < ms.size(); ++i) {
        const double m = static_cast<double>(ms[i]);
        // true white-FM values (sigma = 1, tau0 = 1): avar = hvar = totvar = 1/m; mvar and mtotvar from their
        // weights
        const double truth = name == "mdev"      ? std::sqrt(whiteFmMvar(ms[i]))
                             : name == "mtotdev" ? mtot_truth[i]
                                                 : 1.0 / std::sqrt(m);
        covered[i] += c.points[i].dev_lo <= truth && truth <= c.points[i].dev_hi;
      }
    }
    for (size_t i = 0; i < ms.size(); ++i) {
      const double frac = static_cast<double>(covered[i]) / runs;
      // binomial sd at 400 runs: 2.3 %; noise-ID errors (alpha) add a little
      EXPECT_NEAR(frac, 0.683, 0.08) << name << " m=" << ms[i];
      RecordProperty(name + "_coverage_m" + std::to_string(ms[i]), std::to_string(frac));
    }
  }
}

// ------------------------------------------------------------------------------------------------ validation
TEST(AllanValidation, BadInputsThrow) {
  const auto y = whiteNoise(100, 1.0, 1);
  DeviationOptions opt;
  EXPECT_THROW(computeDeviation("allan", y, InputKind::Rate, 1.0, opt), std::invalid_argument);
  EXPECT_THROW(computeDeviation("oadev", y, InputKind::Rate, 0.0, opt), std::invalid_argument);
  EXPECT_THROW(computeDeviation("oadev", y, InputKind::Rate, -1.0, opt), std::invalid_argument);
  EXPECT_THROW(computeDeviation("oadev", y, InputKind::Rate, std::nan(""), opt), std::invalid_argument);
  auto bad = y;
  bad[50] = std::nan("");
  EXPECT_THROW(computeDeviation("oadev", bad, InputKind::Rate, 1.0, opt), std::invalid_argument);
  bad[50] = INFINITY;
  EXPECT_THROW(computeDeviation("mdev", bad, InputKind::Angle, 1.0, opt), std::invalid_argument);
  EXPECT_THROW(computeDeviationAt("oadev", y, InputKind::Rate, 1.0, {0}, opt), std::invalid_argument);
  opt.confidence = 1.5;
  EXPECT_THROW(computeDeviation("oadev", y, InputKind::Rate, 1.0, opt), std::invalid_argument);
  EXPECT_THROW(deviationEdf("oadev", 3, 1, 100), std::invalid_argument);
  EXPECT_THROW(deviationEdf("nope", 0, 1, 100), std::invalid_argument);
  EXPECT_THROW(rateToAngle(y, 0.0), std::invalid_argument);
  // rateToAngle names the first non-finite sample; finite samples whose double sum overflows are not an error
  // (its mean falls back to long double): the phase of a constant 1e308 rate is flat.
  std::vector<double> r(3000, 1.0);
  r[2100] = -INFINITY;
  r[2500] = std::nan("");
  try {
    rateToAngle(r, 1.0);
    ADD_FAILURE() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("index 2100"), std::string::npos) << e.what();
  }
  const std::vector<double> huge(3000, 1e308);
  const auto xh = rateToAngle(huge, 1.0);
  ASSERT_EQ(xh.size(), 3001u);
  for (double v : xh) ASSERT_EQ(v, 0.0);
  // ... nor alternating +-1e308, whose double lanes overflow in both mean passes: the phase stays finite.
  std::vector<double> alt(3000, 0.0);
  for (size_t i = 0; i < alt.size(); i += 4) alt[i] = 1e308, alt[i + 1] = -1e308;
  for (double v : rateToAngle(alt, 1.0)) ASSERT_TRUE(std::isfinite(v));
  EXPECT_THROW(computeDeviation("mtotdev", bad, InputKind::Rate, 1.0, DeviationOptions{}), std::invalid_argument);
  EXPECT_FALSE(isDeviationName("allan"));
  EXPECT_TRUE(isDeviationName("totdev"));
  // too short to form any term: no points, no crash
  DeviationOptions ok;
  EXPECT_TRUE(computeDeviation("hdev", std::vector<double>{1.0, 2.0}, InputKind::Rate, 1.0, ok).points.empty());
  EXPECT_TRUE(computeDeviation("oadev", std::vector<double>{}, InputKind::Rate, 1.0, ok).points.empty());
}

}  // namespace

// catkin_add_gtest here links gtest without gtest_main.
int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
