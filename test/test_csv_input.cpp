// Tests of the CSV reader: layouts, units, line-numbered errors and .gz input (zlib).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>

#include <zlib.h>

#include "gyro_allan/csv_input.hpp"

using namespace gyro_allan;

TEST(CsvInput, HeaderWithTime) {
  std::istringstream in("t,wx,wy,wz\n0.0,1,2,3\n0.1,4,5,6\n");
  const auto s = parseCsv(in);
  ASSERT_EQ(s.columns.size(), 3u);
  EXPECT_EQ(s.names[0], "wx");
  EXPECT_EQ(s.t, (std::vector<double>{0.0, 0.1}));
  EXPECT_EQ(s.columns[2], (std::vector<double>{3, 6}));
}

TEST(CsvInput, SingleColumnWithCommentsAndDegrees) {
  std::istringstream in("# a comment\n\n180\n-90\n");
  CsvOptions o;
  o.scale = M_PI / 180;
  const auto s = parseCsv(in, o);
  ASSERT_EQ(s.columns.size(), 1u);
  EXPECT_TRUE(s.t.empty());
  EXPECT_DOUBLE_EQ(s.columns[0][0], M_PI);
  EXPECT_DOUBLE_EQ(s.columns[0][1], -M_PI / 2);
  EXPECT_EQ(s.blank_or_comment, 2);
}

TEST(CsvInput, NanPassesThroughForSanitation) {
  std::istringstream in("1\nnan\n3\n");
  const auto s = parseCsv(in);
  EXPECT_TRUE(std::isnan(s.columns[0][1]));
}

TEST(CsvInput, BadRowsNameTheLine) {
  std::istringstream a("t,x\n0,1\n1,abc\n");
  try {
    parseCsv(a);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("line 3"), std::string::npos) << e.what();
  }
  std::istringstream b("1,2,3\n4,5\n");
  try {
    parseCsv(b);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("line 2"), std::string::npos) << e.what();
  }
  std::istringstream c("# only a comment\n");
  EXPECT_THROW(parseCsv(c), std::invalid_argument);
  EXPECT_THROW(readCsvFile("/nonexistent/file.csv"), std::runtime_error);
}

namespace {

std::string testDir() {
  const std::string d = std::string(GYRO_ALLAN_TEST_OUT) + "/csv_gz";
  std::string cmd = "mkdir -p '" + d + "'";
  EXPECT_EQ(std::system(cmd.c_str()), 0);
  return d;
}

void writeFile(const std::string& path, const std::string& bytes) {
  std::ofstream f(path, std::ios::binary);
  f << bytes;
}

std::string readFile(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
}

/// gzip member of `text` written by zlib (gzwrite: gzip header and trailer).
void writeGz(const std::string& path, const std::string& text, const char* mode = "wb") {
  gzFile g = gzopen(path.c_str(), mode);
  ASSERT_NE(g, nullptr);
  ASSERT_EQ(gzwrite(g, text.data(), static_cast<unsigned>(text.size())), static_cast<int>(text.size()));
  ASSERT_EQ(gzclose(g), Z_OK);
}

/// Inflates a whole gzip file in memory (zlib inflate with gzip header detection), for the round-trip check.
std::string inflateGz(const std::string& bytes) {
  z_stream z{};
  EXPECT_EQ(inflateInit2(&z, 16 + MAX_WBITS), Z_OK);
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(bytes.data()));
  z.avail_in = static_cast<uInt>(bytes.size());
  std::string out;
  char buf[4096];
  int rc;
  do {
    z.next_out = reinterpret_cast<Bytef*>(buf);
    z.avail_out = sizeof buf;
    rc = inflate(&z, Z_NO_FLUSH);
    out.append(buf, sizeof buf - z.avail_out);
  } while (rc == Z_OK);
  EXPECT_EQ(rc, Z_STREAM_END);
  inflateEnd(&z);
  return out;
}

std::string sampleCsv(int rows) {
  std::ostringstream o;
  o << "t,wx,wy,wz\n";
  for (int i = 0; i < rows; ++i) o << i * 0.01 << "," << std::sin(i) << "," << std::cos(i) << "," << 1e-3 * i << "\n";
  return o.str();
}

}  // namespace

