// Reference tests of the Allan-family deviations: NIST SP1065 NBS14 values, Stable32 PHASE.DAT / OCXO results, ADIS16405 OADEV.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "gyro_allan/allan.hpp"

using namespace gyro_allan;

namespace {

const std::string kData = std::string(GYRO_ALLAN_SHARED_DATA);
const std::string kNist = kData + "/nist_sp1065/";
// Stable32 prints "Confidence Factor = 0.683" but its bounds are the exact 1-sigma interval (erf(1/sqrt 2)).
const double kOneSigma = 0.68268949213708585;

std::vector<double> loadColumn(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open " + path);
  std::vector<double> v;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    v.push_back(std::stod(line));
  }
  return v;
}

struct S32Row {
  int64_t m = 0;
  double tau = 0;
  int64_t n = 0;
  int alpha = 0;
  double lo = 0, dev = 0, hi = 0;
};

std::vector<S32Row> loadStable32(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open " + path);
  std::vector<S32Row> rows;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream s(line);
    S32Row r;
    if (s >> r.m >> r.tau >> r.n >> r.alpha >> r.lo >> r.dev >> r.hi) rows.push_back(r);
  }
  return rows;
}

/// Published values have 7 significant digits: 1e-7 relative plus half a unit of the last printed digit.
double publishedTol(double v) { return 1e-7 * v + 0.5 * std::pow(10.0, std::floor(std::log10(v)) - 6); }

double rel(double a, double b) { return std::fabs(a / b - 1.0); }

std::vector<double> ocxoFractional() {
  auto f = loadColumn(kNist + "ocxo/ocxo_frequency.txt");
  for (auto& v : f) v = (v - 1e7) / 1e7;
  return f;
}

// ------------------------------------------------------------------------------------------------ NBS14
struct Published {
  const char* name;
  std::vector<double> values;
};

TEST(AllanReference, Nbs14TenPointAllDeviations) {
  const auto y = loadColumn(kNist + "nbs14_10pt_freq.txt");
  const auto x = loadColumn(kNist + "nbs14_10pt_phase.txt");
  ASSERT_EQ(y.size(), 9u);
  ASSERT_EQ(x.size(), 10u);
  const std::vector<Published> pub = {
      {"adev", {91.22945, 115.8082}},  {"oadev", {91.22945, 85.95287}}, {"mdev", {91.22945, 74.78849}},
      {"hdev", {70.80608, 116.7980}},  {"ohdev", {70.80607, 85.61487}}, {"tdev", {52.67135, 86.35831}},
      {"totdev", {91.22945, 93.90379}}};
  DeviationOptions opt;
  opt.compute_edf = false;
  for (const auto& p : pub) {
    for (InputKind kind : {InputKind::Rate, InputKind::Angle}) {
      const auto c = computeDeviationAt(p.name, kind == InputKind::Rate ? y : x, kind, 1.0, {1, 2}, opt);
      ASSERT_EQ(c.points.size(), 2u) << p.name;
      for (size_t i = 0; i < 2; ++i) {
        EXPECT_LT(std::fabs(c.points[i].dev - p.values[i]), publishedTol(p.values[i]))
            << p.name << " m=" << c.points[i].m << " got " << c.points[i].dev;
      }
    }
  }
}

TEST(AllanReference, Nbs14ThousandPointAllDeviations) {
  const auto y = loadColumn(kNist + "nbs14_1000pt_freq.txt");
  ASSERT_EQ(y.size(), 1000u);
  const std::vector<Published> pub = {{"adev", {2.922319e-01, 9.965736e-02, 3.897804e-02}},
                                      {"oadev", {2.922319e-01, 9.159953e-02, 3.241343e-02}},
                                      {"mdev", {2.922319e-01, 6.172376e-02, 2.170921e-02}},
                                      {"hdev", {2.943883e-01, 1.052754e-01, 3.910860e-02}},
                                      {"ohdev", {2.943883e-01, 9.581083e-02, 3.237638e-02}},
                                      {"tdev", {1.687202e-01, 3.563623e-01, 1.253382e+00}},
                                      {"totdev", {2.922319e-01, 9.134743e-02, 3.406530e-02}}};
  DeviationOptions opt;
  opt.compute_edf = false;
  for (const auto& p : pub) {
    const auto c = computeDeviationAt(p.name, y, InputKind::Rate, 1.0, {1, 10, 100}, opt);
    ASSERT_EQ(c.points.size(), 3u) << p.name;
    for (size_t i = 0; i < 3; ++i) {
      EXPECT_LT(std::fabs(c.points[i].dev - p.values[i]), publishedTol(p.values[i]))
          << p.name << " m=" << c.points[i].m << " got " << c.points[i].dev;
    }
  }
}

