// End-to-end tests of the simulate and analyze_bag tools: bag round trip against declared truth, report schema, CSV
// input, and one-line errors with distinct exit codes for unusable input.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include <rosbag/bag.h>
#include <sensor_msgs/Temperature.h>
#include <yaml-cpp/yaml.h>

#include "cli_util.hpp"

namespace {

const std::string kTools = GYRO_ALLAN_TOOL_DIR;
const std::string kOut = std::string(GYRO_ALLAN_TEST_OUT) + "/cli";

using gyro_allan_test::ToolRun;
ToolRun run(const std::string& args) { return gyro_allan_test::runTool(args, kOut); }

using gyro_allan_test::countLines;

class Cli : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    setenv("GYRO_ALLAN_NO_PLOT", "1", 1);  // plots are tested in test_cli_outputs; keep this suite fast
    ASSERT_EQ(std::system(("mkdir -p " + kOut).c_str()), 0);
    // 20 min, 200 Hz, N = 1e-3 rad/sqrt(s), K = 1e-5 rad/s/sqrt(s).
    const ToolRun r = run(kTools + "/simulate --output " + kOut + "/sim.bag --rate 200 --duration 1200 --arw 1e-3 --rrw 1e-5 "
                      "--seed 7 --compression none");
    ASSERT_EQ(r.code, 0) << r.err;
    const ToolRun c = run(kTools + "/simulate --output " + kOut + "/sim.csv --rate 200 --duration 1200 --arw 1e-3 --rrw 1e-5 "
                      "--seed 7");
    ASSERT_EQ(c.code, 0) << c.err;
  }
};

TEST_F(Cli, BagRoundTripRecoversDeclaredNoise) {
  const ToolRun r = run(kTools + "/analyze_bag " + kOut + "/sim.bag --output " + kOut + "/bag_out");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("deg/sqrt(h)"), std::string::npos) << r.out;
  const YAML::Node rep = YAML::LoadFile(kOut + "/bag_out/report.yaml");
  EXPECT_EQ(rep["input"]["topic"].as<std::string>(), "/imu");
  for (const char* ax : {"x", "y", "z"}) {
    const YAML::Node a = rep["axes"][ax];
    ASSERT_TRUE(a) << ax;
    EXPECT_EQ(a["samples"].as<long>(), 240000);
    EXPECT_NEAR(a["rate_hz"].as<double>(), 200.0, 1e-6);
    EXPECT_NEAR(a["duration_s"].as<double>(), 1200.0, 1e-3);
    const YAML::Node c = a["coefficients"];
    for (const char* k : {"quantization", "angle_random_walk", "bias_instability", "rate_random_walk", "rate_ramp"}) {
      ASSERT_TRUE(c[k]) << k;
      EXPECT_TRUE(c[k]["value"] && c[k]["sigma"]) << k;
    }
    EXPECT_NEAR(c["angle_random_walk"]["value"].as<double>() / 1e-3, 1.0, 0.03) << ax;
    const double k = c["rate_random_walk"]["value"].as<double>(), ks = c["rate_random_walk"]["sigma"].as<double>();
    EXPECT_LE(std::fabs(k - 1e-5), 3 * ks) << ax;  // 3 sigma: one draw per axis, and B is free to trade with K
    EXPECT_GE(a["fit"]["chi2_dof"].as<double>(), 0.0);
    // The model follows the curve: within x1.3 of the ADEV at every point with >= 20 degrees of freedom.
    EXPECT_LT(a["fit"]["worst_adev_ratio"].as<double>(), 1.3);
  }
  std::ifstream csv(kOut + "/bag_out/allan.csv");
  std::string header;
  std::getline(csv, header);
  EXPECT_EQ(header, "axis,deviation,tau_s,m,dev,dev_lo,dev_hi,edf,alpha,n_terms,model_dev,model_joint_dev,model_check_dev");
}

