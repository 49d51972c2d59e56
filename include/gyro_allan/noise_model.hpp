// IEEE Std 952/647 gyro noise model: sigma^2(tau) = 3Q^2/tau^2 + N^2/tau + (2 ln2/pi) B^2 + K^2 tau/3 + R^2 tau^2/2,
// fitted to an Allan variance curve by iterated, non-negative generalized least squares (plus optional extra terms).
#pragma once

#include <array>
#include <limits>
#include <functional>
#include <string>
#include <vector>

#include "gyro_allan/allan.hpp"
#include "gyro_allan/stats.hpp"

namespace gyro_allan {

/// The five IEEE 952 terms, in the order of NoiseCoefficients::terms.
enum NoiseTerm { kQuantization = 0, kAngleRandomWalk, kBiasInstability, kRateRandomWalk, kRateRamp, kNumTerms };

/// report.yaml keys of the terms: quantization, angle_random_walk, bias_instability, rate_random_walk, rate_ramp.
const char* noiseTermKey(int term);
/// A set of terms (bit set, 1 << term) by its keys joined with `sep`, e.g. "angle_random_walk+rate_random_walk".
std::string noiseTermSetName(int terms, const char* sep = "+");
/// SI unit of each term: rad, rad/sqrt(s), rad/s, rad/s/sqrt(s), rad/s^2 (for a gyro).
const char* noiseTermUnit(int term);

/// Allan-variance basis of each term per unit coefficient squared: 3/tau^2, 1/tau, 2ln2/pi, tau/3, tau^2/2.
double noiseTermBasis(int term, double tau);
/// The same for a series sampled every tau0 (> 0): the bias instability's column is the flicker's exact Allan variance
/// at m = tau / tau0 samples (flickerAvarShape), the others as above.
double noiseTermBasis(int term, double tau, double tau0);
/// A sampled flicker's Allan variance at m samples over its long-tau floor (2 ln2 / pi) B^2: 1.443 at m = 1, 1.154 at
/// 2, 1.050 at 4, 1.015 at 8, 1.0004 at 64 (Kasdin's discrete 1/f noise, as simulate.cpp generates it).
double flickerAvarShape(double m);

/// A coefficient with its uncertainty. value is the fitted coefficient (the square root of its non-negative AVAR
/// weight c): the model curve is drawn from the values, supported or not. supported: its 95 % interval excludes 0
/// (the data demand the term); a flag that never changes the value. Intervals (same units as value): [lo68, hi68]
/// (68.3 %) and [lo95, hi95] (95 %), taken on c and mapped through the square root, so they are asymmetric; they
/// always hold the value, and start at 0 for a term the data do not demand (an upper bound). sigma: the delta-method
/// standard deviation of a supported value; for an unsupported one the upper end of its 68 % interval.
struct Coefficient {
  double value = 0;
  double sigma = 0;
  bool supported = false;
  double lo68 = 0, hi68 = 0;
  double lo95 = 0, hi95 = 0;
};

/// A coefficient from an estimate c of its square (its AVAR weight, e.g. Q^2) with standard deviation c_sigma:
/// intervals c -+ z c_sigma mapped through the square root (two-sided when supported, [0, upper end] when not);
/// supported when c > z_support c_sigma, else value 0 (used by the wavelet split, whose estimates are not GLS fits).
/// z is k68 for the 68 % interval and k95 for the 95 % one (normal by default; Student t's when c_sigma is itself
/// estimated from few degrees of freedom).
Coefficient coefficientFromSquare(double c, double c_sigma, double z_support = 2.0, double k68 = 1.0,
                                  double k95 = kZ95);

/// An additional Allan-variance term c * basis(tau), c >= 0 fitted jointly with the IEEE terms (used by the model
/// check: sinusoid, Gauss-Markov, bias step...). The reported Coefficient is sqrt(c) with its sigma.
struct ExtraTerm {
  std::string name;
  std::function<double(double tau)> basis;
};

/// How the fit weights the Allan-variance points.
///  Covariance: generalized least squares with the full covariance of the overlapping AVAR estimates across tau
///              (avar_covariance.hpp) at the fitted model itself, on an octave-spaced subset of the points
///              (neighbouring points of a denser grid add almost no information and make the covariance
///              near-singular); every term is fitted, none is selected away; intervals are unified intervals from the
///              GLS information (noise_model_gls.cpp). Used for oadev curves (the default).
///  Edf:        each point weighted by its EDF (2 model^2/edf), neighbours decorrelated by grid density, terms kept
///              at `significance` sigma (other deviations; with significance 0 the plain weighted least-squares
///              baseline of the accuracy studies).
enum class FitWeighting { Covariance, Edf };

struct FitOptions {
  FitWeighting weighting = FitWeighting::Covariance;
  std::array<bool, kNumTerms> enabled{{true, true, true, true, true}};
  int iterations = 6;          ///< reweighting iterations (weights from the current model)
  double min_edf = 3.0;        ///< points with smaller EDF are not fitted (their chi-squared is too skewed)
  double rms_min_edf = 3.0;    ///< points counted in rms_log10 need at least this EDF (every fitted point)
  double significance = 1.0;   ///< an IEEE term is kept only if its c = coef^2 is >= this many sigma above zero
  bool decorrelate = true;     ///< scale weights by the grid density (one octave ~ one independent AVAR estimate)
  /// Covariance weighting: false fits the values, statistics and model curve only, without the unified intervals
  /// (for fits whose only use is their values: the model check's trial fits, whose winner is fitted again with
  /// them). Then FitResult::intervals is false and every interval end is NaN.
  bool intervals = true;
  /// Covariance weighting: estimate with the diagonal of the points' covariance at the model (working independence)
  /// instead of the full covariance, intervals from the sandwich with the full covariance, adequacy judged with the
  /// full covariance. Measured worse than the GLS on the population study (docs/fit.md); kept for that comparison.
  bool working_independence = false;
};

struct FitResult {
  bool ok = false;
  std::string message;                        ///< why not ok
  std::array<Coefficient, kNumTerms> terms;   ///< Q [rad], N [rad/sqrt(s)], B [rad/s], K [rad/s/sqrt(s)], R [rad/s^2]
  std::vector<Coefficient> extra;             ///< one per ExtraTerm, sqrt of its fitted c
  std::vector<double> extra_c;                ///< fitted c of each extra term
  std::vector<double> tau;                    ///< taus of the curve points (all of them)
  double tau0 = 0;                            ///< the curve's sampling interval (B's column; noiseTermBasis)
  std::vector<double> model_var;              ///< model AVAR at each curve point
  std::vector<bool> used;                     ///< point took part in the fit
  double chi2 = 0;                            ///< EDF-weighted chi-squared of the AVAR residual
  int dof = 0;                                ///< fitted points minus free parameters (>= 1)
  double chi2_dof = 0;                        ///< chi2 / dof
  double rms_log10 = 0;                       ///< RMS of log10(measured/model ADEV) over points with edf >= rms_min_edf
  int n_rms = 0;                              ///< points in rms_log10
  /// The model's largest miss where the data's interval is tight (points with edf >= kTightEdf): max over them of
  /// max(model/measured, measured/model) in ADEV; 1 when no point qualifies.
  double worst_adev_ratio = 1.0;
  /// Covariance weighting: chi2 is the generalized chi-squared r' C^-1 r over the octave-spaced points (`gls_used`),
  /// chi2_p its upper-tail probability under chi2(dof); uncertainty says how the intervals were obtained.
  bool gls = false;
  std::vector<bool> gls_used;
  double chi2_p = 1.0;
  std::string uncertainty;                    ///< e.g. "GLS covariance of the AVAR estimates (analytic)"
  /// Evidence per IEEE term: how much the generalized chi-squared rises when the term is held at 0 (0 for a term at 0).
  std::array<double, kNumTerms> evidence{{0, 0, 0, 0, 0}};
  double uncertainty_inflation = 1.0;         ///< sd's variance scaled by chi2/dof when the model misfits (p < 0.01)
  /// Correlation of the IEEE terms' free estimates (AVAR weights) at the fit, every enabled term free; NaN for a
  /// disabled term. Where B, K and R trade (|correlation| near 1) the data tell their sum better than each.
  std::array<std::array<double, kNumTerms>, kNumTerms> correlation{};
  bool intervals = true;  ///< false: fitted with FitOptions::intervals off (values only)
};

/// Points whose EDF is at least this have a tight interval: the 95 % chi-squared interval of their ADEV lies within
/// about x0.72..x1.5 of the estimate (FitResult::worst_adev_ratio).
constexpr double kTightEdf = 20.0;

/// Fits the model to `curve` (AVAR in curve.points[i].var; weights from points[i].edf; edf <= 0 is treated as
/// the non-overlapping count N/m - 1). Iterated: the variance of each AVAR estimate is 2 model^2 / edf.
FitResult fitNoiseModel(const DeviationCurve& curve, const FitOptions& options = {},
                        const std::vector<ExtraTerm>& extra = {});

/// Model AVAR of a fit (IEEE terms + extra terms) at tau.
double modelVariance(const FitResult& fit, double tau, const std::vector<ExtraTerm>& extra = {});
/// One IEEE term's AVAR contribution at tau.
double termVariance(const FitResult& fit, int term, double tau);

/// Goodness-of-fit measures of any model curve against measured points (same definitions as FitResult).
struct FitError {
  double rms_log10 = 0;
  double chi2_dof = 0;
  int n_rms = 0;
  double worst_adev_ratio = 1.0;  ///< as FitResult::worst_adev_ratio
  double chi2_p = std::numeric_limits<double>::quiet_NaN();  ///< the GLS fit's adequacy p-value (NaN: none)
};
/// A fit's own error figures (rms_log10, chi2_dof, n_rms, worst_adev_ratio, chi2_p of a GLS fit).
FitError fitErrorOf(const FitResult& fit);
/// A GLS fit the data reject grossly: generalized chi-squared p < 1e-6 and chi2/dof > 10 (clean records: p ~ U(0,1),
/// chi2/dof ~ 1 +- 0.4; a sawtooth quantization the model cannot describe reaches chi2/dof 1e3).
bool grossMisfit(const FitResult& fit);
FitError fitError(const DeviationCurve& curve, const std::vector<double>& model_var, const std::vector<bool>& used,
                  int n_params, double rms_min_edf = 3.0);

}  // namespace gyro_allan
