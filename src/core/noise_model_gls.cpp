// IEEE 952 fit by generalized least squares: every term fitted at once under non-negativity, weighted by the covariance
// of the overlapping AVAR estimates across tau (avar_covariance.hpp) at the fitted model itself, with unified intervals.
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <mutex>

#include <boost/math/distributions/chi_squared.hpp>

#include "gyro_allan/avar_covariance.hpp"
#include "gyro_allan/unified_interval.hpp"
#include "noise_model_internal.hpp"

namespace gyro_allan {
namespace {

constexpr double kMisfitP = 0.01;        // below this chi-squared p-value the sigmas are inflated by sqrt(chi2/dof)

/// Column t of the design at tau: an IEEE term's basis (B's at the record's tau0), else extra term t - kNumTerms's.
double columnBasis(int t, double tau, double tau0, const std::vector<ExtraTerm>& extra) {
  return t < kNumTerms ? noiseTermBasis(t, tau, tau0) : extra[static_cast<size_t>(t - kNumTerms)].basis(tau);
}

/// Octave-spaced subset: a denser grid's neighbours share most of their data (correlation > 0.9) and make the
/// covariance near-singular, while adding almost no information.
constexpr double kMinRatio = 1.9;

/// Bases of recent curves, shared by all threads (sharedAvarCovarianceBasis): the axes of one record have the same
/// averaging factors and term counts, and the model check refits the same curve dozens of times, on point sets that
/// differ from the fit's by a point or two (a basis costs ~50 ms on a 1 h 400 Hz record; an entry reused, nothing).
std::shared_ptr<const AvarCovarianceBasis> cachedBasis(const std::vector<int64_t>& m, const std::vector<int64_t>& n,
                                                       double tau0) {
  return sharedAvarCovarianceBasis(m, n, tau0);
}

double chi2UpperTail(double chi2, int dof) {
  if (dof < 1 || !std::isfinite(chi2)) return std::numeric_limits<double>::quiet_NaN();
  if (chi2 <= 0) return 1.0;
  return boost::math::cdf(boost::math::complement(boost::math::chi_squared(dof), chi2));
}

/// The points and their covariance machinery for one curve.
struct GlsProblem {
  std::vector<int> idx;          // curve point indices in the fit
  Eigen::VectorXd y;             // measured AVAR
  Eigen::VectorXd fallback_var;  // variance of each estimate from its EDF, where the model gives none
  std::shared_ptr<const AvarCovarianceBasis> basis;
  std::vector<int> term;         // column -> IEEE term (or kNumTerms + extra index)
  Eigen::MatrixXd F;             // design: column basis at each point's tau