TEST_F(Cli, CsvInputGivesTheSameAnswerAsTheBag) {
  const ToolRun b = run(kTools + "/analyze_bag " + kOut + "/sim.bag --output " + kOut + "/rt_bag --quiet");
  const ToolRun c = run(kTools + "/analyze_bag --csv " + kOut + "/sim.csv --rate 200 --output " + kOut + "/rt_csv --quiet");
  ASSERT_EQ(b.code, 0) << b.err;
  ASSERT_EQ(c.code, 0) << c.err;
  EXPECT_TRUE(b.out.empty());
  const YAML::Node rb = YAML::LoadFile(kOut + "/rt_bag/report.yaml"), rc = YAML::LoadFile(kOut + "/rt_csv/report.yaml");
  // The CSV's gyro columns wx, wy, wz are the axes x, y, z, as in the bag.
  const double nb = rb["axes"]["x"]["coefficients"]["angle_random_walk"]["value"].as<double>();
  const double nc = rc["axes"]["x"]["coefficients"]["angle_random_walk"]["value"].as<double>();
  EXPECT_NEAR(nb / nc, 1.0, 1e-6);
}

TEST_F(Cli, JsonFormatAndDeviations) {
  const ToolRun r = run(kTools + "/analyze_bag " + kOut + "/sim.bag --format json --deviations oadev,mdev,hdev --tau-grid octave "
                    "--output " + kOut + "/json_out --quiet");
  ASSERT_EQ(r.code, 0) << r.err;
  std::ifstream f(kOut + "/json_out/report.json");
  std::stringstream ss;
  ss << f.rdbuf();
  const YAML::Node j = YAML::Load(ss.str());  // JSON is YAML
  EXPECT_EQ(j["tau_grid"].as<std::string>(), "octave");
  EXPECT_GT(j["axes"]["z"]["coefficients"]["angle_random_walk"]["value"].as<double>(), 0.0);
  std::ifstream csv(kOut + "/json_out/allan.csv");
  std::string line;
  int mdev = 0, hdev = 0;
  while (std::getline(csv, line)) {
    mdev += line.find(",mdev,") != std::string::npos;
    hdev += line.find(",hdev,") != std::string::npos;
  }
  EXPECT_GT(mdev, 10);
  EXPECT_GT(hdev, 10);
}

// The bundled bag (bags/README.md: N = 2e-4 rad/sqrt(s), B = 2e-5 rad/s, K = 2e-6 rad/s/sqrt(s), nothing else): N
// within 2 % on every axis, and the model check — told nothing — adds no effect (a clean control).
TEST_F(Cli, DefaultBagIsACleanControl) {
  const ToolRun r = run(kTools + "/analyze_bag " + std::string(GYRO_ALLAN_SOURCE_DIR) + "/bags/default.bag --output " +
                        kOut + "/default --quiet");
  ASSERT_EQ(r.code, 0) << r.err;
  const YAML::Node rep = YAML::LoadFile(kOut + "/default/report.yaml");
  for (const char* ax : {"x", "y", "z"}) {
    const YAML::Node a = rep["axes"][ax];
    EXPECT_NEAR(a["coefficients"]["angle_random_walk"]["value"].as<double>() / 2e-4, 1.0, 0.02) << ax;
    EXPECT_EQ(a["method"].as<std::string>(), "joint_fit") << ax;
    ASSERT_TRUE(a["model_check"]) << ax;
    EXPECT_EQ(a["model_check"]["effects"].size(), 0u) << ax << ": " << YAML::Dump(a["model_check"]["effects"]);
    // Where lines were looked for: the whole-record periodogram from 4 periods per record, the Welch PSD up to
    // Nyquist (the bundled bag: 100 Hz).
    const YAML::Node ls = a["model_check"]["line_search"];
    ASSERT_TRUE(ls) << ax;
    EXPECT_GT(ls["periodogram_frequencies"].as<int>(), 0) << ax;
    EXPECT_DOUBLE_EQ(ls["periodogram_band_hz"][1].as<double>(), ls["welch_band_hz"][0].as<double>()) << ax;
    EXPECT_DOUBLE_EQ(ls["welch_band_hz"][1].as<double>(), 50.0) << ax;
    EXPECT_DOUBLE_EQ(ls["false_alarm_per_band"].as<double>(), 0.005) << ax;
  }
}

