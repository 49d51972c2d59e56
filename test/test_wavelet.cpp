// Tests of the wavelet engine: filter-bank identities, PyWavelets fixtures (dwt/idwt/wavedec/waverec/swt/iswt, 4 modes),
// MATLAB-style threshold rules, and wden's exact split (denoised + removed = input) with the removed-angle check.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <map>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "gyro_allan/wavelet.hpp"

using namespace gyro_allan;

namespace {

using Fixtures = std::map<std::string, std::vector<double>>;

const Fixtures& fixtures() {
  static const Fixtures f = [] {
    Fixtures m;
    const std::string path = std::string(GYRO_ALLAN_SOURCE_DIR) + "/test/fixtures/wavelet/pywt_reference.txt";
    std::ifstream in(path);
    if (!in) throw std::runtime_error("cannot open " + path);
    std::string line;
    while (std::getline(in, line)) {
      if (line.empty() || line[0] == '#') continue;
      std::istringstream ls(line);
      std::string key;
      size_t count = 0;
      ls >> key >> count;
      std::vector<double> v(count);
      for (size_t i = 0; i < count; ++i) ls >> v[i];
      if (!ls) throw std::runtime_error("bad fixture line for " + key);
      m[key] = std::move(v);
    }
    return m;
  }();
  return f;
}

const std::vector<double>& fx(const std::string& key) {
  auto it = fixtures().find(key);
  if (it == fixtures().end()) throw std::runtime_error("missing fixture " + key);
  return it->second;
}

bool has(const std::string& key) { return fixtures().count(key) > 0; }

void expectNear(const std::vector<double>& got, const std::vector<double>& want, double tol, const std::string& what) {
  ASSERT_EQ(got.size(), want.size()) << what;
  double worst = 0;
  for (size_t i = 0; i < got.size(); ++i) worst = std::max(worst, std::fabs(got[i] - want[i]));
  EXPECT_LE(worst, tol) << what;
}

const std::vector<std::string> kFixtureWavelets = {"haar", "db4", "sym8", "coif3"};
const std::vector<std::string> kModes = {"symmetric", "periodization", "zero", "periodic"};
const std::vector<std::string> kSignals = {"s16", "s37", "s64", "s101"};
constexpr double kTol = 1e-12;  // against PyWavelets' own output
// Perfect reconstruction is limited by the table's orthonormality (~5e-12 for some filters) times |x| (<= ~15).
constexpr double kTolPr = 1e-10;

}  // namespace

TEST(WaveletFilters, AllNamesPresent) {
  EXPECT_EQ(waveletNames().size(), 1u + 20u + 19u + 5u);
  for (int i = 1; i <= 20; ++i) EXPECT_TRUE(isWaveletName("db" + std::to_string(i)));
  for (int i = 2; i <= 20; ++i) EXPECT_TRUE(isWaveletName("sym" + std::to_string(i)));
  for (int i = 1; i <= 5; ++i) EXPECT_TRUE(isWaveletName("coif" + std::to_string(i)));
  EXPECT_TRUE(isWaveletName("haar"));
  EXPECT_FALSE(isWaveletName("db21"));
  EXPECT_THROW(Wavelet("bior2.2"), std::invalid_argument);
  EXPECT_EQ(Wavelet("db4").dec_len(), 8);
  EXPECT_EQ(Wavelet("sym8").dec_len(), 16);
  EXPECT_EQ(Wavelet("coif3").dec_len(), 18);
  EXPECT_EQ(Wavelet("db20").dec_len(), 40);
}

