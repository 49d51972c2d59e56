// The direct chunk reader (bag_direct.cpp) must give exactly what rosbag::View gives, and step aside when unsure.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

#include <rosbag/bag.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/Temperature.h>
#include <std_msgs/String.h>

#include "gyro_allan/io/bag_input.hpp"
#include "../src/io/bag_direct.hpp"

using namespace gyro_allan;

namespace {

std::string outPath(const std::string& name) {
  static const bool made = [] {  // a clean build has no test_out directory yet
    ::mkdir(GYRO_ALLAN_TEST_OUT, 0755);
    return true;
  }();
  (void)made;
  return std::string(GYRO_ALLAN_TEST_OUT) + "/bag_reader_" + name;
}

struct BagSpec {
  rosbag::compression::CompressionType compression = rosbag::compression::Uncompressed;
  int n = 3000;
  double t0 = 1700000000.0;
  bool temperature = true, other_topic = true, record_times_backwards = false, zero_stamps = false;
};

/// IMU at 200 Hz with a temperature topic at 1 Hz and an unrelated topic, small chunks (many of them).
void writeBag(const std::string& path, const BagSpec& spec) {
  rosbag::Bag bag(path, rosbag::bagmode::Write);
  bag.setCompression(spec.compression);
  bag.setChunkThreshold(2048);
  for (int i = 0; i < spec.n; ++i) {
    const int k = spec.record_times_backwards && i == spec.n / 2 ? i - 50 : i;  // one record written late
    const ros::Time rec(spec.t0 + 0.005 * k + 0.0011);
    sensor_msgs::Imu m;
    m.header.seq = static_cast<uint32_t>(i);
    m.header.stamp = spec.zero_stamps && i % 97 == 5 ? ros::Time() : ros::Time(spec.t0 + 0.005 * i);
    m.header.frame_id = "imu_link";
    m.angular_velocity.x = 1e-3 * std::sin(0.01 * i) + 7e-5;
    m.angular_velocity.y = -2e-4 * i * 1e-3;
    m.angular_velocity.z = 0.3 + 1e-5 * (i % 13);
    m.linear_acceleration.x = 0.01 * (i % 7);
    m.linear_acceleration.y = -0.02;
    m.linear_acceleration.z = 9.81 + 1e-4 * (i % 5);
    bag.write("/imu", rec, m);
    if (spec.temperature && i % 200 == 0) {
      sensor_msgs::Temperature t;
      t.header.stamp = ros::Time(spec.t0 + 0.005 * i + 0.002);
      t.temperature = 25.0 + 0.001 * i;
      bag.write("/imu/temperature", rec, t);
    }
    if (spec.other_topic && i % 50 == 0) {
      std_msgs::String s;
      s.data = "x";
      bag.write("/chatter", rec, s);
    }
  }
  bag.close();
}

void expectSame(const ImuSeries& a, const ImuSeries& b) {
  EXPECT_EQ(a.topic, b.topic);
  EXPECT_EQ(a.frame_id, b.frame_id);
  EXPECT_EQ(a.bags, b.bags);
  EXPECT_EQ(a.messages, b.messages);
  EXPECT_EQ(a.temperature_topic, b.temperature_topic);
  ASSERT_EQ(a.t.size(), b.t.size());
  EXPECT_EQ(a.t.toNanoseconds(), b.t.toNanoseconds());
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(a.gyro[k].toVector(), b.gyro[k].toVector());
    EXPECT_EQ(a.accel[k].toVector(), b.accel[k].toVector());
  }
  EXPECT_EQ(a.temperature_t, b.temperature_t);
  EXPECT_EQ(a.temperature, b.temperature);
}

ImuSeries read(const std::vector<std::string>& paths, BagReadOptions o, const char* reader) {
  o.reader = reader;
  return readImuBags(paths, o);
}

}  // namespace

TEST(BagReader, DirectEqualsRosbagForEveryCompression) {
  int i = 0;
  for (auto c : {rosbag::compression::Uncompressed, rosbag::compression::BZ2, rosbag::compression::LZ4}) {
    BagSpec spec;
    spec.compression = c;
    spec.zero_stamps = true;
    const std::string path = outPath("c" + std::to_string(i++) + ".bag");
    writeBag(path, spec);
    const ImuSeries d = read({path}, {}, "auto"), r = read({path}, {}, "rosbag");
    EXPECT_EQ(d.reader, "direct");
    EXPECT_EQ(r.reader, "rosbag");
    EXPECT_EQ(d.messages, spec.n);
    EXPECT_EQ(d.temperature.size(), 15u);
    expectSame(d, r);
  }
}

TEST(BagReader, DirectEqualsRosbagWithOptions) {
  BagSpec spec;
  const std::string a = outPath("a.bag"), b = outPath("b.bag");
  writeBag(a, spec);
  spec.t0 += 20.0;  // the second bag continues after the first
  writeBag(b, spec);
  std::vector<BagReadOptions> opts(4);
  opts[1].use_bag_time = true;
  opts[2].start_s = 3.0;
  opts[2].duration_s = 10.0;
  opts[3].temperature_topic = "-";
  opts[3].topic = "/imu";
  for (const auto& o : opts) {
    const ImuSeries d = read({b, a}, o, "auto"), r = read({b, a}, o, "rosbag");  // given out of order on purpose
    EXPECT_EQ(d.reader, "direct");
    expectSame(d, r);
  }
}

