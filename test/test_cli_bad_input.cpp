// Bad-input matrix of analyze_bag (issue 8): each bad input gives a one-line error and its exit code, or a warning on
// stderr and in report.yaml, with stamp counts that add up to the messages written; failing runs never touch an old
// report. Cases already in test_cli_analyze_bag.cpp (missing file, empty bag, Temperature topic, unknown topic,
// truncated bag, unknown option, bad CSV number, 2-row CSV) are not repeated. Expected behaviour: docs/reliability.md.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <rosbag/bag.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/Temperature.h>
#include <yaml-cpp/yaml.h>

#include "cli_util.hpp"

namespace {

const std::string kTools = GYRO_ALLAN_TOOL_DIR;
const std::string kOut = std::string(GYRO_ALLAN_TEST_OUT) + "/cli_bad";

using gyro_allan_test::slurp;
using gyro_allan_test::ToolRun;
ToolRun run(const std::string& args) { return gyro_allan_test::runTool(args, kOut); }

using gyro_allan_test::countLines;

bool exists(const std::string& p) { return std::ifstream(p).good(); }

void expectOneLineError(const ToolRun& r, int code, const std::string& needle) {
  EXPECT_EQ(r.code, code) << r.err;
  EXPECT_EQ(countLines(r.err), 1) << r.err;
  EXPECT_NE(r.err.find(needle), std::string::npos) << r.err;
  EXPECT_EQ(r.err.rfind("analyze_bag: error: ", 0), 0u) << r.err;
}

/// One IMU message to write: stamp in s after the base epoch (stamp_zero = a zero header stamp), rates in rad/s.
struct Msg {
  double t;
  double x, y, z;
  bool stamp_zero = false;
};

constexpr double kRate = 200.0;
constexpr double kSigma = 1e-3 * 14.142135623730951;  // N = 1e-3 rad/sqrt(s) white noise at 200 Hz

/// 60 s of 200 Hz white rate noise, stamps exact multiples of 5 ms.
std::vector<Msg> cleanRecord(unsigned seed, double seconds = 60.0) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g(0.0, kSigma);
  std::vector<Msg> m;
  const int n = static_cast<int>(seconds * kRate);
  for (int i = 0; i < n; ++i) m.push_back({(i + 1) / kRate, g(rng), g(rng), g(rng)});
  return m;
}

ros::Time stampOf(double t) {
  const int64_t ns = 1700000000LL * 1000000000LL + std::llround(t * 1e9);
  ros::Time s;
  s.fromNSec(static_cast<uint64_t>(ns));
  return s;
}

void writeBag(const std::string& path, const std::vector<Msg>& msgs) {
  rosbag::Bag bag(path, rosbag::bagmode::Write);
  std::mt19937_64 rng(99);
  std::normal_distribution<double> acc(0.0, 0.02);  // accelerometer at rest: gravity on z plus white noise
  ros::Time last = stampOf(0);
  for (const Msg& m : msgs) {
    sensor_msgs::Imu imu;
    imu.header.frame_id = "imu";
    imu.header.stamp = m.stamp_zero ? ros::Time(0, 0) : stampOf(m.t);
    imu.angular_velocity.x = m.x;
    imu.angular_velocity.y = m.y;
    imu.angular_velocity.z = m.z;
    imu.linear_acceleration.x = acc(rng);
    imu.linear_acceleration.y = acc(rng);
    imu.linear_acceleration.z = 9.80665 + acc(rng);
    last += ros::Duration(0, 1000);  // receive time: strictly increasing, whatever the header says
    bag.write("/imu", last, imu);
  }
}

/// Runs analyze_bag on a bag written from msgs; returns the run and (if it succeeded) the report.
struct Analysed {
  ToolRun run;
  YAML::Node report;
};

Analysed analyse(const std::string& name, const std::vector<Msg>& msgs, const std::string& extra = "") {
  const std::string bag = kOut + "/" + name + ".bag", out = kOut + "/" + name;
  writeBag(bag, msgs);
  Analysed a{run(kTools + "/analyze_bag " + bag + " --output " + out + " " + extra), {}};
  if (a.run.code == 0) a.report = YAML::LoadFile(out + "/report.yaml");
  return a;
}

