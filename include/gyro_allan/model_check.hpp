// Closing the loop on the IEEE 952 fit: residual structure, tracing it to an effect the model lacks (sinusoid,
// narrowband oscillation, Gauss-Markov, bias step, thermal drift, outliers) with evidence from the raw samples,
// joint refit with that effect as an ExtraTerm, kept only when the BIC improves, its parameters are significant and
// the final joint model's RMS log10 error is lower with it than without it (docs/model_check.md, acceptance rule).
#pragma once

#include <map>
#include <string>
#include <vector>

#include "gyro_allan/allan.hpp"
#include "gyro_allan/noise_model.hpp"

namespace gyro_allan {

/// Residual of a model AVAR curve and its verdict.
///
/// Descriptive (not a test): z = sqrt(edf/2) (var/model - 1) per used point, a Wald-Wolfowitz runs test on the signs
/// of z, the most significant same-sign stretch and the short/long-tau trends. Adjacent taus share data, so these z
/// are strongly correlated and the runs numbers would call almost every clean record structured (they did: 296 of
/// 300 clean controls of check_study with the GLS fit).
///
/// Calibrated verdict (`structured`): from the covariance of the AVAR estimates across tau (avar_covariance.hpp,
/// the GLS fit's weight matrix), two tests on the fit's octave-spaced points:
///  - the generalized chi-squared r' C^-1 r of the fit against chi2(dof) (FitResult::chi2, chi2_p): misfit anywhere;
///  - a runs test on the signs of the whitened residuals (L^-1 r, L the Cholesky factor of C, points in tau order):
///    too few runs = a stretch of the curve on one side of the model, which the chi-squared dilutes over all points.
/// Combined by Bonferroni: p_value = min(1, 2 min(chi2_p, runs_p)); structured when p_value < alpha
/// (ModelCheckOptions::structured_alpha; false-alarm rate measured on clean simulated records in
/// docs/model_check.md).
struct ResidualAnalysis {
  std::vector<double> tau;   ///< used points
  std::vector<double> z;     ///< normalized residual (positive: data above the model)
  double chi2_dof = 0;
  int runs = 0;               ///< runs of same-sign z
  double runs_expected = 0;   ///< Wald-Wolfowitz expectation for the observed numbers of signs
  double runs_z = 0;          ///< (runs - expected) / sd: descriptive (correlated z)
  double bump_z = 0;          ///< most significant same-sign stretch: sum z / sqrt(length), signed
  double bump_tau_lo = 0, bump_tau_hi = 0;
  double short_trend_z = 0;   ///< mean z of the 4 shortest-tau points * 2
  double long_trend_z = 0;    ///< mean z of the 4 longest-tau points * 2
  bool descriptive_structure = false;  ///< runs_z < -3, |bump_z| > 5 or a trend beyond 4 (the old, uncalibrated rule)
  // Calibrated tests (GLS fits only; calibrated false when the fit has no covariance).
  bool calibrated = false;
  double chi2 = 0;            ///< generalized chi-squared of the fit (FitResult::chi2)
  int dof = 0;
  double chi2_p = 1.0;        ///< its upper-tail probability
  std::vector<double> whitened_tau, whitened;  ///< whitened residual at the octave-spaced points
  int whitened_runs = 0;
  double whitened_runs_expected = 0;
  double whitened_runs_p = 1.0;  ///< one-sided P(runs <= observed) of the sign runs of the whitened residual
  double p_value = 1.0;       ///< Bonferroni combination of chi2_p and whitened_runs_p
  double alpha = 0.01;        ///< level of the verdict
  bool structured = false;    ///< calibrated: p_value < alpha; without a covariance: the descriptive rule
  std::string summary;        ///< one line for humans
};

/// Descriptive analysis only (no covariance): `structured` is the descriptive rule, `calibrated` false.
ResidualAnalysis analyzeResidual(const DeviationCurve& curve, const std::vector<double>& model_var,
                                 const std::vector<bool>& used, double chi2_dof);

/// Descriptive analysis plus the calibrated verdict for a GLS fit of `curve` (fit.gls; fit.model_var includes the
/// extra terms `extra` at their fitted fit.extra_c). Without fit.gls, as the overload above.
ResidualAnalysis analyzeResidual(const DeviationCurve& curve, const FitResult& fit,
                                 const std::vector<ExtraTerm>& extra, double alpha);

struct EffectParameter {
  double value = 0;
  double sigma = 0;
};

/// One effect added to the model.
struct DetectedEffect {
  std::string type;  ///< "sinusoid", "narrowband", "gauss_markov", "bias_step", "thermal_drift", "warmup", "outliers"
  std::map<std::string, EffectParameter> parameters;  ///< e.g. frequency_hz, amplitude, tau_c_s, sigma, time_s, size
  std::string evidence;   ///< what in the raw samples pointed to it
  double delta_bic = 0;   ///< BIC improvement when it was added (positive = better)
  ExtraTerm term;         ///< its AVAR basis (per unit c) as fitted
  /// Sinusoid / narrowband: the spectral content behind `term` (frequencies [Hz], weights summing to 1, bin width
  /// [Hz]; a sinusoid is one line of width 0): term.basis = sum_i w_i sinusoidAvar(tau, f_i, tau0). Empty otherwise.
  std::vector<double> spectrum_hz, spectrum_weight;
  double spectrum_bin_hz = 0;
};

struct FitSummary {
  double rms_log10 = 0;
  double chi2_dof = 0;
  double bic = 0;   ///< -2 ln L (EDF-based variances, scatter term included) + k ln(n_eff), points divided by the
                    ///< grid density (docs/model_check.md, "The likelihood behind the BIC")
  int n_params = 0;
};

struct ModelCheckOptions {
  FitOptions fit;
  int max_effects = 3;
  double bic_margin = 15.0;         ///< required BIC improvement to keep a deterministic effect (sinusoid, step...)
  /// ... and a stochastic one (Gauss-Markov, narrowband): they can trade places with flicker (B) and shift the
  /// model-based EDF: flicker wiggles gained 10-20 and strong random walks 30-34 in controls (validate_adis).
  double bic_margin_stochastic = 40.0;
  /// An effect is kept only when the final joint model describes the curve better than the same model refitted
  /// without it: RMS log10 error lower by at least this fraction (without the only effect: the plain fit). Hence the
  /// answer's error is below (1 - min_rms_gain) x the plain fit's, or the answer is the plain fit. Chosen on
  /// check_study seeds 1-30 (docs/model_check.md). Negative: off (studies only).
  double min_rms_gain = 0.02;
  /// ... and its amplitude (sqrt(c) of its AVAR term) is at least this many sigma, when it is added and again in the
  /// final joint refit with all kept effects (else it is dropped and the rest refitted).
  double min_amplitude_z = 3.0;
  /// ... and a searched nonlinear parameter (Gauss-Markov tau_c, warm-up theta) has a relative sigma at most this.
  double max_nonlinear_rel_sigma = 0.5;
  /// Level of the calibrated residual verdict (ResidualAnalysis::structured: generalized chi-squared and whitened
  /// runs test, Bonferroni-combined). Chosen on check_study seeds 1-30 (docs/model_check.md).
  double structured_alpha = 0.01;
  double psd_min_prominence_db = 8.0;
  int psd_max_peaks = 3;
  /// Lines from this many periods per record up to 32 fine Welch bins come from the whole-record periodogram
  /// (findSlowLines), above from the Welch PSD; a line is taken out of the samples when its family-wise false-alarm
  /// probability over its band is below line_false_alarm / 2 (the record's below line_false_alarm); at most
  /// psd_max_peaks slow lines.
  double line_min_periods = 4.0;
  double line_false_alarm = 0.01;
  double step_min_z = 6.0;          ///< block-mean difference in robust sigmas
  double acf_min_z = 5.0;           ///< lag-1 correlation in units of 1/sqrt(n)
  double thermal_min_z = 5.0;       ///< rate-vs-temperature slope in sigmas
  double warmup_min_z = 8.0;        ///< warm-up amplitude in (white-residual) sigmas
  /// Gauss-Markov and narrowband candidates only when the plain fit's residual on the measured curve is structured
  /// (ResidualAnalysis::structured at structured_alpha); false: off (studies and tests).
  bool stochastic_needs_structure = true;
  double outlier_min_z = 10.0;      ///< robust sigmas from the local median
  bool search_sinusoid = true, search_gauss_markov = true, search_bias_step = true, search_thermal = true,
       search_outliers = true;
};

/// The band the periodic-effect search covered: the whole-record periodogram from slow_lo_hz (line_min_periods per
/// record) to slow_hi_hz, the Welch PSD from there to nyquist_hz; each band's whole-record bins (independent
/// frequencies), each band tested at a family-wise false-alarm probability of line_false_alarm / 2. All zero when no
/// line was searched.
struct LineSearchBand {
  double slow_lo_hz = 0, slow_hi_hz = 0, nyquist_hz = 0;
  int slow_frequencies = 0, welch_frequencies = 0;
  double false_alarm_each = 0;
};

struct ModelCheck {
  bool ok = false;
  std::string message;
  FitSummary before, after;
  ResidualAnalysis residual_before, residual_after;
  std::vector<DetectedEffect> effects;      ///< in the order they were added
  std::vector<std::string> rejected;        ///< candidates examined and not kept, with the reason
  FitResult fit_before, fit_after;          ///< fit_after: base coefficients + effects jointly
  std::vector<ExtraTerm> extra;             ///< the ExtraTerms of fit_after (same order as effects)
  LineSearchBand line_search;               ///< where lines were searched, at which false-alarm level
  std::vector<double> tau, measured_var, model_var_before, model_var_after;  ///< at the curve points
};

/// Copy of `curve` whose alpha and EDF come from a fitted model instead of the data's own noise identification:
/// alpha of the IEEE term contributing most at each tau (Q: 2 white PM, N: 0, B: -1, K and R: -2), EDF from
/// deviationEdf(curve.name, alpha, m, n_phase), confidence bounds refilled at `confidence`. Useful when the lag-1
/// noise identification is unreliable (few long-tau terms); fit again on the result.
DeviationCurve withModelEdf(const DeviationCurve& curve, const FitResult& fit, double confidence = 0.683);

/// Two-pass IEEE fit: fitNoiseModel with the curve's EDFs, then each point's noise type taken from the model term that
/// dominates there (withModelEdf: Q white PM, N white FM, B flicker FM, K and R random-walk FM) and fitted again.
/// Far less noisy than per-point noise identification at long tau. *curve receives the model-based EDFs and bounds.
/// Used by analyzeAxis and the nodelet alike.
FitResult fitWithModelEdf(DeviationCurve* curve, const FitOptions& options = {}, double confidence = 0.683);

/// Runs the check. `curve` is the measured AVAR curve (oadev with EDF) of `rate` (sample interval tau0), `fit` its
/// plain IEEE fit with opts.fit. temperature (optional) must have rate.size() samples. Throws
/// std::invalid_argument on inconsistent input.
ModelCheck checkModel(const std::vector<double>& rate, double tau0, const DeviationCurve& curve, const FitResult& fit,
                      const ModelCheckOptions& opts, const std::vector<double>* temperature = nullptr);

}  // namespace gyro_allan