TEST_F(Cli, HelpWorks) {
  const ToolRun r = run(kTools + "/analyze_bag --help");
  EXPECT_EQ(r.code, 0);
  EXPECT_NE(r.out.find("--tau-grid"), std::string::npos);
}

// Each unusable input: non-zero exit and exactly one line on stderr naming the problem.
void expectOneLineError(const ToolRun& r, int code, const std::string& needle) {
  EXPECT_EQ(r.code, code) << r.err;
  EXPECT_EQ(countLines(r.err), 1) << r.err;
  EXPECT_NE(r.err.find(needle), std::string::npos) << r.err;
}

TEST_F(Cli, MissingFile) {
  expectOneLineError(run(kTools + "/analyze_bag /nonexistent.bag --output " + kOut + "/e1"), 2, "/nonexistent.bag");
}

TEST_F(Cli, EmptyBag) {
  {
    rosbag::Bag bag(kOut + "/empty.bag", rosbag::bagmode::Write);
  }
  expectOneLineError(run(kTools + "/analyze_bag " + kOut + "/empty.bag --output " + kOut + "/e2"), 2, "no messages");
}

TEST_F(Cli, WrongTopicTypeAndNoImu) {
  {
    rosbag::Bag bag(kOut + "/temp.bag", rosbag::bagmode::Write);
    sensor_msgs::Temperature t;
    t.header.stamp = ros::Time(100.0);
    t.temperature = 20;
    bag.write("/temperature", t.header.stamp, t);
  }
  expectOneLineError(run(kTools + "/analyze_bag " + kOut + "/temp.bag --topic /temperature --output " + kOut + "/e3"), 2,
                     "sensor_msgs/Temperature");
  expectOneLineError(run(kTools + "/analyze_bag " + kOut + "/temp.bag --output " + kOut + "/e3"), 2,
                     "no sensor_msgs/Imu topic");
  expectOneLineError(run(kTools + "/analyze_bag " + kOut + "/sim.bag --topic /nope --output " + kOut + "/e3"), 2,
                     "'/nope' is not in the bag");
}

TEST_F(Cli, TruncatedBag) {
  ASSERT_EQ(std::system(("head -c 300000 " + kOut + "/sim.bag > " + kOut + "/trunc.bag").c_str()), 0);
  const ToolRun r = run(kTools + "/analyze_bag " + kOut + "/trunc.bag --output " + kOut + "/e4");
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_EQ(countLines(r.err), 1) << r.err;
  EXPECT_NE(r.err.find("trunc.bag"), std::string::npos) << r.err;
}

TEST_F(Cli, BadCommandLine) {
  expectOneLineError(run(kTools + "/analyze_bag " + kOut + "/sim.bag --bogus"), 1, "--bogus");
  expectOneLineError(run(kTools + "/analyze_bag " + kOut + "/sim.bag --tau-grid weird"), 1, "--tau-grid");
  expectOneLineError(run(kTools + "/analyze_bag " + kOut + "/sim.bag --confidence 2"), 1, "--confidence");
  expectOneLineError(run(kTools + "/analyze_bag"), 1, "no input");
  expectOneLineError(run(kTools + "/analyze_bag --csv " + kOut + "/sim.csv --deviations foo"), 1, "foo");
}

TEST_F(Cli, CsvProblems) {
  {
    std::ofstream f(kOut + "/bad.csv");
    f << "t,wx\n0.01,1e-3\n0.02,oops\n";
  }
  expectOneLineError(run(kTools + "/analyze_bag --csv " + kOut + "/bad.csv --rate 100 --output " + kOut + "/e5"), 2,
                     "line 3");
  {
    std::ofstream f(kOut + "/short.csv");
    f << "1e-3\n2e-3\n";
  }
  const ToolRun r = run(kTools + "/analyze_bag --csv " + kOut + "/short.csv --rate 100 --output " + kOut + "/e6");
  EXPECT_EQ(r.code, 3) << r.err;
  EXPECT_EQ(countLines(r.err), 1) << r.err;
  expectOneLineError(run(kTools + "/analyze_bag --csv " + kOut + "/short.csv --output " + kOut + "/e6"), 1, "--rate");
}

}  // namespace
