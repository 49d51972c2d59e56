// Closed-loop model check on measured data: the three ADIS16405 static runs (shared data, 100 Hz, 10000 s), all axes.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "gyro_allan/allan.hpp"
#include "gyro_allan/csv_input.hpp"
#include "gyro_allan/model_check.hpp"
#include "gyro_allan/noise_model.hpp"
#include "adis_data.hpp"

using namespace gyro_allan;

namespace {

std::vector<std::vector<double>> readRun(int run) { return gyro_allan_test::readAdisRun(run); }

ModelCheck check(const std::vector<double>& rate) {
  DeviationOptions o;
  o.grid.kind = TauGridKind::Log;
  o.grid.per_decade = 10;
  const DeviationCurve curve = oadev(rate, 0.01, o);
  ModelCheckOptions mo;
  const FitResult fit = fitNoiseModel(curve, mo.fit);
  return checkModel(rate, 0.01, curve, fit, mo);
}

}  // namespace

TEST(ModelCheckAdis, EveryAxisErrorFallsAndChi2Below3) {
  for (int run = 1; run <= 3; ++run) {
    const auto g = readRun(run);
    if (g[0].empty()) GTEST_SKIP() << "ADIS16405 shared data not found";
    ASSERT_EQ(g[0].size(), 1000000u);
    for (int axis = 0; axis < 3; ++axis) {
      SCOPED_TRACE("run " + std::to_string(run) + " axis " + "xyz"[axis]);
      const ModelCheck mc = check(g[axis]);
      ASSERT_TRUE(mc.ok) << mc.message;
      ASSERT_FALSE(mc.effects.empty());
      std::printf("run %d axis %c: rms %.4f -> %.4f chi2/dof %.2f -> %.2f p %.3g -> %.3g worst %.3f -> %.3f\n", run,
                  "xyz"[axis], mc.before.rms_log10, mc.after.rms_log10, mc.before.chi2_dof, mc.after.chi2_dof,
                  mc.fit_before.chi2_p, mc.fit_after.chi2_p, mc.fit_before.worst_adev_ratio,
                  mc.fit_after.worst_adev_ratio);
      // The closed loop: the error falls and the model describes the sensor (chi2/dof <= 3). The RMS log10 error over
      // every fitted point halves on 8 of the 9 axes; run 2 z goes 0.138 -> 0.094 (docs/model_check.md, "Limits").
      EXPECT_LT(mc.after.rms_log10, mc.before.rms_log10);
      EXPECT_LE(mc.after.chi2_dof, 3.0);
      if (axis < 2) {
        // x, y: the sensor's internal filter correlates consecutive samples (lag-1 0.17-0.20): the
        // short-correlation term (a negative 1/tau^2 part the IEEE Q term cannot take).
        EXPECT_EQ(mc.effects.front().type, "short_correlation");
      } else {
        // z: a narrowband oscillation near 20 Hz (PSD feature 1.3-2.3 Hz wide at half power, tails to ~30-35 Hz)
        // plus the same filter correlation.
        EXPECT_EQ(mc.effects.front().type, "narrowband");
        EXPECT_NEAR(mc.effects.front().parameters.at("frequency_hz").value, 20.0, 1.0);
        ASSERT_GE(mc.effects.size(), 2u);
        EXPECT_EQ(mc.effects[1].type, "short_correlation");
      }
    }
  }
}
