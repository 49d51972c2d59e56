// Model check: residual of the IEEE 952 fit, evidence for missing effects from the raw samples, joint refit, BIC gate.
#include "gyro_allan/model_check.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <cstdio>
#include <functional>
#include <limits>
#include <memory>
#include <stdexcept>

#include <Eigen/Dense>

#include "gyro_allan/avar_covariance.hpp"
#include "gyro_allan/effects.hpp"
#include "gyro_allan/spectral.hpp"
#include "gyro_allan/stats.hpp"

namespace gyro_allan {
namespace {

std::string fmt(const char* f, double a) {
  char buf[128];
  std::snprintf(buf, sizeof buf, f, a);
  return buf;
}

int countParams(const FitResult& f) {
  int k = 0;
  for (const auto& t : f.terms)
    if (t.value > 0) ++k;
  for (double c : f.extra_c)
    if (c > 0) ++k;
  return k;
}

// How an extra term behaves: deterministic effects (sinusoid, step, warm-up, temperature-driven drift, impulses)
// add an exactly known amount to the AVAR estimate and no estimation noise of their own; stochastic ones do.
enum class Nature { Deterministic, GaussMarkov, Narrowband, Correction };
// Stochastic effects: they trade variance with B and K on the Allan curve (their own BIC margin; candidates only
// where the plain fit's residual is structured).
bool isStochastic(Nature n) { return n == Nature::GaussMarkov || n == Nature::Narrowband; }
struct TermInfo {
  Nature nature = Nature::Deterministic;
  double tc = 0;         // Gauss-Markov correlation time
  double localized = 0;  // record length T when the effect sits at one place in the record (step, warm-up, shocks)
};

// A candidate effect: how to build its ExtraTerm from its nonlinear parameter, where to search it, and what to
// report.
struct Candidate {
  std::string type;
  std::string evidence;
  std::function<ExtraTerm(double)> make;  // argument: the nonlinear parameter (ignored when there is none)
  Nature nature = Nature::Deterministic;
  bool localized = false;
  double p0 = 0, p_lo = 0, p_hi = 0;      // start and log-grid search range (p_lo == p_hi: fixed)
  int n_nonlinear = 0;                    // nonlinear parameters counted in the BIC
  std::map<std::string, EffectParameter> fixed;  // parameters known from the evidence (frequency, time...)
  std::string nonlinear_name;             // name of the searched parameter in the report
  std::string amplitude_name;             // name of sqrt(c) in the report
  double amplitude_sign = 1.0;
  std::vector<double> spectrum_hz, spectrum_weight;  // sinusoid / narrowband: DetectedEffect's spectral content
  double spectrum_bin_hz = 0;
  bool used = false;
};

// A model: fit plus the extra terms, and the curve weighted for it.
struct Model {
  bool ok = false;
  FitResult fit;
  std::vector<ExtraTerm> extra;
  std::vector<TermInfo> info;
  DeviationCurve weighted;   // curve with EDF from this model's stochastic part
  int n_nonlinear = 0;
  double bic = std::numeric_limits<double>::infinity();
};

struct Trial {
  Model model;
  double p = 0, p_sigma = 0;
  ExtraTerm term;
};

// Stochastic and deterministic parts of a model at tau, and the power-law alpha of its dominant stochastic term
// (Q: 2, N: 0, B: -1, K and R: -2; Gauss-Markov -2 below its correlation time, 0 above; narrowband and
// short-correlation terms add variance but never set alpha).
struct Parts {
  double stochastic = 0, deterministic = 0;
  double localized = 0;   // part of `deterministic` from localized effects
  double record = 0;      // their record length
  int alpha = 0;
};
Parts modelParts(const FitResult& fit, const std::vector<ExtraTerm>& extra, const std::vector<TermInfo>& info,
                 double tau) {
  static const int kAlpha[kNumTerms] = {2, 0, -1, -2, -2};
  Parts p;
  double best = -1;
  auto stochastic = [&](double v, int alpha) {
    p.stochastic += v;
    if (v > best) {
      best = v;
      p.alpha = alpha;
    }
  };
  for (int t = 0; t < kNumTerms; ++t) stochastic(termVariance(fit, t, tau), kAlpha[t]);
  for (size_t e = 0; e < extra.size() && e < fit.extra_c.size(); ++e) {
    const double v = fit.extra_c[e] * extra[e].basis(tau);
    switch (info[e].nature) {
      case Nature::Deterministic:
        p.deterministic += v;
        if (info[e].localized > 0) {
          p.localized += v;
          p.record = info[e].localized;
        }
        break;
      case Nature::GaussMarkov: stochastic(v, tau < info[e].tc ? -2 : 0); break;
      case Nature::Narrowband: p.stochastic += v; break;  // its EDF is left to the broadband terms
      case Nature::Correction: p.stochastic += v; break;  // negative correction of the white level
    }
  }
  return p;
}

// Copy of the curve with alpha and EDF from the model's stochastic part.
DeviationCurve weightFor(const DeviationCurve& curve, const FitResult& fit, const std::vector<ExtraTerm>& extra,
                         const std::vector<TermInfo>& info) {
  DeviationCurve w = curve;
  for (auto& p : w.points) p.alpha = modelParts(fit, extra, info, p.tau).alpha;
  fillConfidence(&w, 0.683);
  return w;
}

// Number of used points within +-1/2 octave of each point (the fit's own decorrelation rule).
std::vector<int> densityCounts(const DeviationCurve& curve, const std::vector<bool>& used) {
  std::vector<int> count(curve.points.size(), 1);
  for (size_t i = 0; i < curve.points.size(); ++i) {
    int c = 0;
    for (size_t j = 0; j < curve.points.size(); ++j) {
      if (j >= used.size() || !used[j]) continue;
      const double ratio = curve.points[j].tau / curve.points[i].tau;
      if (ratio >= M_SQRT1_2 * (1 - 1e-12) && ratio < M_SQRT2 * (1 - 1e-12)) ++c;
    }
    count[i] = std::max(1, c);
  }
  return count;
}

// BIC from a Gaussian likelihood of the AVAR estimates: each estimate has variance 2 s (s + 2 d) / edf, with s the
// model's stochastic and d its deterministic part at that tau (a deterministic effect shifts the estimate but adds
// only a cross term to its scatter); each point counts 1/density (correlated neighbours), k ln(n_eff) penalty.
double modelBic(const Model& m) {
  // Also for GLS fits. Their generalized chi-squared alone cannot tell a deterministic effect from the IEEE term it
  // resembles: a bias step, warm-up or temperature drift has nearly K's shape and the plain GLS fit absorbs it into
  // K with chi2_p 0.15-0.9 (check_study tuning seeds), so that chi2 + k ln(n) gained -3..+3 with the (12-sigma) step
  // in the model and found none of 90 injected steps/warm-ups. What separates them is the scatter each model
  // predicts (K's long-tau estimates scatter, a deterministic effect's hardly), i.e. the log-determinant term of
  // -2 ln L, which this likelihood has and the GLS chi-squared does not.
  const DeviationCurve& c = m.weighted;
  const std::vector<int> count = densityCounts(c, m.fit.used);
  double nll = 0, n_eff = 0;
  for (size_t i = 0; i < c.points.size(); ++i) {
    if (i >= m.fit.used.size() || !m.fit.used[i]) continue;
    const auto& p = c.points[i];
    if (!(p.edf > 0) || !(p.var > 0)) continue;
    const Parts parts = modelParts(m.fit, m.extra, m.info, p.tau);
    const double total = parts.stochastic + parts.deterministic;
    if (!(total > 0)) continue;
    const double s = std::max(parts.stochastic, 1e-6 * total);
    // Cross term of noise and a deterministic effect: 4 s d / edf when the effect is spread over the record; a
    // localized one (step, warm-up) meets only the noise of the few tau-windows around it, variance about
    // 6 s d tau / (T - 2 tau).
    const double spread = parts.deterministic - parts.localized;
    double var = 2.0 * s * (s + 2.0 * spread) / p.edf;
    if (parts.localized > 0) {
      const double span = std::max(parts.record - 2.0 * p.tau, p.tau);
      var += std::max(4.0 / p.edf, 6.0 * p.tau / span) * s * parts.localized;
    }
    const double r = p.var - total;
    const double w = 1.0 / count[i];
    nll += w * (r * r / var + std::log(var));
    n_eff += w;
  }
  return nll + (countParams(m.fit) + m.n_nonlinear) * std::log(std::max(2.0, n_eff));
}

// Fits the model with extra terms, iterating the weights (EDF from the model's own stochastic part). Two starts:
// the previous model's weighting, and the same model with its rate random walk and ramp removed (the weighting a
// deterministic effect would give if it, not K or R, explains the long-tau rise; only when
// may_replace_long_terms); the better BIC wins.
Model fitModel(const DeviationCurve& curve, const Model& previous, const FitOptions& fo,
               const std::vector<ExtraTerm>& extra, const std::vector<TermInfo>& info, int n_nonlinear,
               bool may_replace_long_terms) {
  auto from = [&](const DeviationCurve& start, const FitOptions& o) {
    Model m;
    m.extra = extra;
    m.info = info;
    m.n_nonlinear = n_nonlinear;
    FitOptions values_only = o;  // the first pass gives only the weights of the second
    values_only.intervals = false;
    FitResult f = fitNoiseModel(start, values_only, extra);
    if (!f.ok) return m;
    m.weighted = weightFor(curve, f, extra, info);
    m.fit = fitNoiseModel(m.weighted, o, extra);
    if (!m.fit.ok) return m;
    m.weighted = weightFor(curve, m.fit, extra, info);
    m.ok = true;
    m.bic = modelBic(m);
    return m;
  };
  Model best = from(previous.weighted, fo);
  const bool long_terms = previous.fit.terms[kRateRandomWalk].value > 0 || previous.fit.terms[kRateRamp].value > 0;
  if (long_terms && may_replace_long_terms && !extra.empty()) {
    FitResult shortTau = previous.fit;
    shortTau.terms[kRateRandomWalk] = Coefficient{};
    shortTau.terms[kRateRamp] = Coefficient{};
    const DeviationCurve w = weightFor(curve, shortTau, previous.extra, previous.info);
    Model b = from(w, fo);
    if (b.ok && (!best.ok || b.bic < best.bic)) best = b;
    // The new effect as the explanation of the long-tau rise instead of K and R: a bias step or a warm-up has
    // nearly the shape of rate random walk at tau << T, so NNLS may hand everything to K. Fit without K and R,
    // then once more with them enabled at those weights (bounds for K and R, or K back if the data need it).
    FitOptions no_long = fo;
    no_long.enabled[kRateRandomWalk] = false;
    no_long.enabled[kRateRamp] = false;
    Model c = from(w, no_long);
    if (c.ok) {
      Model full = c;
      full.fit = fitNoiseModel(c.weighted, fo, extra);
      if (full.fit.ok && !full.fit.extra_c.empty() && full.fit.extra_c.back() > 0) {
        full.weighted = weightFor(curve, full.fit, extra, info);
        full.bic = modelBic(full);
        if (full.bic <= c.bic + 2.0) c = full;  // keep the bounds unless they cost the fit
      }
      // K and R left out: report them at 0 (the model drawn has none), unsupported, with the upper ends of the
      // intervals of the fit that had them (Kalibr takes K's bound).
      for (int t : {kRateRandomWalk, kRateRamp}) {
        if (c.fit.terms[t].supported || !full.fit.ok) continue;
        const Coefficient& fc = full.fit.terms[t];
        Coefficient b{0.0, fc.supported ? fc.value + fc.sigma : fc.sigma, false};
        b.hi68 = b.sigma;
        b.hi95 = std::max(b.sigma, fc.hi95);
        c.fit.terms[t] = b;
      }
      if (!best.ok || c.bic < best.bic) best = c;
    }
  }
  return best;
}

// Excess of a broad PSD feature over a smooth floor, on consecutive bins of one PSD.
struct FeatureExcess {
  bool ok = false;
  double f_start = 0, df = 0;
  std::vector<double> power;  // (PSD - floor) x df per bin; tail bins may be slightly negative (estimation noise)
  double total = 0;           // sum of power (units^2)
  double lo = 0, hi = 0;      // extent of the feature, Hz
  double floor_rho = 0;       // b / (2 a) of the floor a + b cos(2 pi f tau0): the lag-1 correlation of an MA(1) floor
  int iterations = 0;
};

// Measures the whole feature around f0 (half-power width w), tails included. The floor under it is
// a + b cos(2 pi f tau0): the PSD of the model's own short-tau noise, white rate noise (N), white angle noise seen
// as rate differences (Q) and a one-sample filter (MA(1), the short-correlation term) all have that shape over the
// whole band (on the ADIS16405 x/y gyros it matches the PSD from 1 Hz to Nyquist within 1 %). It is fitted by least
// squares on every bin outside the current extent (a fit on local flanks let a long tail tilt the floor and cut the
// extent short: chi2/dof 4.4 instead of 0.6 on a simulated 5 Hz feature); the extent then grows by blocks of
// max(8, w/2) bins while a block's mean stands above the floor by more than 3 sigma of a Welch block mean (relative
// sigma sqrt(1.5 / (segments x bins)), Hann: 1.5 bins per independent value); repeated until the extent no longer
// changes. Starting extent f0 +- 2 w.
FeatureExcess measureFeatureExcess(const Psd& ps, double f0, double w, double tau0) {
  FeatureExcess fe;
  const size_t nb = ps.f.size();
  if (nb < 32 || !(ps.df > 0) || ps.segments < 1 || !(w > 0)) return fe;
  const double df = ps.df;
  const int block = std::max(8, static_cast<int>(std::lround(w / (2 * df))));
  const double rel = std::sqrt(1.5 / (static_cast<double>(ps.segments) * block));
  const double z_min = 3.0;
  const size_t first = std::min<size_t>(6, nb - 1);  // as findPsdPeaks: the lowest bins carry flicker / drift
  const double f_min = ps.f[first], f_max = ps.f[nb - 1];
  double lo = std::max(f_min, f0 - 2 * w), hi = std::min(f_max, f0 + 2 * w);
  double a = 0, b = 0;
  auto floorAt = [&](double f) { return a + b * std::cos(2 * M_PI * f * tau0); };
  for (int it = 0; it < 12; ++it) {
    fe.iterations = it + 1;
    double sw = 0, sx = 0, sxx = 0, sy = 0, sxy = 0;
    for (size_t i = first; i < nb; ++i) {
      const double f = ps.f[i];
      if (f >= lo && f <= hi) continue;
      const double x = std::cos(2 * M_PI * f * tau0);
      sw += 1;
      sx += x;
      sxx += x * x;
      sy += ps.p[i];
      sxy += x * ps.p[i];
    }
    if (sw < 8) return fe;
    const double det = sw * sxx - sx * sx;
    if (std::fabs(det) > 1e-12 * sw * sw) {
      b = (sw * sxy - sx * sy) / det;
      a = (sy - b * sx) / sw;
    } else {  // flanks too narrow for a trend: flat floor
      b = 0;
      a = sy / sw;
    }
    // Block mean of the PSD over [f_a, f_b) relative to the floor; false when too few bins.
    auto blockExcess = [&](double f_a, double f_b, double* excess) {
      double sp = 0, sf = 0;
      int cnt = 0;
      const size_t start = static_cast<size_t>(std::lower_bound(ps.f.begin(), ps.f.end(), f_a) - ps.f.begin());
      for (size_t i = std::max(first, start); i < nb && ps.f[i] < f_b; ++i) {
        sp += ps.p[i];
        sf += floorAt(ps.f[i]);
        ++cnt;
      }
      if (cnt < block / 2 || !(sf > 0)) return false;
      *excess = sp / sf - 1.0;
      return true;
    };
    double nlo = lo, nhi = hi, ex = 0;
    while (nlo > f_min && blockExcess(nlo - block * df, nlo, &ex) && ex > z_min * rel) nlo -= block * df;
    while (nhi < f_max && blockExcess(nhi + df * 0.5, nhi + (block + 0.5) * df, &ex) && ex > z_min * rel)
      nhi += block * df;
    nlo = std::max(nlo, f_min);
    nhi = std::min(nhi, f_max);
    const bool same = std::fabs(nlo - lo) < 0.5 * df && std::fabs(nhi - hi) < 0.5 * df;
    lo = nlo;
    hi = nhi;
    if (same) break;
  }
  size_t i0 = nb, i1 = 0;
  for (size_t i = first; i < nb; ++i)
    if (ps.f[i] >= lo - 0.5 * df && ps.f[i] <= hi + 0.5 * df) {
      i0 = std::min(i0, i);
      i1 = i;
    }
  if (i0 >= nb || i1 < i0) return fe;
  for (size_t i = i0; i <= i1; ++i) {
    const double fl = floorAt(ps.f[i]);
    if (!(fl > 0)) return fe;  // the floor must be a power spectrum
    fe.power.push_back((ps.p[i] - fl) * df);
    fe.total += fe.power.back();
  }
  if (!(fe.total > 0)) return fe;
  fe.f_start = ps.f[i0];
  fe.df = df;
  fe.lo = ps.f[i0];
  fe.hi = ps.f[i1];
  fe.floor_rho = a > 0 ? b / (2 * a) : 0.0;
  fe.ok = true;
  return fe;
}

// RMS of log10(measured/model ADEV) over a fixed set of points (the same for every model compared).
double rmsLog10(const DeviationCurve& curve, const std::vector<double>& model, const std::vector<bool>& mask) {
  double s = 0;
  int n = 0;
  for (size_t i = 0; i < curve.points.size(); ++i) {
    if (!mask[i] || !(model[i] > 0) || !(curve.points[i].var > 0)) continue;
    const double l = 0.5 * std::log10(curve.points[i].var / model[i]);
    s += l * l;
    ++n;
  }
  return n > 0 ? std::sqrt(s / n) : std::numeric_limits<double>::quiet_NaN();
}

}  // namespace

FitResult fitWithModelEdf(DeviationCurve* curve, const FitOptions& options, double confidence) {
  FitOptions values_only = options;  // the first pass gives only the EDF of the second
  values_only.intervals = false;
  FitResult f = fitNoiseModel(*curve, values_only);
  if (!f.ok) return f;
  *curve = withModelEdf(*curve, f, confidence);
  return fitNoiseModel(*curve, options);
}

DeviationCurve withModelEdf(const DeviationCurve& curve, const FitResult& fit, double confidence) {
  if (fit.model_var.size() != curve.points.size())
    throw std::invalid_argument("withModelEdf: fit does not belong to the curve (point counts differ)");
  static const int kAlpha[kNumTerms] = {2, 0, -1, -2, -2};
  DeviationCurve out = curve;
  for (auto& p : out.points) {
    int best = kAngleRandomWalk;
    double best_v = -1;
    for (int t = 0; t < kNumTerms; ++t) {
      const double v = termVariance(fit, t, p.tau);
      if (v > best_v) {
        best_v = v;
        best = t;
      }
    }
    p.alpha = kAlpha[best];
  }
  fillConfidence(&out, confidence);
  return out;
}

ResidualAnalysis analyzeResidual(const DeviationCurve& curve, const std::vector<double>& model_var,
                                 const std::vector<bool>& used, double chi2_dof) {
  ResidualAnalysis ra;
  ra.chi2_dof = chi2_dof;
  for (size_t i = 0; i < curve.points.size() && i < model_var.size() && i < used.size(); ++i) {
    if (!used[i] || !(model_var[i] > 0)) continue;
    const auto& p = curve.points[i];
    double edf = p.edf;
    if (!(edf > 0)) edf = static_cast<double>(curve.n_phase) / p.m - 1.0;
    ra.tau.push_back(p.tau);
    ra.z.push_back(std::sqrt(0.5 * edf) * (p.var / model_var[i] - 1.0));
  }
  const size_t n = ra.z.size();
  if (n < 4) {
    ra.summary = "too few points to test the residual";
    return ra;
  }
  // Wald-Wolfowitz runs test on the signs.
  double np = 0, nm = 0;
  for (double z : ra.z) (z >= 0 ? np : nm) += 1;
  ra.runs = 1;
  for (size_t i = 1; i < n; ++i)
    if ((ra.z[i] >= 0) != (ra.z[i - 1] >= 0)) ++ra.runs;
  const double nn = np + nm;
  ra.runs_expected = 2 * np * nm / nn + 1;
  const double var = 2 * np * nm * (2 * np * nm - nn) / (nn * nn * (nn - 1));
  ra.runs_z = var > 0 ? (ra.runs - ra.runs_expected) / std::sqrt(var) : 0.0;
  // Most significant same-sign stretch.
  size_t start = 0;
  for (size_t i = 1; i <= n; ++i) {
    if (i == n || (ra.z[i] >= 0) != (ra.z[start] >= 0)) {
      double s = 0;
      for (size_t j = start; j < i; ++j) s += ra.z[j];
      const double bz = s / std::sqrt(static_cast<double>(i - start));
      if (std::fabs(bz) > std::fabs(ra.bump_z)) {
        ra.bump_z = bz;
        ra.bump_tau_lo = ra.tau[start];
        ra.bump_tau_hi = ra.tau[i - 1];
      }
      start = i;
    }
  }
  const size_t k = std::min<size_t>(4, n / 2);
  double s0 = 0, s1 = 0;
  for (size_t i = 0; i < k; ++i) {
    s0 += ra.z[i];
    s1 += ra.z[n - 1 - i];
  }
  ra.short_trend_z = s0 / std::sqrt(static_cast<double>(k));
  ra.long_trend_z = s1 / std::sqrt(static_cast<double>(k));
  ra.descriptive_structure = ra.runs_z < -3 || std::fabs(ra.bump_z) > 5 || std::fabs(ra.short_trend_z) > 4 ||
                             std::fabs(ra.long_trend_z) > 4;
  ra.structured = ra.descriptive_structure;
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "chi2/dof %.2f; %d runs of sign vs %.1f expected (z = %.1f); largest stretch %s the model at tau "
                "%.3g-%.3g s (z = %.1f); short-tau z %.1f, long-tau z %.1f: %s",
                chi2_dof, ra.runs, ra.runs_expected, ra.runs_z, ra.bump_z >= 0 ? "above" : "below", ra.bump_tau_lo,
                ra.bump_tau_hi, ra.bump_z, ra.short_trend_z, ra.long_trend_z,
                ra.structured ? "structured (descriptive rule, uncalibrated)" : "no clear structure (descriptive)");
  ra.summary = buf;
  return ra;
}

