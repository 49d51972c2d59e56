// Calibration study of the model check's acceptance rule: false positives on clean simulated controls (several
// sensor classes) and detection of injected effects, over a range of seeds, one line per run (CSV) and a summary.
//
//   check_study [--seeds A-B] [--class NAME[,NAME...]] [--csv FILE] [gate options]
//
// Classes (all 1 h; see classes() below for the numbers):
//   controls: consumer, consumer_lsb (200 Hz), consumer_100, consumer_lsb_100 (100 Hz), tactical, fog, rlg, nav, flicker,
//             random_walk
//   injected (on nav): sinusoid, gauss_markov, bias_step, thermal (warm-up with temperature), warmup (without)
// Gate options (ModelCheckOptions): --min-rms-gain X, --min-amplitude-z X, --max-nonlinear-rel-sigma X,
// --bic-margin X, --bic-margin-stochastic X.
// Columns struct.bef / struct.aft: runs whose residual verdict (ResidualAnalysis::structured) was "structured" for the
// plain fit / for the final answer.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

#include "gyro_allan/allan.hpp"
#include "gyro_allan/model_check.hpp"
#include "gyro_allan/noise_model.hpp"
#include "gyro_allan/simulate.hpp"
#include "kit.hpp"

using namespace gyro_allan;

