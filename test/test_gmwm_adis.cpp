// GMWM on measured data: the three ADIS16405 static runs (shared data, 100 Hz, 10000 s): the selected state-space
// model's Allan deviation against the measured one's CI (as often inside as the model's own simulated records?) and
// against the IEEE 952 slope model's (docs/gmwm.md).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "gyro_allan/allan.hpp"
#include "gyro_allan/csv_input.hpp"
#include "gyro_allan/gmwm.hpp"
#include "gyro_allan/noise_model.hpp"
#include "adis_data.hpp"

using namespace gyro_allan;

namespace {

std::vector<std::vector<double>> readRun(int run) { return gyro_allan_test::readAdisRun(run); }

/// Points of `curve` with tau <= tau_max where the model's ADEV lies inside the curve's CI.
int insideCi(const DeviationCurve& curve, const GmwmFit& f, double tau_max) {
  int k = 0;
  for (const auto& p : curve.points) {
    if (p.tau > tau_max * (1 + 1e-9) || !(p.var > 0)) continue;
    const double md = std::sqrt(gmwmModelAvar(f, 0.01, p.m));
    k += md >= p.dev_lo && md <= p.dev_hi;
  }
  return k;
}

}  // namespace

// Measured (gmwm_study adis, docs/gmwm.md). With the MA(q) measurement-noise term the x/y models (MAq + GM(s)
// (+RW)) follow the data from 0.01 s on; the question "inside the CI" is asked against what the truth would score:
// a 68.3 % CI per point is missed by the TRUE model at ~32 % of points, with strong correlation between points.
//  - x/y, derived criterion: the model's count of points inside the data's 68.3 % CI, summed over the six x/y axes,
//    is compared with the same count for the model against R = 8 records simulated from it per axis (same length,
//    grid, CI; seeds 9000+). If the data were a draw from the fitted model, the sum would be distributed as the
//    simulated sums: mean mu = sum of the axes' simulated means, variance v = sum of their sample variances. Claim:
//    sum >= mu - 3 sqrt(v (1 + 1/R)) (one-sided normal 3 sigma: a false failure with probability ~0.0013; the
//    model was fitted to these data, which if anything raises their count). The same for the 95 % CI.
//  - x/y: GMWM rms_log10 below half the IEEE slopes' (measured 0.008-0.055 against 0.31-0.44).
//  - z: a 20-Hz narrowband line (model check) that no GMWM term describes: the fit must say so itself, chi2_p
//    < 1e-6 (measured chi2 ~ 1e5 on 14 dof); ADEV within 2x everywhere (measured <= 1.56).
//  - every axis: the bias is coloured (at least one GM or RW term).
TEST(GmwmAdis, StateSpaceModelFollowsTheMeasuredAllanDeviation) {
  const int R = 8;
  int sum68 = 0, sum95 = 0;
  double mu68 = 0, v68 = 0, mu95 = 0, v95 = 0;
  for (int run = 1; run <= 3; ++run) {
    const auto g = readRun(run);
    if (g[0].empty()) GTEST_SKIP() << "ADIS16405 shared data not found";
    for (int axis = 0; axis < 3; ++axis) {
      DeviationOptions o;
      o.grid.kind = TauGridKind::Log;
      o.grid.per_decade = 10;
      const DeviationCurve curve = oadev(g[axis], 0.01, o);
      const FitResult fit = fitNoiseModel(curve);
      GmwmAxis s = gmwmStage(g[axis], 0.01);
      ASSERT_TRUE(s.ok) << s.message;
      gmwmCompare(&s, curve, fit.model_var);
      const GmwmFit& f = s.selection.chosen();
      const std::string where = "run " + std::to_string(run) + " axis " + "xyz"[axis] + " (" + f.model.name() + ")";
      EXPECT_GE(s.gmwm_vs_data.points, 45) << where;
      EXPECT_TRUE(!f.gm.empty() || f.model.random_walk) << where;
      if (axis < 2) {
        const double tau_max = s.record_s / 10;
        DeviationCurve c95 = curve;
        fillConfidence(&c95, 0.95);
        sum68 += insideCi(curve, f, tau_max);
        sum95 += insideCi(c95, f, tau_max);
        double m68 = 0, q68 = 0, m95 = 0, q95 = 0;
        for (int k = 0; k < R; ++k) {
          const std::vector<double> x =
              simulateGmwmFit(f, 0.01, static_cast<int64_t>(g[axis].size()), 9000 + 100 * run + 10 * axis + k);
          DeviationCurve sc = oadev(x, 0.01, o);
          const double a = insideCi(sc, f, tau_max);
          fillConfidence(&sc, 0.95);
          const double b = insideCi(sc, f, tau_max);
          m68 += a / R;
          q68 += a * a;
          m95 += b / R;
          q95 += b * b;
        }
        mu68 += m68;
        v68 += (q68 - R * m68 * m68) / (R - 1);
        mu95 += m95;
        v95 += (q95 - R * m95 * m95) / (R - 1);
        EXPECT_LT(s.gmwm_vs_data.rms_log10, 0.5 * s.ieee_vs_data.rms_log10) << where;
      } else {
        EXPECT_LT(f.chi2_p, 1e-6) << where;
        EXPECT_LE(s.gmwm_vs_data.worst_ratio, 2.0) << where;
      }
    }
  }
  std::printf("x/y axes: model inside the data's 68.3 %% CI at %d points (simulated from the model: %.1f +- %.1f), "
              "95 %% CI at %d (%.1f +- %.1f)\n",
              sum68, mu68, std::sqrt(v68), sum95, mu95, std::sqrt(v95));
  EXPECT_GE(sum68, mu68 - 3 * std::sqrt(v68 * (1 + 1.0 / R)));
  EXPECT_GE(sum95, mu95 - 3 * std::sqrt(v95 * (1 + 1.0 / R)));
}
