// Equivalent degrees of freedom (Greenhall-Riley 2003, SP1065 totvar), noise identification (lag-1 ACF) and
// chi-squared confidence intervals of Allan-family deviations (exact, or as Stable32 prints them).
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <unordered_map>

#include <boost/math/distributions/chi_squared.hpp>

#include "allan_internal.hpp"
#include "gyro_allan/allan.hpp"
#include "gyro_allan/stats.hpp"

namespace gyro_allan {

// ------------------------------------------------------------------------------------------------ chi-squared
namespace {

/// Memo of chi2Quantile per thread: the fits re-fill confidence intervals of the same points (same EDF) dozens of
/// times.
struct QuantileKey {
  double p, dof;
  bool operator==(const QuantileKey& o) const { return p == o.p && dof == o.dof; }
};
struct QuantileKeyHash {
  size_t operator()(const QuantileKey& k) const {
    return std::hash<double>()(k.p) * 1000003u ^ std::hash<double>()(k.dof);
  }
};

}  // namespace

double chi2Quantile(double p, double dof) {
  if (!(p > 0 && p < 1)) throw std::invalid_argument("chi2Quantile: p must be in (0,1)");
  if (!(dof > 0) || !std::isfinite(dof)) throw std::invalid_argument("chi2Quantile: dof must be finite and > 0");
  thread_local std::unordered_map<QuantileKey, double, QuantileKeyHash> memo;
  const QuantileKey key{p, dof};
  const auto it = memo.find(key);
  if (it != memo.end()) return it->second;
  if (memo.size() >= 65536) memo.clear();  // bounded: a long-running nodelet sees ever new EDFs
  const double x = boost::math::quantile(boost::math::chi_squared_distribution<double>(dof), p);
  memo.emplace(key, x);
  return x;
}

// ------------------------------------------------------------------------------------------------ Greenhall EDF
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

/// Generalized autocovariance kernel of power-law phase noise (Greenhall 2003, eq. 7).
long double sw(long double t, int alpha) {
  const long double a = std::fabs(t);
  switch (alpha) {
    case 2: return -a;
    case 1: return a == 0 ? 0.0L : t * t * std::log(a);
    case 0: return a * a * a;
    case -1: return a == 0 ? 0.0L : -t * t * t * t * std::log(a);
    case -2: return -a * a * a * a * a;
    case -3: return a == 0 ? 0.0L : std::pow(t, 6) * std::log(a);
    case -4: return std::pow(a, 7);
  }
  throw std::invalid_argument("Greenhall EDF: alpha out of range");
}

/// Kernel after the phase averaging filter of length 1/F (F = inf: no averaging, unmodified limit).
long double sx(long double t, double F, int alpha) {
  if (std::isinf(F)) return sw(t, alpha + 2);
  const long double f = F;
  return f * f * (2 * sw(t, alpha) - sw(t - 1 / f, alpha) - sw(t + 1 / f, alpha));
}

long double binom(int n, int k) {
  long double r = 1;
  for (int i = 1; i <= k; ++i) r = r * (n - k + i) / i;
  return r;
}

/// Covariance kernel of the d-th difference (symmetric binomial filter of order 2d applied to sx).
long double sz(long double t, double F, int alpha, int d) {
  long double s = 0;
  for (int k = -d; k <= d; ++k) {
    const long double c = binom(2 * d, d + k) * ((k % 2) ? -1 : 1);
    s += c * sx(t + k, F, alpha);
  }
  return s;
}

long double basicSum(double J, double M, double S, double F, int alpha, int d) {
  const long double z0 = sz(0, F, alpha, d);
  long double sum = z0 * z0;
  const long double zJ = sz(J / S, F, alpha, d);
  sum += (1 - J / M) * zJ * zJ;
  for (int64_t j = 1; j < static_cast<int64_t>(J); ++j) {
    const long double zj = sz(j / S, F, alpha, d);
    sum += 2 * (1 - j / M) * zj * zj;
  }
  return sum;
}

// Greenhall & Riley 2003, Tables 1-3 (asymptotic coefficients); rows alpha = 2..-4, columns d = 1..3. NaN: invalid.
const double NA = std::numeric_limits<double>::quiet_NaN();
const double kTable1[7][3][2] = {  // modified variances
    {{2.0 / 3, 1.0 / 3}, {7.0 / 9, 0.5}, {22.0 / 25, 2.0 / 3}},
    {{0.840, 0.345}, {0.997, 0.616}, {1.141, 0.843}},
    {{1.079, 0.368}, {1.033, 0.607}, {1.184, 0.848}},
    {{NA, NA}, {1.048, 0.534}, {1.180, 0.816}},
    {{NA, NA}, {1.302, 0.535}, {1.175, 0.777}},
    {{NA, NA}, {NA, NA}, {1.194, 0.703}},
    {{NA, NA}, {NA, NA}, {1.489, 0.702}}};
const double kTable2[7][3][2] = {  // unmodified variances
    {{1.5, 0.5}, {35.0 / 18, 1.0}, {2.31, 1.5}},
    {{78.6, 25.2}, {790.0, 410.0}, {9950.0, 6520.0}},
    {{2.0 / 3, 1.0 / 6}, {2.0 / 3, 1.0 / 3}, {7.0 / 9, 0.5}},
    {{NA, NA}, {0.852, 0.375}, {0.997, 0.617}},
    {{NA, NA}, {1.079, 0.368}, {1.033, 0.607}},
    {{NA, NA}, {NA, NA}, {1.053, 0.553}},
    {{NA, NA}, {NA, NA}, {1.302, 0.535}}};
const double kTable3[3][2] = {{6.0, 4.0}, {15.23, 12.0}, {47.8, 40.0}};  // alpha = 1, unmodified

}  // namespace

