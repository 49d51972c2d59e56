// Rest detector: real moved bags and simulated motion are not at rest, real and simulated static records are, the
// streaming monitor decides the same blocks as the batch form, and bad input is refused.
//
// Seeds here (5001-5030) are neither the tuning seeds (1-40) nor the validation seeds (1001-1040) of rest_study.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#define REST_STUDY_NO_MAIN
#include "../studies/rest_study.cpp"  // the study's scenario generators (same scenarios the study measured)

using namespace gyro_allan;
using namespace rest_study;

namespace {

const std::string kData = GYRO_ALLAN_SHARED_DATA;

bool exists(const std::string& p) {
  FILE* f = std::fopen(p.c_str(), "rb");
  if (f) std::fclose(f);
  return f != nullptr;
}

// Block decisions of the streaming monitor on a record, expanded to merged moving intervals.
std::vector<RestInterval> streamMoving(const Record& r, bool use_accel, int64_t* blocks) {
  const bool acc = use_accel && !r.accel.empty();
  RestMonitor m(r.tau0, static_cast<int>(r.gyro.size()), acc);
  std::vector<RestInterval> out;
  int64_t seen = 0;
  auto take = [&]() {
    for (const RestBlock& b : m.decided()) {
      ++seen;
      EXPECT_EQ(m.moving(), m.decided().back().moving);
      if (!b.moving) continue;
      EXPECT_FALSE(b.reason.empty());
      if (!out.empty() && out.back().end == b.samples.begin)
        out.back().end = b.samples.end;
      else
        out.push_back(b.samples);
    }
  };
  double g[3], a[3];
  for (size_t s = 0; s < r.gyro[0].size(); ++s) {
    for (size_t i = 0; i < r.gyro[0][s].size(); ++i) {
      for (size_t c = 0; c < r.gyro.size(); ++c) g[c] = r.gyro[c][s][i];
      if (acc)
        for (int c = 0; c < 3; ++c) a[c] = r.accel[c][s][i];
      const bool made = m.add(g, acc ? a : nullptr);
      EXPECT_EQ(made, !m.decided().empty());
      EXPECT_LE(m.decided().size(), 1u);
      take();
    }
    m.newSegment();
    take();
  }
  EXPECT_EQ(seen, m.blocks());
  *blocks = m.blocks();
  return out;
}

}  // namespace

// ---- real data -------------------------------------------------------------------------------------------------
TEST(Rest, RealMovedBagsAreNotAtRest) {
  for (const auto& b : kRealBags) {
    const std::string path = kData + "/real_bags/" + b.file;
    if (!exists(path)) GTEST_SKIP() << path << " not found";
    const Record r = loadBag(path, b.topic);
    const RestResult res = run(r, RestOptions{});
    EXPECT_FALSE(res.at_rest) << b.file << ": " << res.reason;
    EXPECT_FALSE(res.channel.empty());
    EXPECT_GT(res.moving_fraction, 0.5) << b.file;  // all three move for most of the record
    // Without the accelerometer the gyro alone still tells.
    EXPECT_FALSE(run(r, RestOptions{}, false).at_rest) << b.file;
  }
}

TEST(Rest, AdisStaticRunsAreAtRest) {
  for (int k = 1; k <= 3; ++k) {
    const Record r = loadAdis(kData, k);
    if (r.name.empty()) GTEST_SKIP() << "ADIS16405 shared data not found";
    const RestResult res = run(r, RestOptions{});
    EXPECT_TRUE(res.at_rest) << r.name << ": " << res.reason;
    EXPECT_EQ(res.moving_fraction, 0.0);
    EXPECT_EQ(res.longest_static.begin, 0);
    EXPECT_EQ(res.longest_static.end, 1000000);
    EXPECT_TRUE(res.static_usable);
  }
}

