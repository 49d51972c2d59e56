// Kalibr imu.yaml: axis rules, bounds, quality comment lines, and the units check that Allan N of discrete white noise
// is sigma_d*sqrt(dt).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <sstream>
#include <stdexcept>

#include <yaml-cpp/yaml.h>

#include "gyro_allan/analysis.hpp"
#include "gyro_allan/io/bag_input.hpp"
#include "gyro_allan/kalibr.hpp"

using namespace gyro_allan;

namespace {

Coefficient sup(double v) { return {v, 0.1 * v, true}; }
Coefficient bound(double b) { return {0, b, false}; }

}  // namespace

TEST(Kalibr, WorstAxisTakesLargestAndMarksBound) {
  const KalibrValue w = combineAxes({"x", "y", "z"}, {sup(1e-3), sup(3e-3), bound(2e-3)}, KalibrAxisRule::Worst);
  EXPECT_TRUE(w.present);
  EXPECT_DOUBLE_EQ(w.value, 3e-3);
  EXPECT_EQ(w.axis, "y");
  EXPECT_FALSE(w.bound);
  const KalibrValue b = combineAxes({"x", "y"}, {sup(1e-3), bound(5e-3)}, KalibrAxisRule::Worst);
  EXPECT_DOUBLE_EQ(b.value, 5e-3);
  EXPECT_TRUE(b.bound);
}

TEST(Kalibr, MeanRuleIsQuadraticMean) {
  const KalibrValue m = combineAxes({"x", "y", "z"}, {sup(1.0), sup(2.0), sup(2.0)}, KalibrAxisRule::Mean);
  EXPECT_NEAR(m.value, std::sqrt((1.0 + 4.0 + 4.0) / 3.0), 1e-12);
  EXPECT_FALSE(m.bound);
  EXPECT_TRUE(combineAxes({"x", "y"}, {sup(1.0), bound(0.5)}, KalibrAxisRule::Mean).bound);
  EXPECT_FALSE(combineAxes({}, {}, KalibrAxisRule::Mean).present);
  EXPECT_THROW(combineAxes({"x"}, {}, KalibrAxisRule::Mean), std::invalid_argument);
  EXPECT_THROW(parseKalibrAxisRule("max"), std::invalid_argument);
}

TEST(Kalibr, YamlHasKalibrKeysInSiAndCommentsBounds) {
  std::array<Coefficient, kNumTerms> g{{bound(1e-6), sup(2e-4), sup(1e-5), bound(3e-6), bound(1e-8)}};
  std::array<Coefficient, kNumTerms> a{{bound(1e-6), sup(1.5e-3), sup(1e-4), sup(4e-5), bound(1e-8)}};
  const KalibrParams p = kalibrParams({"x"}, {g}, {"accel_x"}, {a}, 200.0, "/imu0", KalibrAxisRule::Worst);
  const std::string text = kalibrYaml(p);
  const YAML::Node y = YAML::Load(text);
  EXPECT_EQ(y["rostopic"].as<std::string>(), "/imu0");
  EXPECT_DOUBLE_EQ(y["update_rate"].as<double>(), 200.0);
  EXPECT_NEAR(y["gyroscope_noise_density"].as<double>(), 2e-4, 1e-9);
  EXPECT_NEAR(y["gyroscope_random_walk"].as<double>(), 3e-6, 1e-11);  // the bound
  EXPECT_NEAR(y["accelerometer_noise_density"].as<double>(), 1.5e-3, 1e-9);
  EXPECT_NEAR(y["accelerometer_random_walk"].as<double>(), 4e-5, 1e-10);
  // Exactly one NOT SUPPORTED comment (gyroscope_random_walk).
  size_t n = 0;
  for (size_t pos = text.find("NOT SUPPORTED"); pos != std::string::npos; pos = text.find("NOT SUPPORTED", pos + 1)) ++n;
  EXPECT_EQ(n, 1u);
  // ... with the 95 % upper end beside the 68 % one (bound() sets none: the 68 % end stands in); with a set hi95
  // the comment carries it, by the same axis rule, and a bad axis's infinite one is left out.
  EXPECT_NE(text.find("NOT SUPPORTED by the data: this is the upper end of its 68 % interval, the true value may be "
                      "smaller; the 95 % upper end is 3.000000e-06"),
            std::string::npos)
      << text;
  Coefficient k1 = bound(3e-6), k2 = bound(2e-6);
  k1.hi95 = 4e-6;
  k2.hi95 = 9e-6;  // the worst rule's 95 % figure is the largest 95 % end, here another axis's
  const KalibrValue w = combineAxes({"x", "y"}, {k1, k2}, KalibrAxisRule::Worst);
  EXPECT_DOUBLE_EQ(w.value, 3e-6);
  EXPECT_DOUBLE_EQ(w.value95, 9e-6);
  const KalibrValue m = combineAxes({"x", "y"}, {k1, k2}, KalibrAxisRule::Mean);
  EXPECT_NEAR(m.value95, std::sqrt((16e-12 + 81e-12) / 2), 1e-18);
  std::array<Coefficient, kNumTerms> g2 = g;
  g2[kRateRandomWalk] = k1;
  EXPECT_NE(kalibrYaml(kalibrParams({"x"}, {g2}, {}, {}, 100.0, "", KalibrAxisRule::Worst))
                .find("the 95 % upper end is 4.000000e-06"),
            std::string::npos);
  g2[kRateRandomWalk].hi95 = std::numeric_limits<double>::infinity();
  EXPECT_EQ(kalibrYaml(kalibrParams({"x"}, {g2}, {}, {}, 100.0, "", KalibrAxisRule::Worst)).find("95 %"),
            std::string::npos);
  // No accelerometer: keys commented out, not invented.
  const YAML::Node y2 = YAML::Load(kalibrYaml(kalibrParams({"x"}, {g}, {}, {}, 100.0, "", KalibrAxisRule::Worst)));
  EXPECT_FALSE(y2["accelerometer_noise_density"]);
  EXPECT_THROW(kalibrParams({}, {}, {}, {}, 100.0, "", KalibrAxisRule::Worst), std::invalid_argument);
  EXPECT_THROW(kalibrParams({"x"}, {g}, {}, {}, 0.0, "", KalibrAxisRule::Worst), std::invalid_argument);
}