  /// Covariance of the estimates at the model with coefficient weights c (per column).
  Eigen::MatrixXd covariance(const Eigen::VectorXd& c) const {
    const int n = static_cast<int>(idx.size());
    std::array<double, 5> s{{0, 0, 0, 0, 0}};
    Eigen::VectorXd ieee = Eigen::VectorXd::Zero(n), full = Eigen::VectorXd::Zero(n);
    for (int k = 0; k < c.size(); ++k) {
      if (!(c[k] > 0)) continue;
      if (term[static_cast<size_t>(k)] < kNumTerms) {
        s[static_cast<size_t>(term[static_cast<size_t>(k)])] = c[k];
        ieee += c[k] * F.col(k);
      }
      full += c[k] * F.col(k);
    }
    Eigen::MatrixXd cov = avarCovariance(*basis, s);
    // Extra terms (model check effects) have no generalized covariance here: their share of each point's AVAR
    // scales that point's row and column, as if their estimate scattered like the IEEE part's.
    for (int i = 0; i < n; ++i) {
      const double ratio = ieee[i] > 0 ? full[i] / ieee[i] : 1.0;
      if (ratio != 1.0) {
        cov.row(i) *= ratio;
        cov.col(i) *= ratio;
      }
    }
    for (int i = 0; i < n; ++i) {
      if (!(cov(i, i) > 0)) {
        cov.row(i).setZero();
        cov.col(i).setZero();
        cov(i, i) = fallback_var[i];
      }
      cov(i, i) *= 1.0 + 1e-9;
    }
    return cov;
  }
};

/// Whitened problem for one covariance.
struct Whitened {
  Eigen::MatrixXd A;  // L^-1 F
  Eigen::VectorXd b;  // L^-1 y
  bool ok = false;
};

Whitened whiten(const GlsProblem& P, const Eigen::MatrixXd& cov) {
  Whitened w;
  Eigen::LLT<Eigen::MatrixXd> llt(cov);
  Eigen::MatrixXd c = cov;
  for (int attempt = 0; llt.info() != Eigen::Success && attempt < 6; ++attempt) {
    // Near-singular (many points with the same dominant term): a small ridge relative to each variance.
    for (int i = 0; i < c.rows(); ++i) c(i, i) *= 1.0 + std::pow(10.0, attempt - 7);
    llt.compute(c);
  }
  if (llt.info() != Eigen::Success) return w;
  w.A = llt.matrixL().solve(P.F);
  w.b = llt.matrixL().solve(P.y);
  w.ok = true;
  return w;
}

/// NNLS over the given columns (the others held at 0); returns c per column and the generalized chi-squared.
double solveNnls(const Whitened& w, const std::vector<int>& cols, Eigen::VectorXd* c) {
  c->setZero(w.A.cols());
  if (cols.empty()) return w.b.squaredNorm();
  Eigen::MatrixXd A(w.A.rows(), static_cast<int>(cols.size()));
  Eigen::VectorXd scale(static_cast<int>(cols.size()));
  for (size_t k = 0; k < cols.size(); ++k) {
    A.col(static_cast<int>(k)) = w.A.col(cols[k]);
    scale[static_cast<int>(k)] = A.col(static_cast<int>(k)).norm();
    if (scale[static_cast<int>(k)] > 0) A.col(static_cast<int>(k)) /= scale[static_cast<int>(k)];
  }
  const Eigen::VectorXd x = detail::nnls(A, w.b);
  for (size_t k = 0; k < cols.size(); ++k)
    (*c)[cols[k]] = scale[static_cast<int>(k)] > 0 ? x[static_cast<int>(k)] / scale[static_cast<int>(k)] : 0.0;
  return (w.b - w.A * *c).squaredNorm();
}

/// Unconstrained GLS over the columns: estimates and their covariance (inverse information).
void solveFree(const Whitened& w, const std::vector<int>& cols, Eigen::VectorXd* est, Eigen::MatrixXd* cov) {
  const int k = static_cast<int>(cols.size());
  Eigen::MatrixXd A(w.A.rows(), k);
  Eigen::VectorXd scale(k);
  for (int j = 0; j < k; ++j) {
    A.col(j) = w.A.col(cols[static_cast<size_t>(j)]);
    scale[j] = A.col(j).norm();
    if (scale[j] > 0) A.col(j) /= scale[j];
  }
  const Eigen::MatrixXd info = A.transpose() * A;
  const Eigen::MatrixXd inv = info.completeOrthogonalDecomposition().pseudoInverse();
  const Eigen::VectorXd x = inv * (A.transpose() * w.b);
  est->resize(k);
  cov->resize(k, k);
  for (int i = 0; i < k; ++i) {
    (*est)[i] = scale[i] > 0 ? x[i] / scale[i] : 0.0;
    for (int j = 0; j < k; ++j) (*cov)(i, j) = (scale[i] > 0 && scale[j] > 0) ? inv(i, j) / (scale[i] * scale[j]) : 0.0;
  }
}

/// Builds the problem over the octave-spaced usable points; false if fewer than 2.
bool buildProblem(const DeviationCurve& curve, const FitOptions& options, const std::vector<ExtraTerm>& extra,
                  FitResult* r, GlsProblem* P) {
  const size_t np = curve.points.size();
  std::vector<int64_t> ms, ns;
  int64_t last_m = 0;
  for (size_t i = 0; i < np; ++i) {
    const auto& p = curve.points[i];
    // Points by their non-overlapping term count (the most conservative EDF), not by the identified or model EDF:
    // both passes of fitWithModelEdf and every axis of a record then share one set of points and one basis.
    double e = p.edf;
    if (!(e > 0) && p.m > 0) e = static_cast<double>(curve.n_phase) / static_cast<double>(p.m) - 1.0;
    if (!(p.tau > 0 && std::isfinite(p.var) && p.var > 0 && std::isfinite(e) && e >= options.min_edf)) continue;
    r->used[i] = true;
    if (last_m > 0 && static_cast<double>(p.m) < kMinRatio * static_cast<double>(last_m)) continue;
    last_m = p.m;
    P->idx.push_back(static_cast<int>(i));
    ms.push_back(p.m);
    ns.push_back(p.n_terms);
    r->gls_used[i] = true;
  }
  const int n = static_cast<int>(P->idx.size());
  if (n < 2) return false;
  P->basis = cachedBasis(ms, ns, curve.tau0);
  P->y.resize(n);
  P->fallback_var.resize(n);
  for (int i = 0; i < n; ++i) {
    const auto& p = curve.points[static_cast<size_t>(P->idx[static_cast<size_t>(i)])];
    P->y[i] = p.var;
    double e = p.edf > 0 ? p.edf : static_cast<double>(curve.n_phase) / static_cast<double>(p.m) - 1.0;
    P->fallback_var[i] = 2.0 * p.var * p.var / std::max(1.0, e);
  }
  for (int t = 0; t < kNumTerms; ++t)
    if (options.enabled[static_cast<size_t>(t)]) P->term.push_back(t);
  for (size_t e = 0; e < extra.size(); ++e) P->term.push_back(kNumTerms + static_cast<int>(e));
  P->F.resize(n, static_cast<int>(P->term.size()));
  for (int i = 0; i < n; ++i) {
    const double tau = curve.points[static_cast<size_t>(P->idx[static_cast<size_t>(i)])].tau;
    for (size_t k = 0; k < P->term.size(); ++k) {
      const int t = P->term[k];
      P->F(i, static_cast<int>(k)) = columnBasis(t, tau, curve.tau0, extra);
    }
  }
  return true;
}

// The GLS fit of one curve, stage by stage (fitNoiseModelGls runs them in order). The members are the state the
// stages share: the problem, the coefficients, and the result being filled.
struct GlsFit {
  const DeviationCurve& curve;
  const FitOptions& options;
  const std::vector<ExtraTerm>& extra;
  FitResult r;
  GlsProblem P;
  int ncol = 0;
  std::vector<int> all, ieee_cols;  // column sets: every column, the IEEE terms'
  Eigen::VectorXd c;                // coefficient weights (AVAR units), per column
  std::vector<int> pos;             // the columns with a positive weight
  std::vector<double> sd0;          // per column: sd of its estimate at the fit (misfit inflation included)
  Eigen::LLT<Eigen::MatrixXd> fit_llt;  // Cholesky factor of the covariance at the fit

