// Allan-family deviations (adev, oadev, mdev, hdev, ohdev, tdev, totdev, mtotdev, ttotdev) on tau grids, pooled over gap-free segments.
#include "gyro_allan/allan.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "allan_internal.hpp"

namespace gyro_allan {

// ------------------------------------------------------------------------------------------------ tau grids
bool parseTauGrid(const std::string& text, TauGrid* grid, std::string* error) {
  auto fail = [&](const std::string& msg) {
    if (error) *error = msg;
    return false;
  };
  if (!grid) return fail("parseTauGrid: null grid");
  TauGrid g;
  if (text == "octave") {
    g.kind = TauGridKind::Octave;
  } else if (text == "decade") {
    g.kind = TauGridKind::Decade;
  } else if (text == "all") {
    g.kind = TauGridKind::All;
  } else if (text == "log") {
    g.kind = TauGridKind::Log;
    g.per_decade = 10;
  } else if (text.rfind("log:", 0) == 0) {
    const std::string num = text.substr(4);
    if (num.empty() || num.size() > 6 || num.find_first_not_of("0123456789") != std::string::npos)
      return fail("tau grid '" + text + "': expected log:K with K a positive integer");
    const int k = std::stoi(num);
    if (k < 1 || k > 100000) return fail("tau grid '" + text + "': points per decade must be in 1..100000");
    g.kind = TauGridKind::Log;
    g.per_decade = k;
  } else {
    return fail("unknown tau grid '" + text + "' (expected octave, decade, all, log or log:K)");
  }
  *grid = g;
  return true;
}

std::string tauGridName(const TauGrid& grid) {
  switch (grid.kind) {
    case TauGridKind::Octave: return "octave";
    case TauGridKind::Decade: return "decade";
    case TauGridKind::All: return "all";
    case TauGridKind::Log: return "log:" + std::to_string(grid.per_decade);
  }
  return "log:" + std::to_string(grid.per_decade);
}

std::vector<int64_t> tauGridFactors(const TauGrid& grid, int64_t max_m) {
  std::vector<int64_t> ms;
  if (max_m < 1) return ms;
  switch (grid.kind) {
    case TauGridKind::Octave:
      for (int64_t m = 1; m <= max_m; m *= 2) {
        ms.push_back(m);
        if (m > max_m / 2) break;
      }
      break;
    case TauGridKind::Decade:
      for (int64_t dec = 1; dec <= max_m; dec *= 10) {
        for (int64_t f : {1, 2, 4})
          if (f * dec <= max_m) ms.push_back(f * dec);
        if (dec > max_m / 10) break;
      }
      break;
    case TauGridKind::All:
      ms.reserve(static_cast<size_t>(max_m));
      for (int64_t m = 1; m <= max_m; ++m) ms.push_back(m);
      break;
    case TauGridKind::Log: {
      if (grid.per_decade < 1) throw std::invalid_argument("tau grid: log per_decade must be >= 1");
      const double top = std::log10(static_cast<double>(max_m));
      for (int64_t k = 0;; ++k) {
        const double e = static_cast<double>(k) / grid.per_decade;
        if (e > top + 1e-12) break;
        const int64_t m = std::llround(std::pow(10.0, e));
        if (m > max_m) break;
        if (ms.empty() || m > ms.back()) ms.push_back(m);
      }
      break;
    }
  }
  return ms;
}

// ------------------------------------------------------------------------------------------------ phase
namespace {
/// Sum of term(i) over i = 0..count-1 with four independent double partial sums (no loop-carried add chain:
/// vectorisable, and ~3x faster than one accumulator), moved to long double every 1024 terms: as accurate as a
/// long-double loop for these sums (x87 arithmetic does not vectorise). The rate-to-angle mean and the Allan sums
/// (sumSquares) use it.
template <class Term>
long double laneSum(int64_t count, const Term& term) {
  long double total = 0;
  for (int64_t i = 0; i < count;) {
    const int64_t end = std::min(count, i + 1024);
    double a0 = 0, a1 = 0, a2 = 0, a3 = 0;
    for (; i + 4 <= end; i += 4) {
      a0 += term(i);
      a1 += term(i + 1);
      a2 += term(i + 2);
      a3 += term(i + 3);
    }
    for (; i < end; ++i) a0 += term(i);
    total += (a0 + a1) + (a2 + a3);
  }
  return total;
}
}  // namespace

std::vector<double> rateToAngle(const std::vector<double>& rate, double tau0) {
  if (!(tau0 > 0) || !std::isfinite(tau0)) throw std::invalid_argument("rateToAngle: tau0 must be finite and > 0");
  std::vector<double> x(rate.size() + 1, 0.0);
  if (rate.empty()) return x;
  const double* v = rate.data();
  const size_t n = rate.size();
  const auto nl = static_cast<long double>(n);
  const auto count = static_cast<int64_t>(n);
  long double mean = laneSum(count, [v](int64_t i) { return v[i]; }) / nl;
  if (!std::isfinite(static_cast<double>(mean))) {
    // A non-finite sample, or finite ones whose double partial sums overflow: name the first, else sum again in
    // long double (its range holds any sum of doubles).
    long double sum = 0;
    for (size_t i = 0; i < n; ++i) {
      if (!std::isfinite(v[i])) throw std::invalid_argument("rateToAngle: non-finite rate sample at index " + std::to_string(i));
      sum += v[i];
    }
    mean = sum / nl;
  }
  // second pass corrects the mean for the rounding of the first (compensated mean); in long double when the double
  // lanes overflow (rates near the double range, e.g. alternating +-1e308)
  const double m0 = static_cast<double>(mean);
  long double corr = laneSum(count, [v, m0](int64_t i) { return v[i] - m0; });
  if (!std::isfinite(static_cast<double>(corr))) {
    corr = 0;
    for (size_t i = 0; i < n; ++i) corr += static_cast<long double>(v[i]) - static_cast<long double>(m0);
  }
  mean = m0 + corr / nl;
  long double acc = 0;
  const long double t0 = tau0;
  for (size_t i = 0; i < n; ++i) {
    acc += (static_cast<long double>(v[i]) - mean) * t0;
    x[i + 1] = static_cast<double>(acc);
  }
  return x;
}

// ------------------------------------------------------------------------------------------------ sums
namespace {

/// Accumulates squares in double blocks of 1024 (vectorisable), blocks summed in long double.
struct SquareAccumulator {
  long double total = 0;
  double block = 0;
  int count = 0;
  inline void add(double v) {
    block += v * v;
    if (++count == 1024) flush();
  }
  inline void flush() {
    total += block;
    block = 0;
    count = 0;
  }
  long double value() {
    flush();
    return total;
  }
};

/// Sum of term(i)^2 over i = 0..count-1 (laneSum: the overlapping estimators run at memory speed).
template <class Term>
long double sumSquares(int64_t count, const Term& term) {
  return laneSum(count, [&term](int64_t i) {
    const double d = term(i);
    return d * d;
  });
}

void sumsAdev(const double* x, int64_t n, int64_t m, bool overlapping, SegmentSums* s) {
  const int64_t stride = overlapping ? 1 : m;
  if (n < 2 * m + 1) return;
  if (overlapping) {
    const int64_t count = n - 2 * m;
    s->sumsq += sumSquares(count, [x, m](int64_t i) { return x[i + 2 * m] - 2.0 * x[i + m] + x[i]; });
    s->terms += count;
    return;
  }
  SquareAccumulator acc;
  int64_t terms = 0;
  for (int64_t i = 0; i + 2 * m < n; i += stride) {
    acc.add(x[i + 2 * m] - 2.0 * x[i + m] + x[i]);
    ++terms;
  }
  s->sumsq += acc.value();
  s->terms += terms;
}

void sumsHdev(const double* x, int64_t n, int64_t m, bool overlapping, SegmentSums* s) {
  const int64_t stride = overlapping ? 1 : m;
  if (n < 3 * m + 1) return;
  if (overlapping) {
    const int64_t count = n - 3 * m;
    s->sumsq += sumSquares(count, [x, m](int64_t i) {
      return x[i + 3 * m] - 3.0 * x[i + 2 * m] + 3.0 * x[i + m] - x[i];
    });
    s->terms += count;
    return;
  }
  SquareAccumulator acc;
  int64_t terms = 0;
  for (int64_t i = 0; i + 3 * m < n; i += stride) {
    acc.add(x[i + 3 * m] - 3.0 * x[i + 2 * m] + 3.0 * x[i + m] - x[i]);
    ++terms;
  }
  s->sumsq += acc.value();
  s->terms += terms;
}

/// Modified Allan: terms j = 0..n-3m, each the sum over i=j..j+m-1 of second differences at spacing m. The window
/// sum is updated in O(1) per step and recomputed from scratch every max(m, 4096) steps to bound rounding drift
/// (each refresh costs m, so the total stays O(n)).
void sumsMdev(const double* x, int64_t n, int64_t m, SegmentSums* s) {
  if (n < 3 * m) return;
  const int64_t nterms = n - 3 * m + 1;
  auto d2 = [&](int64_t i) -> double { return (x[i + 2 * m] - x[i + m]) - (x[i + m] - x[i]); };
  const int64_t refresh = std::max<int64_t>(m, 4096);
  SquareAccumulator acc;
  for (int64_t start = 0; start < nterms; start += refresh) {
    long double w = 0;
    for (int64_t i = start; i < start + m; ++i) w += d2(i);
    double win = static_cast<double>(w);
    acc.add(win);
    const int64_t end = std::min(nterms, start + refresh);
    for (int64_t j = start + 1; j < end; ++j) {
      win += d2(j + m - 1) - d2(j - 1);
      acc.add(win);
    }
  }
  s->sumsq += acc.value();
  s->terms += nterms;
}

/// Total variance (SP1065 eq. 25): phase extended by reflection at both ends, x*(1-j) = 2x(1) - x(1+j),
/// x*(N+j) = 2x(N) - x(N-j), j = 1..N-2; sum over i = 2..N-1 (1-based) of second differences at spacing m.
void sumsTotdev(const double* x, int64_t n, int64_t m, SegmentSums* s) {
  if (n < 3 || m > n - 1) return;
  // 0-based: x*(i) = 2 x(0) - x(-i) for i < 0, x(i) inside, 2 x(n-1) - x(2(n-1) - i) for i >= n.
  const double left = 2.0 * x[0], right = 2.0 * x[n - 1];
  auto ext = [&](int64_t i) -> double {
    if (i < 0) return left - x[-i];
    if (i >= n) return right - x[2 * (n - 1) - i];
    return x[i];
  };
  SquareAccumulator acc;
  for (int64_t i0 = 1; i0 <= n - 2; ++i0) acc.add(ext(i0 - m) - 2.0 * x[i0] + ext(i0 + m));
  s->sumsq += acc.value();
  s->terms += n - 2;
}

/// From this averaging factor on, mtotdev uses the O(N) fold sums (below, the direct O(N m) loop is cheaper).
constexpr int64_t kMtotFastFrom = 24;

/// One term coef * q[sigma j + c] of a fold term (q: prefix sums of the detrended window, sigma in {-1, 0, 1}).
struct FoldTerm {
  double coef;
  int sigma;
  int64_t c;
};

/// Moments of a sliding window v[i..i+n-1]: m_d = sum_a a^d v[i+a] (d = 0, 1, 2) and q = sum_a v[i+a]^2, moved
/// by one in O(1) (reset() recomputes them from scratch). Double: 2.5 times faster than long double; on the
/// 2e4-point random-walk FM test record the variance then agrees with the reference to <= 8e-13 (1e-15 in long
/// double), the windows being reset every max(n, 64) steps and the blocks short.
struct SlidingMoments {
  double m0 = 0, m1 = 0, m2 = 0, q = 0;
  void reset(const double* v, int64_t i, int64_t n) {
    m0 = m1 = m2 = q = 0;
    for (int64_t a = 0; a < n; ++a) {
      const double va = v[i + a], al = static_cast<double>(a);
      m0 += va;
      m1 += al * va;
      m2 += al * al * va;
      q += va * va;
    }
  }
  /// From the window at i - 1 to the one at i: a -> a - 1, v[i-1] leaves, v[i-1+n] enters at a = n - 1.
  void step(const double* v, int64_t i, int64_t n, double nn, double nn2) {
    const double out_v = v[i - 1], in_v = v[i - 1 + n];
    const double n0 = m0 - out_v + in_v, n1 = m1 + nn * in_v, n2 = m2 + nn2 * in_v;
    m0 = n0;
    m1 = n1 - n0;
    m2 = n2 - 2 * n1 + n0;
    q += in_v * in_v - out_v * out_v;
  }
};

/// Buffers of foldRegimeSum, reused from block to block.
struct FoldWorkspace {
  std::vector<double> Fv, Gv;
  std::vector<long double> PGp;
};

/// Sum over windows i = 0..nb-1 and j = ja..jb of z_{i,j}^2 with z_{i,j} = sum coef q_i[sigma j + c], where
/// q_i[k] = P[i+k] - P[i] - k x_i - s_i k (k-1)/2 (P: prefix sums over the block, s_i the window's slope). The
/// x_i and P[i] parts cancel (sum coef (sigma j + c) = 0 for every fold term), so z = F(i+j) + G(i-j) + K_i -
/// s_i r_j with F, G fixed combinations of P values, K_i one of P[i], P[i+L], and r_j a quadratic in j. The
/// square's parts: F^2, G^2, F, G summed over the window of j and the slope parts (sliding moments, one pass),
/// and the F G products over anti-diagonals (t = i+j, u = i-j: for each t the admissible i form an interval, so
/// the G values form a stride-2 run, summed from prefix sums per parity). O(nb + jb - ja), not O(nb (jb - ja)).
long double foldRegimeSum(const double* P, int64_t nb, const double* slope,
                          const std::vector<FoldTerm>& terms, int64_t ja, int64_t jb, FoldWorkspace* ws) {
  const int64_t nJ = jb - ja + 1;
  if (nJ <= 0 || nb <= 0) return 0;
  const int64_t span = nb + nJ - 1;
  // F over t = i + j (stored at t - ja), G over u = i - j (stored at u + jb); window i uses [i, i + nJ)
  std::vector<double>& Fv = ws->Fv;
  std::vector<double>& Gv = ws->Gv;
  Fv.assign(static_cast<size_t>(span), 0.0);
  Gv.assign(static_cast<size_t>(span), 0.0);
  double csum = 0;
  long double r0 = 0, r1 = 0, r2 = 0;  // r_j = r0 + r1 j + r2 j^2 = sum coef T(sigma j + c), T(k) = k(k-1)/2
  for (const auto& t : terms) {
    csum += t.coef;
    const long double cf = 0.5L * t.coef, c = static_cast<long double>(t.c);
    if (t.sigma != 0) {
      r2 += cf;
      r1 += cf * t.sigma * (2 * c - 1);
    }
    r0 += cf * (c * c - c);
    if (t.sigma == 1)
      for (int64_t k = 0; k < span; ++k) Fv[k] += t.coef * P[k + ja + t.c];
    if (t.sigma == -1)
      for (int64_t k = 0; k < span; ++k) Gv[k] += t.coef * P[k - jb + t.c];
  }
  long double R1 = 0, R2 = 0;  // sums of r_j, r_j^2 over the j range
  for (int64_t j = ja; j <= jb; ++j) {
    const long double jj = static_cast<long double>(j), r = r0 + r1 * jj + r2 * jj * jj;
    R1 += r;
    R2 += r * r;
  }
  const long double ja_l = static_cast<long double>(ja), jb_l = static_cast<long double>(jb);
  // window i: F at i + a has j = ja + a: r = (r0 + r1 ja + r2 ja^2) + (r1 + 2 r2 ja) a + r2 a^2
  const long double kf0 = r0 + r1 * ja_l + r2 * ja_l * ja_l, kf1 = r1 + 2 * r2 * ja_l;
  // G at i + b has j = jb - b: r = (r0 + r1 jb + r2 jb^2) - (r1 + 2 r2 jb) b + r2 b^2
  const long double kg0 = r0 + r1 * jb_l + r2 * jb_l * jb_l, kg1 = -(r1 + 2 * r2 * jb_l);
  // the constant part K_i = kc P[i + c0] - csum P[i] (every fold term has at most one sigma = 0 term)
  double kc = 0;
  int64_t c0 = 0;
  for (const auto& t : terms)
    if (t.sigma == 0) {
      kc = t.coef;
      c0 = t.c;
    }
  // per window: F^2 + G^2 + nJ K^2 + s^2 R2 + 2 K (F + G) - 2 s (K R1 + r.F + r.G), sums over the j window
  const int64_t refresh = std::max<int64_t>(nJ, 64);  // moments recomputed from scratch this often
  const long double nn = static_cast<long double>(nJ);
  const double nd = static_cast<double>(nJ), nd2 = nd * nd;
  SlidingMoments f, g;
  long double total = 0;
  for (int64_t i = 0, next = 0; i < nb; ++i) {
    if (i == next) {
      next += refresh;
      f.reset(Fv.data(), i, nJ);
      g.reset(Gv.data(), i, nJ);
    } else {
      f.step(Fv.data(), i, nJ, nd, nd2);
      g.step(Gv.data(), i, nJ, nd, nd2);
    }
    const long double cf = kf0 * f.m0 + kf1 * f.m1 + r2 * f.m2, cg = kg0 * g.m0 + kg1 * g.m1 + r2 * g.m2;
    const long double si = slope[i];
    const long double k = static_cast<long double>(kc) * P[i + c0] - static_cast<long double>(csum) * P[i];
    total += f.q + g.q + nn * k * k + si * si * R2 + 2 * k * (f.m0 + g.m0) - 2 * si * (k * R1 + cf + cg);
  }
  // F G products: F index T = i + a pairs with G index i + nJ - 1 - a = 2i + nJ - 1 - T, i in [lo, hi]
  std::vector<long double>& PGp = ws->PGp;
  PGp.resize(static_cast<size_t>(span));
  for (int64_t k = 0; k < span; ++k) PGp[k] = Gv[k] + (k >= 2 ? PGp[k - 2] : 0.0L);
  long double cross = 0;
  for (int64_t T = 0; T < span; ++T) {
    const int64_t lo = std::max<int64_t>(0, T - nJ + 1), hi = std::min<int64_t>(nb - 1, T);
    if (lo > hi) continue;
    const int64_t k1 = 2 * lo + nJ - 1 - T, k2 = 2 * hi + nJ - 1 - T;
    cross += Fv[T] * (PGp[k2] - (k1 >= 2 ? PGp[k1 - 2] : 0.0L));
  }
  return total + 2 * cross;
}

/// Modified total variance (NIST SP1065 sec. 5.2.13; Howe & Vernotte, PTTI 1999). For every window of L = 3m
/// phase points y = x[i..i+L-1]: remove the frequency offset estimated from the means of the first and the last
/// h = floor(L/2) points, whose centres are c = ceil(L/2) apart (slope s = (mean_last - mean_first) / c); extend
/// the window by uninverted even reflection at both ends to 9m points [rev y, y, rev y]; average the squares of
/// its 6m second differences of m-point averages. The first 3m of them lie in [rev y, y] (left fold), the last
/// 3m in [y, rev y], which is the left fold of rev y. Each fold sequence is a palindrome, so its terms satisfy
/// Z_j = Z_{L-j}: only j = 0..floor(L/2) count (weights 1, 2, ..., 2, and 1 for j = L/2 when L is even).
/// With q the prefix sums of the detrended window, a left-fold term m z_j = B1 - 2 B2 + B3 is q[j] + 3q[m-j] -
/// 3q[2m-j] + q[3m-j] for j <= m and q[j] - 3q[j-m] - 3q[2m-j] + q[3m-j] for m < j <= L/2; for rev y, q is
/// replaced by q[L] - q[L-k]. Written with P, the prefix sums of x over a block of windows, q[k] = P[i+k] - P[i]
/// - k x[i] - s k(k-1)/2: the x[i] terms cancel, the offset of P cancels, so each term is four or five P values
/// plus s times a constant per j; P is built once per block, relative to a straight line through the block (which
/// the terms cannot see), so its values stay small. For m < kMtotFastFrom the terms are summed directly (3m per
/// window); from there on foldRegimeSum sums each fold and regime over all windows and j in O(windows + m).
/// sumsq accumulates the sum over windows and the 6m terms of (m z_j)^2; the window count N - 3m + 1 is the
/// Stable32 "#". Exact either way: O(N) per tau.
void sumsMtotdev(const double* x, int64_t n, int64_t m, SegmentSums* s) {
  const int64_t L = 3 * m;
  if (n < L) return;
  const int64_t nwin = n - L + 1;
  const int64_t h = L / 2, c = (L + 1) / 2;
  const double inv_span = 1.0 / (static_cast<double>(h) * static_cast<double>(c));
  const int64_t jmid = L / 2;            // last j that counts (pairs with L - j)
  const int64_t j1 = std::min(m, jmid);  // regime 1: j = 0..j1
  // slope coefficients per j: the terms applied to the ramp's prefix sums T(k) = k (k - 1) / 2
  auto T = [](int64_t k) { return 0.5L * static_cast<long double>(k) * static_cast<long double>(k - 1); };
  std::vector<double> tl(static_cast<size_t>(jmid) + 1), tr(static_cast<size_t>(jmid) + 1);
  for (int64_t j = 0; j <= jmid; ++j) {
    if (j <= j1) {
      tl[j] = static_cast<double>(T(j) + 3 * T(m - j) - 3 * T(2 * m - j) + T(3 * m - j));
      tr[j] = static_cast<double>(2 * T(L) - T(3 * m - j) - 3 * T(2 * m + j) + 3 * T(m + j) - T(j));
    } else {
      tl[j] = static_cast<double>(T(j) - 3 * T(j - m) - 3 * T(2 * m - j) + T(3 * m - j));
      tr[j] = static_cast<double>(-4 * T(L) - T(3 * m - j) + 3 * T(4 * m - j) + 3 * T(m + j) - T(j));
    }
  }
  const bool fast = m >= kMtotFastFrom;
  const std::vector<FoldTerm> left1 = {{1, 1, 0}, {3, -1, m}, {-3, -1, 2 * m}, {1, -1, 3 * m}};
  const std::vector<FoldTerm> right1 = {{2, 0, L}, {-1, -1, 3 * m}, {-3, 1, 2 * m}, {3, 1, m}, {-1, 1, 0}};
  const std::vector<FoldTerm> left2 = {{1, 1, 0}, {-3, 1, -m}, {-3, -1, 2 * m}, {1, -1, 3 * m}};
  const std::vector<FoldTerm> right2 = {{-4, 0, L}, {-1, -1, 3 * m}, {3, -1, 4 * m}, {3, 1, m}, {-1, 1, 0}};
  // blocks of 2L windows sharing one prefix-sum array: short enough that the block's phase, relative to a line,
  // stays comparable to the terms (a block of 4096 windows lost 5e-8 at m = 8 on a random-walk FM record)
  const int64_t block = std::max<int64_t>(64, std::min<int64_t>(2 * L, int64_t(1) << 18));
  FoldWorkspace ws;
  std::vector<double> slopes;
  std::vector<double> P;
  long double total = 0;
  for (int64_t i0 = 0; i0 < nwin; i0 += block) {
    const int64_t nb = std::min(nwin, i0 + block) - i0;
    const int64_t count = (nb - 1) + L;  // samples x[i0 .. i0+count-1] are used
    const double x_ref = x[i0];
    const double b = count > 1 ? (x[i0 + count - 1] - x_ref) / static_cast<double>(count - 1) : 0.0;
    P.resize(static_cast<size_t>(count) + 1);
    long double acc = 0;
    P[0] = 0;
    for (int64_t k = 0; k < count; ++k) {
      acc += (x[i0 + k] - x_ref) - b * static_cast<double>(k);
      P[k + 1] = static_cast<double>(acc);
    }
    const double* pp = P.data();
    auto zl1 = [&](const double* p, double p0, double slope, int64_t j) {
      return p[j] + 3.0 * p[m - j] - 3.0 * p[2 * m - j] + p[3 * m - j] - 2.0 * p0 - slope * tl[j];
    };
    auto zr1 = [&](const double* p, double pL, double slope, int64_t j) {
      return 2.0 * pL - p[3 * m - j] - 3.0 * p[2 * m + j] + 3.0 * p[m + j] - p[j] - slope * tr[j];
    };
    auto zl2 = [&](const double* p, double p0, double slope, int64_t j) {
      return p[j] - 3.0 * p[j - m] - 3.0 * p[2 * m - j] + p[3 * m - j] + 4.0 * p0 - slope * tl[j];
    };
    auto zr2 = [&](const double* p, double pL, double slope, int64_t j) {
      return -4.0 * pL - p[3 * m - j] + 3.0 * p[4 * m - j] + 3.0 * p[m + j] - p[j] - slope * tr[j];
    };
    auto sq = [](double a, double b2) { return a * a + b2 * b2; };
    // weight-1 terms (j = 0 and, L even, j = L/2) of every window, direct
    long double ends = 0, all = 0;
    slopes.resize(static_cast<size_t>(nb));
    for (int64_t i = 0; i < nb; ++i) {
      const double* p = pp + i;
      const double p0 = p[0], pL = p[L];
      const double slope = ((pL - p[L - h]) - (p[h] - p0)) * inv_span;
      slopes[i] = slope;
      double e = sq(zl1(p, p0, slope, 0), zr1(p, pL, slope, 0));
      if (L % 2 == 0)
        e += jmid <= j1 ? sq(zl1(p, p0, slope, jmid), zr1(p, pL, slope, jmid))
                        : sq(zl2(p, p0, slope, jmid), zr2(p, pL, slope, jmid));
      ends += e;
      if (fast) continue;
      double a = 0;  // all j = 0..L/2 (m < kMtotFastFrom: at most 11 of them)
      for (int64_t j = 0; j <= j1; ++j) a += sq(zl1(p, p0, slope, j), zr1(p, pL, slope, j));
      for (int64_t j = j1 + 1; j <= jmid; ++j) a += sq(zl2(p, p0, slope, j), zr2(p, pL, slope, j));
      all += a;
    }
    if (fast) {
      const double* sl = slopes.data();
      all = foldRegimeSum(pp, nb, sl, left1, 0, j1, &ws) + foldRegimeSum(pp, nb, sl, right1, 0, j1, &ws);
      if (jmid > j1)
        all += foldRegimeSum(pp, nb, sl, left2, j1 + 1, jmid, &ws) +
               foldRegimeSum(pp, nb, sl, right2, j1 + 1, jmid, &ws);
    }
    total += 2 * all - ends;
  }
  s->sumsq += total;
  s->terms += nwin;
}

}  // namespace

DevKind devKindFromName(const std::string& name) {
  if (name == "adev") return DevKind::Adev;
  if (name == "oadev") return DevKind::Oadev;
  if (name == "mdev") return DevKind::Mdev;
  if (name == "tdev") return DevKind::Tdev;
  if (name == "hdev") return DevKind::Hdev;
  if (name == "ohdev") return DevKind::Ohdev;
  if (name == "totdev") return DevKind::Totdev;
  if (name == "mtotdev") return DevKind::Mtotdev;
  if (name == "ttotdev") return DevKind::Ttotdev;
  throw std::invalid_argument("unknown deviation '" + name +
                              "' (expected adev, oadev, mdev, tdev, hdev, ohdev, totdev, mtotdev, ttotdev)");
}

int64_t deviationMaxFactor(DevKind kind, int64_t n_phase) {
  switch (kind) {
    case DevKind::Adev:
    case DevKind::Oadev: return (n_phase - 1) / 2;
    case DevKind::Hdev:
    case DevKind::Ohdev: return (n_phase - 1) / 3;
    case DevKind::Mdev:
    case DevKind::Tdev:
    case DevKind::Mtotdev:
    case DevKind::Ttotdev: return n_phase / 3;
    case DevKind::Totdev: return n_phase - 1;
  }
  return 0;
}

void accumulateSegment(DevKind kind, const double* x, int64_t n, int64_t m, SegmentSums* s) {
  switch (kind) {
    case DevKind::Adev: sumsAdev(x, n, m, false, s); break;
    case DevKind::Oadev: sumsAdev(x, n, m, true, s); break;
    case DevKind::Hdev: sumsHdev(x, n, m, false, s); break;
    case DevKind::Ohdev: sumsHdev(x, n, m, true, s); break;
    case DevKind::Mdev:
    case DevKind::Tdev: sumsMdev(x, n, m, s); break;
    case DevKind::Totdev: sumsTotdev(x, n, m, s); break;
    case DevKind::Mtotdev:
    case DevKind::Ttotdev: sumsMtotdev(x, n, m, s); break;
  }
}

double varianceFromSums(DevKind kind, const SegmentSums& s, int64_t m, double tau0) {
  if (s.terms <= 0) return 0;
  const long double tau = static_cast<long double>(m) * tau0;
  const long double mean_sq = s.sumsq / static_cast<long double>(s.terms);
  switch (kind) {
    case DevKind::Adev:
    case DevKind::Oadev:
    case DevKind::Totdev: return static_cast<double>(mean_sq / (2.0L * tau * tau));
    case DevKind::Hdev:
    case DevKind::Ohdev: return static_cast<double>(mean_sq / (6.0L * tau * tau));
    case DevKind::Mdev: return static_cast<double>(mean_sq / (2.0L * m * m * tau * tau));
    case DevKind::Tdev: return static_cast<double>(mean_sq / (6.0L * m * m));
    // sumsq holds (m z)^2 over the 6m terms of each window (see sumsMtotdev): mtotvar = mean / (6m m^2 2 tau^2)
    case DevKind::Mtotdev: return static_cast<double>(mean_sq / (12.0L * m * m * m * tau * tau));
    case DevKind::Ttotdev: return static_cast<double>(mean_sq / (36.0L * m * m * m));
  }
  return 0;
}

const std::vector<std::string>& deviationNames() {
  static const std::vector<std::string> names = {"adev",  "oadev",  "mdev",    "tdev",   "hdev",
                                                 "ohdev", "totdev", "mtotdev", "ttotdev"};
  return names;
}

bool isDeviationName(const std::string& name) {
  const auto& n = deviationNames();
  return std::find(n.begin(), n.end(), name) != n.end();
}

namespace {

void checkFinite(const std::vector<double>& seg, size_t k) {
  for (size_t i = 0; i < seg.size(); ++i)
    if (!std::isfinite(seg[i]))
      throw std::invalid_argument("computeDeviation: non-finite sample at index " + std::to_string(i) +
                                  " of segment " + std::to_string(k));
}

/// Phase views of the segments: angle input is used in place, rate input is integrated into `storage`.
std::vector<PhaseSpan> toPhaseSpans(const std::vector<const std::vector<double>*>& segments, InputKind kind,
                                    double tau0, std::vector<std::vector<double>>* storage) {
  std::vector<PhaseSpan> spans;
  storage->reserve(segments.size());
  for (size_t k = 0; k < segments.size(); ++k) {
    const auto& seg = *segments[k];
    checkFinite(seg, k);
    if (seg.empty()) continue;
    if (kind == InputKind::Rate) {
      storage->push_back(rateToAngle(seg, tau0));
      spans.push_back({storage->back().data(), static_cast<int64_t>(storage->back().size())});
    } else {
      spans.push_back({seg.data(), static_cast<int64_t>(seg.size())});
    }
  }
  return spans;
}

/// Overlapping-Allan sums of one span for every factor m <= kBlockedMaxM at once, cache-blocked: the terms are taken
/// in chunks of kChunk, and every m sums its terms of the chunk while x[chunk, chunk + 2m] is still in cache (per m,
/// one pass over a long record would stream it from memory once per tau). kChunk is a multiple of sumSquares'
/// 1024-term blocks, so each m's sum is formed from the same double blocks as sumsAdev's (only the long-double
/// additions of the chunk totals are grouped differently).
constexpr int64_t kBlockedMaxM = 4096, kChunk = 16384;

void sumsOadevBlocked(const double* x, int64_t n, const std::vector<int64_t>& ms, std::vector<SegmentSums>* sums) {
  std::vector<int64_t> count(ms.size());
  for (size_t k = 0; k < ms.size(); ++k) count[k] = std::max<int64_t>(0, n - 2 * ms[k]);
  for (int64_t c = 0; c < n; c += kChunk) {
    for (size_t k = 0; k < ms.size(); ++k) {
      const int64_t m = ms[k], end = std::min(count[k], c + kChunk);
      if (c >= end) continue;
      const double* xc = x + c;
      (*sums)[k].sumsq += sumSquares(end - c, [xc, m](int64_t i) { return xc[i + 2 * m] - 2.0 * xc[i + m] + xc[i]; });
    }
  }
  for (size_t k = 0; k < ms.size(); ++k) (*sums)[k].terms += count[k];
}

DeviationCurve computeOnSpans(DevKind dk, const std::string& name, const std::vector<PhaseSpan>& phases, double tau0,
                              const std::vector<int64_t>& factors, const DeviationOptions& options) {
  DeviationCurve curve;
  curve.name = name;
  curve.tau0 = tau0;
  for (const auto& p : phases) curve.n_phase += p.n > 1 ? p.n : 0;
  // oadev at small factors: all of them in one cache-blocked pass per span.
  std::map<int64_t, SegmentSums> blocked;
  if (dk == DevKind::Oadev) {
    std::vector<int64_t> small;
    for (int64_t m : factors)
      if (m >= 1 && m <= kBlockedMaxM) small.push_back(m);
    if (small.size() > 1) {
      std::vector<SegmentSums> acc(small.size());
      for (const auto& p : phases) {
        if (p.n < 2) continue;
        std::vector<int64_t> ms;
        std::vector<size_t> at;
        for (size_t k = 0; k < small.size(); ++k)
          if (small[k] <= deviationMaxFactor(dk, p.n) && p.n >= 2 * small[k] + 1) ms.push_back(small[k]), at.push_back(k);
        std::vector<SegmentSums> part(ms.size());
        sumsOadevBlocked(p.x, p.n, ms, &part);
        for (size_t j = 0; j < ms.size(); ++j) {
          acc[at[j]].sumsq += part[j].sumsq;
          acc[at[j]].terms += part[j].terms;
        }
      }
      for (size_t k = 0; k < small.size(); ++k) blocked[small[k]] = acc[k];
    }
  }
  for (int64_t m : factors) {
    if (m < 1) throw std::invalid_argument("computeDeviation: averaging factor must be >= 1");
    SegmentSums s;
    const auto b = blocked.find(m);
    if (b != blocked.end()) {
      s = b->second;
    } else {
      for (const auto& p : phases) {
        if (p.n < 2 || m > deviationMaxFactor(dk, p.n)) continue;
        accumulateSegment(dk, p.x, p.n, m, &s);
      }
    }
    if (s.terms <= 0) continue;
    DeviationPoint pt;
    pt.m = m;
    pt.tau = static_cast<double>(m) * tau0;
    pt.n_terms = s.terms;
    pt.var = varianceFromSums(dk, s, m, tau0);
    pt.dev = std::sqrt(std::max(0.0, pt.var));
    if (options.compute_edf) {
      const int a = identifyNoiseAlpha(dk, phases, m);
      pt.alpha = a != kNoAlpha ? a : (curve.points.empty() ? 0 : curve.points.back().alpha);
    }
    curve.points.push_back(pt);
  }
  if (options.compute_edf) fillConfidence(&curve, options.confidence, options.chi2);
  return curve;
}

void checkCommon(double tau0, const DeviationOptions& options) {
  if (!(tau0 > 0) || !std::isfinite(tau0)) throw std::invalid_argument("computeDeviation: tau0 must be finite and > 0");
  if (options.compute_edf && !(options.confidence > 0 && options.confidence < 1))
    throw std::invalid_argument("computeDeviation: confidence must be in (0,1)");
}

DeviationCurve computeImpl(const std::string& name, const std::vector<const std::vector<double>*>& segments,
                           InputKind kind, double tau0, const std::vector<int64_t>* factors,
                           const DeviationOptions& options) {
  const DevKind dk = devKindFromName(name);
  checkCommon(tau0, options);
  std::vector<std::vector<double>> storage;
  const auto spans = toPhaseSpans(segments, kind, tau0, &storage);
  if (factors) return computeOnSpans(dk, name, spans, tau0, *factors, options);
  int64_t longest = 0;
  for (const auto& s : spans) longest = std::max(longest, s.n);
  const auto grid = tauGridFactors(options.grid, deviationMaxFactor(dk, longest));
  return computeOnSpans(dk, name, spans, tau0, grid, options);
}

std::vector<const std::vector<double>*> pointers(const std::vector<std::vector<double>>& segments) {
  std::vector<const std::vector<double>*> p;
  for (const auto& s : segments) p.push_back(&s);
  return p;
}

}  // namespace

DeviationCurve computeDeviationAt(const std::string& name, const std::vector<std::vector<double>>& segments,
                                  InputKind kind, double tau0, const std::vector<int64_t>& factors,
                                  const DeviationOptions& options) {
  return computeImpl(name, pointers(segments), kind, tau0, &factors, options);
}

DeviationCurve computeDeviationAt(const std::string& name, const std::vector<double>& samples, InputKind kind,
                                  double tau0, const std::vector<int64_t>& factors, const DeviationOptions& options) {
  return computeImpl(name, {&samples}, kind, tau0, &factors, options);
}

int64_t deviationMaxFactor(const std::string& name, int64_t n_phase) {
  return deviationMaxFactor(devKindFromName(name), n_phase);
}

DeviationCurve computeDeviation(const std::string& name, const std::vector<std::vector<double>>& segments,
                                InputKind kind, double tau0, const DeviationOptions& options) {
  return computeImpl(name, pointers(segments), kind, tau0, nullptr, options);
}

DeviationCurve computeDeviation(const std::string& name, const std::vector<double>& samples, InputKind kind,
                                double tau0, const DeviationOptions& options) {
  return computeImpl(name, {&samples}, kind, tau0, nullptr, options);
}

DeviationCurve oadev(const std::vector<double>& rate, double tau0, const DeviationOptions& options) {
  return computeDeviation("oadev", rate, InputKind::Rate, tau0, options);
}

}  // namespace gyro_allan
