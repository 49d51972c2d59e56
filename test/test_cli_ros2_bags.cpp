// ROS 2 bags, EuRoC/Kalibr CSVs and split gyro/accel streams as a user brings them: every storage variant of the same
// samples gives the ROS 1 bag's answer, other tools' bags are read or refused in one line, damaged files are refused,
// and the frameworks' configs carry imu.yaml's numbers.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <geometry_msgs/Vector3Stamped.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/Temperature.h>
#include <yaml-cpp/yaml.h>

#include <zlib.h>

#include "../src/rosbag2/crc32.hpp"
#include "cli_util.hpp"
#include "gyro_allan/io/bag_input.hpp"
#include "gyro_allan/io/imu_message.hpp"
#include "gyro_allan/rosbag2/cdr.hpp"
#include "gyro_allan/rosbag2/storage.hpp"
#include "gyro_allan/rosbag2/writer.hpp"

using namespace gyro_allan;
using gyro_allan_test::slurp;
using gyro_allan_test::ToolRun;

namespace {

const std::string kTools = GYRO_ALLAN_TOOL_DIR;
const std::string kOut = std::string(GYRO_ALLAN_TEST_OUT) + "/ros2";
const std::string kShared = std::string(GYRO_ALLAN_SHARED_DATA) + "/ros2_bags";

ToolRun run(const std::string& cmd) { return gyro_allan_test::runTool(cmd, kOut); }

void expectOneLineError(const ToolRun& r, int code, const std::string& needle, const std::string& what) {
  EXPECT_EQ(r.code, code) << what << ": " << r.err << r.out;
  EXPECT_EQ(gyro_allan_test::countLines(r.err), 1) << what << ": " << r.err;
  EXPECT_NE(r.err.find(needle), std::string::npos) << what << ": " << r.err;
}

/// One message of the reference ROS 1 bag.
struct Msg {
  std::string topic;
  int64_t recv_ns = 0;
  bool temperature = false;
  sensor_msgs::Imu imu;
  sensor_msgs::Temperature temp;
};

cdr::Header header(const std_msgs::Header& h) {
  cdr::Header c;
  c.sec = static_cast<int32_t>(h.stamp.sec);
  c.nanosec = h.stamp.nsec;
  c.frame_id = h.frame_id;
  return c;
}

std::string encode(const Msg& m, cdr::Kind kind, bool big) {
  if (m.temperature) {
    cdr::Temperature t;
    t.header = header(m.temp.header);
    t.temperature = m.temp.temperature;
    t.variance = m.temp.variance;
    return cdr::encode(t, kind, big);
  }
  cdr::Imu c;
  c.header = header(m.imu.header);
  c.orientation = {{m.imu.orientation.x, m.imu.orientation.y, m.imu.orientation.z, m.imu.orientation.w}};
  c.angular_velocity = {{m.imu.angular_velocity.x, m.imu.angular_velocity.y, m.imu.angular_velocity.z}};
  c.linear_acceleration = {{m.imu.linear_acceleration.x, m.imu.linear_acceleration.y, m.imu.linear_acceleration.z}};
  for (size_t k = 0; k < 9; ++k) {
    c.orientation_covariance[k] = m.imu.orientation_covariance[k];
    c.angular_velocity_covariance[k] = m.imu.angular_velocity_covariance[k];
    c.linear_acceleration_covariance[k] = m.imu.linear_acceleration_covariance[k];
  }
  return cdr::encode(c, kind, big);
}

rosbag2::WriterTopic topicOf(const Msg& m) {
  const std::string type = m.temperature ? "sensor_msgs/msg/Temperature" : "sensor_msgs/msg/Imu";
  return {m.topic, type, cdr::definition(type)};
}

/// How one ROS 2 variant of the reference samples is written.
struct Variant {
  std::string name;
  std::string storage = "mcap";  // mcap | sqlite3
  rosbag2::McapWriteOptions mcap;
  int db_schema = 4;
  cdr::Kind kind = cdr::Kind::Xcdr1;
  bool big_endian = false;
  int files = 1;                // split into this many files by time
  int metadata_version = 0;     // > 0: a rosbag2 folder with metadata.yaml of this version
  std::string compression_mode; // "", "FILE", "MESSAGE" (zstd)
};

class Ros2Bags : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    ASSERT_EQ(std::system(("rm -rf '" + kOut + "' && mkdir -p '" + kOut + "'").c_str()), 0);
    // 5 min at 100 Hz of a MEMS-like gyro, arrival-time stamps, with a temperature topic: the ROS 1 reference.
    const ToolRun s = run(kTools + "/simulate --output " + kOut + "/ref.bag --rate 100 --duration 300 --arw 1e-3 " +
                          "--rrw 2e-5 --bias-instability 2e-5 --temperature --stamp-jitter 0.3 --seed 7");
    ASSERT_EQ(s.code, 0) << s.err;
    rosbag::Bag bag(kOut + "/ref.bag", rosbag::bagmode::Read);
    for (const rosbag::MessageInstance& mi : rosbag::View(bag)) {
      Msg m;
      m.topic = mi.getTopic();
      m.recv_ns = static_cast<int64_t>(mi.getTime().toNSec());
      if (auto t = mi.instantiate<sensor_msgs::Temperature>()) {
        m.temperature = true;
        m.temp = *t;
      } else {
        m.imu = *mi.instantiate<sensor_msgs::Imu>();
      }
      msgs().push_back(m);
    }
  }
  static std::vector<Msg>& msgs() {
    static std::vector<Msg> m;
    return m;
  }

  /// Writes the reference samples as `v`; returns what to give analyze_bag (a folder, or files).
  static std::vector<std::string> write(const Variant& v) {
    const std::string dir = kOut + "/" + v.name;
    EXPECT_EQ(std::system(("mkdir -p '" + dir + "'").c_str()), 0);
    const std::vector<Msg>& all = msgs();
    std::vector<std::string> files;
    rosbag2::BagMetadata meta;
    meta.version = v.metadata_version;
    meta.storage_identifier = v.storage;
    meta.compression_format = v.compression_mode.empty() ? "" : "zstd";
    meta.compression_mode = v.compression_mode;
    std::map<std::string, int64_t> counts;
    for (int f = 0; f < v.files; ++f) {
      const size_t begin = all.size() * static_cast<size_t>(f) / static_cast<size_t>(v.files);
      const size_t end = all.size() * static_cast<size_t>(f + 1) / static_cast<size_t>(v.files);
      const std::string name = v.name + "_" + std::to_string(f) + (v.storage == "mcap" ? ".mcap" : ".db3");
      const std::string path = dir + "/" + name;
      std::map<std::string, int> ids;
      auto bytesOf = [&](const Msg& m) {
        std::string b = encode(m, v.kind, v.big_endian);
        return v.compression_mode == "MESSAGE" ? rosbag2::zstdCompress(b.data(), b.size()) : b;
      };
      auto fill = [&](auto& w) {  // McapWriter and SqliteWriter alike
        for (size_t i = begin; i < end; ++i) {
          const Msg& m = all[i];
          if (!ids.count(m.topic)) ids[m.topic] = w.addTopic(topicOf(m));
          w.write(ids[m.topic], m.recv_ns, bytesOf(m));
          ++counts[m.topic];
        }
        w.close();
      };
      if (v.storage == "mcap") {
        rosbag2::McapWriter w(path, v.mcap);
        fill(w);
      } else {
        rosbag2::SqliteWriter w(path, v.db_schema);
        fill(w);
      }
      std::string listed = name;
      if (v.compression_mode == "FILE") {
        rosbag2::zstdCompressFile(path, path + ".zstd");
        std::remove(path.c_str());
        listed += ".zstd";
      }
      meta.relative_file_paths.push_back(listed);
      meta.files.push_back({listed, all[begin].recv_ns, all[end - 1].recv_ns - all[begin].recv_ns,
                            static_cast<int64_t>(end - begin)});
      files.push_back(dir + "/" + listed);
    }
    if (v.metadata_version == 0) return files;
    meta.starting_time_ns = all.front().recv_ns;
    meta.duration_ns = all.back().recv_ns - all.front().recv_ns;
    meta.message_count = static_cast<int64_t>(all.size());
    for (const auto& kv : counts) {
      Msg probe;
      probe.topic = kv.first;
      probe.temperature = kv.first == "/temperature";
      meta.topics.push_back({topicOf(probe), kv.second});
    }
    std::ofstream(dir + "/metadata.yaml") << rosbag2::metadataYaml(meta);
    return {dir};
  }
};

