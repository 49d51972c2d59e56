// Shared kit of the study programs (studies/*.cpp): option parsing, seed ranges, conventional units.
#pragma once

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

namespace gyro_allan {
namespace study {

/// Conventional gyro units to SI.
constexpr double kDeg = M_PI / 180.0;
constexpr double kArcsec = kDeg / 3600.0;
constexpr double kDegPerSqrtH = kDeg / 60.0;           ///< deg/sqrt(h) -> rad/sqrt(s)
constexpr double kDegPerH = kDeg / 3600.0;             ///< deg/h -> rad/s
constexpr double kDegPerHSqrtH = kDeg / 3600.0 / 60.0; ///< deg/h/sqrt(h) -> rad/s/sqrt(s)
constexpr double kDegPerH2 = kDeg / 3600.0 / 3600.0;   ///< deg/h^2 -> rad/s^2

/// Seeds first..last (inclusive), from "A-B" or "A".
struct SeedRange {
  int first = 1;
  int last = 1;
  int count() const { return last - first + 1; }
};
/// "A-B" (A <= B) or "A", non-negative integers; else std::invalid_argument naming `what`.
SeedRange parseSeeds(const std::string& s, const std::string& what = "--seeds");
/// The studies' convention: seeds 1-999 tune, 1001- validate. "tuning set", "validation set" or a warning when mixed.
const char* seedSet(const SeedRange& r);

/// A finite number > 0 (>= 0 with allow_zero), else std::invalid_argument naming `what`.
double parseNumber(const std::string& s, const std::string& what, bool allow_zero = false);
/// A whole number (std::invalid_argument naming `what` otherwise).
int parseInt(const std::string& s, const std::string& what);
/// The value after the first `name` in argv[first..], or `def` when it is absent.
std::string optionValue(int argc, char** argv, const char* name, const std::string& def, int first = 1);
/// "a,b,c" -> {"a", "b", "c"}; empty items dropped.
std::vector<std::string> splitList(const std::string& s);

/// Walks argv from argument `first` on: `--name value` options and `--switch` flags.
///   for (Args a(argc, argv); a.next();) if (a.is("--seeds")) seeds = parseSeeds(a.value()); else ...
/// value() throws std::invalid_argument when the option has no value; unknown() builds the error for the rest.
class Args {
 public:
  Args(int argc, char** argv, int first = 1) : argc_(argc), argv_(argv), i_(first - 1) {}
  bool next() { return ++i_ < argc_; }
  const std::string arg() const { return argv_[i_]; }
  bool is(const char* name) const { return arg() == name; }
  std::string value();
  double number(bool allow_zero = false) { const std::string n = arg(); return parseNumber(value(), n, allow_zero); }
  int integer() { const std::string n = arg(); return parseInt(value(), n); }
  [[noreturn]] void unknown() const;

 private:
  int argc_;
  char** argv_;
  int i_;
};

}  // namespace study
}  // namespace gyro_allan