/// Greenhall-Riley EDF of a d-th difference variance of n phase points at factor m.
/// modified: phase averaged over m (mvar); overlapping: stride 1 (else stride m).
double greenhallEdf(int alpha, int d, int64_t m, int64_t n, bool overlapping, bool modified) {
  if (d < 1 || d > 3) throw std::invalid_argument("Greenhall EDF: d must be 1..3");
  if (alpha > 2 || alpha < -4 || alpha + 2 * d <= 1)
    throw std::invalid_argument("Greenhall EDF: alpha " + std::to_string(alpha) + " invalid for difference order " +
                                std::to_string(d));
  const double F = modified ? 1.0 : static_cast<double>(m);
  const double S = overlapping ? static_cast<double>(m) : 1.0;
  const double L = m / F + static_cast<double>(m) * d;
  if (static_cast<double>(n) < L) return 0;
  const double M = 1 + std::floor(S * (n - L) / m);
  const double J = std::min(M, (d + 1) * S);
  const double Jmax = 100;
  const double r = M / S;
  const int row = 2 - alpha, col = d - 1;
  if (modified) {
    if (J <= Jmax) {
      const long double z0 = sz(0, 1, alpha, d);
      return static_cast<double>(z0 * z0 * M / basicSum(J, M, S, 1, alpha, d));
    }
    if (r > d + 1) {
      const double a0 = kTable1[row][col][0], a1 = kTable1[row][col][1];
      return r / (a0 - a1 / r);
    }
    const double mp = Jmax / r;
    const long double z0 = sz(0, 1, alpha, d);
    return static_cast<double>(z0 * z0 * Jmax / basicSum(Jmax, Jmax, mp, 1, alpha, d));
  }
  if (alpha <= 0) {
    if (J <= Jmax) {
      const double Fp = (m * (d + 1) <= Jmax) ? static_cast<double>(m) : kInf;
      const long double z0 = sz(0, Fp, alpha, d);
      return static_cast<double>(z0 * z0 * M / basicSum(J, M, S, Fp, alpha, d));
    }
    if (r > d + 1) {
      const double a0 = kTable2[row][col][0], a1 = kTable2[row][col][1];
      return r / (a0 - a1 / r);
    }
    const double mp = Jmax / r;
    const long double z0 = sz(0, kInf, alpha, d);
    return static_cast<double>(z0 * z0 * Jmax / basicSum(Jmax, Jmax, mp, kInf, alpha, d));
  }
  if (alpha == 1) {
    if (J <= Jmax) {
      const long double z0 = sz(0, static_cast<double>(m), 1, d);
      return static_cast<double>(z0 * z0 * M / basicSum(J, M, S, static_cast<double>(m), 1, d));
    }
    const double b0 = kTable3[col][0], b1 = kTable3[col][1];
    const double bz = b0 + b1 * std::log(static_cast<double>(m));
    if (r > d + 1) {
      const double a0 = kTable2[row][col][0], a1 = kTable2[row][col][1];
      return bz * bz * r / (a0 - a1 / r);
    }
    const double mp = Jmax / r;
    return static_cast<double>(bz * bz * Jmax / basicSum(Jmax, Jmax, mp, mp, 1, d));
  }
  // alpha == 2, unmodified: exact sum over the few non-zero lags (lag k*S, |k| <= d).
  const long double c0 = binom(2 * d, d);
  long double inv = 0;
  for (int k = -d; k <= d; ++k) {
    const double w = 1 - S * std::abs(k) / M;
    if (w <= 0) continue;
    const long double rho = binom(2 * d, d + k) / c0;
    inv += w * rho * rho;
  }
  return static_cast<double>(M / inv);
}

