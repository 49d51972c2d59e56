// Quality verdict of one axis's answer (good / doubtful / bad, with a one-sentence reason), shared by every output.
#pragma once

#include <array>
#include <cstdint>
#include <string>

#include "gyro_allan/noise_model.hpp"

namespace gyro_allan {

struct AxisAnalysis;  // analysis.hpp (which holds a QualityVerdict per axis)

enum class Quality { Good, Doubtful, Bad };
/// "good", "doubtful", "bad".
const char* qualityName(Quality q);

struct QualityVerdict {
  Quality quality = Quality::Good;
  std::string reason;  ///< one short sentence naming the numbers that decided
};

/// The thresholds of the verdict, all in one place. The verdict judges the curve of the reported coefficients:
/// chi2 of its AVAR residual at the model's own covariance (GLS fits give its p-value), and worst_adev_ratio, the
/// largest factor between the model's and the measured ADEV at points with >= kTightEdf degrees of freedom (an ADEV
/// estimate there has a relative sd <= 16 %, so x1.5 is > 3 sd). Measured false-alarm rate and power: docs/quality.md.
/// rms_log10 (RMS of log10(measured / model ADEV)) is descriptive; the method switches use notBad().
namespace quality_limits {
constexpr double kBadAdevRatio = 2.0;            ///< bad above: the model misses a tight point by more than x2
constexpr double kDoubtfulAdevRatio = 1.5;       ///< doubtful above: ... by more than x1.5
constexpr double kBadChi2Dof = 50.0;             ///< bad above
constexpr double kDoubtfulP = 0.01;              ///< doubtful below: the chi2 test rejects the model (GLS fits)
constexpr double kDoubtfulChi2Dof = 5.0;         ///< doubtful above, for fits without a p-value (EDF-weighted chi2)
constexpr double kBadRmsLog10 = 0.15;            ///< notBad(): a method's fit is usable (ADEV off by < 41 % typically)
constexpr double kDoubtfulSpikeFraction = 1e-3;  ///< doubtful when more than this fraction of samples were spikes
constexpr double kDoubtfulMethodRatio = 2.0;     ///< doubtful when joint_fit's and wavelet_split's N differ by more

/// A fit error within the bad limits (rms_log10 <= kBadRmsLog10 and chi2_dof <= kBadChi2Dof; false when either is
/// NaN): the model describes the curve well enough for its numbers to count.
inline bool notBad(double rms_log10, double chi2_dof) { return rms_log10 <= kBadRmsLog10 && chi2_dof <= kBadChi2Dof; }
}  // namespace quality_limits

/// What assessQuality(FitResult) cannot see in the fit itself (all optional).
struct QualityContext {
  int64_t samples = 0;          ///< samples analysed (for the spike fraction)
  int64_t spikes = 0;           ///< samples replaced as spikes
  bool static_stretch = false;  ///< the record was cut to its static stretch (the sensor moved)
  /// Both methods ran and succeeded: N of joint_fit and of wavelet_split (value, or its bound when unsupported).
  bool compare_methods = false;
  Coefficient joint_fit_n, wavelet_split_n;
  /// Appended to a good or doubtful verdict's reason (e.g. that the split's N had no joint fit to be checked against).
  std::string remark;
};

/// The verdict of one analysed axis: from final_error (the error of the chosen method's model), the coefficients,
/// whether the chosen method succeeded, the spikes, AxisAnalysis::static_stretch and joint_fit vs wavelet_split N.
/// bad: the fit failed, no coefficient is supported, worst_adev_ratio > kBadAdevRatio or chi2_dof > kBadChi2Dof (or
/// either not finite); doubtful: worst_adev_ratio > kDoubtfulAdevRatio, chi2_p < kDoubtfulP (chi2_dof >
/// kDoubtfulChi2Dof without a p-value), the record was cut to a static stretch, spikes above kDoubtfulSpikeFraction of
/// the samples, or the two methods' N differ by more than kDoubtfulMethodRatio; good otherwise.
QualityVerdict assessQuality(const AxisAnalysis& a);

/// A bad verdict means the model does not describe the record, so no interval computed under it can be trusted: the
/// 68 % and 95 % intervals of `coefficients` become [0, inf) (values are kept, flagged by the verdict). Returns
/// whether it widened them.
bool unboundIntervalsIfBad(const QualityVerdict& verdict, std::array<Coefficient, kNumTerms>* coefficients);

/// The same rule for a bare fit (the nodelet's per-hop answer: fit.terms, fit.rms_log10, fit.chi2_dof, fit.ok).
QualityVerdict assessQuality(const FitResult& fit, const QualityContext& context = {});

}  // namespace gyro_allan
