// Study behind docs/spikes.md: false spike detections on clean simulated records of several gyro classes (threshold
// choice on one seed set, validation on a disjoint one) and accuracy on records with injected spikes.
//   spike_study [--choose-seeds N] [--validate-seeds N] [--duration S] [--accuracy-seeds N] [--restore-noise 0|1]
//               [--heavy-seeds N]
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "gyro_allan/allan.hpp"
#include "gyro_allan/analysis.hpp"
#include "gyro_allan/model_check.hpp"
#include "gyro_allan/simulate.hpp"
#include "gyro_allan/spikes.hpp"
#include "kit.hpp"

using namespace gyro_allan;

namespace {

struct GyroClass {
  const char* name;
  double rate_hz;
  AxisNoise noise;
};

std::vector<GyroClass> classes() {
  std::vector<GyroClass> c;
  AxisNoise a;
  // Consumer MEMS: N 1 deg/sqrt(h), B 10 deg/h, K 10 deg/h/sqrt(h), 100 Hz.
  a = AxisNoise();
  a.angle_random_walk = 3e-4, a.bias_instability = 5e-5, a.rate_random_walk = 8e-7, a.bias = 0.01;
  c.push_back({"mems_consumer", 100, a});
  // Tactical MEMS: N 0.1 deg/sqrt(h), B 1 deg/h, 400 Hz.
  a = AxisNoise();
  a.angle_random_walk = 3e-5, a.bias_instability = 5e-6, a.rate_random_walk = 1e-7;
  c.push_back({"mems_tactical", 400, a});
  // FOG: N 0.005 deg/sqrt(h), B 0.01 deg/h, Earth rate input, 200 Hz.
  a = AxisNoise();
  a.angle_random_walk = 1.5e-6, a.bias_instability = 5e-8, a.rate_random_walk = 1e-9, a.input_rate = 5e-5;
  c.push_back({"fog", 200, a});
  // RLG with pulse quantization Q = 1 arcsec, N 0.003 deg/sqrt(h), dithered and not, 400 Hz.
  a = AxisNoise();
  a.quantization = 4.8e-6, a.angle_random_walk = 9e-7, a.bias_instability = 2e-8, a.input_rate = 5e-5;
  c.push_back({"rlg_dithered", 400, a});
  a.dither = false;
  c.push_back({"rlg_undithered", 400, a});
  // MEMS with rate_lsb rounding: 16-bit at 2000 deg/s (LSB 1.07e-3 rad/s) about one white sigma, and 4 sigma.
  a = AxisNoise();
  a.angle_random_walk = 1e-4, a.bias_instability = 1e-5, a.rate_lsb = 1.07e-3, a.bias = 2e-3;
  c.push_back({"mems_lsb", 200, a});
  a.angle_random_walk = 2e-5;
  c.push_back({"mems_lsb_coarse", 200, a});
  // MEMS (N 1e-4, 200 Hz: white sigma 1.4e-3 rad/s) with an undeclared effect each.
  AxisNoise m;
  m.angle_random_walk = 1e-4, m.bias_instability = 1.8e-5, m.rate_random_walk = 2e-7, m.quantization = 2e-6;
  a = m;
  a.sine_amplitude = 5e-4, a.sine_frequency = 2.5;
  c.push_back({"mems_sine", 200, a});
  a = m;
  a.sine_amplitude = 7e-3, a.sine_frequency = 23;  // 5 sigma at 23 Hz: the local median does not follow it
  c.push_back({"mems_fast_sine", 200, a});
  a = m;
  a.gm_sigma = 1e-3, a.gm_tau = 5;
  c.push_back({"mems_gauss_markov", 200, a});
  a = m;
  a.step_size = 5e-2, a.step_time = 900;  // a 35-sigma bias step: its edge samples are 17 sigma from the local median
  c.push_back({"mems_big_step", 200, a});
  a = m;
  a.thermal_amplitude = 1e-2, a.thermal_tau = 600;
  c.push_back({"mems_thermal", 200, a});
  return c;
}

double whiteSigma(const GyroClass& g) { return g.noise.angle_random_walk * std::sqrt(g.rate_hz); }

FitResult jointFit(const std::vector<double>& x, double tau0) {
  DeviationOptions o;
  DeviationCurve c = oadev(x, tau0, o);
  enforceRedderWithTau(&c, o.confidence);
  return fitWithModelEdf(&c, FitOptions{}, o.confidence);
}

int arg(int argc, char** argv, const char* name, int def) {
  return study::parseInt(study::optionValue(argc, argv, name, std::to_string(def)), name);
}

}  // namespace