ResidualAnalysis analyzeResidual(const DeviationCurve& curve, const FitResult& fit,
                                 const std::vector<ExtraTerm>& /*extra: their share is in fit.model_var*/,
                                 double alpha) {
  ResidualAnalysis ra = analyzeResidual(curve, fit.model_var, fit.used, fit.chi2_dof);
  ra.alpha = alpha;
  if (!fit.gls || !fit.ok || fit.gls_used.size() != curve.points.size() || !(curve.tau0 > 0)) return ra;
  // Whitened residual at the fit's octave-spaced points, with the covariance the fit uses: the analytic covariance
  // of the IEEE part at the fitted coefficients, each point's row and column scaled by model / IEEE part where extra
  // terms add to it (noise_model_gls.cpp does the same).
  std::vector<int> idx;
  std::vector<int64_t> ms, ns;
  for (size_t i = 0; i < curve.points.size(); ++i) {
    if (!fit.gls_used[i]) continue;
    const auto& p = curve.points[i];
    if (p.m < 1 || p.n_terms < 1 || !(fit.model_var[i] > 0)) return ra;
    idx.push_back(static_cast<int>(i));
    ms.push_back(p.m);
    ns.push_back(p.n_terms);
  }
  const int n = static_cast<int>(idx.size());
  if (n < 4) return ra;
  std::array<double, 5> sq{{0, 0, 0, 0, 0}};
  for (int t = 0; t < kNumTerms; ++t)
    if (fit.terms[t].value > 0) sq[t] = fit.terms[t].value * fit.terms[t].value;
  Eigen::MatrixXd cov;
  try {
    cov = avarCovariance(*sharedAvarCovarianceBasis(ms, ns, curve.tau0), sq);  // the fit's own basis (kept)
  } catch (const std::exception&) {
    return ra;
  }
  Eigen::VectorXd r(n);
  for (int k = 0; k < n; ++k) {
    const size_t i = static_cast<size_t>(idx[k]);
    const auto& p = curve.points[i];
    double ieee = 0;
    for (int t = 0; t < kNumTerms; ++t) ieee += termVariance(fit, t, p.tau);
    const double ratio = ieee > 0 ? fit.model_var[i] / ieee : 1.0;
    cov.row(k) *= ratio;
    cov.col(k) *= ratio;
    r[k] = p.var - fit.model_var[i];
  }
  for (int k = 0; k < n; ++k) {
    if (!(cov(k, k) > 0)) {
      const auto& p = curve.points[static_cast<size_t>(idx[k])];
      const double e = p.edf > 0 ? p.edf : static_cast<double>(curve.n_phase) / p.m - 1.0;
      cov.row(k).setZero();
      cov.col(k).setZero();
      cov(k, k) = 2.0 * p.var * p.var / std::max(1.0, e);
    }
    cov(k, k) *= 1.0 + 1e-9;
  }
  Eigen::LLT<Eigen::MatrixXd> llt(cov);
  for (int attempt = 0; llt.info() != Eigen::Success && attempt < 6; ++attempt) {
    for (int k = 0; k < n; ++k) cov(k, k) *= 1.0 + std::pow(10.0, attempt - 7);
    llt.compute(cov);
  }
  if (llt.info() != Eigen::Success) return ra;
  const Eigen::VectorXd w = llt.matrixL().solve(r);
  for (int k = 0; k < n; ++k) {
    ra.whitened_tau.push_back(curve.points[static_cast<size_t>(idx[k])].tau);
    ra.whitened.push_back(w[k]);
  }
  // Exact Wald-Wolfowitz distribution of the number of runs given the counts of each sign: P(runs <= observed).
  int n1 = 0, n2 = 0;
  for (double v : ra.whitened) (v >= 0 ? n1 : n2) += 1;
  ra.whitened_runs = 1;
  for (int k = 1; k < n; ++k)
    if ((ra.whitened[k] >= 0) != (ra.whitened[k - 1] >= 0)) ++ra.whitened_runs;
  ra.whitened_runs_expected = 2.0 * n1 * n2 / n + 1.0;
  if (n1 > 0 && n2 > 0) {
    auto lchoose = [](int a, int b) {
      if (b < 0 || b > a) return -HUGE_VAL;
      return std::lgamma(a + 1.0) - std::lgamma(b + 1.0) - std::lgamma(a - b + 1.0);
    };
    const double total = lchoose(n, n1);
    double p = 0;
    for (int runs = 2; runs <= ra.whitened_runs; ++runs) {
      const int k = runs / 2;
      double pr;
      if (runs % 2 == 0)
        pr = 2.0 * std::exp(lchoose(n1 - 1, k - 1) + lchoose(n2 - 1, k - 1) - total);
      else
        pr = std::exp(lchoose(n1 - 1, k - 1) + lchoose(n2 - 1, k) - total) +
             std::exp(lchoose(n1 - 1, k) + lchoose(n2 - 1, k - 1) - total);
      p += pr;
    }
    ra.whitened_runs_p = std::min(1.0, p);
  }
  ra.calibrated = true;
  ra.chi2 = fit.chi2;
  ra.dof = fit.dof;
  ra.chi2_p = std::isfinite(fit.chi2_p) ? fit.chi2_p : 1.0;
  ra.p_value = std::min(1.0, 2.0 * std::min(ra.chi2_p, ra.whitened_runs_p));
  ra.structured = ra.p_value < alpha;
  char buf[768];
  std::snprintf(buf, sizeof buf,
                "generalized chi2 %.1f / %d dof (p = %.3g); %d runs of sign of the whitened residual vs %.1f expected "
                "(p = %.3g); combined p = %.3g: %s at %.3g. Descriptive: %s",
                ra.chi2, ra.dof, ra.chi2_p, ra.whitened_runs, ra.whitened_runs_expected, ra.whitened_runs_p,
                ra.p_value, ra.structured ? "structured" : "consistent with the model", alpha, ra.summary.c_str());
  ra.summary = buf;
  return ra;
}

