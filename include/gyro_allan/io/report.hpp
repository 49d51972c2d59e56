// Writes analysis results: report.yaml (or .json), allan.csv and the human summary table; files are written to a
// temporary name and renamed, so an interrupted run never leaves a half-written report.
#pragma once

#include <string>
#include <vector>

#include <yaml-cpp/yaml.h>

#include "gyro_allan/analysis.hpp"
#include "gyro_allan/kalibr.hpp"
#include "gyro_allan/pipeline.hpp"
#include "gyro_allan/rest.hpp"
#include "gyro_allan/timing.hpp"

namespace gyro_allan {

struct ReportMeta {
  std::vector<std::string> sources;  ///< bag or CSV paths
  std::string topic;                 ///< IMU topic (empty for CSV)
  std::string accel_topic;           ///< a separate accelerometer topic (split gyro/accel streams), or empty
  std::string input_note;            ///< how the input was read where the user did not say (e.g. ns stamps), or empty
  std::string input = "rate";        ///< rate | angle
  std::string input_units = "rad/s";
  std::string tau_grid;
  std::string method = "auto";      ///< requested method (each axis names the one it used)
  double confidence = 0.683;
  StampReport stamps;
  std::vector<std::string> warnings;
  /// At-rest check (rest.hpp), rate input.
  bool rest_checked = false;
  RestResult rest;
  bool rest_restricted = false;       ///< only the longest static stretch was analysed
  double rest_from_s = 0, rest_to_s = 0;  ///< that stretch, s from the first kept stamp
  int64_t rest_excluded = 0;          ///< kept samples left out of the analysis as moving
};

/// The report as a YAML tree (schema in docs/outputs.md "report.yaml").
YAML::Node buildReport(const ReportMeta& meta, const std::vector<AxisAnalysis>& axes);
/// YAML text or JSON text of a tree. JSON keeps the types the tree was built with (text from report.cpp's str()
/// stays a string however it looks; numbers, integers and bools as such; NaN/inf as null).
/// A double as a plain YAML scalar with 10 significant digits (.nan, .inf, -.inf for the non-finite); yaml-cpp would
/// print 17 (0.68300000000000005). Shared by every YAML file the tools write.
YAML::Node yamlNumber(double v);

std::string toYaml(const YAML::Node& node);
std::string toJson(const YAML::Node& node);
/// allan.csv: one row per (axis, deviation, tau); columns in docs/outputs.md.
std::string allanCsv(const std::vector<AxisAnalysis>& axes);
/// Fixed-width summary in conventional units.
std::string summaryTable(const std::vector<AxisAnalysis>& axes);
/// report.yaml `accelerometer:` section: per axis (axis names "accel_x" -> "x") the five terms in accelerometer
/// units; `means` = the removed mean (gravity) per axis [m/s^2].
YAML::Node accelerometerNode(const std::vector<AxisAnalysis>& axes, const std::vector<double>& means);
/// The first screen (analyze_bag without --verbose): the coefficient table of the gyro (and accelerometer) in
/// conventional units, then one line per axis in words (verdict and its reason, method, effects added, quantized
/// output, spikes), wrapped at 200 characters.
std::string briefSummary(const std::vector<AxisAnalysis>& gyro, const std::vector<AxisAnalysis>& accel);
/// One axis in words, as briefSummary prints it.
std::string axisWords(const AxisAnalysis& a);
/// A line wrapped at spaces into lines of at most `width` characters, the continuation lines indented by 4.
std::string wrapLine(const std::string& line, size_t width);
/// Summary lines of the accelerometer in conventional units (m/s/sqrt(h), ug, m/s/h/sqrt(h)).
std::string accelSummaryTable(const std::vector<AxisAnalysis>& axes);
/// Copies a pipeline result's stamp report, warnings and at-rest decision into meta.
void setPipelineMeta(const PipelineResult& r, ReportMeta* meta);
/// The files of one analysis, as analyze_bag writes them: DIR/report.yaml (format "yaml") or DIR/report.json
/// ("json"), DIR/allan.csv (gyro, then accelerometer rows), DIR/imu.yaml (Kalibr, `rule` across axes) and beside it
/// the IMU blocks of OpenVINS, VINS-Fusion, ORB-SLAM3 and Basalt (kalibr.hpp frameworkConfigs). DIR must exist. rest_off_note: imu.yaml's data note for rate input analysed without the at-rest check. Throws
/// std::runtime_error naming the file that cannot be written.
void writeAnalysisFiles(const std::string& dir, const ReportMeta& meta, const PipelineResult& r,
                        const std::string& format, KalibrAxisRule rule, bool rate_input,
                        const std::string& rest_off_note);
/// Writes content to path via path.tmp + rename. Throws std::runtime_error naming the path.
void writeFileAtomic(const std::string& path, const std::string& content);

}  // namespace gyro_allan