// ------------------------------------------------------------------------------------------------ per deviation
namespace {

double edfForKind(DevKind kind, int alpha, int64_t m, int64_t n_phase) {
  if (m < 1 || n_phase < 2) return 0;
  switch (kind) {
    case DevKind::Adev: return greenhallEdf(alpha, 2, m, n_phase, false, false);
    case DevKind::Oadev: return greenhallEdf(alpha, 2, m, n_phase, true, false);
    case DevKind::Mdev:
    case DevKind::Tdev: return greenhallEdf(alpha, 2, m, n_phase, true, true);
    // MTOTVAR: the Greenhall-Riley EDF of MVAR on the same data (its term count N - 3m + 1 is MVAR's). Stable32
    // does the same at m <= 8 of PHASE.DAT (matched to 1e-4); at m >= 16 it prints larger EDFs that follow
    // neither this nor SP1065 Table 8 (b T/tau - c), so MVAR's EDF is kept as the conservative choice (see
    // docs/deviations.md).
    case DevKind::Mtotdev:
    case DevKind::Ttotdev: return greenhallEdf(alpha, 2, m, n_phase, true, true);
    case DevKind::Hdev: return greenhallEdf(alpha, 3, m, n_phase, false, false);
    case DevKind::Ohdev: return greenhallEdf(alpha, 3, m, n_phase, true, false);
    case DevKind::Totdev: {
      // TOTVAR is OAVAR plus the terms that reach into the reflected extension: its EDF is taken as the OADEV
      // (Greenhall) EDF scaled by the term ratio (N-2)/(N-2m), capped by the NIST SP1065
      // sec. 5.2.11 empirical edf = b (T/tau) - c (white FM 1.50/0, flicker FM 1.17/0.22, RW FM 0.93/0.36),
      // which alone overstates the EDF at small m (at m = 1 TOTVAR equals OAVAR exactly).
      const double t_over_tau = static_cast<double>(n_phase - 1) / m;
      double cap = 1.50 * t_over_tau;  // PM noises (no SP1065 row): the white FM row
      if (alpha == -1) cap = 1.17 * t_over_tau - 0.22;
      if (alpha == -2) cap = 0.93 * t_over_tau - 0.36;
      double scaled = cap;
      if (n_phase - 2 * m >= 2) {
        const double e = greenhallEdf(alpha, 2, m, n_phase, true, false);
        scaled = e * static_cast<double>(n_phase - 2) / static_cast<double>(n_phase - 2 * m);
      }
      const double edf = std::min(scaled, cap);
      return std::isfinite(edf) ? std::max(0.0, edf) : 0.0;
    }
  }
  return 0;
}

}  // namespace

