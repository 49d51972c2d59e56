// Gyro simulator: declared IEEE 952 noise terms and optional undeclared effects, deterministic by seed.
#include "gyro_allan/simulate.hpp"

#include <cmath>
#include <limits>
#include <complex>
#include <random>
#include <stdexcept>
#include <string>

#include <unsupported/Eigen/FFT>

namespace gyro_allan {
namespace {

/// Portable normal/uniform draws on top of std::mt19937_64 (whose output sequence is fixed by the standard;
/// std::normal_distribution is not, so it is not used).
class Rng {
 public:
  explicit Rng(uint64_t seed) : engine_(seed) {}
  /// Uniform on [0, 1).
  double uniform() { return static_cast<double>(engine_() >> 11) * (1.0 / 9007199254740992.0); }
  /// Standard normal (Marsaglia polar method).
  double normal() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    double u, v, s;
    do {
      u = 2.0 * uniform() - 1.0;
      v = 2.0 * uniform() - 1.0;
      s = u * u + v * v;
    } while (s >= 1.0 || s == 0.0);
    const double f = std::sqrt(-2.0 * std::log(s) / s);
    spare_ = v * f;
    has_spare_ = true;
    return u * f;
  }

 private:
  std::mt19937_64 engine_;
  bool has_spare_ = false;
  double spare_ = 0;
};

uint64_t mixSeed(uint64_t seed, uint64_t stream) {
  // splitmix64 finalizer: distinct, well-spread seeds per axis and per noise source.
  uint64_t z = seed + 0x9E3779B97F4A7C15ULL * (stream + 1);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

void requireFinite(double v, const char* name) {
  if (!std::isfinite(v)) throw std::invalid_argument(std::string("simulate: ") + name + " is not finite");
}
void requireNonNegative(double v, const char* name) {
  requireFinite(v, name);
  if (v < 0) throw std::invalid_argument(std::string("simulate: ") + name + " must be >= 0");
}

void validate(const AxisNoise& a) {
  requireNonNegative(a.quantization, "quantization");
  requireNonNegative(a.angle_random_walk, "angle_random_walk");
  requireNonNegative(a.bias_instability, "bias_instability");
  requireNonNegative(a.rate_random_walk, "rate_random_walk");
  requireFinite(a.rate_ramp, "rate_ramp");
  requireFinite(a.bias, "bias");
  requireFinite(a.input_rate, "input_rate");
  requireFinite(a.sine_amplitude, "sine_amplitude");
  requireNonNegative(a.sine_frequency, "sine_frequency");
  requireNonNegative(a.gm_sigma, "gm_sigma");
  requireNonNegative(a.gm_tau, "gm_tau");
  if (a.gm_sigma > 0 && a.gm_tau <= 0) throw std::invalid_argument("simulate: gm_tau must be > 0 when gm_sigma > 0");
  requireFinite(a.step_size, "step_size");
  requireNonNegative(a.step_time, "step_time");
  requireFinite(a.thermal_amplitude, "thermal_amplitude");
  requireNonNegative(a.thermal_tau, "thermal_tau");
  requireNonNegative(a.rate_lsb, "rate_lsb");
}

// Temperature profile of the warm-up used for both the bias drift and the temperature series.
double warmup(double t, double tau) { return tau > 0 ? 1.0 - std::exp(-t / tau) : 1.0; }

}  // namespace

std::vector<double> flickerNoise(int64_t n, double b, uint64_t seed) {
  std::vector<double> out(static_cast<size_t>(std::max<int64_t>(n, 0)), 0.0);
  if (n <= 0 || b == 0) return out;
  // Kasdin (1995): 1/f^alpha noise = white noise through (1 - z^-1)^(-alpha/2); impulse response
  // h0 = 1, hk = h(k-1) * (alpha/2 + k - 1) / k. With white variance b^2 the one-sided PSD at low f is b^2/(pi f).
  size_t m = 1;
  while (m < 2 * static_cast<size_t>(n)) m <<= 1;
  std::vector<std::complex<double>> hf, wf;
  Eigen::FFT<double> fft;  // one object: its plan (twiddles) for size m serves all three transforms
  {
    std::vector<double> h(m, 0.0), w(m, 0.0);
    const double alpha = 1.0;
    h[0] = 1.0;
    for (int64_t k = 1; k < n; ++k) h[k] = h[k - 1] * (alpha / 2.0 + static_cast<double>(k) - 1.0) / k;
    Rng rng(mixSeed(seed, 7));
    for (int64_t k = 0; k < n; ++k) w[k] = b * rng.normal();
    fft.fwd(hf, h);
    fft.fwd(wf, w);
  }
  for (size_t k = 0; k < hf.size(); ++k) hf[k] *= wf[k];
  std::vector<double> conv;
  fft.inv(conv, hf);
  for (int64_t k = 0; k < n; ++k) out[k] = conv[k];
  return out;
}

std::vector<double> simulateAxis(const AxisNoise& a, double rate_hz, int64_t n, uint64_t seed, int axis) {
  validate(a);
  if (!(rate_hz > 0) || !std::isfinite(rate_hz)) throw std::invalid_argument("simulate: rate_hz must be > 0");
  if (n < 0) throw std::invalid_argument("simulate: negative sample count");
  const double tau0 = 1.0 / rate_hz;
  const uint64_t base = mixSeed(seed, 1000 + static_cast<uint64_t>(axis));
  Rng arw(mixSeed(base, 1)), rrw(mixSeed(base, 2)), gm(mixSeed(base, 3)), dither(mixSeed(base, 4));
  std::vector<double> flicker = flickerNoise(n, a.bias_instability, mixSeed(base, 5));

  std::vector<double> out(static_cast<size_t>(n));
  const double arw_std = a.angle_random_walk / std::sqrt(tau0);
  const double rrw_step = a.rate_random_walk * std::sqrt(tau0);
  const double gm_phi = a.gm_tau > 0 ? std::exp(-tau0 / a.gm_tau) : 0.0;
  const double gm_drive = a.gm_sigma * std::sqrt(1.0 - gm_phi * gm_phi);
  double rw = 0, gmx = a.gm_sigma > 0 ? a.gm_sigma * gm.normal() : 0.0;
  // Quantization as an RLG pulse counter on the accumulated angle: pulse weight q = Q*sqrt(12).
  const double q = a.quantization * std::sqrt(12.0);
  long double theta = 0;      // true accumulated angle
  long double prev_out = 0;   // previous quantized output angle
  for (int64_t k = 0; k < n; ++k) {
    const double t_mid = (static_cast<double>(k) + 0.5) * tau0;
    double w = a.input_rate + a.bias + a.rate_ramp * t_mid;
    if (arw_std > 0) w += arw_std * arw.normal();
    if (rrw_step > 0) {
      rw += rrw_step * rrw.normal();
      w += rw;
    }
    if (!flicker.empty()) w += flicker[static_cast<size_t>(k)];
    if (a.sine_amplitude != 0 && a.sine_frequency > 0) w += a.sine_amplitude * std::sin(2.0 * M_PI * a.sine_frequency * t_mid);
    if (a.gm_sigma > 0) {
      gmx = gm_phi * gmx + gm_drive * gm.normal();
      w += gmx;
    }
    if (a.step_size != 0 && t_mid >= a.step_time) w += a.step_size;
    if (a.thermal_amplitude != 0) w += a.thermal_amplitude * warmup(t_mid, a.thermal_tau);
    if (q > 0) {
      theta += static_cast<long double>(w) * tau0;
      long double angle_out;
      if (a.dither) {
        // Subtractive dither: the readout adds a known random angle before counting and strips it afterwards, so the
        // angle error is exactly uniform on (-q/2, q/2) and independent from sample to sample (Q = q/sqrt(12)).
        const long double d = (dither.uniform() - 0.5) * q;
        angle_out = std::round((theta + d) / q) * q - d;
      } else {
        angle_out = std::floor(theta / q) * q;  // plain pulse count
      }
      w = static_cast<double>((angle_out - prev_out) / tau0);
      prev_out = angle_out;
    }
    if (a.rate_lsb > 0) w = std::round(w / a.rate_lsb) * a.rate_lsb;
    out[static_cast<size_t>(k)] = w;
  }
  return out;
}

SimulatedData simulate(const SimulationSpec& spec) {
  if (!(spec.rate_hz > 0) || !std::isfinite(spec.rate_hz)) throw std::invalid_argument("simulate: rate_hz must be > 0");
  if (!(spec.duration_s > 0) || !std::isfinite(spec.duration_s))
    throw std::invalid_argument("simulate: duration_s must be > 0");
  const double n_real = std::floor(spec.duration_s * spec.rate_hz + 1e-9);
  if (n_real > 4e9) throw std::invalid_argument("simulate: more than 4e9 samples requested");
  const int64_t n = static_cast<int64_t>(n_real);
  SimulatedData d;
  d.rate_hz = spec.rate_hz;
  d.t.resize(static_cast<size_t>(n));
  for (int64_t k = 0; k < n; ++k) d.t[static_cast<size_t>(k)] = static_cast<double>(k) / spec.rate_hz;
  for (int axis = 0; axis < 3; ++axis) d.rate[axis] = simulateAxis(spec.axes[axis], spec.rate_hz, n, spec.seed, axis);
  if (spec.temperature) {
    // Warm-up from 25 degC by 10 degC with the time constant of the (first) thermal drift, plus 0.01 degC sensor noise.
    double tau = 0;
    for (const auto& a : spec.axes)
      if (a.thermal_tau > 0) {
        tau = a.thermal_tau;
        break;
      }
    Rng rng(mixSeed(spec.seed, 77));
    d.temperature.resize(static_cast<size_t>(n));
    for (int64_t k = 0; k < n; ++k)
      d.temperature[static_cast<size_t>(k)] = 25.0 + 10.0 * warmup(d.t[static_cast<size_t>(k)], tau) + 0.01 * rng.normal();
  }
  return d;
}

std::vector<double> receiptStamps(const std::vector<double>& t, double period, double jitter, double late,
                                  uint64_t seed, bool batched) {
  if (!(period > 0) || !(jitter >= 0) || !(late >= 0 && late < 1) || !std::isfinite(jitter))
    throw std::invalid_argument("receiptStamps: period > 0, jitter >= 0 and 0 <= late < 1 expected");
  Rng rng(mixSeed(seed, 99));
  std::vector<double> out(t.size());
  double queue_until = -std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < t.size(); ++i) {
    double a = t[i] + rng.uniform() * jitter * period;
    if (late > 0 && rng.uniform() < late) queue_until = std::max(queue_until, t[i] + (2.0 + 8.0 * rng.uniform()) * period);
    if (a < queue_until) a = queue_until;  // held back: arrives with the burst
    const double gap = batched ? 0.0 : 1e-6;  // a queue keeps the order: one read's stamp, or 1 us apart
    if (i > 0 && !(a >= out[i - 1] + gap)) a = out[i - 1] + gap;
    out[i] = a;
  }
  return out;
}

void addTiltBump(const std::vector<double>& t, double start, double duration, double peak, double g,
                 std::vector<double>* gyro_x, std::vector<double>* accel_y, std::vector<double>* accel_z) {
  if (!(duration > 0) || !std::isfinite(peak) || !gyro_x || gyro_x->size() != t.size())
    throw std::invalid_argument("addTiltBump: duration > 0, finite peak and a gyro axis as long as t expected");
  for (size_t i = 0; i < t.size(); ++i) {
    const double u = (t[i] - start) / duration;
    if (u < 0) continue;
    // Angle of the half-sine rate integrated: peak * duration / pi * (1 - cos(pi u)), held at its end value.
    const double angle = peak * duration / M_PI * (1.0 - std::cos(M_PI * std::min(u, 1.0)));
    if (u <= 1) (*gyro_x)[i] += peak * std::sin(M_PI * u);
    if (accel_y && i < accel_y->size()) (*accel_y)[i] += g * std::sin(angle);
    if (accel_z && i < accel_z->size()) (*accel_z)[i] += g * (std::cos(angle) - 1.0);
  }
}

}  // namespace gyro_allan
