// Test helper: the ADIS16405 static runs in ../shared/data (GYRO_ALLAN_SHARED_DATA), read as gyro rates.
#pragma once

#include <cmath>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

#include "gyro_allan/csv_input.hpp"

namespace gyro_allan_test {

/// Gyro columns of run `run` (1-3) in rad/s (three empty columns when the shared data is missing).
inline std::vector<std::vector<double>> readAdisRun(int run) {
  const std::string path = std::string(GYRO_ALLAN_SHARED_DATA) + "/adis16405/adis16405_imu" + std::to_string(run) +
                           "_100Hz.csv.gz";
  FILE* probe = std::fopen(path.c_str(), "rb");
  if (!probe) return std::vector<std::vector<double>>(3);
  std::fclose(probe);
  gyro_allan::CsvOptions o;
  o.scale = M_PI / 180.0;
  gyro_allan::CsvSeries c = gyro_allan::readCsvFile(path, o);
  c.columns.resize(3);
  return std::move(c.columns);
}

}  // namespace gyro_allan_test
