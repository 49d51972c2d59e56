// Pulse-time reconstruction of a slow undithered pulse counter: at each count change the angle is on a lattice line
// (known exactly), so the angle between those crossings is interpolated and the IEEE fit reads N, B, K from it.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "gyro_allan/quantized_output.hpp"

namespace gyro_allan {

struct PulseTimesOptions {
  int64_t min_crossings = 200;      ///< fewer lattice crossings: not enough to read anything
  double max_back_fraction = 0.25;  ///< crossings against the mean direction (the angle wandering back) above this
                                    ///< fraction: the random walk, not the input, moves the count; not reconstructed
  double max_multi_fraction = 0.01; ///< samples with more than one count above this fraction: not a slow counter
  double tau_min_intervals = 10;     ///< the fit uses tau >= this many mean crossing intervals
};

/// The reconstruction. Counts are d_k = round((rate_k - offset) / quantum_rate) - round(mean count); a sample with
/// d_k != 0 crossed the lattice line floor(theta) + 1 (up) or floor(theta) (down) between its two angle samples, so
/// the angle (in pulses) is known there, at the midpoint of the sample. The rate between the first and the last
/// crossing is the derivative of the piecewise-linear angle through those points, plus the removed constant.
struct PulseTimes {
  bool ok = false;
  std::string message;              ///< why not ok; when ok, one line for humans
  int64_t crossings = 0;            ///< lattice crossings (samples with d_k != 0, counted |d_k| times)
  int64_t back = 0;                 ///< of which against the mean direction
  int64_t multi = 0;                ///< samples with |d_k| > 1
  double mean_interval_s = 0;       ///< (last - first crossing time) / (crossings - 1)
  double tau_min_s = 0;             ///< tau_min_intervals * mean_interval_s
  double pulse_weight = 0;          ///< rad per count (QuantizedOutput::pulse_weight)
  std::vector<double> rate;         ///< reconstructed rate [rad/s] on the sample grid between first and last crossing
};

/// rate: one gap-free segment [rad/s]; q: detectQuantizedOutput of the record (quantized, with its lattice).
PulseTimes reconstructPulseTimes(const std::vector<double>& rate, double tau0, const QuantizedOutput& q,
                                 const PulseTimesOptions& options = {});

}  // namespace gyro_allan
