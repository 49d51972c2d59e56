// Study: bias and spread of Q and N from joint_fit (fitNoiseModel on the raw oadev) and wavelet_split on simulated
// ring-laser-gyro data (Q = 0.35 arcsec, N = 0.001 deg/sqrt(h)), over many seeds and several quantization regimes.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "gyro_allan/allan.hpp"
#include "gyro_allan/noise_model.hpp"
#include "gyro_allan/simulate.hpp"
#include "gyro_allan/wavelet_split.hpp"

using namespace gyro_allan;

namespace {

constexpr double kArcsec = M_PI / 180.0 / 3600.0;
constexpr double kQ = 0.35 * kArcsec;                       // rad
constexpr double kN = 0.001 * M_PI / 180.0 / 60.0;          // rad/sqrt(s)  (0.001 deg/sqrt(h))
constexpr double kDegPerHour = M_PI / 180.0 / 3600.0;       // rad/s

struct Scenario {
  std::string name;
  double rate_hz;
  double duration_s;
  bool dither;
  double input_rate;  // rad/s
};

struct Stats {
  std::vector<double> q, n;
  void add(double qv, double nv) {
    q.push_back(qv / kQ - 1.0);
    n.push_back(nv / kN - 1.0);
  }
  static void ms(const std::vector<double>& v, double* mean, double* sd) {
    double s = 0;
    for (double x : v) s += x;
    *mean = v.empty() ? 0 : s / v.size();
    double ss = 0;
    for (double x : v) ss += (x - *mean) * (x - *mean);
    *sd = v.size() > 1 ? std::sqrt(ss / (v.size() - 1)) : 0;
  }
};

void usage() {
  std::fprintf(stderr,
               "usage: wavelet_study [--seeds N] [--scenario NAME|all] [--level L] [--rule R] [--wavelet W] [--scaling S]\n"
               "                     [--max-share F] [--free-ratio R]\n"
               "  scenarios: dither400 saw400 dither100 saw100 dither100_2h saw100_2h nodither400\n"
               "  (all: every scenario but nodither400; all+: every scenario)\n");
}

}  // namespace

int main(int argc, char** argv) {
  int seeds = 20;
  std::string which = "all";
  WaveletSplitOptions wopt;
  wopt.deviation.compute_edf = true;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) {
        usage();
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--seeds") seeds = std::atoi(next().c_str());
    else if (a == "--scenario") which = next();
    else if (a == "--level") wopt.level = std::atoi(next().c_str());
    else if (a == "--rule") wopt.rule = parseThresholdRule(next());
    else if (a == "--wavelet") wopt.wavelet = next();
    else if (a == "--scaling") wopt.scaling = parseNoiseScaling(next());
    else if (a == "--max-share") wopt.max_quantization_share = std::atof(next().c_str());
    else if (a == "--free-ratio") wopt.free_fit_max_ratio = std::atof(next().c_str());
    else {
      usage();
      return 2;
    }
  }
  const std::vector<Scenario> all = {
      {"dither400", 400, 7200, true, 0.0},
      {"saw400", 400, 7200, false, 10 * kDegPerHour},
      {"dither100", 100, 3600, true, 0.0},
      {"saw100", 100, 3600, false, 10 * kDegPerHour},
      {"dither100_2h", 100, 7200, true, 0.0},
      {"saw100_2h", 100, 7200, false, 10 * kDegPerHour},
      {"nodither400", 400, 7200, false, 0.0},
  };
  std::printf("# wavelet_study: Q = %.3g rad (0.35 arcsec), N = %.4g rad/sqrt(s) (0.001 deg/sqrt(h)), %d seeds\n", kQ,
              kN, seeds);
  std::printf("# wavelet_split: %s, level %s, rule %s, %s, %s; values: relative error in %%, mean (bias) and "
              "std (spread)\n",
              wopt.wavelet.c_str(), wopt.level > 0 ? std::to_string(wopt.level).c_str() : "auto",
              thresholdRuleName(wopt.rule).c_str(), thresholdModeName(wopt.mode).c_str(),
              noiseScalingName(wopt.scaling).c_str());
  std::printf("%-12s %-26s %9s %9s %9s %9s\n", "scenario", "method", "Q bias", "Q spread", "N bias", "N spread");
  for (const auto& sc : all) {
    if (which == "all" ? sc.name == "nodither400" : (which == "all+" ? false : sc.name != which)) continue;
    std::map<std::string, Stats> st;
    std::vector<std::string> order = {"joint_fit", "joint_fit(Q,N only)", "wavelet_split", "  Q angle / N allan",
                                      "  Q allan(removed) / N_r", "  Q allan + N_r back"};
    double lvl = 0, arw_share = 0, kept = 0, white = 0;
    for (int s = 0; s < seeds; ++s) {
      AxisNoise ax;
      ax.quantization = kQ;
      ax.dither = sc.dither;
      ax.angle_random_walk = kN;
      ax.input_rate = sc.input_rate;
      const int64_t n = static_cast<int64_t>(sc.rate_hz * sc.duration_s);
      const auto rate = simulateAxis(ax, sc.rate_hz, n, 1000 + s, 0);
      const double tau0 = 1.0 / sc.rate_hz;
      const auto curve = computeDeviation("oadev", rate, InputKind::Rate, tau0, wopt.deviation);
      const FitResult jf = fitNoiseModel(curve);
      st["joint_fit"].add(jf.terms[kQuantization].value, jf.terms[kAngleRandomWalk].value);
      FitOptions qn;
      qn.enabled = {{true, true, false, false, false}};
      const FitResult jq = fitNoiseModel(curve, qn);
      st["joint_fit(Q,N only)"].add(jq.terms[kQuantization].value, jq.terms[kAngleRandomWalk].value);
      const WaveletSplitResult ws = waveletSplit(rate, tau0, wopt);
      st["wavelet_split"].add(ws.terms[kQuantization].value, ws.terms[kAngleRandomWalk].value);
      st["  Q angle / N allan"].add(ws.q_angle, ws.n_allan);
      st["  Q allan(removed) / N_r"].add(ws.q_allan, ws.n_allan);
      st["  Q allan + N_r back"].add(ws.q_allan, std::sqrt(ws.n_allan * ws.n_allan + ws.n_removed * ws.n_removed));
      lvl += ws.level;
      arw_share += ws.removed_arw_share;
      kept += ws.kept_fraction;
      white += ws.quantization_white ? 1 : 0;
    }
    for (const auto& m : order) {
      double qb, qs, nb, ns;
      Stats::ms(st[m].q, &qb, &qs);
      Stats::ms(st[m].n, &nb, &ns);
      std::printf("%-12s %-26s %9.3f %9.3f %9.3f %9.3f\n", sc.name.c_str(), m.c_str(), 100 * qb, 100 * qs, 100 * nb,
                  100 * ns);
    }
    std::printf("%-12s   (mean split level %.2f, ARW share of removed angle var %.3f%%, kept coeff fraction %.2g, "
                "quantization judged white in %.0f%% of runs)\n",
                sc.name.c_str(), lvl / seeds, 100 * arw_share / seeds, kept / seeds, 100 * white / seeds);
    std::fflush(stdout);
  }
  return 0;
}