TEST(WaveletFilters, OrthonormalityAndVanishingMoments) {
  for (const auto& name : waveletNames()) {
    const Wavelet w(name);
    const auto& h = w.rec_lo;
    const int L = w.dec_len();
    double s = 0, s2 = 0;
    for (double v : h) {
      s += v;
      s2 += v * v;
    }
    // pywt's published tables are exact only to ~1.5e-11 for a few filters (sym3, sym16-sym20): tolerance 3e-11.
    EXPECT_NEAR(s, std::sqrt(2.0), 3e-11) << name;
    EXPECT_NEAR(s2, 1.0, 3e-11) << name;
    // Double-shift orthogonality: sum_k h[k] h[k + 2m] = 0 for m != 0.
    for (int m = 1; 2 * m < L; ++m) {
      double c = 0;
      for (int k = 0; k + 2 * m < L; ++k) c += h[k] * h[k + 2 * m];
      EXPECT_NEAR(c, 0.0, 3e-11) << name << " shift " << 2 * m;
    }
    // Wavelet filter g = rec_hi: sum_k k^p g[k] = 0 for p < vanishing moments (normalised by L^p).
    ASSERT_GT(w.vanishing_moments_psi, 0) << name;
    for (int p = 0; p < w.vanishing_moments_psi; ++p) {
      double mom = 0, scale = 0;
      for (int k = 0; k < L; ++k) {
        const double kp = std::pow(static_cast<double>(k), p);
        mom += kp * w.rec_hi[k];
        scale += kp * std::fabs(w.rec_hi[k]);
      }
      EXPECT_LE(std::fabs(mom) / scale, 1e-9) << name << " moment " << p;
    }
    // Relations between the four filters (pywt's layout).
    for (int k = 0; k < L; ++k) {
      EXPECT_DOUBLE_EQ(w.dec_lo[k], h[L - 1 - k]);
      EXPECT_DOUBLE_EQ(w.dec_hi[k], w.rec_hi[L - 1 - k]);
    }
  }
}

TEST(WaveletFilters, PublishedDb2Values) {
  // Daubechies' D4 scaling filter: (1 + sqrt3, 3 + sqrt3, 3 - sqrt3, 1 - sqrt3) / (4 sqrt2).
  const double r3 = std::sqrt(3.0), d = 4 * std::sqrt(2.0);
  const Wavelet w("db2");
  const std::vector<double> want = {(1 + r3) / d, (3 + r3) / d, (3 - r3) / d, (1 - r3) / d};
  expectNear(w.rec_lo, want, 1e-15, "db2");
}

TEST(WaveletLevels, MaxLevelsMatchPywt) {
  int checked = 0;
  for (const auto& kv : fixtures()) {
    const std::string& key = kv.first;
    if (key.rfind("dwt_max_level/", 0) == 0) {
      long long n;
      int f;
      ASSERT_EQ(std::sscanf(key.c_str(), "dwt_max_level/%lld/%d", &n, &f), 2);
      EXPECT_EQ(dwt_max_level(n, f), static_cast<int>(kv.second[0])) << key;
      ++checked;
    } else if (key.rfind("swt_max_level/", 0) == 0) {
      long long n;
      ASSERT_EQ(std::sscanf(key.c_str(), "swt_max_level/%lld", &n), 1);
      EXPECT_EQ(swt_max_level(n), static_cast<int>(kv.second[0])) << key;
      ++checked;
    }
  }
  EXPECT_GT(checked, 50);
  EXPECT_THROW(dwt_max_level(0, 8), std::invalid_argument);
}

TEST(WaveletDwt, WavedecMatchesPywtAllModesAndLevels) {
  int cases = 0;
  for (const auto& wn : kFixtureWavelets) {
    const Wavelet w(wn);
    for (const auto& mn : kModes) {
      const ExtensionMode mode = parseExtensionMode(mn);
      for (const auto& sn : kSignals) {
        const auto& x = fx("signal/" + sn);
        for (int level = 1;; ++level) {
          const std::string base = "wavedec/" + wn + "/" + mn + "/" + sn + "/L" + std::to_string(level);
          if (!has(base + "/c0")) break;
          const auto coeffs = wavedec(x, w, mode, level);
          ASSERT_EQ(coeffs.size(), static_cast<size_t>(level + 1)) << base;
          for (int i = 0; i <= level; ++i) expectNear(coeffs[i], fx(base + "/c" + std::to_string(i)), kTol, base);
          // waverec of scaled coefficients (not the identity) against pywt.waverec.
          auto scaled = coeffs;
          for (size_t k = 0; k < scaled.size(); ++k)
            for (auto& v : scaled[k]) v *= 1.0 + 0.1 * static_cast<double>(k);
          const std::string rk = "waverec/" + wn + "/" + mn + "/" + sn + "/L" + std::to_string(level);
          expectNear(waverec(scaled, w, mode), fx(rk), kTol, rk);
          // Perfect reconstruction (odd lengths: pywt returns one extra sample for periodization).
          const auto back = waverec(coeffs, w, mode);
          ASSERT_GE(back.size(), x.size());
          for (size_t i = 0; i < x.size(); ++i) EXPECT_NEAR(back[i], x[i], kTolPr) << base;
          ++cases;
        }
      }
    }
  }
  EXPECT_GE(cases, 60);
}

