// Calibration/validation study of the rest detector: false alarms on static records, detection of moved ones.
//
// Scenario generators live here (namespace rest_study) and are reused by test/test_rest.cpp, which includes this file
// with REST_STUDY_NO_MAIN defined, so that the test checks exactly the scenarios the study measured.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <mutex>
#include <random>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "gyro_allan/csv_input.hpp"
#include "gyro_allan/io/bag_input.hpp"
#include "gyro_allan/rest.hpp"
#include "gyro_allan/simulate.hpp"
#include "gyro_allan/stats.hpp"
#include "kit.hpp"

namespace rest_study {

using namespace gyro_allan;

using study::kDeg;
constexpr double kG = 9.80665;
constexpr double kDegSqrtH = study::kDegPerSqrtH;
constexpr double kDegH = study::kDegPerH;
constexpr double kDegHSqrtH = study::kDegPerHSqrtH;

/// A record: 3 gyro axes [rad/s], 3 accel axes [m/s^2] (or none), as segments.
struct Record {
  std::string name;
  double tau0 = 0;
  std::vector<std::vector<std::vector<double>>> gyro, accel;  // [axis][segment][sample]
  RestInterval truth_motion;  // bump/turn scenarios: the moved stretch (sample indices), else empty
  double per_sample_sigma = 0;  // white gyro noise per sample [rad/s] (x axis)
};

RestResult run(const Record& r, const RestOptions& o, bool use_accel = true) {
  std::vector<const std::vector<std::vector<double>>*> g, a;
  for (auto& x : r.gyro) g.push_back(&x);
  if (use_accel)
    for (auto& x : r.accel) a.push_back(&x);
  return detectRest(g, a, r.tau0, o);
}

// ---- static sensor classes ------------------------------------------------------------------------------------
enum SensorClass { kConsumer, kConsumerLpf, kTactical, kFog, kRlgDither, kRlgNoDither, kNumClasses };
const char* const kClassNames[kNumClasses] = {"consumer MEMS", "consumer MEMS + DLPF", "tactical MEMS",
                                              "FOG-like",      "RLG dithered",         "RLG undithered"};
enum Effect { kNone, kSine, kGaussMarkov, kStep, kThermal, kNumEffects };
const char* const kEffectNames[kNumEffects] = {"none", "sinusoid", "Gauss-Markov", "bias step", "warm-up"};

struct Rng {
  std::mt19937_64 g;
  explicit Rng(uint64_t s) : g(s * 0x9E3779B97F4A7C15ull + 12345) {}
  double u(double a, double b) { return std::uniform_real_distribution<double>(a, b)(g); }
  double logu(double a, double b) { return std::exp(u(std::log(a), std::log(b))); }
  int pick(int n) { return std::uniform_int_distribution<int>(0, n - 1)(g); }
  uint64_t seed() { return g(); }
};

/// Effect amplitudes are in units of the white noise of a 1 s average (N / sqrt(1 s)), the convention of the model
/// check's own tests (test_model_check.cpp: sinusoid 2-5 N, Gauss-Markov 1 N, step 3 N, warm-up 10 N). With
/// `per_sample` the sinusoid amplitude is instead 1-3 x the per-sample white noise (a harder, stated-apart set).
struct StaticSpec {
  SensorClass cls = kConsumer;
  Effect effect = kNone;
  bool per_sample_sine = false;
  double max_samples = 1 << 19;
  double max_duration_s = 3600;
};

Record makeStatic(uint64_t seed, const StaticSpec& sp) {
  Rng rng(seed * 7919 + sp.cls * 131 + sp.effect * 17 + (sp.per_sample_sine ? 5 : 0));
  static const double kRates[] = {100, 200, 400, 1000};
  double rate = kRates[rng.pick(4)];
  if (sp.cls == kConsumerLpf) rate = rng.pick(2) ? 400 : 1000;
  // Power-of-two lengths (the flicker FFT is fastest there): 10-45 min, at 1000 Hz 8.7 min (2^19 samples).
  double dur = std::min(sp.max_duration_s, rng.u(600, 3600));
  int64_t n = 1;
  while (n * 2 <= dur * rate) n *= 2;
  n = std::max<int64_t>(n, 1 << 16);
  n = std::min<int64_t>(n, rate >= 1000 ? 1 << 19 : 1 << 18);
  n = std::min<int64_t>(n, static_cast<int64_t>(sp.max_samples));
  if (sp.max_duration_s <= 600) n = static_cast<int64_t>(dur * rate);  // moved records: exactly as asked
  dur = n / rate;
  Record r;
  r.tau0 = 1.0 / rate;
  r.name = std::string(kClassNames[sp.cls]) + " + " + kEffectNames[sp.effect];
  AxisNoise base;
  double acc_density = 0, acc_lsb = 0;
  switch (sp.cls) {
    case kConsumer:
    case kConsumerLpf:
      base.angle_random_walk = rng.u(0.3, 1.0) * kDegSqrtH;
      base.bias_instability = rng.logu(5, 50) * kDegH;
      base.rate_random_walk = rng.logu(1, 20) * kDegHSqrtH;
      base.bias = rng.u(-3, 3) * kDeg;
      if (rng.pick(2)) base.rate_lsb = (rng.pick(2) ? 0.07 : 0.061) * kDeg;
      acc_density = rng.u(150e-6, 400e-6) * kG;
      acc_lsb = rng.pick(2) ? kG / 16384 : 0;
      break;
    case kTactical:
      base.angle_random_walk = rng.u(0.05, 0.3) * kDegSqrtH;
      base.bias_instability = rng.logu(0.5, 5) * kDegH;
      base.rate_random_walk = rng.logu(0.1, 2) * kDegHSqrtH;
      base.bias = rng.u(-0.1, 0.1) * kDeg;
      acc_density = rng.u(30e-6, 100e-6) * kG;
      break;
    case kFog:
      base.angle_random_walk = rng.logu(0.002, 0.05) * kDegSqrtH;
      base.bias_instability = rng.logu(0.005, 0.5) * kDegH;
      acc_density = rng.u(20e-6, 60e-6) * kG;
      break;
    case kRlgDither:
    case kRlgNoDither:
      base.quantization = rng.u(0.3, 3.0) / 3600 * kDeg / std::sqrt(12.0);  // pulse weight 0.3-3 arcsec
      base.dither = sp.cls == kRlgDither;
      base.angle_random_walk = rng.logu(0.0005, 0.005) * kDegSqrtH;
      base.input_rate = rng.u(0, 15) * kDegH;
      acc_density = rng.u(20e-6, 60e-6) * kG;
      break;
    default:
      break;
  }
  const double N = base.angle_random_walk;  // rad/s of a 1 s average
  r.per_sample_sigma = N * std::sqrt(rate);
  AxisNoise ax[3] = {base, base, base};
  const double up = sp.per_sample_sine ? r.per_sample_sigma : N;
  for (int a = 0; a < 3; ++a) {
    AxisNoise& x = ax[a];
    x.bias = base.bias * rng.u(-1, 1);
    switch (sp.effect) {
      case kSine:
        x.sine_frequency = rng.logu(0.5, 50);
        x.sine_amplitude = rng.u(1, sp.per_sample_sine ? 3 : 5) * up;
        break;
      case kGaussMarkov:
        x.gm_sigma = rng.u(1, 5) * N;
        x.gm_tau = rng.logu(1, 100);
        break;
      case kStep:
        x.step_size = rng.u(1, 5) * N * (rng.pick(2) ? 1 : -1);
        x.step_time = rng.u(0.1, 0.9) * dur;
        break;
      case kThermal:
        x.thermal_amplitude = rng.u(3, 20) * N;
        x.thermal_tau = rng.u(100, 1000);
        break;
      default:
        break;
    }
  }
  r.gyro.assign(3, {});
  r.accel.assign(3, {});
  for (int a = 0; a < 3; ++a) {
    std::vector<double> g = simulateAxis(ax[a], rate, n, rng.seed(), a);
    if (sp.cls == kConsumerLpf) {  // digital low-pass (4-sample moving average), as MEMS DLPF settings do
      std::vector<double> f(g.size());
      double s = 0;
      for (size_t i = 0; i < g.size(); ++i) {
        s += g[i];
        if (i >= 4) s -= g[i - 4];
        f[i] = s / std::min<double>(i + 1, 4);
      }
      g.swap(f);
    }
    r.gyro[a].push_back(std::move(g));
    AxisNoise an;
    an.angle_random_walk = acc_density;
    an.bias = a == 2 ? kG : rng.u(-0.2, 0.2);  // level-ish mounting
    an.rate_lsb = acc_lsb;
    r.accel[a].push_back(simulateAxis(an, rate, n, rng.seed(), a + 3));
  }
  return r;
}

// ---- motion ---------------------------------------------------------------------------------------------------
enum Motion { kWave, kTurn, kDrive, kBump, kNumMotions };
const char* const kMotionNames[kNumMotions] = {"hand-waving", "slow turn", "robot base", "bump in 10 min"};

// Band-limited random signal: sum of 24 sinusoids with frequencies in [f1, f2], unit RMS.
std::vector<double> bandLimited(Rng& rng, int64_t n, double tau0, double f1, double f2) {
  std::vector<double> f(24), p(24), amp(24);
  double a2 = 0;
  for (int k = 0; k < 24; ++k) {
    f[k] = rng.u(f1, f2);
    p[k] = rng.u(0, 2 * M_PI);
    amp[k] = rng.u(0.2, 1.0);
    a2 += 0.5 * amp[k] * amp[k];
  }
  std::vector<double> s(n, 0.0);
  for (int k = 0; k < 24; ++k) {
    const double w = 2 * M_PI * f[k] * tau0, a = amp[k] / std::sqrt(a2);
    for (int64_t i = 0; i < n; ++i) s[i] += a * std::sin(w * i + p[k]);
  }
  return s;
}

// Adds a body rotation rate (3 axes, rad/s) and the gravity change of the tilt it causes (small-angle-free, from the
// integrated x/y rates), plus a linear acceleration.
void addMotion(Record& r, const std::vector<double> w[3], const std::vector<double>* lin) {
  const int64_t n = static_cast<int64_t>(r.gyro[0][0].size());
  double tx = 0, ty = 0;
  for (int64_t i = 0; i < n; ++i) {
    for (int a = 0; a < 3; ++a) r.gyro[a][0][i] += w[a][i];
    tx += w[0][i] * r.tau0;
    ty += w[1][i] * r.tau0;
    if (!r.accel.empty()) {
      r.accel[0][0][i] += kG * std::sin(ty) * std::cos(tx);
      r.accel[1][0][i] += -kG * std::sin(tx);
      r.accel[2][0][i] += kG * (std::cos(tx) * std::cos(ty) - 1.0);
      if (lin)
        for (int a = 0; a < 3; ++a) r.accel[a][0][i] += lin[a][i];
    }
  }
}

struct MotionSpec {
  Motion motion = kWave;
  double min_amp = 0.05, max_amp = 5.0;  // hand-waving RMS rate [rad/s]
};

Record makeMoving(uint64_t seed, const MotionSpec& ms) {
  Rng rng(seed * 104729 + ms.motion * 7 + 3);
  StaticSpec sp;
  sp.cls = static_cast<SensorClass>(rng.pick(kNumClasses));
  sp.effect = static_cast<Effect>(rng.pick(kNumEffects));
  sp.max_duration_s = ms.motion == kBump || ms.motion == kTurn ? 600 : rng.u(60, 300);
  Record r = makeStatic(rng.seed() % 1000000007ull, sp);
  if (ms.motion == kBump || ms.motion == kTurn) {
    // 10 min exactly (static records are 600-3600 s, capped at 6e5 samples: at 1000 Hz exactly 600 s)
    for (auto* v : {&r.gyro, &r.accel})
      for (auto& ax : *v) ax[0].resize(std::min<size_t>(ax[0].size(), static_cast<size_t>(600.0 / r.tau0)));
  }
  const int64_t n = static_cast<int64_t>(r.gyro[0][0].size());
  const double T = n * r.tau0;
  std::vector<double> w[3], lin[3];
  for (int a = 0; a < 3; ++a) w[a].assign(n, 0.0), lin[a].assign(n, 0.0);
  r.name = std::string(kMotionNames[ms.motion]) + " on " + r.name;
  switch (ms.motion) {
    case kWave: {
      const double amp = rng.logu(ms.min_amp, ms.max_amp);
      for (int a = 0; a < 3; ++a) {
        std::vector<double> s = bandLimited(rng, n, r.tau0, 0.2, 3.0);
        for (int64_t i = 0; i < n; ++i) w[a][i] = amp * s[i];
        std::vector<double> l = bandLimited(rng, n, r.tau0, 0.2, 3.0);
        const double la = amp * rng.u(0.2, 1.0);  // m/s^2 of hand motion, of the order of the rate
        for (int64_t i = 0; i < n; ++i) lin[a][i] = la * l[i];
      }
      break;
    }
    case kTurn: {  // about the vertical: the accelerometer sees nothing
      const double rate = rng.u(0.05, 0.3) * (rng.pick(2) ? 1 : -1);
      const double t0 = rng.u(60, T - 200), len = rng.u(30, 120);
      for (int64_t i = 0; i < n; ++i) {
        const double t = i * r.tau0;
        double v = 0;
        if (t >= t0 && t < t0 + 1) v = 0.5 * (1 - std::cos(M_PI * (t - t0)));
        else if (t >= t0 + 1 && t < t0 + len - 1) v = 1;
        else if (t >= t0 + len - 1 && t < t0 + len) v = 0.5 * (1 + std::cos(M_PI * (t - (t0 + len - 1))));
        w[2][i] = rate * v;
      }
      r.truth_motion = {static_cast<int64_t>(t0 / r.tau0), static_cast<int64_t>((t0 + len) / r.tau0)};
      break;
    }
    case kDrive: {  // yaw-rate and speed steps with stops, plus motor/floor vibration
      double t = 0, yaw = 0, acc = 0;
      const double vib_g = rng.u(0.005, 0.05), vib_a = rng.u(0.05, 0.5);
      std::vector<double> vx = bandLimited(rng, n, r.tau0, 8, std::min(30.0, 0.4 / r.tau0));
      std::vector<double> vy = bandLimited(rng, n, r.tau0, 8, std::min(30.0, 0.4 / r.tau0));
      std::vector<double> vz = bandLimited(rng, n, r.tau0, 8, std::min(30.0, 0.4 / r.tau0));
      int64_t i = 0;
      while (i < n) {
        const double len = rng.u(2, 10);
        const bool stop = rng.pick(4) == 0;
        const double ny = stop ? 0 : rng.u(-0.8, 0.8), na = stop ? 0 : rng.u(-0.5, 0.5);
        const int64_t e = std::min<int64_t>(n, i + static_cast<int64_t>(len / r.tau0));
        for (; i < e; ++i) {
          yaw += (ny - yaw) * std::min(1.0, r.tau0 / 0.3);  // 0.3 s response
          acc += (na - acc) * std::min(1.0, r.tau0 / 0.3);
          w[2][i] = yaw + (stop ? 0 : vib_g * vz[i]);
          w[0][i] = stop ? 0 : vib_g * vx[i];
          w[1][i] = stop ? 0 : vib_g * vy[i];
          lin[0][i] = acc;
          lin[1][i] = yaw * 0.5;  // centripetal at 0.5 m/s
          lin[2][i] = stop ? 0 : vib_a * vz[i];
        }
        t += len;
      }
      break;
    }
    case kBump: {
      const double t0 = rng.u(100, 500), len = rng.u(2, 5);
      for (int a = 0; a < 3; ++a) {
        const double peak = rng.logu(0.05, 0.5) * (rng.pick(2) ? 1 : -1);
        for (int64_t i = 0; i < n; ++i) {
          const double t = i * r.tau0;
          if (t >= t0 && t < t0 + len) w[a][i] = peak * std::sin(M_PI * (t - t0) / len);
        }
      }
      r.truth_motion = {static_cast<int64_t>(t0 / r.tau0), static_cast<int64_t>((t0 + len) / r.tau0)};
      break;
    }
    default:
      break;
  }
  addMotion(r, w, lin);
  return r;
}

// ---- real data ------------------------------------------------------------------------------------------------
/// ADIS16405 run k (1-3), optionally only the first max_s seconds; empty name when the file is missing.
Record loadAdis(const std::string& dir, int k, double max_s = 0) {
  Record r;
  const std::string path = dir + "/adis16405/adis16405_imu" + std::to_string(k) + "_100Hz.csv.gz";
  FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) return r;
  std::fclose(f);
  CsvSeries c = readCsvFile(path);
  if (c.columns.size() < 6) throw std::runtime_error(path + ": expected 6 columns");
  const size_t n = max_s > 0 ? std::min(c.columns[0].size(), static_cast<size_t>(max_s * 100)) : c.columns[0].size();
  r.name = "ADIS16405 run " + std::to_string(k) + (max_s > 0 ? " (first " + std::to_string(int(max_s)) + " s)" : "");
  r.tau0 = 0.01;
  r.gyro.assign(3, {});
  r.accel.assign(3, {});
  for (int a = 0; a < 3; ++a) {
    std::vector<double> g(c.columns[a].begin(), c.columns[a].begin() + n), ac(c.columns[a + 3].begin(),
                                                                               c.columns[a + 3].begin() + n);
    for (double& v : g) v *= kDeg;
    for (double& v : ac) v *= kG;
    r.gyro[a].push_back(std::move(g));
    r.accel[a].push_back(std::move(ac));
  }
  return r;
}

