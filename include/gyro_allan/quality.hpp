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

/// The thresholds of the verdict, all in one place. Initial values (to be recalibrated on simulated and real
/// records): rms_log10 is the RMS of log10(measured / model ADEV), so 0.15 is a model off by a factor 10^0.15 = 1.41
/// (41 %) in ADEV at a typical point and 0.05 one off by 12 %; chi2_dof is the EDF-weighted chi-squared per degree of
/// freedom of the AVAR residual (1 for a model that fits within the points' own scatter).
namespace quality_limits {
constexpr double kBadRmsLog10 = 0.15;            ///< bad above: gross misfit (ADEV off by > 41 % somewhere typical)
constexpr double kBadChi2Dof = 50.0;             ///< bad above
constexpr double kDoubtfulRmsLog10 = 0.05;       ///< doubtful above (ADEV off by > 12 %)
constexpr double kDoubtfulChi2Dof = 5.0;         ///< doubtful above
constexpr double kDoubtfulSpikeFraction = 1e-3;  ///< doubtful when more than this fraction of samples were spikes
constexpr double kDoubtfulMethodRatio = 2.0;     ///< doubtful when joint_fit's and wavelet_split's N differ by more

/// A fit error within the bad limits (rms_log10 <= kBadRmsLog10 and chi2_dof <= kBadChi2Dof; false when either is
/// NaN): the model describes the curve well enough for its numbers to count.
inline bool notBad(double rms_log10, double chi2_dof) { return rms_log10 <= kBadRmsLog10 && chi2_dof <= kBadChi2Dof; }
}  // namespace quality_limits

/// The note analyze_bag adds to each axis (AxisAnalysis::notes) when only the longest static stretch of a record that
/// moved was analysed; assessQuality looks for it.
extern const char* const kStaticStretchNote;

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
/// whether the chosen method succeeded, the spikes, the notes (static stretch) and joint_fit vs wavelet_split N.
/// bad: the fit failed, no coefficient is supported, rms_log10 > kBadRmsLog10 or chi2_dof > kBadChi2Dof (or either
/// not finite); doubtful: rms_log10 > kDoubtfulRmsLog10, chi2_dof > kDoubtfulChi2Dof, the record was cut to a static
/// stretch, spikes above kDoubtfulSpikeFraction of the samples, or the two methods' N differ by more than
/// kDoubtfulMethodRatio; good otherwise.
QualityVerdict assessQuality(const AxisAnalysis& a);

/// A bad verdict means the model does not describe the record, so no interval computed under it can be trusted: the
/// 68 % and 95 % intervals of `coefficients` become [0, inf) (values are kept, flagged by the verdict). Returns
/// whether it widened them.
bool unboundIntervalsIfBad(const QualityVerdict& verdict, std::array<Coefficient, kNumTerms>* coefficients);

/// The same rule for a bare fit (the nodelet's per-hop answer: fit.terms, fit.rms_log10, fit.chi2_dof, fit.ok).
QualityVerdict assessQuality(const FitResult& fit, const QualityContext& context = {});

}  // namespace gyro_allan