  GlsFit(const DeviationCurve& curve_, const FitOptions& options_, const std::vector<ExtraTerm>& extra_)
      : curve(curve_), options(options_), extra(extra_) {}

  // The working covariance the estimate is weighted by: the diagonal of the points' covariance at the model
  // (working independence), or the full covariance (GLS) when FitOptions::working_independence is off.
  Eigen::MatrixXd working(const Eigen::VectorXd& cc) const {
    Eigen::MatrixXd cov = P.covariance(cc);
    if (options.working_independence) return Eigen::MatrixXd(cov.diagonal().asDiagonal());
    return cov;
  }

  // The result's fixed fields and per-point arrays.
  void initResult() {
    const size_t np = curve.points.size();
    r.gls = true;
    r.uncertainty =
        "GLS: inverse information with the analytic covariance of the AVAR estimates at the fitted model; unified "
        "(Feldman-Cousins) intervals on each term's AVAR weight";
    r.tau.resize(np);
    for (size_t i = 0; i < np; ++i) r.tau[i] = curve.points[i].tau;
    r.model_var.assign(np, 0.0);
    r.used.assign(np, false);
    r.gls_used.assign(np, false);
    r.extra.assign(extra.size(), Coefficient{});
    r.extra_c.assign(extra.size(), 0.0);
    for (auto& row : r.correlation) row.fill(std::numeric_limits<double>::quiet_NaN());
  }

  void columns() {
    ncol = static_cast<int>(P.term.size());
    all.resize(static_cast<size_t>(ncol));
    for (int k = 0; k < ncol; ++k) {
      all[static_cast<size_t>(k)] = k;
      if (P.term[static_cast<size_t>(k)] < kNumTerms) ieee_cols.push_back(k);
    }
  }

  // Every term at once, non-negative, weighted by the covariance of the estimates at the current fit: from each
  // estimate's variance by its EDF, refitted at the covariance of the last fit until the model stops moving (the
  // fixed point is the quasi-likelihood estimate, whose estimating equation is unbiased). False when the EDF-weighted
  // start is not positive definite.
  bool fit() {
    {
      const Whitened w = whiten(P, P.fallback_var.asDiagonal());
      if (!w.ok) return false;
      solveNnls(w, all, &c);
    }
    constexpr int kMaxIterations = 30;
    constexpr double kConverged = 1e-6;  // largest relative change of the model AVAR at a fitted point
    for (int it = 0; it < kMaxIterations; ++it) {
      const Whitened w = whiten(P, working(c));
      if (!w.ok) break;
      Eigen::VectorXd next;
      solveNnls(w, all, &next);
      const Eigen::VectorXd before = P.F * c, after = P.F * next;
      double change = 0;
      for (int i = 0; i < before.size(); ++i)
        change = std::max(change, std::fabs(after[i] - before[i]) / std::max(after[i], 1e-300));
      c = next;
      if (change < kConverged) break;
    }
    return true;
  }