TEST(CsvInput, GzipFileReadsLikeThePlainFile) {
  const std::string d = testDir(), text = sampleCsv(20000);  // > 64 KiB: several reads
  writeFile(d + "/plain.csv", text);
  writeGz(d + "/z.csv.gz", text);
  EXPECT_EQ(inflateGz(readFile(d + "/z.csv.gz")), text);  // a complete gzip stream
  const CsvSeries plain = readCsvFile(d + "/plain.csv"), gz = readCsvFile(d + "/z.csv.gz");
  EXPECT_EQ(gz.rows, 20000);
  EXPECT_EQ(gz.names, plain.names);
  EXPECT_EQ(gz.t, plain.t);
  EXPECT_EQ(gz.columns, plain.columns);
  // The gzip tool reads what zlib wrote, and zlib reads what the gzip tool wrote.
  if (std::system("command -v gzip >/dev/null 2>&1") == 0) {
    EXPECT_EQ(std::system(("gzip -dc '" + d + "/z.csv.gz' | cmp -s - '" + d + "/plain.csv'").c_str()), 0);
    EXPECT_EQ(std::system(("gzip -c '" + d + "/plain.csv' > '" + d + "/tool.csv.gz'").c_str()), 0);
    EXPECT_EQ(readCsvFile(d + "/tool.csv.gz").columns, plain.columns);
  }
  // Two concatenated members (gzip -dc reads both): one series.
  const size_t half = text.find('\n', text.size() / 2) + 1;
  writeGz(d + "/two.csv.gz", text.substr(0, half));
  writeGz(d + "/two.csv.gz", text.substr(half), "ab");
  EXPECT_EQ(readCsvFile(d + "/two.csv.gz").columns, plain.columns);
}

TEST(CsvInput, BadGzipIsAnError) {
  const std::string d = testDir(), text = sampleCsv(2000);
  writeGz(d + "/good.csv.gz", text);
  const std::string bytes = readFile(d + "/good.csv.gz");
  writeFile(d + "/truncated.csv.gz", bytes.substr(0, bytes.size() / 2));
  std::string corrupt = bytes;
  corrupt[corrupt.size() - 6] ^= 0x55;  // the CRC-32 trailer
  writeFile(d + "/corrupt.csv.gz", corrupt);
  writeFile(d + "/plain_named.csv.gz", text);  // not compressed at all
  writeFile(d + "/empty.csv.gz", "");
  for (const char* name : {"truncated", "corrupt", "plain_named", "empty"}) {
    try {
      readCsvFile(d + "/" + name + ".csv.gz");
      ADD_FAILURE() << name << ": no error";
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find("not a readable gzip file"), std::string::npos) << name << ": " << e.what();
    }
  }
  EXPECT_THROW(readCsvFile(d + "/missing.csv.gz"), std::runtime_error);
}

TEST(CsvInput, EurocHeaderNanosecondsAndColumnsByName) {
  // EuRoC / TUM-VI data.csv: the header is a '#' line, the stamps are nanoseconds since the epoch (19 digits: read
  // exactly), gyro then accelerometer by their names.
  std::istringstream in(
      "#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],a_RS_S_x [m s^-2],"
      "a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]\n"
      "1403636579758555392,-0.0991,0.1473,0.0272,8.1477,-0.3759,-2.4026\n"
      "1403636579763555584,-0.0991,0.1403,0.0293,8.0333,-0.4086,-2.4026\n"
      "1403636579768555520,-0.0984,0.1278,0.0377,7.8862,-0.4250,-2.4680\n");
  CsvOptions o;
  o.scale = 2.0;  // applies to the gyro columns only
  const auto s = parseCsv(in, o);
  EXPECT_EQ(s.layout, "euroc");
  EXPECT_EQ(s.time_unit, "ns");
  EXPECT_EQ(s.time_unit_from, "header");
  EXPECT_EQ(s.gyro_unit, "rad/s");
  EXPECT_EQ(s.gyro, (std::vector<int>{0, 1, 2}));
  EXPECT_EQ(s.accel, (std::vector<int>{3, 4, 5}));
  EXPECT_EQ(s.t_ns, (std::vector<int64_t>{1000000000, 1005000192, 1010000128}));  // exact, first - 1 s
  EXPECT_DOUBLE_EQ(s.columns[0][0], -0.1982);
  EXPECT_DOUBLE_EQ(s.columns[3][0], 8.1477);
}

