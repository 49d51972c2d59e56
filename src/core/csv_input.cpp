// CSV / single-column series reader with line-numbered errors.
#include "gyro_allan/csv_input.hpp"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <zlib.h>

namespace gyro_allan {
namespace {

std::vector<std::string> splitFields(const std::string& line) {
  std::vector<std::string> out;
  std::string cur;
  bool any_sep = false;
  for (char ch : line) {
    if (ch == ',' || ch == ';' || ch == '\t') {
      out.push_back(cur);
      cur.clear();
      any_sep = true;
    } else {
      cur.push_back(ch);
    }
  }
  out.push_back(cur);
  if (!any_sep) {  // whitespace separated
    out.clear();
    std::istringstream ss(line);
    std::string f;
    while (ss >> f) out.push_back(f);
  }
  for (auto& f : out) {
    const size_t b = f.find_first_not_of(" \r\n\"'");
    const size_t e = f.find_last_not_of(" \r\n\"'");
    f = (b == std::string::npos) ? std::string() : f.substr(b, e - b + 1);
  }
  return out;
}

bool parseNumber(const std::string& s, double* v) {
  if (s.empty()) return false;
  const char* begin = s.c_str();
  char* end = nullptr;
  errno = 0;
  const double x = std::strtod(begin, &end);
  if (end == begin || *end != '\0') return false;
  *v = x;
  return true;
}

bool isTimeName(std::string n) {
  for (auto& c : n) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return n == "t" || n == "time" || n == "stamp" || n == "t_s" || n == "time_s" || n == "timestamp";
}

}  // namespace

CsvSeries parseCsv(std::istream& in, const CsvOptions& options) {
  if (!std::isfinite(options.scale) || options.scale == 0) throw std::invalid_argument("csv: scale must be finite and non-zero");
  CsvSeries out;
  std::string line;
  int64_t line_no = 0;
  bool have_layout = false;
  int time_col = -1;
  size_t ncols = 0;
  while (std::getline(in, line)) {
    ++line_no;
    const size_t first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') {
      ++out.blank_or_comment;
      continue;
    }
    std::vector<std::string> f = splitFields(line);
    if (!have_layout) {
      have_layout = true;
      ncols = f.size();
      std::vector<double> vals(f.size());
      bool numeric = true;
      for (size_t i = 0; i < f.size(); ++i) numeric = numeric && parseNumber(f[i], &vals[i]);
      std::vector<std::string> names;
      if (!numeric) {
        for (size_t i = 0; i < f.size(); ++i) {
          if (time_col < 0 && isTimeName(f[i])) time_col = static_cast<int>(i);
          else names.push_back(f[i].empty() ? "col" + std::to_string(i) : f[i]);
        }
      } else {
        static const char* xyz[] = {"x", "y", "z"};
        // Numeric first row: 1 column = one axis; 2 = t + one axis; 3 = x,y,z; 4 = t,x,y,z; more = t + columns.
        if (ncols == 2 || ncols >= 4) time_col = 0;
        for (size_t i = 0; i < ncols; ++i)
          if (static_cast<int>(i) != time_col) names.push_back(names.size() < 3 && ncols <= 4 ? xyz[names.size()] : "col" + std::to_string(i));
      }
      if (names.empty()) throw std::invalid_argument("line " + std::to_string(line_no) + ": no value column");
      out.names = names;
      out.columns.assign(names.size(), {});
      if (!numeric) continue;
    }
    if (f.size() != ncols)
      throw std::invalid_argument("line " + std::to_string(line_no) + ": expected " + std::to_string(ncols) +
                                  " columns, found " + std::to_string(f.size()));
    size_t c = 0;
    for (size_t i = 0; i < f.size(); ++i) {
      double v;
      if (!parseNumber(f[i], &v))
        throw std::invalid_argument("line " + std::to_string(line_no) + ": column " + std::to_string(i + 1) +
                                    " is not a number: '" + f[i].substr(0, 40) + "'");
      if (static_cast<int>(i) == time_col) out.t.push_back(v);
      else out.columns[c++].push_back(v * options.scale);  // NaN/Inf pass through: sanitation counts them
    }
    ++out.rows;
  }
  if (out.rows == 0) throw std::invalid_argument("csv: no data rows");
  return out;
}

CsvSeries readCsvFile(const std::string& path, const CsvOptions& options) {
  const bool gz = path.size() > 3 && path.compare(path.size() - 3, 3, ".gz") == 0;
  {
    std::ifstream probe(path);
    if (!probe) throw std::runtime_error("cannot open '" + path + "'");
  }
  if (!gz) {
    std::ifstream f(path);
    return parseCsv(f, options);
  }
  // gzip (one or more members) decompressed by zlib; a file that is not gzip, or is truncated or corrupt, is an error.
  gzFile f = gzopen(path.c_str(), "rb");
  if (!f) throw std::runtime_error("cannot open '" + path + "'");
  const std::runtime_error bad("'" + path + "' is not a readable gzip file");
  if (gzdirect(f)) {
    gzclose_r(f);
    throw bad;
  }
  std::string text;
  char buf[1 << 16];
  int n;
  while ((n = gzread(f, buf, sizeof buf)) > 0) text.append(buf, static_cast<size_t>(n));
  int err = Z_OK;
  gzerror(f, &err);
  const int closed = gzclose_r(f);
  if (n < 0 || (err != Z_OK && err != Z_STREAM_END) || closed != Z_OK) throw bad;
  std::istringstream ss(text);
  return parseCsv(ss, options);
}

}  // namespace gyro_allan