  // Chi-squared at the fitted model's own covariance, its p-value, the misfit inflation, and the evidence: how much
  // the chi-squared rises when each term with a positive weight is held at 0 (0 for the others).
  void statistics(const Whitened& w) {
    const int n = static_cast<int>(P.idx.size());
    for (int k = 0; k < ncol; ++k)
      if (c[k] > 0) pos.push_back(k);
    const double chi2 = (w.b - w.A * c).squaredNorm();
    Eigen::VectorXd best;  // evidence is relative to the best full-covariance fit (the GLS fit itself)
    const double chi2_min = options.working_independence ? solveNnls(w, all, &best) : chi2;
    r.dof = std::max(1, n - static_cast<int>(pos.size()));
    r.chi2 = chi2;
    r.chi2_dof = chi2 / r.dof;
    r.chi2_p = chi2UpperTail(chi2, r.dof);
    r.uncertainty_inflation = (r.chi2_p < kMisfitP && r.chi2_dof > 1) ? r.chi2_dof : 1.0;
    for (int col : ieee_cols) {
      if (!(c[col] > 0)) continue;
      std::vector<int> cols;
      for (int k : all)
        if (k != col) cols.push_back(k);
      Eigen::VectorXd tmp;
      r.evidence[static_cast<size_t>(P.term[static_cast<size_t>(col)])] = solveNnls(w, cols, &tmp) - chi2_min;
    }
  }

  // The linear weights g of the free estimate of column `col` (at position k of cols) at the fitted covariance C:
  // estimate = g' y with g = C^-1 F (F' C^-1 F)^-1 e_k (F: the columns `cols`). Empty when C is not positive definite.
  Eigen::VectorXd weightsOf(const std::vector<int>& cols, int k) const {
    if (fit_llt.info() != Eigen::Success) return {};
    const int m = static_cast<int>(cols.size());
    Eigen::MatrixXd Fc(P.F.rows(), m);
    for (int j = 0; j < m; ++j) {
      Fc.col(j) = P.F.col(cols[static_cast<size_t>(j)]);
      const double nrm = Fc.col(j).norm();
      if (nrm > 0) Fc.col(j) /= nrm;  // scaled for the inverse; undone below
    }
    const Eigen::MatrixXd CiF = fit_llt.solve(Fc);
    const Eigen::MatrixXd inv = (Fc.transpose() * CiF).completeOrthogonalDecomposition().pseudoInverse();
    const double nrm = P.F.col(cols[static_cast<size_t>(k)]).norm();
    return nrm > 0 ? Eigen::VectorXd(CiF * inv.col(k) / nrm) : Eigen::VectorXd();
  }

  // sd of that estimate when the column's true weight is mu and the other columns' are `at`: the weights stay those
  // of the fit (they are what the estimate used), the scatter of y is the covariance at that truth (a sandwich).
  double sdAt(const Eigen::VectorXd& g, int col, double mu, const Eigen::VectorXd& at) const {
    if (g.size() == 0) return std::numeric_limits<double>::quiet_NaN();
    Eigen::VectorXd cm = at;
    cm[col] = std::max(0.0, mu);
    const double var = g.dot(P.covariance(cm) * g);
    return std::sqrt(std::max(0.0, var * r.uncertainty_inflation));
  }