TEST(CsvInput, KalibrNamesAndNanosecondsByMagnitude) {
  // Kalibr's imu0.csv (omega = rate, alpha = acceleration), no unit in the header: ns from the values alone.
  std::istringstream in("timestamp,omega_x,omega_y,omega_z,alpha_x,alpha_y,alpha_z\n"
                        "1385030208726607500,0.0,0.1,0.2,9.8,0.1,0.2\n"
                        "1385030208731607500,0.0,0.1,0.2,9.8,0.1,0.2\n"
                        "1385030208736607500,0.0,0.1,0.2,9.8,0.1,0.2\n");
  const auto s = parseCsv(in);
  EXPECT_EQ(s.layout, "kalibr");
  EXPECT_EQ(s.time_unit, "ns");
  EXPECT_EQ(s.time_unit_from, "magnitude");
  EXPECT_EQ(s.accel, (std::vector<int>{3, 4, 5}));
  EXPECT_EQ(s.t_ns[2] - s.t_ns[0], 10000000);
  // Seven numeric columns without a header: time, gyro, accelerometer in that order.
  std::istringstream bare("1385030208726607500,0.0,0.1,0.2,9.8,0.1,0.2\n1385030208731607500,0.0,0.1,0.2,9.8,0.1,0.2\n");
  const auto b = parseCsv(bare);
  EXPECT_EQ(b.gyro, (std::vector<int>{0, 1, 2}));
  EXPECT_EQ(b.accel, (std::vector<int>{3, 4, 5}));
  EXPECT_EQ(b.time_unit, "ns");
}

TEST(CsvInput, AbsurdTimeColumnsAreRefusedNamingTheUnit) {
  auto error = [](const std::string& text, const std::string& unit = "") {
    std::istringstream in(text);
    CsvOptions o;
    o.time_unit = unit;
    try {
      parseCsv(in, o);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  // Microseconds and milliseconds are not guessed: the message says which unit fits.
  EXPECT_NE(error("t,wx,wy,wz\n0,1,2,3\n5000,1,2,3\n10000,1,2,3\n").find("--time-unit us"), std::string::npos);
  EXPECT_NE(error("t,wx,wy,wz\n0,1,2,3\n5,1,2,3\n10,1,2,3\n").find("--time-unit ms"), std::string::npos);
  // A header that says seconds over nanosecond values: refused, not read as 2e-7 Hz.
  EXPECT_NE(error("t [s],wx,wy,wz\n1403636579758555392,1,2,3\n1403636579763555584,1,2,3\n").find("look like nanoseconds"),
            std::string::npos);
  // Nanoseconds since boot are not guessed either (only epoch stamps are: a date of 2000-2100 in ns, us or ms).
  EXPECT_NE(error("t,x\n0,1\n40000000,1\n80000000,1\n").find("look like nanoseconds (25 Hz"), std::string::npos);
  // A rate no unit makes a sensor's.
  EXPECT_NE(error("t,x\n0,1\n1000000000000000,1\n2000000000000000,1\n").find("not a sensor's time column"),
            std::string::npos);
  // Epoch milliseconds at 1 kHz: a date in ms, not 1 Hz in seconds.
  std::istringstream ms("t,wx,wy,wz\n1700000000000,1,2,3\n1700000000001,1,2,3\n1700000000002,1,2,3\n");
  const auto m = parseCsv(ms);
  EXPECT_EQ(m.time_unit, "ms");
  EXPECT_EQ(m.time_unit_from, "magnitude");
  // The option decides: the same microseconds read as such.
  std::istringstream us("t,wx,wy,wz\n0,1,2,3\n5000,1,2,3\n10000,1,2,3\n");
  CsvOptions o;
  o.time_unit = "us";
  const auto s = parseCsv(us, o);
  EXPECT_EQ(s.t_ns, (std::vector<int64_t>{1000000000, 1005000000, 1010000000}));
  EXPECT_DOUBLE_EQ(s.t[1], 0.005);
  // A time column starting at 0 keeps its first sample (no stamp is 0 in t_ns).
  std::istringstream zero("t,wx,wy,wz\n0.0,1,2,3\n0.01,4,5,6\n0.02,4,5,6\n");
  EXPECT_EQ(parseCsv(zero).t_ns.front(), 1000000000);
}
