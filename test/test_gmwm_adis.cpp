// GMWM on measured data: the three ADIS16405 static runs (shared data, 100 Hz, 10000 s): the selected state-space
// model's Allan deviation against the measured one, and against the IEEE 952 slope model's (docs/gmwm.md).
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

}  // namespace

// Measured (gmwm_study adis, docs/gmwm.md): on x and y the GMWM model's ADEV is within 1.52x of the data's at every
// oadev point from 0.01 s to T/10 = 1000 s (rms_log10 <= 0.047), against the IEEE slopes' 3.2-5.9x (rms_log10
// >= 0.30); on z (a 20-Hz narrowband line and lag-2 correlation, which no GMWM term describes) both models are
// off by up to ~1.9x / 2.6x. Limits: the measured figures with a margin (1.6x; GMWM rms below half the IEEE
// slopes'; z within 2x and no worse in rms than 1.5x the IEEE slopes').
TEST(GmwmAdis, StateSpaceModelFollowsTheMeasuredAllanDeviation) {
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
      const std::string where = "run " + std::to_string(run) + " axis " + "xyz"[axis];
      EXPECT_GE(s.gmwm_vs_data.points, 45) << where;
      EXPECT_GE(s.selection.chosen().gm.size(), 1u) << where;  // the bias is coloured: at least one GM term
      if (axis < 2) {
        EXPECT_LE(s.gmwm_vs_data.worst_ratio, 1.6) << where;
        EXPECT_LT(s.gmwm_vs_data.rms_log10, 0.5 * s.ieee_vs_data.rms_log10) << where;
      } else {
        EXPECT_LE(s.gmwm_vs_data.worst_ratio, 2.0) << where;
        EXPECT_LT(s.gmwm_vs_data.rms_log10, 1.5 * s.ieee_vs_data.rms_log10) << where;
      }
    }
  }
}