TEST(WaveletDwt, IdwtMatchesPywtOnRandomCoefficients) {
  int cases = 0;
  for (const auto& wn : kFixtureWavelets) {
    const Wavelet w(wn);
    for (const auto& mn : kModes) {
      for (int k = 1; k < 40; ++k) {
        const std::string base = "idwt/" + wn + "/" + mn + "/K" + std::to_string(k);
        if (!has(base + "/a")) continue;
        expectNear(idwt(fx(base + "/a"), fx(base + "/d"), w, parseExtensionMode(mn)), fx(base + "/x"), kTol, base);
        ++cases;
      }
    }
  }
  EXPECT_EQ(cases, 4 * 4 * 2 - 0);
}

TEST(WaveletDwt, CoefficientLengths) {
  const Wavelet w("sym8");
  for (int64_t n : {1, 2, 15, 16, 17, 100, 101}) {
    for (const auto& mn : kModes) {
      const auto mode = parseExtensionMode(mn);
      const auto c = dwt(std::vector<double>(n, 1.0), w, mode);
      EXPECT_EQ(static_cast<int64_t>(c.cA.size()), dwt_coeff_len(n, 16, mode)) << n << " " << mn;
    }
  }
  EXPECT_EQ(dwt_coeff_len(101, 16, ExtensionMode::Symmetric), 58);
  EXPECT_EQ(dwt_coeff_len(101, 16, ExtensionMode::Periodization), 51);
}

TEST(WaveletSwt, MatchesPywt) {
  int cases = 0;
  for (const auto& wn : kFixtureWavelets) {
    const Wavelet w(wn);
    for (const std::string sn : {"s16", "s64"}) {
      const auto& x = fx("signal/" + sn);
      for (int level = 1; level <= 3; ++level) {
        const std::string base = "swt/" + wn + "/" + sn + "/L" + std::to_string(level);
        if (!has(base + "/a0")) continue;
        const auto c = swt(x, w, level);
        ASSERT_EQ(c.size(), static_cast<size_t>(level));
        for (int i = 0; i < level; ++i) {
          expectNear(c[i].cA, fx(base + "/a" + std::to_string(i)), kTol, base);
          expectNear(c[i].cD, fx(base + "/d" + std::to_string(i)), kTol, base);
        }
        auto scaled = c;
        for (size_t i = 0; i < scaled.size(); ++i) {
          for (auto& v : scaled[i].cA) v *= 1.0 + 0.1 * static_cast<double>(i);
          for (auto& v : scaled[i].cD) v *= 1.0 - 0.05 * static_cast<double>(i);
        }
        const std::string ik = "iswt/" + wn + "/" + sn + "/L" + std::to_string(level);
        expectNear(iswt(scaled, w), fx(ik), kTol, ik);
        expectNear(iswt(c, w), x, kTolPr, base + " perfect reconstruction");
        ++cases;
      }
    }
  }
  EXPECT_EQ(cases, 4 * (3 + 3));
  EXPECT_THROW(swt(std::vector<double>(12, 0.0), Wavelet("db2"), 3), std::invalid_argument);
}

