// IEEE 952 fit by generalized least squares: the covariance of the overlapping AVAR estimates across tau
// (avar_covariance.hpp) weights the fit, selects the terms by the chi-squared they buy, and gives the intervals.
#include <algorithm>
#include <bitset>
#include <cmath>
#include <limits>
#include <memory>
#include <mutex>

#include <boost/math/distributions/chi_squared.hpp>

#include "gyro_allan/avar_covariance.hpp"
#include "gyro_allan/avar_skewness.hpp"
#include "gyro_allan/selective.hpp"
#include "noise_model_internal.hpp"

namespace gyro_allan {
namespace {

constexpr double kMisfitP = 0.01;        // below this chi-squared p-value the sigmas are inflated by sqrt(chi2/dof)

/// What an IEEE term must save in chi-squared to enter the selection (FitOptions: the ramp dearer).
double entryPenalty(int term, const FitOptions& options) {
  return term == kRateRamp ? options.ramp_penalty : options.term_penalty;
}

/// Column t of the design at tau: an IEEE term's basis (B's at the record's tau0), else extra term t - kNumTerms's.
double columnBasis(int t, double tau, double tau0, const std::vector<ExtraTerm>& extra) {
  return t < kNumTerms ? noiseTermBasis(t, tau, tau0) : extra[static_cast<size_t>(t - kNumTerms)].basis(tau);
}

/// Whether a dropped term `other` is estimated beside a dropped term `t` (since session 20): a dropped rate random walk
/// beside a dropped ramp and the other way round. Fitted with the selected terms alone, a dropped K took up a dropped
/// ramp's rise (its 68 % interval started above the truth in 62 % of tactical records with a ramp at 4 h, in 23 of
/// 40 at 1 h with a ramp near detection), and a dropped R a dropped K's. Estimated together, neither takes up the
/// other's signal, and the wider sd of the pair is in the interval. B is not added: beside a dropped B, K's interval
/// collapsed on `bags/default.bag` (y: upper end 5.5 against a declared 41.25 deg/h/sqrt(h)). docs/calibration.md,
/// "Session 20".
bool jointEstimate(int t, int other) {
  return (t == kRateRandomWalk && other == kRateRamp) || (t == kRateRamp && other == kRateRandomWalk);
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
// stages share: the problem, the coefficients as they evolve, and the result being filled.
struct GlsFit {
  const DeviationCurve& curve;
  const FitOptions& options;
  const std::vector<ExtraTerm>& extra;
  FitResult r;
  GlsProblem P;
  int ncol = 0;
  std::vector<int> all, extras, ieee_cols;  // column sets: every column, the extra terms', the IEEE terms'
  Eigen::VectorXd c;                         // coefficient weights (AVAR units), per column
  Eigen::VectorXd c_full;                    // ... of the full model (before term selection)
  Eigen::MatrixXd cov_full;                  // the full model's covariance of the estimates
  Eigen::VectorXd rival_c;                   // the closest non-nested rival's weights (selectTerms)
  struct CloseRival {
    double gap;
    int terms;
    size_t index;
    Eigen::VectorXd weights;
  };
  std::vector<CloseRival> close_rivals;      // every close rival (isCloseRival; selectTerms), the closest first
  std::vector<CloseRival> close_supersets;   // every larger set of terms within kSupersetGap on AIC (selectTerms)
  std::vector<int> pos;                      // the selected columns
  struct TermInference {
    bool corrected_out = false;
    double sd0 = 0;
    SelectionEvent event;
    SelectiveEstimate est;
  };
  std::vector<TermInference> inf;

  GlsFit(const DeviationCurve& curve_, const FitOptions& options_, const std::vector<ExtraTerm>& extra_)
      : curve(curve_), options(options_), extra(extra_) {}

  double penalty(int col) const { return entryPenalty(P.term[static_cast<size_t>(col)], options); }

  // The column of IEEE term t (-1 when the problem has none).
  int columnOf(int t) const {
    for (int col : ieee_cols)
      if (P.term[static_cast<size_t>(col)] == t) return col;
    return -1;
  }

  // The result's fixed fields and per-point arrays.
  void initResult() {
    const size_t np = curve.points.size();
    r.gls = true;
    r.uncertainty =
        "GLS: inverse information with the analytic covariance of the AVAR estimates at the fitted model; intervals "
        "and values conditional on the term selection (selective inference)";
    r.tau.resize(np);
    for (size_t i = 0; i < np; ++i) r.tau[i] = curve.points[i].tau;
    r.model_var.assign(np, 0.0);
    r.used.assign(np, false);
    r.gls_used.assign(np, false);
    r.extra.assign(extra.size(), Coefficient{});
    r.extra_c.assign(extra.size(), 0.0);
  }

  // Column sets of the problem.
  void columns() {
    ncol = static_cast<int>(P.term.size());
    all.resize(static_cast<size_t>(ncol));
    for (int k = 0; k < ncol; ++k) {
      all[static_cast<size_t>(k)] = k;
      if (P.term[static_cast<size_t>(k)] >= kNumTerms) extras.push_back(k);
      else ieee_cols.push_back(k);
    }
  }

  // The full model: each estimate's variance from its EDF (relative least squares), then the model's covariance,
  // iterated. False when the EDF-weighted start is not positive definite.
  bool fitFullModel() {
    {
      Whitened w = whiten(P, P.fallback_var.asDiagonal());
      if (!w.ok) return false;
      solveNnls(w, all, &c);
    }
    for (int it = 0; it < 4; ++it) {
      const Whitened w = whiten(P, P.covariance(c));
      if (!w.ok) break;
      Eigen::VectorXd next;
      solveNnls(w, all, &next);
      c = next;
    }
    // The covariance stays the full model's from here on: a term dropped for want of evidence may still be there
    // below detection, and the scatter it causes must stay in the weights (with the reduced model's covariance, a
    // record with weak B and K gave chi2/dof ~ 20 for its N-only answer).
    cov_full = P.covariance(c);
    c_full = c;
    return true;
  }

  // Term selection at the full model's covariance: every subset of the IEEE terms (extra terms always in), scored
  // by chi-squared plus a penalty per selected term.
  void selectTerms() {
    const Whitened w = whiten(P, cov_full);
    if (!w.ok) return;
    double best_score = std::numeric_limits<double>::infinity();
    Eigen::VectorXd best_c = c;
    const int ne = static_cast<int>(ieee_cols.size());
    struct Scored {
      int terms;           // IEEE terms with a positive weight, as 1 << term
      double score, aic;   // the selection's score (chi-squared + penalties) and AIC's (chi-squared + 2 per term)
    };
    std::vector<Scored> scored;
    std::vector<Eigen::VectorXd> fits;           // their weights
    for (int mask = 0; mask < (1 << ne); ++mask) {
      std::vector<int> cols = extras;
      for (int b = 0; b < ne; ++b)
        if (mask & (1 << b)) cols.push_back(ieee_cols[static_cast<size_t>(b)]);
      if (cols.empty()) continue;
      Eigen::VectorXd cs;
      double score = solveNnls(w, cols, &cs);
      fits.push_back(cs);
      int terms = 0;
      double aic = score;  // the rival is judged on AIC's scale (2 per term; kRivalGap)
      for (int col : ieee_cols)
        if (cs[col] > 0) score += penalty(col), aic += 2.0, terms |= 1 << P.term[static_cast<size_t>(col)];
      scored.push_back({terms, score, aic});
      if (score < best_score - 1e-9) {
        best_score = score;
        best_c = cs;
      }
    }
    c = best_c;
    // Rivals that tell the record with other terms: neither a subset nor a superset of the selection (nested
    // alternatives are what each term's selective interval accounts for), close by isCloseRival (within kRivalGap on
    // the score or on AIC, or within an entry penalty in chi-squared; noise_model.hpp). The closest one is reported.
    int sel = 0;
    double sel_aic = std::numeric_limits<double>::infinity();
    for (int col : ieee_cols)
      if (c[col] > 0) sel |= 1 << P.term[static_cast<size_t>(col)];
    for (const Scored& x : scored)
      if (x.terms == sel) sel_aic = std::min(sel_aic, x.aic);
    const int n_bit = 1 << kAngleRandomWalk;
    for (size_t i = 0; i < scored.size(); ++i) {
      const int terms = scored[i].terms;
      const double score_gap = scored[i].score - best_score, aic_gap = scored[i].aic - sel_aic;
      const double gap = std::min(score_gap, aic_gap);
      if (terms != sel && (terms & sel) == sel) {  // a larger set of terms: the selection and some it left out
        const bool seen = std::any_of(close_supersets.begin(), close_supersets.end(),
                                      [&](const CloseRival& x) { return x.terms == terms; });
        if (aic_gap < kSupersetGap && !seen) close_supersets.push_back({aic_gap, terms, i, fits[i]});
      }
      if ((terms & sel) == terms || (terms & sel) == sel) continue;
      // A set without the white-noise floor N is no rival to one with it: every gyro has N, and taking N away would
      // leave an answer with no N (a bad verdict, unbounded intervals). None of the session-12 study records had one
      // within the gap.
      if ((sel & n_bit) && !(terms & n_bit)) continue;
      // (A subset with an IEEE column that came out at 0 has the terms of a smaller one: counted once.)
      const bool seen =
          std::any_of(close_rivals.begin(), close_rivals.end(), [&](const CloseRival& x) { return x.terms == terms; });
      if (isCloseRival(sel, terms, score_gap, aic_gap, options) && !seen)
        close_rivals.push_back({gap, terms, i, Eigen::VectorXd()});
      if (gap < r.rival_gap) {
        r.rival_gap = gap, r.rival_terms = terms, rival_c = fits[i];
        r.rival_score_gap = score_gap, r.rival_aic_gap = aic_gap;
      }
    }
    // (stable: on a tie the first in subset order comes first, as for rival_terms above)
    std::stable_sort(close_rivals.begin(), close_rivals.end(),
                     [](const auto& a, const auto& b) { return a.gap < b.gap; });
    for (auto& cr : close_rivals) {
      r.close_rival_terms.push_back(cr.terms);
      r.close_rival_gaps.push_back(cr.gap);
      cr.weights = fits[cr.index];
    }
    std::stable_sort(close_supersets.begin(), close_supersets.end(),
                     [](const auto& a, const auto& b) { return a.gap < b.gap; });
    for (const auto& cs : close_supersets) r.close_superset_terms.push_back(cs.terms);
  }

  // Terms a close rival (isCloseRival) tells otherwise, for every such rival (FitResult::ambiguous):
  // a term the search selected and the rival does without is not supported (its value 0, its interval from 0 to its
  // upper end), and a rival's term the search did not select gets at least the rival's plain upper ends (its free
  // least-squares value + 1 and 1.96 sd at the full model's covariance). The selective intervals (inferAll) condition on which terms were kept,
  // not on which non-nested set of terms won: where a rate random walk told the record about as well as bias
  // instability plus a ramp, K was reported at 3-10x its truth with an interval that excluded it.
  void ambiguity(const Whitened& w) {
    for (int col = 0; col < ncol && rival_c.size() == ncol; ++col)
      if (rival_c[col] > 0 && P.term[static_cast<size_t>(col)] < kNumTerms)
        r.rival_values[static_cast<size_t>(P.term[static_cast<size_t>(col)])] = std::sqrt(rival_c[col]);
    for (const CloseRival& cr : close_rivals) {
      const Eigen::VectorXd& rc = cr.weights;
      std::vector<int> rcols;  // this rival's columns (extra terms included)
      for (int col = 0; col < ncol; ++col)
        if (rc[col] > 0) rcols.push_back(col);
      Eigen::VectorXd est;
      Eigen::MatrixXd cov;
      if (!rcols.empty()) solveFree(w, rcols, &est, &cov);
      for (int col : ieee_cols) {
        const int t = P.term[static_cast<size_t>(col)];
        Coefficient& cc = r.terms_corrected[static_cast<size_t>(t)];
        const bool in_rival = rc[col] > 0, selected = c[col] > 0;  // selected: by the subset search
        if (selected && !in_rival) {  // (also when its selection-corrected value already dropped it)
          cc.supported = false;
          cc.value = 0.0;
          cc.lo68 = cc.lo95 = 0.0;
          cc.sigma = cc.hi68;
          r.ambiguous[static_cast<size_t>(t)] = true;
        } else if (!selected && in_rival && !rcols.empty()) {
          const auto k = static_cast<int>(std::find(rcols.begin(), rcols.end(), col) - rcols.begin());
          const double x = std::max(0.0, est[k]), sd = std::sqrt(std::max(0.0, cov(k, k) * r.uncertainty_inflation));
          cc.hi68 = std::max(cc.hi68, std::sqrt(x + sd));
          cc.hi95 = std::max(cc.hi95, std::sqrt(x + 1.96 * sd));
          cc.sigma = cc.hi68;
          r.ambiguous[static_cast<size_t>(t)] = true;
        }
      }
    }
  }

  // A selected rate ramp beside a dropped rate random walk (FitResult::ramp_bounded_by_random_walk): its 95 % interval in
  // terms_corrected reaches the ramp's plain interval (least-squares value -+ 1.96 sd) with the covariance at K's 68 %
  // upper end instead of the full model's K. A ramp's Allan estimates scatter through the cross term 4 mu mu' Cov(d, d')
  // (avar_covariance.hpp), which a rate random walk's wander makes large, so the ramp's sd depends steeply on K; the full
  // model's K is 0 in most such records (K and R trade over the longest taus), and the ramp's 95 % interval held the
  // truth in 69 of 100 records of a 2 h gyro with K = 3 deg/h/sqrt(h) and R = 20 deg/h^2, R supported in 85 of them
  // (docs/calibration.md, "Session 21"). A K the search selected (c > 0) is in the selected columns already, so R's sd
  // has it free and at the full model's value, also when its correction or a rival reports it dropped.
  void boundRampByRandomWalk() {
    const int r_col = columnOf(kRateRamp), k_col = columnOf(kRateRandomWalk);
    Coefficient& cc = r.terms_corrected[kRateRamp];
    if (!options.intervals || r_col < 0 || k_col < 0 || !(c[r_col] > 0) || c[k_col] > 0 || !cc.supported) return;
    Eigen::VectorXd cm = c_full;
    cm[k_col] = std::max(cm[k_col], inf[static_cast<size_t>(k_col)].est.hi68);
    const Whitened wk = whiten(P, P.covariance(cm));
    if (!wk.ok) return;
    Eigen::VectorXd est;
    Eigen::MatrixXd cov;
    solveFree(wk, pos, &est, &cov);
    const int k = static_cast<int>(std::find(pos.begin(), pos.end(), r_col) - pos.begin());
    const double x = c[r_col], sd = std::sqrt(std::max(0.0, cov(k, k) * r.uncertainty_inflation));
    const double lo95 = cc.lo95, hi95 = cc.hi95;
    cc.lo95 = std::min(cc.lo95, std::sqrt(std::max(0.0, x - 1.96 * sd)));
    cc.hi95 = std::max(cc.hi95, std::sqrt(x + 1.96 * sd));
    r.ramp_bounded_by_random_walk = cc.lo95 != lo95 || cc.hi95 != hi95;
  }

  // Larger sets of terms within kSupersetGap (noise_model.hpp): a selected B's interval in terms_corrected reaches the
  // larger set's plain interval of B, on the side of that set's value. After ambiguity(): a B a close rival does
  // without is a bound already (unsupported) and keeps the rival rule's interval. Only B: the term the study found
  // absorbing a left-out rate random walk; N's interval comes from the selected columns on purpose (Q's column is
  // nearly collinear with N's; inferAll), and widening a selected K or R was not studied.
  void widenBySupersets(const Whitened& w) {
    Coefficient& cc = r.terms_corrected[kBiasInstability];
    const int b_col = columnOf(kBiasInstability);
    if (!options.intervals || b_col < 0 || !(c[b_col] > 0) || !cc.supported) return;
    for (const CloseRival& cs : close_supersets) {
      std::vector<int> cols;
      for (int col = 0; col < ncol; ++col)
        if (cs.weights[col] > 0) cols.push_back(col);
      Eigen::VectorXd est;
      Eigen::MatrixXd cov;
      solveFree(w, cols, &est, &cov);
      const int k = static_cast<int>(std::find(cols.begin(), cols.end(), b_col) - cols.begin());
      const double x = est[k], sd = std::sqrt(std::max(0.0, cov(k, k) * r.uncertainty_inflation));
      const double lo68 = cc.lo68, lo95 = cc.lo95, hi68 = cc.hi68, hi95 = cc.hi95;
      if (x < c[b_col]) {
        cc.lo68 = std::min(cc.lo68, std::sqrt(std::max(0.0, x - sd)));
        cc.lo95 = std::min(cc.lo95, std::sqrt(std::max(0.0, x - 1.96 * sd)));
      } else {
        cc.hi68 = std::max(cc.hi68, std::sqrt(std::max(0.0, x + sd)));
        cc.hi95 = std::max(cc.hi95, std::sqrt(std::max(0.0, x + 1.96 * sd)));
      }
      if (cc.lo68 != lo68 || cc.lo95 != lo95 || cc.hi68 != hi68 || cc.hi95 != hi95) r.widened[kBiasInstability] = true;
    }
  }

  // Final statistics at the same covariance, and the evidence: the chi-squared change when each IEEE term leaves or
  // joins the final set.
  void statistics(const Whitened& w) {
    const int n = static_cast<int>(P.idx.size());
    for (int k = 0; k < ncol; ++k)
      if (c[k] > 0) pos.push_back(k);
    const double chi2 = (w.b - w.A * c).squaredNorm();
    r.dof = std::max(1, n - static_cast<int>(pos.size()));
    r.chi2 = chi2;
    r.chi2_dof = chi2 / r.dof;
    r.chi2_p = chi2UpperTail(chi2, r.dof);
    r.uncertainty_inflation = (r.chi2_p < kMisfitP && r.chi2_dof > 1) ? r.chi2_dof : 1.0;
    for (int col : ieee_cols) {
      const int t = P.term[static_cast<size_t>(col)];
      std::vector<int> cols;
      const bool in = c[col] > 0;
      for (int k : pos)
        if (k != col) cols.push_back(k);
      if (!in) cols.push_back(col);
      Eigen::VectorXd tmp;
      const double other = solveNnls(w, cols, &tmp);
      r.evidence[static_cast<size_t>(t)] = in ? other - chi2 : chi2 - other;
    }
  }

  // Intervals and values by selective inference (selective.hpp). Each term's estimate x (its least-squares value
  // when selected, but a selected K's unconstrained value in a larger set (inferAll); when not, its unconstrained
  // value with the term added) is treated as normal with a variance
  // that grows with the term itself (the AVAR scatter does: a fixed sigma made the upper side too short), and the
  // fact that the subset search kept it (x above the threshold where its chi-squared saving equals the penalty) or
  // dropped it (below) is conditioned on. The intervals then hold the truth at their stated rate among the records
  // where the same selection happened, and a selected term's value is the conditional median-unbiased estimate:
  // a weak term is selected only when it came out high, and its plain least-squares value was biased up (+50 %
  // for a rate random walk near the detection limit). A selected term whose corrected value is 0 is dropped.
  // The columns whose uncertainty counts: for a selected term, the selected terms and those the full model had (a
  // term below the selection threshold still trades with its neighbours; a selected K also a dropped B, inferAll);
  // for a dropped term, the selected terms, itself and a dropped partner (jointEstimate; below).

  // sd of the estimate of column `col` (at position pos_in_cols of cols) when its true weight is x.
  double sdAt(const std::vector<int>& cols, size_t pos_in_cols, int col, double x) const {
    Eigen::VectorXd cm = c_full;
    cm[col] = std::max(0.0, x);
    const Whitened wx = whiten(P, P.covariance(cm));
    if (!wx.ok) return std::numeric_limits<double>::quiet_NaN();
    Eigen::VectorXd est;
    Eigen::MatrixXd cov;
    solveFree(wx, cols, &est, &cov);
    const int k = static_cast<int>(pos_in_cols);
    return std::sqrt(std::max(0.0, cov(k, k) * r.uncertainty_inflation));
  }

  // Third cumulant of the estimate at position k of cols (its GLS weights at the full model's covariance, which made
  // it: a . y is solveFree's value, up to the ridge whiten() adds to a covariance that is not positive definite) at
  // the full model's Q, N and B and a rate random walk of mu, in the spectral form of avar_skewness.hpp, with its
  // variance a' C(mu) a without the rate ramp's share through the three mu of the variance model. The skew the pivot
  // uses is this over the variance model's variance (VarianceModel::skewAt), which also holds the ramp's share and
  // the misfit inflation, both taken as unskewed; near mu = 0, where a' C(0) a exceeds the variance model (the
  // weights were made at the full model), the skew used is the larger.
  ThirdCumulantModel thirdCumulant(const std::vector<int>& cols, size_t k, const double mu[3]) const {
    ThirdCumulantModel tc;
    const Whitened w = whiten(P, cov_full);
    if (!w.ok) return tc;
    Eigen::VectorXd est;
    Eigen::MatrixXd cov;  // (F' C^-1 F)^-1 over cols
    solveFree(w, cols, &est, &cov);
    const int n = static_cast<int>(P.F.rows()), q = static_cast<int>(cols.size());
    Eigen::MatrixXd fc(n, q);
    for (int j = 0; j < q; ++j) fc.col(j) = P.F.col(cols[static_cast<size_t>(j)]);
    const Eigen::VectorXd a = cov_full.ldlt().solve(fc * cov.col(static_cast<int>(k)));  // x = a . y
    std::array<double, 3> fixed{{0, 0, 0}};
    for (int col : ieee_cols) {
      const int t = P.term[static_cast<size_t>(col)];
      if (t < kRateRandomWalk && c_full[col] > 0) fixed[static_cast<size_t>(t)] = c_full[col];
    }
    const std::vector<double> av(a.data(), a.data() + a.size());
    const AvarCombinationSpectrum sp = avarCombinationSpectrum(P.basis->m, P.basis->n_terms, av, P.basis->tau0, fixed);
    double var[3];
    for (int i = 0; i < 3; ++i) {
      const std::array<double, 5> s{{fixed[0], fixed[1], fixed[2], std::max(0.0, mu[i]), 0.0}};
      var[i] = a.dot(avarCovariance(*P.basis, s) * a);
    }
    const VarianceModel k2 = VarianceModel::through(mu, var);
    tc.k0 = k2.v0;
    tc.k1 = k2.v1;
    tc.k2 = k2.v2;
    tc.i2 = sp.i2;
    tc.i3 = sp.i3;
    return tc;
  }

  // One column's selection event, variance model and selective estimate.
  void infer(int col, const std::vector<int>& cols, size_t k, double x, double sd0) {
    TermInference ti;
    ti.sd0 = sd0;
    const int t = P.term[static_cast<size_t>(col)];
    const bool selected = c[col] > 0;
    ti.event.selected = selected;
    if (t >= kNumTerms) {  // extra terms are always in: no selection to condition on
      ti.event.threshold = selected ? -std::numeric_limits<double>::infinity() : std::numeric_limits<double>::infinity();
    } else {
      // The subset search keeps a term when the chi-squared it saves, about (x / sd)^2, exceeds its penalty.
      ti.event.threshold = std::sqrt(penalty(col)) * sd0;
      if (selected) ti.event.threshold = std::min(ti.event.threshold, x);
    }
    if (!options.intervals) {  // values only (FitOptions::intervals): sd0 still gives a selected term its sigma
      constexpr double nan = std::numeric_limits<double>::quiet_NaN();
      ti.est.median = ti.est.lo68 = ti.est.hi68 = ti.est.lo95 = ti.est.hi95 = nan;
      inf[static_cast<size_t>(col)] = ti;
      return;
    }
    const double m1 = std::max({x, sd0, 1e-300});
    const double mu[3] = {0.0, m1, m1 + 4.0 * std::max(sd0, 0.25 * m1)};
    double var[3];
    for (int i = 0; i < 3; ++i) {
      const double sd = sdAt(cols, k, col, mu[i]);
      var[i] = std::isfinite(sd) ? sd * sd : sd0 * sd0;
    }
    VarianceModel vm = VarianceModel::through(mu, var);
    if (!selected && t < kNumTerms) {
      // Dropped. The threshold the search applied was sqrt(penalty) times the sd at the full model's covariance, and
      // that covariance holds the full model's value of this very term, which rises and falls with x: a low x came
      // with a low threshold and a high one with a high threshold (seeds 1-40, the wavelet split's B: (T - truth) / sd
      // from -0.3 for the lowest x to +2.3 for the highest). Conditioning on the observed threshold then treats a
      // record's own scatter as part of the event. For B the event is fixed where the term would enter: x =
      // sqrt(penalty) sd(x), the fixed point of the variance model (the split's dropped B at 68 %: 0.81 -> 0.69 on
      // seeds 1-20, 0.85 -> 0.71 on 2001-2020).
      // Only for B. K's variance is steep in K (penalty * v2 ~ 0.45, 30 min records), its fixed point lay a median 7x
      // beyond the observed threshold and at infinity in a quarter of the records, and conditioning on it made the
      // consumer class's K under-cover (0.35-0.70 of 20 per seed set against 0.60-0.75) and the 30 min issue class's
      // over-cover (0.93 of 100); R moved within its binomial spread. Nor with extra (model-check) terms in the fit:
      // their scatter is not in the covariance (beside a Tc = 10 s Gauss-Markov term K's fixed point was 40x the
      // observed threshold; test_model_check GaussMarkovFound). docs/calibration.md, "Sessions 9-10".
      if (t == kBiasInstability && extras.empty()) ti.event.threshold = vm.entryThreshold(penalty(col));
      // The variance grows with the hypothesised value up to the threshold and is held there. Grown without limit
      // (like a rate random walk's long-tau scatter), "it came out below the threshold" stays likely for any large
      // value and the conditional bound had no finite end; held at the estimate's variance it missed a near-detection
      // K (biased low where B and R trade with it) 2 times in 6 at 95 % (test_noise_model's MEMS case); held at the
      // threshold's it covered 100 % at 68 % (docs/calibration.md).
      vm.cap_mu = std::max(0.0, ti.event.threshold);
    }
    // A selected rate random walk's estimate is read from the longest taus, whose Allan points are right-skewed (its
    // skew 0.4-1.7 in the simulations of docs/calibration.md, "Session 26"), and a normal model's winner's-curse
    // correction left the kept values high (kvis, seeds 31521-31720: +11.3 % median with a normal model, +5.4 % with
    // the skew in). Not with extra terms: their share of the points is not in the spectral form.
    if (selected && t == kRateRandomWalk && extras.empty()) vm.kappa3 = thirdCumulant(cols, k, mu);
    ti.est = selectiveEstimate(x, vm, ti.event);
    if (selected && t < kNumTerms && !(ti.est.median > 0)) {
      // Selected, but its corrected value is 0 (it only just passed): dropped. Its bound is then the plain one-sided
      // one (the conditional set is empty when the estimate sits on the threshold).
      ti.corrected_out = true;
      ti.est = selectiveEstimate(x, vm, SelectionEvent{false, std::numeric_limits<double>::infinity()});
    }
    inf[static_cast<size_t>(col)] = ti;
  }

  // Every column's inference: the selected ones from one solve, each dropped one from its own. N (always selected,
  // far above its threshold) takes its variance from the selected columns only: its value is the selected set's
  // least-squares value, and the quantization column, nearly collinear with N's at short tau, held N's interval
  // wider than its scatter when Q is 0 and dropped (rms of (N - truth) / sigma 0.67-0.93 in the joint-fit classes,
  // 1.0-1.1 this way; coverage_study seeds 1-20). B, K and R keep the full model's columns: they are near their
  // thresholds, and the selected set's variance there let K through in 6 of 100 records (session 6).
  // A selected K's estimate comes from those columns too, not from the selected set alone (since session 23): where
  // a term the record holds was dropped (B below its entry), the selected set's K took up that term's
  // share of the long-tau points, and the selection then kept the records where K came out high. Noise-free, N 0.15
  // deg/sqrt(h), B 1 deg/h (dropped), K 20 deg/h/sqrt(h), 2 h at 100 Hz: K +9.7 % from the selected set, -0.3 % this
  // way (test_noise_model SelectedRandomWalkIsNotRaisedByADroppedFlicker). On records (kr_big: N 0.15, B 1, K 6,
  // R 40): the supported K's median bias +68 % -> +15 % (seeds 29101-29300) and +52 % -> +42 % (30101-30300).
  // That estimate is unconstrained: one at or below K's threshold is dropped by its correction (infer). B and R keep
  // the selected set's values (session 13 took every selected term's from the larger set at once: B improved and K's
  // detection fell; docs/calibration.md, "Session 23").
  // A selected K also has a dropped B's column free where the full model clipped B to 0 (since session 25): the
  // full model's K had taken up B's floor there, so B was not among its positive columns, and K's estimate without
  // B's column kept that floor (kr_big, seeds 30861-31260: B at 0 in the full model in 7 of the 15 records with a
  // supported K, whose modelled sd at the truth was 1.1e-13 against 7-9e-13 in the class's other records;
  // docs/calibration.md, "Session 25"). K's sigma (its sd0) comes from the same columns.
  void inferAll(const Whitened& w) {
    inf.assign(static_cast<size_t>(ncol), TermInference{});
    std::vector<int> ucols = pos;
    for (int col : ieee_cols)
      if (!(c[col] > 0) && c_full[col] > 0) ucols.push_back(col);
    // A dropped B is in ucols exactly when the full model holds it; a selected K adds it where it does not.
    const int b_col = columnOf(kBiasInstability), k_col = columnOf(kRateRandomWalk);
    const bool own_k = b_col >= 0 && k_col >= 0 && c[k_col] > 0 && !(c[b_col] > 0) && !(c_full[b_col] > 0);
    std::vector<int> kcols = ucols;
    if (own_k) kcols.push_back(b_col);
    if (!pos.empty()) {
      Eigen::VectorXd est, est_sel, est_k;
      Eigen::MatrixXd cov, cov_sel, cov_k;
      solveFree(w, ucols, &est, &cov);
      solveFree(w, pos, &est_sel, &cov_sel);
      if (own_k) solveFree(w, kcols, &est_k, &cov_k);
      for (size_t k = 0; k < pos.size(); ++k) {
        const int t = P.term[static_cast<size_t>(pos[k])];
        const bool arw = t == kAngleRandomWalk, rrw = t == kRateRandomWalk;
        const Eigen::MatrixXd& cv = arw ? cov_sel : (rrw && own_k ? cov_k : cov);
        const double x = rrw ? (own_k ? est_k : est)[static_cast<int>(k)] : c[pos[k]];
        infer(pos[k], arw ? pos : (rrw && own_k ? kcols : ucols), k, x,
              std::sqrt(std::max(0.0, cv(static_cast<int>(k), static_cast<int>(k)) * r.uncertainty_inflation)));
      }
    }
    // A dropped term's estimate is its value with the term added to the selected set: the chi-squared it would save
    // there is what the subset search compared with its penalty, so this is the estimate the truncation (x < T)
    // describes. A dropped K or R is estimated with the other one free too when both are dropped (jointEstimate);
    // the variance model then has both columns, so the interval carries the trade, and the truncation is only
    // approximately the search's event (it scored K with R out), at a threshold from the pair's sd. (Session 5
    // added every full-model column, the selected terms' trading partners included: K's estimate came out at
    // 0.05-0.5 of the truth in mean on 1 h records, and its 68 % coverage was 0.84.)
    for (int col = 0; col < ncol; ++col) {
      if (c[col] > 0) continue;
      std::vector<int> cols = pos;
      if (std::find(cols.begin(), cols.end(), col) == cols.end()) cols.push_back(col);
      const size_t k = static_cast<size_t>(std::find(cols.begin(), cols.end(), col) - cols.begin());
      const int t = P.term[static_cast<size_t>(col)];
      for (int other : ieee_cols)
        if (other != col && !(c[other] > 0) && jointEstimate(t, P.term[static_cast<size_t>(other)]))
          cols.push_back(other);
      Eigen::VectorXd est;
      Eigen::MatrixXd cov;
      solveFree(w, cols, &est, &cov);
      infer(col, cols, k, est[static_cast<int>(k)],
            std::sqrt(std::max(0.0, cov(static_cast<int>(k), static_cast<int>(k)) * r.uncertainty_inflation)));
    }
  }

  // `terms`: the least-squares values behind the model curve (the model check works with these); `terms_corrected`:
  // the answer, with the selection-corrected values and the barely selected terms dropped. Both carry the same
  // intervals, until ambiguity(), widenBySupersets() and boundRampByRandomWalk() change some of terms_corrected's.
  void coefficients() {
    for (int col = 0; col < ncol; ++col) {
      const TermInference& ti = inf[static_cast<size_t>(col)];
      Coefficient co;
      co.supported = c[col] > 0;
      co.value = co.supported ? std::sqrt(c[col]) : 0.0;
      co.hi68 = std::sqrt(ti.est.hi68);
      co.hi95 = std::sqrt(ti.est.hi95);
      co.lo68 = std::sqrt(ti.est.lo68);  // a dropped term's unified interval may exclude 0 (selective.hpp)
      co.lo95 = std::sqrt(ti.est.lo95);
      if (co.supported) {
        co.sigma = ti.sd0 / (2.0 * co.value);  // delta method at the least-squares value (the model check's gates)
      } else {
        co.sigma = co.hi68;  // the upper end of its 68 % interval
      }
      const int t = P.term[static_cast<size_t>(col)];
      if (t < kNumTerms) {
        r.terms[static_cast<size_t>(t)] = co;
        Coefficient& cc = r.terms_corrected[static_cast<size_t>(t)];
        cc = co;
        if (co.supported && ti.corrected_out) {
          r.dropped_by_correction[static_cast<size_t>(t)] = true;
          cc.supported = false;
          cc.value = 0.0;
          cc.sigma = cc.hi68;
        } else if (co.supported) {
          cc.value = std::sqrt(ti.est.median);
        }
      } else {
        r.extra[static_cast<size_t>(t - kNumTerms)] = co;
        if (co.supported) r.extra_c[static_cast<size_t>(t - kNumTerms)] = c[col];
      }
    }
  }

  // The model curve at every point and its fit error.
  void modelCurve() {
    for (size_t i = 0; i < curve.points.size(); ++i) {
      double v = 0;
      for (int k = 0; k < ncol; ++k) {
        if (!(c[k] > 0)) continue;
        const int t = P.term[static_cast<size_t>(k)];
        v += c[k] * columnBasis(t, curve.points[i].tau, curve.tau0, extra);
      }
      r.model_var[i] = v;
    }
    DeviationCurve with_edf = curve;  // rms_log10 counts points by EDF (the non-overlapping count where none is given)
    for (auto& p : with_edf.points)
      if (!(p.edf > 0) && p.m > 0) p.edf = static_cast<double>(curve.n_phase) / static_cast<double>(p.m) - 1.0;
    const FitError fe = fitError(with_edf, r.model_var, r.used, static_cast<int>(pos.size()), options.rms_min_edf);
    r.rms_log10 = fe.rms_log10;
    r.n_rms = fe.n_rms;
  }
};

}  // namespace

bool isCloseRival(int selected_terms, int rival_terms, double score_gap, double aic_gap, const FitOptions& options) {
  if (std::min(score_gap, aic_gap) < kRivalGap) return true;
  const std::bitset<kNumTerms> sel(static_cast<unsigned>(selected_terms)), rival(static_cast<unsigned>(rival_terms));
  double entry = 0.0;  // the dearest entry among the selected terms the rival lacks
  for (int t = 0; t < kNumTerms; ++t)
    if (sel[static_cast<size_t>(t)] && !rival[static_cast<size_t>(t)])
      entry = std::max(entry, entryPenalty(t, options));
  const double chi2_gap = aic_gap - 2.0 * (static_cast<double>(rival.count()) - static_cast<double>(sel.count()));
  return chi2_gap < entry;
}

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
  if (!g.fitFullModel()) {
    g.r.message = "covariance of the Allan-variance points is not positive definite";
    return g.r;
  }
  g.selectTerms();
  const Whitened w = whiten(g.P, g.cov_full);
  if (!w.ok) {
    g.r.message = "covariance of the Allan-variance points is not positive definite";
    return g.r;
  }
  g.statistics(w);
  g.inferAll(w);
  g.r.intervals = options.intervals;
  g.coefficients();
  g.ambiguity(w);
  g.widenBySupersets(w);
  g.boundRampByRandomWalk();
  g.modelCurve();
  g.r.ok = true;
  return g.r;
}

}  // namespace detail
}  // namespace gyro_allan
