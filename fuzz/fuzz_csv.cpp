// libFuzzer target: parseCsv on arbitrary text must return a series or throw std::invalid_argument, nothing else.
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>

#include "gyro_allan/csv_input.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  gyro_allan::CsvOptions opt;
  try {
    const gyro_allan::CsvSeries s = gyro_allan::parseCsv(in, opt);
    // Invariants of a successful parse.
    if (s.columns.empty() || s.names.size() != s.columns.size()) __builtin_trap();
    for (const auto& c : s.columns)
      if (static_cast<int64_t>(c.size()) != s.rows) __builtin_trap();
    if (!s.t.empty() && static_cast<int64_t>(s.t.size()) != s.rows) __builtin_trap();
  } catch (const std::invalid_argument&) {
  }
  return 0;
}