/// "Nothing lost": every message written is counted once, as kept or under one drop reason.
void expectNothingLost(const YAML::Node& rep, int64_t written) {
  const YAML::Node s = rep["stamps"];
  ASSERT_TRUE(s);
  EXPECT_EQ(s["input"].as<int64_t>(), written);
  EXPECT_EQ(s["kept"].as<int64_t>() + s["non_finite"].as<int64_t>() + s["zero_stamp"].as<int64_t>() +
                s["out_of_order"].as<int64_t>() + s["duplicate"].as<int64_t>() + s["too_close"].as<int64_t>() +
                s["short_segment"].as<int64_t>(),
            written);
  // Every axis analyses exactly the kept samples.
  for (const char* ax : {"x", "y", "z"}) EXPECT_EQ(rep["axes"][ax]["samples"].as<int64_t>(), s["kept"].as<int64_t>());
}

/// A warning containing needle is on stderr (a long one wrapped: continuation lines indented) and in report.yaml
/// warnings.
void expectWarning(const Analysed& a, const std::string& needle) {
  EXPECT_NE(a.run.err.find("warning: "), std::string::npos) << a.run.err;
  std::string err = a.run.err;
  for (size_t at = err.find("\n    "); at != std::string::npos; at = err.find("\n    ", at)) err.replace(at, 5, " ");
  EXPECT_NE(err.find(needle), std::string::npos) << a.run.err;
  bool found = false;
  for (const auto& w : a.report["warnings"]) found = found || w.as<std::string>().find(needle) != std::string::npos;
  EXPECT_TRUE(found) << needle;
}

/// No warning at all (a clean control must stay clean: the detectors do not cry wolf).
void expectNoWarning(const Analysed& a) {
  EXPECT_EQ(a.run.err.find("warning"), std::string::npos) << a.run.err;
  EXPECT_EQ(a.report["warnings"].size(), 0u);
}

class BadInput : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    ASSERT_EQ(std::system(("mkdir -p " + kOut).c_str()), 0);
    setenv("GYRO_ALLAN_NO_PLOT", "1", 1);  // the plot is not under test here (and costs a Python start per run)
  }
};

TEST_F(BadInput, CleanControlHasNoWarning) {
  const auto m = cleanRecord(1);
  const Analysed a = analyse("clean", m);
  ASSERT_EQ(a.run.code, 0) << a.run.err;
  expectNoWarning(a);
  expectNothingLost(a.report, static_cast<int64_t>(m.size()));
  EXPECT_EQ(a.report["stamps"]["kept"].as<int64_t>(), 12000);
}

TEST_F(BadInput, NanAndInfSamplesAreCountedAndDropped) {
  auto m = cleanRecord(2);
  const double nan = std::nan(""), inf = INFINITY;
  for (int i : {100, 2000, 4000, 6000, 8000}) m[i].x = nan;
  m[9000].y = inf;
  m[9500].z = -inf;
  m[10000].x = inf;
  const Analysed a = analyse("nan", m);
  ASSERT_EQ(a.run.code, 0) << a.run.err;
  EXPECT_EQ(a.report["stamps"]["non_finite"].as<int>(), 8);
  expectWarning(a, "8 samples with NaN/Inf dropped");
  expectNothingLost(a.report, static_cast<int64_t>(m.size()));
  // The axes stay finite and close to the declared noise.
  EXPECT_NEAR(a.report["axes"]["x"]["coefficients"]["angle_random_walk"]["value"].as<double>() / 1e-3, 1.0, 0.1);
}

TEST_F(BadInput, AllNanIsNotAnalysable) {
  auto m = cleanRecord(3, 5.0);
  for (auto& s : m) s.y = std::nan("");
  const Analysed a = analyse("all_nan", m);
  expectOneLineError(a.run, 3, "too few valid samples (0 of 1000)");
}