  // Each term's value, sd and intervals. The estimate x of a term with a positive weight is its weight (the free
  // least-squares value over the positive columns, which the non-negative fit is); of a term at 0, its free value
  // with it added to those columns (<= 0 up to rounding: the fit would otherwise have taken it). x is treated as
  // normal with a variance that grows with the true value (the AVAR scatter does), modelled through three values,
  // and its unified interval is taken on [0, inf): never empty, an upper bound where the term is below its noise,
  // two-sided above, and it holds the reported weight. A term is supported when its 95 % interval excludes 0; that
  // flag never changes the value, so the reported coefficients are the model curve.
  void coefficients(const Whitened& w) {
    sd0.assign(static_cast<size_t>(ncol), 0.0);
    auto longTau = [&](int k) {
      const int t = P.term[static_cast<size_t>(k)];
      return t == kBiasInstability || t == kRateRandomWalk || t == kRateRamp;
    };
    std::vector<double> lo68(static_cast<size_t>(ncol)), hi68(lo68), lo95(lo68), hi95(lo68), sd(lo68);
    // One term's estimate, sd and intervals with the other columns' truth at `at` for the sandwich.
    auto interval = [&](int col, const Eigen::VectorXd& at) {
      // The estimate's columns: the fit's positive ones and the term itself; for a positive B, K or R every enabled
      // one of the three, held at 0 or not, since they trade at the longest taus. (A term at 0 is a bound: the
      // boundary statistic of its free value beside the positive terms.)
      std::vector<int> cols = pos;
      if (!(c[col] > 0)) cols.push_back(col);
      if (longTau(col) && c[col] > 0)
        for (int k : ieee_cols)
          if (longTau(k) && std::find(cols.begin(), cols.end(), k) == cols.end()) cols.push_back(k);
      const int k = static_cast<int>(std::find(cols.begin(), cols.end(), col) - cols.begin());
      Eigen::VectorXd est;
      Eigen::MatrixXd cov;
      solveFree(w, cols, &est, &cov);
      const double x = c[col] > 0 ? c[col] : std::min(0.0, est[k]);
      const size_t u = static_cast<size_t>(col);
      sd[u] = std::sqrt(std::max(0.0, cov(k, k) * r.uncertainty_inflation));
      if (!options.intervals) {  // values only (FitOptions::intervals)
        lo68[u] = hi68[u] = lo95[u] = hi95[u] = std::numeric_limits<double>::quiet_NaN();
        return;
      }
      const Eigen::VectorXd g = weightsOf(cols, k);
      const double s_at_x = sdAt(g, col, std::max(x, 0.0), at);
      if (std::isfinite(s_at_x) && s_at_x > 0) sd[u] = s_at_x;
      const double m1 = std::max({x, sd[u], 1e-300});
      const double mu[3] = {0.0, m1, m1 + 4.0 * std::max(sd[u], 0.25 * m1)};
      double var[3];
      for (int i = 0; i < 3; ++i) {
        const double s = sdAt(g, col, mu[i], at);
        var[i] = std::isfinite(s) && s > 0 ? s * s : sd[u] * sd[u];
      }
      const VarianceModel vm = VarianceModel::through(mu, var);
      unifiedInterval(x, vm, 0.6826894921370859, &lo68[u], &hi68[u]);
      unifiedInterval(x, vm, 0.95, &lo95[u], &hi95[u]);
    };
    for (int col = 0; col < ncol; ++col) interval(col, c);
    // A long-tau term the fit holds at 0 may still be up to its 68 % upper end, and its scatter then widens its
    // positive partners' (with K at 0 the long-tau AVAR of a deterministic ramp looks almost noise-free, and R's
    // interval would be far too narrow): their sandwich is taken with such terms at that upper end.
    if (options.intervals) {
      Eigen::VectorXd at = c;
      bool raised = false;
      for (int k : ieee_cols)
        if (longTau(k) && !(c[k] > 0) && hi68[static_cast<size_t>(k)] > 0) {
          at[k] = hi68[static_cast<size_t>(k)];
          raised = true;
        }
      if (raised)
        for (int col : ieee_cols)
          if (longTau(col) && c[col] > 0) interval(col, at);
    }
    for (int col = 0; col < ncol; ++col) {
      const size_t u = static_cast<size_t>(col);
      sd0[u] = sd[u];
      Coefficient co;
      co.value = std::sqrt(std::max(0.0, c[col]));
      co.lo68 = std::sqrt(lo68[u]);
      co.hi68 = std::sqrt(hi68[u]);
      co.lo95 = std::sqrt(lo95[u]);
      co.hi95 = std::sqrt(hi95[u]);
      co.supported = options.intervals ? lo95[u] > 0 : c[col] > kZ95 * sd[u];
      co.sigma = co.supported ? sd[u] / (2.0 * co.value) : co.hi68;  // delta method; a bound's: its 68 % upper end
      const int t = P.term[u];
      if (t < kNumTerms) {
        r.terms[static_cast<size_t>(t)] = co;
      } else {
        r.extra[static_cast<size_t>(t - kNumTerms)] = co;
        r.extra_c[static_cast<size_t>(t - kNumTerms)] = std::max(0.0, c[col]);
      }
    }
  }