TEST(WaveletThreshold, RulesMatchReference) {
  for (const std::string vn : {"v40", "v200sparse", "v1000", "v20"}) {
    const auto& v = fx("thr_input/" + vn);
    for (const std::string rule : {"sqtwolog", "rigrsure", "heursure", "minimaxi"}) {
      EXPECT_NEAR(thselect(v, parseThresholdRule(rule)), fx("thselect/" + rule + "/" + vn)[0], 1e-12)
          << rule << " " << vn;
    }
    for (const std::string t : {"0.5", "1.2"}) {
      for (const std::string m : {"soft", "hard"}) {
        const auto& want = fx("wthresh/" + m + "/" + t + "/" + vn);
        std::vector<double> got(v.size());
        for (size_t i = 0; i < v.size(); ++i) got[i] = wthresh(v[i], parseThresholdMode(m), std::stod(t));
        expectNear(got, want, 1e-15, "wthresh " + m + " " + t + " " + vn);
      }
    }
  }
  // Known values: sqtwolog of n = 1000 is sqrt(2 ln 1000); minimaxi 0 for n <= 32.
  EXPECT_NEAR(thselect(std::vector<double>(1000, 0.0), ThresholdRule::Sqtwolog), 3.7169221888498383, 1e-12);
  EXPECT_EQ(thselect(std::vector<double>(32, 1.0), ThresholdRule::Minimaxi), 0.0);
  EXPECT_THROW(thselect({}, ThresholdRule::Rigrsure), std::invalid_argument);
  EXPECT_THROW(parseThresholdRule("bayes"), std::invalid_argument);
  EXPECT_THROW(parseExtensionMode("smooth"), std::invalid_argument);
}

TEST(WaveletThreshold, WnoisestIsRobustSigma) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> g(0.0, 2.5);
  std::vector<double> d(200000);
  for (auto& v : d) v = g(rng);
  d[0] = 1e6;  // an outlier changes nothing
  EXPECT_NEAR(wnoisest(d), 2.5, 2.5 * 0.01);
  EXPECT_NEAR(wnoisest({1.0, -3.0, 2.0, 4.0}), 2.5 / 0.6745, 1e-12);
}

TEST(WaveletDenoise, SplitIsExactForEveryRuleAndScaling) {
  std::mt19937_64 rng(11);
  std::normal_distribution<double> g(0.0, 1.0);
  const int n = 5001;  // odd on purpose
  std::vector<double> x(n);
  for (int i = 0; i < n; ++i) x[i] = std::sin(2 * M_PI * i / 500.0) + (i > 2500 ? 2.0 : 0.0) + 0.3 * g(rng);
  for (const std::string rule : {"sqtwolog", "rigrsure", "heursure", "minimaxi"}) {
    for (const std::string mode : {"soft", "hard"}) {
      for (const std::string scal : {"one", "sln", "mln", "sln_rms"}) {
        for (const std::string ext : {"symmetric", "periodization"}) {
          WdenOptions o;
          o.rule = parseThresholdRule(rule);
          o.mode = parseThresholdMode(mode);
          o.scaling = parseNoiseScaling(scal);
          o.extension = parseExtensionMode(ext);
          o.level = 5;
          const auto r = wden(x, o);
          ASSERT_EQ(r.denoised.size(), x.size());
          ASSERT_EQ(r.removed.size(), x.size());
          double worst = 0;
          for (int i = 0; i < n; ++i) worst = std::max(worst, std::fabs(r.denoised[i] + r.removed[i] - x[i]));
          EXPECT_LE(worst, 1e-10) << rule << " " << mode << " " << scal << " " << ext;
          EXPECT_EQ(r.thresholds.size(), 5u);
        }
      }
    }
  }
}

TEST(WaveletDenoise, RemovedByDifferenceEqualsTheReconstruction) {
  // The long-record option (removed = input - denoised) against waverec of the removed coefficients: equal to 1e-12
  // of the signal, denoised part identical.
  std::mt19937_64 rng(12);
  std::normal_distribution<double> g(0.0, 1.0);
  std::vector<double> x(20001);
  for (size_t i = 0; i < x.size(); ++i) x[i] = 5.0 + 0.01 * std::sin(0.003 * i) + g(rng);
  for (const std::string ext : {"symmetric", "periodization"}) {
    WdenOptions o;
    o.level = 6;
    o.extension = parseExtensionMode(ext);
    const WdenResult a = wden(x, o);
    o.removed_by_difference = true;
    const WdenResult b = wden(x, o);
    ASSERT_EQ(a.removed.size(), b.removed.size());
    EXPECT_EQ(a.denoised, b.denoised);
    for (size_t i = 0; i < x.size(); ++i) EXPECT_NEAR(a.removed[i], b.removed[i], 1e-12 * 5.0) << ext << " " << i;
  }
}