TEST_F(BadInput, OutOfOrderDuplicateAndZeroStamps) {
  const auto clean = cleanRecord(4);
  std::vector<Msg> m;
  for (size_t i = 0; i < clean.size(); ++i) {
    Msg s = clean[i];
    if (i == 3000 || i == 3001 || i == 7000) s.stamp_zero = true;  // 3 zero stamps
    m.push_back(s);
    if (i == 5000 || i == 5500) m.push_back(s);                      // 2 duplicates (same stamp, resent)
    if (i % 2000 == 1000) {                                          // 6 stale messages 0.1 s in the past
      Msg old = s;
      old.stamp_zero = false;
      old.t -= 0.1;
      m.push_back(old);
    }
  }
  const Analysed a = analyse("stamps", m);
  ASSERT_EQ(a.run.code, 0) << a.run.err;
  const YAML::Node s = a.report["stamps"];
  EXPECT_EQ(s["zero_stamp"].as<int>(), 3);
  EXPECT_EQ(s["duplicate"].as<int>(), 2);
  EXPECT_EQ(s["out_of_order"].as<int>(), 6);
  EXPECT_EQ(s["kept"].as<int>(), 12000 - 3);
  expectWarning(a, "3 samples with zero stamp dropped");
  expectWarning(a, "2 duplicate stamps dropped");
  expectWarning(a, "6 out-of-order stamps dropped");
  expectNothingLost(a.report, static_cast<int64_t>(m.size()));
}

TEST_F(BadInput, ForwardStampGlitchLosesOnlyItself) {
  // One stamp 1000 s in the future must not make the rest of the bag "out of order".
  auto m = cleanRecord(5);
  m[100].t += 1000.0;
  const Analysed a = analyse("glitch", m);
  ASSERT_EQ(a.run.code, 0) << a.run.err;
  EXPECT_EQ(a.report["stamps"]["out_of_order"].as<int>(), 1);
  EXPECT_EQ(a.report["stamps"]["kept"].as<int>(), 11999);
  expectNothingLost(a.report, static_cast<int64_t>(m.size()));
}

TEST_F(BadInput, GapsSplitSegmentsAndIsolatedSamplesAreCounted) {
  const auto clean = cleanRecord(6);
  std::vector<Msg> m;
  for (size_t i = 0; i < clean.size(); ++i) {
    if (i >= 4000 && i < 4400) continue;                 // 2 s missing
    if ((i >= 8000 && i < 8010) || (i > 8010 && i < 8020)) continue;  // sample 8010 alone between two gaps
    m.push_back(clean[i]);
  }
  const Analysed a = analyse("gaps", m);
  ASSERT_EQ(a.run.code, 0) << a.run.err;
  const YAML::Node s = a.report["stamps"];
  EXPECT_EQ(s["gaps"].as<int>(), 3);
  EXPECT_NEAR(s["gap_time_s"].as<double>(), 2.0 + 0.05 + 0.045, 1e-6);
  EXPECT_EQ(s["short_segment"].as<int>(), 1);
  expectWarning(a, "3 gaps");
  expectWarning(a, "1 samples isolated between gaps dropped");
  expectNothingLost(a.report, static_cast<int64_t>(m.size()));
  EXPECT_EQ(a.report["axes"]["x"]["segments"].as<int>(), 3);
}

TEST_F(BadInput, RateChangeMidBagIsFlagged) {
  auto m = cleanRecord(7);
  for (size_t i = 6000; i < m.size(); ++i) m[i].t = m[5999].t + (i - 5999) / 250.0;  // 200 -> 250 Hz
  const Analysed a = analyse("rate_change", m);
  ASSERT_EQ(a.run.code, 0) << a.run.err;
  EXPECT_TRUE(a.report["stamps"]["rate_changed"].as<bool>());
  expectWarning(a, "sample rate changes within the record");
  expectNothingLost(a.report, static_cast<int64_t>(m.size()));
}