namespace {

// ---- checkModel, stage by stage -------------------------------------------------------------------------------

// What every stage of checkModel reads: the record, its curve, the options and the record's size.
struct CheckInput {
  const std::vector<double>& rate;
  double tau0;
  const DeviationCurve& curve;
  const ModelCheckOptions& opts;
  const std::vector<double>* temperature;
  int64_t n;  // samples
  double T;   // record length, s
  double fs;  // sample rate, Hz
};

// Rejects inputs checkModel cannot work on (std::invalid_argument).
void validateInputs(const std::vector<double>& rate, double tau0, const DeviationCurve& curve, const FitResult& fit,
                    const std::vector<double>* temperature) {
  if (!(tau0 > 0) || !std::isfinite(tau0)) throw std::invalid_argument("checkModel: tau0 must be positive");
  if (rate.size() < 64) throw std::invalid_argument("checkModel: need at least 64 rate samples");
  for (double v : rate)
    if (!std::isfinite(v)) throw std::invalid_argument("checkModel: non-finite rate sample");
  if (curve.points.empty()) throw std::invalid_argument("checkModel: empty Allan-variance curve");
  if (fit.model_var.size() != curve.points.size())
    throw std::invalid_argument("checkModel: fit does not belong to the curve (point counts differ)");
  if (temperature && temperature->size() != rate.size())
    throw std::invalid_argument("checkModel: temperature series length differs from the rate series");
}

// The answer when no model could be checked: the given fit before and after, and why.
ModelCheck unchecked(ModelCheck mc, const FitResult& fit, const std::string& message) {
  mc.message = message;
  mc.fit_after = fit;
  mc.model_var_before = mc.model_var_after = fit.model_var;
  return mc;
}

// The plain IEEE model again, with EDF from its own noise terms (not from the data's noise identification), so
// that it is weighted exactly like the models with effects it is compared with.
Model refitBase(const CheckInput& in, const FitResult& fit) {
  Model given;
  given.fit = fit;
  given.weighted = weightFor(in.curve, fit, {}, {});
  return fitModel(in.curve, given, in.opts.fit, {}, {}, 0, false);
}

// Points the RMS log10 error is taken over, the same for every model compared: enough EDF under the base model.
std::vector<bool> rmsMask(const CheckInput& in, const Model& base) {
  std::vector<bool> rms_mask(in.curve.points.size(), false);
  for (size_t i = 0; i < in.curve.points.size(); ++i)
    rms_mask[i] = base.weighted.points[i].edf >= in.opts.fit.rms_min_edf && in.curve.points[i].var > 0;
  return rms_mask;
}

// The plain model's figures in the report (mc.before, its fit and residual).
void recordBefore(const CheckInput& in, const Model& base, const std::vector<bool>& rms_mask, ModelCheck* mc) {
  mc->fit_before = base.fit;
  mc->model_var_before = base.fit.model_var;
  mc->before.rms_log10 = rmsLog10(in.curve, base.fit.model_var, rms_mask);
  mc->before.chi2_dof = base.fit.chi2_dof;
  mc->before.bic = base.bic;
  mc->before.n_params = countParams(base.fit);
  mc->residual_before = analyzeResidual(base.weighted, base.fit, {}, in.opts.structured_alpha);
}

// Candidate::make of every candidate type: a term named `name` with AVAR basis(p, tau), p the candidate's
// nonlinear parameter (ignored by types without one).
std::function<ExtraTerm(double)> termMaker(const std::string& name, std::function<double(double, double)> basis) {
  return [name, basis](double p) {
    ExtraTerm e;
    e.name = name;
    e.basis = [basis, p](double tau) { return basis(p, tau); };
    return e;
  };
}

// Largest power of two <= v (1 for v < 2).
int64_t pow2Below(int64_t v) {
  int64_t p = 1;
  while (p * 2 <= v) p *= 2;
  return p;
}

// Spectral features of the record: peaks (duplicates across resolutions merged), which are broad, and the measured
// excess of the broad ones.
struct SpectralFeatures {
  std::vector<SpectralPeak> peaks;
  std::vector<bool> broad;            // wider than 4 bins at the finest resolution it was seen at: not a line
  std::vector<FeatureExcess> excess;  // parallel to peaks (ok only for measured broad features)
  std::vector<SpectralLine> lines;    // lines refined on the samples: the slow ones, then the Welch lines (parallel
  std::vector<int> line_of_peak;      // to peaks: index in lines, -1 for a broad feature)
  int64_t coarse = 0;                 // segment length of the coarse PSD
  int64_t fine = 0;                   // segment length of the fine PSD
  LineSearchBand band;                // where refineLines looked for lines (zero when it did not)
};

// The two bands of the line search: the whole-record periodogram from line_min_periods per record up to 32 bins of
// the fine Welch PSD (segments of `fine` samples), the Welch PSD above; each band's whole-record bins.
LineSearchBand lineSearchBand(const CheckInput& in, int64_t fine) {
  LineSearchBand b;
  b.slow_lo_hz = in.opts.line_min_periods / in.T;
  b.slow_hi_hz = std::min(32.0 * in.fs / static_cast<double>(fine), 0.45 * in.fs);
  b.nyquist_hz = 0.5 * in.fs;
  b.slow_frequencies = std::max(0, static_cast<int>(std::floor((b.slow_hi_hz - b.slow_lo_hz) * in.T)));
  b.welch_frequencies = std::max(1, static_cast<int>((b.nyquist_hz - b.slow_hi_hz) * in.T));
  b.false_alarm_each = 0.5 * in.opts.line_false_alarm;
  return b;
}

// Welch PSD peaks at a fine and a coarse resolution, the same feature found at both merged.
SpectralFeatures findSpectralFeatures(const CheckInput& in) {
  const int64_t n = in.n;
  SpectralFeatures sf;
  const int64_t fine = std::min<int64_t>(pow2Below(n / 8), 65536);
  sf.fine = fine;
  sf.coarse = std::min<int64_t>(1024, pow2Below(n / 32));
  std::vector<SpectralPeak> all;
  for (int64_t seg : {fine, sf.coarse}) {
    if (seg < 64) continue;
    const Psd psd = welchPsd(in.rate, in.fs, seg, 0.5);
    for (const auto& pk : findPsdPeaks(psd, in.opts.psd_min_prominence_db, in.opts.psd_max_peaks)) all.push_back(pk);
  }
  // Merge duplicates: the same feature found at both resolutions. A feature no wider than 4 bins of the finest PSD
  // it was found in is a line (sinusoid); wider ones are narrowband oscillations (a 0.3 Hz wide feature is 3
  // coarse bins but 100 fine ones: not a line).
  std::sort(all.begin(), all.end(), [](const SpectralPeak& a, const SpectralPeak& b) { return a.df < b.df; });
  std::vector<SpectralPeak>& kept = sf.peaks;
  for (const auto& pk : all) {
    bool dup = false;
    for (size_t j = 0; j < kept.size(); ++j) {
      SpectralPeak& k = kept[j];
      const double sep = std::fabs(k.frequency_hz - pk.frequency_hz);
      if (sep <= std::max({k.bandwidth_hz, pk.bandwidth_hz, 2 * pk.df})) {
        dup = true;
        // A fine-resolution detection that is broad in its own bins is better described by the coarse one.
        if (k.bandwidth_hz > 4 * k.df && pk.bandwidth_hz > 4 * k.df) k = pk;
        break;
      }
    }
    if (!dup) {
      kept.push_back(pk);
      sf.broad.push_back(pk.bandwidth_hz > 4 * pk.df);
    }
  }
  return sf;
}

// Broad features: measure the whole excess, tails included, over an MA(1)-shaped floor on a mid-resolution PSD
// (>= ~250 segments, so each bin is within ~6 %; measureFeatureExcess).
// A feature narrower than 16 bins of that PSD gets a finer one (down to ~64 segments), so that its shape is
// resolved rather than the Hann window's.
void measureBroadFeatures(const CheckInput& in, SpectralFeatures* sf) {
  const int64_t n = in.n;
  const double fs = in.fs;
  std::vector<SpectralPeak>& kept = sf->peaks;
  std::vector<bool>& kept_broad = sf->broad;
  const int64_t mid = std::min<int64_t>(8192, pow2Below(n / 128));
  std::map<int64_t, Psd> mid_psd;
  auto psdFor = [&](int64_t seg) -> const Psd& {
    auto it = mid_psd.find(seg);
    if (it == mid_psd.end()) it = mid_psd.emplace(seg, welchPsd(in.rate, fs, seg, 0.5)).first;
    return it->second;
  };
  std::vector<FeatureExcess>& excess = sf->excess;
  excess.assign(kept.size(), FeatureExcess{});
  auto segFor = [&](double width) {
    int64_t seg = mid;
    while (seg < pow2Below(n / 32) && fs / seg > width / 16) seg *= 2;
    return seg;
  };
  for (size_t k = 0; k < kept.size(); ++k) {
    const SpectralPeak& pk = kept[k];
    if (!kept_broad[k] && pk.bandwidth_hz <= 4 * pk.df) {
      // Seen only as a line on a coarse PSD (a feature broader than the running median of the fine one is not
      // found there): its half-power width on a PSD resolving it decides.
      const int64_t seg = segFor(pk.bandwidth_hz);
      if (seg < 64 || fs / seg >= pk.df / 2) continue;
      const FeatureExcess fe = measureFeatureExcess(psdFor(seg), pk.frequency_hz, pk.bandwidth_hz, in.tau0);
      if (!fe.ok) continue;
      size_t top = 0;
      for (size_t i = 1; i < fe.power.size(); ++i)
        if (fe.power[i] > fe.power[top]) top = i;
      size_t a = top, b = top;
      while (a > 0 && fe.power[a - 1] >= 0.5 * fe.power[top]) --a;
      while (b + 1 < fe.power.size() && fe.power[b + 1] >= 0.5 * fe.power[top]) ++b;
      if (static_cast<double>(b - a + 1) <= 4.0) continue;  // a line there too
      kept_broad[k] = true;
      kept[k].bandwidth_hz = (b - a + 1) * fe.df;
    }
    const int64_t seg = segFor(pk.bandwidth_hz);
    if (seg <= sf->coarse || seg < 64) continue;
    excess[k] = measureFeatureExcess(psdFor(seg), pk.frequency_hz, kept[k].bandwidth_hz, in.tau0);
  }
}

// Lines refined on the samples. From line_min_periods per record up to 32 bins of the fine Welch PSD: the
// whole-record periodogram (findSlowLines). The Welch search starts at 6 of its bins and needs a line to stand 8 dB
// above its floor, ~14 periods per segment for a line at the white-noise ADEV of tau = 0.37/f; the whole record
// sees such a line ~8x more strongly, and the band overlaps the Welch one. A Welch peak within two of its bins of such a line is the same line; a slow line inside a broad
// Welch feature is part of it and dropped. Every other Welch line is refined on the samples within +-1.5 of its bins
// (refineLine), its noise level the PSD floor there.
void refineLines(const CheckInput& in, SpectralFeatures* sf) {
  sf->band = lineSearchBand(in, sf->fine);
  const LineSearchBand& band = sf->band;
  const double f_lo = band.slow_lo_hz, f_hi = band.slow_hi_hz;
  std::vector<SpectralLine> slow;
  if (sf->fine >= 64 && f_hi > f_lo)
    slow = findSlowLines(in.rate, in.fs, f_lo, f_hi, band.false_alarm_each, in.opts.psd_max_peaks);
  std::vector<SpectralPeak> peaks;
  std::vector<bool> broad;
  std::vector<FeatureExcess> excess;
  std::vector<bool> slow_kept(slow.size(), true);
  for (size_t k = 0; k < sf->peaks.size(); ++k) {
    const SpectralPeak& pk = sf->peaks[k];
    bool same = false;
    for (size_t s = 0; s < slow.size(); ++s) {
      const double sep = std::fabs(slow[s].frequency_hz - pk.frequency_hz);
      if (sf->broad[k] && sep <= std::max(pk.bandwidth_hz, 2 * pk.df)) slow_kept[s] = false;
      if (!sf->broad[k] && sep <= 2 * pk.df) same = true;
    }
    if (same) continue;
    peaks.push_back(pk);
    broad.push_back(sf->broad[k]);
    excess.push_back(sf->excess[k]);
  }
  sf->lines.clear();
  sf->line_of_peak.clear();
  std::vector<SpectralPeak> out_peaks;
  std::vector<bool> out_broad;
  std::vector<FeatureExcess> out_excess;
  for (size_t s = 0; s < slow.size(); ++s) {
    if (!slow_kept[s]) continue;
    SpectralPeak pk;  // the slow line as a feature of its own periodogram (one bin of width 1/T)
    pk.frequency_hz = slow[s].frequency_hz;
    pk.df = 1.0 / in.T;
    pk.bandwidth_hz = pk.df;
    pk.amplitude = slow[s].amplitude;
    pk.prominence_db = 10.0 * std::log10(slow[s].power_ratio);
    out_peaks.push_back(pk);
    out_broad.push_back(false);
    out_excess.push_back(FeatureExcess{});
    sf->line_of_peak.push_back(static_cast<int>(sf->lines.size()));
    sf->lines.push_back(slow[s]);
  }
  for (size_t k = 0; k < peaks.size(); ++k) {
    out_peaks.push_back(peaks[k]);
    out_broad.push_back(broad[k]);
    out_excess.push_back(excess[k]);
    const bool line = !broad[k] && peaks[k].bandwidth_hz <= 4 * peaks[k].df;
    if (line && peaks[k].floor > 0 && peaks[k].frequency_hz > 1.5 * peaks[k].df &&
        peaks[k].frequency_hz + 1.5 * peaks[k].df < in.fs / 2) {
      SpectralLine l = refineLine(in.rate, in.fs, peaks[k].frequency_hz, 1.5 * peaks[k].df, peaks[k].floor);
      l.frequencies = band.welch_frequencies;
      l.false_alarm = lineFalseAlarm(l.power_ratio, l.frequencies);
      sf->line_of_peak.push_back(static_cast<int>(sf->lines.size()));
      sf->lines.push_back(l);
    } else {
      sf->line_of_peak.push_back(-1);
    }
  }
  sf->peaks = out_peaks;
  sf->broad = out_broad;
  sf->excess = out_excess;
}

// The sinusoid (a line) or narrowband-oscillation candidate of one spectral feature; curve_taus: the curve's taus,
// sorted, where a narrowband basis is tabulated.
Candidate spectralCandidate(const CheckInput& in, const SpectralPeak& pk, bool broad, const FeatureExcess& fe,
                            const SpectralLine* refined, const std::shared_ptr<std::vector<double>>& curve_taus) {
  const double fs = in.fs;
  Candidate c;
  const bool line = !broad && pk.bandwidth_hz <= 4 * pk.df;
  c.type = line ? "sinusoid" : "narrowband";
  c.nature = line ? Nature::Deterministic : Nature::Narrowband;
  char buf[512];
  int len = 0;
  if (refined && pk.df * in.T < 1.5)  // found in the whole-record periodogram (its bin is 1/T)
    len = std::snprintf(buf, sizeof buf,
                        "whole-record periodogram %.1f dB above the noise level at %.4g Hz (false-alarm probability "
                        "%.2g over %d frequencies)",
                        10.0 * std::log10(refined->power_ratio), refined->frequency_hz, refined->false_alarm,
                        refined->frequencies);
  else
    len = std::snprintf(buf, sizeof buf,
                        "PSD peak %.1f dB above the local median at %.4g Hz (%s %.3g Hz, %lld-sample Welch "
                        "segments, amplitude %.3g)",
                        pk.prominence_db, pk.frequency_hz, line ? "bin width" : "half-power width",
                        line ? pk.df : pk.bandwidth_hz, static_cast<long long>(std::llround(fs / pk.df)),
                        pk.amplitude);
  if (refined && len > 0 && len < static_cast<int>(sizeof buf))
    len += std::snprintf(buf + len, sizeof buf - len,
                         "; least squares on the samples: %.6g +- %.2g Hz, amplitude %.3g +- %.2g",
                         refined->frequency_hz, refined->frequency_sigma_hz, refined->amplitude,
                         refined->amplitude_sigma);
  if (!line && fe.ok && len > 0 && len < static_cast<int>(sizeof buf))
    std::snprintf(buf + len, sizeof buf - len,
                  "; excess over an MA(1)-shaped floor (lag-1 %.3f) from %.4g to %.4g Hz: amplitude %.3g",
                  fe.floor_rho, fe.lo, fe.hi, std::sqrt(2 * fe.total));
  c.evidence = buf;
  const double f0 = refined ? refined->frequency_hz : pk.frequency_hz;
  const double t0 = in.tau0;
  // A line keeps its PSD frequency; a narrowband oscillation keeps the measured shape of its PSD excess: its
  // AVAR is that of the excess spectrum (spectrumAvar) per unit c = 2 x total power, i.e. the excess-weighted
  // mean of the sampled sinusoid term over the feature's bins. Tabulated at the curve's taus.
  std::shared_ptr<std::vector<std::pair<double, double>>> table;
  std::function<double(double)> shape;
  if (!line && fe.ok) {
    auto wts = std::make_shared<std::vector<double>>(fe.power);
    for (auto& v : *wts) v /= fe.total;
    const double fs0 = fe.f_start, dfe = fe.df;
    shape = [wts, fs0, dfe, t0](double tau) { return 0.5 * spectrumAvar(tau, fs0, dfe, *wts, t0); };
    for (size_t i = 0; i < wts->size(); ++i) {
      c.spectrum_hz.push_back(fs0 + static_cast<double>(i) * dfe);
      c.spectrum_weight.push_back((*wts)[i]);
    }
    c.spectrum_bin_hz = dfe;
  } else if (!line && !pk.profile_f.empty()) {
    // No mid-resolution PSD (short record): the peak finder's own profile of the feature.
    auto fr = std::make_shared<std::vector<double>>(pk.profile_f);
    auto wt = std::make_shared<std::vector<double>>(pk.profile_p);
    double wsum = 0;
    for (double v : *wt) wsum += v;
    for (auto& v : *wt) v /= (wsum > 0 ? wsum : 1.0);
    c.spectrum_hz = *fr;
    c.spectrum_weight = *wt;
    c.spectrum_bin_hz = fr->size() > 1 ? ((*fr)[fr->size() - 1] - (*fr)[0]) / static_cast<double>(fr->size() - 1) : pk.df;
    shape = [fr, wt, t0](double tau) {
      double s = 0;
      for (size_t i = 0; i < fr->size(); ++i) s += (*wt)[i] * sinusoidAvar(tau, (*fr)[i], t0);
      return s;
    };
  }
  if (shape) {
    table = std::make_shared<std::vector<std::pair<double, double>>>();
    for (double tau : *curve_taus) table->push_back({tau, shape(tau)});
    c.make = termMaker("narrowband", [shape, table](double, double tau) {
      const auto it = std::lower_bound(table->begin(), table->end(), std::make_pair(tau, -HUGE_VAL));
      if (it != table->end() && it->first == tau) return it->second;
      return shape(tau);
    });
  } else {
    c.make = termMaker("sinusoid", [f0, t0](double, double tau) { return sinusoidAvar(tau, f0, t0); });
    c.spectrum_hz = {f0};
    c.spectrum_weight = {1.0};
  }
  c.fixed["frequency_hz"] = {f0, refined ? refined->frequency_sigma_hz : line ? pk.df / 2 : pk.df};
  if (!line) c.fixed["bandwidth_hz"] = {pk.bandwidth_hz, pk.df};
  c.amplitude_name = "amplitude";
  c.n_nonlinear = line ? 1 : 2;
  return c;
}

// The record's spectral features: Welch PSD peaks at a fine and a coarse resolution, the broad ones measured, and
// lines below the fine one's band from the whole-record periodogram; lines refined on the samples.
SpectralFeatures spectralFeatures(const CheckInput& in) {
  SpectralFeatures sf = findSpectralFeatures(in);
  measureBroadFeatures(in, &sf);
  refineLines(in, &sf);
  return sf;
}

// Sinusoid / narrowband oscillation candidates of the record's spectral features.
void addSpectralCandidates(const CheckInput& in, const SpectralFeatures& sf, std::vector<Candidate>* cands) {
  // The curve's taus, where the fits evaluate the bases: a narrowband basis is tabulated there once.
  auto curve_taus = std::make_shared<std::vector<double>>();
  for (const auto& p : in.curve.points) curve_taus->push_back(p.tau);
  std::sort(curve_taus->begin(), curve_taus->end());
  for (size_t k = 0; k < sf.peaks.size(); ++k) {
    const SpectralPeak& pk = sf.peaks[k];
    if (pk.frequency_hz <= 0 || pk.frequency_hz >= in.fs / 2) continue;
    const int li = sf.line_of_peak[k];
    cands->push_back(spectralCandidate(in, pk, sf.broad[k], sf.excess[k], li >= 0 ? &sf.lines[li] : nullptr,
                                       curve_taus));
  }
}

// Noise correlated over a few samples (internal filter): the -3 M1 (tau0/tau)^2 correction with
// M1 = sum k gamma_k >= 0 fitted; evidence from the first lags of the samples' autocorrelation rho.
Candidate shortCorrelationCandidate(const std::vector<double>& rho, double noise, double tau0) {
  Candidate c;
  c.type = "short_correlation";
  c.nature = Nature::Correction;
  char buf[256];
  std::snprintf(buf, sizeof buf,
                "autocorrelation of the samples: lag-1 %.3f, lag-2 %.3f, lag-3 %.3f (white: 0 +- %.4f): noise "
                "correlated over a few samples (sensor low-pass/decimation filter)",
                rho[1], rho.size() > 2 ? rho[2] : 0.0, rho.size() > 3 ? rho[3] : 0.0, noise);
  c.evidence = buf;
  const double t0 = tau0;
  c.make = termMaker("short_correlation", [t0](double, double tau) { return shortCorrelationAvar(tau, t0); });
  c.fixed["lag1_correlation"] = {rho[1], noise};
  c.amplitude_name = "sqrt_m1";
  return c;
}

// Gauss-Markov candidates: exponential autocorrelation of the raw samples and of block means (and the
// short-correlation candidate from the samples' first lags).
void addGaussMarkovCandidates(const CheckInput& in, std::vector<Candidate>* cands) {
  struct Scale {
    int64_t block;
    std::string what;
  };
  const int64_t big = std::max<int64_t>(2, in.n / 4000);
  for (const Scale& sc : {Scale{1, "samples"}, Scale{big, "block means"}}) {
    const std::vector<double> x = sc.block == 1 ? in.rate : blockMeans(in.rate, sc.block);
    const int64_t nx = static_cast<int64_t>(x.size());
    if (nx < 200) continue;
    const std::vector<double> ac = autocovariance(x, std::min<int64_t>(nx / 10, 400));
    if (!(ac[0] > 0)) continue;
    std::vector<double> rho(ac.size());
    for (size_t k = 0; k < ac.size(); ++k) rho[k] = ac[k] / ac[0];
    const double noise = 1.0 / std::sqrt(static_cast<double>(nx));
    if (rho[1] < in.opts.acf_min_z * noise) continue;
    const double dt = sc.block * in.tau0;
    if (sc.block == 1) cands->push_back(shortCorrelationCandidate(rho, noise, in.tau0));
    const ExponentialAcfFit ef = fitExponentialAcf(rho, dt, 3 * noise);
    if (!ef.ok || !(ef.tc > 0)) continue;
    Candidate c;
    c.type = "gauss_markov";
    c.nature = Nature::GaussMarkov;
    char buf[256];
    std::snprintf(buf, sizeof buf,
                  "autocorrelation of %s (%.3g s) decays exponentially: lag-1 %.3f (white: 0 +- %.4f), correlation "
                  "time %.3g s over %d lags (r2 %.2f)",
                  sc.what.c_str(), dt, rho[1], noise, ef.tc, ef.lags, ef.r2);
    c.evidence = buf;
    const double t0 = in.tau0;
    c.make = termMaker("gauss_markov", [t0](double tc, double tau) { return gaussMarkovAvar(tau, tc, t0); });
    c.p0 = ef.tc;
    c.p_lo = std::max(in.tau0 / 4, ef.tc / 6);
    c.p_hi = std::min(in.T / 20, ef.tc * 6);  // >= 20 correlation times in the record to tell it from K
    if (!(c.p_hi > c.p_lo)) continue;
    c.n_nonlinear = 1;
    c.nonlinear_name = "tau_c_s";
    c.amplitude_name = "sigma";
    cands->push_back(c);
  }
}

// Bias step candidate: block-mean differences at the averaging time of the curve's minimum.
void addBiasStepCandidate(const CheckInput& in, std::vector<Candidate>* cands) {
  const int64_t n = in.n;
  const double tau0 = in.tau0, T = in.T;
  const std::vector<double>& rate = in.rate;
  double tau_min = in.curve.points.front().tau, dev_min = std::numeric_limits<double>::infinity();
  for (const auto& p : in.curve.points)
    if (p.var > 0 && p.var < dev_min) {
      dev_min = p.var;
      tau_min = p.tau;
    }
  std::vector<int64_t> blocks;
  blocks.push_back(std::clamp<int64_t>(static_cast<int64_t>(tau_min / tau0), std::max<int64_t>(1, n / 1000),
                                       std::max<int64_t>(1, n / 50)));
  blocks.push_back(std::max<int64_t>(1, n / 200));
  MeanShift best;
  int64_t best_block = 0;
  for (int64_t b : blocks) {
    const MeanShift s = detectMeanShift(rate, b, in.opts.step_min_z);
    if (s.found && s.z > best.z) {
      best = s;
      best_block = b;
    }
  }
  if (!best.found) return;
  // Location uncertainty of a step in white noise: about (sigma_sample / size)^2 samples.
  std::vector<double> d(std::min<int64_t>(n - 1, 200000));
  for (size_t i = 0; i < d.size(); ++i) d[i] = std::fabs(rate[i + 1] - rate[i]);
  const double s_sample = upperMedianInPlace(d) / kMadPerSigma / std::sqrt(2.0);
  const double ts = best.index * tau0;
  const double ts_sigma = tau0 * std::max(1.0, (s_sample / best.size) * (s_sample / best.size));
  Candidate c;
  c.type = "bias_step";
  c.localized = true;
  char buf[256];
  std::snprintf(buf, sizeof buf,
                "difference of %.3g s block means %.1f robust sigmas at t = %.4g s; least-squares step %.3g",
                best_block * tau0, best.z, ts, best.size);
  c.evidence = buf;
  c.make = termMaker("bias_step", [ts, T](double, double tau) { return biasStepAvar(tau, ts, T); });
  c.fixed["time_s"] = {ts, ts_sigma};
  c.n_nonlinear = 1;
  c.amplitude_name = "size";
  c.amplitude_sign = best.size >= 0 ? 1.0 : -1.0;
  cands->push_back(c);
}

// A tabulated AVAR (tau, value) at tau: log-log interpolated between entries (linear where a value is not
// positive), held constant beyond the ends.
double tabulatedAvar(const std::vector<std::pair<double, double>>& t, double tau) {
  if (t.empty()) return 0.0;
  if (tau <= t.front().first) return t.front().second;
  if (tau >= t.back().first) return t.back().second;
  for (size_t i = 1; i < t.size(); ++i)
    if (tau <= t[i].first) {
      const double a = t[i - 1].second, bv = t[i].second;
      if (!(a > 0) || !(bv > 0)) return a + (bv - a) * (tau - t[i - 1].first) / (t[i].first - t[i - 1].first);
      const double w = std::log(tau / t[i - 1].first) / std::log(t[i].first / t[i - 1].first);
      return std::exp(std::log(a) + w * (std::log(bv) - std::log(a)));
    }
  return t.back().second;
}

// Thermal drift candidate from the regression of the rate's block means rb (b samples each) on the temperature's.
void addTemperatureCandidate(const CheckInput& in, int64_t b, const std::vector<double>& rb,
                             std::vector<Candidate>* cands) {
  const double tau0 = in.tau0;
  const std::vector<double> tb = blockMeans(*in.temperature, b);
  bool varies = false;
  for (double v : tb) varies = varies || std::fabs(v - tb.front()) > 0;
  if (!varies) return;
  const LinearRegression lr = linearRegression(tb, rb);
  const double z = lr.slope_sigma > 0 ? std::fabs(lr.slope) / lr.slope_sigma : 0.0;
  if (z < in.opts.thermal_min_z) return;
  // Empirical basis: the AVAR of the temperature series itself, at the curve's factors (log-log interpolated
  // elsewhere); c = (rate per degC)^2.
  auto tab = std::make_shared<std::vector<std::pair<double, double>>>();
  for (const auto& p : in.curve.points) {
    const int64_t m = std::max<int64_t>(1, p.m > 0 ? p.m : static_cast<int64_t>(std::llround(p.tau / tau0)));
    tab->push_back({p.tau, overlappingAvarAt(*in.temperature, m)});
  }
  Candidate c;
  c.type = "thermal_drift";
  char buf[256];
  std::snprintf(buf, sizeof buf, "rate vs temperature over %.3g s blocks: slope %.3g +- %.2g (rad/s)/degC, r = %.2f",
                b * tau0, lr.slope, lr.slope_sigma, lr.r);
  c.evidence = buf;
  c.make = termMaker("thermal_drift", [tab](double, double tau) { return tabulatedAvar(*tab, tau); });
  c.amplitude_name = "coefficient_per_degc";
  c.amplitude_sign = lr.slope >= 0 ? 1.0 : -1.0;
  cands->push_back(c);
}

// Lag-1 correlation of the block means rb (b samples each) left after the warm-up fit wf.
double warmupResidualRho1(const std::vector<double>& rb, const WarmupFit& wf, int64_t b, double tau0) {
  std::vector<double> res(rb.size());
  double mean = 0;
  for (size_t i = 0; i < rb.size(); ++i) {
    res[i] = rb[i] - wf.a * -std::expm1(-(i + 0.5) * b * tau0 / wf.theta);
    mean += res[i];
  }
  mean /= res.size();
  double c0 = 0, c1 = 0;
  for (size_t i = 0; i < res.size(); ++i) {
    c0 += (res[i] - mean) * (res[i] - mean);
    if (i + 1 < res.size()) c1 += (res[i] - mean) * (res[i + 1] - mean);
  }
  return c0 > 0 ? c1 / c0 : 1.0;
}

// Warm-up candidate (no temperature given): an exponential a (1 - exp(-t/theta)) fitted to the block means rb.
void addWarmupCandidate(const CheckInput& in, int64_t b, const std::vector<double>& rb, std::vector<Candidate>* cands) {
  const double tau0 = in.tau0, T = in.T;
  // theta <= T/3: a warm-up that does not settle within the record cannot be told from a ramp or a random walk.
  const WarmupFit wf = fitWarmup(rb, b * tau0, T / 200, T / 3);
  // White-noise sigma of the block means from their first differences: a random walk or flicker makes the fit's
  // own a_sigma optimistic, so the evidence threshold is high and the BIC decides.
  // A random walk of the bias also looks like a warm-up over one record: require the block means left after
  // the warm-up to be little correlated (lag-1 < 0.5), as they are for white/flicker noise but not for a walk.
  double resid_rho1 = 1.0;
  if (wf.ok) resid_rho1 = warmupResidualRho1(rb, wf, b, tau0);
  if (!(wf.ok && wf.a_sigma > 0 && std::fabs(wf.a) / wf.a_sigma >= in.opts.warmup_min_z && resid_rho1 < 0.5)) return;
  Candidate c;
  c.type = "warmup";
  c.localized = true;
  char buf[256];
  std::snprintf(buf, sizeof buf,
                "%.3g s block means follow a (1 - exp(-t/theta)): a = %.3g +- %.2g, theta = %.3g s, residual "
                "lag-1 correlation %.2f",
                b * tau0, wf.a, wf.a_sigma, wf.theta, resid_rho1);
  c.evidence = buf;
  c.make = termMaker("warmup", [T](double theta, double tau) { return warmupAvar(tau, theta, T); });
  c.p0 = wf.theta;
  c.p_lo = wf.theta / 4;
  c.p_hi = std::min(wf.theta * 4, T / 3);
  c.n_nonlinear = 1;
  c.nonlinear_name = "theta_s";
  c.amplitude_name = "amplitude";
  c.amplitude_sign = wf.a >= 0 ? 1.0 : -1.0;
  cands->push_back(c);
}

// Thermal drift candidates: regression on temperature when given, otherwise a warm-up exponential.
void addThermalCandidates(const CheckInput& in, std::vector<Candidate>* cands) {
  const int64_t b = std::max<int64_t>(1, in.n / 200);
  const std::vector<double> rb = blockMeans(in.rate, b);
  if (in.temperature && rb.size() >= 8)
    addTemperatureCandidate(in, b, rb, cands);
  else if (rb.size() >= 16)
    addWarmupCandidate(in, b, rb, cands);
}

// Impulsive outliers (shocks) candidate.
void addOutlierCandidate(const CheckInput& in, std::vector<Candidate>* cands) {
  const double tau0 = in.tau0, T = in.T;
  const Outliers o = detectOutliers(in.rate, tau0, in.opts.outlier_min_z);
  if (o.index.empty() || static_cast<int64_t>(o.index.size()) * 1000 >= in.n) return;
  Candidate c;
  c.type = "outliers";
  c.localized = true;
  char buf[256];
  std::snprintf(buf, sizeof buf, "%zu samples beyond %.0f robust sigmas (%.3g) of their local median, first at t = %.4g s",
                o.index.size(), in.opts.outlier_min_z, o.robust_sigma, o.index.front() * tau0);
  c.evidence = buf;
  c.make = termMaker("outliers", [T](double, double tau) { return impulseAvar(tau, T); });
  c.fixed["count"] = {static_cast<double>(o.index.size()), 0.0};
  c.amplitude_name = "rss_area";
  cands->push_back(c);
}

// Every candidate effect the raw samples give evidence for, in the order the searches are enabled; sf: the record's
// spectral features when already computed.
// A stochastic term (Gauss-Markov, narrowband) adds variance the IEEE terms can trade for on the Allan curve, so its
// only evidence there is a curve the plain model does not describe: it is a candidate only when the plain fit's
// residual on the measured curve (mc->residual_before) is structured (the calibrated test at structured_alpha).
std::vector<Candidate> collectCandidates(const CheckInput& in, const SpectralFeatures* sf, ModelCheck* mc) {
  std::vector<Candidate> found;
  if (in.opts.search_sinusoid && in.n >= 256) addSpectralCandidates(in, sf ? *sf : spectralFeatures(in), &found);
  if (in.opts.search_gauss_markov) addGaussMarkovCandidates(in, &found);
  if (in.opts.search_bias_step) addBiasStepCandidate(in, &found);
  if (in.opts.search_thermal) addThermalCandidates(in, &found);
  if (in.opts.search_outliers) addOutlierCandidate(in, &found);
  const ResidualAnalysis& plain = mc->residual_before;  // the measured curve's, before any line was taken out
  std::vector<Candidate> cands;
  for (Candidate& c : found) {
    if (isStochastic(c.nature) && in.opts.stochastic_needs_structure && !plain.structured) {
      mc->rejected.push_back(c.type + ": the plain fit describes the Allan curve (residual p " +
                             fmt("%.2g", plain.p_value) + ", structured below " +
                             fmt("%.2g", in.opts.structured_alpha) + "); a stochastic term needs a curve it does not (" +
                             c.evidence + ")");
      continue;
    }
    cands.push_back(std::move(c));
  }
  return cands;
}

// The current model with candidate c's term at nonlinear parameter p added, refitted.
// intervals false: the fits without their selective intervals (FitOptions::intervals), for trials compared by BIC
// only; the same values, BIC and statistics.
Trial evaluateCandidate(const CheckInput& in, const Model& current, const Candidate& c, double p,
                        bool intervals = true) {
  Trial t;
  t.p = p;
  t.term = c.make(p);
  std::vector<ExtraTerm> ex = current.extra;
  std::vector<TermInfo> info = current.info;
  ex.push_back(t.term);
  TermInfo ti;
  ti.nature = c.nature;
  ti.tc = p;
  ti.localized = c.localized ? in.T : 0.0;
  info.push_back(ti);
  // Only a deterministic effect may stand in for K and R (a stochastic one would just trade places with them).
  FitOptions fo = in.opts.fit;
  fo.intervals = fo.intervals && intervals;
  t.model = fitModel(in.curve, current, fo, ex, info, current.n_nonlinear + c.n_nonlinear,
                     c.nature == Nature::Deterministic);
  return t;
}

// Best trial of a candidate with a search range: log grid, then golden-section refinement between the best point's
// neighbours, and the parameter's sigma; model.ok false when no grid point fits.
Trial searchCandidate(const CheckInput& in, const Model& current, const Candidate& c) {
  const int ng = 21;
  std::vector<double> grid(ng);
  std::vector<Trial> trials(ng);
  int bi = -1;
  for (int g = 0; g < ng; ++g) {
    grid[g] = c.p_lo * std::pow(c.p_hi / c.p_lo, static_cast<double>(g) / (ng - 1));
    trials[g] = evaluateCandidate(in, current, c, grid[g], false);
    if (trials[g].model.ok && (bi < 0 || trials[g].model.bic < trials[bi].model.bic)) bi = g;
  }
  if (bi < 0) return Trial{};
  double a = std::log(grid[std::max(0, bi - 1)]), b = std::log(grid[std::min(ng - 1, bi + 1)]);
  Trial bt = trials[bi];
  const double gr = 0.5 * (std::sqrt(5.0) - 1.0);
  double x1 = b - gr * (b - a), x2 = a + gr * (b - a);
  Trial t1 = evaluateCandidate(in, current, c, std::exp(x1), false);
  Trial t2 = evaluateCandidate(in, current, c, std::exp(x2), false);
  for (int it = 0; it < 12; ++it) {
    if (t1.model.bic < t2.model.bic) {
      b = x2;
      x2 = x1;
      t2 = t1;
      x1 = b - gr * (b - a);
      t1 = evaluateCandidate(in, current, c, std::exp(x1), false);
    } else {
      a = x1;
      x1 = x2;
      t1 = t2;
      x2 = a + gr * (b - a);
      t2 = evaluateCandidate(in, current, c, std::exp(x2), false);
    }
  }
  const Trial& tb = t1.model.bic < t2.model.bic ? t1 : t2;
  if (tb.model.ok && tb.model.bic < bt.model.bic) bt = tb;
  // Sigma of the parameter from the curvature of -2 ln L (= BIC up to a constant) in ln p, inflated by the
  // reduced chi2 when it exceeds 1.
  const double h = 0.05;
  const Trial tm = evaluateCandidate(in, current, c, bt.p * std::exp(-h), false);
  const Trial tp = evaluateCandidate(in, current, c, bt.p * std::exp(h), false);
  const double curv = (tm.model.bic + tp.model.bic - 2 * bt.model.bic) / (h * h);
  const double infl = std::max(1.0, bt.model.fit.chi2_dof);
  const double p_sigma = (curv > 0 && tm.model.ok && tp.model.ok) ? bt.p * std::sqrt(2.0 / curv * infl) : bt.p;
  // The trials above were fitted without their selective intervals (their BIC is the same); the best one again with
  // them, at the same parameter: the same fit as if every trial had had them.
  Trial full = evaluateCandidate(in, current, c, bt.p);
  full.p_sigma = p_sigma;
  return full;
}

// Significance of extra term e of a fit: sqrt(c) over its sigma.
double amplitudeZ(const FitResult& f, size_t e) {
  if (e >= f.extra.size() || e >= f.extra_c.size() || !(f.extra_c[e] > 0)) return 0.0;
  const Coefficient& co = f.extra[e];
  return co.sigma > 0 ? co.value / co.sigma : std::numeric_limits<double>::infinity();
}

// State of the effect selection: the current joint model and the kept effects, parallel to current.extra (the
// report and the candidate each came from).
struct Selection {
  Model current;
  std::vector<DetectedEffect> kept;
  std::vector<size_t> kept_cand;
};

// A candidate's best trial against the current model.
struct Scored {
  size_t ci;
  Trial trial;
};

// Best trial of every candidate not yet used; one the refit gives zero amplitude is rejected.
std::vector<Scored> scoreCandidates(const CheckInput& in, const Model& current, std::vector<Candidate>* cands,
                                    ModelCheck* mc) {
  std::vector<Scored> scored;
  for (size_t ci = 0; ci < cands->size(); ++ci) {
    Candidate& c = (*cands)[ci];
    if (c.used) continue;
    const Trial bt = c.p_hi > c.p_lo ? searchCandidate(in, current, c) : evaluateCandidate(in, current, c, c.p0);
    if (!bt.model.ok) continue;
    // The effect must be present in the refit (NNLS may put it at zero).
    const double cval = bt.model.fit.extra_c.empty() ? 0.0 : bt.model.fit.extra_c.back();
    if (!(cval > 0)) {
      c.used = true;
      mc->rejected.push_back(c.type + ": the refit gives it zero amplitude (" + c.evidence + ")");
      continue;
    }
    scored.push_back({ci, bt});
  }
  return scored;
}

// One round of the forward selection: best BIC first, a candidate is added when it passes the BIC gate and is
// significant (amplitude, nonlinear parameter); one that fails is rejected (with its numbers) and the next one is
// examined; an added one ends the round (true). Whether it lowers the RMS error is judged on the final joint model
// (pruneJointModel): effects that only work together (the ADIS16405 z gyro's narrowband feature and its filter
// correlation each raise the error alone, 0.050 -> 0.083 and 0.075, and lower it together to 0.0065) must not be
// cut one step at a time.
bool admitBest(const CheckInput& in, const std::vector<bool>& rms_mask, std::vector<Scored> scored,
               std::vector<Candidate>* cands, Selection* sel, ModelCheck* mc) {
  const ModelCheckOptions& opts = in.opts;
  std::stable_sort(scored.begin(), scored.end(),
                   [](const Scored& x, const Scored& y) { return x.trial.model.bic < y.trial.model.bic; });
  const double rms_now = rmsLog10(in.curve, sel->current.fit.model_var, rms_mask);  // for the rejection messages
  for (const Scored& sc : scored) {
    Candidate& c = (*cands)[sc.ci];
    const Trial& best = sc.trial;
    c.used = true;
    const double gain = sel->current.bic - best.model.bic;
    const double margin = isStochastic(c.nature) ? opts.bic_margin_stochastic : opts.bic_margin;
    if (gain < margin) {
      mc->rejected.push_back(c.type + ": BIC improves by only " + fmt("%.1f", gain) + " (< " + fmt("%.0f", margin) +
                             "; " + c.evidence + ")");
      continue;
    }
    const double rms_new = rmsLog10(in.curve, best.model.fit.model_var, rms_mask);
    const double az = amplitudeZ(best.model.fit, best.model.fit.extra.size() - 1);
    if (!(az >= opts.min_amplitude_z)) {
      mc->rejected.push_back(c.type + ": " + c.amplitude_name + " " + fmt("%.3g", best.model.fit.extra.back().value) +
                             " is " + fmt("%.1f", az) + " sigma (needs " + fmt("%.0f", opts.min_amplitude_z) +
                             "; RMS log10 " + fmt("%.4f", rms_now) + " -> " + fmt("%.4f", rms_new) + "; " +
                             c.evidence + ")");
      continue;
    }
    if (!c.nonlinear_name.empty() && !(best.p > 0 && best.p_sigma <= opts.max_nonlinear_rel_sigma * best.p)) {
      mc->rejected.push_back(c.type + ": " + c.nonlinear_name + " " + fmt("%.3g", best.p) + " +- " +
                             fmt("%.2g", best.p_sigma) + " (" + fmt("%.0f", 100 * best.p_sigma / best.p) +
                             " %, needs <= " + fmt("%.0f", 100 * opts.max_nonlinear_rel_sigma) + " %; " +
                             c.evidence + ")");
      continue;
    }
    DetectedEffect eff;
    eff.type = c.type;
    eff.evidence = c.evidence;
    eff.delta_bic = gain;
    eff.term = best.term;
    eff.parameters = c.fixed;
    eff.spectrum_hz = c.spectrum_hz;
    eff.spectrum_weight = c.spectrum_weight;
    eff.spectrum_bin_hz = c.spectrum_bin_hz;
    if (!c.nonlinear_name.empty()) eff.parameters[c.nonlinear_name] = {best.p, best.p_sigma};
    eff.parameters[c.amplitude_name] = {c.amplitude_sign, 0.0};  // filled below from the joint refit
    sel->kept.push_back(eff);
    sel->kept_cand.push_back(sc.ci);
    sel->current = best.model;
    return true;
  }
  return false;
}

// Greedy forward selection with the BIC, at most max_effects rounds; candidates never examined are reported.
void forwardSelect(const CheckInput& in, const std::vector<bool>& rms_mask, std::vector<Candidate>* cands,
                   Selection* sel, ModelCheck* mc) {
  for (int round = 0; round < in.opts.max_effects; ++round) {
    std::vector<Scored> scored = scoreCandidates(in, sel->current, cands, mc);
    if (scored.empty()) break;
    if (!admitBest(in, rms_mask, std::move(scored), cands, sel, mc)) break;
  }
  for (const auto& c : *cands)
    if (!c.used) mc->rejected.push_back(c.type + ": not examined (effect limit reached; " + c.evidence + ")");
}

// The joint model refitted without kept effect `drop` (without the only effect: the plain fit); false when that
// refit fails.
bool refitWithout(const CheckInput& in, const Model& base, const std::vector<Candidate>& cands, const Selection& sel,
                  size_t drop, Model* out) {
  const Model& current = sel.current;
  std::vector<ExtraTerm> ex;
  std::vector<TermInfo> info;
  int nn = 0;
  bool deterministic = false;
  for (size_t e = 0; e < current.extra.size(); ++e) {
    if (e == drop) continue;
    ex.push_back(current.extra[e]);
    info.push_back(current.info[e]);
    deterministic = deterministic || current.info[e].nature == Nature::Deterministic;
    nn += cands[sel.kept_cand[e]].n_nonlinear;
  }
  if (ex.empty()) {
    *out = base;
    return true;
  }
  *out = fitModel(in.curve, base, in.opts.fit, ex, info, nn, deterministic);
  return out->ok;
}

// Removes kept effect e; `rest`, the joint model without it, becomes the current model.
void dropKept(Selection* sel, size_t e, const Model& rest) {
  sel->kept.erase(sel->kept.begin() + static_cast<std::ptrdiff_t>(e));
  sel->kept_cand.erase(sel->kept_cand.begin() + static_cast<std::ptrdiff_t>(e));
  sel->current = rest;
}

// What one pruning step did.
enum class Pruned { Nothing, Dropped, Failed };

// Significance in the joint refit: drops the least significant kept effect below min_amplitude_z (another effect
// took its place); Failed (plain fit kept) when the refit without it fails.
Pruned dropInsignificant(const CheckInput& in, const Model& base, const std::vector<Candidate>& cands, Selection* sel,
                         ModelCheck* mc) {
  const ModelCheckOptions& opts = in.opts;
  std::vector<DetectedEffect>& kept = sel->kept;
  size_t worst = kept.size();
  double worst_z = opts.min_amplitude_z;
  for (size_t e = 0; e < kept.size(); ++e) {
    const double z = amplitudeZ(sel->current.fit, e);
    if (!(z >= worst_z)) {
      worst_z = z;
      worst = e;
    }
  }
  if (worst >= kept.size()) return Pruned::Nothing;
  Model rest;
  const bool ok = refitWithout(in, base, cands, *sel, worst, &rest);
  const FitResult& cf = sel->current.fit;
  mc->rejected.push_back(kept[worst].type + ": dropped in the joint refit with " + std::to_string(kept.size() - 1) +
                         " other effect(s): amplitude " +
                         fmt("%.3g", worst < cf.extra.size() ? cf.extra[worst].value : 0.0) + " is " +
                         fmt("%.1f", worst_z) + " sigma (needs " + fmt("%.0f", opts.min_amplitude_z) + "; " +
                         kept[worst].evidence + ")");
  if (!ok) {
    mc->rejected.push_back("joint refit without the dropped effect failed: plain fit kept");
    kept.clear();
    sel->kept_cand.clear();
    sel->current = base;
    return Pruned::Failed;
  }
  dropKept(sel, worst, rest);
  return Pruned::Dropped;
}

// RMS error: the joint model must describe the curve better than the same model refitted without any one effect
// by min_rms_gain; otherwise the effect whose removal costs least is dropped (true).
bool dropCheapest(const CheckInput& in, const Model& base, const std::vector<Candidate>& cands,
                  const std::vector<bool>& rms_mask, Selection* sel, ModelCheck* mc) {
  const double min_gain = in.opts.min_rms_gain;  // negative: the gate is off (studies only)
  std::vector<DetectedEffect>& kept = sel->kept;
  const double rms_all = rmsLog10(in.curve, sel->current.fit.model_var, rms_mask);
  size_t cheapest = kept.size();
  double best_rest_rms = std::numeric_limits<double>::infinity();
  Model best_rest;
  for (size_t e = 0; e < kept.size(); ++e) {
    Model rest;
    if (!refitWithout(in, base, cands, *sel, e, &rest)) continue;
    const double r = rmsLog10(in.curve, rest.fit.model_var, rms_mask);
    if (cheapest == kept.size() || r < best_rest_rms) {
      cheapest = e;
      best_rest_rms = r;
      best_rest = rest;
    }
  }
  if (cheapest == kept.size()) return false;  // no refit without any of them: the final guard decides
  if (std::isfinite(rms_all) && rms_all < best_rest_rms * (1.0 - min_gain)) return false;  // each one earns its place
  const double rel = best_rest_rms > 0 ? (best_rest_rms - rms_all) / best_rest_rms : 0.0;
  mc->rejected.push_back(kept[cheapest].type + ": BIC improves by " + fmt("%.1f", kept[cheapest].delta_bic) +
                         " but the RMS log10 error goes " + fmt("%.4f", best_rest_rms) + " -> " + fmt("%.4f", rms_all) +
                         " with it (" + fmt("%+.1f", -100 * rel) + " %, needs " + fmt("%.0f", -100 * min_gain) + " %" +
                         (kept.size() > 1 ? ", with " + std::to_string(kept.size() - 1) + " other effect(s)" : "") +
                         "; " + kept[cheapest].evidence + ")");
  dropKept(sel, cheapest, best_rest);
  return true;
}

// Every kept effect again in the final joint model, until nothing changes:
//  - significance: one whose amplitude went to zero or below min_amplitude_z in the joint refit (another effect
//    took its place) is dropped, the least significant first;
//  - RMS error: the joint model must describe the curve better than the same model refitted without that effect
//    by min_rms_gain (without the only effect: the plain fit); otherwise the effect whose removal costs least is
//    dropped (a BIC gain with an RMS error that does not fall is a traded weight: a flicker wiggle taken for a
//    Gauss-Markov bump, a stretch of rate random walk taken for a warm-up, a bias step that K already describes).
void pruneJointModel(const CheckInput& in, const Model& base, const std::vector<Candidate>& cands,
                     const std::vector<bool>& rms_mask, Selection* sel, ModelCheck* mc) {
  while (!sel->kept.empty()) {
    const Pruned p = dropInsignificant(in, base, cands, sel, mc);
    if (p == Pruned::Failed) break;
    if (p == Pruned::Dropped) continue;
    if (!dropCheapest(in, base, cands, rms_mask, sel, mc)) break;
  }
}

// Final guard: the answer never describes the curve worse than the plain fit (by the same margin each effect
// needed).
void finalGuard(const CheckInput& in, const Model& base, const std::vector<bool>& rms_mask, Selection* sel,
                ModelCheck* mc) {
  if (sel->kept.empty()) return;
  const double min_gain = in.opts.min_rms_gain;
  const double rms_final = rmsLog10(in.curve, sel->current.fit.model_var, rms_mask);
  if (std::isfinite(rms_final) && rms_final < mc->before.rms_log10 * (1.0 - min_gain)) return;
  std::string names;
  for (const auto& e : sel->kept) names += (names.empty() ? "" : ", ") + e.type;
  mc->rejected.push_back("all effects (" + names + "): the joint refit's RMS log10 error " + fmt("%.4f", rms_final) +
                         " is not " + fmt("%.0f", 100 * min_gain) + " % below the plain fit's " +
                         fmt("%.4f", mc->before.rms_log10) + ": plain fit kept");
  mc->message = "model check kept no effect: the joint refit did not lower the RMS log10 error";
  sel->kept.clear();
  sel->current = base;
}

// The final joint model's figures in the report: the effects with their amplitudes from the joint refit (signs
// from the evidence), mc.after, its fit and residual.
void recordAfter(const CheckInput& in, const std::vector<bool>& rms_mask, const Selection& sel, ModelCheck* mc) {
  const Model& current = sel.current;
  mc->effects = sel.kept;
  for (size_t e = 0; e < mc->effects.size() && e < current.fit.extra.size(); ++e) {
    for (auto& kv : mc->effects[e].parameters) {
      const std::string& k = kv.first;
      if (k == "amplitude" || k == "sigma" || k == "size" || k == "coefficient_per_degc" || k == "rss_area" ||
          k == "sqrt_m1") {
        const double sign = kv.second.value < 0 ? -1.0 : 1.0;
        kv.second = {sign * current.fit.extra[e].value, current.fit.extra[e].sigma};
      }
    }
  }
  mc->fit_after = current.fit;
  mc->extra = current.extra;
  mc->model_var_after = current.fit.model_var;
  mc->after.rms_log10 = rmsLog10(in.curve, current.fit.model_var, rms_mask);
  mc->after.chi2_dof = current.fit.chi2_dof;
  mc->after.bic = current.bic;
  mc->after.n_params = countParams(current.fit) + current.n_nonlinear;
  mc->residual_after = analyzeResidual(current.weighted, current.fit, current.extra, in.opts.structured_alpha);
}

// Lines refined on the samples (refineLines) whose family-wise false-alarm probability over their band is below
// half of line_false_alarm (two bands: the record's false-alarm probability stays below it).
std::vector<SpectralLine> significantLines(const SpectralFeatures& sf, const ModelCheckOptions& opts) {
  std::vector<SpectralLine> out;
  for (const auto& l : sf.lines)
    if (l.amplitude > 0 && l.false_alarm < 0.5 * opts.line_false_alarm) out.push_back(l);
  return out;
}

// x minus the sinusoids c cos(2 pi f i / fs) + s sin(2 pi f i / fs).
std::vector<double> withoutLines(const std::vector<double>& x, double fs, const std::vector<double>& freqs,
                                 const std::vector<std::pair<double, double>>& cs) {
  std::vector<double> y = x;
  for (size_t l = 0; l < freqs.size(); ++l) {
    const double w = 2.0 * M_PI * freqs[l] / fs;
    const std::complex<double> step = std::polar(1.0, w);
    std::complex<double> rot(1.0, 0.0);
    for (size_t i = 0; i < y.size(); ++i) {
      if ((i & 1023) == 0) rot = std::polar(1.0, w * static_cast<double>(i));
      y[i] -= cs[l].first * rot.real() + cs[l].second * rot.imag();
      rot *= step;
    }
  }
  return y;
}

// The overlapping Allan variance of y at the averaging factors of `curve` (its other fields kept, the deviation
// and its bounds rescaled).
DeviationCurve oadevLike(const DeviationCurve& curve, const std::vector<double>& y) {
  DeviationCurve c = curve;
  for (auto& p : c.points) {
    const int64_t m = std::max<int64_t>(1, p.m > 0 ? p.m : static_cast<int64_t>(std::llround(p.tau / curve.tau0)));
    const double v = overlappingAvarAt(y, m);
    const double scale = p.var > 0 && v > 0 ? std::sqrt(v / p.var) : 1.0;
    p.var = v;
    p.dev = std::sqrt(std::max(0.0, v));
    p.dev_lo *= scale;
    p.dev_hi *= scale;
  }
  return c;
}

// The effects other than lines: candidates from the samples, forward selection, pruning, the final guard; the
// result in mc (effects, after, fit_after, residual_after). sf: the record's spectral features when already computed.
void traceEffects(const CheckInput& in, const Model& base, const std::vector<bool>& rms_mask, ModelCheck* mc,
                  const SpectralFeatures* sf) {
  std::vector<Candidate> cands = collectCandidates(in, sf, mc);
  Selection sel;
  sel.current = base;
  forwardSelect(in, rms_mask, &cands, &sel, mc);
  pruneJointModel(in, base, cands, rms_mask, &sel, mc);
  finalGuard(in, base, rms_mask, &sel, mc);
  recordAfter(in, rms_mask, sel, mc);
}

// The lines taken out of the samples, added to the answer: effects with their least-squares amplitude (joint fit
// cs) and frequency, their AVAR A^2 sinusoidAvar(tau, f) added to the model curve; RMS error against the
// measured curve (in: the record as given).
void addLines(const CheckInput& in, const std::vector<SpectralLine>& lines,
              const std::vector<std::pair<double, double>>& cs, const std::vector<bool>& rms_mask, ModelCheck* mc) {
  const double t0 = in.tau0;
  for (size_t k = 0; k < lines.size(); ++k) {
    const SpectralLine& l = lines[k];
    const double A = std::hypot(cs[k].first, cs[k].second), f = l.frequency_hz;
    DetectedEffect e;
    e.type = "sinusoid";
    char buf[384];
    std::snprintf(buf, sizeof buf,
                  "whole-record periodogram %.1f dB above the noise level at %.6g Hz (false-alarm probability %.2g over %d "
                  "frequencies); least squares on the samples (jointly with %zu other line(s)): %.6g +- %.2g Hz, "
                  "amplitude %.3g +- %.2g; taken out of the samples before the other effects were traced",
                  10.0 * std::log10(std::max(l.power_ratio, 1e-300)), f, l.false_alarm, l.frequencies,
                  lines.size() - 1, f, l.frequency_sigma_hz, A, l.amplitude_sigma);
    e.evidence = buf;
    e.parameters["frequency_hz"] = {f, l.frequency_sigma_hz};
    e.parameters["amplitude"] = {A, l.amplitude_sigma};
    e.term.name = "sinusoid";
    e.term.basis = [f, t0](double tau) { return sinusoidAvar(tau, f, t0); };
    e.spectrum_hz = {f};
    e.spectrum_weight = {1.0};
    Coefficient co;
    co.value = A;
    co.sigma = l.amplitude_sigma;
    co.supported = true;
    co.lo68 = std::max(0.0, A - l.amplitude_sigma);
    co.hi68 = A + l.amplitude_sigma;
    co.lo95 = std::max(0.0, A - kZ95 * l.amplitude_sigma);
    co.hi95 = A + kZ95 * l.amplitude_sigma;
    for (size_t i = 0; i < mc->tau.size(); ++i) {
      const double add = A * A * e.term.basis(mc->tau[i]);
      if (i < mc->fit_after.model_var.size()) mc->fit_after.model_var[i] += add;
      if (i < mc->model_var_after.size()) mc->model_var_after[i] += add;
    }
    mc->fit_after.extra.push_back(co);
    mc->fit_after.extra_c.push_back(A * A);
    mc->extra.push_back(e.term);
    mc->effects.push_back(e);
  }
  mc->after.rms_log10 = rmsLog10(in.curve, mc->model_var_after, rms_mask);
  mc->after.n_params += 2 * static_cast<int>(lines.size());
  // The answer's own error figures against the measured curve (its chi-squared stays the fit's of the curve
  // without the lines).
  FitResult& fa = mc->fit_after;
  const FitError fe = fitError(withModelEdf(in.curve, fa), fa.model_var, fa.used, mc->after.n_params,
                               in.opts.fit.rms_min_edf);
  fa.rms_log10 = fe.rms_log10;
  fa.n_rms = fe.n_rms;
  fa.worst_adev_ratio = fe.worst_adev_ratio;
}

}  // namespace

