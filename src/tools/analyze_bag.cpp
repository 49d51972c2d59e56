// analyze_bag: offline gyro noise analysis of rosbags (sensor_msgs/Imu) or CSV series -> report.yaml, allan.csv, summary.
#include <sys/stat.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include <console_bridge/console.h>

#include "gyro_allan/analysis.hpp"
#include "gyro_allan/csv_input.hpp"
#include "gyro_allan/io/bag_input.hpp"
#include "gyro_allan/io/report.hpp"
#include "gyro_allan/timing.hpp"

using namespace gyro_allan;

namespace {

// Exit codes (documented in README "analyze_bag").
constexpr int kExitOk = 0;
constexpr int kExitUsage = 1;     // bad command line
constexpr int kExitInput = 2;     // input unusable: missing file, wrong type, empty, corrupt
constexpr int kExitAnalysis = 3;  // data present but not analysable (too short...)
constexpr int kExitOutput = 4;    // cannot write the output

const char* kUsage = R"(usage: analyze_bag BAG [BAG...] [options]
       analyze_bag --csv FILE --rate HZ [options]

Gyro noise analysis: Allan deviation (overlapping, and other deviations on request) with confidence
intervals, and the IEEE 952/647 noise-model fit (Q, N, B, K, R) per axis.

Input
  BAG...                 rosbags with a sensor_msgs/Imu topic (several bags are stitched by time)
  --topic T              the sensor_msgs/Imu topic (default: the only one in the bags)
  --temperature-topic T  sensor_msgs/Temperature topic (default: the only one, if any; '-' = none)
  --bag-time             use the bag receive time instead of header.stamp
  --start S              skip the first S seconds (default 0)
  --duration S           analyse at most S seconds (default: all)
  --csv FILE             a CSV or single-column text file instead of bags (.gz read through gzip)
  --rate HZ              sample rate of the CSV (required with --csv unless it has a time column)
  --units U              CSV units: rad/s (default) or deg/s; for --input angle: rad or deg
  --input K              rate (default) or angle (accumulated angle samples, e.g. RLG/FOG pulse output)

Analysis
  --tau-grid G           octave | decade | all | log | log:K  (default log:10)
  --deviations LIST      comma list of oadev,adev,mdev,hdev,ohdev,tdev,totdev written to allan.csv (default oadev)
  --method M             auto | joint_fit | wavelet_split: whose coefficients are the answer (default auto:
                         wavelet_split when quantization dominates the shortest tau, else joint_fit)
  --no-wavelet-split     skip the wavelet split (sym8 denoising, Allan variance of both parts)
  --no-model-check       skip the model check (residual -> missing effect -> refit)
  --confidence C         two-sided confidence of the intervals (default 0.683)
  --gap-factor F         an interval longer than F nominal periods is a gap (default 1.5)

Output
  --output DIR           output folder (default ./allan_out); created if missing
  --format yaml|json     report format: DIR/report.yaml or DIR/report.json (default yaml)
  --quiet                print nothing but errors
  -h, --help             this text

Exit codes: 0 ok, 1 bad command line, 2 unusable input, 3 data not analysable, 4 cannot write output.
)";

struct Args {
  std::vector<std::string> bags;
  std::string topic, temperature_topic, csv, output = "allan_out", units, input = "rate", format = "yaml";
  std::string tau_grid = "log:10", deviations = "oadev", method = "auto";
  double rate = 0, confidence = 0.683, gap_factor = 1.5, start = 0, duration = 0;
  bool bag_time = false, quiet = false, wavelet_split = true, model_check = true;
};

struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

double parseDouble(const std::string& flag, const std::string& v) {
  char* end = nullptr;
  const double x = std::strtod(v.c_str(), &end);
  if (v.empty() || *end != '\0' || !std::isfinite(x)) throw UsageError(flag + " needs a number, got '" + v + "'");
  return x;
}

