// Accuracy and interval calibration of the reported noise model on a random population of simulated gyros.
//
//   population_study [--seeds A-B] [--threads N] [--csv FILE] [--fit-only] [--max-samples N] [--misses N]
//                    [--min-cell N] [--curves-out FILE | --curves-in FILE] [--working-independence]
//
// One seed is one sensor axis drawn from broad priors (no fixed classes):
//   rate          log-uniform 100 Hz - 1 kHz;  record length log-uniform 20 min - 6 h
//   N             log-uniform 0.002 - 0.63 deg/sqrt(h) (two and a half decades)
//   B, K, R       each present with probability 1/2, placed by the tau where its AVAR crosses the white noise's
//                 (log-uniform from 1 s to 3x the record: from dominating most of the curve to below the data)
//   Q             present with probability 1/3 (a dithered angle quantizer), crossing the white noise at a tau
//                 log-uniform from 1 to 10 sample intervals
// Seeds 1-999 are the tuning range, 1001- the validation range (kit.hpp); a run in both is refused.
//
// Per axis the whole analyzeAxis runs as analyze_bag runs it (--fit-only: without the wavelet split and the model
// check), and beside it the plain weighted least-squares baseline of the same oadev curve (fitNoiseModel,
// FitWeighting::Edf, significance 0, no decorrelation: every term at its non-negative estimate, iterated EDF weights).
// worst = max over 60 log-spaced tau in [10/rate, T/10] of |adev_model / adev_true - 1| (IEEE formula, values of all
// five terms). Cells: grade by N (nav < 0.01 <= tactical < 0.1 <= consumer, deg/sqrt(h)) x record length (< 1 h,
// 1-3 h, >= 3 h) x the term whose AVAR is largest at T/10 (N when white noise still dominates there).
// Reported per cell and overall: in25 (share with worst <= 0.25) for ours and the baseline, median worst, the share
// where ours is worse than the baseline by > 0.15 in worst, `good` with worst > 0.5, and per present term the 68 % /
// 95 % coverage, the median bias value/truth - 1 (all axes with the term, supported or not), the phantom rate
// (supported where the truth is 0) and values outside their own 68 % interval. --misses N lists the N axes where ours
// is most behind the baseline, with their truth, so the misses can be read and reproduced
// (simulate --seed is not needed: rerun this program with --seeds S-S).
// --curves-out saves each axis's oadev curve; --curves-in fits saved curves again without simulating them (the joint
// fit of --fit-only, which is what the estimator decides; the Allan curve itself costs ~95 % of a run).
// --working-independence: the joint fit estimates with diagonal weights and sandwich intervals
// (FitOptions::working_independence) instead of the GLS, for the comparison in docs/fit.md.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <random>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "gyro_allan/analysis.hpp"
#include "gyro_allan/model_check.hpp"
#include "gyro_allan/noise_model.hpp"
#include "gyro_allan/simulate.hpp"
#include "gyro_allan/stats.hpp"
#include "kit.hpp"

using namespace gyro_allan;

