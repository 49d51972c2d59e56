// Core-level bad inputs (issue 8): sanitize, analyzeAxis, parseCsv, the wavelet transforms and the ROS 2 readers either work or throw
// std::invalid_argument, stamp counts always add up, and every input the fuzzers kept (fuzz/corpus, fuzz/regressions)
// is replayed through the fuzz targets' own checks.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "gyro_allan/analysis.hpp"
#include "gyro_allan/csv_input.hpp"
#include "gyro_allan/timing.hpp"
#include "gyro_allan/wavelet.hpp"

// The fuzz targets themselves, renamed, so regressions run the very same checks (a failed check traps).
#define LLVMFuzzerTestOneInput fuzzCsvOne
#include "../fuzz/fuzz_csv.cpp"
#undef LLVMFuzzerTestOneInput
#define LLVMFuzzerTestOneInput fuzzAnalysisOne
#include "../fuzz/fuzz_analysis.cpp"
#undef LLVMFuzzerTestOneInput
#define LLVMFuzzerTestOneInput fuzzWaveletOne
#include "../fuzz/fuzz_wavelet.cpp"
#undef LLVMFuzzerTestOneInput
#define LLVMFuzzerTestOneInput fuzzRos2One
#include "../fuzz/fuzz_ros2.cpp"
#undef LLVMFuzzerTestOneInput

