// Wavelet split of a gyro rate into a denoised part and the removed fine-scale (quantization) part, Allan variance
// of each, and IEEE 952 coefficients: Q from the removed part, N and longer-tau terms from the coarse scales.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "gyro_allan/allan.hpp"
#include "gyro_allan/noise_model.hpp"
#include "gyro_allan/wavelet.hpp"

namespace gyro_allan {

/// How Q is estimated.
///  "angle": variance of the integrated removed part (the quantization angle error, spectrum-shape free: white
///           dithered error and a sawtooth both have variance Q^2), minus the ARW it carries (exact for the split,
///           from N) and divided by the fraction of white quantization noise the split keeps.
///  "allan": fitNoiseModel of the removed part's oadev with 3Q^2/tau^2 + N_r^2/tau (N_r absorbs removed ARW).
/// How N is estimated (B, K and R: waveletSplit).
///  "wavelet_variance": weighted least squares on the DWT wavelet variances of the coarse levels (ARW-dominated,
///           nearly free of the blue quantization noise), with the remaining quantization share subtracted from Q
///           and the input fit's B and K held fixed.
///  "allan": fitNoiseModel of the denoised part's oadev for tau >= 4 * 2^level * tau0 (where the denoised part
///           holds the full ARW), with a 3Q_d^2/tau^2 term absorbing the leaked quantization noise.
struct WaveletSplitOptions {
  std::string wavelet = "sym8";
  int level = 0;                                   ///< split level; <= 0: automatic (see docs/wavelet_split.md)
  ThresholdRule rule = ThresholdRule::Sqtwolog;
  ThresholdMode mode = ThresholdMode::Soft;
  NoiseScaling scaling = NoiseScaling::SlnRms;    ///< see docs/wavelet_split.md for why not "sln"
  std::string q_estimator = "angle";               ///< "angle" or "allan"
  std::string n_estimator = "wavelet_variance";    ///< "wavelet_variance" or "allan"
  /// Levels used for N: predicted quantization share of the level's variance at most this (wavelet_variance).
  double max_quantization_share = 0.8;
  /// Levels of the free-share fit (whiteness check): white-model quantization at most this times the ARW there.
  double free_fit_max_ratio = 3.0;
  DeviationOptions deviation;                      ///< for the two oadev curves
  /// Terms of the denoised part's fit and of the input fit (Q is handled separately; N, B, K, R by default).
  std::array<bool, kNumTerms> enabled{{true, true, true, true, true}};
  bool keep_signals = false;                       ///< keep denoised/removed samples in the result
  /// Quantization that is not white (a sawtooth): Q^2 and N^2 are corrected for the estimator's bias, and Q^2 takes
  /// its sigma, from this many records simulated from the fitted model (parametric bootstrap); < 2: the analytic
  /// allowance. The pipeline (analysis.hpp) sets 0 unless the output is a detected pulse count (quantized_output.hpp).
  int sawtooth_replicas = 10;
};

/// The parametric bootstrap of Q^2 and N^2 for quantization that is not white (WaveletSplitOptions::sawtooth_replicas):
/// records simulated from the fitted model (an undithered pulse counter of weight Q sqrt(12) at the record's mean
/// rate, and N), each run through the same Q and N estimator.
struct SawtoothBootstrap {
  int replicas = 0;                 ///< records simulated (0: not run: white quantization, or turned off)
  bool applied = false;             ///< Q, N corrected and Q's sigma taken from the replicas; else `note` says why not
  std::string note;
  int replicas_white = 0;           ///< replicas whose quantization the whiteness check called white
  double q2_bias = 0, n2_bias = 0;  ///< mean replica estimate minus the value simulated with [rad^2; rad^2/s]
  double q2_sd = 0, n2_sd = 0;      ///< scatter of the replica estimates [rad^2; rad^2/s]
  double q2_raw = 0, n2_raw = 0;    ///< the record's own estimates before the correction [rad^2; rad^2/s]
};

/// Wavelet variance of one DWT level (interior coefficients only) and the model's prediction.
struct WaveletLevel {
  int level = 0;
  double f_lo = 0, f_hi = 0;     ///< nominal pass band [Hz]
  int64_t count = 0;             ///< interior coefficients used
  double var = 0;                ///< mean square detail coefficient [(rad/s)^2]
  double model_var = 0;          ///< fitted model (all terms)
  double quantization_var = 0;   ///< the quantization part of model_var (white angle error of variance Q^2)
  bool used_for_n = false;
};

struct WaveletSplitResult {
  bool ok = false;
  std::string message;
  std::string wavelet;
  int level = 0;
  double split_frequency_hz = 0;       ///< fs / 2^(level+1): the removed part is (nearly) everything above
  std::vector<double> thresholds;      ///< wden thresholds per level 1..level
  double kept_fraction = 0;            ///< fraction of detail coefficients the thresholding kept (0: a pure split)