std::string joined(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& x : v) s += " '" + x + "'";
  return s;
}

/// The five coefficients (value, sigma) of every gyro and accelerometer axis of a report.
std::vector<double> coefficients(const std::string& report_path) {
  std::vector<double> out;
  const YAML::Node r = YAML::LoadFile(report_path);
  for (const YAML::Node& s : {r["axes"], r["accelerometer"]["axes"]}) {
    if (!s) continue;
    for (const char* axis : {"x", "y", "z"}) {
      const YAML::Node c = s[axis]["coefficients"];
      if (!c) continue;
      for (auto it = c.begin(); it != c.end(); ++it) {
        out.push_back(it->second["value"].as<double>());
        if (it->second["sigma"]) out.push_back(it->second["sigma"].as<double>());
      }
    }
  }
  return out;
}

TEST_F(Ros2Bags, EveryStorageVariantGivesTheRos1Answer) {
  std::vector<Variant> variants;
  auto add = [&](const std::string& name) {
    variants.push_back(Variant());
    variants.back().name = name;
    return &variants.back();
  };
  add("mcap_zstd");
  add("mcap_lz4")->mcap.compression = "lz4";
  add("mcap_none")->mcap.compression = "";
  {
    Variant* v = add("mcap_fastwrite");  // rosbag2's fastwrite preset: no chunks, summary without chunk index
    v->mcap.chunked = false;
    v->mcap.crc = false;
  }
  add("mcap_no_summary")->mcap.summary = false;  // chunks, no index: a scan of the data section
  {
    Variant* v = add("mcap_unchunked_no_index");
    v->mcap.chunked = false;
    v->mcap.summary = false;
  }
  add("mcap_big_endian")->big_endian = true;
  add("mcap_xcdr2")->kind = cdr::Kind::Xcdr2;
  {
    Variant* v = add("mcap_xcdr2_delimited_be");
    v->kind = cdr::Kind::Xcdr2Delimited;
    v->big_endian = true;
  }
  add("mcap_split3")->files = 3;  // three files without metadata.yaml
  {
    Variant* v = add("mcap_split3_folder");
    v->files = 3;
    v->metadata_version = 9;
  }
  {
    Variant* v = add("mcap_file_zstd");  // rosbag2 FILE compression: bag_0.mcap.zstd
    v->metadata_version = 6;
    v->compression_mode = "FILE";
  }
  for (int schema = 1; schema <= 4; ++schema) {
    Variant* v = add("db3_schema" + std::to_string(schema));
    v->storage = "sqlite3";
    v->db_schema = schema;
  }
  {
    Variant* v = add("db3_message_zstd");  // rosbag2 MESSAGE compression, metadata v5 (Humble)
    v->storage = "sqlite3";
    v->db_schema = 3;
    v->metadata_version = 5;
    v->compression_mode = "MESSAGE";
  }
  {
    Variant* v = add("mcap_folder_v3");  // the oldest metadata.yaml with compression fields
    v->metadata_version = 3;
    v->mcap.compression = "lz4";
  }
  {
    Variant* v = add("db3_folder_v7");
    v->storage = "sqlite3";
    v->db_schema = 4;
    v->metadata_version = 7;
  }
  {
    Variant* v = add("db3_folder_v4");
    v->storage = "sqlite3";
    v->db_schema = 2;
    v->metadata_version = 4;
    v->files = 2;
  }

  BagReadOptions o;
  o.progress = false;
  const ImuSeries ref = readImuBags({kOut + "/ref.bag"}, o);
  // The tool's answer with every stage but the model check (whose search costs most of a run and reads the same
  // samples): the samples are compared one by one below, the answer is the end-to-end check.
  const std::string opts = " --no-plot --quiet --no-model-check --output ";
  const ToolRun rr = run(kTools + "/analyze_bag " + kOut + "/ref.bag" + opts + kOut + "/out_ref");
  ASSERT_EQ(rr.code, 0) << rr.err;
  const std::vector<double> want = coefficients(kOut + "/out_ref/report.yaml");
  ASSERT_GT(want.size(), 20u);
  for (const Variant& v : variants) {
    SCOPED_TRACE(v.name);
    const std::vector<std::string> input = write(v);
    // The same series, sample for sample: stamps in ns, values and temperature exactly.
    const ImuSeries s = readImuBags(input, o);
    EXPECT_EQ(s.reader, "rosbag2");
    EXPECT_EQ(s.topic, ref.topic);
    EXPECT_EQ(s.messages, ref.messages);
    EXPECT_EQ(s.t.toNanoseconds(), ref.t.toNanoseconds());
    for (size_t k = 0; k < 3; ++k) {
      EXPECT_EQ(s.gyro[k].toVector(), ref.gyro[k].toVector());
      EXPECT_EQ(s.accel[k].toVector(), ref.accel[k].toVector());
    }
    EXPECT_EQ(s.temperature_topic, ref.temperature_topic);
    EXPECT_EQ(s.temperature, ref.temperature);
    EXPECT_EQ(s.temperature_t, ref.temperature_t);
    // And the same answer from the tool, to 1e-9.
    const std::string out = kOut + "/out_" + v.name;
    const ToolRun r = run(kTools + "/analyze_bag" + joined(input) + opts + out);
    ASSERT_EQ(r.code, 0) << r.err;
    const std::vector<double> got = coefficients(out + "/report.yaml");
    ASSERT_EQ(got.size(), want.size());
    for (size_t i = 0; i < got.size(); ++i)
      EXPECT_NEAR(got[i], want[i], 1e-9 * std::fabs(want[i]) + 1e-300) << "coefficient " << i;
  }
  // Receive times (--bag-time) and a time range read as from the ROS 1 bag.
  BagReadOptions b = o;
  b.use_bag_time = true;
  b.start_s = 30;
  b.duration_s = 100;
  const ImuSeries rb = readImuBags({kOut + "/ref.bag"}, b), sb = readImuBags({kOut + "/mcap_zstd"}, b);
  EXPECT_EQ(sb.t.toNanoseconds(), rb.t.toNanoseconds());
  EXPECT_EQ(sb.gyro[2].toVector(), rb.gyro[2].toVector());
  EXPECT_EQ(sb.temperature_t, rb.temperature_t);
  // bag_scan lists a ROS 2 recording's topics.
  const ToolRun scan = run(kTools + "/bag_scan " + kOut + "/mcap_split3_folder");
  EXPECT_EQ(scan.code, 0) << scan.err;
  EXPECT_NE(scan.out.find("/imu"), std::string::npos) << scan.out;
  EXPECT_NE(scan.out.find("sensor_msgs/msg/Imu"), std::string::npos) << scan.out;
  EXPECT_NE(scan.out.find("zstd"), std::string::npos) << scan.out;
}

