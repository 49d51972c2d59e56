// Quick answers (quick_view.hpp, OnlineAnalyzer::takeQuick): the quick curve is the batch oadev of the window, its N
// agrees with the full analysis's on a static record, stamps that arrive batched or jittered still give one segment,
// a gap starts a new one, and quick answers come at update_s of input time after min_samples.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "gyro_allan/allan.hpp"
#include "gyro_allan/online.hpp"
#include "gyro_allan/simulate.hpp"

using namespace gyro_allan;

namespace {

constexpr int64_t kStart = 1700000000LL * 1000000000LL;

struct Record {
  std::vector<int64_t> ns;
  std::vector<std::array<double, 3>> g;
};

/// A static gyro at `rate` Hz: N 2e-4 rad/sqrt(s), B 2e-5 rad/s, K 1e-6 rad/s/sqrt(s), Q 1e-6 rad on every axis.
Record staticRecord(double rate, double seconds, uint64_t seed) {
  const int64_t n = static_cast<int64_t>(rate * seconds);
  AxisNoise noise;
  noise.quantization = 1e-6;
  noise.angle_random_walk = 2e-4;
  noise.bias_instability = 2e-5;
  noise.rate_random_walk = 1e-6;
  Record r;
  std::array<std::vector<double>, 3> ax;
  for (int a = 0; a < 3; ++a) ax[static_cast<size_t>(a)] = simulateAxis(noise, rate, n, seed, a);
  for (int64_t i = 0; i < n; ++i) {
    r.ns.push_back(kStart + static_cast<int64_t>(std::llround(1e9 * static_cast<double>(i) / rate)));
    r.g.push_back({ax[0][static_cast<size_t>(i)], ax[1][static_cast<size_t>(i)], ax[2][static_cast<size_t>(i)]});
  }
  return r;
}

}  // namespace

TEST(QuickView, CurveIsTheBatchOadevAndNAgreesWithTheFullAnalysis) {
  const Record rec = staticRecord(400, 600, 3);
  OnlineOptions oo;
  oo.window_s = 1e6;
  oo.hop_s = 1e6;
  oo.pipeline.jobs = 2;
  OnlineAnalyzer oa(oo);
  for (size_t i = 0; i < rec.ns.size(); ++i) oa.addSample(rec.ns[i], rec.g[i]);
  ASSERT_TRUE(oa.quickDue());
  QuickAnswer q = oa.takeQuick();
  EXPECT_EQ(q.samples, static_cast<int64_t>(rec.ns.size()));
  EXPECT_EQ(q.segments, 1);
  EXPECT_NEAR(q.tau0, 1.0 / 400, 1e-12);
  EXPECT_EQ(q.window_first_ns, rec.ns.front());
  // Unfitted: the incremental curve equals the batch oadev of the same samples.
  std::vector<double> x;
  for (const auto& g : rec.g) x.push_back(g[0]);
  DeviationOptions dopt;
  dopt.grid.kind = TauGridKind::Octave;  // the quick view's grid
  const DeviationCurve batch = computeDeviation("oadev", x, InputKind::Rate, 1.0 / 400, dopt);
  ASSERT_EQ(q.axes[0].oadev.points.size(), batch.points.size());
  for (size_t i = 0; i < batch.points.size(); ++i) EXPECT_NEAR(q.axes[0].oadev.points[i].var / batch.points[i].var, 1.0, 1e-9) << i;
  OnlineAnalyzer::fitQuick(&q, oo.pipeline);
  const OnlineResult full = oa.analyzeNow();
  ASSERT_TRUE(full.ok) << full.error;
  for (int a = 0; a < 3; ++a) {
    const AxisAnalysis& qa = q.axes[static_cast<size_t>(a)];
    ASSERT_TRUE(qa.fit.ok) << qa.fit.message;
    EXPECT_EQ(qa.method, Method::QuickFit);
    const double nq = qa.coefficients[kAngleRandomWalk].value;
    const double nf = full.result.gyro[static_cast<size_t>(a)].coefficients[kAngleRandomWalk].value;
    EXPECT_NEAR(nq / nf, 1.0, 0.01) << "axis " << a << ": quick N " << nq << ", full N " << nf;
    EXPECT_NEAR(nq / 2e-4, 1.0, 0.03) << "axis " << a;  // and both near the declared truth
    EXPECT_EQ(qa.final_model_var.size(), qa.oadev.points.size());
  }
}

TEST(QuickView, BatchedStampsAreOneSegmentAndAGapStartsAnother) {
  const Record rec = staticRecord(200, 120, 5);
  QuickViewOptions qo;
  qo.window_s = 1e6;
  QuickView batched(qo), gap(qo);
  for (size_t i = 0; i < rec.ns.size(); ++i) {
    // Batched reads: every 10 samples arrive together with the stamp of the last of them, plus up to 3 ms of jitter.
    const size_t last = std::min(rec.ns.size() - 1, i / 10 * 10 + 9);
    batched.add(rec.ns[last] + static_cast<int64_t>((i * 7919) % 3000000), rec.g[i]);
    if (i < 10000 || i >= 10050) gap.add(rec.ns[i], rec.g[i]);  // 50 samples (0.25 s) missing
  }
  ASSERT_TRUE(batched.ready());
  const QuickAnswer b = batched.curves();
  EXPECT_EQ(b.segments, 1);
  EXPECT_EQ(b.samples, static_cast<int64_t>(rec.ns.size()));
  EXPECT_NEAR(b.tau0 * 200, 1.0, 0.002);
  const QuickAnswer g = gap.curves();
  EXPECT_EQ(g.segments, 2);
  EXPECT_EQ(g.samples, static_cast<int64_t>(rec.ns.size()) - 50);
}

TEST(QuickView, AnswersComeEveryUpdateSecondsAfterMinSamples) {
  const Record rec = staticRecord(100, 60, 9);
  OnlineOptions oo;
  oo.window_s = 3600;
  oo.hop_s = 300;
  oo.min_samples = 500;
  oo.update_s = 5;
  OnlineAnalyzer oa(oo);
  std::vector<double> due_at;
  for (size_t i = 0; i < rec.ns.size(); ++i) {
    oa.addSample(rec.ns[i], rec.g[i]);
    if (oa.quickDue()) {
      due_at.push_back(1e-9 * static_cast<double>(rec.ns[i] - kStart));
      oa.takeQuick();
    }
  }
  ASSERT_FALSE(due_at.empty());
  EXPECT_NEAR(due_at.front(), 4.99, 0.011);  // the 500th sample
  for (size_t k = 1; k < due_at.size(); ++k) EXPECT_NEAR(due_at[k] - due_at[k - 1], 5.0, 0.011);
  EXPECT_EQ(due_at.size(), 12u);  // 5 s .. 60 s
  // Off: no quick answers; reset starts over.
  oo.update_s = 0;
  oa.setOptions(oo);
  oa.addSample(rec.ns.back() + 10000000, rec.g.back());
  EXPECT_FALSE(oa.quickDue());
  oo.update_s = 5;
  oa.setOptions(oo);  // the window's samples are fed again
  EXPECT_TRUE(oa.quickDue());
  oa.reset();
  EXPECT_FALSE(oa.quickDue());
  oo.update_s = -1;
  EXPECT_THROW(OnlineAnalyzer{oo}, std::invalid_argument);
}
