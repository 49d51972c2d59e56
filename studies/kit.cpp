// The study kit (kit.hpp): option parsing and seed ranges.
#include "kit.hpp"

#include <algorithm>
#include <cstdlib>
#include <stdexcept>

namespace gyro_allan {
namespace study {

SeedRange parseSeeds(const std::string& s, const std::string& what) {
  const size_t dash = s.find('-');
  const std::string a = s.substr(0, dash), b = dash == std::string::npos ? a : s.substr(dash + 1);
  auto digits = [](const std::string& x) {
    return !x.empty() && x.size() < 10 && std::all_of(x.begin(), x.end(), [](char ch) { return ch >= '0' && ch <= '9'; });
  };
  if (!digits(a) || !digits(b)) throw std::invalid_argument(what + ": A-B or A (non-negative integers)");
  SeedRange r{std::atoi(a.c_str()), std::atoi(b.c_str())};
  if (r.last < r.first) throw std::invalid_argument(what + ": A-B with A <= B");
  return r;
}

const char* seedSet(const SeedRange& r) {
  return r.last <= 999 ? "tuning set" : (r.first >= 1001 ? "validation set" : "MIXED tuning and validation seeds");
}

double parseNumber(const std::string& s, const std::string& what, bool allow_zero) {
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  if (s.empty() || *end != '\0' || !std::isfinite(v) || !(allow_zero ? v >= 0 : v > 0))
    throw std::invalid_argument(what + (allow_zero ? ": not a non-negative number: '" : ": not a positive number: '") +
                                s + "'");
  return v;
}

int parseInt(const std::string& s, const std::string& what) {
  char* end = nullptr;
  const long v = std::strtol(s.c_str(), &end, 10);
  if (s.empty() || *end != '\0') throw std::invalid_argument(what + ": not a whole number: '" + s + "'");
  return static_cast<int>(v);
}

std::string optionValue(int argc, char** argv, const char* name, const std::string& def, int first) {
  for (int i = first; i + 1 < argc; ++i)
    if (std::string(argv[i]) == name) return argv[i + 1];
  return def;
}

std::vector<std::string> splitList(const std::string& s) {
  std::vector<std::string> out;
  size_t p = 0;
  while (p <= s.size()) {
    const size_t q = std::min(s.find(',', p), s.size());
    if (q > p) out.push_back(s.substr(p, q - p));
    p = q + 1;
  }
  return out;
}

std::string Args::value() {
  if (i_ + 1 >= argc_) throw std::invalid_argument(arg() + " needs a value");
  ++i_;
  return argv_[i_];
}

void Args::unknown() const { throw std::invalid_argument("unknown argument '" + arg() + "' (--help for usage)"); }

}  // namespace study
}  // namespace gyro_allan