/// A real bag: tau0 = median stamp step; a step above 10 tau0 (or a negative one) starts a new segment.
Record loadBag(const std::string& path, const std::string& topic) {
  Record r;
  FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) return r;
  std::fclose(f);
  BagReadOptions o;
  o.topic = topic;
  o.temperature_topic = "-";
  ImuSeries s = readImuBags({path}, o);
  const std::vector<int64_t> t = s.t.toNanoseconds();
  std::vector<double> dt;
  for (size_t i = 1; i < t.size(); ++i) dt.push_back((t[i] - t[i - 1]) * 1e-9);
  r.tau0 = upperMedian(dt);
  r.name = path.substr(path.find_last_of('/') + 1);
  std::vector<std::vector<double>> g(3), a(3);
  for (int k = 0; k < 3; ++k) g[k] = s.gyro[k].toVector(), a[k] = s.accel[k].toVector();
  r.gyro.assign(3, {});
  r.accel.assign(3, {});
  size_t start = 0;
  for (size_t i = 1; i <= t.size(); ++i) {
    if (i < t.size() && dt[i - 1] >= 0 && dt[i - 1] <= 10 * r.tau0) continue;
    for (int k = 0; k < 3; ++k) {
      r.gyro[k].emplace_back(g[k].begin() + start, g[k].begin() + i);
      r.accel[k].emplace_back(a[k].begin() + start, a[k].begin() + i);
    }
    start = i;
  }
  return r;
}