TEST_F(BadInput, ImpulsiveShocksAreCounted) {
  auto m = cleanRecord(8);
  const double deg = M_PI / 180.0;
  for (int k = 0; k < 12; ++k) m[500 + 900 * k].z += (k % 2 ? -1 : 1) * (20 + 5 * k) * deg;  // 20..75 deg/s
  const Analysed a = analyse("shocks", m);
  ASSERT_EQ(a.run.code, 0) << a.run.err;
  // Removed as spikes (spikes.hpp) and reported with the with-spikes N alongside; no other axis is touched.
  expectWarning(a, "axis z: 12 spikes removed");
  expectWarning(a, "with them N would be");
  EXPECT_EQ(a.report["axes"]["z"]["spikes"]["count"].as<int>(), 12);
  EXPECT_EQ(a.report["axes"]["x"]["spikes"]["count"].as<int>(), 0);
  for (const auto& w : a.report["warnings"]) EXPECT_EQ(w.as<std::string>().find("axis x"), std::string::npos);
  expectNothingLost(a.report, static_cast<int64_t>(m.size()));
  // --keep-spikes: the old behaviour, a warning only.
  const Analysed k = analyse("shocks_kept", m, "--keep-spikes");
  ASSERT_EQ(k.run.code, 0) << k.run.err;
  expectWarning(k, "axis z: 12 impulsive samples");
  EXPECT_FALSE(k.report["axes"]["z"]["spikes"]);
}

TEST_F(BadInput, SaturatedRunIsFlagged) {
  auto m = cleanRecord(9);
  for (int i = 3000; i < 3040; ++i) m[i].y = 8.72664625997;  // 40 samples stuck at +500 deg/s
  for (int i = 9000; i < 9006; ++i) m[i].y = -8.72664625997;
  const Analysed a = analyse("saturated", m);
  ASSERT_EQ(a.run.code, 0) << a.run.err;
  expectWarning(a, "axis y: 2 runs of identical extreme values (46 samples): saturation");
  EXPECT_EQ(a.run.err.find("impulsive"), std::string::npos) << a.run.err;
}

TEST_F(BadInput, BiasOf50RadPerSecondIsNotAGyroAtRest) {
  auto m = cleanRecord(10);
  for (auto& s : m) s.x += 50.0;  // deg/s data read as rad/s, or a spinning table
  // The at-rest check refuses it (a mean rate above 0.35 rad/s is a turn, not a gyro bias): exit 3, one line.
  const Analysed a = analyse("bias50", m);
  expectOneLineError(a.run, 3, "not at rest");
  EXPECT_NE(a.run.err.find("mean rate 50"), std::string::npos) << a.run.err;
  // --no-rest-check analyses it anyway, with the old warning on the mean.
  const Analysed b = analyse("bias50_unchecked", m, "--no-rest-check");
  ASSERT_EQ(b.run.code, 0) << b.run.err;
  expectWarning(b, "axis x: mean rate 50");
  expectWarning(b, "not a gyro at rest");
  EXPECT_EQ(b.run.err.find("axis y: mean"), std::string::npos) << b.run.err;
}

TEST_F(BadInput, RecordTooShortForTheRequestedDuration) {
  writeBag(kOut + "/short_src.bag", cleanRecord(11, 10.0));
  // --duration 0.01 s keeps 2 samples: not enough for one Allan point.
  expectOneLineError(run(kTools + "/analyze_bag " + kOut + "/short_src.bag --duration 0.01 --output " + kOut + "/s1"), 3,
                     "too few valid samples");
  // --start past the end: nothing in range.
  expectOneLineError(run(kTools + "/analyze_bag " + kOut + "/short_src.bag --start 100 --output " + kOut + "/s2"), 2,
                     "no messages in the requested time range");
}

TEST_F(BadInput, AllZeroStampsAreNotAnalysable) {
  auto m = cleanRecord(12, 2.0);
  for (auto& s : m) s.stamp_zero = true;
  expectOneLineError(analyse("zero_all", m).run, 3, "too few valid samples (0 of 400)");
}

