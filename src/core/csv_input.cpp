// CSV / single-column series reader with line-numbered errors.
#include "gyro_allan/csv_input.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <climits>
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

std::string lower(std::string n) {
  for (auto& c : n) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return n;
}

std::string trim(const std::string& s) {
  const size_t b = s.find_first_not_of(" \t#");
  const size_t e = s.find_last_not_of(" \t");
  return b == std::string::npos ? std::string() : s.substr(b, e - b + 1);
}

/// A header name split into its name and its unit: "timestamp [ns]" -> ("timestamp", "ns"), "w_RS_S_x [rad s^-1]" ->
/// ("w_rs_s_x", "rad s^-1"); lower case.
void splitUnit(const std::string& field, std::string* name, std::string* unit) {
  std::string n = lower(trim(field));
  unit->clear();
  const size_t open = n.find_first_of("[(");
  if (open != std::string::npos) {
    const size_t close = n.find_first_of("])", open);
    *unit = trim(n.substr(open + 1, close == std::string::npos ? std::string::npos : close - open - 1));
    n = trim(n.substr(0, open));
  }
  *name = n;
}

/// Whether a header field names the time column; *unit gets its unit ("s", "ms", "us", "ns") when it says one.
bool isTimeColumn(const std::string& field, std::string* unit) {
  std::string n, u;
  splitUnit(field, &n, &u);
  static const char* kUnits[] = {"ns", "us", "ms", "s"};
  if (u.empty())
    for (const char* k : kUnits) {  // t_ns, timestamp_us, time_s ...
      const std::string suffix = std::string("_") + k;
      if (n.size() > suffix.size() && n.compare(n.size() - suffix.size(), suffix.size(), suffix) == 0) {
        u = k;
        n = n.substr(0, n.size() - suffix.size());
        break;
      }
    }
  if (u == "sec" || u == "seconds") u = "s";
  if (u == "nsec" || u == "nanoseconds") u = "ns";
  if (u == "usec" || u == "\xc2\xb5s" || u == "microseconds") u = "us";
  if (u == "msec" || u == "milliseconds") u = "ms";
  if (!(n == "t" || n == "time" || n == "stamp" || n == "timestamp" || n == "time_stamp" || n == "ts")) return false;
  *unit = (u == "s" || u == "ms" || u == "us" || u == "ns") ? u : "";
  return true;
}

/// The role of a value column by its name: 'g' gyroscope, 'a' accelerometer, 0 unknown; *axis 0..2, *family the
/// naming convention ("euroc", "kalibr", "generic").
char columnRole(const std::string& field, int* axis, std::string* family) {
  std::string n, u;
  splitUnit(field, &n, &u);
  if (n.empty()) return 0;
  const char last = n.back();
  if (last < 'x' || last > 'z') return 0;
  *axis = last - 'x';
  std::string prefix = n.substr(0, n.size() - 1);
  while (!prefix.empty() && (prefix.back() == '_' || prefix.back() == ' ' || prefix.back() == '.')) prefix.pop_back();
  static const char* kGyro[] = {"", "w", "omega", "gyro", "gyr", "gyroscope", "g", "angular_velocity", "ang_vel", "wm"};
  static const char* kAccel[] = {"a", "alpha", "acc", "accel", "accelerometer", "linear_acceleration", "lin_acc", "am"};
  if (prefix == "w_rs_s") {
    *family = "euroc";
    return 'g';
  }
  if (prefix == "a_rs_s") {
    *family = "euroc";
    return 'a';
  }
  for (const char* k : kGyro)
    if (prefix == k) {
      *family = prefix == "omega" ? "kalibr" : "generic";
      return 'g';
    }
  for (const char* k : kAccel)
    if (prefix == k) {
      *family = prefix == "alpha" ? "kalibr" : "generic";  // Kalibr's imu0.csv names the acceleration alpha_x...
      return 'a';
    }
  return 0;
}

