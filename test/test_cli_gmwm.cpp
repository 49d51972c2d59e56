// End-to-end test of analyze_bag --method gmwm / --filter-rate: noise_model.yaml from a CSV of declared WN + GM noise.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include <yaml-cpp/yaml.h>

#include "cli_util.hpp"
#include "gyro_allan/simulate.hpp"

namespace {

const std::string kTools = GYRO_ALLAN_TOOL_DIR;
const std::string kOut = std::string(GYRO_ALLAN_TEST_OUT) + "/cli_gmwm";
gyro_allan_test::ToolRun run(const std::string& args) { return gyro_allan_test::runTool(args, kOut); }

// n samples at 100 Hz (seed): x white (N) + one GM (sigma, tc) + extra_x(k); y and z white (N). Written as a
// wx,wy,wz CSV. False if the file cannot be written.
template <class Extra>
bool writeGmCsv(const std::string& path, double N, double sigma, double tc, int64_t n, uint64_t seed, Extra extra_x) {
  gyro_allan::AxisNoise x, w;
  x.angle_random_walk = N;
  x.gm_sigma = sigma;
  x.gm_tau = tc;
  w.angle_random_walk = N;
  const auto gx = gyro_allan::simulateAxis(x, 100, n, seed, 0), gy = gyro_allan::simulateAxis(w, 100, n, seed, 1),
             gz = gyro_allan::simulateAxis(w, 100, n, seed, 2);
  FILE* f = std::fopen(path.c_str(), "w");
  if (!f) return false;
  std::fprintf(f, "wx,wy,wz\n");
  for (int64_t k = 0; k < n; ++k) std::fprintf(f, "%.9g,%.9g,%.9g\n", gx[k] + extra_x(k), gy[k], gz[k]);
  std::fclose(f);
  return true;
}

}  // namespace

// 1 h at 100 Hz of N = 3e-4 rad/sqrt(s) and one GM (sigma 1e-3 rad/s, tc 2 s) on x; y and z white only. Declared
// truth vs the file: the model on x has one GM, sigma and tc within 15 % (~3 reported sigma; gmwm_study S1 measures
// 10 % in 48/50), N within 5 %; Phi/Qd at 100 Hz and at the 50-Hz filter rate follow from the continuous values.
TEST(CliGmwm, NoiseModelYamlFromDeclaredNoise) {
  setenv("GYRO_ALLAN_NO_PLOT", "1", 1);
  ASSERT_EQ(std::system(("mkdir -p " + kOut).c_str()), 0);
  const double N = 3e-4, sigma = 1e-3, tc = 2.0;
  ASSERT_TRUE(writeGmCsv(kOut + "/gm.csv", N, sigma, tc, 360000, 41, [](int64_t) { return 0.0; }));
  // --filter-rate alone implies --method gmwm (nodelet_noise_model runs --method gmwm --filter-rate 20); report.yaml
  // names the method gmwm either way, as the nodelet's ~save does.
  const auto r = run(kTools + "/analyze_bag --csv " + kOut + "/gm.csv --rate 100 --filter-rate 50 " +
                     "--no-model-check --no-wavelet-split --output " + kOut + "/out --quiet");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(YAML::LoadFile(kOut + "/out/report.yaml")["method"].as<std::string>(), "gmwm");
  const YAML::Node m = YAML::LoadFile(kOut + "/out/noise_model.yaml");
  ASSERT_TRUE(m["axes"]["x"]) << gyro_allan_test::slurp(kOut + "/out/noise_model.yaml");
  const YAML::Node ax = m["axes"]["x"];
  EXPECT_EQ(ax["model"].as<std::string>(), "WN+GM");
  const YAML::Node g = ax["continuous"]["gauss_markov"][0];
  const double s_hat = g["sigma"]["value"].as<double>(), tc_hat = g["correlation_time"]["value"].as<double>();
  EXPECT_NEAR(s_hat / sigma, 1.0, 0.15);
  EXPECT_NEAR(tc_hat / tc, 1.0, 0.15);
  EXPECT_NEAR(ax["continuous"]["angle_random_walk"]["value"].as<double>() / N, 1.0, 0.05);
  ASSERT_EQ(ax["discrete"].size(), 2u);
  for (size_t k = 0; k < 2; ++k) {
    const YAML::Node d = ax["discrete"][k];
    const double dt = d["dt"].as<double>();
    EXPECT_NEAR(dt, k == 0 ? 0.01 : 0.02, 1e-12);
    ASSERT_EQ(d["Phi"].size(), 1u);
    EXPECT_NEAR(d["Phi"][0][0].as<double>(), std::exp(-dt / tc_hat), 1e-9);
    EXPECT_NEAR(d["Qd"][0][0].as<double>(), s_hat * s_hat * (1 - std::exp(-2 * dt / tc_hat)), 1e-6 * s_hat * s_hat);
    EXPECT_NEAR(d["measurement_variance"].as<double>(),
                std::pow(ax["continuous"]["angle_random_walk"]["value"].as<double>(), 2) / dt, 1e-9);
  }
  EXPECT_GT(ax["closed_loop"]["gmwm_model"]["points"].as<int>(), 20);
  // White-only axes: no GM term survives selection (WN+RW may, with a tiny K), and bad options fail in one line.
  EXPECT_EQ(m["axes"]["y"]["continuous"]["gauss_markov"].size(), 0u);
  const auto bad = run(kTools + "/analyze_bag --csv " + kOut + "/gm.csv --rate 100 --filter-rate -5 --output " + kOut +
                       "/bad --quiet");
  EXPECT_EQ(bad.code, 1);
  EXPECT_NE(bad.err.find("--filter-rate"), std::string::npos) << bad.err;
  EXPECT_EQ(run(kTools + "/analyze_bag --csv " + kOut + "/gm.csv --rate 100 --filter-rate 0 --output " + kOut +
                "/bad --quiet").code, 1);
}

