// Third cumulant of a linear combination of overlapping Allan-variance estimates by the spectral approximation.
#include "gyro_allan/avar_skewness.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace gyro_allan {
namespace {

constexpr int kPerOctave = 64;

// sin^4(pi m nu) / sin^2(pi nu) times 2 / m^2, with sin^4 at its mean 3/8 beyond m nu = 4 (the window's side lobes
// oscillate faster than the grid resolves there: exact for the mean, approximate for the higher powers; header).
double window(int64_t m, double nu) {
  const double md = static_cast<double>(m);
  const double sn = std::sin(M_PI * nu);
  const double s4 = md * nu > 4.0 ? 0.375 : std::pow(std::sin(M_PI * md * nu), 4);
  return 2.0 * s4 / (md * md * sn * sn);
}

// Composite Simpson on t = ln(nu) from the lowest window's reach to nu = 1/2; f(nu) is integrated as f(nu) nu dt.
template <class F>
void integrateLog(int64_t m_max, F&& f) {
  const double lo = std::log(1e-4 / static_cast<double>(std::max<int64_t>(m_max, 1))), hi = std::log(0.5);
  int n = static_cast<int>(std::ceil((hi - lo) / std::log(2.0) * kPerOctave));
  if (n % 2) ++n;
  const double h = (hi - lo) / n;
  for (int k = 0; k <= n; ++k) {
    const double w = (k == 0 || k == n) ? 1.0 : (k % 2 ? 4.0 : 2.0);
    const double nu = std::exp(lo + k * h);
    f(nu, w * h / 3.0 * nu);
  }
}

}  // namespace

double termRatePsd(int term, double nu, double tau0) {
  const double s = std::sin(M_PI * std::fabs(nu));
  switch (term) {
    case 0: return 4.0 * s * s / (tau0 * tau0);
    case 1: return 1.0 / tau0;
    case 2: return 1.0 / (2.0 * s);
    case 3: return tau0 / (4.0 * s * s);
    default: return 0.0;
  }
}

double avarWindow(int64_t m, double nu) { return window(m, nu); }

AvarCombinationSpectrum avarCombinationSpectrum(const std::vector<int64_t>& m, const std::vector<int64_t>& n_terms,
                                                const std::vector<double>& a, double tau0,
                                                const std::array<double, 3>& s_fixed) {
  if (m.size() != a.size() || m.size() != n_terms.size())
    throw std::invalid_argument("avarCombinationSpectrum: m, n_terms and a differ in size");
  if (!(tau0 > 0)) throw std::invalid_argument("avarCombinationSpectrum: tau0 must be > 0");
  std::vector<double> w2(m.size()), w3(m.size());  // a_i / n_i^(1/2) and a_i / n_i^(2/3)
  for (size_t i = 0; i < m.size(); ++i) {
    if (n_terms[i] < 1) throw std::invalid_argument("avarCombinationSpectrum: a point without terms");
    const double n = static_cast<double>(n_terms[i]);
    w2[i] = a[i] / std::sqrt(n);
    w3[i] = a[i] / std::pow(n, 2.0 / 3.0);
  }
  AvarCombinationSpectrum r;
  const int64_t m_max = m.empty() ? 1 : *std::max_element(m.begin(), m.end());
  integrateLog(m_max, [&](double nu, double w) {
    double phi2 = 0, phi3 = 0;
    for (size_t i = 0; i < m.size(); ++i) {
      const double h = window(m[i], nu);
      phi2 += w2[i] * h;
      phi3 += w3[i] * h;
    }
    double sf = 0;
    for (int t = 0; t < 3; ++t)
      if (s_fixed[static_cast<size_t>(t)] > 0) sf += s_fixed[static_cast<size_t>(t)] * termRatePsd(t, nu, tau0);
    const double sk = termRatePsd(3, nu, tau0);
    const double u2 = phi2 * sf, v2 = phi2 * sk, u3 = phi3 * sf, v3 = phi3 * sk;
    r.i2[0] += w * u2 * u2;
    r.i2[1] += w * 2.0 * u2 * v2;
    r.i2[2] += w * v2 * v2;
    r.i3[0] += w * u3 * u3 * u3;
    r.i3[1] += w * 3.0 * u3 * u3 * v3;
    r.i3[2] += w * 3.0 * u3 * v3 * v3;
    r.i3[3] += w * v3 * v3 * v3;
  });
  return r;
}

double spectralMeanAvar(int64_t m, double tau0, const std::array<double, 4>& s) {
  double sum = 0;
  integrateLog(m, [&](double nu, double w) {
    double psd = 0;
    for (int t = 0; t < 4; ++t) psd += s[static_cast<size_t>(t)] * termRatePsd(t, nu, tau0);
    sum += w * 2.0 * window(m, nu) * psd;  // both halves of [-1/2, 1/2]
  });
  return sum;
}

}  // namespace gyro_allan
