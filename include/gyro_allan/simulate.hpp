// Gyro simulator with declared IEEE 952 noise (RLG pulse-counter quantization, ARW, flicker bias instability,
// rate random walk, rate ramp, constant bias) plus optional undeclared effects; deterministic by seed.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace gyro_allan {

/// Declared noise of one axis, SI units. Zero disables a term.
struct AxisNoise {
  double quantization = 0;       ///< Q [rad]: angle pulse weight is Q*sqrt(12) (RLG pulse counter on the angle)
  bool dither = true;            ///< subtractive dither: quantization error exactly uniform and white
  double angle_random_walk = 0;  ///< N [rad/sqrt(s)]
  double bias_instability = 0;   ///< B [rad/s], flicker rate noise with one-sided PSD B^2/(pi f)
  double rate_random_walk = 0;   ///< K [rad/s/sqrt(s)]
  double rate_ramp = 0;          ///< R [rad/s^2], deterministic ramp R*t
  double bias = 0;               ///< constant bias [rad/s]
  double input_rate = 0;         ///< true constant input (e.g. Earth rate) [rad/s]
  double rate_lsb = 0;           ///< MEMS-style rounding of each output rate sample to this LSB [rad/s] (white FM)
  // Effects the IEEE model lacks (for testing the model check); zero disables each.
  double sine_amplitude = 0;     ///< sinusoid amplitude [rad/s]
  double sine_frequency = 0;     ///< [Hz]
  double gm_sigma = 0;           ///< first-order Gauss-Markov: stationary std [rad/s]
  double gm_tau = 0;             ///< its correlation time [s]
  double step_size = 0;          ///< bias step [rad/s]
  double step_time = 0;          ///< at this time since start [s]
  double thermal_amplitude = 0;  ///< warm-up drift: amplitude*(1 - exp(-t/thermal_tau)) [rad/s]
  double thermal_tau = 0;        ///< [s]; the temperature series warms 25 -> 35 degC with this time constant
};

struct SimulationSpec {
  double rate_hz = 400;
  double duration_s = 3600;
  uint64_t seed = 1;
  AxisNoise axes[3];
  bool temperature = false;       ///< also produce a temperature series following the thermal warm-up
};

struct SimulatedData {
  double rate_hz = 0;
  std::vector<double> t;          ///< sample times [s] from 0
  std::vector<double> rate[3];    ///< rad/s, the rate the sensor reports (angle increments / tau0 when quantized)
  std::vector<double> temperature;  ///< degC, when requested
};

/// Simulates every axis. Deterministic: same spec, same output. Throws std::invalid_argument on absurd specs.
SimulatedData simulate(const SimulationSpec& spec);

/// One axis only (seed mixes with `axis`).
std::vector<double> simulateAxis(const AxisNoise& noise, double rate_hz, int64_t n, uint64_t seed, int axis = 0);

/// Arrival-time stamps of a driver that stamps on receipt: each sample time t[i] delayed by a uniform 0..jitter
/// periods, and a fraction `late` of samples held back a further 2..10 periods together with everything queued
/// behind them (a burst follows); order is kept. batched: the burst is one buffered read and its samples share the
/// held-back sample's stamp (otherwise they are 1 us apart). Deterministic by seed. jitter >= 0, 0 <= late < 1.
std::vector<double> receiptStamps(const std::vector<double>& t, double period, double jitter, double late,
                                  uint64_t seed, bool batched = false);

/// A sensor picked up and put back tilted: a half-sine rotation about x of peak rate `peak` [rad/s] from `start` for
/// `duration` s (times as in t), added to gyro_x; gravity g on +z in the accelerometer tilts by the integrated angle
/// (added to accel_y, accel_z; it stays tilted afterwards). Either accelerometer pointer may be null.
void addTiltBump(const std::vector<double>& t, double start, double duration, double peak, double g,
                 std::vector<double>* gyro_x, std::vector<double>* accel_y, std::vector<double>* accel_z);

/// Flicker (1/f) rate noise with one-sided PSD B^2/(pi f) (so its AVAR plateau is (2 ln2/pi) B^2): Kasdin's
/// fractional-integration filter applied by FFT.
std::vector<double> flickerNoise(int64_t n, double b, uint64_t seed);

}  // namespace gyro_allan
