// rostest soak node: publishes 10 kHz sensor_msgs/Imu to AnalyzerNodelet with one bad message in ~250 (NaN, Inf,
// saturated, zero stamp, out-of-order, duplicate, other-source) and checks that every valid message was accepted,
// every bad one counted under its reason in /diagnostics, and the nodelet's RSS stayed flat.
#include <gtest/gtest.h>

#include <dirent.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>
#include <string>

#include <diagnostic_msgs/DiagnosticStatus.h>
#include <geometry_msgs/Vector3Stamped.h>
#include <gyro_allan/NoiseReport.h>
#include <ros/ros.h>
#include <sensor_msgs/Imu.h>

#include "nodelet_util.hpp"

namespace {

using namespace nodelet_test;

const char* kNode = "soak_analyzer";

/// PID of the nodelet process: the one whose command line holds __name:=soak_analyzer. 0 if not found.
int nodeletPid() {
  DIR* d = opendir("/proc");
  if (!d) return 0;
  int found = 0;
  while (dirent* e = readdir(d)) {
    const int pid = std::atoi(e->d_name);
    if (pid <= 0) continue;
    std::ifstream f("/proc/" + std::string(e->d_name) + "/cmdline", std::ios::binary);
    std::string cmd((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    std::replace(cmd.begin(), cmd.end(), '\0', ' ');
    if (cmd.find("__name:=" + std::string(kNode) + " ") != std::string::npos ||
        (cmd.find("__name:=" + std::string(kNode)) != std::string::npos &&
         cmd.find("AnalyzerNodelet") != std::string::npos)) {
      found = pid;
      break;
    }
  }
  closedir(d);
  return found;
}

/// VmRSS of a process in kB (0 if unreadable).
long rssKb(int pid) {
  std::ifstream f("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(f, line))
    if (line.rfind("VmRSS:", 0) == 0) return std::atol(line.c_str() + 6);
  return 0;
}

/// The test's view of the nodelet: its IMU and angle input, ~noise and diagnostics.
struct Soak {
  ros::NodeHandle nh;
  ros::Publisher imu_pub_ = nh.advertise<sensor_msgs::Imu>("imu", 200000);
  ros::Publisher angle_pub_ = nh.advertise<geometry_msgs::Vector3Stamped>("angle", 1000);
  Latest<gyro_allan::NoiseReport> reports{nh, std::string(kNode) + "/noise", 100};
  Diagnostics diag{nh, kNode};
  double rate_ = 10000;
  ros::Time t0_{2000.0};

  /// A counter from the diagnostics key/values (-1 until seen).
  double value(const std::string& key) { return diag.value(key, -1.0); }
  ros::Time stamp(int64_t k) const { return t0_ + ros::Duration(static_cast<double>(k) / rate_); }
  void publish(const ros::Time& st, double x, double y, double z) { imu_pub_.publish(imuMessage(st, x, y, z)); }
};

}  // namespace

TEST(NodeletSoak, NothingLostMemoryFlatDiagnosticsConsistent) {
  ros::NodeHandle pnh("~");
  double duration = 30, rate = 10000;
  pnh.param("duration_s", duration, duration);
  pnh.param("rate_hz", rate, rate);
  Soak s;
  s.rate_ = rate;
  ASSERT_TRUE(waitFor(30.0, [&] {
    return s.imu_pub_.getNumSubscribers() > 0 && s.angle_pub_.getNumSubscribers() > 0 && s.reports.publishers() > 0;
  })) << "analyzer nodelet did not come up";
  const int pid = nodeletPid();
  ASSERT_GT(pid, 0) << "nodelet process not found in /proc";
  ros::WallDuration(0.5).sleep();

  std::mt19937_64 rng(8);
  std::normal_distribution<double> g(0.0, 1e-3 * std::sqrt(rate));  // N = 1e-3 rad/sqrt(s)
  enum Bad { kNan, kInf, kSat, kZero, kOoo, kDup, kOther, kNumBad };
  const char* names[kNumBad] = {"NaN", "Inf", "saturated", "zero stamp", "out of order", "duplicate", "other source"};
  int64_t sent_bad[kNumBad] = {};
  int64_t valid = 0, total = 0, k = 0;  // k: stamp slot of the next message
  const int per_tick = static_cast<int>(rate / 100);
  const int64_t ticks = static_cast<int64_t>(duration * 100);
  long rss_start = 0, rss_peak = 0;
  double last[3] = {0, 0, 0};  // the last valid sample's values (a duplicate resends them with its stamp)
  ros::WallRate tick(100);
  const ros::WallTime wall0 = ros::WallTime::now();
  for (int64_t t = 0; t < ticks && ros::ok(); ++t) {
    for (int j = 0; j < per_tick; ++j) {
      ++total;
      // One bad message in 250, cycling through the kinds; none in the first 2 s and the last 3 s (the newest
      // samples' problems are counted by the next analysis, after the stamp grid's lookahead).
      if (k > 2 * rate && t < ticks - 300 && total % 250 == 0) {
        const int b = static_cast<int>((total / 250) % kNumBad);
        ++sent_bad[b];
        switch (b) {
          case kNan: s.publish(s.stamp(k++), std::nan(""), 0, 0); break;
          case kInf: s.publish(s.stamp(k++), 0, -INFINITY, 0); break;
          case kSat: s.publish(s.stamp(k++), 0, 0, 20.0); break;
          case kZero: s.publish(ros::Time(0, 0), 0, 0, 0); break;
          case kOoo: s.publish(s.stamp(k - 3), 0, 0, 0); break;
          case kDup: s.publish(s.stamp(k - 1), last[0], last[1], last[2]); break;  // the last sample resent
          default: {
            geometry_msgs::Vector3Stamped a;
            a.header.stamp = s.stamp(k);
            s.angle_pub_.publish(a);
          }
        }
        continue;
      }
      for (double& v : last) v = g(rng);
      s.publish(s.stamp(k++), last[0], last[1], last[2]);
      ++valid;
    }
    if (t == 1200) rss_start = rssKb(pid);  // 12 s in: the 10 s window is full, queues in steady state
    if (t % 100 == 0) rss_peak = std::max(rss_peak, rssKb(pid));
    tick.sleep();
  }
  const double wall = (ros::WallTime::now() - wall0).toSec();
  // Drain: wait until the nodelet has received every message (or 30 s), then have the window analysed once more
  // (~analyze): the problem counters are updated per analysed window.
  auto received = [&] { return s.value("samples received (total)") + s.value("other source ignored (total)"); };
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(30.0);
  while (ros::WallTime::now() < end && received() < static_cast<double>(total)) ros::WallDuration(0.2).sleep();
  const int reports_before = s.reports.count();
  for (int tries = 0; tries < 100; ++tries) {  // refused while a hop's analysis runs
    std_srvs::Trigger::Response res;
    if (callTrigger(kNode, "analyze", &res) && res.success) break;
    ros::WallDuration(0.2).sleep();
  }
  const ros::WallTime end2 = ros::WallTime::now() + ros::WallDuration(30.0);
  while (ros::WallTime::now() < end2 && s.reports.count() == reports_before) ros::WallDuration(0.1).sleep();
  ros::WallDuration(1.5).sleep();  // one more diagnostics period with the final counts
  const long rss_end = rssKb(pid);

  const double accepted = s.value("samples received (total)") - s.value("NaN/Inf dropped (total)") -
                          s.value("zero stamps (total)") - s.value("out of order (total)") -
                          s.value("duplicates (total)") - s.value("too close (total)") -
                          s.value("short segments dropped (total)");
  // Figures go to stdout and to GYRO_ALLAN_TEST_OUT/nodelet_soak.txt (scripts/soak.sh prints that file).
  std::system(("mkdir -p " + std::string(GYRO_ALLAN_TEST_OUT)).c_str());
  FILE* fig = std::fopen((std::string(GYRO_ALLAN_TEST_OUT) + "/nodelet_soak.txt").c_str(), "w");
  for (FILE* out : {stdout, fig}) {
    if (!out) continue;
    std::fprintf(out, "soak: %.0f s at %.0f Hz (wall %.1f s): sent %lld (valid %lld, bad %lld), accepted %.0f\n", duration,
              rate, wall, static_cast<long long>(total), static_cast<long long>(valid),
              static_cast<long long>(total - valid), accepted);
    for (int b = 0; b < kNumBad; ++b) std::fprintf(out, "soak: bad %-13s sent %lld\n", names[b], static_cast<long long>(sent_bad[b]));
    std::fprintf(out, "soak: counters: NaN/Inf %.0f, too close %.0f, zero %.0f, out-of-order %.0f, duplicate %.0f, other %.0f\n",
              s.value("NaN/Inf dropped (total)"), s.value("too close (total)"), s.value("zero stamps (total)"),
              s.value("out of order (total)"), s.value("duplicates (total)"), s.value("other source ignored (total)"));
    std::fprintf(out, "soak: nodelet pid %d RSS start %ld kB, peak %ld kB, end %ld kB; noise reports %d\n", pid,
                 rss_start, rss_peak, rss_end, s.reports.count());
    std::fflush(out);
  }
  if (fig) std::fclose(fig);

  // Nothing lost: every valid message accepted, every bad one counted under its own reason, once (the windows
  // overlap 5 times). A single out-of-range value ("saturated", 20 rad/s) is not dropped: analyze_bag's rules call a
  // run of >= 5 equal extreme values saturation; a lone one is a spike, replaced by the spike rule and kept.
  EXPECT_EQ(s.value("samples received (total)"), static_cast<double>(total - sent_bad[kOther]));
  EXPECT_EQ(accepted, static_cast<double>(valid + sent_bad[kSat]));
  EXPECT_EQ(s.value("NaN/Inf dropped (total)"), static_cast<double>(sent_bad[kNan] + sent_bad[kInf]));
  EXPECT_EQ(s.value("samples aged out uncounted (total)"), 0.0);
  EXPECT_EQ(s.value("zero stamps (total)"), static_cast<double>(sent_bad[kZero]));
  EXPECT_EQ(s.value("out of order (total)"), static_cast<double>(sent_bad[kOoo]));
  EXPECT_EQ(s.value("duplicates (total)"), static_cast<double>(sent_bad[kDup]));
  EXPECT_EQ(s.value("other source ignored (total)"), static_cast<double>(sent_bad[kOther]));
  // Statuses raised by the faults; the fit keeps running at the learned rate.
  EXPECT_GE(s.diag.maxLevel("stamps"), diagnostic_msgs::DiagnosticStatus::WARN);
  EXPECT_GE(s.diag.maxLevel("input values"), diagnostic_msgs::DiagnosticStatus::WARN);
  EXPECT_GT(s.reports.count(), 0);
  EXPECT_NEAR(s.reports.last().rate_hz, rate, 0.01 * rate);
  // Memory flat: after warm-up, RSS grows by less than 16 MB + 10 % (roscpp buffers breathe; a leak of one
  // allocation per message would add > 40 MB at 10 kHz in 30 s).
  ASSERT_GT(rss_start, 0);
  EXPECT_LT(rss_end, rss_start + 16 * 1024 + rss_start / 10) << "RSS start " << rss_start << " kB, end " << rss_end;
}

int main(int argc, char** argv) { return nodelet_test::runRostest(argc, argv, "nodelet_soak", 1); }
