// Wavelet split pipeline: wden split of the rate, oadev of both parts, Q from the removed part, N from coarse scales.
#include "gyro_allan/wavelet_split.hpp"
#include "gyro_allan/model_check.hpp"
#include "gyro_allan/simulate.hpp"
#include "gyro_allan/stats.hpp"

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <map>
#include <mutex>
#include <new>
#include <numeric>
#include <stdexcept>
#include <string>

#include <boost/math/distributions/students_t.hpp>

namespace gyro_allan {

namespace {

/// h * up(g, step): convolution of h with g upsampled by `step` (g[k] placed at k * step).
std::vector<double> convUpsampled(const std::vector<double>& h, const std::vector<double>& g, int64_t step) {
  const int64_t lh = static_cast<int64_t>(h.size()), lg = static_cast<int64_t>(g.size());
  std::vector<double> out(lh + (lg - 1) * step, 0.0);
  for (int64_t k = 0; k < lg; ++k) {
    const double gk = g[k];
    double* o = out.data() + k * step;
    for (int64_t i = 0; i < lh; ++i) o[i] += gk * h[i];
  }
  return out;
}

/// Equivalent synthesis scaling function of `level` levels (length (F-1)(2^level - 1) + 1, unit norm).
std::vector<double> scalingFunction(const Wavelet& w, int level) {
  std::vector<double> phi{1.0};
  for (int l = 1; l <= level; ++l) phi = convUpsampled(phi, w.rec_lo, int64_t(1) << (l - 1));
  return phi;
}

double lag1(const std::vector<double>& g) {
  double s = 0;
  for (size_t k = 0; k + 1 < g.size(); ++k) s += g[k] * g[k + 1];
  return s;
}

/// |H(nu)|^2 of a filter (Horner in z = e^{-2 pi i nu}: one sincos per call instead of one per tap).
double power(const std::vector<double>& h, double nu) {
  const std::complex<double> z = std::polar(1.0, -2.0 * M_PI * nu);
  std::complex<double> s(0, 0);
  for (size_t k = h.size(); k-- > 0;) s = s * z + h[k];
  return std::norm(s);
}

/// Mean of a series (long double sum).
double meanOf(const std::vector<double>& v) {
  return v.empty() ? 0.0 : static_cast<double>(std::accumulate(v.begin(), v.end(), 0.0L) / static_cast<long double>(v.size()));
}

/// Weighted sample variance helper: mean square of v[b..e).
double meanSquare(const std::vector<double>& v, size_t b, size_t e) {
  long double s = 0;
  for (size_t i = b; i < e; ++i) s += static_cast<long double>(v[i]) * v[i];
  return e > b ? static_cast<double>(s / static_cast<long double>(e - b)) : 0.0;
}

struct LevelData {
  std::vector<double> var;
  std::vector<int64_t> count;
};

/// Wavelet variances of levels 1..J from a symmetric-mode wavedec, dropping F coefficients at each end of every
/// level (those touched by the extension). Levels with fewer than `min_count` interior coefficients are omitted.
LevelData levelVariances(const std::vector<double>& rate, const Wavelet& w, int min_count) {
  const int F = w.dec_len();
  const int64_t n = static_cast<int64_t>(rate.size());
  int J = 0;
  for (int64_t len = n; (len + F - 1) / 2 - 2 * F >= min_count; len = (len + F - 1) / 2) ++J;
  LevelData d;
  if (J < 1) return d;
  // Level by level (the same coefficients as wavedec to level J), keeping only the current approximation.
  DwtCoeffs c = dwt(rate, w, ExtensionMode::Symmetric);
  for (int j = 1; j <= J; ++j) {
    if (j > 1) c = dwt(std::vector<double>(std::move(c.cA)), w, ExtensionMode::Symmetric);
    const auto& dj = c.cD;
    const size_t b = static_cast<size_t>(F), e = dj.size() - static_cast<size_t>(F);
    d.var.push_back(meanSquare(dj, b, e));
    d.count.push_back(static_cast<int64_t>(e - b));
  }
  return d;
}

/// A read-only window of a longer series.
struct AngleView {
  const double* p;
  size_t n;
  const double* begin() const { return p; }
  size_t size() const { return n; }
  double operator[](size_t i) const { return p[i]; }
};

DeviationCurve restrictTau(const DeviationCurve& c, double tau_min) {
  DeviationCurve r = c;
  r.points.clear();
  for (const auto& p : c.points)
    if (p.tau >= tau_min) r.points.push_back(p);
  return r;
}

}  // namespace

namespace {

/// Level responses at tau0 = 1 s (see waveletLevelResponses).
std::vector<std::array<double, kNumTerms>> levelResponsesUnit(const Wavelet& w, int max_level) {
  const double tau0 = 1.0;
  std::vector<std::array<double, kNumTerms>> out(static_cast<size_t>(max_level));
  std::vector<double> phi{1.0};  // scaling function of level j-1
  // Frequency grid for the flicker and random-walk integrals: nu = 2^-j u, u in (0, 8], midpoint rule.
  // 4000 midpoints: the integrands are smooth and periodic-like on the grid, so the rule converges fast (4000 and
  // 16000 points give the same responses to 5e-9 at level 1 and 1e-12 above).
  const int nu_pts = 4000;
  const double u_max = 8.0;
  for (int j = 1; j <= max_level; ++j) {
    const int64_t step = int64_t(1) << (j - 1);
    auto& r = out[static_cast<size_t>(j - 1)];
    r.fill(0.0);
    // Q: white angle error e (variance Q^2), rate = diff(e)/tau0: E d^2 = Q^2 ||psi_j * diff||^2 / tau0^2.
    const std::vector<double> psi = convUpsampled(phi, w.rec_hi, step);
    r[kQuantization] = (2.0 - 2.0 * lag1(psi)) / (tau0 * tau0);
    r[kAngleRandomWalk] = 1.0 / tau0;  // orthonormal transform of white rate noise of variance N^2/tau0
    // B (one-sided PSD B^2/(pi f)) and K (K^2/(2 pi^2 f^2)); R is annihilated (>= 2 vanishing moments).
    const double scale = std::ldexp(1.0, -j);
    const double du = std::min(u_max, std::ldexp(1.0, j - 1)) / nu_pts;
    double sb = 0, sk = 0;
    for (int i = 0; i < nu_pts; ++i) {
      const double nu = scale * (i + 0.5) * du;
      double p = power(w.rec_hi, std::ldexp(nu, j - 1));
      for (int l = 0; l <= j - 2 && p > 0; ++l) p *= power(w.rec_lo, std::ldexp(nu, l));
      sb += p / nu;
      sk += p / (nu * nu);
    }
    const double dnu = scale * du;
    r[kBiasInstability] = sb * dnu / M_PI;
    r[kRateRandomWalk] = sk * dnu * tau0 / (2.0 * M_PI * M_PI);
    r[kRateRamp] = 0.0;
    phi = convUpsampled(phi, w.rec_lo, step);
  }
  return out;
}

}  // namespace

std::vector<std::array<double, kNumTerms>> waveletLevelResponses(const Wavelet& w, int max_level, double tau0) {
  if (max_level < 1) throw std::invalid_argument("waveletLevelResponses: max_level must be >= 1");
  if (!(tau0 > 0)) throw std::invalid_argument("waveletLevelResponses: tau0 must be > 0");
  // The responses depend on tau0 only through the units of each term (Q ~ 1/tau0^2, N ~ 1/tau0, B none, K ~ tau0),
  // so they are computed once per wavelet at tau0 = 1 s and cached (every axis and every nodelet fit reuses them).
  static std::mutex mutex;
  static std::map<std::string, std::vector<std::array<double, kNumTerms>>> cache;
  std::vector<std::array<double, kNumTerms>> out;
  {
    std::lock_guard<std::mutex> lock(mutex);
    auto& unit = cache[w.name + "/" + std::to_string(w.rec_lo.size())];
    if (static_cast<int>(unit.size()) < max_level) unit = levelResponsesUnit(w, max_level);
    out.assign(unit.begin(), unit.begin() + max_level);
  }
  for (auto& r : out) {
    r[kQuantization] /= tau0 * tau0;
    r[kAngleRandomWalk] /= tau0;
    r[kRateRandomWalk] *= tau0;
  }
  return out;
}

SplitAngleFactors splitAngleFactors(const Wavelet& w, int level) {
  if (level < 1 || level > 20) throw std::invalid_argument("splitAngleFactors: level must be 1..20");
  const std::vector<double> phi = scalingFunction(w, level);
  const int64_t S = static_cast<int64_t>(phi.size());
  const int64_t P = int64_t(1) << level;
  // U(t) = sum_{k <= t} phi[k].
  std::vector<double> cum(phi.size());
  {
    long double a = 0;
    for (size_t k = 0; k < phi.size(); ++k) cum[k] = static_cast<double>(a += phi[k]);
  }
  auto U = [&](int64_t t) { return t < 0 ? 0.0 : (t >= S ? cum.back() : cum[static_cast<size_t>(t)]); };
  auto phiAt = [&](int64_t k) { return (k < 0 || k >= S) ? 0.0 : phi[static_cast<size_t>(k)]; };
  // rho(s) = sum phi[k] phi[k+s]; Gram of diff^T phi_i: G(d) = 2 delta_d - rho(P d + 1) - rho(P d - 1).
  const int64_t dmax = S / P + 2;
  std::vector<double> G(static_cast<size_t>(2 * dmax + 1), 0.0);
  auto rho = [&](int64_t s) {
    double acc = 0;
    for (int64_t k = std::max<int64_t>(0, -s); k < S && k + s < S; ++k) acc += phi[static_cast<size_t>(k)] * phi[static_cast<size_t>(k + s)];
    return acc;
  };
  for (int64_t d = -dmax; d <= dmax; ++d) G[static_cast<size_t>(d + dmax)] = (d == 0 ? 2.0 : 0.0) - rho(P * d + 1) - rho(P * d - 1);
  // A window 1 on [n - W, n]: its two edges contribute independently when W > 2 (S + P); averaging over the P phases
  // of n (the left edge runs through all phases too) gives twice the one-edge average.
  const int64_t W = 4 * (S + P);
  long double sum_n = 0, sum_q = 0;
  std::vector<double> c;
  for (int64_t n = 0; n < P; ++n) {
    const int64_t i_lo = static_cast<int64_t>(std::floor(static_cast<double>(n - W - S + 1) / P));
    const int64_t i_hi = static_cast<int64_t>(std::floor(static_cast<double>(n) / P));
    c.assign(static_cast<size_t>(i_hi - i_lo + 1), 0.0);
    long double cc = 0, lin = 0;
    for (int64_t i = i_lo; i <= i_hi; ++i) {
      const double ci = U(n - P * i) - U(n - W - 1 - P * i);
      c[static_cast<size_t>(i - i_lo)] = ci;
      cc += static_cast<long double>(ci) * ci;
      // (diff^T phi_i)[m] = phi[m - P i] - phi[m + 1 - P i], at m = n and m = n - W - 1.
      const double at_n = phiAt(n - P * i) - phiAt(n + 1 - P * i);
      const double at_l = phiAt(n - W - 1 - P * i) - phiAt(n - W - P * i);
      lin += static_cast<long double>(ci) * (at_n - at_l);
    }
    sum_n += static_cast<long double>(W + 1) - cc;
    long double quad = 0;
    const int64_t m = static_cast<int64_t>(c.size());
    for (int64_t a = 0; a < m; ++a) {
      if (c[static_cast<size_t>(a)] == 0.0) continue;
      long double row = 0;
      for (int64_t d = -dmax; d <= dmax; ++d) {
        const int64_t b = a + d;
        if (b < 0 || b >= m) continue;
        row += static_cast<long double>(c[static_cast<size_t>(b)]) * G[static_cast<size_t>(d + dmax)];
      }
      quad += c[static_cast<size_t>(a)] * row;
    }
    sum_q += 2.0L - 2.0L * lin + quad;
  }
  SplitAngleFactors f;
  f.v_n = static_cast<double>(sum_n / (2.0L * P));
  f.v_q = static_cast<double>(sum_q / (2.0L * P));
  return f;
}

namespace {

/// automaticSplitLevel on already computed level variances (levels with >= 32 interior coefficients are used).
int splitLevelFrom(const LevelData& all) {
  LevelData d;
  for (size_t j = 0; j < all.var.size() && all.count[j] >= 32; ++j) {
    d.var.push_back(all.var[j]);
    d.count.push_back(all.count[j]);
  }
  const int J = static_cast<int>(d.var.size());
  if (J < 6) throw std::invalid_argument("wavelet split: record too short for an automatic level (need >= 6 levels)");
  const double plateau = median({d.var[J - 1], d.var[J - 2], d.var[J - 3]});
  int jc = J;
  for (int j = 1; j <= J; ++j) {
    if (d.var[static_cast<size_t>(j - 1)] <= 2.0 * plateau) {
      jc = j;
      break;
    }
  }
  return std::max(1, std::min(jc - 1, J - 4));
}

}  // namespace

int automaticSplitLevel(const std::vector<double>& rate, double tau0, const Wavelet& w) {
  (void)tau0;
  return splitLevelFrom(levelVariances(rate, w, 32));
}

namespace {

// ---- waveletSplit, stage by stage ---------------------------------------------------------------------------------

// Rejects inputs waveletSplit cannot work on (std::invalid_argument); the record-length check is the caller's.
void validateSplitInputs(const std::vector<double>& rate, double tau0, const WaveletSplitOptions& options) {
  if (!(tau0 > 0) || !std::isfinite(tau0)) throw std::invalid_argument("waveletSplit: tau0 must be > 0");
  for (double v : rate)
    if (!std::isfinite(v)) throw std::invalid_argument("waveletSplit: non-finite rate sample");
  if (options.q_estimator != "angle" && options.q_estimator != "allan")
    throw std::invalid_argument("waveletSplit: q_estimator must be 'angle' or 'allan'");
  if (options.n_estimator != "wavelet_variance" && options.n_estimator != "allan")
    throw std::invalid_argument("waveletSplit: n_estimator must be 'wavelet_variance' or 'allan'");
}

// 1. The split at r->level (wden), with its thresholds and the fraction of detail coefficients it kept.
WdenResult splitRecord(const std::vector<double>& rate, const WaveletSplitOptions& options, WaveletSplitResult* r) {
  WdenOptions wo;
  wo.wavelet = options.wavelet;
  wo.level = r->level;
  wo.rule = options.rule;
  wo.mode = options.mode;
  wo.scaling = options.scaling;
  wo.extension = ExtensionMode::Symmetric;
  wo.removed_by_difference = true;  // long records: two record-sized arrays fewer (same parts to ~1e-15)
  WdenResult split = wden(rate, wo);
  r->thresholds = split.thresholds;
  double kept = 0, total = 0;
  for (int k = 1; k <= r->level; ++k) {
    const double cnt = static_cast<double>(rate.size()) / std::ldexp(1.0, k);
    kept += split.kept_fraction[static_cast<size_t>(k - 1)] * cnt;
    total += cnt;
  }
  r->kept_fraction = total > 0 ? kept / total : 0.0;
  return split;
}

// 3. Allan fits. Removed part: 3Q^2/tau^2 + N_r^2/tau. Denoised part above 4 * 2^level * tau0 with a leak term.
void fitParts(double tau0, const WaveletSplitOptions& options, WaveletSplitResult* r) {
  FitOptions rem_opt;
  rem_opt.enabled = {{true, true, false, false, false}};
  r->removed_fit = fitNoiseModel(r->removed_curve, rem_opt);
  const double tau_min = 4.0 * std::ldexp(tau0, r->level);
  FitOptions den_opt;
  den_opt.enabled = options.enabled;
  den_opt.enabled[kQuantization] = true;  // absorbs the quantization noise below the split frequency
  const DeviationCurve den_fit_curve = restrictTau(r->denoised_curve, tau_min);
  r->denoised_fit = fitNoiseModel(den_fit_curve, den_opt);
  if (r->removed_fit.ok) {
    r->q_allan = r->removed_fit.terms[kQuantization].value;
    r->q_allan_sigma = r->removed_fit.terms[kQuantization].sigma;
    r->n_removed = r->removed_fit.terms[kAngleRandomWalk].value;
  }
  if (r->denoised_fit.ok) {
    r->n_allan = r->denoised_fit.terms[kAngleRandomWalk].value;
    r->n_allan_sigma = r->denoised_fit.terms[kAngleRandomWalk].sigma;
  }
}

// Variance of the removed part's angle and its uncertainty.
struct AngleVariance {
  double var = 0, sigma = 0;
};

// Uncertainty of var(angle) by batch means over 64 blocks (0 when there are too few samples).
double batchVarianceSigma(const AngleView& angle) {
  double var_a_sigma = 0;
  const size_t nb = 64, len = angle.size() / nb;
  std::vector<double> bv;
  for (size_t b = 0; b < nb && len > 1; ++b) {
    long double s = 0, s2 = 0;
    for (size_t i = b * len; i < (b + 1) * len; ++i) s += angle[i];
    const long double m = s / len;
    for (size_t i = b * len; i < (b + 1) * len; ++i) s2 += (angle[i] - m) * (angle[i] - m);
    bv.push_back(static_cast<double>(s2 / (len - 1)));
  }
  if (bv.size() > 1) {
    const double mb = std::accumulate(bv.begin(), bv.end(), 0.0) / bv.size();
    double ss = 0;
    for (double v : bv) ss += (v - mb) * (v - mb);
    var_a_sigma = std::sqrt(ss / (bv.size() - 1) / bv.size());
  }
  return var_a_sigma;
}

// The removed part as an angle error, on the interior only: the symmetric extension distorts the split within
// about one level-L scaling function (length S) of each end (measured: +0.6 to +1.8 % on var(angle) at level 9 if
// the ends are kept). Fills r->removed_angle; returns var(angle) and its sigma.
AngleVariance removedAngleVariance(const std::vector<double>& removed, double tau0, int F, WaveletSplitResult* r) {
  const std::vector<double> full_angle = removedAngle(removed, tau0);
  const size_t margin = static_cast<size_t>((F - 1) * (std::ldexp(1.0, r->level) - 1) + 1 + std::ldexp(1.0, r->level));
  if (full_angle.size() < 4 * margin)
    throw std::invalid_argument("waveletSplit: record too short for split level " + std::to_string(r->level));
  const AngleView angle{full_angle.data() + margin, full_angle.size() - 2 * margin};  // interior, not copied
  r->removed_angle = angleErrorStats(angle.begin(), angle.size());
  AngleVariance av;
  av.var = r->removed_angle.std * r->removed_angle.std;
  // Floor: the scatter var(angle) would have if the error were white uniform quantization (excess kurtosis -6/5:
  // Var(s^2) = 0.8 s^4 / n). A pulse counter's sawtooth at constant rate repeats itself, so its batch means barely
  // scatter (the 64-block sigma came out ~7x below the actual error of Q on undithered records, coverage_study).
  av.sigma = std::max(batchVarianceSigma(angle),
                      av.var * std::sqrt(0.8 / static_cast<double>(std::max<size_t>(1, angle.size()))));
  return av;
}

// Weighted least-squares fit of the level variances (LevelModel::fit).
struct LevelFit {
  double n2 = 0, n2_sigma = 0, gamma = 0, gamma_sigma = 0;
  int j_start = 0;
  bool ok = false;
};

// The wavelet variances of levels 1..J as a model: each level's response to the noise terms, with the longer-tau
// terms (B, K) fixed from the denoised Allan fit.
struct LevelModel {
  const std::vector<std::array<double, kNumTerms>>& resp;
  const std::vector<WaveletLevel>& levels;
  int J;
  double b2 = 0, k2 = 0;
  double b2_sd = 0, k2_sd = 0;  // their standard deviations (delta method from the denoised fit's sigmas)