int main(int argc, char** argv) {
  const int choose = arg(argc, argv, "--choose-seeds", 20);
  const int validate = arg(argc, argv, "--validate-seeds", 100);
  const double duration = arg(argc, argv, "--duration", 3600);
  const int acc_seeds = arg(argc, argv, "--accuracy-seeds", 20);
  SpikeOptions acc_opt;  // accuracy part: replacement with (default) or without the noise draw
  acc_opt.restore_noise = arg(argc, argv, "--restore-noise", 1) != 0;
  const std::vector<GyroClass> cls = classes();
  const std::vector<double> zs = {5, 6, 7, 8, 10, 12};

  // 1. Threshold choice: seeds 1..choose; records with any detection at each z.
  std::printf("# false detections on clean records, %.0f s each; choice seeds 1..%d\n", duration, choose);
  std::printf("%-20s", "class");
  for (double z : zs) std::printf("  z=%-5.0f", z);
  std::printf("  (records with >= 1 spike / records; max spikes in one record)\n");
  for (const auto& g : cls) {
    const int64_t n = static_cast<int64_t>(duration * g.rate_hz);
    std::vector<int> hit(zs.size(), 0), worst(zs.size(), 0);
    for (int s = 1; s <= choose; ++s) {
      const std::vector<double> x = simulateAxis(g.noise, g.rate_hz, n, static_cast<uint64_t>(s));
      for (size_t k = 0; k < zs.size(); ++k) {
        SpikeOptions o;
        o.z = zs[k];
        const SpikeReport r = detectSpikes(x, o);
        hit[k] += r.count > 0;
        worst[k] = std::max<int>(worst[k], static_cast<int>(r.count));
      }
    }
    std::printf("%-20s", g.name);
    for (size_t k = 0; k < zs.size(); ++k) std::printf("  %2d/%-2d %-3d", hit[k], choose, worst[k]);
    std::printf("\n");
    std::fflush(stdout);
  }

  // 2. Validation of the default (z = 10) on disjoint seeds 1001..1000+validate.
  std::printf("\n# validation of the default rule (z = 10) on seeds 1001..%d\n", 1000 + validate);
  int total = 0, total_hit = 0;
  for (const auto& g : cls) {
    const int64_t n = static_cast<int64_t>(duration * g.rate_hz);
    int hit = 0;
    int64_t spikes = 0, rejected = 0;
    double max_sigma_ratio = 0, min_sigma_ratio = 1e300;
    for (int s = 1001; s <= 1000 + validate; ++s) {
      const std::vector<double> x = simulateAxis(g.noise, g.rate_hz, n, static_cast<uint64_t>(s));
      const SpikeReport r = detectSpikes(x, SpikeOptions{});
      hit += r.count > 0;
      spikes += r.count;
      rejected += r.rejected;
      const double ratio = r.robust_sigma / whiteSigma(g);
      max_sigma_ratio = std::max(max_sigma_ratio, ratio);
      min_sigma_ratio = std::min(min_sigma_ratio, ratio);
    }
    total += validate;
    total_hit += hit;
    std::printf("%-20s records with spikes %d/%d, spikes %lld, beyond threshold but rejected %lld, robust sigma / "
                "white sigma %.3g..%.3g\n",
                g.name, hit, validate, static_cast<long long>(spikes), static_cast<long long>(rejected),
                min_sigma_ratio, max_sigma_ratio);
    std::fflush(stdout);
  }
  if (total > 0)
    std::printf("all classes: %d of %d clean records with >= 1 detection (%.2f %%)\n", total_hit, total,
                100.0 * total_hit / total);

  // 3. Accuracy: static MEMS 1 h at 200 Hz with injected spikes.
  const double fs = 200, tau0 = 1 / fs;
  const int64_t n = 720000;
  AxisNoise m;
  m.angle_random_walk = 1e-4, m.bias_instability = 1.8e-5, m.rate_random_walk = 2e-7, m.bias = 3e-3;
  const double sigma = m.angle_random_walk * std::sqrt(fs);
  struct Pop {
    const char* name;
    int64_t count;
    double lo, hi;
  };
  std::printf("\n# accuracy: static MEMS (N = 1e-4 rad/sqrt(s), B 1.8e-5, K 2e-7), 1 h at 200 Hz, seeds 2001..%d, "
              "replacement: local median%s\n",
              2000 + acc_seeds, acc_opt.restore_noise ? " + noise draw" : " alone");
  {
    // Cost: detectSpikes on a clean and a spiky 1.44 M-sample record (400 Hz, 1 h), best of 3.
    std::vector<double> x = simulateAxis(m, 400, 1440000, 9);
    for (int pass = 0; pass < 2; ++pass) {
      double best = 1e300;
      for (int r = 0; r < 3; ++r) {
        const auto t0 = std::chrono::steady_clock::now();
        const SpikeReport rep = detectSpikes(x, SpikeOptions{});
        best = std::min(best, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
        if (r == 0 && pass == 1) std::printf("(%lld spikes) ", static_cast<long long>(rep.count));
      }
      std::printf("detectSpikes on 1.44 M samples, %s: %.1f ms\n", pass ? "0.5 % spikes" : "clean", 1e3 * best);
      if (pass == 0)
        for (size_t i = 100; i < x.size(); i += 200) x[i] += 30 * m.angle_random_walk * std::sqrt(400.0);
    }
  }
  for (const Pop& p : {Pop{"A: 0.5 % at 25-40 sigma", 3600, 25, 40}, Pop{"B: 1e-4 at 30-1000 sigma", 72, 30, 1000},
                       Pop{"C: 0.5 % at 10-1000 sigma", 3600, 10, 1000}}) {
    double found_min = 1e9, found_max = 0, k_before = 0, k_after = 0, infl = 0, dev_clean_max = 0;
    std::vector<double> n_after, n_clean, n_sig;
    for (int s = 2001; s <= 2000 + acc_seeds; ++s) {
      const std::vector<double> clean = simulateAxis(m, fs, n, static_cast<uint64_t>(s));
      std::vector<double> x = clean;
      std::mt19937_64 rng(static_cast<uint64_t>(s) * 7 + 1);
      std::uniform_int_distribution<int64_t> pos(0, n - 1);
      std::uniform_real_distribution<double> u(0.0, 1.0);
      std::set<int64_t> at;
      while (static_cast<int64_t>(at.size()) < p.count) at.insert(pos(rng));
      for (int64_t i : at) x[static_cast<size_t>(i)] += (u(rng) < 0.5 ? -1 : 1) * p.lo * std::pow(p.hi / p.lo, u(rng)) * sigma;
      const FitResult with = jointFit(x, tau0);
      const SpikeReport r = removeSpikes(&x, acc_opt);
      const FitResult after = jointFit(x, tau0), ref = jointFit(clean, tau0);
      const double ratio = static_cast<double>(r.count) / p.count;
      found_min = std::min(found_min, ratio);
      found_max = std::max(found_max, ratio);
      k_before += r.excess_kurtosis_before / acc_seeds;
      k_after += r.excess_kurtosis_after / acc_seeds;
      const double na = after.terms[kAngleRandomWalk].value;
      infl += with.terms[kAngleRandomWalk].value / na / acc_seeds;
      n_after.push_back(na / m.angle_random_walk);
      n_clean.push_back(ref.terms[kAngleRandomWalk].value / m.angle_random_walk);
      n_sig.push_back(after.terms[kAngleRandomWalk].sigma / m.angle_random_walk);
      dev_clean_max = std::max(dev_clean_max, std::fabs(na / ref.terms[kAngleRandomWalk].value - 1));
    }
    auto meanStd = [](const std::vector<double>& v, double* mean, double* sd) {
      double a = 0, b = 0;
      for (double x : v) a += x;
      a /= v.size();
      for (double x : v) b += (x - a) * (x - a);
      *mean = a;
      *sd = std::sqrt(b / (v.size() - 1));
    };
    double ma, sa, mc, sc, ms, ss;
    meanStd(n_after, &ma, &sa);
    meanStd(n_clean, &mc, &sc);
    meanStd(n_sig, &ms, &ss);
    std::printf("%s: found/injected %.4f..%.4f; excess kurtosis %.1f -> %.3f; N with spikes / N after x%.2f;\n"
                "   N after / truth %.4f +- %.4f (seed spread), clean record's N / truth %.4f +- %.4f, fit 1-sigma %.4f;"
                " |N after / N clean - 1| <= %.4f\n",
                p.name, found_min, found_max, k_before, k_after, infl, ma, sa, mc, sc, ms, dev_clean_max);
    std::fflush(stdout);
  }

  // 4. Genuinely heavy-tailed white noise (Student t, unit variance) on the same MEMS: what the rule takes out.
  const int heavy_seeds = arg(argc, argv, "--heavy-seeds", 20);
  if (heavy_seeds > 0)
    std::printf("\n# heavy-tailed genuine white noise (Student t, nu dof, scaled to N = 1e-4), 1 h at 200 Hz, seeds "
                "3001..%d\n",
                3000 + heavy_seeds);
  for (double nu : {4.0, 6.0, 10.0}) {
    if (heavy_seeds <= 0) break;
    AxisNoise base = m;
    base.angle_random_walk = 0;
    int hit = 0;
    int64_t spikes = 0;
    double worst = 0, shift = 0;
    for (int s = 3001; s <= 3000 + heavy_seeds; ++s) {
      std::vector<double> x = simulateAxis(base, fs, n, static_cast<uint64_t>(s));
      std::mt19937_64 rng(static_cast<uint64_t>(s) * 13 + 5);
      std::student_t_distribution<double> t(nu);
      const double scale = sigma / std::sqrt(nu / (nu - 2));
      for (auto& v : x) v += scale * t(rng);
      const double n_before = jointFit(x, tau0).terms[kAngleRandomWalk].value;
      const SpikeReport r = removeSpikes(&x, SpikeOptions{});
      hit += r.count > 0;
      spikes += r.count;
      if (r.count > 0) {
        const double d = jointFit(x, tau0).terms[kAngleRandomWalk].value / n_before - 1;
        worst = std::min(worst, d);
        shift += d / heavy_seeds;
      }
    }
    std::printf("t(%g): excess kurtosis %s; records with detections %d/%d, %.1f detections per record (%.2g of "
                "samples); N after / N before removal - 1: mean %.4f %%, worst %.4f %%\n",
                nu, nu > 4 ? std::to_string(6 / (nu - 4)).c_str() : "infinite", hit, heavy_seeds,
                static_cast<double>(spikes) / heavy_seeds, static_cast<double>(spikes) / heavy_seeds / n, 100 * shift,
                100 * worst);
    std::fflush(stdout);
  }
  return 0;
}
