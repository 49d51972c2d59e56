// Wavelet filter banks and DWT/IDWT, wavedec/waverec, SWT/ISWT with PyWavelets index conventions.
#include "gyro_allan/wavelet.hpp"

#include <cmath>
#include <stdexcept>

namespace gyro_allan {

namespace {

const wavelet_detail::FilterEntry* findEntry(const std::string& name) {
  for (const auto& e : wavelet_detail::filterTable()) {
    if (name == e.name) return &e;
  }
  return nullptr;
}

int64_t positiveMod(int64_t i, int64_t n) {
  int64_t r = i % n;
  return r < 0 ? r + n : r;
}

/// Sample i (any integer) of x extended by `mode` (not periodization).
double extended(const std::vector<double>& x, int64_t i, ExtensionMode mode) {
  const int64_t n = static_cast<int64_t>(x.size());
  if (i >= 0 && i < n) return x[i];
  switch (mode) {
    case ExtensionMode::Zero:
      return 0.0;
    case ExtensionMode::Periodic:
    case ExtensionMode::Periodization:
      return x[positiveMod(i, n)];
    case ExtensionMode::Symmetric: {
      const int64_t m = positiveMod(i, 2 * n);
      return m < n ? x[m] : x[2 * n - 1 - m];
    }
  }
  return 0.0;
}

void checkFinite(const std::vector<double>& x, const char* what) {
  for (double v : x) {
    if (!std::isfinite(v)) throw std::invalid_argument(std::string(what) + ": non-finite sample");
  }
}

}  // namespace

Wavelet::Wavelet(const std::string& wavelet_name) : name(wavelet_name) {
  const auto* e = findEntry(wavelet_name);
  if (!e) throw std::invalid_argument("unknown wavelet '" + wavelet_name + "' (haar, db1-db20, sym2-sym20, coif1-coif5)");
  vanishing_moments_psi = e->vanishing_moments_psi;
  const auto& h = e->rec_lo;
  const size_t L = h.size();
  rec_lo = h;
  dec_lo.resize(L);
  dec_hi.resize(L);
  rec_hi.resize(L);
  for (size_t k = 0; k < L; ++k) {
    dec_lo[k] = h[L - 1 - k];
    rec_hi[k] = (k % 2 == 0 ? 1.0 : -1.0) * h[L - 1 - k];
    dec_hi[k] = (k % 2 == 0 ? -1.0 : 1.0) * h[k];
  }
}

const std::vector<std::string>& waveletNames() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> v;
    for (const auto& e : wavelet_detail::filterTable()) v.emplace_back(e.name);
    return v;
  }();
  return names;
}

bool isWaveletName(const std::string& name) { return findEntry(name) != nullptr; }

ExtensionMode parseExtensionMode(const std::string& name) {
  if (name == "symmetric") return ExtensionMode::Symmetric;
  if (name == "periodization") return ExtensionMode::Periodization;
  if (name == "zero") return ExtensionMode::Zero;
  if (name == "periodic") return ExtensionMode::Periodic;
  throw std::invalid_argument("unknown extension mode '" + name + "' (symmetric, periodization, zero, periodic)");
}

std::string extensionModeName(ExtensionMode mode) {
  switch (mode) {
    case ExtensionMode::Symmetric: return "symmetric";
    case ExtensionMode::Periodization: return "periodization";
    case ExtensionMode::Zero: return "zero";
    case ExtensionMode::Periodic: return "periodic";
  }
  return "?";
}

int64_t dwt_coeff_len(int64_t n, int filter_len, ExtensionMode mode) {
  if (n < 1) throw std::invalid_argument("dwt_coeff_len: signal length must be >= 1");
  if (filter_len < 1) throw std::invalid_argument("dwt_coeff_len: filter length must be >= 1");
  if (mode == ExtensionMode::Periodization) return (n + 1) / 2;
  return (n + filter_len - 1) / 2;
}

int dwt_max_level(int64_t n, int filter_len) {
  if (n < 1) throw std::invalid_argument("dwt_max_level: signal length must be >= 1");
  if (filter_len < 2) throw std::invalid_argument("dwt_max_level: filter length must be >= 2");
  // Largest L with (F - 1) * 2^L <= n (integer form of floor(log2(n / (F - 1)))).
  int level = 0;
  int64_t span = filter_len - 1;
  if (n < span) return 0;
  while (span * 2 <= n) {
    span *= 2;
    ++level;
  }
  return level;
}