Args parseArgs(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    const std::string s = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw UsageError(s + " needs a value");
      return argv[++i];
    };
    if (s == "-h" || s == "--help") {
      std::cout << kUsage;
      std::exit(kExitOk);
    } else if (s == "--topic") a.topic = value();
    else if (s == "--temperature-topic") a.temperature_topic = value();
    else if (s == "--output" || s == "-o") a.output = value();
    else if (s == "--csv") a.csv = value();
    else if (s == "--rate") {
      a.rate = parseDouble(s, value());
      if (!(a.rate > 0)) throw UsageError(std::string("--rate must be > 0, got ") + argv[i]);
    }
    else if (s == "--units") a.units = value();
    else if (s == "--input") a.input = value();
    else if (s == "--tau-grid") a.tau_grid = value();
    else if (s == "--deviations") a.deviations = value();
    else if (s == "--method") a.method = value();
    else if (s == "--no-wavelet-split") a.wavelet_split = false;
    else if (s == "--no-model-check") a.model_check = false;
    else if (s == "--confidence") a.confidence = parseDouble(s, value());
    else if (s == "--gap-factor") a.gap_factor = parseDouble(s, value());
    else if (s == "--start") a.start = parseDouble(s, value());
    else if (s == "--duration") a.duration = parseDouble(s, value());
    else if (s == "--format") a.format = value();
    else if (s == "--bag-time") a.bag_time = true;
    else if (s == "--quiet" || s == "-q") a.quiet = true;
    else if (!s.empty() && s[0] == '-') throw UsageError("unknown option " + s + " (see --help)");
    else a.bags.push_back(s);
  }
  if (a.csv.empty() && a.bags.empty()) throw UsageError("no input: give a bag or --csv FILE (see --help)");
  if (!a.csv.empty() && !a.bags.empty()) throw UsageError("give bags or --csv, not both");
  if (a.input != "rate" && a.input != "angle") throw UsageError("--input must be rate or angle");
  if (a.format != "yaml" && a.format != "json") throw UsageError("--format must be yaml or json");
  if (a.rate < 0) throw UsageError("--rate must be > 0");
  if (!(a.confidence > 0 && a.confidence < 1)) throw UsageError("--confidence must be in (0, 1)");
  if (!(a.gap_factor > 1)) throw UsageError("--gap-factor must be > 1");
  if (a.start < 0 || a.duration < 0) throw UsageError("--start and --duration must be >= 0");
  return a;
}

std::vector<std::string> splitList(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ','))
    if (!item.empty()) out.push_back(item);
  return out;
}

/// Impulsive shocks and saturation on one rate axis: robust centre and spread (median, MAD of at most ~1e6 samples),
/// then runs of extreme values (> max(10 sigma, 0.1 rad/s) from the median). A run of >= 5 identical extreme values is
/// saturation; other extreme samples are spikes. Both are warnings: the samples stay in the analysis.
void valueWarnings(const std::string& axis, const std::vector<double>& v, std::vector<std::string>* warnings) {
  if (v.size() < 16) return;
  const size_t step = std::max<size_t>(1, v.size() / 1000000);
  std::vector<double> s;
  for (size_t i = 0; i < v.size(); i += step) s.push_back(v[i]);
  auto median = [](std::vector<double>& x) {
    std::nth_element(x.begin(), x.begin() + static_cast<long>(x.size() / 2), x.end());
    return x[x.size() / 2];
  };
  const double m = median(s);
  for (auto& x : s) x = std::fabs(x - m);
  const double thr = std::max(10 * 1.4826 * median(s), 0.1);
  int64_t spikes = 0, runs = 0, saturated = 0;
  for (size_t i = 0; i < v.size();) {
    size_t j = i + 1;
    while (j < v.size() && v[j] == v[i]) ++j;
    if (std::fabs(v[i] - m) > thr) {
      if (j - i >= 5) ++runs, saturated += static_cast<int64_t>(j - i);
      else spikes += static_cast<int64_t>(j - i);
    }
    i = j;
  }
  char buf[200];
  if (spikes > 0) {
    std::snprintf(buf, sizeof buf, "axis %s: %lld impulsive samples (shocks) more than %.3g rad/s from the median",
                  axis.c_str(), static_cast<long long>(spikes), thr);
    warnings->push_back(buf);
  }
  if (runs > 0) {
    std::snprintf(buf, sizeof buf, "axis %s: %lld runs of identical extreme values (%lld samples): saturation?",
                  axis.c_str(), static_cast<long long>(runs), static_cast<long long>(saturated));
    warnings->push_back(buf);
  }
}

