// The README's demo table is what the quick start prints: runs analyze_bag on bags/default.bag as
// scripts/quickstart.sh does and checks that README.md holds the gyro coefficient table (header and x, y, z rows)
// verbatim, inside a fenced code block, and that the first screen stays readable (at most 25 lines of at most 200
// characters, stdout and stderr together). When the fit changes, re-run the quick start and copy its table.
#include <gtest/gtest.h>

#include <cstdlib>
#include <sstream>
#include <string>
#include <vector>

#include "cli_util.hpp"

namespace {

const std::string kTools = GYRO_ALLAN_TOOL_DIR;
const std::string kSource = GYRO_ALLAN_SOURCE_DIR;
const std::string kOut = std::string(GYRO_ALLAN_TEST_OUT) + "/readme_demo";

std::vector<std::string> lines(const std::string& s) {
  std::vector<std::string> v;
  std::istringstream in(s);
  for (std::string l; std::getline(in, l);) v.push_back(l);
  return v;
}

/// The gyro table of analyze_bag's summary: the header line ("gyro  Q [arcsec] ...") and the lines after it up to
/// the accelerometer's table ("accel ...") or the legend line "(value +- 1 sigma ...)": one row per axis.
std::vector<std::string> gyroTable(const std::string& out) {
  const std::vector<std::string> all = lines(out);
  std::vector<std::string> table;
  for (size_t i = 0; i < all.size(); ++i) {
    if (all[i].rfind("gyro  Q [", 0) != 0) continue;
    table.push_back(all[i]);
    for (size_t j = i + 1; j < all.size() && !all[j].empty() && all[j][0] != '(' && all[j].rfind("accel", 0) != 0; ++j)
      table.push_back(all[j]);
    break;
  }
  return table;
}

TEST(ReadmeDemo, TableIsWhatTheQuickStartPrints) {
  ASSERT_EQ(std::system(("mkdir -p " + kOut).c_str()), 0);
  unsetenv("GYRO_ALLAN_NO_PLOT");  // the quick start draws the plot, and the README shows it
  // scripts/quickstart.sh: `analyze_bag bags/default.bag --output out/default` from the source tree.
  const gyro_allan_test::ToolRun r = gyro_allan_test::runTool(
      "cd '" + kSource + "' && '" + kTools + "/analyze_bag' bags/default.bag --output '" + kOut + "/out'", kOut);
  ASSERT_EQ(r.code, 0) << r.err;

  // The first screen: what a 3-axis gyro + accelerometer prints, stdout and stderr together.
  const std::vector<std::string> screen = lines(r.out + r.err);
  EXPECT_LE(screen.size(), 25u) << r.out << r.err;
  for (const auto& l : screen) EXPECT_LE(l.size(), 200u) << l;
  EXPECT_NE(r.out.find("accel "), std::string::npos) << "the accelerometer's table is on the first screen:\n" << r.out;
  EXPECT_NE(r.out.find("x: good"), std::string::npos) << "one line per axis in words:\n" << r.out;

  const std::vector<std::string> table = gyroTable(r.out);
  ASSERT_GE(table.size(), 4u) << "no gyro table in the output:\n" << r.out;
  int rows = 0;
  for (const auto& l : table) rows += l.rfind("x ", 0) == 0 || l.rfind("y ", 0) == 0 || l.rfind("z ", 0) == 0;
  EXPECT_EQ(rows, 3) << r.out;

  const std::string readme = gyro_allan_test::slurp(kSource + "/README.md");
  ASSERT_FALSE(readme.empty()) << kSource + "/README.md";
  std::string block;
  for (const auto& l : table) block += l + "\n";
  const size_t at = readme.find(block);
  ASSERT_NE(at, std::string::npos) << "README.md does not hold the quick start's table verbatim; it prints:\n"
                                   << block;
  EXPECT_TRUE(at == 0 || readme[at - 1] == '\n') << "the table's header must start a line";
  // Inside a fenced code block: an odd number of ``` fence lines before it.
  int fences = 0;
  for (const auto& l : lines(readme.substr(0, at))) fences += l.rfind("```", 0) == 0;
  EXPECT_EQ(fences % 2, 1) << "the table must be inside a fenced code block";

  // The plot the README shows (docs/demo_allan.png) is the tool's: its SVG twin docs/demo_allan.svg equals the
  // quick start's allan.svg byte for byte (the PNG's pixels depend on the platform's OpenCV fonts; its size may not).
  const std::string svg = gyro_allan_test::slurp(kOut + "/out/allan.svg");
  ASSERT_FALSE(svg.empty()) << "the quick start wrote no allan.svg:\n" << r.err;
  EXPECT_TRUE(svg == gyro_allan_test::slurp(kSource + "/docs/demo_allan.svg"))
      << "docs/demo_allan.svg/.png are not the quick start's plot: copy out/default/allan.svg and allan.png there";
  auto header = [](const std::string& png) { return png.size() > 24 ? png.substr(16, 8) : std::string(); };  // width, height
  EXPECT_EQ(header(gyro_allan_test::slurp(kOut + "/out/allan.png")),
            header(gyro_allan_test::slurp(kSource + "/docs/demo_allan.png")));
}

}  // namespace