namespace {

using namespace gyro_allan;

int64_t accounted(const StampReport& r) {
  return r.kept + r.non_finite + r.zero_stamp + r.out_of_order + r.duplicate + r.too_close + r.short_segment;
}

SanitizedSeries sanitize1(const std::vector<double>& t, const std::vector<double>& v, SanitizeOptions o = {}) {
  return sanitize(t, {&v}, o);
}

TEST(Sanitize, RejectsMalformedArguments) {
  const std::vector<double> t{1, 2, 3}, v{0, 0, 0}, shorter{0, 0};
  EXPECT_THROW(sanitize(t, {}, {}), std::invalid_argument);
  EXPECT_THROW(sanitize(t, {&v, &v, &v, &v}, {}), std::invalid_argument);
  EXPECT_THROW(sanitize(t, {&shorter}, {}), std::invalid_argument);
  EXPECT_THROW(sanitize(t, {nullptr}, {}), std::invalid_argument);
  SanitizeOptions o;
  o.gap_factor = 1.0;
  EXPECT_THROW(sanitize1(t, v, o), std::invalid_argument);
  o.gap_factor = std::nan("");
  EXPECT_THROW(sanitize1(t, v, o), std::invalid_argument);
}

TEST(Sanitize, EmptyAndAllBadInputsKeepNothingWithoutThrowing) {
  const std::vector<double> none;
  EXPECT_EQ(sanitize1(none, none).report.kept, 0);
  const std::vector<double> t{0, 0, 0}, v{1, 2, 3};
  const auto z = sanitize1(t, v);
  EXPECT_EQ(z.report.zero_stamp, 3);
  EXPECT_EQ(z.report.rate_hz, 0.0);
  const std::vector<double> t2{1, 2, 3}, nan3(3, std::nan(""));
  EXPECT_EQ(sanitize1(t2, nan3).report.non_finite, 3);
  const std::vector<double> tinf{INFINITY, -INFINITY, std::nan("")};
  EXPECT_EQ(sanitize1(tinf, v).report.non_finite, 3);
}

TEST(Sanitize, ForwardGlitchAndSwappedPairCostOneSampleEach) {
  std::vector<double> t, v;
  for (int i = 1; i <= 1000; ++i) t.push_back(i * 0.01), v.push_back(0);
  t[0] = 1e6;    // first stamp far ahead
  t[500] = 99;   // one stamp in the middle far ahead
  std::swap(t[700], t[701]);
  const auto s = sanitize1(t, v);
  EXPECT_EQ(s.report.out_of_order, 3);
  EXPECT_EQ(s.report.kept, 997);
  EXPECT_EQ(accounted(s.report), 1000);
  EXPECT_NEAR(s.report.rate_hz, 100.0, 1e-6);
}

TEST(Sanitize, CountsAlwaysAddUpUnderRandomStampDamage) {
  // 200 random damage patterns (drops, zeros, NaN, duplicates, stale and future stamps, gaps): nothing is lost.
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> u(0, 1);
  for (int trial = 0; trial < 200; ++trial) {
    std::vector<double> t, x, y;
    double now = 1;
    const int n = 50 + static_cast<int>(u(rng) * 2000);
    for (int i = 0; i < n; ++i) {
      now += 0.01;
      const double r = u(rng);
      double ti = now, xi = u(rng) - 0.5;
      if (r < 0.02) ti = 0;
      else if (r < 0.04) xi = std::nan("");
      else if (r < 0.06) ti = now - 0.01 * std::floor(u(rng) * 50);
      else if (r < 0.07) ti = now + 100 * u(rng);
      else if (r < 0.09) now += 0.01 * std::floor(u(rng) * 20);
      t.push_back(ti);
      x.push_back(xi);
      y.push_back(-xi);
    }
    const auto s = sanitize(t, {&x, &y}, {});
    ASSERT_EQ(s.report.input, n);
    ASSERT_EQ(accounted(s.report), n) << "trial " << trial;
    ASSERT_EQ(s.t.size(), s.v[0].size());
    ASSERT_EQ(s.t.size(), s.v[1].size());
    // Kept stamps never go back (equal ones are one buffered read: equal stamps, other values).
    for (size_t i = 1; i < s.t.size(); ++i) ASSERT_GE(s.t[i], s.t[i - 1]) << "trial " << trial;
    for (double v : s.v[0]) ASSERT_TRUE(std::isfinite(v));
  }
}

AnalysisOptions defaultOptions() { return AnalysisOptions{}; }

std::vector<std::vector<double>> whiteSegments(size_t n, double sigma, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g(0, sigma);
  std::vector<double> v(n);
  for (auto& x : v) x = g(rng);
  return {v};
}

TEST(AnalyzeAxis, RejectsBadArgumentsWithInvalidArgument) {
  const auto seg = whiteSegments(1000, 1e-2, 1);
  AnalysisOptions o = defaultOptions();
  EXPECT_THROW(analyzeAxis("x", seg, 0.0, o), std::invalid_argument);
  EXPECT_THROW(analyzeAxis("x", seg, -0.01, o), std::invalid_argument);
  EXPECT_THROW(analyzeAxis("x", seg, std::nan(""), o), std::invalid_argument);
  EXPECT_THROW(analyzeAxis("x", seg, INFINITY, o), std::invalid_argument);
  EXPECT_THROW(analyzeAxis("x", {{1.0, 2.0}}, 0.01, o), std::invalid_argument);
  EXPECT_THROW(analyzeAxis("x", {}, 0.01, o), std::invalid_argument);
  EXPECT_THROW(analyzeAxis("x", {{}, {}, {1.0}}, 0.01, o), std::invalid_argument);
  EXPECT_THROW(analyzeAxis("x", {{1.0, std::nan(""), 2.0, 3.0}}, 0.01, o), std::invalid_argument);
  o.deviation.confidence = 1.0;
  EXPECT_THROW(analyzeAxis("x", seg, 0.01, o), std::invalid_argument);
  o = defaultOptions();
  o.deviations = {"bogusdev"};
  EXPECT_THROW(analyzeAxis("x", seg, 0.01, o), std::invalid_argument);
}

TEST(AnalyzeAxis, DegenerateButFiniteDataNeverGivesNonFiniteSupportedTerms) {
  // Stuck sensor (constant), one-LSB toggling, huge and tiny values, many 2-sample segments.
  std::vector<std::vector<std::vector<double>>> cases;
  cases.push_back({std::vector<double>(5000, 0.25)});
  std::vector<double> toggle(5000);
  for (size_t i = 0; i < toggle.size(); ++i) toggle[i] = (i % 2) ? 1e-3 : 0.0;
  cases.push_back({toggle});
  cases.push_back(whiteSegments(3000, 1e150, 2));
  cases.push_back(whiteSegments(3000, 1e-200, 3));
  std::vector<std::vector<double>> pairs(500, std::vector<double>{0.1, -0.1});
  cases.push_back(pairs);
  for (size_t c = 0; c < cases.size(); ++c) {
    try {
      const AxisAnalysis a = analyzeAxis("x", cases[c], 0.01, defaultOptions());
      for (const auto& term : a.fit.terms)
        if (term.supported) {
          EXPECT_TRUE(std::isfinite(term.value) && std::isfinite(term.sigma)) << "case " << c;
        }
      for (const auto& p : a.oadev.points) EXPECT_TRUE(p.tau > 0 && !std::isnan(p.dev)) << "case " << c;
    } catch (const std::invalid_argument& e) {
      SUCCEED() << "case " << c << ": " << e.what();
    }
  }
}

TEST(Csv, MalformedTextThrowsInvalidArgumentNamingTheLine) {
  auto parse = [](const std::string& text) {
    std::istringstream in(text);
    return parseCsv(in);
  };
  EXPECT_THROW(parse(""), std::invalid_argument);
  EXPECT_THROW(parse("# only a comment\n\n"), std::invalid_argument);
  EXPECT_THROW(parse("t\n1\n"), std::invalid_argument);
  try {
    parse("1,2,3\n4,5\n");
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("line 2"), std::string::npos) << e.what();
  }
  try {
    parse("a,b\n1,2\n3,0x\n");
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("line 3"), std::string::npos) << e.what();
  }
  CsvOptions o;
  o.scale = 0;
  std::istringstream in("1\n");
  EXPECT_THROW(parseCsv(in, o), std::invalid_argument);
  // NaN/Inf cells are values, not errors: sanitation counts them.
  const CsvSeries s = parse("nan\ninf\n-inf\n1e-3\n");
  ASSERT_EQ(s.rows, 4);
  EXPECT_TRUE(std::isnan(s.columns[0][0]));
  // A NUL byte and CR line ends.
  EXPECT_EQ(parse("1\r\n2\r\n").rows, 2);
  EXPECT_THROW(parse(std::string("1\n\0\n", 4)), std::invalid_argument);
}