/// A decimal number's text as value * 1e9 in 128-bit integers (exact for any stamp a file holds: 20-digit
/// nanosecond stamps, 1e9-second stamps with 9 decimals). False when it is not a plain decimal (nan, inf, hex).
bool parseDecimalE9(const std::string& s, __int128* out) {
  size_t i = 0;
  bool neg = false;
  if (i < s.size() && (s[i] == '+' || s[i] == '-')) neg = s[i++] == '-';
  __int128 mant = 0;
  int exp = 0, digits = 0;
  bool any = false, dot = false;
  for (; i < s.size(); ++i) {
    const char c = s[i];
    if (c >= '0' && c <= '9') {
      any = true;
      if (digits < 30) {
        mant = mant * 10 + (c - '0');
        if (mant != 0) ++digits;
        if (dot) --exp;
      } else if (!dot) {
        ++exp;  // digits beyond 30 significant ones: scale only
      }
    } else if (c == '.' && !dot) {
      dot = true;
    } else {
      break;
    }
  }
  if (!any) return false;
  if (i < s.size() && (s[i] == 'e' || s[i] == 'E')) {
    ++i;
    bool eneg = false;
    if (i < s.size() && (s[i] == '+' || s[i] == '-')) eneg = s[i++] == '-';
    int e = 0;
    bool edig = false;
    for (; i < s.size() && s[i] >= '0' && s[i] <= '9'; ++i) {
      edig = true;
      if (e < 1000) e = e * 10 + (s[i] - '0');
    }
    if (!edig) return false;
    exp += eneg ? -e : e;
  }
  if (i != s.size()) return false;
  exp += 9;
  if (exp > 0) {
    for (int k = 0; k < exp; ++k) {
      if (mant > (static_cast<__int128>(1) << 120)) return false;
      mant *= 10;
    }
  } else {
    for (int k = 0; k < -exp && mant != 0; ++k) mant = (mant + (k == -exp - 1 ? 5 : 0)) / 10;
  }
  // Beyond 1e19 in any unit no value is a time (epoch nanoseconds are 1.7e18): refused, so that converting the
  // others to nanoseconds (* 1e9) stays inside 128 bits.
  if (mant > static_cast<__int128>(10000000000000000000ULL) * 1000000000) return false;
  *out = neg ? -mant : mant;
  return true;
}

int64_t unitNs(const std::string& unit) {
  return unit == "ns" ? 1 : unit == "us" ? 1000 : unit == "ms" ? 1000000 : 1000000000;
}

/// A time field that is not a plain decimal (nan, inf).
const __int128 kNoTime = -(static_cast<__int128>(1) << 126);

/// Rate [Hz] and span [s] of raw time values (value * 1e9) read in `unit`: the median positive step, max - min.
void implied(const std::vector<__int128>& raw, const std::string& unit, double* rate, double* span) {
  const double to_s = 1e-9 * static_cast<double>(unitNs(unit)) * 1e-9;  // raw -> s
  std::vector<double> steps;
  steps.reserve(raw.size());
  __int128 prev = kNoTime, lo = 0, hi = 0;
  bool any = false;
  for (const auto& r : raw) {
    if (r == kNoTime) continue;
    if (prev != kNoTime && r > prev) steps.push_back(static_cast<double>(r - prev) * to_s);
    prev = r;
    if (!any || r < lo) lo = r;
    if (!any || r > hi) hi = r;
    any = true;
  }
  *rate = 0;
  if (!steps.empty()) {
    std::nth_element(steps.begin(), steps.begin() + static_cast<long>(steps.size() / 2), steps.end());
    *rate = 1.0 / steps[steps.size() / 2];
  }
  *span = static_cast<double>(hi - lo) * to_s;
}

constexpr double kMinRate = 1, kMaxRate = 1e5, kMaxSpan = 366 * 86400.0;
bool plausible(double rate, double span) { return rate >= kMinRate && rate <= kMaxRate && span <= kMaxSpan; }

std::string describeUnit(const std::string& u) {
  return u == "ns" ? "nanoseconds" : u == "us" ? "microseconds" : u == "ms" ? "milliseconds" : "seconds";
}