namespace {

using study::kDegPerSqrtH;
const char* const kTermShort[kNumTerms] = {"Q", "N", "B", "K", "R"};

struct Sensor {
  double rate_hz = 100, duration_s = 3600;
  AxisNoise a;
  std::string grade, length, dominant;
};

double logUniform(std::mt19937_64& g, double lo, double hi) {
  return lo * std::pow(hi / lo, std::uniform_real_distribution<double>(0.0, 1.0)(g));
}

std::array<double, kNumTerms> truthOf(const AxisNoise& a) {
  return {{a.quantization, a.angle_random_walk, a.bias_instability, a.rate_random_walk, std::fabs(a.rate_ramp)}};
}

double ieeeAvar(const std::array<double, kNumTerms>& c, double tau) {
  double v = 0;
  for (int t = 0; t < kNumTerms; ++t) v += c[static_cast<size_t>(t)] * c[static_cast<size_t>(t)] * noiseTermBasis(t, tau);
  return v;
}

/// The sensor of one seed (deterministic).
Sensor draw(uint64_t seed) {
  std::mt19937_64 g(seed * 0x9E3779B97F4A7C15ULL + 0x5EED);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Sensor s;
  s.rate_hz = logUniform(g, 100.0, 1000.0);
  s.duration_s = logUniform(g, 1200.0, 6.0 * 3600.0);
  const double n_deg = logUniform(g, 0.002, 0.002 * std::pow(10.0, 2.5));
  const double n = n_deg * kDegPerSqrtH, n2 = n * n;
  s.a.angle_random_walk = n;
  const double far = 3.0 * s.duration_s;
  // Crossing tau tc of each term with N^2/tau: B^2 (2 ln2/pi) = N^2/tc, K^2 tc/3 = N^2/tc, R^2 tc^2/2 = N^2/tc.
  const bool has_b = u(g) < 0.5, has_k = u(g) < 0.5, has_r = u(g) < 0.5, has_q = u(g) < 1.0 / 3.0;
  const double tb = logUniform(g, 1.0, far), tk = logUniform(g, 1.0, far), tr = logUniform(g, 1.0, far);
  const double tq = logUniform(g, 1.0, 10.0) / s.rate_hz;
  if (has_b) s.a.bias_instability = std::sqrt(n2 / tb / (2.0 * std::log(2.0) / M_PI));
  if (has_k) s.a.rate_random_walk = std::sqrt(3.0 * n2 / (tk * tk));
  if (has_r) s.a.rate_ramp = std::sqrt(2.0 * n2 / (tr * tr * tr));
  if (has_q) s.a.quantization = std::sqrt(n2 * tq / 3.0);
  s.grade = n_deg < 0.01 ? "nav" : n_deg < 0.1 ? "tactical" : "consumer";
  s.length = s.duration_s < 3600 ? "<1h" : s.duration_s < 3 * 3600 ? "1-3h" : ">=3h";
  const std::array<double, kNumTerms> c = truthOf(s.a);
  const double tau = s.duration_s / 10.0;
  int dom = kAngleRandomWalk;
  double best = n2 * noiseTermBasis(kAngleRandomWalk, tau);
  for (int t : {kBiasInstability, kRateRandomWalk, kRateRamp}) {
    const double v = c[static_cast<size_t>(t)] * c[static_cast<size_t>(t)] * noiseTermBasis(t, tau);
    if (v > best) best = v, dom = t;
  }
  s.dominant = kTermShort[dom];
  return s;
}

double worstError(const std::array<Coefficient, kNumTerms>& c, const Sensor& s) {
  std::array<double, kNumTerms> model{};
  for (int t = 0; t < kNumTerms; ++t) model[static_cast<size_t>(t)] = c[static_cast<size_t>(t)].value;
  const std::array<double, kNumTerms> truth = truthOf(s.a);
  const double lo = 10.0 / s.rate_hz, hi = s.duration_s / 10.0;
  double worst = 0;
  for (int i = 0; i < 60; ++i) {
    const double tau = lo * std::pow(hi / lo, i / 59.0);
    worst = std::max(worst, std::fabs(std::sqrt(ieeeAvar(model, tau) / ieeeAvar(truth, tau)) - 1.0));
  }
  return worst;
}

struct Run {
  uint64_t seed = 0;
  Sensor s;
  bool ok = false;
  std::string error, method, quality, effects;
  std::string effect_detail;  ///< per kept effect: BIC gain and evidence; the plain fit's residual verdict
  std::array<Coefficient, kNumTerms> c, base;
  double worst = NAN, base_worst = NAN;
};

/// Tallies of one cell (or of all axes).
struct Tally {
  int n = 0, in25 = 0, base_n = 0, base_in25 = 0, behind = 0, good50 = 0, out68 = 0;
  std::vector<double> worst, base_worst;
  std::array<int, kNumTerms> present{}, in68{}, in95{}, base68{}, base95{}, absent{}, phantom{}, base_phantom{};
  std::array<std::vector<double>, kNumTerms> rel, base_rel;
  void add(const Run& r) {
    ++n;
    in25 += r.worst <= 0.25;
    worst.push_back(r.worst);
    good50 += r.worst > 0.5 && r.quality == "good";
    if (std::isfinite(r.base_worst)) {
      ++base_n;
      base_in25 += r.base_worst <= 0.25;
      base_worst.push_back(r.base_worst);
      behind += r.worst > r.base_worst + 0.15;
    }
    const std::array<double, kNumTerms> truth = truthOf(r.s.a);
    for (int t = 0; t < kNumTerms; ++t) {
      const size_t u = static_cast<size_t>(t);
      const Coefficient &c = r.c[u], &b = r.base[u];
      out68 += !(c.value >= c.lo68 * (1 - 1e-9) && c.value <= c.hi68 * (1 + 1e-9));
      if (truth[u] > 0) {
        ++present[u];
        in68[u] += c.lo68 <= truth[u] && truth[u] <= c.hi68;
        in95[u] += c.lo95 <= truth[u] && truth[u] <= c.hi95;
        base68[u] += b.lo68 <= truth[u] && truth[u] <= b.hi68;
        base95[u] += b.lo95 <= truth[u] && truth[u] <= b.hi95;
        rel[u].push_back(c.value / truth[u] - 1.0);
        base_rel[u].push_back(b.value / truth[u] - 1.0);
      } else {
        ++absent[u];
        phantom[u] += c.supported;
        base_phantom[u] += b.supported;
      }
    }
  }
};

std::string frac(int k, int n) {
  if (n <= 0) return "-";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3f", static_cast<double>(k) / n);
  return buf;
}

std::string med(const std::vector<double>& v, const char* fmt = "%.3f") {
  if (v.empty()) return "-";
  char buf[32];
  std::snprintf(buf, sizeof buf, fmt, median(v));
  return buf;
}

std::string quantileText(std::vector<double> v, double q) {
  if (v.empty()) return "-";
  std::sort(v.begin(), v.end());
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3f", v[static_cast<size_t>(q * (v.size() - 1) + 0.5)]);
  return buf;
}

void printSeenHeader() {
  std::printf("%-30s %5s %7s %9s %7s %9s %7s %7s %7s %7s %6s\n", "cell", "n", "in25", "base-in25", "med", "base-med",
              "p90", "base-p90", "behind", "good50", "out68");
}

void printSeen(const std::string& name, const Tally& t) {
  std::printf("%-30s %5d %7s %9s %7s %9s %7s %7s %7s %7s %6d\n", name.c_str(), t.n, frac(t.in25, t.n).c_str(),
              frac(t.base_in25, t.base_n).c_str(), med(t.worst).c_str(), med(t.base_worst).c_str(),
              quantileText(t.worst, 0.9).c_str(), quantileText(t.base_worst, 0.9).c_str(),
              frac(t.behind, t.base_n).c_str(), frac(t.good50, t.n).c_str(), t.out68);
}

void printTermHeader() {
  std::printf("%-30s %-2s %5s %7s %7s %9s %9s %8s %9s %5s %8s %9s\n", "cell", "t", "n", "cov68", "cov95",
              "base-c68", "base-c95", "bias", "base-bias", "n0", "phantom", "base-phan");
}

void printTerms(const std::string& name, const Tally& t) {
  for (int k = 0; k < kNumTerms; ++k) {
    const size_t u = static_cast<size_t>(k);
    if (t.present[u] == 0 && t.absent[u] == 0) continue;
    std::printf("%-30s %-2s %5d %7s %7s %9s %9s %8s %9s %5d %8s %9s\n", name.c_str(), kTermShort[k], t.present[u],
                frac(t.in68[u], t.present[u]).c_str(), frac(t.in95[u], t.present[u]).c_str(),
                frac(t.base68[u], t.present[u]).c_str(), frac(t.base95[u], t.present[u]).c_str(),
                med(t.rel[u], "%+.3f").c_str(), med(t.base_rel[u], "%+.3f").c_str(), t.absent[u],
                frac(t.phantom[u], t.absent[u]).c_str(), frac(t.base_phantom[u], t.absent[u]).c_str());
  }
}

void writeCurve(FILE* f, uint64_t seed, const DeviationCurve& c) {
  const uint64_t np = c.points.size();
  std::fwrite(&seed, sizeof seed, 1, f);
  std::fwrite(&c.tau0, sizeof c.tau0, 1, f);
  std::fwrite(&c.n_phase, sizeof c.n_phase, 1, f);
  std::fwrite(&np, sizeof np, 1, f);
  for (const auto& p : c.points) {
    std::fwrite(&p.tau, sizeof p.tau, 1, f);
    std::fwrite(&p.m, sizeof p.m, 1, f);
    std::fwrite(&p.var, sizeof p.var, 1, f);
    std::fwrite(&p.n_terms, sizeof p.n_terms, 1, f);
    std::fwrite(&p.edf, sizeof p.edf, 1, f);
    std::fwrite(&p.alpha, sizeof p.alpha, 1, f);
  }
}

bool readCurve(FILE* f, uint64_t* seed, DeviationCurve* c) {
  uint64_t np = 0;
  if (std::fread(seed, sizeof *seed, 1, f) != 1) return false;
  bool ok = std::fread(&c->tau0, sizeof c->tau0, 1, f) == 1 && std::fread(&c->n_phase, sizeof c->n_phase, 1, f) == 1 &&
            std::fread(&np, sizeof np, 1, f) == 1 && np < 100000;
  c->name = "oadev";
  c->points.assign(ok ? np : 0, DeviationPoint{});
  for (auto& p : c->points) {
    ok = ok && std::fread(&p.tau, sizeof p.tau, 1, f) == 1 && std::fread(&p.m, sizeof p.m, 1, f) == 1 &&
         std::fread(&p.var, sizeof p.var, 1, f) == 1 && std::fread(&p.n_terms, sizeof p.n_terms, 1, f) == 1 &&
         std::fread(&p.edf, sizeof p.edf, 1, f) == 1 && std::fread(&p.alpha, sizeof p.alpha, 1, f) == 1;
    p.dev = std::sqrt(p.var);
  }
  return ok;
}

[[noreturn]] void usage(const char* msg) {
  std::fprintf(stderr, "population_study: %s\nusage: population_study [--seeds A-B] [--threads N] [--csv FILE] "
                       "[--fit-only] [--max-samples N] [--misses N] [--min-cell N] [--curves-out F | --curves-in F] "
                       "[--working-independence]\n", msg);
  std::exit(2);
}

}  // namespace