// ---- simulated static ------------------------------------------------------------------------------------------
TEST(Rest, SimulatedStaticClassesWithEffectsAreAtRest) {
  // Every class x effect once (30 records, 2^17 samples each). rest_study measured 0 false alarms in 240 tuning
  // (seeds 1-40) and 0 in 240 validation records (seeds 1001-1040), 95 % upper bound 1.2 % each: at a 1.2 % rate,
  // two or more alarms in 30 records has probability 5 %, so one is tolerated.
  int alarms = 0;
  std::string which;
  for (int c = 0; c < kNumClasses; ++c)
    for (int e = 0; e < kNumEffects; ++e) {
      StaticSpec sp;
      sp.cls = static_cast<SensorClass>(c);
      sp.effect = static_cast<Effect>(e);
      sp.max_samples = 1 << 17;
      const Record r = makeStatic(5001 + c * kNumEffects + e, sp);
      const RestResult res = run(r, RestOptions{});
      if (!res.at_rest) ++alarms, which += "\n  " + r.name + ": " + res.reason;
    }
  EXPECT_LE(alarms, 1) << which;
}

TEST(Rest, IsolatedSpikesAreNotMotion) {
  StaticSpec sp;
  sp.cls = kConsumer;
  sp.max_samples = 1 << 17;
  Record r = makeStatic(5003, sp);
  const RestResult clean = run(r, RestOptions{});
  ASSERT_TRUE(clean.at_rest) << clean.reason;
  // 200 spikes of 50x the per-sample noise (and at least 1 rad/s), some in bursts of 3 samples, on every channel.
  Rng rng(5003);
  const double amp = std::max(1.0, 50 * r.per_sample_sigma);
  const int64_t n = static_cast<int64_t>(r.gyro[0][0].size());
  for (int k = 0; k < 200; ++k) {
    const int64_t i = static_cast<int64_t>(rng.u(0, n - 3));
    const int len = k % 4 == 0 ? 3 : 1;
    for (int j = 0; j < len; ++j) {
      for (int a = 0; a < 3; ++a) r.gyro[a][0][i + j] += (rng.pick(2) ? amp : -amp);
      r.accel[k % 3][0][i + j] += 30.0;
    }
  }
  const RestResult res = run(r, RestOptions{});
  EXPECT_TRUE(res.at_rest) << res.reason;
}

TEST(Rest, AllZeroAccelerometerIsIgnored) {
  StaticSpec sp;
  sp.cls = kTactical;
  sp.max_samples = 1e5;
  Record r = makeStatic(5004, sp);
  for (auto& ax : r.accel)
    for (auto& s : ax) std::fill(s.begin(), s.end(), 0.0);
  const RestResult res = run(r, RestOptions{});
  EXPECT_TRUE(res.at_rest) << res.reason;
  EXPECT_EQ(res.reason.find("accel"), std::string::npos);
}

// ---- simulated motion ------------------------------------------------------------------------------------------
TEST(Rest, SimulatedMotionIsNotAtRest) {
  // rest_study detected all 200 + 200 moved records (tuning and validation; 95 % upper bound of the miss rate 1.5 %
  // each) with the weakest detection 6x above its threshold: no miss is tolerated in these 12.
  for (int m : {kWave, kTurn, kDrive}) {
    for (uint64_t seed = 5001; seed <= 5003; ++seed) {
      MotionSpec ms;
      ms.motion = static_cast<Motion>(m);
      const Record r = makeMoving(seed, ms);
      const RestResult res = run(r, RestOptions{});
      EXPECT_FALSE(res.at_rest) << r.name << " seed " << seed;
    }
  }
  // The smallest hand-waving (0.05-0.1 rad/s RMS), gyro only.
  for (uint64_t seed = 5001; seed <= 5003; ++seed) {
    MotionSpec ms;
    ms.max_amp = 0.1;
    const Record r = makeMoving(seed, ms);
    EXPECT_FALSE(run(r, RestOptions{}, false).at_rest) << r.name << " seed " << seed;
  }
}

