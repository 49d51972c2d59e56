// Coverage study of the coefficient intervals: simulated gyros with declared IEEE 952 noise, the full analyzeAxis,
// and per sensor class and term how often [lo68, hi68] / [lo95, hi95] hold the truth, plus bias, phantom and
// detection rates, and what users see: how far the reported model's Allan deviation is from the true one, next to a
// plain weighted least-squares baseline; one CSV line per axis-run and term, and summary tables.
//
//   coverage_study [--seeds A-B] [--classes a,b,...] [--duration S | --durations S1,S2,...] [--rate HZ]
//                  [--max-samples N] [--threads N] [--csv FILE] [--method auto|joint_fit|wavelet_split]
//                  [--tau-grid G] [--no-model-check] [--no-wavelet-split] [--sawtooth-replicas N] [--list]
//                  [--bound] [--define NAME:key=value,...]...
//
// --define adds a class of your own (a held-out class: nothing was tuned on it), in the units of the table below:
//   --define my_ramp:rate=200,hours=1,n=0.1,b=0.8,k=0.5,r=40      keys rate (Hz), hours, q (arcsec), n, b, k,
//   r, in (deg/h input rate), dither (1 or 0; default 1). Unset terms are 0. Repeatable. With --define only the
//   defined classes run unless --classes names others too.
//
// --bound prints, per class, what one record allows instead of running the study: the Cramer-Rao bound on the model
// ADEV at T/10 from the record's exact likelihood (information_bound.hpp) and the maximum-likelihood fit of that
// likelihood on one Gaussian draw per seed, told the structure or not (docs/fit.md, "What one record allows").
//
// Seeds 1-999 are the tuning set (1-30 by convention), 1001- the validation set (1001-1030); the output says which.
// Default: seeds 1-20, every class at its default duration and rate.
//
// Classes (declared truth; conventional units: Q arcsec, N deg/sqrt(h), B deg/h, K deg/h/sqrt(h), R deg/h^2,
// input deg/h; SI in classes() below). Default record per class; --duration / --durations override it.
//
//   class         | Q    | N      | B     | K     | R | input | rate, length | notes
//   --------------+------+--------+-------+-------+---+-------+--------------+-------------------------------------
//   consumer      | -    | 0.25   | 8     | 10    | - | -     | 200 Hz, 1 h  | consumer MEMS (BMI088/ICM-20948)
//   tactical      | -    | 0.1    | 0.8   | 0.5   | - | -     | 200 Hz, 1 h  | tactical MEMS (ADIS1649x), K small
//   tactical_ramp | -    | 0.1    | 0.8   | 0.5   | 2 | -     | 200 Hz, 1 h  | the same with a ramp (the only R > 0)
//   fog           | -    | 0.005  | 0.05  | -     | - | -     | 100 Hz, 2 h  | navigation FOG: N and B only
//   rlg_dither    | 0.35 | 0.002  | 0.005 | -     | - | 0     | 100 Hz, 2 h  | dithered RLG (dither = true)
//   rlg_saw0      | 0.35 | 0.002  | 0.005 | -     | - | 0     | 100 Hz, 2 h  | undithered RLG (dither = false). Q 0.35
//   rlg_saw1      | 0.35 | 0.002  | 0.005 | -     | - | 1     | 100 Hz, 2 h  |   arcsec: pulse weight Q*sqrt(12) = 1.2
//   rlg_saw2      | 0.35 | 0.002  | 0.005 | -     | - | 2     | 100 Hz, 2 h  |   arcsec (28 cm ring); a constant input
//   rlg_saw5      | 0.35 | 0.002  | 0.005 | -     | - | 5     | 100 Hz, 2 h  |   makes the quantization a sawtooth
//   rlg_saw10     | 0.35 | 0.002  | 0.005 | -     | - | 10    | 100 Hz, 2 h  |
//   rlg_saw15     | 0.35 | 0.002  | 0.005 | -     | - | 15    | 100 Hz, 2 h  |
//   issue         | -    | 0.6875 | 2.063 | 12.38 | - | -     | 100 Hz, 1 h  | the issue's example: N 2e-4 rad/sqrt(s),
//                 |      |        |       |       |   |       |              |   B 1e-5 rad/s, K 1e-6 rad/s/sqrt(s)
//   nk            | -    | 0.6875 | -     | 12.38 | - | -     | 100 Hz, 1 h  | the same with N and K only (phantom B?)
//
// The rate is lowered to max-samples/duration when above it (default 720000: a 4 h record runs at 50 Hz).
// Each (class, duration, seed) simulates with its own stream: simulateAxis seed = seed + (FNV-1a hash of
// "class@duration" << 32), so classes and durations are independent and a run is reproducible from its CSV line.
// Measured (2 threads on a 2-core machine shared with other jobs, load 2.5-4): seeds 1-20 over all classes except
// rlg_saw1 and rlg_saw2 (220 runs) took 83-132 s wall; --durations 600,3600,14400 (660 runs) 194 s. Results do not
// depend on --threads.
//
// Per run (AnalysisOptions defaults except what the command line sets; one segment = the whole record) and term t
// with truth T, the reported Coefficient c = AxisAnalysis::coefficients[t]:
//   T > 0, c supported:    covered68 = lo68 <= T <= hi68, covered95 = lo95 <= T <= hi95      ("sup" columns)
//   T > 0, c unsupported:  the same, with its interval (the unified (Feldman-Cousins) interval, which may start
//                          above 0)                                                            ("ub" columns)
//   cov68 / cov95: over both kinds. bias: median of value/T - 1 over supported terms with T > 0.
//   phantom: fraction of runs with T = 0 where the term is supported; detect: fraction with T > 0 where it is.
//   noint: cases with T > 0 whose interval fields are empty (hi95 = 0 although value or sigma is not); they count
//          as not covered.
// Every coverage figure is followed by its binomial standard error sqrt(p(1-p)/n).
//
// What users see. worst (per run) = max over 60 log-spaced tau in [10/rate, duration/10] of
// |adev_model(tau)/adev_true(tau) - 1|, both from the IEEE formula (noiseTermBasis(term, tau)): adev_model from the
// reported values (Coefficient::value of all five terms, supported or not), adev_true from the declared truth (for
// an undithered rlg_saw class that is a definition). The baseline is a plain weighted least-squares fit of the same
// record's oadev curve: fitNoiseModel with FitWeighting::Edf, significance 0 and decorrelate false (every term at
// its non-negative estimate, intervals from the EDF-weighted covariance); its worst is computed the same way.
//   Per-term tables, added columns: w68 / base-w68 = median (hi68 - lo68)/truth over the cases with truth > 0 of the
//   answer / the baseline; base-cov68 / base-cov95 = the baseline's coverage (as cov68 / cov95).
//   "What users see" table, per class: n = runs ok; in25 / med-worst = fraction of runs with worst <= 25 % and the
//   median worst, for the answer and the baseline; good>50% = fraction of the n runs whose answer's worst is
//   > 50 % while its verdict is good; out68 = reported values (run x term) outside their own [lo68, hi68] (relative
//   tolerance 1e-9; an empty or NaN interval counts as outside).
// CSV columns: class, duration_s, rate_hz, seed, sim_seed, term, truth, the answer's value, sigma, lo68, hi68,
// lo95, hi95, supported; the run's method, quality, rms_log10, chi2_dof; the term's evidence; the run's model_worst
// and base_worst (repeated on its five lines); the baseline's base_value, base_lo68, base_hi68, base_lo95,
// base_hi95; error (empty when the run succeeded).
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <map>
#include <mutex>
#include <random>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "gyro_allan/analysis.hpp"
#include "information_bound.hpp"
#include "kit.hpp"
#include "gyro_allan/noise_model.hpp"
#include "gyro_allan/simulate.hpp"
#include "gyro_allan/stats.hpp"

