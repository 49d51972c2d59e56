// Plain-text series input: a CSV with an optional header (t,wx,wy,wz / one column per axis) or a single column.
#pragma once

#include <istream>
#include <string>
#include <vector>

namespace gyro_allan {

struct CsvSeries {
  std::vector<std::string> names;            ///< column names of the value columns (x, y, z or from the header)
  std::vector<std::vector<double>> columns;  ///< value columns, scaled to SI
  std::vector<double> t;                     ///< time column when present, s (else empty)
  int64_t rows = 0;                          ///< data rows read
  int64_t blank_or_comment = 0;              ///< lines skipped ('#' comments, blank)
};

struct CsvOptions {
  double scale = 1.0;  ///< multiply every value (e.g. pi/180 for deg/s input)
};

/// Parses CSV text. The first non-comment line is a header when it does not parse as numbers; a header column
/// named t, time, stamp or t_s is the time column. Separators: comma, semicolon, tab or spaces. Throws
/// std::invalid_argument with "line N: ..." on a malformed row (wrong column count, not a number).
CsvSeries parseCsv(std::istream& in, const CsvOptions& options = {});
/// Reads a file (a path ending in .gz is decompressed with zlib). Throws std::runtime_error if unreadable or, for
/// .gz, not a complete gzip file.
CsvSeries readCsvFile(const std::string& path, const CsvOptions& options = {});

}  // namespace gyro_allan
