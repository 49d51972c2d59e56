// One axis, end to end: deviations of gap-free segments, the IEEE 952 fit (and later stages) — the core entry point
// shared by analyze_bag and tests.
#pragma once

#include <string>
#include <vector>

#include "gyro_allan/allan.hpp"
#include "gyro_allan/answer.hpp"
#include "gyro_allan/gmwm.hpp"
#include "gyro_allan/pulse_times.hpp"
#include "gyro_allan/model_check.hpp"
#include "gyro_allan/noise_model.hpp"
#include "gyro_allan/quality.hpp"
#include "gyro_allan/quantized_output.hpp"
#include "gyro_allan/spikes.hpp"
#include "gyro_allan/wavelet_split.hpp"

namespace gyro_allan {

struct AnalysisOptions {
  DeviationOptions deviation;                       ///< tau grid and confidence of every curve
  FitOptions fit;                                   ///< IEEE 952 fit settings
  std::vector<std::string> deviations{"oadev"};     ///< curves written out; the fit always uses oadev
  /// Rate samples (rad/s) or angle samples (rad). Angle input is turned into rate samples first (angleToRate, per
  /// gap-free segment); the deviations, the fit, the wavelet split and the model check then run as for rate input
  /// (spike removal does not: a jump in an angle record is not an isolated rate spike).
  InputKind input = InputKind::Rate;
  /// Angle input only: the samples are per-sample increments [rad] instead of the accumulated angle.
  bool angle_increments = false;
  /// Method whose coefficients are the answer: Auto (the rules of answer.hpp choose), JointFit or WaveletSplit.
  Method method = Method::Auto;
  bool wavelet_split = true;                        ///< run the wavelet split (needed for method wavelet_split)
  WaveletSplitOptions split;
  bool model_check = true;                          ///< run the closed loop (residual -> effect -> refit)
  ModelCheckOptions check;
  /// Rate input: isolated spikes (spikes.hpp) are replaced in every gap-free segment before any deviation is
  /// computed; when some were found, the plain joint fit of the untouched samples is kept alongside
  /// (AxisAnalysis::coefficients_with_spikes). Ignored for angle input.
  bool remove_spikes = true;
  SpikeOptions spikes;                              ///< the rule's settings (validated in prepare)
  /// Run the wavelet split on a second thread while the model check runs (they only read the samples); the result
  /// is the same either way.
  bool concurrent_stages = false;
  /// GMWM stage (gmwm.hpp) on the longest gap-free segment, in finish(): wavelet variance, model selection and the
  /// closed-loop comparison with the IEEE joint fit (AxisAnalysis::gmwm; analyze_bag writes noise_model.yaml from it).
  bool gmwm = false;
  GmwmOptions gmwm_options;
};

struct AxisAnalysis {
  std::string axis;                 ///< "x", "y", "z" (or a CSV column name)
  int64_t samples = 0;              ///< rate samples used (sum over segments); angle input: its intervals
  int segments = 0;                 ///< gap-free segments
  double rate_hz = 0;
  double duration_s = 0;            ///< samples / rate (time actually covered, gaps excluded)
  double mean = 0;                  ///< mean of the rate samples (bias), SI; for angle input, of the rates from it
  DeviationCurve oadev;             ///< the curve the model is fitted to
  std::vector<DeviationCurve> curves;  ///< requested deviations, in the order asked
  FitResult fit;                    ///< joint_fit: IEEE 952 fit of oadev
  bool has_split = false;
  WaveletSplitResult split;         ///< wavelet_split (on the longest gap-free segment)
  bool has_check = false;
  ModelCheck check;                 ///< model check of the joint fit (on the longest gap-free segment)
  Method method = Method::JointFit; ///< method chosen for `coefficients` (answer.hpp)
  std::string method_reason;        ///< why
  /// The answer: the chosen method's coefficients; for joint_fit with effects added by the model check, the base
  /// coefficients of the joint refit.
  std::array<Coefficient, kNumTerms> coefficients;
  FitError final_error;             ///< rms_log10 / chi2_dof of the model behind `coefficients` (effects included)
  std::vector<double> final_model_var;  ///< that model's AVAR at oadev's points
  std::vector<std::string> notes;   ///< human notes (segment used, stages skipped and why)
  /// Those of `notes` about the model check (the segment it used, why it failed or was skipped), for its readers.
  std::vector<std::string> check_notes;
  /// Only the longest static stretch of a record that moved was analysed (set by the pipeline; the verdict says so).
  bool static_stretch = false;
  /// Spike removal (rate input with remove_spikes): what was found, summed over segments (indices into the
  /// concatenated segments). Every deviation and coefficient above is of the samples with the spikes replaced.
  bool spikes_checked = false;
  SpikeReport spikes;
  /// When spikes were found (spikes.count > 0): the plain joint fit (oadev + fitWithModelEdf, no wavelet split or
  /// model check) of the untouched samples, for comparison with `fit`.
  bool has_with_spikes = false;
  std::array<Coefficient, kNumTerms> coefficients_with_spikes;
  FitError error_with_spikes;       ///< rms_log10 / chi2_dof of that fit
  /// Rate input (and angle input, of its rates): is the output on a lattice (pulse counter, ADC LSB), and an undithered counter's sawtooth?
  /// (quantized_output.hpp; on the longest gap-free segment, as read: before spike removal)
  QuantizedOutput quantized;
  QualityVerdict quality;           ///< verdict on `coefficients` (quality.hpp), set by finish()
  bool has_gmwm = false;            ///< AnalysisOptions::gmwm
  GmwmAxis gmwm;
  /// A pulse counter without a sawtooth (auto): the pulse-time reconstruction (pulse_times.hpp, rate vector freed),
  /// its oadev from tau_min_s up and the IEEE fit of it. Chosen ("pulse_times") when the other methods fit badly.
  bool has_pulse_times = false;
  PulseTimes pulse_times;
  DeviationCurve pulse_oadev;
  FitResult pulse_fit;
};

/// The IEEE fit behind an analysed axis's B, K and R: for the wavelet split the joint fit, or its fit of the denoised
/// part where the joint fit is a gross misfit (WaveletSplitResult::longer_tau_from_input); pulse_times' fit; the model
/// check's joint refit when it added effects; else the joint fit.
const FitResult& answerFit(const AxisAnalysis& a);
/// Correlation magnitude from which two of B, K and R count as trading (FitResult::correlation; tradeNote).
constexpr double kTradeCorrelation = 0.9;
/// A note naming the pairs of B, K and R whose free estimates in `f` correlate by at least kTradeCorrelation where
/// one of the pair in `c` (the answer) is not supported and one has a value; empty when there is none.
std::string tradeNote(const FitResult& f, const std::array<Coefficient, kNumTerms>& c);

/// Rate samples [rad/s] of one gap-free segment of angle samples, in place: an accumulated angle theta (n points)
/// gives the n - 1 rates (theta[k+1] - theta[k]) / tau0; increments delta (n) give the n rates delta[k] / tau0.
/// The overlapping Allan variance (any deviation) of those rates is that of the angle (second differences of the
/// same phase points). A segment of fewer than 2 accumulated points becomes empty.
void angleToRate(std::vector<double>* segment, double tau0, bool increments);

/// Validates options (throws std::invalid_argument naming the problem) and analyses one axis.
/// Throws std::invalid_argument when the data is too short for any Allan point.
/// `temperature`, when given, holds one temperature per sample, split like `segments` (degC).
AxisAnalysis analyzeAxis(const std::string& axis, const std::vector<std::vector<double>>& segments, double tau0,
                         const AnalysisOptions& options,
                         const std::vector<std::vector<double>>* temperature = nullptr);

/// analyzeAxis in stages, for callers that schedule the stages of several axes on their own threads (analyze_bag):
/// prepare() validates and fits oadev; then split() (wavelet split) and check() (model check) may run concurrently
/// with each other and with other axes' stages (each reads the samples and writes only its own part); finish()
/// returns what analyzeAxis returns and frees the samples. Errors are thrown as analyzeAxis throws them.
class AxisStages {
 public:
  AxisStages(std::string axis, std::vector<std::vector<double>> segments, double tau0, const AnalysisOptions& options,
             const std::vector<std::vector<double>>* temperature = nullptr);
  void prepare();
  void split();
  void check();
  AxisAnalysis finish();
  /// The analysis so far (after prepare: mean, oadev, fit).
  const AxisAnalysis& partial() const { return a_; }

