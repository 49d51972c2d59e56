// MATLAB-style wavelet denoising (wden, thselect, wthresh, wnoisest) returning both the denoised and removed parts.
#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>

#include "gyro_allan/wavelet.hpp"
#include "gyro_allan/stats.hpp"

namespace gyro_allan {

ThresholdRule parseThresholdRule(const std::string& name) {
  if (name == "sqtwolog") return ThresholdRule::Sqtwolog;
  if (name == "rigrsure") return ThresholdRule::Rigrsure;
  if (name == "heursure") return ThresholdRule::Heursure;
  if (name == "minimaxi") return ThresholdRule::Minimaxi;
  throw std::invalid_argument("unknown threshold rule '" + name + "' (sqtwolog, rigrsure, heursure, minimaxi)");
}

ThresholdMode parseThresholdMode(const std::string& name) {
  if (name == "soft" || name == "s") return ThresholdMode::Soft;
  if (name == "hard" || name == "h") return ThresholdMode::Hard;
  throw std::invalid_argument("unknown threshold mode '" + name + "' (soft, hard)");
}

NoiseScaling parseNoiseScaling(const std::string& name) {
  if (name == "one") return NoiseScaling::One;
  if (name == "sln") return NoiseScaling::Sln;
  if (name == "mln") return NoiseScaling::Mln;
  if (name == "sln_rms") return NoiseScaling::SlnRms;
  throw std::invalid_argument("unknown noise scaling '" + name + "' (one, sln, mln, sln_rms)");
}

std::string thresholdRuleName(ThresholdRule rule) {
  switch (rule) {
    case ThresholdRule::Sqtwolog: return "sqtwolog";
    case ThresholdRule::Rigrsure: return "rigrsure";
    case ThresholdRule::Heursure: return "heursure";
    case ThresholdRule::Minimaxi: return "minimaxi";
  }
  return "?";
}

std::string thresholdModeName(ThresholdMode mode) { return mode == ThresholdMode::Soft ? "soft" : "hard"; }

std::string noiseScalingName(NoiseScaling scaling) {
  switch (scaling) {
    case NoiseScaling::One: return "one";
    case NoiseScaling::Sln: return "sln";
    case NoiseScaling::Mln: return "mln";
    case NoiseScaling::SlnRms: return "sln_rms";
  }
  return "?";
}

namespace {

double rigrsure(const std::vector<double>& x) {
  const size_t n = x.size();
  std::vector<double> sx2(n);
  for (size_t i = 0; i < n; ++i) sx2[i] = x[i] * x[i];
  std::sort(sx2.begin(), sx2.end());
  // risk_k = (n - 2k + sum_{i<=k} sx2_i + (n - k) sx2_k) / n, k = 1..n; threshold sqrt(sx2 at the minimum).
  double cum = 0, best_risk = std::numeric_limits<double>::infinity();
  size_t best = 0;
  const double dn = static_cast<double>(n);
  for (size_t i = 0; i < n; ++i) {
    cum += sx2[i];
    const double k = static_cast<double>(i + 1);
    const double risk = (dn - 2.0 * k + cum + (dn - k) * sx2[i]) / dn;
    if (risk < best_risk) {
      best_risk = risk;
      best = i;
    }
  }
  return std::sqrt(sx2[best]);
}

}  // namespace

double thselect(const std::vector<double>& x, ThresholdRule rule) {
  if (x.empty()) throw std::invalid_argument("thselect: empty coefficient vector");
  const double n = static_cast<double>(x.size());
  switch (rule) {
    case ThresholdRule::Sqtwolog:
      return std::sqrt(2.0 * std::log(n));
    case ThresholdRule::Minimaxi:
      return x.size() <= 32 ? 0.0 : 0.3936 + 0.1829 * std::log2(n);
    case ThresholdRule::Rigrsure:
      return rigrsure(x);
    case ThresholdRule::Heursure: {
      const double hthr = std::sqrt(2.0 * std::log(n));
      double e = 0;
      for (double v : x) e += v * v;
      const double eta = (e - n) / n;
      const double crit = std::pow(std::log2(n), 1.5) / std::sqrt(n);
      if (eta < crit) return hthr;
      return std::min(rigrsure(x), hthr);
    }
  }
  return 0.0;
}

double wthresh(double x, ThresholdMode mode, double t) {
  if (mode == ThresholdMode::Hard) return std::fabs(x) > t ? x : 0.0;
  const double m = std::fabs(x) - t;
  return m > 0 ? std::copysign(m, x) : 0.0;
}

double wnoisest(const std::vector<double>& d) {
  if (d.empty()) throw std::invalid_argument("wnoisest: empty coefficient vector");
  std::vector<double> a(d.size());
  for (size_t i = 0; i < d.size(); ++i) a[i] = std::fabs(d[i]);
  return medianInPlace(a) / 0.6745;  // the reference tools' rounded kMadPerSigma, so thresholds match theirs
}

WdenResult wden(const std::vector<double>& x, const WdenOptions& options) {
  if (x.size() < 2) throw std::invalid_argument("wden: need at least 2 samples");
  const Wavelet w(options.wavelet);
  const int64_t n = static_cast<int64_t>(x.size());
  int level = options.level;
  if (level <= 0) level = dwt_max_level(n, w.dec_len());
  if (level < 1) throw std::invalid_argument("wden: signal too short for the wavelet (dwt_max_level is 0)");
  auto coeffs = wavedec(x, w, options.extension, level);  // {cA_L, cD_L, ..., cD_1}

  WdenResult r;
  r.level = level;
  r.thresholds.assign(level, 0.0);
  r.noise_sigma.assign(level, 1.0);
  r.kept_fraction.assign(level, 0.0);
  auto detail = [&](int k) -> std::vector<double>& { return coeffs[level - k + 1]; };  // k = 1..level

  if (options.scaling == NoiseScaling::Sln) {
    const double s = wnoisest(detail(1));
    for (int k = 1; k <= level; ++k) r.noise_sigma[k - 1] = s;
  } else if (options.scaling == NoiseScaling::SlnRms) {
    const auto& d1 = detail(1);
    long double ss = 0;
    for (double v : d1) ss += static_cast<long double>(v) * v;
    const double s = static_cast<double>(std::sqrt(ss / static_cast<long double>(d1.size())));
    for (int k = 1; k <= level; ++k) r.noise_sigma[k - 1] = s;
  } else if (options.scaling == NoiseScaling::Mln) {
    for (int k = 1; k <= level; ++k) r.noise_sigma[k - 1] = wnoisest(detail(k));
  }
  size_t total = 0;
  for (const auto& c : coeffs) total += c.size();

  std::vector<std::vector<double>> removed(coeffs.size());
  if (!options.removed_by_difference) removed[0].assign(coeffs[0].size(), 0.0);  // approximation kept whole
  for (int k = 1; k <= level; ++k) {
    std::vector<double>& d = detail(k);
    const double s = r.noise_sigma[k - 1];
    double thr = 0;
    if (options.rule == ThresholdRule::Sqtwolog || options.rule == ThresholdRule::Minimaxi) {
      const double nt = static_cast<double>(total);  // wden: thselect(c, rule) on all coefficients
      thr = options.rule == ThresholdRule::Sqtwolog ? std::sqrt(2.0 * std::log(nt))
                                                     : (total <= 32 ? 0.0 : 0.3936 + 0.1829 * std::log2(nt));
    } else {
      double maxc = 0;
      for (double v : d) maxc = std::max(maxc, v);
      if (s < std::sqrt(std::numeric_limits<double>::epsilon()) * maxc || s <= 0) {
        thr = 0;
      } else {
        std::vector<double> scaled(d.size());
        for (size_t i = 0; i < d.size(); ++i) scaled[i] = d[i] / s;
        thr = thselect(scaled, options.rule);
      }
    }
    thr *= s;
    r.thresholds[k - 1] = thr;
    auto& rem = removed[level - k + 1];
    if (!options.removed_by_difference) rem.resize(d.size());
    size_t kept = 0;
    for (size_t i = 0; i < d.size(); ++i) {
      const double t = wthresh(d[i], options.mode, thr);
      if (!options.removed_by_difference) rem[i] = d[i] - t;
      d[i] = t;
      if (t != 0.0) ++kept;
    }
    r.kept_fraction[k - 1] = d.empty() ? 0.0 : static_cast<double>(kept) / static_cast<double>(d.size());
  }
  r.denoised = waverec(coeffs, w, options.extension);
  std::vector<std::vector<double>>().swap(coeffs);  // freed before the second reconstruction (long records)
  r.denoised.resize(n);  // periodization of an odd signal reconstructs one extra sample
  if (options.removed_by_difference) {
    r.removed.resize(n);
    for (int64_t i = 0; i < n; ++i) r.removed[static_cast<size_t>(i)] = x[static_cast<size_t>(i)] - r.denoised[static_cast<size_t>(i)];
  } else {
    r.removed = waverec(removed, w, options.extension);
    r.removed.resize(n);
  }
  return r;
}

std::vector<double> removedAngle(const std::vector<double>& removed, double tau0) {
  if (!(tau0 > 0) || !std::isfinite(tau0)) throw std::invalid_argument("removedAngle: tau0 must be > 0");
  std::vector<double> angle(removed.size());
  long double acc = 0;
  for (size_t i = 0; i < removed.size(); ++i) {
    acc += removed[i];
    angle[i] = static_cast<double>(acc * tau0);
  }
  return angle;
}

AngleErrorStats angleErrorStats(const std::vector<double>& angle) { return angleErrorStats(angle.data(), angle.size()); }

AngleErrorStats angleErrorStats(const double* angle, size_t n) {
  if (n < 2) throw std::invalid_argument("angleErrorStats: need at least 2 samples");
  AngleErrorStats s;
  long double sum = 0, sum2 = 0;
  for (size_t i = 0; i < n; ++i) sum += angle[i];
  s.mean = static_cast<double>(sum / n);
  for (size_t i = 0; i < n; ++i) {
    const double v = angle[i];
    sum2 += (v - s.mean) * (v - s.mean);
    s.max_abs = std::max(s.max_abs, std::fabs(v - s.mean));
  }
  s.std = static_cast<double>(std::sqrt(sum2 / (n - 1)));
  s.end = angle[n - 1];
  long double h1 = 0, h2 = 0;
  for (size_t i = 0; i < n / 2; ++i) h1 += angle[i];
  for (size_t i = n / 2; i < n; ++i) h2 += angle[i];
  const double m1 = static_cast<double>(h1 / (n / 2)), m2 = static_cast<double>(h2 / (n - n / 2));
  s.half_mean_ratio = s.std > 0 ? std::fabs(m1 - m2) / s.std : 0.0;
  return s;
}

}  // namespace gyro_allan