// A declared line the model check finds: 20 min at 100 Hz, x = white noise (N = 3e-4 rad/sqrt(s)) + GM (1e-3 rad/s,
// 2 s) + 2e-3 sin(2 pi 7.3 t); y and z white. noise_model.yaml lists the line as a known term of the GMWM fit, not of
// the state-space model; its frequency within one PSD bin of the check's finest Welch segment (16384 samples: 0.0061
// Hz) and its amplitude within 5 % (its reported sigma is < 1 %; the check's own estimate is the start); the GM is
// still found (sigma and tc within 25 %: ~3 reported sigma on 20 min, the CLI test above allows 15 % on 1 h).
TEST(CliGmwm, SinusoidOfTheModelCheckIsAKnownTerm) {
  setenv("GYRO_ALLAN_NO_PLOT", "1", 1);
  ASSERT_EQ(std::system(("mkdir -p " + kOut).c_str()), 0);
  const double N = 3e-4, sigma = 1e-3, tc = 2.0, A = 2e-3, f0 = 7.3;
  ASSERT_TRUE(writeGmCsv(kOut + "/sine.csv", N, sigma, tc, 120000, 43, [&](int64_t k) {
    return A * std::sin(2 * M_PI * f0 * 0.01 * static_cast<double>(k) + 0.4);
  }));
  const auto r = run(kTools + "/analyze_bag --csv " + kOut + "/sine.csv --rate 100 --method gmwm --no-wavelet-split " +
                     "--output " + kOut + "/sine --quiet");
  ASSERT_EQ(r.code, 0) << r.err;
  const std::string text = gyro_allan_test::slurp(kOut + "/sine/noise_model.yaml");
  const YAML::Node m = YAML::Load(text);
  const YAML::Node ax = m["axes"]["x"];
  ASSERT_TRUE(ax["known_terms"]) << text;
  const YAML::Node k = ax["known_terms"][0];
  EXPECT_EQ(k["type"].as<std::string>(), "sinusoid") << text;
  EXPECT_TRUE(k["in_gmwm_fit"].as<bool>());
  EXPECT_FALSE(k["in_state_space_model"].as<bool>());
  EXPECT_NEAR(k["frequency_hz"].as<double>(), f0, 0.0061);
  EXPECT_NEAR(k["amplitude"]["value"].as<double>() / A, 1.0, 0.05);
  EXPECT_EQ(k["amplitude"]["unit"].as<std::string>(), "rad/s");
  ASSERT_EQ(ax["continuous"]["gauss_markov"].size(), 1u) << text;
  const YAML::Node g = ax["continuous"]["gauss_markov"][0];
  EXPECT_NEAR(g["sigma"]["value"].as<double>() / sigma, 1.0, 0.25);
  EXPECT_NEAR(g["correlation_time"]["value"].as<double>() / tc, 1.0, 0.25);
  // The line is in no state: the data-rate model has one GM state only.
  EXPECT_EQ(ax["discrete"][0]["Phi"].size(), 1u);
  // White axes: no effect, no known_terms key.
  EXPECT_FALSE(m["axes"]["y"]["known_terms"]) << text;
}