TEST_F(BadInput, CorruptBagsGiveOneLine) {
  writeBag(kOut + "/good.bag", cleanRecord(13, 10.0));
  const std::string good = slurp(kOut + "/good.bag");
  // Garbage in the middle of the chunk data (header intact).
  std::string bad = good;
  for (size_t i = bad.size() / 3; i < bad.size() / 3 + 4096 && i < bad.size(); ++i) bad[i] = static_cast<char>(0xA5);
  std::ofstream(kOut + "/corrupt.bag", std::ios::binary) << bad;
  const ToolRun r1 = run(kTools + "/analyze_bag " + kOut + "/corrupt.bag --output " + kOut + "/c1");
  EXPECT_NE(r1.code, 0);
  EXPECT_NE(r1.code, -1) << "crashed";
  if (r1.code != 0) {
    EXPECT_EQ(countLines(r1.err), 1) << r1.err;
  }
  // Not a bag at all.
  std::ofstream(kOut + "/text.bag") << "this is not a rosbag\n";
  expectOneLineError(run(kTools + "/analyze_bag " + kOut + "/text.bag --output " + kOut + "/c2"), 2, "text.bag");
  // Zero-length file.
  std::ofstream(kOut + "/zero.bag").close();
  expectOneLineError(run(kTools + "/analyze_bag " + kOut + "/zero.bag --output " + kOut + "/c3"), 2, "zero.bag");
}

TEST_F(BadInput, WrongMessageTypeOnTheImuTopic) {
  // /imu carries Imu messages and, from a second publisher, Temperature messages.
  {
    rosbag::Bag bag(kOut + "/mixed.bag", rosbag::bagmode::Write);
    const auto m = cleanRecord(14, 2.0);
    for (size_t i = 0; i < m.size(); ++i) {
      sensor_msgs::Imu imu;
      imu.header.stamp = stampOf(m[i].t);
      bag.write("/imu", imu.header.stamp, imu);
      if (i == 200) {
        sensor_msgs::Temperature t;
        t.header.stamp = imu.header.stamp;
        bag.write("/imu", t.header.stamp, t);
      }
    }
  }
  const ToolRun r = run(kTools + "/analyze_bag " + kOut + "/mixed.bag --output " + kOut + "/w1");
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_EQ(countLines(r.err), 1) << r.err;
  EXPECT_NE(r.err.find("/imu"), std::string::npos) << r.err;
}

TEST_F(BadInput, AbsurdParameters) {
  writeBag(kOut + "/params.bag", cleanRecord(15, 5.0));
  const std::string b = kTools + "/analyze_bag " + kOut + "/params.bag --output " + kOut + "/p ";
  expectOneLineError(run(b + "--rate 0"), 1, "--rate must be > 0");
  expectOneLineError(run(b + "--rate -200"), 1, "--rate must be > 0");
  expectOneLineError(run(b + "--rate nan"), 1, "--rate needs a number");
  expectOneLineError(run(b + "--rate 1e999"), 1, "--rate needs a number");
  expectOneLineError(run(b + "--rate 200Hz"), 1, "--rate needs a number");
  expectOneLineError(run(b + "--duration -1"), 1, "--duration");
  expectOneLineError(run(b + "--start -5"), 1, "--start");
  expectOneLineError(run(b + "--gap-factor 0.5"), 1, "--gap-factor");
  expectOneLineError(run(b + "--gap-factor 1"), 1, "--gap-factor");
  expectOneLineError(run(b + "--confidence 0"), 1, "--confidence");
  expectOneLineError(run(b + "--tau-grid log:0"), 1, "--tau-grid");
  expectOneLineError(run(b + "--tau-grid log:-3"), 1, "--tau-grid");
  expectOneLineError(run(b + "--format xml"), 1, "--format");
  expectOneLineError(run(b + "--input angle"), 1, "--input angle");
  expectOneLineError(run(b + "--rate"), 1, "--rate needs a value");
}

