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
