// analyze_bag --angle-topic (issue 15): geometry_msgs/Vector3Stamped angles from a bag give the coefficients of the
// rates they came from, accumulated or as increments; wrong, missing and empty angle topics are one-line errors.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <string>

#include <geometry_msgs/Vector3Stamped.h>
#include <rosbag/bag.h>
#include <sensor_msgs/Imu.h>
#include <yaml-cpp/yaml.h>

#include "cli_util.hpp"
#include "gyro_allan/simulate.hpp"

namespace {

const std::string kTools = GYRO_ALLAN_TOOL_DIR;
const std::string kOut = std::string(GYRO_ALLAN_TEST_OUT) + "/cli_angle";
const std::string kBag = kOut + "/rlg.bag";
constexpr double kQ = 1.6968e-6, kN = 2.909e-7;

using gyro_allan_test::ToolRun;
ToolRun run(const std::string& args) { return gyro_allan_test::runTool(args, kOut); }

using gyro_allan_test::countLines;

void expectOneLineError(const ToolRun& r, int code, const std::string& needle) {
  EXPECT_EQ(r.code, code) << r.err;
  EXPECT_EQ(countLines(r.err), 1) << r.err;
  EXPECT_NE(r.err.find(needle), std::string::npos) << r.err;
  EXPECT_EQ(r.err.rfind("analyze_bag: error: ", 0), 0u) << r.err;
}

class AngleCli : public ::testing::Test {
 protected:
  // The undithered ring-laser gyro of test_cli_outputs (Q = 0.35 arcsec, N = 0.001 deg/sqrt(h), 400 Hz, 10 min,
  // 10 deg/h input) on all three axes, in one bag three ways: /imu rates (sensor_msgs/Imu), /angle the accumulated
  // angle (one point more than the rates: the angle before the first sample, a period earlier), /angle_inc the
  // angle increment of each sample.
  static void SetUpTestSuite() {
    setenv("GYRO_ALLAN_NO_PLOT", "1", 1);
    ASSERT_EQ(std::system(("mkdir -p " + kOut).c_str()), 0);
    gyro_allan::SimulationSpec spec;
    spec.rate_hz = 400;
    spec.duration_s = 600;
    spec.seed = 3;
    for (auto& a : spec.axes) {
      a.quantization = kQ;
      a.dither = false;
      a.angle_random_walk = kN;
      a.input_rate = 4.848e-5;
    }
    const gyro_allan::SimulatedData d = gyro_allan::simulate(spec);
    const double tau0 = 1.0 / spec.rate_hz, t0 = 1700000000.0;
    rosbag::Bag bag(kBag, rosbag::bagmode::Write);
    long double acc[3] = {0, 0, 0};
    auto angle = [&](const ros::Time& stamp, const std::string& topic, double x, double y, double z) {
      geometry_msgs::Vector3Stamped v;
      v.header.stamp = stamp;
      v.header.frame_id = "imu_link";
      v.vector.x = x;
      v.vector.y = y;
      v.vector.z = z;
      bag.write(topic, stamp, v);
    };
    angle(ros::Time(t0 - tau0), "/angle", 0, 0, 0);
    for (size_t k = 0; k < d.t.size(); ++k) {
      const ros::Time stamp(t0 + d.t[k]);
      sensor_msgs::Imu imu;
      imu.header.stamp = stamp;
      imu.header.frame_id = "imu_link";
      imu.angular_velocity.x = d.rate[0][k];
      imu.angular_velocity.y = d.rate[1][k];
      imu.angular_velocity.z = d.rate[2][k];
      bag.write("/imu", stamp, imu);
      for (int a = 0; a < 3; ++a) acc[a] += static_cast<long double>(d.rate[a][k]) * tau0;
      angle(stamp, "/angle", static_cast<double>(acc[0]), static_cast<double>(acc[1]), static_cast<double>(acc[2]));
      angle(stamp, "/angle_inc", d.rate[0][k] * tau0, d.rate[1][k] * tau0, d.rate[2][k] * tau0);
    }
  }
};

// The same coefficients from the angle as from the rate (to the 4-byte sample storage's rounding: 1e-4 is a
// hundred times what it costs here), the split's Q within 5 % and N within 10 % of the truth, and the report says
// what was read.
TEST_F(AngleCli, AngleTopicGivesTheRatesCoefficients) {
  // Like with like: the rate run without the rate-only stages (at-rest check, spike removal).
  const ToolRun r = run(kTools + "/analyze_bag " + kBag + " --topic /imu --no-rest-check --keep-spikes --no-accel "
                        "--output " + kOut + "/rate");
  ASSERT_EQ(r.code, 0) << r.err;
  const YAML::Node rate = YAML::LoadFile(kOut + "/rate/report.yaml");
  for (const std::string mode : {"accumulated", "increment"}) {
    const std::string topic = mode == "accumulated" ? "/angle" : "/angle_inc";
    const std::string out = kOut + "/" + mode;
    const ToolRun a = run(kTools + "/analyze_bag " + kBag + " --angle-topic " + topic + " --angle-mode " + mode +
                          " --output " + out);
    ASSERT_EQ(a.code, 0) << a.err;
    EXPECT_EQ(a.err.find("skipped"), std::string::npos) << a.err;
    const YAML::Node rep = YAML::LoadFile(out + "/report.yaml");
    EXPECT_EQ(rep["input"]["topic"].as<std::string>(), topic);
    EXPECT_EQ(rep["input"]["kind"].as<std::string>(), mode == "accumulated" ? "angle" : "angle_increment");
    EXPECT_EQ(rep["input"]["units"].as<std::string>(), "rad");
    for (const char* ax : {"x", "y", "z"}) {
      const YAML::Node aa = rep["axes"][ax], ra = rate["axes"][ax];
      EXPECT_EQ(aa["method"].as<std::string>(), "wavelet_split") << mode << " " << ax;
      EXPECT_EQ(aa["method"].as<std::string>(), ra["method"].as<std::string>()) << mode << " " << ax;
      EXPECT_EQ(aa["samples"].as<int64_t>(), ra["samples"].as<int64_t>()) << mode << " " << ax;
      EXPECT_TRUE(aa["methods"]["wavelet_split"]) << mode << " " << ax;
      // The pulse count is recognised from the angle too (an accumulated angle through the 4-byte storage is off the
      // lattice by up to 2^-11 of the largest rate: analysis.cpp), so the split's sawtooth bootstrap runs as for the
      // rate, with the same replicas.
      ASSERT_TRUE(aa["quantized_output"]) << mode << " " << ax;
      EXPECT_TRUE(aa["quantized_output"]["sawtooth"].as<bool>()) << mode << " " << ax;
      EXPECT_TRUE(aa["methods"]["wavelet_split"]["sawtooth_bootstrap"]["applied"].as<bool>()) << mode << " " << ax;
      EXPECT_TRUE(ra["methods"]["wavelet_split"]["sawtooth_bootstrap"]["applied"].as<bool>()) << ax;
      EXPECT_TRUE(aa["model_check"]) << mode << " " << ax;
      const YAML::Node c = aa["coefficients"], rc = ra["coefficients"];
      EXPECT_NEAR(c["quantization"]["value"].as<double>() / kQ, 1.0, 0.05) << mode << " " << ax;
      EXPECT_NEAR(c["angle_random_walk"]["value"].as<double>() / kN, 1.0, 0.10) << mode << " " << ax;
      for (const char* t : {"quantization", "angle_random_walk", "bias_instability", "rate_random_walk", "rate_ramp"}) {
        ASSERT_EQ(c[t]["supported"].as<bool>(), rc[t]["supported"].as<bool>()) << mode << " " << ax << " " << t;
        if (rc[t]["supported"].as<bool>()) {
          EXPECT_NEAR(c[t]["value"].as<double>() / rc[t]["value"].as<double>(), 1.0, 1e-4) << mode << " " << ax << " " << t;
        }
      }
    }
  }
}

TEST_F(AngleCli, WrongMissingAndEmptyAngleTopicsAreOneLineErrors) {
  const std::string o = " --output " + kOut + "/err";
  expectOneLineError(run(kTools + "/analyze_bag " + kBag + " --angle-topic /imu" + o), 2,
                     "has type sensor_msgs/Imu, not geometry_msgs/Vector3Stamped");
  expectOneLineError(run(kTools + "/analyze_bag " + kBag + " --angle-topic /nope" + o), 2, "'/nope' is not in the bag");
  expectOneLineError(run(kTools + "/analyze_bag " + kBag + " --angle-topic /angle --start 100000" + o), 2,
                     "'/angle' has no messages");
  expectOneLineError(run(kTools + "/analyze_bag " + kBag + " --angle-topic /angle --topic /imu" + o), 1,
                     "--topic or --angle-topic");
  expectOneLineError(run(kTools + "/analyze_bag " + kBag + " --angle-topic /angle --angle-mode sum" + o), 1,
                     "--angle-mode must be accumulated or increment");
  expectOneLineError(run(kTools + "/analyze_bag " + kBag + " --input angle" + o), 1, "--angle-topic");
}

}  // namespace