ModelCheck checkModel(const std::vector<double>& rate, double tau0, const DeviationCurve& curve, const FitResult& fit,
                      const ModelCheckOptions& opts, const std::vector<double>* temperature) {
  validateInputs(rate, tau0, curve, fit, temperature);
  ModelCheck mc;
  mc.fit_before = fit;
  for (const auto& p : curve.points) {
    mc.tau.push_back(p.tau);
    mc.measured_var.push_back(p.var);
  }
  if (!fit.ok) return unchecked(mc, fit, "base fit failed: " + fit.message);
  const int64_t n = static_cast<int64_t>(rate.size());
  const CheckInput in{rate, tau0, curve, opts, temperature, n, n * tau0, 1.0 / tau0};
  const Model base = refitBase(in, fit);
  if (!base.ok) return unchecked(mc, fit, "base refit failed: " + base.fit.message);
  const std::vector<bool> rms_mask = rmsMask(in, base);
  recordBefore(in, base, rms_mask, &mc);

  // Lines first: found and refined on the samples and, where significant, fitted jointly and taken out of them;
  // the other effects are traced on what is left (its own curve and plain fit).
  const bool spectral = opts.search_sinusoid && n >= 256;
  const SpectralFeatures sf = spectral ? spectralFeatures(in) : SpectralFeatures{};
  const std::vector<SpectralLine> lines =
      spectral && curve.name == "oadev" ? significantLines(sf, opts) : std::vector<SpectralLine>{};
  if (lines.empty()) {
    traceEffects(in, base, rms_mask, &mc, spectral ? &sf : nullptr);
  } else {
    const ModelCheck plain = mc;  // before anything was traced
    std::vector<double> freqs;
    for (const auto& l : lines) freqs.push_back(l.frequency_hz);
    const std::vector<std::pair<double, double>> cs = fitSinusoids(rate, in.fs, freqs);
    const std::vector<double> clean = withoutLines(rate, in.fs, freqs, cs);
    const DeviationCurve clean_curve = oadevLike(curve, clean);
    const CheckInput rest{clean, tau0, clean_curve, opts, temperature, n, n * tau0, 1.0 / tau0};
    const FitResult clean_fit = fitNoiseModel(clean_curve, opts.fit);
    if (!clean_fit.ok) return unchecked(mc, fit, "fit without the lines failed: " + clean_fit.message);
    const Model clean_base = refitBase(rest, clean_fit);
    if (!clean_base.ok) return unchecked(mc, fit, "refit without the lines failed: " + clean_base.fit.message);
    traceEffects(rest, clean_base, rmsMask(rest, clean_base), &mc, nullptr);
    addLines(in, lines, cs, rms_mask, &mc);
    // The acceptance rule of every effect: the answer must describe the measured curve better than the plain fit.
    if (!(mc.after.rms_log10 <= (1.0 - opts.min_rms_gain) * mc.before.rms_log10)) {
      const double with_lines = mc.after.rms_log10;
      mc = plain;
      traceEffects(in, base, rms_mask, &mc, &sf);
      for (const auto& l : lines)
        mc.rejected.push_back("sinusoid at " + fmt("%.6g Hz", l.frequency_hz) + " (amplitude " +
                              fmt("%.3g", l.amplitude) + ", false-alarm probability " +
                              fmt("%.2g", l.false_alarm) + "): with the lines taken out the RMS log10 error goes " +
                              fmt("%.4f", plain.before.rms_log10) + " -> " + fmt("%.4f", with_lines) + " (needs -" +
                              fmt("%.0f", 100 * opts.min_rms_gain) + " %)");
    }
  }
  if (sf.fine >= 64) mc.line_search = sf.band;
  mc.ok = true;
  return mc;
}

}  // namespace gyro_allan