using namespace gyro_allan;

namespace {

using namespace study;  // units, parsing (kit.hpp)
const char* const kTermShort[kNumTerms] = {"Q", "N", "B", "K", "R"};

struct Class {
  std::string name;
  double rate_hz = 100;
  double duration_s = 3600;
  AxisNoise a;
};

Class make(const char* name, double rate_hz, double hours, double q_arcsec, double n, double b, double k,
           bool dither = true, double input_deg_h = 0) {
  Class c;
  c.name = name;
  c.rate_hz = rate_hz;
  c.duration_s = hours * 3600.0;
  c.a.quantization = q_arcsec * kArcsec;
  c.a.dither = dither;
  c.a.angle_random_walk = n * kDegPerSqrtH;
  c.a.bias_instability = b * kDegPerH;
  c.a.rate_random_walk = k * kDegPerHSqrtH;
  c.a.input_rate = input_deg_h * kDegPerH;
  return c;
}

std::vector<Class> classes() {
  std::vector<Class> c;
  c.push_back(make("consumer", 200, 1, 0, 0.25, 8, 10));
  c.push_back(make("tactical", 200, 1, 0, 0.1, 0.8, 0.5));
  c.push_back(make("tactical_ramp", 200, 1, 0, 0.1, 0.8, 0.5));
  c.back().a.rate_ramp = 2 * kDegPerH2;
  c.push_back(make("fog", 100, 2, 0, 0.005, 0.05, 0));
  c.push_back(make("rlg_dither", 100, 2, 0.35, 0.002, 0.005, 0, true));
  c.push_back(make("rlg_saw0", 100, 2, 0.35, 0.002, 0.005, 0, false, 0));
  c.push_back(make("rlg_saw1", 100, 2, 0.35, 0.002, 0.005, 0, false, 1));
  c.push_back(make("rlg_saw2", 100, 2, 0.35, 0.002, 0.005, 0, false, 2));
  c.push_back(make("rlg_saw5", 100, 2, 0.35, 0.002, 0.005, 0, false, 5));
  c.push_back(make("rlg_saw10", 100, 2, 0.35, 0.002, 0.005, 0, false, 10));
  c.push_back(make("rlg_saw15", 100, 2, 0.35, 0.002, 0.005, 0, false, 15));
  c.push_back(make("issue", 100, 1, 0, 0, 0, 0));  // given in SI
  c.back().a.angle_random_walk = 2e-4;
  c.back().a.bias_instability = 1e-5;
  c.back().a.rate_random_walk = 1e-6;
  c.push_back(make("nk", 100, 1, 0, 0, 0, 0));
  c.back().a.angle_random_walk = 2e-4;
  c.back().a.rate_random_walk = 1e-6;
  return c;
}

double truthOf(const AxisNoise& a, int t) {
  switch (t) {
    case kQuantization: return a.quantization;
    case kAngleRandomWalk: return a.angle_random_walk;
    case kBiasInstability: return a.bias_instability;
    case kRateRandomWalk: return a.rate_random_walk;
    case kRateRamp: return std::abs(a.rate_ramp);
    default: return 0;
  }
}

/// IEEE 952 Allan variance at tau of five coefficients (rad, rad/sqrt(s), ...): sum of value^2 * noiseTermBasis.
double ieeeAvar(const std::array<double, kNumTerms>& coef, double tau) {
  double v = 0;
  for (int t = 0; t < kNumTerms; ++t) {
    const double c = coef[static_cast<size_t>(t)];
    v += c * c * noiseTermBasis(t, tau);
  }
  return v;
}

/// max |adev_model/adev_true - 1| over 60 log-spaced tau in [10/rate, duration/10], the model from c's values.
double worstAdevError(const std::array<Coefficient, kNumTerms>& c, const AxisNoise& truth, double rate_hz,
                      double duration_s) {
  std::array<double, kNumTerms> model{}, actual{};
  for (int t = 0; t < kNumTerms; ++t) {
    model[static_cast<size_t>(t)] = c[static_cast<size_t>(t)].value;
    actual[static_cast<size_t>(t)] = truthOf(truth, t);
  }
  const int kTaus = 60;
  const double lo = 10.0 / rate_hz, hi = duration_s / 10.0;
  double worst = 0;
  for (int i = 0; i < kTaus; ++i) {
    const double tau = lo * std::pow(hi / lo, static_cast<double>(i) / (kTaus - 1));
    worst = std::max(worst, std::abs(std::sqrt(ieeeAvar(model, tau) / ieeeAvar(actual, tau)) - 1.0));
  }
  return worst;
}

uint64_t fnv1a(const std::string& s) {
  uint64_t h = 1469598103934665603ULL;
  for (unsigned char ch : s) h = (h ^ ch) * 1099511628211ULL;
  return h;
}

/// One class at one duration and rate.
struct Job {
  Class k;
  double duration_s = 0;
  double rate_hz = 0;
  std::string key;  // class name, with @duration when several durations run
  uint64_t stream = 0;  // added to the seed: (FNV-1a of "class@duration") << 32
};

struct Run {
  size_t job = 0;
  int seed = 0;
  uint64_t sim_seed = 0;
  bool ok = false;
  std::string error;
  std::string method;
  std::string quality;  // the axis's verdict (good | doubtful | bad); a bad axis's intervals are [0, inf)
  double rms_log10 = 0, chi2_dof = 0;
  std::array<double, kNumTerms> evidence{};  // FitResult::evidence of the same fit
  std::array<Coefficient, kNumTerms> c;
  std::array<Coefficient, kNumTerms> base;  // the baseline: plain weighted least squares of the same oadev
  double model_worst = std::numeric_limits<double>::quiet_NaN();  // worstAdevError of c (NaN: the run failed)
  double base_worst = std::numeric_limits<double>::quiet_NaN();   // ... of base (NaN also: the baseline fit failed)
};

/// Coverage tallies of one (class, term) cell.
struct Cell {
  int n = 0, in68 = 0, in95 = 0;        // truth > 0, both kinds
  int ns = 0, s68 = 0, s95 = 0;         // supported
  int nu = 0, u68 = 0, u95 = 0;         // unsupported (upper bounds)
  int noint = 0;
  int n0 = 0, phantom = 0;              // truth == 0
  std::vector<double> rel;              // value/truth - 1, supported with truth > 0
  std::vector<double> w68, base_w68;    // (hi68 - lo68)/truth, truth > 0: the answer's, the baseline's
  int base68 = 0, base95 = 0;           // the baseline's coverage, truth > 0 (of n)
  void add(double truth, const Coefficient& c, const Coefficient& base) {
    if (truth > 0) {
      ++n;
      w68.push_back((c.hi68 - c.lo68) / truth);
      base_w68.push_back((base.hi68 - base.lo68) / truth);
      base68 += base.lo68 <= truth && truth <= base.hi68;
      base95 += base.lo95 <= truth && truth <= base.hi95;
      bool c68, c95;
      if (c.supported) {
        c68 = c.lo68 <= truth && truth <= c.hi68;
        c95 = c.lo95 <= truth && truth <= c.hi95;
        ++ns;
        s68 += c68;
        s95 += c95;
        rel.push_back(c.value / truth - 1.0);
      } else {
        c68 = c.lo68 <= truth && truth <= c.hi68;  // lo is 0 unless the unified interval excludes 0
        c95 = c.lo95 <= truth && truth <= c.hi95;
        ++nu;
        u68 += c68;
        u95 += c95;
      }
      in68 += c68;
      in95 += c95;
      if (c.hi95 <= 0 && (c.value > 0 || c.sigma > 0)) ++noint;
    } else {
      ++n0;
      phantom += c.supported;
    }
  }
  void merge(const Cell& o) {
    n += o.n, in68 += o.in68, in95 += o.in95, ns += o.ns, s68 += o.s68, s95 += o.s95, nu += o.nu, u68 += o.u68,
        u95 += o.u95, noint += o.noint, n0 += o.n0, phantom += o.phantom, base68 += o.base68, base95 += o.base95;
    rel.insert(rel.end(), o.rel.begin(), o.rel.end());
    w68.insert(w68.end(), o.w68.begin(), o.w68.end());
    base_w68.insert(base_w68.end(), o.base_w68.begin(), o.base_w68.end());
  }
};

/// The "what users see" tallies of one class (or all): worst errors of the answer and the baseline per run.
struct Seen {
  int n = 0, in25 = 0, good50 = 0, out68 = 0;
  int base_n = 0, base_in25 = 0;
  std::vector<double> worst, base_worst;
  void add(const Run& r) {
    ++n;
    in25 += r.model_worst <= 0.25;
    good50 += r.model_worst > 0.5 && r.quality == "good";
    worst.push_back(r.model_worst);
    for (const auto& c : r.c)
      out68 += !(c.value >= c.lo68 * (1 - 1e-9) && c.value <= c.hi68 * (1 + 1e-9));
    if (std::isfinite(r.base_worst)) {
      ++base_n;
      base_in25 += r.base_worst <= 0.25;
      base_worst.push_back(r.base_worst);
    }
  }
  void merge(const Seen& o) {
    n += o.n, in25 += o.in25, good50 += o.good50, out68 += o.out68, base_n += o.base_n, base_in25 += o.base_in25;
    worst.insert(worst.end(), o.worst.begin(), o.worst.end());
    base_worst.insert(base_worst.end(), o.base_worst.begin(), o.base_worst.end());
  }
};

/// "0.650±0.107" (8 + 1 + 5 chars), or "-" when n == 0.
std::string prop(int k, int n) {
  if (n <= 0) return "-";
  const double p = static_cast<double>(k) / n;
  char buf[48];
  std::snprintf(buf, sizeof buf, "%.3f±%.3f", p, std::sqrt(p * (1 - p) / n));
  return buf;
}

std::string frac(int k, int n) {
  if (n <= 0) return "-";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.2f", static_cast<double>(k) / n);
  return buf;
}

void printHeader() {
  std::printf("%-14s %-4s %4s %-12s %-12s %4s %-12s %-12s %4s %-12s %-12s %9s %5s %8s %7s %6s %8s %8s %-12s %-12s\n",
              "class", "term", "n", "cov68", "cov95", "ns", "sup-cov68", "sup-cov95", "nu", "ub-cov68", "ub-cov95",
              "bias(med)", "noint", "phantom", "detect", "n0", "w68", "base-w68", "base-cov68", "base-cov95");
}

// printf pads by bytes; "±" is two bytes in UTF-8, so pad by hand.
std::string pad(const std::string& s, size_t width) {
  size_t chars = 0;
  for (unsigned char ch : s) chars += (ch & 0xC0) != 0x80;
  return chars >= width ? s : s + std::string(width - chars, ' ');
}

/// median(v) as "%.3g", or "-" when v is empty.
std::string medianText(const std::vector<double>& v) {
  if (v.empty()) return "-";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", median(v));
  return buf;
}

void printRow(const std::string& name, int t, const Cell& c) {
  char bias[32] = "-";
  if (!c.rel.empty()) std::snprintf(bias, sizeof bias, "%+.2f%%", 100 * median(c.rel));
  std::printf("%-14s %-4s %4d %s %s %4d %s %s %4d %s %s %9s %5d %8s %7s %6d %8s %8s %s %s\n", name.c_str(),
              kTermShort[t], c.n, pad(prop(c.in68, c.n), 12).c_str(), pad(prop(c.in95, c.n), 12).c_str(), c.ns,
              pad(prop(c.s68, c.ns), 12).c_str(), pad(prop(c.s95, c.ns), 12).c_str(), c.nu,
              pad(prop(c.u68, c.nu), 12).c_str(), pad(prop(c.u95, c.nu), 12).c_str(), bias, c.noint,
              frac(c.phantom, c.n0).c_str(), frac(c.ns, c.n).c_str(), c.n0, medianText(c.w68).c_str(),
              medianText(c.base_w68).c_str(), pad(prop(c.base68, c.n), 12).c_str(),
              pad(prop(c.base95, c.n), 12).c_str());
}

void printSeenHeader() {
  std::printf("%-14s %4s %6s %10s %11s %15s %9s %6s\n", "class", "n", "in25", "med-worst", "base-in25",
              "base-med-worst", "good>50%", "out68");
}

void printSeenRow(const std::string& name, const Seen& s) {
  std::printf("%-14s %4d %6s %10s %11s %15s %9s %6d\n", name.c_str(), s.n, frac(s.in25, s.n).c_str(),
              medianText(s.worst).c_str(), frac(s.base_in25, s.base_n).c_str(), medianText(s.base_worst).c_str(),
              frac(s.good50, s.n).c_str(), s.out68);
}

/// A class from "--define NAME:key=value,..." (conventional units, as in the table at the top of this file).
Class defineClass(const std::string& spec) {
  const size_t colon = spec.find(':');
  const std::string name = spec.substr(0, colon);
  if (name.empty() || colon == std::string::npos)
    throw std::invalid_argument("--define: NAME:key=value,... expected, got '" + spec + "'");
  Class c = make(name.c_str(), 100, 1, 0, 0, 0, 0);
  bool rate = false, hours = false;
  for (const auto& kv : splitList(spec.substr(colon + 1))) {
    const size_t eq = kv.find('=');
    const std::string key = kv.substr(0, eq), val = eq == std::string::npos ? "" : kv.substr(eq + 1);
    const double v = parseNumber(val, "--define " + name + " " + key, true);
    if (key == "rate") c.rate_hz = v, rate = v > 0;
    else if (key == "hours") c.duration_s = v * 3600.0, hours = v > 0;
    else if (key == "q") c.a.quantization = v * kArcsec;
    else if (key == "n") c.a.angle_random_walk = v * kDegPerSqrtH;
    else if (key == "b") c.a.bias_instability = v * kDegPerH;
    else if (key == "k") c.a.rate_random_walk = v * kDegPerHSqrtH;
    else if (key == "r") c.a.rate_ramp = v * kDegPerH2;
    else if (key == "in") c.a.input_rate = v * kDegPerH;
    else if (key == "dither" && (v == 0 || v == 1)) c.a.dither = v == 1;
    else throw std::invalid_argument("--define " + name + ": unknown key or value '" + kv + "'");
  }
  if (!rate || !hours) throw std::invalid_argument("--define " + name + ": rate and hours must be > 0");
  if (!(c.a.angle_random_walk > 0)) throw std::invalid_argument("--define " + name + ": n must be > 0");
  return c;
}

double parsePositive(const std::string& s, const char* what) { return parseNumber(s, what, false); }

/// The worst |adev_model/adev_true - 1| over worstAdevError's tau grid for squared coefficients s and truth a.
double worstOfSquares(const std::array<double, kNumTerms>& s, const AxisNoise& a, double rate_hz, double duration_s) {
  std::array<Coefficient, kNumTerms> c{};
  for (int t = 0; t < kNumTerms; ++t) c[static_cast<size_t>(t)].value = std::sqrt(std::max(0.0, s[static_cast<size_t>(t)]));
  return worstAdevError(c, a, rate_hz, duration_s);
}

/// --bound: per class, the Cramer-Rao bound on the model ADEV at T/10 from the record's differenced block means
/// (information_bound.hpp), for an estimator told everything but the class's own B, K, R ("told") and for one that
/// must also find N, B and K ("open"), with the share of axes a normal error of that size keeps within 25 %; and,
/// for classes without a ramp, the exact maximum-likelihood fit of the told and of the open terms on one Gaussian
/// draw of the block differences per seed (what the whole-record likelihood achieves: its in25, median worst error
/// and share off by more than 50 % over the same tau grid as the study).
void runBound(const std::vector<Job>& jobs, int s0, int s1) {
  std::printf("# bound: Cramer-Rao bound on the model ADEV at T/10 from the record's block means (blocks T/1200)\n"
              "# told: B, K, R unknown where the class has them, N and Q given; open: N, B, K unknown\n"
              "# ceiling: share of axes a normal error of that sd keeps within 25 %% at T/10 (the worst over tau is larger)\n"
              "# in25 / med: exact maximum likelihood of the told / open terms (non-negative) on one Gaussian draw per\n"
              "#   seed (%d draws): share of axes within 25 %%, median worst error and share off by more than 50 %% over the\n"
              "#   study's tau grid\n",
              s1 - s0 + 1);
  std::printf("%-14s %8s %8s %8s %8s %9s %9s %9s %9s %9s %9s\n", "class", "told_sd", "told_cl", "open_sd", "open_cl",
              "told_in25", "told_med", "told_o50", "open_in25", "open_med", "open_o50");
  for (const Job& j : jobs) {
    const AxisNoise& a = j.k.a;
    const std::array<double, 5> coef{a.quantization, a.angle_random_walk, a.bias_instability, a.rate_random_walk,
                                     std::abs(a.rate_ramp)};
    const double T = j.duration_s, block = T / 1200.0, tau_end = T / 10.0;
    std::array<bool, 5> told{false, false, coef[2] > 0, coef[3] > 0, coef[4] > 0};
    std::array<bool, 5> open{false, true, true, true, coef[4] > 0};
    auto ceiling = [](double sd) { return sd > 0 ? 1.0 - std::erfc(0.25 / sd / std::sqrt(2.0)) : 1.0; };
    // A class of N (and Q) alone leaves the told estimator nothing to find: its bound is 0.
    const bool told_any = told[2] || told[3] || told[4];
    const double sd_told = told_any ? adevInformationBound(coef, T, block, told, {tau_end}).rel_sd[0] : 0.0;
    const double sd_open = adevInformationBound(coef, T, block, open, {tau_end}).rel_sd[0];
    std::string ml[6] = {"-", "-", "-", "-", "-", "-"};  // in25, median, over50 of told, then of open
    if (coef[4] == 0) {
      const int n = static_cast<int>(std::floor(T / block)) - 2;
      std::array<double, 5> s{};
      for (int t = 0; t < 4; ++t) s[static_cast<size_t>(t)] = coef[static_cast<size_t>(t)] * coef[static_cast<size_t>(t)];
      const Eigen::LLT<Eigen::MatrixXd> chol(toeplitzMatrix(blockDifferenceAutocovariance(s, block, n), n));
      double avar_end = 0;
      for (int t = 0; t < 4; ++t) avar_end += s[static_cast<size_t>(t)] * noiseTermBasis(t, tau_end);
      std::array<double, 5> scale{};  // a free term's search scale: its truth, or (truth 0) its share of avar at T/10
      for (int t = 0; t < 4; ++t)
        scale[static_cast<size_t>(t)] =
            s[static_cast<size_t>(t)] > 0 ? s[static_cast<size_t>(t)] : avar_end / noiseTermBasis(t, tau_end);
      for (int mode = 0; mode < 2; ++mode) {
        const std::array<bool, 5>& which = mode == 0 ? told : open;
        std::vector<double> worst;
        for (int seed = s0; seed <= s1; ++seed) {
          std::mt19937_64 rng(static_cast<uint64_t>(seed) + j.stream);
          std::normal_distribution<double> g;
          Eigen::VectorXd e(n);
          for (int i = 0; i < n; ++i) e(i) = g(rng);
          const Eigen::VectorXd z = chol.matrixL() * e;
          // N and Q at their truth; a free term starts at its truth, or off where the truth lacks it.
          worst.push_back(worstOfSquares(blockLikelihoodFit(z, block, s, which, scale), a, j.rate_hz, T));
        }
        const double in25 =
            static_cast<double>(std::count_if(worst.begin(), worst.end(), [](double w) { return w <= 0.25; })) /
            static_cast<double>(worst.size());
        const double over50 =
            static_cast<double>(std::count_if(worst.begin(), worst.end(), [](double w) { return w > 0.5; })) /
            static_cast<double>(worst.size());
        std::sort(worst.begin(), worst.end());
        char buf[64];
        std::snprintf(buf, sizeof buf, "%.2f", in25);
        ml[3 * mode] = buf;
        std::snprintf(buf, sizeof buf, "%.3f", worst[worst.size() / 2]);
        ml[3 * mode + 1] = buf;
        std::snprintf(buf, sizeof buf, "%.3f", over50);
        ml[3 * mode + 2] = buf;
      }
    }
    std::printf("%-14s %8.3f %8.2f %8.3f %8.2f %9s %9s %9s %9s %9s %9s\n", j.key.c_str(), sd_told, ceiling(sd_told),
                sd_open, ceiling(sd_open), ml[0].c_str(), ml[1].c_str(), ml[2].c_str(), ml[3].c_str(), ml[4].c_str(),
                ml[5].c_str());
    std::fflush(stdout);
  }
}

void usage() {
  std::fprintf(stderr,
               "usage: coverage_study [--seeds A-B] [--classes a,b,...] [--duration S | --durations S1,S2,...]\n"
               "                      [--rate HZ] [--max-samples N] [--threads N] [--csv FILE]\n"
               "                      [--method auto|joint_fit|wavelet_split] [--tau-grid G] [--no-model-check]\n"
               "                      [--no-wavelet-split] [--sawtooth-replicas N] [--list] [--bound] [--define NAME:key=value,...]...\n"
               "  --sawtooth-replicas: records simulated per non-white quantization axis for Q's and N's bias and Q's\n"
               "  sigma, where the output is a detected pulse count (default 10, at least 2; 0: the analytic\n"
               "  allowance instead)\n"
               "  --bound: per class, the record's information bound and maximum-likelihood fits instead of the study\n"
               "  --define: a class of your own, e.g. my_ramp:rate=200,hours=1,n=0.1,b=0.8,k=0.5,r=40\n"
               "  (keys rate hours q n b k r in dither; units as --list; unset terms 0; repeatable)\n"
               "  seeds 1-999: tuning set (1-30), 1001-: validation set (1001-1030). Default 1-20.\n"
               "  rate: each class's rate (--list) unless --rate; lowered to max-samples/duration when above it\n"
               "  (default max-samples 720000 = 2 h at 100 Hz, so a 4 h record runs at 50 Hz).\n");
}

}  // namespace

