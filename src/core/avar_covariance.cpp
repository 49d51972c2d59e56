// Covariance of overlapping Allan-variance estimates across tau under the IEEE 952 model (see avar_covariance.hpp).
#include "gyro_allan/avar_covariance.hpp"

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <exception>
#include <mutex>
#include <utility>
#include <cmath>
#include <stdexcept>

namespace gyro_allan {
namespace {

constexpr int kQ = 0, kN = 1, kB = 2, kK = 3;
constexpr long double kWeights[3] = {1.0L, -2.0L, 1.0L};  // second difference x[k] - 2 x[k+m] + x[k+2m]

// 6-point Gauss-Legendre nodes and weights on [-1, 1].
constexpr double kGlX[6] = {-0.9324695142031521, -0.6612093864662645, -0.2386191860831969,
                            0.2386191860831969,  0.6612093864662645,  0.9324695142031521};
constexpr double kGlW[6] = {0.1713244923791704, 0.3607615730481386, 0.4679139345726910,
                            0.4679139345726910, 0.3607615730481386, 0.1713244923791704};

/// Cross-covariances Cov(d_k(m), d_{k+h}(m')) per unit squared coefficient of the smooth terms N, B, K (lag t in
/// samples; the tau0 powers are applied by the caller). N and K vanish outside [-2m', 2m] (exactly: the weights
/// annihilate their polynomial covariances there), so they are set to 0 to avoid cancellation noise.
struct Pair {
  long double m, mp;
  void smooth(long double h, long double* cN, long double* cB, long double* cK) const {
    long double n = 0, b = 0, k = 0;
    const bool inside = h >= -2 * mp && h <= 2 * m;
    for (int a = 0; a < 3; ++a)
      for (int c = 0; c < 3; ++c) {
        const long double w = kWeights[a] * kWeights[c];
        const long double t = a * m - c * mp - h;
        const long double at = std::fabs(t);
        if (at > 0) b += w * t * t * std::log(at);
        if (inside) {
          n += w * at;
          k += w * at * at * at;
        }
      }
    *cN = -0.5L * n;
    *cB = b / (2.0L * static_cast<long double>(M_PI));
    *cK = k / 12.0L;
  }
};

struct Sums {
  long double cc[4][4] = {};  // sum count * c_p * c_q (p <= q)
  long double c[4] = {};      // sum count * c_p
  void add(long double weight, const long double cv[4]) {
    for (int p = 0; p < 4; ++p) {
      c[p] += weight * cv[p];
      for (int q = p; q < 4; ++q) cc[p][q] += weight * cv[p] * cv[q];
    }
  }
};

}  // namespace

namespace {

void checkInput(const std::vector<int64_t>& m, const std::vector<int64_t>& n_terms, double tau0) {
  if (m.empty() || m.size() != n_terms.size())
    throw std::invalid_argument("avarCovarianceBasis: need one term count per averaging factor");
  if (!(tau0 > 0) || !std::isfinite(tau0)) throw std::invalid_argument("avarCovarianceBasis: tau0 must be positive");
  for (size_t i = 0; i < m.size(); ++i)
    if (m[i] < 1 || n_terms[i] < 1) throw std::invalid_argument("avarCovarianceBasis: m and term counts must be >= 1");
}

/// The basis's points with every matrix zero.
AvarCovarianceBasis zeroBasis(const std::vector<int64_t>& m, const std::vector<int64_t>& n_terms, double tau0) {
  const int np = static_cast<int>(m.size());
  AvarCovarianceBasis out;
  out.m = m;
  out.n_terms = n_terms;
  out.tau0 = tau0;
  for (auto& row : out.G)
    for (auto& g : row) g = Eigen::MatrixXd::Zero(np, np);
  for (auto& h : out.H) h = Eigen::MatrixXd::Zero(np, np);
  out.K4 = Eigen::MatrixXd::Zero(np, np);
  return out;
}

/// Entries (i, j) and (j, i), i <= j, of every matrix: they depend only on m, n_terms at i and j and on tau0 (so an
/// entry computed for one set of points holds for any other set with the same two points, in the same order).
void computeEntry(AvarCovarianceBasis* basis, int i, int j) {
  AvarCovarianceBasis& out = *basis;
  const std::vector<int64_t>& m = out.m;
  const std::vector<int64_t>& n_terms = out.n_terms;
  const double tau0 = out.tau0;
  // Powers of tau0 of each term's generalized covariance at a lag of t samples: Q 1, N tau0, B tau0^2, K tau0^3.
  const long double scale[4] = {1.0L, tau0, static_cast<long double>(tau0) * tau0,
                                static_cast<long double>(tau0) * tau0 * tau0};
  const Pair pr{static_cast<long double>(m[static_cast<size_t>(i)]), static_cast<long double>(m[static_cast<size_t>(j)])};
  const int64_t mi = m[static_cast<size_t>(i)], mj = m[static_cast<size_t>(j)];
  const int64_t Mi = n_terms[static_cast<size_t>(i)], Mj = n_terms[static_cast<size_t>(j)];
  // count(h): pairs (k, l = k + h) with 0 <= k < Mi, 0 <= l < Mj.
  auto count = [&](long double h) -> long double {
    const long double hi = std::min<long double>(static_cast<long double>(Mi), static_cast<long double>(Mj) - h);
    const long double lo = std::max<long double>(0.0L, -h);
    return std::max<long double>(0.0L, hi - lo);
  };
  const int64_t wtail = 8 * std::max(mi, mj);  // flicker's tail beyond the support (c_B ~ 1/h^2)
  const int64_t lo = std::max<int64_t>(-(Mi - 1), -2 * mj - wtail);
  const int64_t hi = std::min<int64_t>(Mj - 1, 2 * mi + wtail);
  if (lo > hi) return;
  std::vector<int64_t> knots{lo, hi + 1, 0, Mj - Mi};
  for (int a = 0; a < 3; ++a)
    for (int c = 0; c < 3; ++c) knots.push_back(a * mi - c * mj);
  for (int a = 0; a < 3; ++a) knots.push_back(2 * mi + 1 - a), knots.push_back(-2 * mj - a);
  std::sort(knots.begin(), knots.end());
  knots.erase(std::unique(knots.begin(), knots.end()), knots.end());

  Sums s;
  long double k4 = 0;
  auto evalAt = [&](long double h, long double weight) {
    long double cv[4];
    cv[kQ] = 0;
    pr.smooth(h, &cv[kN], &cv[kB], &cv[kK]);
    s.add(weight * count(h), cv);
  };
  // Quantization: white angle noise, c_Q(h) = sum of w_a w_c over (a, c) with a m - c m' = h (integer lags).
  for (int a = 0; a < 3; ++a)
    for (int c = 0; c < 3; ++c) {
      const int64_t h = a * mi - c * mj;
      if (h < lo || h > hi) continue;
      bool first = true;  // handle each distinct h once
      for (int a2 = 0; a2 < 3 && first; ++a2)
        for (int c2 = 0; c2 < 3; ++c2) {
          if (a2 * 3 + c2 >= a * 3 + c) break;
          if (a2 * mi - c2 * mj == h) {
            first = false;
            break;
          }
        }
      if (!first) continue;
      long double cq = 0;
      for (int a2 = 0; a2 < 3; ++a2)
        for (int c2 = 0; c2 < 3; ++c2)
          if (a2 * mi - c2 * mj == h) cq += kWeights[a2] * kWeights[c2];
      long double cv[4];
      pr.smooth(static_cast<long double>(h), &cv[kN], &cv[kB], &cv[kK]);
      const long double w = count(static_cast<long double>(h));
      // Only the terms involving Q here; the smooth-smooth products are summed below over every lag.
      s.cc[kQ][kQ] += w * cq * cq;
      long double c4 = 0;  // fourth-cumulant weight: sum of w_a^2 w_c^2 over the coinciding samples
      for (int a2 = 0; a2 < 3; ++a2)
        for (int c2 = 0; c2 < 3; ++c2)
          if (a2 * mi - c2 * mj == h) c4 += kWeights[a2] * kWeights[a2] * kWeights[c2] * kWeights[c2];
      k4 += w * c4;
      for (int q = 1; q < 4; ++q) s.cc[kQ][q] += w * cq * cv[q];
      s.c[kQ] += w * cq;
    }
  // Smooth terms: exact near each knot, integrated between them (midpoint rule over the integers, Gauss-Legendre
  // on geometrically graded panels so the flicker's logarithms near the knots are resolved).
  constexpr int64_t kExact = 8;
  for (size_t t = 0; t + 1 < knots.size(); ++t) {
    const int64_t a = knots[t], b = knots[t + 1] - 1;  // integers a..b
    if (b < lo || a > hi) continue;
    if (b - a + 1 <= 2 * kExact + 8) {
      for (int64_t h = a; h <= b; ++h) evalAt(static_cast<long double>(h), 1.0L);
      continue;
    }
    for (int64_t h = a; h < a + kExact; ++h) evalAt(static_cast<long double>(h), 1.0L);
    for (int64_t h = b - kExact + 1; h <= b; ++h) evalAt(static_cast<long double>(h), 1.0L);
    const long double u = static_cast<long double>(a + kExact) - 0.5L;
    const long double v = static_cast<long double>(b - kExact) + 0.5L;
    const long double half = 0.5L * (v - u);
    // Panels from each end: widths in ratio 1:3:9 over each half.
    const long double frac[4] = {0.0L, 1.0L / 13, 4.0L / 13, 1.0L};
    for (int side = 0; side < 2; ++side)
      for (int p = 0; p < 3; ++p) {
        const long double x0 = side == 0 ? u + frac[p] * half : v - frac[p + 1] * half;
        const long double x1 = side == 0 ? u + frac[p + 1] * half : v - frac[p] * half;
        const long double c = 0.5L * (x0 + x1), r = 0.5L * (x1 - x0);
        for (int g = 0; g < 6; ++g) evalAt(c + r * kGlX[g], r * kGlW[g]);
      }
  }
  const long double taui = mi * static_cast<long double>(tau0), tauj = mj * static_cast<long double>(tau0);
  const long double norm = 4.0L * taui * taui * tauj * tauj * static_cast<long double>(Mi) * static_cast<long double>(Mj);
  for (int p = 0; p < 4; ++p) {
    for (int q = p; q < 4; ++q) {
      const long double f = (p == q ? 2.0L : 4.0L) * s.cc[p][q] * scale[p] * scale[q] / norm;
      out.G[static_cast<size_t>(p)][static_cast<size_t>(q)](i, j) = static_cast<double>(f);
      out.G[static_cast<size_t>(p)][static_cast<size_t>(q)](j, i) = static_cast<double>(f);
    }
    if (p == kQ) {
      const long double f4 = k4 / norm;
      out.K4(i, j) = static_cast<double>(f4);
      out.K4(j, i) = static_cast<double>(f4);
    }
    const long double f = 4.0L * taui * taui * tauj * tauj * s.c[p] * scale[p] / norm;
    out.H[static_cast<size_t>(p)](i, j) = static_cast<double>(f);
    out.H[static_cast<size_t>(p)](j, i) = static_cast<double>(f);
  }
}

}  // namespace

AvarCovarianceBasis avarCovarianceBasis(const std::vector<int64_t>& m, const std::vector<int64_t>& n_terms,
                                        double tau0) {
  checkInput(m, n_terms, tau0);
  const int np = static_cast<int>(m.size());
  AvarCovarianceBasis out = zeroBasis(m, n_terms, tau0);
  for (int i = 0; i < np; ++i)
    for (int j = i; j < np; ++j) computeEntry(&out, i, j);
  return out;
}

namespace {

/// One shared basis being built: the entries found in earlier bases are copied at once, the others are summed by
/// every thread that asks for this basis before it is complete (each takes the next entry not yet taken).
struct SharedBuild {
  AvarCovarianceBasis basis;
  std::vector<std::pair<int, int>> todo;  // entries (i <= j) to sum
  std::atomic<size_t> next{0}, done{0};
  std::atomic<bool> complete{false};
  std::mutex mutex;
  std::condition_variable cv;
  std::exception_ptr error;