TEST(Rest, BumpIsExcludedFromLongestStaticStretch) {
  for (uint64_t seed = 5001; seed <= 5004; ++seed) {
    MotionSpec ms;
    ms.motion = kBump;
    const Record r = makeMoving(seed, ms);
    const RestResult res = run(r, RestOptions{});
    SCOPED_TRACE(r.name + " seed " + std::to_string(seed));
    ASSERT_FALSE(res.at_rest);
    EXPECT_TRUE(excludes(res, r.truth_motion))
        << "bump [" << r.truth_motion.begin << ", " << r.truth_motion.end << "), longest static ["
        << res.longest_static.begin << ", " << res.longest_static.end << ")";
    // The bump lasts 2-5 s: only a few blocks around it are moving, and the longer side of the record is usable.
    EXPECT_LT(res.moving_fraction, 0.05);
    const int64_t n = static_cast<int64_t>(r.gyro[0][0].size());
    const int64_t longer_side = std::max(r.truth_motion.begin, n - r.truth_motion.end);
    EXPECT_GE(res.longest_static.end - res.longest_static.begin, longer_side - static_cast<int64_t>(4.0 / r.tau0));
    EXPECT_TRUE(res.static_usable);
  }
}

// ---- streaming -------------------------------------------------------------------------------------------------
TEST(Rest, MonitorDecidesTheSameBlocksAsBatch) {
  std::vector<Record> recs;
  {
    MotionSpec ms;
    ms.motion = kBump;
    recs.push_back(makeMoving(5005, ms));
    ms.motion = kTurn;
    recs.push_back(makeMoving(5006, ms));
  }
  {
    // Segmented: a bump record cut into 4 segments (with a tail shorter than a block, and one shorter than 16).
    MotionSpec ms;
    ms.motion = kBump;
    Record r = makeMoving(5007, ms);
    const size_t n = r.gyro[0][0].size(), bn = static_cast<size_t>(1.0 / r.tau0);
    const std::vector<size_t> cuts = {0, 97 * bn + bn / 3, 97 * bn + bn / 3 + 10, 300 * bn + 7, n};
    for (auto* v : {&r.gyro, &r.accel})
      for (auto& ax : *v) {
        std::vector<std::vector<double>> segs;
        for (size_t k = 0; k + 1 < cuts.size(); ++k)
          segs.emplace_back(ax[0].begin() + cuts[k], ax[0].begin() + cuts[k + 1]);
        ax = segs;
      }
    recs.push_back(std::move(r));
  }
  {
    const std::string path = kData + "/real_bags/ardrone_imu.bag";
    if (exists(path)) recs.push_back(loadBag(path, "/ardrone/imu"));
  }
  for (const Record& r : recs) {
    SCOPED_TRACE(r.name);
    for (bool acc : {true, false}) {
      const RestResult batch = run(r, RestOptions{}, acc);
      int64_t blocks = 0;
      const std::vector<RestInterval> s = streamMoving(r, acc, &blocks);
      EXPECT_EQ(blocks, batch.blocks);
      ASSERT_EQ(s.size(), batch.moving.size());
      for (size_t k = 0; k < s.size(); ++k) {
        EXPECT_EQ(s[k].begin, batch.moving[k].begin);
        EXPECT_EQ(s[k].end, batch.moving[k].end);
      }
    }
  }
}