namespace {

using namespace study;  // kDeg, optionValue, parseSeeds (kit.hpp)

struct Class {
  std::string name;
  std::string expect;  // effect type that counts as a detection ("" = control: any effect is a false positive)
  double rate_hz = 100;
  double duration_s = 3600;
  bool temperature = false;
  AxisNoise a;
  double lowpass = 0;   // first-order low-pass y += (1 - lowpass) (x - y) applied to the simulated rate (a DLPF) ...
  double post_lsb = 0;  // ... and the output rounded to this LSB after it [rad/s]
};

Class make(const char* name, const char* expect, double rate_hz, double duration_s, bool temperature = false) {
  Class k;
  k.name = name;
  k.expect = expect;
  k.rate_hz = rate_hz;
  k.duration_s = duration_s;
  k.temperature = temperature;
  return k;
}

// Consumer MEMS as in the issue: N 0.5 deg/sqrt(h), B 20 deg/h, K 10 deg/h/sqrt(h).
AxisNoise consumer() {
  AxisNoise a;
  a.angle_random_walk = 0.5 * kDeg / 60.0;
  a.bias_instability = 20 * kDeg / 3600.0;
  a.rate_random_walk = 10 * kDeg / 3600.0 / 60.0;
  return a;
}

// The base noise of test_model_check (Q, N, B, K), on which the effects are injected.
AxisNoise base() {
  AxisNoise a;
  a.quantization = 2e-6;
  a.angle_random_walk = 1e-4;
  a.bias_instability = 5e-6;
  a.rate_random_walk = 2e-7;
  return a;
}

std::vector<Class> classes() {
  std::vector<Class> c;
  {
    Class k = make("consumer", "", 200, 3600);
    k.a = consumer();
    c.push_back(k);
  }
  {
    Class k = make("consumer_lsb", "", 200, 3600);  // output rounded to 0.061 deg/s (2000 dps full scale, 16 bit)
    k.a = consumer();
    k.a.rate_lsb = 0.061 * kDeg;
    c.push_back(k);
  }
  {
    Class k = make("consumer_100", "", 100, 3600);  // the same at 100 Hz
    k.a = consumer();
    c.push_back(k);
  }
  {
    Class k = make("consumer_lsb_100", "", 100, 3600);  // 100 Hz, LSB 0.061 deg/s
    k.a = consumer();
    k.a.rate_lsb = 0.061 * kDeg;
    c.push_back(k);
  }
  {
    Class k = make("tactical", "", 200, 3600);  // N 0.15 deg/sqrt(h), B 1 deg/h, K 1 deg/h/sqrt(h)
    k.a.angle_random_walk = 0.15 * kDeg / 60.0;
    k.a.bias_instability = 1 * kDeg / 3600.0;
    k.a.rate_random_walk = 1 * kDeg / 3600.0 / 60.0;
    c.push_back(k);
  }
  {
    Class k = make("fog", "", 100, 3600);  // N 0.01 deg/sqrt(h), B 0.05 deg/h, K 0.02 deg/h/sqrt(h)
    k.a.angle_random_walk = 0.01 * kDeg / 60.0;
    k.a.bias_instability = 0.05 * kDeg / 3600.0;
    k.a.rate_random_walk = 0.02 * kDeg / 3600.0 / 60.0;
    c.push_back(k);
  }
  {
    Class k = make("rlg", "", 100, 3600);  // pulse-counter Q 2 urad (1.5 arcsec pulses), N 0.003 deg/sqrt(h), B 0.003 deg/h
    k.a.quantization = 2e-6;
    k.a.angle_random_walk = 0.003 * kDeg / 60.0;
    k.a.bias_instability = 0.003 * kDeg / 3600.0;
    c.push_back(k);
  }
  {
    Class k = make("nav", "", 100, 3600);  // test_model_check's base noise
    k.a = base();
    c.push_back(k);
  }
  {
    Class k = make("flicker", "", 100, 3600);  // validate_adis controls mix 2: N + strong flicker
    k.a.angle_random_walk = 1e-4;
    k.a.bias_instability = 3e-5;
    c.push_back(k);
  }
  {
    Class k = make("random_walk", "", 100, 3600);  // validate_adis controls mix 3: N + strong random walk
    k.a.angle_random_walk = 1e-4;
    k.a.rate_random_walk = 3e-6;
    c.push_back(k);
  }
  {
    Class k = make("sinusoid", "sinusoid", 100, 3600);
    k.a = base();
    k.a.sine_amplitude = 1e-4;
    k.a.sine_frequency = 1.3;
    c.push_back(k);
  }
  {
    Class k = make("gauss_markov", "gauss_markov", 100, 3600);
    k.a = base();
    k.a.gm_sigma = 6e-5;
    k.a.gm_tau = 10.0;
    c.push_back(k);
  }
  {
    Class k = make("bias_step", "bias_step", 100, 3600);
    k.a = base();
    k.a.step_size = 3e-4;
    k.a.step_time = 0.37 * 3600;
    c.push_back(k);
  }
  {
    Class k = make("thermal", "thermal_drift", 100, 3600, true);
    k.a = base();
    k.a.thermal_amplitude = 3e-4;
    k.a.thermal_tau = 200.0;
    c.push_back(k);
  }
  {
    Class k = make("warmup", "warmup", 100, 3600);
    k.a = base();
    k.a.thermal_amplitude = 3e-4;
    k.a.thermal_tau = 200.0;
    c.push_back(k);
  }
  return c;
}

std::string csvSafe(std::string s) {
  for (auto& ch : s)
    if (ch == '"' || ch == '\n') ch = '\'';
  return s;
}

const char* const kUsage =
    "usage: check_study [--seeds A-B] [--class NAME[,NAME...]] [--csv FILE] [--min-rms-gain X] [--min-amplitude-z X]\n"
    "                   [--max-nonlinear-rel-sigma X] [--bic-margin X] [--bic-margin-stochastic X]\n"
    "  seeds 1-30: the tuning set; 1001-1030: the validation set (docs/validation.md). Default 1-30.\n";

/// Every argument must be a known option followed by its value: anything else is named and the tool exits 1.
bool checkArguments(int argc, char** argv) {
  static const char* const known[] = {"--seeds", "--class", "--csv", "--min-rms-gain", "--min-amplitude-z",
                                      "--max-nonlinear-rel-sigma", "--bic-margin", "--bic-margin-stochastic"};
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--help") == 0 || std::strcmp(argv[i], "-h") == 0) {
      std::fputs(kUsage, stdout);
      std::exit(0);
    }
    bool ok = false;
    for (const char* k : known) ok = ok || std::strcmp(argv[i], k) == 0;
    if (!ok || i + 1 >= argc) {
      std::fprintf(stderr, "check_study: %s %s (--help for usage)\n", ok ? "missing value for" : "unknown option",
                   argv[i]);
      return false;
    }
    ++i;
  }
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  if (!checkArguments(argc, argv)) return 1;
  try {
    const std::string seeds = optionValue(argc, argv, "--seeds", "1-30");
    const SeedRange seed_range = parseSeeds(seeds);
    const int s0 = seed_range.first, s1 = seed_range.last;
    const std::string only = "," + optionValue(argc, argv, "--class", "") + ",";
    const std::string csv_path = optionValue(argc, argv, "--csv", "");
    ModelCheckOptions mo;
    mo.min_rms_gain = std::atof(optionValue(argc, argv, "--min-rms-gain", std::to_string(mo.min_rms_gain)).c_str());
    mo.min_amplitude_z = std::atof(optionValue(argc, argv, "--min-amplitude-z", std::to_string(mo.min_amplitude_z)).c_str());
    mo.max_nonlinear_rel_sigma =
        std::atof(optionValue(argc, argv, "--max-nonlinear-rel-sigma", std::to_string(mo.max_nonlinear_rel_sigma)).c_str());
    mo.bic_margin = std::atof(optionValue(argc, argv, "--bic-margin", std::to_string(mo.bic_margin)).c_str());
    mo.bic_margin_stochastic =
        std::atof(optionValue(argc, argv, "--bic-margin-stochastic", std::to_string(mo.bic_margin_stochastic)).c_str());
    std::printf("# min_rms_gain %.4g, min_amplitude_z %.3g, max_nonlinear_rel_sigma %.3g, bic_margin %.3g, "
                "bic_margin_stochastic %.3g\n",
                mo.min_rms_gain, mo.min_amplitude_z, mo.max_nonlinear_rel_sigma, mo.bic_margin,
                mo.bic_margin_stochastic);
    FILE* csv = csv_path.empty() ? nullptr : std::fopen(csv_path.c_str(), "w");
    if (csv)
      std::fprintf(csv, "class,seed,rms_before,rms_after,n_effects,first_type,worse,structured_before,chi2_dof_before,"
                   "chi2_p_before,structured_after,chi2_p_after,effects,rejected\n");
    std::printf("%-14s %6s %5s %9s %12s %10s %10s %10s\n", "class", "seeds", "runs", "any kept", "expected", "worse rms",
                "struct.bef", "struct.aft");
    for (const Class& k : classes()) {
      if (only != ",," && only.find("," + k.name + ",") == std::string::npos) continue;
      int runs = 0, any = 0, found = 0, worse = 0, struct_before = 0, struct_after = 0;
      std::string which;
      for (int s = s0; s <= s1; ++s) {
        SimulationSpec spec;
        spec.rate_hz = k.rate_hz;
        spec.duration_s = k.duration_s;
        spec.seed = static_cast<uint64_t>(s);
        spec.axes[0] = k.a;
        spec.temperature = k.temperature;
        if (k.a.step_size != 0) spec.axes[0].step_time = (0.2 + 0.6 * ((s * 37) % 100) / 100.0) * k.duration_s;
        SimulatedData d = simulate(spec);
        if (k.lowpass > 0) {
          double y = d.rate[0].empty() ? 0.0 : d.rate[0][0];
          for (auto& v : d.rate[0]) {
            y += (1 - k.lowpass) * (v - y);
            v = y;
          }
        }
        if (k.post_lsb > 0)
          for (auto& v : d.rate[0]) v = std::round(v / k.post_lsb) * k.post_lsb;
        const double tau0 = 1.0 / k.rate_hz;
        DeviationOptions o;
        o.grid.kind = TauGridKind::Log;
        o.grid.per_decade = 10;
        const DeviationCurve curve = oadev(d.rate[0], tau0, o);
        const FitResult fit = fitNoiseModel(curve, mo.fit);
        const ModelCheck mc = checkModel(d.rate[0], tau0, curve, fit, mo, k.temperature ? &d.temperature : nullptr);
        ++runs;
        const bool kept = !mc.effects.empty();
        bool hit = false;
        std::string eff, rej;
        for (const auto& e : mc.effects) {
          hit = hit || e.type == k.expect;
          char buf[160];
          std::snprintf(buf, sizeof buf, "%s%s dBIC %.1f", eff.empty() ? "" : "; ", e.type.c_str(), e.delta_bic);
          eff += buf;
          for (const auto& kv : e.parameters) {
            std::snprintf(buf, sizeof buf, " %s=%.3g+-%.2g", kv.first.c_str(), kv.second.value, kv.second.sigma);
            eff += buf;
          }
        }
        for (const auto& r : mc.rejected) rej += (rej.empty() ? "" : " | ") + r;
        const bool w = kept && !(mc.after.rms_log10 < mc.before.rms_log10);
        any += kept;
        struct_before += mc.residual_before.structured;
        struct_after += mc.residual_after.structured;
        found += hit;
        worse += w;
        if (kept && k.expect.empty()) which += " " + std::to_string(s) + ":" + mc.effects.front().type;
        if (!k.expect.empty() && !hit) which += " " + std::to_string(s) + (kept ? ":" + mc.effects.front().type : ":-");
        if (csv) {
          std::fprintf(csv, "%s,%d,%.5f,%.5f,%zu,%s,%d,%d,%.3f,%.4g,%d,%.4g,\"%s\",\"%s\"\n", k.name.c_str(), s,
                       mc.before.rms_log10, mc.after.rms_log10, mc.effects.size(),
                       kept ? mc.effects.front().type.c_str() : "", w ? 1 : 0, mc.residual_before.structured ? 1 : 0,
                       mc.before.chi2_dof, mc.fit_before.chi2_p, mc.residual_after.structured ? 1 : 0,
                       mc.fit_after.chi2_p, csvSafe(eff).c_str(), csvSafe(rej).c_str());
          std::fflush(csv);
        }
      }
      char range[32];
      std::snprintf(range, sizeof range, "%d-%d", s0, s1);
      std::printf("%-14s %9s %5d %9d %12s %10d %10d %10d %s%s\n", k.name.c_str(), range, runs, any,
                  k.expect.empty() ? "-" : (std::to_string(found) + "/" + std::to_string(runs)).c_str(), worse,
                  struct_before, struct_after, k.expect.empty() ? "kept:" : "missed:", which.c_str());
      std::fflush(stdout);
    }
    if (csv) std::fclose(csv);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "check_study: %s\n", e.what());
    return 1;
  }
}
