// Quality verdict of an axis's answer: an adequacy test of the reported model's curve against the Allan curve (chi2
// at the model's own covariance, the worst ADEV ratio at tight points) and warning signs; the reason names the numbers.
#include "gyro_allan/quality.hpp"

#include <cmath>
#include <limits>
#include <cstdio>
#include <vector>

#include "gyro_allan/analysis.hpp"

namespace gyro_allan {


const char* qualityName(Quality q) {
  switch (q) {
    case Quality::Good: return "good";
    case Quality::Doubtful: return "doubtful";
    case Quality::Bad: return "bad";
  }
  return "bad";
}

namespace {

std::string fmt(const char* f, double a, double b = 0, double c = 0, double d = 0) {
  char buf[200];
  std::snprintf(buf, sizeof buf, f, a, b, c, d);
  return buf;
}

std::string join(const std::vector<std::string>& parts) {
  std::string s;
  for (const auto& p : parts) s += (s.empty() ? "" : "; ") + p;
  return s;
}

/// The shared rule. `ok`/`failure`: whether the answering method succeeded and why not; `e`: the error figures of
/// the curve of the reported coefficients.
QualityVerdict judge(bool ok, const std::string& failure, const std::array<Coefficient, kNumTerms>& terms,
                     const FitError& e, const QualityContext& ctx) {
  using namespace quality_limits;
  QualityVerdict v;
  if (!ok) {
    v.quality = Quality::Bad;
    v.reason = "the fit failed" + (failure.empty() ? std::string() : ": " + failure);
    return v;
  }
  std::vector<std::string> bad, doubtful;
  bool any_supported = false;
  for (const auto& c : terms) any_supported = any_supported || c.supported;
  if (!any_supported) bad.push_back("no noise term is supported by the data (every coefficient is only a bound)");
  if (!std::isfinite(e.chi2_dof) || !std::isfinite(e.worst_adev_ratio))
    bad.push_back("the fit error is not finite (chi2/dof " + fmt("%g", e.chi2_dof) + ", worst ADEV ratio " +
                  fmt("%g", e.worst_adev_ratio) + ")");
  else {
    const std::string off = fmt("the model's ADEV is off by x%.2f at a point whose estimate is tight (>= %.0f "
                                "degrees of freedom)", e.worst_adev_ratio, kTightEdf);
    if (e.worst_adev_ratio > kBadAdevRatio) bad.push_back(off + fmt(" > x%.2f", kBadAdevRatio));
    else if (e.worst_adev_ratio > kDoubtfulAdevRatio) doubtful.push_back(off + fmt(" > x%.2f", kDoubtfulAdevRatio));
    if (e.chi2_dof > kBadChi2Dof) bad.push_back(fmt("chi2/dof %.3g > %.3g", e.chi2_dof, kBadChi2Dof));
    else if (std::isfinite(e.chi2_p) ? e.chi2_p < kDoubtfulP : e.chi2_dof > kDoubtfulChi2Dof)
      doubtful.push_back(std::isfinite(e.chi2_p)
                             ? fmt("the data reject the model: chi2/dof %.3g, p = %.2g < %.2g", e.chi2_dof, e.chi2_p,
                                   kDoubtfulP)
                             : fmt("chi2/dof %.3g > %.3g", e.chi2_dof, kDoubtfulChi2Dof));
  }
  if (!bad.empty()) {
    v.quality = Quality::Bad;
    v.reason = join(bad);
    return v;
  }
  if (e.n_rms <= 0) doubtful.push_back("no tau point has enough degrees of freedom for rms_log10");
  if (ctx.static_stretch) doubtful.push_back("the sensor moved: only the longest static stretch was analysed");
  if (ctx.samples > 0 && ctx.spikes > 0) {
    const double f = static_cast<double>(ctx.spikes) / static_cast<double>(ctx.samples);
    if (f > kDoubtfulSpikeFraction)
      doubtful.push_back(fmt("%.0f spikes replaced (%.2f %% of the samples > %.2f %%)", static_cast<double>(ctx.spikes),
                             100 * f, 100 * kDoubtfulSpikeFraction));
  }
  if (ctx.compare_methods) {
    // Value when supported, else the 1-sigma bound. Both bounds: nothing to compare; one bound: only a supported
    // value above kDoubtfulMethodRatio x the other's bound contradicts it.
    const Coefficient &j = ctx.joint_fit_n, &s = ctx.wavelet_split_n;
    const double xj = j.supported ? j.value : j.sigma, xs = s.supported ? s.value : s.sigma;
    bool differ = false;
    if (j.supported && s.supported) differ = xj > kDoubtfulMethodRatio * xs || xs > kDoubtfulMethodRatio * xj;
    else if (j.supported && !s.supported) differ = xj > kDoubtfulMethodRatio * xs;
    else if (!j.supported && s.supported) differ = xs > kDoubtfulMethodRatio * xj;
    if (differ && xj > 0 && xs > 0) {
      const double r = xj > xs ? xj / xs : xs / xj;
      doubtful.push_back(fmt("joint_fit and wavelet_split disagree on N by x%.2f (%.3g vs %.3g rad/sqrt(s))", r, xj, xs) +
                         (j.supported && s.supported ? "" : ", one of them a bound") +
                         fmt(" > x%.3g", kDoubtfulMethodRatio));
    }
  }
  if (!doubtful.empty()) {
    v.quality = Quality::Doubtful;
    v.reason = join(doubtful) + ctx.remark;
    return v;
  }
  v.quality = Quality::Good;
  v.reason = (std::isfinite(e.chi2_p) ? fmt("the data accept the model (chi2/dof %.3g, p = %.2g)", e.chi2_dof, e.chi2_p)
                                       : fmt("chi2/dof %.3g <= %.3g", e.chi2_dof, kDoubtfulChi2Dof)) +
             fmt(", its ADEV within x%.2f of every tight point", e.worst_adev_ratio) + ctx.remark;
  return v;
}

}  // namespace

QualityVerdict assessQuality(const AxisAnalysis& a) {
  QualityContext ctx;
  ctx.samples = a.samples;
  ctx.spikes = a.spikes_checked ? a.spikes.count : 0;
  ctx.static_stretch = a.static_stretch;
  const bool split_ok = a.has_split && a.split.ok;
  // The joint fit's N held against the split's answer is that of a joint fit that describes the curve: where the
  // plain joint fit misfits grossly (an undithered sawtooth, the reason auto chose the split) its N is ~10-20x the
  // truth and no evidence against the split's. So with the split as the answer: the model check's fit with its
  // effects (the sawtooth's lines) when it added some and fits, else the plain fit when it fits, else nothing to
  // compare (said in the reason). On the coverage study's sawtooth classes at 2 h and 2-5 deg/h the check adds no
  // effects or its fit misfits too, so most sawtooth axes are not cross-checked; at 10 deg/h and 10-20 min the
  // check's fit is used.
  using quality_limits::notBad;
  if (a.fit.ok && split_ok && a.method != Method::PulseTimes) {  // pulse_times: neither method's N is the answer
    const Coefficient* joint_n = &a.fit.terms[kAngleRandomWalk];
    if (a.method == Method::WaveletSplit) {
      if (a.has_check && !a.check.effects.empty() && a.check.fit_after.ok &&
          notBad(a.check.after.rms_log10, a.check.after.chi2_dof))
        joint_n = &a.check.fit_after.terms[kAngleRandomWalk];
      else if (!notBad(a.fit.rms_log10, a.fit.chi2_dof))
        joint_n = nullptr;
    }
    if (joint_n) {
      ctx.compare_methods = true;
      ctx.joint_fit_n = *joint_n;
      ctx.wavelet_split_n = a.split.terms[kAngleRandomWalk];
    } else {
      ctx.remark = fmt("; N not cross-checked: the joint fit misfits the curve (rms_log10 %.3g, chi2/dof %.3g)",
                       a.fit.rms_log10, a.fit.chi2_dof);
    }
  }
  bool ok = a.fit.ok;
  std::string failure = a.fit.message;
  if (a.method == Method::WaveletSplit) {
    ok = split_ok;
    failure = a.has_split ? a.split.message : "wavelet split not run";
  } else if (a.method == Method::PulseTimes) {
    ok = a.pulse_times.ok && a.pulse_fit.ok;
    failure = a.pulse_times.ok ? a.pulse_fit.message : a.pulse_times.message;
  }
  return judge(ok, failure, a.coefficients, a.final_error, ctx);
}

bool unboundIntervalsIfBad(const QualityVerdict& verdict, std::array<Coefficient, kNumTerms>* coefficients) {
  if (verdict.quality != Quality::Bad) return false;
  for (auto& c : *coefficients) {
    c.lo68 = c.lo95 = 0.0;
    c.hi68 = c.hi95 = std::numeric_limits<double>::infinity();
  }
  return true;
}

QualityVerdict assessQuality(const FitResult& fit, const QualityContext& context) {
  return judge(fit.ok, fit.message, fit.terms, fitErrorOf(fit), context);
}

}  // namespace gyro_allan