TEST(BagReader, StepsAsideWhenRecordsAreNotInTimeOrder) {
  BagSpec spec;
  spec.record_times_backwards = true;
  const std::string path = outPath("backwards.bag");
  writeBag(path, spec);
  const ImuSeries d = read({path}, {}, "auto"), r = read({path}, {}, "rosbag");
  EXPECT_EQ(d.reader, "rosbag");  // rosbag::View sorts by record time; the file order differs
  expectSame(d, r);
}

TEST(BagReader, ErrorsStillComeFromRosbag) {
  BagSpec spec;
  spec.temperature = false;
  const std::string path = outPath("errors.bag");
  writeBag(path, spec);
  BagReadOptions o;
  o.topic = "/chatter";
  try {
    read({path}, o, "auto");
    FAIL() << "no error for a topic of the wrong type";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("has type std_msgs/String, not sensor_msgs/Imu"), std::string::npos) << e.what();
  }
  // Truncated copy: the index at the end is gone.
  const std::string cut = outPath("cut.bag");
  {
    FILE* in = std::fopen(path.c_str(), "rb");
    FILE* out = std::fopen(cut.c_str(), "wb");
    ASSERT_TRUE(in && out);
    std::vector<char> buf(20000);
    const size_t n = std::fread(buf.data(), 1, buf.size(), in);
    std::fwrite(buf.data(), 1, n, out);
    std::fclose(in);
    std::fclose(out);
  }
  EXPECT_THROW(read({cut}, {}, "auto"), InputError);
}

TEST(BagReader, CorruptedBagsNeverCrashTheDirectReader) {
  // One byte flip anywhere in small bags (uncompressed: flips hit record headers, the index and message data; lz4:
  // flips hit compressed chunks), or a truncation: the direct reader either steps aside (returns false) or reads the
  // clean bag's series with at most the one message whose bytes were hit changed; it never crashes (ASan:
  // scripts/sanitize.sh). rosbag itself is not called here: a flipped offset in a chunk's index records makes
  // rosbag::View read outside its buffer (segfault in Bag::readHeaderFromBuffer, rosbag_storage 1.15) - the direct
  // reader, which ignores those records, reads such a bag correctly instead.
  int read_direct = 0, declined = 0;
  for (auto c : {rosbag::compression::Uncompressed, rosbag::compression::LZ4}) {
    BagSpec spec;
    spec.n = 600;
    spec.compression = c;
    const std::string clean = outPath(c == rosbag::compression::LZ4 ? "fuzz_lz4.bag" : "fuzz_none.bag");
    writeBag(clean, spec);
    const ImuSeries ref = read({clean}, {}, "rosbag");
    std::ifstream in(clean, std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::mt19937_64 rng(c == rosbag::compression::LZ4 ? 2 : 1);
    const std::string bad = outPath("fuzz_case.bag");
    for (int k = 0; k < 200; ++k) {
      std::string b = bytes;
      size_t at = 0;
      if (k % 5 == 4) {
        b.resize(std::uniform_int_distribution<size_t>(0, b.size() - 1)(rng));  // truncated
      } else {
        at = std::uniform_int_distribution<size_t>(0, b.size() - 1)(rng);
        b[at] = static_cast<char>(b[at] ^ (1 << std::uniform_int_distribution<int>(0, 7)(rng)));
      }
      std::ofstream(bad, std::ios::binary).write(b.data(), static_cast<std::streamsize>(b.size()));
      ImuSeries d;
      if (!readImuBagsDirect({bad}, BagReadOptions{}, &d)) {
        ++declined;
        continue;
      }
      ++read_direct;
      ASSERT_EQ(d.t.size(), ref.t.size()) << "case " << k << " flip at " << at;
      const auto dt = d.t.toNanoseconds(), rt = ref.t.toNanoseconds();
      std::vector<std::vector<double>> dv, rv;
      for (int a = 0; a < 3; ++a) {
        dv.push_back(d.gyro[a].toVector()), rv.push_back(ref.gyro[a].toVector());
        dv.push_back(d.accel[a].toVector()), rv.push_back(ref.accel[a].toVector());
      }
      int changed = 0;
      for (size_t i = 0; i < dt.size(); ++i) {
        bool diff = dt[i] != rt[i];
        for (size_t a = 0; a < dv.size(); ++a) diff = diff || !(dv[a][i] == rv[a][i] || (std::isnan(dv[a][i]) && std::isnan(rv[a][i])));
        changed += diff;
      }
      // One flipped byte changes at most one message; a flipped stamp moves the origin of every relative stamp only
      // if it is the first message, so allow that case to shift all stamps by one constant.
      if (changed > 1) {
        const int64_t shift = dt.size() > 1 ? dt[1] - rt[1] : 0;
        int off = 0;
        for (size_t i = 1; i < dt.size(); ++i) off += dt[i] - rt[i] != shift;
        EXPECT_EQ(off, 0) << "case " << k << " flip at " << at << ": " << changed << " messages differ";
      }
    }
  }
  EXPECT_GT(read_direct, 100);  // most flips land in message data and must still be read
  EXPECT_GT(declined, 20);      // truncations and header damage must be declined, not misread
  std::printf("corrupted bags: %d read by the direct reader, %d left to rosbag\n", read_direct, declined);
}
