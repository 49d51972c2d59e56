// Quantized-output detection: lattice of the rate samples (approximate gcd of value gaps) and the undithered
// pulse-counter sawtooth (a spectral line of the count sequence at the mean count rate or its alias).
#include "gyro_allan/quantized_output.hpp"
#include "gyro_allan/stats.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>

namespace gyro_allan {
namespace {

// Lattice.
constexpr size_t kSubset = 65536;            // samples (strided) whose distinct values give the quantum
constexpr int64_t kMinSamples = 64;          // fewer: not judged
constexpr double kQuantumTol = 1e-6;         // on the lattice within this fraction of the quantum...
constexpr double kStorageTol = 0x1p-21;      // ...plus this fraction of the sample scale: float32 storage (the bag
                                             // reader's compact series, float drivers) rounds by up to 2^-24 of it
constexpr double kMinOnLattice = 0.99;       // fraction of samples on the lattice to call the output quantized
constexpr double kMaxSpan = 65536;           // the samples span at most this many quanta (a finer quantum is moot)
constexpr double kMaxTolOfQuantum = 0.05;    // the tolerance must stay below this fraction of the quantum
constexpr size_t kMaxRareLevels = 64;        // distinct values collected from the whole record when the subset has one
// Sawtooth.
constexpr double kMinTwoLevel = 0.9;         // counts on floor(mean count) or the level above
constexpr double kMinCyclesPerBlock = 64;    // pattern cycles per periodogram block
constexpr int64_t kMinBlockLength = 4096;
constexpr int64_t kMinBlocks = 8;
constexpr double kMinLineToFloor = 20;       // line over the median of the neighbouring bins
constexpr int kFloorNear = 4, kFloorFar = 9; // neighbourhood: bins 4..9 either side of the line

/// Approximate gcd of two positive numbers known to within tol.
double approxGcd(double a, double b, double tol) {
  if (a < b) std::swap(a, b);
  while (b > tol) {
    double r = std::fmod(a, b);
    if (b - r <= tol) r = 0;
    a = b;
    b = r;
  }
  return a;
}

std::string fmt(const char* f, double a = 0, double b = 0, double c = 0, double d = 0) {
  char buf[300];
  std::snprintf(buf, sizeof buf, f, a, b, c, d);
  return buf;
}

// ---- detectQuantizedOutput, stage by stage ----------------------------------------------------------------------

// Pass 1: range and mean of the finite samples.
struct FiniteRange {
  double lo = std::numeric_limits<double>::infinity(), hi = -std::numeric_limits<double>::infinity();
  double mean = 0;
  int64_t finite = 0;
};
FiniteRange finiteRange(const std::vector<double>& rate) {
  FiniteRange r;
  long double sum = 0;
  for (double x : rate) {
    if (!std::isfinite(x)) continue;
    r.lo = std::min(r.lo, x);
    r.hi = std::max(r.hi, x);
    sum += x;
    ++r.finite;
  }
  if (r.finite > 0) r.mean = static_cast<double>(sum / r.finite);
  return r;
}

// Distinct values of the samples: from a strided subset (values within the storage tolerance merged), or from the
// whole record when the subset holds one value; origin is the most populated one.
struct Levels {
  std::vector<double> sub;     // the subset, sorted
  std::vector<double> levels;  // one value per cluster, sorted
  double origin = 0;
};
Levels distinctLevels(const std::vector<double>& rate, const FiniteRange& fr, double abs_tol) {
  Levels lv;
  std::vector<double>& sub = lv.sub;
  const size_t stride = std::max<size_t>(1, rate.size() / kSubset);
  sub.reserve(rate.size() / stride + 1);
  for (size_t i = 0; i < rate.size(); i += stride)
    if (std::isfinite(rate[i])) sub.push_back(rate[i]);
  std::sort(sub.begin(), sub.end());
  const double scale_sub = std::max(std::fabs(sub.front()), std::fabs(sub.back())) + (sub.back() - sub.front());
  const double merge_tol = kStorageTol * scale_sub + abs_tol;
  std::vector<double>& levels = lv.levels;
  std::vector<size_t> members;  // samples of the subset in each level
  for (double v : sub) {
    if (!levels.empty() && v - levels.back() <= 2 * merge_tol) {
      ++members.back();
    } else {
      levels.push_back(v);
      members.push_back(1);
    }
  }
  lv.origin = levels[static_cast<size_t>(std::max_element(members.begin(), members.end()) - members.begin())];
  if (levels.size() == 1) {
    // A counter that rarely counts (e.g. a pulse every few minutes): the other values from the whole record.
    const double tol = kStorageTol * (2 * std::max(std::fabs(fr.lo), std::fabs(fr.hi)) + (fr.hi - fr.lo)) + abs_tol;
    for (double x : rate) {
      if (!std::isfinite(x) || std::fabs(x - lv.origin) <= 2 * tol) continue;
      bool seen = false;
      for (double l : levels) seen = seen || std::fabs(x - l) <= 2 * tol;
      if (!seen) levels.push_back(x);
      if (levels.size() > kMaxRareLevels) break;
    }
    std::sort(levels.begin(), levels.end());
  }
  return lv;
}

// Least-squares refinement of the quantum q from the levels' multiples of it (counted from origin).
double refineQuantum(const std::vector<double>& levels, double origin, double q) {
  double skx = 0, skk = 0;
  for (double l : levels) {
    const double k = std::nearbyint((l - origin) / q);
    skx += k * (l - origin);
    skk += k * k;
  }
  return skk > 0 ? skx / skk : q;
}

// Pass 2: every sample against the lattice (offset + k q, within fixed_tol plus the storage tolerance): the
// fraction on it, the levels spanned, and the fraction of counts on the two levels around the mean count.
void placeOnLattice(const std::vector<double>& rate, double offset, double q, double fixed_tol, QuantizedOutput* out) {
  const int64_t n = static_cast<int64_t>(rate.size());
  const double k_lo = std::floor(out->mean_count);
  int64_t on = 0, two = 0;
  double kmin = std::numeric_limits<double>::infinity(), kmax = -kmin;
  for (double x : rate) {
    if (!std::isfinite(x)) continue;
    const double k = std::nearbyint((x - offset) / q);
    const double tol = fixed_tol + kStorageTol * std::fabs(x);
    if (std::fabs(x - offset - k * q) <= tol) {
      ++on;
      kmin = std::min(kmin, k);
      kmax = std::max(kmax, k);
    }
    two += (k == k_lo || k == k_lo + 1) ? 1 : 0;
  }
  out->fraction_on_lattice = static_cast<double>(on) / static_cast<double>(n);
  out->levels = on > 0 ? static_cast<int64_t>(kmax - kmin) + 1 : 0;
  out->two_level_fraction = static_cast<double>(two) / static_cast<double>(n);
}

// Hann-windowed periodogram power of the count sequence (rate - offset) / q - mu at the frequencies nu (cycles per
// sample), summed over consecutive blocks of `block` samples (Goertzel recursion; a non-finite sample counts as
// `mean`).
std::vector<double> countPower(const std::vector<double>& rate, int64_t block, const std::vector<double>& nu,
                               double mean, double offset, double q, double mu) {
  const int64_t n = static_cast<int64_t>(rate.size());
  const size_t nf = nu.size();
  std::vector<double> coef(nf);
  for (size_t j = 0; j < nf; ++j) {
    double v = std::fabs(nu[j]);
    v = v - std::floor(v);
    if (v > 0.5) v = 1.0 - v;  // a real sequence: the spectrum folds at Nyquist
    coef[j] = 2.0 * std::cos(2.0 * M_PI * v);
  }
  std::vector<double> window(static_cast<size_t>(block));
  for (int64_t i = 0; i < block; ++i) window[static_cast<size_t>(i)] = 0.5 - 0.5 * std::cos(2.0 * M_PI * i / block);
  std::vector<double> power(nf, 0.0);
  const int64_t blocks = n / block;
  std::vector<double> s1(nf), s2(nf);
  for (int64_t b = 0; b < blocks; ++b) {
    std::fill(s1.begin(), s1.end(), 0.0);
    std::fill(s2.begin(), s2.end(), 0.0);
    const double* x = rate.data() + b * block;
    for (int64_t i = 0; i < block; ++i) {
      const double xi = std::isfinite(x[i]) ? x[i] : mean;
      const double y = window[static_cast<size_t>(i)] * ((xi - offset) / q - mu);
      for (size_t j = 0; j < nf; ++j) {
        const double s0 = y + coef[j] * s1[j] - s2[j];
        s2[j] = s1[j];
        s1[j] = s0;
      }
    }
    for (size_t j = 0; j < nf; ++j) power[j] += s1[j] * s1[j] + s2[j] * s2[j] - coef[j] * s1[j] * s2[j];
  }
  return power;
}

// Sawtooth: a counter at constant input counts floor(mu) or floor(mu) + 1, with a pattern repeating at the
// fractional part of mu (cycles per sample): a line in the count spectrum where white rounding has none.
void testSawtooth(const std::vector<double>& rate, double tau0, double mean, QuantizedOutput* out) {
  const int64_t n = static_cast<int64_t>(rate.size());
  const double mu = out->mean_count;
  const double phi = mu - std::nearbyint(mu);  // in [-0.5, 0.5]
  out->alias_hz = std::fabs(phi) / tau0;
  if (out->two_level_fraction < kMinTwoLevel) {
    out->summary += fmt("; white rounding, not a sawtooth (%.1f %% of the counts on the two levels around the mean "
                        "count %.4g)",
                        100 * out->two_level_fraction, mu);
    return;
  }
  int64_t block = kMinBlockLength;
  while (block < kMinCyclesPerBlock / std::max(std::fabs(phi), 1e-300) && block <= n) block *= 2;
  if (kMinBlocks * block > n) {
    out->summary += fmt("; no sawtooth test: the count pattern (mean count %.4g per sample) repeats too slowly for "
                        "this record (%.0f samples)",
                        mu, static_cast<double>(n));
    return;
  }
  // Frequencies in cycles per sample: the line at |phi| and half a bin either side (scalloping), then the floor.
  std::vector<double> nu;
  for (double d : {0.0, -0.5, 0.5}) nu.push_back(std::fabs(phi) + d / static_cast<double>(block));
  for (int d = kFloorNear; d <= kFloorFar; ++d)
    for (int s : {-1, 1}) nu.push_back(std::fabs(phi) + s * d / static_cast<double>(block));
  const std::vector<double> power = countPower(rate, block, nu, mean, out->offset, out->quantum_rate, mu);
  const double line = std::max({power[0], power[1], power[2]});
  std::vector<double> floor_bins(power.begin() + 3, power.end());
  const double floor_level = upperMedianInPlace(floor_bins);
  out->line_to_floor = floor_level > 0 ? line / floor_level : (line > 0 ? std::numeric_limits<double>::infinity() : 0);
  const double f = std::fabs(mu) / tau0;
  if (out->line_to_floor >= kMinLineToFloor) {
    out->sawtooth = true;
    out->sawtooth_hz = f;
    out->summary += fmt("; undithered: sawtooth quantization error at %.4g Hz (|mean| / pulse weight; seen at %.4g "
                        "Hz, %.3g x the spectral floor)",
                        f, out->alias_hz, out->line_to_floor);
  } else {
    out->summary += fmt("; no sawtooth: the count spectrum at %.4g Hz (the mean count's pattern) is %.3g x its floor",
                        out->alias_hz, out->line_to_floor);
  }
}

}  // namespace

QuantizedOutput detectQuantizedOutput(const std::vector<std::vector<double>>& segments, double tau0, double abs_tol) {
  size_t longest = 0;
  for (size_t i = 1; i < segments.size(); ++i)
    if (segments[i].size() > segments[longest].size()) longest = i;
  if (segments.empty()) return detectQuantizedOutput(std::vector<double>(), tau0, abs_tol);
  return detectQuantizedOutput(segments[longest], tau0, abs_tol);
}

QuantizedOutput detectQuantizedOutput(const std::vector<double>& rate, double tau0, double abs_tol) {
  abs_tol = std::isfinite(abs_tol) ? std::max(0.0, abs_tol) : 0.0;
  QuantizedOutput out;
  const int64_t n = static_cast<int64_t>(rate.size());
  if (!(tau0 > 0) || n < kMinSamples) {
    out.summary = "not judged: too few samples";
    return out;
  }
  const FiniteRange fr = finiteRange(rate);
  if (fr.finite < kMinSamples) {
    out.summary = "not judged: too few finite samples";
    return out;
  }
  if (!(fr.hi > fr.lo)) {
    out.summary = "constant output: one value only";
    return out;
  }
  const Levels lv = distinctLevels(rate, fr, abs_tol);
  const std::vector<double>& levels = lv.levels;
  // The spread of the values: the subset's range (a rare outlier of the whole record does not widen it), or the whole
  // record's when the subset holds one value.
  const double range = lv.sub.back() > lv.sub.front() ? lv.sub.back() - lv.sub.front() : fr.hi - fr.lo;
  const double gap_tol =
      8 * kStorageTol * (std::max(std::fabs(levels.front()), std::fabs(levels.back())) + range) + 4 * abs_tol;
  // Approximate gcd of the gaps; stop as soon as it is too fine to matter (noise-like data gets there fast).
  const double q_floor = std::max(range / kMaxSpan, gap_tol / kMaxTolOfQuantum);
  double q = 0;
  for (size_t i = 1; i < levels.size() && (q == 0 || q >= q_floor); ++i) {
    const double g = levels[i] - levels[i - 1];
    q = q == 0 ? g : approxGcd(q, g, gap_tol);
  }
  if (!(q >= q_floor) || levels.size() < 2) {
    out.summary = levels.size() < 2 ? "not quantized: one value only"
                                    : fmt("not quantized: the sample values share no common step coarser than %.3g of "
                                          "their range",
                                          1.0 / kMaxSpan);
    return out;
  }
  q = refineQuantum(levels, lv.origin, q);
  double offset = lv.origin - q * std::nearbyint(lv.origin / q);
  const double fixed_tol = kQuantumTol * q + kStorageTol * (std::fabs(lv.origin) + range) + abs_tol;
  if (std::fabs(offset) <= fixed_tol) offset = 0;  // a plain counter: the lattice holds 0
  out.offset = offset;
  out.quantum_rate = q;
  out.pulse_weight = q * tau0;
  out.mean_count = (fr.mean - offset) / q;

  placeOnLattice(rate, offset, q, fixed_tol, &out);
  const std::string lattice = fmt("a lattice of %.4g rad/s (pulse weight %.4g rad)", q, q * tau0) +
                              (offset != 0 ? fmt(" offset by %.4g rad/s", offset) : std::string()) +
                              fmt(", %.2f %% of the samples on it", 100 * out.fraction_on_lattice);
  if (out.fraction_on_lattice < kMinOnLattice || fixed_tol > kMaxTolOfQuantum * q || out.levels < 2) {
    out.summary = "not quantized: only " + lattice;
    return out;
  }
  out.quantized = true;
  out.summary = "quantized output: " + lattice + fmt(", %.0f levels", static_cast<double>(out.levels));
  testSawtooth(rate, tau0, fr.mean, &out);
  return out;
}

bool isPulseCount(const QuantizedOutput& q) { return q.quantized && q.two_level_fraction >= kMinTwoLevel; }

}  // namespace gyro_allan