TEST_F(Ros2Bags, AngleTopicReadsAsFromARos1Bag) {
  // geometry_msgs/msg/Vector3Stamped angles (an RLG's accumulated pulses) in DELIMITED_CDR2: the samples of the
  // same messages in a ROS 1 bag.
  const std::string r1 = kOut + "/angle.bag", r2 = kOut + "/angle.mcap";
  {
    rosbag::Bag bag(r1, rosbag::bagmode::Write);
    rosbag2::McapWriter w(r2);
    const int id = w.addTopic({"/angle", "geometry_msgs/msg/Vector3Stamped",
                               cdr::definition("geometry_msgs/msg/Vector3Stamped")});
    geometry_msgs::Vector3Stamped m;
    m.header.frame_id = "rlg";
    cdr::Vector3Stamped c;
    c.header.frame_id = "rlg";
    double th = 0;
    for (int i = 0; i < 3000; ++i) {
      th += 1.7e-6 * ((i * 7919) % 5 - 2);
      m.header.stamp = ros::Time(1700000000, 0) + ros::Duration(0.0025 * i);
      m.vector.x = th;
      m.vector.y = -2 * th;
      m.vector.z = 1e-3 + th;
      bag.write("/angle", m.header.stamp, m);
      c.header.sec = static_cast<int32_t>(m.header.stamp.sec);
      c.header.nanosec = m.header.stamp.nsec;
      c.vector = {{m.vector.x, m.vector.y, m.vector.z}};
      w.write(id, static_cast<int64_t>(m.header.stamp.toNSec()), cdr::encode(c, cdr::Kind::Xcdr2Delimited, false));
    }
    w.close();
  }
  BagReadOptions o;
  o.angle_topic = "/angle";
  const ImuSeries a = readImuBags({r1}, o), b = readImuBags({r2}, o);
  EXPECT_EQ(b.reader, "rosbag2");
  EXPECT_EQ(b.t.toNanoseconds(), a.t.toNanoseconds());
  for (size_t k = 0; k < 3; ++k) EXPECT_EQ(b.gyro[k].toVector(), a.gyro[k].toVector());
  EXPECT_TRUE(b.accel[0].empty());
  EXPECT_EQ(b.frame_id, "rlg");
}

