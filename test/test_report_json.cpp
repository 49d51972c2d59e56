// Tests of report.json: every value keeps the type it was built with (text stays text, numbers numbers), strict JSON.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <string>

#include "gyro_allan/io/report.hpp"

using namespace gyro_allan;

namespace {

ReportMeta textThatLooksLikeNumbers() {
  ReportMeta m;
  m.sources = {"1e5", "true"};
  m.topic = "0x10";
  m.tau_grid = "nan";
  m.warnings = {"inf", "-.inf", "12", "a \"quoted\"\tline\n"};
  m.confidence = 0.683;
  m.stamps.kept = 12345;
  return m;
}

}  // namespace

TEST(ReportJson, TextStaysTextNumbersStayNumbers) {
  const std::string json = toJson(buildReport(textThatLooksLikeNumbers(), {}));
  const YAML::Node j = YAML::Load(json);  // JSON is YAML: a quoted scalar has tag "!", a plain one "?"
  auto text = [](const YAML::Node& n, const std::string& want) {
    EXPECT_EQ(n.Tag(), "!") << want;
    EXPECT_EQ(n.Scalar(), want);
  };
  text(j["input"]["sources"][0], "1e5");
  text(j["input"]["sources"][1], "true");
  text(j["input"]["topic"], "0x10");
  text(j["tau_grid"], "nan");
  text(j["warnings"][0], "inf");
  text(j["warnings"][1], "-.inf");
  text(j["warnings"][2], "12");
  text(j["warnings"][3], "a \"quoted\"\tline\n");
  text(j["version"], "0.1.0");
  EXPECT_EQ(j["confidence"].Tag(), "?");
  EXPECT_EQ(j["confidence"].as<double>(), 0.683);
  EXPECT_EQ(j["stamps"]["kept"].Tag(), "?");
  EXPECT_EQ(j["stamps"]["kept"].as<long long>(), 12345);
  EXPECT_EQ(json.find("\"kept\": 12345"), json.find("\"kept\""));  // unquoted
  // report.yaml of the same tree reads back the same values (the string tag is not printed).
  const YAML::Node y = YAML::Load(toYaml(buildReport(textThatLooksLikeNumbers(), {})));
  EXPECT_EQ(y["input"]["topic"].Scalar(), "0x10");
  EXPECT_EQ(y["confidence"].as<double>(), 0.683);
}

TEST(ReportJson, NonFiniteNumbersAreNull) {
  ReportMeta m;
  m.confidence = std::nan("");
  m.stamps.gap_time_s = INFINITY;
  const std::string json = toJson(buildReport(m, {}));
  EXPECT_NE(json.find("\"confidence\": null"), std::string::npos) << json;
  EXPECT_NE(json.find("\"gap_time_s\": null"), std::string::npos) << json;
}

// A strict JSON parser (Python's) takes the file: no nan, inf, hex or bare words.
TEST(ReportJson, StrictParserAcceptsIt) {
  if (std::system("python3 -c 'import json' >/dev/null 2>&1") != 0) GTEST_SKIP() << "no python3";
  const std::string dir = GYRO_ALLAN_TEST_OUT;
  ASSERT_EQ(std::system(("mkdir -p '" + dir + "'").c_str()), 0);
  const std::string path = dir + "/report_json_strict.json";
  std::ofstream(path) << toJson(buildReport(textThatLooksLikeNumbers(), {}));
  EXPECT_EQ(std::system(("python3 -c 'import json, sys; d = json.load(open(sys.argv[1])); "
                         "assert d[\"input\"][\"topic\"] == \"0x10\" and d[\"stamps\"][\"kept\"] == 12345' '" + path + "'")
                            .c_str()),
            0);
}