  void work() {
    for (size_t k = next.fetch_add(1); k < todo.size(); k = next.fetch_add(1)) {
      try {
        computeEntry(&basis, todo[k].first, todo[k].second);
      } catch (...) {
        std::lock_guard<std::mutex> lock(mutex);
        if (!error) error = std::current_exception();
      }
      if (done.fetch_add(1) + 1 == todo.size()) finish();
    }
  }
  void finish() {
    std::lock_guard<std::mutex> lock(mutex);
    complete = true;
    cv.notify_all();
  }
  void wait() {
    std::unique_lock<std::mutex> lock(mutex);
    cv.wait(lock, [&] { return complete.load(); });
  }
};

/// Copies entry (i, j), i <= j, of `out` from `from`'s entry at the same two points when `from` has them in the
/// same order (an entry is computed from its two points alone, and (i, j) is summed with point i first).
bool copyEntry(AvarCovarianceBasis* out, int i, int j, const AvarCovarianceBasis& from, int a, int b) {
  if (a < 0 || b < 0 || (i == j ? a != b : a >= b)) return false;
  for (int p = 0; p < 4; ++p) {
    for (int q = p; q < 4; ++q) {
      auto& g = out->G[static_cast<size_t>(p)][static_cast<size_t>(q)];
      const auto& f = from.G[static_cast<size_t>(p)][static_cast<size_t>(q)];
      g(i, j) = f(a, b);
      g(j, i) = f(b, a);
    }
    out->H[static_cast<size_t>(p)](i, j) = from.H[static_cast<size_t>(p)](a, b);
    out->H[static_cast<size_t>(p)](j, i) = from.H[static_cast<size_t>(p)](b, a);
  }
  out->K4(i, j) = from.K4(a, b);
  out->K4(j, i) = from.K4(b, a);
  return true;
}

}  // namespace

std::shared_ptr<const AvarCovarianceBasis> sharedAvarCovarianceBasis(const std::vector<int64_t>& m,
                                                                     const std::vector<int64_t>& n_terms, double tau0) {
  checkInput(m, n_terms, tau0);
  struct Entry {
    std::vector<int64_t> m, n;
    double tau0;
    std::shared_ptr<SharedBuild> build;
  };
  constexpr size_t kCapacity = 8;
  static std::mutex mutex;
  static std::vector<Entry> cache;
  std::shared_ptr<SharedBuild> build;
  {
    std::lock_guard<std::mutex> lock(mutex);
    for (const auto& e : cache)
      if (e.tau0 == tau0 && e.m == m && e.n == n_terms) build = e.build;
    if (!build) {
      // New set: entries from the complete bases with the same tau0, the rest to sum (outside this lock).
      build = std::make_shared<SharedBuild>();
      build->basis = zeroBasis(m, n_terms, tau0);
      const int np = static_cast<int>(m.size());
      std::vector<const AvarCovarianceBasis*> donors;
      std::vector<std::vector<int>> pos;  // per donor: index of each new point in it, or -1
      for (const auto& e : cache) {
        if (e.tau0 != tau0 || !e.build->complete || e.build->error) continue;
        const AvarCovarianceBasis& d = e.build->basis;
        std::vector<int> p(static_cast<size_t>(np), -1);
        bool any = false;
        for (int i = 0; i < np; ++i)
          for (size_t k = 0; k < d.m.size(); ++k)
            if (d.m[k] == m[static_cast<size_t>(i)] && d.n_terms[k] == n_terms[static_cast<size_t>(i)]) {
              p[static_cast<size_t>(i)] = static_cast<int>(k);
              any = true;
              break;
            }
        if (!any) continue;
        donors.push_back(&d);
        pos.push_back(std::move(p));
      }
      for (int i = 0; i < np; ++i)
        for (int j = i; j < np; ++j) {
          bool copied = false;
          for (size_t d = 0; d < donors.size() && !copied; ++d)
            copied = copyEntry(&build->basis, i, j, *donors[d], pos[d][static_cast<size_t>(i)], pos[d][static_cast<size_t>(j)]);
          if (!copied) build->todo.emplace_back(i, j);
        }
      if (build->todo.empty()) build->complete = true;
      if (cache.size() >= kCapacity) cache.erase(cache.begin());
      cache.push_back({m, n_terms, tau0, build});
    }
  }
  build->work();
  build->wait();
  if (build->error) {
    {
      std::lock_guard<std::mutex> lock(mutex);
      for (size_t k = 0; k < cache.size(); ++k)
        if (cache[k].build == build) {
          cache.erase(cache.begin() + static_cast<std::ptrdiff_t>(k));
          break;
        }
    }
    std::rethrow_exception(build->error);
  }
  return std::shared_ptr<const AvarCovarianceBasis>(build, &build->basis);
}

Eigen::MatrixXd avarCovariance(const AvarCovarianceBasis& basis, const std::array<double, 5>& s,
                               double quantization_excess_kurtosis) {
  const int np = static_cast<int>(basis.m.size());
  Eigen::MatrixXd cov = Eigen::MatrixXd::Zero(np, np);
  if (s[0] > 0 && quantization_excess_kurtosis != 0) cov += quantization_excess_kurtosis * s[0] * s[0] * basis.K4;
  for (int p = 0; p < 4; ++p) {
    if (!(s[static_cast<size_t>(p)] > 0)) continue;
    for (int q = p; q < 4; ++q)
      if (s[static_cast<size_t>(q)] > 0)
        cov += s[static_cast<size_t>(p)] * s[static_cast<size_t>(q)] * basis.G[static_cast<size_t>(p)][static_cast<size_t>(q)];
    if (s[4] > 0) cov += s[static_cast<size_t>(p)] * s[4] * basis.H[static_cast<size_t>(p)];
  }
  return cov;
}

}  // namespace gyro_allan