TEST_F(Ros2Bags, HalvesFlaggedAbsentAreNotData) {
  // A driver without an accelerometer estimate sets linear_acceleration_covariance[0] = -1 in every message; one
  // that loses its gyro now and then flags angular_velocity the same way: those samples are dropped and counted
  // (non_finite), and the accelerometer is not analysed, said on the first screen.
  const std::string path = kOut + "/flagged.mcap";
  int64_t flagged = 0;
  {
    rosbag2::McapWriter w(path);
    int id = 0;
    for (const Msg& m0 : msgs()) {
      if (m0.temperature) continue;
      Msg m = m0;
      m.imu.linear_acceleration_covariance[0] = -1;
      if (m.imu.header.seq % 500 == 7) m.imu.angular_velocity_covariance[0] = -1, ++flagged;
      if (id == 0) id = w.addTopic(topicOf(m));
      w.write(id, m.recv_ns, encode(m, cdr::Kind::Xcdr1, false));
    }
    w.close();
  }
  ASSERT_GT(flagged, 10);
  const ToolRun r = run(kTools + "/analyze_bag " + path + " --no-plot --no-model-check --output " + kOut + "/out_flag");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("linear_acceleration_covariance[0] = -1 in every message"), std::string::npos) << r.out;
  const YAML::Node rep = YAML::LoadFile(kOut + "/out_flag/report.yaml");
  EXPECT_FALSE(rep["accelerometer"]);
  EXPECT_EQ(rep["stamps"]["non_finite"].as<int64_t>(), flagged);
  // The nodelet's conversion is the same function: a flagged half is NaN, the other half kept.
  sensor_msgs::Imu m;
  m.angular_velocity.x = 0.5;
  m.linear_acceleration.z = 9.8;
  m.linear_acceleration_covariance[0] = -1;
  const ImuHalves h = imuHalves(m);
  EXPECT_FALSE(h.gyro_flagged);
  EXPECT_EQ(h.gyro[0], 0.5);
  EXPECT_TRUE(h.accel_flagged);
  EXPECT_TRUE(std::isnan(h.accel[2]));
}