// ------------------------------------------------------------------------------------------------ Stable32
/// Every row of a Stable32 table: sigma to 1e-4 relative (5 printed digits), #terms exact; noise ID (lag-1 ACF)
/// must agree with Stable32's alpha on >= 95 % of the rows with at least 30 decimated points.
void checkAllTau(const std::string& file, const std::string& dev, const std::vector<double>& data, InputKind kind) {
  const auto rows = loadStable32(file);
  ASSERT_GT(rows.size(), 5u) << file;
  std::vector<int64_t> ms;
  for (const auto& r : rows) ms.push_back(r.m);
  DeviationOptions opt;
  const auto c = computeDeviationAt(dev, data, kind, 1.0, ms, opt);
  ASSERT_EQ(c.points.size(), rows.size()) << file;
  const int64_t n_phase = kind == InputKind::Rate ? static_cast<int64_t>(data.size()) + 1 : data.size();
  int acf_rows = 0, acf_agree = 0;
  for (size_t i = 0; i < rows.size(); ++i) {
    const auto& p = c.points[i];
    ASSERT_EQ(p.m, rows[i].m);
    EXPECT_LT(rel(p.dev, rows[i].dev), 1e-4) << file << " m=" << p.m << " got " << p.dev << " want " << rows[i].dev;
    EXPECT_EQ(p.n_terms, rows[i].n) << file << " m=" << p.m;
    if (n_phase / p.m >= 30) {
      ++acf_rows;
      acf_agree += p.alpha == rows[i].alpha;
    }
  }
  ASSERT_GT(acf_rows, 0);
  EXPECT_GE(acf_agree, 0.95 * acf_rows) << file << ": noise ID agrees on " << acf_agree << "/" << acf_rows;
}

/// Octave tables with 68.3 % bounds, using Stable32's alpha for the EDF. Stable32 bounds are reproduced to
/// 1e-4 where 10 <= EDF < 100. Above 100 Stable32's EDF is consistently ~1.1 % larger than the Greenhall-Riley
/// value (an approximation inside Stable32 we could not identify), which moves the bounds by at most 4e-4
/// relative: checked at 1e-3. Below 10 (last octave only) the upper bound differs by up to 1.6e-4 (a 0.05 %
/// EDF difference; our chi-squared quantiles agree with scipy to 1e-11): checked at 2e-4. See docs/deviations.md.
void checkOctaveWithBounds(const std::string& file, const std::string& dev, const std::vector<double>& data,
                           InputKind kind, double dev_tol) {
  const auto rows = loadStable32(file);
  ASSERT_GT(rows.size(), 5u) << file;
  for (const auto& r : rows) {
    DeviationOptions opt;
    opt.confidence = kOneSigma;
    auto c = computeDeviationAt(dev, data, kind, 1.0, {r.m}, opt);
    ASSERT_EQ(c.points.size(), 1u);
    c.points[0].alpha = r.alpha;
    fillConfidence(&c, kOneSigma);
    const auto& p = c.points[0];
    EXPECT_EQ(p.n_terms, r.n) << file << " m=" << r.m;
    EXPECT_LT(rel(p.dev, r.dev), dev_tol) << file << " m=" << r.m;
    const double bound_tol = p.edf >= 100 ? 1e-3 : (p.edf < 10 ? 2e-4 : 1e-4);
    EXPECT_LT(rel(p.dev_lo, r.lo), bound_tol + dev_tol - 1e-4) << file << " m=" << r.m << " edf=" << p.edf;
    EXPECT_LT(rel(p.dev_hi, r.hi), bound_tol + dev_tol - 1e-4) << file << " m=" << r.m << " edf=" << p.edf;
  }
}

TEST(AllanReference, PhaseDatAllTau) {
  const auto x = loadColumn(kNist + "phasedat/PHASE.DAT");
  ASSERT_EQ(x.size(), 1001u);
  for (const std::string dev : {"adev", "oadev", "mdev", "tdev", "hdev", "ohdev", "totdev"})
    checkAllTau(kNist + "phasedat/phase_dat_" + dev + ".txt", dev, x, InputKind::Angle);
}

