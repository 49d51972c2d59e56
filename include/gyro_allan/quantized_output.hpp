// Recognises a quantized gyro output (every rate sample an integer multiple of one quantum) and, among those, the
// undithered pulse counter whose counts repeat with the constant input (a sawtooth quantization error, not white).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace gyro_allan {

/// What detectQuantizedOutput found. The first seven fields are the answer; the rest are the evidence behind it.
struct QuantizedOutput {
  bool quantized = false;
  double quantum_rate = 0;         ///< rad/s per count = q / tau0
  double pulse_weight = 0;         ///< rad per count = q (quantum_rate * tau0)
  double fraction_on_lattice = 0;  ///< samples within tolerance of offset + k * quantum_rate
  bool sawtooth = false;           ///< undithered: the count sequence is periodic at |mean| / pulse_weight
  double sawtooth_hz = 0;          ///< |mean rate - offset| / pulse_weight: pulses per second (when sawtooth)
  std::string summary;             ///< one line for humans, also when not quantized
  // Evidence.
  double offset = 0;               ///< lattice origin (0 for a plain counter): samples are offset + k * quantum_rate
  int64_t levels = 0;              ///< count levels spanned by the samples on the lattice (max k - min k + 1)
  double mean_count = 0;           ///< mean count per sample, (mean - offset) / quantum_rate
  double two_level_fraction = 0;   ///< samples at floor(mean_count) or the level above
  double alias_hz = 0;             ///< where the count pattern's line lies in [0, fs/2]: |frac(mean_count)| / tau0
  double line_to_floor = 0;        ///< count spectrum at alias_hz over the median of its neighbourhood (0: not tested)
};

/// Lattice: the quantum is the approximate gcd of the gaps between the distinct values of a strided subset of at most
/// 65536 samples (plus, when that subset holds one value only, the other values of the whole record), refined by least
/// squares; the output is quantized when >= 99 % of all samples lie within 1e-6 quantum (plus the float32 storage
/// error, 2^-21 of the sample scale) of the lattice and the samples span at most 65536 quanta.
/// Sawtooth (quantized only): >= 90 % of the counts on the two levels around the mean count (a counter at constant
/// input counts floor or ceil of it), at least 64 pattern cycles per block in at least 8 blocks, and a Hann-windowed,
/// block-averaged periodogram of the counts whose value at the predicted pattern frequency (or its alias) is >= 20
/// times the median of the bins 4..9 bins either side. Cost O(n): two passes over the samples, one more for the
/// sawtooth test (15 Goertzel filters) when the first two gates pass. tau0 > 0; non-finite samples count as off the
/// lattice. abs_tol [rad/s]: a further absolute tolerance on every value, for rates whose storage rounded them by more
/// than 2^-24 of their own scale (differences of an accumulated angle held as 4-byte floats: AnalysisOptions, angle).
QuantizedOutput detectQuantizedOutput(const std::vector<double>& rate, double tau0, double abs_tol = 0);

/// A pulse count: quantized, with >= 90 % of the counts on the two levels around the mean count (a counter whose
/// noise is below one count; the sawtooth test's own gate).
bool isPulseCount(const QuantizedOutput& q);

/// The same on the longest of several gap-free segments.
QuantizedOutput detectQuantizedOutput(const std::vector<std::vector<double>>& segments, double tau0,
                                      double abs_tol = 0);

}  // namespace gyro_allan