TEST_F(Ros2Bags, OtherToolsBagsAreReadOrRefusedInOneLine) {
  struct Fixture {
    std::string path;
    bool imu;
  };
  const std::vector<Fixture> fixtures = {
      {"stinger_test_bag", true},          {"stinger_localization_bag", true},
      {"rosbags_rs_mcap", true},           {"rosbags_rs_sqlite3", true},
      {"rosbags_rs_mcap/test_bag_mcap.mcap", true},
      {"rosbag2_talker_mcap", false},      {"rosbag2_multiple_files_mcap", false},
      {"rosbag2_topics_and_services/topics_and_services.mcap", false},
      {"rosbag2_topics_and_services/topics_and_services.db3", false}};
  for (const auto& f : fixtures) {
    SCOPED_TRACE(f.path);
    const ToolRun r = run(kTools + "/analyze_bag " + kShared + "/" + f.path + " --no-plot --output " + kOut + "/fx");
    if (f.imu) {
      EXPECT_TRUE(r.code == 0 || r.code == 3) << r.code << ": " << r.err;
      if (r.code == 3) {
        EXPECT_EQ(gyro_allan_test::countLines(r.err), 1) << r.err;
      }
    } else {
      expectOneLineError(r, 2, "no sensor_msgs/Imu topic", f.path);
    }
  }
  // The real ICM-20948 bag: 10 Hz read as 10 Hz; its messages' values as the rosbags library wrote them.
  BagReadOptions o;
  const ImuSeries s = readImuBags({kShared + "/stinger_test_bag"}, o);
  EXPECT_EQ(s.topic, "/imu/data");
  EXPECT_EQ(s.messages, 104);
  EXPECT_EQ(s.frame_id, "imu_link");
  const ImuSeries m = readImuBags({kShared + "/rosbags_rs_mcap"}, o);
  EXPECT_EQ(m.topic, "/test/sensor_msgs/imu");
  ASSERT_EQ(m.gyro[2].size(), 2u);
  EXPECT_DOUBLE_EQ(m.gyro[2][0], 0.03);
  EXPECT_DOUBLE_EQ(m.accel[2][0], 9.8);
}

