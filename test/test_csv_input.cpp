// Tests of the CSV reader: layouts, units and line-numbered errors.
#include <gtest/gtest.h>

#include <cmath>
#include <sstream>

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
