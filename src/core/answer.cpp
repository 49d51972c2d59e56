// The ordered rules that choose an axis's method, and the method names.
#include "gyro_allan/answer.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "gyro_allan/quality.hpp"

namespace gyro_allan {
namespace {

// pulse_times (slow undithered counters): the linear interpolation between lattice crossings smooths the angle's
// random walk, so its N comes out low by ~2 % in 1-2 h records and ~9 % in 10 min ones (median; coverage_study seeds
// 6001-6020, classes rlg_saw1/rlg_saw2). N's sigma gets this relative systematic allowance in quadrature, and the
// method is used only when the result is that precise (kPulseTimesMaxRelSigma).
constexpr double kPulseTimesSystematic = 0.03;

std::string percent(double share) { return std::to_string(static_cast<int>(100 * share)); }
std::string shareText(const AnswerEvidence& e) {
  return "quantization is " + percent(e.quantization_share) + " % of the Allan variance at the shortest tau";
}

// Evidence: each method's generalized chi-squared on the curve it fitted (joint: the Allan variance; split: the
// denoised signal's). Neither is returned when its fit is grossly worse than the other's — e.g. an undithered pulse
// counter at constant rate, whose sawtooth quantization the Allan model cannot describe (chi2/dof ~1e3) while the
// split removes it and fits the rest at chi2/dof ~1.
bool grosslyWorse(const FitResult& a, const FitResult& b) {
  return grossMisfit(a) && !grossMisfit(b) && b.chi2_dof * 10 < a.chi2_dof;
}

// Quantization-limited gyros (RLG/FOG pulse outputs): where 3Q^2/tau^2 is most of the AVAR at the shortest tau the
// Allan fit trades Q against N, and the wavelet split separates them by scale (docs/wavelet_split.md).
bool quantizationDominates(const AnswerEvidence& e) {
  return e.split_ok && e.quantization_share >= kSplitQuantizationShare;
}

struct Rule {
  Method method;
  bool (*applies)(const AnswerEvidence&);
  std::string (*reason)(const AnswerEvidence&);
};

std::string fmt(const char* f, double a, double b, double c = 0, double d = 0) {
  char buf[320];
  std::snprintf(buf, sizeof buf, f, a, b, c, d);
  return buf;
}

// Auto, in order; the first that applies answers.
const Rule kRules[] = {
    {Method::JointFit,
     [](const AnswerEvidence& e) { return quantizationDominates(e) && e.denoised && grosslyWorse(*e.denoised, *e.joint); },
     [](const AnswerEvidence& e) {
       return fmt("quantization dominates the shortest tau, but the split's fit is grossly worse (chi2/dof %.3g "
                  "against the joint fit's %.3g)",
                  e.denoised->chi2_dof, e.joint->chi2_dof);
     }},
    {Method::WaveletSplit, quantizationDominates, shareText},
    {Method::WaveletSplit, [](const AnswerEvidence& e) { return e.split_ok && e.sawtooth; },
     [](const AnswerEvidence& e) {
       return "undithered quantization: the pulse count repeats at " + std::to_string(e.sawtooth_hz) +
              " Hz (a sawtooth the Allan model's white quantization term cannot describe)";
     }},
    {Method::WaveletSplit, [](const AnswerEvidence& e) { return e.denoised && grosslyWorse(*e.joint, *e.denoised); },
     [](const AnswerEvidence& e) {
       return fmt("the Allan model cannot describe the curve (joint fit chi2/dof %.3g, p %.2g) while the split's "
                  "fit of the denoised signal has chi2/dof %.3g",
                  e.joint->chi2_dof, e.joint->chi2_p, e.denoised->chi2_dof);
     }},
    {Method::JointFit, [](const AnswerEvidence&) { return true; },
     [](const AnswerEvidence& e) {
       return e.quantization_share < kSplitQuantizationShare
                  ? shareText(e) + " (the wavelet split answers from " + percent(kSplitQuantizationShare) + " %)"
                  : std::string("wavelet split not available");
     }},
};

}  // namespace

const char* methodName(Method m) {
  switch (m) {
    case Method::Auto: return "auto";
    case Method::JointFit: return "joint_fit";
    case Method::WaveletSplit: return "wavelet_split";
    case Method::PulseTimes: return "pulse_times";
    case Method::QuickFit: return "quick_fit";
  }
  return "";
}

bool parseRequestedMethod(const std::string& name, Method* m) {
  for (Method c : {Method::Auto, Method::JointFit, Method::WaveletSplit})
    if (name == methodName(c)) {
      *m = c;
      return true;
    }
  return false;
}

MethodChoice chooseMethod(const AnswerEvidence& e) {
  if (e.requested != Method::Auto) return {e.requested, "requested"};
  for (const Rule& r : kRules)
    if (r.applies(e)) return {r.method, r.reason(e)};
  return {Method::JointFit, ""};  // not reached: the last rule always applies
}

Coefficient pulseTimesN(const Coefficient& n) {
  Coefficient c = n;
  c.sigma = std::hypot(c.sigma, kPulseTimesSystematic * c.value);
  c.lo68 = std::max(0.0, c.value - c.sigma), c.hi68 = c.value + c.sigma;
  c.lo95 = std::max(0.0, c.value - kZ95 * c.sigma), c.hi95 = c.value + kZ95 * c.sigma;
  return c;
}

bool pulseTimesAnswers(const MethodChoice& chosen, const FitError& chosen_error, const FitResult& pulse_fit,
                       MethodChoice* choice) {
  const Coefficient n = pulseTimesN(pulse_fit.terms[kAngleRandomWalk]);
  using quality_limits::notBad;
  if (!pulse_fit.ok || !n.supported || !(n.sigma <= kPulseTimesMaxRelSigma * n.value) ||
      notBad(chosen_error.rms_log10, chosen_error.chi2_dof) || !notBad(pulse_fit.rms_log10, pulse_fit.chi2_dof))
    return false;
  char buf[320];
  std::snprintf(buf, sizeof buf,
                "a pulse count without a sawtooth; %s fits badly (rms_log10 %.3g, chi2/dof %.3g) while the angle "
                "reconstructed at the lattice crossings fits (rms_log10 %.3g, chi2/dof %.3g)",
                methodName(chosen.method), chosen_error.rms_log10, chosen_error.chi2_dof, pulse_fit.rms_log10,
                pulse_fit.chi2_dof);
  *choice = {Method::PulseTimes, buf};
  return true;
}

}  // namespace gyro_allan
