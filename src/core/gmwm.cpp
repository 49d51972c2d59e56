// GMWM: Haar MODWT wavelet variance, closed-form model wavelet variances, efficient fit (own Levenberg-Marquardt on
// log parameters), model selection and discretization of the fitted bias model.
#include "gyro_allan/gmwm.hpp"

#include <algorithm>
#include <cctype>
#include <functional>
#include <cmath>
#include <complex>
#include <cstdio>
#include <limits>
#include <random>
#include <stdexcept>

#include <boost/math/distributions/chi_squared.hpp>
#include <unsupported/Eigen/FFT>

#include "gyro_allan/model_check.hpp"

namespace gyro_allan {

// ---- Wavelet variance --------------------------------------------------------------------------------------------

WaveletVariance haarWaveletVariance(const std::vector<double>& x, double tau0, double confidence,
                                    int max_fraction_inv) {
  if (!(tau0 > 0) || !std::isfinite(tau0)) throw std::invalid_argument("haarWaveletVariance: tau0 must be > 0");
  if (!(confidence > 0 && confidence < 1)) throw std::invalid_argument("haarWaveletVariance: confidence in (0, 1)");
  if (max_fraction_inv < 2) throw std::invalid_argument("haarWaveletVariance: max_fraction_inv must be >= 2");
  const int64_t n = static_cast<int64_t>(x.size());
  if (n < 8) throw std::invalid_argument("haarWaveletVariance: fewer than 8 samples");
  long double mean = 0;
  for (double v : x) {
    if (!std::isfinite(v)) throw std::invalid_argument("haarWaveletVariance: a sample is not finite");
    mean += v;
  }
  mean /= n;
  // Prefix sums of the centred samples (the mean changes no Haar coefficient), accumulated in long double and stored
  // as double (8 bytes per sample: a 1e8-sample record needs 0.8 GB, not 1.6).
  std::vector<double> p(static_cast<size_t>(n) + 1, 0.0);
  long double acc = 0;
  for (int64_t i = 0; i < n; ++i) p[i + 1] = static_cast<double>(acc += static_cast<long double>(x[i]) - mean);
  WaveletVariance wv;
  wv.tau0 = tau0;
  wv.n = n;
  wv.confidence = confidence;
  const double alpha = 1.0 - confidence;
  for (int j = 1;; ++j) {
    const int64_t L = int64_t{1} << j;
    if (L * max_fraction_inv > n) break;
    const int64_t m = L / 2;
    long double sum = 0;
    for (int64_t t = L; t <= n; ++t) {  // coefficient ending at sample t-1 uses p[t], p[t-m], p[t-L]
      const long double w = (static_cast<long double>(p[t]) - 2.0L * p[t - m] + p[t - L]) / (2.0L * m);
      sum += w * w;
    }
    const int64_t M = n - L + 1;
    const double nu2 = static_cast<double>(sum / M);
    const double eta = std::max(static_cast<double>(M) / static_cast<double>(L), 1.0);
    boost::math::chi_squared chi(eta);
    wv.level.push_back(j);
    wv.scale.push_back(static_cast<double>(L) * tau0);
    wv.nu2.push_back(nu2);
    wv.n_coeffs.push_back(M);
    wv.eta.push_back(eta);
    wv.lo.push_back(eta * nu2 / boost::math::quantile(chi, 1.0 - alpha / 2));
    wv.hi.push_back(eta * nu2 / boost::math::quantile(chi, alpha / 2));
  }
  if (wv.level.empty()) throw std::invalid_argument("haarWaveletVariance: record too short for level 1");
  return wv;
}

// ---- Closed forms ---------------------------------------------------------------------------------------------------

double wvWhite(double s2, double tau) { return s2 / tau; }
double wvQuantization(double q2, double tau) { return 6.0 * q2 / (tau * tau); }
double wvRandomWalk(double g2, double tau) { return g2 * (tau * tau + 2.0) / (12.0 * tau); }
double wvDrift(double w2, double tau) { return w2 * tau * tau / 16.0; }

namespace {
/// AR(1) WV per unit STATIONARY variance, phi = exp(-a), scale tau = 2m samples: AVAR(m) / 2 with
/// AVAR(m) = (Var(S_m) - Cov(S_m, S'_m)) / m^2 = (m + phi (2 m e - 2 u - u^2) / e^2) / m^2, e = 1 - phi,
/// u = 1 - phi^m (the same quantity as the paper's closed form, written with expm1 to avoid cancellation).
double ar1UnitWv(double a, double tau) {
  // Long double: the bracket is of order m a^2 while its terms are of order m a, so near phi = 1 (tc of 10^8
  // samples) double would keep only a few digits; long double keeps ~1e-4 relative in the worst case (m = 2..4).
  const long double m = tau / 2.0L;
  if (a > 700) return 1.0 / tau;  // phi = 0: white
  const long double al = a;
  const long double phi = std::exp(-al);
  const long double e = -std::expm1(-al);
  const long double u = -std::expm1(-m * al);
  const long double bracket = 2.0L * m * e - 2.0L * u - u * u;
  const double avar = static_cast<double>((m + phi * bracket / (e * e)) / (m * m));
  return std::max(avar, 0.0) / 2.0;
}
}  // namespace

double wvAr1(double phi, double s2, double tau) {
  if (!(phi >= 0 && phi < 1)) throw std::invalid_argument("wvAr1: phi must be in [0, 1)");
  const double a = phi > 0 ? -std::log(phi) : 1e300;
  const double v = s2 / (1.0 - phi * phi);
  return v * ar1UnitWv(a, tau);
}

std::vector<double> maAutocovariance(const std::vector<double>& theta, double s2) {
  const size_t q = theta.size();
  std::vector<double> c(q + 1, 0.0);
  for (size_t h = 0; h <= q; ++h)
    for (size_t k = 0; k + h <= q; ++k) c[h] += (k ? theta[k - 1] : 1.0) * (k + h ? theta[k + h - 1] : 1.0);
  for (auto& v : c) v *= s2;
  return c;
}

double wvShortMemory(const std::vector<double>& acf, double tau) {
  // W = sum_l h_l x_{t-l}, h_l = 1/(2m) for l < m, -1/(2m) for m <= l < 2m; Var(W) = sum_h (sum_l h_l h_{l+|h|})
  // gamma_h, and sum_l s_l s_{l+h} of the +-1 pattern is 2(m - h) - h for 0 <= h <= m, -(2m - h) for m <= h < 2m.
  const double m = tau / 2.0;
  double s = 2.0 * m * (acf.empty() ? 0.0 : acf[0]);
  for (size_t h = 1; h < acf.size(); ++h) {
    const double hd = static_cast<double>(h);
    if (hd >= 2.0 * m) break;
    s += 2.0 * (hd <= m ? 2.0 * m - 3.0 * hd : -(2.0 * m - hd)) * acf[h];
  }
  return s / (4.0 * m * m);
}

double wvFromAutocovariance(const std::vector<double>& acf, int64_t tau) {
  if (tau < 2 || tau % 2) throw std::invalid_argument("wvFromAutocovariance: tau must be even and >= 2");
  const int64_t m = tau / 2;
  std::vector<double> h(static_cast<size_t>(tau));
  for (int64_t l = 0; l < tau; ++l) h[l] = (l < m ? 1.0 : -1.0) / static_cast<double>(tau);
  double s = 0;
  for (int64_t l = 0; l < tau; ++l)
    for (int64_t k = 0; k < tau; ++k) {
      const size_t lag = static_cast<size_t>(std::llabs(l - k));
      if (lag < acf.size()) s += h[l] * h[k] * acf[lag];
    }
  return s;
}

// ---- Models -----------------------------------------------------------------------------------------------------

std::string GmwmModel::name() const {
  std::string s;
  auto add = [&](const std::string& t) { s += (s.empty() ? "" : "+") + t; };
  if (quantization) add("QN");
  if (white) add("WN");
  if (moving_average > 0) add("MA" + std::to_string(moving_average));
  if (gauss_markov == 1) add("GM");
  if (gauss_markov > 1) add(std::to_string(gauss_markov) + "GM");
  if (random_walk) add("RW");
  if (drift) add("DR");
  return s.empty() ? "none" : s;
}

int GmwmModel::parameters() const {
  return (white ? 1 : 0) + (moving_average > 0 ? 1 + moving_average : 0) + (quantization ? 1 : 0) +
         (random_walk ? 1 : 0) + (drift ? 1 : 0) + 2 * gauss_markov;
}

GmwmModel parseGmwmModel(const std::string& text) {
  GmwmModel m;
  m.white = false;
  size_t pos = 0;
  if (text.empty()) throw std::invalid_argument("GMWM model: empty");
  while (pos <= text.size()) {
    size_t end = text.find('+', pos);
    if (end == std::string::npos) end = text.size();
    std::string t = text.substr(pos, end - pos);
    for (auto& c : t) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    if (t == "WN") m.white = true;
    else if (t == "QN") m.quantization = true;
    else if (t == "RW") m.random_walk = true;
    else if (t == "DR") m.drift = true;
    else if (t.size() == 3 && t.substr(0, 2) == "MA" && t[2] >= '1' && t[2] <= '9') m.moving_average = t[2] - '0';
    else if (t.size() >= 2 && t.substr(t.size() - 2) == "GM") {
      const std::string k = t.substr(0, t.size() - 2);
      int count = 1;
      if (!k.empty()) {
        if (k.size() > 1 || !std::isdigit(static_cast<unsigned char>(k[0])))
          throw std::invalid_argument("GMWM model: bad term '" + t + "' in '" + text + "'");
        count = k[0] - '0';
      }
      m.gauss_markov += count;
    } else {
      throw std::invalid_argument("GMWM model: unknown term '" + t + "' in '" + text +
                                  "' (WN, MAq, QN, RW, DR, GM, kGM)");
    }
    pos = end + 1;
  }
  if (m.white && m.moving_average > 0)
    throw std::invalid_argument("GMWM model: MAq already contains the white noise (WN is MA0): '" + text + "'");
  if (m.gauss_markov > 5) throw std::invalid_argument("GMWM model: at most 5 GM terms");
  if (m.parameters() == 0) throw std::invalid_argument("GMWM model: no term");
  return m;
}

namespace {

// Internal parameters (sample units, logs except the MA coefficients): [WN log s2][MA log s2, theta_1..theta_q]
// [QN log q2][RW log g2][DR log w2][GM_i log v_i, log tc_i].
struct Layout {
  int wn = -1, ma = -1, n_ma = 0, qn = -1, rw = -1, dr = -1, gm0 = -1, p = 0, n_gm = 0;
  Layout() = default;
  explicit Layout(const GmwmModel& m) {
    if (m.white) wn = p++;
    if (m.moving_average > 0) {
      ma = p;
      n_ma = m.moving_average;
      p += 1 + n_ma;
    }
    if (m.quantization) qn = p++;
    if (m.random_walk) rw = p++;
    if (m.drift) dr = p++;
    n_gm = m.gauss_markov;
    if (n_gm > 0) gm0 = p;
    p += 2 * n_gm;
  }
};

/// Autocovariance gamma_0..gamma_q of the MA term of `th`.
std::vector<double> maAcf(const Layout& L, const Eigen::VectorXd& th) {
  std::vector<double> theta(static_cast<size_t>(L.n_ma));
  for (int k = 0; k < L.n_ma; ++k) theta[static_cast<size_t>(k)] = th[L.ma + 1 + k];
  return maAutocovariance(theta, std::exp(th[L.ma]));
}

double modelWvAt(const Layout& L, const Eigen::VectorXd& th, double tau) {
  double s = 0;
  if (L.wn >= 0) s += wvWhite(std::exp(th[L.wn]), tau);
  if (L.ma >= 0) s += wvShortMemory(maAcf(L, th), tau);
  if (L.qn >= 0) s += wvQuantization(std::exp(th[L.qn]), tau);
  if (L.rw >= 0) s += wvRandomWalk(std::exp(th[L.rw]), tau);
  if (L.dr >= 0) s += wvDrift(std::exp(th[L.dr]), tau);
  for (int i = 0; i < L.n_gm; ++i)
    s += std::exp(th[L.gm0 + 2 * i]) * ar1UnitWv(std::exp(-th[L.gm0 + 2 * i + 1]), tau);
  return s;
}

/// Two-sided spectrum (sample units, f in cycles/sample) of the stochastic part, sin2 = sin^2(pi f); ma_acf: the MA
/// term's autocovariance (maAcf, computed once by the caller).
double spectrum(const Layout& L, const Eigen::VectorXd& th, double f, double sin2, const std::vector<double>& ma_acf) {
  double s = 0;
  if (L.wn >= 0) s += std::exp(th[L.wn]);
  if (L.ma >= 0) {  // s2 |1 + sum theta_k e^{-i 2 pi f k}|^2 = gamma_0 + 2 sum gamma_h cos(2 pi f h)
    const std::vector<double>& g = ma_acf;
    double v = g[0];
    for (size_t h = 1; h < g.size(); ++h) v += 2.0 * g[h] * std::cos(2.0 * M_PI * f * static_cast<double>(h));
    s += std::max(v, 0.0);
  }
  if (L.qn >= 0) s += std::exp(th[L.qn]) * 4.0 * sin2;
  if (L.rw >= 0) s += std::exp(th[L.rw]) / (4.0 * sin2);
  for (int i = 0; i < L.n_gm; ++i) {
    const double v = std::exp(th[L.gm0 + 2 * i]);
    const double a = std::exp(-th[L.gm0 + 2 * i + 1]);
    const double phi = std::exp(-a), e = -std::expm1(-a);
    const double innov = v * e * (1.0 + phi);  // v (1 - phi^2)
    s += innov / (e * e + 4.0 * phi * sin2);
  }
  return s;
}

// 8-point Gauss-Legendre on [-1, 1].
const double kGlX[8] = {-0.9602898564975363, -0.7966664774136267, -0.5255324099163290, -0.1834346424956498,
                        0.1834346424956498,  0.5255324099163290,  0.7966664774136267,  0.9602898564975363};
const double kGlW[8] = {0.1012285362903763, 0.2223810344533745, 0.3137066458778873, 0.3626837833783620,
                        0.3626837833783620, 0.3137066458778873, 0.2223810344533745, 0.1012285362903763};

/// Mean over a period of sin^4(x) sin^4(2^d x) (d = 0: sin^8, 35/128); exact trapezoid on a trig polynomial.
double periodMean(int d) {
  if (d > 8) return 9.0 / 64.0;
  const int n = 1 << (d + 6);
  double s = 0;
  for (int i = 0; i < n; ++i) {
    const double x = M_PI * (i + 0.5) / n;
    const double a = std::sin(x), b = std::sin(std::ldexp(x, d));
    s += a * a * a * a * b * b * b * b;
  }
  return s / n;
}

}  // namespace

std::vector<double> gmwmModelWv(const WaveletVariance& wv, const GmwmModel& model, const Eigen::VectorXd& theta) {
  const Layout L(model);
  std::vector<double> out(wv.level.size());
  for (size_t j = 0; j < out.size(); ++j) out[j] = modelWvAt(L, theta, std::ldexp(1.0, wv.level[j]));
  return out;
}

std::vector<double> knownTermsWv(const WaveletVariance& wv, const std::vector<GmwmKnownTerm>& known) {
  std::vector<double> out(wv.level.size(), 0.0);
  for (const auto& k : known)
    for (size_t j = 0; j < out.size(); ++j)
      out[j] += k.c * k.basis(std::ldexp(wv.tau0, wv.level[j] - 1)) / 2.0;
  return out;
}

namespace {

/// Haar MODWT squared gain at level with half-length m, f in cycles/sample: sin^4(pi f m) / (m^2 sin^2(pi f)).
double haarGain(double f, double m) {
  const double s = std::sin(M_PI * f);
  if (std::fabs(s) < 1e-300) return 0.0;
  const double a = std::sin(M_PI * f * m);
  return a * a * a * a / (m * m * s * s);
}

/// gmwmKnownCovariance on a layout.
Eigen::MatrixXd knownCovariance(const WaveletVariance& wv, const Layout& L, const Eigen::VectorXd& th,
                                const std::vector<GmwmKnownTerm>& known);

}  // namespace

Eigen::MatrixXd gmwmCovariance(const WaveletVariance& wv, const GmwmModel& model, const Eigen::VectorXd& theta) {
  const Layout L(model);
  const int J = static_cast<int>(wv.level.size());
  Eigen::MatrixXd C = Eigen::MatrixXd::Zero(J, J);
  const std::vector<double> ma_acf = L.ma >= 0 ? maAcf(L, theta) : std::vector<double>();
  static const std::vector<double> cmean = [] {
    std::vector<double> c;
    for (int d = 0; d <= 9; ++d) c.push_back(periodMean(d));
    return c;
  }();
  const double kPeriods = 32;
  for (int a = 0; a < J; ++a)
    for (int b = a; b < J; ++b) {
      const double mj = std::ldexp(1.0, wv.level[a] - 1), mk = std::ldexp(1.0, wv.level[b] - 1);
      const int d = wv.level[b] - wv.level[a];
      // envelope E(f) = S(f)^2 / (mj^2 mk^2 sin^4(pi f)); integrand = sin^4(pi f mj) sin^4(pi f mk) E(f)
      auto envelope = [&](double f, double* s2out) {
        const double sn = std::sin(M_PI * f), s2 = sn * sn;
        const double S = spectrum(L, theta, f, s2, ma_acf);
        if (s2out) *s2out = s2;
        return S * S / (mj * mj * mk * mk * s2 * s2);
      };
      auto full = [&](double f) {
        const double a4 = std::pow(std::sin(M_PI * f * mj), 4), b4 = std::pow(std::sin(M_PI * f * mk), 4);
        return a4 * b4 * envelope(f, nullptr);
      };
      auto slowOnly = [&](double f) {  // fast factor replaced by its mean 3/8
        return std::pow(std::sin(M_PI * f * mj), 4) * 0.375 * envelope(f, nullptr);
      };
      auto panels = [&](double f_from, double f_to, double width, auto&& g) {
        double s = 0;
        for (double lo = f_from; lo < f_to - 1e-300; lo += width) {
          const double hi = std::min(lo + width, f_to), c = 0.5 * (lo + hi), h = 0.5 * (hi - lo);
          for (int q = 0; q < 8; ++q) s += kGlW[q] * h * g(c + h * kGlX[q]);
        }
        return s;
      };
      double integral = 0, f_done;
      if (d <= 4) {
        f_done = std::min(0.5, kPeriods / mj);
        integral += panels(0.0, f_done, 1.0 / mk, full);
      } else {
        const double f0 = std::min(0.5, kPeriods / mk);
        integral += panels(0.0, f0, 1.0 / mk, full);
        f_done = std::min(0.5, kPeriods / mj);
        if (f_done > f0) integral += panels(f0, f_done, 1.0 / mj, slowOnly);
      }
      if (f_done < 0.5) {  // both factors averaged over their common period; envelope on a log grid
        const double c = cmean[static_cast<size_t>(std::min(d, 9))];
        const int np = 48;
        const double l0 = std::log(f_done), l1 = std::log(0.5);
        double s = 0;
        for (int i = 0; i < np; ++i) {
          const double lo = l0 + (l1 - l0) * i / np, hi = l0 + (l1 - l0) * (i + 1) / np;
          const double cc = 0.5 * (lo + hi), h = 0.5 * (hi - lo);
          for (int q = 0; q < 8; ++q) {
            const double f = std::exp(cc + h * kGlX[q]);
            s += kGlW[q] * h * f * envelope(f, nullptr);
          }
        }
        integral += c * s;
      }
      const double Mj = static_cast<double>(wv.n_coeffs[a]), Mk = static_cast<double>(wv.n_coeffs[b]);
      const double v = 2.0 * std::min(Mj, Mk) / (Mj * Mk) * 2.0 * integral;
      C(a, b) = C(b, a) = v;
    }
  return C;
}

namespace {

Eigen::MatrixXd knownCovariance(const WaveletVariance& wv, const Layout& L, const Eigen::VectorXd& th,
                                const std::vector<GmwmKnownTerm>& known) {
  const int J = static_cast<int>(wv.level.size());
  Eigen::MatrixXd C = Eigen::MatrixXd::Zero(J, J);
  const std::vector<double> ma_acf = L.ma >= 0 ? maAcf(L, th) : std::vector<double>();
  for (const auto& k : known) {
    for (size_t i = 0; i < k.spectrum_hz.size(); ++i) {
      const double f = k.spectrum_hz[i] * wv.tau0;  // cycles/sample
      if (!(f > 0) || f >= 0.5) continue;
      const double p = k.c * k.spectrum_weight[i] / 2.0;
      const double sn = std::sin(M_PI * f);
      const double Se = spectrum(L, th, f, sn * sn, ma_acf);
      const double w = k.spectrum_bin_hz * wv.tau0;
      const double self = k.stochastic() && w > 0 ? p * p / (2.0 * w) : 0.0;
      std::vector<double> G(static_cast<size_t>(J));
      for (int a = 0; a < J; ++a) G[static_cast<size_t>(a)] = haarGain(f, std::ldexp(1.0, wv.level[a] - 1));
      for (int a = 0; a < J; ++a)
        for (int b = a; b < J; ++b) {
          const double Ma = static_cast<double>(wv.n_coeffs[a]), Mb = static_cast<double>(wv.n_coeffs[b]);
          const double v = 2.0 * std::min(Ma, Mb) / (Ma * Mb) * G[static_cast<size_t>(a)] *
                           G[static_cast<size_t>(b)] * (2.0 * p * Se + self);
          C(a, b) += v;
          if (b != a) C(b, a) += v;
        }
    }
  }
  return C;
}

}  // namespace

Eigen::MatrixXd gmwmKnownCovariance(const WaveletVariance& wv, const GmwmModel& model, const Eigen::VectorXd& theta,
                                    const std::vector<GmwmKnownTerm>& known) {
  return knownCovariance(wv, Layout(model), theta, known);
}

namespace {

struct Problem {
  const WaveletVariance* wv;
  Layout L;
  // Known terms: WV per unit c at each level (J x K), refitted from theta[L.p + k] as log c, or a fixed sum kfix.
  std::vector<GmwmKnownTerm> known;
  bool refit = false;
  Eigen::MatrixXd kb;
  Eigen::VectorXd kfix;
  Eigen::VectorXd y;   // nu_hat
  Eigen::MatrixXd Winv_chol_inv;  // whitening: r_w = T r with T' T = W
  Eigen::VectorXd lo, hi;         // parameter bounds
};

/// Model WV at level index j: the stochastic terms plus the known terms.
double problemWv(const Problem& P, const Eigen::VectorXd& th, int j) {
  double v = modelWvAt(P.L, th, std::ldexp(1.0, P.wv->level[j]));
  if (P.refit) {
    for (int k = 0; k < P.kb.cols(); ++k) v += std::exp(th[P.L.p + k]) * P.kb(j, k);
  } else if (P.kfix.size() > 0) {
    v += P.kfix[j];
  }
  return v;
}

/// The known terms with c taken from th (refit) or as given.
std::vector<GmwmKnownTerm> knownAt(const Problem& P, const Eigen::VectorXd& th) {
  std::vector<GmwmKnownTerm> k = P.known;
  if (P.refit)
    for (size_t i = 0; i < k.size(); ++i) k[i].c = std::exp(th[P.L.p + static_cast<int>(i)]);
  return k;
}

/// Omega at th: the stochastic terms' model-based covariance plus the known terms' part.
Eigen::MatrixXd problemCovariance(const Problem& P, const GmwmModel& model, const Eigen::VectorXd& th) {
  Eigen::MatrixXd C = gmwmCovariance(*P.wv, model, th);
  if (!P.known.empty()) C += knownCovariance(*P.wv, P.L, th, knownAt(P, th));
  return C;
}

Eigen::VectorXd residual(const Problem& P, const Eigen::VectorXd& th) {
  const int J = static_cast<int>(P.y.size());
  Eigen::VectorXd r(J);
  for (int j = 0; j < J; ++j) r[j] = P.y[j] - problemWv(P, th, j);
  return P.Winv_chol_inv * r;
}

Eigen::MatrixXd jacobian(const Problem& P, const Eigen::VectorXd& th) {
  // d(model)/d(theta) (unwhitened), central differences on the log parameters.
  const int J = static_cast<int>(P.y.size());
  Eigen::MatrixXd D(J, th.size());
  for (int k = 0; k < th.size(); ++k) {
    Eigen::VectorXd tp = th, tm = th;
    const double h = 1e-5;
    tp[k] += h;
    tm[k] -= h;
    for (int j = 0; j < J; ++j) D(j, k) = (problemWv(P, tp, j) - problemWv(P, tm, j)) / (2 * h);
  }
  return D;
}

double levenbergMarquardt(const Problem& P, Eigen::VectorXd* th, int max_iter, int* iters) {
  Eigen::VectorXd x = th->cwiseMax(P.lo).cwiseMin(P.hi);
  Eigen::VectorXd r = residual(P, x);
  double cost = r.squaredNorm();
  double lambda = 1e-3;
  int it = 0;
  for (; it < max_iter; ++it) {
    const Eigen::MatrixXd Jw = -(P.Winv_chol_inv * jacobian(P, x));
    const Eigen::MatrixXd A = Jw.transpose() * Jw;
    const Eigen::VectorXd g = Jw.transpose() * r;
    bool improved = false;
    for (int tries = 0; tries < 12; ++tries) {
      Eigen::MatrixXd Ad = A;
      for (int k = 0; k < A.rows(); ++k) Ad(k, k) += lambda * (A(k, k) + 1e-12);
      const Eigen::VectorXd step = Ad.ldlt().solve(-g);
      if (!step.allFinite()) {
        lambda *= 10;
        continue;
      }
      Eigen::VectorXd xn = (x + step).cwiseMax(P.lo).cwiseMin(P.hi);
      const Eigen::VectorXd rn = residual(P, xn);
      const double cn = rn.squaredNorm();
      if (std::isfinite(cn) && cn < cost) {
        const double rel = (cost - cn) / std::max(cost, 1e-300);
        x = xn;
        r = rn;
        cost = cn;
        lambda = std::max(lambda / 3, 1e-9);
        improved = true;
        if (rel < 1e-10) it = max_iter;  // converged
        break;
      }
      lambda *= 10;
    }
    if (!improved) break;
  }
  *th = x;
  if (iters) *iters += it;
  return cost;
}

void setWeights(Problem* P, const Eigen::MatrixXd& omega) {
  // W = Omega^-1; whitening T = L^-1 with Omega = L L'.
  Eigen::LLT<Eigen::MatrixXd> llt(omega);
  const int J = static_cast<int>(omega.rows());
  if (llt.info() != Eigen::Success) {
    Eigen::MatrixXd d = Eigen::MatrixXd::Zero(J, J);
    for (int j = 0; j < J; ++j) d(j, j) = 1.0 / std::sqrt(std::max(omega(j, j), 1e-300));
    P->Winv_chol_inv = d;
    return;
  }
  P->Winv_chol_inv = llt.matrixL().solve(Eigen::MatrixXd::Identity(J, J));
}

double nearestNu(const WaveletVariance& wv, double tau_samples) {
  size_t best = 0;
  for (size_t j = 0; j < wv.level.size(); ++j)
    if (std::fabs(std::log(std::ldexp(1.0, wv.level[j]) / tau_samples)) <
        std::fabs(std::log(std::ldexp(1.0, wv.level[best]) / tau_samples)))
      best = j;
  return wv.nu2[best];
}

/// The fitting problem of `model` on `wv`: data, log-parameter bounds and first-pass (diagonal) weights.
Problem makeProblem(const WaveletVariance& wv, const Layout& L, const GmwmOptions& options) {
  const int J = static_cast<int>(wv.level.size());
  Problem P;
  P.wv = &wv;
  P.L = L;
  P.known = options.known;
  const int K = static_cast<int>(P.known.size());
  P.refit = options.refit_known && K > 0;
  if (K > 0) {
    P.kb = Eigen::MatrixXd::Zero(J, K);
    for (int k = 0; k < K; ++k)
      for (int j = 0; j < J; ++j)
        P.kb(j, k) = P.known[static_cast<size_t>(k)].basis(std::ldexp(wv.tau0, wv.level[j] - 1)) / 2.0;
    if (!P.refit) {
      P.kfix = Eigen::VectorXd::Zero(J);
      for (int k = 0; k < K; ++k) P.kfix += P.known[static_cast<size_t>(k)].c * P.kb.col(k);
    }
  }
  const int np = L.p + (P.refit ? K : 0);
  P.y = Eigen::Map<const Eigen::VectorXd>(wv.nu2.data(), J);
  const double tau_max = std::ldexp(1.0, wv.level.back());
  const double nu_scale = *std::max_element(wv.nu2.begin(), wv.nu2.end());
  const double tiny = std::log(nu_scale * 1e-14), huge = std::log(nu_scale * 1e8 * tau_max);
  P.lo = Eigen::VectorXd::Constant(np, tiny - std::log(tau_max * tau_max));
  P.hi = Eigen::VectorXd::Constant(np, huge);
  if (P.refit)  // a known term's c within 10^-6..10^3 of the model check's
    for (int k = 0; k < K; ++k) {
      const double c0 = std::max(P.known[static_cast<size_t>(k)].c, 1e-300);
      P.lo[L.p + k] = std::log(c0) - 6 * std::log(10.0);
      P.hi[L.p + k] = std::log(c0) + 3 * std::log(10.0);
    }
  for (int i = 0; i < L.n_gm; ++i) {
    P.lo[L.gm0 + 2 * i + 1] = std::log(0.25);                  // correlation time >= a quarter sample
    P.hi[L.gm0 + 2 * i + 1] = std::log(4.0 * static_cast<double>(wv.n));  // <= 4 record lengths
  }
  // MA coefficients: |theta_k| <= binomial(q, k), a box holding every invertible MA(q) (roots of 1 + sum theta_k z^k
  // outside the unit disc: its coefficients are bounded by those of (1 + z)^q). Every non-negative spectrum of
  // degree q has an invertible factorization (Fejer-Riesz), so the box loses no autocovariance.
  for (int k = 1; k <= L.n_ma; ++k) {
    double binom = 1;
    for (int i = 1; i <= k; ++i) binom = binom * (L.n_ma - k + i) / i;
    P.lo[L.ma + k] = -binom;
    P.hi[L.ma + k] = binom;
  }
  // First pass: diagonal weights from the data's own WV (2 nu_hat^4 / eta).
  {
    Eigen::MatrixXd d = Eigen::MatrixXd::Zero(J, J);
    for (int j = 0; j < J; ++j) d(j, j) = std::sqrt(wv.eta[j] / 2.0) / wv.nu2[j];
    P.Winv_chol_inv = d;
  }
  return P;
}

/// The GM correlation-time combinations (in samples) the starting values are placed at, one vector per start.
std::vector<std::vector<double>> startCombos(const WaveletVariance& wv, const Layout& L) {
  std::vector<double> tcs;
  for (int j = 1; j <= wv.level.back() - 1; j += 2) tcs.push_back(std::ldexp(1.0, j) / 2.0);
  if (tcs.empty()) tcs.push_back(1.0);
  std::vector<std::vector<double>> combos;
  if (L.n_gm == 0) combos.push_back({});
  else {
    std::vector<int> idx(static_cast<size_t>(L.n_gm));
    const int T = static_cast<int>(tcs.size());
    std::function<void(int, int)> rec = [&](int pos, int from) {
      if (pos == L.n_gm) {
        std::vector<double> c;
        for (int i : idx) c.push_back(tcs[static_cast<size_t>(i)]);
        combos.push_back(c);
        return;
      }
      for (int i = from; i < T; ++i) {
        idx[static_cast<size_t>(pos)] = i;
        rec(pos + 1, i + 1);
      }
    };
    rec(0, 0);
    if (combos.empty()) {  // more GMs than grid points: spread them anyway
      std::vector<double> c;
      for (int i = 0; i < L.n_gm; ++i) c.push_back(std::ldexp(1.0, 2 * i));
      combos.push_back(c);
    }
  }
  return combos;
}

/// The best estimate from many starting values (one per combination), refined under the first-pass weights.
Eigen::VectorXd bestStart(const Problem& P, const WaveletVariance& wv, const GmwmModel& model,
                          const std::vector<std::vector<double>>& combos, int* iters) {
  const Layout& L = P.L;
  const double tau_max = std::ldexp(1.0, wv.level.back());
  double best_cost = std::numeric_limits<double>::infinity();
  Eigen::VectorXd best;
  std::vector<std::pair<double, Eigen::VectorXd>> starts;
  for (const auto& c : combos) {
    Eigen::VectorXd th(P.lo.size());
    for (int k = L.p; k < th.size(); ++k) th[k] = std::log(std::max(P.known[static_cast<size_t>(k - L.p)].c, 1e-300));
    const double share = 1.0 / (1 + L.n_gm + (model.random_walk ? 1 : 0));
    if (L.wn >= 0) th[L.wn] = std::log(2.0 * wv.nu2[0] * 0.9);
    if (L.ma >= 0) {  // white start: innovation as WN, theta = 0
      th[L.ma] = std::log(2.0 * wv.nu2[0] * 0.9);
      for (int k = 1; k <= L.n_ma; ++k) th[L.ma + k] = 0.0;
    }
    if (L.qn >= 0) th[L.qn] = std::log(wv.nu2[0] * 4.0 / 6.0 * 0.1);
    if (L.rw >= 0) th[L.rw] = std::log(12.0 * wv.nu2.back() / tau_max * share);
    if (L.dr >= 0) th[L.dr] = std::log(16.0 * wv.nu2.back() / (tau_max * tau_max) * share);
    for (int i = 0; i < L.n_gm; ++i) {
      const double tc = c[static_cast<size_t>(i)];
      const double peak = ar1UnitWv(1.0 / tc, std::max(2.0, 4.0 * tc));
      th[L.gm0 + 2 * i] = std::log(nearestNu(wv, 4.0 * tc) / peak * share);
      th[L.gm0 + 2 * i + 1] = std::log(tc);
    }
    starts.push_back({levenbergMarquardt(P, &th, combos.size() > 3 ? 25 : 200, iters), th});
  }
  // Many starts: each ran a short refinement; the best three are refined fully.
  std::sort(starts.begin(), starts.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  for (size_t i = 0; i < std::min<size_t>(3, starts.size()); ++i) {
    Eigen::VectorXd th = starts[i].second;
    const double cost = combos.size() > 3 ? levenbergMarquardt(P, &th, 200, iters) : starts[i].first;
    if (cost < best_cost) {
      best_cost = cost;
      best = th;
    }
  }
  return best;
}

/// `best` with its GM terms sorted by correlation time.
Eigen::VectorXd sortGaussMarkov(const Layout& L, const Eigen::VectorXd& best) {
  Eigen::VectorXd theta = best;
  std::vector<std::pair<double, double>> g;
  for (int i = 0; i < L.n_gm; ++i) g.push_back({best[L.gm0 + 2 * i + 1], best[L.gm0 + 2 * i]});
  std::sort(g.begin(), g.end());
  for (int i = 0; i < L.n_gm; ++i) {
    theta[L.gm0 + 2 * i] = g[static_cast<size_t>(i)].second;
    theta[L.gm0 + 2 * i + 1] = g[static_cast<size_t>(i)].first;
  }
  return theta;
}

/// Covariance of the log parameters at `theta` under the problem's current weights.
Eigen::MatrixXd parameterCovariance(const Problem& P, const Eigen::VectorXd& theta) {
  const int p = static_cast<int>(theta.size());
  const Eigen::MatrixXd Jw = P.Winv_chol_inv * jacobian(P, theta);
  const Eigen::MatrixXd info = Jw.transpose() * Jw;
  // Pseudo-inverse in correlation form: a direction the data do not inform (a term at its bound) gets an
  // effectively infinite variance instead of whatever a near-singular solve returns.
  Eigen::VectorXd d(p);
  for (int k = 0; k < p; ++k) d[k] = info(k, k) > 0 ? 1.0 / std::sqrt(info(k, k)) : 1e150;
  const Eigen::MatrixXd Cn = d.asDiagonal() * info * d.asDiagonal();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(Cn);
  Eigen::VectorXd inv = es.eigenvalues();
  for (int k = 0; k < p; ++k) inv[k] = inv[k] > 1e-10 ? 1.0 / inv[k] : 1e20;
  return d.asDiagonal() * (es.eigenvectors() * inv.asDiagonal() * es.eigenvectors().transpose()) * d.asDiagonal();
}

/// Standard deviation of log parameter k of `fit`.
double logSd(const GmwmFit& fit, int k) { return std::sqrt(std::max(fit.theta_cov(k, k), 0.0)); }

/// The SI coefficients of `fit` and their 1-sigma, from its theta, theta_cov and tau0.
void fillSiValues(const Layout& L, GmwmFit* fit) {
  // SI values; sd of exp(theta/2)-type quantities by the delta method.
  const double t0 = fit->tau0;
  if (L.wn >= 0) {
    fit->N = std::sqrt(std::exp(fit->theta[L.wn]) * t0);
    fit->N_sd = fit->N * logSd(*fit, L.wn) / 2;
  }
  if (L.ma >= 0) {
    // Innovation density sqrt(s2 tau0); long-run ARW N = that * |1 + sum theta| (S(0) = s2 (1 + sum theta)^2), its
    // log-sd from the gradient of log N: 1/2 on log s2, 1 / (1 + sum theta) on each theta.
    fit->ma_innovation = std::sqrt(std::exp(fit->theta[L.ma]) * t0);
    fit->ma_innovation_sd = fit->ma_innovation * logSd(*fit, L.ma) / 2;
    double sum = 1;
    for (int k = 1; k <= L.n_ma; ++k) {
      fit->ma.push_back(fit->theta[L.ma + k]);
      fit->ma_sd.push_back(logSd(*fit, L.ma + k));
      sum += fit->theta[L.ma + k];
    }
    fit->N = fit->ma_innovation * std::fabs(sum);
    Eigen::VectorXd grad = Eigen::VectorXd::Zero(fit->theta.size());
    grad[L.ma] = 0.5;
    for (int k = 1; k <= L.n_ma; ++k) grad[L.ma + k] = 1.0 / sum;
    fit->N_sd = fit->N * std::sqrt(std::max((grad.transpose() * fit->theta_cov * grad)(0, 0), 0.0));
  }
  if (L.qn >= 0) {
    fit->Q = std::sqrt(std::exp(fit->theta[L.qn])) * t0;
    fit->Q_sd = fit->Q * logSd(*fit, L.qn) / 2;
  }
  if (L.rw >= 0) {
    fit->K = std::sqrt(std::exp(fit->theta[L.rw]) / t0);
    fit->K_sd = fit->K * logSd(*fit, L.rw) / 2;
  }
  if (L.dr >= 0) {
    fit->R = std::sqrt(std::exp(fit->theta[L.dr])) / t0;
    fit->R_sd = fit->R * logSd(*fit, L.dr) / 2;
  }
  for (int i = 0; i < L.n_gm; ++i) {
    GaussMarkovTerm g;
    g.sigma = std::sqrt(std::exp(fit->theta[L.gm0 + 2 * i]));
    g.sigma_sd = g.sigma * logSd(*fit, L.gm0 + 2 * i) / 2;
    g.tc = std::exp(fit->theta[L.gm0 + 2 * i + 1]) * t0;
    g.tc_sd = g.tc * logSd(*fit, L.gm0 + 2 * i + 1);
    fit->gm.push_back(g);
  }
}

/// Sets fit->identified and names in fit->unidentified the coloured terms whose log sd is not below max_log_sd.
void checkIdentified(const Layout& L, double max_log_sd, GmwmFit* fit) {
  fit->identified = true;
  auto check = [&](int k, const std::string& what) {
    if (k >= 0 && !(logSd(*fit, k) < max_log_sd)) {
      fit->identified = false;
      fit->unidentified += (fit->unidentified.empty() ? "" : ", ") + what;
    }
  };
  // WN is every model's base term and QN a sensor property: selection is among the coloured terms, so only those must
  // be supported (a WN traded against a sub-sample GM, as on sensors with an internal low-pass, is no reason to
  // reject the model).
  // MA(q): its order is supported when the last coefficient lies more than 2 sigma from zero (theta is not a log:
  // the same test as "a variance more than 2 sigma above zero" for the others).
  if (L.ma >= 0 && !(std::fabs(fit->theta[L.ma + L.n_ma]) > 2.0 * logSd(*fit, L.ma + L.n_ma))) {
    fit->identified = false;
    fit->unidentified += (fit->unidentified.empty() ? "" : ", ") + std::string("MA") + std::to_string(L.n_ma) +
                         " theta" + std::to_string(L.n_ma);
  }
  check(L.rw, "RW");
  check(L.dr, "DR");
  for (int i = 0; i < L.n_gm; ++i) {
    check(L.gm0 + 2 * i, "GM" + std::to_string(i + 1) + " sigma");
    check(L.gm0 + 2 * i + 1, "GM" + std::to_string(i + 1) + " tc");
  }
}

}  // namespace

GmwmFit fitGmwm(const WaveletVariance& wv, const GmwmModel& model, const GmwmOptions& options) {
  GmwmFit fit;
  fit.model = model;
  const Layout L(model);
  const int J = static_cast<int>(wv.level.size());
  if (L.p == 0) {
    fit.message = "model has no term";
    return fit;
  }
  const int np = L.p + (options.refit_known ? static_cast<int>(options.known.size()) : 0);
  if (J <= np) {
    fit.message = "too few wavelet levels (" + std::to_string(J) + ") for " + std::to_string(np) + " parameters";
    return fit;
  }
  for (const auto& k : options.known)
    if (!k.basis || !(k.c > 0) || !std::isfinite(k.c) || k.spectrum_hz.size() != k.spectrum_weight.size()) {
      fit.message = "known term '" + k.type + "' has no basis, a non-positive c or inconsistent spectrum";
      return fit;
    }
  for (double v : wv.nu2)
    if (!(v > 0) || !std::isfinite(v)) {
      fit.message = "a wavelet variance is zero or not finite (constant or broken data)";
      return fit;
    }
  Problem P = makeProblem(wv, L, options);
  // Robust starting values: WN from level 1, RW from the last level, GMs placed over a grid of correlation times with
  // their variance from the WV near their peak scale (~4 tc); every combination is refined, the best kept.
  int iters = 0;
  Eigen::VectorXd best = bestStart(P, wv, model, startCombos(wv, L), &iters);
  // Efficient weighting: Omega at the current estimate, refit, repeat.
  Eigen::MatrixXd omega;
  for (int k = 0; k < std::max(1, options.weighting_iterations); ++k) {
    omega = problemCovariance(P, model, best);
    setWeights(&P, omega);
    levenbergMarquardt(P, &best, 200, &iters);
  }
  omega = problemCovariance(P, model, best);
  setWeights(&P, omega);
  const Eigen::VectorXd rw = residual(P, best);
  fit.chi2 = rw.squaredNorm();
  fit.tau0 = wv.tau0;
  fit.iterations = iters;
  // Sort GMs by correlation time.
  fit.theta = sortGaussMarkov(L, best);
  fit.theta_cov = parameterCovariance(P, fit.theta);
  fit.dof = J - np;
  fit.chi2_p = fit.dof > 0 ? boost::math::cdf(boost::math::complement(boost::math::chi_squared(fit.dof), fit.chi2)) : 1.0;
  fit.criterion = fit.chi2 + options.penalty_per_parameter * np;
  fit.model_nu2.resize(static_cast<size_t>(J));
  for (int j = 0; j < J; ++j) fit.model_nu2[static_cast<size_t>(j)] = problemWv(P, fit.theta, j);
  fit.known = knownAt(P, fit.theta);
  if (P.refit)
    for (size_t k = 0; k < fit.known.size(); ++k)
      fit.known[k].c_sd = fit.known[k].c * logSd(fit, L.p + static_cast<int>(k));
  fillSiValues(L, &fit);
  checkIdentified(L, options.max_log_sd, &fit);
  fit.ok = fit.theta.allFinite() && std::isfinite(fit.chi2);
  if (!fit.ok) fit.message = "the fit did not converge to finite values";
  return fit;
}

GmwmSelection selectGmwm(const WaveletVariance& wv, const GmwmOptions& options) {
  std::vector<GmwmModel> cands = options.candidates;
  if (cands.empty()) {
    auto base = [&](int k, bool rw) {
      GmwmModel m;
      m.gauss_markov = k;
      m.random_walk = rw;
      m.quantization = options.quantization;
      m.drift = options.drift;
      return m;
    };
    cands.push_back(base(0, true));
    for (int k = 1; k <= options.max_gm; ++k) {
      cands.push_back(base(k, false));
      cands.push_back(base(k, true));
    }
  }
  GmwmSelection sel;
  for (const auto& m : cands) sel.fits.push_back(fitGmwm(wv, m, options));
  auto pick = [&sel]() {
    sel.best = -1;
    for (int pass = 0; pass < 2 && sel.best < 0; ++pass)
      for (size_t i = 0; i < sel.fits.size(); ++i) {
        const GmwmFit& f = sel.fits[i];
        if (!f.ok || (pass == 0 && !f.identified)) continue;
        if (sel.best < 0 || f.criterion < sel.fits[static_cast<size_t>(sel.best)].criterion)
          sel.best = static_cast<int>(i);
      }
  };
  pick();
  // Short-memory measurement noise, forward in the order: the WN candidates with at most as many GM terms as the
  // selected WN model again with MA(q) for WN (the MA describes short lags a WN model needs a GM for; it never asks
  // for an extra GM), q = 1, 2, ..., while the best criterion among order q's fits (identified or not: a sub-sample GM
  // standing in for the filter makes some unidentified) beats order q-1's (default candidate lists only).
  if (options.candidates.empty() && sel.best >= 0) {
    const int max_gm = sel.chosen().model.gauss_markov;
    std::vector<GmwmModel> white_cands;
    for (const auto& m : cands)
      if (m.white && m.gauss_markov <= max_gm) white_cands.push_back(m);
    auto bestOfOrder = [&sel](int q) {
      double b = std::numeric_limits<double>::infinity();
      for (const auto& f : sel.fits)
        if (f.ok && f.model.moving_average == q && (q > 0 || f.model.white)) b = std::min(b, f.criterion);
      return b;
    };
    for (int q = 1; q <= options.max_ma; ++q) {
      for (GmwmModel m : white_cands) {
        m.white = false;
        m.moving_average = q;
        sel.fits.push_back(fitGmwm(wv, m, options));
      }
      if (!(bestOfOrder(q) < bestOfOrder(q - 1))) break;
    }
    pick();
  }
  return sel;
}

// ---- Model AVAR and discretization ---------------------------------------------------------------------------------

double gmwmModelWvAt(const GmwmFit& fit, double tau0, int level) {
  double v = modelWvAt(Layout(fit.model), fit.theta, std::ldexp(1.0, level));
  for (const auto& k : fit.known) v += k.c * k.basis(std::ldexp(tau0, level - 1)) / 2.0;
  return v;
}

double gmwmModelAvar(const GmwmFit& fit, double tau0, int64_t m) {
  if (m < 1) throw std::invalid_argument("gmwmModelAvar: m must be >= 1");
  double v = 2.0 * modelWvAt(Layout(fit.model), fit.theta, 2.0 * static_cast<double>(m));
  for (const auto& k : fit.known) v += k.c * k.basis(static_cast<double>(m) * tau0);
  return v;
}

std::vector<double> simulateGmwmFit(const GmwmFit& fit, double tau0, int64_t n, uint64_t seed) {
  if (!(tau0 > 0) || n < 1) throw std::invalid_argument("simulateGmwmFit: tau0 > 0 and n >= 1 needed");
  const Layout L(fit.model);
  const Eigen::VectorXd& th = fit.theta;
  if (th.size() < L.p) throw std::invalid_argument("simulateGmwmFit: theta does not match the model");
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> nd;
  std::vector<double> x(static_cast<size_t>(n), 0.0);
  // Parameters are per sample (sample units), as fitted.
  const double wn = L.wn >= 0 ? std::sqrt(std::exp(th[L.wn])) : 0.0;
  const double ma = L.ma >= 0 ? std::sqrt(std::exp(th[L.ma])) : 0.0;
  const double qn = L.qn >= 0 ? std::sqrt(std::exp(th[L.qn])) : 0.0;
  const double rw = L.rw >= 0 ? std::sqrt(std::exp(th[L.rw])) : 0.0;
  const double dr = L.dr >= 0 ? std::sqrt(std::exp(th[L.dr])) : 0.0;
  std::vector<double> phi, inn, state, past(static_cast<size_t>(L.n_ma), 0.0);
  for (int i = 0; i < L.n_gm; ++i) {
    const double v = std::exp(th[L.gm0 + 2 * i]), a = std::exp(-th[L.gm0 + 2 * i + 1]);
    phi.push_back(std::exp(-a));
    inn.push_back(std::sqrt(v * -std::expm1(-2 * a)));
    state.push_back(std::sqrt(v) * nd(rng));
  }
  for (auto& e : past) e = ma * nd(rng);
  double walk = 0, q_prev = qn * nd(rng);
  for (int64_t t = 0; t < n; ++t) {
    double y = 0;
    if (L.wn >= 0) y += wn * nd(rng);
    if (L.ma >= 0) {
      const double e = ma * nd(rng);
      y += e;
      for (int k = 0; k < L.n_ma; ++k) y += th[L.ma + 1 + k] * past[static_cast<size_t>(k)];
      for (int k = L.n_ma - 1; k > 0; --k) past[static_cast<size_t>(k)] = past[static_cast<size_t>(k - 1)];
      if (L.n_ma > 0) past[0] = e;
    }
    if (L.qn >= 0) {
      const double q = qn * nd(rng);
      y += q - q_prev;
      q_prev = q;
    }
    for (size_t i = 0; i < phi.size(); ++i) y += (state[i] = phi[i] * state[i] + inn[i] * nd(rng));
    if (L.rw >= 0) y += (walk += rw * nd(rng));
    if (L.dr >= 0) y += dr * static_cast<double>(t);
    x[static_cast<size_t>(t)] = y;
  }
  // Known terms (drawn after the stochastic terms: a fit without them simulates exactly as before).
  std::uniform_real_distribution<double> ud(0.0, 2.0 * M_PI);
  for (const auto& k : fit.known) {
    if (!k.stochastic()) {  // deterministic lines: sqrt(c w_i) sin(2 pi f_i t + phase_i), random phase
      for (size_t i = 0; i < k.spectrum_hz.size(); ++i) {
        const double A = std::sqrt(k.c * k.spectrum_weight[i]), w = 2.0 * M_PI * k.spectrum_hz[i] * tau0;
        const double ph = ud(rng);
        for (int64_t t = 0; t < n; ++t) x[static_cast<size_t>(t)] += A * std::sin(w * static_cast<double>(t) + ph);
      }
      continue;
    }
    // Narrowband: a stationary Gaussian process with the term's spectrum, by inverse FFT over N >= n samples:
    // x_t = sum_k a_k cos(2 pi k t / N) + b_k sin(2 pi k t / N), a_k, b_k ~ N(0, s_k^2), the power c w_i / 2 of
    // component i spread evenly over the FFT bins inside its bin (or put in the nearest FFT bin when narrower).
    int64_t N = 1;
    while (N < n) N *= 2;
    const double dfN = 1.0 / (static_cast<double>(N) * tau0);
    std::vector<double> var(static_cast<size_t>(N / 2 + 1), 0.0);
    for (size_t i = 0; i < k.spectrum_hz.size(); ++i) {
      const double p = k.c * k.spectrum_weight[i] / 2.0, f = k.spectrum_hz[i], w = k.spectrum_bin_hz;
      const int64_t a = std::max<int64_t>(1, static_cast<int64_t>(std::ceil((f - w / 2) / dfN)));
      const int64_t b = std::min<int64_t>(N / 2 - 1, static_cast<int64_t>(std::ceil((f + w / 2) / dfN)) - 1);
      if (b >= a) {
        for (int64_t q = a; q <= b; ++q) var[static_cast<size_t>(q)] += p / static_cast<double>(b - a + 1);
      } else {
        const int64_t q = std::min<int64_t>(N / 2 - 1, std::max<int64_t>(1, std::llround(f / dfN)));
        var[static_cast<size_t>(q)] += p;
      }
    }
    std::vector<std::complex<double>> X(static_cast<size_t>(N / 2 + 1));
    for (size_t q = 0; q < X.size(); ++q) {
      if (!(var[q] > 0)) continue;
      const double sd = std::sqrt(var[q]);
      X[q] = std::complex<double>(0.5 * static_cast<double>(N) * sd * nd(rng), -0.5 * static_cast<double>(N) * sd * nd(rng));
    }
    Eigen::FFT<double> fft;
    fft.SetFlag(Eigen::FFT<double>::HalfSpectrum);
    std::vector<double> y;
    fft.inv(y, X, static_cast<int>(N));
    for (int64_t t = 0; t < n; ++t) x[static_cast<size_t>(t)] += y[static_cast<size_t>(t)];
  }
  return x;
}

DiscreteNoiseModel discretize(const GmwmFit& fit, double dt) {
  if (!(dt > 0) || !std::isfinite(dt)) throw std::invalid_argument("discretize: dt must be > 0");
  DiscreteNoiseModel d;
  d.dt = dt;
  double folded_var = 0;
  int n_gm_states = 0;
  for (const auto& g : fit.gm) {
    if (g.tc < dt / 2) {
      // Long-run equivalent white noise of the sampled AR(1): sigma^2 tau0 (1 + phi0) / (1 - phi0) = N_eq^2.
      const double t0 = fit.tau0 > 0 ? fit.tau0 : dt;
      const double x = t0 / g.tc;
      const double neq2 = g.sigma * g.sigma * t0 * (2.0 - (-std::expm1(-x))) / (-std::expm1(-x));
      folded_var += neq2 / dt;
    } else {
      ++n_gm_states;
    }
  }
  if (fit.model.moving_average > 0) {
    // fit.N is the MA's long-run equivalent white noise (N^2 = S(0) tau0): right for the angle it integrates to over
    // many steps. The mean over one step of k = dt / tau0 > q samples has variance (S(0) - 2 sum_h h gamma_h / k) / k,
    // i.e. N^2 / dt is off by the fraction e = 2 sum_h h gamma_h / (k S(0)), and neighbouring steps correlate by about
    // e / 2 (the q-sample edges). Stated when |e| > 1 % or the step is within the memory (k <= q).
    const int q = fit.model.moving_average;
    d.folded.push_back("ma" + std::to_string(q));
    const double t0 = fit.tau0 > 0 ? fit.tau0 : dt;
    const double k = dt / t0;
    const std::vector<double> g = maAutocovariance(fit.ma, 1.0);
    double s0 = g[0], sh = 0;
    for (size_t h = 1; h < g.size(); ++h) {
      s0 += 2 * g[h];
      sh += static_cast<double>(h) * g[h];
    }
    const std::string name = "ma" + std::to_string(q);
    char buf[240];
    if (k <= q * (1 + 1e-9)) {
      std::snprintf(buf, sizeof buf,
                    "%s folded into white noise at a step of %.3g samples, within its memory (%d samples): right for "
                    "the integrated angle, not for one step's variance or its correlation with the next",
                    name.c_str(), k, q);
      d.approximation = buf;
    } else if (s0 > 0 && std::fabs(2 * sh / (k * s0)) > 0.01) {
      std::snprintf(buf, sizeof buf,
                    "%s folded into white noise: one step's variance is %.1f %% below measurement_variance's white "
                    "part and neighbouring steps correlate by ~%.3f",
                    name.c_str(), 100 * 2 * sh / (k * s0), sh / (k * s0));
      d.approximation = buf;
    }
  }
  const int n = n_gm_states + (fit.K > 0 ? 1 : 0);
  d.Phi = Eigen::MatrixXd::Zero(n, n);
  d.Qd = Eigen::MatrixXd::Zero(n, n);
  int k = 0;
  for (size_t i = 0; i < fit.gm.size(); ++i) {
    if (fit.gm[i].tc < dt / 2) {
      d.folded.push_back("gm" + std::to_string(i + 1));
      continue;
    }
    const double phi = std::exp(-dt / fit.gm[i].tc);
    d.Phi(k, k) = phi;
    d.Qd(k, k) = fit.gm[i].sigma * fit.gm[i].sigma * (-std::expm1(-2.0 * dt / fit.gm[i].tc));
    d.states.push_back("gm" + std::to_string(i + 1));
    ++k;
  }
  if (fit.K > 0) {
    d.Phi(k, k) = 1.0;
    d.Qd(k, k) = fit.K * fit.K * dt;
    d.states.push_back("rw");
  }
  d.white_variance = fit.N * fit.N / dt + folded_var;
  d.quantization_variance = 2.0 * fit.Q * fit.Q / (dt * dt);
  return d;
}

// ---- Closed loop and stage -------------------------------------------------------------------------------------------

CurveAgreement curveAgreement(const DeviationCurve& curve, const std::vector<double>& model_var, double tau_min,
                              double tau_max) {
  CurveAgreement c;
  c.tau_min = tau_min;
  c.tau_max = tau_max;
  double ss = 0;
  for (size_t i = 0; i < curve.points.size() && i < model_var.size(); ++i) {
    const DeviationPoint& p = curve.points[i];
    if (p.tau < tau_min * (1 - 1e-9) || p.tau > tau_max * (1 + 1e-9) || !(p.var > 0) || !(model_var[i] > 0)) continue;
    const double md = std::sqrt(model_var[i]);
    ++c.points;
    if (md >= p.dev_lo && md <= p.dev_hi) ++c.within_ci;
    const double r = md / p.dev, rr = std::max(r, 1 / r);
    if (rr > c.worst_ratio) {
      c.worst_ratio = rr;
      c.worst_tau = p.tau;
    }
    ss += std::pow(std::log10(p.dev / md), 2);
  }
  if (c.points > 0) c.rms_log10 = std::sqrt(ss / c.points);
  return c;
}

GmwmAxis gmwmStage(const std::vector<double>& rate, double tau0, const GmwmOptions& options) {
  GmwmAxis g;
  g.tau0 = tau0;
  g.record_s = static_cast<double>(rate.size()) * tau0;
  g.penalty_per_parameter = options.penalty_per_parameter;
  try {
    g.wv = haarWaveletVariance(rate, tau0, options.confidence);
  } catch (const std::exception& e) {
    g.message = std::string("wavelet variance: ") + e.what();
    return g;
  }
  g.selection = selectGmwm(g.wv, options);
  if (g.selection.best < 0) {
    g.message = "no candidate model could be fitted";
    for (const auto& f : g.selection.fits)
      if (!f.message.empty()) {
        g.message += " (" + f.model.name() + ": " + f.message + ")";
        break;
      }
    return g;
  }
  const GmwmFit& f = g.selection.chosen();
  for (size_t j = 0; j < g.wv.nu2.size(); ++j) {
    ++g.wv_points;
    if (f.model_nu2[j] >= g.wv.lo[j] && f.model_nu2[j] <= g.wv.hi[j]) ++g.wv_within_ci;
  }
  g.ok = true;
  return g;
}

std::vector<GmwmKnownTerm> knownTermsFromEffects(const std::vector<DetectedEffect>& effects,
                                                 const std::vector<double>& extra_c,
                                                 std::vector<LeftOutEffect>* left_out) {
  std::vector<GmwmKnownTerm> out;
  for (size_t i = 0; i < effects.size(); ++i) {
    const DetectedEffect& e = effects[i];
    const double c = i < extra_c.size() ? extra_c[i] : 0.0;
    if (e.type == "sinusoid" || e.type == "narrowband") {
      if (!(c > 0) || !e.term.basis || e.spectrum_hz.empty() || e.spectrum_hz.size() != e.spectrum_weight.size()) {
        if (left_out) left_out->push_back({e.type, "no positive amplitude or spectral content from the model check"});
        continue;
      }
      GmwmKnownTerm k;
      k.type = e.type;
      k.basis = e.term.basis;
      k.c = c;
      k.spectrum_hz = e.spectrum_hz;
      k.spectrum_weight = e.spectrum_weight;
      k.spectrum_bin_hz = e.spectrum_bin_hz;
      for (const auto& p : e.parameters) k.parameters[p.first] = p.second.value;
      out.push_back(k);
    } else if (left_out) {
      std::string why = "not stationary, no wavelet-variance term; not in this model";
      if (e.type == "gauss_markov") why = "not a known term, the GMWM's own GM terms model it";
      if (e.type == "short_correlation") why = "not a known term, the GMWM's own MA(q) measurement noise models it";
      left_out->push_back({e.type, why});
    }
  }
  return out;
}

void gmwmCompare(GmwmAxis* g, const DeviationCurve& oadev, const std::vector<double>& ieee_model_var,
                 const std::vector<double>& final_model_var) {
  if (!g || !g->ok) return;
  const GmwmFit& f = g->selection.chosen();
  std::vector<double> mv(oadev.points.size());
  for (size_t i = 0; i < mv.size(); ++i) mv[i] = gmwmModelAvar(f, g->tau0, std::max<int64_t>(1, oadev.points[i].m));
  const double t_lo = g->tau0, t_hi = g->record_s / 10;
  g->gmwm_vs_data = curveAgreement(oadev, mv, t_lo, t_hi);
  g->ieee_vs_data = curveAgreement(oadev, ieee_model_var, t_lo, t_hi);
  g->final_vs_data = curveAgreement(oadev, final_model_var.empty() ? ieee_model_var : final_model_var, t_lo, t_hi);
  g->worst_avar_ratio_vs_ieee = 1;
  for (size_t i = 0; i < mv.size() && i < ieee_model_var.size(); ++i) {
    const double tau = oadev.points[i].tau;
    if (tau < t_lo * (1 - 1e-9) || tau > t_hi * (1 + 1e-9) || !(mv[i] > 0) || !(ieee_model_var[i] > 0)) continue;
    const double r = mv[i] / ieee_model_var[i];
    g->worst_avar_ratio_vs_ieee = std::max(g->worst_avar_ratio_vs_ieee, std::max(r, 1 / r));
  }
  g->compared = true;
}

// ==== The reported noise model (issue #16): one source for noise_model.yaml and ~noise_model ========================

ReportedNoiseModel reportedNoiseModel(const GmwmAxis& g, double filter_rate_hz, double ieee_bi, double ieee_bi_sigma) {
  ReportedNoiseModel r;
  if (!g.ok) {
    r.error = g.message;
    return r;
  }
  r.ok = true;
  r.fit = g.selection.chosen();
  r.model = r.fit.model.name();
  char sel[160];
  std::snprintf(sel, sizeof sel, "smallest chi2 + %g x parameters among fits whose every term is supported (docs/gmwm.md)",
                g.penalty_per_parameter);
  r.selection = sel;
  for (const GmwmFit& c : g.selection.fits) {
    ReportedCandidate rc;
    rc.model = c.model.name();
    rc.ok = c.ok;
    rc.criterion = c.criterion;
    rc.chi2 = c.chi2;
    rc.dof = c.dof;
    rc.identified = c.identified;
    rc.unidentified = c.unidentified;
    r.candidates.push_back(rc);
  }
  r.segment_s = g.record_s;
  r.data_rate_hz = 1.0 / g.tau0;
  auto disc = [&r](double dt) {
    ReportedDiscreteModel d;
    d.dt = dt;
    d.rate_hz = 1.0 / dt;
    d.model = discretize(r.fit, dt);
    d.measurement_variance = d.model.white_variance + d.model.quantization_variance;
    return d;
  };
  r.discrete.push_back(disc(g.tau0));
  if (filter_rate_hz > 0) r.discrete.push_back(disc(1.0 / filter_rate_hz));
  r.gauss_markov_terms = static_cast<int>(r.fit.gm.size());
  r.tau_min_s = g.gmwm_vs_data.tau_min;
  r.tau_max_s = g.gmwm_vs_data.tau_max;
  r.ieee_bias_instability = ieee_bi;
  r.ieee_bias_instability_sigma = ieee_bi_sigma;
  r.worst_avar_ratio_vs_ieee_model = g.worst_avar_ratio_vs_ieee;
  r.worst_avar_ratio_vs_data = g.gmwm_vs_data.worst_ratio * g.gmwm_vs_data.worst_ratio;
  r.gmwm_model = g.gmwm_vs_data;
  r.ieee_model = g.ieee_vs_data;
  r.final_model = g.final_vs_data;
  r.wavelet_variance_points = g.wv_points;
  r.wavelet_variance_within_ci = g.wv_within_ci;
  r.wavelet_variance_confidence = g.wv.confidence;
  for (const auto& k : r.fit.known) {
    ReportedKnownTerm t;
    t.type = k.type;
    t.in_gmwm_fit = true;
    t.kind = k.stochastic() ? "stationary narrowband oscillation (Gaussian, measured PSD shape)" : "deterministic line";
    auto param = [&k](const char* name) { return k.parameters.count(name) ? k.parameters.at(name) : 0.0; };
    t.frequency_hz = param("frequency_hz");
    if (k.stochastic()) t.bandwidth_hz = param("bandwidth_hz");
    // c = A^2 for a line A sin(2 pi f t); c = 2 var for a narrowband term: both have the RMS sqrt(c / 2).
    t.rms = std::sqrt(k.c / 2);
    t.rms_sigma = k.c > 0 ? t.rms * k.c_sd / (2 * k.c) : 0.0;
    if (!k.stochastic()) {
      t.amplitude = std::sqrt(k.c);
      t.amplitude_sigma = t.rms_sigma * std::sqrt(2.0);
    }
    t.note = "not in Phi/Qd or measurement_variance: notch it out or model it separately (e.g. a second-order "
             "oscillator state)";
    r.known_terms.push_back(t);
  }
  for (const auto& e : g.effects_not_in_model) {
    ReportedKnownTerm t;
    t.type = e.type;
    t.note = e.reason;
    r.known_terms.push_back(t);
  }
  return r;
}

}  // namespace gyro_allan
