// Raw-sample diagnostics for the model check: Welch PSD, peaks, autocovariance, mean shifts, regression, outliers.
#include "block_ranges.hpp"
#include "gyro_allan/spectral.hpp"
#include "gyro_allan/stats.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <stdexcept>
#include <string>

#include <Eigen/Dense>
#include <unsupported/Eigen/FFT>

namespace gyro_allan {
namespace {

void requireFinite(const std::vector<double>& x, const char* who) {
  for (double v : x)
    if (!std::isfinite(v)) throw std::invalid_argument(std::string(who) + ": non-finite sample");
}

}  // namespace

Psd welchPsd(const std::vector<double>& x, double fs, int64_t nperseg, double overlap) {
  if (!(fs > 0) || !std::isfinite(fs)) throw std::invalid_argument("welchPsd: sample rate must be positive");
  if (!(overlap >= 0 && overlap <= 0.9)) throw std::invalid_argument("welchPsd: overlap must be in [0, 0.9]");
  requireFinite(x, "welchPsd");
  const int64_t n = static_cast<int64_t>(x.size());
  nperseg = std::min(nperseg, n);
  if (nperseg < 16) throw std::invalid_argument("welchPsd: need at least 16 samples per segment");
  const int64_t step = std::max<int64_t>(1, static_cast<int64_t>(std::llround(nperseg * (1.0 - overlap))));
  std::vector<double> w(nperseg);
  double wss = 0;
  for (int64_t i = 0; i < nperseg; ++i) {
    w[i] = 0.5 - 0.5 * std::cos(2.0 * M_PI * i / nperseg);  // periodic Hann
    wss += w[i] * w[i];
  }
  const int64_t nb = nperseg / 2 + 1;
  Psd psd;
  psd.fs = fs;
  psd.df = fs / nperseg;
  psd.p.assign(nb, 0.0);
  psd.f.resize(nb);
  for (int64_t k = 0; k < nb; ++k) psd.f[k] = k * psd.df;
  Eigen::FFT<double> fft;
  std::vector<double> seg(nperseg);
  std::vector<std::complex<double>> spec;
  for (int64_t s = 0; s + nperseg <= n; s += step) {
    double mean = 0;
    for (int64_t i = 0; i < nperseg; ++i) mean += x[s + i];
    mean /= nperseg;
    for (int64_t i = 0; i < nperseg; ++i) seg[i] = (x[s + i] - mean) * w[i];
    fft.fwd(spec, seg);
    for (int64_t k = 0; k < nb; ++k) psd.p[k] += std::norm(spec[k]);
    ++psd.segments;
  }
  const double scale = 1.0 / (psd.segments * wss * fs);
  for (int64_t k = 0; k < nb; ++k) {
    const bool edge = (k == 0) || (nperseg % 2 == 0 && k == nb - 1);
    psd.p[k] *= scale * (edge ? 1.0 : 2.0);
  }
  return psd;
}

std::vector<SpectralPeak> findPsdPeaks(const Psd& psd, double min_prominence_db, int max_peaks) {
  const int64_t nb = static_cast<int64_t>(psd.p.size());
  std::vector<SpectralPeak> peaks;
  if (nb < 32 || max_peaks <= 0) return peaks;
  const int64_t hw = std::min<int64_t>(128, std::max<int64_t>(8, nb / 8));
  const int64_t first = 6;
  std::vector<double> floor(nb, 0.0);
  // Floor = median of the bins k-h..k+h; the window moves by at most one bin at each end per step, so a sorted copy
  // is kept up to date by binary-search insertion and removal instead of a selection per bin.
  std::vector<double> win;
  int64_t wlo = 0, whi = 0;  // sorted holds psd.p[wlo, whi)
  for (int64_t k = first; k < nb; ++k) {
    const int64_t h = std::min({hw, k - 1, nb - 1 - k});
    if (h < 3) {
      floor[k] = 0;
      continue;
    }
    const int64_t lo = k - h, hi = k + h + 1;
    if (lo < wlo || lo > whi || hi < whi) {  // not a forward slide (first use): rebuild
      win.assign(psd.p.begin() + lo, psd.p.begin() + hi);
      std::sort(win.begin(), win.end());
      wlo = lo;
      whi = hi;
    }
    for (; whi < hi; ++whi) win.insert(std::upper_bound(win.begin(), win.end(), psd.p[whi]), psd.p[whi]);
    for (; wlo < lo; ++wlo) win.erase(std::lower_bound(win.begin(), win.end(), psd.p[wlo]));
    const size_t m = win.size() / 2;
    floor[k] = win.size() % 2 ? win[m] : 0.5 * (win[m - 1] + win[m]);
  }
  const double ratio_min = std::pow(10.0, min_prominence_db / 10.0);
  std::vector<bool> taken(nb, false);
  // Candidate local maxima above the threshold, strongest prominence first.
  std::vector<std::pair<double, int64_t>> cand;
  for (int64_t k = first; k < nb - 1; ++k) {
    if (floor[k] <= 0) continue;
    const double r = psd.p[k] / floor[k];
    if (r >= ratio_min && psd.p[k] >= psd.p[k - 1] && psd.p[k] >= psd.p[k + 1]) cand.push_back({r, k});
  }
  std::sort(cand.begin(), cand.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  for (const auto& c : cand) {
    const int64_t k = c.second;
    if (taken[k]) continue;
    // Extent of the feature: contiguous bins whose excess over the floor stays above 1/32 of the peak excess, at least
    // +-2 bins (the Hann main lobe).
    const double fl = floor[k];
    const double peak_excess = psd.p[k] - fl;
    int64_t lo = k, hi = k;
    while (lo - 1 >= first && (psd.p[lo - 1] - fl > peak_excess / 32 || k - lo < 2)) --lo;
    while (hi + 1 < nb && (psd.p[hi + 1] - fl > peak_excess / 32 || hi - k < 2)) ++hi;
    double power = 0, moment = 0;
    int64_t half_lo = k, half_hi = k;
    std::vector<double> p_f, p_p;
    for (int64_t i = lo; i <= hi; ++i) {
      const double e = std::max(0.0, psd.p[i] - fl);
      power += e * psd.df;
      if (e > 0) {
        p_f.push_back(psd.f[i]);
        p_p.push_back(e * psd.df);
      }
      moment += e * psd.df * psd.f[i];
      if (e >= peak_excess / 2) {
        half_lo = std::min(half_lo, i);
        half_hi = std::max(half_hi, i);
      }
      taken[i] = true;
    }
    if (power <= 0) continue;
    SpectralPeak p;
    p.frequency_hz = moment / power;
    p.prominence_db = 10.0 * std::log10(c.first);
    p.power = power;
    p.amplitude = std::sqrt(2.0 * power);
    p.bandwidth_hz = (half_hi - half_lo + 1) * psd.df;
    p.df = psd.df;
    p.floor = fl;
    p.profile_f = p_f;
    p.profile_p = p_p;
    peaks.push_back(p);
    if (static_cast<int>(peaks.size()) >= max_peaks) break;
  }
  return peaks;
}

namespace {

// Least-squares sinusoids at the given frequencies on y (rate r, sample j at j / r) with a mean and a linear trend:
// each one's cos and sin coefficients (phase referred to t = 0) and the sum of squares they explain beyond mean and
// trend. Cos and sin by rotation recurrences, re-anchored every 1024 samples.
struct SinusoidsFit {
  std::vector<std::pair<double, double>> cs;
  double explained = 0;
};

SinusoidsFit leastSquaresSinusoids(const std::vector<double>& y, double r, const std::vector<double>& freqs) {
  const int64_t J = static_cast<int64_t>(y.size());
  const int L = static_cast<int>(freqs.size());
  const int k = 2 + 2 * L;
  if (J < k) throw std::invalid_argument("fitSinusoids: fewer samples than parameters");
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(k, k);
  Eigen::VectorXd rhs = Eigen::VectorXd::Zero(k), g(k);
  std::vector<std::complex<double>> step(L), rot(L, 1.0);
  for (int l = 0; l < L; ++l) step[l] = std::polar(1.0, 2.0 * M_PI * freqs[l] / r);
  const double tm = 0.5 * static_cast<double>(J - 1);
  for (int64_t j = 0; j < J; ++j) {
    g[0] = 1.0;
    g[1] = static_cast<double>(j) - tm;
    for (int l = 0; l < L; ++l) {
      if ((j & 1023) == 0) rot[l] = std::polar(1.0, 2.0 * M_PI * freqs[l] / r * static_cast<double>(j));
      g[2 + 2 * l] = rot[l].real();
      g[3 + 2 * l] = rot[l].imag();
      rot[l] *= step[l];
    }
    A.selfadjointView<Eigen::Lower>().rankUpdate(g);
    rhs.noalias() += g * y[j];
  }
  const Eigen::MatrixXd full_A = A.selfadjointView<Eigen::Lower>();
  const Eigen::VectorXd full = full_A.ldlt().solve(rhs);
  const Eigen::Vector2d base = full_A.topLeftCorner<2, 2>().ldlt().solve(rhs.head<2>());
  SinusoidsFit out;
  out.cs.assign(static_cast<size_t>(L), {0.0, 0.0});
  if (!full.allFinite() || !base.allFinite()) return out;
  for (int l = 0; l < L; ++l) out.cs[l] = {full[2 + 2 * l], full[3 + 2 * l]};
  out.explained = std::max(0.0, full.dot(rhs) - base.dot(rhs.head<2>()));
  return out;
}

// One sinusoid at f: its coefficients and the sum of squares it explains.
struct LineFit {
  double a = 0, b = 0, explained = 0;
};

LineFit fitSinusoidAt(const std::vector<double>& y, double r, double f) {
  const SinusoidsFit s = leastSquaresSinusoids(y, r, {f});
  return {s.cs[0].first, s.cs[0].second, s.explained};
}

// Gain of a b-sample block mean at frequency f (rate fs), referred to the block's centre: real, 1 at f = 0.
double blockMeanGain(double f, double fs, int64_t b) {
  const double s = std::sin(M_PI * f / fs);
  if (b <= 1 || std::fabs(s) < 1e-300) return 1.0;
  return std::sin(M_PI * f * static_cast<double>(b) / fs) / (static_cast<double>(b) * s);
}

SpectralLine lineFromFit(const LineFit& lf, double gain, double f, double T, double noise_psd) {
  SpectralLine l;
  l.frequency_hz = f;
  l.amplitude = std::hypot(lf.a, lf.b) / gain;
  l.noise_psd = noise_psd;
  if (noise_psd > 0 && l.amplitude > 0) {
    l.amplitude_sigma = std::sqrt(noise_psd / T);
    l.frequency_sigma_hz = std::sqrt(3.0 * noise_psd) / (M_PI * l.amplitude * std::pow(T, 1.5));
    l.power_ratio = l.amplitude * l.amplitude * T / (2.0 * noise_psd);
  }
  return l;
}

// Chance that the periodogram of noise alone exceeds `ratio` times its level somewhere in a band of M whole-record
// bins, searched on a fine grid: M_eff = M kappa sqrt(ratio) independent exponential variates (the sqrt(ratio)
// growth of the maximum over a continuous frequency, Baluev 2008), kappa = 0.85 set on clean records (white noise
// with and without a random walk, seeds 1-600; docs/model_check.md).
double falseAlarmOf(double ratio, int M) {
  const double m_eff = M * std::max(1.0, 0.85 * std::sqrt(ratio));
  return -std::expm1(m_eff * std::log1p(-std::exp(-ratio)));
}

// Least-squares straight line of x against the sample index, centred: x ~ mean + slope (i - (n - 1) / 2).
struct Trend {
  double mean = 0, slope = 0;
};

Trend trendOf(const std::vector<double>& x) {
  const int64_t n = static_cast<int64_t>(x.size());
  const double tm = 0.5 * static_cast<double>(n - 1);
  double sy = 0, sty = 0, stt = 0;
  for (int64_t i = 0; i < n; ++i) {
    const double t = static_cast<double>(i) - tm;
    sy += x[i];
    sty += t * x[i];
    stt += t * t;
  }
  return {sy / static_cast<double>(n), stt > 0 ? sty / stt : 0.0};
}

}  // namespace

double lineFalseAlarm(double ratio, int frequencies) { return falseAlarmOf(ratio, frequencies); }

std::vector<std::pair<double, double>> fitSinusoids(const std::vector<double>& x, double fs,
                                                     const std::vector<double>& frequencies_hz) {
  requireFinite(x, "fitSinusoids");
  return leastSquaresSinusoids(x, fs, frequencies_hz).cs;
}

SpectralLine refineLine(const std::vector<double>& x, double fs, double f0, double half_width, double noise_psd) {
  if (!(fs > 0) || !(f0 > 0) || !(f0 < fs / 2) || !(half_width > 0))
    throw std::invalid_argument("refineLine: need fs > 0, 0 < f0 < fs/2 and half_width > 0");
  requireFinite(x, "refineLine");
  const int64_t n = static_cast<int64_t>(x.size());
  if (n < 64) throw std::invalid_argument("refineLine: need at least 64 samples");
  const double T = static_cast<double>(n) / fs;
  // Zoom: x shifted by -f0 and averaged over blocks of b samples (the band f0 +- half_width keeps >= 98 % of its
  // amplitude), then the periodogram of those block means on a grid of 1/(4T) and a golden-section refinement.
  const int64_t b = std::clamp<int64_t>(static_cast<int64_t>(fs / (8.0 * half_width)), 1, n / 16);
  const int64_t J = n / b;
  std::vector<std::complex<double>> z(static_cast<size_t>(J));
  const double w0 = -2.0 * M_PI * f0 / fs;
  const std::complex<double> step = std::polar(1.0, w0);
  std::complex<double> rot(1.0, 0.0);
  for (int64_t j = 0; j < J; ++j) {
    std::complex<double> acc(0.0, 0.0);
    for (int64_t k = j * b; k < (j + 1) * b; ++k) {
      if ((k & 1023) == 0) rot = std::polar(1.0, w0 * static_cast<double>(k));
      acc += x[k] * rot;
      rot *= step;
    }
    z[j] = acc / static_cast<double>(b);
  }
  const double fz = fs / static_cast<double>(b);
  auto zoomPower = [&](double df) {
    const std::complex<double> st = std::polar(1.0, -2.0 * M_PI * df / fz);
    std::complex<double> r(1.0, 0.0), acc(0.0, 0.0);
    for (int64_t j = 0; j < J; ++j) {
      if ((j & 1023) == 0) r = std::polar(1.0, -2.0 * M_PI * df / fz * static_cast<double>(j));
      acc += z[j] * r;
      r *= st;
    }
    const double g = blockMeanGain(df, fs, b);
    return std::norm(acc) / (g * g);
  };
  const double grid = 1.0 / (4.0 * T);
  double best = 0, best_p = -1;
  for (double df = -half_width; df <= half_width; df += grid) {
    if (!(f0 + df > 0 && f0 + df < fs / 2)) continue;
    const double p = zoomPower(df);
    if (p > best_p) {
      best_p = p;
      best = df;
    }
  }
  const double dfz = goldenSectionMax(zoomPower, best - grid, best + grid, 30);
  const double f = std::clamp(f0 + dfz, 1e-12 * fs, 0.5 * fs * (1 - 1e-12));
  return lineFromFit(fitSinusoidAt(x, fs, f), 1.0, f, T, noise_psd);
}

std::vector<SpectralLine> findSlowLines(const std::vector<double>& x, double fs, double f_lo, double f_hi,
                                        double false_alarm, int max_lines) {
  if (!(fs > 0) || !(f_lo > 0) || !(f_hi > f_lo) || !(f_hi < fs / 2))
    throw std::invalid_argument("findSlowLines: need 0 < f_lo < f_hi < fs/2");
  requireFinite(x, "findSlowLines");
  std::vector<SpectralLine> lines;
  const int64_t n = static_cast<int64_t>(x.size());
  const int64_t b = std::max<int64_t>(1, static_cast<int64_t>(fs / (8.0 * f_hi)));
  const int64_t J = n / b;
  if (J < 64 || max_lines <= 0) return lines;
  const double fy = fs / static_cast<double>(b), T = static_cast<double>(J) / fy;
  const int frequencies = static_cast<int>(std::floor((f_hi - f_lo) * T));
  if (frequencies < 8) return lines;
  // Block means of the detrended record (the least-squares line of x, subtracted at each block's centre: a straight
  // line's block mean), the residual the lines are taken out of one by one.
  const Trend tr = trendOf(x);
  const double tm = 0.5 * static_cast<double>(n - 1);
  std::vector<double> y(static_cast<size_t>(J));
  for (int64_t j = 0; j < J; ++j) {
    double s = 0;
    for (int64_t k = j * b; k < (j + 1) * b; ++k) s += x[k];
    const double centre = static_cast<double>(j * b) + 0.5 * static_cast<double>(b - 1);
    y[j] = s / static_cast<double>(b) - tr.mean - tr.slope * (centre - tm);
  }
  int64_t L = 1;
  while (L < 4 * J) L *= 2;
  const double dfp = fy / static_cast<double>(L);  // padded grid
  Eigen::FFT<double> fft;
  fft.SetFlag(Eigen::FFT<double>::HalfSpectrum);
  std::vector<double> seg(static_cast<size_t>(L), 0.0);
  std::vector<std::complex<double>> spec;
  const int64_t m_fit_lo = std::max<int64_t>(1, static_cast<int64_t>(std::ceil(1.0 / T / dfp)));
  const int64_t m_fit_hi = std::min<int64_t>(L / 2 - 1, static_cast<int64_t>(1.5 * f_hi / dfp));
  const int64_t m_lo = static_cast<int64_t>(std::ceil(f_lo / dfp)), m_hi = static_cast<int64_t>(f_hi / dfp);
  std::vector<double> taken_hz;
  // Tukey window (cosine tapers over 10 % at each end): side lobes falling as 1/k^3, so that a random walk's
  // 1/f^2 power does not leak into the bins above it, for 0.3 dB of a line's peak.
  std::vector<double> win(static_cast<size_t>(J), 1.0);
  const int64_t taper = std::max<int64_t>(1, J / 10);
  for (int64_t j = 0; j < taper; ++j) {
    const double v = 0.5 - 0.5 * std::cos(M_PI * (static_cast<double>(j) + 0.5) / static_cast<double>(taper));
    win[j] = v;
    win[J - 1 - j] = v;
  }
  double wss = 0;
  for (double v : win) wss += v * v;
  for (int round = 0; round < max_lines; ++round) {
    for (int64_t j = 0; j < J; ++j) seg[j] = y[j] * win[j];
    fft.fwd(spec, seg);
    std::vector<double> P(static_cast<size_t>(L / 2 + 1));
    for (size_t m = 0; m < P.size(); ++m) P[m] = 2.0 * std::norm(spec[m]) / (fy * wss);
    // Noise level: S(f) = g(f)^2 (w + b / f + k / f^2), white, flicker and random-walk rate noise seen through the
    // block mean's gain g, fitted by Whittle maximum likelihood (iteratively reweighted least squares with weights
    // 1/S^2, non-negative coefficients).
    std::vector<bool> use(P.size(), true);
    Eigen::Vector3d c(1.0, 0.0, 0.0);
    auto basis = [&](double f) {
      const double g = blockMeanGain(f, fs, b);
      return Eigen::Vector3d(g * g, g * g / f, g * g / (f * f));
    };
    auto level = [&](double f) { return std::max(1e-300, basis(f).dot(c)); };
    {  // start: flat at the median / ln 2 (the mean of an exponential variate)
      std::vector<double> band(P.begin() + m_fit_lo, P.begin() + m_fit_hi + 1);
      c[0] = std::max(1e-300, upperMedianInPlace(band) / std::log(2.0));
    }
    // Points within 2 whole-record bins of one more than 10x above the level are left out (a line's main lobe and
    // shoulders; noise alone exceeds 10x at e^-10 of the points).
    const int64_t lobe = 2 * L / J + 1;
    auto excludeLines = [&]() {
      std::fill(use.begin(), use.end(), true);
      for (int64_t m = m_fit_lo; m <= m_fit_hi; ++m)
        if (P[m] > 10.0 * level(m * dfp))
          for (int64_t q = std::max<int64_t>(0, m - lobe); q <= std::min<int64_t>(m_fit_hi, m + lobe); ++q)
            use[q] = false;
    };
    for (int it = 0; it < 12; ++it) {
      // Weighted normal equations at the current level, then the non-negative least-squares solution: of the seven
      // subsets of the three terms, the feasible one with the smallest weighted residual.
      Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
      Eigen::Vector3d r = Eigen::Vector3d::Zero();
      double pp = 0;
      for (int64_t m = m_fit_lo; m <= m_fit_hi; ++m) {
        if (!use[m]) continue;
        const Eigen::Vector3d g = basis(m * dfp);
        const double s = level(m * dfp), w = 1.0 / (s * s);
        A.noalias() += w * g * g.transpose();
        r.noalias() += w * g * P[m];
        pp += w * P[m] * P[m];
      }
      Eigen::Vector3d best_c = c;
      double best_sse = HUGE_VAL;
      for (int mask = 1; mask < 8; ++mask) {
        std::vector<int> idx;
        for (int q = 0; q < 3; ++q)
          if (mask & (1 << q)) idx.push_back(q);
        const int k = static_cast<int>(idx.size());
        Eigen::MatrixXd As(k, k);
        Eigen::VectorXd rs(k);
        for (int a = 0; a < k; ++a) {
          rs[a] = r[idx[a]];
          for (int bq = 0; bq < k; ++bq) As(a, bq) = A(idx[a], idx[bq]);
        }
        const Eigen::VectorXd xs = As.ldlt().solve(rs);
        if (!xs.allFinite() || (xs.array() < 0).any()) continue;
        Eigen::Vector3d cand = Eigen::Vector3d::Zero();
        for (int a = 0; a < k; ++a) cand[idx[a]] = xs[a];
        const double sse = pp - 2 * cand.dot(r) + cand.dot(A * cand);
        if (sse < best_sse) {
          best_sse = sse;
          best_c = cand;
        }
      }
      if (!(best_sse < HUGE_VAL)) return lines;
      c = best_c;
      if (it >= 1) excludeLines();  // the first fit sees every point (a random walk's low bins are not lines)
    }
    double best_ratio = 0;
    int64_t best_m = -1;
    for (int64_t m = std::max<int64_t>(m_lo, 1); m <= m_hi; ++m) {
      bool near = false;
      for (double fh : taken_hz) near = near || std::fabs(m * dfp - fh) < 2.0 / T;
      if (near) continue;
      const double ratio = P[m] / level(m * dfp);
      if (ratio > best_ratio) {
        best_ratio = ratio;
        best_m = m;
      }
    }
    if (best_m < 0) break;
    const double fa = falseAlarmOf(best_ratio, frequencies);
    if (!(fa < false_alarm)) break;
    // Refine on the block means: frequency within +-1 padded bin by golden section on the explained power, then the
    // amplitude corrected for the block mean's gain; the fitted sinusoid leaves the residual before the next round.
    const double fr = goldenSectionMax([&](double f) { return fitSinusoidAt(y, fy, f).explained; },
                                (best_m - 1) * dfp, (best_m + 1) * dfp, 30);
    const LineFit lf = fitSinusoidAt(y, fy, fr);
    const double g = blockMeanGain(fr, fs, b);
    // The amplitude from every sample: a line above f_hi folded into the band by the block means has none there.
    const LineFit lx = fitSinusoidAt(x, fs, fr);
    if (std::hypot(lx.a, lx.b) >= 0.5 * std::hypot(lf.a, lf.b) / g) {
      SpectralLine l = lineFromFit(lx, 1.0, fr, T, level(fr) / (g * g));
      l.power_ratio = best_ratio;
      l.false_alarm = fa;
      l.frequencies = frequencies;
      lines.push_back(l);
    }
    taken_hz.push_back(fr);
    // Block centre j + (b - 1)/2 samples of x; fitSinusoidAt's phase is referred to block 0's centre.
    for (int64_t j = 0; j < J; ++j) {
      const double ph = 2.0 * M_PI * fr * static_cast<double>(j) / fy;
      y[j] -= lf.a * std::cos(ph) + lf.b * std::sin(ph);
    }
  }
  return lines;
}

std::vector<double> autocovariance(const std::vector<double>& x, int64_t max_lag) {
  requireFinite(x, "autocovariance");
  const int64_t n = static_cast<int64_t>(x.size());
  if (n < 2) throw std::invalid_argument("autocovariance: need at least 2 samples");
  if (max_lag < 0) throw std::invalid_argument("autocovariance: max_lag must be >= 0");
  max_lag = std::min(max_lag, n - 1);
  double mean = 0;
  for (double v : x) mean += v;
  mean /= n;
  // Blocked FFT correlation: with X_b the spectrum of block b (length B, zero-padded to 2B), sum_i x[i] x[i+k] over
  // block b and its successor is IFFT(conj(X_b) (X_b + (-1)^j X_{b+1}))[k] for k <= B (the successor shifted by B
  // is the factor (-1)^j), and by linearity the spectra of all blocks add before one inverse transform. One real FFT
  // of 2B points per block, cache-resident, instead of one transform of the whole record.
  int64_t B = 256;
  while (B < max_lag + 1) B *= 2;
  const int64_t L = 2 * B, nb = (n + B - 1) / B, nh = B + 1;
  Eigen::FFT<double> fft;
  fft.SetFlag(Eigen::FFT<double>::HalfSpectrum);
  std::vector<double> seg(static_cast<size_t>(L), 0.0);
  std::vector<std::complex<double>> cur, next, acc(static_cast<size_t>(nh), 0.0);
  auto spectrumOf = [&](int64_t b, std::vector<std::complex<double>>* out) {
    std::fill(seg.begin(), seg.end(), 0.0);
    const int64_t lo = b * B, hi = std::min(n, lo + B);
    for (int64_t i = lo; i < hi; ++i) seg[static_cast<size_t>(i - lo)] = x[static_cast<size_t>(i)] - mean;
    fft.fwd(*out, seg);
  };
  spectrumOf(0, &cur);
  for (int64_t b = 0; b < nb; ++b) {
    if (b + 1 < nb) spectrumOf(b + 1, &next);
    for (int64_t j = 0; j < nh; ++j) {
      std::complex<double> y = cur[static_cast<size_t>(j)];
      if (b + 1 < nb) y += (j % 2 ? -1.0 : 1.0) * next[static_cast<size_t>(j)];
      acc[static_cast<size_t>(j)] += std::conj(cur[static_cast<size_t>(j)]) * y;
    }
    cur.swap(next);
  }
  fft.inv(seg, acc, L);
  std::vector<double> acov(static_cast<size_t>(max_lag + 1));
  for (int64_t k = 0; k <= max_lag; ++k) acov[static_cast<size_t>(k)] = seg[static_cast<size_t>(k)] / n;
  return acov;
}

std::vector<double> blockMeans(const std::vector<double>& x, int64_t block) {
  if (block < 1) throw std::invalid_argument("blockMeans: block must be >= 1");
  const int64_t nb = static_cast<int64_t>(x.size()) / block;
  std::vector<double> out(nb);
  for (int64_t b = 0; b < nb; ++b) {
    long double s = 0;
    for (int64_t i = 0; i < block; ++i) s += x[b * block + i];
    out[b] = static_cast<double>(s / block);
  }
  return out;
}

ExponentialAcfFit fitExponentialAcf(const std::vector<double>& rho, double dt, double floor) {
  ExponentialAcfFit fit;
  std::vector<double> lx, ly;
  for (size_t k = 1; k < rho.size(); ++k) {
    if (!(rho[k] > floor)) break;
    lx.push_back(k * dt);
    ly.push_back(std::log(rho[k]));
  }
  fit.lags = static_cast<int>(lx.size());
  if (lx.size() < 2) {
    if (lx.size() == 1 && rho[1] < 1) {  // one lag: exponential through it with a = 1
      fit.ok = true;
      fit.a = 1;
      fit.tc = -dt / std::log(rho[1]);
      fit.r2 = 0;
    }
    return fit;
  }
  if (lx.size() == 2) {  // two lags: the exponential through both
    const double slope = (ly[1] - ly[0]) / (lx[1] - lx[0]);
    if (!(slope < 0)) return fit;
    fit.ok = true;
    fit.tc = -1.0 / slope;
    fit.a = std::exp(ly[0] - slope * lx[0]);
    fit.r2 = 1;
    return fit;
  }
  const LinearRegression lr = linearRegression(lx, ly);
  if (!(lr.slope < 0)) return fit;
  fit.ok = true;
  fit.tc = -1.0 / lr.slope;
  fit.a = std::exp(lr.intercept);
  fit.r2 = lr.r * lr.r;
  return fit;
}

MeanShift detectMeanShift(const std::vector<double>& x, int64_t block, double z_min) {
  MeanShift out;
  if (block < 1) throw std::invalid_argument("detectMeanShift: block must be >= 1");
  requireFinite(x, "detectMeanShift");
  const std::vector<double> bm = blockMeans(x, block);
  const int64_t nb = static_cast<int64_t>(bm.size());
  if (nb < 8) return out;
  std::vector<double> d(nb - 1), ad(nb - 1);
  for (int64_t i = 0; i + 1 < nb; ++i) d[i] = bm[i + 1] - bm[i];
  const double med = median(d);
  for (int64_t i = 0; i + 1 < nb; ++i) ad[i] = std::fabs(d[i] - med);
  const double scale = median(ad) / kMadPerSigma;
  if (!(scale > 0)) return out;
  // A step inside block b splits between differences b-1 and b: score each block boundary region by the larger of
  // the single difference and the two-difference sum scaled by sqrt(2)... use the sum of neighbours' excess.
  int64_t best = -1;
  double best_z = 0;
  for (int64_t i = 0; i + 1 < nb; ++i) {
    double z = std::fabs(d[i] - med) / scale;
    if (i + 1 < nb - 1) z = std::max(z, std::fabs(d[i] + d[i + 1] - 2 * med) / (scale * std::sqrt(2.0)));
    if (z > best_z) {
      best_z = z;
      best = i;
    }
  }
  if (best < 0 || best_z < z_min) return out;
  // Localize: least-squares single step over the window [best - 1, best + 3) blocks (samples).
  const int64_t n = static_cast<int64_t>(x.size());
  const int64_t lo = std::max<int64_t>(0, (best - 1) * block);
  const int64_t hi = std::min<int64_t>(n, (best + 3) * block);
  std::vector<long double> cum(hi - lo + 1, 0.0L);
  for (int64_t i = lo; i < hi; ++i) cum[i - lo + 1] = cum[i - lo] + x[i];
  const int64_t len = hi - lo;
  double best_gain = -1;
  int64_t best_k = lo + len / 2;
  double best_size = 0;
  for (int64_t k = 1; k < len; ++k) {
    const long double s1 = cum[k], s2 = cum[len] - cum[k];
    const double m1 = static_cast<double>(s1 / k), m2 = static_cast<double>(s2 / (len - k));
    const double gain = (m2 - m1) * (m2 - m1) * static_cast<double>(k) * (len - k) / len;
    if (gain > best_gain) {
      best_gain = gain;
      best_k = lo + k;
      best_size = m2 - m1;
    }
  }
  out.found = true;
  out.index = best_k;
  out.size = best_size;
  out.z = best_z;
  return out;
}

LinearRegression linearRegression(const std::vector<double>& x, const std::vector<double>& y) {
  if (x.size() != y.size()) throw std::invalid_argument("linearRegression: x and y differ in length");
  const int64_t n = static_cast<int64_t>(x.size());
  if (n < 3) throw std::invalid_argument("linearRegression: need at least 3 points");
  double mx = 0, my = 0;
  for (int64_t i = 0; i < n; ++i) {
    mx += x[i];
    my += y[i];
  }
  mx /= n;
  my /= n;
  double sxx = 0, syy = 0, sxy = 0;
  for (int64_t i = 0; i < n; ++i) {
    sxx += (x[i] - mx) * (x[i] - mx);
    syy += (y[i] - my) * (y[i] - my);
    sxy += (x[i] - mx) * (y[i] - my);
  }
  LinearRegression lr;
  lr.n = static_cast<int>(n);
  if (!(sxx > 0)) throw std::invalid_argument("linearRegression: x is constant");
  lr.slope = sxy / sxx;
  lr.intercept = my - lr.slope * mx;
  lr.r = (syy > 0) ? sxy / std::sqrt(sxx * syy) : 0.0;
  lr.rss = std::max(0.0, syy - lr.slope * sxy);
  lr.slope_sigma = std::sqrt(lr.rss / (n - 2) / sxx);
  return lr;
}

WarmupFit fitWarmup(const std::vector<double>& bm, double block_s, double theta_min, double theta_max) {
  WarmupFit best;
  const int64_t n = static_cast<int64_t>(bm.size());
  if (n < 8 || !(theta_min > 0) || !(theta_max > theta_min) || !(block_s > 0)) return best;
  const int steps = 60;
  for (int s = 0; s <= steps; ++s) {
    const double theta = theta_min * std::pow(theta_max / theta_min, static_cast<double>(s) / steps);
    std::vector<double> g(n);
    for (int64_t i = 0; i < n; ++i) g[i] = -std::expm1(-(i + 0.5) * block_s / theta);
    LinearRegression lr;
    try {
      lr = linearRegression(g, bm);  // block means = c + a g
    } catch (const std::invalid_argument&) {
      continue;  // g constant at this theta
    }
    if (!best.ok || lr.rss < best.rss) {
      best.ok = true;
      best.theta = theta;
      best.a = lr.slope;
      best.rss = lr.rss;
      // theta was fitted too: n - 3 degrees of freedom instead of the regression's n - 2.
      best.a_sigma = lr.slope_sigma * std::sqrt(static_cast<double>(n - 2) / std::max<int64_t>(1, n - 3));
    }
  }
  return best;
}

Outliers detectOutliers(const std::vector<double>& x, double tau0, double z_min, int half_window) {
  Outliers out;
  requireFinite(x, "detectOutliers");
  if (half_window < 1) throw std::invalid_argument("detectOutliers: half_window must be >= 1");
  const int64_t n = static_cast<int64_t>(x.size());
  if (n < 2 * half_window + 2) return out;
  // Distance of sample i from the median of its +-half_window neighbours (the window is cut at the ends).
  std::vector<double> win;
  auto devAt = [&](int64_t i) {
    const int64_t lo = std::max<int64_t>(0, i - half_window), hi = std::min<int64_t>(n, i + half_window + 1);
    win.clear();
    for (int64_t j = lo; j < hi; ++j)
      if (j != i) win.push_back(x[static_cast<size_t>(j)]);
    return x[static_cast<size_t>(i)] - medianInPlace(win);
  };
  // Robust sigma: median absolute distance of 2^15-2^16 evenly spaced samples / 0.6745 (the MAD of 2^15 values is
  // within ~0.7 %: immaterial for a 10-sigma threshold).
  {
    const int64_t step = std::max<int64_t>(1, n >> 15);
    std::vector<double> ad;
    ad.reserve(static_cast<size_t>(n / step + 1));
    for (int64_t i = 0; i < n; i += step) ad.push_back(std::fabs(devAt(i)));
    out.robust_sigma = medianInPlace(ad) / kMadPerSigma;
  }
  if (!(out.robust_sigma > 0)) return out;
  const double limit = z_min * out.robust_sigma;
  // A sample whose window (itself included) spans at most `limit` cannot be farther than that from the window's
  // median. Windows of the samples in block b (B >= half_window samples) lie within blocks b-1..b+1, so a block whose
  // three-block range is at most `limit` is skipped whole; the rest get the exact median sample by sample.
  const int64_t B = std::max<int64_t>(16, half_window);
  const int64_t nb = (n + B - 1) / B;
  std::vector<double> bmin, bmax;
  detail::blockMinMax(x, B, &bmin, &bmax);
  for (int64_t b = 0; b < nb; ++b) {
    double mn = bmin[static_cast<size_t>(b)], mx = bmax[static_cast<size_t>(b)];
    if (b > 0) mn = std::min(mn, bmin[static_cast<size_t>(b - 1)]), mx = std::max(mx, bmax[static_cast<size_t>(b - 1)]);
    if (b + 1 < nb) mn = std::min(mn, bmin[static_cast<size_t>(b + 1)]), mx = std::max(mx, bmax[static_cast<size_t>(b + 1)]);
    if (mx - mn <= limit) continue;
    for (int64_t i = b * B; i < std::min(n, (b + 1) * B); ++i) {
      const double d = devAt(i);
      if (std::fabs(d) > limit) {
        out.index.push_back(i);
        out.sum_sq_area += (d * tau0) * (d * tau0);
      }
    }
  }
  return out;
}

}  // namespace gyro_allan