/// The refusal of a time column whose implied rate or span is absurd in `unit`, naming the units that would fit.
[[noreturn]] void absurdTime(const std::vector<__int128>& raw, const std::string& unit, const std::string& from) {
  double rate, span;
  implied(raw, unit, &rate, &span);
  char buf[400];
  std::snprintf(buf, sizeof buf, "time column read as %s (%s) implies %.3g Hz over %.3g s", describeUnit(unit).c_str(),
                from == "header" ? "its header says so" : from == "option" ? "--time-unit" : "the default", rate, span);
  std::string msg = buf;
  std::string fits;
  for (const char* u : {"s", "ms", "us", "ns"}) {
    if (u == unit) continue;
    double r2, s2;
    implied(raw, u, &r2, &s2);
    if (plausible(r2, s2)) {
      std::snprintf(buf, sizeof buf, "%s (%.4g Hz, %.4g s): give --time-unit %s", describeUnit(u).c_str(), r2, s2, u);
      fits = buf;
      break;
    }
  }
  msg += fits.empty() ? ": not a sensor's time column (a sensor samples at 1 Hz - 100 kHz for at most a year)"
                      : "; its values look like " + fits;
  throw std::invalid_argument(msg);
}

}  // namespace

CsvSeries parseCsv(std::istream& in, const CsvOptions& options) {
  if (!std::isfinite(options.scale) || options.scale == 0) throw std::invalid_argument("csv: scale must be finite and non-zero");
  if (!options.time_unit.empty() && options.time_unit != "s" && options.time_unit != "ms" && options.time_unit != "us" &&
      options.time_unit != "ns")
    throw std::invalid_argument("csv: time unit must be s, ms, us or ns");
  CsvSeries out;
  std::string line;
  int64_t line_no = 0;
  bool have_layout = false;
  int time_col = -1;
  size_t ncols = 0;
  std::string header_unit;
  std::vector<std::string> hash_header;  // the last '#' line before the data that names several columns
  std::vector<double> accel_scale;        // per value column: 1 for the gyro's, the accelerometer unit's for its own
  std::vector<__int128> raw_t;            // the time column, value * 1e9, exactly
  while (std::getline(in, line)) {
    ++line_no;
    const size_t first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') {
      ++out.blank_or_comment;
      if (!have_layout && first != std::string::npos) {
        std::vector<std::string> f = splitFields(line.substr(first + 1));
        double v;
        bool numeric = true;
        for (const auto& x : f) numeric = numeric && parseNumber(x, &v);
        if (f.size() >= 2 && !numeric) hash_header = f;
      }
      continue;
    }
    std::vector<std::string> f = splitFields(line);
    if (!have_layout) {
      have_layout = true;
      ncols = f.size();
      std::vector<double> vals(f.size());
      bool numeric = true;
      for (size_t i = 0; i < f.size(); ++i) numeric = numeric && parseNumber(f[i], &vals[i]);
      std::vector<std::string> header;
      if (!numeric) header = f;
      else if (hash_header.size() == ncols) header = hash_header;  // "#timestamp [ns],w_RS_S_x [rad s^-1],..."
      std::vector<std::string> names;
      if (!header.empty()) {
        for (size_t i = 0; i < header.size(); ++i) {
          std::string unit;
          if (time_col < 0 && isTimeColumn(header[i], &unit)) {
            time_col = static_cast<int>(i);
            header_unit = unit;
          } else {
            names.push_back(header[i].empty() ? "col" + std::to_string(i) : trim(header[i]));
          }
        }
        // Gyroscope and accelerometer columns by name (all three axes of each, else none).
        std::array<int, 3> g{{-1, -1, -1}}, a{{-1, -1, -1}};
        std::string family = "generic";
        for (size_t c = 0; c < names.size(); ++c) {
          int axis = 0;
          std::string fam;
          const char role = columnRole(names[c], &axis, &fam);
          std::array<int, 3>& slot = role == 'g' ? g : a;
          if (role && slot[static_cast<size_t>(axis)] < 0) {
            slot[static_cast<size_t>(axis)] = static_cast<int>(c);
            if (fam != "generic") family = fam;
          }
        }
        auto complete = [](const std::array<int, 3>& x) { return x[0] >= 0 && x[1] >= 0 && x[2] >= 0; };
        if (complete(g)) {
          out.gyro.assign(g.begin(), g.end());
          if (complete(a)) out.accel.assign(a.begin(), a.end());
          out.layout = family;
        }
        for (int c : out.gyro) {
          std::string n, u;
          splitUnit(names[static_cast<size_t>(c)], &n, &u);
          const std::string gu = u.find("rad") != std::string::npos ? "rad/s"
                                 : (u.find("deg") != std::string::npos || u.find("\xc2\xb0") != std::string::npos || u == "dps") ? "deg/s"
                                 : "";
          if (!gu.empty()) out.gyro_unit = gu;
        }
        accel_scale.assign(names.size(), 0);
        for (int c : out.accel) {
          std::string n, u;
          splitUnit(names[static_cast<size_t>(c)], &n, &u);
          accel_scale[static_cast<size_t>(c)] = (u == "g") ? 9.80665 : 1.0;
        }
      } else {
        static const char* xyz[] = {"x", "y", "z"};
        // Numeric first row: 1 column = one axis; 2 = t + one axis; 3 = x,y,z; 4 = t,x,y,z; 7 = t, gyro x,y,z,
        // accelerometer x,y,z (EuRoC's and Kalibr's order); more = t + columns.
        if (ncols == 2 || ncols >= 4) time_col = 0;
        if (ncols == 7) {
          names = {"wx", "wy", "wz", "ax", "ay", "az"};
          out.gyro = {0, 1, 2};
          out.accel = {3, 4, 5};
        } else {
          for (size_t i = 0; i < ncols; ++i)
            if (static_cast<int>(i) != time_col)
              names.push_back(names.size() < 3 && ncols <= 4 ? xyz[names.size()] : "col" + std::to_string(i));
          if (ncols == 4) out.gyro = {0, 1, 2};
        }
        accel_scale.assign(names.size(), 0);
        for (int c : out.accel) accel_scale[static_cast<size_t>(c)] = 1.0;
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
      if (static_cast<int>(i) == time_col) {
        out.t.push_back(v);
        __int128 r = 0;
        raw_t.push_back(parseDecimalE9(f[i], &r) ? r : kNoTime);  // nan, inf: a zero (invalid) stamp
      } else {
        const double k = accel_scale[c] > 0 ? accel_scale[c] : options.scale;
        out.columns[c++].push_back(v * k);  // NaN/Inf pass through: sanitation counts them
      }
    }
    ++out.rows;
  }
  if (out.rows == 0) throw std::invalid_argument("csv: no data rows");
  if (time_col >= 0) {
    // The unit: the option's, the header's, else the one in which the first stamp is a date of this century (epoch
    // stamps in ns, us or ms: EuRoC, TUM-VI, Kalibr), else seconds.
    std::string unit = options.time_unit, from = "option";
    if (unit.empty() && !header_unit.empty()) unit = header_unit, from = "header";
    if (unit.empty()) {
      unit = "s", from = "default";
      __int128 first = kNoTime;
      for (const auto& r : raw_t)
        if (r != kNoTime) {
          first = r;
          break;
        }
      for (const char* u : {"ns", "us", "ms"}) {
        const double epoch_s = static_cast<double>(first) * 1e-9 * static_cast<double>(unitNs(u)) * 1e-9;
        double rate, span;
        implied(raw_t, u, &rate, &span);
        if (first != kNoTime && epoch_s > 946684800.0 && epoch_s < 4102444800.0 && plausible(rate, span)) {
          unit = u, from = "magnitude";  // 2000-01-01 .. 2100-01-01
          break;
        }
      }
    }
    double rate, span;
    implied(raw_t, unit, &rate, &span);
    if (rate > 0 && !plausible(rate, span)) absurdTime(raw_t, unit, from);
    out.time_unit = unit;
    out.time_unit_from = from;
    // Exact ns since (first - 1 s); a stamp that is not a plain decimal (nan, inf) is a zero stamp.
    const __int128 per = unitNs(unit);
    __int128 first = kNoTime;
    for (const auto& r : raw_t)
      if (r != kNoTime) {
        first = r;
        break;
      }
    const __int128 origin = first == kNoTime ? 0 : first * per / 1000000000 - 1000000000;
    out.t_ns.reserve(raw_t.size());
    for (size_t i = 0; i < raw_t.size(); ++i) {
      const __int128 ns = raw_t[i] == kNoTime ? 0 : raw_t[i] * per / 1000000000 - origin;
      const bool bad = ns == 0 || ns > static_cast<__int128>(INT64_MAX) || ns < -static_cast<__int128>(INT64_MAX);
      out.t_ns.push_back(bad ? 0 : static_cast<int64_t>(ns));
      out.t[i] *= 1e-9 * static_cast<double>(unitNs(unit));  // seconds, as written
    }
  }
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