int main(int argc, char** argv) {
  try {
    std::string seeds = "1-20", only, csv_path, durations;
    double duration_override = 0, rate_override = 0, max_samples = 720000;
    int threads = static_cast<int>(std::min(2u, std::max(1u, std::thread::hardware_concurrency())));
    bool list = false, bound = false;
    AnalysisOptions opt;
    std::vector<Class> defined;
    for (int i = 1; i < argc; ++i) {
      const std::string a = argv[i];
      auto next = [&]() -> std::string {
        if (i + 1 >= argc) throw std::invalid_argument(a + " needs a value");
        return argv[++i];
      };
      if (a == "--seeds") seeds = next();
      else if (a == "--classes" || a == "--class") only = next();
      else if (a == "--duration") duration_override = parsePositive(next(), "--duration");
      else if (a == "--durations") durations = next();
      else if (a == "--rate") rate_override = parsePositive(next(), "--rate");
      else if (a == "--max-samples") max_samples = parsePositive(next(), "--max-samples");
      else if (a == "--threads") threads = static_cast<int>(parsePositive(next(), "--threads"));
      else if (a == "--csv") csv_path = next();
      else if (a == "--method") {
        if (!parseRequestedMethod(next(), &opt.method)) throw std::invalid_argument("--method: auto, joint_fit or wavelet_split");
      }
      else if (a == "--tau-grid") {
        std::string err;
        if (!parseTauGrid(next(), &opt.deviation.grid, &err)) throw std::invalid_argument("--tau-grid: " + err);
      } else if (a == "--no-model-check") opt.model_check = false;
      else if (a == "--no-wavelet-split") opt.wavelet_split = false;
      else if (a == "--sawtooth-replicas") {
        const double v = parseNumber(next(), "--sawtooth-replicas", true);
        if (v != std::floor(v) || v == 1 || v > 1000)
          throw std::invalid_argument("--sawtooth-replicas: 0 (off) or a whole number 2..1000");
        opt.split.sawtooth_replicas = static_cast<int>(v);
      } else if (a == "--list") list = true;
      else if (a == "--bound") bound = true;
      else if (a == "--define") defined.push_back(defineClass(next()));
      else if (a == "--help" || a == "-h") {
        usage();
        return 0;
      } else {
        usage();
        throw std::invalid_argument("unknown argument '" + a + "'");
      }
    }
    if (duration_override > 0 && !durations.empty())
      throw std::invalid_argument("--duration and --durations exclude each other");

    std::vector<Class> all = classes();
    for (const auto& d : defined) {
      if (std::any_of(all.begin(), all.end(), [&](const Class& k) { return k.name == d.name; }))
        throw std::invalid_argument("--define: class '" + d.name + "' already exists");
      all.push_back(d);
      if (!only.empty()) only += ",";
      only += d.name;
    }
    if (list) {
      std::printf("%-14s %8s %8s %10s %10s %10s %10s %10s %6s %8s\n", "class", "rate_hz", "dur_s", "Q[arcsec]",
                  "N[d/rh]", "B[d/h]", "K[d/h/rh]", "R[d/h2]", "dither", "in[d/h]");
      for (const auto& k : all)
        std::printf("%-14s %8.0f %8.0f %10.4g %10.4g %10.4g %10.4g %10.4g %6d %8.3g\n", k.name.c_str(), k.rate_hz,
                    k.duration_s, k.a.quantization / kArcsec, k.a.angle_random_walk / kDegPerSqrtH,
                    k.a.bias_instability / kDegPerH, k.a.rate_random_walk / kDegPerHSqrtH, k.a.rate_ramp / kDegPerH2,
                    k.a.dither ? 1 : 0, k.a.input_rate / kDegPerH);
      return 0;
    }

    const SeedRange seed_range = parseSeeds(seeds);
    const int s0 = seed_range.first, s1 = seed_range.last;
    const char* set = seedSet(seed_range);

    std::vector<std::string> wanted = splitList(only);
    for (const auto& w : wanted)
      if (std::none_of(all.begin(), all.end(), [&](const Class& k) { return k.name == w; }))
        throw std::invalid_argument("unknown class '" + w + "' (--list shows them)");
    std::vector<double> durs;
    for (const auto& d : splitList(durations)) durs.push_back(parsePositive(d, "--durations"));
    if (duration_override > 0) durs = {duration_override};

    std::vector<Job> jobs;
    for (const auto& k : all) {
      if (!wanted.empty() && std::find(wanted.begin(), wanted.end(), k.name) == wanted.end()) continue;
      const std::vector<double> ds = durs.empty() ? std::vector<double>{k.duration_s} : durs;
      for (double d : ds) {
        Job j;
        j.k = k;
        j.duration_s = d;
        j.rate_hz = rate_override > 0 ? rate_override : k.rate_hz;
        if (j.rate_hz * d > max_samples) j.rate_hz = max_samples / d;
        j.key = k.name;
        j.stream = fnv1a(k.name + "@" + std::to_string(static_cast<long>(std::lround(d)))) << 32;
        if (durs.size() > 1) j.key += "@" + std::to_string(static_cast<long>(std::lround(d))) + "s";
        jobs.push_back(j);
      }
    }

    if (bound) {
      runBound(jobs, s0, s1);
      return 0;
    }

    std::vector<Run> runs;
    for (size_t j = 0; j < jobs.size(); ++j)
      for (int s = s0; s <= s1; ++s) {
        Run r;
        r.job = j;
        r.seed = s;
        r.sim_seed = static_cast<uint64_t>(s) + jobs[j].stream;
        runs.push_back(r);
      }

    std::printf("# coverage_study: seeds %d-%d (%s), %zu class runs x %d seeds = %zu axis-runs, %d thread(s)\n", s0,
                s1, set, jobs.size(), s1 - s0 + 1, runs.size(), threads);
    std::printf("# analyzeAxis: method %s, tau grid %s, wavelet split %s, model check %s, spikes removed %s\n",
                methodName(opt.method), tauGridName(opt.deviation.grid).c_str(), opt.wavelet_split ? "on" : "off",
                opt.model_check ? "on" : "off", opt.remove_spikes ? "yes" : "no");
    std::fflush(stdout);

    const auto t_start = std::chrono::steady_clock::now();
    std::atomic<size_t> next_run{0};
    std::mutex progress;
    size_t done = 0;
    auto worker = [&]() {
      for (;;) {
        const size_t i = next_run.fetch_add(1);
        if (i >= runs.size()) return;
        Run& r = runs[i];
        const Job& j = jobs[r.job];
        try {
          const int64_t n = static_cast<int64_t>(std::llround(j.rate_hz * j.duration_s));
          std::vector<std::vector<double>> seg(1);
          seg[0] = simulateAxis(j.k.a, j.rate_hz, n, r.sim_seed, 0);
          const AxisAnalysis a = analyzeAxis("x", seg, 1.0 / j.rate_hz, opt);
          r.c = a.coefficients;
          r.method = methodName(a.method);
          r.quality = qualityName(a.quality.quality);
          r.rms_log10 = a.final_error.rms_log10;
          r.chi2_dof = a.final_error.chi2_dof;
          const FitResult& f = answerFit(a);
          r.evidence = f.evidence;
          r.model_worst = worstAdevError(r.c, j.k.a, j.rate_hz, j.duration_s);
          FitOptions base_opt;
          base_opt.weighting = FitWeighting::Edf;
          base_opt.significance = 0;
          base_opt.decorrelate = false;
          const FitResult base = fitNoiseModel(a.oadev, base_opt);
          if (base.ok) {
            r.base = base.terms;
            r.base_worst = worstAdevError(r.base, j.k.a, j.rate_hz, j.duration_s);
          }
          r.ok = true;
        } catch (const std::exception& e) {
          r.error = e.what();
        }
        std::lock_guard<std::mutex> lock(progress);
        ++done;
        if (done % 20 == 0 || done == runs.size())
          std::fprintf(stderr, "\r%zu/%zu runs", done, runs.size()), std::fflush(stderr);
      }
    };
    std::vector<std::thread> pool;
    for (int t = 0; t < std::max(1, threads); ++t) pool.emplace_back(worker);
    for (auto& th : pool) th.join();
    std::fprintf(stderr, "\n");
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();

    if (!csv_path.empty()) {
      FILE* csv = std::fopen(csv_path.c_str(), "w");
      if (!csv) throw std::runtime_error("cannot write " + csv_path);
      std::fprintf(csv,
                   "class,duration_s,rate_hz,seed,sim_seed,term,truth,value,sigma,lo68,hi68,lo95,hi95,supported,"
                   "method,quality,rms_log10,chi2_dof,evidence,model_worst,base_worst,base_value,base_lo68,"
                   "base_hi68,base_lo95,base_hi95,error\n");
      for (const auto& r : runs) {
        const Job& j = jobs[r.job];
        for (int t = 0; t < kNumTerms; ++t) {
          const Coefficient& c = r.c[static_cast<size_t>(t)];
          const Coefficient& b = r.base[static_cast<size_t>(t)];
          std::string err = r.error;
          for (auto& ch : err)
            if (ch == ',' || ch == '"' || ch == '\n') ch = ';';
          std::fprintf(csv,
                       "%s,%.0f,%.6g,%d,%llu,%s,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%d,%s,%s,%.6g,%.6g,%.6g,%.6g,%.6g,"
                       "%.9g,%.9g,%.9g,%.9g,%.9g,%s\n",
                       j.k.name.c_str(), j.duration_s, j.rate_hz, r.seed,
                       static_cast<unsigned long long>(r.sim_seed), kTermShort[t], truthOf(j.k.a, t), c.value,
                       c.sigma, c.lo68, c.hi68, c.lo95, c.hi95, c.supported ? 1 : 0, r.method.c_str(), r.quality.c_str(), r.rms_log10,
                       r.chi2_dof, r.evidence[static_cast<size_t>(t)], r.model_worst, r.base_worst, b.value, b.lo68,
                       b.hi68, b.lo95, b.hi95, err.c_str());
        }
      }
      std::fclose(csv);
    }

    // Summary: per class run (class@duration), per term, then all classes.
    std::array<Cell, kNumTerms> total;
    std::array<Cell, kNumTerms> answered;  // axes whose verdict is not bad: an unbounded interval covers trivially
    // ... and of those, the values that are estimates: pulse_times' Q is the lattice's pulse weight / sqrt(12),
    // exact by definition (sigma 1e-6 relative), so its interval always holds the truth and says nothing about
    // calibration.
    std::array<Cell, kNumTerms> estimated;
    int bad_axes = 0, exact_values = 0;
    std::vector<Seen> seen(jobs.size());
    Seen seen_all;
    std::printf("# coverage of the truth by [lo68,hi68] / [lo95,hi95] (unsupported terms too: usually [0, hi]), "
                "each ± its binomial standard error; bias = median(value/truth - 1) over supported terms\n");
    std::printf("# cov = all cases with truth > 0 (n); sup = supported (ns); ub = unsupported, upper bound (nu); "
                "noint = interval fields empty; phantom = supported with truth 0 (of n0); detect = ns/n\n");
    int errors = 0;
    for (size_t ji = 0; ji < jobs.size(); ++ji) {
      const Job& j = jobs[ji];
      std::array<Cell, kNumTerms> cells;
      std::map<std::string, int> methods;
      std::vector<double> rms, chi;
      int ok = 0, err = 0;
      std::string first_error;
      for (const auto& r : runs) {
        if (r.job != ji) continue;
        if (!r.ok) {
          ++err;
          if (first_error.empty()) first_error = r.error;
          continue;
        }
        ++ok;
        ++methods[r.method];
        rms.push_back(r.rms_log10);
        chi.push_back(r.chi2_dof);
        seen[ji].add(r);
        const bool bad = r.quality == "bad";
        bad_axes += bad;
        for (int t = 0; t < kNumTerms; ++t) {
          const Coefficient& c = r.c[static_cast<size_t>(t)];
          const Coefficient& b = r.base[static_cast<size_t>(t)];
          cells[static_cast<size_t>(t)].add(truthOf(j.k.a, t), c, b);
          if (bad) continue;
          answered[static_cast<size_t>(t)].add(truthOf(j.k.a, t), c, b);
          const bool exact = c.supported && c.value > 0 && c.sigma <= 1e-5 * c.value;
          exact_values += exact;
          if (!exact) estimated[static_cast<size_t>(t)].add(truthOf(j.k.a, t), c, b);
        }
      }
      seen_all.merge(seen[ji]);
      errors += err;
      std::string m;
      for (const auto& kv : methods) m += " " + kv.first + " " + std::to_string(kv.second);
      std::printf("\n## %s: %.0f s at %.4g Hz, %d runs ok, %d failed;%s; median rms_log10 %.4f, median chi2_dof %.3g\n",
                  j.key.c_str(), j.duration_s, j.rate_hz, ok, err, m.c_str(), median(rms), median(chi));
      if (!first_error.empty()) std::printf("   first error: %s\n", first_error.c_str());
      printHeader();
      for (int t = 0; t < kNumTerms; ++t) {
        printRow(j.key, t, cells[static_cast<size_t>(t)]);
        total[static_cast<size_t>(t)].merge(cells[static_cast<size_t>(t)]);
      }
    }
    std::printf("\n## all classes (seeds %d-%d, %s)\n", s0, s1, set);
    printHeader();
    for (int t = 0; t < kNumTerms; ++t) printRow("all", t, total[static_cast<size_t>(t)]);
    std::printf("\n## all classes, axes with an answer (verdict not bad; %d bad axes left out)\n", bad_axes);
    printHeader();
    for (int t = 0; t < kNumTerms; ++t) printRow("answered", t, answered[static_cast<size_t>(t)]);
    std::printf("\n## ... and of those, estimated values only (%d exact values left out: pulse_times' Q = pulse / sqrt(12))\n",
                exact_values);
    printHeader();
    for (int t = 0; t < kNumTerms; ++t) printRow("estimated", t, estimated[static_cast<size_t>(t)]);
    std::printf("\n## what users see: worst |adev_model/adev_true - 1| over 60 tau in [10/rate, duration/10] per run; "
                "in25 = fraction with worst <= 25 %%, med-worst = median worst, answer and baseline (EDF-weighted "
                "least squares, significance 0); good>50%% = fraction of runs off by > 50 %% with verdict good; "
                "out68 = values outside their own [lo68, hi68]\n");
    printSeenHeader();
    for (size_t ji = 0; ji < jobs.size(); ++ji) printSeenRow(jobs[ji].key, seen[ji]);
    printSeenRow("all", seen_all);
    std::printf("\n# %zu axis-runs (%d failed) in %.1f s wall on %d thread(s)\n", runs.size(), errors, elapsed,
                threads);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "coverage_study: %s\n", e.what());
    return 1;
  }
}
