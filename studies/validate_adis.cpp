// Validation of the closed-loop model check: runs oadev + IEEE 952 fit + checkModel on the ADIS16405 static runs
// (shared data) and, with `controls`, measures the false-positive rate on simulated data without any effect.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

#include "gyro_allan/allan.hpp"
#include "gyro_allan/csv_input.hpp"
#include "gyro_allan/model_check.hpp"
#include "gyro_allan/noise_model.hpp"
#include "gyro_allan/simulate.hpp"
#include "kit.hpp"

using namespace gyro_allan;

namespace {

void usage() {
  std::fprintf(stderr,
               "usage: validate_adis adis [--data DIR] [--out DIR] [--runs 1,2,3]\n"
               "       validate_adis controls [--seeds N] [--rate HZ] [--duration S] [--mix 1|2|3]\n"
               "  adis:     per run and gyro axis: oadev (log grid, 10/decade), IEEE 952 fit, model check; prints a\n"
               "            table and writes DIR/adis_model_check.csv (curves) and DIR/adis_summary.csv\n"
               "  controls: simulated axes with IEEE noise only (several noise mixes); counts seeds where the check\n"
               "            added any effect (false positives)\n");
}

// Reads the three gyro columns (deg/s) of an ADIS16405 CSV (gzip) and returns them in rad/s.
std::vector<std::vector<double>> readAdis(const std::string& path) {
  CsvOptions o;
  o.scale = M_PI / 180.0;
  CsvSeries c = readCsvFile(path, o);
  if (c.columns.size() < 3 || c.columns[0].empty()) throw std::runtime_error("failed to read " + path);
  c.columns.resize(3);
  return std::move(c.columns);
}

struct AxisResult {
  DeviationCurve curve;
  FitResult fit;
  ModelCheck mc;
};

AxisResult analyze(const std::vector<double>& rate, double tau0, const ModelCheckOptions& mo,
                   const std::vector<double>* temperature = nullptr) {
  AxisResult r;
  DeviationOptions o;
  o.grid.kind = TauGridKind::Log;
  o.grid.per_decade = 10;
  r.curve = oadev(rate, tau0, o);
  r.fit = fitNoiseModel(r.curve, mo.fit);
  r.mc = checkModel(rate, tau0, r.curve, r.fit, mo, temperature);
  return r;
}

std::string effectLine(const DetectedEffect& e) {
  std::string s = e.type + " (dBIC " + std::to_string(static_cast<int>(std::lround(e.delta_bic))) + "):";
  for (const auto& kv : e.parameters) {
    char buf[96];
    std::snprintf(buf, sizeof buf, " %s=%.4g+-%.2g", kv.first.c_str(), kv.second.value, kv.second.sigma);
    s += buf;
  }
  return s;
}

int runAdis(int argc, char** argv) {
  const char* env = std::getenv("GYRO_ALLAN_SHARED_DATA");
  const std::string data = study::optionValue(argc, argv, "--data", env ? std::string(env, 2) + "/adis16405" : "../shared/data/adis16405", 2);
  const std::string out = study::optionValue(argc, argv, "--out", ".", 2);
  const std::string runs = study::optionValue(argc, argv, "--runs", "1,2,3", 2);
  const double tau0 = 0.01;
  ModelCheckOptions mo;
  FILE* curves = std::fopen((out + "/adis_model_check.csv").c_str(), "w");
  FILE* summary = std::fopen((out + "/adis_summary.csv").c_str(), "w");
  if (!curves || !summary) throw std::runtime_error("cannot write to " + out);
  std::fprintf(curves, "run,axis,tau_s,adev,model_before,model_after,edf\n");
  std::fprintf(summary,
               "run,axis,rms_given,chi2_dof_given,rms_before,chi2_dof_before,rms_after,chi2_dof_after,ratio,effects\n");
  const char* axes = "xyz";
  for (char rc : runs) {
    if (rc < '1' || rc > '3') continue;
    const std::string path = data + "/adis16405_imu" + rc + "_100Hz.csv.gz";
    const auto g = readAdis(path);
    std::printf("== run %c: %zu samples (%.0f s)\n", rc, g[0].size(), g[0].size() * tau0);
    for (int a = 0; a < 3; ++a) {
      const AxisResult r = analyze(g[a], tau0, mo);
      const ModelCheck& mc = r.mc;
      std::printf("-- run %c gyro %c: plain fit (as given) rms_log10 %.4f chi2/dof %.2f; reweighted: rms %.4f chi2/dof "
                  "%.2f\n   residual: %s\n",
                  rc, axes[a], r.fit.rms_log10, r.fit.chi2_dof, mc.before.rms_log10, mc.before.chi2_dof,
                  mc.residual_before.summary.c_str());
      const char* names[kNumTerms] = {"Q", "N", "B", "K", "R"};
      std::printf("   before:");
      for (int t = 0; t < kNumTerms; ++t)
        std::printf(" %s=%.3g+-%.2g%s", names[t], mc.fit_before.terms[t].value, mc.fit_before.terms[t].sigma,
                    mc.fit_before.terms[t].supported ? "" : "(bound)");
      std::printf("\n");
      std::string eff;
      for (const auto& e : mc.effects) {
        std::printf("   + %s\n     evidence: %s\n", effectLine(e).c_str(), e.evidence.c_str());
        eff += (eff.empty() ? "" : "; ") + effectLine(e);
      }
      for (const auto& rj : mc.rejected) std::printf("   - %s\n", rj.c_str());
      std::printf("   after: ");
      for (int t = 0; t < kNumTerms; ++t)
        std::printf(" %s=%.3g+-%.2g%s", names[t], mc.fit_after.terms[t].value, mc.fit_after.terms[t].sigma,
                    mc.fit_after.terms[t].supported ? "" : "(bound)");
      std::printf("\n   error: rms_log10 %.4f -> %.4f (x%.1f), chi2/dof %.2f -> %.2f\n   residual after: %s\n",
                  mc.before.rms_log10, mc.after.rms_log10, mc.before.rms_log10 / mc.after.rms_log10,
                  mc.before.chi2_dof, mc.after.chi2_dof, mc.residual_after.summary.c_str());
      for (size_t i = 0; i < mc.tau.size(); ++i)
        std::fprintf(curves, "%c,%c,%.6g,%.6e,%.6e,%.6e,%.1f\n", rc, axes[a], mc.tau[i], std::sqrt(mc.measured_var[i]),
                     std::sqrt(std::max(0.0, mc.model_var_before[i])), std::sqrt(std::max(0.0, mc.model_var_after[i])),
                     r.curve.points[i].edf);
      std::string effq = eff;
      for (auto& ch : effq)
        if (ch == '"') ch = '\'';
      std::fprintf(summary, "%c,%c,%.4f,%.2f,%.4f,%.2f,%.4f,%.2f,%.2f,\"%s\"\n", rc, axes[a], r.fit.rms_log10,
                   r.fit.chi2_dof, mc.before.rms_log10, mc.before.chi2_dof, mc.after.rms_log10, mc.after.chi2_dof,
                   mc.before.rms_log10 / mc.after.rms_log10, effq.c_str());
      std::fflush(stdout);
    }
  }
  std::fclose(curves);
  std::fclose(summary);
  return 0;
}

int runControls(int argc, char** argv) {
  const int seeds = std::atoi(study::optionValue(argc, argv, "--seeds", "100", 2).c_str());
  const double rate = std::atof(study::optionValue(argc, argv, "--rate", "100", 2).c_str());
  const double duration = std::atof(study::optionValue(argc, argv, "--duration", "3600", 2).c_str());
  if (seeds < 1 || !(rate > 0) || !(duration > 0)) throw std::invalid_argument("controls: bad --seeds/--rate/--duration");
  struct Mix {
    const char* name;
    AxisNoise a;
  };
  std::vector<Mix> mixes(3);
  mixes[0].name = "Q+N+B+K (navigation grade-like)";
  mixes[0].a.quantization = 2e-6;
  mixes[0].a.angle_random_walk = 1e-4;
  mixes[0].a.bias_instability = 5e-6;
  mixes[0].a.rate_random_walk = 2e-7;
  mixes[1].name = "N+B strong flicker";
  mixes[1].a.angle_random_walk = 1e-4;
  mixes[1].a.bias_instability = 3e-5;
  mixes[2].name = "N+K strong random walk";
  mixes[2].a.angle_random_walk = 1e-4;
  mixes[2].a.rate_random_walk = 3e-6;
  const int only = std::atoi(study::optionValue(argc, argv, "--mix", "0", 2).c_str());  // 1..3: one mix only
  ModelCheckOptions mo;
  int total = 0, total_fp = 0;
  for (size_t mi = 0; mi < mixes.size(); ++mi) {
    if (only > 0 && static_cast<int>(mi) + 1 != only) continue;
    const Mix& mix = mixes[mi];
    int fp = 0;
    std::string kinds;
    for (int s = 1; s <= seeds; ++s) {
      const std::vector<double> y =
          simulateAxis(mix.a, rate, static_cast<int64_t>(duration * rate), static_cast<uint64_t>(1000 + s));
      const AxisResult r = analyze(y, 1.0 / rate, mo);
      if (!r.mc.effects.empty()) {
        ++fp;
        kinds += " " + std::to_string(s) + ":" + r.mc.effects.front().type;
      }
    }
    std::printf("%-34s false positives %d / %d (%.1f %%)%s\n", mix.name, fp, seeds, 100.0 * fp / seeds,
                kinds.c_str());
    std::fflush(stdout);
    total += seeds;
    total_fp += fp;
  }
  std::printf("all controls: %d / %d seeds with an effect added (%.1f %%)\n", total_fp, total, 100.0 * total_fp / total);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    usage();
    return 2;
  }
  try {
    const std::string cmd = argv[1];
    if (cmd == "adis") return runAdis(argc, argv);
    if (cmd == "controls") return runControls(argc, argv);
    usage();
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "validate_adis: %s\n", e.what());
    return 1;
  }
}
