// Generalized Method of Wavelet Moments (Guerrier et al. 2013): Haar MODWT wavelet variance, closed-form wavelet
// variances of WN/QN/RW/DR/Gauss-Markov (+ the model check's lines as known terms), efficient GMWM fit, model
// selection, and the filter-ready state-space model.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "gyro_allan/allan.hpp"

namespace gyro_allan {

// ---- Wavelet variance ----------------------------------------------------------------------------------------
// Haar MODWT at level j (j = 1, 2, ...): filter length L_j = 2^j samples, scale tau_j = 2^j tau0; the coefficient
// W_{j,t} = (mean of samples t-m+1..t  -  mean of samples t-2m+1..t-m) / 2 with m = 2^(j-1). Its variance nu_j^2 is
// half the Allan variance at averaging time m tau0: nu_j^2 = AVAR(tau_j / 2) / 2. The estimate averages W^2 over the
// M_j = n - L_j + 1 coefficients that involve no boundary (unbiased), i.e. it equals oavar(m) / 2 exactly.

struct WaveletVariance {
  double tau0 = 0;                 ///< sample interval [s]
  int64_t n = 0;                   ///< samples
  std::vector<int> level;          ///< j
  std::vector<double> scale;       ///< tau_j = 2^j tau0 [s]
  std::vector<double> nu2;         ///< estimate [(rad/s)^2]
  std::vector<int64_t> n_coeffs;   ///< M_j
  std::vector<double> eta;         ///< EDF of the CI: max(M_j / 2^j, 1) (Percival's eta_3, as the GMWM package)
  std::vector<double> lo, hi;      ///< chi-squared CI of nu2 at `confidence`
  double confidence = 0.95;
};

/// Haar MODWT wavelet variance of the samples at levels 1..J, J the largest level with 2^j <= n / max_fraction_inv
/// (default: scales up to a quarter of the record). Throws std::invalid_argument when fewer than 8 samples or any
/// sample is not finite.
WaveletVariance haarWaveletVariance(const std::vector<double>& x, double tau0, double confidence = 0.95,
                                    int max_fraction_inv = 4);

// ---- Theoretical wavelet variance (sample units: variances per sample, scale tau in samples = 2^j) -------------
/// White noise of variance s2: s2 / tau.
double wvWhite(double s2, double tau);
/// Quantization noise (a first difference of white noise of variance q2, as a pulse counter): 6 q2 / tau^2.
double wvQuantization(double q2, double tau);
/// Random walk with innovation variance g2: g2 (tau^2 + 2) / (12 tau).
double wvRandomWalk(double g2, double tau);
/// Linear drift of slope w per sample: w^2 tau^2 / 16.
double wvDrift(double w2, double tau);
/// AR(1) x_t = phi x_{t-1} + e_t, Var(e) = s2, 0 <= phi < 1 (Guerrier et al. 2013):
///   ((phi^2 - 1) tau + 2 phi (phi^tau - 4 phi^(tau/2) + 3)) s2 / ((phi - 1)^3 (phi + 1) tau^2).
/// Evaluated in a cancellation-free form in terms of a = -ln(phi).
double wvAr1(double phi, double s2, double tau);
/// Moving average x_t = e_t + theta_1 e_{t-1} + ... + theta_q e_{t-q}, Var(e) = s2: autocovariances gamma_0..gamma_q,
/// gamma_h = s2 sum_k theta_k theta_{k+h} (theta_0 = 1).
std::vector<double> maAutocovariance(const std::vector<double>& theta, double s2);
/// Haar wavelet variance of a stationary process whose autocovariance vanishes beyond acf.size() - 1 (short memory,
/// e.g. an MA(q)), exact at any scale tau = 2m samples: (2m gamma_0 + 2 sum_{h>=1} a_m(h) gamma_h) / (4 m^2) with the
/// Haar filter's autocorrelation a_m(h) = 2m - 3h (h <= m), -(2m - h) (m <= h < 2m), 0 beyond. O(q).
double wvShortMemory(const std::vector<double>& acf, double tau);
/// Exact Haar wavelet variance of a stationary process from its autocovariance acf[0..] (acf[k] = 0 beyond the
/// vector): sum_l sum_l' h_l h_l' acf(|l - l'|). O(tau^2); the reference for the closed forms (tests).
double wvFromAutocovariance(const std::vector<double>& acf, int64_t tau);

// ---- Known terms (effects found by the model check) ---------------------------------------------------------------
/// An effect the model check found (model_check.hpp) entered into the GMWM as a fixed-shape term: its Haar WV at
/// level j is c basis(2^(j-1) tau0) / 2 (nu_j^2 = AVAR(tau_j / 2) / 2). Only stationary spectral effects enter:
/// "sinusoid" (a deterministic line, c = A^2 of A sin(2 pi f t)) and "narrowband" (a stationary Gaussian oscillation
/// with the measured shape of its PSD excess, c = 2 x its variance). Neither is part of the state-space bias model
/// (Phi, Qd): a filter must notch them or model them separately.
struct GmwmKnownTerm {
  std::string type;                        ///< "sinusoid" or "narrowband"
  std::function<double(double tau)> basis; ///< AVAR per unit c at averaging time tau [s] (ExtraTerm::basis)
  double c = 0;                            ///< amplitude coefficient (the model check's joint refit; fitted: GMWM's)
  double c_sd = 0;                         ///< its 1-sigma (GMWM fit; 0 when fixed)
  /// Spectral content: component frequencies [Hz] and weights summing to 1 (power of component i = c w_i / 2); one
  /// line for a sinusoid; a narrowband's bins of width spectrum_bin_hz. Used by the covariance and the simulation.
  std::vector<double> spectrum_hz, spectrum_weight;
  double spectrum_bin_hz = 0;
  std::map<std::string, double> parameters;  ///< the model check's parameters (SI: frequency_hz, bandwidth_hz, ...)
  bool stochastic() const { return type == "narrowband"; }
};

// ---- Models -----------------------------------------------------------------------------------------------------
/// A composite model: sum of the enabled processes.
struct GmwmModel {
  bool white = true;           ///< WN (angle random walk N)
  bool quantization = false;   ///< QN (Q)
  bool random_walk = false;    ///< RW (rate random walk K)
  bool drift = false;          ///< DR (rate ramp R)
  int gauss_markov = 0;        ///< number of first-order Gauss-Markov (AR1) terms
  /// Order q of a short-memory measurement noise MA(q) (white noise through a q-tap FIR, e.g. a sensor's output
  /// filter) that replaces WN (white = false; WN is MA(0)); 0 = none.
  int moving_average = 0;
  std::string name() const;    ///< e.g. "WN+2GM+RW", "MA2+GM+RW"
  int parameters() const;      ///< free parameters
};
/// Parses "WN+2GM+RW", "QN+WN+GM", "MA2+GM", ... (terms WN, MAq (q = 1..9, not with WN), QN, RW, DR, GM, kGM;
/// case-insensitive). Throws on bad text.
GmwmModel parseGmwmModel(const std::string& text);

struct GaussMarkovTerm {
  double sigma = 0, sigma_sd = 0;  ///< stationary standard deviation [rad/s] and its 1-sigma
  double tc = 0, tc_sd = 0;        ///< correlation time [s] and its 1-sigma
};

/// A fitted model in SI (gyro: rad, rad/s). The *_sd are 1-sigma from the GMWM asymptotic covariance
/// (J' Omega^-1 J)^-1 mapped from the log parameters by the delta method.
struct GmwmFit {
  GmwmModel model;
  bool ok = false;
  std::string message;
  double N = 0, N_sd = 0;       ///< angle random walk [rad/sqrt(s)]; with MA(q): its long-run equivalent sqrt(S(0) tau0)
  /// MA(q) measurement noise (model.moving_average = q): coefficients theta_1..theta_q (lags in data samples) with
  /// their 1-sigma, and the innovation as a white-noise density sqrt(Var(e) tau0) [rad/sqrt(s)]. Its long-run angle
  /// random walk is N = ma_innovation * |1 + sum theta|.
  std::vector<double> ma, ma_sd;
  double ma_innovation = 0, ma_innovation_sd = 0;
  double Q = 0, Q_sd = 0;       ///< quantization [rad] (Allan convention: AVAR 3 Q^2 / tau^2)
  double K = 0, K_sd = 0;       ///< rate random walk [rad/s/sqrt(s)]
  double R = 0, R_sd = 0;       ///< rate ramp magnitude [rad/s^2]
  std::vector<GaussMarkovTerm> gm;  ///< sorted by correlation time
  double tau0 = 0;              ///< sample interval of the data [s]
  double chi2 = 0;              ///< (nu_hat - nu(theta))' Omega(theta)^-1 (nu_hat - nu(theta)) at the estimate
  int dof = 0;                  ///< levels - parameters
  double chi2_p = 1;            ///< upper tail of chi2(dof)
  double criterion = 0;         ///< chi2 + penalty * parameters (smaller is better)
  /// Every coloured term is supported by the data: each log parameter (log variance of RW/DR/GM, log tc) has a 1-sigma
  /// below `GmwmOptions::max_log_sd` (for a variance: the estimate lies more than 2 sigma above zero). Selection
  /// considers identified fits only (a spurious extra GM fitted to the last noisy levels is not identified).
  bool identified = false;
  std::string unidentified;     ///< which terms were not
  std::vector<double> model_nu2;   ///< model WV at the levels
  /// Known terms (GmwmOptions::known) with c as fitted (GmwmOptions::refit_known) or as given; part of model_nu2 and
  /// of gmwmModelAvar / gmwmModelWvAt / simulateGmwmFit, not of discretize().
  std::vector<GmwmKnownTerm> known;
  Eigen::VectorXd theta;        ///< internal log parameters (then log c of each known term when refitted)
  Eigen::MatrixXd theta_cov;
  int iterations = 0;
};

struct GmwmOptions {
  /// Penalty per free parameter of the selection criterion chi2 + penalty p. 2 is the WIC of an efficient GMWM
  /// (its optimism 2 tr((J'WJ)^-1 J'W Omega W J) is 2p when W = Omega^-1); the default is calibrated on the tuning
  /// seeds of gmwm_study (docs/gmwm.md).
  double penalty_per_parameter = 2.0;
  /// Candidate models for selection; empty = WN+RW, WN+kGM, WN+kGM+RW for k = 1..max_gm (QN/DR added when
  /// quantization / drift below are set).
  std::vector<GmwmModel> candidates;
  int max_gm = 3;
  /// MA(q) measurement-noise candidates (docs/gmwm.md; default candidate lists only): the WN candidates with at most
  /// as many GM terms as the selected WN model, again with MA(1) instead of WN; while the best MA(q) criterion beats
  /// the best of order q-1 (WN for q = 1), MA(q+1) versions are added, up to this order (0 = none).
  int max_ma = 4;
  bool quantization = false;    ///< default candidates also carry QN
  bool drift = false;           ///< default candidates also carry DR
  double max_log_sd = 0.5;      ///< see GmwmFit::identified
  int weighting_iterations = 3; ///< Omega re-evaluated at the current estimate this many times
  double confidence = 0.95;     ///< of the wavelet-variance CI
  /// Known terms (effects of the model check, docs/gmwm.md "Known terms") added to every candidate's theoretical WV
  /// and to its WV covariance. Empty: the fit is exactly the one without them.
  std::vector<GmwmKnownTerm> known;
  /// Re-estimate each known term's c as a non-negative weight (a log parameter started at the given c, counted in
  /// the parameters and dof; the same for every candidate, so the selection is unchanged by it); false: fixed at c.
  bool refit_known = true;
};

/// The known terms' WV at the levels of wv (sum over terms of c basis(2^(j-1) tau0) / 2).
std::vector<double> knownTermsWv(const WaveletVariance& wv, const std::vector<GmwmKnownTerm>& known);

/// Model-based covariance of the WV estimates (asymptotic, Gaussian process): Cov(nu_j, nu_k) =
/// 2 min(M_j, M_k) / (M_j M_k) * integral_{-1/2}^{1/2} |H_j(f)|^2 |H_k(f)|^2 S(f)^2 df, S the model's two-sided
/// spectrum in sample units (the drift, deterministic, contributes nothing). Exposed for tests.
Eigen::MatrixXd gmwmCovariance(const WaveletVariance& wv, const GmwmModel& model, const Eigen::VectorXd& theta);
/// What the known terms add to that covariance (same Gaussian asymptotics; the fit's Omega is the sum): with the total
/// spectrum S + S_k, S_k = sum_i p_i/2 (delta(f - f_i) + delta(f + f_i)), p_i = c w_i / 2, the integral gains the cross
/// term 2 sum_i p_i G_j(f_i) G_k(f_i) S(f_i) (for a deterministic line exactly the variance of 2 W_line W_noise) and,
/// for a narrowband term with its power p_i spread over a bin of width w (cycles/sample), its own
/// sum_i p_i^2 G_j G_k / (2 w); a line's own part is deterministic: none. G_j = |H_j|^2. theta: the stochastic part.
Eigen::MatrixXd gmwmKnownCovariance(const WaveletVariance& wv, const GmwmModel& model, const Eigen::VectorXd& theta,
                                    const std::vector<GmwmKnownTerm>& known);
/// Model WV at the levels of wv for internal parameters theta.
std::vector<double> gmwmModelWv(const WaveletVariance& wv, const GmwmModel& model, const Eigen::VectorXd& theta);

/// Fits one model to a wavelet variance: robust multi-start, then Levenberg-Marquardt on the log parameters with the
/// weight Omega^-1 re-evaluated at the estimate (weighting_iterations times; the first pass weights by the data's
/// own WV, 2 nu_hat^4 / eta). Never throws on bad data: ok = false with a message.
GmwmFit fitGmwm(const WaveletVariance& wv, const GmwmModel& model, const GmwmOptions& options = {});

struct GmwmSelection {
  std::vector<GmwmFit> fits;   ///< every candidate, in candidate order
  int best = -1;               ///< index of the smallest criterion among ok fits
  const GmwmFit& chosen() const { return fits.at(static_cast<size_t>(best)); }
};
/// Fits every candidate (then the MA(q) ones, GmwmOptions::max_ma) and picks the smallest criterion among identified
/// fits (among all ok fits when none is identified). best = -1 when none fitted.
GmwmSelection selectGmwm(const WaveletVariance& wv, const GmwmOptions& options = {});

// ---- Model Allan variance and the filter-ready state-space form ------------------------------------------------
/// Overlapping-AVAR expectation of the fitted model at averaging factor m (tau = m tau0), exact for sampled data.
double gmwmModelAvar(const GmwmFit& fit, double tau0, int64_t m);
/// Model wavelet variance at scale 2^j tau0.
double gmwmModelWvAt(const GmwmFit& fit, double tau0, int level);
/// A record of n samples at interval tau0 simulated from the fitted model (WN or MA(q), GM terms started
/// stationary, RW from 0, QN as a first difference of white noise, DR as a ramp; deterministic by seed): data of which
/// `fit` is the truth, e.g. to see how often the true model's Allan deviation lies inside the data's CI.
std::vector<double> simulateGmwmFit(const GmwmFit& fit, double tau0, int64_t n, uint64_t seed);

/// Discrete bias model b = sum of states, state x = [gm_i .. , rw] (rw only when K > 0):
/// x[k+1] = Phi x[k] + w[k], Cov(w) = Qd, Phi = diag(exp(-dt/tc_i), 1), Qd = diag(sigma_i^2 (1 - exp(-2 dt/tc_i)),
/// K^2 dt). Measurement white noise of one rate sample averaged over dt: N^2 / dt (+ 2 Q^2 / dt^2 for quantization,
/// which is not white: lag-1 correlation -1/2). A GM whose correlation time is below dt/2 is white at that step: it
/// is not a state but folded into the white variance as the white noise with the same long-run angle random walk:
/// N_eq^2 / dt with N_eq^2 = sigma^2 tau0 (1 + phi0) / (1 - phi0), phi0 = exp(-tau0/tc) at the data interval tau0
/// (the sampled AR(1)'s sum of autocovariances; 2 sigma^2 tc when tc >> tau0). Listed in `folded`.
/// An MA(q) measurement noise is folded the same way (its N is already the long-run equivalent, N^2 = S(0) tau0),
/// listed as "maq": right for the integrated angle; one step's variance and the correlation of neighbouring steps are
/// off by O(q / k) at k = dt / tau0 samples per step, which `approximation` states when above 1 % (or k <= q).
struct DiscreteNoiseModel {
  double dt = 0;
  Eigen::MatrixXd Phi, Qd;
  std::vector<std::string> states;
  std::vector<std::string> folded;   ///< GM terms folded into white_variance
  double white_variance = 0;      ///< N^2 / dt (+ folded GMs) [(rad/s)^2]
  double quantization_variance = 0;  ///< 2 Q^2 / dt^2 [(rad/s)^2]
  std::string approximation;      ///< empty, or what the white measurement noise leaves out at this dt
};
DiscreteNoiseModel discretize(const GmwmFit& fit, double dt);

// ---- Closed-loop check and the analysis stage -----------------------------------------------------------------------
/// A model's Allan deviation against a measured curve over tau in [tau_min, tau_max].
struct CurveAgreement {
  double tau_min = 0, tau_max = 0;
  int points = 0;
  int within_ci = 0;          ///< model ADEV inside [dev_lo, dev_hi]
  double worst_ratio = 1;     ///< max over points of max(r, 1/r), r = model ADEV / measured ADEV
  double worst_tau = 0;       ///< where
  double rms_log10 = 0;       ///< RMS of log10(measured / model ADEV)
};
CurveAgreement curveAgreement(const DeviationCurve& curve, const std::vector<double>& model_var, double tau_min,
                              double tau_max);

/// GMWM of one axis (the analysis stage behind --method gmwm and noise_model.yaml).
/// A model-check effect that is not a known term of the GMWM fit, and why.
struct LeftOutEffect {
  std::string type;    ///< DetectedEffect::type
  std::string reason;
};

struct GmwmAxis {
  bool ok = false;
  std::string message;             ///< why not ok
  double tau0 = 0, record_s = 0;   ///< the segment analysed
  double penalty_per_parameter = 0;  ///< of the selection criterion used
  WaveletVariance wv;
  GmwmSelection selection;
  int wv_points = 0, wv_within_ci = 0;  ///< chosen model's WV inside the data's WV CI
  /// Closed loop: the chosen state-space model's AVAR (exact for sampled data) and the IEEE 952 model's, each against
  /// the measured oadev over tau from tau0 to record/10.
  bool compared = false;
  CurveAgreement gmwm_vs_data, ieee_vs_data;
  CurveAgreement final_vs_data;  ///< the report's final model (IEEE terms + the model check's effects, or the split)
  double worst_avar_ratio_vs_ieee = 1;  ///< max over the same points of the AVAR ratio GMWM / IEEE model (or inverse)
  /// Effects of the model check that are not known terms of the fit (knownTermsFromEffects).
  std::vector<LeftOutEffect> effects_not_in_model;
};

/// WV and model selection on one gap-free segment of rate samples. Never throws: ok = false with a message.
GmwmAxis gmwmStage(const std::vector<double>& rate, double tau0, const GmwmOptions& options = {});
/// The model check's effects as known terms: sinusoid and narrowband enter (c from the check's joint refit);
/// the others are returned in *left_out with the reason (gauss_markov / short_correlation: the GMWM's own GM / MA(q)
/// terms model it; bias_step, thermal_drift, warmup, outliers: not stationary, no wavelet-variance term).
struct DetectedEffect;
std::vector<GmwmKnownTerm> knownTermsFromEffects(const std::vector<DetectedEffect>& effects,
                                                 const std::vector<double>& extra_c,
                                                 std::vector<LeftOutEffect>* left_out);
/// Fills the closed-loop comparison (ieee_model_var: the IEEE model's AVAR at oadev's points).
/// final_model_var (optional): the report's final model at the same points.
void gmwmCompare(GmwmAxis* g, const DeviationCurve& oadev, const std::vector<double>& ieee_model_var,
                 const std::vector<double>& final_model_var = {});

// ==== The reported noise model (issue #16) ==========================================================================
// Everything noise_model.yaml and the nodelet's ~noise_model message report for one axis, computed here once: both
// writers only copy these fields (src/io/noise_model_yaml.cpp, src/ros/noise_model_msg.cpp).

/// One discrete model of the report: discretize() at dt plus the measurement variance a filter uses.
struct ReportedDiscreteModel {
  double dt = 0;                     ///< [s]
  double rate_hz = 0;                ///< 1 / dt [Hz]
  DiscreteNoiseModel model;          ///< Phi, Qd, states, folded, white_variance, quantization_variance
  double measurement_variance = 0;   ///< white_variance + quantization_variance [(rad/s)^2]
};

/// One candidate of the selection as reported.
struct ReportedCandidate {
  std::string model;                 ///< e.g. "WN+2GM"
  bool ok = false;
  double criterion = 0, chi2 = 0;
  int dof = 0;
  bool identified = false;
  std::string unidentified;          ///< terms not supported (empty when identified)
};

/// One effect of the model check as reported (noise_model.yaml "known_terms"): a known term of the GMWM fit
/// (sinusoid, narrowband) or an effect the model leaves out (in_gmwm_fit false: type and note only).
struct ReportedKnownTerm {
  std::string type;                  ///< "sinusoid", "narrowband", "gauss_markov", "bias_step", ...
  bool in_gmwm_fit = false;          ///< in the fit's WV, covariance, chi2/dof and the closed loop
  bool in_state_space_model = false; ///< always false: not in Phi, Qd or measurement_variance
  std::string kind;                  ///< "deterministic line" or "stationary narrowband oscillation (...)"
  double frequency_hz = 0;           ///< [Hz] (0: not applicable)
  double bandwidth_hz = 0;           ///< [Hz] narrowband only (0: not applicable)
  double amplitude = 0, amplitude_sigma = 0;  ///< line: A of A sin(2 pi f t) [rad/s] (0: not applicable)
  double rms = 0, rms_sigma = 0;     ///< sqrt(c / 2) [rad/s]
  std::string note;                  ///< what a filter must do about it, or why it is not in the model
};

/// The noise model of one axis as reported (noise_model.yaml "axes.<axis>", docs/outputs.md).
struct ReportedNoiseModel {
  bool ok = false;
  std::string error;                 ///< why there is no model (the GMWM stage's message); the rest is empty
  std::string model;                 ///< chosen model name
  std::string selection;             ///< the selection rule in words (with the penalty per parameter)
  std::vector<ReportedCandidate> candidates;  ///< every candidate, in candidate order
  GmwmFit fit;                       ///< the chosen fit: continuous N, Q, K, R, gm (each with its 1-sigma), chi2, dof, chi2_p
  double segment_s = 0;              ///< length of the analysed segment [s]
  double data_rate_hz = 0;           ///< 1 / tau0 [Hz]
  std::vector<ReportedDiscreteModel> discrete;  ///< [0] at the data rate, [1] at the filter rate when one was asked
  // Flicker approximation: the GM terms stand in for the IEEE bias instability over the closed loop's tau range.
  int gauss_markov_terms = 0;
  double tau_min_s = 0, tau_max_s = 0;            ///< tau range of the closed-loop comparison [s]
  double ieee_bias_instability = 0, ieee_bias_instability_sigma = 0;  ///< the IEEE fit's reported B [rad/s]
  double worst_avar_ratio_vs_ieee_model = 1;      ///< max AVAR ratio GMWM / IEEE model (or inverse) over the range
  double worst_avar_ratio_vs_data = 1;            ///< the GMWM model's worst ADEV ratio vs the data, squared
  // Closed loop (gmwmCompare): each model's ADEV against the measured oadev.
  CurveAgreement gmwm_model, ieee_model, final_model;
  int wavelet_variance_points = 0, wavelet_variance_within_ci = 0;
  double wavelet_variance_confidence = 0;
  /// The model check's effects: fit.known (in the fit and the closed loop, NOT in Phi/Qd or measurement_variance),
  /// then the other effects, which the model does not contain. Empty when the check found none.
  std::vector<ReportedKnownTerm> known_terms;
};

/// The reported model of one axis's GMWM stage. filter_rate_hz <= 0: only the data rate's discrete model.
/// ieee_bi, ieee_bi_sigma: the IEEE fit's bias instability (AxisAnalysis::fit.terms_corrected) for the flicker part.
ReportedNoiseModel reportedNoiseModel(const GmwmAxis& g, double filter_rate_hz, double ieee_bi, double ieee_bi_sigma);

}  // namespace gyro_allan