 private:
  void removeSegmentSpikes();
  void pulseTimes();
  // finish()'s steps, in order.
  void runGmwm();
  void noteStages();
  MethodChoice chooseAllanMethod() const;
  void answerWithSplit();
  void answerWithFit(const FitResult& f);
  void considerPulseTimes();
  void answerWithPulseTimes();
  void judge();
  std::string axis_;
  std::vector<std::vector<double>> segments_;
  double tau0_;
  AnalysisOptions options_;
  const std::vector<std::vector<double>>* temperature_;
  AxisAnalysis a_;
  DeviationCurve raw_oadev_;
  size_t longest_ = 0;
  bool angle_points_ = false;  ///< the input was accumulated angle: each segment had one point more than its rates
  bool prepared_ = false;
  std::string split_note_, check_note_;
};

/// Gyro noise gets redder with tau (quantization, then ARW, flicker, rate random walk): a noise type identified as
/// bluer than at a shorter tau is a misidentification of the lag-1 ACF method on few points (it can turn a random-walk
/// point into white PM, whose EDF is a thousand times larger). Replaces each alpha by the running minimum over shorter
/// taus and recomputes EDF and intervals. allan.hpp itself keeps Stable32's per-point identification.
void enforceRedderWithTau(DeviationCurve* curve, double confidence);

/// Conventional units for humans: factor from SI and label of each IEEE term
/// (arcsec, deg/sqrt(h), deg/h, deg/h/sqrt(h), deg/h^2).
double conventionalFactor(int term);
const char* conventionalUnit(int term);

}  // namespace gyro_allan