// Units: discrete white rate noise with std sigma_d at rate f is Kalibr's sigma_g = sigma_d / sqrt(f) (Kalibr wiki:
// sigma_gd = sigma_g / sqrt(dt)); its ADEV at tau = 1 s equals sigma_g. The whole pipeline must give that number,
// not sqrt(2) times it. 200 Hz, 10 min, sigma_d = 0.01 rad/s -> sigma_g = 7.071e-4; tolerance 5 % (ADEV of 600 s
// of white noise at tau ~ 1 s has ~1 % scatter, the fit over all taus less).
TEST(Kalibr, WhiteNoiseDensityIsDiscreteSigmaTimesSqrtDt) {
  const double f = 200.0, sigma_d = 0.01;
  std::mt19937_64 rng(11);
  std::normal_distribution<double> n(0.0, sigma_d);
  std::vector<std::vector<double>> seg(1);
  for (int i = 0; i < 200 * 600; ++i) seg[0].push_back(n(rng));
  AnalysisOptions opt;
  opt.wavelet_split = false;
  opt.model_check = false;
  const AxisAnalysis a = analyzeAxis("x", seg, 1.0 / f, opt);
  const KalibrParams p = kalibrParams({"x"}, {a.coefficients}, {}, {}, f, "/imu", KalibrAxisRule::Worst);
  const double sigma_g = sigma_d / std::sqrt(f);
  EXPECT_NEAR(p.gyroscope_noise_density.value / sigma_g, 1.0, 0.05);
  EXPECT_FALSE(p.gyroscope_noise_density.bound);
  // ADEV of white noise is sigma_g / sqrt(tau): sigma_g at tau = 1 s (checked on the points with 0.05 <= tau <= 1,
  // EDF >= ~900: 1-sigma scatter <= 3.3 %, tolerance 10 %; a sqrt(2) mistake would be 41 %).
  int checked = 0;
  for (const auto& pt : a.oadev.points)
    if (pt.tau >= 0.05 && pt.tau <= 1.0 + 1e-9) {
      EXPECT_NEAR(pt.dev * std::sqrt(pt.tau) / sigma_g, 1.0, 0.10) << pt.tau;
      ++checked;
    }
  EXPECT_GE(checked, 3);
  // White noise has no rate random walk: written as a bound well below N's scale at 1 s.
  EXPECT_TRUE(p.gyroscope_random_walk.bound || p.gyroscope_random_walk.value < 0.1 * sigma_g);
  // A clean record: the verdict is good; float noise is not a quantized output.
  EXPECT_EQ(a.quality.quality, Quality::Good) << a.quality.reason;
  EXPECT_FALSE(a.quantized.quantized) << a.quantized.summary;
}

