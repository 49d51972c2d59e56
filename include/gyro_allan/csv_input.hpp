// Plain-text series input: a CSV with an optional header (t,wx,wy,wz / one column per axis, EuRoC/TUM-VI data.csv,
// Kalibr's imu0.csv) or a single column; the time column's unit (s, ms, us, ns) from its header or its magnitude.
#pragma once

#include <istream>
#include <string>
#include <vector>

namespace gyro_allan {

struct CsvSeries {
  std::vector<std::string> names;            ///< column names of the value columns (x, y, z or from the header)
  std::vector<std::vector<double>> columns;  ///< value columns, scaled to SI
  std::vector<double> t;                     ///< time column when present, s (else empty)
  /// The time column exactly, in integer ns since (its first value - 1 s): no rounding of long epoch stamps, and
  /// no stamp at 0 (a zero stamp is invalid to the sanitation). Parallel to t.
  std::vector<int64_t> t_ns;
  std::string time_unit;                     ///< "s", "ms", "us" or "ns": how the time column was read
  std::string time_unit_from;                ///< "header", "option", "magnitude" (epoch stamps in ns, us, ms) or "default"
  /// Gyroscope and accelerometer columns recognised by their names (indices into columns, in x, y, z order): EuRoC
  /// and TUM-VI (w_RS_S_x ..., a_RS_S_x ...), Kalibr (omega_x ..., alpha_x ...), and wx / gyro_x / acc_x ... names.
  /// Empty when the header names no such columns (then the value columns are the gyro's, in order).
  std::vector<int> gyro, accel;
  std::string gyro_unit;                     ///< the gyro columns' unit as the header gives it ("rad/s", "deg/s"), or ""
  std::string layout = "generic";           ///< "euroc" (w_RS_S_/a_RS_S_), "kalibr" (omega_/alpha_) or "generic"
  int64_t rows = 0;                          ///< data rows read
  int64_t blank_or_comment = 0;              ///< lines skipped ('#' comments, blank)
};

struct CsvOptions {
  double scale = 1.0;  ///< multiply every value but the accelerometer's (e.g. pi/180 for deg/s input)
  /// Unit of the time column: "" = from its header ("[ns]", "t_ns"...), else the unit in which its first stamp is a
  /// date of 2000-2100 (epoch stamps in ns, us or ms), else seconds; or "s", "ms", "us", "ns".
  std::string time_unit;
};


/// Parses CSV text. The first non-comment line is a header when it does not parse as numbers (a '#' line before the
/// data is the header when it names several columns, as in EuRoC's "#timestamp [ns],w_RS_S_x [rad s^-1],..."); a
/// header column named t, time, timestamp, stamp (with an optional unit: t_s, timestamp [ns]...) is the time
/// column. Separators: comma, semicolon, tab or spaces. Throws std::invalid_argument with "line N: ..." on a
/// malformed row (wrong column count, not a number), and on a time column whose implied rate or span is not a
/// sensor's (1 Hz to 100 kHz, at most a year), naming the unit it would fit.
CsvSeries parseCsv(std::istream& in, const CsvOptions& options = {});
/// Reads a file (a path ending in .gz is decompressed with zlib). Throws std::runtime_error if unreadable or, for
/// .gz, not a complete gzip file.
CsvSeries readCsvFile(const std::string& path, const CsvOptions& options = {});

}  // namespace gyro_allan