TEST(AllanReference, PhaseDatOctaveWithBounds) {
  const auto x = loadColumn(kNist + "phasedat/PHASE.DAT");
  for (const std::string dev : {"adev", "oadev", "mdev", "tdev", "hdev", "ohdev"})
    checkOctaveWithBounds(kNist + "phasedat/phase_dat_" + dev + "_octave.txt", dev, x, InputKind::Angle, 1e-4);
}

TEST(AllanReference, OcxoAllTau) {
  const auto y = ocxoFractional();
  ASSERT_EQ(y.size(), 19982u);
  for (const std::string dev : {"adev", "oadev", "mdev", "hdev", "ohdev"})
    checkAllTau(kNist + "ocxo/stable32_" + dev + "_alltau.txt", dev, y, InputKind::Rate);
}

TEST(AllanReference, OcxoOctaveWithBounds) {
  const auto y = ocxoFractional();
  // Non-overlapping adev/hdev match to 1.2e-4 except hdev at m = 2048 (1.5e-4): checked at 2e-4. The overlapping oadev/mdev octave tables were made by
  // Stable32 from f/1e7 (mean 1.0, file ocxo_frequency.001): integrating that to phase cost Stable32 ~1e-3 relative
  // (the all-tau tables, made from the offset-removed file, agree with us to 5e-5), so they are checked at 2e-3.
  checkOctaveWithBounds(kNist + "ocxo/adev_octave.txt", "adev", y, InputKind::Rate, 2e-4);
  checkOctaveWithBounds(kNist + "ocxo/hdev_octave.txt", "hdev", y, InputKind::Rate, 2e-4);
  checkOctaveWithBounds(kNist + "ocxo/oadev_octave.txt", "oadev", y, InputKind::Rate, 2e-3);
  checkOctaveWithBounds(kNist + "ocxo/mdev_octave.txt", "mdev", y, InputKind::Rate, 2e-3);
}

// ------------------------------------------------------------------------------------------------ ADIS16405
TEST(AllanReference, Adis16405Imu1OadevMatchesAvarPackage) {
  const std::string gz = kData + "/adis16405/adis16405_imu1_100Hz.csv.gz";
  const std::string cmd = "gzip -dc '" + gz + "'";
  FILE* pipe = popen(cmd.c_str(), "r");
  ASSERT_NE(pipe, nullptr);
  std::vector<double> g[3];
  char line[256];
  bool header = true;
  while (fgets(line, sizeof line, pipe)) {
    if (header) {
      header = false;
      continue;
    }
    char* p = line;
    for (int k = 0; k < 3; ++k) {
      char* end = nullptr;
      g[k].push_back(std::strtod(p, &end));
      p = end + 1;
    }
  }
  ASSERT_EQ(pclose(pipe), 0);
  ASSERT_EQ(g[0].size(), 1000000u);

  std::ifstream ref(kData + "/adis16405/imu1_oadev_reference.csv");
  ASSERT_TRUE(ref.good());
  std::map<std::string, int> channel = {{"\"Gyro. X\"", 0}, {"\"Gyro. Y\"", 1}, {"\"Gyro. Z\"", 2}};
  std::map<int, std::vector<std::pair<double, double>>> want;  // channel -> (tau, avar)
  std::string row;
  while (std::getline(ref, row)) {
    if (row.empty() || row[0] == '#' || row.rfind("\"channel\"", 0) == 0) continue;
    std::istringstream s(row);
    std::string ch, tau, avar;
    std::getline(s, ch, ',');
    std::getline(s, tau, ',');
    std::getline(s, avar, ',');
    if (channel.count(ch)) want[channel[ch]].push_back({std::stod(tau), std::stod(avar)});
  }
  for (int k = 0; k < 3; ++k) {
    ASSERT_EQ(want[k].size(), 18u);
    std::vector<int64_t> ms;
    for (const auto& w : want[k]) ms.push_back(std::llround(w.first * 100.0));
    DeviationOptions opt;
    opt.compute_edf = false;
    const auto c = computeDeviationAt("oadev", g[k], InputKind::Rate, 0.01, ms, opt);
    ASSERT_EQ(c.points.size(), 18u);
    for (size_t i = 0; i < 18; ++i) {
      EXPECT_NEAR(c.points[i].tau, want[k][i].first, 1e-12);
      EXPECT_LT(rel(c.points[i].var, want[k][i].second), 1e-5) << "gyro " << k << " tau " << c.points[i].tau;
    }
  }
}

}  // namespace

// catkin_add_gtest here links gtest without gtest_main.
int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