TEST(WaveletDenoise, DenoisesAKnownSignal) {
  // Blocky signal + white noise sigma 0.2: sqtwolog/sln must estimate sigma and reduce the error a lot.
  std::mt19937_64 rng(3);
  std::normal_distribution<double> g(0.0, 0.2);
  const int n = 4096;
  std::vector<double> truth(n), x(n);
  for (int i = 0; i < n; ++i) {
    truth[i] = std::sin(2 * M_PI * i / 1024.0) + (i > 2000 && i < 2600 ? 1.0 : 0.0);
    x[i] = truth[i] + g(rng);
  }
  WdenOptions o;
  o.level = 6;
  const auto r = wden(x, o);
  EXPECT_NEAR(r.noise_sigma[0], 0.2, 0.2 * 0.05);
  EXPECT_NEAR(r.thresholds[0], 0.2 * std::sqrt(2 * std::log(4096.0 + 5 * 15 + 60)), 0.2 * 0.3);  // ~ sigma*sqrt(2ln n)
  double e_in = 0, e_out = 0;
  for (int i = 0; i < n; ++i) {
    e_in += (x[i] - truth[i]) * (x[i] - truth[i]);
    e_out += (r.denoised[i] - truth[i]) * (r.denoised[i] - truth[i]);
  }
  EXPECT_LT(e_out, 0.2 * e_in);
}

TEST(WaveletDenoise, RemovedQuantizationAngleIsBoundedAndZeroMean) {
  // RLG-like rate: pulse counter on angle (weight q) with subtractive dither + slow ARW. The removed fine-scale part
  // integrates to the angle quantization error: bounded by ~q, zero-mean, std ~ q/sqrt(12) = Q.
  std::mt19937_64 rng(5);
  std::normal_distribution<double> g(0.0, 1.0);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double tau0 = 0.01, Q = 1.7e-6, q = Q * std::sqrt(12.0), N = 1e-6;
  const int n = 200000;
  std::vector<double> rate(n);
  double theta = 0, prev_count = 0;
  for (int i = 0; i < n; ++i) {
    theta += N * std::sqrt(tau0) * g(rng);
    const double d = u(rng);
    const double count = q * (std::floor(theta / q + d) - d + 0.5);  // subtractive dither: error uniform, white
    rate[i] = (count - prev_count) / tau0;
    prev_count = count;
  }
  WdenOptions o;
  o.level = 6;
  const auto r = wden(rate, o);
  const auto angle = removedAngle(r.removed, tau0);
  const auto s = angleErrorStats(angle);
  EXPECT_LT(s.max_abs, 1.2 * q);            // about the mean: the integration constant -e(0) is unknown
  EXPECT_LT(std::fabs(s.mean), 0.6 * q);    // that constant is the first sample's error, within +-q/2
  EXPECT_NEAR(s.std, Q, 0.1 * Q);
  EXPECT_LT(s.half_mean_ratio, 0.1);        // no drift between the halves
  // Without the wavelet split the integral of the whole rate is the wandering true angle (not bounded).
  const auto whole = angleErrorStats(removedAngle(rate, tau0));
  EXPECT_GT(whole.std, 5 * Q);
  EXPECT_THROW(removedAngle(r.removed, 0.0), std::invalid_argument);
}

TEST(WaveletErrors, BadInputThrows) {
  const Wavelet w("db4");
  EXPECT_THROW(dwt({}, w, ExtensionMode::Symmetric), std::invalid_argument);
  EXPECT_THROW(idwt({1, 2}, {1}, w, ExtensionMode::Symmetric), std::invalid_argument);
  EXPECT_THROW(idwt({1, 2}, {1, 2}, w, ExtensionMode::Symmetric), std::invalid_argument);  // too short for F = 8
  EXPECT_THROW(waverec({{1, 2, 3}, {1}}, w, ExtensionMode::Symmetric), std::invalid_argument);
  EXPECT_THROW(wavedec({1.0, std::nan("")}, w, ExtensionMode::Symmetric), std::invalid_argument);
  EXPECT_THROW(wden({1.0}, WdenOptions{}), std::invalid_argument);
  EXPECT_THROW(parseNoiseScaling("xyz"), std::invalid_argument);
}

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
