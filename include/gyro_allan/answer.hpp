// The answer of an axis analysis as data: the methods as a type and the ordered rules that choose one.
#pragma once

#include <string>

#include "gyro_allan/noise_model.hpp"

namespace gyro_allan {

/// Method whose coefficients are an axis's answer. Auto is only a request (the rules below choose); QuickFit is the
/// quick view's fit (quick_view.hpp), never chosen by the rules.
enum class Method { Auto, JointFit, WaveletSplit, PulseTimes, QuickFit };

/// The method's name on the command line, in report.yaml/json and in messages: "auto", "joint_fit",
/// "wavelet_split", "pulse_times", "quick_fit".
const char* methodName(Method m);
/// A requestable method from its name (auto, joint_fit, wavelet_split); false for anything else.
bool parseRequestedMethod(const std::string& name, Method* m);

struct MethodChoice {
  Method method = Method::JointFit;
  std::string reason;  ///< why, for humans (report.yaml method_reason)
};

/// What the rules read (AxisStages::finish fills it from the stages' results).
struct AnswerEvidence {
  Method requested = Method::Auto;
  bool split_ok = false;            ///< the wavelet split ran and succeeded
  double quantization_share = 0;    ///< of the Allan variance at the shortest tau, by the joint fit's Q
  bool sawtooth = false;            ///< an undithered pulse count (quantized_output.hpp)
  double sawtooth_hz = 0;
  const FitResult* joint = nullptr;     ///< the joint fit of oadev
  const FitResult* denoised = nullptr;  ///< the split's fit of the denoised signal (null: none)
};

/// The wavelet split answers (auto) when quantization is at least this share of the Allan variance at the shortest tau.
constexpr double kSplitQuantizationShare = 0.5;

/// The requested method, or for auto the first rule of an ordered table that applies: the split grossly worse than
/// the joint fit where quantization dominates -> joint_fit; quantization dominating the shortest tau -> wavelet_split;
/// a sawtooth pulse count -> wavelet_split; a joint fit the data reject grossly while the split's fits ->
/// wavelet_split; otherwise joint_fit.
MethodChoice chooseMethod(const AnswerEvidence& e);

/// The pulse-time reconstruction's N with its interval widened by the interpolation's systematic error
/// (kPulseTimesSystematic in quadrature).
Coefficient pulseTimesN(const Coefficient& n);

/// The last rule (auto, a pulse counter without a sawtooth): pulse_times replaces `chosen` when the chosen method fits
/// badly (`chosen_error`) and the pulse-time fit does not, with N (pulseTimesN) within kPulseTimesMaxRelSigma.
/// Returns true and sets *choice (method and reason) when it applies.
bool pulseTimesAnswers(const MethodChoice& chosen, const FitError& chosen_error, const FitResult& pulse_fit,
                       MethodChoice* choice);
/// pulse_times' N is used only when its relative sigma (after pulseTimesN) is at most this.
constexpr double kPulseTimesMaxRelSigma = 0.10;

}  // namespace gyro_allan
