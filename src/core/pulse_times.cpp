// Pulse-time reconstruction of a slow undithered pulse counter (pulse_times.hpp): lattice crossings -> angle knots
// -> piecewise-linear angle -> rate on the sample grid.
#include "gyro_allan/pulse_times.hpp"

#include <cmath>
#include <cstdio>

namespace gyro_allan {

PulseTimes reconstructPulseTimes(const std::vector<double>& rate, double tau0, const QuantizedOutput& q,
                                 const PulseTimesOptions& o) {
  PulseTimes p;
  p.pulse_weight = q.pulse_weight;
  char buf[320];
  if (!q.quantized || !(q.quantum_rate > 0) || !(tau0 > 0)) {
    p.message = "not a quantized output";
    return p;
  }
  const double base = std::nearbyint(q.mean_count);
  const double phi = q.mean_count - base;  // net crossings per sample, sign = the mean direction
  // Knots: (angle-grid index, angle in pulses). Rate sample k spans angle samples k and k + 1.
  std::vector<double> kt, ka;
  double level = 0;  // floor(theta) in pulses, after removing base per sample
  for (size_t k = 0; k < rate.size(); ++k) {
    const double d = std::nearbyint((rate[k] - q.offset) / q.quantum_rate) - base;
    if (d == 0) continue;
    const double line = d > 0 ? level + d : level + d + 1;  // the last lattice line crossed in this sample
    level += d;
    p.crossings += static_cast<int64_t>(std::fabs(d));
    if (std::fabs(d) > 1) ++p.multi;
    if ((d > 0) != (phi > 0)) p.back += static_cast<int64_t>(std::fabs(d));
    kt.push_back(static_cast<double>(k) + 0.5);
    ka.push_back(line);
  }
  const double n = static_cast<double>(rate.size());
  if (p.crossings < o.min_crossings || kt.size() < 2) {
    std::snprintf(buf, sizeof buf, "%lld lattice crossings in %.0f samples (< %lld)",
                  static_cast<long long>(p.crossings), n, static_cast<long long>(o.min_crossings));
    p.message = buf;
    return p;
  }
  const double back = static_cast<double>(p.back) / static_cast<double>(p.crossings);
  const double multi = static_cast<double>(p.multi) / n;
  if (back > o.max_back_fraction) {
    std::snprintf(buf, sizeof buf,
                  "%.1f %% of the %lld lattice crossings go against the mean direction (> %.1f %%): the angle's random "
                  "walk, not the input, moves the count",
                  100 * back, static_cast<long long>(p.crossings), 100 * o.max_back_fraction);
    p.message = buf;
    return p;
  }
  if (multi > o.max_multi_fraction) {
    std::snprintf(buf, sizeof buf, "%.2f %% of the samples hold more than one count (> %.2f %%): not a slow counter",
                  100 * multi, 100 * o.max_multi_fraction);
    p.message = buf;
    return p;
  }
  // Piecewise-linear angle through the knots on the integer grid j in [ceil(kt.front()), floor(kt.back())].
  const int64_t j0 = static_cast<int64_t>(std::ceil(kt.front())), j1 = static_cast<int64_t>(std::floor(kt.back()));
  std::vector<double> theta;
  theta.reserve(static_cast<size_t>(j1 - j0 + 1));
  size_t s = 0;
  for (int64_t j = j0; j <= j1; ++j) {
    const double t = static_cast<double>(j);
    while (s + 2 < kt.size() && kt[s + 1] < t) ++s;
    const double w = (t - kt[s]) / (kt[s + 1] - kt[s]);
    theta.push_back(ka[s] + w * (ka[s + 1] - ka[s]));
  }
  const double constant = q.offset + base * q.quantum_rate;
  p.rate.resize(theta.size() - 1);
  for (size_t k = 0; k + 1 < theta.size(); ++k) p.rate[k] = (theta[k + 1] - theta[k]) * q.quantum_rate + constant;
  p.mean_interval_s = (kt.back() - kt.front()) * tau0 / static_cast<double>(kt.size() - 1);
  p.tau_min_s = o.tau_min_intervals * p.mean_interval_s;
  std::snprintf(buf, sizeof buf,
                "%lld lattice crossings every %.3g s on average (%.1f %% backwards); the angle between them is "
                "interpolated and fitted from tau >= %.3g s",
                static_cast<long long>(p.crossings), p.mean_interval_s, 100 * back, p.tau_min_s);
  p.message = buf;
  p.ok = true;
  return p;
}

}  // namespace gyro_allan