TEST_F(BadInput, CsvWithBadRows) {
  auto write = [](const std::string& name, const std::string& text) {
    std::ofstream(kOut + "/" + name) << text;
    return kOut + "/" + name;
  };
  const std::string a = kTools + "/analyze_bag --rate 100 --output " + kOut + "/csv_out --csv ";
  expectOneLineError(run(a + write("cols.csv", "t,wx,wy\n0.01,1,2\n0.02,1\n")), 2, "line 3: expected 3 columns, found 2");
  expectOneLineError(run(a + write("header_only.csv", "t,wx,wy,wz\n")), 2, "no data rows");
  expectOneLineError(run(a + write("empty.csv", "")), 2, "no data rows");
  expectOneLineError(run(a + write("only_time.csv", "time\n1\n2\n")), 2, "no value column");
  expectOneLineError(run(a + write("binary.csv", std::string("\x7f" "ELF\x01\x02\x00\x00junk", 12))), 2, "binary.csv");
  expectOneLineError(run(a + kOut + "/no_such.csv"), 2, "no_such.csv");
  expectOneLineError(run(a + kOut + "/cols.csv --units furlongs"), 1, "--units");
  // NaN / Inf cells are counted like bag samples; stamps in the time column are sanitized the same way.
  std::string text = "t,w\n";
  std::mt19937 rng(3);
  std::normal_distribution<double> g(0, kSigma);
  int rows = 0;
  for (int i = 1; i <= 4000; ++i) {
    char buf[64];
    const double t = i / 100.0;
    if (i == 50) text += "0.5,nan\n";
    else if (i == 60) text += "0.6,inf\n";
    else if (i == 70) text += "0.1,0.001\n";  // out of order
    else {
      std::snprintf(buf, sizeof buf, "%.2f,%.9g\n", t, g(rng));
      text += buf;
    }
    ++rows;
  }
  const ToolRun r = run(a + write("nan.csv", text));
  ASSERT_EQ(r.code, 0) << r.err;
  const YAML::Node rep = YAML::LoadFile(kOut + "/csv_out/report.yaml");
  EXPECT_EQ(rep["stamps"]["input"].as<int>(), rows);
  EXPECT_EQ(rep["stamps"]["non_finite"].as<int>(), 2);
  EXPECT_EQ(rep["stamps"]["out_of_order"].as<int>(), 1);
  EXPECT_EQ(rep["stamps"]["kept"].as<int>(), rows - 3);
}

TEST_F(BadInput, FailedRunLeavesThePreviousReportIntact) {
  writeBag(kOut + "/keep.bag", cleanRecord(16, 20.0));
  const std::string out = kOut + "/keep_out";
  ASSERT_EQ(run(kTools + "/analyze_bag " + kOut + "/keep.bag --quiet --output " + out).code, 0);
  const std::string report = slurp(out + "/report.yaml"), csv = slurp(out + "/allan.csv");
  ASSERT_FALSE(report.empty());
  // Unusable input, unanalysable data, and a bad command line into the same folder.
  std::ofstream(kOut + "/garbage.bag") << "garbage";
  EXPECT_EQ(run(kTools + "/analyze_bag " + kOut + "/garbage.bag --output " + out).code, 2);
  EXPECT_EQ(run(kTools + "/analyze_bag " + kOut + "/keep.bag --duration 0.005 --output " + out).code, 3);
  EXPECT_EQ(run(kTools + "/analyze_bag " + kOut + "/keep.bag --rate 0 --output " + out).code, 1);
  EXPECT_EQ(slurp(out + "/report.yaml"), report);
  EXPECT_EQ(slurp(out + "/allan.csv"), csv);
  EXPECT_FALSE(exists(out + "/report.yaml.tmp"));
  EXPECT_FALSE(exists(out + "/allan.csv.tmp"));
}

TEST_F(BadInput, UnwritableOutputIsExit4) {
  writeBag(kOut + "/w.bag", cleanRecord(17, 5.0));
  // A regular file where the output folder should be.
  std::ofstream(kOut + "/a_file") << "x";
  expectOneLineError(run(kTools + "/analyze_bag " + kOut + "/w.bag --quiet --output " + kOut + "/a_file/sub"), 4,
                     "a_file");
  // report.yaml is a folder: the rename fails and no .tmp is left behind.
  ASSERT_EQ(std::system(("mkdir -p " + kOut + "/dirrep/report.yaml/x").c_str()), 0);
  expectOneLineError(run(kTools + "/analyze_bag " + kOut + "/w.bag --quiet --output " + kOut + "/dirrep"), 4,
                     "report.yaml");
  EXPECT_FALSE(exists(kOut + "/dirrep/report.yaml.tmp"));
}

}  // namespace