// ---- bad input -------------------------------------------------------------------------------------------------
TEST(Rest, BadInputIsRefusedWithAClearMessage) {
  const std::vector<std::vector<double>> seg1 = {std::vector<double>(1000, 0.001)};
  const std::vector<std::vector<double>> seg_short = {std::vector<double>(999, 0.001)};
  const std::vector<std::vector<double>> seg2 = {std::vector<double>(500, 0.001), std::vector<double>(500, 0.001)};
  const std::vector<std::vector<double>> empty = {std::vector<double>()};
  std::vector<std::vector<double>> nan = seg1;
  nan[0][123] = std::numeric_limits<double>::quiet_NaN();
  using P = std::vector<const std::vector<std::vector<double>>*>;
  auto expectThrow = [](const std::function<void()>& f, const std::string& needle) {
    try {
      f();
      ADD_FAILURE() << "no exception, expected one mentioning '" << needle << "'";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
  };
  expectThrow([&] { detectRest(P{}, P{}, 0.01); }, "1 to 3 gyro axes");
  expectThrow([&] { detectRest(P{&seg1, &seg1, &seg1, &seg1}, P{}, 0.01); }, "1 to 3 gyro axes");
  expectThrow([&] { detectRest(P{&seg1, nullptr}, P{}, 0.01); }, "null gyro axis");
  expectThrow([&] { detectRest(P{&seg1, &seg_short}, P{}, 0.01); }, "gyro y segment 0 has 999 samples");
  expectThrow([&] { detectRest(P{&seg1, &seg2}, P{}, 0.01); }, "gyro y has 2 segments");
  expectThrow([&] { detectRest(P{&seg1}, P{&seg1, &seg1}, 0.01); }, "0 or 3 accelerometer axes");
  expectThrow([&] { detectRest(P{&seg1}, P{&seg1, &seg1, &seg_short}, 0.01); }, "accel z segment 0 has 999");
  expectThrow([&] { detectRest(P{&empty}, P{}, 0.01); }, "no samples");
  for (double t : {0.0, -0.01, std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity()})
    expectThrow([&] { detectRest(P{&seg1}, P{}, t); }, "tau0 must be positive");
  expectThrow([&] { detectRest(P{&seg1, &nan}, P{}, 0.01); }, "gyro y sample 123 is not finite");
  expectThrow([&] { detectRest(P{&seg1}, P{&seg1, &seg1, &nan}, 0.01); }, "accel z sample 123 is not finite");
  RestOptions bad;
  bad.block_z = 0;
  expectThrow([&] { detectRest(P{&seg1}, P{}, 0.01, bad); }, "block_z");
  expectThrow([&] { RestMonitor m(0.0, 3, false); }, "tau0 must be positive");
  expectThrow([&] { RestMonitor m(0.01, 0, false); }, "1 to 3 gyro axes");
  expectThrow([&] { RestMonitor m(0.01, 4, false); }, "1 to 3 gyro axes");
  RestMonitor m(0.01, 3, true);
  const double g[3] = {0, 0, std::numeric_limits<double>::quiet_NaN()}, ok[3] = {0, 0, 0};
  expectThrow([&] { m.add(g, ok); }, "gyro z sample 0 is not finite");
  expectThrow([&] { m.add(ok, nullptr); }, "accelerometer sample missing");
}

TEST(Rest, ShortAndConstantInputDoNotBreak) {
  // A constant (stuck or unpublished) gyro and a record shorter than two blocks: at rest, no exception.
  const std::vector<std::vector<double>> c = {std::vector<double>(5000, 0.01)};
  using P = std::vector<const std::vector<std::vector<double>>*>;
  RestResult r = detectRest(P{&c, &c, &c}, P{}, 0.01);
  EXPECT_TRUE(r.at_rest) << r.reason;
  EXPECT_EQ(r.longest_static.end, 5000);
  const std::vector<std::vector<double>> s = {std::vector<double>(150, 0.01)};
  r = detectRest(P{&s}, P{}, 0.01);
  EXPECT_TRUE(r.at_rest);
  EXPECT_NE(r.reason.find("as far as can be told"), std::string::npos) << r.reason;
  // A constant turn at 1 rad/s changes no block mean: the rate magnitude decides.
  const std::vector<std::vector<double>> turn = {std::vector<double>(5000, 1.0)};
  r = detectRest(P{&c, &c, &turn}, P{}, 0.01);
  EXPECT_FALSE(r.at_rest);
  EXPECT_EQ(r.channel, "gyro |w|");
}