TEST_F(Ros2Bags, DamagedFilesAreRefusedInOneLine) {
  const std::vector<std::string> good = write([] {
    Variant v;
    v.name = "damage_src";
    return v;
  }());
  const std::string src = slurp(good.front());
  ASSERT_GT(src.size(), 10000u);
  auto put = [](const std::string& path, const std::string& bytes) { std::ofstream(path, std::ios::binary) << bytes; };
  const std::string d = kOut + "/damaged";
  ASSERT_EQ(std::system(("mkdir -p " + d).c_str()), 0);
  put(d + "/truncated.mcap", src.substr(0, src.size() / 2));
  std::string flipped = src;
  flipped[src.size() / 3] ^= 0x10;  // inside a zstd chunk: the CRC or the decompression says so
  put(d + "/flipped.mcap", flipped);
  std::string noise(20000, '\0');
  for (size_t i = 0; i < noise.size(); ++i) noise[i] = static_cast<char>((i * 2654435761u) >> 13);
  put(d + "/random.mcap", noise);
  put(d + "/empty.mcap", "");
  // Unknown chunk compression: an MCAP whose chunks say "zzzz" (no CRCs to trip over first).
  {
    Variant v;
    v.name = "damage_comp";
    v.mcap.crc = false;
    std::string b = slurp(write(v).front());
    for (size_t at = b.find("zstd"); at != std::string::npos; at = b.find("zstd", at + 4)) b.replace(at, 4, "zzzz");
    put(d + "/unknown_compression.mcap", b);
  }
  // A .db3 whose Imu topic holds other messages, and a truncated .db3.
  {
    rosbag2::SqliteWriter w(d + "/wrong_type.db3", 4);
    const int id = w.addTopic({"/imu", "sensor_msgs/msg/Imu", ""});
    const std::string text = std::string("\x00\x01\x00\x00\x06\x00\x00\x00hello\x00", 14);  // a std_msgs/String
    for (int i = 0; i < 100; ++i) w.write(id, 1700000000000000000 + i * 10000000LL, text);
    w.close();
  }
  {
    Variant v;
    v.name = "damage_db3";
    v.storage = "sqlite3";
    const std::string b = slurp(write(v).front());
    put(d + "/truncated.db3", b.substr(0, b.size() / 3));
  }
  const std::map<std::string, std::string> expect = {
      {"truncated.mcap", "truncated"},       {"flipped.mcap", "damaged MCAP file"},
      {"random.mcap", "not an MCAP file"},   {"empty.mcap", "empty file"},
      {"unknown_compression.mcap", "compression 'zzzz' is not supported"},
      {"wrong_type.db3", "not a sensor_msgs/msg/Imu"}, {"truncated.db3", "sqlite3"}};
  for (const auto& kv : expect)
    expectOneLineError(run(kTools + "/analyze_bag " + d + "/" + kv.first + " --no-plot --output " + kOut + "/dmg"), 2,
                       kv.second, kv.first);
  // A ROS 1 bag and a ROS 2 file in one call: refused.
  expectOneLineError(run(kTools + "/analyze_bag " + kOut + "/ref.bag " + good.front() + " --output " + kOut + "/dmg"), 2,
                     "not both", "mixed");
}

/// The report's N (angle random walk) per axis of a section ("axes" or "accelerometer").
std::vector<double> arw(const YAML::Node& report, const char* section) {
  std::vector<double> out;
  const bool gyro = std::string(section) == "axes";
  const YAML::Node axes = gyro ? report["axes"] : report["accelerometer"]["axes"];
  const char* key = gyro ? "angle_random_walk" : "velocity_random_walk";
  for (const char* axis : {"x", "y", "z"}) out.push_back(axes[axis]["coefficients"][key]["value"].as<double>());
  return out;
}