int main(int argc, char** argv) {
  uint64_t first = 1, last = 200;
  int threads = 2, misses = 20, min_cell = 30;
  double max_samples = 4e7;
  bool fit_only = false, gls = true;
  std::string csv, curves_out, curves_in, set;
  try {
    for (study::Args a(argc, argv); a.next();) {
      if (a.is("--seeds")) {
        const study::SeedRange r = study::parseSeeds(a.value());
        first = static_cast<uint64_t>(std::max(1, r.first)), last = static_cast<uint64_t>(std::max(1, r.last));
        set = study::seedSet(r);
      } else if (a.is("--threads")) threads = std::max(1, a.integer());
      else if (a.is("--csv")) csv = a.value();
      else if (a.is("--fit-only")) fit_only = true;
      else if (a.is("--working-independence")) gls = false;
      else if (a.is("--max-samples")) max_samples = a.number();
      else if (a.is("--misses")) misses = a.integer();
      else if (a.is("--min-cell")) min_cell = a.integer();
      else if (a.is("--curves-out")) curves_out = a.value();
      else if (a.is("--curves-in")) curves_in = a.value();
      else a.unknown();
    }
  } catch (const std::invalid_argument& e) {
    usage(e.what());
  }
  if (set.empty()) set = study::seedSet(study::SeedRange{static_cast<int>(first), static_cast<int>(last)});
  if (set.find("set") == std::string::npos) usage(set.c_str());
  std::printf("# population_study: seeds %lu-%lu (%s), %s%s\n", static_cast<unsigned long>(first),
              static_cast<unsigned long>(last), set.c_str(), gls ? "" : "working-independence fit, ",
              fit_only ? "joint fit only (no wavelet split, no model check)" : "the whole analyzeAxis");
  std::vector<Run> runs(static_cast<size_t>(last - first + 1));
  std::vector<DeviationCurve> curves(runs.size());
  std::vector<bool> have_curve(runs.size(), false);
  if (!curves_in.empty()) {
    FILE* f = std::fopen(curves_in.c_str(), "rb");
    if (!f) usage(("cannot read " + curves_in).c_str());
    uint64_t seed;
    DeviationCurve c;
    while (readCurve(f, &seed, &c))
      if (seed >= first && seed <= last) curves[seed - first] = c, have_curve[seed - first] = true;
    std::fclose(f);
  }
  std::atomic<size_t> next{0};
  auto worker = [&]() {
    for (size_t i; (i = next++) < runs.size();) {
      Run& r = runs[i];
      r.seed = first + i;
      r.s = draw(r.seed);
      try {
        double rate = r.s.rate_hz;
        if (rate * r.s.duration_s > max_samples) rate = max_samples / r.s.duration_s;
        r.s.rate_hz = rate;
        DeviationCurve oadev;
        AnalysisOptions opt;
        opt.fit.working_independence = !gls;
        if (!curves_in.empty()) {
          if (!have_curve[i]) throw std::runtime_error("no saved curve");
          oadev = curves[i];
          DeviationCurve weighted = oadev;
          const FitResult fit = fitWithModelEdf(&weighted, opt.fit, opt.deviation.confidence);
          if (!fit.ok) throw std::runtime_error(fit.message);
          r.c = fit.terms;
          r.method = "joint_fit";
          r.quality = "-";
        } else {
          const int64_t n = static_cast<int64_t>(rate * r.s.duration_s);
          std::vector<std::vector<double>> seg(1);
          seg[0] = simulateAxis(r.s.a, rate, n, r.seed ^ 0xA5A5A5A5ULL, 0);
          if (fit_only) opt.wavelet_split = false, opt.model_check = false;
          const AxisAnalysis an = analyzeAxis("x", seg, 1.0 / rate, opt);
          r.c = an.coefficients;
          r.method = methodName(an.method);
          r.quality = qualityName(an.quality.quality);
          oadev = an.oadev;
          if (an.has_check)
            for (const auto& e : an.check.effects) {
              r.effects += (r.effects.empty() ? "" : "+") + e.type;
              char buf[96];
              std::snprintf(buf, sizeof buf, "    %s: BIC gain %.1f, plain fit's residual p %.3g; ", e.type.c_str(),
                            e.delta_bic, an.check.residual_before.p_value);
              r.effect_detail += buf + e.evidence + "\n";
            }
          if (!curves_out.empty()) curves[i] = oadev, have_curve[i] = true;
        }
        r.worst = worstError(r.c, r.s);
        FitOptions bo;
        bo.weighting = FitWeighting::Edf;
        bo.significance = 0;
        bo.decorrelate = false;
        const FitResult base = fitNoiseModel(oadev, bo);
        if (base.ok) r.base = base.terms, r.base_worst = worstError(r.base, r.s);
        r.ok = true;
      } catch (const std::exception& e) {
        r.error = e.what();
      }
    }
  };
  std::vector<std::thread> pool;
  for (int k = 0; k < threads; ++k) pool.emplace_back(worker);
  for (auto& t : pool) t.join();
  if (!curves_out.empty()) {
    FILE* f = std::fopen(curves_out.c_str(), "wb");
    if (!f) usage(("cannot write " + curves_out).c_str());
    for (size_t i = 0; i < runs.size(); ++i)
      if (have_curve[i]) writeCurve(f, runs[i].seed, curves[i]);
    std::fclose(f);
  }

  if (!csv.empty()) {
    FILE* f = std::fopen(csv.c_str(), "w");
    if (!f) usage(("cannot write " + csv).c_str());
    std::fprintf(f, "seed,rate_hz,duration_s,grade,length,dominant,method,effects,quality,worst,base_worst,term,truth,value,"
                    "lo68,hi68,lo95,hi95,supported,base_value,base_lo68,base_hi68,error\n");
    for (const Run& r : runs) {
      const auto truth = truthOf(r.s.a);
      for (int t = 0; t < kNumTerms; ++t) {
        const size_t u = static_cast<size_t>(t);
        const Coefficient &c = r.c[u], &b = r.base[u];
        std::fprintf(f, "%lu,%.6g,%.6g,%s,%s,%s,%s,%s,%s,%.6g,%.6g,%s,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%d,%.9g,%.9g,%.9g,\"%s\"\n",
                     static_cast<unsigned long>(r.seed), r.s.rate_hz, r.s.duration_s, r.s.grade.c_str(),
                     r.s.length.c_str(), r.s.dominant.c_str(), r.method.c_str(), r.effects.c_str(), r.quality.c_str(), r.worst,
                     r.base_worst, kTermShort[t], truth[u], c.value, c.lo68, c.hi68, c.lo95, c.hi95, c.supported ? 1 : 0,
                     b.value, b.lo68, b.hi68, r.error.c_str());
      }
    }
    std::fclose(f);
  }

  Tally all;
  std::map<std::string, Tally> cells, margins;
  int failed = 0;
  for (const Run& r : runs) {
    if (!r.ok) {
      ++failed;
      continue;
    }
    all.add(r);
    cells[r.s.grade + " " + r.s.length + " " + r.s.dominant].add(r);
    margins["grade " + r.s.grade].add(r);
    margins["length " + r.s.length].add(r);
    margins["dominant " + r.s.dominant].add(r);
  }
  std::printf("# %zu axes, %d failed\n", runs.size(), failed);
  for (const Run& r : runs)
    if (!r.ok) std::printf("#   seed %lu failed: %s\n", static_cast<unsigned long>(r.seed), r.error.c_str());
  std::printf("\n## What users see: worst |adev_model/adev_true - 1| over [10/rate, T/10]; behind = ours worse than the "
              "baseline by > 0.15\n");
  printSeenHeader();
  printSeen("all", all);
  for (const auto& kv : margins) printSeen(kv.first, kv.second);
  for (const auto& kv : cells)
    if (kv.second.n >= min_cell) printSeen(kv.first, kv.second);
  std::printf("\n## Terms: coverage of the truth (present), median bias (all axes with the term), phantom (absent)\n");
  printTermHeader();
  printTerms("all", all);
  for (const auto& kv : margins) printTerms(kv.first, kv.second);
  for (const auto& kv : cells)
    if (kv.second.n >= min_cell) printTerms(kv.first, kv.second);
  std::printf("\n## Cells with fewer than %d axes (not judged):", min_cell);
  for (const auto& kv : cells)
    if (kv.second.n < min_cell) std::printf(" [%s] %d", kv.first.c_str(), kv.second.n);
  std::printf("\n");
  if (misses > 0) {
    std::vector<const Run*> order;
    for (const Run& r : runs)
      if (r.ok && std::isfinite(r.base_worst)) order.push_back(&r);
    std::sort(order.begin(), order.end(),
              [](const Run* a, const Run* b) { return a->worst - a->base_worst > b->worst - b->base_worst; });
    std::printf("\n## Axes where ours is most behind the baseline (worst, base worst; truth in SI)\n");
    for (int k = 0; k < misses && k < static_cast<int>(order.size()); ++k) {
      const Run& r = *order[static_cast<size_t>(k)];
      if (!(r.worst > r.base_worst)) break;
      std::printf("seed %lu  %s %s %s  %.9g Hz %.9g s  %s%s%s %s  worst %.3f base %.3f  Q %.9g N %.9g B %.9g K %.9g R %.9g\n",
                  static_cast<unsigned long>(r.seed), r.s.grade.c_str(), r.s.length.c_str(), r.s.dominant.c_str(),
                  r.s.rate_hz, r.s.duration_s, r.method.c_str(), r.effects.empty() ? "" : "+", r.effects.c_str(),
                  r.quality.c_str(), r.worst, r.base_worst,
                  r.s.a.quantization, r.s.a.angle_random_walk, r.s.a.bias_instability, r.s.a.rate_random_walk,
                  std::fabs(r.s.a.rate_ramp));
      std::printf("%s", r.effect_detail.c_str());
    }
  }
  return 0;
}