  DeviationCurve denoised_curve;       ///< oadev of the denoised part
  DeviationCurve removed_curve;        ///< oadev of the removed part
  /// Q, N, B, K, R with 1-sigma (same layout and units as FitResult::terms): Q and N the split's, B, K and R the
  /// input fit's or the denoised fit's (longer_tau_from_input; waveletSplit). The model curve behind the fit errors
  /// is drawn from these values.
  bool longer_tau_from_input = false;
  std::array<Coefficient, kNumTerms> terms;
  FitResult denoised_fit;              ///< Allan fit of the denoised part (tau >= 4 * 2^level * tau0)
  FitResult removed_fit;               ///< Allan fit of the removed part: 3Q^2/tau^2 + N_r^2/tau
  FitError fit_error;                  ///< combined model vs oadev of the input (rms_log10, chi2_dof)
  FitError denoised_fit_error;         ///< denoised fit vs denoised curve
  FitError removed_fit_error;          ///< removed fit vs removed curve

  /// Integral of the removed part (quantization angle error), on the interior: one level-L scaling function length
  /// plus 2^L samples are dropped at each end, where the symmetric extension distorts the split.
  AngleErrorStats removed_angle;
  // ARW accounting: the removed part carries the white ARW above the split frequency.
  double removed_arw_angle_var = 0;    ///< N^2 tau0 V_N: ARW share of the removed angle variance [rad^2]
  double removed_arw_share = 0;        ///< removed_arw_angle_var / var(removed angle)
  double quantization_kept = 0;        ///< V_Q: fraction of white quantization angle variance in the removed part
  /// Whiteness check of the quantization noise on the coarse levels: the share gamma fitted freely there agrees
  /// with the white model Q^2 a_j (true), or not (false: e.g. a sawtooth; N then comes from the free fit).
  bool quantization_white = true;
  double quantization_level_share = 0; ///< gamma / Q^2 of the free fit (1 for white quantization noise)
  SawtoothBootstrap sawtooth_bootstrap;  ///< bias and sigmas of Q^2, N^2 by simulation when not white

  // Every estimate, so the choice can be checked (all SI).
  double q_angle = 0, q_angle_sigma = 0;
  double q_allan = 0, q_allan_sigma = 0;
  double n_removed = 0;                ///< N_r of the removed-part Allan fit
  double n_wavelet = 0, n_wavelet_sigma = 0;
  double n_allan = 0, n_allan_sigma = 0;
  std::vector<WaveletLevel> levels;

  std::vector<double> denoised, removed;  ///< only with keep_signals
};

/// Runs the split on `rate` [rad/s] sampled every tau0 [s]. Throws std::invalid_argument on bad input (tau0 <= 0,
/// non-finite samples, too short a record for the wavelet, unknown estimator names).
/// `raw_oadev`, when given, is computeDeviation("oadev", rate, Rate, tau0, options.deviation) computed by the caller
/// (the pipeline already has it); it is used as is instead of being computed again.
/// B, K and R live at long tau, where the split changes nothing; they are read from the fit of the input's own Allan
/// curve (fitWithModelEdf with options.enabled: the `input_fit` the caller already has or, without it, the split's
/// own) unless that fit is a gross misfit (grossMisfit: e.g. a sawtooth quantization the model cannot describe),
/// and then from the denoised part's fit.
WaveletSplitResult waveletSplit(const std::vector<double>& rate, double tau0, const WaveletSplitOptions& options = {},
                                const DeviationCurve* raw_oadev = nullptr, const FitResult* input_fit = nullptr);

/// Expected mean square of the level-j DWT detail coefficient (orthonormal, interior) per unit coefficient squared
/// of each IEEE term (Q^2 of white angle error, N^2, B^2 flicker, K^2): exact for Q and N (filter norms), by
/// numerical integration of the PSD for B and K. R gives none (vanishing moments). Index [j-1][term].
std::vector<std::array<double, kNumTerms>> waveletLevelResponses(const Wavelet& w, int max_level, double tau0);

/// Exact factors of the linear split at `level` (all detail coefficients removed) for the removed-part angle
/// (cumulative sum * tau0), averaged over the 2^level phases:
///   E var(angle) = V_Q * Q^2 (white angle error of variance Q^2) + V_N * N^2 * tau0 (white rate noise).
struct SplitAngleFactors {
  double v_q = 0;
  double v_n = 0;  ///< in samples
};
SplitAngleFactors splitAngleFactors(const Wavelet& w, int level);

/// The automatic split level, model-free: with the DWT wavelet variances of the rate, the plateau is the median of
/// the three coarsest usable levels (ARW-dominated), the crossover level is the first level whose variance is at
/// most twice the plateau, and the split level is one below it (clamped to [1, levels - 4]).
int automaticSplitLevel(const std::vector<double>& rate, double tau0, const Wavelet& w);

}  // namespace gyro_allan