int swt_max_level(int64_t n) {
  if (n < 1) throw std::invalid_argument("swt_max_level: signal length must be >= 1");
  int level = 0;
  while (n % 2 == 0) {
    n /= 2;
    ++level;
  }
  return level;
}

DwtCoeffs dwt(const std::vector<double>& x, const Wavelet& w, ExtensionMode mode) {
  if (x.empty()) throw std::invalid_argument("dwt: empty signal");
  const int64_t n = static_cast<int64_t>(x.size());
  const int F = w.dec_len();
  const double* lo = w.dec_lo.data();
  const double* hi = w.dec_hi.data();
  DwtCoeffs out;
  // Extended copy xe with xe[i + pad] = x_ext(i), so the inner loops have no branches.
  const int64_t pad = F;
  int64_t K, start;  // cA[o] = sum_j lo[j] * x_ext(2o + start - j)
  std::vector<double> src;
  const std::vector<double>* base = &x;
  ExtensionMode ext = mode;
  if (mode == ExtensionMode::Periodization) {
    if (n % 2 == 1) {
      src = x;
      src.push_back(x.back());
      base = &src;
    }
    K = static_cast<int64_t>(base->size()) / 2;
    start = F / 2;
    ext = ExtensionMode::Periodic;
  } else {
    K = (n + F - 1) / 2;
    start = 1;
  }
  const int64_t nb = static_cast<int64_t>(base->size());
  std::vector<double> xe(nb + 2 * pad);
  for (int64_t i = -pad; i < nb + pad; ++i) xe[i + pad] = extended(*base, i, ext);
  out.cA.assign(K, 0.0);
  out.cD.assign(K, 0.0);
  for (int64_t o = 0; o < K; ++o) {
    const double* p = xe.data() + pad + 2 * o + start;  // p[-j] = x_ext(2o + start - j)
    double a = 0, d = 0;
    for (int j = 0; j < F; ++j) {
      a += lo[j] * p[-j];
      d += hi[j] * p[-j];
    }
    out.cA[o] = a;
    out.cD[o] = d;
  }
  return out;
}

std::vector<double> idwt(const std::vector<double>& cA, const std::vector<double>& cD, const Wavelet& w,
                         ExtensionMode mode) {
  if (cA.size() != cD.size()) throw std::invalid_argument("idwt: cA and cD lengths differ");
  if (cA.empty()) throw std::invalid_argument("idwt: empty coefficients");
  const int64_t K = static_cast<int64_t>(cA.size());
  const int F = w.dec_len();
  if (mode == ExtensionMode::Periodization) {
    // Adjoint of the periodized analysis: x[(2o + F/2 - j) mod 2K] += dec_lo[j] cA[o] + dec_hi[j] cD[o].
    const int64_t M = 2 * K;
    const int64_t off = F;  // buffer index = 2o + F/2 - j + off >= 0
    std::vector<double> buf(M + 2 * F + 2, 0.0);
    for (int64_t o = 0; o < K; ++o) {
      double* p = buf.data() + 2 * o + F / 2 + off;
      const double a = cA[o], d = cD[o];
      for (int j = 0; j < F; ++j) p[-j] += w.dec_lo[j] * a + w.dec_hi[j] * d;
    }
    std::vector<double> x(M, 0.0);
    for (int64_t i = 0; i < static_cast<int64_t>(buf.size()); ++i) {
      if (buf[i] != 0.0) x[positiveMod(i - off, M)] += buf[i];
    }
    return x;
  }
  const int64_t n_out = 2 * K - F + 2;
  if (n_out < 1) throw std::invalid_argument("idwt: too few coefficients for the filter length");
  std::vector<double> x(n_out);
  const double* rl = w.rec_lo.data();
  const double* rh = w.rec_hi.data();
  // x[n] = sum_k cA[k] rec_lo[n + F - 2 - 2k] + cD[k] rec_hi[...], k in [ceil((n-1)/2), floor((n+F-2)/2)].
  for (int64_t i = 0; i < n_out; ++i) {
    const int64_t k_lo = i >= 1 ? i / 2 : 0;  // ceil((i-1)/2) = i/2 for i >= 1
    const int64_t k_hi = (i + F - 2) / 2;
    double acc = 0;
    for (int64_t k = k_lo; k <= k_hi; ++k) {
      const int64_t j = i + F - 2 - 2 * k;
      acc += cA[k] * rl[j] + cD[k] * rh[j];
    }
    x[i] = acc;
  }
  return x;
}

