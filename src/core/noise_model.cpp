// IEEE 952/647 noise-model fit: EDF-weighted, iterated, non-negative least squares on the Allan variance.
#include "gyro_allan/noise_model.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <stdexcept>

#include <Eigen/Dense>

#include "noise_model_internal.hpp"

namespace gyro_allan {
namespace {
constexpr double kFlickerFactor = 0.4412712003053032;  // 2 ln2 / pi
}  // namespace

namespace detail {

/// Lawson-Hanson active-set NNLS: min ||A x - b|| s.t. x >= 0. Written here because neither Eigen 3.3 (Noetic)
/// nor Eigen 3.4's main modules ship an NNLS solver; the problems are tiny (<= ~10 columns).
Eigen::VectorXd nnls(const Eigen::MatrixXd& A, const Eigen::VectorXd& b) {
  const int n = static_cast<int>(A.cols());
  Eigen::VectorXd x = Eigen::VectorXd::Zero(n);
  std::vector<bool> passive(n, false);
  const double tol = 1e-12 * std::max(1.0, A.norm() * b.norm());
  auto solvePassive = [&](Eigen::VectorXd* s) {
    std::vector<int> idx;
    for (int j = 0; j < n; ++j)
      if (passive[j]) idx.push_back(j);
    s->setZero(n);
    if (idx.empty()) return;
    Eigen::MatrixXd Ap(A.rows(), static_cast<int>(idx.size()));
    for (size_t k = 0; k < idx.size(); ++k) Ap.col(static_cast<int>(k)) = A.col(idx[k]);
    Eigen::VectorXd sp = Ap.colPivHouseholderQr().solve(b);
    for (size_t k = 0; k < idx.size(); ++k) (*s)[idx[k]] = sp[static_cast<int>(k)];
  };
  for (int outer = 0; outer < 3 * n + 10; ++outer) {
    Eigen::VectorXd w = A.transpose() * (b - A * x);
    int best = -1;
    double best_w = tol;
    for (int j = 0; j < n; ++j)
      if (!passive[j] && w[j] > best_w) {
        best_w = w[j];
        best = j;
      }
    if (best < 0) break;
    passive[best] = true;
    Eigen::VectorXd s;
    for (int inner = 0; inner < 3 * n + 10; ++inner) {
      solvePassive(&s);
      bool all_pos = true;
      for (int j = 0; j < n; ++j)
        if (passive[j] && s[j] <= 0) all_pos = false;
      if (all_pos) break;
      double alpha = 1.0;
      for (int j = 0; j < n; ++j)
        if (passive[j] && s[j] <= 0) alpha = std::min(alpha, x[j] / (x[j] - s[j]));
      x += alpha * (s - x);
      for (int j = 0; j < n; ++j)
        if (passive[j] && x[j] <= 1e-15 * std::max(1.0, x.cwiseAbs().maxCoeff())) {
          passive[j] = false;
          x[j] = 0;
        }
    }
    for (int j = 0; j < n; ++j) x[j] = passive[j] ? std::max(0.0, s[j]) : 0.0;
  }
  return x;
}

}  // namespace detail

namespace {
using detail::nnls;

struct Column {
  int term;  // IEEE term index, or kNumTerms + extra index
  std::function<double(double)> basis;
};

}  // namespace

const char* noiseTermKey(int term) {
  static const char* keys[] = {"quantization", "angle_random_walk", "bias_instability", "rate_random_walk", "rate_ramp"};
  return (term >= 0 && term < kNumTerms) ? keys[term] : "unknown";
}

std::string noiseTermSetName(int terms, const char* sep) {
  std::string s;
  for (int t = 0; t < kNumTerms; ++t)
    if ((terms >> t) & 1) s += std::string(s.empty() ? "" : sep) + noiseTermKey(t);
  return s;
}

const char* noiseTermUnit(int term) {
  static const char* units[] = {"rad", "rad/sqrt(s)", "rad/s", "rad/s/sqrt(s)", "rad/s^2"};
  return (term >= 0 && term < kNumTerms) ? units[term] : "";
}

double noiseTermBasis(int term, double tau) {
  switch (term) {
    case kQuantization: return 3.0 / (tau * tau);
    case kAngleRandomWalk: return 1.0 / tau;
    case kBiasInstability: return kFlickerFactor;
    case kRateRandomWalk: return tau / 3.0;
    case kRateRamp: return tau * tau / 2.0;
    default: return 0.0;
  }
}

Coefficient coefficientFromSquare(double c, double c_sigma, double z_support, double k68, double k95) {
  Coefficient co;
  const double sc = std::max(0.0, c_sigma);
  co.supported = c > 0 && c > z_support * sc;
  if (co.supported) {
    co.value = std::sqrt(c);
    co.sigma = 0.5 * sc / co.value;
    co.lo68 = std::sqrt(std::max(0.0, c - k68 * sc));
    co.lo95 = std::sqrt(std::max(0.0, c - k95 * sc));
  } else {
    co.sigma = std::sqrt(std::max(0.0, std::max(0.0, c) + sc));
  }
  co.hi68 = std::sqrt(std::max(0.0, c + k68 * sc));
  co.hi95 = std::sqrt(std::max(0.0, c + k95 * sc));
  return co;
}

// The flicker's Allan variance at m samples over its long-tau floor, exact for Kasdin's discrete 1/f noise (white
// noise through (1 - z^-1)^(-1/2), the form simulate.cpp generates): its first differences have the autocorrelation
// rho(h) = prod_{k<=h} (k - 3/2) / (k + 1/2) and variance 4/pi, their partial sums the structure function D(h), and
// AVAR(m) = sum_{|h|<m} (m - |h|) [D(m + h) + D(|m - h|) - 2 D(|h|)] / (4 m^2). 1.4427 at m = 1, 1.1542 at 2, 1.05 at 4,
// 1.0004 at 64; beyond the table (512 samples, its excess 8e-6) the excess is continued as 1/m^2 (it falls about as
// log(m)/m^2: exponent 1.85 between 64 and 256, 1.87 between 256 and 1024; the tail's error is below 3e-7). The table
// costs ~0.4 ms once (to 2048 it was 6 ms, a process's start).
double flickerAvarShape(double m) {
  constexpr int kMax = 512;
  static const std::vector<double> table = [] {
    std::vector<double> d(2 * kMax + 1, 0.0);  // D(h)
    const double g0 = 4.0 / M_PI;
    double rho = 1.0, step = g0;  // step = D(h) - D(h - 1) = g0 + 2 sum_{j<h} gamma(j)
    for (int h = 1; h <= 2 * kMax; ++h) {
      d[static_cast<size_t>(h)] = d[static_cast<size_t>(h - 1)] + step;
      rho *= (h - 1.5) / (h + 0.5);
      step += 2.0 * g0 * rho;
    }
    std::vector<double> g(kMax + 1, 1.0);
    for (int mm = 1; mm <= kMax; ++mm) {
      double s = 0;
      for (int h = -(mm - 1); h <= mm - 1; ++h) {
        const int a = std::abs(h);
        s += (mm - a) * (d[static_cast<size_t>(mm + h)] + d[static_cast<size_t>(std::abs(mm - h))] - 2.0 * d[static_cast<size_t>(a)]);
      }
      g[static_cast<size_t>(mm)] = s / (4.0 * mm * mm) / kFlickerFactor;
    }
    return g;
  }();
  if (!(m > 1)) return table[1];
  if (m >= kMax) return 1.0 + (table[kMax] - 1.0) * (kMax / m) * (kMax / m);
  const int i = static_cast<int>(m);
  const double f = m - i;
  return table[static_cast<size_t>(i)] * (1 - f) + table[static_cast<size_t>(i + 1)] * f;
}

double noiseTermBasis(int term, double tau, double tau0) {
  const double b = noiseTermBasis(term, tau);
  return term == kBiasInstability && tau0 > 0 ? b * flickerAvarShape(tau / tau0) : b;
}

double termVariance(const FitResult& fit, int term, double tau) {
  const double v = fit.terms[static_cast<size_t>(term)].value;
  return v * v * noiseTermBasis(term, tau, fit.tau0);
}

double modelVariance(const FitResult& fit, double tau, const std::vector<ExtraTerm>& extra) {
  double s = 0;
  for (int t = 0; t < kNumTerms; ++t) s += termVariance(fit, t, tau);
  for (size_t e = 0; e < extra.size() && e < fit.extra_c.size(); ++e) s += fit.extra_c[e] * extra[e].basis(tau);
  return s;
}

bool grossMisfit(const FitResult& fit) { return fit.gls && fit.chi2_p < 1e-6 && fit.chi2_dof > 10.0; }

FitError fitErrorOf(const FitResult& fit) {
  FitError e;
  e.rms_log10 = fit.rms_log10;
  e.chi2_dof = fit.chi2_dof;
  e.n_rms = fit.n_rms;
  e.worst_adev_ratio = fit.worst_adev_ratio;
  if (fit.gls) e.chi2_p = fit.chi2_p;
  return e;
}

FitError fitError(const DeviationCurve& curve, const std::vector<double>& model_var, const std::vector<bool>& used,
                  int n_params, double rms_min_edf) {
  FitError e;
  double chi2 = 0, sum_log = 0;
  int n_used = 0;
  for (size_t i = 0; i < curve.points.size() && i < model_var.size(); ++i) {
    const auto& p = curve.points[i];
    const double m = model_var[i];
    if (!(m > 0) || !(p.var > 0)) continue;
    if (i < used.size() && used[i]) {
      const double r = p.var / m - 1.0;
      chi2 += 0.5 * p.edf * r * r;
      ++n_used;
    }
    if (i < used.size() && used[i] && p.edf >= kTightEdf) {
      const double ratio = std::sqrt(p.var > m ? p.var / m : m / p.var);
      e.worst_adev_ratio = std::max(e.worst_adev_ratio, ratio);
    }
    if (p.edf >= rms_min_edf && (i >= used.size() || used[i])) {
      const double l = 0.5 * std::log10(p.var / m);
      sum_log += l * l;
      ++e.n_rms;
    }
  }
  const int dof = std::max(1, n_used - n_params);
  e.chi2_dof = chi2 / dof;
  e.rms_log10 = e.n_rms > 0 ? std::sqrt(sum_log / e.n_rms) : std::numeric_limits<double>::quiet_NaN();
  return e;
}

namespace {
FitResult fitNoiseModelEdf(const DeviationCurve& curve, const FitOptions& options, const std::vector<ExtraTerm>& extra);
}  // namespace

FitResult fitNoiseModel(const DeviationCurve& curve, const FitOptions& options, const std::vector<ExtraTerm>& extra) {
  const bool gls = options.weighting == FitWeighting::Covariance && detail::glsApplies(curve);
  FitResult r = gls ? detail::fitNoiseModelGls(curve, options, extra) : fitNoiseModelEdf(curve, options, extra);
  r.tau0 = curve.tau0;
  return r;
}

namespace {

// ---- fitNoiseModelEdf, stage by stage ---------------------------------------------------------------------------

// Points to fit and every point's EDF (edf <= 0: the non-overlapping count N/m - 1 as a conservative stand-in);
// fills r->tau and r->used.
void selectPoints(const DeviationCurve& curve, const FitOptions& options, FitResult* r, std::vector<int>* pts,
                  std::vector<double>* edf) {
  const size_t np = curve.points.size();
  edf->assign(np, 0.0);
  for (size_t i = 0; i < np; ++i) {
    const auto& p = curve.points[i];
    r->tau[i] = p.tau;
    double e = p.edf;
    if (!(e > 0) && p.m > 0) e = static_cast<double>(curve.n_phase) / static_cast<double>(p.m) - 1.0;
    (*edf)[i] = e;
    if (p.tau > 0 && std::isfinite(p.var) && p.var > 0 && std::isfinite(e) && e >= options.min_edf) {
      pts->push_back(static_cast<int>(i));
      r->used[i] = true;
    }
  }
}

// The design's columns: the enabled IEEE terms, then the extra terms.
std::vector<Column> fitColumns(const FitOptions& options, const std::vector<ExtraTerm>& extra, double tau0) {
  std::vector<Column> all_cols;
  for (int t = 0; t < kNumTerms; ++t)
    if (options.enabled[static_cast<size_t>(t)])
      all_cols.push_back({t, [t, tau0](double tau) { return noiseTermBasis(t, tau, tau0); }});
  for (size_t e = 0; e < extra.size(); ++e) all_cols.push_back({kNumTerms + static_cast<int>(e), extra[e].basis});
  return all_cols;
}

// Weights: AVAR estimates at nearby taus are strongly correlated (a 10-per-decade grid has ~3 points per octave
// that share most of their data). Treating them as independent overstates the information and understates the
// coefficient sigmas, so each point's EDF is divided by the number of fitted points within +-1/2 octave of it.
std::vector<double> decorrelatedEdf(const DeviationCurve& curve, const FitOptions& options,
                                    const std::vector<int>& pts, const std::vector<double>& edf) {
  std::vector<double> wedf(edf);
  if (!options.decorrelate) return wedf;
  for (int i : pts) {
    int count = 0;
    for (int j : pts) {
      const double ratio = curve.points[static_cast<size_t>(j)].tau / curve.points[static_cast<size_t>(i)].tau;
      if (ratio >= M_SQRT1_2 * (1 - 1e-12) && ratio < M_SQRT2 * (1 - 1e-12)) ++count;
    }
    wedf[static_cast<size_t>(i)] = edf[static_cast<size_t>(i)] / std::max(1, count);
  }
  return wedf;
}

// The iterated, reweighted NNLS on the fitted points: columns, which are active, coefficients, and the model at the
// points that sets the weights.
struct EdfSolver {
  const DeviationCurve& curve;
  const FitOptions& options;
  const std::vector<int>& pts;
  const std::vector<double>& wedf;
  const std::vector<Column>& all_cols;
  int m;                       // fitted points
  std::vector<bool> active;    // per column
  Eigen::VectorXd c;           // coefficient per column
  std::vector<double> model;   // model variance at the fitted points (starts at the measured one)