  // Variance of level j from the fixed longer-tau terms.
  double other(int j) const {
    const auto& rj = resp[static_cast<size_t>(j - 1)];
    return b2 * rj[kBiasInstability] + k2 * rj[kRateRandomWalk];
  }

  // Weighted least squares of var_j - other_j = n2 * b_j (+ gamma * a_j when gamma is free) over the given levels,
  // weights count_j / (2 model_j^2) from the current model. ok false if no level qualifies.
  LevelFit fit(bool free_gamma, double gamma_fixed, double share_max, double n2_start) const {
    LevelFit f;
    double n2c = n2_start, gc = free_gamma ? gamma_fixed : gamma_fixed;
    for (int it = 0; it < 5; ++it) {
      double s11 = 0, s12 = 0, s22 = 0, t1 = 0, t2 = 0;
      int used = 0;
      // Levels: the contiguous block from the coarse end where the criterion holds (a quantization error that is
      // not white can pass the criterion on fine levels where it is far from negligible).
      int j_start = J + 1;
      for (int j = J; j >= 1; --j) {
        const auto& rj = resp[static_cast<size_t>(j - 1)];
        const auto& L = levels[static_cast<size_t>(j - 1)];
        const bool pass = L.count >= 8 && (free_gamma ? gamma_fixed * rj[kQuantization] <= share_max * n2c * rj[kAngleRandomWalk]
                                                      : gamma_fixed * rj[kQuantization] <= share_max * L.var);
        if (!pass) break;
        j_start = j;
      }
      f.j_start = j_start;
      for (int j = j_start; j <= J; ++j) {
        const auto& rj = resp[static_cast<size_t>(j - 1)];
        const auto& L = levels[static_cast<size_t>(j - 1)];
        const double model = std::max(n2c * rj[kAngleRandomWalk] + gc * rj[kQuantization] + other(j), 1e-300);
        const double wgt = static_cast<double>(L.count) / (2.0 * model * model);
        const double y = L.var - other(j) - (free_gamma ? 0.0 : gamma_fixed * rj[kQuantization]);
        const double x1 = rj[kAngleRandomWalk], x2 = rj[kQuantization];
        s11 += wgt * x1 * x1;
        s12 += wgt * x1 * x2;
        s22 += wgt * x2 * x2;
        t1 += wgt * x1 * y;
        t2 += wgt * x2 * y;
        ++used;
      }
      if (used == 0) return f;
      f.ok = true;
      if (free_gamma && used >= 3) {
        const double det = s11 * s22 - s12 * s12;
        double nn = (s22 * t1 - s12 * t2) / det, gg = (s11 * t2 - s12 * t1) / det;
        if (gg < 0) {  // non-negative: quantization share zero
          gg = 0;
          nn = t1 / s11;
          f.n2_sigma = std::sqrt(1.0 / s11);
          f.gamma_sigma = std::sqrt(1.0 / s22);
        } else {
          f.n2_sigma = std::sqrt(s22 / det);
          f.gamma_sigma = std::sqrt(s11 / det);
        }
        n2c = std::max(0.0, nn);
        gc = gg;
      } else {
        n2c = std::max(0.0, t1 / s11);
        f.n2_sigma = std::sqrt(1.0 / s11);
      }
    }
    f.n2 = n2c;
    f.gamma = gc;
    return f;
  }
};

// The levels of the report (bands, counts, variances), before the model is known.
void describeLevels(const LevelData& lv, int J, double tau0, WaveletSplitResult* r) {
  r->levels.assign(static_cast<size_t>(J), WaveletLevel{});
  for (int j = 1; j <= J; ++j) {
    auto& L = r->levels[static_cast<size_t>(j - 1)];
    L.level = j;
    L.f_hi = 1.0 / (tau0 * std::ldexp(2.0, j - 1));
    L.f_lo = L.f_hi / 2;
    L.count = lv.count[static_cast<size_t>(j - 1)];
    L.var = lv.var[static_cast<size_t>(j - 1)];
  }
}

// Q^2 (angle) and N^2 (levels) with their sigmas, and the levels N used.
struct QnEstimate {
  double q2 = 0, q2_sigma = 0, n2 = 0, n2_sigma = 0;
  double n2_sigma_levels = 0;  // n2_sigma before the sawtooth's skirt allowance (level fit, B's and K's part)
  double q2_sigma_longer = 0;  // the part of q2_sigma from B's and K's uncertainty (kept when the bootstrap sets it)
  double q_sigma_dof = 0;  // > 0: Q^2's sigma is estimated from that many degrees of freedom (Student t intervals)
  int j_used = 0;
};

// Relative uncertainty of the lost quantization fraction 1 - V_Q_eff for a sawtooth (undithered pulse counter at a
// constant rate). The free fit's share gamma / Q^2 uses white quantization's level response, but the sawtooth is a
// line at f_saw = |mean rate| / pulse (pulse = Q sqrt(12)) broadened by the random walk of its phase, and the part of
// that line's skirt below the split frequency is what the white shape misjudges. The skirt of a diffusion-broadened
// line falls like (f_split / f_saw)^2, so that is the allowance on the share, times the white lost fraction 1 - V_Q.
// No free constant; the form was chosen on tuning records (seeds 1-2 of the simulator, coverage_study seeds 1-20),
// where the share's actual error was ~0.25 at f_saw / f_split = 2.1 (2 deg/h) and 0.03-0.07 at 5-8
// (docs/wavelet_split.md).
double sawtoothSkirt(double q2, double mean_rate_abs, double split_frequency_hz) {
  const double f_saw = q2 > 0 ? mean_rate_abs / std::sqrt(12.0 * q2) : 0.0;
  return f_saw > 0 ? std::min(1.0, std::pow(split_frequency_hz / f_saw, 2)) : 1.0;
}
double sawtoothLostSigma(const SplitAngleFactors& fac, double q2, double mean_rate_abs, double split_frequency_hz) {
  if (!(q2 > 0)) return 0.0;
  return (1.0 - fac.v_q) * sawtoothSkirt(q2, mean_rate_abs, split_frequency_hz);
}

// The removed angle's variance from the longer-tau terms (B and K, fixed from the denoised Allan fit): the removed
// rate holds their power in detail levels 1..L too (rj[B] doubles per level, rj[K] quadruples), and the angle weighs
// each level's power by 1 / (2 pi f)^2. Level j holds a share rj 2^-j of the rate's variance in the octave below
// f_j = 1 / (2^j tau0), so its angle variance is rj 2^-j times the band's mean of 1 / (2 pi f)^2, i.e. rj 2^j times
// a constant that depends on the spectral shape within the octave: for a flat (ARW) band the mean of 1/f^2 over
// [f/2, f] is 2 / f^2, for flicker (1/f, B) (3/2) / (ln 2 f^2), for a random walk (1/f^2, K) (7/3) / f^2. The white
// constant is taken from the exact factor v_n (splitAngleFactors) rather than from the ideal octaves: sym8's
// measured v_n / sum_j 2^j is 0.0521-0.0529 for L = 6-10 against 1 / (2 pi^2) = 0.0507 for sharp octaves. B and K
// get the white constant times their octave-shape ratios (1.082, 1.167). Without it the removed angle's B share
// was read as quantization: Q +0.25 % (median; mean z +1.3) at B 30 deg/h, N 0.25 deg/sqrt(h), Q 2 arcsec.
double removedAngleOfLongerTerms(const LevelModel& lm, const SplitAngleFactors& fac, double tau0, int level) {
  if (!(lm.b2 > 0) && !(lm.k2 > 0)) return 0.0;
  const double flicker_shape = 1.5 / std::log(2.0) / 2.0, walk_shape = (7.0 / 3.0) / 2.0;
  double white = 0, other = 0;
  for (int j = 1; j <= std::min(level, lm.J); ++j) {
    const auto& rj = lm.resp[static_cast<size_t>(j - 1)];
    const double w = std::ldexp(1.0, j);
    white += rj[kAngleRandomWalk] * w;
    other += (lm.b2 * rj[kBiasInstability] * flicker_shape + lm.k2 * rj[kRateRandomWalk] * walk_shape) * w;
  }
  return white > 0 ? fac.v_n * tau0 * other / white : 0.0;
}

// Q (angle) and N (levels) depend on each other weakly: iterate. With the white-quantization model the levels
// near the crossover have a known quantization share Q^2 a_j ("fixed"). A quantization error that is not white
// (sawtooth of a pulse counter at constant rate) leaves the coarse levels nearly clean, and subtracting the white
// share there would bias N low; so the share is also fitted freely ("free": gamma a_j over levels whose white
// share is at most free_fit_max_ratio times the ARW) and the fixed fit is used only when gamma agrees with Q^2 within
// 3 sigma. For non-white quantization the lost fraction 1 - V_Q is scaled by the same gamma / Q^2.
// Sets r->quantization_white, quantization_level_share and quantization_kept.
QnEstimate iterateQn(const LevelModel& lm, const SplitAngleFactors& fac, const AngleVariance& av, double tau0,
                     double n2_start, double mean_rate_abs, const WaveletSplitOptions& options, WaveletSplitResult* r) {
  QnEstimate e;
  e.n2 = n2_start;
  const double var_a = av.var, var_a_sigma = av.sigma;
  const double kFreeFitMaxRatio = options.free_fit_max_ratio;
  e.j_used = lm.J + 1;
  const double other_a = removedAngleOfLongerTerms(lm, fac, tau0, r->level);
  double v_q_eff = fac.v_q, lost_sigma = 0;
  for (int it = 0; it < 5; ++it) {
    e.q2 = std::max(0.0, (var_a - fac.v_n * e.n2 * tau0 - other_a) / v_q_eff);
    e.q2_sigma = std::sqrt(var_a_sigma * var_a_sigma + std::pow(fac.v_n * tau0 * e.n2_sigma, 2) +
                           std::pow(e.q2 * lost_sigma, 2)) / v_q_eff;
    const LevelFit fixed = lm.fit(false, e.q2, options.max_quantization_share, e.n2);
    const LevelFit freef = lm.fit(true, e.q2, kFreeFitMaxRatio, e.n2);
    // White when the free share agrees with Q^2 and the two fits agree on N^2 (each within 3 sigma). A sawtooth can
    // pass the first test on a short record, whose few coarse levels leave gamma uncertain; the fixed fit then read
    // the non-white power of the finer levels it adds as ARW (10 min at 2 deg/h: N^2 x100, Q^2 driven to 0 and the
    // split failed on 5 of 20 records). The second test catches exactly that. The two fits share their coarse levels,
    // so their N^2 are positively correlated and hypot() overstates the sigma of the difference: the test leans
    // towards white. It applies only when the free fit fitted the share (with fewer than 3 levels it did not, and its
    // N^2 then carries the quantization unsubtracted).
    const bool share_agrees = !(freef.ok && freef.gamma_sigma > 0 && std::fabs(freef.gamma - e.q2) > 3.0 * freef.gamma_sigma);
    const bool n_agrees = !(fixed.ok && freef.ok && freef.gamma_sigma > 0 &&
                            std::fabs(fixed.n2 - freef.n2) > 3.0 * std::hypot(fixed.n2_sigma, freef.n2_sigma));
    r->quantization_white = share_agrees && n_agrees;
    r->quantization_level_share = freef.ok && e.q2 > 0 ? freef.gamma / e.q2 : 0.0;
    const LevelFit& use = (r->quantization_white && fixed.ok) ? fixed : freef;
    if (use.ok) {
      e.n2 = use.n2;
      e.n2_sigma = use.n2_sigma;
      e.j_used = use.j_start;
    }
    const double lost = (1.0 - fac.v_q) * (r->quantization_white ? 1.0 : std::min(1.0, r->quantization_level_share));
    lost_sigma = r->quantization_white ? 0.0 : sawtoothLostSigma(fac, e.q2, mean_rate_abs, r->split_frequency_hz);
    v_q_eff = 1.0 - lost;
  }
  r->quantization_kept = v_q_eff;
  // B and K are fixed at the denoised fit's values, which are estimates: their uncertainty moves N^2 (the levels'
  // B and K shares are subtracted) and Q^2 (through N^2 and the removed angle's B and K share). Linear propagation,
  // one standard deviation of each at a time, the level fit redone as chosen above. At B 30 deg/h with N 0.25
  // deg/sqrt(h) the fixed B's share of N's coarse levels made N's sigma 0.6 of its scatter without this.
  for (int term = 0; term < 2; ++term) {
    const double sd = term == 0 ? lm.b2_sd : lm.k2_sd;
    if (!(sd > 0)) continue;
    LevelModel m = lm;
    (term == 0 ? m.b2 : m.k2) += sd;
    const LevelFit fixed = m.fit(false, e.q2, options.max_quantization_share, e.n2);
    const LevelFit freef = m.fit(true, e.q2, kFreeFitMaxRatio, e.n2);
    const LevelFit& use = (r->quantization_white && fixed.ok) ? fixed : freef;
    if (!use.ok) continue;
    const double dn2 = use.n2 - e.n2;
    const double dother = removedAngleOfLongerTerms(m, fac, tau0, r->level) - other_a;
    const double dq2 = -(fac.v_n * tau0 * dn2 + dother) / v_q_eff;
    e.n2_sigma = std::hypot(e.n2_sigma, dn2);
    e.q2_sigma = std::hypot(e.q2_sigma, dq2);
    e.q2_sigma_longer = std::hypot(e.q2_sigma_longer, dq2);
  }
  if (!r->quantization_white && e.n2 > 0) {
    // N's levels carry the sawtooth's skirt too (the free fit's gamma a_j, white-shaped): the same relative allowance
    // on that part of them, rho = (quantization part) / (ARW part) summed over the levels N used.
    double qa = 0, nb = 0;
    for (int j = e.j_used; j <= lm.J; ++j) {
      const auto& rj = lm.resp[static_cast<size_t>(j - 1)];
      qa += std::min(1.0, r->quantization_level_share) * e.q2 * rj[kQuantization];
      nb += e.n2 * rj[kAngleRandomWalk];
    }
    const double skirt = sawtoothSkirt(e.q2, mean_rate_abs, r->split_frequency_hz);
    e.n2_sigma_levels = e.n2_sigma;
    if (nb > 0) e.n2_sigma = std::hypot(e.n2_sigma, skirt * (qa / nb) * e.n2);
  }
  return e;
}

// The levels' model variances and Q, N from the angle and the levels, with the ARW share of the removed angle.
void recordQn(const LevelModel& lm, const QnEstimate& e, const SplitAngleFactors& fac, const AngleVariance& av,
              double tau0, WaveletSplitResult* r) {
  for (int j = 1; j <= lm.J; ++j) {
    const auto& rj = lm.resp[static_cast<size_t>(j - 1)];
    auto& L = r->levels[static_cast<size_t>(j - 1)];
    const double share = r->quantization_white ? 1.0 : r->quantization_level_share;
    L.quantization_var = share * e.q2 * rj[kQuantization];
    L.model_var = L.quantization_var + e.n2 * rj[kAngleRandomWalk] + lm.other(j);
    L.used_for_n = j >= e.j_used;
  }
  r->q_angle = std::sqrt(e.q2);
  r->q_angle_sigma = r->q_angle > 0 ? 0.5 * e.q2_sigma / r->q_angle : std::sqrt(e.q2_sigma);
  r->n_wavelet = std::sqrt(e.n2);
  r->n_wavelet_sigma = r->n_wavelet > 0 ? 0.5 * e.n2_sigma / r->n_wavelet : std::sqrt(e.n2_sigma);
  r->removed_arw_angle_var = fac.v_n * e.n2 * tau0;
  r->removed_arw_share = av.var > 0 ? r->removed_arw_angle_var / av.var : 0.0;
}

// Q^2 and N^2 of one record by the split's own estimator (split at `level`, removed angle, level model without B and
// K), without the Allan curves: one replica of the sawtooth bootstrap.
struct ReplicaQn {
  double q2 = 0, n2 = 0;
  bool white = true;
};
ReplicaQn replicaQn(std::vector<double> rate, double tau0, int level, const WaveletSplitOptions& options,
                    const Wavelet& w, const SplitAngleFactors& fac, double n2_start) {
  WaveletSplitResult s;
  s.level = level;
  s.split_frequency_hz = 1.0 / (tau0 * std::ldexp(2.0, level));
  const LevelData lv = levelVariances(rate, w, 8);
  const double mean_rate_abs = std::fabs(meanOf(rate));
  WdenResult split = splitRecord(rate, options, &s);
  std::vector<double>().swap(rate);  // only the removed part is needed from here: one split's memory at most
  std::vector<double>().swap(split.denoised);
  const AngleVariance av = removedAngleVariance(split.removed, tau0, w.dec_len(), &s);
  const int J = static_cast<int>(lv.var.size());
  const auto resp = waveletLevelResponses(w, std::max(1, J), tau0);
  const LevelModel lm{resp, s.levels, J};
  describeLevels(lv, J, tau0, &s);
  const QnEstimate e = iterateQn(lm, fac, av, tau0, n2_start, mean_rate_abs, options, &s);
  return {e.q2, e.n2, s.quantization_white};
}

// Quantization that is not white (an undithered pulse counter at a constant rate: a sawtooth). How much of the
// sawtooth the split loses, and how it leaks into N's coarse levels, depends on where its line and harmonics fall
// against the split frequency and on the thresholds the noise sets; the white-shaped level model misjudges it by a
// rate-dependent bias (coverage_study seeds 1-60: Q -0.20 % at 2 deg/h with a scatter of 0.03 %, +0.08 % at 5 deg/h,
// ~0 at 10-15 deg/h) that no closed form here follows. So the estimator is run on records simulated from the fitted
// model: an undithered pulse counter of weight Q sqrt(12) at the record's mean rate, and N. B and K are left out of
// the replicas and of their level model alike (the record's level model subtracts its fitted B and K; what is
// corrected here is the split's handling of the sawtooth), which also keeps a replica to the cost and memory of one
// more split (no flicker FFT). Q^2 and N^2 are corrected by the replicas' mean bias; Q's sigma is their scatter times
// sqrt(1 + 1/R) (the record's own scatter plus that of the estimated bias), with Student t intervals.
// Skipped, the analytic allowance staying, when the replicas do not behave like the record: most of them judged white,
// one without Q or N, a corrected value <= 0, or the simulator refusing the model or running out of memory.
void sawtoothBootstrap(double tau0, int64_t n, const WaveletSplitOptions& options, const Wavelet& w,
                       const SplitAngleFactors& fac, double mean_rate, QnEstimate* e, WaveletSplitResult* r) {
  const int R = options.sawtooth_replicas;
  if (R < 2 || r->quantization_white || !(e->q2 > 0) || !(e->n2 > 0)) return;
  SawtoothBootstrap& b = r->sawtooth_bootstrap;
  if (options.q_estimator != "angle" || options.n_estimator != "wavelet_variance") {
    b.note = "not run: Q and N are not the angle and wavelet-variance estimates";
    return;
  }
  // The model to 5 significant digits: a pulse counter's output flips where the angle crosses a pulse boundary, so a
  // change of 1e-7 in the pulse weight or the rate (the same record read as rate, as angle, or through the 4-byte
  // sample storage) moves dozens of pulses of a replica and its estimates by ~1e-4; rounded, such records simulate
  // the same replicas. (The bias is measured against the rounded model, so the rounding costs nothing.)
  auto round5 = [](double x) {
    if (!(x != 0) || !std::isfinite(x)) return x;
    const double scale = std::pow(10.0, 4 - static_cast<int>(std::floor(std::log10(std::fabs(x)))));
    return std::round(x * scale) / scale;
  };
  AxisNoise ax;
  ax.quantization = round5(std::sqrt(e->q2));
  ax.dither = false;
  ax.angle_random_walk = round5(std::sqrt(e->n2));
  ax.input_rate = round5(mean_rate);
  const double q2_sim = ax.quantization * ax.quantization, n2_sim = ax.angle_random_walk * ax.angle_random_walk;
  // Seeds from the record's length, split level and total angle in whole pulses (mean rate x duration / (Q sqrt(12))):
  // reproducible for a record, the same for the record read as rate, as angle or through the 4-byte sample storage
  // (their samples differ in the last bits, ~1e-8 of the total, far below a pulse), and different between records,
  // whose totals scatter by tens of pulses (with one fixed seed set, every record's sigma shared the same replicas'
  // luck: Q's 68 % coverage 0.55-0.57 in two of four classes, tuning seeds 1-60).
  const double pulses = std::round(ax.input_rate * static_cast<double>(n) * tau0 / (ax.quantization * std::sqrt(12.0)));
  const uint64_t key = std::isfinite(pulses) ? static_cast<uint64_t>(static_cast<int64_t>(std::fmod(pulses, 9.0e18))) : 0;
  uint64_t seed = 0xcbf29ce484222325ull;
  for (uint64_t v : {static_cast<uint64_t>(n), static_cast<uint64_t>(r->level), key}) seed = (seed ^ v) * 0x100000001b3ull;
  std::vector<double> q2s, n2s;
  b.replicas = R;
  b.q2_raw = e->q2;
  b.n2_raw = e->n2;
  try {
    for (int i = 0; i < R; ++i) {
      const ReplicaQn q =
          replicaQn(simulateAxis(ax, 1.0 / tau0, n, seed + static_cast<uint64_t>(i), 0), tau0, r->level, options, w, fac, n2_sim);
      q2s.push_back(q.q2);
      n2s.push_back(q.n2);
      b.replicas_white += q.white ? 1 : 0;
    }
  } catch (const std::invalid_argument& ex) {
    b.note = std::string("not applied: the simulator refused the fitted model (") + ex.what() + ")";
    return;
  } catch (const std::bad_alloc&) {
    b.note = "not applied: out of memory simulating the replicas";
    return;
  }
  auto usable = [](double x) { return x > 0 && std::isfinite(x); };
  if (!std::all_of(q2s.begin(), q2s.end(), usable) || !std::all_of(n2s.begin(), n2s.end(), usable)) {
    b.note = "not applied: a replica gave no Q or no N";
    return;
  }
  if (2 * b.replicas_white > R) {
    b.note = "not applied: most replicas' quantization was judged white, unlike the record's";
    return;
  }
  auto meanSd = [](const std::vector<double>& v, double* mean, double* sd) {
    *mean = std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
    double ss = 0;
    for (double x : v) ss += (x - *mean) * (x - *mean);
    *sd = std::sqrt(ss / static_cast<double>(v.size() - 1));
  };
  double mq, mn;
  meanSd(q2s, &mq, &b.q2_sd);
  meanSd(n2s, &mn, &b.n2_sd);
  b.q2_bias = mq - q2_sim;
  b.n2_bias = mn - n2_sim;
  if (!(e->q2 - b.q2_bias > 0) || !(e->n2 - b.n2_bias > 0)) {
    b.note = "not applied: the bias correction would leave Q or N at or below 0";
    return;
  }
  b.applied = true;
  const double inflate = std::sqrt(1.0 + 1.0 / R);
  e->q2 -= b.q2_bias;
  e->n2 -= b.n2_bias;
  e->q2_sigma = std::hypot(b.q2_sd * inflate, e->q2_sigma_longer);  // the replicas hold no B or K
  e->q_sigma_dof = R - 1;
  // N^2: the replicas' N scatter came out below the records' actual one (0.9-1.1 % of N against 1.0-1.4 %, tuning
  // seeds 1-60; with it, mean err^2 / sigma^2 of N was 1.7), so N keeps the level fit's own sigma, less the skirt
  // allowance (the bias it allowed for is now removed), plus the bias estimate's scatter.
  e->n2_sigma = std::hypot(e->n2_sigma_levels, b.n2_sd / std::sqrt(static_cast<double>(R)));
}

// A coefficient from its square and the sigma of the square; with sigma_dof > 0 the sigma is itself an estimate and
// the intervals take Student t quantiles of that many degrees of freedom instead of the normal 1 and 1.96.
Coefficient fromSquare(double c, double c_sigma, double sigma_dof) {
  if (!(sigma_dof > 0)) return coefficientFromSquare(c, c_sigma);
  const boost::math::students_t t(sigma_dof);
  return coefficientFromSquare(c, c_sigma, 2.0, boost::math::quantile(t, kP68Upper),
                               boost::math::quantile(t, 0.975));
}

void reportCoefficients(const WaveletSplitOptions& options, const QnEstimate& e, const FitResult& longer,
                        WaveletSplitResult* r) {
  if (options.q_estimator == "angle") {
    r->terms[kQuantization] = fromSquare(e.q2, e.q2_sigma, e.q_sigma_dof);
  } else {
    r->terms[kQuantization] = r->removed_fit.terms[kQuantization];
  }
  if (options.n_estimator == "wavelet_variance") {
    r->terms[kAngleRandomWalk] = coefficientFromSquare(e.n2, e.n2_sigma);
  } else {
    r->terms[kAngleRandomWalk] = r->denoised_fit.terms[kAngleRandomWalk];
  }
  if (!options.enabled[kAngleRandomWalk]) r->terms[kAngleRandomWalk] = Coefficient{};
  if (!options.enabled[kQuantization]) r->terms[kQuantization] = Coefficient{};
  for (int t = kBiasInstability; t < kNumTerms; ++t) {  // B, K and R: the longer-tau fit's
    const size_t i = static_cast<size_t>(t);
    if (!options.enabled[i] || !longer.ok) continue;
    r->terms[i] = longer.terms[i];
  }
}

// Model Allan variance of the given terms at the curve's taus.
std::vector<double> modelOf(const DeviationCurve& c, const std::array<Coefficient, kNumTerms>& terms) {
  std::vector<double> m(c.points.size(), 0.0);
  for (size_t i = 0; i < c.points.size(); ++i)
    for (int t = 0; t < kNumTerms; ++t) m[i] += terms[static_cast<size_t>(t)].value * terms[static_cast<size_t>(t)].value * noiseTermBasis(t, c.points[i].tau, c.tau0);
  return m;
}

// 7. Fit error measures: the reported terms against the input's curve, and each part's own fit.
void fitErrors(const DeviationCurve& raw_curve, WaveletSplitResult* r) {
  int n_params = 0;
  for (const auto& c : r->terms) n_params += c.value > 0 ? 1 : 0;
  // The input curve's EDF from the reported model's dominant term at each tau (its own noise identification sees
  // white PM everywhere on a quantization-dominated record and would call the longest taus tight).
  FitResult reported;
  reported.ok = true;
  reported.terms = r->terms;
  reported.tau0 = raw_curve.tau0;
  reported.model_var = modelOf(raw_curve, r->terms);
  const DeviationCurve with_edf = withModelEdf(raw_curve, reported);
  r->fit_error = fitError(with_edf, modelOf(with_edf, r->terms), std::vector<bool>(with_edf.points.size(), true),
                          std::max(1, n_params), FitOptions{}.rms_min_edf);
  if (r->denoised_fit.ok) {
    r->denoised_fit_error.rms_log10 = r->denoised_fit.rms_log10;
    r->denoised_fit_error.chi2_dof = r->denoised_fit.chi2_dof;
    r->denoised_fit_error.n_rms = r->denoised_fit.n_rms;
  }
  if (r->removed_fit.ok) {
    r->removed_fit_error.rms_log10 = r->removed_fit.rms_log10;
    r->removed_fit_error.chi2_dof = r->removed_fit.chi2_dof;
    r->removed_fit_error.n_rms = r->removed_fit.n_rms;
  }
}

}  // namespace

WaveletSplitResult waveletSplit(const std::vector<double>& rate, double tau0, const WaveletSplitOptions& options,
                                const DeviationCurve* raw_oadev, const FitResult* input_fit) {
  validateSplitInputs(rate, tau0, options);
  const Wavelet w(options.wavelet);
  const int F = w.dec_len();
  if (static_cast<int64_t>(rate.size()) < 64 * F)
    throw std::invalid_argument("waveletSplit: record too short (need at least 64 * filter length samples)");

  WaveletSplitResult r;
  r.wavelet = options.wavelet;
  // Wavelet variances of the input (all levels with >= 8 interior coefficients): one deep decomposition serves the
  // automatic level (its levels with >= 32 coefficients, the same numbers as a separate decomposition) and N.
  const LevelData lv = levelVariances(rate, w, 8);
  r.level = options.level > 0 ? options.level : splitLevelFrom(lv);
  r.split_frequency_hz = 1.0 / (tau0 * std::ldexp(2.0, r.level));

  WdenResult split = splitRecord(rate, options, &r);

  // 2. Allan deviation of each part, and of the input (for the combined fit error).
  r.denoised_curve = computeDeviation("oadev", split.denoised, InputKind::Rate, tau0, options.deviation);
  r.removed_curve = computeDeviation("oadev", split.removed, InputKind::Rate, tau0, options.deviation);
  const DeviationCurve raw_curve =
      raw_oadev ? *raw_oadev : computeDeviation("oadev", rate, InputKind::Rate, tau0, options.deviation);

  fitParts(tau0, options, &r);
  // 3b. The longer-tau terms: the input fit's where the IEEE model describes the input's curve, else the denoised fit's.
  FitResult own_fit;
  if (!input_fit) {
    DeviationCurve weighted = raw_curve;
    FitOptions fo;
    fo.enabled = options.enabled;
    own_fit = fitWithModelEdf(&weighted, fo, options.deviation.confidence);
    input_fit = &own_fit;
  }
  r.longer_tau_from_input = input_fit->ok && !grossMisfit(*input_fit);
  const FitResult& longer = r.longer_tau_from_input ? *input_fit : r.denoised_fit;

  // 4. Wavelet variances of the input and their responses.
  const int J = static_cast<int>(lv.var.size());
  const auto resp = waveletLevelResponses(w, std::max(1, J), tau0);
  const SplitAngleFactors fac = splitAngleFactors(w, r.level);
  r.quantization_kept = fac.v_q;

  // 5. Q (angle) and N (wavelet variance), iterated: each uses the other's current value.
  const AngleVariance av = removedAngleVariance(split.removed, tau0, F, &r);
  // Longer-tau terms (fixed in the level model).
  LevelModel lm{resp, r.levels, J};
  if (longer.ok) {
    if (options.enabled[kBiasInstability]) lm.b2 = std::pow(longer.terms[kBiasInstability].value, 2);
    if (options.enabled[kRateRandomWalk]) lm.k2 = std::pow(longer.terms[kRateRandomWalk].value, 2);
    const Coefficient &b = longer.terms[kBiasInstability], &k = longer.terms[kRateRandomWalk];
    if (lm.b2 > 0) lm.b2_sd = 2.0 * b.value * b.sigma;
    if (lm.k2 > 0) lm.k2_sd = 2.0 * k.value * k.sigma;
  }
  double n2 = r.n_allan * r.n_allan;
  if (!(n2 > 0) && J > 0) n2 = lv.var[static_cast<size_t>(J - 1)] * tau0;  // start from the coarsest level
  describeLevels(lv, J, tau0, &r);
  const double mean_rate = meanOf(rate);
  const double mean_rate_abs = std::fabs(mean_rate);
  QnEstimate qn = iterateQn(lm, fac, av, tau0, n2, mean_rate_abs, options, &r);
  if (!options.keep_signals) {  // the parts are not needed any more: the bootstrap's replicas get their memory
    std::vector<double>().swap(split.denoised);
    std::vector<double>().swap(split.removed);
  }
  sawtoothBootstrap(tau0, static_cast<int64_t>(rate.size()), options, w, fac, mean_rate, &qn, &r);
  recordQn(lm, qn, fac, av, tau0, &r);

  reportCoefficients(options, qn, longer, &r);
  fitErrors(raw_curve, &r);
  r.ok = r.q_angle > 0 && r.n_wavelet > 0;
  if (!r.ok) r.message = "wavelet split found no quantization or no ARW";
  if (options.keep_signals) {
    r.denoised = std::move(split.denoised);
    r.removed = std::move(split.removed);
  }
  return r;
}

}  // namespace gyro_allan