TEST(Kalibr, QualityLinePerAxisAndBadDecidingAxisIsSaid) {
  std::array<Coefficient, kNumTerms> g{{bound(1e-6), sup(2e-4), sup(1e-5), bound(3e-6), bound(1e-8)}};
  std::array<Coefficient, kNumTerms> worse{{bound(1e-6), sup(5e-4), sup(1e-5), bound(2e-6), bound(1e-8)}};
  KalibrParams p = kalibrParams({"x", "y"}, {g, worse}, {}, {}, 200.0, "/imu", KalibrAxisRule::Worst);
  p.quality.push_back({"gyro", "x", {Quality::Good, "fit error rms_log10 0.010 <= 0.05, chi2/dof 1.1 <= 5"}});
  p.quality.push_back({"gyro", "y", {Quality::Bad, "the model is off by x1.58 in ADEV (rms_log10 0.200 > 0.15)"}});
  const std::string text = kalibrYaml(p);
  EXPECT_NE(text.find("# Quality gyro x: good (fit error rms_log10 0.010"), std::string::npos) << text;
  EXPECT_NE(text.find("# Quality gyro y: BAD (the model is off by x1.58"), std::string::npos) << text;
  const YAML::Node y = YAML::Load(text);  // comments only: the values are untouched
  EXPECT_NEAR(y["gyroscope_noise_density"].as<double>(), 5e-4, 1e-10);
  EXPECT_NEAR(y["gyroscope_random_walk"].as<double>(), 3e-6, 1e-11);
  // N is decided by y (bad): its comment says so; K is decided by x (good): no flag.
  std::string n_line, k_line;
  std::istringstream lines(text);
  for (std::string l; std::getline(lines, l);) {
    if (l.rfind("gyroscope_noise_density:", 0) == 0) n_line = l;
    if (l.rfind("gyroscope_random_walk:", 0) == 0) k_line = l;
  }
  EXPECT_NE(n_line.find("BAD FIT on axis y"), std::string::npos) << n_line;
  EXPECT_EQ(k_line.find("BAD FIT"), std::string::npos) << k_line;
  // Mean rule: every value includes y.
  KalibrParams m = kalibrParams({"x", "y"}, {g, worse}, {}, {}, 200.0, "/imu", KalibrAxisRule::Mean);
  m.quality = p.quality;
  const std::string mt = kalibrYaml(m);
  EXPECT_NE(mt.find("BAD FIT on axis y"), std::string::npos) << mt;
}

// The bundled bag (bags/default.bag: MEMS gyro, rates rounded to 1e-4 rad/s) axis x, end to end: a good verdict in
// imu.yaml, and the output recognised as a 1e-4 rad/s lattice without sawtooth.
TEST(Kalibr, DefaultBagVerdictAndQuantizedOutput) {
  BagReadOptions bo;
  bo.progress = false;
  const ImuSeries s = readImuBags({std::string(GYRO_ALLAN_SOURCE_DIR) + "/bags/default.bag"}, bo);
  const std::vector<std::vector<double>> seg{s.gyro[0].toVector()};
  const AxisAnalysis a = analyzeAxis("x", seg, 0.01, AnalysisOptions());
  EXPECT_EQ(a.quality.quality, Quality::Good) << a.quality.reason;
  EXPECT_NE(a.quality.reason.find("the data accept the model"), std::string::npos) << a.quality.reason;
  EXPECT_TRUE(a.quantized.quantized) << a.quantized.summary;
  EXPECT_NEAR(a.quantized.quantum_rate / 1e-4, 1.0, 1e-6) << a.quantized.summary;
  EXPECT_FALSE(a.quantized.sawtooth) << a.quantized.summary;
  KalibrParams p = kalibrParams({"x"}, {a.coefficients}, {}, {}, 100.0, s.topic, KalibrAxisRule::Worst);
  p.quality.push_back({"gyro", "x", a.quality});
  const std::string text = kalibrYaml(p);
  EXPECT_NE(text.find("# Quality gyro x: good (" + a.quality.reason + ")"), std::string::npos) << text;
  EXPECT_EQ(text.find("BAD FIT"), std::string::npos) << text;
}