struct RealCase {
  const char* file;
  const char* topic;
};
const RealCase kRealBags[] = {{"ardrone_imu.bag", "/ardrone/imu"},
                              {"phidgets_imu_upside_down.bag", "/imu/data_raw"},
                              {"sparkfun_razor.bag", "/imu/data_raw"}};

// ---- evaluation ----------------------------------------------------------------------------------------------
/// Runs f(i) for i in [0, n) on `jobs` threads.
inline void parallelFor(int n, int jobs, const std::function<void(int)>& f) {
  std::atomic<int> next(0);
  std::vector<std::thread> th;
  for (int j = 0; j < std::max(1, jobs); ++j)
    th.emplace_back([&] {
      for (int i; (i = next++) < n;) f(i);
    });
  for (auto& t : th) t.join();
}

/// Bump/turn: the longest static stretch does not overlap the true moved stretch.
inline bool excludes(const RestResult& res, const RestInterval& truth) {
  return res.longest_static.end <= truth.begin || res.longest_static.begin >= truth.end;
}

}  // namespace rest_study

#ifndef REST_STUDY_NO_MAIN
using namespace rest_study;

namespace {

struct Row {
  std::string name;
  bool outside = false;  // not part of the target set: left out of the total
  int n = 0, moving = 0, excl = 0, truths = 0;
  double max_score = 0, max_spread = 0;
  double min_score = 1e300, min_spread = 1e300;
  std::string worst;
};

// One-sided 95 % upper bound of a rate with k events in n trials (Clopper-Pearson, by bisection).
double upper95(int k, int n) {
  if (n == 0) return 1;
  double lo = static_cast<double>(k) / n, hi = 1;
  for (int it = 0; it < 60; ++it) {
    const double p = 0.5 * (lo + hi);
    // P(X <= k | p)
    double c = 0, term = std::pow(1 - p, n);
    for (int i = 0; i <= k; ++i) {
      c += term;
      term *= (static_cast<double>(n - i) / (i + 1)) * (p / (1 - p));
    }
    if (c > 0.05) lo = p; else hi = p;
  }
  return hi;
}

void usage() {
  std::fprintf(stderr,
               "usage: rest_study [--seeds A-B] [--jobs J] [--data DIR] [--set static|moving|real|all]\n"
               "                  [--block-z Z] [--record-ratio R] [--gyro-floor F] [--accel-floor F] [--verbose]\n"
               "  tuning seeds 1-40, validation seeds 1001-1040 (docs/rest_detection.md)\n");
}

}  // namespace