  // The correlation of the IEEE terms' free estimates at the fit (every enabled term free, the estimate's own
  // weights, the points' full covariance at the fit): how B, K and R trade.
  void correlation(const Whitened& w) {
    const int m = static_cast<int>(ieee_cols.size());
    if (!options.working_independence) {  // the GLS's own inverse information is its sandwich
      Eigen::VectorXd est;
      Eigen::MatrixXd cov;
      solveFree(w, ieee_cols, &est, &cov);
      store(cov);
      return;
    }
    std::vector<Eigen::VectorXd> g(static_cast<size_t>(m));
    for (int k = 0; k < m; ++k) g[static_cast<size_t>(k)] = weightsOf(ieee_cols, k);
    for (const auto& gk : g)
      if (gk.size() == 0) return;
    const Eigen::MatrixXd sigma = P.covariance(c);
    Eigen::MatrixXd cov(m, m);
    for (int i = 0; i < m; ++i)
      for (int j = 0; j < m; ++j) cov(i, j) = g[static_cast<size_t>(i)].dot(sigma * g[static_cast<size_t>(j)]);
    store(cov);
  }

  void store(const Eigen::MatrixXd& cov) {
    for (size_t i = 0; i < ieee_cols.size(); ++i)
      for (size_t j = 0; j < ieee_cols.size(); ++j) {
        const double d = std::sqrt(cov(static_cast<int>(i), static_cast<int>(i)) * cov(static_cast<int>(j), static_cast<int>(j)));
        r.correlation[static_cast<size_t>(P.term[static_cast<size_t>(ieee_cols[i])])]
                     [static_cast<size_t>(P.term[static_cast<size_t>(ieee_cols[j])])] =
            d > 0 ? cov(static_cast<int>(i), static_cast<int>(j)) / d : std::numeric_limits<double>::quiet_NaN();
      }
  }

  // The model curve at every point and its fit error over every fitted point.
  void modelCurve() {
    for (size_t i = 0; i < curve.points.size(); ++i) {
      double v = 0;
      for (int k : pos) v += c[k] * columnBasis(P.term[static_cast<size_t>(k)], curve.points[i].tau, curve.tau0, extra);
      r.model_var[i] = v;
    }
    DeviationCurve with_edf = curve;  // points counted by EDF (the non-overlapping count where none is given)
    for (auto& p : with_edf.points)
      if (!(p.edf > 0) && p.m > 0) p.edf = static_cast<double>(curve.n_phase) / static_cast<double>(p.m) - 1.0;
    const FitError fe = fitError(with_edf, r.model_var, r.used, static_cast<int>(pos.size()), options.rms_min_edf);
    r.rms_log10 = fe.rms_log10;
    r.n_rms = fe.n_rms;
    r.worst_adev_ratio = fe.worst_adev_ratio;
  }
};

}  // namespace

namespace detail {

bool glsApplies(const DeviationCurve& curve) {
  if (curve.name != "oadev" || !(curve.tau0 > 0) || curve.points.size() < 2) return false;
  for (const auto& p : curve.points)
    if (p.m < 1 || p.n_terms < 1) return false;
  return true;
}

FitResult fitNoiseModelGls(const DeviationCurve& curve, const FitOptions& options, const std::vector<ExtraTerm>& extra) {
  GlsFit g(curve, options, extra);
  g.initResult();
  if (!buildProblem(curve, options, extra, &g.r, &g.P) || g.P.term.empty()) {
    g.r.message = "too few Allan-variance points to fit (" + std::to_string(g.P.idx.size()) + ")";
    return g.r;
  }
  g.columns();
  const char* not_pd = "covariance of the Allan-variance points is not positive definite";
  if (!g.fit()) {
    g.r.message = not_pd;
    return g.r;
  }
  const Whitened w = whiten(g.P, g.P.covariance(g.c));  // the full covariance: adequacy and evidence
  const Eigen::MatrixXd working = g.working(g.c);
  const Whitened we = options.working_independence ? whiten(g.P, working) : w;  // the estimate's own weights
  if (!w.ok || !we.ok) {
    g.r.message = not_pd;
    return g.r;
  }
  g.statistics(w);
  g.r.intervals = options.intervals;
  if (options.intervals || options.working_independence) g.fit_llt.compute(working);
  g.coefficients(we);
  g.correlation(we);
  g.modelCurve();
  g.r.ok = true;
  return g.r;
}

}  // namespace detail
}  // namespace gyro_allan