TEST_F(Ros2Bags, EurocCsvAndSplitRealSenseStreams) {
  // EuRoC/TUM-VI data.csv at 200 Hz (10 min): nanosecond stamps from the header, gyro and accelerometer by their names.
  const double n_gyro = 1.5e-4, n_acc = 2.2e-3;
  char opts[200];
  std::snprintf(opts, sizeof opts, " --rate 200 --duration 600 --arw %g --accel-noise %g --seed 11", n_gyro, n_acc);
  ASSERT_EQ(run(kTools + "/simulate --output " + kOut + "/euroc.csv --csv-format euroc" + opts).code, 0);
  const ToolRun r = run(kTools + "/analyze_bag --csv " + kOut + "/euroc.csv --no-plot --output " + kOut + "/out_euroc");
  ASSERT_EQ(r.code, 0) << r.err;
  const YAML::Node rep = YAML::LoadFile(kOut + "/out_euroc/report.yaml");
  EXPECT_NEAR(rep["axes"]["x"]["rate_hz"].as<double>(), 200, 0.01);
  for (double v : arw(rep, "axes")) EXPECT_NEAR(v, n_gyro, 0.03 * n_gyro);
  for (double v : arw(rep, "accelerometer")) EXPECT_NEAR(v, n_acc, 0.03 * n_acc);
  // The same samples without the header (Kalibr's imu0.csv order: ns stamp, gyro, accelerometer): nanoseconds from
  // the magnitude, said on the first screen; a header that calls them seconds is refused, naming the unit.
  {
    std::ifstream in(kOut + "/euroc.csv");
    std::ofstream bare(kOut + "/kalibr.csv"), wrong(kOut + "/wrong_unit.csv");
    std::string line;
    std::getline(in, line);
    wrong << "t [s],wx,wy,wz,ax,ay,az\n";
    while (std::getline(in, line)) bare << line << "\n", wrong << line << "\n";
  }
  const ToolRun k = run(kTools + "/analyze_bag --csv " + kOut + "/kalibr.csv --no-plot --output " + kOut + "/out_kalibr");
  ASSERT_EQ(k.code, 0) << k.err;
  EXPECT_NE(k.out.find("nanoseconds"), std::string::npos) << k.out;
  EXPECT_EQ(arw(YAML::LoadFile(kOut + "/out_kalibr/report.yaml"), "accelerometer"), arw(rep, "accelerometer"));
  expectOneLineError(run(kTools + "/analyze_bag --csv " + kOut + "/wrong_unit.csv --output " + kOut + "/out_wrong"), 2,
                     "look like nanoseconds", "ns read as s");

  // RealSense-style split streams: gyro at 400 Hz on /camera/gyro/sample, accelerometer at 250 Hz on
  // /camera/accel/sample, in a ROS 2 MCAP and a ROS 1 bag; the pair is found by its names.
  const double n_rs = 3e-4, a_rs = 1.4e-3;
  std::snprintf(opts, sizeof opts, " --rate 400 --accel-rate 250 --duration 300 --arw %g --accel-noise %g --seed 5",
                n_rs, a_rs);
  for (const char* ext : {".mcap", ".bag"}) {
    SCOPED_TRACE(ext);
    const std::string bag = kOut + "/realsense" + ext;
    ASSERT_EQ(run(kTools + "/simulate --output " + bag + opts +
                  " --topic /camera/gyro/sample --accel-topic /camera/accel/sample").code, 0);
    const ToolRun s = run(kTools + "/analyze_bag " + bag + " --no-plot --output " + kOut + "/out_rs");
    ASSERT_EQ(s.code, 0) << s.err;
    EXPECT_NE(s.out.find("accelerometer from /camera/accel/sample at 250 Hz"), std::string::npos) << s.out;
    std::istringstream screen(s.out + s.err);
    for (std::string l; std::getline(screen, l);) EXPECT_LE(l.size(), 200u) << l;
    const YAML::Node rs = YAML::LoadFile(kOut + "/out_rs/report.yaml");
    EXPECT_NEAR(rs["axes"]["x"]["rate_hz"].as<double>(), 400, 0.01);
    EXPECT_NEAR(rs["accelerometer"]["axes"]["x"]["rate_hz"].as<double>(), 250, 0.01);
    for (double v : arw(rs, "axes")) EXPECT_NEAR(v, n_rs, 0.03 * n_rs);
    for (double v : arw(rs, "accelerometer")) EXPECT_NEAR(v, a_rs, 0.03 * a_rs);
    // The accelerometer's stream alone is not a gyro.
    expectOneLineError(run(kTools + "/analyze_bag " + bag + " --topic /camera/accel/sample --output " + kOut + "/o"), 2,
                       "carries no angular velocity", "accel topic as gyro");
  }
}