int main(int argc, char** argv) {
  int s0 = 1, s1 = 40, jobs = 2;
  bool verbose = false;
  std::string set = "all", data = "/work/shared/data";
  RestOptions opts;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto v = [&]() -> std::string {
      if (i + 1 >= argc) {
        usage();
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--seeds") {
      const std::string s = v();
      try {
        const study::SeedRange r = study::parseSeeds(s);
        s0 = r.first, s1 = r.last;
      } catch (const std::invalid_argument& e) {
        std::fprintf(stderr, "rest_study: %s\n", e.what());
        return usage(), 2;
      }
    } else if (a == "--jobs") jobs = std::atoi(v().c_str());
    else if (a == "--data") data = v();
    else if (a == "--set") set = v();
    else if (a == "--block-z") opts.block_z = std::atof(v().c_str());
    else if (a == "--record-ratio") opts.record_ratio = std::atof(v().c_str());
    else if (a == "--gyro-floor") opts.gyro_floor = std::atof(v().c_str());
    else if (a == "--accel-floor") opts.accel_floor = std::atof(v().c_str());
    else if (a == "--verbose") verbose = true;
    else return usage(), 2;
  }
  const int ns = s1 - s0 + 1;
  std::printf("rest_study: seeds %d-%d, block %g s, block_z %g, record_ratio %g, window %d, floors %g rad/s %g m/s^2, "
              "max rest rate %g rad/s\n\n",
              s0, s1, opts.block_s, opts.block_z, opts.record_ratio, opts.window_blocks, opts.gyro_floor,
              opts.accel_floor, opts.max_rest_rate);
  std::mutex mu;
  auto report = [&](const char* title, std::vector<Row>& rows, bool want_moving, bool show_excl) {
    std::printf("### %s\n\n| set | records | called moving | rate | 95%% upper bound of the %s rate | %s |%s\n"
                "|---|---|---|---|---|---|---|%s\n",
                title, want_moving ? "miss" : "false-alarm",
                want_moving ? "min score | min spread" : "max score | max spread",
                show_excl ? " moved stretch outside the longest static one |" : "", show_excl ? "---|" : "");
    int tn = 0, tm = 0;
    for (auto& r : rows) {
      if (!r.outside) tn += r.n, tm += r.moving;
      const int k = want_moving ? r.n - r.moving : r.moving;
      std::printf("| %s | %d | %d | %.1f %% | %.1f %% | %.3g | %.3g |", r.name.c_str(), r.n, r.moving,
                  100.0 * r.moving / std::max(1, r.n), 100.0 * upper95(k, r.n),
                  want_moving ? r.min_score : r.max_score, want_moving ? r.min_spread : r.max_spread);
      if (show_excl) {
        if (r.truths) std::printf(" %d / %d |", r.excl, r.truths);
        else std::printf(" - |");
      }
      std::printf("\n");
    }
    const int k = want_moving ? tn - tm : tm;
    std::printf("| **all (target set)** | %d | %d | %.1f %% | %.1f %% | | |%s\n\n", tn, tm,
                100.0 * tm / std::max(1, tn), 100.0 * upper95(k, tn), show_excl ? " |" : "");
    for (auto& r : rows)
      if (!r.worst.empty() && verbose) std::printf("  %s: %s\n", r.name.c_str(), r.worst.c_str());
    std::fflush(stdout);
  };
  auto account = [&](Row& row, const RestResult& res, const std::string& name, bool want_moving) {
    std::lock_guard<std::mutex> l(mu);
    ++row.n;
    if (!res.at_rest) ++row.moving;
    row.max_score = std::max(row.max_score, res.score);
    row.max_spread = std::max(row.max_spread, res.spread);
    row.min_score = std::min(row.min_score, res.score);
    row.min_spread = std::min(row.min_spread, res.spread);
    if (res.at_rest == want_moving && verbose)
      row.worst += "\n    " + name + " -> " + (res.at_rest ? "at rest: " : "MOVING: ") + res.reason;
  };

  if (set == "all" || set == "static") {
    std::vector<Row> rows(kNumClasses + 1);
    for (int c = 0; c < kNumClasses; ++c) rows[c].name = kClassNames[c];
    rows[kNumClasses].name = "sinusoid 1-3x per-sample noise (outside the target set)";
    rows[kNumClasses].outside = true;
    // Per seed: every class once, its effect cycling with the seed (each class x effect pair every 5 seeds).
    const int per = kNumClasses + 1;
    parallelFor(ns * per, jobs, [&](int i) {
      const uint64_t seed = s0 + i / per;
      const int k = i % per;
      StaticSpec sp;
      int row;
      if (k < kNumClasses) {
        sp.cls = static_cast<SensorClass>(k);
        sp.effect = static_cast<Effect>((seed + k) % kNumEffects);
        row = sp.cls;
      } else {
        sp.cls = static_cast<SensorClass>(seed % kNumClasses);
        sp.effect = kSine;
        sp.per_sample_sine = true;
        row = kNumClasses;
      }
      const Record r = makeStatic(seed, sp);
      const RestResult res = run(r, opts);
      account(rows[row], res, r.name + " seed " + std::to_string(seed), false);
    });
    report("Static simulated records (each class once per seed; effect none, sinusoid, Gauss-Markov, bias step, warm-up by turn)", rows, false,
           false);
  }
  if (set == "all" || set == "moving") {
    std::vector<Row> rows(kNumMotions + 2);
    for (int m = 0; m < kNumMotions; ++m) rows[m].name = kMotionNames[m];
    rows[kNumMotions].name = "hand-waving, gyro only";
    rows[kNumMotions + 1].name = "hand-waving 0.05-0.1 rad/s RMS, gyro only";
    rows[kNumMotions + 1].outside = true;
    const int per = kNumMotions + 2;
    parallelFor(ns * per, jobs, [&](int i) {
      const uint64_t seed = s0 + i / per;
      const int k = i % per;
      MotionSpec ms;
      ms.motion = k < kNumMotions ? static_cast<Motion>(k) : kWave;
      if (k == kNumMotions + 1) ms.max_amp = 0.1;
      const Record r = makeMoving(seed, ms);
      const RestResult res = run(r, opts, k < kNumMotions);
      account(rows[k], res, r.name + " seed " + std::to_string(seed), true);
      if (r.truth_motion.end > r.truth_motion.begin) {
        std::lock_guard<std::mutex> l(mu);
        ++rows[k].truths;
        if (excludes(res, r.truth_motion)) ++rows[k].excl;
      }
    });
    report("Moved simulated records", rows, true, true);
  }
  if (set == "all" || set == "real") {
    std::printf("### Real data\n\n| record | samples | tau0 [s] | verdict | moving fraction | longest static [s] | "
                "score | spread | reason |\n|---|---|---|---|---|---|---|---|---|\n");
    auto line = [&](const Record& r) {
      if (r.name.empty()) return;
      const RestResult res = run(r, opts);
      int64_t n = 0;
      for (auto& s : r.gyro[0]) n += s.size();
      std::printf("| %s | %lld | %.4g | %s | %.2f | %.0f | %.3g | %.3g | %s |\n", r.name.c_str(),
                  static_cast<long long>(n), r.tau0, res.at_rest ? "at rest" : "MOVING", res.moving_fraction,
                  (res.longest_static.end - res.longest_static.begin) * r.tau0, res.score, res.spread,
                  res.reason.c_str());
      std::fflush(stdout);
    };
    for (int k = 1; k <= 3; ++k) line(loadAdis(data, k));
    for (const auto& b : kRealBags) line(loadBag(data + "/real_bags/" + b.file, b.topic));
    std::printf("\n");
  }
  return 0;
}
#endif