void makeDir(const std::string& dir) {
  std::string path;
  std::stringstream ss(dir);
  std::string part;
  if (!dir.empty() && dir[0] == '/') path = "/";
  while (std::getline(ss, part, '/')) {
    if (part.empty()) continue;
    path += part + "/";
    if (mkdir(path.c_str(), 0775) != 0 && errno != EEXIST) throw std::runtime_error("cannot create folder '" + path + "'");
  }
}

int run(const Args& args) {
  AnalysisOptions opt;
  std::string err;
  if (!parseTauGrid(args.tau_grid, &opt.deviation.grid, &err)) throw UsageError("--tau-grid: " + err);
  opt.deviation.confidence = args.confidence;
  opt.deviations = splitList(args.deviations);
  if (opt.deviations.empty()) throw UsageError("--deviations is empty");
  for (const auto& d : opt.deviations)
    if (!isDeviationName(d)) throw UsageError("--deviations: unknown deviation '" + d + "'");
  opt.input = args.input == "angle" ? InputKind::Angle : InputKind::Rate;
  if (args.method != "auto" && args.method != "joint_fit" && args.method != "wavelet_split")
    throw UsageError("--method must be auto, joint_fit or wavelet_split");
  if (args.method == "wavelet_split" && !args.wavelet_split)
    throw UsageError("--method wavelet_split contradicts --no-wavelet-split");
  opt.method = args.method;
  opt.wavelet_split = args.wavelet_split;
  opt.model_check = args.model_check;

  ReportMeta meta;
  meta.tau_grid = tauGridName(opt.deviation.grid);
  meta.method = args.method;
  std::vector<double> temp_t, temp_v;  // temperature series (bags with a sensor_msgs/Temperature topic)
  meta.confidence = args.confidence;
  meta.input = args.input;
  SanitizeOptions so;
  so.gap_factor = args.gap_factor;

  std::vector<std::string> names;
  std::vector<double> t;
  std::vector<std::vector<double>> values;
  if (!args.csv.empty()) {
    CsvOptions co;
    const std::string u = args.units.empty() ? (args.input == "angle" ? "rad" : "rad/s") : args.units;
    if (u == "deg/s" || u == "deg") co.scale = M_PI / 180.0;
    else if (u != "rad/s" && u != "rad") throw UsageError("--units must be rad/s or deg/s (rad or deg for angles)");
    meta.input_units = u;
    CsvSeries cs;
    try {
      cs = readCsvFile(args.csv, co);
    } catch (const std::exception& e) {
      throw InputError(args.csv + ": " + e.what());
    }
    meta.sources.push_back(args.csv);
    names = cs.names;
    values = cs.columns;
    if (!cs.t.empty()) {
      t = cs.t;
      if (args.rate > 0) so.nominal_rate_hz = args.rate;
    } else {
      if (!(args.rate > 0)) throw UsageError("--rate HZ is required for a CSV without a time column");
      t.resize(static_cast<size_t>(cs.rows));
      for (size_t i = 0; i < t.size(); ++i) t[i] = (static_cast<double>(i) + 1.0) / args.rate;
      so.nominal_rate_hz = args.rate;
    }
  } else {
    if (args.input == "angle") throw UsageError("--input angle is for CSV input; bags carry sensor_msgs/Imu rates");
    BagReadOptions bo;
    bo.topic = args.topic;
    bo.temperature_topic = args.temperature_topic;
    bo.use_bag_time = args.bag_time;
    bo.start_s = args.start;
    bo.duration_s = args.duration;
    bo.progress = !args.quiet;
    ImuSeries s = readImuBags(args.bags, bo);
    meta.sources = s.bags;
    meta.topic = s.topic;
    names = {"x", "y", "z"};
    t = std::move(s.t);
    values = {std::move(s.gyro[0]), std::move(s.gyro[1]), std::move(s.gyro[2])};
    temp_t = std::move(s.temperature_t);
    temp_v = std::move(s.temperature);
    if (args.rate > 0) so.nominal_rate_hz = args.rate;
  }
  if (values.size() > 3) {
    if (!args.quiet) std::cerr << "analyze_bag: warning: only the first 3 value columns are analysed\n";
    values.resize(3);
    names.resize(3);
  }
  std::vector<const std::vector<double>*> ptrs;
  for (const auto& v : values) ptrs.push_back(&v);
  SanitizedSeries ss = sanitize(t, ptrs, so);
  meta.stamps = ss.report;
  meta.warnings = ss.report.warnings();
  if (ss.report.kept < 3 || !(ss.report.nominal_period_s > 0))
    throw std::invalid_argument("too few valid samples (" + std::to_string(ss.report.kept) + " of " +
                                std::to_string(ss.report.input) + ")");
  const double tau0 = ss.report.nominal_period_s;
  const std::vector<std::vector<double>> temperature_segments = ss.interpolateSegments(temp_t, temp_v);
  // A gyro at rest reads Earth rate plus bias: hundreds of deg/s means wrong units or a moving sensor.
  std::vector<AxisAnalysis> results;
  for (size_t a = 0; a < values.size(); ++a) {
    if (opt.input == InputKind::Rate) valueWarnings(names[a], ss.v[a], &meta.warnings);
    results.push_back(analyzeAxis(names[a], ss.segmentValues(static_cast<int>(a)), tau0, opt,
                                  temperature_segments.empty() ? nullptr : &temperature_segments));
    if (opt.input == InputKind::Rate && std::fabs(results.back().mean) > 1.0)
      meta.warnings.push_back("axis " + names[a] + ": mean rate " + std::to_string(results.back().mean) +
                              " rad/s is not a gyro at rest (wrong units or a moving sensor?)");
  }
  for (const auto& w : meta.warnings)
    if (!args.quiet) std::cerr << "analyze_bag: warning: " << w << "\n";

  try {
    makeDir(args.output);
    const YAML::Node report = buildReport(meta, results);
    writeFileAtomic(args.output + "/allan.csv", allanCsv(results));
    if (args.format == "json") writeFileAtomic(args.output + "/report.json", toJson(report));
    else writeFileAtomic(args.output + "/report.yaml", toYaml(report));
  } catch (const std::exception& e) {
    std::cerr << "analyze_bag: error: " << e.what() << "\n";
    return kExitOutput;
  }
  if (!args.quiet) {
    std::printf("%s%s: %lld samples, %.6g Hz, %.1f s, tau grid %s\n", meta.sources.front().c_str(),
                meta.topic.empty() ? "" : (" " + meta.topic).c_str(), static_cast<long long>(ss.report.kept),
                1.0 / tau0, static_cast<double>(ss.report.kept) * tau0, meta.tau_grid.c_str());
    std::printf("%s", summaryTable(results).c_str());
    std::printf("wrote %s/report.%s and %s/allan.csv\n", args.output.c_str(), args.format.c_str(), args.output.c_str());
  }
  return kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  // rosbag/cpp_common report parse problems through console_bridge before throwing: silence it so a corrupt bag
  // gives our one-line error only.
  console_bridge::setLogLevel(console_bridge::CONSOLE_BRIDGE_LOG_NONE);
  try {
    return run(parseArgs(argc, argv));
  } catch (const UsageError& e) {
    std::cerr << "analyze_bag: error: " << e.what() << "\n";
    return kExitUsage;
  } catch (const InputError& e) {
    std::cerr << "analyze_bag: error: " << e.what() << "\n";
    return kExitInput;
  } catch (const std::invalid_argument& e) {
    std::cerr << "analyze_bag: error: " << e.what() << "\n";
    return kExitAnalysis;
  } catch (const std::exception& e) {
    std::cerr << "analyze_bag: error: " << e.what() << "\n";
    return kExitInput;
  }
}