int64_t equivalentPhasePoints(DevKind kind, int64_t n, int64_t m) {
  switch (kind) {
    case DevKind::Adev: return (n + 1) * m + 1;
    case DevKind::Oadev: return n + 2 * m;
    case DevKind::Mdev:
    case DevKind::Tdev:
    case DevKind::Mtotdev:
    case DevKind::Ttotdev: return n + 3 * m - 1;
    case DevKind::Hdev: return (n + 2) * m + 1;
    case DevKind::Ohdev: return n + 3 * m;
    case DevKind::Totdev: return n + 2;
  }
  return 0;
}

double deviationEdf(const std::string& name, int alpha, int64_t m, int64_t n_phase) {
  const DevKind kind = devKindFromName(name);
  if (alpha < -2 || alpha > 2) throw std::invalid_argument("deviationEdf: alpha must be in -2..2");
  return edfForKind(kind, alpha, m, n_phase);
}

bool deviationIntervalFactors(double edf, double confidence, ChiSquareConvention convention, double* lo, double* hi) {
  if (!lo || !hi) throw std::invalid_argument("deviationIntervalFactors: null output");
  if (!(confidence > 0 && confidence < 1))
    throw std::invalid_argument("deviationIntervalFactors: confidence must be in (0,1)");
  *lo = *hi = 0;
  if (!(edf > 0) || !std::isfinite(edf)) return false;
  double qhi, qlo;
  if (convention == ChiSquareConvention::Stable32 && edf > 100) {
    // Stable32 above 100 degrees of freedom: Wilson-Hilferty at the confidence truncated to two decimals
    // (0.683 -> 0.68). Reproduces every printed 68.3 % bound of the PHASE.DAT and OCXO octave tables with
    // EDF > 100 to <= 6.1e-5 relative (exact quantiles at 0.683 are off by up to 4e-4 there).
    const double c2 = std::floor(confidence * 100 + 1e-9) / 100;
    if (!(c2 > 0)) throw std::invalid_argument("deviationIntervalFactors: Stable32 convention needs confidence >= 0.01");
    const double z = normalQuantile(0.5 * (1 + c2));
    const double h = 2.0 / (9.0 * edf);
    qhi = edf * std::pow(1.0 - h + z * std::sqrt(h), 3);
    qlo = edf * std::pow(std::max(0.0, 1.0 - h - z * std::sqrt(h)), 3);
  } else {
    qhi = chi2Quantile(0.5 * (1 + confidence), edf);
    qlo = chi2Quantile(0.5 * (1 - confidence), edf);
  }
  *lo = std::sqrt(edf / qhi);
  *hi = std::sqrt(edf / qlo);
  return true;
}

void fillConfidence(DeviationCurve* curve, double confidence, ChiSquareConvention convention) {
  if (!curve) throw std::invalid_argument("fillConfidence: null curve");
  if (!(confidence > 0 && confidence < 1)) throw std::invalid_argument("fillConfidence: confidence must be in (0,1)");
  const DevKind kind = devKindFromName(curve->name);
  for (auto& p : curve->points) {
    const int64_t n_eq = equivalentPhasePoints(kind, p.n_terms, p.m);
    p.edf = edfForKind(kind, std::max(-2, std::min(2, p.alpha)), p.m, n_eq);
    double lo = 0, hi = 0;
    if (deviationIntervalFactors(p.edf, confidence, convention, &lo, &hi)) {
      p.dev_lo = p.dev * lo;
      p.dev_hi = p.dev * hi;
    } else {
      p.edf = 0;
      p.dev_lo = p.dev_hi = 0;
    }
  }
}

