// reportedNoiseModel (gmwm.hpp): the per-axis numbers noise_model.yaml and the nodelet's ~noise_model report are
// the GMWM stage's own (chosen fit, discretize() at the data rate and the filter rate, the closed loop), never new math.
#include <gtest/gtest.h>

#include <vector>

#include "gyro_allan/gmwm.hpp"
#include "gyro_allan/simulate.hpp"

namespace gyro_allan {
namespace {

/// 2^16 samples at 100 Hz of white noise plus one Gauss-Markov term (declared truth: N 1e-4, sigma 2e-4, tc 2 s).
GmwmAxis stage() {
  AxisNoise a;
  a.angle_random_walk = 1e-4;
  a.gm_sigma = 2e-4;
  a.gm_tau = 2;
  const std::vector<double> x = simulateAxis(a, 100, 1 << 16, 21);
  GmwmAxis g = gmwmStage(x, 0.01);
  // The closed-loop fields come from gmwmCompare in the pipeline; set them to distinct values to see them copied.
  g.gmwm_vs_data.tau_min = 0.01, g.gmwm_vs_data.tau_max = 65.5, g.gmwm_vs_data.worst_ratio = 1.25;
  g.gmwm_vs_data.points = 30, g.gmwm_vs_data.within_ci = 27;
  g.ieee_vs_data.rms_log10 = 0.03;
  g.final_vs_data.worst_tau = 4.2;
  g.worst_avar_ratio_vs_ieee = 1.7;
  return g;
}

TEST(ReportedNoiseModel, CopiesTheStageAndDiscretizesAtBothRates) {
  const GmwmAxis g = stage();
  ASSERT_TRUE(g.ok) << g.message;
  const ReportedNoiseModel r = reportedNoiseModel(g, 20.0, 3e-5, 4e-6);
  ASSERT_TRUE(r.ok);
  EXPECT_TRUE(r.error.empty());
  const GmwmFit& f = g.selection.chosen();
  EXPECT_EQ(r.model, f.model.name());
  EXPECT_EQ(r.fit.N, f.N);
  EXPECT_EQ(r.fit.gm.size(), f.gm.size());
  EXPECT_GE(r.fit.gm.size(), 1u);  // the declared GM term is selected
  EXPECT_NE(r.selection.find("2 x parameters"), std::string::npos) << r.selection;  // default penalty 2
  ASSERT_EQ(r.candidates.size(), g.selection.fits.size());
  for (size_t k = 0; k < r.candidates.size(); ++k) {
    EXPECT_EQ(r.candidates[k].model, g.selection.fits[k].model.name());
    EXPECT_EQ(r.candidates[k].criterion, g.selection.fits[k].criterion);
    EXPECT_EQ(r.candidates[k].identified, g.selection.fits[k].identified);
  }
  EXPECT_EQ(r.segment_s, g.record_s);
  EXPECT_EQ(r.data_rate_hz, 100.0);
  // discrete[0] at the data interval, discrete[1] at the filter rate: discretize()'s output, and R = white + quantization.
  ASSERT_EQ(r.discrete.size(), 2u);
  const double dts[2] = {0.01, 1.0 / 20.0};
  for (int k = 0; k < 2; ++k) {
    const ReportedDiscreteModel& d = r.discrete[k];
    const DiscreteNoiseModel ref = discretize(f, dts[k]);
    EXPECT_EQ(d.dt, dts[k]);
    EXPECT_EQ(d.rate_hz, 1.0 / dts[k]);
    EXPECT_EQ(d.model.states, ref.states);
    EXPECT_EQ(d.model.folded, ref.folded);
    EXPECT_TRUE(d.model.Phi == ref.Phi);
    EXPECT_TRUE(d.model.Qd == ref.Qd);
    EXPECT_EQ(d.measurement_variance, ref.white_variance + ref.quantization_variance);
  }
  // Flicker approximation and closed loop: the stage's comparison and the IEEE bias instability given.
  EXPECT_EQ(r.gauss_markov_terms, static_cast<int>(f.gm.size()));
  EXPECT_EQ(r.tau_min_s, 0.01);
  EXPECT_EQ(r.tau_max_s, 65.5);
  EXPECT_EQ(r.ieee_bias_instability, 3e-5);
  EXPECT_EQ(r.ieee_bias_instability_sigma, 4e-6);
  EXPECT_EQ(r.worst_avar_ratio_vs_ieee_model, 1.7);
  EXPECT_EQ(r.worst_avar_ratio_vs_data, 1.25 * 1.25);  // ADEV ratio squared
  EXPECT_EQ(r.gmwm_model.points, 30);
  EXPECT_EQ(r.gmwm_model.within_ci, 27);
  EXPECT_EQ(r.ieee_model.rms_log10, 0.03);
  EXPECT_EQ(r.final_model.worst_tau, 4.2);
  EXPECT_EQ(r.wavelet_variance_points, g.wv_points);
  EXPECT_EQ(r.wavelet_variance_within_ci, g.wv_within_ci);
  EXPECT_EQ(r.wavelet_variance_confidence, g.wv.confidence);

  // No filter rate: the data rate's model only.
  EXPECT_EQ(reportedNoiseModel(g, 0, 3e-5, 4e-6).discrete.size(), 1u);
}

TEST(ReportedNoiseModel, FailedStageCarriesOnlyItsReason) {
  const GmwmAxis g = gmwmStage(std::vector<double>(5, 0.0), 0.01);  // too short for a wavelet variance
  ASSERT_FALSE(g.ok);
  const ReportedNoiseModel r = reportedNoiseModel(g, 20.0, 0, 0);
  EXPECT_FALSE(r.ok);
  EXPECT_EQ(r.error, g.message);
  EXPECT_FALSE(r.error.empty());
  EXPECT_TRUE(r.model.empty());
  EXPECT_TRUE(r.discrete.empty());
  EXPECT_TRUE(r.candidates.empty());
}

}  // namespace
}  // namespace gyro_allan