TEST_F(Ros2Bags, FrameworkConfigsCarryImuYamlsValues) {
  const std::string out = kOut + "/out_ref";  // from EveryStorageVariantGivesTheRos1Answer, or made here
  if (!std::ifstream(out + "/imu.yaml")) {
    ASSERT_EQ(run(kTools + "/analyze_bag " + kOut + "/ref.bag --no-plot --quiet --output " + out).code, 0);
  }
  const YAML::Node k = YAML::LoadFile(out + "/imu.yaml");
  auto load = [&](const std::string& file) {
    std::string text = slurp(out + "/" + file);
    if (text.rfind("%YAML:1.0", 0) == 0) text = text.substr(text.find('\n') + 1);  // OpenCV's directive
    return YAML::Load(text);
  };
  const double gn = k["gyroscope_noise_density"].as<double>(), gw = k["gyroscope_random_walk"].as<double>();
  const double an = k["accelerometer_noise_density"].as<double>(), aw = k["accelerometer_random_walk"].as<double>();
  const double rate = k["update_rate"].as<double>();
  const YAML::Node ov = load("kalibr_imu_chain.yaml")["imu0"];
  EXPECT_EQ(ov["gyroscope_noise_density"].as<double>(), gn);
  EXPECT_EQ(ov["gyroscope_random_walk"].as<double>(), gw);
  EXPECT_EQ(ov["accelerometer_noise_density"].as<double>(), an);
  EXPECT_EQ(ov["accelerometer_random_walk"].as<double>(), aw);
  EXPECT_EQ(ov["update_rate"].as<double>(), rate);
  EXPECT_EQ(ov["rostopic"].as<std::string>(), k["rostopic"].as<std::string>());
  EXPECT_EQ(ov["Tg"].size(), 3u);
  const YAML::Node orb = load("orb_slam3_imu.yaml");
  EXPECT_EQ(orb["IMU.NoiseGyro"].as<double>(), gn);
  EXPECT_EQ(orb["IMU.GyroWalk"].as<double>(), gw);
  EXPECT_EQ(orb["IMU.NoiseAcc"].as<double>(), an);
  EXPECT_EQ(orb["IMU.AccWalk"].as<double>(), aw);
  EXPECT_EQ(orb["IMU.Frequency"].as<int>(), static_cast<int>(rate));  // an integer: ORB-SLAM3's older parser wants one
  const YAML::Node basalt = load("basalt_imu.json")["value0"];
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(basalt["gyro_noise_std"][i].as<double>(), gn);
    EXPECT_EQ(basalt["gyro_bias_std"][i].as<double>(), gw);
    EXPECT_EQ(basalt["accel_noise_std"][i].as<double>(), an);
    EXPECT_EQ(basalt["accel_bias_std"][i].as<double>(), aw);
  }
  EXPECT_EQ(basalt["imu_update_rate"].as<double>(), rate);
  // VINS-Fusion's pre-integration takes per-sample noise: imu.yaml's densities times sqrt(rate) (both files print 7
  // significant digits: the product of the rounded value may differ from the rounded product by 2 in the last).
  const YAML::Node vins = load("vins_fusion_imu.yaml");
  const double f = std::sqrt(rate), tol = 3e-6;
  EXPECT_NEAR(vins["gyr_n"].as<double>(), gn * f, tol * gn * f);
  EXPECT_NEAR(vins["gyr_w"].as<double>(), gw * f, tol * gw * f);
  EXPECT_NEAR(vins["acc_n"].as<double>(), an * f, tol * an * f);
  EXPECT_NEAR(vins["acc_w"].as<double>(), aw * f, tol * aw * f);
  EXPECT_EQ(vins["imu_topic"].as<std::string>(), k["rostopic"].as<std::string>());
}

TEST_F(Ros2Bags, BatchReadsRos1AndRos2BagsSideBySide) {
  const std::string d = kOut + "/batch_in";
  ASSERT_EQ(std::system(("rm -rf " + d + " && mkdir -p " + d + " && cp " + kOut + "/ref.bag " + d + "/a.bag").c_str()), 0);
  Variant v;
  v.name = "batch_src";
  v.metadata_version = 8;
  const std::string folder = write(v).front();
  ASSERT_EQ(std::system(("cp -r " + folder + " " + d + "/b_folder && cp " + folder + "/batch_src_0.mcap " + d +
                         "/c.mcap").c_str()), 0);
  const ToolRun r = run(kTools + "/analyze_bag --batch " + d + " --no-plot --quiet --output " + kOut + "/batch_out");
  ASSERT_EQ(r.code, 0) << r.err;
  const std::string csv = slurp(kOut + "/batch_out/summary.csv");
  for (const char* name : {"a.bag,gyro,x,ok", "b_folder,gyro,x,ok", "c.mcap,gyro,x,ok"})
    EXPECT_NE(csv.find(name), std::string::npos) << name << "\n" << csv;
}

TEST(Crc32, FoldedCrcIsZlibsOnEveryLengthAndAlignment) {
  std::vector<uint8_t> b(1 << 16);
  uint32_t x = 12345;
  for (auto& v : b) v = static_cast<uint8_t>((x = x * 1664525u + 1013904223u) >> 24);
  for (size_t n = 0; n < 700; ++n)
    for (size_t off : {0, 1, 7, 13}) {
      const uint32_t want = static_cast<uint32_t>(crc32(0, b.data() + off, static_cast<uInt>(n)));
      ASSERT_EQ(rosbag2::crc32Update(0, b.data() + off, n), want) << n << " at " << off;
    }
  // Extending a running CRC, as the summary CRC does over two pieces.
  const uint32_t whole = static_cast<uint32_t>(crc32(0, b.data(), static_cast<uInt>(b.size())));
  EXPECT_EQ(rosbag2::crc32Update(rosbag2::crc32Update(0, b.data(), 1000), b.data() + 1000, b.size() - 1000), whole);
}

}  // namespace