std::vector<std::vector<double>> wavedec(const std::vector<double>& x, const Wavelet& w, ExtensionMode mode,
                                         int level) {
  if (x.empty()) throw std::invalid_argument("wavedec: empty signal");
  checkFinite(x, "wavedec");
  if (level < 0) level = dwt_max_level(static_cast<int64_t>(x.size()), w.dec_len());
  std::vector<std::vector<double>> details;
  std::vector<double> a = x;
  for (int l = 0; l < level; ++l) {
    DwtCoeffs c = dwt(a, w, mode);
    details.push_back(std::move(c.cD));
    a = std::move(c.cA);
  }
  std::vector<std::vector<double>> out;
  out.reserve(level + 1);
  out.push_back(std::move(a));
  for (int l = level - 1; l >= 0; --l) out.push_back(std::move(details[l]));
  return out;
}

std::vector<double> waverec(const std::vector<std::vector<double>>& coeffs, const Wavelet& w, ExtensionMode mode) {
  if (coeffs.empty()) throw std::invalid_argument("waverec: no coefficients");
  std::vector<double> a = coeffs[0];
  for (size_t i = 1; i < coeffs.size(); ++i) {
    const auto& d = coeffs[i];
    if (a.size() == d.size() + 1) {
      a.pop_back();
    } else if (a.size() != d.size()) {
      throw std::invalid_argument("waverec: coefficient lengths do not match a wavedec layout");
    }
    a = idwt(a, d, w, mode);
  }
  return a;
}

std::vector<DwtCoeffs> swt(const std::vector<double>& x, const Wavelet& w, int level) {
  if (x.empty()) throw std::invalid_argument("swt: empty signal");
  checkFinite(x, "swt");
  const int64_t n = static_cast<int64_t>(x.size());
  const int maxl = swt_max_level(n);
  if (level < 0) level = maxl;
  if (level < 1 || level > maxl)
    throw std::invalid_argument("swt: level must be 1..swt_max_level (signal length divisible by 2^level)");
  const int F = w.dec_len();
  std::vector<DwtCoeffs> out(level);
  std::vector<double> a = x;
  for (int l = 1; l <= level; ++l) {
    const int64_t step = int64_t(1) << (l - 1);
    const int64_t shift = step * F / 2;
    DwtCoeffs c;
    c.cA.assign(n, 0.0);
    c.cD.assign(n, 0.0);
    for (int64_t o = 0; o < n; ++o) {
      double sa = 0, sd = 0;
      for (int j = 0; j < F; ++j) {
        const double v = a[positiveMod(o + shift - j * step, n)];
        sa += w.dec_lo[j] * v;
        sd += w.dec_hi[j] * v;
      }
      c.cA[o] = sa;
      c.cD[o] = sd;
    }
    a = c.cA;
    out[level - l] = std::move(c);
  }
  return out;
}

std::vector<double> iswt(const std::vector<DwtCoeffs>& coeffs, const Wavelet& w) {
  if (coeffs.empty()) throw std::invalid_argument("iswt: no coefficients");
  const int level = static_cast<int>(coeffs.size());
  const int64_t n = static_cast<int64_t>(coeffs[0].cA.size());
  if (n == 0) throw std::invalid_argument("iswt: empty coefficients");
  for (const auto& c : coeffs) {
    if (static_cast<int64_t>(c.cD.size()) != n || static_cast<int64_t>(c.cA.size()) != n)
      throw std::invalid_argument("iswt: all coefficient arrays must have the same length");
  }
  if (swt_max_level(n) < level) throw std::invalid_argument("iswt: length not divisible by 2^level");
  const int F = w.dec_len();
  std::vector<double> a = coeffs[0].cA;
  for (int l = level; l >= 1; --l) {
    const auto& d = coeffs[level - l].cD;
    const int64_t step = int64_t(1) << (l - 1);
    const int64_t shift = step * F / 2;
    std::vector<double> prev(n, 0.0);
    for (int64_t o = 0; o < n; ++o) {
      for (int j = 0; j < F; ++j) {
        prev[positiveMod(o + shift - j * step, n)] += 0.5 * (w.dec_lo[j] * a[o] + w.dec_hi[j] * d[o]);
      }
    }
    a = std::move(prev);
  }
  return a;
}

}  // namespace gyro_allan