TEST(Wavelet, BadArgumentsThrowInvalidArgument) {
  EXPECT_THROW(Wavelet("nonexistent"), std::invalid_argument);
  const Wavelet w("sym8");
  EXPECT_THROW(dwt({}, w, ExtensionMode::Symmetric), std::invalid_argument);
  EXPECT_THROW(swt({1.0, 2.0, 3.0}, w, 1), std::invalid_argument);  // length not a multiple of 2^level
  std::vector<double> x(64, 1.0);
  // A level above dwt_max_level is allowed (as in PyWavelets, which only warns): it must still reconstruct.
  const auto deep = wavedec(x, w, ExtensionMode::Symmetric, 100);
  const auto back = waverec(deep, w, ExtensionMode::Symmetric);
  ASSERT_GE(back.size(), x.size());
  for (size_t i = 0; i < x.size(); ++i) EXPECT_NEAR(back[i], 1.0, 1e-9);
  EXPECT_THROW(idwt({1.0, 2.0}, {1.0}, w, ExtensionMode::Symmetric), std::invalid_argument);
  EXPECT_THROW(waverec({}, w, ExtensionMode::Symmetric), std::invalid_argument);
}

// Replays every kept fuzz input (seed corpus and fixed crashers) through the targets' own checks.
void replay(const std::string& target, int (*one)(const uint8_t*, size_t)) {
  int n = 0;
  for (const char* kind : {"corpus", "regressions"}) {
    const std::filesystem::path dir = std::filesystem::path(GYRO_ALLAN_SOURCE_DIR) / "fuzz" / kind / target;
    if (!std::filesystem::exists(dir)) continue;
    for (const auto& e : std::filesystem::directory_iterator(dir)) {
      if (!e.is_regular_file()) continue;
      std::ifstream f(e.path(), std::ios::binary);
      const std::string bytes((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
      SCOPED_TRACE(e.path().string());
      EXPECT_NO_THROW(one(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size()));
      ++n;
    }
  }
  EXPECT_GT(n, 0) << "no fuzz inputs for " << target;
}

TEST(FuzzRegressions, Csv) { replay("csv", fuzzCsvOne); }
TEST(FuzzRegressions, Analysis) { replay("analysis", fuzzAnalysisOne); }
TEST(FuzzRegressions, Wavelet) { replay("wavelet", fuzzWaveletOne); }
TEST(FuzzRegressions, Ros2) { replay("ros2", fuzzRos2One); }

}  // namespace