// ------------------------------------------------------------------------------------------------ noise ID
namespace {

/// Pooled lag-1 autocorrelation of the d-th differences (d = 0..2) of the phase decimated by m, each segment's
/// sequence mean-removed; computed on the fly (no copy of the data).
double lag1AcfOfDifferences(const std::vector<PhaseSpan>& phases, int64_t m, int d) {
  // double precision is ample for a statistic used to the nearest 0.25; block sums keep long sums accurate.
  // A span with more than kMaxPoints points of the differenced sequence is sampled: 16 contiguous blocks of
  // kMaxPoints / 16 points spread evenly over it (mean over those points, lag-1 pairs within blocks). The estimate's
  // standard error there is ~1/sqrt(2^17) = 0.003 against decision steps of 0.25 in delta, and the long records of the
  // pipeline (millions of samples at every small m) stop paying a full pass per point and differencing order.
  constexpr int64_t kMaxPoints = int64_t(1) << 17, kBlocks = 16;
  long double num = 0, den = 0;
  for (const auto& p : phases) {
    if (p.n < 2) continue;
    const int64_t count = (p.n - 1) / m + 1 - d;  // points of the differenced sequence
    if (count < 2) continue;
    auto z = [&](int64_t i) -> double {
      const int64_t j = i * m;
      if (d == 0) return p.x[j];
      if (d == 1) return p.x[j + m] - p.x[j];
      return (p.x[j + 2 * m] - p.x[j + m]) - (p.x[j + m] - p.x[j]);
    };
    // Blocks [start, start + len) of the sequence that are used.
    std::vector<std::pair<int64_t, int64_t>> blocks;
    if (count <= kMaxPoints) {
      blocks.push_back({0, count});
    } else {
      const int64_t len = kMaxPoints / kBlocks;
      for (int64_t b = 0; b < kBlocks; ++b) blocks.push_back({b * (count - len) / (kBlocks - 1), len});
    }
    long double msum = 0;
    int64_t used = 0;
    for (const auto& bl : blocks) {
      double block = 0;
      for (int64_t i = bl.first; i < bl.first + bl.second; ++i) {
        block += z(i);
        if (((i - bl.first) & 1023) == 1023) {
          msum += block;
          block = 0;
        }
      }
      msum += block;
      used += bl.second;
    }
    const double mean = static_cast<double>(msum / used);
    for (const auto& bl : blocks) {
      double prev = z(bl.first) - mean, bnum = 0, bden = prev * prev;
      for (int64_t i = bl.first + 1; i < bl.first + bl.second; ++i) {
        const double cur = z(i) - mean;
        bden += cur * cur;
        bnum += prev * cur;
        prev = cur;
        if (((i - bl.first) & 1023) == 0) {
          num += bnum;
          den += bden;
          bnum = bden = 0;
        }
      }
      num += bnum;
      den += bden;
    }
  }
  return den > 0 ? static_cast<double>(num / den) : 0.0;
}

}  // namespace

int identifyNoiseAlpha(DevKind kind, const std::vector<PhaseSpan>& phases, int64_t m) {
  (void)kind;
  int64_t total = 0;  // decimated phase points over all segments
  for (const auto& p : phases)
    if (p.n >= 2) total += (p.n - 1) / m + 1;
  // Fewer than 30 points: no reliable identification here; the caller reuses the neighbouring point's alpha.
  // (A B1-ratio identification is not used there: on PHASE.DAT and the OCXO record it disagrees with Stable32's
  // choice at most such points and flips between PM and FM from one m to the next, which makes the EDF weights jump.)
  if (total < 30) return kNoAlpha;
  // Riley & Greenhall lag-1 ACF: difference until delta = r1/(1+r1) < 0.25 (at most dmax = 2 times);
  // alpha = 2 - round(2 delta) - 2 d (phase data), clamped to [-2, 2].
  const int dmax = 2;
  for (int d = 0;; ++d) {
    const double r1 = lag1AcfOfDifferences(phases, m, d);
    const double delta = r1 / (1 + r1);
    if (delta < 0.25 || d >= dmax) {
      const int a = 2 - static_cast<int>(std::lround(2 * delta)) - 2 * d;
      return std::max(-2, std::min(2, a));
    }
  }
}

}  // namespace gyro_allan
