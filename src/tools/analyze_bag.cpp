// analyze_bag: offline gyro noise analysis of rosbags (sensor_msgs/Imu) or CSV series -> report.yaml, allan.csv, summary.
#include <dirent.h>
#ifdef __GLIBC__
#include <malloc.h>
#endif
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <climits>
#include <condition_variable>
#include <cmath>
#include <ctime>
#include <cstdio>
#include <cstring>
#include <exception>
#include <functional>
#include <iostream>
#include <memory>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <console_bridge/console.h>

#include "gyro_allan/analysis.hpp"
#include "gyro_allan/compact_series.hpp"
#include "gyro_allan/csv_input.hpp"
#include "gyro_allan/io/bag_input.hpp"
#include "gyro_allan/io/noise_model_yaml.hpp"
#include "gyro_allan/io/plot.hpp"
#include "gyro_allan/io/report.hpp"
#include "gyro_allan/kalibr.hpp"
#include "gyro_allan/pipeline.hpp"
#include "gyro_allan/rosbag2/storage.hpp"
#include "gyro_allan/rest.hpp"
#include "gyro_allan/timing.hpp"

using namespace gyro_allan;

namespace {

// Exit codes (documented in docs/outputs.md, "Exit codes and errors").
constexpr int kExitOk = 0;
constexpr int kExitUsage = 1;     // bad command line
constexpr int kExitInput = 2;     // input unusable: missing file, wrong type, empty, corrupt
constexpr int kExitAnalysis = 3;  // data present but not analysable (too short...)
constexpr int kExitOutput = 4;    // cannot write the output
constexpr int kExitBatchFailed = 5;  // --batch: at least one bag failed (its row in summary.csv says why)

const char* kUsage = R"(usage: analyze_bag BAG [BAG...] [options]        ROS 1 .bag files, or one ROS 2 recording
                                                    (rosbag2 folder, .mcap or .db3 files)
       analyze_bag BAG [BAG...] --angle-topic T [--angle-mode accumulated|increment] [options]
       analyze_bag --csv FILE [--rate HZ] [options]
       analyze_bag --batch DIR [options]

Gyro noise analysis of a sensor at rest: Allan deviations with confidence intervals and the IEEE 952 noise
coefficients Q, N, B, K, R per axis, with 68 % / 95 % intervals and a quality verdict.

Input
  BAG...                 bags with a sensor_msgs/Imu topic: ROS 1 .bag files (several of one recording are
                         stitched), or a ROS 2 recording: a rosbag2 folder (metadata.yaml; sqlite3 or mcap
                         storage, zstd FILE/MESSAGE compression) or its .mcap / .db3 files, read without ROS 2
  --topic T              sensor_msgs/Imu topic (default: the only one, or the gyro of a gyro/accel pair)
  --accel-topic T        the accelerometer from its own sensor_msgs/Imu topic at its own rate (RealSense
                         /camera/accel/sample; found by itself when the only two Imu topics are such a pair)
  --angle-topic T        read angles instead: geometry_msgs/Vector3Stamped, angle per axis [rad]
  --angle-mode M         accumulated (default) or increment (angle per sample); --angle-topic, --input angle
  --temperature-topic T  sensor_msgs/Temperature topic for the model check (default: the only one; '-' = none)
  --bag-time             use the bag receive time instead of header.stamp
  --start S              skip the first S seconds (default 0)
  --duration S           analyse at most S seconds (default: all)
  --csv FILE             CSV (header t,wx,wy,wz, time optional) or one column per axis; .gz accepted; EuRoC /
                         TUM-VI data.csv and Kalibr imu0.csv (ns stamps, gyro, accelerometer) recognised
  --time-unit U          the CSV time column's unit: s, ms, us, ns (default: its header's, else s, or ns
                         when the values can only be nanosecond stamps)
  --rate HZ              sample rate (required for a CSV without a time column; default: from the stamps)
  --units U              CSV units: rad/s (default) or deg/s; rad or deg with --input angle
  --input K              CSV content: rate (default) or angle
  --batch DIR            every DIR/*.bag, *.mcap, *.db3 and rosbag2 folder on its own into OUTPUT/<name>/,
                         plus OUTPUT/summary.csv

Analysis
  --method M             auto (default) | joint_fit | wavelet_split | gmwm (auto + DIR/noise_model.yaml)
  --filter-rate HZ       noise_model.yaml: Phi/Qd also at this filter rate (implies --method gmwm)
  --tau-grid G           octave | decade | all | log | log:K (default log:10)
  --deviations LIST      deviations in allan.csv: oadev,adev,mdev,hdev,ohdev,tdev,totdev,mtotdev,ttotdev
                         (default oadev; mtotdev and ttotdev cost ~60x an oadev)
  --confidence C         two-sided confidence of the deviation intervals (default 0.683)
  --gap-factor F         a stamp later than its slot by F - 1 periods is a gap (default 1.5)
  --no-rest-check        skip the at-rest check (default: a moved record is cut to its longest static
                         stretch of >= 60 s, or refused with exit 3)
  --keep-spikes          keep isolated spikes (default: replaced and reported)
  --no-wavelet-split     skip the wavelet split
  --no-model-check       skip the model check (residual -> missing effect -> refit)
  --no-accel             skip the accelerometer (linear_acceleration)
  -j, --jobs N           threads (default: one per core; 1 = sequential; same results)

Output
  -o, --output DIR       output folder (default ./allan_out): report.yaml, allan.csv, allan.png/svg, imu.yaml
                         (Kalibr) and the IMU blocks of OpenVINS, VINS-Fusion, ORB-SLAM3 and Basalt
  --format F             yaml (default) or json report
  --kalibr-axis R        imu.yaml: worst (default: the largest axis) or mean (quadratic mean of the axes)
  --no-plot              no allan.png/allan.svg (also GYRO_ALLAN_NO_PLOT=1)
  -v, --verbose          print every statistic (fit errors, model-check tests) and warning in full
  -q, --quiet            print nothing but errors
  -h, --help             this text

Exit codes: 0 ok, 1 bad command line, 2 unusable input, 3 not analysable (too short, or moving),
4 cannot write the output, 5 --batch: some bags failed.

Details: README.md; the files and fields: docs/outputs.md; methods: docs/ (fit.md, timeline.md, ...).
)";

struct Args {
  std::vector<std::string> bags;
  std::string topic, angle_topic, accel_topic, time_unit, angle_mode = "accumulated", temperature_topic, csv, output = "allan_out", units, input = "rate", format = "yaml";
  std::string tau_grid = "log:10", deviations = "oadev", method = "auto";
  std::string batch, kalibr_axis = "worst";
  bool accel = true, plot = true;
  double rate = 0, confidence = 0.683, gap_factor = 1.5, start = 0, duration = 0;
  int jobs = 0;  // 0 = one per core
  bool bag_time = false, quiet = false, verbose = false, wavelet_split = true, model_check = true, keep_spikes = false;
  bool rest_check = true;
  double filter_rate = 0;  // GMWM (#16): --filter-rate HZ
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
    else if (s == "--angle-topic") a.angle_topic = value();
    else if (s == "--accel-topic") a.accel_topic = value();
    else if (s == "--time-unit") a.time_unit = value();
    else if (s == "--angle-mode") a.angle_mode = value();
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
    else if (s == "--filter-rate") {  // GMWM (#16)
      a.filter_rate = parseDouble(s, value());
      if (!(a.filter_rate > 0)) throw UsageError("--filter-rate must be > 0");
    }
    else if (s == "--no-wavelet-split") a.wavelet_split = false;
    else if (s == "--no-model-check") a.model_check = false;
    else if (s == "--confidence") a.confidence = parseDouble(s, value());
    else if (s == "--gap-factor") a.gap_factor = parseDouble(s, value());
    else if (s == "--start") a.start = parseDouble(s, value());
    else if (s == "--duration") a.duration = parseDouble(s, value());
    else if (s == "--format") a.format = value();
    else if (s == "--bag-time") a.bag_time = true;
    else if (s == "--batch") a.batch = value();
    else if (s == "--kalibr-axis") a.kalibr_axis = value();
    else if (s == "--no-accel") a.accel = false;
    else if (s == "--keep-spikes") a.keep_spikes = true;
    else if (s == "--no-rest-check") a.rest_check = false;
    else if (s == "--no-plot") a.plot = false;
    else if (s == "--jobs" || s == "-j") {
      const double j = parseDouble(s, value());
      if (!(j >= 1 && j <= 256) || j != std::floor(j)) throw UsageError("--jobs must be an integer in 1..256");
      a.jobs = static_cast<int>(j);
    }
    else if (s == "--quiet" || s == "-q") a.quiet = true;
    else if (s == "--verbose" || s == "-v") a.verbose = true;
    else if (!s.empty() && s[0] == '-') throw UsageError("unknown option " + s + " (see --help)");
    else a.bags.push_back(s);
  }
  if (a.csv.empty() && a.bags.empty() && a.batch.empty())
    throw UsageError("no input: give a bag, --csv FILE or --batch DIR (see --help)");
  if (!a.csv.empty() && !a.bags.empty()) throw UsageError("give bags or --csv, not both");
  if (!a.batch.empty() && (!a.csv.empty() || !a.bags.empty())) throw UsageError("--batch takes no other input");
  if (a.kalibr_axis != "worst" && a.kalibr_axis != "mean") throw UsageError("--kalibr-axis must be worst or mean");
  if (a.input != "rate" && a.input != "angle") throw UsageError("--input must be rate or angle");
  if (a.angle_mode != "accumulated" && a.angle_mode != "increment")
    throw UsageError("--angle-mode must be accumulated or increment");
  if (!a.angle_topic.empty() && !a.topic.empty()) throw UsageError("give --topic or --angle-topic, not both");
  if (!a.angle_topic.empty() && !a.csv.empty()) throw UsageError("--angle-topic is for bags; CSV angles: --input angle");
  if (!a.accel_topic.empty() && !a.csv.empty()) throw UsageError("--accel-topic is for bags");
  if (!a.accel_topic.empty() && !a.angle_topic.empty()) throw UsageError("--accel-topic is for IMU topics, not --angle-topic");
  if (!a.time_unit.empty() && a.time_unit != "s" && a.time_unit != "ms" && a.time_unit != "us" && a.time_unit != "ns")
    throw UsageError("--time-unit must be s, ms, us or ns");
  if (!a.time_unit.empty() && a.csv.empty()) throw UsageError("--time-unit is for CSV input");
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

/// The input's state for the printed summary: timeline and at-rest check, one line each (spikes follow the table).
std::string inputSummary(const ReportMeta& meta) {
  const StampReport& st = meta.stamps;
  char buf[700];
  std::string out;
  std::snprintf(buf, sizeof buf, "arrival-time stamps (99 %% within %.3g ms of their slot), samples placed on a "
                "regular grid", 1e3 * st.jitter_p99_s);
  std::string stamps = st.receipt_stamps ? std::string(buf) : "regular";
  if (st.gaps > 0) stamps += "; " + std::to_string(st.gaps) + " gaps (" + std::to_string(st.missing_samples) + " samples missing)";
  const int64_t dropped = st.non_finite + st.zero_stamp + st.out_of_order + st.duplicate + st.too_close + st.short_segment;
  if (dropped > 0) stamps += "; " + std::to_string(dropped) + " samples dropped (see warnings)";
  std::snprintf(buf, sizeof buf, "stamps: %s\n", stamps.c_str());
  out += buf;
  if (meta.rest_checked) {
    if (meta.rest.at_rest)
      std::snprintf(buf, sizeof buf, "motion: %s\n", meta.rest.reason.c_str());
    else
      std::snprintf(buf, sizeof buf, "motion: NOT AT REST outside %.1f-%.1f s (%s): only that static stretch is analysed\n",
                    meta.rest_from_s, meta.rest_to_s, meta.rest.reason.c_str());
    out += buf;
  }
  return out;
}

/// The first screen's opening line: input, rate, span, and the state of its stamps and motion in a few words.
std::string briefInput(const ReportMeta& meta, const PipelineResult& pr, int64_t analysed, double tau0) {
  char buf[300];
  const double span = static_cast<double>(analysed) * tau0;
  std::snprintf(buf, sizeof buf, "%s%s%s: %lld samples at %.6g Hz, %.1f %s", meta.sources.front().c_str(),
                meta.sources.size() > 1 ? (" (+" + std::to_string(meta.sources.size() - 1) + ")").c_str() : "",
                meta.topic.empty() ? "" : (" " + meta.topic).c_str(), static_cast<long long>(analysed), 1.0 / tau0,
                span >= 7200 ? span / 3600 : span >= 120 ? span / 60 : span, span >= 7200 ? "h" : span >= 120 ? "min" : "s");
  std::string s = buf;
  if (!meta.accel_topic.empty() && pr.accel_tau0 > 0) {
    std::snprintf(buf, sizeof buf, "; accelerometer from %s at %.6g Hz", meta.accel_topic.c_str(), 1.0 / pr.accel_tau0);
    s += buf;
  }
  const StampReport& st = meta.stamps;
  if (st.receipt_stamps) s += "; arrival-time stamps put back on the sampler's grid";
  if (st.gaps > 0) s += "; " + std::to_string(st.gaps) + " gaps";
  const int64_t dropped = st.non_finite + st.zero_stamp + st.out_of_order + st.duplicate + st.too_close + st.short_segment;
  if (dropped > 0) s += "; " + std::to_string(dropped) + " samples dropped";
  if (meta.rest_checked) {
    if (meta.rest.at_rest) s += "; at rest";
    else {
      std::snprintf(buf, sizeof buf, "; MOVED: only %.1f-%.1f s analysed", meta.rest_from_s, meta.rest_to_s);
      s += buf;
    }
  }
  if (!meta.input_note.empty()) s += "; " + meta.input_note;
  return s;
}

/// GYRO_ALLAN_PROFILE=1: one stderr line per stage with wall and CPU time since start, resident and peak memory (for
/// bench/whole_tool.sh and docs/performance.md).
void profileStage(const char* stage) {
  static const bool on = [] {
    const char* e = std::getenv("GYRO_ALLAN_PROFILE");
    return e && std::string(e) == "1";
  }();
  if (!on) return;
  static const auto t0 = std::chrono::steady_clock::now();
  const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  long rss = 0, hwm = 0;
  if (FILE* f = std::fopen("/proc/self/status", "r")) {
    char line[256];
    while (std::fgets(line, sizeof line, f)) {
      std::sscanf(line, "VmRSS: %ld", &rss);
      std::sscanf(line, "VmHWM: %ld", &hwm);
    }
    std::fclose(f);
  }
  // Process CPU time (all threads) since the first stage: cpu/wall over a stage is how many cores it kept busy.
  timespec cpu{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &cpu);
  static const double c0 = static_cast<double>(cpu.tv_sec) + 1e-9 * static_cast<double>(cpu.tv_nsec);
  const double c = static_cast<double>(cpu.tv_sec) + 1e-9 * static_cast<double>(cpu.tv_nsec) - c0;
  std::fprintf(stderr, "profile: %-28s %7.3f s  cpu %6.3f s  rss %6.1f MB  peak %6.1f MB\n", stage, t, c, rss / 1024.0,
               hwm / 1024.0);
#ifdef __GLIBC__
  if (std::getenv("GYRO_ALLAN_PROFILE_MALLOC")) malloc_stats();
#endif
}

/// A topic whose angular velocity is never published (all zero, or flagged absent by covariance[0] = -1) is not a gyro:
/// one line saying so, and how to read a split gyro/accel pair.
void checkGyroPublished(const ImuSeries& s) {
  bool any = false;
  for (const auto& axis : s.gyro)
    for (size_t i = 0; i < axis.size() && !any; ++i) any = axis[i] != 0 && std::isfinite(axis[i]);
  if (any || s.gyro[0].empty()) return;
  const bool flagged = s.gyro_flagged == static_cast<int64_t>(s.gyro[0].size());
  throw InputError("topic '" + s.topic + "' carries no angular velocity (" +
                   (flagged ? "angular_velocity_covariance[0] = -1" : "all zero") +
                   " in every message): an accelerometer stream? give the gyro's topic with --topic and this one "
                   "with --accel-topic");
}

int run(const Args& args, std::vector<AxisAnalysis>* gyro_out = nullptr,
        std::vector<AxisAnalysis>* accel_out = nullptr) {
  AnalysisOptions opt;
  std::string err;
  if (!parseTauGrid(args.tau_grid, &opt.deviation.grid, &err)) throw UsageError("--tau-grid: " + err);
  opt.deviation.confidence = args.confidence;
  opt.deviations = splitList(args.deviations);
  if (opt.deviations.empty()) throw UsageError("--deviations is empty");
  for (const auto& d : opt.deviations)
    if (!isDeviationName(d)) throw UsageError("--deviations: unknown deviation '" + d + "'");
  const bool angle_input = args.input == "angle" || !args.angle_topic.empty();
  opt.input = angle_input ? InputKind::Angle : InputKind::Rate;
  opt.angle_increments = angle_input && args.angle_mode == "increment";
  // GMWM (#16): --method gmwm = auto's coefficients plus the GMWM stage; --filter-rate implies it.
  opt.gmwm = args.method == "gmwm" || args.filter_rate > 0;
  if (!parseRequestedMethod(args.method == "gmwm" ? "auto" : args.method, &opt.method))
    throw UsageError("--method must be auto, joint_fit, wavelet_split or gmwm");
  if (opt.method == Method::WaveletSplit && !args.wavelet_split)
    throw UsageError("--method wavelet_split contradicts --no-wavelet-split");
  opt.wavelet_split = args.wavelet_split;
  opt.model_check = args.model_check;
  opt.remove_spikes = !args.keep_spikes;
  const char* no_plot = std::getenv("GYRO_ALLAN_NO_PLOT");
  const bool plot = args.plot && !(no_plot && std::string(no_plot) == "1");

  ReportMeta meta;
  meta.tau_grid = tauGridName(opt.deviation.grid);
  // --filter-rate implies --method gmwm (--help), and the nodelet's ~save writes gmwm for auto + GMWM: the same here.
  meta.method = (opt.gmwm && args.method == "auto") ? "gmwm" : args.method;
  std::vector<double> temp_t, temp_v;  // temperature series (bags with a sensor_msgs/Temperature topic)
  std::string accel_flag_note;          // the accelerometer flagged absent in every message
  // Bags: samples and stamps held compactly (4 bytes each) until sanitized; accel = linear_acceleration, m/s^2.
  std::array<CompactSeries, 3> gyro_c, accel;
  CompactStamps t_c;
  bool compact = false;
  meta.confidence = args.confidence;
  meta.input = !angle_input ? "rate" : opt.angle_increments ? "angle_increment" : "angle";
  SanitizeOptions so;
  so.gap_factor = args.gap_factor;

  std::vector<std::string> names;
  std::vector<double> t;
  std::vector<std::vector<double>> values;
  CompactStamps accel_t_c;  // a separate accelerometer stream's own stamps (bags with --accel-topic)
  std::string input_note;   // how the input was read, when it was not what the user said (printed, in report.yaml)
  if (!args.csv.empty()) {
    CsvOptions co;
    const std::string u = args.units.empty() ? (args.input == "angle" ? "rad" : "rad/s") : args.units;
    if (u == "deg/s" || u == "deg") co.scale = M_PI / 180.0;
    else if (u != "rad/s" && u != "rad") throw UsageError("--units must be rad/s or deg/s (rad or deg for angles)");
    co.time_unit = args.time_unit;
    meta.input_units = u;
    CsvSeries cs;
    try {
      cs = readCsvFile(args.csv, co);
    } catch (const std::exception& e) {
      throw InputError(args.csv + ": " + e.what());
    }
    meta.sources.push_back(args.csv);
    if (!cs.gyro_unit.empty() && !angle_input) {  // the header says the unit
      if (!args.units.empty() && args.units != cs.gyro_unit)
        throw UsageError("--units " + args.units + " contradicts the CSV header's gyro unit " + cs.gyro_unit);
      if (args.units.empty() && cs.gyro_unit == "deg/s")
        for (int c : cs.gyro)
          for (double& v : cs.columns[static_cast<size_t>(c)]) v *= M_PI / 180.0;
      meta.input_units = cs.gyro_unit;
    }
    if (cs.time_unit_from == "magnitude")
      input_note = "time column read as " +
                   std::string(cs.time_unit == "ns" ? "nanoseconds" : cs.time_unit == "us" ? "microseconds" : "milliseconds") +
                   " (epoch stamps)";
    if (!cs.t.empty() && cs.gyro.size() == 3) {
      // Gyroscope (and accelerometer) columns known by name: read as a bag's samples are, at exact stamps.
      std::vector<std::string> unused;
      std::vector<bool> used(cs.columns.size(), false);
      for (int c : cs.gyro) used[static_cast<size_t>(c)] = true;
      for (int c : cs.accel) used[static_cast<size_t>(c)] = true;
      for (size_t c = 0; c < cs.columns.size(); ++c)
        if (!used[c]) unused.push_back(cs.names[c]);
      if (!unused.empty() && !args.quiet) {
        std::string list;
        for (const auto& n : unused) list += (list.empty() ? "" : ", ") + n;
        std::cerr << "analyze_bag: warning: CSV columns not analysed: " << list << "\n";
      }
      names = {"x", "y", "z"};
      t_c.reserve(cs.t_ns.size());
      for (int64_t ns : cs.t_ns) t_c.push_back(ns);
      for (size_t k = 0; k < 3; ++k) {
        for (double v : cs.columns[static_cast<size_t>(cs.gyro[k])]) gyro_c[k].push_back(v);
        if (args.accel && cs.accel.size() == 3)
          for (double v : cs.columns[static_cast<size_t>(cs.accel[k])]) accel[k].push_back(v);
      }
      t = t_c.toSeconds();
      compact = true;
      if (args.rate > 0) so.nominal_rate_hz = args.rate;
    } else {
      names = cs.names;
      values = cs.columns;
      if (cs.gyro.size() == 3) {  // gyro columns known by name: the axes x, y, z, as from a bag
        names = {"x", "y", "z"};
        values.clear();
        for (int c : cs.gyro) values.push_back(cs.columns[static_cast<size_t>(c)]);
      }
      if (!cs.t.empty()) {
        t.resize(cs.t_ns.size());  // seconds since (the first stamp - 1 s), exactly as the file gives them
        for (size_t i = 0; i < t.size(); ++i) t[i] = 1e-9 * static_cast<double>(cs.t_ns[i]);
        if (args.rate > 0) so.nominal_rate_hz = args.rate;
      } else {
        if (!(args.rate > 0)) throw UsageError("--rate HZ is required for a CSV without a time column");
        t.resize(static_cast<size_t>(cs.rows));
        for (size_t i = 0; i < t.size(); ++i) t[i] = (static_cast<double>(i) + 1.0) / args.rate;
        so.nominal_rate_hz = args.rate;
      }
    }
  } else {
    if (args.input == "angle")
      throw UsageError("--input angle is for CSV input; bag angles: --angle-topic T (geometry_msgs/Vector3Stamped)");
    BagReadOptions bo;
    bo.topic = args.topic;
    bo.angle_topic = args.angle_topic;
    bo.accel_topic = args.accel_topic;
    if (angle_input) meta.input_units = "rad";
    bo.temperature_topic = args.temperature_topic;
    bo.use_bag_time = args.bag_time;
    bo.start_s = args.start;
    bo.duration_s = args.duration;
    bo.progress = !args.quiet;
    profileStage("start");
    ImuSeries s = readImuBags(args.bags, bo);
    releaseFreed();  // the bag index (tens of MB of small nodes) is freed: give its pages back before the analysis
    profileStage("read");
    meta.sources = s.bags;
    meta.topic = s.topic;
    meta.accel_topic = s.accel_topic;
    if (!s.accel_topic.empty() && args.accel_topic.empty())
      input_note = "the gyro/accel pair found by its topics' names";
    checkGyroPublished(s);
    names = {"x", "y", "z"};
    t_c = std::move(s.t);
    gyro_c = std::move(s.gyro);
    compact = true;
    temp_t = std::move(s.temperature_t);
    if (args.accel) {
      if (s.accel_flagged > 0 && s.accel_flagged == static_cast<int64_t>(s.accel[0].size())) {
        accel_flag_note = "accelerometer: linear_acceleration_covariance[0] = -1 in every message (not published): "
                          "not analysed";
      } else {
        accel = std::move(s.accel);
        accel_t_c = std::move(s.accel_t);
      }
    }
    temp_v = std::move(s.temperature);
    if (args.rate > 0) so.nominal_rate_hz = args.rate;
  }
  if (values.size() > 3) {
    if (!args.quiet) std::cerr << "analyze_bag: warning: only the first 3 value columns are analysed\n";
    values.resize(3);
    names.resize(3);
  }
  meta.input_note = input_note;
  PipelineInput in;
  in.compact = compact;
  in.names = std::move(names);
  in.t = std::move(t);
  in.values = std::move(values);
  in.t_c = std::move(t_c);
  in.gyro_c = std::move(gyro_c);
  in.accel_c = std::move(accel);
  in.accel_t_c = std::move(accel_t_c);
  in.temperature_t = std::move(temp_t);
  in.temperature = std::move(temp_v);
  PipelineOptions po;
  po.analysis = opt;
  po.sanitize = so;
  po.rest_check = args.rest_check;
  po.accel = args.accel;
  po.jobs = args.jobs;
  po.stage = profileStage;
  PipelineResult pr = runPipeline(std::move(in), po);
  if (pr.accel_note.empty()) pr.accel_note = accel_flag_note;
  const double tau0 = pr.tau0;
  setPipelineMeta(pr, &meta);
  const std::vector<AxisAnalysis>& results = pr.gyro;
  const std::vector<AxisAnalysis>& accel_results = pr.accel;
  const std::string& accel_note = pr.accel_note;
  // Warnings on stderr, each in full: with --verbose on one line; else wrapped at 200 characters (continuation lines
  // indented), at most 6 of them (report.yaml has them all).
  size_t shown = 0;
  for (const auto& w : meta.warnings) {
    if (args.quiet) break;
    if (!args.verbose && ++shown > 6) {
      std::cerr << "analyze_bag: warning: " << meta.warnings.size() - 6 << " more warnings in report.yaml\n";
      break;
    }
    std::cerr << (args.verbose ? "analyze_bag: warning: " + w : wrapLine("analyze_bag: warning: " + w, 200)) << "\n";
  }
  try {
    makeDir(args.output);
    writeAnalysisFiles(args.output, meta, pr, args.format, parseKalibrAxisRule(args.kalibr_axis),
                       opt.input == InputKind::Rate,
                       "the whole record; at-rest check skipped (--no-rest-check): valid only if the sensor was static");
    if (opt.gmwm) writeFileAtomic(args.output + "/noise_model.yaml", noiseModelYaml(results, args.filter_rate, meta.sources));
  } catch (const std::exception& e) {
    std::cerr << "analyze_bag: error: " << e.what() << "\n";
    return kExitOutput;
  }
  std::string plot_note;  // the plot is optional: a failure is a warning
  if (plot) {
    try {
      plot_note = writeFigure(args.output, analysisFigure(results, accel_results));
    } catch (const std::exception& e) {
      plot_note = e.what();
    }
    if (!plot_note.empty() && !args.quiet) std::cerr << "analyze_bag: warning: no allan.png: " << plot_note << "\n";
  }
  if (!args.quiet) {
    const int64_t analysed = pr.analysed();
    if (args.verbose) {
      std::printf("%s%s: %lld samples, %.6g Hz, %.1f s, tau grid %s\n", meta.sources.front().c_str(),
                  meta.topic.empty() ? "" : (" " + meta.topic).c_str(), static_cast<long long>(analysed), 1.0 / tau0,
                  static_cast<double>(analysed) * tau0, meta.tau_grid.c_str());
      if (!meta.input_note.empty()) std::printf("input: %s\n", meta.input_note.c_str());
      std::printf("%s", inputSummary(meta).c_str());
      std::printf("%s", summaryTable(results).c_str());
      if (!accel_results.empty()) std::printf("%s", accelSummaryTable(accel_results).c_str());
    } else {
      std::printf("%s\n", wrapLine(briefInput(meta, pr, analysed, tau0), 200).c_str());
      std::printf("%s", briefSummary(results, accel_results).c_str());
    }
    if (opt.gmwm) std::printf("%swrote %s/noise_model.yaml\n", gmwmSummary(results).c_str(), args.output.c_str());
    if (!accel_note.empty()) std::printf("%s\n", accel_note.c_str());
    std::printf("wrote %s/: report.%s, allan.csv%s\n", args.output.c_str(), args.format.c_str(),
                !plot ? "" : plot_note.empty() ? ", allan.png, allan.svg" : "");
    std::printf("IMU noise for Kalibr imu.yaml, OpenVINS kalibr_imu_chain.yaml, VINS-Fusion vins_fusion_imu.yaml, "
                "ORB-SLAM3 orb_slam3_imu.yaml, Basalt basalt_imu.json\n");
  }
  if (gyro_out) *gyro_out = results;
  if (accel_out) *accel_out = accel_results;
  return kExitOk;
}

/// One CSV field, quoted when it holds a comma, quote or newline.
std::string csvField(const std::string& v) {
  if (v.find_first_of(",\"\n") == std::string::npos) return v;
  std::string q = "\"";
  for (char c : v) q += c == '"' ? std::string("\"\"") : std::string(1, c == '\n' ? ' ' : c);
  return q + "\"";
}

/// --batch DIR: every DIR/*.bag (sorted by name) analysed on its own into OUTPUT/<bag name>/; OUTPUT/summary.csv has
/// one row per bag, sensor and axis (fitted coefficients in SI; unsupported terms listed in `unsupported`) or one row with
/// the error of a failing bag.
int runBatch(const Args& args) {
  std::vector<std::string> bags;
  DIR* d = opendir(args.batch.c_str());
  if (!d) throw InputError("--batch: cannot open folder '" + args.batch + "'");
  while (dirent* e = readdir(d)) {
    const std::string n = e->d_name;
    if (n == "." || n == "..") continue;
    // ROS 1 bags, ROS 2 storage files and ROS 2 recording folders, each analysed on its own.
    if ((n.size() > 4 && n.compare(n.size() - 4, 4, ".bag") == 0) || rosbag2::isRos2Input(args.batch + "/" + n))
      bags.push_back(n);
  }
  closedir(d);
  std::sort(bags.begin(), bags.end());
  if (bags.empty()) throw InputError("--batch: no *.bag, *.mcap, *.db3 or rosbag2 folder in '" + args.batch + "'");
  try {
    makeDir(args.output);
  } catch (const std::exception& e) {
    std::cerr << "analyze_bag: error: " << e.what() << "\n";
    return kExitOutput;
  }
  std::ostringstream csv;
  csv << "bag,sensor,axis,status,quantization,angle_random_walk,bias_instability,rate_random_walk,rate_ramp,"
         "unsupported,rms_log10,method,quality,error\n";
  int failed = 0;
  for (const auto& name : bags) {
    Args sub = args;
    sub.batch.clear();
    sub.bags = {args.batch + "/" + name};
    auto stem = [](const std::string& n) {
      const size_t dot = n.rfind('.');
      return dot == std::string::npos || dot == 0 ? n : n.substr(0, dot);
    };
    size_t same = 0;  // a.bag beside a.mcap: each keeps its whole name
    for (const auto& other : bags) same += stem(other) == stem(name);
    sub.output = args.output + "/" + (same > 1 ? name : stem(name));
    std::vector<AxisAnalysis> gyro, accel;
    std::string error;
    int code = kExitOk;
    try {
      code = run(sub, &gyro, &accel);
      if (code != kExitOk) error = "cannot write output to " + sub.output;
    } catch (const std::exception& e) {
      error = e.what();
      code = kExitInput;
    }
    if (!args.quiet) std::fprintf(stderr, "analyze_bag: batch: %s: %s\n", name.c_str(), error.empty() ? "ok" : error.c_str());
    if (!error.empty()) {
      ++failed;
      csv << csvField(name) << ",,,failed,,,,,,,,,," << csvField(error) << "\n";
      continue;
    }
    auto rows = [&](const std::vector<AxisAnalysis>& axes, const char* sensor) {
      for (const auto& a : axes) {
        std::string axis = a.axis;
        if (axis.rfind("accel_", 0) == 0) axis = axis.substr(6);
        csv << csvField(name) << ',' << sensor << ',' << axis << ",ok";
        std::string unsupported;
        char buf[32];
        for (int t = 0; t < kNumTerms; ++t) {
          const Coefficient& c = a.coefficients[static_cast<size_t>(t)];
          std::snprintf(buf, sizeof buf, ",%.6g", c.value);
          csv << buf;
          if (!c.supported) unsupported += std::string(unsupported.empty() ? "" : " ") + noiseTermKey(t);
        }
        std::snprintf(buf, sizeof buf, ",%.4f", a.final_error.rms_log10);
        csv << ',' << unsupported << buf << ',' << methodName(a.method) << ',' << qualityName(a.quality.quality) << ",\n";
      }
    };
    rows(gyro, "gyro");
    rows(accel, "accel");
  }
  try {
    writeFileAtomic(args.output + "/summary.csv", csv.str());
  } catch (const std::exception& e) {
    std::cerr << "analyze_bag: error: " << e.what() << "\n";
    return kExitOutput;
  }
  if (!args.quiet)
    std::printf("batch: %zu bags, %d failed; wrote %s/summary.csv\n", bags.size(), failed, args.output.c_str());
  return failed ? kExitBatchFailed : kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  // rosbag/cpp_common report parse problems through console_bridge before throwing: silence it so a corrupt bag
  // gives our one-line error only.
  console_bridge::setLogLevel(console_bridge::CONSOLE_BRIDGE_LOG_NONE);
  try {
    const Args args = parseArgs(argc, argv);
    return args.batch.empty() ? run(args) : runBatch(args);
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