  EdfSolver(const DeviationCurve& cv, const FitOptions& o, const std::vector<int>& p, const std::vector<double>& w,
            const std::vector<Column>& cols)
      : curve(cv), options(o), pts(p), wedf(w), all_cols(cols), m(static_cast<int>(p.size())),
        active(cols.size(), true), c(Eigen::VectorXd::Zero(static_cast<int>(cols.size()))),
        model(static_cast<size_t>(m)) {
    for (int i = 0; i < m; ++i) model[static_cast<size_t>(i)] = curve.points[static_cast<size_t>(pts[static_cast<size_t>(i)])].var;
  }

  // Weighted design over the given columns.
  void design(const std::vector<int>& cols, Eigen::MatrixXd* A, Eigen::VectorXd* b) const {
    A->resize(m, static_cast<int>(cols.size()));
    b->resize(m);
    for (int i = 0; i < m; ++i) {
      const auto& p = curve.points[static_cast<size_t>(pts[static_cast<size_t>(i)])];
      const double s = std::sqrt(0.5 * wedf[static_cast<size_t>(pts[static_cast<size_t>(i)])]) / model[static_cast<size_t>(i)];
      for (size_t k = 0; k < cols.size(); ++k) (*A)(i, static_cast<int>(k)) = s * all_cols[static_cast<size_t>(cols[k])].basis(p.tau);
      (*b)[i] = s * p.var;
    }
  }
  // Design with unit-norm columns (the basis functions span ~12 decades over the taus); scale holds the norms.
  void scaledDesign(const std::vector<int>& cols, Eigen::MatrixXd* A, Eigen::VectorXd* b, Eigen::VectorXd* scale) const {
    design(cols, A, b);
    scale->resize(A->cols());
    for (int k = 0; k < A->cols(); ++k) {
      (*scale)[k] = A->col(k).norm();
      if ((*scale)[k] > 0) A->col(k) /= (*scale)[k];
    }
  }
  // Indices of the active columns.
  std::vector<int> activeCols() const {
    std::vector<int> cols;
    for (size_t k = 0; k < all_cols.size(); ++k)
      if (active[k]) cols.push_back(static_cast<int>(k));
    return cols;
  }
  // Model at the fitted points from the current coefficients (kept where it is not positive).
  void updateModel() {
    for (int i = 0; i < m; ++i) {
      const double tau = curve.points[static_cast<size_t>(pts[static_cast<size_t>(i)])].tau;
      double v = 0;
      for (size_t k = 0; k < all_cols.size(); ++k)
        if (c[static_cast<int>(k)] > 0) v += c[static_cast<int>(k)] * all_cols[k].basis(tau);
      if (v > 0) model[static_cast<size_t>(i)] = v;
    }
  }
  // NNLS on the active columns, reweighted by the model, options.iterations times.
  void solveIrls() {
    for (int it = 0; it < std::max(1, options.iterations); ++it) {
      const std::vector<int> cols = activeCols();
      Eigen::MatrixXd A;
      Eigen::VectorXd b, scale;
      scaledDesign(cols, &A, &b, &scale);
      Eigen::VectorXd x = nnls(A, b);
      c.setZero();
      for (size_t k = 0; k < cols.size(); ++k)
        c[cols[k]] = scale[static_cast<int>(k)] > 0 ? x[static_cast<int>(k)] / scale[static_cast<int>(k)] : 0.0;
      updateModel();
    }
  }
  // Covariance of c over the given columns at the current weights (inverse Fisher information).
  void covariance(const std::vector<int>& cols, Eigen::MatrixXd* cov) const {
    Eigen::MatrixXd A;
    Eigen::VectorXd b, scale;
    scaledDesign(cols, &A, &b, &scale);
    Eigen::MatrixXd F = A.transpose() * A;
    Eigen::MatrixXd Finv = F.completeOrthogonalDecomposition().pseudoInverse();
    *cov = Finv;
    for (int i = 0; i < cov->rows(); ++i)
      for (int j = 0; j < cov->cols(); ++j) {
        const double si = scale[i], sj = scale[j];
        (*cov)(i, j) = (si > 0 && sj > 0) ? Finv(i, j) / (si * sj) : 0.0;
      }
  }
  // Backward elimination: drop the least significant IEEE term while any is below options.significance sigma, then
  // refit. Returns the terms dropped for insignificance (they still count in the covariance).
  std::vector<int> eliminate() {
    std::vector<int> eliminated;
    for (size_t round = 0; round < all_cols.size(); ++round) {
      std::vector<int> pos;
      for (size_t k = 0; k < all_cols.size(); ++k) {
        if (!active[k]) continue;
        if (c[static_cast<int>(k)] > 0) pos.push_back(static_cast<int>(k));
        else if (all_cols[k].term < kNumTerms) active[k] = false;  // NNLS put it at the bound
      }
      if (pos.empty()) break;
      Eigen::MatrixXd cov;
      covariance(pos, &cov);
      int worst = -1;
      double worst_z = options.significance;
      for (size_t k = 0; k < pos.size(); ++k) {
        if (all_cols[static_cast<size_t>(pos[k])].term >= kNumTerms) continue;  // extra terms are the caller's to judge
        const double sd = std::sqrt(std::max(0.0, cov(static_cast<int>(k), static_cast<int>(k))));
        const double z = sd > 0 ? c[pos[k]] / sd : std::numeric_limits<double>::infinity();
        if (z < worst_z) {
          worst_z = z;
          worst = pos[k];
        }
      }
      if (worst < 0) break;
      active[static_cast<size_t>(worst)] = false;
      eliminated.push_back(worst);
      c[worst] = 0;
      solveIrls();
    }
    return eliminated;
  }
  // The supported columns: active with a positive coefficient.
  std::vector<int> supportedCols() const {
    std::vector<int> pos;
    for (size_t k = 0; k < all_cols.size(); ++k)
      if (active[k] && c[static_cast<int>(k)] > 0) pos.push_back(static_cast<int>(k));
    return pos;
  }
};

// Final statistics: model at every point, chi2/dof and RMS log10 error with n_params supported terms. Returns the
// factor the uncertainties are scaled by when the model under-explains the scatter (max(1, chi2/dof)).
double finalStatistics(const EdfSolver& s, const std::vector<double>& edf, int n_params, FitResult* r) {
  const DeviationCurve& curve = s.curve;
  const size_t np = curve.points.size();
  for (size_t i = 0; i < np; ++i) {
    double v = 0;
    for (size_t k = 0; k < s.all_cols.size(); ++k)
      if (s.c[static_cast<int>(k)] > 0) v += s.c[static_cast<int>(k)] * s.all_cols[k].basis(curve.points[i].tau);
    r->model_var[i] = v;
  }
  DeviationCurve weighted = curve;
  for (size_t i = 0; i < np; ++i) weighted.points[i].edf = edf[i];
  const FitError fe = fitError(weighted, r->model_var, r->used, n_params, s.options.rms_min_edf);
  r->dof = std::max(1, s.m - n_params);
  r->chi2_dof = fe.chi2_dof;
  r->chi2 = fe.chi2_dof * r->dof;
  r->rms_log10 = fe.rms_log10;
  r->n_rms = fe.n_rms;
  r->worst_adev_ratio = fe.worst_adev_ratio;
  return std::max(1.0, r->chi2_dof);
}

// Coefficient sqrt(c) from c = cval with variance cvar (scaled by inflate): value, sigma and intervals when
// supported, otherwise its 1-sigma and one-sided upper bounds.
Coefficient coefficientFrom(double cval, double cvar, double inflate, bool supported) {
  Coefficient co;
  co.supported = supported;
  if (supported) {
    co.value = std::sqrt(cval);
    co.sigma = std::sqrt(cvar * inflate) / (2.0 * co.value);
  } else {
    co.value = 0;
    co.sigma = std::sqrt(std::max(0.0, cval) + std::sqrt(cvar * inflate));  // 1-sigma upper bound
  }
  const double sc = std::sqrt(std::max(0.0, cvar * inflate));
  if (supported) {
    co.lo68 = std::sqrt(std::max(0.0, cval - sc));
    co.hi68 = std::sqrt(cval + sc);
    co.lo95 = std::sqrt(std::max(0.0, cval - kZ95 * sc));
    co.hi95 = std::sqrt(cval + kZ95 * sc);
  } else {
    co.hi68 = std::sqrt(std::max(0.0, std::max(0.0, cval) + 0.4758 * sc));  // one-sided 68.3 %: z = 0.4758
    co.hi95 = std::sqrt(std::max(0.0, std::max(0.0, cval) + kZ95OneSided * sc));
  }
  return co;
}

// Stores a column's coefficient in r: an IEEE term's, or an extra term's with its c (0 when unsupported).
void storeCoefficient(const Column& col, const Coefficient& co, double cval, FitResult* r) {
  const int term = col.term;
  if (term < kNumTerms) r->terms[static_cast<size_t>(term)] = co;
  else {
    r->extra[static_cast<size_t>(term - kNumTerms)] = co;
    r->extra_c[static_cast<size_t>(term - kNumTerms)] = co.supported ? cval : 0.0;
  }
}

// Sigmas come from the covariance of the supported terms together with the terms dropped for insignificance:
// a term the data cannot tell apart from a neighbour (bias instability vs rate random walk over a short record)
// was dropped, but the uncertainty it causes in its neighbour must stay in that neighbour's sigma.
void setSupported(const EdfSolver& s, const std::vector<int>& pos, const std::vector<int>& eliminated, double inflate,
                  FitResult* r) {
  if (pos.empty()) return;
  std::vector<int> cols = pos;
  for (int e : eliminated)
    if (std::find(cols.begin(), cols.end(), e) == cols.end()) cols.push_back(e);
  Eigen::MatrixXd cov;
  s.covariance(cols, &cov);
  for (size_t k = 0; k < pos.size(); ++k) {
    const double cval = s.c[pos[k]];
    storeCoefficient(s.all_cols[static_cast<size_t>(pos[k])],
                     coefficientFrom(cval, cov(static_cast<int>(k), static_cast<int>(k)), inflate, true), cval, r);
  }
}

// Bounds of the terms the data does not support: the unconstrained estimate and its sigma when the term is added.
void setBounds(const EdfSolver& s, const std::vector<int>& pos, double inflate, FitResult* r) {
  for (size_t k = 0; k < s.all_cols.size(); ++k) {
    if (std::find(pos.begin(), pos.end(), static_cast<int>(k)) != pos.end()) continue;
    std::vector<int> cols = pos;
    cols.push_back(static_cast<int>(k));
    Eigen::MatrixXd A;
    Eigen::VectorXd b, scale;
    s.scaledDesign(cols, &A, &b, &scale);
    Eigen::VectorXd x = A.colPivHouseholderQr().solve(b);
    const int last = static_cast<int>(cols.size()) - 1;
    const double cu = scale[last] > 0 ? x[last] / scale[last] : 0.0;
    Eigen::MatrixXd cov;
    s.covariance(cols, &cov);
    storeCoefficient(s.all_cols[k], coefficientFrom(cu, std::max(0.0, cov(last, last)), inflate, false), cu, r);
  }
}

/// EDF-weighted relative least squares (FitWeighting::Edf, and curves the GLS does not apply to).
FitResult fitNoiseModelEdf(const DeviationCurve& curve, const FitOptions& options, const std::vector<ExtraTerm>& extra) {
  FitResult r;
  const size_t np = curve.points.size();
  r.tau.resize(np);
  r.model_var.assign(np, 0.0);
  r.used.assign(np, false);
  r.extra.assign(extra.size(), Coefficient{});
  r.extra_c.assign(extra.size(), 0.0);

  std::vector<int> pts;
  std::vector<double> edf;
  selectPoints(curve, options, &r, &pts, &edf);
  const std::vector<Column> all_cols = fitColumns(options, extra, curve.tau0);
  if (pts.size() < 2 || all_cols.empty()) {
    r.message = "too few Allan-variance points to fit (" + std::to_string(pts.size()) + ")";
    return r;
  }
  const std::vector<double> wedf = decorrelatedEdf(curve, options, pts, edf);
  EdfSolver s(curve, options, pts, wedf, all_cols);
  s.solveIrls();
  const std::vector<int> eliminated = s.eliminate();
  const std::vector<int> pos = s.supportedCols();
  const double inflate = finalStatistics(s, edf, static_cast<int>(pos.size()), &r);
  setSupported(s, pos, eliminated, inflate, &r);
  setBounds(s, pos, inflate, &r);
  r.ok = true;
  return r;
}
}  // namespace

}  // namespace gyro_allan
